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

/// Target `weighted_fqi` (its own seed `huge_rewards_f64`): rewards of −10³⁰⁷ with reward
/// weights 10³⁰, γ = 1 and 11 iterations overflowed the weighted sums, and the fit returned
/// Q = −∞ as a success. Fix: `TabularFqi::fit` bounds the magnitudes before it touches the
/// table and refuses inputs whose values could overflow (`InvalidParameter { reward }`),
/// leaving the table as it was.
#[test]
fn fqi_refuses_rewards_whose_values_would_overflow() {
    use awfqi::fqi::{CellGrid, EmptyCells, FqiConfig, FqiEntry, SampleSet, TabularFqi};
    use awfqi::model::Transition;
    let step = |i: usize| {
        let (x, y) = ((i % 10) as f64, (i / 3) as f64 * 2.5);
        let up = i % 2 == 0;
        Transition {
            state: [x, y],
            action: if up { 2 } else { 0 },
            reward: -1e307,
            next_state: if up {
                [x, (y + 1.0).min(10.0)]
            } else {
                [(x + 1.0).min(10.0), y]
            },
            absorbing: false,
        }
    };
    let samples: Vec<_> = (0..12).map(step).collect();
    let weights = [1e30; 12];
    let grid = CellGrid::cube(0.0, 10.0, 5).unwrap();
    let mut storage = vec![FqiEntry::<f64>::EMPTY; 100];
    let mut fqi = TabularFqi::new(grid, 4, &mut storage).unwrap();
    let config = FqiConfig::new(1.0, 11, EmptyCells::Nearest).unwrap();
    let sets = [SampleSet::weighted(&samples, Some(&weights), None)];
    assert_eq!(
        fqi.fit(&sets, &config),
        Err(Error::InvalidParameter {
            parameter: "reward"
        })
    );
    assert!(fqi.entries().iter().all(|e| e.q() == 0.0), "table changed");
    // The same data at ordinary magnitudes fit, with every value finite.
    let ordinary: Vec<_> = samples
        .iter()
        .map(|s| Transition { reward: -1.0, ..*s })
        .collect();
    let sets = [SampleSet::weighted(&ordinary, Some(&[2.0; 12]), None)];
    fqi.fit(&sets, &config).unwrap();
    assert!(fqi.entries().iter().all(|e| e.q().is_finite()));
}

/// Target `score_draw`: a source-data row set built from records whose state was NaN was
/// accepted, and the sampler then drew the row `([NaN, 0], 0)` as a query point (a success
/// carrying a non-finite value). Fix: `RowSet::source_data` / `both` refuse a record with a
/// non-finite state (`NonFinite { state }`); `PointGrid::new` likewise refuses a spacing
/// whose last point overflows (`InvalidParameter { spacing }`), which made `+∞` states.
#[test]
fn score_rows_are_always_finite_query_points() {
    use awfqi::model::Transition;
    use awfqi::score::{PointGrid, RowSet};
    let record = |x: f64| Transition {
        state: [x, 0.0],
        action: 0,
        reward: 0.0,
        next_state: [0.0, 0.0],
        absorbing: false,
    };
    let good = [record(1.0), record(2.0)];
    let bad = [record(1.0), record(f64::NAN)];
    let sources: [&[Transition<[f64; 2], f64>]; 2] = [&good, &bad];
    assert_eq!(
        RowSet::source_data(&sources).err(),
        Some(Error::NonFinite { parameter: "state" })
    );
    let grid = awfqi::env::PuddleWorld::score_grid(5.0).unwrap();
    assert_eq!(
        RowSet::both(grid, 4, &sources).err(),
        Some(Error::NonFinite { parameter: "state" })
    );
    let rows = RowSet::source_data(&sources[..1]).unwrap();
    assert!(rows.iter().all(|(s, _)| s.iter().all(|c| c.is_finite())));

    assert_eq!(
        PointGrid::new([0.0, 0.0], [1e308, 1.0], [3, 1]).err(),
        Some(Error::InvalidParameter {
            parameter: "spacing"
        })
    );
    assert_eq!(
        PointGrid::<f32, 2>::new([3e38, 0.0], [1e38, 1.0], [2, 2]).err(),
        Some(Error::InvalidParameter {
            parameter: "spacing"
        })
    );
    let ok = PointGrid::<f64, 2>::new([0.0, 0.0], [1e307, 1.0], [3, 2]).unwrap();
    assert!((0..ok.len()).all(|p| ok.point(p).unwrap().iter().all(|c| c.is_finite())));
}

