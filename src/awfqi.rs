//! AWFQI, the active loop (spec §12, thesis §4.3 Algorithm 2), one step at a time.
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
//! 5. run **weighted tabular FQI** ([`TabularFqi`]) on `D₀` (weight 1) followed by the
//!    sources in order; iteration 1 fits the reward model with the reward weights, later
//!    iterations use transition weights, which are all 1 (the shared-dynamics
//!    configuration of §7.6 that §12 prescribes: `weight_st = (off, off)`).
//!
//! The caller evaluates the greedy policy between steps ([`Awfqi::q`],
//! [`crate::evaluation::evaluate_greedy`]) — nothing here depends on the evaluation.
//!
//! **Memory.** The kernel borrows everything large from the caller, so it can live in
//! statics on a microcontroller: the target-sample buffer (`K·n` records of
//! `Transition<[T; 2], T>`), the reward-weight buffer (one `T` per source record), the
//! target [`Gp`], the FQI table, the score sampler and the source data. Measured on
//! `thumbv7em-none-eabihf` in `f32` for the configuration of the end-to-end test
//! (`tests/awfqi_puddle.rs`: 11 × 11 cells, `N = 64`, 484 score rows, 3 steps of 50
//! queries, 910 source records), in bytes:
//!
//! | part | bytes |
//! |---|---:|
//! | `Awfqi` itself (configuration, target model, slices) | 444 |
//! | target GP `Gp<f32, 64, 3>` | 17 692 |
//! | FQI table, 484 × `FqiEntry<f32>` (20) | 9 680 |
//! | target samples, 150 × `Transition` (28) | 4 200 |
//! | alias table, 484 × `AliasEntry<f32>` (8) | 3 872 |
//! | reward weights, 910 × `f32` | 3 640 |
//! | **RAM written by the loop** | **39 528** |
//! | source records, 910 × 28 (read-only: flash) | 25 480 |
//! | source reward posteriors, 910 × 8 (read-only: flash) | 7 280 |
//! | score values, 484 × 12 (set-up only, then reusable) | 5 808 |
//!
//! plus the stack of a GP prediction (`N` floats) and of the hyperparameter search.
//!
//! **Errors part-way.** A step validates its capacity before drawing. If the target model,
//! the GP or the weights fail later, the records already queried stay in `D₀` and the
//! Q-function keeps its previous fit; the step counter does not advance.

use crate::dataset::{GpTraining, INPUT_DIM, Output, SubsetRule, batch_transform, fit_gp, input};
use crate::env::{GenerativeModel, Transition};
use crate::fqi::{FqiConfig, SampleSet, TabularFqi};
use crate::gp::{Gp, Hyperparameters};
use crate::score::RowSampler;
use crate::weights::{NoiseSubtraction, Posterior, WeightParams, WeightSummary};
use crate::{Error, Real, Result};
use rand_core::Rng;

/// Settings of AWFQI.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AwfqiConfig<T> {
    /// Queries per step, `n = H·B` (§12: 500 for B = 10, 50 for B = 1).
    pub budget: usize,
    /// Reward-weight estimator, `v_r` and `w_max` (§7.6: mean, 0.1, 1000).
    pub weights: WeightParams<T>,
    /// Noise subtraction of the target GP's predictive stds (§7.1: the reference rule).
    pub noise_subtraction: NoiseSubtraction,
    /// Which target records the target GP is fitted on when `D₀` exceeds its capacity.
    pub subset: SubsetRule,
    /// Initial hyperparameters, bounds and search budget of the target GP (§4.2).
    pub gp_training: GpTraining<T>,
    /// Discount, iterations and empty-cell rule of FQI (§5: 0.99, 60).
    pub fqi: FqiConfig<T>,
}

impl<T: Real> AwfqiConfig<T> {
    /// The thesis configuration (§12) for a per-step budget: mean estimator with
    /// `v_r = 0.1`, `w_max = 1000`, reference noise subtraction, the reference GP training
    /// (10 restarts), γ = 0.99 with 60 iterations, nearest-cell filling — and
    /// [`SubsetRule::Spread`] **\[CHOICE\]**: with a target GP far smaller than the
    /// reference's 4000, "the last N" would forget every earlier step's queries, while an
    /// even spread keeps them all represented.
    pub fn thesis(budget: usize) -> Self {
        Self {
            budget,
            weights: WeightParams::reference_reward(),
            noise_subtraction: NoiseSubtraction::Reference,
            subset: SubsetRule::Spread,
            gp_training: GpTraining::reference(),
            fqi: FqiConfig::reference(),
        }
    }

    /// Checks the parts that can be invalid when built field by field.
    ///
    /// Errors: `budget == 0` ([`Error::InvalidParameter`] `budget`); invalid GP bounds or
    /// search options.
    pub fn validate(&self) -> Result<()> {
        if self.budget == 0 {
            return Err(Error::InvalidParameter {
                parameter: "budget",
            });
        }
        self.gp_training.initial.validate()?;
        self.gp_training.bounds.validate()?;
        self.gp_training.search.validate()
    }
}

