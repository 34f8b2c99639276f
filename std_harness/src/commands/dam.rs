//! `awfqi-harness dam`: the IWFQI paper's water-reservoir experiment (Tirinzoni et al.,
//! ICML 2018) — FQI, IWFQI, IWFQI-ideal, RBT (the published curves), SDT and the active
//! algorithms on the common protocol ([`super::transfer`]). Defaults: the published
//! configuration (1 episode of 360 days per step, 10 steps, 20 runs, 100 trees with
//! `min_samples_split = 20`, 60 iterations, ε = 0.3, evaluation from (200, 1) ten times).

use crate::domains::dam;

use awfqi::env::Dam;

use crate::transfer::algorithms::embedded::{EmbeddedDomain, OnPlant};

use super::transfer::{
    BASELINES_AND_AWFQI, Config, EmbeddedPath, PaperArgs, SweepDefaults, embedded_config,
};

/// Arguments of `awfqi-harness dam`.
pub type Args = PaperArgs;

/// Runs the experiment and writes every output.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let domain = dam::domain();
    let config = Config::resolve(&args.common, args.fixed_gp, &domain, &BASELINES_AND_AWFQI)?;
    // The core's algorithms with settings scaled from the source records.
    let embedded = EmbeddedPath {
        setup: OnPlant::<Dam<f32>, 2, 3>::shared,
        domain: EmbeddedDomain::scaled(&domain, config.iterations),
        config: embedded_config(
            &args.embedded,
            &args.adaptive,
            config.setting,
            config.spacing,
            SweepDefaults::DAM,
        )?,
        adaptive: args.adaptive.options(),
    };
    let data = crate::transfer::domain_data::dam::data();
    super::transfer::run(&config, domain, data, None, Some(embedded))
}
