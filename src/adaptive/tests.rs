extern crate std;
use super::replan::relabel_rewards;
use super::*;
use crate::env::{Dynamics, Puddle, PuddleWorld};
use crate::fqi::{CellGrid, EmptyCells, FqiConfig, FqiEntry, RewardModel};
use crate::gp::{Hyperparameters, SearchOptions};
use crate::record_gp::{GpTraining, SubsetRule, input};
use crate::score::PointGrid;
use crate::thesis::SourceScales;
use crate::weights::NoiseSubtraction;
use crate::weights::Posterior;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;
use std::vec;
use std::vec::Vec;

type Record = Transition<[f64; 2], f64>;
const GP: usize = 16;

/// Generative-model records of `world` at pseudo-random states.
fn query_records(world: &PuddleWorld<f64>, n: usize, seed: u64) -> Vec<Record> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let s = [
                crate::rng::uniform::<f64, _>(&mut rng) * 10.0,
                crate::rng::uniform::<f64, _>(&mut rng) * 10.0,
            ];
            world.query(s, i % 4, &mut rng).unwrap()
        })
        .collect()
}

fn training() -> GpTraining<f64, 3> {
    GpTraining {
        search: SearchOptions {
            max_evaluations: 40,
            restarts: 1,
            isotropic: true,
        },
        ..GpTraining::published()
    }
}

fn config(budget: usize) -> AdaptiveConfig<f64, 2, 3> {
    let mut c = AdaptiveConfig::recommended(budget, [0.0, 0.0], 50, 0.3, [(0.0, 10.0); 2]);
    c.awfqi.gp_training = training();
    c.awfqi.fqi = FqiConfig::new(0.99, 20, EmptyCells::Nearest).unwrap();
    c.verify = 0.5;
    // Three sub-batches whatever the budget (the schedule rule gives one below 16 queries).
    c.sub_batches = 3;
    c.candidates = 40;
    c
}

/// Sources, their oracle posteriors (std 0.05) and their reward mean functions.
struct Fixture {
    sources: Vec<Vec<Record>>,
    posteriors: Vec<Posterior<f64>>,
    means: Vec<MeanFunction<f64, GP, 3>>,
}

impl Fixture {
    fn new(worlds: &[PuddleWorld<f64>]) -> Self {
        let sources: Vec<Vec<Record>> = worlds
            .iter()
            .enumerate()
            .map(|(k, w)| query_records(w, 40, k as u64))
            .collect();
        let posteriors = worlds
            .iter()
            .zip(&sources)
            .flat_map(|(w, rs)| {
                rs.iter()
                    .map(|r| Posterior::new(w.mean_reward(r.state).unwrap(), 0.05))
            })
            .collect();
        let mut gp = std::boxed::Box::new(Gp::<f64, GP, 3>::empty());
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let means = sources
            .iter()
            .map(|rs| {
                let mut f = MeanFunction::EMPTY;
                f.fit_rewards(&mut gp, rs, &training(), SubsetRule::Spread, &mut rng)
                    .unwrap();
                f
            })
            .collect();
        Self {
            sources,
            posteriors,
            means,
        }
    }

    fn slices(&self) -> Vec<&[Record]> {
        self.sources.iter().map(Vec::as_slice).collect()
    }
}

// Storage for budget 12 × 3 steps, 120 source records, 40 slots, 6 × 6 cells, 3 sources.
crate::adaptive_storage! {
    struct Storage {
        scalar: f64,
        state_dim: 2,
        actions: 4,
        gp_points: GP,
        steps: 3,
        budget: 12,
        sources: 3,
        source_records: 120,
        source_posteriors: 120,
        candidates: 40,
        table_entries: 144,
    }
}

crate::adaptive_storage! {
    struct ShortWeights {
        scalar: f64,
        state_dim: 2,
        actions: 4,
        gp_points: GP,
        steps: 3,
        budget: 12,
        sources: 3,
        source_records: 119,
        source_posteriors: 119,
        candidates: 40,
        table_entries: 144,
    }
}

crate::adaptive_storage! {
    struct OneStep {
        scalar: f64,
        state_dim: 2,
        actions: 4,
        gp_points: GP,
        steps: 1,
        budget: 12,
        sources: 3,
        source_records: 120,
        source_posteriors: 120,
        candidates: 40,
        table_entries: 144,
    }
}

