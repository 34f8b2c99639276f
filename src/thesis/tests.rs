extern crate std;
use super::*;
use crate::alias::AliasEntry;
use crate::env::{Dynamics, PuddleWorld};
use crate::fqi::SampleSet;
use crate::fqi::TabularFqi;
use crate::fqi::{CellGrid, FqiEntry};
use crate::gp::SearchOptions;
use crate::record_gp::{SubsetRule, predict_posteriors};
use crate::score::{GpSourceModel, RowSet, ScoreTable, Scores};
use crate::weights::effective_sample_size;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::vec;
use std::vec::Vec;

type Record = Transition<[f64; 2], f64>;

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

fn small_config(budget: usize) -> AwfqiConfig<f64, 3> {
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
    posteriors: Vec<Posterior<f64>>,
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
            .flat_map(|(w, r)| oracle_posteriors(w, r))
            .collect();
        Self {
            sources,
            posteriors,
        }
    }

    fn slices(&self) -> Vec<&[Record]> {
        self.sources.iter().map(Vec::as_slice).collect()
    }

    fn source_records(&self) -> usize {
        self.sources.iter().map(Vec::len).sum()
    }
}

/// Heap buffers for a kernel with `samples` target records, `weights` weights, `rows`
/// candidate rows and `entries` FQI entries.
struct Heap<const N: usize> {
    gp: std::boxed::Box<Gp<f64, N, 3>>,
    samples: Vec<Record>,
    weights: Vec<f64>,
    alias: Vec<AliasEntry<f64>>,
    fqi: Vec<FqiEntry<f64>>,
}

impl<const N: usize> Heap<N> {
    fn new(samples: usize, weights: usize, rows: usize, entries: usize) -> Self {
        Self {
            gp: std::boxed::Box::new(Gp::empty()),
            samples: vec![Transition::EMPTY; samples],
            weights: vec![0.0; weights],
            alias: vec![AliasEntry::EMPTY; rows],
            fqi: vec![FqiEntry::EMPTY; entries],
        }
    }

    fn buffers(&mut self) -> AwfqiBuffers<'_, f64, 2, 3, N> {
        AwfqiBuffers {
            gp: &mut self.gp,
            samples: &mut self.samples,
            weights: &mut self.weights,
            alias: &mut self.alias,
            fqi: &mut self.fqi,
        }
    }
}

