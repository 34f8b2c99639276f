//! Importance weights: `WeightParams::new`/`weight`/`weights_into` (both estimators) on
//! arbitrary observations and posteriors, `predictive_stds` and `StdTransform` (every
//! noise-subtraction rule), `ideal_weight`, `WeightSummary` and `effective_sample_size`.
//!
//! Invariants: no panic; a weight returned as a success is finite and in `[0, w_max]`;
//! transformed stds are finite and ≥ 0; the ESS lies in `[0, n]`; errors are only the
//! documented kinds.
#![no_main]

use awfqi::float::Real;
use awfqi::weights::{
    Estimator, NoiseSubtraction, Posterior, StdTransform, WeightParams, WeightSummary,
    effective_sample_size, ideal_weight, predictive_stds,
};
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, trace};
use libfuzzer_sys::fuzz_target;

fn real<T: Real>(b: &mut Bytes) -> T {
    T::from_f64(b.num())
}

fn run<T: Real>(b: &mut Bytes) {
    let estimator = if b.bool() {
        Estimator::Mean
    } else {
        Estimator::Heuristic
    };
    let (v, cap) = (real::<T>(b), real::<T>(b));
    let params = match WeightParams::new(estimator, v, cap) {
        Ok(p) => p,
        Err(e) => {
            expect_kind("WeightParams::new", &e, &[Kind::NonFinite, Kind::Invalid]);
            WeightParams::reference_reward()
        }
    };
    let n = b.index(8);
    let ys: Vec<T> = (0..n).map(|_| real(b)).collect();
    let targets: Vec<Posterior<T>> = (0..n).map(|_| Posterior::new(real(b), real(b))).collect();
    let sources: Vec<Posterior<T>> = (0..n).map(|_| Posterior::new(real(b), real(b))).collect();
    trace!("{params:?} weight({ys:?}, {targets:?}, {sources:?})");
    let max = params.max_weight().to_f64();
    for ((&y, &t), &s) in ys.iter().zip(&targets).zip(&sources) {
        match params.weight(y, t, s) {
            Ok(w) => {
                let w = w.to_f64();
                finite("weight", "w", w);
                assert!((0.0..=max).contains(&w), "weight {w} outside [0, {max}]");
            }
            Err(e) => expect_kind("weight", &e, &[Kind::NonFinite, Kind::Invalid]),
        }
    }
    let mut out = vec![T::ZERO; if b.u8() == 0xff { n + 1 } else { n }];
    match params.weights_into(&ys, &targets, &sources, &mut out) {
        Ok(()) => {
            for &w in &out {
                assert!(w.is_finite() && w.to_f64() >= 0.0 && w.to_f64() <= max);
            }
            let mut summary = WeightSummary::new();
            summary.add(&out).expect("valid weights");
            summary.add_ones(b.index(4));
            let ess = summary.effective_sample_size().to_f64();
            finite("WeightSummary", "ess", ess);
            assert!(ess >= 0.0 && ess <= summary.count().to_f64() * (1.0 + 1e-4) + 1e-6);
            finite("WeightSummary", "mean", summary.mean().to_f64());
        }
        Err(e) => expect_kind("weights_into", &e, &[Kind::NonFinite, Kind::Invalid]),
    }

    let mode = [
        NoiseSubtraction::Reference,
        NoiseSubtraction::Principled,
        NoiseSubtraction::Off,
    ][b.index(3)];
    let noise = real::<T>(b);
    let mut variances: Vec<T> = (0..b.index(8)).map(|_| real(b)).collect();
    trace!("predictive_stds({mode:?}, {noise:?}, {variances:?})");
    match predictive_stds(mode, noise, &mut variances) {
        Ok(()) => {
            for s in &variances {
                finite("predictive_stds", "std", s.to_f64());
                assert!(s.to_f64() >= 0.0);
            }
        }
        Err(e) => expect_kind("predictive_stds", &e, &[Kind::NonFinite, Kind::Invalid]),
    }
    match StdTransform::new(mode, noise, real(b)) {
        Ok(t) => {
            let s = t.apply(real(b)).to_f64();
            assert!(!s.is_nan() && s >= 0.0, "std {s}");
        }
        Err(e) => expect_kind("StdTransform::new", &e, &[Kind::NonFinite, Kind::Invalid]),
    }
    match ideal_weight(real::<T>(b), real(b), real(b), real(b)) {
        Ok(w) => assert!(
            !w.is_nan() && w.to_f64() >= 0.0,
            "ideal weight {}",
            w.to_f64()
        ),
        Err(e) => expect_kind("ideal_weight", &e, &[Kind::NonFinite, Kind::Invalid]),
    }
    let ws: Vec<T> = (0..b.index(8)).map(|_| real(b)).collect();
    match effective_sample_size(&ws) {
        Ok(ess) => {
            finite("effective_sample_size", "ess", ess.to_f64());
            assert!(ess.to_f64() >= 0.0 && ess.to_f64() <= ws.len() as f64 * (1.0 + 1e-4));
        }
        Err(e) => expect_kind(
            "effective_sample_size",
            &e,
            &[Kind::Empty, Kind::NonFinite, Kind::Invalid],
        ),
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    if b.bool() {
        run::<f32>(&mut b)
    } else {
        run::<f64>(&mut b)
    }
});