crate::adaptive_storage! {
    struct TwoSources {
        scalar: f64,
        state_dim: 2,
        actions: 4,
        gp_points: GP,
        steps: 2,
        budget: 12,
        sources: 2,
        source_records: 80,
        source_posteriors: 80,
        candidates: 40,
        table_entries: 144,
    }
}

crate::adaptive_storage! {
    struct NoTable {
        scalar: f64,
        state_dim: 2,
        actions: 4,
        gp_points: GP,
        steps: 3,
        budget: 12,
        sources: 3,
        source_records: 120,
        source_posteriors: 120,
        candidates: 40,
        table_entries: 0,
    }
}

fn rows() -> RowSet<'static, f64, 2> {
    RowSet::grid(PointGrid::spanning([0.0; 2], [10.0; 2], 2.0).unwrap(), 4).unwrap()
}

fn grid() -> CellGrid<f64, 2> {
    CellGrid::cube(0.0, 10.0, 6).unwrap()
}

#[test]
fn a_mean_function_predicts_its_gps_mean_from_k_inverse_y() {
    let records = query_records(&PuddleWorld::target(Dynamics::Shared), 30, 3);
    let mut gp = Gp::<f64, GP, 3>::empty();
    let mut f = MeanFunction::<f64, GP, 3>::EMPTY;
    assert_eq!(f.mean(&[1.0, 2.0, 0.0]), Ok(0.0));
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    f.fit_rewards(&mut gp, &records, &training(), SubsetRule::Spread, &mut rng)
        .unwrap();
    assert_eq!(f.len(), GP);
    // α solves (K + (σ²ₙ + jitter) I) α = y: check the residual by hand.
    let mut alpha = [0.0; GP];
    assert_eq!(gp.mean_weights(&mut alpha), Ok(GP));
    let h = *gp.hyperparameters();
    let diag = h.noise_variance + gp.jitter();
    for (i, (xi, yi)) in gp.inputs().iter().zip(gp.targets()).enumerate() {
        let k_alpha: f64 = gp
            .inputs()
            .iter()
            .zip(&alpha)
            .map(|(xj, a)| h.covariance(xi, xj) * a)
            .sum::<f64>()
            + diag * alpha[i];
        assert!(
            (k_alpha - yi).abs() < 1e-8 * (1.0 + yi.abs()),
            "{k_alpha} {yi}"
        );
    }
    for r in query_records(&PuddleWorld::target(Dynamics::Shared), 20, 4) {
        let z = input(r.state, r.action);
        let want = gp.predict(&z).unwrap().mean;
        assert!((f.mean(&z).unwrap() - want).abs() < 1e-9 * (1.0 + want.abs()));
    }
    assert!(f.mean(&[f64::NAN, 0.0, 0.0]).is_err());
    let mut short = [0.0; 3];
    assert_eq!(
        gp.mean_weights(&mut short),
        Err(Error::CapacityExceeded { capacity: 3 })
    );
}

#[test]
fn invalid_settings_are_named() {
    let ok = config(12);
    assert!(ok.validate().is_ok());
    let cases: [(AdaptiveConfig<f64, 2, 3>, Error); 7] = [
        (
            AdaptiveConfig {
                sub_batches: 0,
                ..ok
            },
            Error::InvalidParameter {
                parameter: "sub_batches",
            },
        ),
        (
            AdaptiveConfig { horizon: 0, ..ok },
            Error::InvalidParameter {
                parameter: "horizon",
            },
        ),
        (
            AdaptiveConfig { verify: 1.5, ..ok },
            Error::OutOfRange {
                parameter: "verify",
            },
        ),
        (
            AdaptiveConfig {
                floor: f64::NAN,
                ..ok
            },
            Error::NonFinite { parameter: "floor" },
        ),
        (
            AdaptiveConfig {
                relevance_width: 0.0,
                ..ok
            },
            Error::OutOfRange {
                parameter: "relevance_width",
            },
        ),
        (
            AdaptiveConfig {
                bounds: [(0.0, 10.0), (3.0, 3.0)],
                ..ok
            },
            Error::OutOfRange {
                parameter: "bounds",
            },
        ),
        (
            AdaptiveConfig {
                awfqi: AwfqiConfig {
                    budget: 0,
                    ..ok.awfqi
                },
                ..ok
            },
            Error::InvalidParameter {
                parameter: "budget",
            },
        ),
    ];
    for (c, e) in cases {
        assert_eq!(c.validate().map(|_| ()), Err(e));
    }
}

