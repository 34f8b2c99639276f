//! The GP fits of the puddle experiments (spec §4.2, §6, §7.2, §11.2) on top of the large-N
//! f64 GP [`crate::gp_large`]: inputs `z = (s_x, s_y, a)`, one scalar output per GP, the
//! reference's fitting procedure (initial values plus restarts, last `max_gp` samples), and
//! the noise subtraction of the predicted standard deviations.

use awfqi::dataset::Output;
use awfqi::weights::{NoiseSubtraction, Posterior};
use rand_core::Rng;

use super::sources::Record;
use crate::gp_large::{self, FitOptions, LargeGp};

/// The input `z = (s_x, s_y, a)` of a record (the action as a plain real coordinate, §1).
pub fn input(r: &Record) -> [f64; 3] {
    [r.state[0], r.state[1], r.action as f64]
}

/// How the GPs are fitted: restarts, the training cap and the search strategy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct GpOptions {
    /// Optimisations from random starts after the one from the initial values (spec: 10).
    pub restarts: usize,
    /// Only the last this many training records are used (spec `max_gp`: 4000).
    pub max_gp: usize,
    /// The search strategy (absent from result files when it is the spec's).
    #[serde(default, skip_serializing_if = "GpSearch::is_spec")]
    pub search: GpSearch,
}

/// How the hyperparameter optimisations are spent.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum GpSearch {
    /// Spec §4.2: every start optimised on all the data.
    #[default]
    Spec,
    /// `gp_large`'s screened search: starts screened on a 300-point subsample, then the
    /// distinct end points refined on all the data. Not the spec's procedure; a budget
    /// option for large target sets.
    Screened,
}

impl GpSearch {
    /// `true` for [`GpSearch::Spec`].
    pub fn is_spec(&self) -> bool {
        *self == GpSearch::Spec
    }
}

impl GpOptions {
    /// Spec §4.2: 10 restarts, `max_gp` 4000.
    pub fn reference() -> Self {
        Self {
            restarts: gp_large::DEFAULT_RESTARTS,
            max_gp: gp_large::MAX_GP,
            search: GpSearch::Spec,
        }
    }

    fn fit_options(&self) -> FitOptions {
        FitOptions {
            restarts: self.restarts,
            max_points: self.max_gp,
            strategy: match self.search {
                GpSearch::Spec => gp_large::FitStrategy::AllStarts,
                GpSearch::Screened => gp_large::FitStrategy::SCREENED,
            },
            ..FitOptions::default()
        }
    }
}

/// A GP fitted on one output of a set of records.
#[derive(Debug, Clone)]
pub struct RecordGp {
    gp: LargeGp<3>,
}

/// What a fit reached: for the per-step diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GpSummary {
    /// Training points used.
    pub points: usize,
    /// Fitted signal variance `c`.
    pub signal_variance: f64,
    /// Fitted length scale `ℓ`.
    pub length_scale: f64,
    /// Fitted noise variance `σ²ₙ`.
    pub noise_variance: f64,
    /// Log marginal likelihood at the optimum.
    pub log_marginal_likelihood: f64,
}

impl RecordGp {
    /// Fits a GP on `output` of `records` (§4.2: fresh initial hyperparameters, restarts,
    /// the last `max_gp` records).
    pub fn fit<R: Rng + ?Sized>(
        records: &[Record],
        output: Output,
        options: &GpOptions,
        rng: &mut R,
    ) -> anyhow::Result<Self> {
        let inputs: Vec<[f64; 3]> = records.iter().map(input).collect();
        let targets = records
            .iter()
            .map(|r| output.of(r))
            .collect::<awfqi::Result<Vec<f64>>>()?;
        let (gp, _) = LargeGp::fit(&inputs, &targets, &options.fit_options(), rng)?;
        Ok(Self { gp })
    }

    /// Hyperparameters and likelihood reached.
    pub fn summary(&self) -> GpSummary {
        let h = self.gp.hyperparameters();
        GpSummary {
            points: self.gp.len(),
            signal_variance: h.signal_variance,
            length_scale: h.length_scale,
            noise_variance: h.noise_variance,
            log_marginal_likelihood: self.gp.log_marginal_likelihood(),
        }
    }

    /// Posterior means at `zs`.
    pub fn means(&self, zs: &[[f64; 3]]) -> Vec<f64> {
        let mut means = vec![0.0; zs.len()];
        let mut stds = vec![0.0; zs.len()];
        self.gp
            .predict_into(zs, &mut means, &mut stds)
            .expect("output lengths match the inputs");
        means
    }

    /// Posteriors `(μ, σ)` at `zs` as one batch, the predictive stds (which include the
    /// noise) turned into stds of the mean function by `noise` (§4.2; `Off` keeps them).
    pub fn posteriors(&self, zs: &[[f64; 3]], noise: NoiseSubtraction) -> Vec<Posterior<f64>> {
        let mut means = vec![0.0; zs.len()];
        let mut stds = vec![0.0; zs.len()];
        self.gp
            .predict_into(zs, &mut means, &mut stds)
            .expect("output lengths match the inputs");
        let sigma2 = self.gp.hyperparameters().noise_variance;
        match noise {
            NoiseSubtraction::Reference => {
                gp_large::subtract_noise(&mut stds, sigma2, gp_large::NoiseSubtraction::Reference);
            }
            NoiseSubtraction::Principled => {
                gp_large::subtract_noise(&mut stds, sigma2, gp_large::NoiseSubtraction::Variance);
            }
            NoiseSubtraction::Off => {}
        }
        means
            .into_iter()
            .zip(stds)
            .map(|(m, s)| Posterior::new(m, s.max(0.0)))
            .collect()
    }
}

/// The three GPs of one source (reward, next x, next y; §6 step 3, §11.2).
#[derive(Debug, Clone)]
pub struct SourceGps {
    /// Reward, next-x and next-y GPs.
    pub gps: [RecordGp; 3],
}

impl SourceGps {
    /// Fits the three GPs on all records of a source (in the order reward, next x, next y).
    pub fn fit<R: Rng + ?Sized>(
        records: &[Record],
        options: &GpOptions,
        rng: &mut R,
    ) -> anyhow::Result<Self> {
        let reward = RecordGp::fit(records, Output::Reward, options, rng)?;
        let next_x = RecordGp::fit(records, Output::NextState(0), options, rng)?;
        let next_y = RecordGp::fit(records, Output::NextState(1), options, rng)?;
        Ok(Self {
            gps: [reward, next_x, next_y],
        })
    }

    /// The three posteriors at the records' own inputs, noise-subtracted per GP over the
    /// batch (§6 step 3).
    pub fn posteriors_at(
        &self,
        records: &[Record],
        noise: NoiseSubtraction,
    ) -> anyhow::Result<[Vec<Posterior<f64>>; 3]> {
        let zs: Vec<[f64; 3]> = records.iter().map(input).collect();
        Ok(std::array::from_fn(|k| self.gps[k].posteriors(&zs, noise)))
    }
}

impl SourceGps {
    /// The posterior means of the three GPs at `zs` (reward, next x, next y): the value
    /// triples `(ρ_r, ρ_x, ρ_y)` of the realistic score table (§11.2), in batch.
    pub fn means_at(&self, zs: &[[f64; 3]]) -> [Vec<f64>; 3] {
        std::array::from_fn(|k| self.gps[k].means(zs))
    }
}
