extern crate std;
use super::*;
use crate::alias::AliasEntry;
use crate::env::{Dynamics, PuddleWorld};
use crate::error::Error;
use crate::gp::Gp;
use crate::model::Transition;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::vec;
use std::vec::Vec;

fn population_variance(values: &[f64]) -> f64 {
    let m = values.len() as f64;
    let mean = values.iter().sum::<f64>() / m;
    values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m
}

#[test]
fn puddle_grid_has_the_thesis_row_count_and_exact_coordinates() {
    let grid = PuddleWorld::<f64>::score_grid(0.1).unwrap();
    assert_eq!(grid.points(), [101, 101]);
    let rows = RowSet::grid(grid, 4).unwrap();
    assert_eq!(rows.len(), 40_804);
    // Row r = 4·(i + 101·j) + a is (0.1·i, 0.1·j, a).
    let (s, a) = rows.row(4 * (37 + 101 * 100) + 3).unwrap();
    assert_eq!(s, [0.1 * 37.0, 0.1 * 100.0]);
    assert_eq!(s[1], 10.0);
    assert_eq!(a, 3);
    assert!(rows.row(40_804).is_none());
    assert_eq!(rows.iter().count(), 40_804);
    assert_eq!(rows.iter().nth(4 * 5 + 2), rows.row(4 * 5 + 2));
    assert!(PuddleWorld::<f64>::score_grid(0.3).is_err());
    assert_eq!(
        PuddleWorld::<f32>::score_grid(0.5).unwrap().points(),
        [21, 21]
    );
    assert!(RowSet::grid(grid, 0).is_err());
}

fn record(x: f64, y: f64, a: usize) -> Transition<[f64; 2], f64> {
    Transition {
        state: [x, y],
        action: a,
        reward: -1.0,
        next_state: [x, y],
        absorbing: false,
    }
}

#[test]
fn source_rows_follow_the_grid_rows_source_by_source() {
    let s1 = [record(1.0, 2.0, 0), record(3.0, 4.0, 1)];
    let s2 = [record(5.0, 6.0, 2)];
    let sources: [&[_]; 2] = [&s1, &s2];
    let rows = RowSet::source_data(&sources).unwrap();
    assert_eq!(rows.len(), 3);
    assert_eq!(rows.row(2), Some(([5.0, 6.0], 2)));
    let grid = PointGrid::new([0.0, 0.0], [1.0, 1.0], [2, 1]).unwrap();
    let both = RowSet::both(grid, 2, &sources).unwrap();
    assert_eq!(both.len(), 4 + 3);
    let all: Vec<_> = both.iter().collect();
    assert_eq!(
        all,
        vec![
            ([0.0, 0.0], 0),
            ([0.0, 0.0], 1),
            ([1.0, 0.0], 0),
            ([1.0, 0.0], 1),
            ([1.0, 2.0], 0),
            ([3.0, 4.0], 1),
            ([5.0, 6.0], 2),
        ]
    );
    for (r, row) in all.iter().enumerate() {
        assert_eq!(both.row(r).as_ref(), Some(row));
    }
    let empty: [&[Transition<[f64; 2], f64>]; 1] = [&[]];
    assert_eq!(RowSet::source_data(&empty), Err(Error::EmptyData));
}

#[test]
fn oracle_table_is_exactly_zero_where_sources_agree() {
    let grid = PuddleWorld::<f64>::score_grid(0.5).unwrap();
    let rows = RowSet::grid(grid, 4).unwrap();
    let mut storage = vec![Scores::default(); rows.len()];
    // Shared dynamics: every source moves by exactly 1, so the next-state columns vanish
    // everywhere, not just approximately.
    let sources = PuddleWorld::sources(Dynamics::Shared);
    let table = ScoreTable::compute(rows, &sources, &mut storage).unwrap();
    assert_eq!(table.len(), 21 * 21 * 4);
    assert!(table.values().iter().all(|v| v.next_state == [0.0; 2]));
    assert!(table.values().iter().any(|v| v.reward > 1.0));
    // Three copies of one source agree everywhere: every score is exactly 0.
    let same = [PuddleWorld::<f64>::source_1(Dynamics::PuddleBased); 3];
    let mut storage = vec![Scores::default(); rows.len()];
    let table = ScoreTable::compute(rows, &same, &mut storage).unwrap();
    assert!(table.values().iter().all(|v| v.total() == 0.0));
    // Puddle-based dynamics: the step lengths differ, so V_x, V_y do not vanish.
    let sources = PuddleWorld::sources(Dynamics::PuddleBased);
    let mut storage = vec![Scores::default(); rows.len()];
    let table = ScoreTable::compute(rows, &sources, &mut storage).unwrap();
    assert!(table.values().iter().any(|v| v.next_state[0] > 0.0));
}

