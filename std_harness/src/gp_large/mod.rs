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
//! [`Par`] given in [`FitOptions::parallelism`] (sequential by default: experiments
//! parallelise across runs).

pub mod fixed;
pub mod growing;
pub mod optimizer;

use awfqi::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::triangular::BlockStructure;
use faer::{Accum, Mat, Par};
use rand_core::Rng;

pub use faer::Par as Parallelism;

/// Jitter added to the training diagonal: the reference's `alpha` (spec §4.2).
pub const JITTER: f64 = 1e-10;

/// The conditioning policy of a [`LargeGp`] (the core's `awfqi::gp::Conditioning` for f64):
/// the jitter on the training diagonal and the largest trusted condition estimate.
///
/// The large GP never escalates its jitter: it factorises `K + (σ²ₙ + jitter) I` with
/// exactly [`LargeConditioning::jitter`] or fails with [`Error::NotPositiveDefinite`], so the
/// jitter never exceeds `jitter / σ²ₙ` relative to the noise (`10⁻⁸` inside the spec box,
/// `σ²ₙ ≥ 10⁻²`). After the final factorisation of a fit the diagonal condition estimate
/// `(max Lᵢᵢ / min Lᵢᵢ)²` (a lower bound on `κ₂`) must stay within
/// [`LargeConditioning::max_condition`], else the fit is refused with
/// [`Error::IllConditioned`]: in f64 the default `10⁻²/ε = 4.5·10¹³` is far above what the
/// spec box allows (`κ₂ ≤ 1 + n·c/σ²ₙ ≤ 4·10¹⁰` at `n = 4000`), so it never changes a fit of
/// the faithful path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LargeConditioning {
    /// Added to the training diagonal ([`JITTER`], the reference's `alpha`; 0 for none).
    pub jitter: f64,
    /// The largest trusted diagonal condition estimate.
    pub max_condition: f64,
}

impl Default for LargeConditioning {
    fn default() -> Self {
        Self {
            jitter: JITTER,
            max_condition: 1e-2 / f64::EPSILON,
        }
    }
}

impl LargeConditioning {
    fn validate(&self) -> Result<()> {
        if !(self.jitter.is_finite() && self.jitter >= 0.0) {
            return Err(Error::InvalidParameter {
                parameter: "jitter",
            });
        }
        if self.max_condition.is_nan() || self.max_condition < 1.0 {
            return Err(Error::InvalidParameter {
                parameter: "max_condition",
            });
        }
        Ok(())
    }
}

/// `(max Lᵢᵢ / min Lᵢᵢ)²` of a lower Cholesky factor.
fn diagonal_condition(factor: &Mat<f64>) -> f64 {
    let n = factor.nrows().min(factor.ncols());
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for i in 0..n {
        lo = lo.min(factor[(i, i)]);
        hi = hi.max(factor[(i, i)]);
    }
    if n == 0 {
        1.0
    } else if lo > 0.0 {
        (hi / lo).powi(2)
    } else {
        f64::INFINITY
    }
}

/// Restarts of the hyperparameter search besides the initial values (spec §4.2).
pub const DEFAULT_RESTARTS: usize = 10;

/// The spec's `max_gp`: a target GP uses at most the last this many samples (spec §4.2).
pub const MAX_GP: usize = 4000;

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// Kernel hyperparameters: signal variance `c`, length scale `ℓ`, noise variance `σ²ₙ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpHyperparameters {
    /// Signal variance `c > 0`.
    pub signal_variance: f64,
    /// Isotropic length scale `ℓ > 0`.
    pub length_scale: f64,
    /// Noise variance `σ²ₙ ≥ 0`.
    pub noise_variance: f64,
}

impl GpHyperparameters {
    /// Spec §4.2's initial values: `c = ℓ = σ²ₙ = 1`.
    pub const SPEC_INITIAL: Self = Self {
        signal_variance: 1.0,
        length_scale: 1.0,
        noise_variance: 1.0,
    };

    /// `θ = (ln c, ln ℓ, ln σ²ₙ)`.
    pub fn to_log(&self) -> [f64; 3] {
        [
            self.signal_variance.ln(),
            self.length_scale.ln(),
            self.noise_variance.ln(),
        ]
    }

    /// The hyperparameters of `θ = (ln c, ln ℓ, ln σ²ₙ)`.
    pub fn from_log(theta: &[f64; 3]) -> Self {
        Self {
            signal_variance: theta[0].exp(),
            length_scale: theta[1].exp(),
            noise_variance: theta[2].exp(),
        }
    }

