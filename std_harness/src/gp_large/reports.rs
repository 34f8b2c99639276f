//! What a fit reports: every optimisation ([`OptimizationRun`]), the fit as a whole
//! ([`FitReport`]) and the comparison of two strategies ([`SearchComparison`]).

use super::*;

/// What one optimisation of a fit did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimizationRun {
    /// Starting point `θ` (log space).
    pub start: [f64; 3],
    /// The optimum found (log space).
    pub theta: [f64; 3],
    /// Its log marginal likelihood (`−∞` when the start could not be evaluated).
    pub log_marginal_likelihood: f64,
    /// Likelihood values the optimiser asked for.
    pub evaluations: usize,
    /// Cholesky factorisations spent: the values at points not evaluated before in the
    /// fit (a repeated `θ` is answered from a memo), plus one per gradient at such a point.
    pub factorizations: usize,
    /// Gradient evaluations spent.
    pub gradients: usize,
    /// Why it stopped.
    pub stop: optimizer::Stop,
    /// [`FitStrategy::Screened`]: the end point on the subsample (where the full-data
    /// optimisation started) and the subsample evaluations spent.
    pub screening: Option<([f64; 3], usize)>,
    /// [`FitStrategy::Staged`]: the end point on the intermediate subsample (where the
    /// full-data optimisation started) and the evaluations spent there; `None` for a start
    /// merged after the screening.
    pub staging: Option<([f64; 3], usize)>,
    /// The optimiser's inverse-Hessian model at the end (see
    /// [`optimizer::Minimum::inverse_hessian`]).
    pub inverse_hessian: [[f64; 3]; 3],
    /// [`FitStrategy::Screened`]: the earlier run whose refinement this start shares
    /// (its `theta`, likelihood and counts are copies of that run's).
    pub merged_into: Option<usize>,
}

/// The record of a [`LargeGp::fit`]: every optimisation and the index of the one kept.
#[derive(Debug, Clone, PartialEq)]
pub struct FitReport {
    /// The initial-value optimisation first, then the restarts in order.
    pub runs: Vec<OptimizationRun>,
    /// Index in `runs` of the kept optimum (the first of the highest likelihood).
    pub best: usize,
    /// [`FitOptions::compare`]: the other search's result next to the kept one.
    pub comparison: Option<SearchComparison>,
}

/// The kept search against the one of [`FitOptions::compare`], run on the same data and the
/// same starts (the checker of a fast search against the spec's, or the other way round).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchComparison {
    /// Log marginal likelihood of the kept search's optimum.
    pub log_marginal_likelihood: f64,
    /// Log marginal likelihood of the other search's optimum.
    pub other_log_marginal_likelihood: f64,
    /// Cholesky factorisations of the kept search (all data; the final conditioning not
    /// counted).
    pub factorizations: usize,
    /// Cholesky factorisations of the other search (all data; a screening subsample's not
    /// counted).
    pub other_factorizations: usize,
    /// Seconds the kept search took (thread CPU is not separated: wall time of the call).
    pub seconds: f64,
    /// Seconds the other search took.
    pub other_seconds: f64,
}

impl SearchComparison {
    /// `|other − kept| / max(|kept|, 1)`.
    pub fn relative_difference(&self) -> f64 {
        (self.other_log_marginal_likelihood - self.log_marginal_likelihood).abs()
            / self.log_marginal_likelihood.abs().max(1.0)
    }
}
