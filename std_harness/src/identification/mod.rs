//! The Grid World identification study (`awfqi-harness identify`) of spec §10.4 (thesis
//! §4.1.5, Figs. 4.2 and 4.3), with the two additions of this project — adaptive
//! scoring and the belief-weighted policy.
//!
//! For every run a true candidate θ* is drawn; every criterion and budget of that run
//! uses the same θ* (common random numbers). For each (criterion, budget) the belief is
//! updated from `budget` generative-model queries, and the chosen policy — MAP (optimal
//! policy of the most probable candidate, as the thesis) or belief-weighted (greedy in
//! Σ_θ b_θ Q*_θ) — is evaluated exactly in the true MDP from (0, 0).
//!
//! Seeding (spec §1's \[CHOICE\]): every random stream is a ChaCha8 generator seeded from
//! a hash of (`--seed`, purpose, run index, criterion, budget). No stream depends on
//! thread scheduling, on the other criteria or budgets requested, or on `--runs`
//! addressing, so `--runs 0..50` and `--runs 50..100` reproduce exactly the per-run
//! records of `--runs 100`. Streams:
//! - θ*: (seed, TRUTH, run);
//! - the prior mutual-information score (a random estimate): (seed, MI_SCORE, run,
//!   criterion), computed once per run and shared by all budgets of that run; the
//!   uniform and variance scores are deterministic and computed once for the whole study;
//! - the queries (pair draws, reward noise, and for adaptive criteria the score's own
//!   draws): (seed, QUERIES, run, criterion, budget) in the `independent` design (each
//!   budget its own experiment, as the thesis's 10 runs per budget), or (seed, QUERIES,
//!   run, criterion) in the `nested` design (one query sequence per run whose prefixes
//!   give all budgets: cheaper, and smoother curves, but budgets are then correlated).

use anyhow::{anyhow, bail};
use awfqi::env::GridWorld;
use awfqi::identify::{
    Belief, Criterion, MiConfig, RewardEntropy, Scoring, belief_weighted_policy, compute_score,
    run_queries,
};
use awfqi::model::FiniteMdp;
use awfqi::planning::{StoppingRule, evaluate_policy, greedy_policy, value_iteration};
use awfqi::rng;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::run_range::RunRange;
use crate::seeding::stream;

/// Number of candidate MDPs of the thesis study.
const K: usize = 4;
const STATES: usize = 100;
const ACTIONS: usize = 4;
const PAIRS: usize = STATES * ACTIONS;

/// Purpose tags of the random streams.
const TRUTH: u64 = 1;
const MI_SCORE: u64 = 2;
const QUERIES: u64 = 3;

/// A score criterion of the study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CriterionName {
    /// Uniform over all state-action pairs.
    Uniform,
    /// Inter-MDP variance, from the prior (thesis).
    Variance,
    /// Mutual information with the spec's binned estimator, from the prior (thesis).
    Mi,
    /// Mutual information with the thesis's literal eq. 4.14 (no ln Δ, no ½ ln 2πe, no
    /// clipping), from the prior.
    MiLiteral,
    /// Mutual information from the prior, with Î_R = 0 exactly where the candidates'
    /// reward models coincide (no estimator noise there).
    MiSkip,
    /// Adaptive mutual information: recomputed with the current belief before every
    /// query (with the exact zero of `mi-skip`, which is what makes it affordable).
    Adaptive,
    /// Adaptive inter-MDP variance: recomputed with the current belief before every
    /// query.
    AdaptiveVariance,
}

impl CriterionName {
    /// Stable identifier used in seeding (independent of the order on the command line).
    fn id(self) -> u64 {
        match self {
            Self::Uniform => 1,
            Self::Variance => 2,
            Self::Mi => 3,
            Self::MiLiteral => 4,
            Self::MiSkip => 5,
            Self::Adaptive => 6,
            Self::AdaptiveVariance => 7,
        }
    }

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Uniform => "uniform",
            Self::Variance => "variance",
            Self::Mi => "mi",
            Self::MiLiteral => "mi-literal",
            Self::MiSkip => "mi-skip",
            Self::Adaptive => "adaptive",
            Self::AdaptiveVariance => "adaptive-variance",
        }
    }
}

