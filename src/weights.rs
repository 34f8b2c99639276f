//! Importance weights of source samples (spec §7.3, §7.7) and their effective sample size.
//!
//! A source sample `(z, y)` (a reward, or one next-state coordinate) is worth
//! `p_target(y | z) / p_source(y | z)` target samples. Neither density is known: both are
//! Gaussians `𝒩(y; f(z), v)` whose mean functions `f` carry GP posteriors. The two
//! estimators of §7.3 turn the posteriors `(μ_t, σ_t)` and `(μ_s, σ_s)` into one weight:
//!
//! - [`Estimator::Mean`], the expected ratio `E[𝒩(y; f_t, v)] · E[1/𝒩(y; f_s, v)]`:
//!   `𝒩(y; μ_t, v+σ_t²) / 𝒩(y; μ_s, v−σ_s²) · v/(v−σ_s²)` when `v > σ_s²`, else 0;
//! - [`Estimator::Heuristic`]: `𝒩(y; μ_t, v+σ_t²) / 𝒩(y; μ_s, v+σ_s²)`;
//!
//! both capped at `w_max`. They are computed as a difference of log-densities and
//! exponentiated once, so a ratio of two underflowing densities is still exact; a NaN that
//! arises anyway (from an overflowing square) is mapped to 0, as the spec prescribes.
//!
//! The GP predictive standard deviations that feed the estimators go through
//! [`predictive_stds`], which applies the reference's noise-subtraction rule (§4.2) or the
//! principled alternative of §14.7. [`ideal_weight`] is the oracle weight of §7.7 and
//! [`WeightSummary`] gives the diagnostics `w_mean` and `w_eff` of §7.2.

use crate::error::{Error, Result};
use crate::error::{ensure_all_finite, ensure_finite};
use crate::float::Real;

/// Which estimator of §7.3 turns two GP posteriors into a weight.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Estimator {
    /// The expected density ratio; discards (weight 0) a sample whose source posterior
    /// variance reaches the noise variance. The reference experiments' default.
    Mean,
    /// The ratio of the two posterior predictive densities.
    Heuristic,
}

/// A Gaussian posterior of a mean function at one input: its mean and its standard
/// deviation (not variance).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Posterior<T> {
    /// Posterior mean μ.
    pub mean: T,
    /// Posterior standard deviation σ ≥ 0.
    pub std: T,
}

impl<T: Real> Posterior<T> {
    /// Mean 0, std 0; `const` and all-zero, so a buffer of posteriors can be a `static` in
    /// `.bss`: `static mut POSTERIORS: [Posterior<f32>; 600] = [Posterior::EMPTY; 600];`.
    pub const EMPTY: Self = Self {
        mean: T::ZERO,
        std: T::ZERO,
    };

    /// A posterior with the given mean and standard deviation (checked when used).
    pub fn new(mean: T, std: T) -> Self {
        Self { mean, std }
    }

    fn validate(&self) -> Result<()> {
        ensure_finite(self.mean, "posterior.mean")?;
        ensure_finite(self.std, "posterior.std")?;
        if self.std < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "posterior.std",
            });
        }
        Ok(())
    }
}

/// Validated parameters of the weight estimators: the estimator, the noise variance `v`
/// it assumes and the cap `w_max`.
///
/// The published runs use `v = 0.1` for rewards and `0.2` for transitions although the true
/// noise variances are 0.01 and 0.04 (§14.6); pass whichever you mean to reproduce.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WeightParams<T> {
    estimator: Estimator,
    noise_variance: T,
    max_weight: T,
}

