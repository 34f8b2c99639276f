//! `awfqi-adaptive`: the adaptive AWFQI as the core runs it ([`awfqi::prelude::AdaptiveAwfqi`]; not
//! a thesis algorithm — the thesis's `awfqi` and `awfqi-oracle` stay as they are): the
//! query distribution is recomputed from what the target has answered, several times per
//! step, and aims at what decides the greedy policy.
//!
//! It runs on the embedded set-up ([`EmbeddedSetup`]: the `f32` source records, their
//! stored posteriors, the candidate rows of the setting and the sources' reward
//! [`MeanFunction`]s) with the FQI approximator of [`EmbeddedConfig::adaptive_q`]
//! (by default [`ADAPTIVE_Q`], chosen on the tuning runs `--seed 100`,
//! `docs/active-budget.md`) and the loop's knobs of [`AdaptiveOptions`] (by default the
//! core's recommended configuration).
//!
//! [`EmbeddedConfig::adaptive_q`]: super::EmbeddedConfig::adaptive_q
//! [`ADAPTIVE_Q`]: super::ADAPTIVE_Q

use awfqi::model::GenerativeModel;
use awfqi::prelude::{
    AdaptiveAwfqi, AdaptiveBuffers, AdaptiveConfig, Dims, FqiConfig, FqiEntry, Gp, KnnRecord,
    MeanFunction, QFunction, QStorage, SampleSet, SourceData, StatePlusAction, Transition,
    TreeNode, TreeRecord,
};
use rand_chacha::ChaCha8Rng;
use serde::{Serialize, Serializer};

use super::{EmbeddedSetup, GP_POINTS, Plant, Record, Record32, RunLearner, T, after_step};
use crate::transfer::algorithms::Experiment;
use crate::transfer::protocol::{Diagnostics, Learner};

/// The adaptive loop's knobs a run may set (fields of the core's [`AdaptiveConfig`]), as
/// the result files record them. The defaults are the core's recommended configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AdaptiveOptions {
    /// Sub-batches per step (re-planning points), ≥ 1 (`None`: the core's schedule rule).
    pub sub_batches: Option<usize>,
    /// Share of each sub-batch spent on greedy verification rollouts, in [0, 1] (`None`:
    /// the schedule rule's).
    pub verify: Option<f64>,
    /// Verify from every distinct evaluation start state of the domain (else from the
    /// middle one alone).
    pub all_starts: bool,
    /// Spend a sub-batch's drawn queries on more verification when its plan verified short.
    pub safeguard: bool,
    /// Fading source weights: the pseudo-records `κ` and the cells per state coordinate
    /// (`None`: off).
    pub fading: Option<(f64, usize)>,
    /// Score rows by residual surprise.
    pub surprise: bool,
    /// Scale scores by the residual GP's remaining variance.
    pub uncertainty: bool,
    /// Weight rows by their closeness to the verified greedy paths.
    pub decision: bool,
    /// Share of the drawn probability spread uniformly over the candidates, in [0, 1].
    pub floor: f64,
    /// Candidate rows scored per sub-batch.
    pub candidates: usize,
    /// Width of the relevance kernel, as a share of each state coordinate's range.
    pub relevance_width: f64,
    /// Relabel contradicted source rewards by the target GP instead of down-weighting
    /// the records.
    pub relabel: bool,
    /// Warm refits: likelihood evaluations and restarts of every search after a GP's first
    /// in a run (`None`: the thesis's search every time).
    pub refit: Option<(usize, usize)>,
    /// Capacity of the target GPs and of the sources' mean functions.
    pub gp_points: GpCapacity,
    /// Also fit the same approximator on the run's target samples alone after every step,
    /// as a paired baseline ([`crate::transfer::protocol::Diagnostics::fqi_same_samples`]);
    /// changes nothing of the learner's own run. Absent from the result files when off.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub same_samples_fqi: bool,
}

/// `awfqi-adaptive`'s GP capacity by default (the recommended configuration,
/// `docs/embedded-adaptive.md`).
pub const ADAPTIVE_GP_POINTS: GpCapacity = GpCapacity::P32;

/// The capacities `awfqi-adaptive`'s target GPs and the sources' mean functions are built
/// for: the core sizes a GP by a type parameter, so each capacity is a variant run by its
/// own typed instance ([`with_learner`]), and a capacity not listed here is refused where
/// the user names it ([`GpCapacity::try_from`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GpCapacity {
    /// 16 points.
    P16,
    /// 24 points.
    P24,
    /// 32 points.
    P32,
    /// 48 points.
    P48,
    /// 64 points: the shared set-up's own capacity ([`GP_POINTS`]), whose source means it
    /// reuses.
    P64,
}