#[test]
fn construction_checks_the_parts_before_anything_changes() {
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let sources = SourceData::new(&slices, &fx.posteriors).unwrap();
    let target = PuddleWorld::target(Dynamics::Shared);
    let valid = config(12).validate().unwrap();
    let mut storage = std::boxed::Box::new(Storage::new());
    let e = AdaptiveAwfqi::new(
        valid,
        grid(),
        sources,
        &fx.means[..2],
        rows(),
        target,
        &mut *storage,
    );
    assert_eq!(
        e.err(),
        Some(Error::InvalidParameter { parameter: "means" })
    );
    let mut small = std::boxed::Box::new(ShortWeights::new());
    let e = AdaptiveAwfqi::new(
        valid,
        grid(),
        sources,
        &fx.means,
        rows(),
        target,
        &mut *small,
    );
    assert_eq!(
        e.err(),
        Some(Error::BufferTooSmall {
            buffer: "weights (`source_records`: one per source record)",
            capacity: 119,
            needed: 120,
        })
    );
    let pairs = [([1.0, 1.0], 4)];
    let e = AdaptiveAwfqi::new(
        valid,
        grid(),
        sources,
        &fx.means,
        RowSet::pairs(&pairs).unwrap(),
        target,
        &mut *storage,
    );
    assert_eq!(
        e.err(),
        Some(Error::OutOfRange {
            parameter: "actions"
        })
    );
}

#[test]
fn a_step_spends_its_budget_on_verified_paths_and_drawn_rows() {
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let sources = SourceData::new(&slices, &fx.posteriors).unwrap();
    let valid = config(12).validate().unwrap();
    let target = PuddleWorld::target(Dynamics::Shared);
    let mut storage = std::boxed::Box::new(Storage::new());
    let mut kernel = AdaptiveAwfqi::new(
        valid,
        grid(),
        sources,
        &fx.means,
        rows(),
        target,
        &mut *storage,
    )
    .unwrap();
    // The first verification follows the plan fitted on the unweighted sources alone.
    let mut entries = vec![FqiEntry::EMPTY; 144];
    let mut q = Approximator::from(grid())
        .build(4, &mut entries[..])
        .unwrap();
    let sets: Vec<_> = slices
        .iter()
        .map(|s| crate::fqi::SampleSet::unweighted(s))
        .collect();
    q.fit(&sets, &valid.awfqi.fqi, &mut ChaCha8Rng::seed_from_u64(0))
        .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let report = kernel.step(&mut rng).unwrap();
    assert_eq!((report.step, report.n_target_samples), (1, 12));
    assert_eq!(report.n_source_samples, 120);
    let d0 = kernel.target_samples().to_vec();
    assert_eq!(d0.len(), 12);
    assert_eq!(d0[0].action, q.greedy_action([0.0, 0.0]).unwrap());
    // Quotas 4, 4, 4, half verified: records 0–1, 4–5, 8–9 are rollouts from the start;
    // the others are drawn grid rows (coordinates multiples of 2).
    let mut path = Vec::new();
    for b in 0..3 {
        let first = d0[4 * b];
        assert_eq!(first.state, [0.0, 0.0]);
        if !first.absorbing {
            assert_eq!(d0[4 * b + 1].state, first.next_state);
        }
        path.extend([d0[4 * b].state, d0[4 * b + 1].state]);
        for r in &d0[4 * b + 2..4 * b + 4] {
            assert!(r.state.iter().all(|x| x % 2.0 == 0.0), "{:?}", r.state);
        }
    }
    assert_eq!(kernel.path(), &path[..]);
    // Every weight is a valid weight (no relabelling in the recommended configuration),
    // the beliefs a distribution.
    assert!(kernel.relabelled_rewards().is_empty());
    assert_eq!(kernel.reward_weights().len(), 120);
    assert!(
        kernel
            .reward_weights()
            .iter()
            .all(|w| w.is_finite() && *w >= 0.0 && *w <= 1000.0)
    );
    let total: f64 = kernel.beliefs().iter().map(|b| b.plausibility).sum();
    assert!((total - 1.0).abs() < 1e-12);
    // The residual GP holds the target records' residuals: 12 points.
    assert_eq!(kernel.gp().len(), 12);

    // Same seed, fresh run: the same records.
    kernel.reset();
    assert!(kernel.target_samples().is_empty());
    kernel.step(&mut ChaCha8Rng::seed_from_u64(5)).unwrap();
    assert_eq!(kernel.target_samples(), &d0[..]);
}