#[test]
fn oracle_reward_scores_match_the_spec_golden_rewards() {
    // Spec §2.7: r̄ of sources 1, 2, 3 at a few points; V_r is their population variance.
    let golden: [([f64; 2], [f64; 3]); 4] = [
        ([1.0, 4.0], [-1.000907, -12.529551, -1.000907]),
        ([2.0, 2.0], [-1.000074, -22.527471, -1.000074]),
        ([5.0, 9.0], [-0.039372, -0.039663, -1.039372]),
        ([8.0, 2.0], [-1.134113, -1.061376, -23.870533]),
    ];
    let grid = PuddleWorld::<f64>::score_grid(1.0).unwrap();
    let rows = RowSet::grid(grid, 4).unwrap();
    let mut storage = vec![Scores::default(); rows.len()];
    let sources = PuddleWorld::sources(Dynamics::Shared);
    let table = ScoreTable::compute(rows, &sources, &mut storage).unwrap();
    for (point, rewards) in golden {
        let p = point[0] as usize + 11 * point[1] as usize;
        let want = population_variance(&rewards);
        for a in 0..4 {
            let row = table.row(4 * p + a).unwrap();
            assert_eq!(row.state, point);
            // The golden rewards have 6 decimals: allow for that rounding.
            assert!(
                (row.scores.reward - want).abs() < 1e-5 * (1.0 + want),
                "{point:?}: {} vs {want}",
                row.scores.reward
            );
            assert_eq!(row.scores.total(), row.scores.reward);
        }
    }
}

