//! The algorithms compared on the protocol of §3, one module each, and the experiment
//! context they share ([`Experiment`]).

pub mod embedded;
pub mod episodic;
pub mod iwfqi;
pub mod plain_fqi;
pub mod rbt;
pub mod sdt;

use std::sync::Arc;

use awfqi::weights::{Estimator, NoiseSubtraction};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use self::rbt::ComplianceSum;
use super::domain_data::DomainData;
use super::gp::{GpOptions, GpSearch};
use super::protocol::{Learner, Protocol};
use super::score_tables::ScoreTableData;
use super::sources::SourceSet;
use crate::domains::{Domain, IdealMeans};

/// The algorithms compared, in the order the outputs list them; their names, seed ids,
/// plot colours and descriptions are one table ([`Algorithm::row`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum Algorithm {
    /// Plain FQI on target episodes (§5).
    Fqi,
    /// IWFQI with the mean estimator (§7).
    Iwfqi,
    /// IWFQI with the heuristic estimator (§7.5).
    IwfqiHeuristic,
    /// IWFQI with the ideal weights of §7.7.
    IwfqiIdeal,
    /// Relevance-based transfer (§8).
    Rbt,
    /// Shared-dynamics transfer (§9).
    Sdt,
    /// AWFQI with the realistic (GP) score table (§12).
    Awfqi,
    /// AWFQI with the oracle score table (§12).
    AwfqiOracle,
    /// The thesis's AWFQI as the core runs it (`awfqi::thesis::Awfqi`: f32, fixed memory).
    AwfqiEmbedded,
    /// The adaptive AWFQI as the core runs it (`awfqi::adaptive::AdaptiveAwfqi`: f32, fixed memory):
    /// queries re-planned from the target's answers within every step (not a thesis
    /// algorithm).
    AwfqiAdaptive,
}

/// One row of the algorithm table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AlgorithmRow {
    /// The name in file names, tables, plots and on the command line.
    pub name: &'static str,
    /// The seed stream's identifier: never changed, never reused.
    pub id: u64,
    /// Colour index in the plot palette ([`crate::plot::PALETTE`]; the yellow one, 6, is
    /// left for the source states of the scatter plots).
    pub color: usize,
    /// One line on what it is (the command line's help).
    pub description: &'static str,
}

impl Algorithm {
    /// Every algorithm.
    pub const ALL: [Algorithm; 10] = [
        Algorithm::Fqi,
        Algorithm::Iwfqi,
        Algorithm::IwfqiHeuristic,
        Algorithm::IwfqiIdeal,
        Algorithm::Rbt,
        Algorithm::Sdt,
        Algorithm::Awfqi,
        Algorithm::AwfqiOracle,
        Algorithm::AwfqiEmbedded,
        Algorithm::AwfqiAdaptive,
    ];

    /// The algorithm table. Each algorithm has a colour of its own (the headline, the
    /// adaptive AWFQI, the crimson). Seed id 10 belonged to a retired std version of the
    /// adaptive AWFQI: never reuse it.
    pub const fn row(self) -> AlgorithmRow {
        let (name, id, color, description) = match self {
            Algorithm::Fqi => ("fqi", 1, 7, "FQI on the target's episodes alone (spec §5)"),
            Algorithm::Iwfqi => ("iwfqi", 2, 0, "IWFQI, mean estimator (spec §7)"),
            Algorithm::IwfqiHeuristic => (
                "iwfqi-heuristic",
                3,
                10,
                "IWFQI, heuristic estimator (spec §7.5)",
            ),
            Algorithm::IwfqiIdeal => (
                "iwfqi-ideal",
                4,
                5,
                "IWFQI with the ideal weights from the true models (spec §7.7)",
            ),
            Algorithm::Rbt => ("rbt", 5, 4, "Relevance-based transfer (spec §8)"),
            Algorithm::Sdt => ("sdt", 6, 3, "Shared-dynamics transfer (spec §9)"),
            Algorithm::Awfqi => (
                "awfqi",
                7,
                1,
                "The thesis's AWFQI: queries drawn from the realistic score table (spec §12)",
            ),
            Algorithm::AwfqiOracle => (
                "awfqi-oracle",
                8,
                2,
                "AWFQI with the oracle score table (spec §12)",
            ),
            Algorithm::AwfqiEmbedded => (
                "awfqi-embedded",
                9,
                9,
                "The thesis's AWFQI as the core runs it: f32, fixed memory, tile-coded FQI",
            ),
            Algorithm::AwfqiAdaptive => (
                "awfqi-adaptive",
                11,
                8,
                "AWFQI re-planning its queries from the target's answers within every step, \
                 as the core runs it (f32, fixed memory)",
            ),
        };
        AlgorithmRow {
            name,
            id,
            color,
            description,
        }
    }

