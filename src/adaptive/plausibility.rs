//! How plausible each source is as a model of the target, from the target's answers.
//!
//! `π_k ∝ exp(−Σᵢ e²ᵢₖ / (2 v_r))`, `e²ᵢₖ` the squared difference between target record
//! `i`'s reward and source `k`'s mean at the record, clipped at [`CLIP`]` · v_r` so that a
//! feature every source lacks does not decide between them; a record whose absorbing flag
//! differs from that of source `k`'s nearest record (same action) costs the clip. The
//! errors depend on the record and the (fixed) source means only, so each source keeps one
//! running sum, updated once per query: O(sources) memory whatever the number of records.

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::Transition;

/// The clip of a squared reward error, in units of the estimator's reward variance `v_r`.
pub const CLIP: f64 = 25.0;

/// One source's evidence: the running sum of its clipped squared errors and its
/// plausibility as of the last re-plan. 2 `T`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SourceBelief<T> {
    /// `Σᵢ e²ᵢₖ` over the target records so far.
    pub squared_errors: T,
    /// `π_k` (the beliefs sum to 1) as of the last re-plan.
    pub plausibility: T,
}

impl<T: Real> SourceBelief<T> {
    /// No evidence yet (also the all-zero value for `.bss`).
    pub const EMPTY: Self = Self {
        squared_errors: T::ZERO,
        plausibility: T::ZERO,
    };
}

/// Resets every belief to no evidence and the uniform plausibility `1/m`.
pub fn reset<T: Real>(beliefs: &mut [SourceBelief<T>]) {
    let uniform = T::ONE / T::from_usize(beliefs.len().max(1));
    for b in beliefs {
        *b = SourceBelief {
            squared_errors: T::ZERO,
            plausibility: uniform,
        };
    }
}

/// The clipped squared error of a target record against a source: `min((r − μ)², CLIP·v)`,
/// or the clip when the source's nearest record ends its episode where the record does not
/// (or the other way round).
pub fn clipped_error<T: Real>(reward: T, source_mean: T, ends_agree: bool, v: T) -> T {
    let clip = T::from_f64(CLIP) * v;
    if ends_agree {
        (reward - source_mean).squared().min(clip)
    } else {
        clip
    }
}

/// Whether the record of `records` nearest to `(state, action)` — same action, each
/// coordinate's distance divided by its range `upper − lower` — is absorbing (`false`
/// when no record has the action; the first of equally near records counts).
pub fn nearest_ends<T: Real, const D: usize>(
    records: &[Transition<[T; D], T>],
    state: &[T; D],
    action: usize,
    bounds: &[(T, T); D],
) -> bool {
    let mut best = (T::INFINITY, false);
    for r in records.iter().filter(|r| r.action == action) {
        let mut d = T::ZERO;
        for ((&p, &q), &(lo, hi)) in r.state.iter().zip(state).zip(bounds) {
            d += ((p - q) / (hi - lo)).squared();
        }
        if d < best.0 {
            best = (d, r.absorbing);
        }
    }
    best.1
}

/// Sets every plausibility from the running error sums: `π_k ∝ exp(−Σe²ₖ/(2v))`, computed
/// relative to the best source so nothing underflows to an all-zero vector.
///
/// Errors: no sources ([`Error::EmptyData`]); a non-finite sum or `v ≤ 0`
/// ([`Error::NonFinite`] / [`Error::InvalidParameter`] `reward variance`).
pub fn update<T: Real>(beliefs: &mut [SourceBelief<T>], v: T) -> Result<()> {
    if beliefs.is_empty() {
        return Err(Error::EmptyData);
    }
    if v.is_nan() || v <= T::ZERO {
        return Err(Error::InvalidParameter {
            parameter: "reward variance",
        });
    }
    let mut best = T::INFINITY;
    for b in beliefs.iter() {
        crate::error::ensure_finite(b.squared_errors, "squared_errors")?;
        best = best.min(b.squared_errors);
    }
    let two_v = v + v;
    let mut total = T::ZERO;
    for b in beliefs.iter_mut() {
        b.plausibility = (-(b.squared_errors - best) / two_v).exp();
        total += b.plausibility;
    }
    // total ≥ 1: the best source contributes exp(0).
    for b in beliefs.iter_mut() {
        b.plausibility /= total;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plausibility_follows_the_clipped_likelihood() {
        // Source 0 matches, source 1 is off by 1 on two records: log-ratio 2·1/(2·0.5) = 2.
        let mut b = [SourceBelief::<f64>::EMPTY; 2];
        b[1].squared_errors = 2.0;
        update(&mut b, 0.5).unwrap();
        let want = 1.0 / (1.0 + (-2.0f64).exp());
        assert!((b[0].plausibility - want).abs() < 1e-12);
        assert!((b[0].plausibility + b[1].plausibility - 1.0).abs() < 1e-12);
        // Equal (clipped) errors, however large: no preference, and no underflow.
        let mut b = [SourceBelief::<f32>::EMPTY; 3];
        for x in &mut b {
            x.squared_errors = 1.0e4;
        }
        update(&mut b, 0.1).unwrap();
        for x in &b {
            assert!((x.plausibility - 1.0 / 3.0).abs() < 1e-6);
        }
        assert_eq!(update::<f64>(&mut [], 0.1), Err(Error::EmptyData));
        assert!(update(&mut [SourceBelief::<f64>::EMPTY], 0.0).is_err());
    }

    #[test]
    fn errors_are_clipped_and_a_disagreeing_end_costs_the_clip() {
        assert_eq!(clipped_error(-1.0, -1.5, true, 0.1), 0.25);
        assert!((clipped_error(-1.0, -50.0, true, 0.1) - 2.5).abs() < 1e-12);
        assert!((clipped_error(-1.0, -1.0, false, 0.1) - 2.5).abs() < 1e-12);
    }

    #[test]
    fn the_nearest_record_of_the_same_action_decides_the_end() {
        let r = |x: f64, y: f64, action: usize, absorbing: bool| Transition {
            state: [x, y],
            action,
            reward: 0.0,
            next_state: [x, y],
            absorbing,
        };
        let records = [
            r(9.0, 9.0, 0, true),
            r(1.0, 1.0, 0, false),
            r(9.1, 9.1, 1, false),
        ];
        let bounds = [(0.0, 10.0); 2];
        assert!(nearest_ends(&records, &[8.5, 9.0], 0, &bounds));
        assert!(!nearest_ends(&records, &[2.0, 2.0], 0, &bounds));
        // Action 1's only record is not absorbing, however close action 0's is.
        assert!(!nearest_ends(&records, &[9.0, 9.0], 1, &bounds));
        assert!(!nearest_ends(&records, &[9.0, 9.0], 3, &bounds));
        // Distances are in units of each range: with y's range 10× smaller, the record
        // 0.5 away in y (0.25) is farther than the one 1 away in x (0.01).
        let records = [r(0.0, 0.5, 0, true), r(1.0, 0.0, 0, false)];
        assert!(nearest_ends(&records, &[0.0, 0.0], 0, &[(0.0, 10.0); 2]));
        assert!(!nearest_ends(
            &records,
            &[0.0, 0.0],
            0,
            &[(0.0, 10.0), (0.0, 1.0)]
        ));
    }
}
