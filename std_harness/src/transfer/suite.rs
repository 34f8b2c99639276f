//! The plant suite: every plant the transfer study measures on, at two budget schedules of
//! the same total, against the plant's anchors ([`super::anchors`]).
//!
//! - [`SuitePlant`]: the plants (Puddle World's thesis setting 2 (b), the zones, the
//!   thermal room, the tanks, the Dam, Acrobot), their schedules and their baselines;
//! - [`AnchorFile`]: the anchors computed once (`awfqi-harness suite --anchors`) and kept
//!   in `std_harness/data/suite-anchors.json`;
//! - [`summarise`]: a cell's result files (one plant at one schedule) as raw and normalised
//!   returns, `(R − R_random) / (R_best − R_random)`, failed runs and the paired comparison
//!   of `awfqi-adaptive` with FQI on its own target samples.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::algorithms::Algorithm;
use super::anchors::{Estimate, PlanReturn};
use super::result_dir::result_path;
use super::results::{ResultFile, mean_and_stderr};

/// A plant of the suite.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SuitePlant {
    /// Puddle World, thesis setting 2 (b) (shared dynamics, three published sources).
    Puddle,
    /// The zones firmware example's plant (two sources of 300 records, rewards differ).
    Zones,
    /// The thermal room (three sources of 400 records: the target's, another tariff, a
    /// leaky room).
    Thermal,
    /// The tanks (three sources of 400 records: the target's, another recipe, a worn pump).
    Tanks,
    /// The IWFQI paper's Dam (six published sources).
    Dam,
    /// The IWFQI paper's Acrobot (two published sources).
    Acrobot,
}

/// A budget schedule: `steps` steps of `queries` target samples each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Schedule {
    /// Steps.
    pub steps: usize,
    /// Target samples (generative-model queries) per step.
    pub queries: usize,
}

impl Schedule {
    /// `K×Q`, the cell's directory name.
    pub fn name(&self) -> String {
        format!("{}x{}", self.steps, self.queries)
    }

    /// The episodic baselines' share of the same samples: the fewest episodes of at most
    /// `horizon` steps that hold `queries` samples, each cut to `queries / episodes` steps
    /// (`(episodes, length)`; `queries` a multiple of `episodes`, as every schedule of the
    /// suite is).
    pub fn episodes(&self, horizon: usize) -> (usize, usize) {
        let episodes = self.queries.div_ceil(horizon.max(1)).max(1);
        (episodes, self.queries / episodes)
    }
}

impl SuitePlant {
    /// Every plant, in the page's order.
    pub const ALL: [SuitePlant; 6] = [
        SuitePlant::Puddle,
        SuitePlant::Zones,
        SuitePlant::Thermal,
        SuitePlant::Tanks,
        SuitePlant::Dam,
        SuitePlant::Acrobot,
    ];

    /// The name in directories, tables and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SuitePlant::Puddle => "puddle",
            SuitePlant::Zones => "zones",
            SuitePlant::Thermal => "thermal",
            SuitePlant::Tanks => "tanks",
            SuitePlant::Dam => "dam",
            SuitePlant::Acrobot => "acrobot",
        }
    }

    /// The two schedules of the same total budget: the plant's usual steps of 50 (Acrobot
    /// 100) queries, and twice the steps of half the queries.
    pub fn schedules(self) -> [Schedule; 2] {
        let (steps, queries) = match self {
            SuitePlant::Puddle => (6, 50),
            SuitePlant::Zones | SuitePlant::Thermal => (2, 50),
            SuitePlant::Tanks => (4, 50),
            SuitePlant::Dam => (10, 50),
            SuitePlant::Acrobot => (10, 100),
        };
        [
            Schedule { steps, queries },
            Schedule {
                steps: 2 * steps,
                queries: queries / 2,
            },
        ]
    }

    /// The algorithms a run of the suite computes by default: FQI on the same number of
    /// target samples, IWFQI where it runs in minutes (not on the Dam, ≈ 800 s a run, nor
    /// on Acrobot, whose 8 400 source records make its GPs as slow), and the adaptive AWFQI
    /// (with FQI on its own samples, paired).
    pub fn algorithms(self) -> Vec<Algorithm> {
        match self {
            SuitePlant::Dam | SuitePlant::Acrobot => {
                vec![Algorithm::Fqi, Algorithm::AwfqiAdaptive]
            }
            _ => vec![Algorithm::Fqi, Algorithm::Iwfqi, Algorithm::AwfqiAdaptive],
        }
    }
}