#[test]
fn a_full_buffer_refuses_the_step_before_any_query() {
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let sources = SourceData::new(&slices, &fx.posteriors).unwrap();
    let valid = config(12).validate().unwrap();
    let mut storage = std::boxed::Box::new(OneStep::new());
    let mut kernel = AdaptiveAwfqi::new(
        valid,
        grid(),
        sources,
        &fx.means,
        rows(),
        PuddleWorld::target(Dynamics::Shared),
        &mut *storage,
    )
    .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    kernel.step(&mut rng).unwrap();
    let before = kernel.target_samples().to_vec();
    let beliefs = kernel.beliefs().to_vec();
    assert_eq!(
        kernel.step(&mut rng).err(),
        Some(Error::BufferTooSmall {
            buffer: "samples (`steps` × `budget` target records)",
            capacity: 12,
            needed: 24,
        })
    );
    assert_eq!(kernel.target_samples(), &before[..]);
    assert_eq!(kernel.beliefs(), &beliefs[..]);
    assert_eq!(kernel.steps(), 1);
}

#[test]
fn the_source_that_answers_like_the_target_becomes_plausible() {
    // Source 0 is the target itself; source 1 has a deep puddle on the start, where every
    // verification begins, so its rewards there contradict the target's.
    let target = PuddleWorld::target(Dynamics::Shared);
    let wrong = PuddleWorld::new(
        [5.0, 10.0],
        &[Puddle::new([0.5, 0.5], 0.8)],
        Dynamics::Shared,
    )
    .unwrap();
    let fx = Fixture::new(&[target, wrong]);
    let slices = fx.slices();
    let sources = SourceData::new(&slices, &fx.posteriors).unwrap();
    let valid = config(12).validate().unwrap();
    let mut storage = std::boxed::Box::new(TwoSources::new());
    let mut kernel = AdaptiveAwfqi::new(
        valid,
        grid(),
        sources,
        &fx.means,
        rows(),
        target,
        &mut *storage,
    )
    .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    kernel.step(&mut rng).unwrap();
    kernel.step(&mut rng).unwrap();
    let b = kernel.beliefs();
    assert!(b[0].squared_errors < b[1].squared_errors, "{b:?}");
    assert!(b[0].plausibility > 0.99, "{b:?}");
    // The beliefs are exactly the clipped likelihood of the records' errors.
    let mut expect = [SourceBelief::<f64>::EMPTY; 2];
    for r in kernel.target_samples() {
        let z = input(r.state, r.action);
        for (k, e) in expect.iter_mut().enumerate() {
            let ends = plausibility::nearest_ends(slices[k], &r.state, r.action, &[(0.0, 10.0); 2]);
            e.squared_errors += plausibility::clipped_error(
                r.reward,
                fx.means[k].mean(&z).unwrap(),
                ends == r.absorbing,
                0.1,
            );
        }
    }
    for (e, b) in expect.iter().zip(b) {
        assert!((e.squared_errors - b.squared_errors).abs() < 1e-9);
    }
}

