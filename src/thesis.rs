//! AWFQI, the active loop (spec §12, thesis §4.3 Algorithm 2), one step at a time, for any
//! plant with a `D`-dimensional state.
//!
//! A step spends a budget of `n` generative-model queries on the target where the sources
//! disagree, then solves the target by importance-weighted FQI on the target's and the
//! sources' records:
//!
//! 1. draw `n` rows of the score table with replacement ([`RowSampler`], O(1) per draw);
//! 2. query the target's [`GenerativeModel`] at each drawn `(s, a)` and append the records
//!    to the target dataset `D₀`, which accumulates across steps;
//! 3. fit the **target reward GP** from fresh initial hyperparameters on a bounded subset
//!    of `D₀` ([`SubsetRule`]: the GP has a fixed capacity `N`; the reference's rule is the
//!    last `N`, here the default is [`SubsetRule::Spread`], see [`AwfqiConfig::thesis`]);
//! 4. give every source record its **reward weight** (§7.3 estimator, `v_r`, `w_max`) from
//!    the target GP's posterior at the record's `z`, noise-subtracted over each source's
//!    batch, and the source GP posterior stored with the source data (§6 step 3);
//! 5. run **weighted FQI** — the table ([`crate::fqi::TabularFqi`]) or tile coding
//!    ([`crate::fqi::TileFqi`]), the builder's [`crate::fqi::Approximator`] — on `D₀` (weight 1)
//!    followed by the sources in order; iteration 1 fits the reward model with the reward
//!    weights, later iterations use transition weights. These are all 1 by default (the
//!    shared-dynamics configuration of §7.6 that §12 prescribes: `weight_st = (off, off)`);
//!    with [`AwfqiBuilder::transition_weights`] each step first fits one target GP per
//!    next-state coordinate in turn (in the same GP, before the reward GP) and weighs
//!    every source record by the product over coordinates of the §7.3 estimator against
//!    the stored source next-state posteriors (§7.2 step 4).
//!
//! The caller evaluates the greedy policy between steps ([`Awfqi::q`],
//! [`crate::evaluation::evaluate_greedy`]) — nothing here depends on the evaluation.
//!
//! **Set-up.** [`AwfqiBuilder`] performs the whole set-up once — source reward GPs, their
//! stored posteriors, the score table over the caller's candidate set, the sampler, the
//! source data, the FQI table — in one [`AwfqiStorage`] (or any [`AwfqiBuffers`]); the
//! [`AwfqiBuilder`] shows it on a plant of its own.
//!
//! **Dimensions.** `D` is the state dimension, `I = D + 1` the GP input dimension (the state
//! followed by the action; stable Rust cannot write `D + 1` in a type, so both are
//! parameters and `I == D + 1` is checked at compile time), `N` the target GP's capacity.
//!
//! **Memory.** The learner borrows everything large, so it can live in statics on a
//! microcontroller: the target-sample buffer (`K·n` records of `Transition<[T; D], T>`),
//! the reward-weight buffer (one `T` per source record), the target [`Gp`], the FQI table
//! and the score sampler's alias table (all in [`AwfqiStorage`]), and the source records
//! and their stored posteriors (e.g. in flash). Measured on `thumbv7em-none-eabihf` in
//! `f32` for the configuration of the end-to-end test (`tests/awfqi_puddle.rs`: 11 × 11
//! cells, `N = 64`, 484 score rows, 3 steps of 50 queries, 910 source records), in bytes:
//!
//! | part | bytes |
//! |---|---:|
//! | `Awfqi` itself (configuration, target model, slices) | 468 |
//! | target GP `Gp<f32, 64, 3>` | 17 704 |
//! | FQI table, 484 × `FqiEntry<f32>` (20) | 9 680 |
//! | target samples, 150 × `Transition<[f32; 2], f32>` (28) | 4 200 |
//! | alias table, 484 × `AliasEntry<f32>` (8) | 3 872 |
//! | reward weights, 910 × `f32` | 3 640 |
//! | **RAM written by the loop** (the learner and its `AwfqiStorage<f32, 2, 3, 64, 150, 910, 484, 484>` of 39 096) | **39 564** |
//! | source records, 910 × 28 (read-only: flash) | 25 480 |
//! | source reward posteriors, 910 × 8 (read-only: flash) | 7 280 |
//! | score values, 484 × 12 (set-up only, then reusable) | 5 808 |
//!
//! plus the stack of a GP prediction (`N` floats) and of the hyperparameter search.
//!
//! **Errors part-way.** A step validates its capacity before drawing. If the target model,
//! the GP or the weights fail later, the records already queried stay in `D₀` and the
//! Q-function keeps its previous fit; the step counter does not advance.
//!
//! **Example**: the thesis's AWFQI on the crate docs' heater: the builder performs its whole set-up
//! once (source reward GPs → stored posteriors → score table over your candidate pairs →
//! sampler → source data → FQI table).
//!
//! ```rust
//! use awfqi::prelude::{
//!     Awfqi, AwfqiConfig, CellGrid, GenerativeModel, PointGrid, Posterior,
//!     RowSet, Scores, SourceMeans, SourceModel, Transition,
//! };
//! use rand_chacha::ChaCha8Rng;
//! use rand_core::{Rng, SeedableRng};
//! # #[derive(Clone, Copy)]
//! # struct Heater {
//! #     gain: f32,
//! # }
//! # impl SourceModel<f32, 1> for Heater {
//! #     fn predict(&self, [s]: [f32; 1], action: usize) -> awfqi::Result<SourceMeans<f32, 1>> {
//! #         if !(0.0..=1.0).contains(&s) || action > 1 {
//! #             return Err(awfqi::Error::OutOfRange { parameter: "state" });
//! #         }
//! #         let next = s + self.gain * action as f32 - 0.1 * s;
//! #         Ok(SourceMeans { reward: -(s - 0.5).abs(), next_state: [next.clamp(0.0, 1.0)] })
//! #     }
//! # }
//! # impl GenerativeModel<f32> for Heater {
//! #     type State = [f32; 1];
//! #     fn num_actions(&self) -> usize {
//! #         2
//! #     }
//! #     fn query<R: Rng + ?Sized>(
//! #         &self,
//! #         state: [f32; 1],
//! #         action: usize,
//! #         rng: &mut R,
//! #     ) -> awfqi::Result<Transition<[f32; 1], f32>> {
//! #         let mean = self.predict(state, action)?;
//! #         let noise = (rng.next_u32() as f32 / u32::MAX as f32 - 0.5) * 0.02;
//! #         let next_state = [(mean.next_state[0] + noise).clamp(0.0, 1.0)];
//! #         Ok(Transition { state, action, reward: mean.reward, next_state, absorbing: false })
//! #     }
//! # }
//!
//! # fn main() -> awfqi::Result<()> {
//! let mut rng = ChaCha8Rng::seed_from_u64(7);
//! let sources = [Heater { gain: 0.15 }, Heater { gain: 0.3 }];
//! let mut data = [[Transition::EMPTY; 20]; 2];
//! for (heater, records) in sources.iter().zip(&mut data) {
//!     for (i, r) in records.iter_mut().enumerate() {
//!         *r = heater.query([i as f32 / 19.0], i % 2, &mut rng)?;
//!     }
//! }
//! let records: [&[Transition<[f32; 1], f32>]; 2] = [&data[0], &data[1]];
//!
//! // All the memory the loop writes: a 16-point GP over (s, a), 2 steps × 10 queries,
//! // 40 source records, 42 candidate rows, 10 cells × 2 actions (`static` in `.bss` on a
//! // device). Set-up memory: the fitted source posteriors and the score values.
//! awfqi::awfqi_storage! {
//!     struct HeaterStorage {
//!         scalar: f32,
//!         state_dim: 1,
//!         gp_points: 16,
//!         steps: 2,
//!         budget: 10,
//!         source_records: 40,
//!         candidate_rows: PointGrid::<f32, 1>::rows(21, 2),
//!         table_entries: 10 * 2,
//!     }
//! }
//! let mut storage = HeaterStorage::new();
//! let mut posteriors = [Posterior::default(); 40];
//! let mut scores = [Scores::ZERO; 42];
//!
//! // The thesis's settings (Puddle World's scales; for a plant of your own derive them from
//! // the logs: `AwfqiConfig::scaled`, docs/embedding.md), 10 queries per step.
//! let mut config = AwfqiConfig::thesis(10);
//! config.gp_training.search.restarts = 1;
//! let candidates = RowSet::grid(PointGrid::spanning([0.0], [1.0], 0.05)?, 2)?;
//! let mut kernel = Awfqi::builder(config.validate()?, CellGrid::cube(0.0, 1.0, 10)?, &records, candidates)
//!     .fit_posteriors(&mut posteriors) // one reward GP per source, fitted here
//!     .scores_from(&sources, &mut scores)? // oracle scores from the sources' means
//!     .steps(2) // the run's length: a target buffer too short is refused here
//!     .build(Heater { gain: 0.2 }, &mut storage, &mut rng)?;
//! for _ in 0..2 {
//!     let report = kernel.step(&mut rng)?; // 10 queries, target GP, weights, weighted FQI
//!     assert!(report.wr_eff > 0.0);
//! }
//! // The greedy policy heats when cold and not when hot.
//! assert_eq!(kernel.q().greedy_action([0.2])?, 1);
//! assert_eq!(kernel.q().greedy_action([0.9])?, 0);
//! # Ok(())
//! # }
//! ```
//!