/// One source dataset with what §6 stores with it: the records and, per record, the
/// posterior `(μ^s_r, σ^s_r)` of the source's reward GP at the record's own `z`
/// (noise-subtracted; see [`crate::dataset::predict_posteriors`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SourceData<'a, T> {
    records: &'a [Transition<[T; 2], T>],
    reward_posteriors: &'a [Posterior<T>],
}

impl<'a, T: Real> SourceData<'a, T> {
    /// Pairs the records with their stored reward posteriors.
    ///
    /// Errors: slices of different lengths ([`Error::InvalidParameter`]
    /// `reward_posteriors`), a non-finite posterior or a negative std.
    pub fn new(
        records: &'a [Transition<[T; 2], T>],
        reward_posteriors: &'a [Posterior<T>],
    ) -> Result<Self> {
        if records.len() != reward_posteriors.len() {
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

    /// The records.
    pub fn records(&self) -> &'a [Transition<[T; 2], T>] {
        self.records
    }

    /// The stored reward posteriors, one per record.
    pub fn reward_posteriors(&self) -> &'a [Posterior<T>] {
        self.reward_posteriors
    }
}

/// What one step did: the diagnostics of §7.2 step 6 and §12 step 6.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepReport<T> {
    /// Steps completed, this one included (`k`).
    pub step: usize,
    /// `|D₀|` after the step (`k·n`).
    pub n_target_samples: usize,
    /// Number of source records.
    pub n_source_samples: usize,
    /// Records the target GP was fitted on (`min(|D₀|, N)`).
    pub gp_points: usize,
    /// The target GP's log marginal likelihood after the search.
    pub gp_log_likelihood: T,
    /// The target GP's hyperparameters after the search.
    pub gp_hyperparameters: Hyperparameters<T, INPUT_DIM>,
    /// Mean reward weight over all records, target ones (weight 1) included (`wr_mean`).
    pub wr_mean: T,
    /// Effective sample size of the reward weights over all records (`wr_eff`).
    pub wr_eff: T,
    /// Mean transition weight (1: transition weights are off).
    pub ws_mean: T,
    /// Effective sample size of the transition weights (all records).
    pub ws_eff: T,
}

/// The AWFQI kernel: configuration, borrowed storage and the state of a run.
///
/// Generic over the scalar `T`, the target model `G` (any [`GenerativeModel`] with 2-D
/// states, e.g. `PuddleWorld<T>`) and the target GP's capacity `N`. The struct holds the
/// configuration, the target model by value, and slices/references to the caller's
/// storage: `size_of::<Awfqi<f32, PuddleWorld<f32>, 64>>()` is 444 bytes on
/// `thumbv7em-none-eabihf` (212 of them the Puddle World model); see the module docs for
/// the storage it borrows.
#[derive(Debug)]
pub struct Awfqi<'a, T, G, const N: usize> {
    config: AwfqiConfig<T>,
    target: G,
    sampler: RowSampler<'a, T>,
    sources: &'a [SourceData<'a, T>],
    samples: &'a mut [Transition<[T; 2], T>],
    len: usize,
    weights: &'a mut [T],
    gp: &'a mut Gp<T, N, INPUT_DIM>,
    fqi: TabularFqi<'a, T, 2>,
    steps: usize,
}