#[test]
fn kernel_averaging_plans_on_d0_and_the_relabelled_sources() {
    // The kNN approximator in the loop: the first verification follows the kNN plan on the
    // unweighted sources, and after a step the kernel's Q is the kNN fit on D₀ and the
    // sources with the relabelled rewards the kernel reports (rebuilt here independently).
    use crate::fqi::{Kernel, KnnStorage, Neighbours, SampleSet};
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let mut c = config(12);
    c.relabel = true;
    let valid = c.validate().unwrap();
    let nb = Neighbours::cube(3, 0.0, 10.0, Kernel::Gaussian(0.1)).unwrap();
    let mut storage = std::boxed::Box::new(NoTable::new());
    let mut knn = std::boxed::Box::new(KnnStorage::<f64, 2, 156, { 156 * 4 * 3 }>::new());
    let mut buffers = storage.buffers();
    buffers.fqi = knn.storage();
    let mut kernel = AdaptiveAwfqi::new(
        valid,
        nb,
        SourceData::new(&slices, &fx.posteriors).unwrap(),
        &fx.means,
        rows(),
        PuddleWorld::target(Dynamics::Shared),
        buffers,
    )
    .unwrap();
    let mut reference = KnnStorage::<f64, 2, 156, { 156 * 4 * 3 }>::new();
    let mut q = Approximator::from(nb)
        .build(4, reference.storage())
        .unwrap();
    let plain: Vec<_> = slices.iter().map(|s| SampleSet::unweighted(s)).collect();
    q.fit(&plain, &valid.awfqi.fqi, &mut ChaCha8Rng::seed_from_u64(0))
        .unwrap();
    kernel.step(&mut ChaCha8Rng::seed_from_u64(5)).unwrap();
    let d0 = kernel.target_samples().to_vec();
    assert_eq!(d0[0].action, q.greedy_action([0.0, 0.0]).unwrap());
    // Relabelling: every source weight 1, rewards replaced.
    let y = kernel.relabelled_rewards().to_vec();
    assert_eq!(y.len(), 120);
    let mut sets = vec![SampleSet::unweighted(&d0)];
    let mut offset = 0;
    for s in &slices {
        sets.push(SampleSet::unweighted(s).with_rewards(Some(&y[offset..offset + s.len()])));
        offset += s.len();
    }
    q.fit(&sets, &valid.awfqi.fqi, &mut ChaCha8Rng::seed_from_u64(0))
        .unwrap();
    for x in [0.0, 1.3, 4.0, 7.7, 9.9] {
        for y in [0.0, 2.5, 6.1, 9.5] {
            for a in 0..4 {
                assert_eq!(kernel.q().value([x, y], a), q.value([x, y], a));
            }
        }
    }

    // Too few record slots: refused at the first plan, before any query.
    let mut small = KnnStorage::<f64, 2, 100, { 100 * 4 * 3 }>::new();
    let mut buffers = storage.buffers();
    buffers.fqi = small.storage();
    let mut kernel = AdaptiveAwfqi::new(
        valid,
        nb,
        SourceData::new(&slices, &fx.posteriors).unwrap(),
        &fx.means,
        rows(),
        PuddleWorld::target(Dynamics::Shared),
        buffers,
    )
    .unwrap();
    assert_eq!(
        kernel.step(&mut ChaCha8Rng::seed_from_u64(5)).err(),
        Some(Error::CapacityExceeded { capacity: 100 })
    );
    assert!(kernel.target_samples().is_empty());
}

#[test]
fn with_relabelling_the_sources_keep_weight_one_and_get_relabelled_rewards() {
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let mut c = config(12);
    c.relabel = true;
    let mut storage = std::boxed::Box::new(Storage::new());
    let mut kernel = AdaptiveAwfqi::new(
        c.validate().unwrap(),
        grid(),
        SourceData::new(&slices, &fx.posteriors).unwrap(),
        &fx.means,
        rows(),
        PuddleWorld::target(Dynamics::Shared),
        &mut *storage,
    )
    .unwrap();
    assert!(
        kernel.relabelled_rewards().is_empty(),
        "nothing relabelled before a step"
    );
    let report = kernel.step(&mut ChaCha8Rng::seed_from_u64(5)).unwrap();
    // No weights (every one is 1, the report says so), one finite reward per source
    // record, some of them moved by the target's answers.
    assert!(kernel.reward_weights().is_empty());
    assert_eq!(report.wr_mean, 1.0);
    let relabelled = kernel.relabelled_rewards();
    assert_eq!(relabelled.len(), 120);
    assert!(relabelled.iter().all(|y| y.is_finite()));
    let own: Vec<f64> = slices
        .iter()
        .flat_map(|s| s.iter().map(|r| r.reward))
        .collect();
    assert!(own.iter().zip(relabelled).any(|(r, y)| r != y));
    // reset forgets them.
    kernel.reset();
    assert!(kernel.relabelled_rewards().is_empty());
}

