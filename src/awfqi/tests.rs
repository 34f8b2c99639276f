extern crate std;
use super::*;
use crate::alias::AliasEntry;
use crate::dataset::{SubsetRule, predict_posteriors};
use crate::env::{Dynamics, PuddleWorld};
use crate::fqi::{CellGrid, FqiEntry};
use crate::gp::SearchOptions;
use crate::score::{PointGrid, RowSet, ScoreColumn, ScoreTable, Scores};
use crate::weights::effective_sample_size;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::vec;
use std::vec::Vec;

type Record = Transition<[f64; 2], f64>;

fn blank() -> Record {
    Transition {
        state: [0.0; 2],
        action: 0,
        reward: 0.0,
        next_state: [0.0; 2],
        absorbing: false,
    }
}

/// Generative-model records of `world` at pseudo-random states.
fn query_records(world: &PuddleWorld<f64>, n: usize, seed: u64) -> Vec<Record> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let s = [
                crate::rng::uniform::<f64, _>(&mut rng) * 10.0,
                (i % 11) as f64,
            ];
            world.query(s, i % 4, &mut rng).unwrap()
        })
        .collect()
}

/// Source posteriors: the oracle mean reward with std 0.05.
fn oracle_posteriors(world: &PuddleWorld<f64>, records: &[Record]) -> Vec<Posterior<f64>> {
    records
        .iter()
        .map(|r| Posterior::new(world.mean_reward(r.state).unwrap(), 0.05))
        .collect()
}

fn small_config(budget: usize) -> AwfqiConfig<f64> {
    let mut config = AwfqiConfig::thesis(budget);
    config.gp_training.search = SearchOptions {
        max_evaluations: 60,
        restarts: 2,
        isotropic: true,
    };
    config.fqi = FqiConfig::new(0.99, 20, crate::fqi::EmptyCells::Nearest).unwrap();
    config
}

struct Fixture {
    sources: Vec<Vec<Record>>,
    posteriors: Vec<Vec<Posterior<f64>>>,
}

impl Fixture {
    fn new() -> Self {
        let worlds = PuddleWorld::sources(Dynamics::Shared);
        let sources: Vec<Vec<Record>> = worlds
            .iter()
            .enumerate()
            .map(|(k, w)| query_records(w, 30 + 5 * k, k as u64))
            .collect();
        let posteriors = worlds
            .iter()
            .zip(&sources)
            .map(|(w, r)| oracle_posteriors(w, r))
            .collect();
        Self {
            sources,
            posteriors,
        }
    }

    fn data(&self) -> Vec<SourceData<'_, f64>> {
        self.sources
            .iter()
            .zip(&self.posteriors)
            .map(|(r, p)| SourceData::new(r, p).unwrap())
            .collect()
    }

    fn source_records(&self) -> usize {
        self.sources.iter().map(Vec::len).sum()
    }
}

