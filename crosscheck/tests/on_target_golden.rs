//! Recomputes, on the host in `f64`, every expected value the on-target suite
//! (`tests/on_target/`) checks the Cortex-M4F build against, with code independent of the
//! core's implementation: the harness's reference GP, and spec §2.3's step written out from
//! the formulas (full 2×2 covariance inverse, not the core's eigen-split). A value of
//! `tests/on_target/src/golden.rs` that disagrees by more than 1e-12 (relative) fails here,
//! and the message prints the recomputed table.

#[allow(dead_code)]
#[path = "../../tests/on_target/src/golden.rs"]
mod golden;

use awfqi_reference::gp::{Hyperparameters, ReferenceGp};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1.0)
}

fn reference_gp(points: usize) -> ReferenceGp {
    let hyper = Hyperparameters {
        signal_variance: golden::GP_SIGNAL_VARIANCE,
        length_scales: golden::GP_LENGTH_SCALES.to_vec(),
        noise_variance: golden::GP_NOISE_VARIANCE,
    };
    let x: Vec<Vec<f64>> = golden::GP_X[..points].iter().map(|p| p.to_vec()).collect();
    // The core always adds the reference's base jitter 1e-10 to the diagonal.
    ReferenceGp::fit_with_diagonal(&x, &golden::GP_Y[..points], &hyper, 1e-10).unwrap()
}

#[test]
fn gp_golden_values_are_the_reference_gps() {
    let gps = [reference_gp(7), reference_gp(8)];
    let preds: Vec<Vec<(f64, f64)>> = gps
        .iter()
        .map(|gp| golden::GP_TEST.iter().map(|x| gp.predict(x)).collect())
        .collect();
    let lml = [
        gps[0].log_marginal_likelihood(),
        gps[1].log_marginal_likelihood(),
    ];
    let stored = [golden::GP_PRED_7, golden::GP_PRED_8];
    let ok = preds.iter().zip(&stored).all(|(p, s)| {
        p.iter()
            .zip(s)
            .all(|(a, b)| close(a.0, b.0) && close(a.1, b.1))
    }) && lml.iter().zip(&golden::GP_LML).all(|(a, b)| close(*a, *b));
    assert!(
        ok,
        "golden.rs is stale; recomputed:\nGP_PRED_7 = {:?}\nGP_PRED_8 = {:?}\nGP_LML = {:?}",
        preds[0], preds[1], lml
    );
}

/// Spec §2.6's instances, typed from the spec's table: (goal, [(mean, variance)]).
fn instance(i: usize) -> ([f64; 2], Vec<([f64; 2], f64)>) {
    let common = vec![
        ([1.0, 10.0], 0.8),
        ([1.0, 8.0], 0.8),
        ([6.0, 6.0], 0.8),
        ([6.0, 4.0], 0.8),
    ];
    match i {
        0 => ([5.0, 10.0], [vec![([1.0, 4.0], 0.7)], common].concat()),
        1 => ([5.0, 10.0], common),
        2 => (
            [5.0, 10.0],
            vec![
                ([2.0, 2.0], 0.8),
                ([4.0, 6.0], 0.8),
                ([1.0, 8.0], 0.8),
                ([2.0, 4.0], 0.8),
                ([8.5, 7.0], 0.8),
                ([8.5, 5.0], 0.8),
            ],
        ),
        _ => ([7.0, 10.0], [vec![([8.0, 2.0], 0.7)], common].concat()),
    }
}

/// W(s) with the full bivariate normal density, Σ = [[v, 1e-5], [1e-5, v]].
fn puddle_weight(puddles: &[([f64; 2], f64)], s: [f64; 2]) -> f64 {
    let c = 1e-5;
    puddles
        .iter()
        .map(|&(m, v)| {
            let det = v * v - c * c;
            let (dx, dy) = (s[0] - m[0], s[1] - m[1]);
            let quad = (v * dx * dx - 2.0 * c * dx * dy + v * dy * dy) / det;
            (-0.5 * quad).exp() / (2.0 * std::f64::consts::PI * det.sqrt())
        })
        .sum()
}

fn in_goal(goal: [f64; 2], s: [f64; 2]) -> bool {
    ((s[0] - goal[0]).powi(2) + (s[1] - goal[1]).powi(2)).sqrt() < 1.41
}

#[test]
fn puddle_step_golden_values_follow_spec_2_3() {
    let mut computed = Vec::new();
    for &(i, s, a, seed) in &golden::STEP_CASES {
        let (goal, puddles) = instance(i);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let ex: f64 = awfqi::rng::standard_normal(&mut rng);
        let ey: f64 = awfqi::rng::standard_normal(&mut rng);
        let eta: f64 = awfqi::rng::standard_normal(&mut rng);
        let w = puddle_weight(&puddles, s);
        let alpha = 1.0 / (1.0 + 5.0 * w);
        let e = [[alpha, 0.0], [-alpha, 0.0], [0.0, alpha], [0.0, -alpha]][a];
        let next = [
            (s[0] + e[0] + 0.2 * ex).clamp(0.0, 10.0),
            (s[1] + e[1] + 0.2 * ey).clamp(0.0, 10.0),
        ];
        let base = if in_goal(goal, s) { 0.0 } else { -1.0 };
        let reward = base - 100.0 * w + 0.1 * eta;
        computed.push((next, reward, in_goal(goal, next)));
    }
    let ok = computed.iter().zip(&golden::STEP_EXPECTED).all(|(c, g)| {
        close(c.0[0], g.0[0]) && close(c.0[1], g.0[1]) && close(c.1, g.1) && c.2 == g.2
    });
    assert!(
        ok,
        "golden.rs is stale; recomputed:\nSTEP_EXPECTED = {computed:?}"
    );
}

#[allow(dead_code, clippy::type_complexity, clippy::approx_constant)]
#[allow(clippy::excessive_precision, clippy::unreadable_literal)]
mod iwfqi_golden {
    include!("../../tests/data/iwfqi_domains_golden.rs");
}

/// The on-target Dam and Acrobot cases are rows of the table the published definitions
/// produced (`scripts/golden/iwfqi_domains.py`, `tests/data/iwfqi_domains_golden.rs`).
#[test]
fn iwfqi_domain_golden_values_are_the_published_definitions() {
    for (&(k, s, a), &(r, next)) in golden::ACROBOT_CASES.iter().zip(&golden::ACROBOT_EXPECTED) {
        let row = iwfqi_golden::ACROBOT
            .iter()
            .find(|row| row.0 == k && row.1 == s && row.2 == a)
            .expect("every on-target Acrobot case is a golden row");
        assert!(close(row.3, r) && row.4.iter().zip(&next).all(|(x, y)| close(*x, *y)));
    }
    for (&(k, s, a), &(r, mean)) in golden::DAM_CASES.iter().zip(&golden::DAM_EXPECTED) {
        let row = iwfqi_golden::DAM
            .iter()
            .find(|row| row.0 == k && row.1 == s && row.2 == a)
            .expect("every on-target Dam case is a golden row");
        assert!(
            close(row.3, r) && close(row.6, mean),
            "{row:?} vs {r}, {mean}"
        );
    }
}
