//! Measures nalgebra's Cholesky (no default features, as the core would use it) against the
//! core's hand-written one: speed of a 64-point f32 fit, and the
//! conditioning behaviour on the 90 exact hard cases of `tests/data/gp_hard_cases.json`
//! (how often each returns a factor whose mean is wrong beyond 1e-2 of the data scale).
//!
//!     cargo run --release -p awfqi-crosscheck --example nalgebra_cholesky
//!
//! Code size and stack on the Cortex-M4F: `scripts/cholesky-size`. The figures and the
//! reason the hand-written factor stays: docs/footprint.md, "The design card's packages".
use std::time::Instant;

use awfqi::gp::{Conditioning, Gp, Hyperparameters};
use nalgebra::{Cholesky, SMatrix, SVector};

/// The hard cases have at most 48 points; the padding is an identity block (no coupling).
const M: usize = 48;

fn kernel(a: &[f64], b: &[f64], c: f64, ls: &[f64]) -> f64 {
    let s: f64 = a
        .iter()
        .zip(b)
        .zip(ls)
        .map(|((p, q), l)| ((p - q) / l).powi(2))
        .sum();
    c * (-0.5 * s).exp()
}

fn main() {
    // Speed: 64 points in 3-D, f32, kernel fill + factorisation + solve, both ways.
    const N: usize = 64;
    let xs: Vec<[f32; 3]> = (0..N)
        .map(|i| {
            let t = i as f32;
            [
                (t * 0.37).sin() * 5.0,
                (t * 0.11).cos() * 5.0,
                (i % 4) as f32,
            ]
        })
        .collect();
    let ys: Vec<f32> = xs.iter().map(|x| x[0].sin() + 0.1 * x[1]).collect();
    let hyper = Hyperparameters::isotropic(1.0f32, 1.5, 0.05);
    let reps = 2000;
    let mut gp = Gp::<f32, N, 3>::new(hyper).unwrap();
    let start = Instant::now();
    for _ in 0..reps {
        gp.fit(std::hint::black_box(&xs), &ys).unwrap();
    }
    let core_us = start.elapsed().as_secs_f64() / reps as f64 * 1e6;
    let start = Instant::now();
    let mut sink = 0.0f32;
    for _ in 0..reps {
        let xs = std::hint::black_box(&xs);
        let k = SMatrix::<f32, N, N>::from_fn(|i, j| {
            let d: f32 = (0..3).map(|d| ((xs[i][d] - xs[j][d]) / 1.5).powi(2)).sum();
            (-0.5 * d).exp() + if i == j { 0.05 + 1e-10 } else { 0.0 }
        });
        let chol = Cholesky::new(k).unwrap();
        let y = SVector::<f32, N>::from_fn(|i, _| ys[i]);
        sink += chol.solve(&y)[0];
    }
    let na_us = start.elapsed().as_secs_f64() / reps as f64 * 1e6;
    println!(
        "f32 N=64 D=3 fit (kernel + Cholesky + solve): core {core_us:.1} µs, nalgebra SMatrix {na_us:.1} µs ({sink:.1})"
    );

    // Conditioning: the exact hard cases, f32 and f64, no jitter, nalgebra's plain Cholesky
    // against the core under its default policy.
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../tests/data/gp_hard_cases.json"
    ))
    .unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let nums = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let rows = |v: &serde_json::Value| -> Vec<Vec<f64>> {
        v.as_array().unwrap().iter().map(nums).collect()
    };
    for precision in ["f32", "f64"] {
        let (mut ok, mut wrong, mut refused, mut worst) = (0, 0, 0, 0.0f64);
        for case in doc["cases"].as_array().unwrap() {
            let x = rows(&case["x"]);
            let y = nums(&case["y"]);
            let xt = rows(&case["x_test"]);
            let c = case["signal_variance"].as_f64().unwrap();
            let ls = nums(&case["length_scales"]);
            let s2 = case["noise_variance"].as_f64().unwrap();
            let exact = nums(&case["exact"]["mean"]);
            let scale = y.iter().fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
            let n = x.len();
            let entry = |i: usize, j: usize| -> f64 {
                if i < n && j < n {
                    kernel(&x[i], &x[j], c, &ls) + if i == j { s2 } else { 0.0 }
                } else if i == j {
                    1.0
                } else {
                    0.0
                }
            };
            let means: Option<Vec<f64>> = if precision == "f32" {
                let k = SMatrix::<f32, M, M>::from_fn(|i, j| entry(i, j) as f32);
                Cholesky::new(k).map(|ch| {
                    let a = ch.solve(&SVector::<f32, M>::from_fn(|i, _| {
                        y.get(i).map_or(0.0, |&v| v as f32)
                    }));
                    xt.iter()
                        .map(|t| {
                            (0..n)
                                .map(|i| kernel(t, &x[i], c, &ls) as f32 * a[i])
                                .sum::<f32>() as f64
                        })
                        .collect()
                })
            } else {
                let k = SMatrix::<f64, M, M>::from_fn(entry);
                Cholesky::new(k).map(|ch| {
                    let a = ch.solve(&SVector::<f64, M>::from_fn(|i, _| {
                        y.get(i).copied().unwrap_or(0.0)
                    }));
                    xt.iter()
                        .map(|t| (0..n).map(|i| kernel(t, &x[i], c, &ls) * a[i]).sum())
                        .collect()
                })
            };
            match means {
                None => refused += 1,
                Some(m) => {
                    let e = m
                        .iter()
                        .zip(&exact)
                        .map(|(a, b)| (a - b).abs() / b.abs().max(scale))
                        .fold(0.0, f64::max);
                    worst = worst.max(e);
                    if e > 1e-2 || e.is_nan() {
                        wrong += 1
                    } else {
                        ok += 1
                    }
                }
            }
        }
        println!(
            "nalgebra {precision}: {ok} within 1e-2, {wrong} wrong answers returned, {refused} refused; worst mean error {worst:.2e}"
        );
    }
    let _ = Conditioning::<f32>::DEFAULT;
}
