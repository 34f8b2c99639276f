//! Gaussian process: construction, fit, add_point (both full-capacity policies), predict,
//! log marginal likelihood, set_hyperparameters, set_conditioning and the bounded
//! hyperparameter search, on
//! arbitrary points, targets, hyperparameters and bounds, in f32 and f64.
//!
//! Invariants: no panic; a success never returns a non-finite number (the log marginal
//! likelihood may be −∞, as documented), variances are ≥ 0 and the noisy one is the latent
//! one plus σ²ₙ; errors are only the documented kinds; an error leaves the hyperparameters
//! unchanged and the data either unchanged or (documented last resort) cleared.
#![no_main]

use awfqi::float::Real;
use awfqi::gp::{Conditioning, Gp, HyperparameterBounds, Hyperparameters, SearchOptions, WhenFull};
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, trace};
use libfuzzer_sys::fuzz_target;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

const N: usize = 6;
const D: usize = 2;

fn hyper<T: Real>(b: &mut Bytes) -> Hyperparameters<T, D> {
    Hyperparameters {
        signal_variance: T::from_f64(b.num()),
        length_scales: [T::from_f64(b.num()), T::from_f64(b.num())],
        noise_variance: T::from_f64(b.num()),
    }
}

fn point<T: Real>(b: &mut Bytes) -> [T; D] {
    [T::from_f64(b.num()), T::from_f64(b.num())]
}

fn pair<T: Real>(b: &mut Bytes) -> (T, T) {
    (T::from_f64(b.num()), T::from_f64(b.num()))
}

/// The data and hyperparameters, to compare before and after a failed call.
fn snapshot<T: Real>(gp: &Gp<T, N, D>) -> (Vec<[T; D]>, Vec<T>, Hyperparameters<T, D>) {
    (
        gp.inputs().to_vec(),
        gp.targets().to_vec(),
        *gp.hyperparameters(),
    )
}

#[track_caller]
fn unchanged_after_error<T: Real>(
    call: &str,
    gp: &Gp<T, N, D>,
    before: &(Vec<[T; D]>, Vec<T>, Hyperparameters<T, D>),
) {
    let after = snapshot(gp);
    assert!(
        after.2 == before.2,
        "{call}: error changed the hyperparameters"
    );
    let data_kept = after.0 == before.0 && after.1 == before.1;
    assert!(data_kept || gp.is_empty(), "{call}: error changed the data");
}