impl<T: Real> WeightParams<T> {
    /// Checks and stores the parameters.
    ///
    /// Errors: a non-finite or non-positive `noise_variance` or `max_weight`.
    pub fn new(estimator: Estimator, noise_variance: T, max_weight: T) -> Result<Self> {
        ensure_finite(noise_variance, "noise_variance")?;
        ensure_finite(max_weight, "max_weight")?;
        if noise_variance <= T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "noise_variance",
            });
        }
        if max_weight <= T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "max_weight",
            });
        }
        Ok(Self {
            estimator,
            noise_variance,
            max_weight,
        })
    }

    /// The reward configuration of the reference experiments (§7.6): mean estimator,
    /// `v = 0.1`, `w_max = 1000`.
    pub fn reference_reward() -> Self {
        Self {
            estimator: Estimator::Mean,
            noise_variance: T::from_f64(0.1),
            max_weight: T::from_f64(1000.0),
        }
    }

    /// The transition configuration of the reference experiments (§7.6): mean estimator,
    /// `v = 0.2`, `w_max = 1000` (the published `v_s`, §14.6).
    pub fn reference_transition() -> Self {
        Self {
            estimator: Estimator::Mean,
            noise_variance: T::from_f64(0.2),
            max_weight: T::from_f64(1000.0),
        }
    }

    /// The estimator.
    pub fn estimator(&self) -> Estimator {
        self.estimator
    }

    /// The noise variance `v` assumed by the estimator.
    pub fn noise_variance(&self) -> T {
        self.noise_variance
    }

    /// The cap `w_max`.
    pub fn max_weight(&self) -> T {
        self.max_weight
    }

    /// `true` when the estimator discards a record whose source posterior is `source`
    /// whatever its observation (weight 0 by the variance rule of §7.3: the mean
    /// estimator with `σ_s² ≥ v`). A share of such records is a sign that `v` is small for
    /// the sources' posterior uncertainty (see [`crate::thesis::Warning`]).
    pub fn discards(&self, source: Posterior<T>) -> bool {
        self.estimator == Estimator::Mean && self.noise_variance - source.std.squared() <= T::ZERO
    }

    /// The weight of one source observation `y` given the target and source posteriors
    /// of the mean function at the sample's input (§7.3).
    ///
    /// The result lies in `[0, w_max]`. Errors: a non-finite `y`, a non-finite posterior or
    /// a negative standard deviation.
    pub fn weight(&self, y: T, target: Posterior<T>, source: Posterior<T>) -> Result<T> {
        ensure_finite(y, "y")?;
        target.validate()?;
        source.validate()?;
        Ok(self.weight_unchecked(y, target, source))
    }

    /// [`WeightParams::weight`] for finite inputs (already validated).
    fn weight_unchecked(&self, y: T, target: Posterior<T>, source: Posterior<T>) -> T {
        let log_w = match log_weight(self.estimator, y, target, source, self.noise_variance) {
            Some(l) => l,
            None => return T::ZERO,
        };
        cap_exp(log_w, self.max_weight)
    }

    /// Fills `out[i]` with the weight of `ys[i]` under `targets[i]` and `sources[i]`.
    ///
    /// All inputs are checked before `out` is written. Errors: slices of different
    /// lengths ([`Error::InvalidParameter`] naming `out`), and the errors of
    /// [`WeightParams::weight`].
    pub fn weights_into(
        &self,
        ys: &[T],
        targets: &[Posterior<T>],
        sources: &[Posterior<T>],
        out: &mut [T],
    ) -> Result<()> {
        let n = out.len();
        if ys.len() != n || targets.len() != n || sources.len() != n {
            return Err(Error::InvalidParameter { parameter: "out" });
        }
        ensure_all_finite(ys, "y")?;
        for p in targets.iter().chain(sources.iter()) {
            p.validate()?;
        }
        for (((w, &y), &t), &s) in out.iter_mut().zip(ys).zip(targets).zip(sources) {
            *w = self.weight_unchecked(y, t, s);
        }
        Ok(())
    }
}

/// `exp(log_w)` capped at `cap`, with NaN mapped to 0 (§7.3 numerics).
fn cap_exp<T: Real>(log_w: T, cap: T) -> T {
    if log_w.is_nan() {
        T::ZERO
    } else if log_w >= cap.ln() {
        cap
    } else {
        let w = log_w.exp();
        if w.is_nan() { T::ZERO } else { w.min(cap) }
    }
}

/// `ln 𝒩(y; μ, var)` for `var > 0`.
fn log_normal_density<T: Real>(y: T, mean: T, variance: T) -> T {
    let two = T::from_f64(2.0);
    -(two * T::PI * variance).ln() / two - (y - mean).squared() / (two * variance)
}

