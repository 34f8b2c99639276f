//! The bad-input sweep: every public function of the core that takes data, given NaN, ±∞,
//! empty slices, out-of-range states and actions, zero or negative variances and length
//! scales, and capacity overflow, returns the error its documentation names — kind and, where
//! documented, the parameter — and leaves the caller's data and the object's state as they
//! were. Run in `f32` (the microcontroller's precision) and `f64` where the code is generic.

use awfqi::alias::{AliasEntry, AliasTable};
use awfqi::env::{Dynamics, EpisodeRecord, GridWorld, Puddle, PuddleWorld};
use awfqi::evaluation::{EvaluationProtocol, evaluate};
use awfqi::fqi::{
    Approximator, CellGrid, EmptyCells, FqiConfig, FqiEntry, SampleSet, TabularFqi, TileFqi,
    Tilings,
};
use awfqi::gp::{Gp, HyperparameterBounds, Hyperparameters, SearchOptions, WhenFull};
use awfqi::model::{FiniteMdp, GenerativeModel, Transition};
use awfqi::model::{SourceMeans, SourceModel};
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use awfqi::prelude::{Awfqi, AwfqiBuffers, AwfqiConfig, SourceData};
use awfqi::record_gp::{
    GpTraining, Output, SubsetRule, batch_transform, fit_gp, predict_posteriors,
};
use awfqi::score::{PointGrid, RowSet, ScoreColumn, ScoreTable, Scores};
use awfqi::weights::{
    Estimator, NoiseSubtraction, Posterior, StdTransform, WeightParams, WeightSummary,
    effective_sample_size, ideal_weight, predictive_stds,
};
use awfqi::{Error, Result, prelude::Real};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// NaN, +∞ and −∞.
fn non_finite<T: Real>() -> [T; 3] {
    [T::from_f64(f64::NAN), T::INFINITY, T::NEG_INFINITY]
}

fn nf(parameter: &'static str) -> Error {
    Error::NonFinite { parameter }
}

fn inv(parameter: &'static str) -> Error {
    Error::InvalidParameter { parameter }
}

fn oor(parameter: &'static str) -> Error {
    Error::OutOfRange { parameter }
}

/// The error of a call that must fail.
#[track_caller]
fn err<V>(r: Result<V>) -> Error {
    match r {
        Ok(_) => panic!("expected an error, got a success"),
        Err(e) => e,
    }
}

fn rng() -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(99)
}

/// The generator was not advanced: its next word equals a fresh copy's.
#[track_caller]
fn untouched(r: &mut ChaCha8Rng) {
    assert_eq!(r.next_u64(), rng().next_u64(), "the generator was advanced");
}

fn t<T: Real>(x: f64) -> T {
    T::from_f64(x)
}

// ---------------------------------------------------------------------------------- rng ---

fn rng_draws<T: Real>() {
    let mut r = rng();
    for x in non_finite::<T>() {
        assert_eq!(err(awfqi::rng::uniform_in(&mut r, x, t(1.0))), nf("low"));
        assert_eq!(err(awfqi::rng::uniform_in(&mut r, t(0.0), x)), nf("high"));
        assert_eq!(err(awfqi::rng::normal(&mut r, x, t(1.0))), nf("mean"));
        assert_eq!(err(awfqi::rng::normal(&mut r, t(0.0), x)), nf("std"));
        assert_eq!(
            err(awfqi::rng::categorical(&mut r, &[t(1.0), x])),
            nf("weights")
        );
    }
    assert_eq!(
        err(awfqi::rng::uniform_in(&mut r, t::<T>(2.0), t(1.0))),
        inv("low")
    );
    assert_eq!(
        err(awfqi::rng::normal(&mut r, t::<T>(0.0), t(-1e-30))),
        inv("std")
    );
    assert_eq!(
        err(awfqi::rng::categorical::<T, _>(&mut r, &[])),
        Error::EmptyData
    );
    assert_eq!(
        err(awfqi::rng::categorical(&mut r, &[t::<T>(1.0), t(-1.0)])),
        inv("weights")
    );
    assert_eq!(
        err(awfqi::rng::categorical(&mut r, &[t::<T>(0.0), t(0.0)])),
        inv("weights")
    );
}

#[test]
fn rng_rejects_bad_parameters() {
    rng_draws::<f32>();
    rng_draws::<f64>();
}

// ------------------------------------------------------------------------------- policy ---

#[test]
fn policies_reject_bad_parameters() {
    assert_eq!(err(UniformPolicy::new(0)), inv("num_actions"));
    let greedy = |_: &[f32; 2]| -> Result<usize> { Ok(0) };
    for e in non_finite::<f32>() {
        assert_eq!(err(EpsilonGreedyPolicy::new(greedy, e, 4)), nf("epsilon"));
    }
    for e in [-1e-6f32, 1.000001, -1.0] {
        assert_eq!(err(EpsilonGreedyPolicy::new(greedy, e, 4)), oor("epsilon"));
    }
    assert_eq!(
        err(EpsilonGreedyPolicy::new(greedy, 0.3f32, 0)),
        inv("num_actions")
    );
}

// ------------------------------------------------------------------------- Puddle World ---

fn puddle_states<T: Real>() {
    let world = PuddleWorld::<T>::target(Dynamics::PuddleBased);
    let mut bad: Vec<([T; 2], Error)> = Vec::new();
    for x in non_finite::<T>() {
        bad.push(([x, t(1.0)], nf("state")));
        bad.push(([t(1.0), x], nf("state")));
    }
    for s in [[-1e-3, 5.0], [5.0, 10.001], [1e30, 0.0], [-1e30, -1e30]] {
        bad.push(([t(s[0]), t(s[1])], oor("state")));
    }
    for (s, e) in bad {
        assert_eq!(world.check_state(s), Err(e));
        assert_eq!(err(world.puddle_weight(s)), e);
        assert_eq!(err(world.step_length(s)), e);
        assert_eq!(err(world.in_goal(s)), e);
        assert_eq!(err(world.mean_reward(s)), e);
        assert_eq!(err(world.mean_next_state(s, 0)), e);
        let mut r = rng();
        assert_eq!(err(world.step(s, 0, &mut r)), e);
        assert_eq!(err(world.query(s, 0, &mut r)), e);
        untouched(&mut r); // "nothing is drawn when the arguments are invalid"
    }
    for a in [4, 5, usize::MAX] {
        let s = [t(1.0), t(1.0)];
        assert_eq!(err(world.mean_next_state(s, a)), oor("action"));
        let mut r = rng();
        assert_eq!(err(world.step(s, a, &mut r)), oor("action"));
        untouched(&mut r);
    }
}

fn puddle_construction<T: Real>() {
    let good = Puddle::new([t::<T>(1.0), t(4.0)], t(0.7));
    for x in non_finite::<T>() {
        assert_eq!(
            err(PuddleWorld::new([x, t(1.0)], &[good], Dynamics::Shared)),
            nf("goal")
        );
        let p = Puddle::new([t(1.0), x], t(0.7));
        assert_eq!(
            err(PuddleWorld::new([t(5.0), t(10.0)], &[p], Dynamics::Shared)),
            nf("puddle mean")
        );
        let p = Puddle::new([t(1.0), t(1.0)], x);
        assert_eq!(
            err(PuddleWorld::new([t(5.0), t(10.0)], &[p], Dynamics::Shared)),
            nf("puddle variance")
        );
    }
    for v in [0.0, -0.7, 1e-5, 1e-6] {
        let p = Puddle::new([t(1.0), t(1.0)], t(v));
        assert_eq!(
            err(PuddleWorld::new(
                [t(5.0), t(10.0)],
                &[good, p],
                Dynamics::Shared
            )),
            inv("puddle variance")
        );
    }
    let nine = [good; 9];
    assert_eq!(
        err(PuddleWorld::new([t(5.0), t(10.0)], &nine, Dynamics::Shared)),
        Error::CapacityExceeded { capacity: 8 }
    );
}

