//! Cost estimate of one IWFQI run of the puddle reference configuration (shared dynamics,
//! 6 steps × 10 episodes, 60 iterations, 50 trees, evaluation included) on one core, built
//! from this crate's regressors. **A timing sketch, not the experiment**: the weight formula
//! (spec §7.3 mean estimator, v_r = 0.1, w_max = 1000) is written inline here, and only the
//! reward GP is fitted (transition weights off, as in the shared-dynamics configuration).
//!
//! `cargo run --release -p awfqi-harness --example iwfqi_cost [-- spec|screened [SEED]]`

use std::time::Instant;

use awfqi::env::{Dynamics, PUDDLE_DISCOUNT, PUDDLE_HORIZON, PuddleWorld};
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use awfqi_harness::fqi::{Dataset, FqiOptions, fqi};
use awfqi_harness::gp_large::{FitOptions, FitStrategy, LargeGp, NoiseSubtraction, subtract_noise};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// One source: its records and the stored source-GP reward posterior (mean, std).
struct Source {
    data: Dataset<2>,
    reward_gp: Vec<(f64, f64)>,
}

fn read_source(path: &str) -> Source {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut data = Dataset::new();
    let mut reward_gp = Vec::new();
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|f| f.parse().unwrap()).collect();
        data.states.push([v[1], v[2]]);
        data.actions.push(v[3] as usize);
        data.rewards.push(v[4]);
        data.next_states.push([v[5], v[6]]);
        data.absorbing.push(v[7] != 0.0);
        reward_gp.push((v[8], v[9]));
    }
    Source { data, reward_gp }
}

fn ln_normal(y: f64, mean: f64, var: f64) -> f64 {
    -0.5 * ((y - mean).powi(2) / var + (2.0 * std::f64::consts::PI * var).ln())
}

/// Spec §7.3's mean estimator.
fn mean_weight(y: f64, target: (f64, f64), source: (f64, f64), v: f64) -> f64 {
    let denom = v - source.1 * source.1;
    if denom <= 0.0 {
        return 0.0;
    }
    let log = ln_normal(y, target.0, v + target.1 * target.1) - ln_normal(y, source.0, denom)
        + (v / denom).ln();
    let w = log.exp().min(1000.0);
    if w.is_nan() { 0.0 } else { w }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let strategy = match args.get(1).map(String::as_str) {
        Some("screened") => FitStrategy::SCREENED,
        _ => FitStrategy::AllStarts,
    };
    let seed: u64 = args.get(2).map_or(0, |s| s.parse().unwrap());
    let dir = format!(
        "{}/../../shared/data/puddle-sources",
        env!("CARGO_MANIFEST_DIR")
    );
    let sources: Vec<Source> = (1..=3)
        .map(|k| read_source(&format!("{dir}/shared_dynamics_source_{k}.csv")))
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let target = PuddleWorld::<f64>::target(Dynamics::Shared);
    let mut uniform = UniformPolicy::new(4).unwrap();
    let options = FitOptions {
        strategy,
        ..FitOptions::default()
    };
    println!("GP strategy: {strategy:?}");
    let start = Instant::now();
    let mut target_data = Dataset::new();
    let mut q = None;
    for step in 1..=6 {
        let t = Instant::now();
        for _ in 0..10 {
            let mut push = |r: awfqi::env::EpisodeRecord<f64>| {
                target_data.push(r.transition);
                Ok(())
            };
            match &q {
                None => target.run_episode_with(&mut uniform, PUDDLE_HORIZON, &mut rng, &mut push),
                Some(q) => {
                    let greedy =
                        |s: &[f64; 2]| Ok(awfqi_harness::trees::ActionForests::greedy_action(q, s));
                    let mut policy = EpsilonGreedyPolicy::new(greedy, 0.3, 4).unwrap();
                    target.run_episode_with(&mut policy, PUDDLE_HORIZON, &mut rng, &mut push)
                }
            }
            .unwrap();
        }
        // Target reward GP (spec §7.2 step 2) and reward weights (step 3).
        let z = |s: &[f64; 2], a: usize| [s[0], s[1], a as f64];
        let zs: Vec<[f64; 3]> = target_data
            .states
            .iter()
            .zip(&target_data.actions)
            .map(|(s, &a)| z(s, a))
            .collect();
        let (gp, _) = LargeGp::fit(&zs, &target_data.rewards, &options, &mut rng).unwrap();
        let t_gp = t.elapsed().as_secs_f64();
        let mut union = target_data.clone();
        let mut wr = vec![1.0; target_data.len()];
        for src in &sources {
            let szs: Vec<[f64; 3]> = src
                .data
                .states
                .iter()
                .zip(&src.data.actions)
                .map(|(s, &a)| z(s, a))
                .collect();
            let mut means = vec![0.0; szs.len()];
            let mut stds = vec![0.0; szs.len()];
            gp.predict_into(&szs, &mut means, &mut stds).unwrap();
            subtract_noise(
                &mut stds,
                gp.hyperparameters().noise_variance,
                NoiseSubtraction::Reference,
            );
            for i in 0..szs.len() {
                wr.push(mean_weight(
                    src.data.rewards[i],
                    (means[i], stds[i]),
                    src.reward_gp[i],
                    0.1,
                ));
            }
            union.extend_from(&src.data);
        }
        let ws = vec![1.0; union.len()];
        let t_weights = t.elapsed().as_secs_f64();
        let learned = fqi(&union, &FqiOptions::iwfqi(&wr, &ws), &mut rng)
            .unwrap()
            .q;
        let t_fqi = t.elapsed().as_secs_f64();
        let mut greedy = |s: &[f64; 2]| Ok(learned.greedy_action(s));
        let mean_return: f64 = (0..5)
            .map(|_| {
                target
                    .rollout(&mut greedy, PUDDLE_HORIZON, PUDDLE_DISCOUNT, &mut rng)
                    .unwrap()
                    .discounted_return
            })
            .sum::<f64>()
            / 5.0;
        println!(
            "step {step}: {:4} target + {} source records, GP fit {:.2} s ({:?}), weights {:.2} s, \
             FQI {:.2} s, evaluation {:.3} s, mean w_r {:.3}, greedy return {:.2}",
            target_data.len(),
            union.len() - target_data.len(),
            t_gp,
            gp.hyperparameters(),
            t_weights - t_gp,
            t_fqi - t_weights,
            t.elapsed().as_secs_f64() - t_fqi,
            wr.iter().sum::<f64>() / wr.len() as f64,
            mean_return
        );
        q = Some(learned);
    }
    println!("one IWFQI run: {:.1} s", start.elapsed().as_secs_f64());
}
