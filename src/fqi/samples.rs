//! The data of a weighted FQI fit: sample sets with their weights and replacement rewards,
//! checked once before any approximator changes.

use super::FqiConfig;
use super::config::EmptyCells;
use crate::error::ensure_finite;
use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::Transition;

/// A slice of samples with optional per-sample weights (absent = all 1) and optional
/// rewards that replace the samples' own (absent = their own).
///
/// AWFQI passes the target samples (unweighted) and one set per source, so the records
/// never need to be copied into one buffer; adaptive AWFQI's relabelling passes the
/// sources' rewards as the target sees them beside the untouched records.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleSet<'a, T, const D: usize> {
    samples: &'a [Transition<[T; D], T>],
    reward_weights: Option<&'a [T]>,
    transition_weights: Option<&'a [T]>,
    rewards: Option<&'a [T]>,
}

impl<'a, T: Real, const D: usize> SampleSet<'a, T, D> {
    /// Samples with weight 1 everywhere.
    pub fn unweighted(samples: &'a [Transition<[T; D], T>]) -> Self {
        Self {
            samples,
            reward_weights: None,
            transition_weights: None,
            rewards: None,
        }
    }

    /// Samples with reward weights (iteration 1) and transition weights (iterations ≥ 2);
    /// `None` means all 1. Lengths are checked by the fit.
    pub fn weighted(
        samples: &'a [Transition<[T; D], T>],
        reward_weights: Option<&'a [T]>,
        transition_weights: Option<&'a [T]>,
    ) -> Self {
        Self {
            samples,
            reward_weights,
            transition_weights,
            rewards: None,
        }
    }

    /// The same set fitted on `rewards` (one per sample, in order) instead of the samples'
    /// own rewards; `None` keeps their own. The length and finiteness are checked by the
    /// fit, like the weights'.
    pub fn with_rewards(self, rewards: Option<&'a [T]>) -> Self {
        Self { rewards, ..self }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// `true` when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    pub(super) fn validate(&self, actions: usize) -> Result<()> {
        if let Some(r) = self.rewards {
            if r.len() != self.samples.len() {
                return Err(Error::InvalidParameter {
                    parameter: "rewards",
                });
            }
            crate::error::ensure_all_finite(r, "reward")?;
        }
        for (weights, name) in [
            (self.reward_weights, "reward_weights"),
            (self.transition_weights, "transition_weights"),
        ] {
            if let Some(w) = weights {
                if w.len() != self.samples.len() {
                    return Err(Error::InvalidParameter { parameter: name });
                }
                for &x in w {
                    ensure_finite(x, name)?;
                    if x < T::ZERO {
                        return Err(Error::InvalidParameter { parameter: name });
                    }
                }
            }
        }
        for s in self.samples {
            if s.action >= actions {
                return Err(Error::OutOfRange {
                    parameter: "action",
                });
            }
            ensure_finite(s.reward, "reward")?;
            crate::error::ensure_all_finite(&s.state, "state")?;
            crate::error::ensure_all_finite(&s.next_state, "next_state")?;
        }
        Ok(())
    }

    /// `(sample, reward, w_r, w_s)`: the reward is the replacement when there is one.
    pub(super) fn iter(self) -> impl Iterator<Item = Weighted<'a, T, D>> {
        self.samples.iter().enumerate().map(move |(i, s)| {
            let pick = |w: Option<&[T]>| w.and_then(|w| w.get(i).copied()).unwrap_or(T::ONE);
            let reward = self
                .rewards
                .and_then(|r| r.get(i).copied())
                .unwrap_or(s.reward);
            (
                s,
                reward,
                pick(self.reward_weights),
                pick(self.transition_weights),
            )
        })
    }
}

/// One sample of a fit as `(sample, reward, w_r, w_s)`.
pub(super) type Weighted<'a, T, const D: usize> = (&'a Transition<[T; D], T>, T, T, T);

/// Every sample of `sets`, set after set, as [`SampleSet::iter`] gives them.
pub(super) fn each<'s, T: Real + 's, const D: usize>(
    sets: impl Iterator<Item = SampleSet<'s, T, D>>,
) -> impl Iterator<Item = Weighted<'s, T, D>> {
    sets.flat_map(SampleSet::iter)
}

/// Writes every sample of `sets` into `slots` as `record` makes it, in order (the records
/// of the approximators that keep them; the fit has checked that they fit).
pub(super) fn load<'s, X, T: Real + 's, const D: usize>(
    slots: &mut [X],
    sets: impl Iterator<Item = SampleSet<'s, T, D>>,
    record: impl Fn(Weighted<'s, T, D>) -> X,
) {
    for (slot, sample) in slots.iter_mut().zip(each(sets)) {
        *slot = record(sample);
    }
}

/// Rejects finite inputs whose fit could overflow `T`: every sum of the fit is bounded by
/// `Σ w_r·|r|` or by `(Σ w_r + Σ w_s) · max|Q|`, and `|Q_k| ≤ k · max(|r|, |fill value|)`
/// (weighted means never exceed their largest term), so when these bounds are finite (with
/// a factor 4 for rounding) so is every value the fit computes.
pub(super) fn check_magnitudes<'s, T: Real + 's, const D: usize>(
    sets: impl Iterator<Item = SampleSet<'s, T, D>>,
    config: &FqiConfig<T>,
) -> Result<()> {
    let mut reward_mass = T::ZERO;
    let mut weight_mass = T::ZERO;
    let mut largest = match config.empty_cells() {
        EmptyCells::Value(v) => v.abs(),
        _ => T::ZERO,
    };
    for (_, reward, w_r, w_s) in each(sets) {
        reward_mass += w_r * reward.abs();
        weight_mass += w_r + w_s;
        largest = largest.max(reward.abs());
    }
    let bound =
        largest * T::from_usize(config.iterations()) * (T::ONE + weight_mass) * T::from_f64(4.0);
    if reward_mass.is_finite() && bound.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            parameter: "reward",
        })
    }
}
