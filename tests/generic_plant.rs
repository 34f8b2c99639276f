//! The whole AWFQI loop at four state dimensions, on a toy plant whose optimal policy is
//! known in closed form: the generic path (records, GP inputs of dimension 5, realistic
//! score table, weights, a 4-D tabular FQI, evaluation) with nothing Puddle-specific.
//!
//! **The plant.** States `s ∈ [−1, 1]⁴`; action 0 moves every coordinate by −0.5, action 1
//! by +0.5 (clipped to the box, plus a little noise); the reward is `−(Σ s̄′ − c)² / 4` at the
//! mean next state `s̄′`, with set-point `c = 0` for the target. When `Σ s ≥ c + 1`, moving
//! down lowers the sum by 0.5 to 2 and moving up raises it (some coordinate is below 1), so
//! moving down gives the strictly better reward and a next state nearer the set-point, from
//! which the same holds again; symmetrically below. In closed form,
//! `π*(s) = 0 if Σ s ≥ c + 1, 1 if Σ s ≤ c − 1` (nearer the set-point the two moves overshoot
//! in turn and the comparison depends on the clipping; those cells are not checked).
//!
//! **The transfer.** Two sources: the same dynamics with `c = 0` (the target's twin) and
//! with `c = 1` (a shifted set-point). Their records are logged at every centre of the FQI
//! grid's cells with both actions, twice, in random order; the builder fits one reward GP
//! per source (64 points over `(s, a) ∈ ℝ⁵`), stores the posteriors and computes the
//! realistic score table over the same centres; AWFQI then spends 3 steps of 40 queries on
//! the target. FQI counts a (cell, action) pair as having data from a total reward weight of
//! 0.05 (not the Puddle World default 0.5): where the target GP is still uncertain the
//! twin's weights drop to a few tenths, and the cell should keep them.
//!
//! **How robust.** With this test's generator seeds 0–19 instead of its seed, 17 runs
//! recover π* in every checked cell and three miss one or two cells, all at `|Σ s| = 1`
//! (measured while writing the test; a 48-point GP instead of 64 missed 10–50 cells).

use awfqi::prelude::{
    Awfqi, AwfqiConfig, AwfqiStorage, CellGrid, EmptyCells, EvaluationProtocol, FqiConfig,
    GenerativeModel, PointGrid, Policy, Posterior, Real, RowSet, Scores, SourceMeans, SourceModel,
    Transition, evaluate,
};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

const D: usize = 4;
type T = f64;
type Record = Transition<[T; D], T>;

/// Step of every coordinate per action.
const STEP: f64 = 0.5;

/// The toy plant: set-point `c` of the sum of the coordinates.
#[derive(Debug, Clone, Copy)]
struct SumPlant {
    c: T,
}

impl SourceModel<T, D> for SumPlant {
    fn predict(&self, state: [T; D], action: usize) -> awfqi::Result<SourceMeans<T, D>> {
        if action > 1 {
            return Err(awfqi::Error::OutOfRange {
                parameter: "action",
            });
        }
        if state.iter().any(|x| !(-1.0..=1.0).contains(x)) {
            return Err(awfqi::Error::OutOfRange { parameter: "state" });
        }
        let step = if action == 0 { -STEP } else { STEP };
        let next_state = state.map(|x| (x + step).clamp(-1.0, 1.0));
        Ok(SourceMeans {
            reward: -(next_state.iter().sum::<T>() - self.c).powi(2) / 4.0,
            next_state,
        })
    }
}

impl GenerativeModel<T> for SumPlant {
    type State = [T; D];

    fn num_actions(&self) -> usize {
        2
    }

    fn query<R: Rng + ?Sized>(
        &self,
        state: [T; D],
        action: usize,
        rng: &mut R,
    ) -> awfqi::Result<Record> {
        let mean = self.predict(state, action)?;
        let mut noise = || awfqi::rng::normal(rng, 0.0, 0.05);
        let mut next_state = mean.next_state;
        for x in &mut next_state {
            *x = (*x + noise()?).clamp(-1.0, 1.0);
        }
        Ok(Transition {
            state,
            action,
            reward: mean.reward + noise()?,
            next_state,
            absorbing: false,
        })
    }
}

