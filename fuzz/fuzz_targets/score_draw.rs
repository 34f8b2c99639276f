//! Score tables and drawing at state dimension 2, 1 or 3 (bits 2–3 of the first byte; 0 is
//! 2-D, so the seeds written for 2-D stay 2-D): `PointGrid::new`/`spanning` (and Puddle
//! World's `score_grid`), `RowSet::grid`/`source_data`/`both`/`pairs`,
//! `ScoreTable::compute` with arbitrary source models (means straight from the fuzzer, NaN
//! and overflow included) and with the Puddle World oracle, `ScoreTable::from_parts`,
//! `sampler` on every column (one beyond the state dimension too) and draws;
//! `AliasTable::build` on arbitrary weights.
//!
//! Invariants: no panic; computed scores are finite and ≥ 0; a drawn row is in range and its
//! `(s, a)` is the row's; an alias table's probabilities are finite, sum to 1 and are 0 for
//! weight-0 rows; errors are only the documented kinds.
#![no_main]

use awfqi::alias::{AliasEntry, AliasTable};
use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::model::Transition;
use awfqi::model::{SourceMeans, SourceModel};
use awfqi::score::{PointGrid, RowSet, ScoreColumn, ScoreTable, Scores};
use awfqi::{Result, prelude::Real};
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, kind, trace};
use libfuzzer_sys::fuzz_target;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// A source whose means come from the fuzzer (reward, then the next state), cycling through
/// a small table.
#[derive(Debug)]
struct Fuzzed<T> {
    values: Vec<Vec<T>>,
    fail_at: Option<usize>,
    calls: core::cell::Cell<usize>,
}

impl<T: Real, const D: usize> SourceModel<T, D> for Fuzzed<T> {
    fn predict(&self, _state: [T; D], _action: usize) -> Result<SourceMeans<T, D>> {
        let k = self.calls.get();
        self.calls.set(k + 1);
        if self.fail_at == Some(k) {
            return Err(awfqi::Error::OutOfRange { parameter: "state" });
        }
        let v = self.values.get(k % self.values.len().max(1));
        let at = |i: usize| v.and_then(|v| v.get(i)).copied().unwrap_or(T::ZERO);
        Ok(SourceMeans {
            reward: at(0),
            next_state: core::array::from_fn(|i| at(i + 1)),
        })
    }
}

fn real<T: Real>(b: &mut Bytes) -> T {
    T::from_f64(b.num())
}

fn alias<T: Real>(b: &mut Bytes) {
    let n = b.index(40);
    let weights: Vec<T> = (0..n).map(|_| real(b)).collect();
    let mut storage = vec![AliasEntry::<T>::EMPTY; b.index(41)];
    trace!("AliasTable::build({weights:?}, storage {})", storage.len());
    match AliasTable::build(weights.iter().copied(), &mut storage) {
        Ok(table) => {
            assert_eq!(table.len(), n);
            let mut total = 0.0;
            for (i, w) in weights.iter().enumerate() {
                let p = table.probability(i).expect("row in range").to_f64();
                assert!(p.is_finite() && p >= 0.0, "probability {p}");
                if *w == T::ZERO {
                    assert!(p < 1e-6, "weight-0 row {i} has probability {p}");
                }
                total += p;
            }
            assert!((total - 1.0).abs() < 1e-4, "probabilities sum to {total}");
            let mut rng = ChaCha8Rng::seed_from_u64(3);
            let mut out = [0usize; 16];
            table.sample_into(&mut rng, &mut out);
            assert!(out.iter().all(|&r| r < n));
        }
        Err(e) => expect_kind(
            "AliasTable::build",
            &e,
            &[Kind::Capacity, Kind::Empty, Kind::NonFinite, Kind::Invalid],
        ),
    }
}