    fn validate(&self) -> Result<()> {
        for (v, parameter) in [
            (self.signal_variance, "signal_variance"),
            (self.length_scale, "length_scale"),
            (self.noise_variance, "noise_variance"),
        ] {
            if !v.is_finite() {
                return Err(Error::NonFinite { parameter });
            }
        }
        if self.signal_variance <= 0.0 {
            return Err(Error::InvalidParameter {
                parameter: "signal_variance",
            });
        }
        if self.length_scale <= 0.0 {
            return Err(Error::InvalidParameter {
                parameter: "length_scale",
            });
        }
        if self.noise_variance < 0.0 {
            return Err(Error::InvalidParameter {
                parameter: "noise_variance",
            });
        }
        Ok(())
    }
}

/// Bounds of the hyperparameter search, as `(low, high)` of each hyperparameter (not of its
/// logarithm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HyperparameterBox {
    /// Bounds of `c`.
    pub signal_variance: (f64, f64),
    /// Bounds of `ℓ`.
    pub length_scale: (f64, f64),
    /// Bounds of `σ²ₙ`.
    pub noise_variance: (f64, f64),
}

impl HyperparameterBox {
    /// Spec §4.2: `c ∈ [10⁻⁵, 10⁵]`, `ℓ ∈ [10⁻², 10³]`, `σ²ₙ ∈ [10⁻², 1]`.
    pub const SPEC: Self = Self {
        signal_variance: (1e-5, 1e5),
        length_scale: (1e-2, 1e3),
        noise_variance: (1e-2, 1.0),
    };

    /// Lower and upper corners in log space.
    pub fn log_bounds(&self) -> ([f64; 3], [f64; 3]) {
        (
            [
                self.signal_variance.0.ln(),
                self.length_scale.0.ln(),
                self.noise_variance.0.ln(),
            ],
            [
                self.signal_variance.1.ln(),
                self.length_scale.1.ln(),
                self.noise_variance.1.ln(),
            ],
        )
    }

    fn validate(&self) -> Result<()> {
        let (lo, hi) = self.log_bounds();
        for i in 0..3 {
            if !(lo[i].is_finite() && hi[i].is_finite()) {
                return Err(Error::NonFinite {
                    parameter: "bounds",
                });
            }
            if lo[i] > hi[i] {
                return Err(Error::InvalidParameter {
                    parameter: "bounds",
                });
            }
        }
        Ok(())
    }
}

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

/// A prediction: mean and standard deviation (the std includes the noise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpPrediction {
    /// Posterior mean `k*ᵀK⁻¹y`.
    pub mean: f64,
    /// `√max(c + σ²ₙ − k*ᵀK⁻¹k*, 0)`.
    pub std: f64,
}

/// A Gaussian process conditioned on its training data (see the [module docs](self)).
///
/// Memory: the `n × n` Cholesky factor (`8n²` bytes), the inputs and `K⁻¹y`.
#[derive(Debug, Clone)]
pub struct LargeGp<const D: usize> {
    inputs: Vec<[f64; D]>,
    hyper: GpHyperparameters,
    /// Lower Cholesky factor `L` of `K + (σ²ₙ + jitter) I` (lower triangle).
    factor: Mat<f64>,
    /// `K⁻¹y`.
    alpha: Vec<f64>,
    lml: f64,
    par: Par,
    jitter: f64,
}

/// [`Error::IllConditioned`] when the factor's diagonal condition estimate exceeds the
/// policy's limit.
fn check_condition(factor: &Mat<f64>, conditioning: &LargeConditioning) -> Result<()> {
    let condition = diagonal_condition(factor);
    if condition <= conditioning.max_condition {
        Ok(())
    } else {
        Err(Error::IllConditioned {
            condition: awfqi::error::Number(condition),
            limit: awfqi::error::Number(conditioning.max_condition),
        })
    }
}

fn validate_data<const D: usize>(inputs: &[[f64; D]], targets: &[f64]) -> Result<()> {
    if inputs.is_empty() {
        return Err(Error::EmptyData);
    }
    if targets.len() != inputs.len() {
        return Err(Error::InvalidParameter {
            parameter: "targets",
        });
    }
    if inputs.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            parameter: "inputs",
        });
    }
    if targets.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            parameter: "targets",
        });
    }
    Ok(())
}

fn squared_distance<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum()
}