#[test]
fn a_step_queries_weighs_and_fits_as_specified() {
    let fx = Fixture::new();
    let slices = fx.slices();
    let worlds = PuddleWorld::sources(Dynamics::Shared);
    let rows = RowSet::grid(PuddleWorld::score_grid(1.0).unwrap(), 4).unwrap();
    let mut scores = vec![Scores::default(); rows.len()];
    let mut oracle = scores.clone();
    let table = ScoreTable::compute(rows, &worlds, &mut oracle).unwrap();

    let budget = 20;
    let n_source = fx.source_records();
    let mut heap = Heap::<16>::new(2 * budget, n_source, rows.len(), 11 * 11 * 4);
    let grid = CellGrid::cube(0.0, 10.0, 11).unwrap();
    let target = PuddleWorld::target(Dynamics::Shared);
    let config = small_config(budget).validate().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut kernel = Awfqi::builder(config, grid, &slices, rows)
        .stored_posteriors(&fx.posteriors)
        .scores_from(&worlds, &mut scores)
        .unwrap()
        .build(target, heap.buffers(), &mut rng)
        .unwrap();
    assert_eq!(kernel.steps(), 0);
    assert_eq!(kernel.sources().len(), n_source);
    assert_eq!(kernel.sampler().rows().len(), rows.len());

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
        .map(|i| crate::record_gp::input(d0[i].state, d0[i].action))
        .collect();
    assert_eq!(kernel.gp().inputs(), &want[..]);

    // Independent route to the weights: posteriors of the fitted GP per source batch, then
    // the slice estimator.
    let mut expected = Vec::new();
    let mut offset = 0;
    for records in &fx.sources {
        let source_post = &fx.posteriors[offset..offset + records.len()];
        offset += records.len();
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
    fqi2.fit(&sets, &small_config(budget).fqi).unwrap();
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
        Some(Error::BufferTooSmall {
            buffer: "samples (`steps` × `budget` target records)",
            capacity: 2 * budget,
            needed: 3 * budget,
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
    let slices = fx.slices();
    let worlds = PuddleWorld::sources(Dynamics::Shared);
    let rows = RowSet::grid(PuddleWorld::score_grid(2.0).unwrap(), 4).unwrap();
    let mut scores = vec![Scores::default(); rows.len()];
    ScoreTable::compute(rows, &worlds, &mut scores).unwrap();
    let target = PuddleWorld::target(Dynamics::Shared);
    // `lend`: the kernel borrows the plant (`GenerativeModel for &G`) instead of owning it.
    let run = |seed: u64, lend: bool| {
        let mut heap = Heap::<8>::new(10, fx.source_records(), rows.len(), 100);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let builder = Awfqi::builder(
            small_config(10).validate().unwrap(),
            CellGrid::cube(0.0, 10.0, 5).unwrap(),
            &slices,
            rows,
        )
        .stored_posteriors(&fx.posteriors)
        .stored_scores(&scores);
        let (report, samples, q) = if lend {
            let mut kernel = builder.build(&target, heap.buffers(), &mut rng).unwrap();
            let report = kernel.step(&mut rng).unwrap();
            let q: Vec<f64> = kernel.q().entries().iter().map(|e| e.q()).collect();
            (report, kernel.target_samples().to_vec(), q)
        } else {
            let mut kernel = builder.build(target, heap.buffers(), &mut rng).unwrap();
            let report = kernel.step(&mut rng).unwrap();
            let q: Vec<f64> = kernel.q().entries().iter().map(|e| e.q()).collect();
            (report, kernel.target_samples().to_vec(), q)
        };
        (report, samples, q)
    };
    assert_eq!(run(3, false), run(3, false));
    assert_ne!(run(3, false).1, run(4, false).1);
    // A lent plant is the same plant: the same run, bit for bit.
    assert_eq!(run(3, true), run(3, false));
}

#[test]
fn the_builder_fits_each_source_gp_once_for_posteriors_and_realistic_scores() {
    let fx = Fixture::new();
    let slices = fx.slices();
    let rows = RowSet::grid(PuddleWorld::score_grid(2.5).unwrap(), 4).unwrap();
    let mut config = small_config(10);
    config.gp_training.search.max_evaluations = 30;
    let config = config.validate().unwrap();
    let n_source = fx.source_records();

    // Independent route: fit the source GPs one after the other from the same stream,
    // predict their posteriors, and score with all of them at once.
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut gps = Vec::new();
    let mut want_posteriors = Vec::new();
    for records in &slices {
        let mut gp = Gp::<f64, 8, 3>::empty();
        crate::record_gp::fit_gp(
            &mut gp,
            records,
            crate::record_gp::Output::Reward,
            config.subset,
            &config.gp_training,
            &mut rng,
        )
        .unwrap();
        let mut p = vec![Posterior::default(); records.len()];
        predict_posteriors(&gp, records, config.noise_subtraction, &mut p).unwrap();
        want_posteriors.extend(p);
        gps.push(gp);
    }
    let models: Vec<_> = gps.iter().map(|g| GpSourceModel::new(g, None)).collect();
    let mut want_scores = vec![Scores::ZERO; rows.len()];
    ScoreTable::compute(rows, &models, &mut want_scores).unwrap();
    let after_set_up = rng.clone();

    for realistic in [true, false] {
        let mut heap = Heap::<8>::new(10, n_source, rows.len(), 64);
        let mut posteriors = vec![Posterior::default(); n_source + 3];
        let mut scores = vec![Scores::ZERO; rows.len()];
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let builder = Awfqi::builder(config, CellGrid::cube(0.0, 10.0, 4).unwrap(), &slices, rows)
            .fit_posteriors(&mut posteriors);
        let builder = if realistic {
            builder.realistic_scores(&mut scores)
        } else {
            builder.stored_scores(&want_scores)
        };
        let kernel = builder
            .build(
                PuddleWorld::target(Dynamics::Shared),
                heap.buffers(),
                &mut rng,
            )
            .unwrap();
        assert_eq!(kernel.sources().reward_posteriors(), &want_posteriors[..]);
        // Each source GP was fitted once: the stream is where the independent route left it.
        assert_eq!(rng, after_set_up);
        if realistic {
            assert_eq!(scores, want_scores);
        }
    }
}

#[test]
fn a_target_buffer_one_sample_short_of_the_run_is_refused_before_the_first_step() {
    let fx = Fixture::new();
    let slices = fx.slices();
    let worlds = PuddleWorld::sources(Dynamics::Shared);
    let rows = RowSet::grid(PuddleWorld::score_grid(5.0).unwrap(), 4).unwrap();
    let mut scores = vec![Scores::default(); rows.len()];
    ScoreTable::compute(rows, &worlds, &mut scores).unwrap();
    let grid = CellGrid::cube(0.0, 10.0, 3).unwrap();
    let config = small_config(10).validate().unwrap();
    let n_source = fx.source_records();
    // Ten steps of 10 queries need 100 target samples.
    let build = |samples: usize| {
        let mut heap = Heap::<8>::new(samples, n_source, rows.len(), 36);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        Awfqi::builder(config, grid, &slices, rows)
            .stored_posteriors(&fx.posteriors)
            .stored_scores(&scores)
            .steps(10)
            .build(
                PuddleWorld::target(Dynamics::Shared),
                heap.buffers(),
                &mut rng,
            )
            .map(|kernel| kernel.steps())
    };
    assert_eq!(
        build(99),
        Err(Error::BufferTooSmall {
            buffer: "samples (`steps` × `budget` target records)",
            capacity: 99,
            needed: 100,
        })
    );
    assert_eq!(build(100), Ok(0));
}

#[test]
fn the_builder_checks_sizes_and_stages_before_fitting() {
    let fx = Fixture::new();
    let slices = fx.slices();
    let worlds = PuddleWorld::sources(Dynamics::Shared);
    let rows = RowSet::grid(PuddleWorld::score_grid(5.0).unwrap(), 4).unwrap();
    let mut scores = vec![Scores::default(); rows.len()];
    ScoreTable::compute(rows, &worlds, &mut scores).unwrap();
    let grid = CellGrid::cube(0.0, 10.0, 3).unwrap();
    let target = PuddleWorld::target(Dynamics::Shared);
    let n_source = fx.source_records();
    let config = small_config(10).validate().unwrap();
    let builder = || Awfqi::builder(config, grid, &slices, rows);
    let build = |b: AwfqiBuilder<'_, f64, 2, 3>, heap: &mut Heap<8>| {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let result = b.build(target, heap.buffers(), &mut rng).map(|_| ());
        (result, rng == ChaCha8Rng::seed_from_u64(1))
    };
    let complete = || {
        builder()
            .stored_posteriors(&fx.posteriors)
            .stored_scores(&scores)
    };
    let ok = || Heap::<8>::new(10, n_source, rows.len(), 36);

    assert_eq!(build(complete(), &mut ok()), (Ok(()), true));
    // Each buffer too short names itself and the const parameter of `AwfqiStorage` that
    // sizes it, with its length and the length needed.
    let too_small = |buffer, capacity, needed| Error::BufferTooSmall {
        buffer,
        capacity,
        needed,
    };
    let cases: [(Heap<8>, Error); 4] = [
        (
            Heap::new(10, n_source - 1, rows.len(), 36),
            too_small(
                "weights (`source_records`: one per source record)",
                n_source - 1,
                n_source,
            ),
        ),
        (
            Heap::new(9, n_source, rows.len(), 36),
            too_small("samples (`steps` × `budget` target records)", 9, 10),
        ),
        (
            Heap::new(10, n_source, rows.len() - 1, 36),
            too_small(
                "alias (`candidate_rows`: one entry per candidate row)",
                rows.len() - 1,
                rows.len(),
            ),
        ),
        (
            Heap::new(10, n_source, rows.len(), 35),
            too_small(
                "fqi (`table_entries` or the approximator's memory: cells × actions)",
                35,
                36,
            ),
        ),
    ];
    for (mut heap, error) in cases {
        assert_eq!(build(complete(), &mut heap).0, Err(error));
    }
    // Missing stages, and posteriors or scores of the wrong length.
    let missing = Error::InvalidParameter {
        parameter: "posteriors",
    };
    assert_eq!(
        build(builder().stored_scores(&scores), &mut ok()).0,
        Err(missing)
    );
    assert_eq!(
        build(builder().stored_posteriors(&fx.posteriors), &mut ok()).0,
        Err(Error::InvalidParameter {
            parameter: "scores"
        })
    );
    assert_eq!(
        build(
            builder()
                .stored_posteriors(&fx.posteriors[1..])
                .stored_scores(&scores),
            &mut ok()
        )
        .0,
        Err(Error::InvalidParameter {
            parameter: "reward_posteriors"
        })
    );
    let mut few = vec![Posterior::default(); n_source - 1];
    assert_eq!(
        build(
            builder().fit_posteriors(&mut few).stored_scores(&scores),
            &mut ok()
        ),
        (
            Err(Error::BufferTooSmall {
                buffer: "posteriors (one per source record)",
                capacity: n_source - 1,
                needed: n_source,
            }),
            true
        )
    );
    let mut few_scores = vec![Scores::ZERO; rows.len() - 1];
    assert_eq!(
        build(
            builder()
                .stored_posteriors(&fx.posteriors)
                .realistic_scores(&mut few_scores),
            &mut ok()
        ),
        (
            Err(Error::BufferTooSmall {
                buffer: "scores (one per candidate row)",
                capacity: rows.len() - 1,
                needed: rows.len(),
            }),
            true
        )
    );
    // Candidate rows with an action the model does not have.
    let five = RowSet::grid(PuddleWorld::score_grid(5.0).unwrap(), 5).unwrap();
    let mut five_scores = vec![Scores::ZERO; five.len()];
    let b = Awfqi::builder(config, grid, &slices, five)
        .stored_posteriors(&fx.posteriors)
        .scores_from(
            &[PuddleWorld::<f64>::target(Dynamics::Shared)],
            &mut five_scores,
        );
    assert_eq!(
        b.err(),
        Some(Error::OutOfRange {
            parameter: "action"
        })
    );
    let b = Awfqi::builder(config, grid, &slices, five)
        .stored_posteriors(&fx.posteriors)
        .stored_scores(&five_scores);
    let mut heap = Heap::<8>::new(10, n_source, five.len(), 36);
    assert_eq!(
        build(b, &mut heap).0,
        Err(Error::OutOfRange {
            parameter: "actions"
        })
    );
    // Configuration.
    assert!(small_config(0).validate().is_err());
    let mut c = small_config(10);
    c.sampling = crate::score::ScoreColumn::NextState(2);
    assert_eq!(
        c.validate().err(),
        Some(Error::OutOfRange {
            parameter: "sampling"
        })
    );
    c.sampling = crate::score::ScoreColumn::NextState(1);
    assert!(c.validate().is_ok());
}

/// The storage block is `const`-constructible, so it can be a `static`.
static STORAGE_IN_A_STATIC: AwfqiStorage<f32, 2, 3, 8, 10, 20, 30, 36> = AwfqiStorage::new();

#[test]
fn storage_is_all_zero_and_lends_its_parts() {
    let mut storage = STORAGE_IN_A_STATIC.clone();
    let buffers = storage.buffers();
    assert_eq!(
        (
            buffers.samples.len(),
            buffers.weights.len(),
            buffers.alias.len(),
            buffers.fqi.len()
        ),
        (10, 20, 30, 36)
    );
    assert!(buffers.gp.is_empty());
    assert!(buffers.samples.iter().all(|t| *t == Transition::EMPTY));
}
