//! The fixed-capacity Gaussian-process regressor [`Gp`].

use super::cholesky;
use super::conditioning::{self, BASE_JITTER, Conditioning};
use super::covariance::{self, Hyperparameters};
use super::search::{self, HyperparameterBounds, LogBox, SearchOptions};
use crate::error::{Error, Result};
use crate::float::Real;
use rand_core::Rng;

/// How many times the jitter is escalated after a failed factorisation.
///
/// Escalation `k` (1 ≤ k ≤ 4) adds `max(10⁻¹⁰, c·ε) · 10ᵏ` instead of the base jitter, where
/// `c` is the signal variance and `ε` the machine epsilon of `T`. Cholesky's backward error
/// is of order `n·ε·c`, so the steps start just above rounding level and end at
/// `≈ 1.2·10⁻³·c` in `f32` and `10⁻⁶` (for `c ≤ 4.5·10⁵`) in `f64`. When the last one fails
/// too, the operation returns [`Error::NotPositiveDefinite`]. Escalations beyond the GP's
/// [`Conditioning`] limit are tried only to name the jitter that would have been needed
/// ([`Error::JitterLimit`]).
pub const JITTER_ESCALATIONS: usize = 4;

/// `ln 2π`.
const LN_2PI: f64 = 1.837_877_066_409_345_3;

/// What a hyperparameter search reached: the log marginal likelihood and whether the
/// likelihood's optimum was refused by the conditioning policy (the GP then holds the best
/// evaluated point the policy trusts: an honest fit, not the best one).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Searched<T> {
    pub(crate) lml: T,
    pub(crate) refused: bool,
}

/// The jitter of escalation `level` (0 = the policy's base jitter) for signal variance `c`.
fn jitter_at<T: Real>(level: usize, c: T, policy: &Conditioning<T>) -> T {
    if level == 0 {
        return policy.base_jitter();
    }
    let mut jitter = T::from_f64(BASE_JITTER).max(c * T::EPSILON);
    for _ in 0..level {
        jitter *= T::from_f64(10.0);
    }
    jitter
}

/// Where the first factorisation attempt starts (later attempts always start from row 0).
#[derive(Clone, Copy)]
struct Start {
    /// Jitter level of the first attempt.
    level: usize,
    /// First row of the factor to compute in the first attempt (earlier rows are kept).
    row: usize,
    /// First entry of `z = L⁻¹y` to compute in the first attempt.
    solve: usize,
}

/// What one factorisation attempt gave.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Attempt {
    /// The factor and `z = L⁻¹y` are finite.
    Solved,
    /// The kernel matrix did not factorise with this jitter.
    Breakdown,
    /// The factor is finite but `z = L⁻¹y` is not: the targets are too large for `T`.
    Overflow,
}

impl Attempt {
    fn solved(self) -> bool {
        self == Attempt::Solved
    }
}

/// One attempt: writes the kernel rows `start.row..n`, factorises them and solves for
/// `z[start.solve..n]`, with the given jitter.
#[allow(clippy::too_many_arguments)]
fn attempt<T: Real, const D: usize>(
    hyper: &Hyperparameters<T, D>,
    xs: &[[T; D]],
    ys: &[T],
    factor: &mut [T],
    stride: usize,
    z: &mut [T],
    jitter: T,
    row: usize,
    solve: usize,
) -> Attempt {
    let n = xs.len();
    if !jitter.is_finite() || ys.len() != n {
        return Attempt::Breakdown;
    }
    if !(covariance::fill_rows(hyper, xs, jitter, factor, stride, row, n)
        && cholesky::factor_rows(factor, stride, row, n))
    {
        return Attempt::Breakdown;
    }
    let (Some(src), Some(dst)) = (ys.get(solve..n), z.get_mut(solve..n)) else {
        return Attempt::Breakdown;
    };
    // Element-wise: the lengths are equal, but `copy_from_slice` keeps a length-mismatch
    // panic path where the optimiser cannot prove it.
    for (d, &s) in dst.iter_mut().zip(src) {
        *d = s;
    }
    if cholesky::forward_solve(factor, stride, solve, n, z) {
        Attempt::Solved
    } else {
        Attempt::Overflow
    }
}