#[test]
fn relabelling_keeps_uncontradicted_rewards_and_replaces_contradicted_ones() {
    let v = 0.01;
    // Exact agreement: λ = 1.
    assert_eq!(relabelled_reward(-1.0, -1.0, 0.3, v), -1.0);
    // By hand: r = −1, μ = −2, σ² + v = 0.25 + 0.75 = 1, u = 1, λ = e^{−1/2}.
    let lambda = (-0.5f64).exp();
    let want = -lambda - 2.0 * (1.0 - lambda);
    assert!((relabelled_reward(-1.0, -2.0, 0.5, 0.75) - want).abs() < 1e-15);
    // A confident puddle (μ = −10, σ = 0.1) replaces a dry reward: u ≈ 64, λ ≈ 0.
    assert!((relabelled_reward(-1.0, -10.0, 0.1, v) + 10.0).abs() < 1e-12);
    // An unsure target (σ = 30) keeps it: u ≈ 0.3, λ ≈ 0.96.
    assert!((relabelled_reward(-1.0, -10.0, 30.0, v) + 1.0).abs() < 0.5);
}

#[test]
fn the_median_of_odd_even_tied_and_empty_rewards() {
    let with = |rewards: &[f64]| -> Vec<Record> {
        rewards
            .iter()
            .map(|&reward| Transition {
                state: [0.0; 2],
                action: 0,
                reward,
                next_state: [0.0; 2],
                absorbing: false,
            })
            .collect()
    };
    assert_eq!(median(&with(&[])), 0.0);
    assert_eq!(median(&with(&[3.0, -1.0, 2.0])), 2.0);
    assert_eq!(median(&with(&[4.0, -1.0, 2.0, -10.0])), 0.5);
    assert_eq!(median(&with(&[-1.0, -1.0, -10.0, -1.0])), -1.0);
    assert_eq!(median(&with(&[-10.0, -1.0, -10.0, -1.0])), -5.5);
}

#[test]
fn relabelled_source_rewards_follow_the_target_gp_in_closed_form() {
    // A target GP with one point at z₀ (y = −9 around a centre of −1, so a −10 reward
    // there) and tiny noise: at z₀ its mean is ≈ −9 (+ centre = −10) and its posterior std
    // ≈ 0, so a dry −1 source reward at z₀ becomes ≈ −10; far from z₀ the mean is the
    // centre and the std √c = 1 (principled noise subtraction), so a −1 reward is kept
    // and a −3 one moves by the closed-form λ with u = 2/√(1 + v).
    let hyper = Hyperparameters::isotropic(1.0, 0.5, 1e-6);
    let mut gp = Gp::<f64, GP, 3>::new(hyper).unwrap();
    let z0 = input([2.0, 2.0], 1);
    gp.fit(&[z0], &[-9.0]).unwrap();
    let rec = |state: [f64; 2], reward: f64| Transition {
        state,
        action: 1,
        reward,
        next_state: state,
        absorbing: false,
    };
    let near = [rec([2.0, 2.0], -1.0)];
    let far = [rec([9.0, 9.0], -1.0), rec([9.0, 1.0], -3.0)];
    let records: [&[Record]; 2] = [&near, &far];
    let posteriors = [Posterior::new(0.0, 0.1); 3];
    let sources = SourceData::new(&records, &posteriors).unwrap();
    let v = 0.01;
    let mut out = [0.0; 3];
    relabel_rewards(
        &gp,
        &sources,
        -1.0,
        v,
        NoiseSubtraction::Principled,
        &mut out,
    )
    .unwrap();
    assert!((out[0] + 10.0).abs() < 1e-3, "{out:?}");
    assert!((out[1] + 1.0).abs() < 1e-9, "{out:?}");
    let u = 2.0 / (1.0 + v).sqrt();
    let lambda = (-0.5 * u * u).exp();
    assert!(
        (out[2] - (-3.0 * lambda - (1.0 - lambda))).abs() < 1e-9,
        "{out:?}"
    );
    // Too short an output: refused.
    assert_eq!(
        relabel_rewards(
            &gp,
            &sources,
            -1.0,
            v,
            NoiseSubtraction::Principled,
            &mut out[..2]
        ),
        Err(Error::CapacityExceeded { capacity: 2 })
    );
}

crate::adaptive_storage! {
    struct Built {
        scalar: f64,
        state_dim: 2,
        actions: 4,
        gp_points: GP,
        steps: 2,
        budget: 12,
        sources: 3,
        source_records: 120,
        source_posteriors: 120,
        candidates: 40,
        sweep_cells: 6,
    }
}

// Room for 99 target samples.
crate::adaptive_storage! {
    struct NinetyNine {
        scalar: f64,
        state_dim: 2,
        actions: 4,
        gp_points: GP,
        steps: 1,
        budget: 99,
        sources: 3,
        source_records: 120,
        source_posteriors: 120,
        candidates: 40,
        sweep_cells: 6,
    }
}