/// One plant's anchors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlantAnchors {
    /// The plant.
    pub plant: SuitePlant,
    /// The uniformly random policy.
    pub random: Estimate,
    /// The hand-written controller, where the field has one: its name and return.
    pub controller: Option<(String, Estimate)>,
    /// Dynamic programming on the mean model at each resolution.
    pub plans: Vec<PlanReturn>,
    /// The best known return: the best of the plans and the controller.
    pub best: f64,
    /// Which policy gives it.
    pub best_label: String,
}

impl PlantAnchors {
    /// Builds the anchors and picks the best known return.
    pub fn new(
        plant: SuitePlant,
        random: Estimate,
        controller: Option<(String, Estimate)>,
        plans: Vec<PlanReturn>,
    ) -> Self {
        let mut best = (f64::NEG_INFINITY, String::new());
        for p in &plans {
            if p.value.mean > best.0 {
                let cells: Vec<String> = p.cells.iter().map(|c| c.to_string()).collect();
                best = (
                    p.value.mean,
                    format!("dynamic programming, {} cells", cells.join("×")),
                );
            }
        }
        if let Some((name, e)) = &controller
            && e.mean > best.0
        {
            best = (e.mean, name.clone());
        }
        Self {
            plant,
            random,
            controller,
            plans,
            best: best.0,
            best_label: best.1,
        }
    }

    /// `(R − R_random) / (R_best − R_random)`.
    pub fn normalise(&self, r: f64) -> f64 {
        (r - self.random.mean) / (self.best - self.random.mean)
    }
}

/// The anchors of every plant and how they were computed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnchorFile {
    /// The command that computed them.
    pub command: String,
    /// Its seed.
    pub seed: u64,
    /// Repetitions of the evaluation behind each return.
    pub repetitions: usize,
    /// Each plant's anchors.
    pub plants: Vec<PlantAnchors>,
}

/// The committed anchors (`std_harness/data/suite-anchors.json`).
pub const COMMITTED_ANCHORS: &str = include_str!("../../data/suite-anchors.json");

impl AnchorFile {
    /// The committed anchors.
    ///
    /// Errors: a file that does not parse.
    pub fn committed() -> anyhow::Result<Self> {
        Ok(serde_json::from_str(COMMITTED_ANCHORS)?)
    }

    /// `plant`'s anchors.
    pub fn of(&self, plant: SuitePlant) -> Option<&PlantAnchors> {
        self.plants.iter().find(|p| p.plant == plant)
    }
}

/// Per-step statistics of one policy over the runs of a cell.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StepStats {
    /// The plant.
    pub plant: &'static str,
    /// The schedule.
    pub schedule: String,
    /// The policy (an algorithm, or `fqi-same-samples`).
    pub policy: String,
    /// Step (1-based).
    pub step: usize,
    /// Runs.
    pub runs: usize,
    /// Mean return.
    pub mean: f64,
    /// Its standard error.
    pub stderr: f64,
    /// Mean normalised return.
    pub normalised: f64,
    /// Its standard error.
    pub normalised_stderr: f64,
    /// Runs whose normalised return is below 0.5.
    pub failed: usize,
}

/// The paired difference of two policies' returns at one step (runs paired by index).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Paired {
    /// Step.
    pub step: usize,
    /// Pairs.
    pub runs: usize,
    /// Mean difference (first minus second).
    pub mean: f64,
    /// Its standard error (sample standard deviation / √n).
    pub stderr: f64,
    /// The two-sided p-value of the paired t-test (NaN below 2 pairs or with no spread).
    pub p: f64,
}

/// A cell's summary.
#[derive(Debug, Clone, PartialEq)]
pub struct CellSummary {
    /// Per-step statistics of every policy.
    pub steps: Vec<StepStats>,
    /// `awfqi-adaptive` against FQI on its own samples, per step.
    pub adaptive_vs_same_samples: Vec<Paired>,
}

/// The name of FQI on the adaptive learner's own samples in the tables.
pub const SAME_SAMPLES: &str = "fqi-same-samples";