#[test]
fn a_step_queries_weighs_and_fits_as_specified() {
    let fx = Fixture::new();
    let data = fx.data();
    let worlds = PuddleWorld::sources(Dynamics::Shared);
    let rows = RowSet::grid(PointGrid::puddle(1.0).unwrap(), 4).unwrap();
    let mut scores = vec![Scores::default(); rows.len()];
    let table = ScoreTable::compute(rows, &worlds, &mut scores).unwrap();
    let mut alias = vec![AliasEntry::default(); table.len()];
    let sampler = table.sampler(ScoreColumn::Reward, &mut alias).unwrap();

    let budget = 20;
    let mut samples = vec![blank(); 2 * budget];
    let n_source = fx.source_records();
    let mut weights = vec![0.0; n_source];
    let mut gp = Gp::<f64, 16, 3>::empty();
    let grid = CellGrid::cube(0.0, 10.0, 11).unwrap();
    let mut entries = vec![FqiEntry::default(); 11 * 11 * 4];
    let fqi = TabularFqi::new(grid, 4, &mut entries).unwrap();
    let target = PuddleWorld::target(Dynamics::Shared);
    let config = small_config(budget);
    let mut kernel = Awfqi::new(
        config,
        target,
        sampler,
        &data,
        &mut samples,
        &mut weights,
        &mut gp,
        fqi,
    )
    .unwrap();

    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let report = kernel.step(&mut rng).unwrap();
    assert_eq!(report.step, 1);
    assert_eq!(report.n_target_samples, budget);
    assert_eq!(report.n_source_samples, n_source);
    assert_eq!(report.gp_points, 16);
    // Every query starts at a grid row with positive V_r (zero-score rows are never drawn).
    for r in kernel.target_samples() {
        assert_eq!(r.state, [r.state[0].round(), r.state[1].round()]);
        let p = (r.state[0] as usize) + 11 * (r.state[1] as usize);
        assert!(table.row(4 * p + r.action).unwrap().scores.reward > 0.0);
    }
    // The GP holds the spread subset of D₀.
    let d0 = kernel.target_samples().to_vec();
    let want: Vec<[f64; 3]> = SubsetRule::Spread
        .indices(budget, 16)
        .map(|i| crate::dataset::input(d0[i].state, d0[i].action))
        .collect();
    assert_eq!(kernel.gp().inputs(), &want[..]);

    // Independent route to the weights: posteriors of the fitted GP per source batch, then
    // the slice estimator.
    let mut expected = Vec::new();
    for (records, source_post) in fx.sources.iter().zip(&fx.posteriors) {
        let mut target_post = vec![Posterior::default(); records.len()];
        predict_posteriors(
            kernel.gp(),
            records,
            NoiseSubtraction::Reference,
            &mut target_post,
        )
        .unwrap();
        let ys: Vec<f64> = records.iter().map(|r| r.reward).collect();
        let mut w = vec![0.0; records.len()];
        WeightParams::reference_reward()
            .weights_into(&ys, &target_post, source_post, &mut w)
            .unwrap();
        expected.extend(w);
    }
    assert_eq!(kernel.reward_weights().len(), expected.len());
    for (a, b) in kernel.reward_weights().iter().zip(&expected) {
        assert!((a - b).abs() <= 1e-12 * (1.0 + b.abs()), "{a} vs {b}");
    }
    assert!(expected.iter().any(|&w| w > 0.0));
    // Diagnostics over all records, target ones with weight 1.
    let mut all = vec![1.0; budget];
    all.extend(&expected);
    let ess = effective_sample_size(&all).unwrap();
    assert!((report.wr_eff - ess).abs() < 1e-9 * ess);
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    assert!((report.wr_mean - mean).abs() < 1e-12);
    assert_eq!(report.ws_eff, all.len() as f64);
    assert_eq!(report.ws_mean, 1.0);

    // Independent route to Q: weighted FQI on the same sets.
    let mut entries2 = vec![FqiEntry::default(); 11 * 11 * 4];
    let mut fqi2 = TabularFqi::new(grid, 4, &mut entries2).unwrap();
    let mut sets = vec![SampleSet::unweighted(&d0)];
    let mut offset = 0;
    for r in &fx.sources {
        sets.push(SampleSet::weighted(
            r,
            Some(&expected[offset..offset + r.len()]),
            None,
        ));
        offset += r.len();
    }
    fqi2.fit(&sets, &config.fqi).unwrap();
    for (a, b) in kernel.q().entries().iter().zip(fqi2.entries()) {
        assert!((a.q() - b.q()).abs() < 1e-9 * (1.0 + b.q().abs()));
    }

    // Step 2 appends; step 3 has no room: refused before anything is drawn.
    let report = kernel.step(&mut rng).unwrap();
    assert_eq!(report.step, 2);
    assert_eq!(report.n_target_samples, 2 * budget);
    assert_eq!(&kernel.target_samples()[..budget], &d0[..]);
    let before = rng.clone();
    assert_eq!(
        kernel.step(&mut rng).err(),
        Some(Error::CapacityExceeded {
            capacity: 2 * budget
        })
    );
    assert_eq!(rng, before);
    assert_eq!(kernel.steps(), 2);
    kernel.reset();
    assert_eq!(kernel.steps(), 0);
    assert!(kernel.target_samples().is_empty());
    assert!(kernel.q().entries().iter().all(|e| e.q() == 0.0));
}