fn run<T: Real>(b: &mut Bytes) {
    let h = hyper(b);
    trace!(
        "Gp::<{}, {N}, {D}>::new({h:?})",
        core::any::type_name::<T>()
    );
    let mut gp = match Gp::<T, N, D>::new(h) {
        Ok(gp) => gp,
        Err(e) => {
            expect_kind("new", &e, &[Kind::NonFinite, Kind::Invalid]);
            Gp::empty()
        }
    };
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(b.u8()));
    for _ in 0..24 {
        if b.is_empty() {
            break;
        }
        // The policy holds for every factor kept: its condition estimate is within the limit.
        let kappa = gp.condition_estimate().to_f64();
        assert!(
            kappa <= gp.conditioning().max_condition().to_f64(),
            "a factor beyond the condition limit was kept: {kappa}"
        );
        let before = snapshot(&gp);
        match b.u8() % 7 {
            0 => {
                let n = b.index(N + 2);
                let xs: Vec<[T; D]> = (0..n).map(|_| point(b)).collect();
                let mut ys: Vec<T> = (0..n).map(|_| T::from_f64(b.num())).collect();
                if b.u8() == 0xff {
                    ys.pop();
                }
                trace!("fit(&{xs:?}, &{ys:?})");
                match gp.fit(&xs, &ys) {
                    Ok(()) => assert_eq!(gp.len(), n),
                    Err(e) => {
                        expect_kind(
                            "fit",
                            &e,
                            &[
                                Kind::Invalid,
                                Kind::Empty,
                                Kind::Capacity,
                                Kind::NonFinite,
                                Kind::NotPd,
                                Kind::Overflow,
                                Kind::Conditioning,
                            ],
                        );
                        unchanged_after_error("fit", &gp, &before);
                    }
                }
            }
            1 => {
                let x = point(b);
                let y = T::from_f64(b.num());
                let when_full = if b.bool() {
                    WhenFull::DropOldest
                } else {
                    WhenFull::Refuse
                };
                trace!("add_point({x:?}, {y:?}, {when_full:?})");
                match gp.add_point(x, y, when_full) {
                    Ok(()) => assert_eq!(gp.len(), (before.0.len() + 1).min(N)),
                    Err(e) => {
                        expect_kind(
                            "add_point",
                            &e,
                            &[
                                Kind::NonFinite,
                                Kind::Capacity,
                                Kind::NotPd,
                                Kind::Overflow,
                                Kind::Conditioning,
                            ],
                        );
                        unchanged_after_error("add_point", &gp, &before);
                    }
                }
            }
            2 | 3 => {
                let x = point(b);
                trace!("predict(&{x:?})");
                match gp.predict(&x) {
                    Ok(p) => {
                        let (m, lv, nv) = (
                            p.mean.to_f64(),
                            p.latent_variance.to_f64(),
                            p.noisy_variance.to_f64(),
                        );
                        finite("predict", "mean", m);
                        finite("predict", "latent_variance", lv);
                        finite("predict", "noisy_variance", nv);
                        assert!(lv >= 0.0 && nv >= lv, "predict: variances {lv} {nv}");
                    }
                    Err(e) => expect_kind(
                        "predict",
                        &e,
                        &[Kind::NonFinite, Kind::NotPd, Kind::Overflow],
                    ),
                }
            }
            4 => match gp.log_marginal_likelihood() {
                Ok(v) => {
                    let v = v.to_f64();
                    assert!(!v.is_nan() && v != f64::INFINITY, "lml = {v}");
                }
                Err(e) => expect_kind(
                    "log_marginal_likelihood",
                    &e,
                    &[Kind::Empty, Kind::Overflow],
                ),
            },
            5 if b.bool() => {
                let mut policy = Conditioning::<T>::DEFAULT;
                if b.bool() {
                    policy = policy.without_base_jitter();
                }
                let (ratio, limit) = pair::<T>(b);
                let policy = policy
                    .with_max_jitter_ratio(ratio)
                    .and_then(|p| p.with_max_condition(limit));
                trace!("set_conditioning({policy:?})");
                match policy {
                    Err(e) => expect_kind("Conditioning", &e, &[Kind::Invalid]),
                    Ok(policy) => match gp.set_conditioning(policy) {
                        Ok(()) => assert_eq!(gp.conditioning(), &policy),
                        Err(e) => {
                            expect_kind(
                                "set_conditioning",
                                &e,
                                &[Kind::NotPd, Kind::Overflow, Kind::Conditioning],
                            );
                            unchanged_after_error("set_conditioning", &gp, &before);
                        }
                    },
                }
            }
            5 => match {
                let h = hyper(b);
                trace!("set_hyperparameters({h:?})");
                gp.set_hyperparameters(h)
            } {
                Ok(()) => {}
                Err(e) => {
                    expect_kind(
                        "set_hyperparameters",
                        &e,
                        &[
                            Kind::NonFinite,
                            Kind::Invalid,
                            Kind::NotPd,
                            Kind::Overflow,
                            Kind::Conditioning,
                        ],
                    );
                    unchanged_after_error("set_hyperparameters", &gp, &before);
                }
            },
            _ => {
                let bounds = HyperparameterBounds {
                    signal_variance: pair(b),
                    length_scales: [pair(b), pair(b)],
                    noise_variance: pair(b),
                };
                let options = SearchOptions {
                    max_evaluations: b.index(40),
                    restarts: b.index(4),
                    isotropic: b.bool(),
                };
                trace!("optimize_hyperparameters(&{bounds:?}, &{options:?}, rng)");
                match gp.optimize_hyperparameters(&bounds, &options, &mut rng) {
                    Ok(v) => {
                        finite("optimize_hyperparameters", "lml", v.to_f64());
                        assert!(
                            bounds.contains(gp.hyperparameters()),
                            "optimum outside the box"
                        );
                        assert_eq!(gp.inputs(), &before.0[..]);
                    }
                    Err(e) => {
                        expect_kind(
                            "optimize_hyperparameters",
                            &e,
                            &[
                                Kind::NonFinite,
                                Kind::Invalid,
                                Kind::Capacity,
                                Kind::Empty,
                                Kind::NotPd,
                                Kind::Overflow,
                                Kind::Conditioning,
                            ],
                        );
                        unchanged_after_error("optimize_hyperparameters", &gp, &before);
                    }
                }
            }
        }
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
