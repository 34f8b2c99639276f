//! The transfer commands' options resolved against the domain's published configuration
//! ([`crate::domains::Published`]), with their ranges checked, and the algorithm sets.

use std::path::PathBuf;

use anyhow::bail;
use clap::ValueEnum;

use crate::domains::Domain;
use crate::run_range::RunRange;
use crate::transfer::algorithms::Algorithm;
use crate::transfer::gp::GpOptions;
use crate::transfer::score_tables::Mode;

use super::{CommonArgs, FixedGpArgs};

/// One value of `--algorithms`: an algorithm, or `all` of those the domain runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlgorithmChoice {
    /// Every algorithm that runs on the domain.
    All,
    /// One algorithm.
    One(Algorithm),
}

/// `all`, then every algorithm in the table's order.
const ALGORITHM_CHOICES: [AlgorithmChoice; Algorithm::ALL.len() + 1] = {
    let mut out = [AlgorithmChoice::All; Algorithm::ALL.len() + 1];
    let mut i = 0;
    while i < Algorithm::ALL.len() {
        out[i + 1] = AlgorithmChoice::One(Algorithm::ALL[i]);
        i += 1;
    }
    out
};

impl ValueEnum for AlgorithmChoice {
    fn value_variants<'a>() -> &'a [Self] {
        &ALGORITHM_CHOICES
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        match self {
            AlgorithmChoice::All => Some(
                clap::builder::PossibleValue::new("all")
                    .help("Every algorithm that runs on the domain"),
            ),
            AlgorithmChoice::One(a) => a.to_possible_value(),
        }
    }
}

/// The Dam's and Acrobot's default algorithms: the baselines and the thesis's AWFQI (the
/// adaptive algorithm's re-planning multiplies their large FQI fits, so it is asked for by
/// name there).
pub const BASELINES_AND_AWFQI: [Algorithm; 7] = [
    Algorithm::Fqi,
    Algorithm::Iwfqi,
    Algorithm::IwfqiIdeal,
    Algorithm::Rbt,
    Algorithm::Sdt,
    Algorithm::Awfqi,
    Algorithm::AwfqiOracle,
];

/// The options resolved against the domain's defaults.
#[derive(Debug, Clone)]
pub struct Config {
    /// The raw arguments.
    pub args: CommonArgs,
    /// The fixed-kernel GPs' options (the Dam's and Acrobot's; defaults elsewhere).
    pub fixed_gp: FixedGpArgs,
    /// Setting.
    pub setting: Mode,
    /// Episodes per step.
    pub episodes_per_step: usize,
    /// Steps.
    pub steps: usize,
    /// Runs.
    pub runs: RunRange,
    /// Algorithms (sorted, unique).
    pub algorithms: Vec<Algorithm>,
    /// Output directory.
    pub out: PathBuf,
    /// FQI iterations.
    pub iterations: usize,
    /// Trees.
    pub trees: usize,
    /// Fitted GPs' `max_gp`.
    pub max_gp: usize,
    /// RBT's `n_total`.
    pub rbt_total: usize,
    /// Score-table spacing.
    pub spacing: f64,
    /// Metric threshold.
    pub threshold: f64,
}

/// The largest `--steps` accepted.
pub const MAX_STEPS: usize = 1_000;
/// The largest `--episodes-per-step` accepted.
pub const MAX_EPISODES_PER_STEP: usize = 10_000;
/// The largest `--queries-per-step` and `--episode-length` accepted.
pub const MAX_QUERIES_PER_STEP: usize = 1_000_000;
/// The largest `--iterations` (FQI) accepted.
pub const MAX_ITERATIONS: usize = 100_000;
/// The largest `--trees` accepted.
pub const MAX_TREES: usize = 10_000;
/// The largest `--max-gp` accepted (a dense GP of this many points needs 8·n² bytes).
pub const MAX_GP_POINTS: usize = 100_000;
/// The largest `--gp-restarts` accepted.
pub const MAX_GP_RESTARTS: usize = 10_000;
/// The largest `--threads` accepted, per core available: more threads only share the
/// cores (and each holds a run's memory).
pub const THREADS_PER_CORE: usize = 4;
/// Run indices must be below this (seeds are derived from them).
pub const MAX_RUN_INDEX: usize = 1 << 32;

