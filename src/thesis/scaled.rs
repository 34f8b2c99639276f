use super::AwfqiConfig;
use crate::error::{Error, Result};
use crate::float::Real;
use crate::gp::{
    Conditioning, HyperparameterBounds, Hyperparameters, MAX_SEARCH_PARAMETERS, SearchOptions,
};
use crate::model::Transition;
use crate::record_gp::{Dims, GpTraining, StatePlusAction};
use crate::weights::{Estimator, WeightParams};

/// `v = K·ν`: the weights' noise variance as a multiple of the measured local noise.
///
/// Chosen on the tuning seeds (100–119) of the zones example (`docs/embedding.md`) with the
/// recommended adaptive kernel, with the estimator, among the mean and the heuristic
/// estimator with `K ∈ {0.5, 1, 2, 4, 8, 16}`: the best mean return among the settings
/// whose steps warn of collapsed weights in at most one step in eight (defaults should not
/// warn as a rule). The heuristic estimator with `K = 4`: −5.57 ± 0.05, 4 of 40 steps
/// warned. The best return overall, the mean estimator with `K = 2`, is 0.01 ± 0.06 higher
/// (paired, p = 0.84) with 39 of 40 steps warned; `K = 16` gives up 0.40 ± 0.09 (p = 2·10⁻⁴).
pub const NOISE_MULTIPLIER: f64 = 4.0;

/// The estimator of the scaled weights: the ratio of the two predictive densities
/// ([`Estimator::Heuristic`]). The mean estimator's factor `v/(v − σ_s²)` grows without
/// bound as a source posterior's variance nears `v`, so with a `v` small enough to tell the
/// sources apart a few records reach the cap and carry the weights (see
/// [`NOISE_MULTIPLIER`]).
pub const SCALED_ESTIMATOR: Estimator = Estimator::Heuristic;

/// Random restarts of every scaled GP search (after the start from the scaled values).
pub const SCALED_RESTARTS: usize = 2;

/// Likelihood evaluations of a scaled GP search per searched parameter (an ARD search over
/// `I` inputs searches `I + 2`).
pub const SCALED_EVALUATIONS_PER_PARAMETER: usize = 40;

/// The median of χ²₁: `Δ²/(2ν)` for the difference `Δ` of two independent Gaussian
/// observations of variance `ν`.
const CHI2_1_MEDIAN: f64 = 0.454_936_423_119_572_7;

/// Settings that scale themselves: the GP's hyperparameter starts and bounds, its noise
/// floor and the weights' noise variances derived from the source data, so a new plant
/// needs no hand-tuned GP settings.
///
/// [`AwfqiConfig::thesis`] is in Puddle World's units; on a plant whose states span
/// `[0, 500]` or whose rewards are in the thousands, its GPs start at the wrong scale, its
/// search box misses the likelihood's optimum and `v_r = 0.1` makes the reward weights
/// collapse onto a few records. [`SourceScales::measure`] reads the scales off the source
/// records once, [`AwfqiConfig::scaled`] turns them into settings by the rules below, and
/// a step's [`StepReport::warnings`](super::StepReport::warnings) says when they still do
/// not fit.
///
/// **What is measured** (all source records together):
/// - the range `[lᵢ, uᵢ]` of each state coordinate (states and next states) and the number
///   of actions `A` (largest action + 1); the span `sᵢ = uᵢ − lᵢ` (1 for a constant
///   coordinate) and, for the action input, `s_a = max(A − 1, 1)`;
/// - the rewards' mean `r̄`, variance `σ²_r` and second moment `m₂ = r̄² + σ²_r` (the scale
///   of what a zero-mean GP must explain);
/// - a **local noise** `ν` of the rewards and of each next-state coordinate: for each
///   record, a linear fit to its `min(2(D + 1), 16)` nearest records of the same source and
///   action (distance in units of the spans) and the record's residual `ε` from it, scaled
///   by the fit's own variance at the record (`ε²/(1 + h)`, variance `ν` for Gaussian
///   noise); `ν = median(ε²/(1 + h)) / 0.4549` (the median of χ²₁). The fit removes what
///   the output varies between neighbours to first order (a slope, the state carried into
///   the next state), which in four and more dimensions, where neighbours are far apart, is
///   most of a neighbour difference; curvature over that distance remains. With fewer than
///   `D + 2` such records the nearest one's difference `Δ` stands in (`Δ²/2`). The median
///   keeps a jump (a puddle's edge, a flood threshold) from dominating it. Three passes of
///   O(n²/A) distance computations per source and output, once, in no memory.
///
/// **The rules** ([`AwfqiConfig::scaled`]):
/// - every GP input `i` (each state coordinate, then the action): length-scale start
///   `sᵢ/2`, bounds `[sᵢ/100, 10·sᵢ]`; the search is ARD (one length scale per input) up
///   to 6 inputs (the search's limit), isotropic beyond;
/// - signal variance: start `m₂`, bounds `[m₂/100, 10·m₂]`;
/// - noise variance: start `max(ν_r, floor)`, bounds `[floor, m₂]`, with the **noise
///   floor** `floor = m₂ · max(10⁻⁴, 10⁴·ε)` (`ε` the precision's epsilon: `1.2·10⁻³·m₂`
///   in `f32`, `10⁻⁴·m₂` in `f64`), which keeps a GP whose inputs cluster (repeated
///   queries, rollouts) within the condition number the precision can trust;
/// - search: [`SCALED_RESTARTS`] random restarts and [`SCALED_EVALUATIONS_PER_PARAMETER`]
///   likelihood evaluations per searched parameter;
/// - reward weights: the heuristic estimator ([`SCALED_ESTIMATOR`]; the thesis's mean
///   estimator discards and caps records whose source posterior is nearly as uncertain as
///   `v`) with `v_r = max(K·ν_r, floor)`, `K =` [`NOISE_MULTIPLIER`] `= 4`, `w_max = 1000`;
///   transition weights ([`SourceScales::transition_weights`]): the same rule on the mean
///   of the next-state coordinates' `ν`;
/// - everything else as [`AwfqiConfig::thesis`]: reference noise subtraction, the spread
///   subset rule, sampling on `V_r`, FQI with γ = 0.99 and 60 iterations (set `fqi` to
///   your plant's discount).
///
/// What the source records say about a plant's scales (see above).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SourceScales<T, const D: usize> {
    /// Smallest value of each state coordinate over states and next states.
    pub lower: [T; D],
    /// Largest value of each state coordinate over states and next states.
    pub upper: [T; D],
    /// Number of actions (largest action index + 1).
    pub actions: usize,
    /// Number of records measured.
    pub records: usize,
    /// Mean reward `r̄`.
    pub reward_mean: T,
    /// Variance of the rewards `σ²_r`.
    pub reward_variance: T,
    /// Local noise `ν_r` of the rewards.
    pub reward_noise: T,
    /// Local noise `ν` of each next-state coordinate.
    pub next_state_noise: [T; D],
}