pub(crate) mod builder;
mod report;
mod scaled;
pub(crate) mod transfer;

pub use builder::{AwfqiBuffers, AwfqiBuilder, AwfqiStorage};
pub use report::{COLLAPSED_SHARE, DISCARDED_SHARE, StepReport, Warning, Warnings, Weights};
pub use scaled::{
    NOISE_MULTIPLIER, SCALED_ESTIMATOR, SCALED_EVALUATIONS_PER_PARAMETER, SCALED_RESTARTS,
    SourceScales,
};

use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::{Approximator, FqiConfig, QFunction};
use crate::gp::Gp;
use crate::model::{GenerativeModel, Transition};
use crate::record_gp::{
    Dims, GpTraining, InputDim, Output, StatePlusAction, SubsetRule, fit_gp_searched,
    visit_posteriors,
};
use crate::score::{RowSampler, ScoreColumn};
use crate::weights::{NoiseSubtraction, Posterior, WeightParams, WeightSummary, WeightTally};
use rand_core::Rng;
use transfer::{ReplanGp, SourceValues, Transfer};

/// Settings of AWFQI for a GP input dimension `I` (`D + 1`): the parameters before
/// validation (linfa style: [`AwfqiConfig::validate`] turns them into a
/// [`ValidAwfqiConfig`], which is what the builder takes).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub struct AwfqiConfig<T, const I: usize> {
    /// Queries per step, `n = H·B` (§12: 500 for B = 10, 50 for B = 1).
    pub budget: usize,
    /// Reward-weight estimator, `v_r` and `w_max` (§7.6: mean, 0.1, 1000).
    pub weights: WeightParams<T>,
    /// Noise subtraction of the GPs' predictive stds (§7.1: the reference rule); also used
    /// for the source posteriors the builder fits.
    pub noise_subtraction: NoiseSubtraction,
    /// Which records a GP is fitted on when a dataset exceeds its capacity (the target GP,
    /// and the source GPs the builder fits).
    pub subset: SubsetRule,
    /// Initial hyperparameters, bounds and search budget of every GP (§4.2).
    pub gp_training: GpTraining<T, I>,
    /// Discount, iterations and empty-cell rule of FQI (§5: 0.99, 60).
    pub fqi: FqiConfig<T>,
    /// The score column the queries are drawn on (§11.3: `V_r`).
    pub sampling: ScoreColumn,
}