impl Config {
    /// Resolves `args` for `domain`: the options left out take the domain's published
    /// values, `--algorithms` left out takes `defaults`, and `all` every algorithm.
    pub fn resolve<const D: usize>(
        args: &CommonArgs,
        fixed_gp: FixedGpArgs,
        domain: &Domain<D>,
        defaults: &[Algorithm],
    ) -> anyhow::Result<Self> {
        let p = &domain.published;
        let mut algorithms: Vec<Algorithm> = if args.algorithms.is_empty() {
            defaults.to_vec()
        } else if args.algorithms.contains(&AlgorithmChoice::All) {
            Algorithm::ALL.to_vec()
        } else {
            args.algorithms
                .iter()
                .filter_map(|c| match c {
                    AlgorithmChoice::One(a) => Some(*a),
                    AlgorithmChoice::All => None,
                })
                .collect()
        };
        algorithms.sort();
        algorithms.dedup();
        let config = Self {
            args: args.clone(),
            fixed_gp,
            setting: args.setting.unwrap_or(Mode::Grid),
            episodes_per_step: args.episodes_per_step.unwrap_or(p.episodes_per_step),
            steps: args.steps.unwrap_or(p.steps),
            runs: args.runs.unwrap_or(RunRange {
                start: 0,
                end: p.runs,
            }),
            algorithms,
            out: args
                .out
                .clone()
                .unwrap_or_else(|| PathBuf::from("results").join(domain.command)),
            iterations: args.iterations.unwrap_or(p.iterations),
            trees: args.trees.unwrap_or(p.trees),
            max_gp: args.max_gp.unwrap_or(p.max_gp),
            rbt_total: args.rbt_total.unwrap_or(p.rbt_total),
            spacing: args.spacing.unwrap_or(domain.grid_spacing),
            threshold: args.threshold.unwrap_or(p.threshold),
        };
        config.check_ranges()?;
        Ok(config)
    }