impl<T: Real, const D: usize> SourceScales<T, D> {
    /// Measures the scales of `sources` (one slice per source; see the module docs).
    ///
    /// Errors: no record at all ([`Error::EmptyData`]); a non-finite state, reward or next
    /// state ([`Error::NonFinite`] `sources`).
    pub fn measure(sources: &[&[Transition<[T; D], T>]]) -> Result<Self> {
        let mut lower = [T::INFINITY; D];
        let mut upper = [T::NEG_INFINITY; D];
        let (mut records, mut actions) = (0usize, 0usize);
        let (mut sum, mut sum_sq) = (T::ZERO, T::ZERO);
        for r in sources.iter().flat_map(|s| s.iter()) {
            let finite =
                r.reward.is_finite() && r.state.iter().chain(&r.next_state).all(|x| x.is_finite());
            if !finite {
                return Err(Error::NonFinite {
                    parameter: "sources",
                });
            }
            for ((lo, hi), (&s, &n)) in lower
                .iter_mut()
                .zip(upper.iter_mut())
                .zip(r.state.iter().zip(&r.next_state))
            {
                *lo = lo.min(s).min(n);
                *hi = hi.max(s).max(n);
            }
            records += 1;
            actions = actions.max(r.action.saturating_add(1));
            sum += r.reward;
            sum_sq += r.reward * r.reward;
        }
        if records == 0 {
            return Err(Error::EmptyData);
        }
        let n = T::from_usize(records);
        let reward_mean = sum / n;
        let reward_variance = (sum_sq / n - reward_mean * reward_mean).max(T::ZERO);
        let mut span = [T::ONE; D];
        for ((s, &lo), &hi) in span.iter_mut().zip(&lower).zip(&upper) {
            if hi > lo {
                *s = hi - lo;
            }
        }
        let reward_noise = local_noise(sources, &span, |r| r.reward);
        let mut next_state_noise = [T::ZERO; D];
        for (k, noise) in next_state_noise.iter_mut().enumerate() {
            *noise = local_noise(sources, &span, |r| {
                r.next_state.get(k).copied().unwrap_or(T::ZERO)
            });
        }
        Ok(Self {
            lower,
            upper,
            actions,
            records,
            reward_mean,
            reward_variance,
            reward_noise,
            next_state_noise,
        })
    }

    /// `(lower, upper)` of each state coordinate, as [`crate::adaptive::AdaptiveConfig::bounds`]
    /// takes them (a constant coordinate gets a unit interval around its value).
    pub fn bounds(&self) -> [(T, T); D] {
        let mut bounds = [(T::ZERO, T::ONE); D];
        for ((b, &lo), &hi) in bounds.iter_mut().zip(&self.lower).zip(&self.upper) {
            *b = if hi > lo {
                (lo, hi)
            } else {
                let half = T::ONE / T::from_f64(2.0);
                (lo - half, lo + half)
            };
        }
        bounds
    }

    /// The span `sᵢ` of GP input `i`: a state coordinate's range (1 when constant), and
    /// for the action input (`i = D`) `max(A − 1, 1)`.
    pub fn span(&self, input: usize) -> T {
        match (self.lower.get(input), self.upper.get(input)) {
            (Some(&lo), Some(&hi)) if hi > lo => hi - lo,
            (Some(_), Some(_)) => T::ONE,
            _ => T::from_usize(self.actions.saturating_sub(1).max(1)),
        }
    }