/// The closed-form optimal action of the target (`c = 0`), or `None` near the set-point.
fn optimal_action(state: &[T; D]) -> Option<usize> {
    let sum: T = state.iter().sum();
    if sum >= 1.0 {
        Some(0)
    } else if sum <= -1.0 {
        Some(1)
    } else {
        None
    }
}

/// The lattice of cell centres: 4 per axis, spacing 0.5 = one step.
fn lattice() -> PointGrid<T, D> {
    PointGrid::new([-0.75; D], [STEP; D], [CELLS; D]).unwrap()
}

/// `REPEATS` records of `plant` at every lattice point with every action, in a random
/// order (as data logged from a plant would be; an even spread of the records — the GPs'
/// subset rule — then does not follow the lattice's rows).
fn records(plant: &SumPlant, rng: &mut ChaCha8Rng) -> Vec<Record> {
    let lattice = lattice();
    let mut pairs: Vec<(usize, usize)> = (0..REPEATS)
        .flat_map(|_| (0..lattice.len()).flat_map(|p| [(p, 0), (p, 1)]))
        .collect();
    for i in (1..pairs.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        pairs.swap(i, j);
    }
    pairs
        .into_iter()
        .map(|(p, action)| plant.query(lattice.point(p).unwrap(), action, rng).unwrap())
        .collect()
}

/// Cells per axis of the FQI grid: 4⁴ = 256 cells of width 0.5 (one step), × 2 actions.
const CELLS: usize = 4;
/// Candidate rows: the 4⁴ lattice points × 2 actions.
const ROWS: usize = 256 * 2;
/// Records per lattice pair and source.
const REPEATS: usize = 2;
/// Records per source.
const PER_SOURCE: usize = REPEATS * ROWS;
const BUDGET: usize = 40;
/// Capacity of the GPs.
const GP_POINTS: usize = 64;
const STEPS: usize = 3;
/// The kernel's memory: GP of 64 points over (s, a) ∈ ℝ⁵, target samples, weights, alias
/// table, FQI table.
type Storage =
    AwfqiStorage<T, D, 5, GP_POINTS, { STEPS * BUDGET }, { 2 * PER_SOURCE }, ROWS, { 256 * 2 }>;