/// Factorises `K(xs) + (σ²ₙ + jitter) I` into `factor` and solves `z = L⁻¹ ys`, escalating
/// the jitter after a failure (every later attempt recomputes all rows) as far as `policy`
/// allows, and refusing a factor whose condition estimate exceeds the policy's limit. Returns
/// the jitter level used.
///
/// Errors: [`Error::JitterLimit`] when only a jitter beyond the policy's limit factorises
/// (the ladder is climbed on to name it), [`Error::IllConditioned`] when every allowed factor
/// was beyond the condition limit, [`Error::Overflow`] naming `y` when the matrix factorised
/// but `L⁻¹y` overflowed at every jitter (the targets are too large for `T`; the kernel
/// matrix does not depend on them), [`Error::NotPositiveDefinite`] otherwise.
#[allow(clippy::too_many_arguments)]
fn factorize<T: Real, const D: usize>(
    hyper: &Hyperparameters<T, D>,
    policy: &Conditioning<T>,
    xs: &[[T; D]],
    ys: &[T],
    factor: &mut [T],
    stride: usize,
    z: &mut [T],
    start: Start,
) -> Result<usize> {
    let c = hyper.signal_variance;
    let allowed = policy.allowed_jitter(hyper.noise_variance);
    let limit = policy.max_condition();
    let n = xs.len();
    let mut ill_conditioned: Option<T> = None;
    let mut overflow = false;
    let breakdown = |overflow: bool| {
        if overflow {
            Error::Overflow { parameter: "y" }
        } else {
            Error::NotPositiveDefinite
        }
    };
    for level in start.level..=JITTER_ESCALATIONS {
        let jitter = jitter_at(level, c, policy);
        let (row, solve) = if level == start.level {
            (start.row, start.solve)
        } else {
            (0, 0)
        };
        if level > 0 && (jitter.is_nan() || jitter > allowed) {
            // Beyond the policy: find the jitter that would have worked, to name it.
            let needed = (level..=JITTER_ESCALATIONS).find_map(|l| {
                let j = jitter_at(l, c, policy);
                let (row, solve) = if l == start.level {
                    (row, solve)
                } else {
                    (0, 0)
                };
                let outcome = attempt(hyper, xs, ys, factor, stride, z, j, row, solve);
                overflow |= outcome == Attempt::Overflow;
                (outcome.solved() && conditioning::diagonal_condition(factor, stride, n) <= limit)
                    .then_some(j)
            });
            return Err(match (needed, ill_conditioned) {
                (Some(needed), _) => Error::JitterLimit {
                    needed: crate::error::Number(needed.to_f64()),
                    allowed: crate::error::Number(allowed.to_f64()),
                },
                (None, Some(condition)) => ill(condition, limit),
                (None, None) => breakdown(overflow),
            });
        }
        match attempt(hyper, xs, ys, factor, stride, z, jitter, row, solve) {
            Attempt::Solved => {
                let condition = conditioning::diagonal_condition(factor, stride, n);
                if condition <= limit {
                    return Ok(level);
                }
                ill_conditioned = Some(condition);
            }
            Attempt::Overflow => overflow = true,
            Attempt::Breakdown => {}
        }
    }
    Err(match ill_conditioned {
        Some(condition) => ill(condition, limit),
        None => breakdown(overflow),
    })
}

fn ill<T: Real>(condition: T, limit: T) -> Error {
    Error::IllConditioned {
        condition: crate::error::Number(condition.to_f64()),
        limit: crate::error::Number(limit.to_f64()),
    }
}

/// `−½ zᵀz − Σ ln L_ii − (n/2) ln 2π` for the first `n` points.
fn log_marginal_likelihood<T: Real>(factor: &[T], stride: usize, z: &[T], n: usize) -> T {
    let z = z.get(..n).unwrap_or(&[]);
    let half = T::from_f64(0.5);
    -half * cholesky::dot(z, z)
        - cholesky::half_log_det(factor, stride, n)
        - half * T::from_usize(n) * T::from_f64(LN_2PI)
}

