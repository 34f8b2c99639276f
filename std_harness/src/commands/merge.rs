//! `awfqi-harness merge OUT SHARD...`: combines the result files of shard directories
//! (each written by `puddle`, `dam`, `acrobot` or `identify` with its own `--runs`, on any
//! machine) into OUT, then regenerates the summary, metrics and plots there. The shards
//! must hold one configuration and disjoint runs; the merged files equal those of one
//! invocation over all their runs.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Parser, Subcommand};

use crate::commands::transfer::ensure_writable;
use crate::identification::{self, stored};
use crate::store::{self, Conflict, DirLock, conflict_error};
use crate::transfer::algorithms::Algorithm;
use crate::transfer::result_dir::{self, append_log, inspect, result_path};
use crate::transfer::results::{ResultFile, RunRecord};

/// Arguments of `awfqi-harness merge`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// The directory the merged files go to (created when absent). Result files already
    /// there must hold the shards' configuration; their runs are kept, and a run also in a
    /// shard must be the same run.
    pub out: PathBuf,
    /// Shard directories (`--out` of each shard's invocation).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Skip the plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Start anew a result file in OUT that holds another configuration, cannot be read or
    /// holds other runs of the same indices (the shards' runs win), keeping the old file as
    /// `<name>.json.<timestamp>.bak`.
    #[arg(long)]
    pub replace: bool,
}

/// The logs that are concatenated (lines already in OUT's are not repeated).
const LOGS: [(&str, &str); 2] = [
    ("timing.csv", crate::commands::transfer::TIMING_HEADER),
    ("gp_search_check.tsv", ""),
];

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    for shard in &args.shards {
        if !shard.is_dir() {
            bail!("shard {} is not a directory", shard.display());
        }
    }
    let transfer = shard_files(&args.shards)?;
    let identify: Vec<PathBuf> = args
        .shards
        .iter()
        .map(|s| s.join(stored::FILE))
        .filter(|p| p.exists())
        .collect();
    let empty: Vec<String> = args
        .shards
        .iter()
        .filter(|s| {
            !s.join(stored::FILE).exists()
                && !transfer
                    .iter()
                    .any(|(_, p, _)| p.parent() == Some(s.as_path()))
        })
        .map(|s| s.display().to_string())
        .collect();
    if !empty.is_empty() {
        bail!(
            "shard(s) {} hold no result files (<algorithm>.json or {}). Nothing was written.",
            empty.join(", "),
            stored::FILE
        );
    }
    for note in missing_algorithms(&args.shards, &transfer) {
        eprintln!("note: {note}");
    }
    if !identify.is_empty() {
        merge_identify(args, &identify)?;
    }
    if !transfer.is_empty() {
        let command = merge_transfer(args, &transfer)?;
        regenerate(args, &command)?;
    }
    Ok(())
}

/// Every `<algorithm>.json` of the shards, read, in shard order.
fn shard_files(shards: &[PathBuf]) -> anyhow::Result<Vec<(Algorithm, PathBuf, ResultFile)>> {
    let mut files = Vec::new();
    for shard in shards {
        for a in Algorithm::ALL {
            let path = result_path(shard, a);
            if path.exists() {
                let file = ResultFile::read(&path)
                    .with_context(|| format!("shard file {} cannot be read", path.display()))?;
                files.push((a, path, file));
            }
        }
    }
    Ok(files)
}