/// `exp(x)` for `x ≤ 0` (any `x < −746`, and `−∞`, give 0), within 1 ulp of the exact value
/// (subnormal results correctly rounded from it), without branches so that a loop over a
/// slice vectorises. Used for the kernel matrix, where libm's scalar `exp` was 13 % of a fit.
///
/// fdlibm's method: `x = k ln 2 + r` with `|r| ≤ ln 2 / 2` (`k` rounded to nearest by the
/// `1.5·2⁵²` trick, `ln 2` split in two so that `x − k·ln2_hi` is exact), `exp(r)` from the
/// degree-5 Remez approximation `R(r²)` of `r (eʳ + 1)/(eʳ − 1)` evaluated as
/// `1 − ((lo − r c/(2 − c)) − hi)`, then scaled by `2^⌊k/2⌋ · 2^(k − ⌊k/2⌋)` (two exact powers of
/// two, so a subnormal result is rounded once). Plain multiplications and additions only
/// (no fused multiply-add), so every vector width gives bitwise the same results.
#[inline(always)]
fn exp_nonpositive(x: f64) -> f64 {
    const LN2_HI: f64 = 0.6931471803691238;
    const LN2_LO: f64 = 1.9082149292705877e-10;
    const LOG2_E: f64 = std::f64::consts::LOG2_E;
    const P1: f64 = 0.16666666666666602;
    const P2: f64 = -0.0027777777777015593;
    const P3: f64 = 6.613756321437934e-5;
    const P4: f64 = -1.6533902205465252e-6;
    const P5: f64 = 4.1381367970572385e-8;
    /// Adding and subtracting it rounds an `|v| < 2⁵¹` to the nearest integer.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    /// `2⁵² + 1023`: adding it puts a biased exponent `k + 1023 ∈ [0, 2047]` in the low bits.
    const BIAS: f64 = 4_503_599_627_371_519.0;
    let x = x.clamp(-746.0, 0.0);
    let k = (x * LOG2_E + ROUND) - ROUND;
    let hi = x - k * LN2_HI;
    let lo = k * LN2_LO;
    let r = hi - lo;
    let t = r * r;
    let c = r - t * (P1 + t * (P2 + t * (P3 + t * (P4 + t * P5))));
    let y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
    let k1 = (k * 0.5 + ROUND) - ROUND;
    let k2 = k - k1;
    let pow2 = |m: f64| f64::from_bits((m + BIAS).to_bits() << 52);
    y * pow2(k1) * pow2(k2)
}

/// Calls the AVX-512 build of a function when the CPU has AVX-512F, else its AVX2 build
/// when it has AVX2, else the portable one (on x86-64; elsewhere always the portable one).
macro_rules! widest_vectors {
    ($avx512:ident, $avx2:ident, $generic:ident, ($($arg:expr),*)) => {{
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            return unsafe { $avx512($($arg),*) };
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above).
            return unsafe { $avx2($($arg),*) };
        }
        $generic($($arg),*)
    }};
}

/// One column of the kernel matrix: `e = exp(k·d²)` ([`exp_nonpositive`]) and `out = c·e`.
#[inline(always)]
fn kernel_column_generic(k: f64, c: f64, d2: &[f64], e: &mut [f64], out: &mut [f64]) {
    for ((o, ev), &d) in out.iter_mut().zip(e.iter_mut()).zip(d2) {
        *ev = exp_nonpositive(k * d);
        *o = c * *ev;
    }
}

/// [`kernel_column_generic`] compiled for AVX2 (4 lanes).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn kernel_column_avx2(k: f64, c: f64, d2: &[f64], e: &mut [f64], out: &mut [f64]) {
    kernel_column_generic(k, c, d2, e, out);
}

/// [`kernel_column_generic`] compiled for AVX-512 (8 lanes; half the time of AVX2's).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn kernel_column_avx512(k: f64, c: f64, d2: &[f64], e: &mut [f64], out: &mut [f64]) {
    kernel_column_generic(k, c, d2, e, out);
}

/// [`kernel_column_generic`] with the widest vectors the CPU has (bitwise the same results).
fn kernel_column(k: f64, c: f64, d2: &[f64], e: &mut [f64], out: &mut [f64]) {
    widest_vectors!(
        kernel_column_avx512,
        kernel_column_avx2,
        kernel_column_generic,
        (k, c, d2, e, out)
    )
}

/// One column's share of the gradient sums: `Σ tᵢ` and `Σ tᵢ d²ᵢ` with
/// `tᵢ = (αᵢ αⱼ − K⁻¹ᵢⱼ) eᵢ`, in 8 interleaved partial sums so that the loop vectorises.
#[inline(always)]
fn gradient_column_generic(
    kinv: &[f64],
    alpha: &[f64],
    aj: f64,
    e: &[f64],
    d2: &[f64],
) -> (f64, f64) {
    const LANES: usize = 8;
    let (mut se, mut sd) = ([0.0; LANES], [0.0; LANES]);
    let n = kinv.len().min(alpha.len()).min(e.len()).min(d2.len());
    let split = n - n % LANES;
    let (kinv, kinv_rest) = kinv[..n].split_at(split);
    let (alpha, alpha_rest) = alpha[..n].split_at(split);
    let (e, e_rest) = e[..n].split_at(split);
    let (d2, d2_rest) = d2[..n].split_at(split);
    for (((k, a), ev), d) in kinv
        .chunks_exact(LANES)
        .zip(alpha.chunks_exact(LANES))
        .zip(e.chunks_exact(LANES))
        .zip(d2.chunks_exact(LANES))
    {
        for l in 0..LANES {
            let t = (a[l] * aj - k[l]) * ev[l];
            se[l] += t;
            sd[l] += t * d[l];
        }
    }
    for (((&k, &a), &ev), &d) in kinv_rest.iter().zip(alpha_rest).zip(e_rest).zip(d2_rest) {
        let t = (a * aj - k) * ev;
        se[0] += t;
        sd[0] += t * d;
    }
    (se.iter().sum(), sd.iter().sum())
}

