//! The workloads of the footprint images (`src/bin/footprint/`), kept here so the on-target
//! suite runs them too (a footprint of code that does not work would mean nothing).

use awfqi::gp::{Gp, HyperparameterBounds, Hyperparameters, SearchOptions, WhenFull};
use awfqi::rng::{normal, uniform_in};
use awfqi::{Real, Result};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// A GP reward model as a controller would run it: `N` noisy observations of a puddle-like
/// reward `−1 − 20·exp(−‖s − (6, 4)‖²/1.6)` at random `(s_x, s_y, a)`, added one by one;
/// a bounded hyperparameter search (30 evaluations, 1 restart, spec §4.2's box); four more
/// observations through the sliding window; eight predictions and the log marginal
/// likelihood. Returns the sum of the predicted means and variances plus the likelihood.
///
/// `gp` may hold anything on entry (even all-zero bits): it is re-initialised first.
pub fn gp_reward_model<const N: usize>(gp: &mut Gp<f32, N, 3>, seed: u64) -> Result<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    gp.clear();
    gp.set_hyperparameters(Hyperparameters::isotropic(1.0, 1.0, 0.1))?;
    let observe = |rng: &mut ChaCha8Rng, i: usize| -> Result<([f32; 3], f32)> {
        let x = uniform_in(rng, 0.0f32, 10.0)?;
        let y = uniform_in(rng, 0.0f32, 10.0)?;
        let d2 = (x - 6.0) * (x - 6.0) + (y - 4.0) * (y - 4.0);
        let reward = -1.0 - 20.0 * (-d2 / 1.6).exp();
        Ok(([x, y, (i % 4) as f32], normal(rng, reward, 0.1)?))
    };
    for i in 0..N {
        let (x, y) = observe(&mut rng, i)?;
        gp.add_point(x, y, WhenFull::Refuse)?;
    }
    let options = SearchOptions {
        max_evaluations: 30,
        restarts: 1,
        isotropic: true,
    };
    let mut total =
        gp.optimize_hyperparameters(&HyperparameterBounds::spec_default(), &options, &mut rng)?;
    for i in 0..4 {
        let (x, y) = observe(&mut rng, i)?;
        gp.add_point(x, y, WhenFull::DropOldest)?;
    }
    for i in 0..8u8 {
        let p = gp.predict(&[f32::from(i), 4.0, f32::from(i % 4)])?;
        total += p.mean + p.latent_variance;
    }
    Ok(total + gp.log_marginal_likelihood()?)
}