/// What [`Gp::add_point`] does when the GP already holds `N` points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WhenFull {
    /// Return [`Error::CapacityExceeded`] and keep the GP as it is.
    Refuse,
    /// Forget the oldest point, then add the new one (a sliding window of the last `N`).
    DropOldest,
}

/// A prediction at one input.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Prediction<T> {
    /// Posterior mean `k*ᵀ K⁻¹ y`.
    pub mean: T,
    /// Variance of the latent function, `c − k*ᵀ K⁻¹ k*`, clipped at 0.
    pub latent_variance: T,
    /// Variance of a new observation: `latent_variance + σ²ₙ` (spec §4.2's predicted
    /// variance, which includes the noise).
    pub noisy_variance: T,
}

/// Gaussian-process regression with room for `N` points of dimension `D`, allocation-free.
///
/// ARD squared-exponential kernel `c·exp(−½ Σ_d ((x_d − x′_d)/ℓ_d)²)`, noise variance `σ²ₙ`
/// on the training diagonal only, zero prior mean, targets used as given (not centred).
/// The lower Cholesky factor `L` of `K + (σ²ₙ + jitter) I` and `z = L⁻¹y` are kept, so a
/// prediction costs O(n·D + n²) and the log marginal likelihood O(n).
///
/// **Memory** (all inline, no heap):
/// `size_of::<T>() · (N² + N·(D + 2) + D + 4) + 2 · size_of::<usize>() + 2`, rounded up to the
/// alignment; see the table in the [module docs](super). [`Gp::predict`] also uses
/// `N · size_of::<T>()` bytes of stack. For large `N` avoid moving a `Gp` through the stack
/// of a microcontroller: build it in place in a `static` with [`Gp::empty`] and fill it with
/// [`Gp::set_hyperparameters`] and [`Gp::fit`].
///
/// **State guarantee:** a method that returns an error leaves the data and hyperparameters
/// as they were. When a factorisation failed after the old factor had been overwritten, the
/// old one is recomputed from the kept data, which gives the same factor (to rounding, when
/// it came from [`WhenFull::DropOldest`]'s update). Should even that fail, the GP is
/// emptied ([`Gp::clear`]) rather than left inconsistent.
#[derive(Debug, Clone)]
pub struct Gp<T, const N: usize, const D: usize> {
    hyper: Hyperparameters<T, D>,
    inputs: [[T; D]; N],
    targets: [T; N],
    /// Row-major; the leading `len × len` lower triangle is `L`.
    factor: [[T; N]; N],
    /// `z = L⁻¹ y` (so `K⁻¹y = L⁻ᵀ z`, the mean weights, is never needed explicitly).
    whitened: [T; N],
    len: usize,
    jitter_level: usize,
    conditioning: Conditioning<T>,
}

impl<T: Real, const N: usize, const D: usize> Default for Gp<T, N, D> {
    /// [`Gp::empty`].
    fn default() -> Self {
        Self::empty()
    }
}

impl<T: Real, const N: usize, const D: usize> Gp<T, N, D> {
    /// The number of points the GP can hold.
    pub const CAPACITY: usize = N;

    /// An empty GP with spec §4.2's initial hyperparameters (`c = ℓ = σ²ₙ = 1`).
    ///
    /// `const`, so a GP can be placed in a `static` without passing through the stack.
    pub const fn empty() -> Self {
        Self::with(Hyperparameters::SPEC_INITIAL)
    }

    /// An empty GP whose every bit is zero, hyperparameters included, so storage holding
    /// it can be a zero-initialised `static` (`.bss`); it must get hyperparameters
    /// ([`Gp::set_hyperparameters`]) before use; the learners set them when they are built.
    pub const fn zeroed() -> Self {
        Self::with(Hyperparameters::isotropic(T::ZERO, T::ZERO, T::ZERO))
    }

