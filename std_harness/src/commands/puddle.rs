//! `awfqi-harness puddle`: the Puddle World transfer experiments (spec §3–§9, §11–§13) —
//! every algorithm on the common protocol ([`super::transfer`]), including the core's
//! embedded AWFQI (`awfqi-kernel`). Defaults: thesis setting 2, sub-setting (b): shared
//! dynamics, 1 episode per step, 6 steps, 10 runs.

use rand_chacha::ChaCha8Rng;

use crate::domains::puddle;
use crate::transfer::algorithms::{Experiment, awfqi_kernel};
use crate::transfer::protocol::StepRecord;
use crate::transfer::score_tables::Mode;
use crate::transfer::sources::{Record, SourceSet};

pub use super::transfer::{Args, DynamicsArg, NoiseArg};
use super::transfer::{Config, Defaults, KernelHooks};

/// The command's defaults (thesis setting 2 (b), spec §13.2).
pub const DEFAULTS: Defaults = Defaults {
    episodes_per_step: 1,
    steps: 6,
    runs: 10,
    threshold: -25.0,
};

fn kernel_setup(
    sources: &SourceSet<2>,
    mode: Mode,
    spacing: f64,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<awfqi_kernel::KernelSetup> {
    awfqi_kernel::KernelSetup::new(sources, mode, spacing, rng)
}

fn kernel_run(
    experiment: &Experiment<2>,
    rng: &mut ChaCha8Rng,
    after_step: &mut dyn FnMut(&StepRecord),
) -> anyhow::Result<(Vec<StepRecord>, Vec<Record<2>>)> {
    awfqi_kernel::run(experiment, rng, after_step)
}

/// Runs the experiment and writes every output.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let dynamics = args.dynamics.unwrap_or(DynamicsArg::Shared).dynamics();
    let domain = puddle::domain(dynamics);
    let config = Config::resolve(args, &domain, &DEFAULTS, true)?;
    let hooks = KernelHooks {
        setup: kernel_setup,
        run: kernel_run,
    };
    super::transfer::run(&config, domain, Some(dynamics), Some(hooks))
}
