//! `awfqi-harness identify`: runs the identification study ([`crate::identification`]) and
//! writes its outputs. Records already in `identify.json` (same configuration) are kept
//! and their runs skipped, so shards (`--runs A..B`) and an interrupted invocation rerun
//! fill one file; writers to one directory take its lock.

use std::collections::BTreeSet;
use std::time::Instant;

use anyhow::Context;

pub use crate::identification::Args;
use crate::identification::{assemble, config, run_records, stored, table, write_outputs};
use crate::store::{self, DirLock, refusal};

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start = Instant::now();
    let out = &args.out;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let path = out.join(stored::FILE);
    let wanted = config(args);
    let present: BTreeSet<usize> = {
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
    let records = run_records(args, &todo, true)?;
    let elapsed = start.elapsed();

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
