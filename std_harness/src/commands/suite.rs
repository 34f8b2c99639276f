//! `awfqi-harness suite`: the plant suite — every plant of
//! [`SuitePlant`] at its two budget schedules of the
//! same total, each cell an ordinary transfer experiment (`<out>/<plant>/<K>x<Q>`, the
//! result files of `puddle`, `dam` and `acrobot`, so `--runs A..B` shards and `merge`
//! work per cell), then one page, `<out>/suite.md` (and `suite.csv`), of raw and
//! normalised returns against the committed anchors.
//!
//! Each cell runs FQI on the same number of target samples (episodes cut to the step's
//! queries), IWFQI where it runs in minutes, and `awfqi-adaptive` with its settings
//! derived as the plant's own command derives them (scaled from the source records; the
//! thesis's on Puddle World) and with FQI on its own samples alongside, paired. The
//! unit-box plants' sources are generated from the source plants with `--seed`.
//!
//! `--anchors` computes the anchors instead (the random policy, dynamic programming on the
//! mean model at doubling resolutions, the hand-written controllers) and writes
//! `<out>/anchors.json`, the file kept as `std_harness/data/suite-anchors.json`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::{Parser, ValueEnum};

use awfqi::env::{Tanks, Thermal, Zones};

use crate::domains::{Domain, unit_box};
use crate::run_range::RunRange;
use crate::transfer::algorithms::Algorithm;
use crate::transfer::algorithms::embedded::{EmbeddedDomain, OnPlant, Plant};
use crate::transfer::anchors::{self, Estimate, PlanReturn};
use crate::transfer::domain_data::DomainData;
use crate::transfer::suite::{
    AnchorFile, PlantAnchors, Schedule, StepStats, SuitePlant, anchors_markdown, cell_markdown,
    summarise,
};
use awfqi::prelude::{Dims, StatePlusAction};

use super::transfer::{Config, EmbeddedPath, PaperArgs, SweepDefaults, embedded_config};

/// A plant on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PlantArg {
    /// Puddle World, thesis setting 2 (b).
    Puddle,
    /// The zones (3-D, 4 actions).
    Zones,
    /// The thermal room (3-D, 3 commands).
    Thermal,
    /// The tanks (4-D, 9 actions).
    Tanks,
    /// The IWFQI paper's Dam.
    Dam,
    /// The IWFQI paper's Acrobot.
    Acrobot,
}

impl PlantArg {
    fn plant(self) -> SuitePlant {
        match self {
            PlantArg::Puddle => SuitePlant::Puddle,
            PlantArg::Zones => SuitePlant::Zones,
            PlantArg::Thermal => SuitePlant::Thermal,
            PlantArg::Tanks => SuitePlant::Tanks,
            PlantArg::Dam => SuitePlant::Dam,
            PlantArg::Acrobot => SuitePlant::Acrobot,
        }
    }
}

/// Which of a plant's two schedules.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ScheduleArg {
    /// Both.
    Both,
    /// The plant's usual steps (50 queries, Acrobot 100).
    Long,
    /// Twice the steps of half the queries.
    Short,
}

/// Arguments of `awfqi-harness suite`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Plants (default: all).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub plants: Vec<PlantArg>,
    /// Schedules.
    #[arg(long, value_enum, default_value = "both")]
    pub schedules: ScheduleArg,
    /// Runs per cell: a count N (runs 0..N) or a range A..B; results merge with those in
    /// --out.
    #[arg(long, default_value = "2")]
    pub runs: RunRange,
    /// Algorithms (default: each plant's, see the command's docs).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub algorithms: Vec<Algorithm>,
    /// Experiment seed (also of the unit-box plants' source data).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory.
    #[arg(long, default_value = "results/suite")]
    pub out: PathBuf,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Compute nothing: summarise the runs already in --out.
    #[arg(long)]
    pub no_run: bool,
    /// Recompute runs already in --out (see the transfer commands' `--replace`).
    #[arg(long)]
    pub replace: bool,
    /// Merge these shard directories (each the --out of a `suite` invocation with its own
    /// --runs) into --out cell by cell, then summarise.
    #[arg(long, num_args = 1.., value_delimiter = ',')]
    pub merge_from: Vec<PathBuf>,
    /// Compute the anchors instead and write `<out>/anchors.json`.
    #[arg(long)]
    pub anchors: bool,
    /// Repetitions of the evaluation behind each anchor (one rollout per start each).
    #[arg(long, default_value_t = 200)]
    pub repetitions: usize,
    /// No progress output.
    #[arg(long)]
    pub quiet: bool,
    /// The command line as typed; filled by the binary.
    #[arg(skip)]
    pub command: Vec<String>,
}