/// [`gradient_column_generic`] compiled for AVX-512.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn gradient_column_avx512(
    kinv: &[f64],
    alpha: &[f64],
    aj: f64,
    e: &[f64],
    d2: &[f64],
) -> (f64, f64) {
    gradient_column_generic(kinv, alpha, aj, e, d2)
}

/// [`gradient_column_generic`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn gradient_column_avx2(kinv: &[f64], alpha: &[f64], aj: f64, e: &[f64], d2: &[f64]) -> (f64, f64) {
    gradient_column_generic(kinv, alpha, aj, e, d2)
}

/// [`gradient_column_generic`] with the widest vectors the CPU has (bitwise the same results).
fn gradient_column(kinv: &[f64], alpha: &[f64], aj: f64, e: &[f64], d2: &[f64]) -> (f64, f64) {
    widest_vectors!(
        gradient_column_avx512,
        gradient_column_avx2,
        gradient_column_generic,
        (kinv, alpha, aj, e, d2)
    )
}

/// Evaluates the log marginal likelihood and its gradient at many `θ` for fixed data,
/// reusing its buffers. The numerical heart of [`LargeGp::fit`], public for tests and
/// benchmarks.
pub struct LikelihoodEvaluator<'a, const D: usize> {
    targets: &'a [f64],
    /// Squared distances, strict lower triangle packed column by column.
    d2: Vec<f64>,
    /// `exp(−d²/(2ℓ²))` at the last evaluated `θ`, same layout.
    e: Vec<f64>,
    /// `K`, then `L` in the lower triangle; after a gradient, `K⁻¹`.
    chol: Mat<f64>,
    /// `L⁻¹` during a gradient.
    inv: Mat<f64>,
    /// `L⁻¹y` after a value, `K⁻¹y` after [`LikelihoodEvaluator::finish_alpha`] (a
    /// one-column matrix for faer's solves).
    alpha: Mat<f64>,
    scratch: MemBuffer,
    par: Par,
    /// `θ` and the kernel values of the last successful value evaluation.
    last: Option<[f64; 3]>,
    /// Every `θ` evaluated through [`NegativeLml`] with its value, so that a repeated point
    /// (line searches of different starts often end on the same corner of the box) costs
    /// no factorisation.
    memo: Vec<([f64; 3], Option<f64>)>,
    /// Cholesky factorisations done (every [`LikelihoodEvaluator::value`] call).
    factorizations: usize,
    /// Added to the training diagonal ([`JITTER`] unless set by [`Self::with_jitter`]).
    jitter: f64,
}

