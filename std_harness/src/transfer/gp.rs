//! The GP fits of the transfer experiments (spec §4.2, §6, §7.2, §11.2) on records of any
//! domain: inputs `z = (s, value(a))` ([`crate::domains::Domain::input`]), one scalar
//! output per GP, and either the reference's fitting procedure (initial values plus
//! restarts, last `max_gp` records, [`crate::gp_large::LargeGp`]) or the fixed kernels of
//! the IWFQI paper's Dam and Acrobot runs ([`crate::gp_large::fixed::FixedGp`]), and the
//! noise subtraction of the predicted standard deviations.

use awfqi::weights::{NoiseSubtraction, Posterior, predictive_stds};
use rand_core::Rng;

use crate::domains::{Domain, GP_INPUT, GpInput, Record};
use crate::gp_large::fixed::{FixedGp, FixedKernel, PredictiveVariance};
use crate::gp_large::growing::{GrowingFixedGp, Storage};
use crate::gp_large::{self, FitOptions, LargeGp};

/// Which value of a record a GP models: the core's.
pub use awfqi::record_gp::Output;

/// How a GP's kernel is obtained.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub enum KernelSpec {
    /// Constant × isotropic RBF plus white noise, fitted by marginal likelihood (§4.2).
    Fitted,
    /// A fixed kernel (the Dam's and Acrobot's published ones).
    Fixed(FixedKernel),
}

/// One GP of an experiment: its kernel and whether the fitted noise is subtracted from its
/// predicted stds.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct GpSpec {
    /// The kernel.
    pub kernel: KernelSpec,
    /// `false`: stds are used as predicted (the reference's `subtract_noise_* = False`).
    pub subtract_noise: bool,
}

impl GpSpec {
    /// Spec §4.2's fitted GP with noise subtraction (Puddle World).
    pub fn fitted() -> Self {
        Self {
            kernel: KernelSpec::Fitted,
            subtract_noise: true,
        }
    }

    /// A fixed kernel, with or without noise subtraction.
    pub fn fixed(kernel: FixedKernel, subtract_noise: bool) -> Self {
        Self {
            kernel: KernelSpec::Fixed(kernel),
            subtract_noise,
        }
    }

    /// The noise subtraction this GP applies when the experiment asks for `requested`
    /// (a GP without subtraction keeps its stds).
    pub fn noise(&self, requested: NoiseSubtraction) -> NoiseSubtraction {
        if self.subtract_noise {
            requested
        } else {
            NoiseSubtraction::Off
        }
    }
}

/// How IWFQI weighs the source records of a domain: the GP of the reward and, per state
/// dimension, the GP of the next-state coordinate when that dimension is weighted.
#[derive(Debug, Clone, PartialEq)]
pub struct Weighting<const D: usize> {
    /// The reward GP.
    pub reward: GpSpec,
    /// Per state dimension: `Some(GP)` when the published runs weighed it.
    pub transition: [Option<GpSpec>; D],
    /// The GP of a dimension the published runs did not weigh, used when transition
    /// weights are forced on (`--transition-weights true`).
    pub transition_fallback: GpSpec,
}

impl<const D: usize> Weighting<D> {
    /// The GP of `output`: the reward GP, the weighted dimension's GP, or the fallback for
    /// an unweighted dimension.
    pub fn gp_spec(&self, output: Output) -> GpSpec {
        match output {
            Output::Reward => self.reward.clone(),
            Output::NextState(d) => self
                .transition
                .get(d)
                .cloned()
                .flatten()
                .unwrap_or_else(|| self.transition_fallback.clone()),
        }
    }
}

/// How the fitted GPs are fitted: restarts, the training cap and the search strategy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct GpOptions {
    /// Optimisations from random starts after the one from the initial values (spec: 10).
    pub restarts: usize,
    /// Only the last this many training records are used (spec `max_gp`: 4000).
    pub max_gp: usize,
    /// The search strategy asked for (`--gp-search`); `None`: each learner's default
    /// ([`GpOptions::resolved`]). Absent from result files when not asked for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub search: Option<GpSearch>,
    /// Also run the other search (spec ↔ screened) on every fit, on the same data and
    /// starts, and record both optima in [`search_checks`]. The kept GP is `search`'s, so
    /// the results do not change; never written to result files.
    #[serde(skip)]
    pub check: bool,
    /// How IWFQI's fixed-kernel target GPs follow the growing target data (`--fixed-gp`).
    /// Absent from result files when it is the default.
    #[serde(default, skip_serializing_if = "FixedGpUpdate::is_default")]
    pub fixed_update: FixedGpUpdate,
    /// How the fixed-kernel GPs compute their predictive variance (`--fixed-gp-variance`;
    /// the explicit inverse is scikit-learn's arithmetic, an ablation). Absent from result
    /// files when it is the default.
    #[serde(default, skip_serializing_if = "PredictiveVariance::is_default")]
    pub fixed_variance: PredictiveVariance,
}