/// The natural log of the uncapped weight, or `None` when the mean estimator discards the
/// sample (`v ≤ σ_s²`). May be NaN for extreme inputs (the caller maps it to weight 0).
fn log_weight<T: Real>(
    estimator: Estimator,
    y: T,
    target: Posterior<T>,
    source: Posterior<T>,
    v: T,
) -> Option<T> {
    let target_var = v + target.std.squared();
    let log_num = log_normal_density(y, target.mean, target_var);
    match estimator {
        Estimator::Heuristic => {
            let source_var = v + source.std.squared();
            Some(log_num - log_normal_density(y, source.mean, source_var))
        }
        Estimator::Mean => {
            let source_var = v - source.std.squared();
            if source_var > T::ZERO {
                Some(
                    log_num - log_normal_density(y, source.mean, source_var) + v.ln()
                        - source_var.ln(),
                )
            } else {
                None
            }
        }
    }
}

/// How GP predictive variances become the posterior standard deviations the estimators
/// use (§4.2 "noise subtraction", §14.7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NoiseSubtraction {
    /// The reference's rule, on standard deviations over a batch: with `σ̂_n = √σ_n²` and
    /// `m` the smallest predictive std of the batch, subtract `σ̂_n` from every std if
    /// `σ̂_n ≤ m`, else subtract `m` (so the smallest becomes exactly 0).
    Reference,
    /// The principled alternative: `√max(v − σ_n², 0)`, the latent function's std.
    Principled,
    /// No subtraction: the std of the noisy predictive distribution, `√max(v, 0)`.
    Off,
}

/// The map from one noisy GP predictive variance to a posterior standard deviation under a
/// [`NoiseSubtraction`] rule, fixed for a batch (§4.2, §7.2).
///
/// The reference rule depends on the batch only through its smallest variance, so a batch
/// can be processed in two streaming passes (find the smallest, then transform each) without
/// storing it. Size: two `T` and the mode.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StdTransform<T> {
    mode: NoiseSubtraction,
    noise_variance: T,
    shift: T,
}

impl<T: Real> StdTransform<T> {
    /// The transform for a batch whose smallest noisy predictive variance is
    /// `smallest_variance` (used by [`NoiseSubtraction::Reference`] only), for a GP of noise
    /// variance `noise_variance`.
    ///
    /// Errors: non-finite arguments, a negative `noise_variance`.
    pub fn new(mode: NoiseSubtraction, noise_variance: T, smallest_variance: T) -> Result<Self> {
        ensure_finite(noise_variance, "noise_variance")?;
        ensure_finite(smallest_variance, "variances")?;
        if noise_variance < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "noise_variance",
            });
        }
        let smallest_std = smallest_variance.max(T::ZERO).sqrt();
        let noise_std = noise_variance.sqrt();
        let shift = if noise_std <= smallest_std {
            noise_std
        } else {
            smallest_std
        };
        Ok(Self {
            mode,
            noise_variance,
            shift,
        })
    }

    /// The posterior std for one noisy predictive variance of the batch (negative variances
    /// from rounding count as 0; the result is never negative).
    pub fn apply(&self, variance: T) -> T {
        let v = variance.max(T::ZERO);
        match self.mode {
            NoiseSubtraction::Off => v.sqrt(),
            NoiseSubtraction::Principled => (v - self.noise_variance).max(T::ZERO).sqrt(),
            // max(·, 0) only absorbs rounding: every std of the batch is ≥ the shift.
            NoiseSubtraction::Reference => (v.sqrt() - self.shift).max(T::ZERO),
        }
    }
}

/// Turns a batch of noisy GP predictive variances (`v = c + σ_n² − k*ᵀK⁻¹k*`, noise
/// included) into posterior standard deviations, in place, by `mode` (see
/// [`StdTransform`]).
///
/// The batch matters only for [`NoiseSubtraction::Reference`], whose shift depends on the
/// smallest std of the batch (§7.2 uses one batch per source dataset). The values are
/// checked before any is changed. Errors: a non-finite variance or `noise_variance`, a
/// negative `noise_variance`.
pub fn predictive_stds<T: Real>(
    mode: NoiseSubtraction,
    noise_variance: T,
    variances: &mut [T],
) -> Result<()> {
    ensure_all_finite(variances, "variances")?;
    let smallest = variances.iter().fold(T::INFINITY, |m, &v| m.min(v));
    let smallest = if smallest.is_finite() {
        smallest
    } else {
        T::ZERO
    };
    let transform = StdTransform::new(mode, noise_variance, smallest)?;
    for v in variances.iter_mut() {
        *v = transform.apply(*v);
    }
    Ok(())
}