fn puddle_episodes<T: Real>() {
    let world = PuddleWorld::<T>::target(Dynamics::Shared);
    let mut policy = UniformPolicy::new(4).unwrap();
    let marker = EpisodeRecord {
        t: 7,
        ..EpisodeRecord::<T>::default()
    };
    let mut records = [marker; 50];
    let mut r = rng();
    assert_eq!(
        err(world.run_episode(&mut policy, 0, &mut records, &mut r)),
        inv("horizon")
    );
    assert_eq!(
        err(world.run_episode(&mut policy, 50, &mut records[..49], &mut r)),
        Error::CapacityExceeded { capacity: 49 }
    );
    assert_eq!(
        err(world.run_episode_with(&mut policy, 0, &mut r, |_| Ok(()))),
        inv("horizon")
    );
    assert!(
        records.iter().all(|x| *x == marker),
        "records written on error"
    );
    for d in non_finite::<T>() {
        assert_eq!(
            err(world.rollout(&mut policy, 50, d, &mut r)),
            nf("discount")
        );
    }
    for d in [-0.01, 1.01] {
        assert_eq!(
            err(world.rollout(&mut policy, 50, t(d), &mut r)),
            oor("discount")
        );
    }
    assert_eq!(
        err(world.rollout(&mut policy, 0, t(0.9), &mut r)),
        inv("horizon")
    );
    untouched(&mut r);
    // A policy that returns an invalid action stops the episode with the step's error.
    let mut bad_policy = |_: &[T; 2]| -> Result<usize> { Ok(4) };
    assert_eq!(
        err(world.rollout(&mut bad_policy, 50, t(0.9), &mut r)),
        oor("action")
    );
    assert_eq!(
        err(evaluate(
            &world,
            &mut policy,
            &EvaluationProtocol {
                rollouts: 0,
                ..world.evaluation_protocol()
            },
            &mut r
        )),
        inv("rollouts")
    );
}

#[test]
fn puddle_world_rejects_bad_states_actions_and_parameters() {
    puddle_states::<f32>();
    puddle_states::<f64>();
    puddle_construction::<f32>();
    puddle_construction::<f64>();
    puddle_episodes::<f32>();
    puddle_episodes::<f64>();
}

// --------------------------------------------------------------------------- Grid World ---

#[test]
fn grid_world_rejects_bad_indices_and_parameters() {
    assert_eq!(
        err(GridWorld::<f32>::new(0, 3, (0, 0), 0.25, false)),
        inv("width")
    );
    assert_eq!(
        err(GridWorld::<f32>::new(3, 0, (0, 0), 0.25, false)),
        inv("height")
    );
    assert_eq!(
        err(GridWorld::<f32>::new(usize::MAX, 2, (0, 0), 0.25, false)),
        inv("height")
    );
    assert_eq!(
        err(GridWorld::<f32>::new(3, 3, (3, 0), 0.25, false)),
        oor("goal")
    );
    assert_eq!(
        err(GridWorld::<f32>::new(3, 3, (0, 3), 0.25, false)),
        oor("goal")
    );
    for v in non_finite::<f64>() {
        assert_eq!(
            err(GridWorld::<f64>::new(3, 3, (1, 1), v, false)),
            nf("reward_variance")
        );
    }
    for v in [0.0f64, -0.25] {
        assert_eq!(
            err(GridWorld::<f64>::new(3, 3, (1, 1), v, false)),
            inv("reward_variance")
        );
    }
    assert_eq!(err(GridWorld::<f32>::thesis(4, false)), oor("index"));

    let grid = GridWorld::<f32>::thesis(0, true).unwrap();
    assert_eq!(err(grid.state_of(10, 0)), oor("cell"));
    assert_eq!(err(grid.state_of(0, 10)), oor("cell"));
    assert_eq!(err(grid.cell_of(100)), oor("state"));
    for (s, a, e) in [
        (100, 0, oor("state")),
        (usize::MAX, 0, oor("state")),
        (0, 4, oor("action")),
    ] {
        assert_eq!(err(grid.next_state(s, a)), e);
        assert_eq!(err(grid.reward_mean(s, a)), e);
        assert_eq!(err(grid.reward_variance(s, a)), e);
        assert_eq!(err(grid.transition_probability(s, a, 0)), e);
        let mut visited = false;
        assert_eq!(err(grid.for_each_successor(s, a, |_, _| visited = true)), e);
        assert!(!visited);
        assert_eq!(err(grid.query(s, a, &mut rng())), e);
    }
    assert_eq!(
        err(grid.transition_probability(0, 0, 100)),
        oor("next_state")
    );
}

// ------------------------------------------------------------------- Gaussian process ---

fn hyper_fields<T: Real>() {
    let ok = Hyperparameters::<T, 2>::isotropic(t(1.0), t(1.0), t(0.1));
    for x in non_finite::<T>() {
        let mut h = ok;
        h.signal_variance = x;
        assert_eq!(h.validate(), Err(nf("signal_variance")));
        assert_eq!(err(Gp::<T, 4, 2>::new(h)), nf("signal_variance"));
        let mut h = ok;
        h.length_scales[1] = x;
        assert_eq!(h.validate(), Err(nf("length_scales")));
        let mut h = ok;
        h.noise_variance = x;
        assert_eq!(h.validate(), Err(nf("noise_variance")));
    }
    for v in [0.0, -1.0, -1e-30] {
        let mut h = ok;
        h.signal_variance = t(v);
        assert_eq!(h.validate(), Err(inv("signal_variance")));
        let mut h = ok;
        h.length_scales[0] = t(v);
        assert_eq!(h.validate(), Err(inv("length_scales")));
    }
    let mut h = ok;
    h.noise_variance = t(-1e-30);
    assert_eq!(h.validate(), Err(inv("noise_variance")));
}

fn fitted<T: Real>() -> Gp<T, 4, 2> {
    let mut gp = Gp::<T, 4, 2>::new(Hyperparameters::isotropic(t(1.0), t(1.0), t(0.1))).unwrap();
    gp.fit(
        &[[t(0.0), t(0.0)], [t(1.0), t(0.5)], [t(2.0), t(1.0)]],
        &[t(0.5), t(-1.0), t(0.25)],
    )
    .unwrap();
    gp
}

/// Everything observable of a GP: data, hyperparameters, jitter and a prediction.
fn state<T: Real>(gp: &Gp<T, 4, 2>) -> (Vec<[T; 2]>, Vec<T>, Hyperparameters<T, 2>, T, String) {
    let p = gp.predict(&[t(0.7), t(0.3)]).map(|p| format!("{p:?}"));
    (
        gp.inputs().to_vec(),
        gp.targets().to_vec(),
        *gp.hyperparameters(),
        gp.jitter(),
        format!("{p:?}"),
    )
}