/// How a fixed-kernel target GP (the Dam's and Acrobot's) follows the target data, which
/// only grows from step to step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FixedGpUpdate {
    /// Append each step's records to the factor and to the posterior at the source
    /// records ([`GrowingFixedGp`]): the refit's posterior to rounding, at `n²Δ + nΔq`
    /// instead of `n³/3 + n²q` a step, but holding the factor and `L⁻¹K(X, Q)` between
    /// steps (Acrobot: ≈ 7 GB a run at the last step).
    #[default]
    Incremental,
    /// As `Incremental`, keeping only the factor's lower triangle and recomputing the rows
    /// of `L⁻¹K(X, Q)` an append needs ([`Storage::Compact`]): less memory (Acrobot: a
    /// run peaks at 2.3 GB instead of 7.7 GB) for `n·q` kernel evaluations and one more
    /// triangular solve a step; the same posterior to rounding.
    Compact,
    /// Recondition on all target records every step, as the reference does.
    Refit,
}

impl FixedGpUpdate {
    fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// What an appended GP keeps between steps; `None` when the GP is refitted.
    pub fn storage(&self) -> Option<Storage> {
        match self {
            Self::Incremental => Some(Storage::Stored),
            Self::Compact => Some(Storage::Compact),
            Self::Refit => None,
        }
    }
}

/// One checked fit (see [`GpOptions::check`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchCheck {
    /// The search whose GP was kept.
    pub search: GpSearch,
    /// Training points.
    pub points: usize,
    /// Both searches' optima, counts and times.
    pub comparison: gp_large::SearchComparison,
}

static SEARCH_CHECKS: std::sync::Mutex<Vec<SearchCheck>> = std::sync::Mutex::new(Vec::new());

/// Takes the fits checked so far in this process (in completion order).
pub fn search_checks() -> Vec<SearchCheck> {
    SEARCH_CHECKS
        .lock()
        .map(|mut v| std::mem::take(&mut *v))
        .unwrap_or_default()
}

/// How the hyperparameter optimisations are spent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GpSearch {
    /// Spec §4.2: every start optimised on all the data.
    #[default]
    Spec,
    /// `gp_large`'s screened search: starts screened on a 300-point subsample, then the
    /// distinct end points refined on all the data. Not the spec's procedure; a budget
    /// option for large target sets.
    Screened,
    /// `gp_large`'s staged search: the screened search with a 1 000-point stage between
    /// the subsample and all the data, whose curvature model starts the full-data
    /// optimisation. Not the spec's procedure; fewer `O(n³)` evaluations than `screened`
    /// above 1 000 target points.
    Staged,
}

impl GpOptions {
    /// Spec §4.2: 10 restarts, `max_gp` 4000, each learner's default search.
    pub fn published() -> Self {
        Self {
            restarts: gp_large::DEFAULT_RESTARTS,
            max_gp: gp_large::MAX_GP,
            search: None,
            check: false,
            fixed_update: FixedGpUpdate::Incremental,
            fixed_variance: PredictiveVariance::Stable,
        }
    }

    /// These options with the search fixed: the one asked for, else `default` (a learner's
    /// default: [`GpSearch::Screened`] where it was checked to land on the spec's optimum,
    /// [`GpSearch::Spec`] elsewhere).
    pub fn resolved(&self, default: GpSearch) -> Self {
        Self {
            search: Some(self.search.unwrap_or(default)),
            ..*self
        }
    }

    /// The search these options run (the spec's when none was resolved).
    pub fn search(&self) -> GpSearch {
        self.search.unwrap_or(GpSearch::Spec)
    }

