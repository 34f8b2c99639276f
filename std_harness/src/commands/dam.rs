//! `awfqi-harness dam`: the IWFQI paper's water-reservoir experiment (Tirinzoni et al.,
//! ICML 2018) — FQI, IWFQI, IWFQI-ideal, RBT (the published curves), SDT and the active
//! algorithms on the common protocol ([`super::transfer`]). Defaults: the published
//! configuration (1 episode of 360 days per step, 10 steps, 20 runs, 100 trees with
//! `min_samples_split = 20`, 60 iterations, ε = 0.3, evaluation from (200, 1) ten times).

use crate::domains::dam;

use super::transfer::{BASELINES_AND_AWFQI, Config, PaperArgs};

/// Arguments of `awfqi-harness dam`.
pub type Args = PaperArgs;

/// Runs the experiment and writes every output.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let domain = dam::domain();
    let config = Config::resolve(
        &args.common,
        args.fixed_gp,
        &domain,
        &BASELINES_AND_AWFQI,
        false,
    )?;
    let data = crate::transfer::domain_data::dam::data();
    super::transfer::run(&config, domain, data, None, None)
}