impl Args {
    fn plants(&self) -> Vec<SuitePlant> {
        if self.plants.is_empty() {
            SuitePlant::ALL.to_vec()
        } else {
            let mut p: Vec<SuitePlant> = self.plants.iter().map(|p| p.plant()).collect();
            p.sort();
            p.dedup();
            p
        }
    }

    fn schedules(&self, plant: SuitePlant) -> Vec<Schedule> {
        let [long, short] = plant.schedules();
        match self.schedules {
            ScheduleArg::Both => vec![long, short],
            ScheduleArg::Long => vec![long],
            ScheduleArg::Short => vec![short],
        }
    }

    fn algorithms(&self, plant: SuitePlant) -> Vec<Algorithm> {
        if self.algorithms.is_empty() {
            plant.algorithms()
        } else {
            self.algorithms.clone()
        }
    }
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    if args.anchors {
        return write_anchors(args);
    }
    let anchors = AnchorFile::committed()?;
    let mut page = String::new();
    let mut csv_rows: Vec<StepStats> = Vec::new();
    for plant in args.plants() {
        for schedule in args.schedules(plant) {
            let dir = args.out.join(plant.name()).join(schedule.name());
            let algorithms = args.algorithms(plant);
            if !args.merge_from.is_empty() {
                merge_cell(args, plant, &schedule, &dir)?;
            } else if !args.no_run {
                let start = Instant::now();
                run_cell(args, plant, &schedule, &algorithms, &dir)
                    .with_context(|| format!("{} {}", plant.name(), schedule.name()))?;
                if !args.quiet {
                    eprintln!(
                        "suite: {} {} done in {:.1} s",
                        plant.name(),
                        schedule.name(),
                        start.elapsed().as_secs_f64()
                    );
                }
            }
            let Some(a) = anchors.of(plant) else {
                eprintln!("suite: no anchors for {}: not summarised", plant.name());
                continue;
            };
            let summary = summarise(&dir, plant, &schedule, &algorithms, a)?;
            page.push_str(&cell_markdown(plant, &schedule, &summary));
            csv_rows.extend(summary.steps);
        }
    }
    let text = format!(
        "### Anchors\n\n{}\n### Returns\n\nRaw returns ± standard error over runs; normalised: \
         (R − R_random) / (R_best − R_random) with the anchors above; failed: runs whose \
         normalised return at the last step is below 0.5. `fqi` learns from its own episodes \
         with the same number of target samples per step; `fqi-same-samples` is FQI with \
         `awfqi-adaptive`'s approximator on `awfqi-adaptive`'s own target samples, evaluated \
         on the same rollouts' noise.\n{page}",
        anchors_markdown(&anchors)
    );
    std::fs::create_dir_all(&args.out)?;
    crate::store::write_atomic(&args.out.join("suite.md"), text.as_bytes())?;
    crate::store::write_csv(&args.out.join("suite.csv"), &csv_rows)?;
    println!("{text}");
    println!("outputs in {}", args.out.display());
    Ok(())
}

/// The argument vector of the cell's transfer command.
fn cell_argv(
    args: &Args,
    plant: SuitePlant,
    schedule: &Schedule,
    algorithms: &[Algorithm],
    dir: &Path,
    horizon: usize,
) -> Vec<String> {
    let (episodes, length) = schedule.episodes(horizon);
    let names: Vec<&str> = algorithms.iter().map(|a| a.name()).collect();
    let mut v: Vec<String> = vec![
        plant.name().into(),
        "--steps".into(),
        schedule.steps.to_string(),
        "--queries-per-step".into(),
        schedule.queries.to_string(),
        "--episodes-per-step".into(),
        episodes.to_string(),
        "--episode-length".into(),
        length.to_string(),
        "--runs".into(),
        args.runs.to_string(),
        "--seed".into(),
        args.seed.to_string(),
        "--algorithms".into(),
        names.join(","),
        "--out".into(),
        dir.display().to_string(),
        "--threads".into(),
        args.threads.to_string(),
        "--no-plots".into(),
        "--adaptive-same-samples-fqi".into(),
    ];
    if matches!(
        plant,
        SuitePlant::Zones | SuitePlant::Thermal | SuitePlant::Tanks
    ) {
        v.extend(["--sources".into(), "generate".into()]);
    }
    for (on, flag) in [
        (args.quiet, "--quiet"),
        (args.replace, "--replace"),
        (args.no_run, "--no-run"),
    ] {
        if on {
            v.push(flag.into());
        }
    }
    v
}