fn gp_calls<T: Real>() {
    hyper_fields::<T>();
    let mut gp = fitted::<T>();
    let before = state(&gp);
    let x3 = [[t(0.0), t(0.0)], [t(1.0), t(0.5)], [t(2.0), t(1.0)]];
    assert_eq!(gp.fit(&x3, &[t(1.0), t(2.0)]), Err(inv("y")));
    assert_eq!(gp.fit(&[], &[]), Err(Error::EmptyData));
    let x5 = [[t(0.0), t(0.0)]; 5];
    assert_eq!(
        gp.fit(&x5, &[t(0.0); 5]),
        Err(Error::CapacityExceeded { capacity: 4 })
    );
    for x in non_finite::<T>() {
        let mut bad = x3;
        bad[1][0] = x;
        assert_eq!(gp.fit(&bad, &[t(1.0); 3]), Err(nf("x")));
        assert_eq!(gp.fit(&x3, &[t(1.0), x, t(1.0)]), Err(nf("y")));
        assert_eq!(
            gp.add_point([t(0.5), x], t(1.0), WhenFull::DropOldest),
            Err(nf("x"))
        );
        assert_eq!(
            gp.add_point([t(0.5), t(0.5)], x, WhenFull::DropOldest),
            Err(nf("y"))
        );
        assert_eq!(err(gp.predict(&[x, t(0.0)])), nf("x"));
        let mut h = *gp.hyperparameters();
        h.length_scales[0] = x;
        assert_eq!(gp.set_hyperparameters(h), Err(nf("length_scales")));
    }
    let mut h = *gp.hyperparameters();
    h.length_scales[1] = t(0.0);
    assert_eq!(gp.set_hyperparameters(h), Err(inv("length_scales")));
    assert_eq!(state(&gp), before, "a rejected call changed the GP");

    // Capacity: a full GP refuses with `Refuse` and stays as it was.
    gp.add_point([t(3.0), t(1.5)], t(0.0), WhenFull::Refuse)
        .unwrap();
    let full = state(&gp);
    assert_eq!(
        gp.add_point([t(4.0), t(2.0)], t(0.0), WhenFull::Refuse),
        Err(Error::CapacityExceeded { capacity: 4 })
    );
    assert_eq!(state(&gp), full);

    // The search: bad bounds, bad options, no data, too many ARD parameters.
    let mut r = rng();
    let options = SearchOptions {
        max_evaluations: 10,
        restarts: 1,
        isotropic: true,
    };
    let ok = HyperparameterBounds::<T, 2>::spec_default();
    for x in non_finite::<T>() {
        let mut b = ok;
        b.signal_variance.1 = x;
        assert_eq!(
            err(gp.optimize_hyperparameters(&b, &options, &mut r)),
            nf("signal_variance")
        );
        let mut b = ok;
        b.length_scales[1].0 = x;
        assert_eq!(b.validate(), Err(nf("length_scales")));
        let mut b = ok;
        b.noise_variance.0 = x;
        assert_eq!(b.validate(), Err(nf("noise_variance")));
    }
    for (lo, hi) in [(0.0, 1.0), (-1.0, 1.0), (2.0, 1.0)] {
        let mut b = ok;
        b.noise_variance = (t(lo), t(hi));
        assert_eq!(
            err(gp.optimize_hyperparameters(&b, &options, &mut r)),
            inv("noise_variance")
        );
    }
    let mut b = ok;
    b.length_scales = [(t(0.1), t(0.2)), (t(0.3), t(0.4))];
    assert_eq!(
        err(gp.optimize_hyperparameters(&b, &options, &mut r)),
        inv("length_scales")
    );
    let few = SearchOptions {
        max_evaluations: 1,
        restarts: 1,
        isotropic: true,
    };
    assert_eq!(
        err(gp.optimize_hyperparameters(&ok, &few, &mut r)),
        inv("max_evaluations")
    );
    let overflow = SearchOptions {
        max_evaluations: 10,
        restarts: usize::MAX,
        isotropic: true,
    };
    assert_eq!(overflow.validate(), Err(inv("restarts")));
    assert_eq!(state(&gp), full, "a rejected search changed the GP");
    untouched(&mut r);

    let mut empty = Gp::<T, 4, 2>::empty();
    assert_eq!(err(empty.log_marginal_likelihood()), Error::EmptyData);
    assert_eq!(
        err(empty.optimize_hyperparameters(&ok, &options, &mut r)),
        Error::EmptyData
    );
    let mut wide = Gp::<T, 4, 7>::empty();
    wide.add_point([t(0.0); 7], t(1.0), WhenFull::Refuse)
        .unwrap();
    let ard = SearchOptions {
        max_evaluations: 10,
        restarts: 1,
        isotropic: false,
    };
    assert_eq!(
        err(wide.optimize_hyperparameters(&HyperparameterBounds::spec_default(), &ard, &mut r)),
        Error::CapacityExceeded { capacity: 8 }
    );
}

#[test]
fn gp_rejects_bad_data_hyperparameters_and_bounds_and_keeps_its_state() {
    gp_calls::<f32>();
    gp_calls::<f64>();
}

// ------------------------------------------------------------------------- alias table ---

fn alias<T: Real>() {
    let mut storage = [AliasEntry::<T>::EMPTY; 3];
    let w = |xs: &[f64]| xs.iter().map(|&x| t::<T>(x)).collect::<Vec<T>>();
    assert_eq!(
        err(AliasTable::build(w(&[1.0, 2.0, 3.0, 4.0]), &mut storage)),
        Error::CapacityExceeded { capacity: 3 }
    );
    assert_eq!(
        err(AliasTable::build(w(&[]), &mut storage)),
        Error::EmptyData
    );
    for x in non_finite::<T>() {
        assert_eq!(
            err(AliasTable::build([t(1.0), x], &mut storage)),
            nf("weights")
        );
    }
    assert_eq!(
        err(AliasTable::build(w(&[1.0, -1e-30]), &mut storage)),
        inv("weights")
    );
    assert_eq!(
        err(AliasTable::build(w(&[0.0, 0.0]), &mut storage)),
        inv("weights")
    );
}

#[test]
fn alias_table_rejects_bad_weights() {
    alias::<f32>();
    alias::<f64>();
}

// ----------------------------------------------------------------------------- weights ---