#[test]
fn same_seed_same_run() {
    let fx = Fixture::new();
    let data = fx.data();
    let worlds = PuddleWorld::sources(Dynamics::Shared);
    let rows = RowSet::grid(PointGrid::puddle(2.0).unwrap(), 4).unwrap();
    let mut scores = vec![Scores::default(); rows.len()];
    let table = ScoreTable::compute(rows, &worlds, &mut scores).unwrap();
    let run = |seed: u64| {
        let mut alias = vec![AliasEntry::default(); table.len()];
        let sampler = table.sampler(ScoreColumn::Reward, &mut alias).unwrap();
        let mut samples = vec![blank(); 10];
        let mut weights = vec![0.0; fx.source_records()];
        let mut gp = Gp::<f64, 8, 3>::empty();
        let grid = CellGrid::cube(0.0, 10.0, 5).unwrap();
        let mut entries = vec![FqiEntry::default(); 100];
        let fqi = TabularFqi::new(grid, 4, &mut entries).unwrap();
        let mut kernel = Awfqi::new(
            small_config(10),
            PuddleWorld::target(Dynamics::Shared),
            sampler,
            &data,
            &mut samples,
            &mut weights,
            &mut gp,
            fqi,
        )
        .unwrap();
        let report = kernel.step(&mut ChaCha8Rng::seed_from_u64(seed)).unwrap();
        let q: Vec<f64> = kernel.q().entries().iter().map(|e| e.q()).collect();
        (report, kernel.target_samples().to_vec(), q)
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3).1, run(4).1);
}

#[test]
fn construction_checks_storage_and_configuration() {
    let fx = Fixture::new();
    let data = fx.data();
    assert!(SourceData::new(&fx.sources[0], &fx.posteriors[1]).is_err());
    let bad = [Posterior::new(0.0, -1.0)];
    assert!(SourceData::new(&fx.sources[0][..1], &bad).is_err());
    let worlds = PuddleWorld::sources(Dynamics::Shared);
    let rows = RowSet::grid(PointGrid::puddle(5.0).unwrap(), 4).unwrap();
    let mut scores = vec![Scores::default(); rows.len()];
    let table = ScoreTable::compute(rows, &worlds, &mut scores).unwrap();
    let mut alias = vec![AliasEntry::default(); table.len()];
    let sampler = table.sampler(ScoreColumn::Reward, &mut alias).unwrap();
    let grid = CellGrid::cube(0.0, 10.0, 3).unwrap();
    let target = PuddleWorld::target(Dynamics::Shared);
    let n_source = fx.source_records();
    let mut samples = vec![blank(); 10];
    let mut gp = Gp::<f64, 8, 3>::empty();

    let mut weights = vec![0.0; n_source - 1];
    let mut entries = vec![FqiEntry::default(); 36];
    let fqi = TabularFqi::new(grid, 4, &mut entries).unwrap();
    let err = Awfqi::new(
        small_config(10),
        target,
        sampler,
        &data,
        &mut samples,
        &mut weights,
        &mut gp,
        fqi,
    )
    .err();
    assert_eq!(
        err,
        Some(Error::CapacityExceeded {
            capacity: n_source - 1
        })
    );

    let mut weights = vec![0.0; n_source];
    let mut entries = vec![FqiEntry::default(); 36];
    let fqi = TabularFqi::new(grid, 4, &mut entries).unwrap();
    let err = Awfqi::new(
        small_config(11),
        target,
        sampler,
        &data,
        &mut samples,
        &mut weights,
        &mut gp,
        fqi,
    )
    .err();
    assert_eq!(err, Some(Error::CapacityExceeded { capacity: 10 }));

    let mut entries = vec![FqiEntry::default(); 27];
    let fqi = TabularFqi::new(grid, 3, &mut entries).unwrap();
    let err = Awfqi::new(
        small_config(10),
        target,
        sampler,
        &data,
        &mut samples,
        &mut weights,
        &mut gp,
        fqi,
    )
    .err();
    assert_eq!(
        err,
        Some(Error::InvalidParameter {
            parameter: "actions"
        })
    );
    assert!(small_config(0).validate().is_err());
}