impl<T: Real, const I: usize> AwfqiConfig<T, I> {
    /// The thesis configuration (§12) for a per-step budget: the **faithful Puddle World
    /// setting**, not a default for another plant. Its GP scales (every GP starts from
    /// `c = ℓ = σ²ₙ = 1` and searches `c ∈ [10⁻⁵, 10⁵]`, `ℓ ∈ [10⁻², 10³]`,
    /// `σ²ₙ ∈ [10⁻², 1]`, isotropic, 10 restarts, 550 evaluations) and its reward-weight
    /// noise `v_r = 0.1` are in Puddle World's units (states in `[0, 10]²`, rewards of
    /// about −1 per step); for a plant of your own start from
    /// [`AwfqiConfig::scaled`], which derives them from your source data.
    ///
    /// The values: mean estimator with `v_r = 0.1`, `w_max = 1000`
    /// ([`WeightParams::reference_reward`]); reference noise subtraction; the reference GP
    /// training above ([`GpTraining::published`]); FQI with γ = 0.99, 60 iterations and,
    /// for (cell, action) pairs without data, [`crate::fqi::EmptyCells::CappedNearest`] with a
    /// minimum total weight of 0.5 ([`FqiConfig::published`]); sampling on `V_r`
    /// ([`ScoreColumn::Reward`]) — and [`SubsetRule::Spread`] **\[CHOICE\]**: with a target
    /// GP far smaller than the reference's 4000, "the last N" would forget every earlier
    /// step's queries, while an even spread keeps them all represented.
    ///
    /// ```
    /// use awfqi::prelude::{AwfqiConfig, EmptyCells, Estimator, NoiseSubtraction, ScoreColumn, SubsetRule};
    /// let c = AwfqiConfig::<f64, 3>::thesis(50);
    /// assert_eq!(c.budget, 50);
    /// assert_eq!(c.weights.estimator(), Estimator::Mean);
    /// assert_eq!((c.weights.noise_variance(), c.weights.max_weight()), (0.1, 1000.0));
    /// assert_eq!(c.noise_subtraction, NoiseSubtraction::Reference);
    /// assert_eq!(c.subset, SubsetRule::Spread);
    /// let gp = c.gp_training;
    /// assert_eq!(gp.initial.signal_variance, 1.0);
    /// assert_eq!(gp.initial.length_scales, [1.0; 3]);
    /// assert_eq!(gp.initial.noise_variance, 1.0);
    /// assert_eq!(gp.bounds.signal_variance, (1e-5, 1e5));
    /// assert_eq!(gp.bounds.length_scales, [(1e-2, 1e3); 3]);
    /// assert_eq!(gp.bounds.noise_variance, (1e-2, 1.0));
    /// assert!(gp.search.isotropic);
    /// assert_eq!((gp.search.restarts, gp.search.max_evaluations), (10, 550));
    /// assert_eq!((c.fqi.discount(), c.fqi.iterations()), (0.99, 60));
    /// assert_eq!(c.fqi.empty_cells(), EmptyCells::CappedNearest);
    /// assert_eq!(c.fqi.min_weight(), 0.5);
    /// assert_eq!(c.sampling, ScoreColumn::Reward);
    /// ```
    pub fn thesis(budget: usize) -> Self {
        Self {
            budget,
            weights: WeightParams::reference_reward(),
            noise_subtraction: NoiseSubtraction::Reference,
            subset: SubsetRule::Spread,
            gp_training: GpTraining::published(),
            fqi: FqiConfig::published(),
            sampling: ScoreColumn::Reward,
        }
    }