    const fn with(hyper: Hyperparameters<T, D>) -> Self {
        Self {
            hyper,
            inputs: [[T::ZERO; D]; N],
            targets: [T::ZERO; N],
            factor: [[T::ZERO; N]; N],
            whitened: [T::ZERO; N],
            len: 0,
            jitter_level: 0,
            conditioning: Conditioning::DEFAULT,
        }
    }

    /// An empty GP with the given hyperparameters.
    ///
    /// Errors: those of [`Hyperparameters::validate`].
    pub fn new(hyper: Hyperparameters<T, D>) -> Result<Self> {
        hyper.validate()?;
        Ok(Self::with(hyper))
    }

    /// Number of points held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` when the GP holds no points.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The current hyperparameters.
    pub fn hyperparameters(&self) -> &Hyperparameters<T, D> {
        &self.hyper
    }

    /// The jitter added to the training diagonal by the current factor: [`BASE_JITTER`]
    /// unless the factorisation had to escalate (see [`JITTER_ESCALATIONS`]).
    pub fn jitter(&self) -> T {
        jitter_at(
            self.jitter_level,
            self.hyper.signal_variance,
            &self.conditioning,
        )
    }

    /// The conditioning policy (see [`Conditioning`]).
    pub fn conditioning(&self) -> &Conditioning<T> {
        &self.conditioning
    }

    /// Sets the conditioning policy and refactorises the data held (O(n³/6)).
    ///
    /// Errors: those of the factorisation ([`Error::JitterLimit`],
    /// [`Error::IllConditioned`], [`Error::Overflow`] naming `y`,
    /// [`Error::NotPositiveDefinite`]); on error the previous policy is kept.
    pub fn set_conditioning(&mut self, conditioning: Conditioning<T>) -> Result<()> {
        let previous = self.conditioning;
        self.conditioning = conditioning;
        self.refactorize_or_roll_back(|gp| gp.conditioning = previous)
    }

    /// The diagonal condition estimate `(max Lᵢᵢ / min Lᵢᵢ)²` of the current factor, a lower
    /// bound on the spectral condition number of `K + (σ²ₙ + jitter) I` (1 without data). A
    /// factor is kept only while it is at most [`Conditioning::max_condition`]. O(n).
    pub fn condition_estimate(&self) -> T {
        conditioning::diagonal_condition(self.factor.as_flattened(), N, self.len)
    }

    /// The inputs held, oldest first.
    pub fn inputs(&self) -> &[[T; D]] {
        self.inputs.get(..self.len).unwrap_or(&[])
    }

    /// The targets held, oldest first.
    pub fn targets(&self) -> &[T] {
        self.targets.get(..self.len).unwrap_or(&[])
    }

    /// Forgets every point (the hyperparameters stay).
    pub fn clear(&mut self) {
        self.len = 0;
        self.jitter_level = 0;
    }

    /// Factorises the first `n` stored points from `start`; the factor and `z` change, the
    /// data, `len` and jitter level do not.
    fn factorize_stored(&mut self, n: usize, start: Start) -> Result<usize> {
        let (Some(xs), Some(ys)) = (self.inputs.get(..n), self.targets.get(..n)) else {
            return Err(Error::CapacityExceeded { capacity: N });
        };
        factorize(
            &self.hyper,
            &self.conditioning,
            xs,
            ys,
            self.factor.as_flattened_mut(),
            N,
            &mut self.whitened,
            start,
        )
    }

    /// Refactorises the data held after a setting changed; on error `roll_back` puts the
    /// previous setting back and the previous factor is restored.
    fn refactorize_or_roll_back(&mut self, roll_back: impl FnOnce(&mut Self)) -> Result<()> {
        let fresh = Start {
            level: 0,
            row: 0,
            solve: 0,
        };
        match self.factorize_stored(self.len, fresh) {
            Ok(level) => {
                self.jitter_level = level;
                Ok(())
            }
            Err(e) => {
                roll_back(self);
                self.restore();
                Err(e)
            }
        }
    }

    /// Recomputes the factor of the stored data after a failed operation; empties the GP if
    /// even that fails.
    fn restore(&mut self) {
        let fresh = Start {
            level: 0,
            row: 0,
            solve: 0,
        };
        match self.factorize_stored(self.len, fresh) {
            Ok(level) => self.jitter_level = level,
            Err(_) => self.clear(),
        }
    }

