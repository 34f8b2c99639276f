//! Where a spec §4.2 fit spends its likelihood evaluations: replays the fit's optimisations
//! (same starts as `LargeGp::fit`) through a logging objective on the reward-like data of
//! `gp_timing`, and counts per start the values, the gradients, the values whose `θ` was
//! already evaluated (in this start or an earlier one), and the rejected line-search
//! trials (values not followed by a gradient).
//!
//! `cargo run --release -p awfqi-harness --example gp_eval_count [-- N1 N2 ...]` (default 500 1000)

use awfqi_harness::gp_large::optimizer::{self, Objective};
use awfqi_harness::gp_large::{
    FitOptions, HyperparameterBox, LargeGp, LikelihoodEvaluator, Parallelism,
};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

#[path = "common/mod.rs"]
mod common;

struct Logged<'e, 'a> {
    eval: &'e mut LikelihoodEvaluator<'a, 3>,
    values: Vec<[f64; 3]>,
    gradients: usize,
    with_gradient: Vec<bool>,
}

impl Objective<3> for Logged<'_, '_> {
    fn value(&mut self, x: &[f64; 3]) -> Option<f64> {
        self.values.push(*x);
        self.with_gradient.push(false);
        self.eval.value(x).map(|v| -v)
    }
    fn gradient(&mut self) -> [f64; 3] {
        self.gradients += 1;
        if let Some(last) = self.with_gradient.last_mut() {
            *last = true;
        }
        self.eval
            .gradient()
            .map_or([f64::NAN; 3], |g| [-g[0], -g[1], -g[2]])
    }
}

fn main() {
    let sizes = common::sizes_from_args(&[500, 1000]);
    let max = *sizes.iter().max().unwrap();
    let (zs, ys) = common::uniform_reward_data(max);
    let options = FitOptions::default();
    let (lower, upper) = HyperparameterBox::SPEC.log_bounds();
    for n in sizes {
        let (z, y) = (&zs[..n], &ys[..n]);
        let mut fit_rng = ChaCha8Rng::seed_from_u64(n as u64);
        let mut starts = vec![options.initial.to_log()];
        for _ in 0..options.restarts {
            starts.push(std::array::from_fn(|i| {
                lower[i] + awfqi::rng::uniform_f64(&mut fit_rng) * (upper[i] - lower[i])
            }));
        }
        let mut eval = LikelihoodEvaluator::new(z, y, Parallelism::Seq).unwrap();
        let mut seen: Vec<[f64; 3]> = Vec::new();
        let (mut total_v, mut total_g, mut total_dup, mut total_rej) = (0, 0, 0, 0);
        println!("N = {n}");
        let mut best = f64::INFINITY;
        for (s, start) in starts.iter().enumerate() {
            let mut obj = Logged {
                eval: &mut eval,
                values: Vec::new(),
                gradients: 0,
                with_gradient: Vec::new(),
            };
            let m = optimizer::minimize(&mut obj, start, &lower, &upper, &options.optimizer);
            let dup = obj
                .values
                .iter()
                .enumerate()
                .filter(|(i, x)| obj.values[..*i].contains(x) || seen.contains(x));
            let dup = dup.count();
            if std::env::var_os("SHOW_REPEATS").is_some() {
                for (i, x) in obj.values.iter().enumerate() {
                    if obj.values[..i].contains(x) || seen.contains(x) {
                        println!(
                            "    repeat at value {i}: θ {x:?} (same start: {}, needs gradient: {})",
                            obj.values[..i].contains(x),
                            obj.with_gradient[i]
                        );
                    }
                }
            }
            let rejected = obj.with_gradient.iter().filter(|g| !**g).count();
            println!(
                "  start {s:2}: {:3} values ({} reported), {:3} gradients, {} repeated θ, \
                 {:3} values without gradient, {} iterations, stop {:?}, −LML {:.6}",
                obj.values.len(),
                m.evaluations,
                obj.gradients,
                dup,
                rejected,
                m.iterations,
                m.stop,
                m.f
            );
            best = best.min(m.f);
            total_v += obj.values.len();
            total_g += obj.gradients;
            total_dup += dup;
            total_rej += rejected;
            seen.extend(obj.values);
        }
        println!(
            "  total: {total_v} values, {total_g} gradients, {total_dup} repeated θ, \
             {total_rej} values without gradient; best −LML {best:.6}"
        );
        let (gp, report) =
            LargeGp::fit(z, y, &options, &mut ChaCha8Rng::seed_from_u64(n as u64)).unwrap();
        println!(
            "  LargeGp::fit: LML {:.6}, best start {}",
            gp.log_marginal_likelihood(),
            report.best
        );
    }
}