impl<'a, T, G, const N: usize> Awfqi<'a, T, G, N>
where
    T: Real,
    G: GenerativeModel<T, State = [T; 2]>,
{
    /// Assembles a kernel for a fresh run (`D₀` empty, Q = 0).
    ///
    /// - `sampler`: the score table's row sampler ([`crate::score::ScoreTable::sampler`]);
    /// - `sources`: the source datasets with their stored reward posteriors;
    /// - `samples`: room for the target records of all steps (`K·n`);
    /// - `weights`: room for one reward weight per source record;
    /// - `gp`: the target GP (its contents are replaced every step);
    /// - `fqi`: the Q-function, whose grid and action count define the discretisation.
    ///
    /// Errors: an invalid configuration; `fqi.actions()` different from the model's
    /// ([`Error::InvalidParameter`] `actions`); `weights` shorter than the number of source
    /// records ([`Error::CapacityExceeded`] with its length); `samples` unable to hold one
    /// step ([`Error::CapacityExceeded`] with its length).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        config: AwfqiConfig<T>,
        target: G,
        sampler: RowSampler<'a, T>,
        sources: &'a [SourceData<'a, T>],
        samples: &'a mut [Transition<[T; 2], T>],
        weights: &'a mut [T],
        gp: &'a mut Gp<T, N, INPUT_DIM>,
        mut fqi: TabularFqi<'a, T, 2>,
    ) -> Result<Self> {
        config.validate()?;
        if fqi.actions() != target.num_actions() {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        let source_records: usize = sources.iter().map(|s| s.records.len()).sum();
        if weights.len() < source_records {
            return Err(Error::CapacityExceeded {
                capacity: weights.len(),
            });
        }
        if samples.len() < config.budget {
            return Err(Error::CapacityExceeded {
                capacity: samples.len(),
            });
        }
        fqi.clear();
        gp.clear();
        Ok(Self {
            config,
            target,
            sampler,
            sources,
            samples,
            len: 0,
            weights,
            gp,
            fqi,
            steps: 0,
        })
    }

    /// Starts a new run on the same storage: empties `D₀`, resets Q to 0 and the step count.
    pub fn reset(&mut self) {
        self.len = 0;
        self.steps = 0;
        self.fqi.clear();
        self.gp.clear();
    }

    /// The configuration.
    pub fn config(&self) -> &AwfqiConfig<T> {
        &self.config
    }

    /// Steps completed in this run.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// The target dataset `D₀` (generative-model records, in query order).
    pub fn target_samples(&self) -> &[Transition<[T; 2], T>] {
        self.samples.get(..self.len).unwrap_or(&[])
    }

    /// The reward weights of the last step, source by source, record by record.
    pub fn reward_weights(&self) -> &[T] {
        let n: usize = self.sources.iter().map(|s| s.records.len()).sum();
        self.weights.get(..n).unwrap_or(&[])
    }

    /// The Q-function of the last step (0 before the first).
    pub fn q(&self) -> &TabularFqi<'a, T, 2> {
        &self.fqi
    }

    /// The target GP of the last step.
    pub fn gp(&self) -> &Gp<T, N, INPUT_DIM> {
        self.gp
    }

    /// The target model.
    pub fn target(&self) -> &G {
        &self.target
    }

    /// Runs one step (module docs): `n` queries, target GP, reward weights, weighted FQI.
    ///
    /// Errors: `D₀` has no room for `n` more records ([`Error::CapacityExceeded`] with the
    /// buffer's length; checked before anything is drawn); then the first error of a query,
    /// the GP fit or search, a prediction or a weight, after which the state is as the
    /// module docs describe.
    pub fn step<R: Rng + ?Sized>(&mut self, rng: &mut R) -> Result<StepReport<T>> {
        let budget = self.config.budget;
        self.len
            .checked_add(budget)
            .filter(|&e| e <= self.samples.len())
            .ok_or(Error::CapacityExceeded {
                capacity: self.samples.len(),
            })?;
        // 1–3: draw rows and query the target.
        for _ in 0..budget {
            let (_, state, action) = self.sampler.draw(rng);
            let record = self.target.query(state, action, rng)?;
            if let Some(slot) = self.samples.get_mut(self.len) {
                *slot = record;
                self.len += 1;
            }
        }
        let target = self.samples.get(..self.len).unwrap_or(&[]);
        // 4: target reward GP on a bounded subset of D₀.
        let lml = fit_gp(
            self.gp,
            target,
            Output::Reward,
            self.config.subset,
            &self.config.gp_training,
            rng,
        )?;
        // Reward weights, one noise-subtraction batch per source.
        let mut wr = WeightSummary::new();
        wr.add_ones(target.len());
        let capacity = self.weights.len();
        let mut rest: &mut [T] = self.weights;
        for source in self.sources {
            let (mine, tail) = core::mem::take(&mut rest)
                .split_at_mut_checked(source.records.len())
                .ok_or(Error::CapacityExceeded { capacity })?;
            rest = tail;
            source_weights(
                self.gp,
                source,
                &self.config.weights,
                self.config.noise_subtraction,
                mine,
            )?;
            wr.add(mine)?;
        }
        // 5: weighted FQI on D₀ then the sources.
        let weights: &[T] = self.weights;
        let sets = core::iter::once(SampleSet::unweighted(target)).chain(self.sources.iter().scan(
            0usize,
            move |offset, s| {
                let start = *offset;
                *offset += s.records.len();
                let w = weights.get(start..*offset);
                Some(SampleSet::weighted(s.records, w, None))
            },
        ));
        self.fqi.fit_sets(sets, &self.config.fqi)?;
        self.steps += 1;
        let total = wr.count();
        Ok(StepReport {
            step: self.steps,
            n_target_samples: self.len,
            n_source_samples: self.sources.iter().map(|s| s.records.len()).sum(),
            gp_points: self.gp.len(),
            gp_log_likelihood: lml,
            gp_hyperparameters: *self.gp.hyperparameters(),
            wr_mean: wr.mean(),
            wr_eff: wr.effective_sample_size(),
            ws_mean: T::ONE,
            ws_eff: total,
        })
    }
}

/// The reward weights of one source's records under the target GP (§7.2 steps 2–3).
fn source_weights<T: Real, const N: usize>(
    gp: &Gp<T, N, INPUT_DIM>,
    source: &SourceData<'_, T>,
    params: &WeightParams<T>,
    noise: NoiseSubtraction,
    out: &mut [T],
) -> Result<()> {
    if source.records.is_empty() {
        return Ok(());
    }
    let transform = batch_transform(gp, source.records, noise)?;
    for ((w, r), &s) in out
        .iter_mut()
        .zip(source.records)
        .zip(source.reward_posteriors)
    {
        let p = gp.predict(&input(r.state, r.action))?;
        let t = Posterior::new(p.mean, transform.apply(p.noisy_variance));
        *w = params.weight(r.reward, t, s)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