#[test]
fn awfqi_recovers_the_closed_form_policy_at_four_dimensions() {
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let sources = [SumPlant { c: 0.0 }, SumPlant { c: 1.0 }];
    let data: Vec<Vec<Record>> = sources.iter().map(|p| records(p, &mut rng)).collect();
    let slices: Vec<&[Record]> = data.iter().map(Vec::as_slice).collect();

    let mut storage = Box::new(Storage::new());
    let mut posteriors = vec![Posterior::default(); 2 * PER_SOURCE];
    let mut scores = vec![Scores::ZERO; ROWS];
    let mut config = AwfqiConfig::thesis(BUDGET);
    config.gp_training.search.max_evaluations = 120;
    config.gp_training.search.restarts = 2;
    config.fqi = FqiConfig::new(0.8, 30, EmptyCells::CappedNearest)
        .unwrap()
        .with_min_weight(0.05)
        .unwrap();
    let candidates = RowSet::grid(lattice(), 2).unwrap();
    assert_eq!(candidates.len(), ROWS);
    let target = SumPlant { c: 0.0 };
    let mut kernel = Awfqi::builder(
        config.validate().unwrap(),
        CellGrid::cube(-1.0, 1.0, CELLS).unwrap(),
        &slices,
        candidates,
    )
    .fit_posteriors(&mut posteriors)
    .realistic_scores(&mut scores)
    .build(target, &mut *storage, &mut rng)
    .unwrap();

    for step in 1..=STEPS {
        let report = kernel.step(&mut rng).unwrap();
        assert_eq!(report.n_target_samples, step * BUDGET);
        assert!(report.wr_eff > 0.0 && report.wr_eff.is_finite());
        assert_eq!(report.gp_hyperparameters.length_scales.len(), D + 1);
    }
    // The stored posteriors come from each source's reward GP: at the twin's records they
    // track its mean reward far better than a constant would.
    let twin = &kernel.sources().reward_posteriors()[..PER_SOURCE];
    let truth: Vec<T> = data[0]
        .iter()
        .map(|r| sources[0].predict(r.state, r.action).unwrap().reward)
        .collect();
    let mean_truth = truth.iter().sum::<T>() / truth.len() as T;
    let spread = truth.iter().map(|r| (r - mean_truth).abs()).sum::<T>();
    let error = twin
        .iter()
        .zip(&truth)
        .map(|(p, r)| (p.mean - r).abs())
        .sum::<T>();
    assert!(error < 0.3 * spread, "posterior error {error} vs {spread}");
    // Most of the twin's records keep a substantial weight, few of the shifted source's.
    let weights = kernel.reward_weights();
    let kept = |w: &[T]| w.iter().filter(|&&x| x > 0.5).count() as T / w.len() as T;
    let (twin, shifted) = (kept(&weights[..PER_SOURCE]), kept(&weights[PER_SOURCE..]));
    assert!(twin > 0.6 && shifted < 0.25, "kept {twin} vs {shifted}");

    // The greedy policy is π* in every cell whose centre is clearly on one side.
    let q = kernel.q();
    let grid = *q.as_tabular().unwrap().grid();
    let mut checked = 0;
    for cell in 0..grid.len() {
        let centre = grid.center(cell).unwrap();
        if let Some(best) = optimal_action(&centre) {
            assert_eq!(
                q.greedy_action(centre).unwrap(),
                best,
                "cell {cell} at {centre:?}"
            );
            checked += 1;
        }
    }
    assert!(checked >= 100, "only {checked} cells checked");

    // And its return from a far corner matches π*'s (common random numbers).
    let protocol = EvaluationProtocol {
        start: [1.0; D],
        rollouts: 5,
        horizon: 20,
        discount: 0.99,
    };
    let mut optimal = |s: &[T; D]| Ok(usize::from(s.iter().sum::<T>() < 0.0));
    let learned = evaluate(
        &target,
        &mut greedy(q),
        &protocol,
        &mut ChaCha8Rng::seed_from_u64(1),
    );
    let best = evaluate(
        &target,
        &mut optimal,
        &protocol,
        &mut ChaCha8Rng::seed_from_u64(1),
    );
    let (learned, best) = (learned.unwrap(), best.unwrap());
    assert!(
        learned.mean_return >= best.mean_return - 0.5,
        "greedy {} vs optimal {}",
        learned.mean_return,
        best.mean_return
    );
}

/// The greedy policy of a Q-function as a [`Policy`].
fn greedy<'q, T: Real, const D: usize>(
    q: &'q awfqi::fqi::QFunction<'_, T, D>,
) -> impl Policy<[T; D]> + 'q {
    move |s: &[T; D]| q.greedy_action(*s)
}

