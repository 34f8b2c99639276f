//! `awfqi-harness identify`: runs the identification study ([`crate::identification`]) and
//! writes its outputs.

use std::time::Instant;

pub use crate::identification::Args;
use crate::identification::{study, table, write_outputs};

/// Runs the subcommand.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let start = Instant::now();
    let study = study(args, true)?;
    let elapsed = start.elapsed();
    let written = write_outputs(&study, &args.out, !args.no_plots)?;
    print!("{}", table(&study));
    println!(
        "{} runs in {:.1} s on {} threads; wrote:",
        args.runs.end - args.runs.start,
        elapsed.as_secs_f64(),
        rayon::current_num_threads()
    );
    for path in written {
        println!("  {}", path.display());
    }
    Ok(())
}
