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
///   record, the nearest record of the same source and action (distance in units of the
///   spans), and `ν = median(Δ²) / (2 · 0.4549)` over those pairs' differences `Δ` — the
///   noise variance for Gaussian noise (`Δ²/2ν` is then χ²₁, median 0.4549), plus what the
///   output varies over the distance to a neighbour; the median keeps a jump (a puddle's
///   edge, a flood threshold) from dominating it. Three passes of O(n²/A) distance
///   computations per source and output, once, in no memory (a microcontroller measures
///   700 records of a 3-D plant in well under a second).
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

/// The local noise `median(Δ²)/(2·0.4549)` of `output` over each record's nearest record of
/// the same source and action (distance in units of `span`); 0 without any pair.
///
/// Nothing is stored: the median is located by two histogram passes over the pairs, the
/// first over `log₂(Δ²/max)` in half-octave bins (64 octaves; smaller values in the first
/// bin), the second linear inside the bin that holds the median, whose midpoint is taken
/// (relative error below 0.3 %). Three passes over the pairs in all.
fn local_noise<T: Real, const D: usize>(
    sources: &[&[Transition<[T; D], T>]],
    span: &[T; D],
    output: impl Fn(&Transition<[T; D], T>) -> T,
) -> T {
    // The squared output difference of every record to its nearest neighbour.
    let visit = |f: &mut dyn FnMut(T)| {
        for source in sources {
            for (i, r) in source.iter().enumerate() {
                let mut best: Option<(T, T)> = None;
                for (j, q) in source.iter().enumerate() {
                    if i == j || q.action != r.action {
                        continue;
                    }
                    let mut d2 = T::ZERO;
                    for ((&a, &b), &s) in r.state.iter().zip(&q.state).zip(span) {
                        d2 += ((a - b) / s).squared();
                    }
                    if best.is_none_or(|(bd, _)| d2 < bd) {
                        best = Some((d2, (output(r) - output(q)).squared()));
                    }
                }
                if let Some((_, delta2)) = best {
                    f(delta2);
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

    /// The nearest-neighbour squared differences, by brute force with a sort: the median
    /// the histogram passes must find.
    fn brute_median(sources: &[&[Transition<[f64; 2], f64>]], span: [f64; 2]) -> f64 {
        let mut all = Vec::new();
        for s in sources {
            for (i, r) in s.iter().enumerate() {
                let best = s
                    .iter()
                    .enumerate()
                    .filter(|&(j, q)| j != i && q.action == r.action)
                    .map(|(_, q)| {
                        let d2: f64 = (0..2)
                            .map(|k| ((r.state[k] - q.state[k]) / span[k]).powi(2))
                            .sum();
                        (d2, (r.reward - q.reward).powi(2))
                    })
                    .fold(None, |b: Option<(f64, f64)>, x| match b {
                        Some(b) if b.0 <= x.0 => Some(b),
                        _ => Some(x),
                    });
                if let Some((_, delta2)) = best {
                    all.push(delta2);
                }
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
    fn the_local_noise_is_the_median_of_the_neighbours_differences() {
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
        // x' = x + 1 exactly: the next states differ only by the neighbours' distance
        // (about 1/2000 apart), y' not at all.
        assert!(scales.next_state_noise[0] < 1e-5);
        assert_eq!(scales.next_state_noise[1], 0.0);
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
