//! FQI by a model sweep on anchors (representative states placed from the records) on
//! arbitrary boxes, budgets, samples, weights and settings (f32 and f64; state dimension 2,
//! 1 or 4 from bits 1–2 of the first byte): `AnchorSweep::new`/`with_neighbours`/
//! `with_rewards`/`with_min_mass`/`with_lookahead`, `AnchorFqi::new`/`fit`/`value`/
//! `max_value`/`greedy_action`/`next_state`/`anchor`, storage one short of what is needed
//! too, and the same sweep through `Approximator::build` and `QFunction`.
//!
//! Invariants: no panic; a successful fit places between 1 and the budget's nodes, inside
//! the box, and leaves every reward, value, absorption and query finite; a failed fit
//! leaves the model, the nodes and the values exactly as they were; queries return finite
//! values or typed errors.
#![no_main]

use awfqi::float::Real;
use awfqi::fqi::{
    AnchorEntry, AnchorFqi, AnchorParts, AnchorSweep, Approximator, EmptyCells, FqiConfig,
    QStorage, RewardModel, SampleSet, SweepNode,
};
use awfqi::model::Transition;
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, trace};
use libfuzzer_sys::fuzz_target;

fn real<T: Real>(b: &mut Bytes) -> T {
    T::from_f64(b.num())
}