/// Parses a transfer command's arguments from `argv` (its name first).
fn parse<A: clap::Args>(argv: &[String]) -> anyhow::Result<A> {
    #[derive(Parser)]
    struct Wrap<A: clap::Args> {
        #[command(flatten)]
        args: A,
    }
    Ok(Wrap::<A>::try_parse_from(argv)?.args)
}

/// Runs one cell.
fn run_cell(
    args: &Args,
    plant: SuitePlant,
    schedule: &Schedule,
    algorithms: &[Algorithm],
    dir: &Path,
) -> anyhow::Result<()> {
    let horizon = horizon_of(plant);
    let argv = cell_argv(args, plant, schedule, algorithms, dir, horizon);
    match plant {
        SuitePlant::Puddle => {
            let mut a: super::puddle::Args = parse(&argv)?;
            a.common.command = argv;
            super::puddle::run(&a)
        }
        SuitePlant::Dam => {
            let mut a: PaperArgs = parse(&argv)?;
            a.common.command = argv;
            super::dam::run(&a)
        }
        SuitePlant::Acrobot => {
            let mut a: PaperArgs = parse(&argv)?;
            a.common.command = argv;
            super::acrobot::run(&a)
        }
        SuitePlant::Zones => {
            let mut a: PaperArgs = parse(&argv)?;
            a.common.command = argv;
            run_unit_box::<Zones<f32>, 3, 4>(
                &a,
                unit_box::zones(),
                crate::transfer::domain_data::unit_box::zones(),
            )
        }
        SuitePlant::Thermal => {
            let mut a: PaperArgs = parse(&argv)?;
            a.common.command = argv;
            run_unit_box::<Thermal<f32>, 3, 4>(
                &a,
                unit_box::thermal(),
                crate::transfer::domain_data::unit_box::thermal(),
            )
        }
        SuitePlant::Tanks => {
            let mut a: PaperArgs = parse(&argv)?;
            a.common.command = argv;
            run_unit_box::<Tanks<f32>, 4, 5>(
                &a,
                unit_box::tanks(),
                crate::transfer::domain_data::unit_box::tanks(),
            )
        }
    }
}

/// A plant's horizon.
fn horizon_of(plant: SuitePlant) -> usize {
    match plant {
        SuitePlant::Puddle => awfqi::env::PUDDLE_HORIZON,
        SuitePlant::Zones => awfqi::env::ZONES_HORIZON,
        SuitePlant::Thermal => awfqi::env::THERMAL_HORIZON,
        SuitePlant::Tanks => awfqi::env::TANKS_HORIZON,
        SuitePlant::Dam => awfqi::env::DAM_HORIZON,
        SuitePlant::Acrobot => awfqi::env::ACROBOT_HORIZON,
    }
}

/// A unit-box plant's transfer experiment, as `dam` runs the Dam's: the core's algorithms
/// with settings scaled from the source records.
fn run_unit_box<P: Plant<D>, const D: usize, const I: usize>(
    args: &PaperArgs,
    domain: Domain<D>,
    data: DomainData<D>,
) -> anyhow::Result<()>
where
    Dims<D, I>: StatePlusAction,
{
    let config = Config::resolve(&args.common, args.fixed_gp, &domain, &[])?;
    let embedded = EmbeddedPath {
        setup: OnPlant::<P, D, I>::shared,
        domain: EmbeddedDomain::scaled(&domain, config.iterations),
        config: embedded_config(
            &args.embedded,
            &args.adaptive,
            config.setting,
            config.spacing,
            SweepDefaults::UNIT_BOX,
        )?,
        adaptive: args.adaptive.options(),
    };
    super::transfer::run(&config, domain, data, None, Some(embedded))
}

/// Merges the shards' files of one cell into `dir`.
fn merge_cell(
    args: &Args,
    plant: SuitePlant,
    schedule: &Schedule,
    dir: &Path,
) -> anyhow::Result<()> {
    let shards: Vec<PathBuf> = args
        .merge_from
        .iter()
        .map(|s| s.join(plant.name()).join(schedule.name()))
        .filter(|s| s.is_dir())
        .collect();
    if shards.is_empty() {
        return Ok(());
    }
    super::merge::run(&super::merge::Args {
        out: dir.to_path_buf(),
        shards,
        no_plots: true,
        replace: args.replace,
    })
}