    /// The name used in file names, tables and on the command line.
    pub fn name(self) -> &'static str {
        self.row().name
    }

    /// Stable identifier used in seeding (never reorder).
    pub fn id(self) -> u64 {
        self.row().id
    }

    /// Colour index in the plot palette.
    pub fn color(self) -> usize {
        self.row().color
    }

    /// One line on what the algorithm is.
    pub fn description(self) -> &'static str {
        self.row().description
    }

    /// `true` for the algorithms whose target data are generative-model queries.
    pub fn is_active(self) -> bool {
        matches!(
            self,
            Algorithm::Awfqi
                | Algorithm::AwfqiOracle
                | Algorithm::AwfqiEmbedded
                | Algorithm::AwfqiAdaptive
        )
    }

    /// `true` for the algorithms that need the realistic score table.
    pub fn needs_realistic_table(self) -> bool {
        matches!(self, Algorithm::Awfqi)
    }

    /// `true` for the core's algorithms (`f32`, fixed memory, borrowed storage: they run
    /// through [`Experiment::with_learner`] on the experiment's embedded set-up).
    pub fn is_embedded(self) -> bool {
        matches!(self, Algorithm::AwfqiEmbedded | Algorithm::AwfqiAdaptive)
    }
}

/// IWFQI's estimator variances (§7.1, §14.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Variances {
    /// The published runs' values: Puddle World's `v_r = 0.1`, `v_s = 0.2` (standard
    /// deviations used as variances), the Dam's 0.25 and 4, Acrobot's 0.01 and 1.
    Published,
    /// Puddle World's true noise variances `v_r = 0.01`, `v_s = 0.04` (the Dam's and
    /// Acrobot's rewards have no noise, so there is no such value for them).
    Corrected,
}

impl Variances {
    /// Puddle World's `(v_r, v_s)`.
    pub fn values(self) -> (f64, f64) {
        match self {
            Variances::Published => (0.1, 0.2),
            Variances::Corrected => (0.01, 0.04),
        }
    }
}

/// Options of the transfer algorithms that the spec exposes (§7.1, §8, §14).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TransferOptions {
    /// `(v_r, v_s)` of the estimated weights.
    pub variances: Variances,
    /// Weight cap `w_max` (1000).
    pub max_weight: f64,
    /// Noise subtraction of the target GPs' stds (reference rule by default).
    #[serde(serialize_with = "serialize_noise")]
    pub noise: NoiseSubtraction,
    /// Target-GP fitting (10 restarts, max_gp 4000).
    pub gp: GpOptions,
    /// Transition weights on (`None`: the published configuration of the domain: off for
    /// shared-dynamics Puddle World, on for puddle-based (§7.6), on the Dam's storage and
    /// on Acrobot's four coordinates).
    pub transition_weights: Option<bool>,
    /// RBT's `n_total` (500).
    pub rbt_total: usize,
    /// RBT's compliance aggregate (the spec's means; written to the result files only
    /// when sums).
    #[serde(skip_serializing_if = "ComplianceSum::is_spec")]
    pub rbt_compliance: ComplianceSum,
    /// How the ideal weights get mean next states (`None`: the domain's published way).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ideal_means: Option<IdealMeans>,
}

fn serialize_noise<S: serde::Serializer>(n: &NoiseSubtraction, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(match n {
        NoiseSubtraction::Reference => "reference",
        NoiseSubtraction::Principled => "principled",
        NoiseSubtraction::Off => "off",
    })
}