fn weight_calls<T: Real>() {
    for x in non_finite::<T>() {
        let e = err(WeightParams::new(Estimator::Mean, x, t(1000.0)));
        assert!(
            matches!(
                e,
                Error::NonFinite {
                    parameter: "noise_variance"
                } | Error::InvalidParameter {
                    parameter: "noise_variance"
                }
            ),
            "{e:?}"
        );
        let e = err(WeightParams::new(Estimator::Mean, t(0.1), x));
        assert!(
            matches!(
                e,
                Error::NonFinite {
                    parameter: "max_weight"
                } | Error::InvalidParameter {
                    parameter: "max_weight"
                }
            ),
            "{e:?}"
        );
    }
    for v in [0.0, -0.1] {
        assert_eq!(
            err(WeightParams::new(
                Estimator::Heuristic,
                t::<T>(v),
                t(1000.0)
            )),
            inv("noise_variance")
        );
        assert_eq!(
            err(WeightParams::new(Estimator::Heuristic, t::<T>(0.1), t(v))),
            inv("max_weight")
        );
    }
    let params = WeightParams::<T>::new(Estimator::Mean, t(0.1), t(1000.0)).unwrap();
    let good = Posterior::new(t::<T>(-1.0), t(0.1));
    for x in non_finite::<T>() {
        assert_eq!(err(params.weight(x, good, good)), nf("y"));
        assert_eq!(
            err(params.weight(t(-1.0), Posterior::new(x, t(0.1)), good)),
            nf("posterior.mean")
        );
        assert_eq!(
            err(params.weight(t(-1.0), good, Posterior::new(t(0.0), x))),
            nf("posterior.std")
        );
    }
    assert_eq!(
        err(params.weight(t(-1.0), good, Posterior::new(t(0.0), t(-0.1)))),
        inv("posterior.std")
    );

    let sentinel = t::<T>(-7.0);
    let mut out = [sentinel; 3];
    let ys = [t::<T>(-1.0); 3];
    assert_eq!(
        params.weights_into(&ys[..2], &[good; 3], &[good; 3], &mut out),
        Err(inv("out"))
    );
    assert_eq!(
        params.weights_into(&ys, &[good; 3], &[good; 2], &mut out),
        Err(inv("out"))
    );
    let mut bad_ys = ys;
    bad_ys[2] = T::from_f64(f64::NAN);
    assert_eq!(
        params.weights_into(&bad_ys, &[good; 3], &[good; 3], &mut out),
        Err(nf("y"))
    );
    assert!(
        out.iter().all(|&w| w == sentinel),
        "weights_into wrote on error"
    );

    for x in non_finite::<T>() {
        assert_eq!(
            err(StdTransform::new(NoiseSubtraction::Reference, x, t(0.1))),
            nf("noise_variance")
        );
        assert_eq!(
            err(StdTransform::new(NoiseSubtraction::Reference, t(0.1), x)),
            nf("variances")
        );
        let mut v = [t::<T>(0.5), x, t(0.2)];
        let copy = format!("{v:?}");
        assert_eq!(
            predictive_stds(NoiseSubtraction::Principled, t(0.1), &mut v),
            Err(nf("variances"))
        );
        assert_eq!(
            format!("{v:?}"),
            copy,
            "predictive_stds changed its input on error"
        );
        let mut v = [t::<T>(0.5)];
        assert_eq!(
            predictive_stds(NoiseSubtraction::Off, x, &mut v),
            Err(nf("noise_variance"))
        );
        assert_eq!(v, [t(0.5)]);
        assert!(matches!(
            err(ideal_weight(x, t(0.0), t(0.0), t(0.01))),
            Error::NonFinite { .. }
        ));
        assert!(matches!(
            err(ideal_weight(t(0.0), t(0.0), x, t(0.01))),
            Error::NonFinite { .. }
        ));
        assert!(matches!(
            err(ideal_weight(t(0.0), t(0.0), t(0.0), x)),
            Error::NonFinite { .. }
        ));
    }
    assert_eq!(
        err(StdTransform::new(
            NoiseSubtraction::Reference,
            t::<T>(-0.1),
            t(0.1)
        )),
        inv("noise_variance")
    );
    for v in [0.0, -0.01] {
        assert_eq!(
            err(ideal_weight(t::<T>(0.0), t(0.0), t(0.0), t(v))),
            inv("variance")
        );
    }

    let mut summary = WeightSummary::<T>::new();
    summary.add(&[t(1.0), t(0.5)]).unwrap();
    let (count, mean, ess) = (
        summary.count(),
        summary.mean(),
        summary.effective_sample_size(),
    );
    for x in non_finite::<T>() {
        assert!(matches!(
            summary.add(&[t(1.0), x]),
            Err(Error::NonFinite {
                parameter: "weights"
            })
        ));
        assert!(matches!(
            err(effective_sample_size(&[t(1.0), x])),
            Error::NonFinite {
                parameter: "weights"
            }
        ));
    }
    assert_eq!(summary.add(&[t(1.0), t(-1.0)]), Err(inv("weights")));
    assert_eq!(
        (
            summary.count(),
            summary.mean(),
            summary.effective_sample_size()
        ),
        (count, mean, ess)
    );
    assert_eq!(err(effective_sample_size::<T>(&[])), Error::EmptyData);
    assert_eq!(
        err(effective_sample_size(&[t::<T>(1.0), t(-0.5)])),
        inv("weights")
    );
}

#[test]
fn weights_reject_bad_observations_posteriors_and_parameters() {
    weight_calls::<f32>();
    weight_calls::<f64>();
}

// ----------------------------------------------------------------------------- dataset ---

fn record<T: Real>(i: usize) -> Transition<[T; 2], T> {
    let x = T::from_usize(i % 10);
    Transition {
        state: [x, t(5.0)],
        action: i % 4,
        reward: -x,
        next_state: [x, t(6.0)],
        absorbing: false,
    }
}

fn dataset_calls<T: Real>() {
    let mut gp3 = Gp::<T, 8, 3>::empty();
    let training = GpTraining::<T, 3>::published();
    let mut r = rng();
    assert_eq!(
        err(fit_gp(
            &mut gp3,
            &[] as &[Transition<[T; 2], T>],
            Output::Reward,
            SubsetRule::Last,
            &training,
            &mut r
        )),
        Error::EmptyData
    );
    untouched(&mut r);
    let mut records: Vec<_> = (0..5).map(record::<T>).collect();
    records[2].reward = T::from_f64(f64::NAN);
    assert_eq!(
        err(fit_gp(
            &mut gp3,
            &records,
            Output::Reward,
            SubsetRule::Spread,
            &training,
            &mut r
        )),
        nf("y")
    );
    let mut bad_training = training;
    bad_training.search.max_evaluations = 0;
    assert!(
        fit_gp(
            &mut gp3,
            &records[..2],
            Output::NextState(0),
            SubsetRule::Last,
            &bad_training,
            &mut r
        )
        .is_err()
    );

    let records: Vec<_> = (0..5).map(record::<T>).collect();
    let sentinel = Posterior::new(t::<T>(9.0), t(9.0));
    let mut out = vec![sentinel; 4];
    assert_eq!(
        predict_posteriors(&gp3, &records, NoiseSubtraction::Reference, &mut out),
        Err(inv("out"))
    );
    assert!(out.iter().all(|p| *p == sentinel));
    assert_eq!(
        predict_posteriors::<T, 8, 2, 3>(&gp3, &[], NoiseSubtraction::Reference, &mut []),
        Err(Error::EmptyData)
    );
    assert_eq!(
        err(batch_transform::<T, 8, 2, 3>(
            &gp3,
            &[],
            NoiseSubtraction::Off
        )),
        Error::EmptyData
    );
    let mut nan_state = records.clone();
    nan_state[0].state[1] = T::INFINITY;
    let mut out = vec![sentinel; 5];
    assert_eq!(
        predict_posteriors(&gp3, &nan_state, NoiseSubtraction::Principled, &mut out),
        Err(nf("x"))
    );
}

#[test]
fn dataset_helpers_reject_empty_and_non_finite_records() {
    dataset_calls::<f32>();
    dataset_calls::<f64>();
}

// --------------------------------------------------------------------------------- fqi ---

