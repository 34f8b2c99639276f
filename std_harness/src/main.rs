//! `awfqi-harness`: experiments, baselines and the reference implementation around the
//! awfqi core. Each subcommand lives in its own module under `commands/`. An error ends the
//! process with exit status 1 and a plain message; `AWFQI_DEBUG=1` adds the stack trace.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use awfqi_harness::commands;

/// Experiments and tools for the awfqi kernel.
#[derive(Parser)]
#[command(
    name = "awfqi-harness",
    version,
    about,
    after_help = "An error ends the command with exit status 1 and a plain message; \
                  AWFQI_DEBUG=1 adds the stack trace (a debug report)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// A quick demonstration: one Puddle World episode and a GP fit, written to results/demo.
    Demo(commands::demo::Args),
    /// Gaussian-process regression cases from a JSON file, by the core or the reference.
    Gp(commands::gp::Args),
    /// Finite-MDP identification on the Grid World (thesis Figs. 4.2 and 4.3).
    Identify(commands::identify::Args),
    /// Puddle World transfer experiments: every algorithm on the protocol of spec §3.
    Puddle(Box<commands::puddle::Args>),
    /// The IWFQI paper's water reservoir (Dam): every algorithm on the protocol of spec §3.
    Dam(commands::dam::Args),
    /// The IWFQI paper's multitask Acrobot: every algorithm on the protocol of spec §3.
    Acrobot(commands::acrobot::Args),
    /// Combines the result files of shard directories (same configuration, disjoint runs)
    /// into OUT and regenerates the summary, metrics and plots.
    Merge(commands::merge::Args),
    /// The plant suite: every plant at two budget schedules of the same total, against
    /// the random policy and the best known return.
    Suite(commands::suite::Args),
}

/// The environment variable that asks for a debug report of an error (its chain with the
/// stack trace) instead of the plain message.
const DEBUG_VARIABLE: &str = "AWFQI_DEBUG";

fn main() -> ExitCode {
    let debug = std::env::var_os(DEBUG_VARIABLE).is_some_and(|v| !v.is_empty() && v != "0");
    if debug && std::env::var_os("RUST_LIB_BACKTRACE").is_none() {
        // SAFETY: no other thread runs yet.
        unsafe { std::env::set_var("RUST_LIB_BACKTRACE", "1") };
    }
    ignore_file_size_signal();
    match run(Cli::parse().command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            report(&error, debug);
            ExitCode::FAILURE
        }
    }
}

/// Prints `error` on stderr: its message and causes, as anyhow does, but never a stack
/// trace (even with `RUST_BACKTRACE=1`, common on a developer's machine) unless `debug`.
fn report(error: &anyhow::Error, debug: bool) {
    if debug {
        eprintln!("Error: {error:?}");
        return;
    }
    eprintln!("Error: {error}");
    let causes: Vec<String> = error.chain().skip(1).map(|c| c.to_string()).collect();
    match causes.as_slice() {
        [] => {}
        [one] => eprintln!("\nCaused by:\n    {one}"),
        many => {
            eprintln!("\nCaused by:");
            for (i, cause) in many.iter().enumerate() {
                eprintln!("    {i}: {cause}");
            }
        }
    }
}

/// A write beyond the file-size limit (`ulimit -f`) would kill the process with SIGXFSZ,
/// silently and with a temporary file left behind; ignored, the write fails with `EFBIG`
/// instead, and the writer reports it, naming the file, and removes its temporary file.
fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to "ignore" at start-up, before any thread.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

fn run(command: Command) -> anyhow::Result<()> {
    // The transfer commands record their command line in their result files.
    let typed = || std::env::args().skip(1).collect::<Vec<String>>();
    match command {
        Command::Demo(args) => commands::demo::run(&args),
        Command::Gp(args) => commands::gp::run(&args),
        Command::Identify(args) => commands::identify::run(&args),
        Command::Puddle(mut args) => {
            args.common.command = typed();
            commands::puddle::run(&args)
        }
        Command::Dam(mut args) => {
            args.common.command = typed();
            commands::dam::run(&args)
        }
        Command::Acrobot(mut args) => {
            args.common.command = typed();
            commands::acrobot::run(&args)
        }
        Command::Merge(args) => commands::merge::run(&args),
        Command::Suite(mut args) => {
            args.command = typed();
            commands::suite::run(&args)
        }
    }
}