impl Default for TransferOptions {
    fn default() -> Self {
        Self {
            variances: Variances::Published,
            max_weight: 1000.0,
            noise: NoiseSubtraction::Reference,
            gp: GpOptions::published(),
            transition_weights: None,
            rbt_total: 500,
            rbt_compliance: ComplianceSum::Means,
            ideal_means: None,
        }
    }
}

/// Everything the runs of one experiment share (read-only, across threads).
#[derive(Debug, Clone)]
pub struct Experiment<const D: usize = 2> {
    /// The domain.
    pub domain: Arc<Domain<D>>,
    /// The domain's source data and weighting.
    pub data: Arc<DomainData<D>>,
    /// The protocol.
    pub protocol: Protocol,
    /// The source datasets.
    pub sources: Arc<SourceSet<D>>,
    /// Options of the transfer algorithms.
    pub options: TransferOptions,
    /// The oracle score table of the setting (AWFQI_oracle).
    pub oracle_table: Option<Arc<ScoreTableData<D>>>,
    /// The realistic score table of the setting (AWFQI).
    pub realistic_table: Option<Arc<ScoreTableData<D>>>,
    /// The ideal weights `(w_r, w_s)` of every source record (IWFQI-ideal), computed once.
    pub ideal_weights: Option<Arc<(Vec<f64>, Vec<f64>)>>,
    /// The embedded algorithms' shared set-up on the domain's plant (`None`: no embedded
    /// algorithm asked for, or none on this domain).
    pub embedded: Option<Arc<dyn embedded::SharedSetup<D>>>,
    /// `awfqi-adaptive`'s options.
    pub adaptive_options: embedded::adaptive::AdaptiveOptions,
}

impl<const D: usize> Experiment<D> {
    /// Whether IWFQI-type algorithms use transition weights here.
    pub fn transition_weights(&self) -> bool {
        !self.transition_dims().is_empty()
    }

    /// The GP search of `algorithm`'s fits when none is asked for: `screened` where it was
    /// checked on every fit of the reference runs to reach the spec's optimum (relative LML
    /// within 10⁻⁶), the spec's everywhere else (not checked). Checked: `iwfqi`, `awfqi`,
    /// `iwfqi-heuristic` and `awfqi-oracle` without transition weights (20, 10, 10 and 10
    /// runs; `awfqi-oracle` in thesis setting 2 (a), the configuration where its search
    /// costs most) and, on Puddle World, `iwfqi` with them (the puddle-based dynamics'
    /// reference configuration, 10 runs).
    pub fn default_search(&self, algorithm: Algorithm) -> GpSearch {
        let checked = match algorithm {
            Algorithm::Iwfqi => !self.transition_weights() || self.domain.name == "puddle world",
            Algorithm::Awfqi | Algorithm::AwfqiOracle | Algorithm::IwfqiHeuristic => {
                !self.transition_weights()
            }
            _ => false,
        };
        if checked {
            GpSearch::Screened
        } else {
            GpSearch::Spec
        }
    }

    /// The state coordinates IWFQI weighs transitions on: the domain's published ones, all
    /// of them with `--transition-weights true`, none with `false`.
    pub fn transition_dims(&self) -> Vec<usize> {
        let published = &self.data.weighting.transition;
        match self.options.transition_weights {
            None => (0..D).filter(|&d| published[d].is_some()).collect(),
            Some(true) => (0..D).collect(),
            Some(false) => Vec::new(),
        }
    }

    /// IWFQI's `(v_r, v_s)`.
    ///
    /// Errors: corrected variances requested for a domain without noise variances.
    pub fn variances(&self) -> anyhow::Result<(f64, f64)> {
        match self.options.variances {
            Variances::Published => Ok(self.domain.published.variances),
            Variances::Corrected if self.domain.name == "puddle world" => {
                Ok(Variances::Corrected.values())
            }
            Variances::Corrected => anyhow::bail!(
                "--variances corrected applies to Puddle World only: the {}'s rewards have no noise",
                self.domain.name
            ),
        }
    }

