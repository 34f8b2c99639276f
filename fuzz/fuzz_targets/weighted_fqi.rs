//! Weighted tabular FQI on arbitrary grids, samples, weights and settings (f32 and f64; state
//! dimension 2, 1 or 3 from bits 1–2 of the first byte, so the seeds written for 2-D stay
//! 2-D): `CellGrid::new`/`cube`, `FqiConfig::new`/`with_min_weight`,
//! `TabularFqi::new`/`fit`/`value`/`max_value`/`greedy_action`; with bit 3 of the first
//! byte, tile coding over the grid's box instead (`Tilings::new`, `TileFqi` through
//! `Approximator::build` and `QFunction`).
//!
//! Invariants: no panic; a successful fit leaves every Q-value, reward model and weight
//! finite; a failed fit leaves the table exactly as it was (documented: everything is
//! checked before the table changes); queries return finite values or typed errors.
#![no_main]

use awfqi::float::Real;
use awfqi::fqi::{Approximator, CellGrid, EmptyCells, FqiConfig, FqiEntry, SampleSet, Tilings};
use awfqi::model::Transition;
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, trace};
use libfuzzer_sys::fuzz_target;

/// Cells per dimension at most. The FQI is one implementation over the grid's slice of
/// cells: 4 per dimension already has interior cells, both edges, empty cells whose nearest
/// visited cell lies at radius 1 to 3 (shells clipped on one side and on both) and ties;
/// 5 and 6 (the former limit) repeat those paths on a larger slice, and the nearest-cell
/// search grows with the square of the cell count (4³ = 64 cells instead of 216 in 3-D,
/// a measured ~10x of the target's time).
const MAX_CELLS: usize = 4;

fn real<T: Real>(b: &mut Bytes) -> T {
    T::from_f64(b.num())
}

