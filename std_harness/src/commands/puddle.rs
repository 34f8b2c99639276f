//! `awfqi-harness puddle`: the Puddle World transfer experiments (spec §3–§9, §11–§13) —
//! every algorithm on the common protocol ([`super::transfer`]), including the core's
//! embedded ones. Defaults: thesis setting 2, sub-setting (b): shared dynamics, 1 episode
//! per step, 6 steps, 10 runs of the headline comparison ([`HEADLINE`]);
//! `--algorithms all` runs every algorithm.

use rand_chacha::ChaCha8Rng;

use crate::domains::puddle;
use crate::transfer::algorithms::awfqi_kernel::{self, KernelConfig, KernelSetup};
use crate::transfer::algorithms::{Algorithm, adaptive_kernel};
use crate::transfer::sources::SourceSet;

pub use super::transfer::{Args, DynamicsArg, NoiseArg};
use super::transfer::{Config, KernelHooks};

/// The command's default algorithms, the headline comparison: FQI on the target alone,
/// IWFQI, the thesis's AWFQI and the adaptive AWFQI.
pub const HEADLINE: [Algorithm; 4] = [
    Algorithm::Fqi,
    Algorithm::Iwfqi,
    Algorithm::Awfqi,
    Algorithm::AwfqiAdaptiveKernel,
];

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
    let config = Config::resolve(args, &domain, &HEADLINE, true)?;
    let hooks = KernelHooks {
        setup: kernel_setup,
        learner: awfqi_kernel::with_learner,
        adaptive_learner: adaptive_kernel::with_learner,
    };
    let data = crate::transfer::domain_data::puddle::data(dynamics);
    super::transfer::run(&config, domain, data, Some(dynamics), Some(hooks))
}