impl GpCapacity {
    /// Every capacity, smallest first.
    pub const ALL: [GpCapacity; 5] = [
        GpCapacity::P16,
        GpCapacity::P24,
        GpCapacity::P32,
        GpCapacity::P48,
        GpCapacity::P64,
    ];

    /// The number of points.
    pub const fn points(self) -> usize {
        match self {
            GpCapacity::P16 => 16,
            GpCapacity::P24 => 24,
            GpCapacity::P32 => 32,
            GpCapacity::P48 => 48,
            GpCapacity::P64 => GP_POINTS,
        }
    }
}

impl TryFrom<usize> for GpCapacity {
    type Error = anyhow::Error;

    /// The capacity of `points` points.
    ///
    /// Errors: a capacity the harness is not built for, naming those it is.
    fn try_from(points: usize) -> anyhow::Result<Self> {
        GpCapacity::ALL
            .into_iter()
            .find(|c| c.points() == points)
            .ok_or_else(|| {
                let all: Vec<String> = GpCapacity::ALL.iter().map(ToString::to_string).collect();
                anyhow::anyhow!(
                    "{points} points is not a GP capacity of awfqi-adaptive: it must be one of {}",
                    all.join(", ")
                )
            })
    }
}

impl std::str::FromStr for GpCapacity {
    type Err = anyhow::Error;

    /// A number of points, as the command line gives it.
    fn from_str(s: &str) -> anyhow::Result<Self> {
        let points: usize = s
            .trim()
            .parse()
            .map_err(|_| anyhow::anyhow!("{s:?} is not a number of points"))?;
        Self::try_from(points)
    }
}

impl std::fmt::Display for GpCapacity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.points())
    }
}

impl Serialize for GpCapacity {
    /// The number of points, as the result files record it.
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(self.points() as u64)
    }
}

impl Default for AdaptiveOptions {
    /// The core's [`AdaptiveConfig::recommended`].
    fn default() -> Self {
        let c = AdaptiveConfig::<f64, 2, 3>::recommended(1, [0.0; 2], 1, 0.0, [(0.0, 1.0); 2]);
        Self {
            sub_batches: None,
            verify: None,
            all_starts: false,
            safeguard: c.safeguard,
            fading: None,
            surprise: c.surprise,
            uncertainty: c.uncertainty,
            decision: c.decision,
            floor: c.floor,
            candidates: c.candidates,
            relevance_width: c.relevance_width,
            relabel: c.relabel,
            refit: match c.refit {
                awfqi::adaptive::Refit::Warm(o) => Some((o.max_evaluations, o.restarts)),
                awfqi::adaptive::Refit::Search => None,
            },
            gp_points: ADAPTIVE_GP_POINTS,
            same_samples_fqi: false,
        }
    }
}

/// The core's configuration for `experiment`: the recommended one on the set-up's
/// domain settings ([`EmbeddedSetup::awfqi_config`]) with the experiment's adaptive options
/// and the FQI iterations its approximator runs ([`super::EmbeddedQ::fqi`]).
///
/// Errors: those of [`super::EmbeddedQ::fqi`].
fn config<const N: usize, const D: usize, const I: usize>(
    experiment: &Experiment<D>,
    setup: &EmbeddedSetup<N, D, I>,
) -> anyhow::Result<AdaptiveConfig<T, D, I>>
where
    Dims<D, I>: StatePlusAction,
{
    let o = experiment.adaptive_options;
    let domain = &setup.domain;
    let bounds = domain.bounds.map(|(lo, hi)| (lo as T, hi as T));
    let start = domain.start.map(|x| x as T);
    let budget = experiment.budget();
    let mut c = AdaptiveConfig::recommended(
        budget,
        start,
        experiment.domain.horizon,
        experiment.protocol.epsilon as T,
        bounds,
    );
    c.awfqi = setup.awfqi_config(budget);
    c.awfqi.fqi = setup.config.adaptive_q.fqi(c.awfqi.fqi)?;
    if let Some(s) = o.sub_batches {
        c.sub_batches = s;
    }
    if let Some(v) = o.verify {
        c.verify = v as T;
    }
    c.safeguard = o.safeguard;
    c.surprise = o.surprise;
    c.uncertainty = o.uncertainty;
    c.decision = o.decision;
    c.floor = o.floor as T;
    c.candidates = o.candidates;
    c.relevance_width = o.relevance_width as T;
    c.relabel = o.relabel;
    c.refit = match o.refit {
        Some((max_evaluations, restarts)) => {
            awfqi::adaptive::Refit::Warm(awfqi::prelude::SearchOptions {
                max_evaluations,
                restarts,
                isotropic: c.awfqi.gp_training.search.isotropic,
            })
        }
        None => awfqi::adaptive::Refit::Search,
    };
    Ok(c)
}

