//! `awfqi-embedded`: the thesis's AWFQI as the core runs it ([`awfqi::thesis::Awfqi`]): a target
//! reward GP of capacity [`GP_POINTS`] fitted on an even spread of `D₀` (the core's
//! [`awfqi::record_gp::SubsetRule::Spread`]) with the core's bounded Nelder–Mead search, weighted FQI
//! by tile coding ([`TILINGS`](super::TILINGS) offset tilings of [`TILES`](super::TILES)
//! tiles per axis, or the [`CELLS`](super::CELLS) × `CELLS` table) instead of Extra-Trees,
//! transition weights on request (`--transition-weights true`), and the realistic score
//! table of the set-up ([`EmbeddedSetup`]), on any domain ([`Plant`]) with its settings
//! ([`EmbeddedDomain`](super::EmbeddedDomain)).

use awfqi::model::GenerativeModel;
use awfqi::prelude::{
    AliasEntry, Awfqi, AwfqiBuffers, Dims, Estimator, FqiEntry, Gp, StatePlusAction, Transition,
    WeightParams,
};
use rand_chacha::ChaCha8Rng;

use super::{EmbeddedSetup, GP_POINTS, Plant, Record, Record32, RunLearner, T, after_step};
use crate::transfer::algorithms::Experiment;
use crate::transfer::protocol::{Diagnostics, Learner};

/// The memory one run writes, on the heap and sized at run time: what a
/// firmware holds in an [`awfqi::thesis::AwfqiStorage`].
#[derive(Debug)]
pub struct EmbeddedMemory<const N: usize = GP_POINTS, const D: usize = 2, const I: usize = 3> {
    gp: Box<Gp<T, N, I>>,
    samples: Vec<Record32<D>>,
    weights: Vec<T>,
    alias: Vec<AliasEntry<T>>,
    fqi: Vec<FqiEntry<T>>,
    transition_weights: Vec<T>,
}

impl<const N: usize, const D: usize, const I: usize> EmbeddedMemory<N, D, I>
where
    Dims<D, I>: StatePlusAction,
{
    /// Room for `steps × budget` target samples, one weight per stored posterior, one alias
    /// entry per score row, the FQI entries of `setup`'s approximator for `actions` actions
    /// and, with `transition_weights`, one transition weight per source record.
    ///
    /// Errors: an approximator too large for memory.
    pub fn new(
        setup: &EmbeddedSetup<N, D, I>,
        steps: usize,
        budget: usize,
        actions: usize,
        transition_weights: bool,
    ) -> anyhow::Result<Self> {
        let entries = setup
            .config
            .q
            .approximator(&setup.domain.bounds)?
            .required_entries(actions)
            .ok_or_else(|| anyhow::anyhow!("FQI approximator too large"))?;
        let records = setup.posteriors.len();
        Ok(Self {
            gp: Box::new(Gp::<T, N, I>::empty()),
            samples: vec![Transition::EMPTY; steps * budget],
            weights: vec![0.0; records],
            alias: vec![AliasEntry::EMPTY; setup.values.len()],
            fqi: vec![FqiEntry::EMPTY; entries],
            transition_weights: vec![0.0; if transition_weights { records } else { 0 }],
        })
    }

    /// The core's buffers and the transition-weight buffer.
    fn buffers(&mut self) -> (AwfqiBuffers<'_, T, D, I, N>, &mut [T]) {
        (
            AwfqiBuffers {
                gp: &mut self.gp,
                samples: &mut self.samples,
                weights: &mut self.weights,
                alias: &mut self.alias,
                fqi: &mut self.fqi,
            },
            &mut self.transition_weights,
        )
    }
}

/// `awfqi-embedded` as a [`Learner`]: each protocol step is one [`Awfqi::step`] (score →
/// draw → query → weights → weighted FQI); the greedy action is the `f32` table's, and `D₀`
/// is kept in `f64` for the result files.
pub struct EmbeddedLearner<
    'a,
    P,
    const N: usize = GP_POINTS,
    const D: usize = 2,
    const I: usize = 3,