    /// Checks the parameters that can be invalid when built field by field.
    ///
    /// Errors: `budget == 0` ([`Error::InvalidParameter`] `budget`); invalid GP
    /// hyperparameters, bounds or search options; a sampling column
    /// [`ScoreColumn::NextState`] beyond the state dimension `I − 1`
    /// ([`Error::OutOfRange`] `sampling`).
    pub fn validate(self) -> Result<ValidAwfqiConfig<T, I>> {
        if self.budget == 0 {
            return Err(Error::InvalidParameter {
                parameter: "budget",
            });
        }
        self.gp_training.validate()?;
        if let ScoreColumn::NextState(k) = self.sampling {
            if k.saturating_add(1) >= I {
                return Err(Error::OutOfRange {
                    parameter: "sampling",
                });
            }
        }
        Ok(ValidAwfqiConfig(self))
    }
}

/// An [`AwfqiConfig`] that passed [`AwfqiConfig::validate`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ValidAwfqiConfig<T, const I: usize>(AwfqiConfig<T, I>);

impl<T: Copy, const I: usize> ValidAwfqiConfig<T, I> {
    /// The checked settings (also reachable field by field through `Deref`:
    /// `valid.budget`).
    pub fn config(&self) -> &AwfqiConfig<T, I> {
        &self.0
    }