/// The memory one run writes, on the heap and sized at run time: what a firmware holds in
/// an [`awfqi::prelude::AdaptiveStorage`].
#[derive(Debug)]
struct Memory<const N: usize, const D: usize, const I: usize> {
    gp: Box<Gp<T, N, I>>,
    samples: Vec<Record32<D>>,
    weights: Vec<T>,
    candidates: Vec<awfqi::adaptive::candidates::Candidate<T>>,
    q: QMemory<D>,
    path: Vec<[T; D]>,
    beliefs: Vec<awfqi::adaptive::plausibility::SourceBelief<T>>,
}

/// The memory of one Q-function, sized for its approximator.
#[derive(Debug, Clone)]
struct QMemory<const D: usize> {
    fqi: Vec<FqiEntry<T>>,
    records: Vec<KnnRecord<T, D>>,
    links: Vec<u16>,
    tree_records: Vec<TreeRecord<T, D>>,
    nodes: Vec<TreeNode<T>>,
    sweep_entries: Vec<awfqi::fqi::SweepEntry<T, D>>,
    sweep_nodes: Vec<awfqi::fqi::SweepNode<T>>,
    anchor_entries: Vec<awfqi::fqi::AnchorEntry<T>>,
    anchor_positions: Vec<[T; D]>,
    anchor_landings: Vec<[T; D]>,
}

impl<const D: usize> QMemory<D> {
    fn storage(&mut self) -> QStorage<'_, T, D> {
        QStorage {
            entries: &mut self.fqi,
            records: &mut self.records,
            links: &mut self.links,
            tree_records: &mut self.tree_records,
            nodes: &mut self.nodes,
            sweep_entries: &mut self.sweep_entries,
            sweep_nodes: &mut self.sweep_nodes,
            anchor_entries: &mut self.anchor_entries,
            anchor_positions: &mut self.anchor_positions,
            anchor_landings: &mut self.anchor_landings,
        }
    }
}

impl<const N: usize, const D: usize, const I: usize> Memory<N, D, I> {
    fn buffers(&mut self) -> AdaptiveBuffers<'_, T, D, I, N> {
        AdaptiveBuffers {
            gp: &mut self.gp,
            samples: &mut self.samples,
            weights: &mut self.weights,
            candidates: &mut self.candidates,
            fqi: self.q.storage(),
            path: &mut self.path,
            beliefs: &mut self.beliefs,
        }
    }
}

/// `awfqi-adaptive` as a [`Learner`]: each protocol step is one
/// [`AdaptiveAwfqi::step`]; the greedy action is the `f32` Q-function's, and `D₀` is kept in
/// `f64` for the result files.
struct AdaptiveLearner<'a, P, const N: usize, const D: usize, const I: usize> {
    adaptive: AdaptiveAwfqi<'a, T, P, D, I, N>,
    collected: Vec<Record<D>>,
    /// FQI on the target samples alone with the same approximator, and its settings, when
    /// [`AdaptiveOptions::same_samples_fqi`] asks for it.
    baseline: Option<(QFunction<'a, T, D>, FqiConfig<T>)>,
}

impl<P, const N: usize, const D: usize, const I: usize> Learner<D>
    for AdaptiveLearner<'_, P, N, D, I>
where
    P: GenerativeModel<T, State = [T; D]>,
    Dims<D, I>: StatePlusAction,
{
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        let report = self.adaptive.step(rng)?;
        let samples = self.adaptive.target_samples();
        if let Some((q, fqi)) = &mut self.baseline {
            // From a copy of the generator: the learner's own draws stay as without it.
            let mut own = rng.clone();
            q.fit(&[SampleSet::unweighted(samples)], fqi, &mut own)?;
        }
        Ok(after_step(
            "awfqi-adaptive",
            &report,
            samples,
            &mut self.collected,
            false,
        ))
    }

    fn greedy_action(&self, s: &[f64; D]) -> usize {
        self.adaptive
            .q()
            .greedy_action(s.map(|x| x as T))
            .unwrap_or(0)
    }

    fn target_samples(&self) -> &[Record<D>] {
        &self.collected
    }

    fn same_samples_action(&self, s: &[f64; D]) -> Option<usize> {
        let (q, _) = self.baseline.as_ref()?;
        Some(q.greedy_action(s.map(|x| x as T)).unwrap_or(0))
    }
}

