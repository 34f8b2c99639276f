//! The drawn queries' distribution over a random subset of the candidate rows.
//!
//! A row's score is `relevance × (surprise + disagreement) × uncertainty`, mixed with a
//! coverage floor: `p = (1 − floor)·score/Σscore + floor·relevance/Σrelevance` (module
//! docs of [`crate::adaptive`]). The subset is drawn afresh before each sub-batch's
//! queries; its rows and their factors live in one [`Candidate`] per slot, so the scoring is
//! two passes over the slots, and each drawn query a scan of their probabilities.

use crate::error::Result;

use crate::float::Real;

/// One candidate row of a sub-batch and its score's factors. Size: one `usize` and 3 `T`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Candidate<T> {
    /// The row's index in the candidate set.
    pub row: usize,
    /// Closeness to this step's verified greedy paths, in (0, 1] (1 when off).
    pub relevance: T,
    /// First `surprise + disagreement`, then, once the batch is known, the whole score.
    pub score: T,
    /// The residual GP's noisy predictive variance at the row (0 without a residual GP).
    pub variance: T,
}

impl<T: Real> Candidate<T> {
    /// The all-zero slot (for `.bss`).
    pub const EMPTY: Self = Self {
        row: 0,
        relevance: T::ZERO,
        score: T::ZERO,
        variance: T::ZERO,
    };
}

/// `exp(−d²/2)` with `d` the distance from `state` to the nearest of `path` in units of
/// `width_d = (upper_d − lower_d)·width` per coordinate; 1 for an empty path.
pub fn relevance<T: Real, const D: usize>(
    state: &[T; D],
    path: &[[T; D]],
    bounds: &[(T, T); D],
    width: T,
) -> T {
    if path.is_empty() {
        return T::ONE;
    }
    let mut nearest = T::INFINITY;
    for p in path {
        let mut d2 = T::ZERO;
        for ((&s, &q), &(lo, hi)) in state.iter().zip(p).zip(bounds) {
            d2 += ((s - q) / ((hi - lo) * width)).squared();
        }
        nearest = nearest.min(d2);
    }
    (-(nearest / (T::ONE + T::ONE))).exp()
}

/// The weighted mean and variance of values `(μₖ, πₖ)` (weights summing to 1), computed
/// in one pass on values shifted by the first, so that equal values give exactly 0;
/// `(0, 0)` without values. Stops at the first error.
pub fn weighted_spread<T: Real>(values: impl Iterator<Item = Result<(T, T)>>) -> Result<(T, T)> {
    let mut first = None;
    let mut mean = T::ZERO;
    let mut second = T::ZERO;
    for value in values {
        let (m, p) = value?;
        let d = m - *first.get_or_insert(m);
        mean += p * d;
        second += p * d * d;
    }
    Ok((
        first.unwrap_or(T::ZERO) + mean,
        (second - mean * mean).max(T::ZERO),
    ))
}

/// Turns the slots' factors into scores in place (`score ← relevance·score·uncertainty`,
/// `uncertainty = min(std²/signal, 1)` from `std` when given) and returns
/// `(Σscore, Σrelevance)`.
pub fn finish_scores<T: Real>(
    slots: &mut [Candidate<T>],
    uncertainty: Option<&dyn Fn(T) -> T>,
) -> (T, T) {
    let mut total = T::ZERO;
    let mut relevance = T::ZERO;
    for c in slots.iter_mut() {
        let u = uncertainty.map_or(T::ONE, |f| f(c.variance));
        c.score = c.relevance * c.score * u;
        total += c.score;
        relevance += c.relevance;
    }
    (total, relevance)
}

/// The drawing probability of a slot (unnormalised: the draw normalises): the
/// score's share mixed with the floor's relevance share; without any score, the relevance
/// share alone, and uniform if even that is 0.
pub fn probability<T: Real>(c: &Candidate<T>, totals: (T, T), floor: T, slots: usize) -> T {
    let (total, relevance) = totals;
    let (drawn, floor) = if total > T::ZERO {
        (c.score / total, floor)
    } else {
        (T::ZERO, T::ONE)
    };
    let spread = if relevance > T::ZERO {
        c.relevance / relevance
    } else {
        T::ONE / T::from_usize(slots.max(1))
    };
    (T::ONE - floor) * drawn + floor * spread
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relevance_is_a_gaussian_of_the_scaled_distance_to_the_nearest_path_state() {
        let bounds = [(0.0, 10.0); 2];
        assert_eq!(relevance(&[3.0, 3.0], &[], &bounds, 0.1), 1.0);
        // Nearest state 1 unit away in x, width 1: exp(−½).
        let path = [[9.0, 9.0], [2.0, 3.0]];
        let r = relevance(&[3.0, 3.0], &path, &bounds, 0.1);
        assert!((r - (-0.5f64).exp()).abs() < 1e-12);
        // Width 2 (range 20): d = 0.5, exp(−1/8).
        let r = relevance(&[3.0, 3.0], &path, &[(0.0, 20.0); 2], 0.1);
        assert!((r - (-0.125f64).exp()).abs() < 1e-12);
    }

    #[test]
    fn spread_is_the_weighted_population_variance() {
        // Means −1, −3 with weights ¾, ¼: mean −1.5, variance ¾·0.25 + ¼·2.25 = 0.75.
        let (m, v) = weighted_spread([Ok((-1.0, 0.75)), Ok((-3.0, 0.25))].into_iter()).unwrap();
        assert!((m + 1.5).abs() < 1e-12 && (v - 0.75).abs() < 1e-12);
        let (m, v) =
            weighted_spread([Ok((-100.0f32, 0.5)), Ok((-100.0, 0.5))].into_iter()).unwrap();
        assert_eq!((m, v), (-100.0, 0.0));
        let e = crate::error::Error::EmptyData;
        assert_eq!(
            weighted_spread([Ok((1.0, 1.0)), Err(e)].into_iter()),
            Err(e)
        );
    }

    #[test]
    fn probabilities_mix_the_score_with_the_floor_and_sum_to_one() {
        let mut slots = [
            Candidate {
                row: 0,
                relevance: 1.0,
                score: 2.0,
                variance: 0.5,
            },
            Candidate {
                row: 7,
                relevance: 0.5,
                score: 4.0,
                variance: 1.0,
            },
        ];
        // Uncertainty = variance here: scores 1·2·0.5 = 1 and 0.5·4·1 = 2.
        let u = |v: f64| v;
        let totals = finish_scores(&mut slots, Some(&u));
        assert_eq!(totals, (3.0, 1.5));
        let p = slots.map(|c| probability(&c, totals, 0.1, 2));
        assert!((p[0] - (0.9 / 3.0 + 0.1 * (1.0 / 1.5))).abs() < 1e-12);
        assert!((p[0] + p[1] - 1.0).abs() < 1e-12);
        // No score at all: the relevance share alone.
        let zero = (0.0, 1.5);
        assert!((probability(&slots[1], zero, 0.1, 2) - 0.5 / 1.5).abs() < 1e-12);
        // Not even relevance: uniform.
        assert_eq!(probability(&slots[1], (0.0, 0.0), 0.1, 2), 0.5);
    }
}