/// Target `score_draw`: two sources whose finite next-x values differ by 2.7·10¹⁵⁴ (f64)
/// gave a variance of +∞, returned in a successfully computed score table. Fix:
/// `ScoreTable::compute` refuses values whose variance overflows
/// (`InvalidParameter { source value }`).
#[test]
fn score_variance_overflow_is_an_error() {
    use awfqi::model::{SourceMeans, SourceModel};
    use awfqi::score::{PointGrid, RowSet, ScoreTable, Scores};
    struct Constant([f64; 3]);
    impl SourceModel<f64, 2> for Constant {
        fn predict(&self, _: [f64; 2], _: usize) -> awfqi::Result<SourceMeans<f64, 2>> {
            let [reward, x, y] = self.0;
            Ok(SourceMeans {
                reward,
                next_state: [x, y],
            })
        }
    }
    let rows = RowSet::grid(PointGrid::new([0.0, 0.0], [2.0, 2.0], [3, 3]).unwrap(), 4).unwrap();
    let mut storage = vec![Scores::ZERO; rows.len()];
    let sources = [Constant([1.0, 2.0, 3.0]), Constant([0.0, -2.68e154, 0.0])];
    assert_eq!(
        ScoreTable::compute(rows, &sources, &mut storage).err(),
        Some(Error::InvalidParameter {
            parameter: "source value"
        })
    );
    let sources = [Constant([1.0, 2.0, 3.0]), Constant([0.0, -2.68e150, 0.0])];
    let table = ScoreTable::compute(rows, &sources, &mut storage).unwrap();
    assert!(table.values().iter().all(|s| s.total().is_finite()));
}

/// Target `weights`: six weights of 3.4·10³⁸ (f32, a cap of 3.4·10³⁸ allows them) made the
/// summary's `Σw²` overflow, and `effective_sample_size` returned `∞/∞ = NaN`. Fix:
/// `WeightSummary` keeps its sums relative to the largest weight seen (rescaling when a
/// larger one arrives), as `effective_sample_size` of a slice already did.
#[test]
fn weight_summary_of_huge_and_tiny_weights_is_finite_and_exact() {
    use awfqi::weights::{WeightSummary, effective_sample_size};
    let mut s = WeightSummary::<f32>::new();
    s.add(&[3.4e38; 6]).unwrap();
    s.add_ones(2);
    let ess = s.effective_sample_size();
    // (6·w + 2)² / (6·w² + 2) → 6 as w → ∞.
    assert!((ess - 6.0).abs() < 1e-4, "ess {ess}");
    assert!((s.mean() / 2.55e38 - 1.0).abs() < 1e-5, "mean {}", s.mean()); // 3.4e38 · 6/8
    // Tiny weights: Σw² would underflow to 0 without the scaling; ESS of equal weights is n.
    let mut t = WeightSummary::<f32>::new();
    t.add(&[1e-30; 4]).unwrap();
    assert!((t.effective_sample_size() - 4.0).abs() < 1e-5);
    // The running summary agrees with the one-slice function.
    let w = [0.5f32, 0.0, 1e3, 2.0, 7.5];
    let mut u = WeightSummary::new();
    u.add(&w[..2]).unwrap();
    u.add(&w[2..]).unwrap();
    let direct = effective_sample_size(&w).unwrap();
    assert!((u.effective_sample_size() - direct).abs() < 1e-5 * direct);
}