/// The Dam's standard operating rule: release the demand, 10, and the most, 30, above the
/// flooding threshold (the other plants' controllers are the core's: the zones' and the
/// thermal room's thermostats, the tanks' proportional controller; Puddle World has none).
pub fn dam_rule(s: &[f64; 2]) -> usize {
    if s[0] > awfqi::env::DAM_FLOODING {
        7
    } else {
        4
    }
}

/// Acrobot's energy pumping: torque in the direction of the first link's velocity.
pub fn acrobot_pumping(s: &[f64; 4]) -> usize {
    usize::from(s[2] >= 0.0)
}

/// A hand-written controller: its name and its policy.
type Controller<'a, const D: usize> = (&'a str, fn(&[f64; D]) -> usize);

/// Computes one plant's anchors.
fn plant_anchors<const D: usize>(
    plant: SuitePlant,
    domain: &Domain<D>,
    controller: Option<Controller<'_, D>>,
    resolutions: &[[usize; D]],
    args: &Args,
) -> anyhow::Result<PlantAnchors> {
    let start = Instant::now();
    let random = anchors::random_return(domain, args.repetitions, args.seed)?;
    let controller: Option<(String, Estimate)> = match controller {
        Some((name, f)) => Some((
            name.to_string(),
            anchors::mean_return(domain, &anchors::rule(f), args.repetitions, args.seed)?,
        )),
        None => None,
    };
    let plans: Vec<PlanReturn> =
        anchors::plan_returns(domain, resolutions, args.repetitions, args.seed)?;
    let a = PlantAnchors::new(plant, random, controller, plans);
    eprintln!(
        "anchors: {}: random {:.3}, best {:.3} ({}) in {:.1} s",
        plant.name(),
        a.random.mean,
        a.best,
        a.best_label,
        start.elapsed().as_secs_f64()
    );
    Ok(a)
}

/// `--anchors`: computes the anchors of the selected plants.
fn write_anchors(args: &Args) -> anyhow::Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()?;
    let plants = pool.install(|| -> anyhow::Result<Vec<PlantAnchors>> {
        args.plants()
            .into_iter()
            .map(|plant| match plant {
                SuitePlant::Puddle => plant_anchors(
                    plant,
                    &crate::domains::puddle::domain(awfqi::env::Dynamics::Shared),
                    None,
                    &[[25; 2], [50; 2], [100; 2]],
                    args,
                ),
                SuitePlant::Zones => plant_anchors(
                    plant,
                    &unit_box::zones(),
                    Some(("thermostat", awfqi::env::zones_thermostat::<f64>)),
                    &[[10; 3], [20; 3], [40; 3]],
                    args,
                ),
                SuitePlant::Thermal => plant_anchors(
                    plant,
                    &unit_box::thermal(),
                    Some(("thermostat", awfqi::env::thermal_thermostat::<f64>)),
                    &[[10; 3], [20; 3], [40; 3]],
                    args,
                ),
                SuitePlant::Tanks => plant_anchors(
                    plant,
                    &unit_box::tanks(),
                    Some((
                        "proportional controller",
                        awfqi::env::tanks_proportional::<f64>,
                    )),
                    &[[5; 4], [10; 4], [20; 4]],
                    args,
                ),
                SuitePlant::Dam => plant_anchors(
                    plant,
                    &crate::domains::dam::domain(),
                    Some(("standard operating rule", dam_rule)),
                    &[[50, 359], [100, 359], [200, 359]],
                    args,
                ),
                SuitePlant::Acrobot => plant_anchors(
                    plant,
                    &crate::domains::acrobot::domain(),
                    Some(("energy pumping", acrobot_pumping)),
                    &[[5; 4], [10; 4], [20; 4]],
                    args,
                ),
            })
            .collect()
    })?;
    let file = AnchorFile {
        command: format!("awfqi-harness {}", args.command.join(" ")),
        seed: args.seed,
        repetitions: args.repetitions,
        plants,
    };
    std::fs::create_dir_all(&args.out)?;
    let path = args.out.join("anchors.json");
    crate::store::write_atomic(&path, serde_json::to_string_pretty(&file)?.as_bytes())?;
    println!("{}", anchors_markdown(&file));
    println!("anchors written to {}", path.display());
    Ok(())
}
