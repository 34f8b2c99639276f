//! `awfqi-adaptive`: AWFQI whose query distribution is recomputed from what the target has
//! shown, several times per step (issue 11; not a thesis algorithm — the thesis's `awfqi`
//! and `awfqi-oracle` stay as they are).
//!
//! Each step's budget `n = H·B` is spent in [`AdaptiveOptions::sub_batches`] sub-batches.
//! A sub-batch:
//! 1. **verifies** the current greedy policy: a share [`AdaptiveOptions::verify`] of the
//!    sub-batch follows greedy rollouts from the target's initial state in the generative
//!    model (ε-greedy after the first), so a feature of the target that no source has
//!    (Puddle World's (1, 4) puddle) is met where the policy would meet it;
//! 2. draws the rest from the setting's score-table rows (a random candidate subset) with
//!    probability ∝ relevance × (surprise + plausible disagreement) × uncertainty, mixed
//!    with a coverage floor; every factor is a switch;
//! 3. refits the target reward model (source-informed prior mean plus a GP on the
//!    residuals), the IWFQI weights of the source records and weighted FQI, and re-plans.
//!
//! The source-informed prior mean is `m(z) = Σ_k π_k μ_k(z)`, `μ_k` source `k`'s reward-GP
//! mean (the realistic score table's GPs) and `π_k` the plausibility of source `k` under
//! the target's observations (a clipped Gaussian likelihood, so a feature that every
//! source lacks does not decide between them). Nothing tells the algorithm which source
//! the target is.

use std::sync::Arc;

use awfqi::alias::{AliasEntry, AliasTable};
use awfqi::weights::{Estimator, Posterior, WeightParams, WeightSummary};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::Experiment;
use super::episodic::Episodic;
use super::nearest_model::NearestModel;
use crate::domains::{GpInput, Record, Rows};
use crate::forest_fqi::{Dataset, FqiOptions, fqi};
use crate::joint_q::QFunction;
use crate::transfer::gp::{GpOptions, GpSearch, GpSummary, Output, RecordGp, SourceGps};
use crate::transfer::protocol::{Diagnostics, Learner};