fn fqi_calls<T: Real>() {
    for x in non_finite::<T>() {
        let e = err(CellGrid::new([x, t(0.0)], [t(10.0), t(10.0)], [2, 2]));
        assert!(
            matches!(e, Error::NonFinite { parameter: "lower" }),
            "{e:?}"
        );
        let e = err(CellGrid::new([t(0.0), t(0.0)], [t(10.0), x], [2, 2]));
        assert_eq!(e, nf("upper"));
        assert_eq!(
            err(FqiConfig::new(x, 10, EmptyCells::Nearest)),
            nf("discount")
        );
        assert_eq!(
            err(FqiConfig::new(t(0.9), 10, EmptyCells::Value(x))),
            nf("empty_cells")
        );
        assert_eq!(
            err(FqiConfig::<T>::published().with_min_weight(x)),
            nf("min_weight")
        );
    }
    assert_eq!(
        err(CellGrid::new(
            [t::<T>(1.0), t(0.0)],
            [t(1.0), t(10.0)],
            [2, 2]
        )),
        inv("upper")
    );
    assert_eq!(
        err(CellGrid::new(
            [t::<T>(0.0), t(0.0)],
            [t(1.0), t(1.0)],
            [0, 2]
        )),
        inv("cells")
    );
    assert!(matches!(
        err(CellGrid::<T, 2>::cube(t::<T>(0.0), t(1.0), usize::MAX)),
        Error::CapacityExceeded { .. }
    ));
    for d in [-0.01, 1.01] {
        assert_eq!(
            err(FqiConfig::new(t::<T>(d), 10, EmptyCells::Nearest)),
            inv("discount")
        );
    }
    assert_eq!(
        err(FqiConfig::new(t::<T>(0.9), 0, EmptyCells::Nearest)),
        inv("iterations")
    );
    assert_eq!(
        err(FqiConfig::<T>::published().with_min_weight(t(-1.0))),
        inv("min_weight")
    );

    let grid = CellGrid::cube(t::<T>(0.0), t(10.0), 3).unwrap();
    let mut storage = vec![FqiEntry::<T>::EMPTY; 36];
    assert_eq!(err(TabularFqi::new(grid, 0, &mut storage)), inv("actions"));
    assert_eq!(
        err(TabularFqi::new(grid, 4, &mut storage[..35])),
        Error::CapacityExceeded { capacity: 35 }
    );
    let mut fqi = TabularFqi::new(grid, 4, &mut storage).unwrap();
    let config = FqiConfig::new(t::<T>(0.9), 5, EmptyCells::Nearest).unwrap();
    let good: Vec<_> = (0..8).map(record::<T>).collect();
    fqi.fit(&[SampleSet::unweighted(&good)], &config).unwrap();
    let before: Vec<FqiEntry<T>> = fqi.entries().to_vec();

    assert_eq!(fqi.fit(&[], &config), Err(Error::EmptyData));
    assert_eq!(
        fqi.fit(&[SampleSet::unweighted(&good[..0])], &config),
        Err(Error::EmptyData)
    );
    let mut bad = good.clone();
    bad[3].action = 4;
    assert_eq!(
        fqi.fit(&[SampleSet::unweighted(&bad)], &config),
        Err(oor("action"))
    );
    for x in non_finite::<T>() {
        for field in 0..4 {
            let mut bad = good.clone();
            match field {
                0 => bad[1].state[0] = x,
                1 => bad[1].next_state[1] = x,
                2 => bad[1].reward = x,
                _ => {}
            }
            let w = [t(1.0), x, t(1.0), t(1.0), t(1.0), t(1.0), t(1.0), t(1.0)];
            let set = if field == 3 {
                SampleSet::weighted(&good, Some(&w), None)
            } else {
                SampleSet::unweighted(&bad)
            };
            assert!(
                matches!(fqi.fit(&[set], &config), Err(Error::NonFinite { .. })),
                "field {field}"
            );
            let set = SampleSet::weighted(&good, None, Some(&w));
            assert!(matches!(
                fqi.fit(&[set], &config),
                Err(Error::NonFinite { .. })
            ));
        }
    }
    let negative = [
        t::<T>(1.0),
        t(-0.5),
        t(1.0),
        t(1.0),
        t(1.0),
        t(1.0),
        t(1.0),
        t(1.0),
    ];
    assert!(matches!(
        fqi.fit(
            &[SampleSet::weighted(&good, Some(&negative), None)],
            &config
        ),
        Err(Error::InvalidParameter { .. })
    ));
    let short = [t::<T>(1.0); 7];
    assert!(matches!(
        fqi.fit(&[SampleSet::weighted(&good, None, Some(&short))], &config),
        Err(Error::InvalidParameter { .. })
    ));
    assert!(
        fqi.entries() == &before[..],
        "a rejected fit changed the table"
    );

    for x in non_finite::<T>() {
        assert_eq!(err(fqi.value([x, t(1.0)], 0)), nf("state"));
        assert_eq!(err(fqi.max_value([t(1.0), x])), nf("state"));
        assert_eq!(err(fqi.greedy_action([x, x])), nf("state"));
        assert_eq!(err(grid.cell_of([x, t(1.0)])), nf("state"));
    }
    assert_eq!(err(fqi.value([t(1.0), t(1.0)], 4)), oor("action"));
    assert_eq!(grid.coordinates(9), None);
    assert_eq!(grid.center(usize::MAX), None);
}

fn tile_calls<T: Real>() {
    for x in non_finite::<T>() {
        assert_eq!(err(Tilings::<T, 2>::cube(x, t(1.0), 3, 2)), nf("lower"));
        assert_eq!(err(Tilings::<T, 2>::cube(t(0.0), x, 3, 2)), nf("upper"));
    }
    assert_eq!(
        err(Tilings::<T, 2>::cube(t(1.0), t(0.0), 3, 2)),
        inv("upper")
    );
    assert_eq!(
        err(Tilings::<T, 2>::cube(t(0.0), t(1.0), 0, 2)),
        inv("tiles")
    );
    assert_eq!(
        err(Tilings::<T, 2>::cube(t(0.0), t(1.0), 3, 0)),
        inv("count")
    );
    assert!(matches!(
        err(Tilings::<T, 3>::cube(t(0.0), t(1.0), 1 << 12, 2)),
        Error::CapacityExceeded { .. }
    ));
    // (3 + 1)² tiles × 4 actions × 2 tilings = 128 entries.
    let tilings = Tilings::cube(t::<T>(0.0), t(10.0), 3, 2).unwrap();
    let mut storage = vec![FqiEntry::<T>::EMPTY; 128];
    assert_eq!(err(TileFqi::new(tilings, 0, &mut storage)), inv("actions"));
    assert_eq!(
        err(TileFqi::new(tilings, 4, &mut storage[..127])),
        Error::CapacityExceeded { capacity: 127 }
    );
    let approximator: Approximator<T, 2> = tilings.into();
    assert_eq!(approximator.required_entries(4), Some(128));
    assert_eq!(
        err(approximator.build(4, &mut storage[..100])),
        Error::CapacityExceeded { capacity: 100 }
    );
    let mut fqi = TileFqi::new(tilings, 4, &mut storage).unwrap();
    let config = FqiConfig::new(t::<T>(0.9), 5, EmptyCells::CappedNearest).unwrap();
    let good: Vec<_> = (0..8).map(record::<T>).collect();
    fqi.fit(&[SampleSet::unweighted(&good)], &config).unwrap();
    let before: Vec<FqiEntry<T>> = fqi.entries().to_vec();
    assert_eq!(fqi.fit(&[], &config), Err(Error::EmptyData));
    let mut bad = good.clone();
    bad[3].action = 4;
    assert_eq!(
        fqi.fit(&[SampleSet::unweighted(&bad)], &config),
        Err(oor("action"))
    );
    for x in non_finite::<T>() {
        let mut bad = good.clone();
        bad[2].next_state[0] = x;
        assert_eq!(
            fqi.fit(&[SampleSet::unweighted(&bad)], &config),
            Err(nf("next_state"))
        );
        let w = [t(1.0), t(1.0), x, t(1.0), t(1.0), t(1.0), t(1.0), t(1.0)];
        assert_eq!(
            fqi.fit(&[SampleSet::weighted(&good, None, Some(&w))], &config),
            Err(nf("transition_weights"))
        );
        assert_eq!(err(fqi.value([x, t(1.0)], 0)), nf("state"));
        assert_eq!(err(fqi.max_value([t(1.0), x])), nf("state"));
        assert_eq!(err(fqi.greedy_action([x, x])), nf("state"));
    }
    let negative = [t::<T>(-1.0); 8];
    assert_eq!(
        fqi.fit(
            &[SampleSet::weighted(&good, Some(&negative), None)],
            &config
        ),
        Err(inv("reward_weights"))
    );
    assert!(
        fqi.entries() == &before[..],
        "a rejected fit changed the tiles"
    );
    assert_eq!(err(fqi.value([t(1.0), t(1.0)], 4)), oor("action"));
}

