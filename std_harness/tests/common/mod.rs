//! Helpers shared by the harness's end-to-end tests.

use awfqi_harness::commands::puddle::Args;
use clap::Parser;

/// The command line as `awfqi-harness` parses it.
#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    args: Args,
}

/// Parses `words` (the subcommand first) into the harness's arguments.
pub fn parse(words: &[&str]) -> Args {
    Cli::parse_from(words).args
}

/// Options that make a run quick and silent: 2 FQI iterations of 2 trees, one thread, no
/// plots, no progress output.
#[allow(dead_code)] // not every test binary uses it
pub const QUICK: [&str; 8] = [
    "--iterations",
    "2",
    "--trees",
    "2",
    "--threads",
    "1",
    "--quiet",
    "--no-plots",
];