/// How a policy is chosen from the final belief.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PolicyName {
    /// Optimal policy of the MAP candidate (thesis).
    Map,
    /// Greedy in Σ_θ b_θ Q*_θ.
    Belief,
}

impl PolicyName {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Map => "map",
            Self::Belief => "belief",
        }
    }
}

/// How budgets relate within a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Design {
    /// Each budget is its own experiment with its own query stream.
    Independent,
    /// One query sequence per run and criterion; budget n uses its first n queries.
    Nested,
}

/// The outcome of one (run, criterion, budget).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    /// Criterion.
    pub criterion: CriterionName,
    /// Budget n.
    pub budget: usize,
    /// MAP candidate θ̂.
    pub map: usize,
    /// θ̂ = θ*.
    pub identified: bool,
    /// Posterior mass of θ*.
    pub posterior_true: f64,
    /// Belief entropy (nats).
    pub entropy: f64,
    /// V^{π_MAP}_{θ*}(s₀).
    pub return_map: f64,
    /// V^{π_belief}_{θ*}(s₀).
    pub return_belief: f64,
}

/// Everything about one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IdentificationRun {
    /// Run index.
    pub run: usize,
    /// True candidate θ*.
    pub theta_star: usize,
    /// V*_{θ*}(s₀).
    pub optimal_return: f64,
    /// One outcome per criterion and budget.
    pub outcomes: Vec<Outcome>,
}

/// One row of `identify.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Criterion.
    pub criterion: String,
    /// Policy.
    pub policy: String,
    /// Budget n.
    pub budget: usize,
    /// Runs aggregated.
    pub runs: usize,
    /// Fraction of runs with θ̂ = θ*.
    pub identification_rate: f64,
    /// Mean return of the policy in the true MDP from (0, 0).
    pub return_mean: f64,
    /// Standard error of that mean (sample sd / √runs).
    pub return_stderr: f64,
    /// Mean over runs of V*_{θ*}(s₀).
    pub optimal_return: f64,
}

/// The configuration echoed into `identify.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyConfig {
    /// Budgets.
    pub budgets: Vec<usize>,
    /// From the first run index of the records to one past the last (the records of one
    /// configuration merge whatever their ranges; no other field may differ).
    pub runs: RunRange,
    /// Criteria.
    pub criteria: Vec<CriterionName>,
    /// Policies.
    pub policies: Vec<PolicyName>,
    /// Seed.
    pub seed: u64,
    /// Absorbing-goal variant.
    pub absorbing: bool,
    /// γ.
    pub gamma: f64,
    /// MI draws m.
    pub mi_samples: usize,
    /// MI bins B.
    pub mi_bins: usize,
    /// Design.
    pub design: Design,
    /// Goal cells of the candidates.
    pub goals: Vec<(usize, usize)>,
}

impl Default for StudyConfig {
    /// The thesis's study (Figs. 4.2 and 4.3): budgets 1 to 128, 100 runs, the uniform,
    /// variance, mutual-information and adaptive criteria, both policies, γ = 0.9, 1 000 MI
    /// draws in 30 bins, independent budgets.
    fn default() -> Self {
        Self {
            budgets: vec![1, 2, 4, 8, 16, 32, 64, 128],
            runs: RunRange { start: 0, end: 100 },
            criteria: vec![
                CriterionName::Uniform,
                CriterionName::Variance,
                CriterionName::Mi,
                CriterionName::Adaptive,
            ],
            policies: vec![PolicyName::Map, PolicyName::Belief],
            seed: 0,
            absorbing: false,
            gamma: 0.9,
            mi_samples: 1000,
            mi_bins: 30,
            design: Design::Independent,
            goals: awfqi::env::THESIS_GOALS.to_vec(),
        }
    }
}

