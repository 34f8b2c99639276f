//! Gaussian-process regression for large `N` (f64, heap, faer's blocked Cholesky), as the
//! faithful path of IWFQI, AWFQI and the source-data generation fits it (spec §4.2).
//!
//! * **Kernel**: `k(z, z′) = c·exp(−‖z − z′‖² / (2ℓ²))` (constant × isotropic RBF) plus the
//!   white noise `σ²ₙ` and the jitter [`JITTER`] `= 10⁻¹⁰` on the training diagonal only
//!   (never escalated; 0 or another value through [`LargeConditioning`], which also refuses
//!   a factor whose condition estimate is beyond trust);
//!   zero prior mean; targets used as given (not centred, not scaled).
//! * **Fit** ([`LargeGp::fit`]): maximises the log marginal likelihood over
//!   `θ = (ln c, ln ℓ, ln σ²ₙ)` inside the box of [`HyperparameterBox::SPEC`] with a
//!   box-constrained quasi-Newton method and the analytic gradient ([`optimizer`]), from the
//!   initial values and from [`DEFAULT_RESTARTS`] `= 10` starts drawn uniformly in the log
//!   box (three uniforms per restart, in restart order, from the caller's generator), and
//!   keeps the best. Only the last `max_points` ([`MAX_GP`] `= 4000`, spec's `max_gp`)
//!   samples are used. This is [`FitStrategy::AllStarts`], the default. The option
//!   [`FitStrategy::Screened`] runs the same starts on a 300-point subsample first and
//!   refines each distinct end point on all data: it found the same optimum on every
//!   published source GP and on the target GPs measured, 10–20 times faster at
//!   `n ≥ 1000`, but it is not the spec's procedure.
//! * **Prediction**: mean `k*ᵀK⁻¹y` and std `√max(c + σ²ₙ − k*ᵀK⁻¹k*, 0)`, which
//!   **includes** the noise; the core's [`awfqi::weights::predictive_stds`] applies the
//!   reference's noise-subtraction rule (or the principled variance version, spec §14.7)
//!   where the record GPs turn these into posteriors (`transfer::gp`).
//!
//! # Cost
//!
//! One likelihood value is a Cholesky factorisation (`n³/3` flops) after `n²/2`
//! exponentials for `K` (a branch-free exp within 1 ulp, vectorised with AVX-512 or AVX2
//! when the CPU has them: 0.75 ns each instead of libm's 3–4 ns) and a forward solve; its
//! gradient needs the backward solve and `K⁻¹` (a triangular inverse and a triangular
//! product, `2n³/3` more). Both run near the core's peak (≈ 80 GFlop/s on the AMD Zen 5
//! measured), so at `n ≥ 1000` the `O(n³)` work is ≈ 90 % of a fit. A spec fit on
//! reward-like data spends ≈ 380–450 values and ≈ 290–370 gradients over its 11 starts (a
//! `θ` evaluated before in the fit, typically a box corner reached by several line
//! searches, is answered from a memo: 2–3 % of the values): measured on one shared core,
//! 0.7 s at `n = 500`, 5.7 s at `n = 1000` and 19–20 s at `n = 1500` (before the fast
//! exp, the deferred backward solve and the memo: 0.8 s, 6.5 s and 21.5 s), see
//! `examples/gp_timing.rs` and `examples/gp_eval_count.rs`. Buffers: two `n × n`
//! matrices and two packed triangles (`3n²` f64 in all: 69 MB at `n = 1700`, 384 MB at
//! `n = 4000`), reused by every evaluation of a fit. Linear algebra runs with the
//! [`Par`](faer::Par) given in [`FitOptions::parallelism`] (sequential by default: experiments
//! parallelise across runs).

pub mod fixed;
pub mod growing;
pub mod optimizer;

mod conditioning;
mod fit_options;
mod hyperparameters;
mod kernel;
mod large_gp;
mod likelihood;
mod reports;
mod search;

pub use conditioning::LargeConditioning;
pub use faer::Par as Parallelism;
pub use fit_options::{FitOptions, FitStrategy};
pub use hyperparameters::{GpHyperparameters, HyperparameterBox};
pub use large_gp::{GpPrediction, LargeGp};
pub use likelihood::LikelihoodEvaluator;
pub use reports::{FitReport, OptimizationRun, SearchComparison};

/// Jitter added to the training diagonal: the reference's `alpha` (spec §4.2).
pub const JITTER: f64 = 1e-10;

/// Restarts of the hyperparameter search besides the initial values (spec §4.2).
pub const DEFAULT_RESTARTS: usize = 10;

/// The spec's `max_gp`: a target GP uses at most the last this many samples (spec §4.2).
pub const MAX_GP: usize = 4000;

#[cfg(test)]
mod tests;