    fn fit_options(&self) -> FitOptions {
        FitOptions {
            restarts: self.restarts,
            max_points: self.max_gp,
            strategy: match self.search() {
                GpSearch::Spec => gp_large::FitStrategy::AllStarts,
                GpSearch::Screened => gp_large::FitStrategy::SCREENED,
                GpSearch::Staged => gp_large::FitStrategy::STAGED,
            },
            compare: self.check.then_some(match self.search() {
                GpSearch::Spec => gp_large::FitStrategy::SCREENED,
                GpSearch::Screened | GpSearch::Staged => gp_large::FitStrategy::AllStarts,
            }),
            ..FitOptions::default()
        }
    }
}

#[derive(Debug, Clone)]
enum Model {
    Fitted(LargeGp<GP_INPUT>),
    Fixed(FixedGp<GP_INPUT>),
}

/// A GP fitted on one output of a set of records.
#[derive(Debug, Clone)]
pub struct RecordGp {
    model: Model,
}

/// What a fit reached: for the per-step diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GpSummary {
    /// Training points used.
    pub points: usize,
    /// Fitted signal variance `c` (fixed kernels: the sum of their terms').
    pub signal_variance: f64,
    /// Fitted length scale `ℓ` (fixed kernels: the first term's first one).
    pub length_scale: f64,
    /// Fitted noise variance `σ²ₙ`.
    pub noise_variance: f64,
    /// Log marginal likelihood at the optimum (fixed kernels: the jitter used instead,
    /// negated, so a retried factorisation shows).
    pub log_marginal_likelihood: f64,
}

impl RecordGp {
    /// Fits a GP with `spec` on `(inputs, targets)`, the last `options.max_gp` of them
    /// (§4.2: fresh initial hyperparameters and restarts for a fitted kernel; a fixed one
    /// is conditioned, split exactly along coordinate `split` when it decorrelates there).
    pub fn fit<R: Rng + ?Sized>(
        inputs: &[GpInput],
        targets: &[f64],
        spec: &GpSpec,
        options: &GpOptions,
        split: Option<usize>,
        rng: &mut R,
    ) -> anyhow::Result<Self> {
        let model = match &spec.kernel {
            KernelSpec::Fitted => {
                let (gp, report) = LargeGp::fit(inputs, targets, &options.fit_options(), rng)?;
                if let Some(comparison) = report.comparison
                    && let Ok(mut checks) = SEARCH_CHECKS.lock()
                {
                    checks.push(SearchCheck {
                        search: options.search(),
                        points: gp.len(),
                        comparison,
                    });
                }
                Model::Fitted(gp)
            }
            KernelSpec::Fixed(kernel) => {
                let skip = inputs.len().saturating_sub(options.max_gp);
                let gp = FixedGp::fit(
                    &inputs[skip..],
                    &targets[skip..],
                    kernel,
                    split,
                    faer::Par::Seq,
                )?
                .with_variance(options.fixed_variance);
                Model::Fixed(gp)
            }
        };
        Ok(Self { model })
    }

    /// Fits `output` of `records` of `domain` (the action coordinate is the split one).
    pub fn fit_records<const D: usize, R: Rng + ?Sized>(
        domain: &Domain<D>,
        records: &[Record<D>],
        output: Output,
        spec: &GpSpec,
        options: &GpOptions,
        rng: &mut R,
    ) -> anyhow::Result<Self> {
        let inputs: Vec<GpInput> = records.iter().map(|r| domain.input(r)).collect();
        let targets = records
            .iter()
            .map(|r| output.of(r))
            .collect::<awfqi::Result<Vec<f64>>>()?;
        Self::fit(&inputs, &targets, spec, options, Some(D), rng)
    }

    /// Hyperparameters and likelihood reached.
    pub fn summary(&self) -> GpSummary {
        match &self.model {
            Model::Fitted(gp) => {
                let h = gp.hyperparameters();
                GpSummary {
                    points: gp.len(),
                    signal_variance: h.signal_variance,
                    length_scale: h.length_scale,
                    noise_variance: h.noise_variance,
                    log_marginal_likelihood: gp.log_marginal_likelihood(),
                }
            }
            Model::Fixed(gp) => fixed_summary(gp.kernel(), gp.len(), gp.jitter()),
        }
    }

    fn noise_variance(&self) -> f64 {
        match &self.model {
            Model::Fitted(gp) => gp.hyperparameters().noise_variance,
            Model::Fixed(gp) => gp.kernel().noise_variance,
        }
    }