/// One note per algorithm whose file some shards lack: the merged file then holds only the
/// runs of the shards named (legitimate when the shards split the algorithms, a lost shard
/// file otherwise).
fn missing_algorithms(
    shards: &[PathBuf],
    files: &[(Algorithm, PathBuf, ResultFile)],
) -> Vec<String> {
    let mut notes = Vec::new();
    for a in Algorithm::ALL {
        let holds = |s: &PathBuf| {
            files
                .iter()
                .any(|(b, p, _)| *b == a && p.parent() == Some(s.as_path()))
        };
        let (with, without): (Vec<&PathBuf>, Vec<&PathBuf>) = shards.iter().partition(|s| holds(s));
        if with.is_empty() || without.is_empty() {
            continue;
        }
        let names = |v: &[&PathBuf]| {
            v.iter()
                .map(|s| s.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        notes.push(format!(
            "{}.json is in {} but not in {}: the merged file holds only the runs of the first",
            a.name(),
            names(&with),
            names(&without)
        ));
    }
    notes
}

/// The remedy of a shard that does not fit the others.
const SHARD_REMEDY: &str = "Nothing was written. Merge only shards of one configuration.";

/// Merges the transfer result files into OUT under its lock; returns the command to
/// regenerate the outputs with.
fn merge_transfer(
    args: &Args,
    files: &[(Algorithm, PathBuf, ResultFile)],
) -> anyhow::Result<Vec<String>> {
    let Some((_, first_path, first)) = files.first() else {
        bail!("no result files to merge");
    };
    let experiment = &first.experiment;
    // Each algorithm's parameters: those of its first file.
    let mut parameters: BTreeMap<Algorithm, serde_json::Value> = BTreeMap::new();
    for (a, _, f) in files {
        if let Some(r) = f.runs.first() {
            parameters.entry(*a).or_insert_with(|| r.parameters.clone());
        }
    }
    let against = format!("{}", first_path.display());
    let mut merged: BTreeMap<Algorithm, BTreeMap<usize, (RunRecord, &Path)>> = BTreeMap::new();
    for (a, path, file) in files {
        if let Err(conflict) = result_dir::check(path, experiment, parameters.get(a)) {
            return Err(conflict_error(path, conflict, &against, SHARD_REMEDY));
        }
        let runs = merged.entry(*a).or_default();
        for r in &file.runs {
            if let Some((_, other)) = runs.get(&r.run) {
                bail!(
                    "{} run {} is in both {} and {}: shards must hold disjoint runs. Nothing \
                     was written.",
                    a.name(),
                    r.run,
                    other.join(format!("{}.json", a.name())).display(),
                    path.display()
                );
            }
            runs.insert(r.run, (r.clone(), path.parent().unwrap_or(Path::new("."))));
        }
    }
    let command = files
        .iter()
        .map(|(_, _, f)| &f.command)
        .find(|c| !c.is_empty())
        .cloned()
        .unwrap_or_default();

    let out = &args.out;
    ensure_writable(out)?;
    let _lock = DirLock::acquire(out)?;
    let runs: Vec<usize> = merged.values().flat_map(|m| m.keys().copied()).collect();
    let (_, notes) = inspect(out, experiment, &parameters, &runs, args.replace)?;
    for note in notes {
        eprintln!("note: {note}");
    }
    let mut written = Vec::new();
    for (a, runs) in merged {
        let path = result_path(out, a);
        let mut all: BTreeMap<usize, RunRecord> = BTreeMap::new();
        if path.exists() {
            // `inspect` checked it: this configuration.
            for r in ResultFile::read(&path)?.runs {
                all.insert(r.run, r);
            }
        }
        for (run, (record, shard)) in runs {
            match all.get(&run) {
                Some(old) if *old != record && !args.replace => bail!(
                    "{} run {run} in {} differs from the run of that index already in {}. \
                     {}",
                    a.name(),
                    shard.display(),
                    path.display(),
                    store::writer_remedy(&path)
                ),
                _ => {
                    all.insert(run, record);
                }
            }
        }
        let file =
            ResultFile::new(experiment.clone(), all.into_values().collect()).with_command(&command);
        file.write(&path)?;
        written.push(format!("{} ({} runs)", path.display(), file.n_runs));
    }
    for (name, header) in LOGS {
        merge_log(&args.shards, &out.join(name), name, header)?;
    }
    println!("merged {}", written.join(", "));
    Ok(command)
}

/// Appends the shards' lines of the log `name` that `target` lacks.
fn merge_log(shards: &[PathBuf], target: &Path, name: &str, header: &str) -> anyhow::Result<()> {
    let mut have: Vec<String> = match std::fs::read_to_string(target) {
        Ok(text) => text.lines().map(String::from).collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => bail!("reading {}: {e}", target.display()),
    };
    let mut new = String::new();
    let mut header_line = header.trim_end().to_string();
    for shard in shards {
        let path = shard.join(name);
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let mut lines = text.lines();
        if let Some(h) = lines.next()
            && header_line.is_empty()
        {
            header_line = h.to_string();
        }
        for line in lines {
            if !have.iter().any(|l| l == line) {
                have.push(line.to_string());
                new.push_str(line);
                new.push('\n');
            }
        }
    }
    if new.is_empty() {
        return Ok(());
    }
    append_log(target, &format!("{header_line}\n"), &new)
}

/// The experiment commands whose recorded command lines `merge` replays.
#[derive(Parser)]
#[command(no_binary_name = true)]
struct Recorded {
    #[command(subcommand)]
    command: Experiment,
}

#[derive(Subcommand)]
enum Experiment {
    Puddle(Box<super::puddle::Args>),
    Dam(super::dam::Args),
    Acrobot(super::acrobot::Args),
}

/// Regenerates OUT's summary, metrics and plots: the shards' command with `--no-run`.
fn regenerate(args: &Args, command: &[String]) -> anyhow::Result<()> {
    if command.is_empty() {
        bail!(
            "the result files do not record the command that made them: run that command \
             with --no-run --out {} to regenerate the summary and plots",
            args.out.display()
        );
    }
    let mut words = command.to_vec();
    words.extend([
        "--out".to_string(),
        args.out.display().to_string(),
        "--no-run".into(),
        "--quiet".into(),
    ]);
    if args.no_plots {
        words.push("--no-plots".into());
    }
    let recorded = Recorded::try_parse_from(&words)
        .with_context(|| format!("replaying the recorded command {command:?}"))?;
    match recorded.command {
        Experiment::Puddle(a) => super::puddle::run(&a),
        Experiment::Dam(a) => super::dam::run(&a),
        Experiment::Acrobot(a) => super::acrobot::run(&a),
    }
}

/// Merges the shards' `identify.json` into OUT's and rewrites its outputs.
fn merge_identify(args: &Args, paths: &[PathBuf]) -> anyhow::Result<()> {
    let mut studies = Vec::new();
    for path in paths {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("shard file {} cannot be read", path.display()))?;
        let study: identification::Study = serde_json::from_str(&text)
            .with_context(|| format!("shard file {} cannot be read", path.display()))?;
        studies.push((path, study));
    }
    let Some((first_path, first)) = studies.first() else {
        return Ok(());
    };
    let config = first.config.clone();
    let mut records: BTreeMap<usize, (identification::IdentificationRun, &Path)> = BTreeMap::new();
    for (path, study) in &studies {
        if let Err(conflict) = stored::check(path, &config) {
            return Err(conflict_error(
                path,
                conflict,
                &first_path.display().to_string(),
                SHARD_REMEDY,
            ));
        }
        for r in &study.records {
            if let Some((_, other)) = records.get(&r.run) {
                bail!(
                    "identification run {} is in both {} and {}: shards must hold disjoint \
                     runs. Nothing was written.",
                    r.run,
                    other.display(),
                    path.display()
                );
            }
            records.insert(r.run, (r.clone(), path.as_path()));
        }
    }
    let out = &args.out;
    ensure_writable(out)?;
    let _lock = DirLock::acquire(out)?;
    let target = out.join(stored::FILE);
    let mut all: BTreeMap<usize, identification::IdentificationRun> = BTreeMap::new();
    match stored::check(&target, &config) {
        Ok(None) => {}
        Ok(Some(old)) => {
            if args.replace {
                store::copy_backup(&target)?;
            }
            all.extend(old.records.into_iter().map(|r| (r.run, r)));
        }
        Err(Conflict::Unreadable(_) | Conflict::Differs(_)) if args.replace => {
            let kept = store::backup(&target)?;
            eprintln!("note: moved {} to {}", target.display(), kept.display());
        }
        Err(conflict) => {
            return Err(conflict_error(
                &target,
                conflict,
                &first_path.display().to_string(),
                &store::writer_remedy(&target),
            ));
        }
    }
    for (run, (record, path)) in records {
        match all.get(&run) {
            Some(old) if *old != record && !args.replace => bail!(
                "identification run {run} in {} differs from the run of that index already in \
                 {}. {}",
                path.display(),
                target.display(),
                store::writer_remedy(&target)
            ),
            _ => {
                all.insert(run, record);
            }
        }
    }
    let study = identification::assemble(config, all.into_values().collect());
    identification::write_outputs(&study, out, !args.no_plots)?;
    println!("merged {} ({} runs)", target.display(), study.records.len());
    Ok(())
}