/// Summarises the result files of `algorithms` in `dir` (one plant at one schedule)
/// against `anchors`; absent files are skipped.
///
/// Errors: a result file that cannot be read.
pub fn summarise(
    dir: &Path,
    plant: SuitePlant,
    schedule: &Schedule,
    algorithms: &[Algorithm],
    anchors: &PlantAnchors,
) -> anyhow::Result<CellSummary> {
    // Per policy: run index → returns per step.
    let mut policies: BTreeMap<String, BTreeMap<usize, Vec<f64>>> = BTreeMap::new();
    for &a in algorithms {
        let path = result_path(dir, a);
        if !path.exists() {
            continue;
        }
        let file = ResultFile::read(&path)?;
        for run in &file.runs {
            let returns = run.steps.iter().map(|s| s.perf_disc_greedy_mean).collect();
            policies
                .entry(a.name().to_string())
                .or_default()
                .insert(run.run, returns);
            let same: Option<Vec<f64>> = run
                .steps
                .iter()
                .map(|s| s.diagnostics.fqi_same_samples)
                .collect();
            if let Some(same) = same {
                policies
                    .entry(SAME_SAMPLES.to_string())
                    .or_default()
                    .insert(run.run, same);
            }
        }
    }
    let mut steps = Vec::new();
    for (policy, runs) in &policies {
        let count = runs.values().map(Vec::len).max().unwrap_or(0);
        for k in 0..count {
            let raw: Vec<f64> = runs.values().filter_map(|r| r.get(k).copied()).collect();
            let normalised: Vec<f64> = raw.iter().map(|&r| anchors.normalise(r)).collect();
            let (mean, stderr) = mean_and_stderr(&raw);
            let (n_mean, n_stderr) = mean_and_stderr(&normalised);
            steps.push(StepStats {
                plant: plant.name(),
                schedule: schedule.name(),
                policy: policy.clone(),
                step: k + 1,
                runs: raw.len(),
                mean,
                stderr,
                normalised: n_mean,
                normalised_stderr: n_stderr,
                failed: normalised.iter().filter(|&&x| x < 0.5).count(),
            });
        }
    }
    let adaptive_vs_same_samples = match (
        policies.get(Algorithm::AwfqiAdaptive.name()),
        policies.get(SAME_SAMPLES),
    ) {
        (Some(a), Some(b)) => paired(a, b),
        _ => Vec::new(),
    };
    Ok(CellSummary {
        steps,
        adaptive_vs_same_samples,
    })
}

/// Per step, the paired differences `a − b` over the run indices both hold.
fn paired(a: &BTreeMap<usize, Vec<f64>>, b: &BTreeMap<usize, Vec<f64>>) -> Vec<Paired> {
    let count = a.values().map(Vec::len).max().unwrap_or(0);
    (0..count)
        .map(|k| {
            let d: Vec<f64> = a
                .iter()
                .filter_map(|(run, x)| Some(x.get(k)? - b.get(run)?.get(k)?))
                .collect();
            let n = d.len() as f64;
            let mean = d.iter().sum::<f64>() / n;
            let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
            let stderr = (var / n).sqrt();
            let p = if d.len() >= 2 && stderr > 0.0 {
                student_two_sided(mean / stderr, n - 1.0)
            } else {
                f64::NAN
            };
            Paired {
                step: k + 1,
                runs: d.len(),
                mean,
                stderr,
                p,
            }
        })
        .collect()
}

/// The two-sided p-value of Student's t with `df` degrees of freedom:
/// `I_{df/(df+t²)}(df/2, 1/2)`.
pub fn student_two_sided(t: f64, df: f64) -> f64 {
    incomplete_beta(df / (df + t * t), df / 2.0, 0.5)
}

/// The regularised incomplete beta function `I_x(a, b)` (continued fraction, modified
/// Lentz; Numerical Recipes, section 6.4).
fn incomplete_beta(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    let front = ln_front.exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(x, a, b) / a
    } else {
        1.0 - front * beta_fraction(1.0 - x, b, a) / b
    }
}

fn beta_fraction(x: f64, a: f64, b: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..300 {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        d = if d.abs() < TINY { TINY } else { d };
        c = 1.0 + aa / c;
        c = if c.abs() < TINY { TINY } else { c };
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// `ln Γ(x)`, x > 0 (Lanczos, g = 7, nine coefficients).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut sum = G[0];
    for (i, g) in G.iter().enumerate().skip(1) {
        sum += g / (x + i as f64);
    }
    let t = x + 7.5;
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

/// A cell's tables in Markdown: every policy at the first and the last step and its mean
/// over the steps (raw ± s.e., normalised ± s.e., failed runs at the last step), then the
/// paired comparison per step.
pub fn cell_markdown(plant: SuitePlant, schedule: &Schedule, summary: &CellSummary) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\n#### {}, {} steps × {} queries\n",
        plant.name(),
        schedule.steps,
        schedule.queries
    );
    out.push_str(
        "| policy | runs | step 1 | last step | normalised, step 1 | normalised, last | normalised, mean over steps | failed runs (last step < 0.5) |\n|---|---|---|---|---|---|---|---|\n",
    );
    let mut names: Vec<&String> = summary.steps.iter().map(|s| &s.policy).collect();
    names.dedup();
    for name in names {
        let rows: Vec<&StepStats> = summary.steps.iter().filter(|s| &s.policy == name).collect();
        let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
            continue;
        };
        let mean_norm = rows.iter().map(|r| r.normalised).sum::<f64>() / rows.len() as f64;
        let _ = writeln!(
            out,
            "| {name} | {} | {:.2} ± {:.2} | {:.2} ± {:.2} | {:.3} ± {:.3} | {:.3} ± {:.3} | {mean_norm:.3} | {} |",
            last.runs,
            first.mean,
            first.stderr,
            last.mean,
            last.stderr,
            first.normalised,
            first.normalised_stderr,
            last.normalised,
            last.normalised_stderr,
            last.failed
        );
    }
    if !summary.adaptive_vs_same_samples.is_empty() {
        out.push_str(
            "\nawfqi-adaptive − FQI on its own samples (paired by run):\n\n| step | runs | difference ± s.e. | p (paired t) |\n|---|---|---|---|\n",
        );
        for p in &summary.adaptive_vs_same_samples {
            let _ = writeln!(
                out,
                "| {} | {} | {:+.3} ± {:.3} | {} |",
                p.step,
                p.runs,
                p.mean,
                p.stderr,
                if p.p.is_nan() {
                    "–".to_string()
                } else {
                    format!("{:.2e}", p.p)
                }
            );
        }
    }
    out
}