    fn predict_into(&self, zs: &[GpInput], means: &mut [f64], stds: &mut [f64]) {
        let result = match &self.model {
            Model::Fitted(gp) => gp.predict_into(zs, means, stds),
            Model::Fixed(gp) => gp.predict_into(zs, means, stds),
        };
        if result.is_err() {
            // Only a query correlated with several split blocks fails: report it as
            // unknown (NaN means give weight 0 downstream, never a wrong weight).
            means.fill(f64::NAN);
            stds.fill(f64::NAN);
        }
    }

    /// Posterior means at `zs`.
    pub fn means(&self, zs: &[GpInput]) -> Vec<f64> {
        let mut means = vec![0.0; zs.len()];
        let mut stds = vec![0.0; zs.len()];
        self.predict_into(zs, &mut means, &mut stds);
        means
    }

    /// Posteriors `(μ, σ)` at `zs` as one batch, the predictive stds (which include the
    /// noise) turned into stds of the mean function by `noise` (§4.2; `Off` keeps them).
    pub fn posteriors(&self, zs: &[GpInput], noise: NoiseSubtraction) -> Vec<Posterior<f64>> {
        let mut means = vec![0.0; zs.len()];
        let mut stds = vec![0.0; zs.len()];
        self.predict_into(zs, &mut means, &mut stds);
        posteriors_from(&means, &stds, noise, self.noise_variance())
    }
}

/// Posteriors from one batch's means and predictive stds, the stds turned into stds of the
/// mean function by `noise` over the batch.
fn posteriors_from(
    means: &[f64],
    stds: &[f64],
    noise: NoiseSubtraction,
    noise_variance: f64,
) -> Vec<Posterior<f64>> {
    // The core's one rule (awfqi::weights::predictive_stds) on the noisy variances s².
    // Exact: in binary floating point √(s·s) = s whenever s·s neither overflows nor
    // underflows, and predicted stds are far from both. A batch the GP could not predict
    // (NaN, see `RecordGp::predict_into`) is left as it is.
    let mut variances: Vec<f64> = stds.iter().map(|s| s * s).collect();
    let stds = if predictive_stds(noise, noise_variance, &mut variances).is_ok() {
        &variances[..]
    } else {
        stds
    };
    means
        .iter()
        .zip(stds)
        .map(|(&m, &s)| Posterior::new(m, s.max(0.0)))
        .collect()
}

/// The summary of a fixed-kernel GP: the sum of its terms' signal variances, the first
/// term's first length scale, and the jitter (negated) in place of a likelihood.
fn fixed_summary(kernel: &FixedKernel, points: usize, jitter: f64) -> GpSummary {
    GpSummary {
        points,
        signal_variance: kernel.terms.iter().map(|t| t.signal_variance).sum(),
        length_scale: kernel
            .terms
            .first()
            .and_then(|t| t.length_scales.first())
            .copied()
            .unwrap_or(f64::NAN),
        noise_variance: kernel.noise_variance,
        log_marginal_likelihood: -jitter,
    }
}

/// A fixed-kernel target GP kept conditioned at the source records as target records
/// arrive ([`FixedGpUpdate::Incremental`]), for IWFQI's weights.
#[derive(Debug, Clone)]
pub struct GrowingRecordGp {
    gp: GrowingFixedGp<GP_INPUT>,
    output: Output,
    /// The queries' batches (one per source), in order.
    batches: Vec<usize>,
    subtract_noise: bool,
}

impl GrowingRecordGp {
    /// The GP `spec` of `output` on `domain`, to be predicted at `batches` of inputs (one
    /// per source), keeping `storage` between steps; `None` when that GP's kernel is
    /// fitted, not fixed.
    pub fn new<const D: usize>(
        _domain: &Domain<D>,
        spec: &GpSpec,
        output: Output,
        batches: &[Vec<GpInput>],
        storage: Storage,
    ) -> Option<anyhow::Result<Self>> {
        let KernelSpec::Fixed(kernel) = &spec.kernel else {
            return None;
        };
        let queries: Vec<GpInput> = batches.iter().flatten().copied().collect();
        Some(
            GrowingFixedGp::new(kernel, Some(D), queries, faer::Par::Seq)
                .map(|gp| Self {
                    gp: gp.with_storage(storage),
                    output,
                    batches: batches.iter().map(Vec::len).collect(),
                    subtract_noise: spec.subtract_noise,
                })
                .map_err(Into::into),
        )
    }