    /// The rewards' second moment `m₂ = r̄² + σ²_r` (a tiny positive value when every reward
    /// is 0, so that the rules below stay valid).
    pub fn reward_scale(&self) -> T {
        let m2 = self.reward_mean * self.reward_mean + self.reward_variance;
        m2.max(T::MIN_POSITIVE.sqrt())
    }

    /// The GP's noise floor: `m₂ · max(10⁻⁴, 10⁴·ε)`.
    pub fn noise_floor(&self) -> T {
        let relative = T::from_f64(1e-4).max(T::from_f64(1e4) * T::EPSILON);
        self.reward_scale() * relative
    }

    /// The scaled training of every GP over the inputs `(state, action)` (module docs).
    pub fn gp_training<const I: usize>(&self) -> Result<GpTraining<T, I>>
    where
        Dims<D, I>: StatePlusAction,
    {
        let m2 = self.reward_scale();
        let floor = self.noise_floor();
        let two = T::from_f64(2.0);
        let mut initial = Hyperparameters {
            signal_variance: m2,
            length_scales: [T::ONE; I],
            noise_variance: self.reward_noise.max(floor).min(m2),
        };
        let mut bounds = HyperparameterBounds {
            signal_variance: (m2 / T::from_f64(100.0), m2 * T::from_f64(10.0)),
            length_scales: [(T::ONE, T::ONE); I],
            noise_variance: (floor, m2.max(floor)),
        };
        for (i, (start, bound)) in initial
            .length_scales
            .iter_mut()
            .zip(bounds.length_scales.iter_mut())
            .enumerate()
        {
            let s = self.span(i);
            *start = s / two;
            *bound = (s / T::from_f64(100.0), s * T::from_f64(10.0));
        }
        let isotropic = I + 2 > MAX_SEARCH_PARAMETERS;
        if isotropic {
            // One tied length scale, bounded by the intersection of the per-input bounds:
            // give every input the union so the intersection is not empty.
            let lo = bounds
                .length_scales
                .iter()
                .fold(T::INFINITY, |m, b| m.min(b.0));
            let hi = bounds.length_scales.iter().fold(T::ZERO, |m, b| m.max(b.1));
            bounds.length_scales = [(lo, hi); I];
        }
        let parameters = if isotropic { 3 } else { I + 2 };
        let training = GpTraining {
            initial,
            bounds,
            search: SearchOptions {
                max_evaluations: SCALED_EVALUATIONS_PER_PARAMETER * parameters,
                restarts: SCALED_RESTARTS,
                isotropic,
            },
            conditioning: Conditioning::DEFAULT,
        };
        training.validate()?;
        Ok(training)
    }

    /// The scaled reward weights: [`SCALED_ESTIMATOR`], `v_r = max(K·ν_r, floor)`,
    /// `w_max = 1000`.
    ///
    /// Errors: those of [`WeightParams::new`] (a non-finite scale).
    pub fn reward_weights(&self) -> Result<WeightParams<T>> {
        let v = (T::from_f64(NOISE_MULTIPLIER) * self.reward_noise).max(self.noise_floor());
        WeightParams::new(SCALED_ESTIMATOR, v, T::from_f64(1000.0))
    }

    /// The scaled transition weights: [`SCALED_ESTIMATOR`] with `v_s = K·ν̄_s`, `ν̄_s` the mean
    /// of the next-state coordinates' local noise (at least the same relative floor of their
    /// squared spans), `w_max = 1000`. One `v_s` serves every coordinate, so coordinates of
    /// very different noise are best given comparable units first.
    ///
    /// Errors: those of [`WeightParams::new`].
    pub fn transition_weights(&self) -> Result<WeightParams<T>> {
        let mut sum = T::ZERO;
        let mut floor = T::ZERO;
        let relative = T::from_f64(1e-4).max(T::from_f64(1e4) * T::EPSILON);
        for (k, &nu) in self.next_state_noise.iter().enumerate() {
            sum += nu;
            floor += self.span(k).squared() * relative;
        }
        let d = T::from_usize(D.max(1));
        let v = (T::from_f64(NOISE_MULTIPLIER) * sum / d).max(floor / d);
        WeightParams::new(SCALED_ESTIMATOR, v, T::from_f64(1000.0))
    }
}