    /// Replaces the data by `x`, `y` and factorises (O(n³/6) multiply-adds and n²/2 kernel
    /// evaluations).
    ///
    /// Errors: `x` and `y` of different lengths ([`Error::InvalidParameter`] naming `y`),
    /// no points ([`Error::EmptyData`]), more than `N` ([`Error::CapacityExceeded`]), a
    /// non-finite value ([`Error::NonFinite`] naming `x` or `y`), targets too large for
    /// `T` ([`Error::Overflow`] naming `y`: `L⁻¹y` overflows), and
    /// [`Error::NotPositiveDefinite`]. On error the GP keeps its previous data.
    pub fn fit(&mut self, x: &[[T; D]], y: &[T]) -> Result<()> {
        if x.len() != y.len() {
            return Err(Error::InvalidParameter { parameter: "y" });
        }
        if x.is_empty() {
            return Err(Error::EmptyData);
        }
        if x.len() > N {
            return Err(Error::CapacityExceeded { capacity: N });
        }
        if !x.iter().all(|p| p.iter().all(|v| v.is_finite())) {
            return Err(Error::NonFinite { parameter: "x" });
        }
        crate::error::ensure_all_finite(y, "y")?;
        let fresh = Start {
            level: 0,
            row: 0,
            solve: 0,
        };
        let result = factorize(
            &self.hyper,
            &self.conditioning,
            x,
            y,
            self.factor.as_flattened_mut(),
            N,
            &mut self.whitened,
            fresh,
        );
        match result {
            Ok(level) => {
                let (Some(xs), Some(ys)) = (
                    self.inputs.get_mut(..x.len()),
                    self.targets.get_mut(..y.len()),
                ) else {
                    return Err(Error::CapacityExceeded { capacity: N });
                };
                // Element-wise, as in `attempt`: no length-mismatch panic path.
                for (d, s) in xs.iter_mut().zip(x) {
                    *d = *s;
                }
                for (d, &s) in ys.iter_mut().zip(y) {
                    *d = s;
                }
                self.len = x.len();
                self.jitter_level = level;
                Ok(())
            }
            Err(e) => {
                self.restore();
                Err(e)
            }
        }
    }

    /// Sets the hyperparameters and refactorises the data held (O(n³/6)).
    ///
    /// Errors: those of [`Hyperparameters::validate`] and of the factorisation
    /// ([`Error::JitterLimit`], [`Error::IllConditioned`], [`Error::Overflow`] naming `y`,
    /// [`Error::NotPositiveDefinite`]); on error the previous hyperparameters are kept.
    pub fn set_hyperparameters(&mut self, hyper: Hyperparameters<T, D>) -> Result<()> {
        hyper.validate()?;
        let previous = self.hyper;
        self.hyper = hyper;
        self.refactorize_or_roll_back(|gp| gp.hyper = previous)
    }

    /// Adds one observation.
    ///
    /// Below capacity the factor is extended by one row: O(n·D + n²) work, the same bits a
    /// refit would give. At capacity, [`WhenFull::Refuse`] returns
    /// [`Error::CapacityExceeded`], and [`WhenFull::DropOldest`] forgets the oldest point by
    /// a stable rank-one update of the factor and then extends it, O(n·D + n²) in all (the
    /// result agrees with a refit to rounding). Two cases fall back to a full refactorisation,
    /// O(n³/6): when the extension fails and the jitter must be escalated, and when dropping
    /// a point while the jitter is escalated (so a refit may return to the base jitter).
    ///
    /// Errors: [`Error::NonFinite`] naming `x` or `y`, [`Error::CapacityExceeded`],
    /// [`Error::Overflow`] naming `y` and [`Error::NotPositiveDefinite`]; on error the GP
    /// keeps its previous data.
    pub fn add_point(&mut self, x: [T; D], y: T, when_full: WhenFull) -> Result<()> {
        if !x.iter().all(|v| v.is_finite()) {
            return Err(Error::NonFinite { parameter: "x" });
        }
        crate::error::ensure_finite(y, "y")?;
        let n = self.len;
        if n < N {
            let (Some(xs), Some(ys)) = (self.inputs.get_mut(n), self.targets.get_mut(n)) else {
                return Err(Error::CapacityExceeded { capacity: N });
            };
            (*xs, *ys) = (x, y);
            let extend = Start {
                level: self.jitter_level,
                row: n,
                solve: n,
            };
            return match self.factorize_stored(n + 1, extend) {
                Ok(level) => {
                    self.len = n + 1;
                    self.jitter_level = level;
                    Ok(())
                }
                Err(e) => {
                    self.restore();
                    Err(e)
                }
            };
        }
        match when_full {
            WhenFull::Refuse => Err(Error::CapacityExceeded { capacity: N }),
            WhenFull::DropOldest => self.replace_oldest(x, y),
        }
    }