/// The ideal (oracle) weight of §7.7 for one coordinate:
/// `𝒩(y; mean_target, variance) / 𝒩(y; mean_source, variance)`, uncapped.
///
/// Use the true noise variances (0.01 for rewards, 0.04 per next-state coordinate); a
/// transition weight is the product over coordinates. May be `+∞` when the ratio
/// overflows `T`. Errors: non-finite inputs, a non-positive variance.
pub fn ideal_weight<T: Real>(y: T, mean_target: T, mean_source: T, variance: T) -> Result<T> {
    ensure_finite(y, "y")?;
    ensure_finite(mean_target, "mean_target")?;
    ensure_finite(mean_source, "mean_source")?;
    ensure_finite(variance, "variance")?;
    if variance <= T::ZERO {
        return Err(Error::InvalidParameter {
            parameter: "variance",
        });
    }
    let two = T::from_f64(2.0);
    let log_w = ((y - mean_source).squared() - (y - mean_target).squared()) / (two * variance);
    Ok(if log_w.is_nan() { T::ZERO } else { log_w.exp() })
}

/// Running sums of a set of weights, for the diagnostics of §7.2: the mean weight and the
/// effective sample size `(Σw)² / Σw²`.
///
/// Feed it several slices (target records with weight 1, then each source) without
/// concatenating them. The sums are kept relative to the largest weight seen so far (and
/// rescaled when a larger one arrives), like [`effective_sample_size`], so they neither
/// overflow nor underflow for any finite weights. Size: four `T`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WeightSummary<T> {
    count: T,
    /// The largest weight so far (0 while every weight is 0).
    scale: T,
    /// `Σ w / scale`.
    sum: T,
    /// `Σ (w / scale)²`.
    sum_of_squares: T,
}

impl<T: Real> WeightSummary<T> {
    /// An empty summary.
    pub fn new() -> Self {
        Self {
            count: T::ZERO,
            scale: T::ZERO,
            sum: T::ZERO,
            sum_of_squares: T::ZERO,
        }
    }

    /// Adds every weight of `weights`.
    ///
    /// Checked before anything is added. Errors: a non-finite or negative weight.
    pub fn add(&mut self, weights: &[T]) -> Result<()> {
        ensure_all_finite(weights, "weights")?;
        if weights.iter().any(|&w| w < T::ZERO) {
            return Err(Error::InvalidParameter {
                parameter: "weights",
            });
        }
        for &w in weights {
            self.push(w, T::ONE);
        }
        Ok(())
    }

    /// Adds `count` weights equal to 1 (the target's own records).
    pub fn add_ones(&mut self, count: usize) {
        if count > 0 {
            self.push(T::ONE, T::from_usize(count));
        }
    }

    /// Adds `times` copies of the finite, non-negative weight `w`.
    fn push(&mut self, w: T, times: T) {
        self.count += times;
        if w > self.scale {
            let ratio = self.scale / w;
            self.sum *= ratio;
            self.sum_of_squares *= ratio * ratio;
            self.scale = w;
        }
        if self.scale > T::ZERO {
            let u = w / self.scale;
            self.sum += times * u;
            self.sum_of_squares += times * u * u;
        }
    }

    /// Number of weights added.
    pub fn count(&self) -> T {
        self.count
    }

    /// Mean weight; 0 when empty.
    pub fn mean(&self) -> T {
        if self.count > T::ZERO {
            self.sum / self.count * self.scale
        } else {
            T::ZERO
        }
    }

    /// Effective sample size `(Σw)² / Σw²`; 0 when empty or when every weight is 0.
    pub fn effective_sample_size(&self) -> T {
        if self.sum_of_squares > T::ZERO {
            self.sum / self.sum_of_squares * self.sum
        } else {
            T::ZERO
        }
    }
}

/// What one step's weights of the source records looked like: their [`WeightSummary`], how
/// many the variance rule discarded and how many reached the cap (the diagnostics of
/// [`crate::StepReport`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct WeightTally<T> {
    /// The source records' weights alone.
    pub(crate) sources: WeightSummary<T>,
    /// Records the variance rule discarded.
    pub(crate) discarded: usize,
    /// Records whose weight reached `w_max`.
    pub(crate) capped: usize,
}

impl<T: Real> WeightTally<T> {
    /// An empty tally.
    pub(crate) fn new() -> Self {
        Self {
            sources: WeightSummary::new(),
            discarded: 0,
            capped: 0,
        }
    }