/// The whole study: configuration, aggregated rows and per-run records.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Study {
    /// Configuration.
    pub config: StudyConfig,
    /// Aggregated rows (criterion × policy × budget).
    pub rows: Vec<Row>,
    /// Per-run records (re-plot or merge from these).
    pub records: Vec<IdentificationRun>,
}

/// What every run shares: candidates, optimal Q tables, MAP returns, fixed scores.
struct Shared {
    candidates: [GridWorld<f64>; K],
    /// Q*_θ for all θ, candidate-major.
    q_tables: Vec<f64>,
    /// V*_θ(s₀).
    optimal: [f64; K],
    /// `map_return[θ̂][θ*]` = V^{π*_θ̂}_{θ*}(s₀).
    map_return: [[f64; K]; K],
    uniform_score: Vec<f64>,
    variance_score: Vec<f64>,
    rule: StoppingRule<f64>,
}

fn core_error(e: awfqi::Error) -> anyhow::Error {
    anyhow!("core error: {e}")
}

impl Shared {
    fn new(config: &StudyConfig) -> anyhow::Result<Self> {
        let candidates = GridWorld::<f64>::thesis_candidates(config.absorbing);
        let rule = StoppingRule::default();
        let mut q_tables = vec![0.0; K * PAIRS];
        let mut optimal = [0.0; K];
        let mut policies = [[0usize; STATES]; K];
        for (k, mdp) in candidates.iter().enumerate() {
            let q = &mut q_tables[k * PAIRS..(k + 1) * PAIRS];
            let mut v = vec![0.0; STATES];
            let c = value_iteration(mdp, config.gamma, rule, &mut v, q).map_err(core_error)?;
            if !c.converged {
                bail!("value iteration did not converge for candidate {k}");
            }
            optimal[k] = v[mdp.initial_state()];
            greedy_policy(q, ACTIONS, &mut policies[k]).map_err(core_error)?;
        }
        let mut map_return = [[0.0; K]; K];
        for (guess, policy) in policies.iter().enumerate() {
            for (truth, mdp) in candidates.iter().enumerate() {
                let mut v = vec![0.0; STATES];
                evaluate_policy(mdp, policy, config.gamma, rule, &mut v).map_err(core_error)?;
                map_return[guess][truth] = v[mdp.initial_state()];
            }
        }
        let prior = [1.0 / K as f64; K];
        let mut unused = stream(0, &[]);
        let mut uniform_score = vec![0.0; PAIRS];
        compute_score(
            &Criterion::Uniform,
            &candidates,
            &prior,
            &mut unused,
            &mut uniform_score,
        )
        .map_err(core_error)?;
        let mut variance_score = vec![0.0; PAIRS];
        compute_score(
            &Criterion::Variance,
            &candidates,
            &prior,
            &mut unused,
            &mut variance_score,
        )
        .map_err(core_error)?;
        Ok(Self {
            candidates,
            q_tables,
            optimal,
            map_return,
            uniform_score,
            variance_score,
            rule,
        })
    }
}

fn mi_config(config: &StudyConfig, entropy: RewardEntropy, skip: bool) -> MiConfig {
    MiConfig {
        samples: config.mi_samples,
        bins: config.mi_bins,
        reward_entropy: entropy,
        skip_identical_rewards: skip,
    }
}