    /// The checked settings, by value (to change one and validate again).
    pub fn into_inner(self) -> AwfqiConfig<T, I> {
        self.0
    }

    /// Queries per step.
    pub fn budget(&self) -> usize {
        self.0.budget
    }

    /// The reward-weight estimator, `v_r` and `w_max`.
    pub fn weights(&self) -> WeightParams<T> {
        self.0.weights
    }

    /// The noise subtraction of the GPs' predictive stds.
    pub fn noise_subtraction(&self) -> NoiseSubtraction {
        self.0.noise_subtraction
    }

    /// Which records a GP is fitted on when a dataset exceeds its capacity.
    pub fn subset(&self) -> SubsetRule {
        self.0.subset
    }

    /// How every GP is trained.
    pub fn gp_training(&self) -> &GpTraining<T, I> {
        &self.0.gp_training
    }

    /// FQI's discount, iterations and empty-cell rule.
    pub fn fqi(&self) -> FqiConfig<T> {
        self.0.fqi
    }

    /// The score column the queries are drawn on.
    pub fn sampling(&self) -> ScoreColumn {
        self.0.sampling
    }
}

impl<T, const I: usize> core::ops::Deref for ValidAwfqiConfig<T, I> {
    type Target = AwfqiConfig<T, I>;

    fn deref(&self) -> &AwfqiConfig<T, I> {
        &self.0
    }
}

/// One source's records.
type Records<'a, T, const D: usize> = &'a [Transition<[T; D], T>];

/// The source datasets with what §6 stores with them: the records, one slice per source,
/// and per record the posterior `(μ^s_r, σ^s_r)` of its source's reward GP at the record's
/// own `z` (noise-subtracted; see [`crate::record_gp::predict_posteriors`]), all sources'
/// posteriors in one slice, source after source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SourceData<'a, T, const D: usize> {
    records: &'a [&'a [Transition<[T; D], T>]],
    reward_posteriors: &'a [Posterior<T>],
}

impl<'a, T: Real, const D: usize> SourceData<'a, T, D> {
    /// Pairs the records with their stored reward posteriors.
    ///
    /// Errors: a posterior count other than the record count ([`Error::InvalidParameter`]
    /// `reward_posteriors`), a non-finite posterior or a negative std.
    pub fn new(
        records: &'a [&'a [Transition<[T; D], T>]],
        reward_posteriors: &'a [Posterior<T>],
    ) -> Result<Self> {
        let total = records
            .iter()
            .try_fold(0usize, |n, r| n.checked_add(r.len()));
        if total != Some(reward_posteriors.len()) {
            return Err(Error::InvalidParameter {
                parameter: "reward_posteriors",
            });
        }
        for p in reward_posteriors {
            crate::error::ensure_finite(p.mean, "reward_posteriors")?;
            crate::error::ensure_finite(p.std, "reward_posteriors")?;
            if p.std < T::ZERO {
                return Err(Error::InvalidParameter {
                    parameter: "reward_posteriors",
                });
            }
        }
        Ok(Self {
            records,
            reward_posteriors,
        })
    }

    /// The records, source by source.
    pub fn records(&self) -> &'a [&'a [Transition<[T; D], T>]] {
        self.records
    }

    /// The stored reward posteriors, one per record, source after source.
    pub fn reward_posteriors(&self) -> &'a [Posterior<T>] {
        self.reward_posteriors
    }

    /// Number of records of all sources.
    pub fn len(&self) -> usize {
        self.reward_posteriors.len()
    }

    /// `true` without any source record.
    pub fn is_empty(&self) -> bool {
        self.reward_posteriors.is_empty()
    }

    /// Each source's records with its posteriors.
    fn iter(&self) -> impl Iterator<Item = (Records<'a, T, D>, &'a [Posterior<T>])> {
        let mut rest = self.reward_posteriors;
        self.records.iter().map(move |&records| {
            let (mine, tail) = rest.split_at_checked(records.len()).unwrap_or((rest, &[]));
            rest = tail;
            (records, mine)
        })
    }
}