    /// Adds one source's `weights`, of which `discarded` were discarded by the variance
    /// rule; counts those at `cap`.
    ///
    /// Errors: those of [`WeightSummary::add`].
    pub(crate) fn add(&mut self, weights: &[T], cap: T, discarded: usize) -> Result<()> {
        self.sources.add(weights)?;
        let capped = weights.iter().filter(|&&w| w >= cap).count();
        self.capped = self.capped.saturating_add(capped);
        self.discarded = self.discarded.saturating_add(discarded);
        Ok(())
    }
}

/// The effective sample size `(Σw)² / Σw²` of `weights` (§7.2): between 1 and the number of
/// non-zero weights; 0 when there are none.
///
/// Computed after scaling by the largest weight, so it neither overflows nor underflows.
/// Errors: an empty slice, a non-finite or negative weight.
pub fn effective_sample_size<T: Real>(weights: &[T]) -> Result<T> {
    if weights.is_empty() {
        return Err(Error::EmptyData);
    }
    ensure_all_finite(weights, "weights")?;
    let mut largest = T::ZERO;
    for &w in weights {
        if w < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "weights",
            });
        }
        largest = largest.max(w);
    }
    if largest <= T::ZERO {
        return Ok(T::ZERO);
    }
    let mut sum = T::ZERO;
    let mut sum_of_squares = T::ZERO;
    for &w in weights {
        let u = w / largest;
        sum += u;
        sum_of_squares += u * u;
    }
    Ok(sum / sum_of_squares * sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spec §7.3 golden table: (y, μ_t, σ_t, μ_s, σ_s, v, mean, heuristic).
    const GOLDEN: [[f64; 8]; 5] = [
        [
            -1.0,
            -1.2,
            0.1,
            -1.0,
            0.05,
            0.1,
            0.805079404153,
            0.804827777517,
        ],
        [
            -1.3,
            -1.0,
            0.2,
            -1.25,
            0.03,
            0.1,
            0.623422515078,
            0.623257005989,
        ],
        [
            -5.0,
            -1.0,
            0.05,
            -5.1,
            0.04,
            0.1,
            1.33061875955e-34,
            1.32832086981e-34,
        ],
        [
            2.3,
            2.0,
            0.1,
            2.2,
            0.02,
            0.2,
            0.808455457025,
            0.808372998447,
        ],
        [0.0, 0.0, 0.1, 0.0, 0.4, 0.1, 0.0, 1.53741222957],
    ];

    fn rel_close(a: f64, b: f64, tol: f64) -> bool {
        if b == 0.0 {
            a == 0.0
        } else {
            ((a - b) / b).abs() <= tol
        }
    }

    #[test]
    fn golden_values_of_the_spec_in_f64() {
        for row in GOLDEN {
            let [y, mt, st, ms, ss, v, mean, heur] = row;
            let t = Posterior::new(mt, st);
            let s = Posterior::new(ms, ss);
            let pm = WeightParams::new(Estimator::Mean, v, 1000.0).unwrap();
            let ph = WeightParams::new(Estimator::Heuristic, v, 1000.0).unwrap();
            let wm = pm.weight(y, t, s).unwrap();
            let wh = ph.weight(y, t, s).unwrap();
            assert!(rel_close(wm, mean, 1e-10), "mean {wm} vs {mean}");
            assert!(rel_close(wh, heur, 1e-10), "heuristic {wh} vs {heur}");
        }
    }

    #[test]
    fn golden_values_of_the_spec_in_f32() {
        for row in GOLDEN {
            let c = |x: f64| x as f32;
            let t = Posterior::new(c(row[1]), c(row[2]));
            let s = Posterior::new(c(row[3]), c(row[4]));
            let pm = WeightParams::new(Estimator::Mean, c(row[5]), 1000.0).unwrap();
            let ph = WeightParams::new(Estimator::Heuristic, c(row[5]), 1000.0).unwrap();
            let wm = pm.weight(c(row[0]), t, s).unwrap() as f64;
            let wh = ph.weight(c(row[0]), t, s).unwrap() as f64;
            // f32: the exponent of row 3 is about −78, so 1e-4 relative is ~1e-5 absolute
            // error in the log.
            assert!(rel_close(wm, row[6], 1e-4), "mean {wm} vs {}", row[6]);
            assert!(rel_close(wh, row[7], 1e-4), "heuristic {wh} vs {}", row[7]);
        }
    }

    #[test]
    fn cap_and_underflow_are_handled_in_log_space() {
        let p = WeightParams::new(Estimator::Heuristic, 0.1f64, 1000.0).unwrap();
        // Target density at y is large, source density astronomically small: capped.
        let w = p
            .weight(0.0, Posterior::new(0.0, 0.0), Posterior::new(100.0, 0.0))
            .unwrap();
        assert_eq!(w, 1000.0);
        // Both densities underflow to 0 in f64 (0/0 = NaN in the plain ratio of the
        // reference); the log ratio of this symmetric case is exactly 0, so the weight is 1.
        let w = p
            .weight(
                5000.0,
                Posterior::new(0.0, 0.0),
                Posterior::new(10_000.0, 0.0),
            )
            .unwrap();
        assert_eq!(w, 1.0);
        // A NaN arising inside (overflowing squares in f32: inf − inf) maps to 0.
        let p32 = WeightParams::new(Estimator::Heuristic, 0.1f32, 1000.0).unwrap();
        let w = p32
            .weight(
                3.0e38,
                Posterior::new(-3.0e38, 0.0),
                Posterior::new(-3.0e38, 0.0),
            )
            .unwrap();
        assert_eq!(w, 0.0);
    }

    #[test]
    fn mean_estimator_discards_at_the_boundary() {
        // σ_s² == v exactly (0.5² = 0.25 has no rounding): discarded.
        let p2 = WeightParams::new(Estimator::Mean, 0.25f64, 1000.0).unwrap();
        let w = p2
            .weight(0.0, Posterior::new(0.0, 0.1), Posterior::new(0.0, 0.5))
            .unwrap();
        assert_eq!(w, 0.0);
        // Just inside: v − σ_s² = 0.25 − 0.49² = 0.0099 > 0, weight
        // 𝒩(0;0,0.26)/𝒩(0;0,0.0099)·0.25/0.0099 = √(0.0099/0.26)·0.25/0.0099.
        let w = p2
            .weight(0.0, Posterior::new(0.0, 0.1), Posterior::new(0.0, 0.49))
            .unwrap();
        let want = (0.0099f64 / 0.26).sqrt() * 0.25 / 0.0099;
        assert!(rel_close(w, want, 1e-9), "{w} vs {want}");
    }

    #[test]
    fn weights_into_validates_before_writing() {
        let p = WeightParams::<f64>::reference_reward();
        let t = [Posterior::new(-1.2, 0.1), Posterior::new(-1.0, 0.2)];
        let s = [Posterior::new(-1.0, 0.05), Posterior::new(-1.25, 0.03)];
        let mut out = [7.0; 2];
        assert_eq!(
            p.weights_into(&[-1.0, f64::NAN], &t, &s, &mut out),
            Err(Error::NonFinite { parameter: "y" })
        );
        assert_eq!(out, [7.0; 2]);
        let bad = [Posterior::new(-1.0, -0.05), Posterior::new(-1.25, 0.03)];
        assert_eq!(
            p.weights_into(&[-1.0, -1.3], &t, &bad, &mut out),
            Err(Error::InvalidParameter {
                parameter: "posterior.std"
            })
        );
        assert_eq!(
            p.weights_into(&[-1.0], &t, &s, &mut out),
            Err(Error::InvalidParameter { parameter: "out" })
        );
        assert_eq!(out, [7.0; 2]);
        p.weights_into(&[-1.0, -1.3], &t, &s, &mut out).unwrap();
        assert!(rel_close(out[0], GOLDEN[0][6], 1e-10));
        assert!(rel_close(out[1], GOLDEN[1][6], 1e-10));
    }

    #[test]
    fn parameters_are_validated() {
        assert_eq!(
            WeightParams::new(Estimator::Mean, 0.0f32, 1.0),
            Err(Error::InvalidParameter {
                parameter: "noise_variance"
            })
        );
        assert_eq!(
            WeightParams::new(Estimator::Mean, 0.1f32, f32::INFINITY),
            Err(Error::NonFinite {
                parameter: "max_weight"
            })
        );
        assert_eq!(
            WeightParams::new(Estimator::Mean, 0.1f32, -1.0),
            Err(Error::InvalidParameter {
                parameter: "max_weight"
            })
        );
    }

    #[test]
    fn ideal_weight_golden_value() {
        let w = ideal_weight(-1.05f64, -1.0, -1.2, 0.01).unwrap();
        assert!((w - core::f64::consts::E).abs() < 1e-12);
        let w = ideal_weight(-1.05f32, -1.0, -1.2, 0.01).unwrap();
        assert!((w - core::f32::consts::E).abs() < 1e-4);
        // Identical means: exactly 1 (shared dynamics gives w_s = 1 exactly).
        assert_eq!(ideal_weight(3.7f64, 4.0, 4.0, 0.04).unwrap(), 1.0);
        assert!(ideal_weight(0.0f64, 0.0, 0.0, 0.0).is_err());
    }

    #[test]
    fn ess_golden_value_and_edge_cases() {
        let w = [1.0f64, 1.0, 0.5, 0.0, 2.0];
        assert!((effective_sample_size(&w).unwrap() - 3.24).abs() < 1e-12);
        let w32 = [1.0f32, 1.0, 0.5, 0.0, 2.0];
        assert!((effective_sample_size(&w32).unwrap() - 3.24).abs() < 1e-5);
        // Scale invariance, including values whose squares overflow f32.
        let big = [1.0e30f32, 1.0e30, 0.5e30, 0.0, 2.0e30];
        assert!((effective_sample_size(&big).unwrap() - 3.24).abs() < 1e-5);
        assert_eq!(effective_sample_size(&[0.0f64; 3]).unwrap(), 0.0);
        assert_eq!(effective_sample_size::<f64>(&[]), Err(Error::EmptyData));
        assert!(effective_sample_size(&[1.0f64, -1.0]).is_err());
        assert!(effective_sample_size(&[1.0f64, f64::NAN]).is_err());
    }

    #[test]
    fn summary_matches_ess_over_concatenation() {
        let mut s = WeightSummary::<f64>::new();
        s.add_ones(2);
        s.add(&[0.5, 0.0, 2.0]).unwrap();
        assert!((s.effective_sample_size() - 3.24).abs() < 1e-12);
        assert!((s.mean() - 0.9).abs() < 1e-12);
        assert_eq!(s.count(), 5.0);
        assert!(s.add(&[1.0, -2.0]).is_err());
        assert_eq!(s.count(), 5.0);
        assert_eq!(WeightSummary::<f32>::new().effective_sample_size(), 0.0);
        assert_eq!(WeightSummary::<f32>::new().mean(), 0.0);
    }

    #[test]
    fn noise_subtraction_rules() {
        // Reference rule, σ̂_n ≤ min std: subtract σ̂_n = 0.1 from every std.
        let mut v = [0.25f64, 0.09, 1.0];
        predictive_stds(NoiseSubtraction::Reference, 0.01, &mut v).unwrap();
        let want = [0.4, 0.2, 0.9];
        for (a, b) in v.iter().zip(want) {
            assert!((a - b).abs() < 1e-12);
        }
        // Reference rule, σ̂_n = 0.5 > min std 0.3: subtract 0.3, smallest becomes 0.
        let mut v = [0.09f64, 0.36, 1.0];
        predictive_stds(NoiseSubtraction::Reference, 0.25, &mut v).unwrap();
        let want = [0.0, 0.3, 0.7];
        for (a, b) in v.iter().zip(want) {
            assert!((a - b).abs() < 1e-12);
        }
        // Principled: √max(v − σ_n², 0).
        let mut v = [0.09f64, 0.36, 0.2];
        predictive_stds(NoiseSubtraction::Principled, 0.25, &mut v).unwrap();
        let want = [0.0, 0.11f64.sqrt(), 0.0];
        for (a, b) in v.iter().zip(want) {
            assert!((a - b).abs() < 1e-12);
        }
        let mut v = [0.09f64, -1e-18];
        predictive_stds(NoiseSubtraction::Off, 0.25, &mut v).unwrap();
        assert_eq!(v, [0.3, 0.0]);
        // Validation before mutation.
        let mut v = [0.09f64, f64::NAN];
        assert!(predictive_stds(NoiseSubtraction::Reference, 0.25, &mut v).is_err());
        assert_eq!(v[0], 0.09);
        assert!(predictive_stds(NoiseSubtraction::Off, -1.0, &mut v).is_err());
    }
}