    /// The active algorithms' per-step budget: `--queries-per-step`, else `n = H·B` (§12).
    pub fn budget(&self) -> usize {
        self.protocol
            .queries_per_step
            .unwrap_or(self.domain.horizon * self.protocol.episodes_per_step)
    }

    /// The per-run parameters recorded in the results (§3.4).
    pub fn parameters(&self, algorithm: Algorithm) -> serde_json::Value {
        let p = &self.protocol;
        let mut v = serde_json::json!({
            "algorithm": algorithm.name(),
            "batch_size": p.episodes_per_step,
            "steps": p.steps,
            "iterations": p.iterations,
            "trees": p.trees,
            "epsilon": p.epsilon,
        });
        let (v_r, v_s) = self.variances().unwrap_or((f64::NAN, f64::NAN));
        let o = &mut v;
        match algorithm {
            Algorithm::Iwfqi
            | Algorithm::IwfqiHeuristic
            | Algorithm::Awfqi
            | Algorithm::AwfqiOracle => {
                o["estimator"] = if algorithm == Algorithm::IwfqiHeuristic {
                    "heuristic".into()
                } else {
                    "mean".into()
                };
                o["var_rw"] = v_r.into();
                o["var_st"] = v_s.into();
                o["max_weight"] = self.options.max_weight.into();
                o["max_gp"] = self.options.gp.max_gp.into();
                o["gp_restarts"] = self.options.gp.restarts.into();
                if self.options.gp.search.is_none()
                    && self.default_search(algorithm) == GpSearch::Screened
                {
                    // Only where the default differs from the spec's, so the other
                    // algorithms' files stay as they were.
                    o["gp_search"] = "screened".into();
                }
                o["weight_rw"] = true.into();
                let dims = self.transition_dims();
                let st: Vec<bool> = (0..D)
                    .map(|d| dims.contains(&d) && !algorithm.is_active())
                    .collect();
                o["weight_st"] = serde_json::json!(st);
                o["noise_subtraction"] = serde_json::to_value(self.options)
                    .map(|t| t["noise"].clone())
                    .unwrap_or_default();
            }
            Algorithm::IwfqiIdeal => {
                let (v_r, v_s) = self.domain.published.ideal_variances;
                o["var_rw"] = v_r.into();
                o["var_st"] = v_s.into();
                o["weights"] = "ideal".into();
                let means = self.ideal_means();
                if means != IdealMeans::Exact {
                    o["ideal_means"] = serde_json::to_value(means).unwrap_or_default();
                }
            }
            Algorithm::Rbt => {
                o["delta_sa"] = 0.1.into();
                o["delta_s_prime"] = 0.1.into();
                o["delta_r"] = 0.1.into();
                o["mu"] = 0.8.into();
                o["n_total"] = self.options.rbt_total.into();
                if !self.options.rbt_compliance.is_spec() {
                    o["compliance"] = "sums".into();
                }
            }
            Algorithm::AwfqiEmbedded => {
                if let Some(e) = &self.embedded {
                    o["embedded"] = e.parameters(e.config().q);
                }
            }
            Algorithm::AwfqiAdaptive => {
                if let Some(e) = &self.embedded {
                    o["embedded"] = e.parameters(e.config().adaptive_q);
                    // The adaptive algorithm's own GPs, not the set-up's.
                    let a = self.adaptive_options;
                    o["embedded"]["gp_capacity"] = a.gp_points.points().into();
                    let search = e.gp_search();
                    o["embedded"]["gp_search"] = match a.refit {
                        Some((e, r)) => {
                            format!("{search}, then warm refits of {e} evaluations, {r} restarts")
                        }
                        None => search,
                    }
                    .into();
                }
                o["var_rw"] = v_r.into();
                o["max_weight"] = self.options.max_weight.into();
                o["adaptive"] = serde_json::to_value(self.adaptive_options).unwrap_or_default();
            }
            Algorithm::Fqi | Algorithm::Sdt => {}
        }
        if algorithm.is_active() {
            o["budget_per_step"] = self.budget().into();
            let table = match algorithm {
                Algorithm::AwfqiOracle => self.oracle_table.as_ref().map(|t| (t.mode, "oracle")),
                Algorithm::Awfqi => self.realistic_table.as_ref().map(|t| (t.mode, "realistic")),
                Algorithm::AwfqiEmbedded => self
                    .embedded
                    .as_ref()
                    .map(|e| (e.config().mode, "realistic (the core's f32 GPs)")),
                _ => None,
            };
            if let Some((mode, kind)) = table {
                o["score_table"] =
                    serde_json::json!({"mode": mode.name(), "values": kind, "column": "V_r"});
            }
        }
        v
    }

