//! `awfqi-harness`: experiments, baselines and the reference implementation around the
//! awfqi core. Each subcommand lives in its own module under `commands/`.

use clap::{Parser, Subcommand};

use awfqi_harness::commands;

/// Experiments and tools for the awfqi kernel.
#[derive(Parser)]
#[command(name = "awfqi-harness", version, about)]
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

fn main() -> anyhow::Result<()> {
    // The transfer commands record their command line in their result files.
    let typed = || std::env::args().skip(1).collect::<Vec<String>>();
    match Cli::parse().command {
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
