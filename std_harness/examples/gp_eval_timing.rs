//! Minimum over repetitions of one GP likelihood value (Cholesky) and one gradient (K⁻¹) at
//! the given sizes, single-threaded, with the achieved GFlop/s (n³/3 and 2n³/3 flops).
//! Minimums are robust on a shared machine; use this to compare builds.
//!
//! `cargo run --release -p awfqi-harness --example gp_eval_timing [-- N1 N2 ...]`

use std::time::Instant;

use awfqi_harness::gp_large::{LikelihoodEvaluator, Parallelism};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

#[path = "common/mod.rs"]
mod common;

fn main() {
    let sizes = common::sizes_from_args(&[500, 1000, 1700]);
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut u = || awfqi::rng::uniform_f64(&mut rng);
    for n in sizes {
        let zs: Vec<[f64; 3]> = (0..n)
            .map(|_| [10.0 * u(), 10.0 * u(), (4.0 * u()).floor()])
            .collect();
        let ys: Vec<f64> = zs.iter().map(|z| -1.0 - 0.1 * z[0] + 0.1 * u()).collect();
        let mut eval = LikelihoodEvaluator::new(&zs, &ys, Parallelism::Seq).unwrap();
        let theta = [3.3, 0.2, -4.6];
        let (mut value, mut gradient) = (f64::INFINITY, f64::INFINITY);
        for _ in 0..7 {
            let t = Instant::now();
            eval.value(&theta).unwrap();
            let v = t.elapsed().as_secs_f64();
            eval.gradient().unwrap();
            gradient = gradient.min(t.elapsed().as_secs_f64() - v);
            value = value.min(v);
        }
        let n3 = (n as f64).powi(3);
        println!(
            "N = {n}: value {:.2} ms ({:.1} GFlop/s), gradient {:.2} ms ({:.1} GFlop/s)",
            value * 1e3,
            n3 / 3.0 / value * 1e-9,
            gradient * 1e3,
            2.0 * n3 / 3.0 / gradient * 1e-9
        );
    }
}