#[test]
fn tile_coding_rejects_bad_tilings_and_samples_and_keeps_its_values() {
    tile_calls::<f32>();
    tile_calls::<f64>();
}

#[test]
fn fqi_rejects_bad_grids_settings_and_samples_and_keeps_its_table() {
    fqi_calls::<f32>();
    fqi_calls::<f64>();
}

// ------------------------------------------------------------------------------- score ---

/// A source model whose value is `value` right of x = 5 (a non-finite one makes the table fail).
struct Faulty<T> {
    value: T,
}

impl<T: Real> SourceModel<T, 2> for Faulty<T> {
    fn predict(&self, state: [T; 2], _action: usize) -> Result<SourceMeans<T, 2>> {
        let reward = if state[0] > t(5.0) {
            self.value
        } else {
            t(1.0)
        };
        Ok(SourceMeans {
            reward,
            next_state: [t(0.0); 2],
        })
    }
}

fn score_calls<T: Real>() {
    for x in non_finite::<T>() {
        assert_eq!(
            err(PointGrid::new([x, t(0.0)], [t(1.0), t(1.0)], [2, 2])),
            nf("lower")
        );
        assert_eq!(
            err(PointGrid::new([t(0.0), t(0.0)], [t(1.0), x], [2, 2])),
            nf("spacing")
        );
        assert!(matches!(
            err(PuddleWorld::score_grid(x)),
            Error::NonFinite { .. }
                | Error::InvalidParameter {
                    parameter: "spacing"
                }
        ));
    }
    for d in [0.0, -1.0] {
        assert_eq!(
            err(PointGrid::new(
                [t::<T>(0.0), t(0.0)],
                [t(d), t(1.0)],
                [2, 2]
            )),
            inv("spacing")
        );
        assert_eq!(err(PuddleWorld::score_grid(t::<T>(d))), inv("spacing"));
    }
    assert_eq!(err(PuddleWorld::score_grid(t::<T>(0.3))), inv("spacing"));
    assert_eq!(
        err(PointGrid::new(
            [t::<T>(0.0), t(0.0)],
            [t(1.0), t(1.0)],
            [0, 2]
        )),
        inv("points")
    );
    let grid = PuddleWorld::score_grid(t::<T>(5.0)).unwrap();
    assert_eq!(err(RowSet::grid(grid, 0)), inv("actions"));
    assert_eq!(err(RowSet::both(grid, 0, &[])), inv("actions"));
    let empty: [&[Transition<[T; 2], T>]; 2] = [&[], &[]];
    assert_eq!(err(RowSet::source_data(&empty)), Error::EmptyData);
    assert_eq!(err(RowSet::<T, 2>::source_data(&[])), Error::EmptyData);

    let rows = RowSet::grid(grid, 4).unwrap();
    let worlds = PuddleWorld::<T>::sources(Dynamics::Shared);
    let mut storage = vec![Scores::<T, 2>::ZERO; 36];
    assert_eq!(
        err(ScoreTable::compute(rows, &worlds[..0], &mut storage)),
        Error::EmptyData
    );
    assert_eq!(
        err(ScoreTable::compute(rows, &worlds, &mut storage[..35])),
        Error::CapacityExceeded { capacity: 35 }
    );
    for x in non_finite::<T>() {
        let models = [Faulty { value: t(2.0) }, Faulty { value: x }];
        assert_eq!(
            err(ScoreTable::compute(rows, &models, &mut storage)),
            nf("source value")
        );
        let mut values = vec![Scores::<T, 2>::ZERO; 36];
        values[7].reward = x;
        assert_eq!(err(ScoreTable::from_parts(rows, &values)), nf("scores"));
    }
    // A model that rejects a state passes its error on.
    let outside = RowSet::grid(
        PointGrid::new([t(-5.0), t(0.0)], [t(5.0), t(5.0)], [2, 1]).unwrap(),
        4,
    )
    .unwrap();
    assert_eq!(
        err(ScoreTable::compute(outside, &worlds, &mut storage)),
        oor("state")
    );
    let mut values = vec![Scores::<T, 2>::ZERO; 36];
    values[3].next_state[0] = t(-1e-30);
    assert_eq!(err(ScoreTable::from_parts(rows, &values)), inv("scores"));
    assert_eq!(
        err(ScoreTable::from_parts(rows, &values[..35])),
        Error::CapacityExceeded { capacity: 35 }
    );
    let table = ScoreTable::compute(rows, &worlds, &mut storage).unwrap();
    let mut alias = [AliasEntry::<T>::EMPTY; 35];
    assert!(matches!(
        err(table.sampler(ScoreColumn::Reward, &mut alias)),
        Error::CapacityExceeded { .. }
    ));
}

#[test]
fn score_tables_reject_bad_grids_models_and_storage() {
    score_calls::<f32>();
    score_calls::<f64>();
}

// ------------------------------------------------------------------------------- awfqi ---

