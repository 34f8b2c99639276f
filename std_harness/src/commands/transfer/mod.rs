//! The transfer-experiment commands (`awfqi-harness puddle`, `dam`, `acrobot`): every
//! algorithm on the common protocol of one domain, result files in the reference's layout,
//! a summary, transfer metrics, learning curves and sample scatters.
//!
//! The three commands share their options ([`CommonArgs`]; each command adds its own
//! groups); an option left out takes the domain's default ([`crate::domains::Published`]:
//! Puddle World's thesis setting 2 (b), the Dam's and Acrobot's published configurations).
//! Runs of all algorithms go in parallel (rayon,
//! `--threads`), each run seeded from (`--seed`, algorithm, run index), so the same seed
//! gives the same numbers whatever the scheduling, and `--runs A..B` computes a slice of
//! runs whose results merge into the `<algorithm>.json` files already in `--out`
//! ([`crate::transfer::result_dir`]: same configuration only, runs already there kept,
//! writers locked).

mod args;
mod config;
mod embedded;
mod experiment;
mod logs;
mod plan;
mod progress;
mod report;
mod run;

pub use args::{CommonArgs, FixedGpArgs, NoiseArg, PaperArgs};
pub use config::{
    AlgorithmChoice, BASELINES_AND_AWFQI, Config, MAX_EPISODES_PER_STEP, MAX_GP_POINTS,
    MAX_GP_RESTARTS, MAX_ITERATIONS, MAX_RUN_INDEX, MAX_STEPS, MAX_TREES,
};
pub use embedded::{
    AdaptiveArgs, AdaptiveQArg, EmbeddedArgs, EmbeddedQArg, SweepDefaults, embedded_config,
};
pub use experiment::{EmbeddedPath, SetupFn, build_experiment};
pub use logs::TIMING_HEADER;
pub use plan::ensure_writable;
pub use run::{run, run_one};