#[test]
fn sampler_follows_the_column_or_is_uniform_when_it_is_zero() {
    let grid = PuddleWorld::<f64>::score_grid(2.0).unwrap();
    let rows = RowSet::grid(grid, 4).unwrap();
    let mut storage = vec![Scores::default(); rows.len()];
    let sources = PuddleWorld::sources(Dynamics::Shared);
    let table = ScoreTable::compute(rows, &sources, &mut storage).unwrap();
    let mut alias = vec![AliasEntry::default(); table.len()];
    let sampler = table.sampler(ScoreColumn::Reward, &mut alias).unwrap();
    let total: f64 = table.values().iter().map(|v| v.reward).sum();
    for r in 0..table.len() {
        let p = sampler.alias().probability(r).unwrap();
        assert!((p - table.values()[r].reward / total).abs() < 1e-12);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (r, s, a) = sampler.draw(&mut rng);
    assert_eq!(table.rows().row(r), Some((s, a)));
    // V_x is identically 0 under shared dynamics: uniform.
    let sampler = table
        .sampler(ScoreColumn::NextState(0), &mut alias)
        .unwrap();
    let uniform = 1.0 / table.len() as f64;
    for r in 0..table.len() {
        assert!((sampler.alias().probability(r).unwrap() - uniform).abs() < 1e-15);
    }
    let mut short = vec![AliasEntry::default(); 3];
    assert!(table.sampler(ScoreColumn::Reward, &mut short).is_err());
}

#[test]
fn compute_reports_bad_storage_sources_and_states() {
    let grid = PuddleWorld::<f64>::score_grid(5.0).unwrap();
    let rows = RowSet::grid(grid, 4).unwrap();
    let sources = PuddleWorld::sources(Dynamics::Shared);
    let mut short = vec![Scores::default(); 5];
    assert_eq!(
        ScoreTable::compute(rows, &sources, &mut short).err(),
        Some(Error::CapacityExceeded { capacity: 5 })
    );
    let mut storage = vec![Scores::default(); rows.len()];
    let none: [PuddleWorld<f64>; 0] = [];
    assert_eq!(
        ScoreTable::compute(rows, &none, &mut storage).err(),
        Some(Error::EmptyData)
    );
    // A grid reaching outside [0, 10]²: the oracle refuses the state.
    let outside = PointGrid::new([0.0, 0.0], [6.0, 6.0], [3, 3]).unwrap();
    let rows = RowSet::grid(outside, 4).unwrap();
    assert_eq!(
        ScoreTable::compute(rows, &sources, &mut storage).err(),
        Some(Error::OutOfRange { parameter: "state" })
    );
}

#[test]
fn realistic_table_uses_the_gp_posterior_means() {
    use crate::gp::Hyperparameters;
    use crate::record_gp::input;
    let hyper = Hyperparameters::isotropic(4.0, 2.0, 0.01);
    let mut gp_a = Gp::<f64, 8, 3>::new(hyper).unwrap();
    let mut gp_b = Gp::<f64, 8, 3>::new(hyper).unwrap();
    let xs = [[1.0, 1.0, 0.0], [5.0, 5.0, 1.0], [9.0, 2.0, 2.0]];
    gp_a.fit(&xs, &[-1.0, -20.0, -1.0]).unwrap();
    gp_b.fit(&xs, &[-1.0, -2.0, -6.0]).unwrap();
    let grid = PuddleWorld::<f64>::score_grid(2.5).unwrap();
    let rows = RowSet::grid(grid, 4).unwrap();
    let models = [
        GpSourceModel::new(&gp_a, None),
        GpSourceModel::new(&gp_b, None),
    ];
    let mut storage = vec![Scores::default(); rows.len()];
    let table = ScoreTable::compute(rows, &models, &mut storage).unwrap();
    for r in 0..table.len() {
        let row = table.row(r).unwrap();
        let z = input(row.state, row.action);
        let (a, b) = (
            gp_a.predict(&z).unwrap().mean,
            gp_b.predict(&z).unwrap().mean,
        );
        // Population variance of two values: ((a − b)/2)².
        let want = ((a - b) / 2.0).powi(2);
        assert!((row.scores.reward - want).abs() < 1e-9 * (1.0 + want));
        assert_eq!(row.scores.next_state, [0.0; 2]);
    }
    assert!(table.values().iter().any(|v| v.reward > 1.0));
    // The same GP for every source (and as its own next-state model): exactly 0.
    let same = [GpSourceModel::new(&gp_a, Some([&gp_b, &gp_b])); 3];
    let table = ScoreTable::compute(rows, &same, &mut storage).unwrap();
    assert!(table.values().iter().all(|v| v.total() == 0.0));
}

#[test]
fn a_table_can_be_rebuilt_from_stored_scores() {
    let rows = RowSet::grid(PuddleWorld::<f64>::score_grid(5.0).unwrap(), 4).unwrap();
    let mut storage = vec![Scores::default(); rows.len()];
    let sources = PuddleWorld::sources(Dynamics::Shared);
    let table = ScoreTable::compute(rows, &sources, &mut storage).unwrap();
    let copy: Vec<Scores<f64, 2>> = table.values().to_vec();
    let again = ScoreTable::from_parts(rows, &copy).unwrap();
    assert_eq!(again.values(), table.values());
    assert_eq!(again.row(7), table.row(7));
    assert_eq!(
        ScoreTable::from_parts(rows, &copy[..3]).err(),
        Some(Error::CapacityExceeded { capacity: 3 })
    );
    let mut bad = copy.clone();
    bad[2].next_state[1] = -1.0;
    assert!(ScoreTable::from_parts(rows, &bad).is_err());
    bad[2].next_state[1] = f64::NAN;
    assert!(ScoreTable::from_parts(rows, &bad).is_err());
}

#[test]
fn realistic_table_one_gp_at_a_time_equals_the_table_of_all_gps_bit_for_bit() {
    use crate::gp::SearchOptions;
    use crate::record_gp::{GpTraining, Output, SubsetRule, fit_gp};
    // Three sources' records from the Puddle World sources, uniformly drawn.
    let worlds = PuddleWorld::<f64>::sources(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let records: Vec<Vec<Transition<[f64; 2], f64>>> = worlds
        .iter()
        .map(|w| {
            (0..30)
                .map(|i| {
                    let s = [
                        crate::rng::uniform::<f64, _>(&mut rng) * 10.0,
                        crate::rng::uniform::<f64, _>(&mut rng) * 10.0,
                    ];
                    crate::model::GenerativeModel::query(w, s, i % 4, &mut rng).unwrap()
                })
                .collect()
        })
        .collect();
    let slices: Vec<&[_]> = records.iter().map(Vec::as_slice).collect();
    let training = GpTraining {
        search: SearchOptions {
            max_evaluations: 40,
            restarts: 1,
            isotropic: true,
        },
        ..GpTraining::published()
    };
    let rows = RowSet::both(PuddleWorld::score_grid(2.5).unwrap(), 4, &slices).unwrap();
    // All GPs at once, from the same stream.
    let mut fit_rng = ChaCha8Rng::seed_from_u64(9);
    let gps: Vec<Gp<f64, 16, 3>> = slices
        .iter()
        .map(|r| {
            let mut gp = Gp::empty();
            fit_gp(
                &mut gp,
                r,
                Output::Reward,
                SubsetRule::Spread,
                &training,
                &mut fit_rng,
            )
            .unwrap();
            gp
        })
        .collect();
    let models: Vec<_> = gps.iter().map(|g| GpSourceModel::new(g, None)).collect();
    let mut all = vec![Scores::ZERO; rows.len()];
    ScoreTable::compute(rows, &models, &mut all).unwrap();
    // One GP slot, one source at a time; the callback sees every fitted GP.
    let mut one = vec![Scores::ZERO; rows.len()];
    let mut scratch = vec![AliasEntry::EMPTY; rows.len()];
    let mut gp = Gp::<f64, 16, 3>::empty();
    let mut seen = Vec::new();
    let mut fit_rng = ChaCha8Rng::seed_from_u64(9);
    let table = ScoreTable::realistic(
        rows,
        &slices,
        &mut gp,
        &training,
        SubsetRule::Spread,
        &mut one,
        &mut scratch,
        &mut fit_rng,
        |j, g| {
            seen.push((j, g.inputs().to_vec()));
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(table.values(), &all[..]);
    assert!(all.iter().any(|v| v.reward > 0.0));
    for (j, inputs) in &seen {
        assert_eq!(inputs, gps[*j].inputs());
    }
    assert_eq!(seen.len(), 3);
    // Sizes are checked before anything is fitted.
    let mut short = vec![AliasEntry::EMPTY; rows.len() - 1];
    let before = fit_rng.clone();
    assert_eq!(
        ScoreTable::realistic(
            rows,
            &slices,
            &mut gp,
            &training,
            SubsetRule::Spread,
            &mut one,
            &mut short,
            &mut fit_rng,
            |_, _| Ok(()),
        )
        .err(),
        Some(Error::CapacityExceeded {
            capacity: rows.len() - 1
        })
    );
    assert_eq!(fit_rng, before);
}

#[test]
fn candidate_pairs_and_grids_in_three_dimensions() {
    // A 3-D grid: 2 × 3 × 2 points from (−1, 0, 5) with spacings (0.5, 1, 2), first axis
    // fastest.
    let grid = PointGrid::new([-1.0, 0.0, 5.0], [0.5, 1.0, 2.0], [2, 3, 2]).unwrap();
    assert_eq!(grid.len(), 12);
    assert_eq!(grid.point(0), Some([-1.0, 0.0, 5.0]));
    assert_eq!(grid.point(1 + 2 * 2 + 6), Some([-0.5, 2.0, 7.0]));
    assert_eq!(grid.point(12), None);
    let spanning = PointGrid::<f64, 3>::spanning([0.0; 3], [1.0, 2.0, 0.5], 0.5).unwrap();
    assert_eq!(spanning.points(), [3, 5, 2]);
    assert_eq!(
        PointGrid::<f64, 3>::spanning([0.0; 3], [1.0, 2.0, 0.7], 0.5).err(),
        Some(Error::InvalidParameter {
            parameter: "spacing"
        })
    );
    // The caller's own pairs, after the grid rows.
    let pairs = [([0.25, 0.5, 0.75], 1), ([1.0, 1.0, 1.0], 0)];
    let rows = RowSet::new(Some((grid, 2)), &pairs, &[]).unwrap();
    assert_eq!(rows.len(), 24 + 2);
    assert_eq!(rows.row(24), Some(pairs[0]));
    assert_eq!(rows.row(25), Some(pairs[1]));
    assert_eq!(rows.row(26), None);
    assert_eq!(rows.iter().nth(24), Some(pairs[0]));
    assert_eq!(rows.row(3), Some(([-0.5, 0.0, 5.0], 1)));
    let only = RowSet::pairs(&pairs).unwrap();
    assert_eq!(only.iter().collect::<Vec<_>>(), pairs.to_vec());
    let bad = [([0.0, f64::NAN, 0.0], 0)];
    assert_eq!(
        RowSet::pairs(&bad).err(),
        Some(Error::NonFinite { parameter: "state" })
    );
    assert_eq!(RowSet::<f64, 3>::pairs(&[]).err(), Some(Error::EmptyData));
    // Scores over 3 next-state coordinates: a column beyond them is refused.
    let values = [Scores {
        reward: 1.0,
        next_state: [0.5, 0.0, 2.0],
    }; 2];
    let table = ScoreTable::from_parts(only, &values).unwrap();
    assert_eq!(values[0].total(), 3.5);
    assert_eq!(values[0].get(ScoreColumn::NextState(2)), Some(2.0));
    assert_eq!(values[0].get(ScoreColumn::NextState(3)), None);
    let mut alias = [AliasEntry::EMPTY; 2];
    assert_eq!(
        table.sampler(ScoreColumn::NextState(3), &mut alias).err(),
        Some(Error::OutOfRange {
            parameter: "column"
        })
    );
    assert!(table.sampler(ScoreColumn::NextState(2), &mut alias).is_ok());
}

#[test]
fn spanning_point_and_row_counts_are_const_and_agree_with_the_grid() {
    const POINTS: usize = PointGrid::<f32, 2>::spanning_points(0.0, 10.0, 0.1);
    const ROWS: usize = PointGrid::<f32, 2>::rows(POINTS, 4);
    let grid = PointGrid::spanning([0.0f32; 2], [10.0; 2], 0.1).unwrap();
    assert_eq!(grid.points(), [POINTS; 2]);
    assert_eq!(RowSet::grid(grid, 4).unwrap().len(), ROWS);
    assert_eq!(ROWS, 101 * 101 * 4);
    for (lo, hi, d, want) in [
        (0.0, 1.0, 0.05, 21),
        (0.0, 10.0, 1.25, 9),
        (-1.0, 1.0, 0.5, 5),
    ] {
        assert_eq!(PointGrid::<f64, 1>::spanning_points(lo, hi, d), want);
        let grid = PointGrid::spanning([lo], [hi], d).unwrap();
        assert_eq!(grid.points(), [want]);
    }
    // What spanning refuses counts 0 points.
    assert_eq!(PointGrid::<f64, 1>::spanning_points(0.0, 1.0, 0.3), 0);
    assert_eq!(PointGrid::<f64, 1>::spanning_points(0.0, 1.0, 0.0), 0);
    assert_eq!(PointGrid::<f64, 1>::spanning_points(1.0, 0.0, 0.1), 0);
    assert!(PointGrid::spanning([0.0f64], [1.0], 0.3).is_err());
    assert_eq!(PointGrid::<f64, 3>::rows(usize::MAX, 2), usize::MAX);
}