impl<'a, const D: usize> LikelihoodEvaluator<'a, D> {
    /// Prepares the evaluation on `(inputs, targets)`.
    ///
    /// Errors: empty data ([`Error::EmptyData`]), mismatched lengths, non-finite values.
    pub fn new(inputs: &[[f64; D]], targets: &'a [f64], par: Par) -> Result<Self> {
        validate_data(inputs, targets)?;
        let n = inputs.len();
        let mut d2 = Vec::with_capacity(n * (n - 1) / 2);
        for j in 0..n {
            for i in j + 1..n {
                d2.push(squared_distance(&inputs[i], &inputs[j]));
            }
        }
        let scratch = MemBuffer::new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                n,
                par,
                Default::default(),
            ),
        );
        Ok(Self {
            targets,
            e: vec![0.0; d2.len()],
            d2,
            chol: Mat::zeros(n, n),
            inv: Mat::zeros(n, n),
            alpha: Mat::zeros(n, 1),
            scratch,
            par,
            last: None,
            memo: Vec::new(),
            factorizations: 0,
            jitter: JITTER,
        })
    }

    /// The same evaluator with `jitter` on the training diagonal instead of [`JITTER`].
    pub fn with_jitter(mut self, jitter: f64) -> Self {
        self.jitter = jitter;
        self
    }

    /// The log marginal likelihood at `θ = (ln c, ln ℓ, ln σ²ₙ)`, or `None` when the Gram
    /// matrix is not positive definite (the reference then reports `−∞`).
    pub fn value(&mut self, theta: &[f64; 3]) -> Option<f64> {
        self.last = None;
        self.factorizations += 1;
        let n = self.targets.len();
        let h = GpHyperparameters::from_log(theta);
        let c = h.signal_variance;
        let k = -0.5 / (h.length_scale * h.length_scale);
        let mut p = 0;
        for j in 0..n {
            let col = self.chol.col_as_slice_mut(j);
            col[j] = c + h.noise_variance + self.jitter;
            let len = n - j - 1;
            kernel_column(
                k,
                c,
                &self.d2[p..p + len],
                &mut self.e[p..p + len],
                &mut col[j + 1..],
            );
            p += len;
        }
        faer::linalg::cholesky::llt::factor::cholesky_in_place(
            self.chol.as_mut(),
            Default::default(),
            self.par,
            MemStack::new(&mut self.scratch),
            Default::default(),
        )
        .ok()?;
        // yᵀK⁻¹y = ‖L⁻¹y‖²: the backward solve for α = K⁻¹y waits for a gradient.
        self.alpha.col_as_slice_mut(0).copy_from_slice(self.targets);
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            self.chol.as_ref(),
            self.alpha.as_mut(),
            self.par,
        );
        let fit: f64 = self.alpha.col_as_slice(0).iter().map(|w| w * w).sum();
        let log_det: f64 = (0..n).map(|i| self.chol[(i, i)].ln()).sum();
        let lml = -0.5 * fit - log_det - 0.5 * n as f64 * LN_2PI;
        if !lml.is_finite() {
            return None;
        }
        self.last = Some(*theta);
        Some(lml)
    }

    /// `α = K⁻¹y` from `L⁻¹y` (in `alpha` after a value) by the backward solve with `Lᵀ`; `L`
    /// must still be in `chol` (no gradient since the value).
    fn finish_alpha(&mut self) {
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            self.chol.as_ref().transpose(),
            self.alpha.as_mut(),
            self.par,
        );
    }

    /// `∂ LML / ∂θ` at the `θ` of the last successful [`LikelihoodEvaluator::value`]
    /// (`½ tr((ααᵀ − K⁻¹) ∂K/∂θ_k)` with `α = K⁻¹y`), or `None` without one. Overwrites the
    /// factor, so it can be called once per value.
    pub fn gradient(&mut self) -> Option<[f64; 3]> {
        let theta = self.last.take()?;
        let n = self.targets.len();
        let h = GpHyperparameters::from_log(&theta);
        self.finish_alpha();
        // K⁻¹ = L⁻ᵀ L⁻¹ into the lower triangle of `chol`.
        faer::linalg::triangular_inverse::invert_lower_triangular(
            self.inv.as_mut(),
            self.chol.as_ref(),
            self.par,
        );
        faer::linalg::matmul::triangular::matmul(
            self.chol.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            self.inv.as_ref().transpose(),
            BlockStructure::TriangularUpper,
            self.inv.as_ref(),
            BlockStructure::TriangularLower,
            1.0,
            self.par,
        );
        let alpha = self.alpha.col_as_slice(0);
        // Diagonal (e = 1, d² = 0) and strict lower triangle (counted twice by symmetry).
        let mut diag = 0.0;
        let (mut off_e, mut off_ed2) = (0.0, 0.0);
        let mut p = 0;
        for j in 0..n {
            let col = self.chol.col_as_slice(j);
            let w = alpha[j] * alpha[j] - col[j];
            diag += w;
            let len = n - j - 1;
            let (d2, e) = (&self.d2[p..p + len], &self.e[p..p + len]);
            let (se, sd) = gradient_column(&col[j + 1..], &alpha[j + 1..], alpha[j], e, d2);
            off_e += se;
            off_ed2 += sd;
            p += len;
        }
        let c = h.signal_variance;
        let l2 = h.length_scale * h.length_scale;
        Some([
            0.5 * c * (diag + 2.0 * off_e),
            c * off_ed2 / l2,
            0.5 * h.noise_variance * diag,
        ])
    }
}

/// Minimises `−LML` through the evaluator, answering a `θ` evaluated before (bitwise the
/// same) from the evaluator's memo: the optimiser sees exactly the values it would have
/// computed, and a gradient at a memoised point refactorises first.
struct NegativeLml<'e, 'a, const D: usize> {
    eval: &'e mut LikelihoodEvaluator<'a, D>,
    /// The last value came from the memo at this `θ`: the factor in `eval` is not its.
    stale: Option<[f64; 3]>,
}

impl<const D: usize> optimizer::Objective<3> for NegativeLml<'_, '_, D> {
    fn value(&mut self, x: &[f64; 3]) -> Option<f64> {
        if let Some(&(_, v)) = self.eval.memo.iter().find(|(t, _)| t == x) {
            self.stale = Some(*x);
            return v.map(|v| -v);
        }
        self.stale = None;
        let v = self.eval.value(x);
        self.eval.memo.push((*x, v));
        v.map(|v| -v)
    }
    fn gradient(&mut self) -> [f64; 3] {
        if let Some(x) = self.stale.take() {
            self.eval.value(&x);
        }
        self.eval
            .gradient()
            .map_or([f64::NAN; 3], |g| [-g[0], -g[1], -g[2]])
    }
}