#[test]
fn the_builder_derives_the_settings_fits_the_sources_once_and_runs_its_steps() {
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let mut memory = std::boxed::Box::new(Built::new());
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let target = PuddleWorld::target(Dynamics::Shared);
    let mut kernel = AdaptiveAwfqi::builder(target, &slices, 12, [(0.0, 10.0); 2], [0.0, 0.0])
        .rewards(RewardModel::Pooled)
        .configure(|c| c.awfqi.gp_training = training())
        .build(&mut *memory, &mut rng)
        .unwrap();
    // Settings: the scaled ones for these records, the builder's inputs, the rules.
    let scales = SourceScales::measure(&slices).unwrap();
    let scaled = AwfqiConfig::<f64, 3>::scaled(12, &scales).unwrap();
    let c = kernel.config();
    assert_eq!(c.awfqi.weights, scaled.weights);
    assert_eq!(c.awfqi.gp_training, training());
    assert_eq!((c.budget(), c.horizon(), c.epsilon()), (12, 12, 0.3));
    assert_eq!((c.start(), c.bounds()), ([0.0; 2], [(0.0, 10.0); 2]));
    assert_eq!(c.candidates(), 40); // the block's slots
    // Rows: 4 per sweep cell and axis, both borders, every action.
    assert_eq!(kernel.rows().len(), 25 * 25 * 4);
    assert_eq!(kernel.rows().row(1), Some(([0.0, 0.0], 1)));
    let (next, action) = kernel.rows().row(4).unwrap();
    assert!((next[0] - 10.0 / 24.0).abs() < 1e-12 && next[1] == 0.0 && action == 0);
    // Each source fitted once, in order, from the caller's generator: the same fits by
    // hand give the same mean functions and stored posteriors.
    let mut by_hand = ChaCha8Rng::seed_from_u64(3);
    let mut gp = std::boxed::Box::new(Gp::<f64, GP, 3>::empty());
    let mut posteriors = vec![Posterior::EMPTY; 120];
    for ((source, mean), stored) in slices
        .iter()
        .zip(kernel.means())
        .zip(posteriors.chunks_mut(40))
    {
        let mut f = MeanFunction::EMPTY;
        f.fit_rewards(&mut gp, source, &training(), c.awfqi.subset, &mut by_hand)
            .unwrap();
        crate::record_gp::predict_posteriors(&gp, source, NoiseSubtraction::Reference, stored)
            .unwrap();
        assert_eq!(f.mean(&[3.0, 4.0, 1.0]), mean.mean(&[3.0, 4.0, 1.0]));
    }
    assert_eq!(kernel.sources().reward_posteriors(), &posteriors[..]);
    assert_eq!(rng, by_hand);
    // Two steps fit the block; a third has no room and says so before querying.
    kernel.step(&mut rng).unwrap();
    kernel.step(&mut rng).unwrap();
    assert_eq!(kernel.target_samples().len(), 24);
    assert!(matches!(
        kernel.step(&mut rng),
        Err(Error::BufferTooSmall { needed: 36, .. })
    ));
    assert_eq!(kernel.target_samples().len(), 24);
}

#[test]
fn a_target_buffer_with_room_for_99_of_100_samples_is_refused_before_the_first_step() {
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let mut memory = std::boxed::Box::new(NinetyNine::new());
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let target = PuddleWorld::target(Dynamics::Shared);
    let built = AdaptiveAwfqi::builder(target, &slices, 50, [(0.0, 10.0); 2], [0.0, 0.0])
        .steps(2)
        .build(&mut *memory, &mut rng);
    assert_eq!(
        built.err(),
        Some(Error::BufferTooSmall {
            buffer: crate::thesis::builder::buffer::SAMPLES,
            capacity: 99,
            needed: 100,
        })
    );
    // Refused before any source GP was fitted.
    assert_eq!(rng, ChaCha8Rng::seed_from_u64(3));
    // One step fits.
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let built = AdaptiveAwfqi::builder(target, &slices, 50, [(0.0, 10.0); 2], [0.0, 0.0])
        .steps(1)
        .configure(|c| c.awfqi.gp_training = training())
        .build(&mut *memory, &mut rng);
    assert_eq!(built.map(|k| k.steps()), Ok(0));
}