    /// The full-capacity path of [`WhenFull::DropOldest`].
    fn replace_oldest(&mut self, x: [T; D], y: T) -> Result<()> {
        let (Some(&oldest_x), Some(&oldest_y)) = (self.inputs.first(), self.targets.first()) else {
            return Err(Error::CapacityExceeded { capacity: N });
        };
        self.inputs.rotate_left(1);
        self.targets.rotate_left(1);
        if let (Some(xs), Some(ys)) = (self.inputs.last_mut(), self.targets.last_mut()) {
            (*xs, *ys) = (x, y);
        }
        let updated = self.jitter_level == 0
            && cholesky::drop_first(self.factor.as_flattened_mut(), N, N, &mut self.whitened)
            && attempt(
                &self.hyper,
                &self.inputs,
                &self.targets,
                self.factor.as_flattened_mut(),
                N,
                &mut self.whitened,
                self.conditioning.base_jitter(),
                N - 1,
                0,
            )
            .solved()
            && self.condition_estimate() <= self.conditioning.max_condition();
        if updated {
            self.jitter_level = 0;
            return Ok(());
        }
        let fresh = Start {
            level: 0,
            row: 0,
            solve: 0,
        };
        match self.factorize_stored(N, fresh) {
            Ok(level) => {
                self.jitter_level = level;
                Ok(())
            }
            Err(e) => {
                self.inputs.rotate_right(1);
                self.targets.rotate_right(1);
                if let (Some(xs), Some(ys)) = (self.inputs.first_mut(), self.targets.first_mut()) {
                    (*xs, *ys) = (oldest_x, oldest_y);
                }
                self.restore();
                Err(e)
            }
        }
    }

    /// Predicts at `x`: posterior mean, latent variance and noisy variance; with no data,
    /// the prior (`0`, `c`, `c + σ²ₙ`). O(n·D + n²) work and `N · size_of::<T>()` bytes of
    /// stack.
    ///
    /// Errors: [`Error::NonFinite`] naming `x`; [`Error::NotPositiveDefinite`] when the
    /// stored factor is too ill-conditioned to give a finite prediction in this precision
    /// (possible only with data near the overflow limit of `T`); [`Error::Overflow`] naming
    /// `y` when the mean overflows `T` (targets too large for the precision).
    pub fn predict(&self, x: &[T; D]) -> Result<Prediction<T>> {
        if !x.iter().all(|v| v.is_finite()) {
            return Err(Error::NonFinite { parameter: "x" });
        }
        let n = self.len;
        let c = self.hyper.signal_variance;
        let mut v = [T::ZERO; N];
        for (vi, xi) in v.iter_mut().zip(self.inputs()) {
            *vi = self.hyper.covariance(x, xi);
        }
        if !cholesky::forward_solve(self.factor.as_flattened(), N, 0, n, &mut v) {
            return Err(Error::NotPositiveDefinite);
        }
        let (Some(v), Some(z)) = (v.get(..n), self.whitened.get(..n)) else {
            return Err(Error::CapacityExceeded { capacity: N });
        };
        let mean = cholesky::dot(v, z);
        let explained = cholesky::dot(v, v);
        if !explained.is_finite() {
            return Err(Error::NotPositiveDefinite);
        }
        if !mean.is_finite() {
            return Err(Error::Overflow { parameter: "y" });
        }
        let latent_variance = (c - explained).max(T::ZERO);
        Ok(Prediction {
            mean,
            latent_variance,
            noisy_variance: latent_variance + self.hyper.noise_variance,
        })
    }