/// The AWFQI learner: configuration, borrowed storage and the state of a run.
///
/// Generic over the scalar `T`, the target model `G` (any [`GenerativeModel`] with states
/// `[T; D]`), the state dimension `D`, the GP input dimension `I = D + 1` and the target
/// GP's capacity `N`; the capacities of the buffers are the lengths of the slices it
/// borrows, so its code is the same for every capacity. Built by [`AwfqiBuilder`].
/// `size_of::<Awfqi<f32, PuddleWorld<f32>, 2, 3, 64>>()` is 468 bytes on
/// `thumbv7em-none-eabihf` (216 of them the Puddle World model; a learner built over
/// `&model` — [`GenerativeModel`] is implemented for references — holds 4 bytes instead,
/// which keeps every frame that holds the learner small).
#[derive(Debug)]
pub struct Awfqi<'a, T, G, const D: usize, const I: usize, const N: usize> {
    config: ValidAwfqiConfig<T, I>,
    sampler: RowSampler<'a, T, D>,
    transitions: Option<TransitionWeighting<'a, T>>,
    run: Transfer<'a, T, G, D, I, N>,
}

/// Transition weights (§7.2 step 4, every next-state dimension on): the estimator, the
/// stored source posteriors of every next-state coordinate (record after record, `D` per
/// record, all sources in one slice) and room for one weight per source record.
#[derive(Debug)]
pub(crate) struct TransitionWeighting<'a, T> {
    pub(crate) params: WeightParams<T>,
    pub(crate) posteriors: &'a [Posterior<T>],
    pub(crate) weights: &'a mut [T],
}

/// The entry point of the set-up. (The model type and the GP capacity are fixed later, by
/// [`AwfqiBuilder::build`]; this `impl` names them `()` and 0 only so that
/// `Awfqi::builder(…)` needs no type annotations, as `HashMap::new` does for its hasher.)
impl<'a, T: Real, const D: usize, const I: usize> Awfqi<'a, T, (), D, I, 0> {
    /// Starts the set-up of a learner with its required parts: see [`AwfqiBuilder`].
    pub fn builder(
        config: ValidAwfqiConfig<T, I>,
        approximator: impl Into<Approximator<T, D>>,
        sources: &'a [&'a [Transition<[T; D], T>]],
        candidates: crate::score::RowSet<'a, T, D>,
    ) -> AwfqiBuilder<'a, T, D, I>
    where
        crate::record_gp::Dims<D, I>: crate::record_gp::StatePlusAction,
    {
        AwfqiBuilder::new(config, approximator, sources, candidates)
    }
}