fn scores<T: Real, const D: usize>(b: &mut Bytes) {
    let grid = if b.bool() {
        let lower: [T; D] = core::array::from_fn(|_| real(b));
        let spacing: [T; D] = core::array::from_fn(|_| real(b));
        let points: [usize; D] = core::array::from_fn(|_| b.index(8));
        trace!("PointGrid::new({lower:?}, {spacing:?}, {points:?})");
        PointGrid::new(lower, spacing, points)
    } else {
        let d = real::<T>(b);
        // In 2-D this is Puddle World's `score_grid(d)`.
        trace!("PointGrid::spanning(0, 10, {d:?})");
        PointGrid::spanning([T::ZERO; D], [T::from_f64(10.0); D], d)
    };
    let grid = match grid {
        Ok(g) if g.len() <= 400 => Some(g),
        Ok(_) => None,
        Err(e) => {
            expect_kind(
                "PointGrid",
                &e,
                &[Kind::NonFinite, Kind::Invalid, Kind::Capacity],
            );
            None
        }
    };
    let records: Vec<Vec<Transition<[T; D], T>>> = (0..b.index(3))
        .map(|_| {
            (0..b.index(6))
                .map(|_| Transition {
                    state: core::array::from_fn(|_| real(b)),
                    action: b.index(5),
                    reward: T::ZERO,
                    next_state: [T::ZERO; D],
                    absorbing: false,
                })
                .collect()
        })
        .collect();
    let slices: Vec<&[Transition<[T; D], T>]> = records.iter().map(|r| &r[..]).collect();
    let pairs: Vec<([T; D], usize)> = slices
        .iter()
        .flat_map(|s| s.iter().map(|t| (t.state, t.action)))
        .collect();
    let actions = b.index(6);
    let mode = b.u8() % 4;
    let (rows, documented): (_, &[Kind]) = match (mode, grid) {
        (0, Some(g)) => (RowSet::grid(g, actions), &[Kind::Invalid, Kind::Capacity]),
        (1, Some(g)) => (
            RowSet::both(g, actions, &slices),
            &[Kind::Invalid, Kind::Capacity, Kind::NonFinite],
        ),
        (3, _) => (RowSet::pairs(&pairs), &[Kind::Empty, Kind::NonFinite]),
        _ => (
            RowSet::source_data(&slices),
            &[Kind::Empty, Kind::NonFinite],
        ),
    };
    if let (Ok(r), 3) = (&rows, mode) {
        // The records' pairs give the same rows as the records themselves.
        if let Ok(s) = RowSet::source_data(&slices) {
            assert!(r.iter().eq(s.iter()), "pairs and source rows differ");
        }
    }
    let rows = match rows {
        Ok(r) => r,
        Err(e) => {
            expect_kind("RowSet", &e, documented);
            return;
        }
    };
    for r in 0..rows.len() {
        assert!(rows.row(r).is_some());
    }
    assert!(rows.row(rows.len()).is_none());
    let mut storage = vec![Scores::<T, D>::ZERO; rows.len() + b.index(3)];
    if b.u8() == 0xff {
        storage.truncate(rows.len().saturating_sub(1));
    }
    let oracle = b.bool();
    let result = if oracle && D == 2 {
        oracle_table::<T, D>(rows, b.index(4), &mut storage)
    } else {
        let sources: Vec<Fuzzed<T>> = (0..b.index(4))
            .map(|_| Fuzzed {
                values: (0..1 + b.index(4))
                    .map(|_| (0..=D).map(|_| real(b)).collect())
                    .collect(),
                fail_at: if b.u8() == 0xff {
                    Some(b.index(8))
                } else {
                    None
                },
                calls: core::cell::Cell::new(0),
            })
            .collect();
        trace!("ScoreTable::compute({} rows, {sources:?})", rows.len());
        ScoreTable::compute(rows, &sources, &mut storage)
    };
    let table = match result {
        Ok(t) => t,
        Err(e) => {
            expect_kind(
                "ScoreTable::compute",
                &e,
                &[
                    Kind::Empty,
                    Kind::Capacity,
                    Kind::NonFinite,
                    Kind::OutOfRange,
                    Kind::Invalid,
                ],
            );
            return;
        }
    };
    for s in table.values() {
        let columns = (0..D).map(ScoreColumn::NextState);
        for column in [ScoreColumn::Reward, ScoreColumn::Total]
            .into_iter()
            .chain(columns)
        {
            let v = s.get(column).expect("a column of the state dimension");
            finite("ScoreTable::compute", "score", v.to_f64());
            assert!(v >= T::ZERO, "negative variance");
        }
        assert_eq!(s.get(ScoreColumn::NextState(D)), None);
    }
    let column = match b.index(4) {
        0 => ScoreColumn::Reward,
        1 => ScoreColumn::Total,
        _ => ScoreColumn::NextState(b.index(D + 2)),
    };
    let mut alias_storage = vec![AliasEntry::<T>::EMPTY; table.len()];
    let sampler = match table.sampler(column, &mut alias_storage) {
        Ok(s) => s,
        Err(e) => {
            expect_kind(
                "sampler",
                &e,
                &[Kind::Capacity, Kind::NonFinite, Kind::OutOfRange],
            );
            if matches!(column, ScoreColumn::NextState(k) if k < D) {
                assert_ne!(kind(&e), Kind::OutOfRange, "a valid column was refused");
            }
            return;
        }
    };
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(b.u8()));
    for _ in 0..16 {
        let (r, state, action) = sampler.draw(&mut rng);
        assert_eq!(table.rows().row(r), Some((state, action)), "drawn row {r}");
    }
    let copy: Vec<Scores<T, D>> = table.values().to_vec();
    match ScoreTable::from_parts(rows, &copy) {
        Ok(t) => assert_eq!(t.len(), rows.len()),
        Err(e) => expect_kind(
            "from_parts",
            &e,
            &[Kind::Capacity, Kind::NonFinite, Kind::Invalid],
        ),
    }
}

/// The Puddle World oracle table (2-D only; `D` is checked by the caller).
fn oracle_table<'a, T: Real, const D: usize>(
    rows: RowSet<'a, T, D>,
    sources: usize,
    storage: &'a mut [Scores<T, D>],
) -> Result<ScoreTable<'a, T, D>> {
    struct Oracle<T>(PuddleWorld<T>);
    impl<T: Real, const D: usize> SourceModel<T, D> for Oracle<T> {
        fn predict(&self, state: [T; D], action: usize) -> Result<SourceMeans<T, D>> {
            let [x, y] = [0, 1].map(|k| state.get(k).copied().unwrap_or(T::ZERO));
            let m = SourceModel::<T, 2>::predict(&self.0, [x, y], action)?;
            Ok(SourceMeans {
                reward: m.reward,
                next_state: core::array::from_fn(|k| {
                    m.next_state.get(k).copied().unwrap_or(T::ZERO)
                }),
            })
        }
    }
    let worlds = PuddleWorld::<T>::sources(Dynamics::Shared).map(Oracle);
    ScoreTable::compute(rows, &worlds[..sources.min(3)], storage)
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    let first = b.u8();
    match (first % 4, (first >> 2) % 3) {
        (0, _) => alias::<f32>(&mut b),
        (1, _) => alias::<f64>(&mut b),
        (2, 0) => scores::<f32, 2>(&mut b),
        (2, 1) => scores::<f32, 1>(&mut b),
        (2, _) => scores::<f32, 3>(&mut b),
        (_, 0) => scores::<f64, 2>(&mut b),
        (_, 1) => scores::<f64, 1>(&mut b),
        (_, _) => scores::<f64, 3>(&mut b),
    }
});
