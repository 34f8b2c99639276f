//! `awfqi-harness acrobot`: the IWFQI paper's multitask Acrobot experiment (Tirinzoni et
//! al., ICML 2018) — FQI, IWFQI, IWFQI-ideal, RBT (the published curves), SDT and the
//! active algorithms on the common protocol ([`super::transfer`]). Defaults: the published
//! configuration (10 episodes per step, 20 steps, 20 runs, 50 trees with
//! `min_samples_split = 5`, `min_samples_leaf = 2`, 50 iterations, ε = 0.1, evaluation from
//! nine start angles).

use crate::domains::acrobot;

use super::transfer::{BASELINES_AND_AWFQI, Config, PaperArgs};

/// Arguments of `awfqi-harness acrobot`.
pub type Args = PaperArgs;

/// Runs the experiment and writes every output.
pub fn run(args: &Args) -> anyhow::Result<()> {
    let domain = acrobot::domain();
    let config = Config::resolve(
        &args.common,
        args.fixed_gp,
        &domain,
        &BASELINES_AND_AWFQI,
        false,
    )?;
    let data = crate::transfer::domain_data::acrobot::data();
    super::transfer::run(&config, domain, data, None, None)
}