    /// The mean weights `α = K⁻¹y` of the data held into `out[..len]` (`K` with noise and
    /// jitter), so that the posterior mean is `Σᵢ k(x, xᵢ) αᵢ`: all a copy of the GP that
    /// only predicts means needs besides its inputs and hyperparameters
    /// (`crate::adaptive::MeanFunction`). Returns `len`; O(n²).
    ///
    /// Errors: `out` shorter than the points held ([`Error::CapacityExceeded`] with its
    /// length); [`Error::NotPositiveDefinite`] when the back substitution is not finite.
    pub fn mean_weights(&self, out: &mut [T]) -> Result<usize> {
        let n = self.len;
        let capacity = out.len();
        let (Some(alpha), Some(z)) = (out.get_mut(..n), self.whitened.get(..n)) else {
            return Err(Error::CapacityExceeded { capacity });
        };
        alpha.copy_from_slice(z);
        if cholesky::backward_solve(self.factor.as_flattened(), N, n, alpha) {
            Ok(n)
        } else {
            Err(Error::NotPositiveDefinite)
        }
    }

    /// The log marginal likelihood `−½ yᵀK⁻¹y − Σ ln L_ii − (n/2) ln 2π` of the data held,
    /// with `K` including noise and jitter; O(n).
    ///
    /// Errors: [`Error::EmptyData`] when the GP holds no points; [`Error::Overflow`] naming
    /// `y` when `yᵀK⁻¹y` overflows `T` (targets too large for the precision).
    pub fn log_marginal_likelihood(&self) -> Result<T> {
        if self.len == 0 {
            return Err(Error::EmptyData);
        }
        let lml = log_marginal_likelihood(self.factor.as_flattened(), N, &self.whitened, self.len);
        if lml.is_finite() {
            Ok(lml)
        } else {
            Err(Error::Overflow { parameter: "y" })
        }
    }

    /// Searches the box `bounds` for the hyperparameters that maximise the log marginal
    /// likelihood (spec §4.2; see [`SearchOptions`](super::SearchOptions) for the method), leaves the GP
    /// fitted with the best ones and returns their log marginal likelihood.
    ///
    /// Cost: `options.max_evaluations + 1` factorisations of O(n³/6) and no allocation; the
    /// search's own arrays (a simplex of at most 9 points and the box) take under 1 KiB of
    /// stack in `f64`. Each evaluation factorises in place, so the factor is rebuilt at the
    /// end. Failed factorisations count as `−∞`. The evaluations may use the whole jitter
    /// ladder (the search explores, and its path does not depend on the policy); the optimum
    /// is then held to the GP's [`Conditioning`]. An escalated jitter turns the model into
    /// one with more noise, so the likelihood of such a point rates that other model, not the
    /// hyperparameters found (in `f32` a long-length-scale, large-signal corner can look best
    /// this way while its exact likelihood is far worse). When the optimum is beyond the
    /// policy, the GP therefore takes the best evaluated point whose factor the policy
    /// trusts (no jitter beyond its bound, condition within its limit); only when there is
    /// none does the search fail. The generator is used only for the restarts: one `u64` per
    /// searched parameter per restart.
    ///
    /// Errors: those of [`HyperparameterBounds::validate`] and [`SearchOptions::validate`];
    /// [`Error::CapacityExceeded`] for an ARD search (`isotropic == false`) with
    /// `D + 2 >` [`MAX_SEARCH_PARAMETERS`](super::MAX_SEARCH_PARAMETERS);
    /// [`Error::EmptyData`] without data; [`Error::NotPositiveDefinite`] when no evaluated
    /// point could be factorised; [`Error::JitterLimit`] or [`Error::IllConditioned`] when
    /// the optimum is beyond the conditioning policy and no evaluated point is within it.
    /// On error the previous hyperparameters are kept.
    pub fn optimize_hyperparameters<R: Rng + ?Sized>(
        &mut self,
        bounds: &HyperparameterBounds<T, D>,
        options: &SearchOptions,
        rng: &mut R,
    ) -> Result<T> {
        self.search(bounds, options, rng).map(|s| s.lml)
    }