/// Hands a fresh learner for one run of `experiment` on the plant `P`, over `setup`, to `f`
/// (the core's adaptive AWFQI borrows its memory and the set-up for the whole run, so they
/// live in this frame), with the experiment's GP capacity: the set-up's source means at
/// its own capacity, means fitted afresh at the others (`fitted_means`).
///
/// Errors: a plant the experiment does not run, those of the core's configuration and
/// constructor, of the means' fits and of `f`.
pub fn with_learner<P: Plant<D>, const D: usize, const I: usize>(
    setup: &EmbeddedSetup<GP_POINTS, D, I>,
    experiment: &Experiment<D>,
    rng: &mut ChaCha8Rng,
    f: RunLearner<'_, D>,
) -> anyhow::Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    match experiment.adaptive_options.gp_points {
        GpCapacity::P16 => with_learner_of::<P, 16, D, I>(setup, fitted_means, experiment, rng, f),
        GpCapacity::P24 => with_learner_of::<P, 24, D, I>(setup, fitted_means, experiment, rng, f),
        GpCapacity::P32 => with_learner_of::<P, 32, D, I>(setup, fitted_means, experiment, rng, f),
        GpCapacity::P48 => with_learner_of::<P, 48, D, I>(setup, fitted_means, experiment, rng, f),
        GpCapacity::P64 => with_learner_of::<P, GP_POINTS, D, I>(
            setup,
            |setup, _| Ok(setup.means().to_vec()),
            experiment,
            rng,
            f,
        ),
    }
}

/// The sources' reward mean functions of capacity `N`, fitted as the set-up fits its own
/// (the published training, an even spread), from a stream of their own so every run has
/// the same.
///
/// Errors: those of [`MeanFunction::fit_rewards`].
fn fitted_means<const N: usize, const D: usize, const I: usize>(
    setup: &EmbeddedSetup<GP_POINTS, D, I>,
    sources: &[&[Record32<D>]],
) -> anyhow::Result<Vec<MeanFunction<T, N, I>>>
where
    Dims<D, I>: StatePlusAction,
{
    use rand_core::SeedableRng;
    let mut rng = ChaCha8Rng::seed_from_u64(N as u64);
    let mut gp = Box::new(Gp::<T, N, I>::empty());
    let mut means = vec![MeanFunction::EMPTY; sources.len()];
    let training = setup.awfqi_config(1).gp_training;
    for (mean, source) in means.iter_mut().zip(sources) {
        mean.fit_rewards(
            &mut gp,
            source,
            &training,
            awfqi::prelude::SubsetRule::Spread,
            &mut rng,
        )?;
    }
    Ok(means)
}

/// The sources' reward mean functions of capacity `N` for a run over `setup`.
type MeansOf<const N: usize, const D: usize, const I: usize> =
    fn(
        &EmbeddedSetup<GP_POINTS, D, I>,
        &[&[Record32<D>]],
    ) -> anyhow::Result<Vec<MeanFunction<T, N, I>>>;