    /// The CLI's ranges: every budget positive and below a bound that still finishes, the
    /// run range non-empty, the threads at most [`THREADS_PER_CORE`] per core, the score
    /// spacing and the threshold finite. Each error names
    /// the option.
    fn check_ranges(&self) -> anyhow::Result<()> {
        let within = |name: &str, value: usize, low: usize, high: usize| -> anyhow::Result<()> {
            if !(low..=high).contains(&value) {
                bail!("--{name} {value} is out of range: it must be {low} to {high}");
            }
            Ok(())
        };
        within("steps", self.steps, 1, MAX_STEPS)?;
        within(
            "episodes-per-step",
            self.episodes_per_step,
            1,
            MAX_EPISODES_PER_STEP,
        )?;
        within("iterations", self.iterations, 1, MAX_ITERATIONS)?;
        within("trees", self.trees, 1, MAX_TREES)?;
        within("max-gp", self.max_gp, 1, MAX_GP_POINTS)?;
        within("rbt-total", self.rbt_total, 1, usize::MAX)?;
        within("gp-restarts", self.args.gp_restarts, 0, MAX_GP_RESTARTS)?;
        if let Some(q) = self.args.queries_per_step {
            within("queries-per-step", q, 1, MAX_QUERIES_PER_STEP)?;
        }
        if let Some(l) = self.args.episode_length {
            within("episode-length", l, 1, MAX_QUERIES_PER_STEP)?;
        }
        if self.runs.start >= self.runs.end || self.runs.end > MAX_RUN_INDEX {
            bail!(
                "--runs {}..{} is out of range: it must be a non-empty range of run indices below {MAX_RUN_INDEX}",
                self.runs.start,
                self.runs.end
            );
        }
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let max_threads = THREADS_PER_CORE * cores;
        if self.args.threads > max_threads {
            bail!(
                "--threads {} is out of range: it must be 0 (every core) to {max_threads} \
                 ({THREADS_PER_CORE} per core, {cores} core(s) available)",
                self.args.threads
            );
        }
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            bail!(
                "--spacing {} must be a positive finite number",
                self.spacing
            );
        }
        if !self.threshold.is_finite() {
            bail!("--threshold {} must be a finite number", self.threshold);
        }
        Ok(())
    }

    /// The GP options of the fits.
    pub(super) fn gp(&self) -> GpOptions {
        GpOptions {
            restarts: self.args.gp_restarts,
            max_gp: self.max_gp,
            search: self.args.gp_search,
            check: self.args.check_gp_search,
            fixed_update: self.fixed_gp.fixed_gp,
            fixed_variance: self.fixed_gp.fixed_gp_variance,
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use awfqi::env::Dynamics;

    use super::*;
    use crate::domains::{dam, puddle};

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: CommonArgs,
    }

    fn args(words: &[&str]) -> CommonArgs {
        Cli::parse_from(std::iter::once("transfer").chain(words.iter().copied())).args
    }

    #[test]
    fn algorithms_default_to_the_command_s_set_and_all_means_what_the_domain_runs() {
        let puddle = puddle::domain(Dynamics::Shared);
        let dam = dam::domain();
        let resolve = |words: &[&str], domain_is_puddle: bool| {
            let a = args(words);
            if domain_is_puddle {
                Config::resolve(
                    &a,
                    FixedGpArgs::default(),
                    &puddle,
                    &crate::commands::puddle::HEADLINE,
                )
            } else {
                Config::resolve(&a, FixedGpArgs::default(), &dam, &BASELINES_AND_AWFQI)
            }
            .map(|c| c.algorithms)
        };
        assert_eq!(
            resolve(&[], true).unwrap(),
            crate::commands::puddle::HEADLINE.to_vec()
        );
        assert_eq!(
            resolve(&["--algorithms", "all"], true).unwrap(),
            Algorithm::ALL
        );
        let on_dam = resolve(&["--algorithms", "all"], false).unwrap();
        assert_eq!(on_dam, Algorithm::ALL);
        assert_eq!(resolve(&[], false).unwrap(), BASELINES_AND_AWFQI.to_vec());
        // Named algorithms keep the table's order, once each.
        assert_eq!(
            resolve(&["--algorithms", "awfqi,fqi,awfqi"], false).unwrap(),
            [Algorithm::Fqi, Algorithm::Awfqi]
        );
        assert_eq!(
            resolve(&["--algorithms", "awfqi-adaptive,awfqi-embedded"], false).unwrap(),
            [Algorithm::AwfqiEmbedded, Algorithm::AwfqiAdaptive]
        );
    }

    #[test]
    fn query_budget_and_episode_length_are_checked_and_absent_by_default() {
        let dam = dam::domain();
        let resolve =
            |words: &[&str]| Config::resolve(&args(words), FixedGpArgs::default(), &dam, &[]);
        let c = resolve(&[]).unwrap();
        assert_eq!(
            (c.args.queries_per_step, c.args.episode_length),
            (None, None)
        );
        let c = resolve(&["--queries-per-step", "50", "--episode-length", "25"]).unwrap();
        assert_eq!(
            (c.args.queries_per_step, c.args.episode_length),
            (Some(50), Some(25))
        );
        for bad in [
            ["--queries-per-step", "0"],
            ["--episode-length", "0"],
            ["--queries-per-step", "1000001"],
        ] {
            let e = resolve(&bad).unwrap_err().to_string();
            assert!(
                e.contains(&bad[0][2..]) && e.contains("out of range"),
                "{e}"
            );
        }
    }

    #[test]
    fn options_left_out_take_the_domain_s_published_values() {
        let dam = dam::domain();
        let c = Config::resolve(
            &args(&[]),
            FixedGpArgs::default(),
            &dam,
            &BASELINES_AND_AWFQI,
        )
        .unwrap();
        let p = &dam.published;
        assert_eq!(
            (c.steps, c.episodes_per_step, c.runs.end, c.threshold),
            (p.steps, p.episodes_per_step, p.runs, p.threshold)
        );
        let c =
            Config::resolve(&args(&["--steps", "3"]), FixedGpArgs::default(), &dam, &[]).unwrap();
        assert_eq!(c.steps, 3);
    }
}
