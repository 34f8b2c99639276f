//! How a fit searches: [`FitStrategy`] and [`FitOptions`].

use super::*;
use faer::Par;

/// How [`LargeGp::fit`] spends its optimisations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FitStrategy {
    /// Spec §4.2 as written: every start (initial values and restarts) is optimised on all
    /// the data, and the best optimum is kept.
    AllStarts,
    /// A faster search for the same optimum (**not** the spec's procedure): every start is
    /// first optimised on an evenly spaced subsample of at most `subsample` points; the end
    /// points are then refined on all the data, once per group of end points closer than
    /// `merge_radius` in log space (infinity norm), and the best refined optimum is kept.
    /// With at most `subsample` points it is [`FitStrategy::AllStarts`].
    ///
    /// The starts are the same draws as [`FitStrategy::AllStarts`]'s. Each full-data
    /// optimisation begins near its optimum instead of at a random corner of the box, which
    /// removes most of the `O(n³)` evaluations; the result differs from the spec's only when
    /// the subsample's likelihood has no end point in the basin of the full data's best
    /// optimum.
    Screened {
        /// Size of the screening subsample.
        subsample: usize,
        /// End points within this distance (log space, infinity norm) share one refinement.
        merge_radius: f64,
    },
    /// [`FitStrategy::Screened`] with a second, larger subsample between the screening and
    /// all the data (**not** the spec's procedure either): each distinct screened end point
    /// is first refined on an evenly spaced subsample of `intermediate` points, end points
    /// that land within `merge_radius` of an earlier one there share its refinement, and
    /// the rest are refined on all the data from there. A likelihood value costs `n³/3`,
    /// so the intermediate stage is cheap (1/27 of a full one at a third of the points),
    /// and the full-data optimisations start closer to their optimum than
    /// [`FitStrategy::Screened`]'s: fewer `O(n³)` evaluations at large `n`. With at most
    /// `intermediate` points it is [`FitStrategy::Screened`].
    Staged {
        /// Size of the screening subsample.
        subsample: usize,
        /// Size of the intermediate subsample (larger than `subsample`).
        intermediate: usize,
        /// End points within this distance (log space, infinity norm) share one refinement,
        /// after the screening and again after the intermediate stage.
        merge_radius: f64,
        /// Start each full-data optimisation with the intermediate one's inverse-Hessian
        /// model (scaled by the ratio of the sizes) instead of a scaled identity.
        warm_hessian: bool,
    },
}

impl FitStrategy {
    /// [`FitStrategy::Screened`] with a 300-point subsample and a merge radius of 0.5.
    pub const SCREENED: Self = Self::Screened {
        subsample: 300,
        merge_radius: 0.5,
    };

    /// [`FitStrategy::Staged`] with subsamples of 300 and 1 000 points and a merge radius
    /// of 0.5.
    pub const STAGED: Self = Self::Staged {
        subsample: 300,
        intermediate: 1000,
        merge_radius: 0.5,
        warm_hessian: true,
    };
}

/// Options of [`LargeGp::fit`]; [`FitOptions::default`] is spec §4.2's procedure.
#[derive(Debug, Clone, Copy)]
pub struct FitOptions {
    /// Starting hyperparameters of the first optimisation (spec: all 1).
    pub initial: GpHyperparameters,
    /// Search box (spec §4.2).
    pub bounds: HyperparameterBox,
    /// Further optimisations from uniform draws in the log box (spec: 10).
    pub restarts: usize,
    /// Use only the last this many samples (spec `max_gp` = 4000).
    pub max_points: usize,
    /// Stopping rules of each optimisation (scipy's L-BFGS-B defaults).
    pub optimizer: optimizer::Options,
    /// faer's parallelism for the linear algebra ([`Par::Seq`] by default).
    pub parallelism: Par,
    /// How the starts are optimised ([`FitStrategy::AllStarts`], the spec's, by default).
    pub strategy: FitStrategy,
    /// Jitter and trusted condition ([`LargeConditioning::default`]: the reference's).
    pub conditioning: LargeConditioning,
    /// Also run this search on the same data and starts, and report its optimum in
    /// [`FitReport::comparison`] (the kept GP is `strategy`'s; no extra random draws).
    pub compare: Option<FitStrategy>,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            initial: GpHyperparameters::SPEC_INITIAL,
            bounds: HyperparameterBox::SPEC,
            restarts: DEFAULT_RESTARTS,
            max_points: MAX_GP,
            optimizer: optimizer::Options::default(),
            parallelism: Par::Seq,
            strategy: FitStrategy::AllStarts,
            conditioning: LargeConditioning::default(),
            compare: None,
        }
    }
}