/// The switches and sizes of `awfqi-adaptive` (each ingredient can be turned off for the
/// ablation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AdaptiveOptions {
    /// Sub-batches per step (re-planning points), ≥ 1.
    pub sub_batches: usize,
    /// Share of each sub-batch spent on greedy verification rollouts, in [0, 1].
    pub verify: f64,
    /// Score by residual surprise: the squared mean of the residual GP (target reward
    /// minus the prior mean).
    pub surprise: bool,
    /// Scale scores by the residual GP's remaining variance (covered rows stop being
    /// drawn).
    pub uncertainty: bool,
    /// Decision relevance: weight rows by their closeness to this step's verified greedy
    /// paths.
    pub decision: bool,
    /// Source-informed prior mean for the target reward GP of the weights (off: IWFQI's
    /// zero-mean GP on the rewards).
    pub prior: bool,
    /// Share of the drawn (non-verification) probability spread uniformly over the
    /// candidates (relevance-weighted when `decision` is on), in [0, 1].
    pub floor: f64,
    /// Candidate rows scored per sub-batch (a uniform subset of the setting's rows).
    pub candidates: usize,
    /// Trees of the intermediate plans (0: the protocol's; the last sub-batch of a step
    /// always uses the protocol's).
    pub plan_trees: usize,
    /// Trees of each step's last fit, the plan the step ends with (0: the protocol's).
    /// More trees average away the Q-function's noise, which at 50 queries shows as
    /// greedy 2-cycles in the open (docs/active-budget.md, "Remaining failures"). Written
    /// to the result files only when set, so those of the protocol's trees are unchanged.
    #[serde(skip_serializing_if = "is_protocol_trees")]
    pub final_trees: usize,
    /// Width of the relevance kernel, as a share of each state coordinate's range.
    pub relevance_width: f64,
    /// FQI's rewards from the target reward model (prior mean plus residual GP mean) at
    /// every record, instead of the weighted records' own rewards.
    pub model_rewards: bool,
    /// End a verification rollout at the first surprise (a reward more than `3·√v_r` from
    /// the reward model's prediction; the plan changes there anyway) and give the rest of
    /// its quota to drawn queries (which the relevance kernel puts around the surprise).
    pub surprise_stop: bool,
    /// Multiply every source record's weights by its source's plausibility (relative to the
    /// most plausible source), in every FQI iteration.
    pub source_weights: bool,
    /// Hyperparameter search of this algorithm's own GP fits (the residual GP and the
    /// weights' GP; refitted at every sub-batch). `Screened` is the spec's search up to 300
    /// target points (sub-setting (b) unchanged) and keeps sub-setting (a), up to 3 000
    /// points and six fits per step, affordable.
    pub gp_search: GpSearch,
    /// Exploration of the verification rollouts after a sub-batch's first (`None`: the
    /// protocol's ε; 0: greedy, so they visit what the evaluation's noisy greedy rollouts
    /// visit).
    pub verify_epsilon: Option<f64>,
    /// Rollouts of the current plan simulated per sub-batch in a nearest-record transition
    /// model (no queries); their states join the relevance kernel's centres, so the drawn
    /// queries also cover the part of the greedy path that verification has not reached
    /// and the neighbourhood that noisy rollouts visit (0: off).
    pub simulate: usize,
    /// A sub-batch's verification resumes the previous sub-batch's unfinished rollout
    /// (from its last state, with the new plan) instead of restarting from the initial
    /// state, so the whole path gets verified when a quota is shorter than the path.
    pub resume: bool,
    /// Temperature of the source plausibilities: the clipped log-likelihood is divided by
    /// it (1: the plain likelihood; larger: closer to the uniform mixture, which
    /// `f64::INFINITY` gives), so a few records explained by one source's GP fit do not
    /// make it the only source.
    pub temperature: f64,
    /// The prior mean of the target reward model is the sources' consensus, the median of
    /// their reward means at the input (what most sources agree on), instead of the
    /// plausibility-weighted mean.
    pub consensus: bool,
    /// Relabel instead of down-weighting: every source record keeps weight 1, and its
    /// reward becomes `λ r + (1 − λ) μ_T`, `μ_T` the weights' target reward GP's mean at
    /// the record and `λ = exp(−u²/2)`, `u = (r − μ_T)/√(σ_T² + v_r)`: a source reward
    /// stays where the target GP does not contradict it and is replaced by the target's
    /// where it does, so every action keeps the sources' transitions around a feature
    /// only the target has.
    pub relabel: bool,
    /// awfqi-adaptive-kernel's relabelling ([`awfqi::AdaptiveConfig::relabel`]): off by
    /// default, where the tuning runs put it for the core's tile-coded FQI (relabelling
    /// is `awfqi-adaptive`'s default; docs/active-budget.md).
    pub kernel_relabel: bool,
    /// awfqi-adaptive-kernel's warm refits: likelihood evaluations and restarts of every
    /// search after a GP's first in a run (`None`: the thesis's search every time).
    pub kernel_refit: Option<(usize, usize)>,
    /// awfqi-adaptive-kernel's GP capacity (target GPs and the sources' mean functions).
    pub kernel_gp_points: usize,
    /// awfqi-adaptive-kernel's candidate rows scored per sub-batch.
    pub kernel_candidates: usize,
    /// A source record that ends its episode (absorbs) keeps weight only when that end is
    /// corroborated: by a target record's end there, or by at least half of the other
    /// sources (their nearest record with the same action ends too). A goal only one
    /// source has then does not pull the greedy policy (its records are dropped).
    pub corroborate: bool,
    /// Plan selection: every plan of a step (the one it started with and each
    /// sub-batch's) is rolled out this many times in the nearest-record model of the
    /// records held, and the step ends with the best (0: off, the last plan).
    pub select: usize,
    /// A diagnostic bound, not an algorithm: FQI's source records from the true target
    /// model (see [`AdaptiveOracle`]).
    pub oracle: AdaptiveOracle,
}

/// Oracle diagnostics of `awfqi-adaptive`: what its loop reaches when FQI's rewards or
/// weights come from the target's true mean reward (they read the instance, which the
/// algorithm never does), to tell how much a better reward model could still gain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum AdaptiveOracle {
    /// No oracle: the algorithm.
    None,
    /// Every record (target and sources) relabelled with the target's mean reward, all
    /// weights 1.
    Rewards,
    /// A source record keeps weight 1 where its source's mean reward equals the target's
    /// (within 0.3) and gets 0 elsewhere.
    Validity,
}

impl Default for AdaptiveOptions {
    fn default() -> Self {
        Self {
            sub_batches: 3,
            verify: 0.7,
            surprise: true,
            uncertainty: true,
            decision: true,
            prior: false,
            floor: 0.1,
            candidates: 4000,
            plan_trees: 0,
            final_trees: 0,
            relevance_width: 0.1,
            model_rewards: false,
            source_weights: false,
            surprise_stop: false,
            gp_search: GpSearch::Screened,
            verify_epsilon: None,
            simulate: 0,
            resume: false,
            temperature: 1.0,
            consensus: false,
            relabel: true,
            kernel_relabel: false,
            kernel_refit: Some((30, 0)),
            kernel_gp_points: 32,
            kernel_candidates: 250,
            corroborate: false,
            oracle: AdaptiveOracle::None,
            select: 0,
        }
    }
}