/// The same loop with tile coding instead of the table (3 tiles of width 2/3 per axis, 4
/// offset tilings: 4 · 4⁴ · 2 = 2 048 entries), in buffers sized at run time: the greedy
/// policy is π* at the lattice points clearly on one side of the set-point. (With this
/// test's generator seeds 0–9 instead of its seed, all 132 checked points were right in
/// every run, measured while writing the test.)
#[test]
fn awfqi_with_tile_coding_recovers_the_closed_form_policy_at_four_dimensions() {
    use awfqi::prelude::{AwfqiBuffers, FqiEntry, Gp, Tilings};
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let sources = [SumPlant { c: 0.0 }, SumPlant { c: 1.0 }];
    let data: Vec<Vec<Record>> = sources.iter().map(|p| records(p, &mut rng)).collect();
    let slices: Vec<&[Record]> = data.iter().map(Vec::as_slice).collect();
    let mut posteriors = vec![Posterior::default(); 2 * PER_SOURCE];
    let mut scores = vec![Scores::ZERO; ROWS];
    let mut config = AwfqiConfig::thesis(BUDGET);
    config.gp_training.search.max_evaluations = 120;
    config.gp_training.search.restarts = 2;
    config.fqi = FqiConfig::new(0.8, 30, EmptyCells::CappedNearest)
        .unwrap()
        .with_min_weight(0.05)
        .unwrap();
    let tilings = Tilings::cube(-1.0, 1.0, 3, 4).unwrap();
    let mut gp = Box::new(Gp::<T, GP_POINTS, 5>::empty());
    let mut samples = vec![Transition::EMPTY; STEPS * BUDGET];
    let mut weights = vec![0.0; 2 * PER_SOURCE];
    let mut alias = vec![awfqi::alias::AliasEntry::EMPTY; ROWS];
    let mut fqi = vec![FqiEntry::EMPTY; 4 * 256 * 2];
    let buffers = AwfqiBuffers {
        gp: &mut gp,
        samples: &mut samples,
        weights: &mut weights,
        alias: &mut alias,
        fqi: &mut fqi,
    };
    let mut kernel = Awfqi::builder(
        config.validate().unwrap(),
        tilings,
        &slices,
        RowSet::grid(lattice(), 2).unwrap(),
    )
    .fit_posteriors(&mut posteriors)
    .realistic_scores(&mut scores)
    .build(SumPlant { c: 0.0 }, buffers, &mut rng)
    .unwrap();
    for _ in 0..STEPS {
        kernel.step(&mut rng).unwrap();
    }
    let q = kernel.q();
    let lattice = lattice();
    let (mut checked, mut wrong) = (0, 0);
    for p in 0..lattice.len() {
        let point = lattice.point(p).unwrap();
        if let Some(best) = optimal_action(&point) {
            checked += 1;
            if q.greedy_action(point).unwrap() != best {
                wrong += 1;
                eprintln!("miss at {point:?}");
            }
        }
    }
    assert!(checked >= 100, "only {checked} points checked");
    assert_eq!(wrong, 0);
}

/// Kernel-averaging FQI (`KnnFqi`) at four dimensions on the same plant, without the loop:
/// the twin's records (weight 1) and those of a source with set-point 3 (reward weight 0,
/// so the reward model must ignore them; transition weight 1, as with shared dynamics),
/// `k = 2` (the two records of each lattice pair). Every lattice point where the closed
/// form decides gets π*'s action (with that source at reward weight 1 some do not: checked
/// while writing the test).
#[test]
fn knn_fqi_recovers_the_closed_form_policy_at_four_dimensions() {
    use awfqi::prelude::{Kernel, KnnFqi, KnnRecord, Neighbours, SampleSet};
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let twin = records(&SumPlant { c: 0.0 }, &mut rng);
    let shifted = records(&SumPlant { c: 3.0 }, &mut rng);
    let ignore = vec![0.0; shifted.len()];
    let sets = [
        SampleSet::unweighted(&twin),
        SampleSet::weighted(&shifted, Some(&ignore), None),
    ];
    let nb = Neighbours::cube(2, -1.0, 1.0, Kernel::Uniform).unwrap();
    let n = twin.len() + shifted.len();
    let mut slots = vec![KnnRecord::EMPTY; n];
    let mut links = vec![0u16; nb.required_links(n, 2).unwrap()];
    let mut q = KnnFqi::new(nb, 2, &mut slots, &mut links).unwrap();
    let config = FqiConfig::new(0.9, 40, EmptyCells::Nearest)
        .unwrap()
        .with_min_weight(0.5)
        .unwrap();
    q.fit(&sets, &config).unwrap();
    let lattice = lattice();
    let mut checked = 0;
    for p in 0..lattice.len() {
        let s = lattice.point(p).unwrap();
        if let Some(best) = optimal_action(&s) {
            assert_eq!(q.greedy_action(s).unwrap(), best, "at {s:?}");
            checked += 1;
        }
    }
    // Σ s ≥ 1 or ≤ −1 on the 4⁴ lattice of centres ±0.25, ±0.75.
    assert!(checked > 100, "{checked}");
}
