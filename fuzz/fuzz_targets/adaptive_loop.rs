//! Adaptive AWFQI (`AdaptiveAwfqi`) on Puddle World, in f32 and f64: `AdaptiveConfig`
//! (budget, sub-batches, verification share, floor, candidates, relevance width, start,
//! horizon, exploration, bounds, switches) and its `validate`; source records and
//! posteriors from the fuzzer (NaN, ±∞ and huge values included); each source's
//! `MeanFunction` fitted on its records (or left the zero function); candidate rows (grid,
//! pairs or source rows); the approximator (table, tiles, kernel averaging with a fuzzed
//! `k`, kernel, reach and common ball, the hybrid of tiles and kernel averaging,
//! Extra-Trees, stored or streamed, with fuzzed trees, node budget and growth limits, or a
//! model sweep with fuzzed cells, reward model, minimum mass and lookahead); thesis or warm
//! refits with fuzzed budgets; buffers of every size (one short of what is needed too); then
//! the plan, steps and `reset`.
//!
//! Invariants: no panic; errors only of the documented kinds; a successful step spends the
//! whole budget (`D₀` grows by it), reports finite diagnostics, leaves finite weights and
//! Q-values and beliefs that sum to 1; a failed step leaves the step count as it was.
#![no_main]

use awfqi::adaptive::candidates::Candidate;
use awfqi::adaptive::plausibility::SourceBelief;
use awfqi::env::{Dynamics, PuddleWorld};
use awfqi::record_gp::GpTraining;
use awfqi::{
    Error,
    prelude::{
        AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, CellGrid, EmptyCells, ExtraTrees,
        FqiConfig, FqiEntry, Gp, Kernel, KnnRecord, MeanFunction, ModelSweep, Neighbours,
        PointGrid, Posterior, QStorage, Real, RowSet, SourceData, SubsetRule, Tilings, Transition,
        TreeNode, TreeRecord,
    },
};
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite, trace};
use libfuzzer_sys::fuzz_target;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// Capacity of the GP and of the mean functions.
const N: usize = 8;

/// Every kind: a step fits GPs (which can fail to factorise) on fuzzed data.
const ANY: &[Kind] = &[
    Kind::Empty,
    Kind::Capacity,
    Kind::NonFinite,
    Kind::OutOfRange,
    Kind::Invalid,
    Kind::Overflow,
    Kind::NotPd,
    Kind::Conditioning,
];

fn real<T: Real>(b: &mut Bytes) -> T {
    T::from_f64(b.num())
}

/// `needed` or, when the fuzzer says so, one less (an error the constructor must catch) or
/// a few more.
fn size(b: &mut Bytes, needed: usize) -> usize {
    match b.u8() % 8 {
        0 => needed.saturating_sub(1),
        1 => needed + 3,
        _ => needed,
    }
}

