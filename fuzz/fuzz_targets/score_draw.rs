//! Score tables and drawing: `PointGrid::new`/`puddle`, `RowSet::grid`/`source_data`/`both`,
//! `ScoreTable::compute` with arbitrary source models (value triples straight from the
//! fuzzer, NaN and overflow included) and with the Puddle World oracle,
//! `ScoreTable::from_parts`, `sampler` on every column and draws; `AliasTable::build` on
//! arbitrary weights.
//!
//! Invariants: no panic; computed scores are finite and ≥ 0; a drawn row is in range and its
//! `(s, a)` is the row's; an alias table's probabilities are finite, sum to 1 and are 0 for
//! weight-0 rows; errors are only the documented kinds.
#![no_main]

use awfqi::alias::{AliasEntry, AliasTable};
use awfqi::env::{Dynamics, PuddleWorld, Transition};
use awfqi::score::{PointGrid, RowSet, ScoreColumn, ScoreTable, Scores, SourceModel};
use awfqi::{Real, Result};
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, trace};
use libfuzzer_sys::fuzz_target;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// A source whose value triples come from the fuzzer, cycling through a small table.
#[derive(Debug)]
struct Fuzzed<T> {
    values: Vec<[T; 3]>,
    fail_at: Option<usize>,
    calls: core::cell::Cell<usize>,
}

impl<T: Real> SourceModel<T> for Fuzzed<T> {
    fn predict(&self, _state: [T; 2], _action: usize) -> Result<[T; 3]> {
        let k = self.calls.get();
        self.calls.set(k + 1);
        if self.fail_at == Some(k) {
            return Err(awfqi::Error::OutOfRange { parameter: "state" });
        }
        Ok(self
            .values
            .get(k % self.values.len().max(1))
            .copied()
            .unwrap_or([T::ZERO; 3]))
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

fn scores<T: Real>(b: &mut Bytes) {
    let grid = if b.bool() {
        let lower = [real::<T>(b), real(b)];
        let spacing = [real::<T>(b), real(b)];
        let points = [b.index(8), b.index(8)];
        trace!("PointGrid::new({lower:?}, {spacing:?}, {points:?})");
        PointGrid::new(lower, spacing, points)
    } else {
        let d = real::<T>(b);
        trace!("PointGrid::puddle({d:?})");
        PointGrid::puddle(d)
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
    let records: Vec<Vec<Transition<[T; 2], T>>> = (0..b.index(3))
        .map(|_| {
            (0..b.index(6))
                .map(|_| Transition {
                    state: [real(b), real(b)],
                    action: b.index(5),
                    reward: T::ZERO,
                    next_state: [T::ZERO; 2],
                    absorbing: false,
                })
                .collect()
        })
        .collect();
    let slices: Vec<&[Transition<[T; 2], T>]> = records.iter().map(|r| &r[..]).collect();
    let actions = b.index(6);
    let (rows, documented): (_, &[Kind]) = match (b.u8() % 3, grid) {
        (0, Some(g)) => (RowSet::grid(g, actions), &[Kind::Invalid, Kind::Capacity]),
        (1, Some(g)) => (
            RowSet::both(g, actions, &slices),
            &[Kind::Invalid, Kind::Capacity, Kind::NonFinite],
        ),
        _ => (
            RowSet::source_data(&slices),
            &[Kind::Empty, Kind::NonFinite],
        ),
    };
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
    let mut storage = vec![Scores::<T>::ZERO; rows.len() + b.index(3)];
    if b.u8() == 0xff {
        storage.truncate(rows.len().saturating_sub(1));
    }
    let oracle = b.bool();
    let result = if oracle {
        let worlds = PuddleWorld::<T>::sources(Dynamics::Shared);
        ScoreTable::compute(rows, &worlds[..b.index(4)], &mut storage)
    } else {
        let sources: Vec<Fuzzed<T>> = (0..b.index(4))
            .map(|_| Fuzzed {
                values: (0..1 + b.index(4))
                    .map(|_| [real(b), real(b), real(b)])
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
        for v in [
            s.get(ScoreColumn::Reward),
            s.get(ScoreColumn::NextX),
            s.get(ScoreColumn::NextY),
            s.total(),
        ] {
            finite("ScoreTable::compute", "score", v.to_f64());
            assert!(v >= T::ZERO, "negative variance");
        }
    }
    let column = [
        ScoreColumn::Reward,
        ScoreColumn::NextX,
        ScoreColumn::NextY,
        ScoreColumn::Total,
    ][b.index(4)];
    let mut alias_storage = vec![AliasEntry::<T>::EMPTY; table.len()];
    let sampler = match table.sampler(column, &mut alias_storage) {
        Ok(s) => s,
        Err(e) => {
            expect_kind("sampler", &e, &[Kind::Capacity, Kind::NonFinite]);
            return;
        }
    };
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(b.u8()));
    for _ in 0..16 {
        let (r, state, action) = sampler.draw(&mut rng);
        assert_eq!(table.rows().row(r), Some((state, action)), "drawn row {r}");
    }
    let copy: Vec<Scores<T>> = table.values().to_vec();
    match ScoreTable::from_parts(rows, &copy) {
        Ok(t) => assert_eq!(t.len(), rows.len()),
        Err(e) => expect_kind(
            "from_parts",
            &e,
            &[Kind::Capacity, Kind::NonFinite, Kind::Invalid],
        ),
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    match b.u8() % 4 {
        0 => alias::<f32>(&mut b),
        1 => alias::<f64>(&mut b),
        2 => scores::<f32>(&mut b),
        _ => scores::<f64>(&mut b),
    }
});
