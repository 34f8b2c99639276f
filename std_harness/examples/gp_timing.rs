//! Wall time of the large-N GP on one core: one likelihood value (Cholesky), one gradient
//! (K⁻¹), and a full spec §4.2 fit (initial values + 10 restarts) at the given sizes, on
//! reward-like data drawn from the Puddle World target with a uniform policy.
//!
//! `cargo run --release -p awfqi-harness --example gp_timing [-- N1 N2 ...]` (default 500 1700;
//! `GP_TIMING_SKIP_SPEC=1` leaves out the spec's fit, which takes minutes at `N ≥ 2000`)

use std::time::Instant;

use awfqi_harness::gp_large::{FitOptions, FitStrategy, LargeGp, LikelihoodEvaluator, Parallelism};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

#[path = "common/mod.rs"]
mod common;

fn main() {
    let sizes = common::sizes_from_args(&[500, 1700]);
    let max = *sizes.iter().max().unwrap();
    let (zs, ys) = common::uniform_reward_data(max);
    for n in sizes {
        let (z, y) = (&zs[..n], &ys[..n]);
        let mut eval = LikelihoodEvaluator::new(z, y, Parallelism::Seq).unwrap();
        let theta = [0.5, 0.3, -3.0];
        eval.value(&theta).unwrap();
        let t = Instant::now();
        let reps = 3;
        for _ in 0..reps {
            eval.value(&theta).unwrap();
        }
        let t_value = t.elapsed().as_secs_f64() / reps as f64;
        let t = Instant::now();
        for _ in 0..reps {
            eval.value(&theta).unwrap();
            eval.gradient().unwrap();
        }
        let t_both = t.elapsed().as_secs_f64() / reps as f64;
        println!(
            "N = {n}: value {:.1} ms, value + gradient {:.1} ms",
            t_value * 1e3,
            t_both * 1e3
        );
        let skip_spec = std::env::var_os("GP_TIMING_SKIP_SPEC").is_some();
        for (name, strategy) in [
            ("spec (all starts on all data)", FitStrategy::AllStarts),
            ("screened (300-point subsample)", FitStrategy::SCREENED),
            (
                "staged (300, then 1000 points), cold",
                FitStrategy::Staged {
                    subsample: 300,
                    intermediate: 1000,
                    merge_radius: 0.5,
                    warm_hessian: false,
                },
            ),
            ("staged (300, then 1000 points), warm", FitStrategy::STAGED),
        ] {
            if skip_spec && strategy == FitStrategy::AllStarts {
                continue;
            }
            let options = FitOptions {
                strategy,
                ..FitOptions::default()
            };
            let mut fit_rng = ChaCha8Rng::seed_from_u64(n as u64);
            let t = Instant::now();
            let (gp, report) = LargeGp::fit(z, y, &options, &mut fit_rng).unwrap();
            let t_fit = t.elapsed().as_secs_f64();
            let evals: usize = report
                .runs
                .iter()
                .filter(|r| r.merged_into.is_none())
                .map(|r| r.evaluations)
                .sum();
            let factorizations: usize = report
                .runs
                .iter()
                .filter(|r| r.merged_into.is_none())
                .map(|r| r.factorizations)
                .sum();
            let grads: usize = report
                .runs
                .iter()
                .filter(|r| r.merged_into.is_none())
                .map(|r| r.gradients)
                .sum();
            println!(
                "  {name}: fit {:.2} s, {evals} values ({factorizations} factorisations) + \
                 {grads} gradients on all data, per start {:?}; LML {:.6}, {:?}",
                t_fit,
                report
                    .runs
                    .iter()
                    .map(|r| if r.merged_into.is_some() {
                        0
                    } else {
                        r.evaluations
                    })
                    .collect::<Vec<_>>(),
                gp.log_marginal_likelihood(),
                gp.hyperparameters()
            );
        }
    }
}