/// The index of the first of the highest likelihood among the finished optimisations.
fn best_run(runs: &[OptimizationRun]) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (i, run) in runs.iter().enumerate() {
        if run.merged_into.is_none()
            && run.log_marginal_likelihood.is_finite()
            && best.is_none_or(|b| run.log_marginal_likelihood > runs[b].log_marginal_likelihood)
        {
            best = Some(i);
        }
    }
    best
}

/// Optimises `starts` on `eval`'s data as `strategy` says (the first start is the initial
/// values, the others the restarts).
fn search<const D: usize>(
    strategy: FitStrategy,
    (inputs, targets): (&[[f64; D]], &[f64]),
    eval: &mut LikelihoodEvaluator<'_, D>,
    starts: &[[f64; 3]],
    options: &FitOptions,
) -> Result<Vec<OptimizationRun>> {
    let (lower, upper) = options.bounds.log_bounds();
    let optimize_warm = |eval: &mut LikelihoodEvaluator<'_, D>,
                         start: &[f64; 3],
                         inverse_hessian: Option<&[[f64; 3]; 3]>| {
        let factorizations = eval.factorizations;
        let m = optimizer::minimize_warm(
            &mut NegativeLml { eval, stale: None },
            start,
            &lower,
            &upper,
            &options.optimizer,
            inverse_hessian,
        );
        OptimizationRun {
            start: *start,
            theta: m.x,
            log_marginal_likelihood: -m.f,
            evaluations: m.evaluations,
            factorizations: eval.factorizations - factorizations,
            gradients: m.gradients,
            stop: m.stop,
            screening: None,
            staging: None,
            merged_into: None,
            inverse_hessian: m.inverse_hessian,
        }
    };
    let optimize =
        |eval: &mut LikelihoodEvaluator<'_, D>, start: &[f64; 3]| optimize_warm(eval, start, None);
    // The screened and staged searches: `(subsample, merge radius, intermediate stage)`,
    // the stage being its size and whether it carries the curvature model (a staged
    // search with no more points than its stage is the screened one).
    let screening = match strategy {
        FitStrategy::Screened {
            subsample,
            merge_radius,
        } => Some((subsample.max(1), merge_radius, None)),
        FitStrategy::Staged {
            subsample,
            intermediate,
            merge_radius,
            warm_hessian,
        } => {
            let stage = (inputs.len() > intermediate && intermediate > subsample.max(1))
                .then_some((intermediate, warm_hessian));
            Some((subsample.max(1), merge_radius, stage))
        }
        FitStrategy::AllStarts => None,
    };
    let mut runs: Vec<OptimizationRun> = Vec::with_capacity(starts.len());
    match screening {
        Some((subsample, merge_radius, stage)) if inputs.len() > subsample => {
            let jitter = options.conditioning.jitter;
            let (a_inputs, a_targets) = evenly_spaced(inputs, targets, subsample);
            let mut a_eval = LikelihoodEvaluator::new(&a_inputs, &a_targets, options.parallelism)?
                .with_jitter(jitter);
            let (b_inputs, b_targets) = match stage {
                Some((intermediate, _)) => evenly_spaced(inputs, targets, intermediate),
                None => (Vec::new(), Vec::new()),
            };
            let mut b_eval = match stage {
                Some(_) => Some(
                    LikelihoodEvaluator::new(&b_inputs, &b_targets, options.parallelism)?
                        .with_jitter(jitter),
                ),
                None => None,
            };
            let close = |a: &[f64; 3], b: &[f64; 3]| {
                a.iter().zip(b).all(|(x, y)| (x - y).abs() <= merge_radius)
            };
            for start in starts {
                let screened = optimize(&mut a_eval, start);
                let end = screened.theta;
                let shared = runs.iter().position(|r| {
                    r.merged_into.is_none() && r.screening.is_some_and(|(e, _)| close(&e, &end))
                });
                let mut run = match (shared, stage, b_eval.as_mut()) {
                    (Some(j), _, _) => OptimizationRun {
                        merged_into: Some(j),
                        staging: None,
                        ..runs[j]
                    },
                    (None, Some((_, warm)), Some(b_eval)) => {
                        let h = carried_model(&screened, a_inputs.len(), b_inputs.len());
                        let staged = optimize_warm(b_eval, &end, warm.then_some(&h));
                        let mid = staged.theta;
                        let shared = runs.iter().position(|r| {
                            r.merged_into.is_none()
                                && r.staging.is_some_and(|(m, _)| close(&m, &mid))
                        });
                        let mut run = match shared {
                            Some(j) => OptimizationRun {
                                merged_into: Some(j),
                                ..runs[j]
                            },
                            None => {
                                let h = carried_model(&staged, b_inputs.len(), inputs.len());
                                optimize_warm(eval, &mid, warm.then_some(&h))
                            }
                        };
                        run.staging = Some((mid, staged.evaluations));
                        run
                    }
                    _ => optimize(eval, &end),
                };
                run.start = *start;
                run.screening = Some((end, screened.evaluations));
                runs.push(run);
            }
        }
        _ => {
            for start in starts {
                let run = optimize(eval, start);
                runs.push(run);
            }
        }
    }
    Ok(runs)
}