/// What every run of `awfqi-adaptive` shares: the candidate rows and the sources' reward
/// GPs with their means at the rows and at every source record (computed once).
#[derive(Debug, Clone)]
pub struct AdaptiveSetup<const D: usize = 2> {
    /// The setting's rows.
    pub rows: Rows<D>,
    /// Their GP inputs.
    pub row_inputs: Vec<GpInput>,
    /// `row_means[k][i]`: source `k`'s reward-GP mean at row `i`.
    pub row_means: Vec<Vec<f64>>,
    /// `record_means[k][j]`: source `k`'s reward-GP mean at record `j` of the sources'
    /// union.
    pub record_means: Vec<Vec<f64>>,
    /// The sources' reward GPs.
    pub gps: Vec<SourceGps>,
    /// The source of each record of the union.
    pub source_of: Vec<usize>,
    /// Each source's records as `(state, action, absorbing)`: a nearest-record guess of
    /// where the source's episodes end, for the plausibilities.
    pub endings: Vec<Vec<([f64; D], usize, bool)>>,
}

impl<const D: usize> AdaptiveSetup<D> {
    /// Predicts every source GP at the rows and at the union of the source records.
    pub fn new(
        experiment_domain: &crate::domains::Domain<D>,
        rows: Rows<D>,
        sources: &crate::transfer::sources::SourceSet<D>,
        gps: Vec<SourceGps>,
    ) -> Self {
        let union: Vec<Record<D>> = sources
            .sources
            .iter()
            .flat_map(|s| s.records.iter().copied())
            .collect();
        let source_of = sources
            .sources
            .iter()
            .enumerate()
            .flat_map(|(k, s)| std::iter::repeat_n(k, s.len()))
            .collect();
        let endings = sources
            .sources
            .iter()
            .map(|s| {
                s.records
                    .iter()
                    .map(|r| (r.state, r.action, r.absorbing))
                    .collect()
            })
            .collect();
        use rayon::prelude::*;
        let row_inputs: Vec<GpInput> = rows
            .iter()
            .map(|(s, a)| experiment_domain.gp_input(s, *a))
            .collect();
        let record_inputs: Vec<GpInput> =
            union.iter().map(|r| experiment_domain.input(r)).collect();
        let row_means = gps
            .par_iter()
            .map(|g| g.gps[0].means(&row_inputs))
            .collect();
        let record_means = gps
            .par_iter()
            .map(|g| g.gps[0].means(&record_inputs))
            .collect();
        Self {
            rows,
            row_inputs,
            row_means,
            record_means,
            gps,
            source_of,
            endings,
        }
    }

    /// Whether source `k`'s record nearest to `(state, action)` (same action, distance
    /// scaled by `bounds`) ends its episode.
    fn source_ends(
        &self,
        k: usize,
        state: &[f64; D],
        action: usize,
        bounds: &[(f64, f64); D],
    ) -> bool {
        let mut best = (f64::INFINITY, false);
        for (s, a, end) in &self.endings[k] {
            if *a != action {
                continue;
            }
            let d: f64 = (0..D)
                .map(|d| ((s[d] - state[d]) / (bounds[d].1 - bounds[d].0)).powi(2))
                .sum();
            if d < best.0 {
                best = (d, *end);
            }
        }
        best.1
    }
}

/// The target reward model of one refit: source plausibilities, the prior mean's residual
/// GP.
#[derive(Debug, Clone)]
struct RewardModel {
    /// Source plausibilities `π_k` (sum 1).
    plausibility: Vec<f64>,
    /// GP on `r − m(z)` of the target records.
    residual: RecordGp,
}

/// `awfqi-adaptive`.
#[derive(Debug, Clone)]
pub struct Adaptive<'e, const D: usize = 2> {
    experiment: &'e Experiment<D>,
    setup: Arc<AdaptiveSetup<D>>,
    options: AdaptiveOptions,
    run: Episodic<'e, D>,
    reward: WeightParams<f64>,
    /// The estimator's reward variance `v_r` (also the plausibilities' scale).
    reward_variance: f64,
    sources: Dataset<D>,
    /// The source records in order (for their stored posteriors).
    source_records: usize,
    /// States of this step's verification rollouts (the relevance kernel's centres).
    path: Vec<[f64; D]>,
    /// Where an unfinished verification rollout stopped, and its length so far
    /// ([`AdaptiveOptions::resume`]).
    resume_at: Option<([f64; D], usize)>,
    /// The source records' rewards FQI used in the last refit when they were not their
    /// own (relabelled).
    rewards: Option<Vec<f64>>,
    /// The reward model of the last refit (`None` before any target data).
    model: Option<RewardModel>,
    /// Diagnostics of the last refit.
    last: Diagnostics,
}