impl<T: Real, const I: usize> AwfqiConfig<T, I> {
    /// Settings derived from the source data (the [rules](crate::thesis::SourceScales)): the
    /// scaled GP training and reward weights, and otherwise [`AwfqiConfig::thesis`]'s
    /// values for `budget` queries per step. The start for a plant of your own; set `fqi`
    /// to its discount.
    ///
    /// ```
    /// use awfqi::prelude::{AwfqiConfig, SourceScales, Transition};
    /// # fn main() -> awfqi::Result<()> {
    /// // Two logs of a plant whose state spans [0, 500] and whose rewards are near −300.
    /// let log = |shift: f32| -> [Transition<[f32; 1], f32>; 40] {
    ///     core::array::from_fn(|i| Transition {
    ///         state: [i as f32 * 12.5],
    ///         action: i % 3,
    ///         reward: -300.0 + shift * (i % 3) as f32 + (i % 7) as f32,
    ///         next_state: [i as f32 * 12.5 + 5.0],
    ///         absorbing: false,
    ///     })
    /// };
    /// let (a, b) = (log(10.0), log(-10.0));
    /// let scales = SourceScales::measure(&[&a, &b])?;
    /// let config = AwfqiConfig::<f32, 2>::scaled(50, &scales)?;
    /// let gp = config.gp_training;
    /// assert_eq!(gp.initial.length_scales[0], 492.5 / 2.0); // states 0–487.5, next to 492.5
    /// assert_eq!(gp.initial.length_scales[1], 1.0); // 3 actions: span 2
    /// assert!(gp.bounds.signal_variance.0 > 500.0); // rewards near −300: m₂ ≈ 9·10⁴
    /// assert!(config.weights.noise_variance() > 1.0); // v_r from the local noise
    /// config.validate()?;
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// Errors: those of [`SourceScales::gp_training`] and
    /// [`SourceScales::reward_weights`].
    pub fn scaled<const D: usize>(budget: usize, scales: &SourceScales<T, D>) -> Result<Self>
    where
        Dims<D, I>: StatePlusAction,
    {
        Ok(Self {
            weights: scales.reward_weights()?,
            gp_training: scales.gp_training()?,
            ..Self::thesis(budget)
        })
    }
}

/// Bins of each of the two histogram passes that locate the median.
const BINS: usize = 128;

/// Most neighbours of the local linear fit (see [`local_residual`]).
const MAX_NEIGHBOURS: usize = 16;

/// The local noise of `output`: the median over the records of `ε²/(1 + h)`, divided by
/// 0.4549 (the median of χ²₁), with `ε` the record's output minus a linear fit to its
/// `min(2(D + 1), 16)` nearest records of the same source and action (distance in units
/// of `span`) and `h` that fit's variance at the record relative to the noise
/// ([`local_residual`]); where a record has fewer than `D + 2` such neighbours, the
/// difference `Δ` to its nearest one (`ε²/(1 + h)` replaced by `Δ²/2`). The fit removes
/// what the output varies over the distance to the neighbours (a slope, or the state
/// carried into the next state), which in four and more dimensions, where neighbours are
/// far apart, is most of a neighbour difference. 0 without any neighbour.
///
/// Nothing is stored: the median is located by two histogram passes over the records,
/// the first over `log₂(x/max)` in half-octave bins (64 octaves; smaller values in the
/// first bin), the second linear inside the bin that holds the median, whose midpoint is
/// taken (relative error below 0.3 %). Three passes over the records in all.
fn local_noise<T: Real, const D: usize>(
    sources: &[&[Transition<[T; D], T>]],
    span: &[T; D],
    output: impl Fn(&Transition<[T; D], T>) -> T,
) -> T {
    // Twice each record's noise estimate (so that the median is that of `Δ²` for a pair,
    // whose half is the noise variance).
    let visit = |f: &mut dyn FnMut(T)| {
        for source in sources {
            for (i, r) in source.iter().enumerate() {
                if let Some(x) = local_residual(source, i, r, span, &output) {
                    f(x);
                }
            }
        }
    };
    let (mut count, mut largest) = (0usize, T::ZERO);
    visit(&mut |d2| {
        count += 1;
        largest = largest.max(d2);
    });
    if count == 0 || largest <= T::ZERO {
        return T::ZERO;
    }
    let half = count.div_ceil(2);
    // Pass 1: half-octave bins below `largest`; bin 0 takes everything below 2⁻⁶⁴·largest.
    let per_octave = T::from_f64(2.0 / core::f64::consts::LN_2);
    let octaves = T::from_usize(BINS);
    let bin_of = |d2: T| {
        let x = (d2 / largest).ln() * per_octave + octaves; // in (−∞, BINS]
        if x.is_finite() && x > T::ZERO {
            x.to_usize_saturating().min(BINS - 1)
        } else {
            0
        }
    };
    let edge = |b: usize| {
        if b == 0 {
            T::ZERO
        } else {
            largest * ((T::from_usize(b) - octaves) / per_octave).exp()
        }
    };
    let mut histogram = [0usize; BINS];
    visit(&mut |d2| {
        if let Some(h) = histogram.get_mut(bin_of(d2)) {
            *h += 1;
        }
    });
    let (bin, below) = median_bin(&histogram, half);
    let (lo, hi) = (
        edge(bin),
        if bin + 1 >= BINS {
            largest
        } else {
            edge(bin + 1)
        },
    );
    // Pass 2: linear bins inside [lo, hi].
    let width = (hi - lo) / T::from_usize(BINS);
    let mut fine = [0usize; BINS];
    visit(&mut |d2| {
        if d2 >= lo && d2 <= hi && bin_of(d2) == bin {
            let k = if width > T::ZERO {
                ((d2 - lo) / width).to_usize_saturating().min(BINS - 1)
            } else {
                0
            };
            if let Some(h) = fine.get_mut(k) {
                *h += 1;
            }
        }
    });
    let (k, _) = median_bin(&fine, half.saturating_sub(below));
    let median = lo + width * (T::from_usize(k) + T::ONE / T::from_f64(2.0));
    median / T::from_f64(2.0 * CHI2_1_MEDIAN)
}