/// The inverse-Hessian model an optimisation on `from` points hands to the next stage on
/// `to` points: the negative log likelihood grows about linearly with the data, and its
/// curvature with it, so the inverse shrinks by `from / to`.
fn carried_model(run: &OptimizationRun, from: usize, to: usize) -> [[f64; 3]; 3] {
    let ratio = from as f64 / to as f64;
    run.inverse_hessian.map(|row| row.map(|v| v * ratio))
}

/// `m` of the points (`m < inputs.len()`), evenly spaced in the data's order: indices
/// `⌊i·n/m⌋`.
fn evenly_spaced<const D: usize>(
    inputs: &[[f64; D]],
    targets: &[f64],
    m: usize,
) -> (Vec<[f64; D]>, Vec<f64>) {
    let n = inputs.len();
    (0..m)
        .map(|i| (inputs[i * n / m], targets[i * n / m]))
        .unzip()
}

impl<const D: usize> LargeGp<D> {
    /// Conditions a GP with fixed hyperparameters on `(inputs, targets)` (all of them, no
    /// `max_points` cap).
    ///
    /// Errors: empty data ([`Error::EmptyData`]), mismatched lengths, non-finite values,
    /// invalid hyperparameters, a Gram matrix that is not positive definite
    /// ([`Error::NotPositiveDefinite`]).
    pub fn new(
        inputs: &[[f64; D]],
        targets: &[f64],
        hyper: GpHyperparameters,
        par: Par,
    ) -> Result<Self> {
        Self::new_with(inputs, targets, hyper, par, &LargeConditioning::default())
    }

    /// [`LargeGp::new`] under a conditioning policy.
    ///
    /// Errors: those of [`LargeGp::new`], an invalid policy ([`Error::InvalidParameter`]),
    /// a factor beyond the policy's condition limit ([`Error::IllConditioned`]).
    pub fn new_with(
        inputs: &[[f64; D]],
        targets: &[f64],
        hyper: GpHyperparameters,
        par: Par,
        conditioning: &LargeConditioning,
    ) -> Result<Self> {
        hyper.validate()?;
        conditioning.validate()?;
        let mut eval =
            LikelihoodEvaluator::new(inputs, targets, par)?.with_jitter(conditioning.jitter);
        let lml = eval
            .value(&hyper.to_log())
            .ok_or(Error::NotPositiveDefinite)?;
        check_condition(&eval.chol, conditioning)?;
        eval.finish_alpha();
        Ok(Self {
            inputs: inputs.to_vec(),
            hyper,
            alpha: eval.alpha.col_as_slice(0).to_vec(),
            factor: eval.chol,
            lml,
            par,
            jitter: conditioning.jitter,
        })
    }

    /// The jitter on the training diagonal of this fit.
    pub fn jitter(&self) -> f64 {
        self.jitter
    }

    /// The diagonal condition estimate `(max Lᵢᵢ / min Lᵢᵢ)²` of the factor (see
    /// [`LargeConditioning`]).
    pub fn condition_estimate(&self) -> f64 {
        diagonal_condition(&self.factor)
    }