fn run<T: Real, const D: usize>(b: &mut Bytes) {
    let (lower, upper): ([T; D], [T; D]) = if b.bool() {
        (
            core::array::from_fn(|_| real(b)),
            core::array::from_fn(|_| real(b)),
        )
    } else {
        ([T::ZERO; D], [T::from_f64(10.0); D])
    };
    let budget = b.index(40);
    trace!("AnchorSweep::new({lower:?}, {upper:?}, {budget})");
    let anchors = match AnchorSweep::new(lower, upper, budget) {
        Ok(a) => a,
        Err(e) => {
            let allowed = [Kind::Invalid, Kind::NonFinite, Kind::Capacity];
            expect_kind("AnchorSweep::new", &e, &allowed);
            return;
        }
    };
    let anchors = match anchors.with_neighbours(b.index(6)) {
        Ok(a) => a,
        Err(e) => {
            expect_kind("with_neighbours", &e, &[Kind::Invalid]);
            return;
        }
    };
    let rewards = [
        RewardModel::PerAction,
        RewardModel::Pooled,
        RewardModel::Backfilled,
    ][usize::from(b.u8() % 3)];
    let min_mass = if b.bool() { real(b) } else { T::ZERO };
    let anchors = match anchors.with_min_mass(min_mass) {
        Ok(a) => a.with_rewards(rewards).with_lookahead(b.bool()),
        Err(e) => {
            expect_kind("with_min_mass", &e, &[Kind::Invalid]);
            return;
        }
    };
    let actions = b.index(5);
    let short = |b: &mut Bytes, n: usize| {
        if b.u8() == 0xff {
            n.saturating_sub(1)
        } else {
            n
        }
    };
    let needed = anchors.required_entries(actions.max(1)).unwrap_or(0);
    let mut entries = vec![AnchorEntry::<T>::EMPTY; short(b, needed)];
    let mut nodes = vec![SweepNode::<T>::EMPTY; short(b, budget)];
    let mut positions = vec![[T::ZERO; D]; short(b, budget)];
    let mut landings = vec![[T::ZERO; D]; short(b, budget)];
    let via_q = b.bool();
    let discount = if b.bool() { real(b) } else { T::from_f64(0.9) };
    let config = match FqiConfig::new(discount, b.index(12), EmptyCells::Nearest) {
        Ok(c) => c,
        Err(e) => {
            let allowed = [Kind::NonFinite, Kind::OutOfRange, Kind::Invalid];
            expect_kind("FqiConfig::new", &e, &allowed);
            return;
        }
    };

    let n_sets = 1 + b.index(3);
    let mut samples: Vec<Vec<Transition<[T; D], T>>> = Vec::new();
    let mut weights: Vec<(Option<Vec<T>>, Option<Vec<T>>, Option<Vec<T>>)> = Vec::new();
    for _ in 0..n_sets {
        let n = b.index(30);
        let set: Vec<_> = (0..n)
            .map(|_| Transition {
                state: core::array::from_fn(|_| real(b)),
                action: b.index(6),
                reward: real(b),
                next_state: core::array::from_fn(|_| real(b)),
                absorbing: b.bool(),
            })
            .collect();
        let values = |b: &mut Bytes| {
            if b.bool() {
                let m = if b.u8() == 0xff { n + 1 } else { n };
                Some((0..m).map(|_| real::<T>(b)).collect::<Vec<T>>())
            } else {
                None
            }
        };
        weights.push((values(b), values(b), values(b)));
        samples.push(set);
    }
    let sets: Vec<SampleSet<'_, T, D>> = samples
        .iter()
        .zip(&weights)
        .map(|(s, (r, t, y))| {
            SampleSet::weighted(s, r.as_deref(), t.as_deref()).with_rewards(y.as_deref())
        })
        .collect();
    let probes: Vec<([T; D], usize)> = (0..4)
        .map(|_| (core::array::from_fn(|_| real(b)), b.index(6)))
        .collect();
    trace!("{anchors:?} {actions} actions, {config:?}, {samples:?}, {weights:?}");
    let allowed_fit = [
        Kind::Empty,
        Kind::OutOfRange,
        Kind::NonFinite,
        Kind::Invalid,
    ];

    if via_q {
        let approximator: Approximator<T, D> = anchors.into();
        let storage = QStorage {
            sweep_nodes: &mut nodes,
            anchor_entries: &mut entries,
            anchor_positions: &mut positions,
            anchor_landings: &mut landings,
            ..QStorage::default()
        };
        let mut q = match approximator.build(actions, storage) {
            Ok(q) => q,
            Err(e) => {
                expect_kind("Approximator::build", &e, &[Kind::Invalid, Kind::Capacity]);
                return;
            }
        };
        let mut rng = <rand_chacha::ChaCha8Rng as rand_core::SeedableRng>::seed_from_u64(0);
        let before: Vec<_> = probes.iter().map(|&(s, a)| q.value(s, a)).collect();
        if let Err(e) = q.fit(&sets, &config, &mut rng) {
            expect_kind("QFunction::fit", &e, &allowed_fit);
            let after: Vec<_> = probes.iter().map(|&(s, a)| q.value(s, a)).collect();
            assert!(before == after, "a failed fit changed the Q-function");
        }
        for &(s, a) in &probes {
            match q.value(s, a) {
                Ok(v) => finite("value", "q", v.to_f64()),
                Err(e) => expect_kind("value", &e, &[Kind::NonFinite, Kind::OutOfRange]),
            }
            match q.greedy_action(s) {
                Ok(g) => assert!(g < actions),
                Err(e) => expect_kind("greedy_action", &e, &[Kind::NonFinite]),
            }
        }
        return;
    }

    let parts = AnchorParts {
        entries: &mut entries,
        nodes: &mut nodes,
        positions: &mut positions,
        landings: &mut landings,
    };
    let mut fqi = match AnchorFqi::new(anchors, actions, parts) {
        Ok(f) => f,
        Err(e) => {
            expect_kind("AnchorFqi::new", &e, &[Kind::Invalid, Kind::Capacity]);
            return;
        }
    };
    let model = |f: &AnchorFqi<'_, T, D>| {
        let placed: Vec<_> = (0..f.placed()).map(|i| f.anchor(i)).collect();
        (f.entries().to_vec(), f.nodes().to_vec(), placed)
    };
    let before = model(&fqi);
    match fqi.fit(&sets, &config) {
        Ok(()) => {
            assert!(fqi.placed() >= 1 && fqi.placed() <= budget);
            for e in fqi.entries() {
                finite("fit", "reward", e.reward().to_f64());
            }
            for n in fqi.nodes() {
                finite("fit", "value", n.value().to_f64());
                finite("fit", "absorbing", n.absorbing().to_f64());
            }
            for i in 0..fqi.placed() {
                let p = fqi.anchor(i).expect("a placed node");
                for ((&v, &lo), &hi) in p.iter().zip(&lower).zip(&upper) {
                    finite("anchor", "position", v.to_f64());
                    let slack = (hi - lo).to_f64().abs() * 1e-5;
                    let (v, lo, hi) = (v.to_f64(), lo.to_f64(), hi.to_f64());
                    assert!(
                        v >= lo - slack && v <= hi + slack,
                        "node {v} outside [{lo}, {hi}]"
                    );
                }
            }
        }
        Err(e) => {
            expect_kind("fit", &e, &allowed_fit);
            assert!(model(&fqi) == before, "a failed fit changed the model");
        }
    }
    for &(s, a) in &probes {
        match fqi.value(s, a) {
            Ok(v) => finite("value", "q", v.to_f64()),
            Err(e) => expect_kind("value", &e, &[Kind::NonFinite, Kind::OutOfRange]),
        }
        match fqi.max_value(s) {
            Ok(v) => finite("max_value", "v", v.to_f64()),
            Err(e) => expect_kind("max_value", &e, &[Kind::NonFinite]),
        }
        match fqi.greedy_action(s) {
            Ok(g) => assert!(g < actions),
            Err(e) => expect_kind("greedy_action", &e, &[Kind::NonFinite]),
        }
    }
    let _ = fqi.next_state(0, 0);
    assert!(fqi.next_state(budget, 0).is_none());
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let first = b.u8();
    match (first & 1 == 1, ((first >> 1) & 3) % 3) {
        (true, 0) => run::<f32, 2>(&mut b),
        (false, 0) => run::<f64, 2>(&mut b),
        (true, 1) => run::<f32, 1>(&mut b),
        (false, 1) => run::<f64, 1>(&mut b),
        (true, _) => run::<f32, 4>(&mut b),
        (false, _) => run::<f64, 4>(&mut b),
    }
});