#[test]
fn verification_cycles_over_the_declared_starts_with_rollouts_of_the_rules_length() {
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let sources = SourceData::new(&slices, &fx.posteriors).unwrap();
    let valid = config(12).validate().unwrap();
    let target = PuddleWorld::target(Dynamics::Shared);
    let mut storage = std::boxed::Box::new(Storage::new());
    let kernel = AdaptiveAwfqi::new(
        valid,
        grid(),
        sources,
        &fx.means,
        rows(),
        target,
        &mut *storage,
    )
    .unwrap();
    let starts = [[0.5, 0.5], [7.5, 2.5], [2.5, 7.5]];
    assert_eq!(
        AdaptiveAwfqi::new(
            valid,
            grid(),
            SourceData::new(&slices, &fx.posteriors).unwrap(),
            &fx.means,
            rows(),
            PuddleWorld::target(Dynamics::Shared),
            &mut *std::boxed::Box::new(Storage::new()),
        )
        .unwrap()
        .with_starts(&[])
        .err(),
        Some(Error::EmptyData)
    );
    let mut kernel = kernel.with_starts(&starts).unwrap();
    assert_eq!(kernel.starts(), &starts[..]);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let report = kernel.step(&mut rng).unwrap();
    // 6 verification queries a step over 3 starts: rollouts of at most 2 steps; quotas of
    // 4 with 2 verified: sub-batch b verifies from start b.
    let d0 = kernel.target_samples().to_vec();
    for (b, start) in starts.iter().enumerate() {
        assert_eq!(&d0[4 * b].state, start);
        if !d0[4 * b].absorbing {
            assert_eq!(d0[4 * b + 1].state, d0[4 * b].next_state);
        }
    }
    // The next step starts again from the first start state.
    kernel.step(&mut rng).unwrap();
    assert_eq!(kernel.target_samples()[12].state, starts[0]);
    // The report carries the plan check: the target rewards' spread, a finite shortfall.
    assert!(report.reward_std > 0.0 && report.plan_shortfall.is_finite());
}

#[test]
fn fading_bounds_the_sources_weight_where_the_target_answered() {
    use super::fading::{FadeCell, Fading};
    let fx = Fixture::new(&PuddleWorld::sources(Dynamics::Shared));
    let slices = fx.slices();
    let valid = config(12).validate().unwrap();
    let run = |fading: Option<f64>| {
        let sources = SourceData::new(&slices, &fx.posteriors).unwrap();
        let mut storage = std::boxed::Box::new(Storage::new());
        let mut table = vec![FadeCell::EMPTY; 5 * 5 * 4];
        let kernel = AdaptiveAwfqi::new(
            valid,
            grid(),
            sources,
            &fx.means,
            rows(),
            PuddleWorld::target(Dynamics::Shared),
            &mut *storage,
        )
        .unwrap();
        let mut kernel = match fading {
            Some(k) => kernel
                .with_fading(
                    Fading {
                        pseudo_records: k,
                        cells: 5,
                    },
                    &mut table,
                )
                .unwrap(),
            None => kernel,
        };
        kernel.step(&mut ChaCha8Rng::seed_from_u64(5)).unwrap();
        (
            kernel.target_samples().to_vec(),
            kernel.reward_weights().to_vec(),
        )
    };
    let (_, plain) = run(None);
    let (d0, faded) = run(Some(0.5));
    // In every cell (5 per axis, per action) with a target record, the source weights of
    // the last re-plan sum to at most 0.5.
    let axis = |x: f64| ((x / 2.0) as usize).min(4);
    let cell = |s: [f64; 2], a: usize| (a * 5 + axis(s[0])) * 5 + axis(s[1]);
    let records: Vec<_> = slices.iter().flat_map(|s| s.iter()).collect();
    let mut answered_with_sources = 0;
    for r in &d0 {
        let c = cell(r.state, r.action);
        let mine: Vec<usize> = (0..records.len())
            .filter(|&i| cell(records[i].state, records[i].action) == c)
            .collect();
        let sum: f64 = mine.iter().map(|&i| faded[i]).sum();
        assert!(sum <= 0.5 + 1e-9, "cell {c}: {sum}");
        answered_with_sources += usize::from(!mine.is_empty());
    }
    assert!(answered_with_sources > 0);
    // Fading only lowers weights: in all, the sources weigh less than without it.
    assert!(faded.iter().sum::<f64>() < plain.iter().sum::<f64>());
}