/// [`with_learner`] with target GPs and mean functions of `N` points.
fn with_learner_of<P: Plant<D>, const N: usize, const D: usize, const I: usize>(
    setup: &EmbeddedSetup<GP_POINTS, D, I>,
    means: MeansOf<N, D, I>,
    experiment: &Experiment<D>,
    rng: &mut ChaCha8Rng,
    f: RunLearner<'_, D>,
) -> anyhow::Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    let plant = P::target(experiment)?;
    let actions = plant.num_actions();
    let config = config(experiment, setup)?.validate()?;
    let sources = setup.source_slices();
    let rows = setup.rows(&sources)?;
    let approximator = setup.config.adaptive_q.approximator(&setup.domain.bounds)?;
    let entries = approximator
        .required_entries(actions)
        .ok_or_else(|| anyhow::anyhow!("FQI approximator too large"))?;
    let budget = experiment.budget();
    let slots = config.candidates.min(rows.len());
    // Kernel averaging and trees hold every target and source record of a fit.
    let n = experiment.protocol.steps * budget + setup.posteriors().len();
    let (records, links) = match approximator {
        awfqi::prelude::Approximator::Knn(nb) | awfqi::prelude::Approximator::Hybrid(_, nb) => {
            let links = nb
                .required_links(n, actions)
                .ok_or_else(|| anyhow::anyhow!("kNN links overflow"))?;
            (n, links)
        }
        _ => (0, 0),
    };
    let (tree_records, nodes) = match approximator {
        awfqi::prelude::Approximator::Trees(forests) => {
            let nodes = forests
                .required_nodes(actions)
                .ok_or_else(|| anyhow::anyhow!("tree nodes overflow"))?;
            (n, nodes)
        }
        _ => (0, 0),
    };
    let (sweep_entries, sweep_nodes) = match approximator {
        awfqi::prelude::Approximator::Sweep(sweep) => (
            sweep
                .required_entries(actions)
                .ok_or_else(|| anyhow::anyhow!("sweep entries overflow"))?,
            sweep.nodes(),
        ),
        awfqi::prelude::Approximator::Anchors(anchors) => (0, anchors.nodes()),
        _ => (0, 0),
    };
    let (anchor_entries, anchors) = match approximator {
        awfqi::prelude::Approximator::Anchors(anchors) => (
            anchors
                .required_entries(actions)
                .ok_or_else(|| anyhow::anyhow!("anchor entries overflow"))?,
            anchors.nodes(),
        ),
        _ => (0, 0),
    };
    let q = QMemory {
        fqi: vec![FqiEntry::EMPTY; entries],
        records: vec![KnnRecord::EMPTY; records],
        links: vec![0; links],
        tree_records: vec![TreeRecord::EMPTY; tree_records],
        nodes: vec![TreeNode::EMPTY; nodes],
        sweep_entries: vec![awfqi::fqi::SweepEntry::EMPTY; sweep_entries],
        sweep_nodes: vec![awfqi::fqi::SweepNode::EMPTY; sweep_nodes],
        anchor_entries: vec![awfqi::fqi::AnchorEntry::EMPTY; anchor_entries],
        anchor_positions: vec![[0.0; D]; anchors],
        anchor_landings: vec![[0.0; D]; anchors],
    };
    let mut spare = experiment
        .adaptive_options
        .same_samples_fqi
        .then(|| q.clone());
    let mut memory = Memory::<N, D, I> {
        gp: Box::new(Gp::empty()),
        samples: vec![Transition::EMPTY; experiment.protocol.steps * budget],
        weights: vec![0.0; setup.posteriors().len()],
        candidates: vec![awfqi::adaptive::candidates::Candidate::EMPTY; slots],
        q,
        path: vec![[0.0; D]; budget],
        beliefs: vec![awfqi::adaptive::plausibility::SourceBelief::EMPTY; sources.len()],
    };
    let fqi = config.awfqi().fqi;
    let baseline = match &mut spare {
        Some(spare) => Some((approximator.build(actions, spare.storage())?, fqi)),
        None => None,
    };
    let means = means(setup, &sources)?;
    let means: &[MeanFunction<T, N, I>] = &means;
    let starts = verification_starts(experiment, setup);
    let fading = experiment.adaptive_options.fading.map(|(kappa, cells)| {
        let f = awfqi::adaptive::Fading {
            pseudo_records: kappa as T,
            cells,
        };
        let len = cells
            .saturating_pow(D as u32)
            .saturating_mul(actions)
            .min(1 << 20);
        (f, vec![awfqi::adaptive::FadeCell::EMPTY; len.max(1)])
    });
    let mut fade_table = fading.as_ref().map(|(_, t)| t.clone()).unwrap_or_default();
    let adaptive = AdaptiveAwfqi::new(
        config,
        approximator,
        SourceData::new(&sources, setup.posteriors())?,
        means,
        rows,
        plant,
        memory.buffers(),
    )?
    .with_starts(&starts)?;
    let adaptive = match fading {
        Some((f, _)) => adaptive.with_fading(f, &mut fade_table)?,
        None => adaptive,
    };
    let mut learner = AdaptiveLearner {
        adaptive,
        collected: Vec::new(),
        baseline,
    };
    f(&mut learner, rng)
}

/// Where the verification rollouts start: the domain's distinct evaluation start states
/// ([`AdaptiveOptions::all_starts`]), else the set-up's start alone.
fn verification_starts<const N: usize, const D: usize, const I: usize>(
    experiment: &Experiment<D>,
    setup: &EmbeddedSetup<N, D, I>,
) -> Vec<[T; D]> {
    let mut starts: Vec<[T; D]> = Vec::new();
    if experiment.adaptive_options.all_starts {
        for s in &experiment.domain.evaluation_starts {
            let s = s.map(|x| x as T);
            if !starts.contains(&s) {
                starts.push(s);
            }
        }
    }
    if starts.is_empty() {
        starts.push(setup.domain.start.map(|x| x as T));
    }
    starts
}
