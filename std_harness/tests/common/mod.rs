//! Helpers shared by the harness's end-to-end tests.

use clap::{Args, FromArgMatches, Parser};

/// The command line as `awfqi-harness` parses it for one subcommand's arguments `A`.
#[derive(Parser)]
struct Cli<A: Args + FromArgMatches> {
    #[command(flatten)]
    args: A,
}

/// Parses `words` (the subcommand first) into that subcommand's arguments.
pub fn parse<A: Args + FromArgMatches>(words: &[&str]) -> A {
    Cli::<A>::parse_from(words).args
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
