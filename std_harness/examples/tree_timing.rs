//! Micro-timing of the Extra-Trees hot paths (minimum over repetitions, one thread):
//! growing a 50-tree forest on one action's share of a reference-size dataset, and batch
//! prediction at as many next states as FQI evaluates per forest and iteration.
//!
//! `cargo run --release -p awfqi-harness --example tree_timing [-- N_RECORDS]`

use std::time::Instant;

use awfqi_harness::trees::Forest;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

fn min_time<F: FnMut()>(reps: usize, mut f: F) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let n: usize = std::env::args().nth(1).map_or(1800, |s| s.parse().unwrap());
    let per_action = n / 4;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut u = || awfqi::rng::uniform_f64(&mut rng);
    let xs: Vec<[f64; 2]> = (0..per_action).map(|_| [10.0 * u(), 10.0 * u()]).collect();
    let ys: Vec<f64> = xs.iter().map(|x| -(x[0] + x[1]) - 0.5 * u()).collect();
    let ws = vec![1.0; per_action];
    let queries: Vec<[f64; 2]> = (0..n).map(|_| [10.0 * u(), 10.0 * u()]).collect();
    let mut forest = Forest::empty();
    let mut seed_rng = ChaCha8Rng::seed_from_u64(2);
    let fit = min_time(20, || {
        forest.refit(&xs, &ys, &ws, 50, &mut seed_rng).unwrap();
    });
    let mut out = vec![0.0; n];
    let predict = min_time(20, || forest.predict_into(&queries, &mut out).unwrap());
    let nodes = forest.n_nodes();
    // A fingerprint of the forest's predictions (bits), to check that a speed-up keeps them.
    let fingerprint = out.iter().fold(0u64, |h, v| h.rotate_left(5) ^ v.to_bits());
    println!("fingerprint {fingerprint:016x}");
    println!(
        "fit 50 trees on {per_action} records: {:.3} ms ({:.1} ns/node, {nodes} nodes)",
        fit * 1e3,
        fit * 1e9 / nodes as f64
    );
    println!(
        "predict {n} queries x 50 trees: {:.3} ms ({:.2} ns per query-tree)",
        predict * 1e3,
        predict * 1e9 / (n * 50) as f64
    );
    println!(
        "=> one FQI iteration ~ 4 x (fit + predict) = {:.1} ms, 60 iterations {:.2} s",
        4.0 * (fit + predict) * 1e3,
        240.0 * (fit + predict)
    );
}