#[test]
fn awfqi_rejects_bad_configuration_sources_and_storage_and_keeps_its_state() {
    type T = f32;
    let mut config = AwfqiConfig::<T, 3>::thesis(4);
    config.gp_training.search.max_evaluations = 10;
    config.gp_training.search.restarts = 1;
    let mut zero = config;
    zero.budget = 0;
    assert_eq!(zero.validate().err(), Some(inv("budget")));
    let mut bad_bounds = config;
    bad_bounds.gp_training.bounds.noise_variance = (0.0, 1.0);
    assert_eq!(bad_bounds.validate().err(), Some(inv("noise_variance")));
    let config = config.validate().unwrap();

    let records: Vec<_> = (0..6).map(record::<T>).collect();
    let sources: [&[Transition<[T; 2], T>]; 1] = [&records];
    let posteriors = vec![Posterior::new(-1.0, 0.1); 6];
    assert_eq!(
        err(SourceData::new(&sources, &posteriors[..5])),
        inv("reward_posteriors")
    );
    for x in non_finite::<T>() {
        let mut p = posteriors.clone();
        p[4].std = x;
        assert_eq!(err(SourceData::new(&sources, &p)), nf("reward_posteriors"));
    }
    let mut p = posteriors.clone();
    p[1].std = -0.1;
    assert_eq!(err(SourceData::new(&sources, &p)), inv("reward_posteriors"));

    let rows = RowSet::grid(PuddleWorld::score_grid(5.0).unwrap(), 4).unwrap();
    let mut scores = vec![Scores::<T, 2>::ZERO; rows.len()];
    ScoreTable::compute(
        rows,
        &PuddleWorld::<T>::sources(Dynamics::Shared),
        &mut scores,
    )
    .unwrap();
    let grid = CellGrid::cube(0.0, 10.0, 3).unwrap();
    let target = PuddleWorld::<T>::target(Dynamics::Shared);
    let mut gp = Gp::<T, 8, 3>::empty();
    let mut alias = vec![AliasEntry::<T>::EMPTY; rows.len()];
    let mut entries = vec![FqiEntry::<T>::EMPTY; 36];
    let (mut samples, mut weights) = (vec![Transition::EMPTY; 8], vec![0.0; 6]);
    let builder = || {
        Awfqi::builder(config, grid, &sources, rows)
            .stored_posteriors(&posteriors)
            .stored_scores(&scores)
    };
    // Every size is checked before the set-up starts; the caller's buffers are lent back.
    let mut r = rng();
    let mut build = |samples: &mut [Transition<[T; 2], T>],
                     weights: &mut [T],
                     alias: &mut [AliasEntry<T>],
                     fqi: &mut [FqiEntry<T>]| {
        let buffers = AwfqiBuffers {
            gp: &mut gp,
            samples,
            weights,
            alias,
            fqi,
        };
        builder().build(target, buffers, &mut r).map(|_| ())
    };
    // Each error names the buffer and the named capacity (of `awfqi_storage!`) that sizes it.
    let named = |e: Option<Error>| match e {
        Some(Error::BufferTooSmall {
            buffer,
            capacity,
            needed,
        }) => (buffer.split(' ').next().unwrap_or(""), capacity, needed),
        other => panic!("not a named buffer error: {other:?}"),
    };
    let param = |e: Option<Error>| match e {
        Some(Error::BufferTooSmall { buffer, .. }) => buffer.split('`').nth(1).unwrap_or(""),
        _ => "",
    };
    let e = build(&mut samples, &mut weights[..5], &mut alias, &mut entries).err();
    assert_eq!((named(e), param(e)), (("weights", 5, 6), "source_records"));
    let e = build(&mut samples[..3], &mut weights, &mut alias, &mut entries).err();
    assert_eq!((named(e), param(e)), (("samples", 3, 4), "steps"));
    let e = build(&mut samples, &mut weights, &mut alias[..2], &mut entries).err();
    assert_eq!(
        (named(e), param(e)),
        (("alias", 2, rows.len()), "candidate_rows")
    );
    let e = build(&mut samples, &mut weights, &mut alias, &mut entries[..35]).err();
    assert_eq!((named(e), param(e)), (("fqi", 35, 36), "table_entries"));
    untouched(&mut r);

    // Two steps of 4 fill the 8-sample buffer; a third is refused before anything is drawn
    // or changed.
    let buffers = AwfqiBuffers {
        gp: &mut gp,
        samples: &mut samples,
        weights: &mut weights,
        alias: &mut alias,
        fqi: &mut entries,
    };
    let mut kernel = builder().build(target, buffers, &mut r).unwrap();
    kernel.step(&mut r).unwrap();
    kernel.step(&mut r).unwrap();
    let (d0, q, w) = (
        kernel.target_samples().to_vec(),
        kernel.q().entries().to_vec(),
        kernel.reward_weights().to_vec(),
    );
    let mut copy = r.clone();
    assert!(matches!(
        err(kernel.step(&mut r)),
        Error::BufferTooSmall {
            capacity: 8,
            needed: 12,
            ..
        }
    ));
    assert_eq!(
        r.next_u64(),
        copy.next_u64(),
        "a refused step drew from the generator"
    );
    assert_eq!(kernel.steps(), 2);
    assert_eq!(kernel.target_samples(), &d0[..]);
    assert!(kernel.q().entries() == &q[..]);
    assert_eq!(kernel.reward_weights(), &w[..]);
}

// ----------------------------------------------------------- identification, planning ---

fn identify_calls<T: Real>() {
    use awfqi::identify::{
        Belief, Criterion, MiConfig, Scoring, StateAction, belief_weighted_policy,
        belief_weighted_q, compute_score, draw_pair, draw_pairs, log_likelihood, run_queries,
    };
    let candidates = GridWorld::<T>::thesis_candidates(false);
    assert_eq!(err(Belief::<T, 4>::uniform(0)), Error::EmptyData);
    assert_eq!(
        err(Belief::<T, 4>::uniform(5)),
        Error::CapacityExceeded { capacity: 4 }
    );
    assert_eq!(err(Belief::<T, 4>::from_weights(&[])), Error::EmptyData);
    assert!(matches!(
        err(Belief::<T, 4>::from_weights(&[t(1.0); 5])),
        Error::CapacityExceeded { .. }
    ));
    for x in non_finite::<T>() {
        assert!(matches!(
            err(Belief::<T, 4>::from_weights(&[t(1.0), x])),
            Error::NonFinite { .. }
        ));
        assert_eq!(
            err(log_likelihood(&candidates[0], 0, 0, 1, x)),
            nf("reward")
        );
    }
    assert!(matches!(
        err(Belief::<T, 4>::from_weights(&[t(1.0), t(-1.0)])),
        Error::InvalidParameter { .. }
    ));
    assert!(matches!(
        err(Belief::<T, 4>::from_weights(&[t(0.0), t(0.0)])),
        Error::InvalidParameter { .. }
    ));
    assert_eq!(
        err(log_likelihood(&candidates[0], 100, 0, 1, t(0.0))),
        oor("state")
    );

    let mut belief = Belief::<T, 4>::uniform(4).unwrap();
    belief.update(&candidates, 99, 1, 98, t(1.0)).unwrap();
    let before = belief;
    assert_eq!(
        belief.update(&candidates[..3], 0, 0, 1, t(0.0)),
        Err(inv("candidates"))
    );
    assert_eq!(
        belief.update(&candidates, 100, 0, 0, t(0.0)),
        Err(oor("state"))
    );
    assert_eq!(
        belief.update(&candidates, 0, 4, 0, t(0.0)),
        Err(oor("action"))
    );
    assert_eq!(
        belief.update(&candidates, 0, 0, 100, t(0.0)),
        Err(oor("next_state"))
    );
    for x in non_finite::<T>() {
        assert_eq!(belief.update(&candidates, 0, 0, 1, x), Err(nf("reward")));
    }
    assert_eq!(belief, before, "a rejected update changed the belief");
    let mut short = [T::ZERO; 3];
    assert!(belief.probabilities(&mut short).is_err());

    // Scores: bad beliefs, storage, configurations; `out` untouched for those.
    let mut rng = rng();
    let sentinel = t::<T>(-3.0);
    let mut out = vec![sentinel; 400];
    let p = belief.probability_array();
    let mi = |samples, bins| {
        Criterion::MutualInformation(MiConfig {
            samples,
            bins,
            ..MiConfig::default()
        })
    };
    for criterion in [Criterion::Uniform, Criterion::Variance, mi(10, 8)] {
        assert_eq!(
            err(compute_score::<T, GridWorld<T>, _>(
                &criterion,
                &[],
                &p,
                &mut rng,
                &mut out
            )),
            Error::EmptyData
        );
        assert!(matches!(
            err(compute_score(
                &criterion,
                &candidates,
                &p[..3],
                &mut rng,
                &mut out
            )),
            Error::InvalidParameter { .. }
        ));
        let mut bad = p;
        bad[1] = T::from_f64(f64::NAN);
        assert_eq!(
            err(compute_score(
                &criterion,
                &candidates,
                &bad,
                &mut rng,
                &mut out
            )),
            nf("belief")
        );
        bad[1] = t(-0.5);
        assert_eq!(
            err(compute_score(
                &criterion,
                &candidates,
                &bad,
                &mut rng,
                &mut out
            )),
            inv("belief")
        );
        assert_eq!(
            err(compute_score(
                &criterion,
                &candidates,
                &[T::ZERO; 4],
                &mut rng,
                &mut out
            )),
            inv("belief")
        );
        assert!(matches!(
            err(compute_score(
                &criterion,
                &candidates,
                &p,
                &mut rng,
                &mut out[..399]
            )),
            Error::CapacityExceeded { .. }
        ));
        let mut long = vec![sentinel; 401];
        assert_eq!(
            err(compute_score(
                &criterion,
                &candidates,
                &p,
                &mut rng,
                &mut long
            )),
            inv("scores")
        );
        assert!(long.iter().all(|&v| v == sentinel));
    }
    for (samples, bins, e) in [
        (0, 8, inv("samples")),
        (10, 0, inv("bins")),
        (10, 129, Error::CapacityExceeded { capacity: 128 }),
    ] {
        assert_eq!(
            err(compute_score(
                &mi(samples, bins),
                &candidates,
                &p,
                &mut rng,
                &mut out
            )),
            e
        );
    }
    assert!(
        out.iter().all(|&v| v == sentinel),
        "a rejected score wrote its output"
    );

    // Draws from a score.
    let score = [t::<T>(1.0), t(0.0), t(2.0), t(1.0)];
    assert_eq!(err(draw_pair(&score, 0, &mut rng)), inv("num_actions"));
    assert_eq!(err(draw_pair::<T, _>(&[], 2, &mut rng)), Error::EmptyData);
    assert_eq!(err(draw_pair(&score, 3, &mut rng)), inv("scores"));
    assert_eq!(
        err(draw_pair(&[t::<T>(1.0), t(-1.0)], 2, &mut rng)),
        inv("scores")
    );
    for x in non_finite::<T>() {
        assert_eq!(err(draw_pair(&[t::<T>(1.0), x], 2, &mut rng)), nf("scores"));
    }
    let marker = StateAction {
        state: 7,
        action: 7,
    };
    let mut pairs = [marker; 3];
    assert!(draw_pairs(&[t::<T>(1.0), t(-1.0)], 2, &mut rng, &mut pairs).is_err());
    assert!(pairs.iter().all(|p| *p == marker));

    // The query loop: wrong score storage, a belief over other candidates, a bad fixed score.
    let model = candidates[2];
    let mut score = vec![T::ZERO; 399];
    let mut b = Belief::<T, 4>::uniform(4).unwrap();
    let fresh = b;
    assert!(
        run_queries(
            &candidates,
            &model,
            &Scoring::Adaptive(Criterion::Variance),
            5,
            &mut b,
            &mut score,
            &mut rng,
            |_, _| {}
        )
        .is_err()
    );
    let mut score = vec![T::ZERO; 400];
    let mut b3 = Belief::<T, 4>::uniform(3).unwrap();
    assert!(
        run_queries(
            &candidates,
            &model,
            &Scoring::Fixed,
            5,
            &mut b3,
            &mut score,
            &mut rng,
            |_, _| {}
        )
        .is_err()
    );
    score[5] = t(-1.0);
    assert!(
        run_queries(
            &candidates,
            &model,
            &Scoring::Fixed,
            5,
            &mut b,
            &mut score,
            &mut rng,
            |_, _| {}
        )
        .is_err()
    );
    assert_eq!(b, fresh);

    // Belief-weighted Q and policy.
    let q = vec![t::<T>(0.5); 4 * 8];
    let mut q_out = [sentinel; 8];
    assert_eq!(
        belief_weighted_q(&q[..31], &p, &mut q_out),
        Err(inv("q_tables"))
    );
    assert_eq!(belief_weighted_q(&q, &p, &mut []), Err(Error::EmptyData));
    let mut bad_q = q.clone();
    bad_q[3] = T::INFINITY;
    assert!(matches!(
        belief_weighted_q(&bad_q, &p, &mut q_out),
        Err(Error::NonFinite { .. })
    ));
    let mut policy = [9usize; 2];
    assert!(belief_weighted_policy(&q, &p, 0, &mut q_out, &mut policy).is_err());
    assert!(belief_weighted_policy(&q, &p, 4, &mut q_out, &mut policy[..1]).is_err());
    assert!(q_out.iter().all(|&v| v == sentinel) && policy == [9, 9]);
}

