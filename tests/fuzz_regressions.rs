//! Regression tests for the crashes the fuzz targets in `fuzz/` found, one test per finding,
//! written from the crash input's trace (`AWFQI_FUZZ_TRACE=1`, see `fuzz/src/lib.rs`).
//! Each names the target, what it found and the fix.

use awfqi::Error;
use awfqi::gp::{Gp, Hyperparameters, WhenFull};

/// Target `gp`: `set_hyperparameters` accepted `c = σ²ₙ = f64::MAX` on an empty GP (each
/// finite, but `c + σ²ₙ` overflows), after which `predict` returned the prior's noisy
/// variance `c + σ²ₙ = ∞` as a success. Fix: `Hyperparameters::validate` rejects an
/// overflowing `c + σ²ₙ` (`InvalidParameter { noise_variance }`).
#[test]
fn gp_hyperparameters_whose_sum_overflows_are_rejected() {
    let huge = Hyperparameters::<f64, 2> {
        signal_variance: f64::MAX,
        length_scales: [f64::MAX, f64::MAX],
        noise_variance: f64::MAX,
    };
    let invalid = Err(Error::InvalidParameter {
        parameter: "noise_variance",
    });
    assert_eq!(huge.validate(), invalid);
    assert_eq!(Gp::<f64, 6, 2>::new(huge).err(), invalid.err());

    let mut gp = Gp::<f64, 6, 2>::new(Hyperparameters::isotropic(1.0, 1.0, 1.5e-47)).unwrap();
    assert_eq!(gp.set_hyperparameters(huge), invalid);
    assert_eq!(gp.hyperparameters().signal_variance, 1.0);
    gp.add_point([-1.9e-183, -102.4], -70.4, WhenFull::DropOldest)
        .unwrap();
    let p = gp.predict(&[-102.0, -102.4]).unwrap();
    assert!(p.mean.is_finite() && p.noisy_variance.is_finite());

    // The same in f32, where the overflow threshold is much lower; just below it is fine.
    let f32_huge = Hyperparameters::<f32, 1>::isotropic(3.0e38, 1.0, 1.0e38);
    assert!(matches!(
        Gp::<f32, 4, 1>::new(f32_huge),
        Err(Error::InvalidParameter { .. })
    ));
    let gp = Gp::<f32, 4, 1>::new(Hyperparameters::isotropic(1.0e38, 1.0, 1.0e38)).unwrap();
    let prior = gp.predict(&[0.0]).unwrap();
    assert_eq!(prior.noisy_variance, 2.0e38);
}