/// Target `gp` (after the search's fallback to the best trusted point): in `f32`, with a
/// target of 3.9e25 the data fit `yᵀK⁻¹y` overflows at small signal variances, so the first
/// point the policy trusted rated −∞; the search's optimum (a large signal variance) was
/// beyond the policy, and the fallback returned `Ok(−∞)`. Fix: only a point with a finite
/// likelihood is a fallback; without one the refusal is the error.
#[test]
fn gp_search_fallback_never_returns_a_non_finite_likelihood() {
    use awfqi::gp::{HyperparameterBounds, SearchOptions};
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    let mut gp = Gp::<f32, 6, 2>::empty();
    gp.fit(
        &[[0.0, 0.0], [111.0, 111.0], [111.0, 111.0], [111.0, 111.0]],
        &[111.0; 4],
    )
    .unwrap();
    // The crash input's generator seed (its 17th byte).
    let mut rng = ChaCha8Rng::seed_from_u64(255);
    let fixed = HyperparameterBounds {
        signal_variance: (111.0, 111.0),
        length_scales: [(111.0, 111.0), (111.0, 111.0)],
        noise_variance: (111.0, 111.0),
    };
    let options = SearchOptions {
        max_evaluations: 0,
        restarts: 3,
        isotropic: false,
    };
    if let Ok(v) = gp.optimize_hyperparameters(&fixed, &options, &mut rng) {
        assert!(v.is_finite(), "{v}");
    }
    gp.add_point([0.0, 0.0], 3.861_006_8e25, WhenFull::DropOldest)
        .unwrap();
    let bounds = HyperparameterBounds {
        signal_variance: (69.269_53, 5.142_912_6e25),
        length_scales: [(69.269_53, 69.269_53), (36.929_688, 69.269_53)],
        noise_variance: (69.269_53, 111.0),
    };
    let options = SearchOptions {
        max_evaluations: 31,
        restarts: 3,
        isotropic: true,
    };
    let before = *gp.hyperparameters();
    match gp.optimize_hyperparameters(&bounds, &options, &mut rng) {
        Ok(v) => {
            assert!(v.is_finite(), "a success with lml {v}");
            assert_eq!(gp.log_marginal_likelihood(), Ok(v));
        }
        Err(e) => {
            assert!(
                matches!(e, Error::JitterLimit { .. } | Error::IllConditioned { .. }),
                "{e:?}"
            );
            assert_eq!(gp.hyperparameters(), &before);
        }
    }
}

/// Target `gp`: a search whose optimum the conditioning policy refused and whose fallback
/// failed too returned the error with the GP holding the search's hyperparameters (the
/// documented contract: on error the previous hyperparameters are kept). Trace of the
/// crash input (f64, generator seed 125).
#[test]
fn gp_search_error_keeps_the_previous_hyperparameters() {
    use awfqi::gp::{Conditioning, HyperparameterBounds, SearchOptions};
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    let mut gp = Gp::<f64, 6, 2>::new(Hyperparameters::isotropic(
        3.013_515_369_954_056_6e296,
        125.488_281_25,
        125.488_281_25,
    ))
    .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(125);
    let policy = Conditioning::<f64>::DEFAULT
        .without_base_jitter()
        .with_max_jitter_ratio(63.488_281_25)
        .and_then(|p| p.with_max_condition(9.050_273_318_221_717e62))
        .unwrap();
    let _ = gp.set_conditioning(policy);
    let _ = gp.add_point([1.96875, 1.00390625], 1.00390625, WhenFull::DropOldest);
    let _ = gp.add_point([1.00390625, 1.00390625], 1.00390625, WhenFull::Refuse);
    let _ = gp.add_point([1.01171875, 1.00390625], 1.00390625, WhenFull::DropOldest);
    let _ = gp.add_point(
        [0.00390625, 1.358408876914e-312],
        42.59765625,
        WhenFull::Refuse,
    );
    let _ = gp.add_point(
        [1.0, 2.68156414328591e154],
        3.542178508925456e-79,
        WhenFull::DropOldest,
    );
    let _ = gp.add_point([-73.0, -73.0], -105.0, WhenFull::DropOldest);
    let _ = gp.add_point([-73.0, -73.0], -74.29296875, WhenFull::DropOldest);
    let bounds = HyperparameterBounds {
        signal_variance: (1.00390625, 3.4e38),
        length_scales: [(3.4e38, 3.4e38), (3.4e38, 3.4e38)],
        noise_variance: (1.2e-38, 63.0),
    };
    let options = SearchOptions {
        max_evaluations: 20,
        restarts: 1,
        isotropic: true,
    };
    let before = *gp.hyperparameters();
    match gp.optimize_hyperparameters(&bounds, &options, &mut rng) {
        Ok(v) => assert!(v.is_finite(), "{v}"),
        Err(e) => assert_eq!(gp.hyperparameters(), &before, "after {e:?}"),
    }
}