    /// Fits the hyperparameters by maximising the log marginal likelihood on the last
    /// `options.max_points` samples (spec §4.2), then conditions on those samples.
    ///
    /// Draws `3 · options.restarts` uniforms from `rng` (restart starts, in order).
    ///
    /// Errors: as [`LargeGp::new`], plus invalid options (`max_points == 0`, bad bounds or
    /// initial values), and [`Error::NotPositiveDefinite`] when no start could be evaluated.
    pub fn fit<R: Rng + ?Sized>(
        inputs: &[[f64; D]],
        targets: &[f64],
        options: &FitOptions,
        rng: &mut R,
    ) -> Result<(Self, FitReport)> {
        validate_data(inputs, targets)?;
        options.initial.validate()?;
        options.bounds.validate()?;
        options.conditioning.validate()?;
        if options.max_points == 0 {
            return Err(Error::InvalidParameter {
                parameter: "max_points",
            });
        }
        let skip = inputs.len().saturating_sub(options.max_points);
        let (inputs, targets) = (&inputs[skip..], &targets[skip..]);
        let (lower, upper) = options.bounds.log_bounds();
        let mut starts = vec![options.initial.to_log()];
        for _ in 0..options.restarts {
            starts.push(std::array::from_fn(|i| {
                lower[i] + awfqi::rng::uniform_f64(rng) * (upper[i] - lower[i])
            }));
        }
        // The comparison search first, on its own evaluator, dropped before the kept search
        // allocates its buffers (both are `3n²` f64).
        let comparison = match options.compare {
            Some(other) => {
                let clock = std::time::Instant::now();
                let mut other_eval =
                    LikelihoodEvaluator::new(inputs, targets, options.parallelism)?
                        .with_jitter(options.conditioning.jitter);
                let runs = search(other, (inputs, targets), &mut other_eval, &starts, options)?;
                let lml =
                    best_run(&runs).map_or(f64::NEG_INFINITY, |b| runs[b].log_marginal_likelihood);
                Some((
                    lml,
                    other_eval.factorizations,
                    clock.elapsed().as_secs_f64(),
                ))
            }
            None => None,
        };
        let clock = std::time::Instant::now();
        let mut eval = LikelihoodEvaluator::new(inputs, targets, options.parallelism)?
            .with_jitter(options.conditioning.jitter);
        let runs = search(
            options.strategy,
            (inputs, targets),
            &mut eval,
            &starts,
            options,
        )?;
        let best = best_run(&runs);
        let best = best.ok_or(Error::NotPositiveDefinite)?;
        let theta = runs[best].theta;
        let factorizations = eval.factorizations;
        let seconds = clock.elapsed().as_secs_f64();
        let lml = eval.value(&theta).ok_or(Error::NotPositiveDefinite)?;
        check_condition(&eval.chol, &options.conditioning)?;
        eval.finish_alpha();
        let comparison =
            comparison.map(
                |(other_lml, other_factorizations, other_seconds)| SearchComparison {
                    log_marginal_likelihood: runs[best].log_marginal_likelihood,
                    other_log_marginal_likelihood: other_lml,
                    factorizations,
                    other_factorizations,
                    seconds,
                    other_seconds,
                },
            );
        let gp = Self {
            inputs: inputs.to_vec(),
            hyper: GpHyperparameters::from_log(&theta),
            alpha: eval.alpha.col_as_slice(0).to_vec(),
            factor: eval.chol,
            lml,
            par: options.parallelism,
            jitter: options.conditioning.jitter,
        };
        Ok((
            gp,
            FitReport {
                runs,
                best,
                comparison,
            },
        ))
    }

    /// Number of training points.
    pub fn len(&self) -> usize {
        self.inputs.len()
    }

    /// `false`: a GP always has training points.
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// The hyperparameters in use.
    pub fn hyperparameters(&self) -> GpHyperparameters {
        self.hyper
    }

    /// The training inputs (after the `max_points` cap).
    pub fn inputs(&self) -> &[[f64; D]] {
        &self.inputs
    }

    /// The log marginal likelihood of the training data.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.lml
    }

    /// Prediction at one input (mean and std including the noise).
    pub fn predict(&self, z: &[f64; D]) -> GpPrediction {
        let mut means = [0.0];
        let mut stds = [0.0];
        self.predict_into(std::slice::from_ref(z), &mut means, &mut stds)
            .expect("lengths match");
        GpPrediction {
            mean: means[0],
            std: stds[0],
        }
    }

    /// Predictions at many inputs into `means` and `stds` (blocked: one triangular solve
    /// per block of 256 inputs).
    ///
    /// Errors: output lengths differ from `zs.len()` ([`Error::InvalidParameter`]).
    pub fn predict_into(&self, zs: &[[f64; D]], means: &mut [f64], stds: &mut [f64]) -> Result<()> {
        if means.len() != zs.len() {
            return Err(Error::InvalidParameter { parameter: "means" });
        }
        if stds.len() != zs.len() {
            return Err(Error::InvalidParameter { parameter: "stds" });
        }
        const BLOCK: usize = 256;
        let n = self.inputs.len();
        let c = self.hyper.signal_variance;
        let k = -0.5 / (self.hyper.length_scale * self.hyper.length_scale);
        let prior = c + self.hyper.noise_variance;
        let mut cross = Mat::<f64>::zeros(n, BLOCK.min(zs.len()));
        for ((block, mb), sb) in zs
            .chunks(BLOCK)
            .zip(means.chunks_mut(BLOCK))
            .zip(stds.chunks_mut(BLOCK))
        {
            let m = block.len();
            cross.truncate(n, m);
            for (q, z) in block.iter().enumerate() {
                let col = cross.col_as_slice_mut(q);
                for (v, x) in col.iter_mut().zip(&self.inputs) {
                    *v = c * (k * squared_distance(x, z)).exp();
                }
                mb[q] = col.iter().zip(&self.alpha).map(|(a, b)| a * b).sum();
            }
            faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                self.factor.as_ref(),
                cross.as_mut(),
                self.par,
            );
            for (q, s) in sb.iter_mut().enumerate() {
                let v: f64 = cross.col_as_slice(q).iter().map(|x| x * x).sum();
                *s = (prior - v).max(0.0).sqrt();
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