/// Twice the noise estimate of record `i` (`r`) of `source`: `2ε²/(1 + h)` from a linear
/// fit to its nearest records of the same action, or `Δ²` to the nearest one where there
/// are too few for a fit ([`local_noise`]); `None` without any neighbour.
///
/// The fit is centred least squares on the `K` neighbours' offsets `xⱼ` from `r` (in units
/// of `span`): slope `g = S⁻¹ Σ (xⱼ − x̄)(yⱼ − ȳ)` with `S = Σ (xⱼ − x̄)(xⱼ − x̄)ᵀ`,
/// prediction at `r` (offset 0) `ŷ = ȳ − g·x̄`, whose error has variance `ν(1/K + x̄ᵀS⁻¹x̄)`;
/// so `ε = y − ŷ` has variance `ν(1 + h)`, `h = 1/K + x̄ᵀS⁻¹x̄`.
fn local_residual<T: Real, const D: usize>(
    source: &[Transition<[T; D], T>],
    i: usize,
    r: &Transition<[T; D], T>,
    span: &[T; D],
    output: &impl Fn(&Transition<[T; D], T>) -> T,
) -> Option<T> {
    let k = (2 * (D + 1)).min(MAX_NEIGHBOURS);
    // The k nearest, sorted by distance: (squared distance, index).
    let mut near = [(T::INFINITY, usize::MAX); MAX_NEIGHBOURS];
    let mut found = 0usize;
    let offset = |q: &Transition<[T; D], T>| {
        let mut x = [T::ZERO; D];
        for ((o, (&a, &b)), &s) in x.iter_mut().zip(q.state.iter().zip(&r.state)).zip(span) {
            *o = (a - b) / s;
        }
        x
    };
    for (j, q) in source.iter().enumerate() {
        if i == j || q.action != r.action {
            continue;
        }
        let d2 = offset(q).iter().fold(T::ZERO, |a, &x| a + x * x);
        let slots = near.get_mut(..k)?;
        if found < k || slots.last().is_some_and(|&(far, _)| d2 < far) {
            // Insert in order, dropping the farthest.
            let mut item = (d2, j);
            for slot in slots.iter_mut() {
                if item.0 < slot.0 {
                    core::mem::swap(slot, &mut item);
                }
            }
            found = (found + 1).min(k);
        }
    }
    let y = output(r);
    let (_, nearest) = *near.first()?;
    let nearest = source.get(nearest)?;
    if found < D + 2 {
        return Some((y - output(nearest)).squared());
    }
    let members = near.get(..found)?;
    let kt = T::from_usize(found);
    let (mut mean_x, mut mean_y) = ([T::ZERO; D], T::ZERO);
    for &(_, j) in members {
        let q = source.get(j)?;
        for (m, x) in mean_x.iter_mut().zip(offset(q)) {
            *m += x / kt;
        }
        mean_y += output(q) / kt;
    }
    let mut gram = [[T::ZERO; D]; D];
    let mut cross = [T::ZERO; D];
    for &(_, j) in members {
        let q = source.get(j)?;
        let x = offset(q);
        let dy = output(q) - mean_y;
        for (a, row) in gram.iter_mut().enumerate() {
            let xa = x.get(a).copied().unwrap_or(T::ZERO) - mean_x.get(a).copied()?;
            if let Some(c) = cross.get_mut(a) {
                *c += xa * dy;
            }
            for (b, cell) in row.iter_mut().enumerate() {
                let xb = x.get(b).copied().unwrap_or(T::ZERO) - mean_x.get(b).copied()?;
                *cell += xa * xb;
            }
        }
    }
    // A ridge of 10⁻⁶ of the mean diagonal keeps a flat neighbourhood solvable.
    let trace = (0..D).fold(T::ZERO, |t, a| {
        t + gram
            .get(a)
            .and_then(|row| row.get(a))
            .copied()
            .unwrap_or(T::ZERO)
    });
    let ridge = (trace / T::from_usize(D.max(1))) * T::from_f64(1e-6) + T::MIN_POSITIVE;
    for (a, row) in gram.iter_mut().enumerate() {
        if let Some(cell) = row.get_mut(a) {
            *cell += ridge;
        }
    }
    let chol = cholesky(gram)?;
    let slope = solve(&chol, cross);
    let at_mean = solve(&chol, mean_x);
    let fit = mean_y
        - slope
            .iter()
            .zip(&mean_x)
            .fold(T::ZERO, |a, (&g, &m)| a + g * m);
    let leverage = T::ONE / kt
        + mean_x
            .iter()
            .zip(&at_mean)
            .fold(T::ZERO, |a, (&m, &z)| a + m * z);
    let e = y - fit;
    let x = T::from_f64(2.0) * e.squared() / (T::ONE + leverage);
    x.is_finite().then_some(x)
}