fn run<T: Real>(b: &mut Bytes) {
    let dynamics = if b.bool() {
        Dynamics::PuddleBased
    } else {
        Dynamics::Shared
    };
    let target = PuddleWorld::<T>::target(dynamics);
    // A near-valid state (and sometimes anything at all).
    let state = |b: &mut Bytes| -> [T; 2] {
        core::array::from_fn(|_| match b.u8() {
            0xff => real(b),
            v => T::from_f64(10.0 * f64::from(v) / 254.0),
        })
    };

    // Configuration.
    let start = if b.bool() { state(b) } else { [T::ZERO; 2] };
    let bounds = if b.u8().is_multiple_of(8) {
        [(real(b), real(b)), (T::ZERO, T::from_f64(10.0))]
    } else {
        [(T::ZERO, T::from_f64(10.0)); 2]
    };
    let mut config = AdaptiveConfig::<T, 2, 3>::recommended(
        b.index(9),
        start,
        b.index(12),
        T::from_f64(f64::from(b.u8()) / 200.0),
        bounds,
    );
    config.awfqi.gp_training = GpTraining {
        search: awfqi::gp::SearchOptions {
            max_evaluations: b.index(20),
            restarts: b.index(2),
            isotropic: true,
        },
        ..GpTraining::published()
    };
    if b.bool() {
        config.awfqi.gp_training.initial.noise_variance = real(b);
    }
    config.awfqi.subset = if b.bool() {
        SubsetRule::Spread
    } else {
        SubsetRule::Last
    };
    config.sub_batches = b.index(4);
    config.verify = T::from_f64(f64::from(b.u8()) / 200.0);
    config.floor = if b.bool() {
        real(b)
    } else {
        T::from_f64(f64::from(b.u8()) / 255.0)
    };
    config.candidates = b.index(20);
    config.relevance_width = if b.u8().is_multiple_of(8) {
        real(b)
    } else {
        T::from_f64(0.1)
    };
    config.surprise = b.bool();
    config.uncertainty = b.bool();
    config.decision = b.bool();
    config.relabel = b.bool();
    config.refit = if b.bool() {
        awfqi::adaptive::Refit::Warm(awfqi::gp::SearchOptions {
            max_evaluations: b.index(12),
            restarts: b.index(2),
            isotropic: true,
        })
    } else {
        awfqi::adaptive::Refit::Search
    };
    // The published FQI settings (γ = 0.99, capped nearest, minimum weight 0.5) with 1 to 8
    // iterations instead of their 60: the same loop body, while 60 iterations per replan
    // took three quarters of the target's time (measured with perf).
    config.awfqi.fqi = FqiConfig::new(T::from_f64(0.99), 1 + b.index(8), EmptyCells::CappedNearest)
        .and_then(|c| c.with_min_weight(T::from_f64(0.5)))
        .expect("the published FQI settings");
    trace!("{config:?}");
    let config = match config.validate() {
        Ok(c) => c,
        Err(e) => {
            expect_kind(
                "AdaptiveConfig::validate",
                &e,
                &[Kind::Invalid, Kind::NonFinite, Kind::OutOfRange],
            );
            return;
        }
    };

    // Sources: records with fuzzed rewards, their posteriors and mean functions.
    let sources: Vec<Vec<Transition<[T; 2], T>>> = (0..b.index(4))
        .map(|_| {
            (0..b.index(7))
                .map(|_| Transition {
                    state: state(b),
                    action: b.index(4),
                    reward: real(b),
                    next_state: state(b),
                    absorbing: b.bool(),
                })
                .collect()
        })
        .collect();
    let slices: Vec<&[Transition<[T; 2], T>]> = sources.iter().map(Vec::as_slice).collect();
    let total: usize = slices.iter().map(|s| s.len()).sum();
    let posteriors: Vec<Posterior<T>> = (0..size(b, total))
        .map(|_| Posterior::new(real(b), T::from_f64(f64::from(b.u8()) / 100.0)))
        .collect();
    let data = match SourceData::new(&slices, &posteriors) {
        Ok(d) => d,
        Err(e) => {
            expect_kind("SourceData::new", &e, &[Kind::Invalid, Kind::NonFinite]);
            return;
        }
    };
    let mut gp = Box::new(Gp::<T, N, 3>::empty());
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(b.u8()));
    let mut means = vec![MeanFunction::<T, N, 3>::EMPTY; size(b, slices.len())];
    for (mean, source) in means.iter_mut().zip(&slices) {
        if b.bool() {
            let before = mean.clone();
            if let Err(e) = mean.fit_rewards(
                &mut gp,
                source,
                &config.awfqi.gp_training,
                config.awfqi.subset,
                &mut rng,
            ) {
                expect_kind("MeanFunction::fit_rewards", &e, ANY);
                assert!(*mean == before, "a failed fit changed the mean function");
            }
        }
    }

    // Candidates.
    let pairs: Vec<([T; 2], usize)> = (0..1 + b.index(4))
        .map(|_| (state(b), b.index(5)))
        .collect();
    let spacing = T::from_f64(10.0 / f64::from(1 + b.u8() % 4));
    let grid = PointGrid::spanning([T::ZERO; 2], [T::from_f64(10.0); 2], spacing);
    let rows = match (b.u8() % 3, grid) {
        (0, Ok(g)) => RowSet::grid(g, 4),
        (1, _) => RowSet::pairs(&pairs),
        _ => RowSet::source_data(&slices),
    };
    let rows = match rows {
        Ok(r) => r,
        Err(e) => {
            expect_kind(
                "RowSet",
                &e,
                &[Kind::Empty, Kind::NonFinite, Kind::Capacity],
            );
            return;
        }
    };
    let approximator: awfqi::fqi::Approximator<T, 2> = match b.u8() % 6 {
        5 => {
            let rewards = [
                awfqi::fqi::RewardModel::PerAction,
                awfqi::fqi::RewardModel::Pooled,
                awfqi::fqi::RewardModel::Backfilled,
            ][usize::from(b.u8() % 3)];
            let min_mass = if b.bool() { real(b) } else { T::ZERO };
            let lookahead = b.bool();
            match ModelSweep::cube(T::ZERO, T::from_f64(10.0), b.index(6))
                .and_then(|s| s.with_min_mass(min_mass))
            {
                Ok(s) => s.with_rewards(rewards).with_lookahead(lookahead).into(),
                Err(e) => {
                    expect_kind("ModelSweep", &e, &[Kind::Invalid]);
                    return;
                }
            }
        }
        0 => match Tilings::cube(T::ZERO, T::from_f64(10.0), b.index(4), b.index(4)) {
            Ok(t) => t.into(),
            Err(e) => {
                expect_kind("Tilings::cube", &e, &[Kind::Invalid]);
                return;
            }
        },
        1 => CellGrid::cube(T::ZERO, T::from_f64(10.0), 1 + b.index(4))
            .expect("a valid cube")
            .into(),
        4 => {
            let (trees, nodes) = (b.index(6), b.index(40));
            let (split, leaf) = (b.index(4), b.index(3));
            let forests = if b.bool() {
                ExtraTrees::streamed(trees, nodes)
            } else {
                ExtraTrees::new(trees, nodes)
            };
            match forests.and_then(|f| f.with_min_samples(split, leaf)) {
                Ok(f) => f.into(),
                Err(e) => {
                    expect_kind("ExtraTrees", &e, &[Kind::Invalid]);
                    return;
                }
            }
        }
        _ => {
            let kernel = if b.bool() {
                Kernel::Gaussian(real(b))
            } else {
                Kernel::Uniform
            };
            let reach = b.bool().then(|| real::<T>(b));
            let common = b.bool();
            let nb = Neighbours::cube(b.index(8), T::ZERO, T::from_f64(10.0), kernel)
                .and_then(|n| reach.map_or(Ok(n), |r| n.with_reach(r)))
                .map(|n| if common { n.with_common_ball() } else { n });
            let tilings = b
                .bool()
                .then(|| Tilings::cube(T::ZERO, T::from_f64(10.0), 1 + b.index(3), 1 + b.index(3)));
            match (nb, tilings) {
                (Ok(n), None) => n.into(),
                (Ok(n), Some(Ok(t))) => awfqi::fqi::Approximator::Hybrid(t, n),
                (Ok(_), Some(Err(e))) => {
                    expect_kind("Tilings::cube", &e, &[Kind::Invalid]);
                    return;
                }
                (Err(e), _) => {
                    expect_kind("Neighbours", &e, &[Kind::Invalid, Kind::NonFinite]);
                    return;
                }
            }
        }
    };

    // The kernel's memory.
    let budget = config.awfqi.budget;
    let steps = 1 + b.index(3);
    let slots = config.candidates.min(rows.len());
    let needed = approximator
        .required_entries(4)
        .unwrap_or(usize::MAX)
        .min(1 << 14);
    let mut samples = vec![Transition::EMPTY; size(b, steps * budget)];
    let mut weights = vec![T::ZERO; size(b, total)];
    let mut candidates = vec![Candidate::EMPTY; size(b, slots)];
    let mut fqi = vec![FqiEntry::EMPTY; size(b, needed)];
    // Kernel averaging: one record slot per target and source record, and their links;
    // trees: as many record slots, and their nodes.
    let (records_needed, links_needed, nodes_needed) = match approximator {
        awfqi::fqi::Approximator::Knn(nb) | awfqi::fqi::Approximator::Hybrid(_, nb) => {
            let r = samples.len() + total;
            (
                r,
                nb.required_links(r, 4).unwrap_or(usize::MAX).min(1 << 16),
                0,
            )
        }
        awfqi::fqi::Approximator::Trees(f) => (
            samples.len() + total,
            0,
            f.required_nodes(4).unwrap_or(usize::MAX).min(1 << 14),
        ),
        _ => (0, 0, 0),
    };
    let trees = matches!(approximator, awfqi::fqi::Approximator::Trees(_));
    let (sweep_entries, sweep_nodes) = match approximator {
        awfqi::fqi::Approximator::Sweep(s) => (s.required_entries(4).unwrap_or(0), s.nodes()),
        _ => (0, 0),
    };
    let mut sweep_entries = vec![awfqi::fqi::SweepEntry::EMPTY; size(b, sweep_entries)];
    let mut sweep_nodes = vec![awfqi::fqi::SweepNode::EMPTY; size(b, sweep_nodes)];
    let record_slots = size(b, records_needed);
    let mut records = vec![KnnRecord::EMPTY; if trees { 0 } else { record_slots }];
    let mut links = vec![0u16; size(b, links_needed)];
    let mut tree_records = vec![TreeRecord::EMPTY; if trees { record_slots } else { 0 }];
    let mut nodes = vec![TreeNode::EMPTY; size(b, nodes_needed)];
    let mut path = vec![[T::ZERO; 2]; size(b, budget)];
    let mut beliefs = vec![SourceBelief::EMPTY; size(b, slices.len())];
    let buffers = AdaptiveBuffers {
        gp: &mut gp,
        samples: &mut samples,
        weights: &mut weights,
        candidates: &mut candidates,
        fqi: QStorage {
            entries: &mut fqi,
            records: &mut records,
            links: &mut links,
            tree_records: &mut tree_records,
            nodes: &mut nodes,
            sweep_entries: &mut sweep_entries,
            sweep_nodes: &mut sweep_nodes,
            ..QStorage::default()
        },
        path: &mut path,
        beliefs: &mut beliefs,
    };
    let mut kernel =
        match AdaptiveAwfqi::new(config, approximator, data, &means, rows, target, buffers) {
            Ok(k) => k,
            Err(e) => {
                expect_kind("AdaptiveAwfqi::new", &e, ANY);
                return;
            }
        };
    trace!("built: {} rows, {} source records", rows.len(), total);
    if b.bool() {
        if let Err(e) = kernel.plan(&mut rng) {
            expect_kind("plan", &e, ANY);
            assert_eq!(kernel.steps(), 0);
        }
    }
    for round in 0..2 {
        for _ in 0..steps + 1 {
            let done = kernel.steps();
            let len = kernel.target_samples().len();
            match kernel.step(&mut rng) {
                Ok(report) => {
                    trace!("step {}: {report:?}", report.step);
                    assert_eq!(report.step, done + 1);
                    assert_eq!(kernel.target_samples().len(), len + budget);
                    assert_eq!(report.n_target_samples, len + budget);
                    finite("step", "wr_mean", report.wr_mean.to_f64());
                    finite("step", "wr_eff", report.wr_eff.to_f64());
                    for e in kernel.q().entries() {
                        finite("step", "q", e.q().to_f64());
                    }
                    for s in [[0.0, 0.0], [3.3, 7.1], [10.0, 10.0]] {
                        let v = kernel.q().max_value(s.map(T::from_f64));
                        finite("step", "max q", v.expect("a finite state").to_f64());
                    }
                    for &w in kernel.reward_weights() {
                        finite("step", "weight", w.to_f64());
                    }
                    for &y in kernel.relabelled_rewards() {
                        finite("step", "relabelled reward", y.to_f64());
                    }
                    let sum: f64 = kernel
                        .beliefs()
                        .iter()
                        .map(|b| b.plausibility.to_f64())
                        .sum();
                    assert!((sum - 1.0).abs() < 1e-3, "beliefs sum to {sum}");
                }
                Err(e) => {
                    trace!("step error {e:?}");
                    expect_kind("step", &e, ANY);
                    assert_eq!(kernel.steps(), done, "a failed step advanced the count");
                    if let Error::CapacityExceeded { .. } = e {
                        // The only capacity a step can lack is D₀'s, refused up front —
                        // or, for kernel averaging and trees, the record slots of a re-plan.
                        if record_slots >= records_needed {
                            assert_eq!(kernel.target_samples().len(), len);
                        }
                    }
                }
            }
        }
        if round == 0 {
            kernel.reset();
            assert_eq!(kernel.steps(), 0);
            assert!(kernel.target_samples().is_empty());
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    if b.bool() {
        run::<f32>(&mut b);
    } else {
        run::<f64>(&mut b);
    }
});