    /// [`Gp::optimize_hyperparameters`], also saying whether the optimum was refused by the
    /// conditioning policy (and the best trusted point kept instead).
    pub(crate) fn search<R: Rng + ?Sized>(
        &mut self,
        bounds: &HyperparameterBounds<T, D>,
        options: &SearchOptions,
        rng: &mut R,
    ) -> Result<Searched<T>> {
        options.validate()?;
        let space = LogBox::new(bounds, options.isotropic)?;
        let n = self.len;
        if n == 0 {
            return Err(Error::EmptyData);
        }
        let previous = self.hyper;
        let (Some(xs), Some(ys)) = (self.inputs.get(..n), self.targets.get(..n)) else {
            return Err(Error::CapacityExceeded { capacity: N });
        };
        let factor = self.factor.as_flattened_mut();
        let whitened = &mut self.whitened;
        // The evaluations climb the whole jitter ladder (the search explores; its path does
        // not depend on the policy), the optimum is held to the policy below.
        let explore = if self.conditioning.base_jitter() == T::ZERO {
            Conditioning::UNBOUNDED.without_base_jitter()
        } else {
            Conditioning::UNBOUNDED
        };
        let policy = &explore;
        let fresh = Start {
            level: 0,
            row: 0,
            solve: 0,
        };
        // The best evaluated point whose factor the GP's own policy trusts (jitter within its
        // bound, condition estimate within its limit): the fallback when the optimum is not.
        let strict = self.conditioning;
        let limit = strict.max_condition();
        let mut trusted: Option<(search::Theta<T>, T)> = None;
        let mut objective = |theta: &search::Theta<T>| -> T {
            let hyper = space.hyperparameters::<D>(theta);
            let Ok(level) = factorize(&hyper, policy, xs, ys, factor, N, whitened, fresh) else {
                return T::NEG_INFINITY;
            };
            let lml = log_marginal_likelihood(factor, N, whitened, n);
            let jitter_ok = level == 0
                || jitter_at(level, hyper.signal_variance, policy)
                    <= strict.allowed_jitter(hyper.noise_variance);
            // Only a finite likelihood is a fallback: the first trusted point may rate −∞
            // (in f32 a data fit that overflows), and a success must return a number.
            if jitter_ok
                && lml.is_finite()
                && conditioning::diagonal_condition(factor, N, n) <= limit
                && trusted.is_none_or(|(_, best)| lml > best)
            {
                trusted = Some((*theta, lml));
            }
            lml
        };
        let (best, value) = search::maximize(&space, options, rng, &mut objective);
        if value.is_finite() {
            // On error `set_hyperparameters` keeps (and refactorises) the previous ones.
            let refused = match self.set_hyperparameters(space.hyperparameters::<D>(&best)) {
                Ok(()) => {
                    return self.log_marginal_likelihood().map(|lml| Searched {
                        lml,
                        refused: false,
                    });
                }
                Err(e) => e,
            };
            // The fallback needs the data: when even the previous hyperparameters could not
            // be refactorised, the roll-back cleared it (the documented last resort), and
            // setting other hyperparameters on the empty GP would change them on an error.
            return match (refused, trusted) {
                (Error::JitterLimit { .. } | Error::IllConditioned { .. }, Some((theta, _)))
                    if self.len == n =>
                {
                    self.set_hyperparameters(space.hyperparameters::<D>(&theta))?;
                    self.log_marginal_likelihood()
                        .map(|lml| Searched { lml, refused: true })
                }
                (e, _) => Err(e),
            };
        }
        self.hyper = previous;
        self.restore();
        Err(Error::NotPositiveDefinite)
    }
}
