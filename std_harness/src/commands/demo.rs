//! The `demo` subcommand (to be written).

/// Arguments of `awfqi-harness demo`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs the subcommand.
pub fn run(_args: &Args) -> anyhow::Result<()> {
    anyhow::bail!("not yet implemented")
}