/// The scoring of a criterion: a fixed score (computed here, for random ones from the
/// run's MI stream) or an adaptive rule.
fn scoring_for(
    config: &StudyConfig,
    shared: &Shared,
    run: usize,
    criterion: CriterionName,
) -> anyhow::Result<(Scoring, Vec<f64>)> {
    let prior = [1.0 / K as f64; K];
    let fixed_mi = |entropy, skip| -> anyhow::Result<(Scoring, Vec<f64>)> {
        let mut rng = stream(config.seed, &[MI_SCORE, run as u64, criterion.id()]);
        let mut score = vec![0.0; PAIRS];
        let c = Criterion::MutualInformation(mi_config(config, entropy, skip));
        compute_score(&c, &shared.candidates, &prior, &mut rng, &mut score).map_err(core_error)?;
        Ok((Scoring::Fixed, score))
    };
    Ok(match criterion {
        CriterionName::Uniform => (Scoring::Fixed, shared.uniform_score.clone()),
        CriterionName::Variance => (Scoring::Fixed, shared.variance_score.clone()),
        CriterionName::Mi => fixed_mi(RewardEntropy::Differential, false)?,
        CriterionName::MiLiteral => fixed_mi(RewardEntropy::Literal, false)?,
        CriterionName::MiSkip => fixed_mi(RewardEntropy::Differential, true)?,
        CriterionName::Adaptive => (
            Scoring::Adaptive(Criterion::MutualInformation(mi_config(
                config,
                RewardEntropy::Differential,
                true,
            ))),
            vec![0.0; PAIRS],
        ),
        CriterionName::AdaptiveVariance => {
            (Scoring::Adaptive(Criterion::Variance), vec![0.0; PAIRS])
        }
    })
}

/// MAP and belief-weighted evaluation of one final belief.
fn evaluate(
    config: &StudyConfig,
    shared: &Shared,
    theta_star: usize,
    criterion: CriterionName,
    budget: usize,
    belief: &Belief<f64, K>,
) -> anyhow::Result<Outcome> {
    let map = belief.map();
    let probabilities = belief.probability_array();
    let return_belief = if config.policies.contains(&PolicyName::Belief) {
        let mut q = vec![0.0; PAIRS];
        let mut policy = vec![0usize; STATES];
        belief_weighted_policy(
            &shared.q_tables,
            &probabilities,
            ACTIONS,
            &mut q,
            &mut policy,
        )
        .map_err(core_error)?;
        let truth = &shared.candidates[theta_star];
        let mut v = vec![0.0; STATES];
        evaluate_policy(truth, &policy, config.gamma, shared.rule, &mut v).map_err(core_error)?;
        v[truth.initial_state()]
    } else {
        f64::NAN
    };
    Ok(Outcome {
        criterion,
        budget,
        map,
        identified: map == theta_star,
        posterior_true: probabilities[theta_star],
        entropy: belief.entropy(),
        return_map: shared.map_return[map][theta_star],
        return_belief,
    })
}

/// One run: θ*, then every criterion and budget.
fn run_one(config: &StudyConfig, shared: &Shared, run: usize) -> anyhow::Result<IdentificationRun> {
    let mut truth_rng = stream(config.seed, &[TRUTH, run as u64]);
    let theta_star = ((rng::uniform_f64(&mut truth_rng) * K as f64) as usize).min(K - 1);
    let truth = &shared.candidates[theta_star];
    let mut outcomes = Vec::new();
    for &criterion in &config.criteria {
        let (scoring, mut score) = scoring_for(config, shared, run, criterion)?;
        match config.design {
            Design::Independent => {
                for &budget in &config.budgets {
                    let parts = [QUERIES, run as u64, criterion.id(), budget as u64];
                    let mut rng = stream(config.seed, &parts);
                    let mut belief = Belief::<f64, K>::uniform(K).map_err(core_error)?;
                    let mut work = score.clone();
                    run_queries(
                        &shared.candidates,
                        truth,
                        &scoring,
                        budget,
                        &mut belief,
                        &mut work,
                        &mut rng,
                        |_, _| {},
                    )
                    .map_err(core_error)?;
                    outcomes.push(evaluate(
                        config, shared, theta_star, criterion, budget, &belief,
                    )?);
                }
            }
            Design::Nested => {
                let longest = config.budgets.iter().copied().max().unwrap_or(0);
                let mut rng = stream(config.seed, &[QUERIES, run as u64, criterion.id()]);
                let mut belief = Belief::<f64, K>::uniform(K).map_err(core_error)?;
                let mut snapshots = vec![None; longest + 1];
                snapshots[0] = Some(belief);
                run_queries(
                    &shared.candidates,
                    truth,
                    &scoring,
                    longest,
                    &mut belief,
                    &mut score,
                    &mut rng,
                    |done, b| {
                        if config.budgets.contains(&done) {
                            snapshots[done] = Some(*b);
                        }
                    },
                )
                .map_err(core_error)?;
                for &budget in &config.budgets {
                    let b = snapshots[budget].ok_or_else(|| anyhow!("missing snapshot"))?;
                    outcomes.push(evaluate(config, shared, theta_star, criterion, budget, &b)?);
                }
            }
        }
    }
    Ok(IdentificationRun {
        run,
        theta_star,
        optimal_return: shared.optimal[theta_star],
        outcomes,
    })
}