fn planning_calls<T: Real>() {
    use awfqi::planning::{
        StoppingRule, backup, evaluate_policy, greedy_action, greedy_policy, q_from_values,
        value_iteration,
    };
    let grid = GridWorld::<T>::thesis(1, false).unwrap();
    let rule = StoppingRule {
        tolerance: t::<T>(1e-6),
        max_sweeps: 100,
    };
    let (mut values, mut q) = (vec![T::ZERO; 100], vec![T::ZERO; 400]);
    for g in non_finite::<T>() {
        assert!(matches!(
            err(value_iteration(&grid, g, rule, &mut values, &mut q)),
            Error::NonFinite { .. }
        ));
        let bad = StoppingRule {
            tolerance: g,
            max_sweeps: 10,
        };
        assert_eq!(
            err(value_iteration(&grid, t(0.9), bad, &mut values, &mut q)),
            nf("tolerance")
        );
    }
    for g in [-0.1, 1.5] {
        assert!(value_iteration(&grid, t::<T>(g), rule, &mut values, &mut q).is_err());
    }
    let bad = StoppingRule {
        tolerance: t::<T>(-1.0),
        max_sweeps: 10,
    };
    assert_eq!(
        err(value_iteration(&grid, t(0.9), bad, &mut values, &mut q)),
        inv("tolerance")
    );
    let bad = StoppingRule {
        tolerance: t::<T>(1e-6),
        max_sweeps: 0,
    };
    assert_eq!(
        err(value_iteration(&grid, t(0.9), bad, &mut values, &mut q)),
        inv("max_sweeps")
    );
    assert!(matches!(
        err(value_iteration(
            &grid,
            t(0.9),
            rule,
            &mut values[..99],
            &mut q
        )),
        Error::CapacityExceeded { .. }
    ));
    assert!(matches!(
        err(q_from_values(&grid, t(0.9), &values, &mut q[..399])),
        Error::CapacityExceeded { .. }
    ));
    let mut long = vec![T::ZERO; 401];
    assert!(matches!(
        err(q_from_values(&grid, t(0.9), &values, &mut long)),
        Error::InvalidParameter { .. }
    ));
    assert!(
        values.iter().chain(&q).all(|&v| v == T::ZERO),
        "a rejected solve wrote"
    );
    assert!(matches!(
        err(backup(&grid, t(0.9), &values, 100, 0)),
        Error::OutOfRange { .. }
    ));
    assert!(backup(&grid, t(0.9), &values[..10], 95, 0).is_err());

    assert_eq!(err(greedy_action::<T>(&[])), Error::EmptyData);
    assert_eq!(
        err(greedy_action(&[t::<T>(1.0), T::from_f64(f64::NAN)])),
        nf("q")
    );
    let mut policy = [7usize; 100];
    assert_eq!(greedy_policy(&q, 0, &mut policy), Err(inv("num_actions")));
    assert_eq!(greedy_policy(&q[..399], 4, &mut policy), Err(inv("q")));
    assert!(greedy_policy(&q, 4, &mut policy[..99]).is_err());
    let mut nan_q = q.clone();
    nan_q[17] = T::from_f64(f64::NAN);
    assert_eq!(greedy_policy(&nan_q, 4, &mut policy), Err(nf("q")));
    assert!(
        policy.iter().all(|&a| a == 7),
        "a rejected greedy_policy wrote"
    );
    let mut bad_policy = [0usize; 100];
    bad_policy[3] = 4;
    assert!(matches!(
        err(evaluate_policy(
            &grid,
            &bad_policy,
            t(0.9),
            rule,
            &mut values
        )),
        Error::OutOfRange { .. }
    ));
    assert!(evaluate_policy(&grid, &bad_policy[..99], t(0.9), rule, &mut values).is_err());
}

#[test]
fn identification_and_planning_reject_bad_input_and_keep_their_state() {
    identify_calls::<f32>();
    identify_calls::<f64>();
    planning_calls::<f32>();
    planning_calls::<f64>();
}