    /// Conditions on `records` (all target records so far, the last `max_gp` of them as
    /// [`RecordGp::fit_records`] would): appends the new ones. `Ok(false)` when that is not
    /// possible — more than `max_gp` records (the window slides) or records that do not
    /// continue the ones conditioned on — so the caller refits instead.
    pub fn update<const D: usize>(
        &mut self,
        domain: &Domain<D>,
        records: &[Record<D>],
        max_gp: usize,
    ) -> anyhow::Result<bool> {
        let known = self.gp.len();
        let continues = records.len() >= known
            && records.len() <= max_gp
            && records[..known]
                .iter()
                .zip(self.gp.inputs())
                .all(|(r, z)| domain.input(r) == *z);
        if !continues {
            return Ok(false);
        }
        let new = &records[known..];
        let inputs: Vec<GpInput> = new.iter().map(|r| domain.input(r)).collect();
        let targets = new
            .iter()
            .map(|r| self.output.of(r))
            .collect::<awfqi::Result<Vec<f64>>>()?;
        self.gp.extend(&inputs, &targets)?;
        Ok(true)
    }

    /// The posteriors at every batch, noise-subtracted per batch as
    /// [`RecordGp::posteriors`] (when this GP subtracts at all).
    pub fn posteriors(&self, noise: NoiseSubtraction) -> Vec<Vec<Posterior<f64>>> {
        let q = self.gp.queries().len();
        let (mut means, mut stds) = (vec![0.0; q], vec![0.0; q]);
        if self.gp.posterior_into(&mut means, &mut stds).is_err() {
            // As `RecordGp::predict_into`: unknown, never a wrong weight.
            means.fill(f64::NAN);
            stds.fill(f64::NAN);
        }
        let noise = if self.subtract_noise {
            noise
        } else {
            NoiseSubtraction::Off
        };
        let noise_variance = self.gp.kernel().noise_variance;
        let mut start = 0;
        self.batches
            .iter()
            .map(|&len| {
                let range = start..start + len;
                start += len;
                posteriors_from(&means[range.clone()], &stds[range], noise, noise_variance)
            })
            .collect()
    }

    /// Points, kernel and jitter, as [`RecordGp::summary`] reports a fixed GP.
    pub fn summary(&self) -> GpSummary {
        fixed_summary(self.gp.kernel(), self.gp.len(), self.gp.jitter())
    }
}

/// The GPs of one source: the reward's, then one per listed next-state coordinate (§6 step
/// 3, §11.2).
#[derive(Debug, Clone)]
pub struct SourceGps {
    /// The GPs, in the order of `outputs`.
    pub gps: Vec<RecordGp>,
    /// What each GP models.
    pub outputs: Vec<Output>,
    /// Their specs.
    specs: Vec<GpSpec>,
}

impl SourceGps {
    /// Fits one GP per output on all `records` of a source, in the order of `outputs`,
    /// with `weighting`'s GP of each output.
    pub fn fit<const D: usize, R: Rng + ?Sized>(
        domain: &Domain<D>,
        weighting: &Weighting<D>,
        records: &[Record<D>],
        outputs: &[Output],
        options: &GpOptions,
        rng: &mut R,
    ) -> anyhow::Result<Self> {
        let specs: Vec<GpSpec> = outputs.iter().map(|&o| weighting.gp_spec(o)).collect();
        let gps = outputs
            .iter()
            .zip(&specs)
            .map(|(&o, spec)| RecordGp::fit_records(domain, records, o, spec, options, rng))
            .collect::<anyhow::Result<_>>()?;
        Ok(Self {
            gps,
            outputs: outputs.to_vec(),
            specs,
        })
    }

    /// The posteriors at the records' own inputs, noise-subtracted per GP over the batch
    /// by the reference's rule where the GP subtracts at all (§6 step 3).
    pub fn posteriors_at<const D: usize>(
        &self,
        domain: &Domain<D>,
        records: &[Record<D>],
    ) -> anyhow::Result<Vec<Vec<Posterior<f64>>>> {
        let zs: Vec<GpInput> = records.iter().map(|r| domain.input(r)).collect();
        Ok(self
            .gps
            .iter()
            .zip(&self.specs)
            .map(|(gp, spec)| gp.posteriors(&zs, spec.noise(NoiseSubtraction::Reference)))
            .collect())
    }

    /// The posterior means of the GPs at `zs`, in the order of the outputs: the values of
    /// the realistic score table (§11.2), in batch.
    pub fn means_at(&self, zs: &[GpInput]) -> Vec<Vec<f64>> {
        self.gps.iter().map(|g| g.means(zs)).collect()
    }
}

#[cfg(test)]
mod tests;