impl<'a, T, G, const D: usize, const I: usize, const N: usize> Awfqi<'a, T, G, D, I, N>
where
    T: Real,
    G: GenerativeModel<T, State = [T; D]>,
    Dims<D, I>: StatePlusAction,
{
    /// Assembles a learner for a fresh run (`D₀` empty, Q = 0) from parts the builder has
    /// checked: `samples` holds at least one step, `weights` one weight per source record,
    /// `fqi` has the model's action count.
    #[allow(clippy::too_many_arguments)]
    fn assemble(
        config: ValidAwfqiConfig<T, I>,
        target: G,
        sampler: RowSampler<'a, T, D>,
        sources: SourceData<'a, T, D>,
        samples: &'a mut [Transition<[T; D], T>],
        weights: &'a mut [T],
        gp: &'a mut Gp<T, N, I>,
        fqi: QFunction<'a, T, D>,
        transitions: Option<TransitionWeighting<'a, T>>,
    ) -> Result<Self> {
        let () = InputDim::<D, I>::CHECK;
        let run = Transfer::new(target, sources, samples, weights, gp, fqi);
        run.gp.set_hyperparameters(config.gp_training.initial)?;
        Ok(Self {
            config,
            sampler,
            transitions,
            run,
        })
    }

    /// Starts a new run on the same set-up: empties `D₀`, resets Q to 0 and the step count.
    pub fn reset(&mut self) {
        self.run.reset();
    }

    /// The configuration.
    pub fn config(&self) -> &ValidAwfqiConfig<T, I> {
        &self.config
    }

    /// Steps completed in this run.
    pub fn steps(&self) -> usize {
        self.run.steps
    }

    /// The target dataset `D₀` (generative-model records, in query order).
    pub fn target_samples(&self) -> &[Transition<[T; D], T>] {
        self.run.target_samples()
    }

    /// The reward weights of the last step, source by source, record by record.
    pub fn reward_weights(&self) -> &[T] {
        self.run.source_values()
    }

    /// The source data with their stored posteriors.
    pub fn sources(&self) -> &SourceData<'a, T, D> {
        &self.run.sources
    }

    /// The score table's row sampler.
    pub fn sampler(&self) -> &RowSampler<'a, T, D> {
        &self.sampler
    }

    /// The Q-function of the last step (0 before the first).
    pub fn q(&self) -> &QFunction<'a, T, D> {
        &self.run.fqi
    }

    /// The transition weights of the last step, source by source, record by record
    /// (empty when transition weights are off: every weight is then 1).
    pub fn transition_weights(&self) -> &[T] {
        match &self.transitions {
            Some(t) => t.weights.get(..self.run.sources.len()).unwrap_or(&[]),
            None => &[],
        }
    }

    /// The target GP of the last step.
    pub fn gp(&self) -> &Gp<T, N, I> {
        self.run.gp
    }

    /// The target model.
    pub fn target(&self) -> &G {
        &self.run.target
    }

    /// Runs one step (module docs): `n` queries, target GP, reward weights, weighted FQI.
    ///
    /// Errors: `D₀` has no room for `n` more records ([`Error::BufferTooSmall`] naming
    /// `samples` and its `Q`; checked before anything is drawn); then the first error of a
    /// query, the GP fit or search, a prediction or a weight, after which the state is as
    /// the module docs describe.
    // Inlined into its caller: a firmware loop calls it from one place, and a frame of its
    // own on top of the caller's (which holds the learner) costs the 32 KiB configuration
    // its margin (measured: 656 B more stack when it was not inlined).
    #[inline(always)]
    pub fn step<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<StepReport<T, I>> {
        let budget = self.config.budget;
        let run = &mut self.run;
        run.ensure_room(budget)?;
        // 1–3: draw rows and query the target.
        for _ in 0..budget {
            let (_, state, action) = self.sampler.draw(rng);
            let record = run.target.query(state, action, rng)?;
            run.push(record);
        }
        let target = run.samples.get(..run.len).unwrap_or(&[]);
        // Transition weights first (§7.2 step 4), one target GP per next-state dimension
        // fitted in turn in the same fixed-capacity GP, so that it holds the reward GP at
        // the end of the step.
        let mut ws = WeightSummary::new();
        ws.add_ones(target.len());
        let mut ws_tally = WeightTally::new();
        let mut refused = 0usize;
        let transitions_on = self.transitions.is_some();
        if let Some(tw) = self.transitions.as_mut() {
            for d in 0..D {
                let output = Output::NextState(d);
                output.of(target.first().ok_or(Error::EmptyData)?)?;
                let fit = fit_gp_searched(
                    run.gp,
                    target,
                    |r| output.of(r),
                    self.config.subset,
                    &self.config.gp_training,
                    rng,
                )?;
                refused += usize::from(fit.refused);
                let mut start = 0usize;
                for records in run.sources.records {
                    let end = start + records.len();
                    let out = tw
                        .weights
                        .get_mut(start..end)
                        .ok_or(Error::CapacityExceeded { capacity: end })?;
                    transition_weights_of(
                        run.gp,
                        records,
                        tw.posteriors.get(start * D..end * D).unwrap_or(&[]),
                        d,
                        &tw.params,
                        self.config.noise_subtraction,
                        out,
                    )?;
                    start = end;
                }
            }
            let weights = tw.weights.get(..run.sources.len()).unwrap_or(&[]);
            ws.add(weights)?;
            // A record is discarded when any of its `D` coordinates is.
            let (mut discarded, mut last) = (0usize, None);
            for (k, &p) in tw.posteriors.iter().enumerate() {
                let record = k.checked_div(D);
                if tw.params.discards(p) && record != last {
                    discarded += 1;
                    last = record;
                }
            }
            ws_tally.add(weights, tw.params.max_weight(), discarded)?;
        }
        // 4: target reward GP on a bounded subset of D₀.
        let fit = fit_gp_searched(
            run.gp,
            target,
            |r| Ok(r.reward),
            self.config.subset,
            &self.config.gp_training,
            rng,
        )?;
        refused += usize::from(fit.refused);
        let gp = ReplanGp::of(run.gp, fit.lml);
        // Reward weights, one noise-subtraction batch per source.
        let mut wr = WeightSummary::new();
        wr.add_ones(target.len());
        let mut wr_tally = WeightTally::new();
        run.fit_reward_weights(
            &self.config.weights,
            self.config.noise_subtraction,
            &mut wr,
            &mut wr_tally,
            false,
        )?;
        // 5: weighted FQI on D₀ then the sources.
        let transition: Option<&[T]> = self.transitions.as_ref().map(|t| &*t.weights);
        run.fit_q(SourceValues::Weights, transition, &self.config.fqi, rng)?;
        run.steps += 1;
        let mut report = run.report(&wr, &wr_tally, gp, refused);
        report.queries = budget;
        // Off: exactly 1 and the record count, as before transition weights existed.
        if transitions_on {
            report.ws_mean = ws.mean();
            report.ws_eff = ws.effective_sample_size();
            report.ws_source_eff = ws_tally.sources.effective_sample_size();
            report.ws_discarded = ws_tally.discarded;
            report.ws_capped = ws_tally.capped;
        }
        Ok(report)
    }
}