fn mean_and_stderr(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return (mean, 0.0);
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// Aggregates per-run records into criterion × policy × budget rows.
pub fn aggregate(config: &StudyConfig, records: &[IdentificationRun]) -> Vec<Row> {
    let optimal = mean_and_stderr(&records.iter().map(|r| r.optimal_return).collect::<Vec<_>>()).0;
    let mut rows = Vec::new();
    for &criterion in &config.criteria {
        for &policy in &config.policies {
            for &budget in &config.budgets {
                let outcomes: Vec<&Outcome> = records
                    .iter()
                    .flat_map(|r| &r.outcomes)
                    .filter(|o| o.criterion == criterion && o.budget == budget)
                    .collect();
                let rate = outcomes.iter().filter(|o| o.identified).count() as f64
                    / outcomes.len().max(1) as f64;
                let returns: Vec<f64> = outcomes
                    .iter()
                    .map(|o| match policy {
                        PolicyName::Map => o.return_map,
                        PolicyName::Belief => o.return_belief,
                    })
                    .collect();
                let (return_mean, return_stderr) = mean_and_stderr(&returns);
                rows.push(Row {
                    criterion: criterion.name().to_string(),
                    policy: policy.name().to_string(),
                    budget,
                    runs: outcomes.len(),
                    identification_rate: rate,
                    return_mean,
                    return_stderr,
                    optimal_return: optimal,
                });
            }
        }
    }
    rows
}

/// Runs the study (in parallel over runs, on the current rayon pool) without writing
/// anything.
pub fn study(config: &StudyConfig, progress: bool) -> anyhow::Result<Study> {
    let runs: Vec<usize> = (config.runs.start..config.runs.end).collect();
    let records = run_records(config, &runs, progress)?;
    Ok(assemble(config.clone(), records))
}

/// The study of `config` over `records` (any order, distinct runs): records by run index,
/// `config.runs` their hull, and the aggregated rows.
pub fn assemble(mut config: StudyConfig, mut records: Vec<IdentificationRun>) -> Study {
    records.sort_by_key(|r| r.run);
    if let (Some(first), Some(last)) = (records.first(), records.last()) {
        config.runs = RunRange {
            start: first.run,
            end: last.run + 1,
        };
    }
    let rows = aggregate(&config, &records);
    Study {
        config,
        rows,
        records,
    }
}

/// The records of `runs` (in parallel, on the current rayon pool), in that order.
pub fn run_records(
    config: &StudyConfig,
    runs: &[usize],
    progress: bool,
) -> anyhow::Result<Vec<IdentificationRun>> {
    if config.budgets.is_empty() || config.criteria.is_empty() || config.policies.is_empty() {
        bail!(
            "the study needs at least one budget, criterion and policy (--budgets, --criteria, --policy)"
        );
    }
    let shared = Shared::new(config)?;
    let bar = if progress {
        let bar = ProgressBar::new(runs.len() as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "identify {bar:40} {pos}/{len} runs  {elapsed} (eta {eta})",
            )
            .map_err(|e| anyhow!("{e}"))?,
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let records = runs
        .par_iter()
        .map(|&run| {
            let record = run_one(config, &shared, run);
            bar.inc(1);
            record
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    bar.finish_and_clear();
    Ok(records)
}

mod outputs;
pub mod stored;
pub use outputs::{identification_figure, return_figure, table, write_outputs};

#[cfg(test)]
mod tests;