fn run<T: Real, const D: usize>(b: &mut Bytes, tiles: bool) {
    let grid = if b.bool() {
        let lower: [T; D] = core::array::from_fn(|_| real(b));
        let upper: [T; D] = core::array::from_fn(|_| real(b));
        let cells: [usize; D] = core::array::from_fn(|_| b.index(7).min(MAX_CELLS));
        trace!("CellGrid::new({lower:?}, {upper:?}, {cells:?})");
        match CellGrid::new(lower, upper, cells) {
            Ok(g) => g,
            Err(e) => {
                expect_kind(
                    "CellGrid::new",
                    &e,
                    &[Kind::Invalid, Kind::NonFinite, Kind::Capacity],
                );
                return;
            }
        }
    } else {
        CellGrid::cube(T::ZERO, T::from_f64(10.0), (1 + b.index(6)).min(MAX_CELLS))
            .expect("a valid grid")
    };
    let actions = b.index(5);
    let (approximator, entries): (Approximator<T, D>, usize) = if tiles {
        let count = 1 + b.index(4);
        match Tilings::new(grid.lower(), grid.upper(), grid.cells()[0], count) {
            Ok(t) => (t.into(), (MAX_CELLS + 1).pow(D as u32) * 4 * count),
            Err(e) => {
                expect_kind("Tilings::new", &e, &[Kind::Invalid, Kind::NonFinite]);
                return;
            }
        }
    } else {
        (grid.into(), MAX_CELLS.pow(D as u32) * 4)
    };
    let mut storage = vec![FqiEntry::<T>::EMPTY; entries];
    let mut fqi = match approximator.build(actions, &mut storage[..]) {
        Ok(f) => f,
        Err(e) => {
            expect_kind("Approximator::build", &e, &[Kind::Invalid, Kind::Capacity]);
            return;
        }
    };
    let discount = if b.bool() { real(b) } else { T::from_f64(0.9) };
    let iterations = b.index(12);
    let empty = match b.u8() % 3 {
        0 => EmptyCells::Nearest,
        1 => EmptyCells::CappedNearest,
        _ => EmptyCells::Value(real(b)),
    };
    let config = match FqiConfig::new(discount, iterations, empty) {
        Ok(c) => c,
        Err(e) => {
            expect_kind(
                "FqiConfig::new",
                &e,
                &[Kind::NonFinite, Kind::OutOfRange, Kind::Invalid],
            );
            return;
        }
    };
    let config = if b.bool() {
        match config.with_min_weight(real(b)) {
            Ok(c) => c,
            Err(e) => {
                expect_kind("with_min_weight", &e, &[Kind::NonFinite, Kind::Invalid]);
                return;
            }
        }
    } else {
        config
    };

    let n_sets = 1 + b.index(3);
    let mut samples: Vec<Vec<Transition<[T; D], T>>> = Vec::new();
    let mut rewards: Vec<Option<Vec<T>>> = Vec::new();
    let mut transitions: Vec<Option<Vec<T>>> = Vec::new();
    for _ in 0..n_sets {
        let n = b.index(20);
        let set: Vec<_> = (0..n)
            .map(|_| Transition {
                state: core::array::from_fn(|_| real(b)),
                action: b.index(6),
                reward: real(b),
                next_state: core::array::from_fn(|_| real(b)),
                absorbing: b.bool(),
            })
            .collect();
        let weights = |b: &mut Bytes| {
            if b.bool() {
                let m = if b.u8() == 0xff { n + 1 } else { n };
                Some((0..m).map(|_| real::<T>(b)).collect::<Vec<T>>())
            } else {
                None
            }
        };
        rewards.push(weights(b));
        transitions.push(weights(b));
        samples.push(set);
    }
    let sets: Vec<SampleSet<'_, T, D>> = samples
        .iter()
        .zip(&rewards)
        .zip(&transitions)
        .map(|((s, r), t)| SampleSet::weighted(s, r.as_deref(), t.as_deref()))
        .collect();
    trace!("fit({samples:?}, rewards {rewards:?}, transitions {transitions:?}, {config:?})");
    let before: Vec<FqiEntry<T>> = fqi.entries().to_vec();
    // Only trees draw random numbers; the table and tiles take the generator and ignore it.
    let mut rng = <rand_chacha::ChaCha8Rng as rand_core::SeedableRng>::seed_from_u64(0);
    match fqi.fit(&sets, &config, &mut rng) {
        Ok(()) => {
            for e in fqi.entries() {
                finite("fit", "q", e.q().to_f64());
                finite("fit", "reward_model", e.reward_model().to_f64());
                finite("fit", "transition_weight", e.transition_weight().to_f64());
            }
        }
        Err(e) => {
            expect_kind(
                "fit",
                &e,
                &[
                    Kind::Empty,
                    Kind::OutOfRange,
                    Kind::NonFinite,
                    Kind::Invalid,
                ],
            );
            assert!(
                fqi.entries() == &before[..],
                "a failed fit changed the table"
            );
        }
    }
    for _ in 0..4 {
        let s: [T; D] = core::array::from_fn(|_| real(b));
        let a = b.index(6);
        match fqi.value(s, a) {
            Ok(v) => finite("value", "q", v.to_f64()),
            Err(e) => expect_kind("value", &e, &[Kind::NonFinite, Kind::OutOfRange]),
        }
        match fqi.max_value(s) {
            Ok(v) => finite("max_value", "v", v.to_f64()),
            Err(e) => expect_kind("max_value", &e, &[Kind::NonFinite]),
        }
        match fqi.greedy_action(s) {
            Ok(a) => assert!(a < actions),
            Err(e) => expect_kind("greedy_action", &e, &[Kind::NonFinite]),
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let first = b.u8();
    let tiles = first & 8 != 0;
    match (first & 1 == 1, ((first >> 1) & 3) % 3) {
        (true, 0) => run::<f32, 2>(&mut b, tiles),
        (false, 0) => run::<f64, 2>(&mut b, tiles),
        (true, 1) => run::<f32, 1>(&mut b, tiles),
        (false, 1) => run::<f64, 1>(&mut b, tiles),
        (true, _) => run::<f32, 3>(&mut b, tiles),
        (false, _) => run::<f64, 3>(&mut b, tiles),
    }
});