impl<'e, const D: usize> Adaptive<'e, D> {
    /// A fresh run of `experiment` (its adaptive set-up must be built).
    pub fn new(experiment: &'e Experiment<D>) -> anyhow::Result<Self> {
        let setup = experiment
            .adaptive
            .clone()
            .ok_or_else(|| anyhow::anyhow!("no adaptive set-up in the experiment"))?;
        let options = experiment.adaptive_options;
        anyhow::ensure!(
            options.sub_batches >= 1,
            "--adaptive-sub-batches must be ≥ 1"
        );
        anyhow::ensure!(
            (0.0..=1.0).contains(&options.verify) && (0.0..=1.0).contains(&options.floor),
            "--adaptive-verify and --adaptive-floor must lie in [0, 1]"
        );
        anyhow::ensure!(options.candidates >= 1, "--adaptive-candidates must be ≥ 1");
        anyhow::ensure!(
            options
                .verify_epsilon
                .is_none_or(|e| (0.0..=1.0).contains(&e)),
            "--adaptive-verify-epsilon must lie in [0, 1]"
        );
        let (v_r, _) = experiment.variances()?;
        let sources = experiment.sources.union();
        Ok(Self {
            experiment,
            setup,
            options,
            run: Episodic::new(experiment),
            reward: WeightParams::new(Estimator::Mean, v_r, experiment.options.max_weight)?,
            reward_variance: v_r,
            source_records: sources.len(),
            sources,
            path: Vec::new(),
            resume_at: None,
            rewards: None,
            model: None,
            last: Diagnostics::default(),
        })
    }

    /// The experiment's GP options with this algorithm's hyperparameter search.
    fn gp_options(&self) -> GpOptions {
        GpOptions {
            search: Some(self.options.gp_search),
            ..self.experiment.options.gp
        }
    }

    /// The reward model's prior mean from the sources' means `values` at one input: their
    /// median with [`AdaptiveOptions::consensus`], else their `weights`-weighted mean.
    fn prior(&self, values: impl Iterator<Item = f64>, weights: &[f64]) -> f64 {
        if self.options.consensus {
            median(values.collect())
        } else {
            values.zip(weights).map(|(x, w)| w * x).sum()
        }
    }

    /// Sources' reward-GP means at `zs`: `[k][i]`.
    fn source_means(&self, zs: &[GpInput]) -> Vec<Vec<f64>> {
        self.setup.gps.iter().map(|g| g.gps[0].means(zs)).collect()
    }

