extern crate std;
use super::*;
use crate::env::Dynamics;
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
    let grid = PointGrid::<f64>::puddle(0.1).unwrap();
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
    assert!(PointGrid::<f64>::puddle(0.3).is_err());
    assert_eq!(PointGrid::<f32>::puddle(0.5).unwrap().points(), [21, 21]);
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
    let grid = PointGrid::<f64>::puddle(0.5).unwrap();
    let rows = RowSet::grid(grid, 4).unwrap();
    let mut storage = vec![Scores::default(); rows.len()];
    // Shared dynamics: every source moves by exactly 1, so the next-state columns vanish
    // everywhere, not just approximately.
    let sources = PuddleWorld::sources(Dynamics::Shared);
    let table = ScoreTable::compute(rows, &sources, &mut storage).unwrap();
    assert_eq!(table.len(), 21 * 21 * 4);
    assert!(
        table
            .values()
            .iter()
            .all(|v| v.next_x == 0.0 && v.next_y == 0.0)
    );
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
    assert!(table.values().iter().any(|v| v.next_x > 0.0));
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
    let grid = PointGrid::<f64>::puddle(1.0).unwrap();
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
    let grid = PointGrid::<f64>::puddle(2.0).unwrap();
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
    let sampler = table.sampler(ScoreColumn::NextX, &mut alias).unwrap();
    let uniform = 1.0 / table.len() as f64;
    for r in 0..table.len() {
        assert!((sampler.alias().probability(r).unwrap() - uniform).abs() < 1e-15);
    }
    let mut short = vec![AliasEntry::default(); 3];
    assert!(table.sampler(ScoreColumn::Reward, &mut short).is_err());
}

#[test]
fn compute_reports_bad_storage_sources_and_states() {
    let grid = PointGrid::<f64>::puddle(5.0).unwrap();
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
    use crate::dataset::input;
    use crate::gp::Hyperparameters;
    let hyper = Hyperparameters::isotropic(4.0, 2.0, 0.01);
    let mut gp_a = Gp::<f64, 8, 3>::new(hyper).unwrap();
    let mut gp_b = Gp::<f64, 8, 3>::new(hyper).unwrap();
    let xs = [[1.0, 1.0, 0.0], [5.0, 5.0, 1.0], [9.0, 2.0, 2.0]];
    gp_a.fit(&xs, &[-1.0, -20.0, -1.0]).unwrap();
    gp_b.fit(&xs, &[-1.0, -2.0, -6.0]).unwrap();
    let grid = PointGrid::<f64>::puddle(2.5).unwrap();
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
        assert_eq!((row.scores.next_x, row.scores.next_y), (0.0, 0.0));
    }
    assert!(table.values().iter().any(|v| v.reward > 1.0));
    // The same GP for every source (and as its own next-state model): exactly 0.
    let same = [GpSourceModel::new(&gp_a, Some([&gp_b, &gp_b])); 3];
    let table = ScoreTable::compute(rows, &same, &mut storage).unwrap();
    assert!(table.values().iter().all(|v| v.total() == 0.0));
}

#[test]
fn a_table_can_be_rebuilt_from_stored_scores() {
    let rows = RowSet::grid(PointGrid::<f64>::puddle(5.0).unwrap(), 4).unwrap();
    let mut storage = vec![Scores::default(); rows.len()];
    let sources = PuddleWorld::sources(Dynamics::Shared);
    let table = ScoreTable::compute(rows, &sources, &mut storage).unwrap();
    let copy: Vec<Scores<f64>> = table.values().to_vec();
    let again = ScoreTable::from_parts(rows, &copy).unwrap();
    assert_eq!(again.values(), table.values());
    assert_eq!(again.row(7), table.row(7));
    assert_eq!(
        ScoreTable::from_parts(rows, &copy[..3]).err(),
        Some(Error::CapacityExceeded { capacity: 3 })
    );
    let mut bad = copy.clone();
    bad[2].next_y = -1.0;
    assert!(ScoreTable::from_parts(rows, &bad).is_err());
    bad[2].next_y = f64::NAN;
    assert!(ScoreTable::from_parts(rows, &bad).is_err());
}