/// Multiplies `out[i]` by the weight of coordinate `d` of record `i`'s next state under the
/// target GP `gp` (fitted on that coordinate) and the stored source posteriors
/// (`posteriors[i·D + d]`); `d == 0` sets it (§7.2 step 4, one noise-subtraction batch per
/// source).
fn transition_weights_of<T: Real, const N: usize, const D: usize, const I: usize>(
    gp: &Gp<T, N, I>,
    records: &[Transition<[T; D], T>],
    posteriors: &[Posterior<T>],
    d: usize,
    params: &WeightParams<T>,
    noise: NoiseSubtraction,
    out: &mut [T],
) -> Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    if records.is_empty() {
        return Ok(());
    }
    let mut slots = out.iter_mut().zip(posteriors.chunks_exact(D));
    visit_posteriors(gp, records, noise, |r, target| {
        let Some((w, source)) = slots.next() else {
            return Ok(());
        };
        let s = source.get(d).copied().ok_or(Error::InvalidParameter {
            parameter: "transition_posteriors",
        })?;
        let y = r.next_state.get(d).copied().ok_or(Error::OutOfRange {
            parameter: "output",
        })?;
        let w_d = params.weight(y, target, s)?;
        *w = if d == 0 { w_d } else { *w * w_d };
        Ok(())
    })
}

#[cfg(test)]
mod tests;