    /// Fits the reward model on `D₀` (non-empty).
    fn reward_model(&self, rng: &mut ChaCha8Rng) -> anyhow::Result<RewardModel> {
        let domain = &*self.experiment.domain;
        let data = &self.run.data;
        let zs: Vec<GpInput> = data.iter().map(|r| domain.input(r)).collect();
        let means = self.source_means(&zs);
        let v = self.reward_variance;
        let bounds = &domain.state_bounds;
        // Squared reward errors per source, clipped at 25 v; a record whose episode end
        // the source's nearest record contradicts costs the clip.
        let errors: Vec<Vec<f64>> = means
            .iter()
            .enumerate()
            .map(|(k, m)| {
                data.iter()
                    .zip(m)
                    .map(|(r, mu)| {
                        let ends = self.setup.source_ends(k, &r.state, r.action, bounds);
                        if ends != r.absorbing {
                            25.0 * v
                        } else {
                            (r.reward - mu).powi(2).min(25.0 * v)
                        }
                    })
                    .collect()
            })
            .collect();
        let plausibility = plausibility(&errors, v * self.options.temperature);
        let residuals: Vec<Record<D>> = data
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let m = self.prior(means.iter().map(|m| m[i]), &plausibility);
                Record {
                    reward: r.reward - m,
                    ..*r
                }
            })
            .collect();
        let spec = domain.gp_spec(Output::Reward);
        let residual = RecordGp::fit_records(
            domain,
            &residuals,
            Output::Reward,
            &spec,
            &self.gp_options(),
            rng,
        )?;
        Ok(RewardModel {
            plausibility,
            residual,
        })
    }

    /// The reward weights of the source records (in union order), the weights' GP and its
    /// posteriors at the records (union order).
    fn source_weights(
        &self,
        model: &RewardModel,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<(Vec<f64>, GpSummary, Vec<Posterior<f64>>)> {
        let domain = &*self.experiment.domain;
        let options = &self.experiment.options;
        let spec = domain.gp_spec(Output::Reward);
        let noise = spec.noise(options.noise);
        let sources = &self.experiment.sources.sources;
        let mut wr = Vec::with_capacity(self.source_records);
        let mut posteriors = Vec::with_capacity(self.source_records);
        // IWFQI's own GP when the prior is off. Relabelling reads the GP's mean far from
        // the target data too, so there its prior mean is the target rewards' median
        // instead of zero (a zero prior would relabel towards an optimistic 0).
        let centre = if self.options.relabel {
            median(self.run.data.iter().map(|r| r.reward).collect())
        } else {
            0.0
        };
        let plain = if self.options.prior {
            None
        } else {
            let centred: Vec<Record<D>>;
            let records = if centre == 0.0 {
                &self.run.data
            } else {
                centred = self
                    .run
                    .data
                    .iter()
                    .map(|r| Record {
                        reward: r.reward - centre,
                        ..*r
                    })
                    .collect();
                &centred
            };
            Some(RecordGp::fit_records(
                domain,
                records,
                Output::Reward,
                &spec,
                &self.gp_options(),
                rng,
            )?)
        };
        let mut offset = 0;
        for s in sources {
            let zs: Vec<GpInput> = s.records.iter().map(|r| domain.input(r)).collect();
            let targets: Vec<Posterior<f64>> = match &plain {
                Some(gp) => gp
                    .posteriors(&zs, noise)
                    .into_iter()
                    .map(|p| Posterior::new(centre + p.mean, p.std))
                    .collect(),
                None => model
                    .residual
                    .posteriors(&zs, noise)
                    .into_iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let prior = self.prior(
                            self.setup.record_means.iter().map(|m| m[offset + i]),
                            &model.plausibility,
                        );
                        Posterior::new(prior + p.mean, p.std)
                    })
                    .collect(),
            };
            let ys: Vec<f64> = s.records.iter().map(|r| r.reward).collect();
            let mut out = vec![0.0; ys.len()];
            self.reward
                .weights_into(&ys, &targets, &s.reward, &mut out)?;
            wr.extend(out);
            posteriors.extend(targets);
            offset += s.len();
        }
        let summary = plain.as_ref().unwrap_or(&model.residual).summary();
        Ok((wr, summary, posteriors))
    }

    /// Weighted FQI on `D₀` then the sources with `trees` trees; sources unweighted before
    /// any target data.
    fn refit(&mut self, trees: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<()> {
        let n_target = self.run.data.len();
        let mut relabelled = Vec::new();
        let (wr_source, model, gp) = if n_target == 0 {
            (vec![1.0; self.source_records], None, None)
        } else {
            let model = self.reward_model(rng)?;
            let (mut w, gp, posteriors) = self.source_weights(&model, rng)?;
            if self.options.relabel {
                let v = self.reward_variance;
                relabelled.extend(
                    posteriors
                        .iter()
                        .zip(&self.sources.rewards)
                        .map(|(p, &r)| relabelled_reward(r, p, v)),
                );
                w = vec![1.0; w.len()];
            }
            (w, Some(model), Some(gp))
        };
        let mut union: Dataset<D> = self.run.data.iter().copied().collect();
        union.extend_from(&self.sources);
        if !relabelled.is_empty() {
            union.rewards[n_target..].copy_from_slice(&relabelled);
        }
        self.rewards = (!relabelled.is_empty()).then_some(relabelled);
        let mut wr = vec![1.0; n_target];
        wr.extend_from_slice(&wr_source);
        let mut ws = vec![1.0; wr.len()];
        if self.options.corroborate {
            for j in self.uncorroborated_ends() {
                wr[n_target + j] = 0.0;
                ws[n_target + j] = 0.0;
            }
        }
        if let Some(model) = &model {
            if self.options.source_weights {
                let top = model.plausibility.iter().copied().fold(0.0, f64::max);
                for (j, &k) in self.setup.source_of.iter().enumerate() {
                    let f = model.plausibility[k] / top;
                    wr[n_target + j] *= f;
                    ws[n_target + j] *= f;
                }
            }
            if self.options.model_rewards {
                union.rewards = self.model_rewards(model, &union);
            }
        }
        match self.options.oracle {
            AdaptiveOracle::None => {}
            AdaptiveOracle::Validity if n_target > 0 => {
                let domain = self.run.domain;
                for j in 0..self.source_records {
                    let (state, action) = (self.sources.states[j], self.sources.actions[j]);
                    let target = domain.target.mean_reward(state, action)?;
                    let source =
                        domain.sources[self.setup.source_of[j]].mean_reward(state, action)?;
                    wr[n_target + j] = if (target - source).abs() < 0.3 {
                        1.0
                    } else {
                        0.0
                    };
                }
            }
            AdaptiveOracle::Validity => {}
            AdaptiveOracle::Rewards => {
                for i in 0..union.len() {
                    union.rewards[i] = self
                        .run
                        .domain
                        .target
                        .mean_reward(union.states[i], union.actions[i])?;
                }
                wr.fill(1.0);
            }
        }
        let mut options = self.run.options(FqiOptions::iwfqi(&wr, &ws));
        options.n_trees = trees;
        self.run.q = Some(fqi(&union, &options, rng)?.q.into());
        let mut s = WeightSummary::<f64>::new();
        s.add(&wr)?;
        self.last = Diagnostics {
            n_source_samples: Some(self.source_records),
            wr_mean: Some(s.mean()),
            wr_eff: Some(s.effective_sample_size()),
            reward_gp: gp,
            ..Diagnostics::default()
        };
        self.model = model;
        Ok(())
    }

    /// The source records (union order) whose episode end is corroborated neither by a
    /// target record that ends nearby (same action, within 10 % of each coordinate's
    /// range) nor by at least half of the other sources' nearest records.
    fn uncorroborated_ends(&self) -> Vec<usize> {
        let bounds = &self.run.domain.state_bounds;
        let m = self.setup.endings.len();
        let mut out = Vec::new();
        let mut offset = 0;
        for (k, records) in self.setup.endings.iter().enumerate() {
            for (i, (state, action, ends)) in records.iter().enumerate() {
                if !ends {
                    continue;
                }
                let others = (0..m)
                    .filter(|&o| o != k && self.setup.source_ends(o, state, *action, bounds))
                    .count();
                let target = self.run.data.iter().any(|r| {
                    r.absorbing
                        && r.action == *action
                        && (0..D).all(|d| {
                            (r.state[d] - state[d]).abs() <= 0.1 * (bounds[d].1 - bounds[d].0)
                        })
                });
                if !target && 2 * others < m - 1 {
                    out.push(offset + i);
                }
            }
            offset += records.len();
        }
        out
    }

    /// The reward model's mean at every record of `union` (`D₀` first, then the sources in
    /// union order).
    fn model_rewards(&self, model: &RewardModel, union: &Dataset<D>) -> Vec<f64> {
        let domain = &*self.experiment.domain;
        let n_target = self.run.data.len();
        let zs: Vec<GpInput> = (0..union.len())
            .map(|i| domain.gp_input(&union.states[i], union.actions[i]))
            .collect();
        let residual = model.residual.means(&zs);
        let target_means = self.source_means(&zs[..n_target]);
        (0..union.len())
            .map(|i| {
                let prior = if i < n_target {
                    self.prior(target_means.iter().map(|m| m[i]), &model.plausibility)
                } else {
                    let j = i - n_target;
                    self.prior(
                        self.setup.record_means.iter().map(|m| m[j]),
                        &model.plausibility,
                    )
                };
                prior + residual[i]
            })
            .collect()
    }

    /// The reward model's mean at one record (the uniform source mixture before any
    /// target data).
    fn predict(&self, record: &Record<D>) -> f64 {
        let z = [self.experiment.domain.input(record)];
        let means = self.source_means(&z);
        let m = means.len() as f64;
        match &self.model {
            Some(model) => {
                let prior = self.prior(means.iter().map(|x| x[0]), &model.plausibility);
                prior + model.residual.means(&z)[0]
            }
            None => means.iter().map(|x| x[0] / m).sum(),
        }
    }

    /// Up to `n` queries along greedy rollouts from the target's initial state (ε-greedy
    /// after the first rollout of the call); returns how many were made (fewer than `n`
    /// only when a surprise stopped them).
    fn verify(&mut self, n: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<usize> {
        let threshold = 3.0 * self.reward_variance.sqrt();
        let domain = self.run.domain;
        let num_actions = domain.num_actions();
        let epsilon = self
            .options
            .verify_epsilon
            .unwrap_or(self.run.protocol.epsilon);
        let mut left = n;
        let mut first = true;
        while left > 0 {
            let (mut state, done) = match self.resume_at.take() {
                Some(at) if self.options.resume => at,
                _ => (domain.target.initial_state(rng), 0),
            };
            for t in done..domain.horizon {
                if left == 0 {
                    if self.options.resume {
                        self.resume_at = Some((state, t));
                    }
                    break;
                }
                let explore = !first && awfqi::rng::uniform_f64(rng) < epsilon;
                let action = if explore {
                    awfqi::rng::uniform_index(rng, num_actions)
                } else {
                    self.run.greedy_action(&state)
                };
                let record = domain.target.step(state, action, rng)?;
                let surprised = self.options.surprise_stop
                    && (record.reward - self.predict(&record)).abs() > threshold;
                self.run.data.push(record);
                self.path.push(state);
                left -= 1;
                if surprised {
                    return Ok(n - left);
                }
                if record.absorbing {
                    break;
                }
                state = record.next_state;
            }
            first = false;
        }
        Ok(n)
    }

    /// States of `n` rollouts of the current greedy policy from the target's initial state
    /// in the nearest-record model of the records held (no query is made).
    fn simulate(&self, n: usize, rng: &mut ChaCha8Rng) -> Vec<[f64; D]> {
        let domain = self.run.domain;
        let model = NearestModel::new(&self.run.data, &self.sources, None, domain.state_bounds);
        let greedy = |s: &[f64; D]| self.run.greedy_action(s);
        let mut states = Vec::new();
        for _ in 0..n {
            let start = domain.target.initial_state(rng);
            model.rollout(start, &greedy, domain.horizon, domain.discount, rng, |s| {
                states.push(*s)
            });
        }
        states
    }

    /// Keeps, of this step's plans, the one whose mean discounted return over
    /// [`AdaptiveOptions::select`] simulated rollouts from the target's initial state is
    /// highest (the latest on ties), in the nearest-record model of the last refit's
    /// records and rewards (relabelled ones included).
    fn select_plan(
        &mut self,
        plans: Vec<QFunction<D>>,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<()> {
        let domain = self.run.domain;
        let model = NearestModel::new(
            &self.run.data,
            &self.sources,
            self.rewards.as_deref(),
            domain.state_bounds,
        );
        let mut best: Option<(f64, QFunction<D>)> = None;
        for plan in plans {
            let greedy = |s: &[f64; D]| plan.greedy_action(s);
            let mut total = 0.0;
            for _ in 0..self.options.select {
                let start = domain.target.initial_state(rng);
                total +=
                    model.rollout(start, &greedy, domain.horizon, domain.discount, rng, |_| {});
            }
            let value = total / self.options.select as f64;
            if best.as_ref().is_none_or(|(v, _)| value >= *v) {
                best = Some((value, plan));
            }
        }
        if let Some((_, plan)) = best {
            self.run.q = Some(plan);
        }
        Ok(())
    }

    /// `n` queries drawn from a candidate subset of the rows by the adaptive score.
    fn draw(&mut self, n: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<()> {
        if n == 0 {
            return Ok(());
        }
        let model = self.model.as_ref();
        let setup = Arc::clone(&self.setup);
        let o = self.options;
        let c = o.candidates.min(setup.rows.len());
        let picks: Vec<usize> = (0..c)
            .map(|_| awfqi::rng::uniform_index(rng, setup.rows.len()))
            .collect();
        let m = setup.row_means.len() as f64;
        let uniform = vec![1.0 / m; setup.row_means.len()];
        let pi = model.map_or(&uniform, |m| &m.plausibility);
        let zs: Vec<GpInput> = picks.iter().map(|&i| setup.row_inputs[i]).collect();
        let (res_mean, res_var) = match model {
            Some(model) => {
                let post = model
                    .residual
                    .posteriors(&zs, awfqi::weights::NoiseSubtraction::Reference);
                let c = model
                    .residual
                    .summary()
                    .signal_variance
                    .max(f64::MIN_POSITIVE);
                (
                    post.iter().map(|p| p.mean).collect(),
                    post.iter().map(|p| (p.std * p.std / c).min(1.0)).collect(),
                )
            }
            None => (vec![0.0; c], vec![1.0; c]),
        };
        let bounds = &self.run.domain.state_bounds;
        let relevance: Vec<f64> = picks
            .iter()
            .map(|&i| {
                if !o.decision || self.path.is_empty() {
                    return 1.0;
                }
                let s = &setup.rows[i].0;
                let d2 = self
                    .path
                    .iter()
                    .map(|p| {
                        (0..D)
                            .map(|d| {
                                let w = (bounds[d].1 - bounds[d].0) * o.relevance_width;
                                ((s[d] - p[d]) / w).powi(2)
                            })
                            .sum::<f64>()
                    })
                    .fold(f64::INFINITY, f64::min);
                (-0.5 * d2).exp()
            })
            .collect();
        let score: Vec<f64> = picks
            .iter()
            .enumerate()
            .map(|(j, &i)| {
                let mean: f64 = setup.row_means.iter().zip(pi).map(|(r, p)| p * r[i]).sum();
                let disagreement: f64 = setup
                    .row_means
                    .iter()
                    .zip(pi)
                    .map(|(r, p)| p * (r[i] - mean).powi(2))
                    .sum();
                let surprise = if o.surprise {
                    res_mean[j] * res_mean[j]
                } else {
                    0.0
                };
                let uncertainty = if o.uncertainty { res_var[j] } else { 1.0 };
                relevance[j] * (surprise + disagreement) * uncertainty
            })
            .collect();
        let total: f64 = score.iter().sum();
        let rel_total: f64 = relevance.iter().sum();
        let probabilities: Vec<f64> = score
            .iter()
            .zip(&relevance)
            .map(|(s, r)| {
                let drawn = if total > 0.0 { s / total } else { 0.0 };
                let floor = if total > 0.0 { o.floor } else { 1.0 };
                (1.0 - floor) * drawn + floor * r / rel_total
            })
            .collect();
        let mut storage = vec![AliasEntry::<f64>::default(); c];
        let alias = AliasTable::build(probabilities, &mut storage)?;
        for _ in 0..n {
            let (state, action) = setup.rows[picks[alias.sample(rng)]];
            let record = self.run.domain.target.step(state, action, rng)?;
            self.run.data.push(record);
        }
        Ok(())
    }
}

/// A source reward as the target sees it ([`AdaptiveOptions::relabel`]): `λ r + (1 − λ) μ`
/// with `λ = exp(−u²/2)`, `u = (r − μ)/√(σ² + v)` the reward's z-score under the target
/// GP's posterior `(μ, σ)` and the reward variance `v`. A reward the target GP does not
/// contradict (`u ≈ 0`, also wherever the GP is uncertain) stays; one it confidently
/// contradicts becomes the GP's mean.
fn relabelled_reward(r: f64, target: &Posterior<f64>, v: f64) -> f64 {
    let u = (r - target.mean) / (target.std * target.std + v).sqrt();
    let lambda = (-0.5 * u * u).exp();
    lambda * r + (1.0 - lambda) * target.mean
}

/// The median of `v` (0 when empty).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => 0.0,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Source plausibilities from the target records' clipped squared errors `e2[k][i]`:
/// `π_k ∝ exp(−Σ_i e2_ik/(2v))`, `v` the estimator's reward variance; the clip (applied by
/// the caller) keeps a feature that every source lacks from deciding.
fn plausibility(e2: &[Vec<f64>], v: f64) -> Vec<f64> {
    let log: Vec<f64> = e2
        .iter()
        .map(|e| -e.iter().sum::<f64>() / (2.0 * v))
        .collect();
    let top = log.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let w: Vec<f64> = log.iter().map(|l| (l - top).exp()).collect();
    let total: f64 = w.iter().sum();
    w.into_iter().map(|x| x / total).collect()
}

/// `0`, the tree count that means "the protocol's" (serde's `skip_serializing_if`).
fn is_protocol_trees(trees: &usize) -> bool {
    *trees == 0
}

impl<const D: usize> Learner<D> for Adaptive<'_, D> {
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        let n = self.experiment.budget();
        let s = self.options.sub_batches;
        let trees = self.run.protocol.trees;
        let plan_trees = match self.options.plan_trees {
            0 => trees,
            t => t,
        };
        let final_trees = match self.options.final_trees {
            0 => trees,
            t => t,
        };
        self.path.clear();
        self.resume_at = None;
        if self.run.q.is_none() {
            self.refit(plan_trees, rng)?;
        }
        let mut plans = Vec::new();
        if self.options.select > 0 {
            plans.extend(self.run.q.clone());
        }
        for b in 0..s {
            let quota = n * (b + 1) / s - n * b / s;
            let verify = ((quota as f64 * self.options.verify).round() as usize).min(quota);
            let made = self.verify(verify, rng)?;
            if self.options.simulate > 0 && made < quota {
                let simulated = self.simulate(self.options.simulate, rng);
                self.path.extend(simulated);
            }
            self.draw(quota - made, rng)?;
            let t = if b + 1 == s { final_trees } else { plan_trees };
            self.refit(t, rng)?;
            if self.options.select > 0 {
                plans.extend(self.run.q.clone());
            }
        }
        if self.options.select > 0 {
            self.select_plan(plans, rng)?;
        }
        Ok(self.last.clone())
    }

    fn greedy_action(&self, state: &[f64; D]) -> usize {
        self.run.greedy_action(state)
    }

    fn target_samples(&self) -> &[Record<D>] {
        &self.run.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relabelling_keeps_uncontradicted_rewards_and_replaces_contradicted_ones() {
        let v = 0.1;
        // The GP agrees: the reward stays, exactly.
        let agree = Posterior::new(-1.0, 0.3);
        assert_eq!(relabelled_reward(-1.0, &agree, v), -1.0);
        // One combined standard deviation away: λ = e^{-1/2}, by hand.
        let p = Posterior::new(-1.0, 0.3);
        let r = -1.0 - (0.09f64 + v).sqrt();
        let lambda = (-0.5f64).exp();
        let want = lambda * r - (1.0 - lambda);
        assert!((relabelled_reward(r, &p, v) - want).abs() < 1e-12);
        // A confident contradiction (the source has no puddle where the target has one):
        // the target GP's mean replaces the source's reward.
        let puddle = Posterior::new(-10.0, 0.2);
        assert!((relabelled_reward(-1.0, &puddle, v) + 10.0).abs() < 1e-9);
        // Far from the target's data the GP is uncertain: the source's reward stays
        // (u = 9/√(300² + 0.1) ≈ 0.03, so it moves by 1 − λ ≈ 4.5·10⁻⁴ of the difference).
        let unsure = Posterior::new(-10.0, 300.0);
        assert!((relabelled_reward(-1.0, &unsure, v) + 1.0).abs() < 0.01);
    }

    #[test]
    fn median_of_odd_even_and_empty_lists() {
        assert_eq!(median(vec![3.0, -1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(Vec::new()), 0.0);
    }

    #[test]
    fn plausibility_follows_the_clipped_likelihood() {
        // Source 0 matches, source 1 is off by 1 on two records: log-ratio 2·1/(2·0.5) = 2.
        let p = plausibility(&[vec![0.0, 0.0], vec![1.0, 1.0]], 0.5);
        let want = 1.0 / (1.0 + (-2.0f64).exp());
        assert!((p[0] - want).abs() < 1e-12 && (p[0] + p[1] - 1.0).abs() < 1e-12);
        // Equal (clipped) errors: no preference, however large.
        let p = plausibility(&[vec![12.5], vec![12.5]], 0.5);
        assert!((p[0] - 0.5).abs() < 1e-12);
    }
}
