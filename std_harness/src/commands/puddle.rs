//! `awfqi-harness puddle`: the Puddle World transfer experiments (spec §3–§9, §11–§13) —
//! every algorithm on the common protocol ([`super::transfer`]), including the core's
//! embedded AWFQI (`awfqi-kernel`). Defaults: thesis setting 2, sub-setting (b): shared
//! dynamics, 1 episode per step, 6 steps, 10 runs.

use rand_chacha::ChaCha8Rng;

use crate::domains::puddle;
use crate::transfer::algorithms::adaptive_kernel;
use crate::transfer::algorithms::awfqi_kernel::{self, KernelConfig, KernelSetup};
use crate::transfer::sources::SourceSet;

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
    config: KernelConfig,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<KernelSetup> {
    KernelSetup::new(sources, config, rng)
}

/// Runs the experiment and writes every output.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let dynamics = args.dynamics.unwrap_or(DynamicsArg::Shared).dynamics();
    let domain = puddle::domain(dynamics);
    let config = Config::resolve(args, &domain, &DEFAULTS, true)?;
    let hooks = KernelHooks {
        setup: kernel_setup,
        learner: awfqi_kernel::with_learner,
        adaptive_learner: adaptive_kernel::with_learner,
    };
    let data = crate::transfer::domain_data::puddle::data(dynamics);
    super::transfer::run(&config, domain, data, Some(dynamics), Some(hooks))
}
