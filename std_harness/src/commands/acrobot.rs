//! `awfqi-harness acrobot`: the IWFQI paper's multitask Acrobot experiment (Tirinzoni et
//! al., ICML 2018) — FQI, IWFQI, IWFQI-ideal, RBT (the published curves), SDT and the
//! active algorithms on the common protocol ([`super::transfer`]). Defaults: the published
//! configuration (10 episodes per step, 20 steps, 20 runs, 50 trees with
//! `min_samples_split = 5`, `min_samples_leaf = 2`, 50 iterations, ε = 0.1, evaluation from
//! nine start angles).

use crate::domains::acrobot;

use awfqi::env::Acrobot;

use crate::transfer::algorithms::embedded::{EmbeddedDomain, OnPlant};

use super::transfer::{
    BASELINES_AND_AWFQI, Config, EmbeddedPath, PaperArgs, SweepDefaults, embedded_config,
};

/// Arguments of `awfqi-harness acrobot`.
pub type Args = PaperArgs;

/// Runs the experiment and writes every output.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let domain = acrobot::domain();
    let config = Config::resolve(&args.common, args.fixed_gp, &domain, &BASELINES_AND_AWFQI)?;
    // The core's algorithms with settings scaled from the source records.
    let embedded = EmbeddedPath {
        setup: OnPlant::<Acrobot<f32>, 4, 5>::shared,
        domain: EmbeddedDomain::scaled(&domain, config.iterations),
        config: embedded_config(
            &args.embedded,
            &args.adaptive,
            config.setting,
            config.spacing,
            SweepDefaults::ACROBOT,
        )?,
        adaptive: args.adaptive.options(),
    };
    let data = crate::transfer::domain_data::acrobot::data();
    super::transfer::run(&config, domain, data, None, Some(embedded))
}
