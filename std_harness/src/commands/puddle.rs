//! `awfqi-harness puddle`: the Puddle World transfer experiments (spec §3–§9, §11–§13) —
//! every algorithm on the common protocol ([`super::transfer`]), including the core's
//! embedded ones. Defaults: thesis setting 2, sub-setting (b): shared dynamics, 1 episode
//! per step, 6 steps, 10 runs of the headline comparison ([`HEADLINE`]);
//! `--algorithms all` runs every algorithm.

use clap::ValueEnum;

use awfqi::env::{Dynamics, PuddleWorld};

use crate::domains::puddle;
use crate::transfer::algorithms::Algorithm;
use crate::transfer::algorithms::embedded::{EmbeddedDomain, OnPlant};

use super::transfer::{
    AdaptiveArgs, CommonArgs, Config, EmbeddedArgs, EmbeddedPath, FixedGpArgs, SweepDefaults,
    embedded_config,
};

/// The command's default algorithms, the headline comparison: FQI on the target alone,
/// IWFQI, the thesis's AWFQI and the adaptive AWFQI.
pub const HEADLINE: [Algorithm; 4] = [
    Algorithm::Fqi,
    Algorithm::Iwfqi,
    Algorithm::Awfqi,
    Algorithm::AwfqiAdaptive,
];

/// Puddle World's dynamics variants on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DynamicsArg {
    /// κ = 0: all tasks share their transitions (the thesis's setting).
    Shared,
    /// κ = 5: puddles slow the agent down.
    Puddle,
}

impl DynamicsArg {
    /// The core's variant.
    pub fn dynamics(self) -> Dynamics {
        match self {
            DynamicsArg::Shared => Dynamics::Shared,
            DynamicsArg::Puddle => Dynamics::PuddleBased,
        }
    }
}

/// Arguments of `awfqi-harness puddle`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Every transfer command's options.
    #[command(flatten)]
    pub common: CommonArgs,
    /// Puddle World's dynamics variant.
    #[arg(long, value_enum, default_value = "shared")]
    pub dynamics: DynamicsArg,
    /// `awfqi-embedded`'s options.
    #[command(flatten)]
    pub embedded: EmbeddedArgs,
    /// `awfqi-adaptive`'s options.
    #[command(flatten)]
    pub adaptive: AdaptiveArgs,
}

/// Runs the experiment and writes every output.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let dynamics = args.dynamics.dynamics();
    let domain = puddle::domain(dynamics);
    let config = Config::resolve(&args.common, FixedGpArgs::default(), &domain, &HEADLINE)?;
    let embedded = EmbeddedPath {
        setup: OnPlant::<PuddleWorld<f32>, 2, 3>::shared,
        domain: EmbeddedDomain::puddle(),
        config: embedded_config(
            &args.embedded,
            &args.adaptive,
            config.setting,
            config.spacing,
            SweepDefaults::PUDDLE,
        )?,
        adaptive: args.adaptive.options(),
    };
    let data = crate::transfer::domain_data::puddle::data(dynamics);
    super::transfer::run(&config, domain, data, Some(dynamics), Some(embedded))
}