/// The anchors as a Markdown table.
pub fn anchors_markdown(anchors: &AnchorFile) -> String {
    let mut out = String::from(
        "| plant | random | best known | by | hand-written controller | dynamic programming on the mean model (cells per axis: return) |\n|---|---|---|---|---|---|\n",
    );
    for a in &anchors.plants {
        let controller = a.controller.as_ref().map_or("–".to_string(), |(name, e)| {
            format!("{name}: {:.2} ± {:.2}", e.mean, e.stderr)
        });
        let plans: Vec<String> = a
            .plans
            .iter()
            .map(|p| {
                let cells: Vec<String> = p.cells.iter().map(|c| c.to_string()).collect();
                format!(
                    "{}: {:.2} ± {:.2}",
                    cells.join("×"),
                    p.value.mean,
                    p.value.stderr
                )
            })
            .collect();
        let _ = writeln!(
            out,
            "| {} | {:.2} ± {:.2} | {:.2} | {} | {controller} | {} |",
            a.plant.name(),
            a.random.mean,
            a.random.stderr,
            a.best,
            a.best_label,
            if plans.is_empty() {
                "–".to_string()
            } else {
                plans.join("; ")
            }
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn student_t_p_values_match_the_tables() {
        // t(19) = 2.093 is the two-sided 5 % point; t(9) = 3.250 the 1 % point; t = 0: 1.
        assert!((student_two_sided(2.093, 19.0) - 0.05).abs() < 5e-4);
        assert!((student_two_sided(3.250, 9.0) - 0.01).abs() < 1e-4);
        assert!((student_two_sided(0.0, 5.0) - 1.0).abs() < 1e-12);
        assert!((student_two_sided(-2.093, 19.0) - 0.05).abs() < 5e-4);
    }

    #[test]
    fn schedules_split_the_same_total_and_episodes_hold_the_queries() {
        for plant in SuitePlant::ALL {
            let [a, b] = plant.schedules();
            assert_eq!(a.steps * a.queries, b.steps * b.queries, "{plant:?}");
        }
        // The zones' 40-step day: 50 queries are two episodes of 25.
        let s = Schedule {
            steps: 2,
            queries: 50,
        };
        assert_eq!(s.episodes(40), (2, 25));
        assert_eq!(s.episodes(360), (1, 50));
        assert_eq!(s.name(), "2x50");
    }

    #[test]
    fn normalisation_maps_random_to_0_and_best_to_1() {
        let e = |mean| Estimate {
            mean,
            stderr: 0.0,
            rollouts: 1,
        };
        let a = PlantAnchors::new(
            SuitePlant::Zones,
            e(-30.0),
            Some(("thermostat".into(), e(-12.0))),
            vec![PlanReturn {
                cells: vec![10, 10, 10],
                value: e(-10.0),
            }],
        );
        assert_eq!(a.best, -10.0);
        assert!(a.best_label.contains("10×10×10"));
        assert!((a.normalise(-30.0)).abs() < 1e-12 && (a.normalise(-10.0) - 1.0).abs() < 1e-12);
        assert!((a.normalise(-20.0) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn committed_anchors_cover_every_plant_and_rank_best_above_random() {
        let file = AnchorFile::committed().unwrap();
        for plant in SuitePlant::ALL {
            let a = file.of(plant).unwrap_or_else(|| panic!("{plant:?}"));
            assert!(a.best > a.random.mean + 3.0 * a.random.stderr, "{a:?}");
        }
    }
}
