//! `awfqi-harness identify`: runs the identification study ([`crate::identification`]) and
//! writes its outputs. Records already in `identify.json` (same configuration) are kept
//! and their runs skipped, so shards (`--runs A..B`) and an interrupted invocation rerun
//! fill one file; writers to one directory take its lock.

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;

use crate::commands::transfer::ensure_writable;
use crate::identification::{
    CriterionName, Design, PolicyName, StudyConfig, assemble, run_records, stored, table,
    write_outputs,
};
use crate::run_range::RunRange;
use crate::store::{self, DirLock, refusal};

/// Arguments of `awfqi-harness identify` (defaults: [`StudyConfig::default`], the
/// thesis's study).
#[derive(clap::Args, Debug, Clone)]
pub struct Args {
    /// Query budgets n.
    #[arg(long, value_delimiter = ',', default_values_t = StudyConfig::default().budgets)]
    pub budgets: Vec<usize>,
    /// Runs: a count N (runs 0..N) or a range A..B of run indices (for splitting a
    /// sweep over machines; each run's record does not depend on the range).
    #[arg(long, default_value_t = StudyConfig::default().runs)]
    pub runs: RunRange,
    /// Score criteria.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = StudyConfig::default().criteria)]
    pub criteria: Vec<CriterionName>,
    /// Policies evaluated from the final belief.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = StudyConfig::default().policies)]
    pub policy: Vec<PolicyName>,
    /// Experiment seed.
    #[arg(long, default_value_t = StudyConfig::default().seed)]
    pub seed: u64,
    /// Output directory.
    #[arg(long, default_value = "results/identify")]
    pub out: PathBuf,
    /// Use the variant with absorbing goals (candidates then differ in transitions too).
    #[arg(long)]
    pub absorbing: bool,
    /// Discount factor γ.
    #[arg(long, default_value_t = StudyConfig::default().gamma)]
    pub gamma: f64,
    /// Monte-Carlo draws m of the reward mutual-information estimator.
    #[arg(long, default_value_t = StudyConfig::default().mi_samples)]
    pub mi_samples: usize,
    /// Common histogram bins B of the reward mutual-information estimator.
    #[arg(long, default_value_t = StudyConfig::default().mi_bins)]
    pub mi_bins: usize,
    /// Independent experiments per budget, or nested prefixes of one query sequence.
    #[arg(long, value_enum, default_value_t = StudyConfig::default().design)]
    pub design: Design,
    /// Skip writing the plots.
    #[arg(long)]
    pub no_plots: bool,
    /// Recompute runs already in `identify.json`, and start anew a file that holds another
    /// configuration or cannot be read, keeping the old one as
    /// `identify.json.<timestamp>.bak`. Without it such a file is an error (nothing is
    /// written) and runs already there are kept.
    #[arg(long)]
    pub replace: bool,
}

impl Args {
    /// The study these arguments ask for, as `identify.json` records it.
    pub fn config(&self) -> StudyConfig {
        StudyConfig {
            budgets: self.budgets.clone(),
            runs: self.runs,
            criteria: self.criteria.clone(),
            policies: self.policy.clone(),
            seed: self.seed,
            absorbing: self.absorbing,
            gamma: self.gamma,
            mi_samples: self.mi_samples,
            mi_bins: self.mi_bins,
            design: self.design,
            ..StudyConfig::default()
        }
    }
}

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start = Instant::now();
    let out = &args.out;
    // An existing --out is checked now; a new one is created only once the study's
    // configuration has passed its checks (the runs), so a refusal creates nothing.
    let exists = out.exists();
    if exists {
        ensure_writable(out)?;
    }
    let path = out.join(stored::FILE);
    let wanted = args.config();
    let present: BTreeSet<usize> = if !exists {
        BTreeSet::new()
    } else {
        let _lock = DirLock::acquire(out)?;
        match stored::check(&path, &wanted) {
            Ok(None) => BTreeSet::new(),
            Ok(Some(old)) => {
                if args.replace {
                    let kept = store::copy_backup(&path)?;
                    eprintln!(
                        "note: kept a copy of {} as {}",
                        path.display(),
                        kept.display()
                    );
                }
                old.records.iter().map(|r| r.run).collect()
            }
            Err(_) if args.replace => {
                let kept = store::backup(&path)?;
                eprintln!("note: moved {} to {}", path.display(), kept.display());
                BTreeSet::new()
            }
            Err(conflict) => {
                return Err(refusal(&path, conflict));
            }
        }
    };
    let (todo, kept): (Vec<usize>, Vec<usize>) =
        (args.runs.start..args.runs.end).partition(|r| args.replace || !present.contains(r));
    let records = run_records(&wanted, &todo, true)?;
    let elapsed = start.elapsed();

    ensure_writable(out)?;
    let _lock = DirLock::acquire(out)?;
    // The file as it is now: another writer may have added records since.
    let mut all = match stored::check(&path, &wanted) {
        Ok(None) => Vec::new(),
        Ok(Some(old)) => old.records,
        Err(conflict) => {
            return Err(refusal(&path, conflict))
                .context("another writer changed the file since this invocation began");
        }
    };
    for record in records {
        match all.iter().position(|r| r.run == record.run) {
            Some(i) if args.replace => all[i] = record,
            Some(_) => {}
            None => all.push(record),
        }
    }
    let study = assemble(wanted, all);
    let written = write_outputs(&study, out, !args.no_plots)?;
    print!("{}", table(&study));
    println!(
        "{} runs in {:.1} s on {} threads; wrote:",
        todo.len(),
        elapsed.as_secs_f64(),
        rayon::current_num_threads()
    );
    for path in written {
        println!("  {}", path.display());
    }
    if !kept.is_empty() {
        println!(
            "Kept {} run(s) already in {} instead of recomputing them; --replace recomputes them.",
            kept.len(),
            path.display()
        );
    }
    Ok(())
}