    /// How the ideal weights get their mean next states.
    pub fn ideal_means(&self) -> IdealMeans {
        self.options
            .ideal_means
            .unwrap_or(self.domain.published.ideal_means)
    }

    /// Hands a fresh learner of `algorithm` for one run to `f`, with the stream `rng`
    /// (which an embedded set-up draws from first): every algorithm, the embedded ones included,
    /// through this one door.
    pub fn with_learner(
        &self,
        algorithm: Algorithm,
        rng: &mut ChaCha8Rng,
        f: &mut dyn FnMut(&mut dyn Learner<D>, &mut ChaCha8Rng) -> anyhow::Result<()>,
    ) -> anyhow::Result<()> {
        let embedded = || {
            self.embedded.as_deref().ok_or_else(|| {
                anyhow::anyhow!(
                    "{} is not available on {}: no embedded set-up",
                    algorithm.name(),
                    self.domain.name
                )
            })
        };
        match algorithm {
            Algorithm::AwfqiEmbedded => embedded()?.with_thesis_learner(self, rng, f),
            Algorithm::AwfqiAdaptive => embedded()?.with_adaptive_learner(self, rng, f),
            _ => {
                let mut learner = self.learner(algorithm)?;
                f(learner.as_mut(), rng)
            }
        }
    }

    /// A fresh learner of `algorithm` for one run (the embedded ones, which borrow their storage
    /// for the whole run, only through [`Experiment::with_learner`]).
    pub fn learner(&self, algorithm: Algorithm) -> anyhow::Result<Box<dyn Learner<D> + '_>> {
        use awfqi::weights::Estimator::{Heuristic, Mean};
        // Every GP-fitting learner gets its algorithm's search from here.
        let gp = self.options.gp.resolved(self.default_search(algorithm));
        Ok(match algorithm {
            Algorithm::Fqi => Box::new(plain_fqi::Fqi::new(self)),
            Algorithm::Iwfqi => Box::new(iwfqi::Iwfqi::estimated(self, Mean, None, gp)?),
            Algorithm::IwfqiHeuristic => {
                Box::new(iwfqi::Iwfqi::estimated(self, Heuristic, None, gp)?)
            }
            Algorithm::IwfqiIdeal => Box::new(iwfqi::Iwfqi::ideal(self)?),
            Algorithm::Rbt => Box::new(rbt::Rbt::new(self)),
            Algorithm::Sdt => Box::new(sdt::Sdt::new(self)),
            Algorithm::Awfqi => {
                let table = self.realistic_table.clone();
                let table = table.ok_or_else(|| anyhow::anyhow!("no realistic score table"))?;
                Box::new(iwfqi::Iwfqi::estimated(self, Mean, Some(table), gp)?)
            }
            Algorithm::AwfqiOracle => {
                let table = self.oracle_table.clone();
                let table = table.ok_or_else(|| anyhow::anyhow!("no oracle score table"))?;
                Box::new(iwfqi::Iwfqi::estimated(self, Mean, Some(table), gp)?)
            }
            Algorithm::AwfqiEmbedded | Algorithm::AwfqiAdaptive => {
                anyhow::bail!("{} runs through with_learner", algorithm.name())
            }
        })
    }
}

/// An estimator's name.
pub fn estimator_name(e: Estimator) -> &'static str {
    match e {
        Estimator::Mean => "mean",
        Estimator::Heuristic => "heuristic",
    }
}