> {
    awfqi: Awfqi<'a, T, P, D, I, N>,
    collected: Vec<Record<D>>,
}

impl<'a, P, const N: usize, const D: usize, const I: usize> EmbeddedLearner<'a, P, N, D, I>
where
    P: GenerativeModel<T, State = [T; D]>,
    Dims<D, I>: StatePlusAction,
{
    /// The builder's set-up from the shared source data and score values (`sources` are
    /// `setup`'s [`EmbeddedSetup::source_slices`]) over `memory`, with a per-step budget, on
    /// the target `plant`, from the stream `rng`; with `transition` (the estimator variance
    /// `v_s`), transition weights on every coordinate.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        setup: &'a EmbeddedSetup<N, D, I>,
        sources: &'a [&'a [Record32<D>]],
        memory: &'a mut EmbeddedMemory<N, D, I>,
        budget: usize,
        plant: P,
        transition: Option<f64>,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Self> {
        let (buffers, transition_weights) = memory.buffers();
        let mut builder = Awfqi::builder(
            setup.awfqi_config(budget).validate()?,
            setup.config.q.approximator(&setup.domain.bounds)?,
            sources,
            setup.rows(sources)?,
        )
        .stored_posteriors(&setup.posteriors)
        .stored_scores(&setup.values);
        if let Some(v_s) = transition {
            if setup.transition_posteriors.len() != D * setup.posteriors.len() {
                anyhow::bail!("transition weights need the sources' stored next-state posteriors");
            }
            builder = builder.transition_weights(
                WeightParams::new(Estimator::Mean, v_s as T, 1000.0)?,
                &setup.transition_posteriors,
                transition_weights,
            );
        }
        let awfqi = builder.build(plant, buffers, rng)?;
        Ok(Self {
            awfqi,
            collected: Vec::new(),
        })
    }
}

impl<P, const N: usize, const D: usize, const I: usize> Learner<D>
    for EmbeddedLearner<'_, P, N, D, I>
where
    P: GenerativeModel<T, State = [T; D]>,
    Dims<D, I>: StatePlusAction,
{
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        let report = self.awfqi.step(rng)?;
        let samples = self.awfqi.target_samples();
        Ok(after_step(
            "awfqi-embedded",
            &report,
            samples,
            &mut self.collected,
            true,
        ))
    }

    fn greedy_action(&self, s: &[f64; D]) -> usize {
        self.awfqi.q().greedy_action(s.map(|x| x as T)).unwrap_or(0)
    }

    fn target_samples(&self) -> &[Record<D>] {
        &self.collected
    }
}

/// Hands a fresh learner for one run of `experiment` on the plant `P`, over `setup`, to
/// `f`: the core's AWFQI borrows its memory and the source data for the whole run, so they
/// live in this frame while [`protocol::run`](crate::transfer::protocol::run) drives the
/// learner inside `f`.
///
/// Errors: a plant the experiment does not run, transition weights without the sources'
/// next-state posteriors, those of the core's builder and of `f`.
pub fn with_learner<P: Plant<D>, const D: usize, const I: usize>(
    setup: &EmbeddedSetup<GP_POINTS, D, I>,
    experiment: &Experiment<D>,
    rng: &mut ChaCha8Rng,
    f: RunLearner<'_, D>,
) -> anyhow::Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    let plant = P::target(experiment)?;
    let budget = experiment.budget();
    let sources = setup.source_slices();
    // Transition weights only on request (`--transition-weights true`), on every
    // coordinate, with the estimator variance v_s of the experiment: the active algorithms
    // run without them (§12), and on this small-GP path they were measured to hurt under
    // puddle-based dynamics (§12.1).
    let transition = if experiment.options.transition_weights == Some(true) {
        Some(experiment.variances()?.1)
    } else {
        None
    };
    let mut memory = EmbeddedMemory::new(
        setup,
        experiment.protocol.steps,
        budget,
        plant.num_actions(),
        transition.is_some(),
    )?;
    let mut learner =
        EmbeddedLearner::new(setup, &sources, &mut memory, budget, plant, transition, rng)?;
    f(&mut learner, rng)
}