/// The lower Cholesky factor of a symmetric positive-definite `a`; `None` when a pivot is
/// not positive.
fn cholesky<T: Real, const D: usize>(a: [[T; D]; D]) -> Option<[[T; D]; D]> {
    let mut l = [[T::ZERO; D]; D];
    for i in 0..D {
        for j in 0..=i {
            let mut sum = *a.get(i)?.get(j)?;
            for k in 0..j {
                sum -= *l.get(i)?.get(k)? * *l.get(j)?.get(k)?;
            }
            if i == j {
                if !sum.is_finite() || sum <= T::ZERO {
                    return None;
                }
                *l.get_mut(i)?.get_mut(j)? = sum.sqrt();
            } else {
                let d = *l.get(j)?.get(j)?;
                *l.get_mut(i)?.get_mut(j)? = sum / d;
            }
        }
    }
    Some(l)
}

/// `x` with `L Lᵀ x = b` for a lower Cholesky factor `l` with a positive diagonal.
fn solve<T: Real, const D: usize>(l: &[[T; D]; D], b: [T; D]) -> [T; D] {
    let at = |i: usize, j: usize| l.get(i).and_then(|r| r.get(j)).copied().unwrap_or(T::ONE);
    let mut y = b;
    for i in 0..D {
        let mut sum = y.get(i).copied().unwrap_or(T::ZERO);
        for k in 0..i {
            sum -= at(i, k) * y.get(k).copied().unwrap_or(T::ZERO);
        }
        if let Some(v) = y.get_mut(i) {
            *v = sum / at(i, i);
        }
    }
    for i in (0..D).rev() {
        let mut sum = y.get(i).copied().unwrap_or(T::ZERO);
        for k in i + 1..D {
            sum -= at(k, i) * y.get(k).copied().unwrap_or(T::ZERO);
        }
        if let Some(v) = y.get_mut(i) {
            *v = sum / at(i, i);
        }
    }
    y
}

/// The first bin at which the running count reaches `rank`, and the count before it.
fn median_bin(histogram: &[usize], rank: usize) -> (usize, usize) {
    let mut before = 0usize;
    for (b, &n) in histogram.iter().enumerate() {
        if before + n >= rank {
            return (b, before);
        }
        before += n;
    }
    (histogram.len().saturating_sub(1), before)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;
    use std::vec::Vec;

    fn record(state: [f64; 2], action: usize, reward: f64) -> Transition<[f64; 2], f64> {
        Transition {
            state,
            action,
            reward,
            next_state: [state[0] + 1.0, state[1]],
            absorbing: false,
        }
    }

    /// Twice each record's noise estimate by brute force (all same-action neighbours
    /// sorted, the nearest 6 fitted by a 2 × 2 inverse, the nearest difference with fewer
    /// than 4), sorted: the median the histogram passes must find.
    fn brute_median(sources: &[&[Transition<[f64; 2], f64>]], span: [f64; 2]) -> f64 {
        let mut all = Vec::new();
        for s in sources {
            for (i, r) in s.iter().enumerate() {
                let mut near: Vec<(f64, [f64; 2], f64)> = s
                    .iter()
                    .enumerate()
                    .filter(|&(j, q)| j != i && q.action == r.action)
                    .map(|(_, q)| {
                        let x = [
                            (q.state[0] - r.state[0]) / span[0],
                            (q.state[1] - r.state[1]) / span[1],
                        ];
                        (x[0] * x[0] + x[1] * x[1], x, q.reward)
                    })
                    .collect();
                near.sort_by(|a, b| a.0.total_cmp(&b.0));
                if near.is_empty() {
                    continue;
                }
                if near.len() < 4 {
                    all.push((r.reward - near[0].2).powi(2));
                    continue;
                }
                near.truncate(6);
                let k = near.len() as f64;
                let mx = [0, 1].map(|d| near.iter().map(|n| n.1[d]).sum::<f64>() / k);
                let my = near.iter().map(|n| n.2).sum::<f64>() / k;
                let (mut sxx, mut sxy, mut syy, mut bx, mut by) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for n in &near {
                    let (u, v, w) = (n.1[0] - mx[0], n.1[1] - mx[1], n.2 - my);
                    sxx += u * u;
                    sxy += u * v;
                    syy += v * v;
                    bx += u * w;
                    by += v * w;
                }
                let det = sxx * syy - sxy * sxy;
                let inv = [[syy / det, -sxy / det], [-sxy / det, sxx / det]];
                let g = [
                    inv[0][0] * bx + inv[0][1] * by,
                    inv[1][0] * bx + inv[1][1] * by,
                ];
                let fit = my - g[0] * mx[0] - g[1] * mx[1];
                let h = 1.0 / k
                    + mx[0] * (inv[0][0] * mx[0] + inv[0][1] * mx[1])
                    + mx[1] * (inv[1][0] * mx[0] + inv[1][1] * mx[1]);
                all.push(2.0 * (r.reward - fit).powi(2) / (1.0 + h));
            }
        }
        all.sort_by(f64::total_cmp);
        all[all.len().div_ceil(2) - 1]
    }

    #[test]
    fn ranges_moments_and_actions_are_measured() {
        let a = [record([0.0, 5.0], 0, -2.0), record([3.0, 1.0], 2, -4.0)];
        let b = [record([1.0, 2.0], 1, 0.0)];
        let scales = SourceScales::measure(&[&a, &b]).unwrap();
        // Next states shift x by 1: x in [0, 4], y in [1, 5].
        assert_eq!(scales.lower, [0.0, 1.0]);
        assert_eq!(scales.upper, [4.0, 5.0]);
        assert_eq!(scales.actions, 3);
        assert_eq!(scales.records, 3);
        assert!((scales.reward_mean + 2.0).abs() < 1e-12);
        assert!((scales.reward_variance - 8.0 / 3.0).abs() < 1e-12);
        assert_eq!(scales.span(0), 4.0);
        assert_eq!(scales.span(2), 2.0); // actions 0..3
        assert_eq!(scales.bounds(), [(0.0, 4.0), (1.0, 5.0)]);
        // No pair of the same source and action: no local noise.
        assert_eq!(scales.reward_noise, 0.0);
    }

    #[test]
    fn bad_sources_are_refused() {
        let none: [&[Transition<[f64; 2], f64>]; 1] = [&[]];
        assert_eq!(SourceScales::measure(&none), Err(Error::EmptyData));
        let bad = [record([0.0, f64::NAN], 0, 1.0)];
        assert_eq!(
            SourceScales::measure(&[&bad]),
            Err(Error::NonFinite {
                parameter: "sources"
            })
        );
    }

    #[test]
    fn the_local_noise_is_the_median_of_the_local_fits_residuals() {
        // Irregular states and rewards: the histogram passes find the sorted median.
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let make = |rng: &mut ChaCha8Rng, n: usize| -> Vec<Transition<[f64; 2], f64>> {
            (0..n)
                .map(|i| {
                    let x = crate::rng::uniform::<f64, _>(rng) * 10.0;
                    let y = crate::rng::uniform::<f64, _>(rng) * 4.0;
                    let r = (x * y).sin() * 3.0 + crate::rng::standard_normal::<f64, _>(rng);
                    record([x, y], i % 3, r)
                })
                .collect()
        };
        let (a, b) = (make(&mut rng, 301), make(&mut rng, 120));
        let sources: [&[Transition<[f64; 2], f64>]; 2] = [&a, &b];
        let scales = SourceScales::measure(&sources).unwrap();
        let span = [scales.span(0), scales.span(1)];
        let want = brute_median(&sources, span) / (2.0 * CHI2_1_MEDIAN);
        let got = scales.reward_noise;
        assert!((got - want).abs() <= 3e-3 * want, "{got} vs {want}");
    }

    #[test]
    fn pure_noise_is_measured_as_its_variance() {
        // A constant reward plus noise of variance 0.04 on dense states: ν ≈ 0.04 (the
        // median of 2 000 χ²₁ draws is within a few per cent of its value).
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let records: Vec<_> = (0..2000)
            .map(|i| {
                let x = crate::rng::uniform::<f64, _>(&mut rng);
                let noise = 0.2 * crate::rng::standard_normal::<f64, _>(&mut rng);
                record([x, 0.5], i % 2, -7.0 + noise)
            })
            .collect();
        let scales = SourceScales::measure(&[&records]).unwrap();
        assert!(
            (scales.reward_noise - 0.04).abs() < 0.006,
            "{}",
            scales.reward_noise
        );
        // x' = x + 1 exactly and y' constant: a local linear fit explains both up to
        // rounding.
        assert!(scales.next_state_noise[0] < 1e-12);
        assert!(scales.next_state_noise[1] < 1e-12);
    }

    #[test]
    fn the_rules_give_the_documented_settings() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let records: Vec<_> = (0..400)
            .map(|i| {
                let x = crate::rng::uniform::<f64, _>(&mut rng) * 500.0;
                let y = crate::rng::uniform::<f64, _>(&mut rng) * 3.0 + 1.0;
                let noise = 2.0 * crate::rng::standard_normal::<f64, _>(&mut rng);
                record([x, y], i % 4, -100.0 + x / 10.0 + noise)
            })
            .collect();
        let scales = SourceScales::measure(&[&records]).unwrap();
        let m2 = scales.reward_mean.powi(2) + scales.reward_variance;
        let floor = m2 * 1e-4;
        assert_eq!(scales.noise_floor(), floor);
        let training = scales.gp_training::<3>().unwrap();
        let spans = [scales.span(0), scales.span(1), 3.0];
        assert_eq!(scales.span(2), 3.0);
        for (i, span) in spans.into_iter().enumerate() {
            assert_eq!(training.initial.length_scales[i], span / 2.0);
            assert_eq!(
                training.bounds.length_scales[i],
                (span / 100.0, span * 10.0)
            );
        }
        assert_eq!(training.initial.signal_variance, m2);
        assert_eq!(training.bounds.signal_variance, (m2 / 100.0, m2 * 10.0));
        assert_eq!(training.bounds.noise_variance, (floor, m2));
        assert_eq!(
            training.initial.noise_variance,
            scales.reward_noise.max(floor)
        );
        assert!(!training.search.isotropic);
        assert_eq!(training.search.restarts, SCALED_RESTARTS);
        assert_eq!(
            training.search.max_evaluations,
            5 * SCALED_EVALUATIONS_PER_PARAMETER
        );
        let weights = scales.reward_weights().unwrap();
        assert_eq!(weights.estimator(), Estimator::Heuristic);
        assert_eq!(
            weights.noise_variance(),
            NOISE_MULTIPLIER * scales.reward_noise
        );
        assert_eq!(weights.max_weight(), 1000.0);
        // The local noise sees the noise (variance 4) plus the slope over a neighbour's
        // distance: at least the noise, not the rewards' spread (variance ≈ 208).
        assert!(scales.reward_noise > 3.0 && scales.reward_noise < 20.0);
        // f32: the floor follows the precision.
        let narrow: Vec<Transition<[f32; 2], f32>> = records
            .iter()
            .map(|r| Transition {
                state: r.state.map(|x| x as f32),
                action: r.action,
                reward: r.reward as f32,
                next_state: r.next_state.map(|x| x as f32),
                absorbing: false,
            })
            .collect();
        let s32 = SourceScales::measure(&[&narrow]).unwrap();
        let want = s32.reward_scale() * 1e4 * f32::EPSILON;
        assert!((s32.noise_floor() - want).abs() <= 1e-6 * want);
        // The configuration: scaled GP and weights, the thesis's other settings.
        let config = AwfqiConfig::<f64, 3>::scaled(20, &scales).unwrap();
        let thesis = AwfqiConfig::<f64, 3>::thesis(20);
        assert_eq!(config.gp_training, training);
        assert_eq!(config.weights, weights);
        assert_eq!(config.fqi, thesis.fqi);
        assert_eq!(config.subset, thesis.subset);
        assert_eq!(config.noise_subtraction, thesis.noise_subtraction);
        config.validate().unwrap();
    }

    /// A 4-D pump-and-tank plant's logs: two tank levels and two flows in [0, 1], three
    /// pump settings; next states drift smoothly with noise of variance `0.05² = 0.0025`
    /// on every coordinate, rewards are a smooth tracking cost with noise of variance
    /// `0.02² = 0.0004`. Three sources of 400 records from uniform states.
    fn four_d_logs() -> Vec<Vec<Transition<[f64; 4], f64>>> {
        let mut rng = ChaCha8Rng::seed_from_u64(40);
        (0..3)
            .map(|k| {
                (0..400)
                    .map(|i| {
                        let s = [(); 4].map(|_| crate::rng::uniform::<f64, _>(&mut rng));
                        let a = i % 3;
                        let pump = 0.5 * a as f64 - 0.5;
                        let drift = [
                            0.1 * s[2] - 0.05 * s[0] + 0.05 * pump,
                            0.05 * s[0] - 0.1 * s[3] + 0.02 * k as f64,
                            0.2 * (pump - s[2]),
                            0.1 * (s[0] - s[1]) - 0.05 * s[3],
                        ];
                        let mut next = s;
                        for (n, d) in next.iter_mut().zip(drift) {
                            *n += d + 0.05 * crate::rng::standard_normal::<f64, _>(&mut rng);
                        }
                        let cost = 0.5 * (s[0] - 0.6).powi(2)
                            + 0.3 * (s[1] - 0.4).powi(2)
                            + 0.1 * pump.abs()
                            + 0.05 * k as f64 * s[2];
                        Transition {
                            state: s,
                            action: a,
                            reward: -cost + 0.02 * crate::rng::standard_normal::<f64, _>(&mut rng),
                            next_state: next,
                            absorbing: false,
                        }
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn the_noise_of_a_four_dimensional_plant_is_measured_within_a_factor_of_two() {
        let logs = four_d_logs();
        let slices: Vec<&[Transition<[f64; 4], f64>]> = logs.iter().map(|l| &l[..]).collect();
        let scales = SourceScales::measure(&slices).unwrap();
        let within = |got: f64, truth: f64| got > truth / 2.0 && got < truth * 2.0;
        assert!(
            within(scales.reward_noise, 0.0004),
            "reward noise {}",
            scales.reward_noise
        );
        for (k, &nu) in scales.next_state_noise.iter().enumerate() {
            assert!(within(nu, 0.0025), "next-state noise {k}: {nu}");
        }
    }

    #[test]
    fn wide_inputs_search_one_tied_length_scale() {
        let records: Vec<Transition<[f64; 6], f64>> = (0..50)
            .map(|i| Transition {
                state: [i as f64, 0.0, 1.0, 2.0 * i as f64, 3.0, 4.0],
                action: i % 2,
                reward: i as f64,
                next_state: [i as f64; 6],
                absorbing: false,
            })
            .collect();
        let scales = SourceScales::measure(&[&records]).unwrap();
        let training = scales.gp_training::<7>().unwrap();
        assert!(training.search.isotropic);
        let (lo, hi) = training.bounds.length_scales[0];
        assert!(training.bounds.length_scales.iter().all(|&b| b == (lo, hi)));
        assert_eq!(
            training.search.max_evaluations,
            3 * SCALED_EVALUATIONS_PER_PARAMETER
        );
        let v = scales.transition_weights().unwrap();
        assert!(v.noise_variance() > 0.0);
    }
}
