//! The Bayesian belief over K known candidate MDPs (spec §10.2 step 4), kept in log space.

use crate::error::{Error, Result};
use crate::float::Real;
use crate::float::log_sum_exp;
use crate::model::{FiniteMdp, Transition};

/// ln of one observation's likelihood under `mdp`:
/// ln p(s′ | s, a) + ln 𝒩(r; r(s, a), v(s, a)).
///
/// −∞ when the transition is impossible under `mdp` (p = 0), or when the reward is so far
/// from the mean that its log-density underflows.
///
/// Errors: model errors (indices out of range), a non-finite `reward`, a non-finite or
/// negative probability, a non-finite mean or a variance that is not finite and positive.
pub fn log_likelihood<T: Real, M: FiniteMdp<T>>(
    mdp: &M,
    state: usize,
    action: usize,
    next_state: usize,
    reward: T,
) -> Result<T> {
    crate::error::ensure_finite(reward, "reward")?;
    let p = mdp.transition_probability(state, action, next_state)?;
    crate::error::ensure_finite(p, "transition_probability")?;
    if p < T::ZERO {
        return Err(Error::InvalidParameter {
            parameter: "transition_probability",
        });
    }
    let mean = crate::error::ensure_finite(mdp.reward_mean(state, action)?, "reward_mean")?;
    let variance = positive_variance(mdp.reward_variance(state, action)?)?;
    if p == T::ZERO {
        return Ok(T::NEG_INFINITY);
    }
    // Standardise first so that (r − μ)² overflows only for absurd rewards.
    let z = (reward - mean) / variance.sqrt();
    let half = T::from_f64(0.5);
    let two_pi = T::from_f64(2.0) * T::PI;
    Ok(p.ln() - half * z * z - half * (two_pi * variance).ln())
}

/// Checks a reward variance: finite and strictly positive.
pub(crate) fn positive_variance<T: Real>(v: T) -> Result<T> {
    crate::error::ensure_finite(v, "reward_variance")?;
    if v > T::ZERO {
        Ok(v)
    } else {
        Err(Error::InvalidParameter {
            parameter: "reward_variance",
        })
    }
}

/// A probability distribution over `len ≤ K` candidate MDPs, stored as normalised
/// log-probabilities so that products of thousands of likelihoods neither underflow nor
/// overflow.
///
/// Memory: `2·K·size_of::<T>()` bytes plus two words and a flag (the prior is kept for resets and
/// for the spec's fall-back). Capacity is the const generic `K`; more candidates than `K`
/// is [`Error::CapacityExceeded`].
///
/// Observations are applied one at a time; the result equals the batch formula of
/// spec §10.2 (the order of updates only changes rounding). If an observation has
/// likelihood 0 under every candidate that still has mass, the batch posterior is 0/0 and
/// the spec keeps the prior b⁰: the belief then returns to b⁰, is marked
/// [`contradicted`](Self::is_contradicted), and ignores further observations (as the batch
/// formula would, whose product stays 0) until [`reset`](Self::reset).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Belief<T, const K: usize> {
    log_prior: [T; K],
    log_posterior: [T; K],
    len: usize,
    observations: usize,
    contradicted: bool,
}

impl<T: Real, const K: usize> Belief<T, K> {
    /// The uniform prior b⁰_θ = 1/`len` over `len` candidates.
    ///
    /// Errors: `len == 0` ([`Error::EmptyData`]), `len > K`
    /// ([`Error::CapacityExceeded`]).
    pub fn uniform(len: usize) -> Result<Self> {
        Self::check_len(len)?;
        let log_p = -T::from_usize(len).ln();
        let mut log_prior = [T::NEG_INFINITY; K];
        log_prior
            .iter_mut()
            .take(len)
            .for_each(|slot| *slot = log_p);
        Ok(Self {
            log_prior,
            log_posterior: log_prior,
            len,
            observations: 0,
            contradicted: false,
        })
    }

    /// A prior proportional to the non-negative `weights` (one per candidate; they need
    /// not sum to 1).
    ///
    /// Errors: an empty slice, more than `K` weights, a non-finite or negative weight, or
    /// all weights zero.
    pub fn from_weights(weights: &[T]) -> Result<Self> {
        Self::check_len(weights.len())?;
        let largest = crate::rng::validate_weights(weights)?;
        let mut log_prior = [T::NEG_INFINITY; K];
        for (slot, &w) in log_prior.iter_mut().zip(weights) {
            *slot = (w / largest).ln();
        }
        let total = log_sum_exp(log_prior.get(..weights.len()).unwrap_or(&[]));
        log_prior
            .iter_mut()
            .take(weights.len())
            .for_each(|l| *l -= total);
        Ok(Self {
            log_prior,
            log_posterior: log_prior,
            len: weights.len(),
            observations: 0,
            contradicted: false,
        })
    }

    fn check_len(len: usize) -> Result<()> {
        if len == 0 {
            Err(Error::EmptyData)
        } else if len > K {
            Err(Error::CapacityExceeded { capacity: K })
        } else {
            Ok(())
        }
    }

    /// Number of candidates.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always `false`: a belief has at least one candidate. (Present for API symmetry.)
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Observations applied since construction or the last [`reset`](Self::reset).
    pub fn observations(&self) -> usize {
        self.observations
    }

    /// `true` after an observation that every candidate with mass declared impossible;
    /// the belief is then b⁰ (spec §10.2's fall-back).
    pub fn is_contradicted(&self) -> bool {
        self.contradicted
    }

    /// The normalised log-probabilities ln b_θ, one per candidate (−∞ for zero mass).
    pub fn log_probabilities(&self) -> &[T] {
        self.log_posterior.get(..self.len).unwrap_or(&[])
    }

    /// The normalised log prior ln b⁰_θ.
    pub fn log_prior(&self) -> &[T] {
        self.log_prior.get(..self.len).unwrap_or(&[])
    }

    /// The probabilities b_θ written into `out` (exactly one entry per candidate).
    ///
    /// Errors: `out` shorter ([`Error::CapacityExceeded`]) or longer
    /// ([`Error::InvalidParameter`]) than [`len`](Self::len).
    pub fn probabilities(&self, out: &mut [T]) -> Result<()> {
        crate::planning::check_len(out.len(), self.len, "probabilities")?;
        for (o, &l) in out.iter_mut().zip(self.log_probabilities()) {
            *o = l.exp();
        }
        Ok(())
    }

    /// The probabilities as a fixed array; entries past [`len`](Self::len) are 0.
    pub fn probability_array(&self) -> [T; K] {
        let mut out = [T::ZERO; K];
        for (o, &l) in out.iter_mut().zip(self.log_probabilities()) {
            *o = l.exp();
        }
        out
    }

    /// The maximum-a-posteriori candidate θ̂ = argmax_θ b_θ, ties to the smallest index.
    pub fn map(&self) -> usize {
        let mut best = 0;
        let mut best_value = T::NEG_INFINITY;
        for (i, &l) in self.log_probabilities().iter().enumerate() {
            if l > best_value {
                best = i;
                best_value = l;
            }
        }
        best
    }

    /// Shannon entropy −Σ_θ b_θ ln b_θ in nats (0 ln 0 = 0): ln K for the uniform belief,
    /// 0 once one candidate holds all the mass.
    pub fn entropy(&self) -> T {
        let h: T = self
            .log_probabilities()
            .iter()
            .filter(|l| l.is_finite())
            .map(|&l| -(l.exp() * l))
            .sum();
        h.max(T::ZERO)
    }

    /// Returns to the prior and forgets all observations.
    pub fn reset(&mut self) {
        self.log_posterior = self.log_prior;
        self.observations = 0;
        self.contradicted = false;
    }

    /// Bayes' rule with one observation (s, a, s′, r):
    /// ln b̃_θ = ln b_θ + ln p_θ(s′|s, a) + ln 𝒩(r; r_θ(s, a), v_θ(s, a)), then
    /// normalised by log-sum-exp.
    ///
    /// Errors: `candidates.len()` differs from [`len`](Self::len)
    /// ([`Error::InvalidParameter`] naming `candidates`), and any error of
    /// [`log_likelihood`]. The belief is unchanged on error: all likelihoods are computed
    /// before anything is written.
    pub fn update<M: FiniteMdp<T>>(
        &mut self,
        candidates: &[M],
        state: usize,
        action: usize,
        next_state: usize,
        reward: T,
    ) -> Result<()> {
        if candidates.len() != self.len {
            return Err(Error::InvalidParameter {
                parameter: "candidates",
            });
        }
        let mut log_l = [T::NEG_INFINITY; K];
        for (slot, mdp) in log_l.iter_mut().zip(candidates) {
            *slot = log_likelihood(mdp, state, action, next_state, reward)?;
        }
        if self.contradicted {
            self.observations = self.observations.saturating_add(1);
            return Ok(());
        }
        // Shift the log-likelihoods by their maximum first: only ratios matter, and
        // adding values of order −10⁴ to log-probabilities of order 1 would otherwise
        // cost f32 its last digits of the posterior (spacing 0.004 at 4·10⁴).
        let shift = log_l
            .iter()
            .take(self.len)
            .copied()
            .fold(T::NEG_INFINITY, T::max);
        let mut next = self.log_posterior;
        for (n, &l) in next.iter_mut().zip(log_l.iter()).take(self.len) {
            *n += if shift.is_finite() { l - shift } else { l };
        }
        // Normalise relative to the largest entry: n − max is exact for nearby values
        // (Sterbenz), so the normaliser is computed on numbers of order 1.
        let top = next
            .iter()
            .take(self.len)
            .copied()
            .fold(T::NEG_INFINITY, T::max);
        if top.is_finite() {
            next.iter_mut().take(self.len).for_each(|n| *n -= top);
        }
        let live = next.get(..self.len).unwrap_or(&[]);
        let total = log_sum_exp(live);
        if total == T::NEG_INFINITY {
            self.log_posterior = self.log_prior;
            self.contradicted = true;
        } else if total.is_finite() {
            for (p, &n) in self
                .log_posterior
                .iter_mut()
                .zip(next.iter())
                .take(self.len)
            {
                *p = n - total;
            }
        } else {
            // +∞ or NaN cannot arise from finite log-probabilities and log-likelihoods
            // that are finite or −∞; refuse rather than corrupt the belief.
            return Err(Error::NonFinite {
                parameter: "log_likelihood",
            });
        }
        self.observations = self.observations.saturating_add(1);
        Ok(())
    }

    /// [`update`](Self::update) with a transition returned by a generative model.
    pub fn observe<M: FiniteMdp<T>>(
        &mut self,
        candidates: &[M],
        transition: &Transition<usize, T>,
    ) -> Result<()> {
        self.update(
            candidates,
            transition.state,
            transition.action,
            transition.next_state,
            transition.reward,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::GridWorld;
    use crate::model::GenerativeModel;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    #[test]
    fn log_likelihood_is_the_gaussian_log_density() {
        let g = GridWorld::<f64>::thesis(3, false).unwrap();
        // At the goal (5,5) = 55 the mean is 1, variance 0.25; move x+1 leads to 56.
        let r = 0.3;
        let want = -(r - 1.0f64).powi(2) / 0.5 - 0.5 * (2.0 * core::f64::consts::PI * 0.25).ln();
        let got = log_likelihood(&g, 55, 0, 56, r).unwrap();
        assert!((got - want).abs() < 1e-14);
        assert_eq!(log_likelihood(&g, 55, 0, 57, r).unwrap(), f64::NEG_INFINITY);
        assert_eq!(
            log_likelihood(&g, 55, 0, 56, f64::NAN),
            Err(Error::NonFinite {
                parameter: "reward"
            })
        );
    }

    #[test]
    fn uniform_prior_has_maximal_entropy_and_first_index_map() {
        let b = Belief::<f32, 8>::uniform(4).unwrap();
        assert_eq!(b.len(), 4);
        assert!((b.entropy() - 4f32.ln()).abs() < 1e-6);
        assert_eq!(b.map(), 0, "ties go to the smallest index");
        let mut p = [0.0f32; 4];
        b.probabilities(&mut p).unwrap();
        assert!(p.iter().all(|&x| (x - 0.25).abs() < 1e-7));
        assert_eq!(
            Belief::<f32, 4>::uniform(5),
            Err(Error::CapacityExceeded { capacity: 4 })
        );
        assert_eq!(Belief::<f32, 4>::uniform(0), Err(Error::EmptyData));
        assert!(b.probabilities(&mut [0.0; 3]).is_err());
    }

    #[test]
    fn weighted_prior_is_normalised() {
        let b = Belief::<f64, 4>::from_weights(&[1.0, 3.0, 0.0]).unwrap();
        let p = b.probability_array();
        assert!((p[0] - 0.25).abs() < 1e-15 && (p[1] - 0.75).abs() < 1e-15);
        assert_eq!(p[2], 0.0);
        assert_eq!(b.map(), 1);
        assert!(Belief::<f64, 4>::from_weights(&[0.0, 0.0]).is_err());
        assert!(Belief::<f64, 4>::from_weights(&[1.0, -1.0]).is_err());
        assert!(Belief::<f64, 2>::from_weights(&[1.0, 1.0, 1.0]).is_err());
    }

    #[test]
    fn one_observation_matches_bayes_rule_by_hand() {
        // Query the goal of candidate 0, (9,9) = 99, and observe reward 1.0.
        let c = GridWorld::<f64>::thesis_candidates(false);
        let mut b = Belief::<f64, 4>::uniform(4).unwrap();
        b.update(&c, 99, 2, 99, 1.0).unwrap();
        // Likelihood ratio candidate 0 vs the others: exp((1−0)²/(2·0.25)) = e².
        let e2 = 2.0f64.exp();
        let want0 = e2 / (e2 + 3.0);
        let p = b.probability_array();
        assert!((p[0] - want0).abs() < 1e-14);
        for &q in &p[1..] {
            assert!((q - 1.0 / (e2 + 3.0)).abs() < 1e-14);
        }
        assert_eq!(b.map(), 0);
        assert_eq!(b.observations(), 1);
    }

    #[test]
    fn posterior_mass_moves_to_the_true_mdp_as_n_grows() {
        let c = GridWorld::<f64>::thesis_candidates(false);
        for truth in 0..4 {
            // Average the true candidate's posterior over 200 seeds at n = 4, 16, 64
            // queries cycling over the four goal cells: it must grow towards 1.
            let mut mean_at = [0.0; 3];
            for seed in 0..200 {
                let mut rng = ChaCha8Rng::seed_from_u64(seed * 4 + truth as u64);
                let mut b = Belief::<f64, 4>::uniform(4).unwrap();
                for i in 1..=64 {
                    let t = c[truth].query(c[i % 4].goal(), 0, &mut rng).unwrap();
                    b.observe(&c, &t).unwrap();
                    if let Some(k) = [4, 16, 64].iter().position(|&n| n == i) {
                        mean_at[k] += b.probability_array()[truth] / 200.0;
                    }
                }
            }
            assert!(mean_at[0] > 0.25, "truth {truth}: {mean_at:?}");
            assert!(
                mean_at[0] < mean_at[1] && mean_at[1] < mean_at[2],
                "{mean_at:?}"
            );
            assert!(mean_at[2] > 0.999, "{mean_at:?}");
        }
    }

    #[test]
    fn stays_finite_and_normalised_after_ten_thousand_extreme_updates() {
        let c = GridWorld::<f32>::thesis_candidates(false);
        let mut b = Belief::<f32, 4>::uniform(4).unwrap();
        let mut map_changes = 0;
        for i in 0..10_000 {
            // Rewards far in the tails: each update multiplies likelihood ratios by e^±10⁴.
            let reward = if i % 2 == 0 { 150.0 } else { -150.0 };
            let s = c[i % 4].goal();
            b.update(
                &c,
                s,
                (i / 4) % 4,
                c[0].next_state(s, (i / 4) % 4).unwrap(),
                reward,
            )
            .unwrap();
            let p = b.probability_array();
            assert!(p.iter().all(|x| x.is_finite() && *x >= 0.0));
            let total: f32 = p.iter().sum();
            assert!((total - 1.0).abs() < 1e-5, "step {i}: {p:?}");
            assert!(b.log_probabilities().iter().all(|l| !l.is_nan()));
            if i > 0 && b.map() != (i - 1) % 4 {
                map_changes += 1;
            }
        }
        assert!(b.entropy().is_finite());
        assert!(!b.is_contradicted());
        // Log-likelihood ratios of ±600 per update swing the mass between candidates.
        assert!(map_changes > 100, "{map_changes}");
    }

    #[test]
    fn impossible_observation_under_every_candidate_falls_back_to_the_prior() {
        // Absorbing goals: from 99 under action 1 candidate 0 stays, the others move to 98.
        let c = GridWorld::<f64>::thesis_candidates(true);
        let mut b = Belief::<f64, 4>::uniform(4).unwrap();
        b.update(&c, 99, 1, 99, 1.0).unwrap();
        let p = b.probability_array();
        assert_eq!(p[1..], [0.0; 3], "transition impossible for 1..4");
        assert!((p[0] - 1.0).abs() < 1e-15);
        // Now observe what only the others allow: nothing with mass explains it.
        b.update(&c, 99, 1, 98, 0.0).unwrap();
        assert!(b.is_contradicted());
        assert_eq!(b.log_probabilities(), b.log_prior());
        b.update(&c, 99, 2, 99, 1.0).unwrap();
        assert_eq!(
            b.log_probabilities(),
            b.log_prior(),
            "sticky, as the batch formula"
        );
        b.reset();
        assert!(!b.is_contradicted() && b.observations() == 0);
    }

    #[test]
    fn bad_observations_leave_the_belief_untouched() {
        let c = GridWorld::<f64>::thesis_candidates(false);
        let mut b = Belief::<f64, 4>::uniform(4).unwrap();
        b.update(&c, 99, 0, 99, 2.0).unwrap();
        let before = b;
        assert!(b.update(&c, 100, 0, 99, 1.0).is_err());
        assert!(b.update(&c, 99, 4, 99, 1.0).is_err());
        assert!(b.update(&c, 99, 0, 99, f64::INFINITY).is_err());
        assert_eq!(
            b.update(&c[..3], 99, 0, 99, 1.0),
            Err(Error::InvalidParameter {
                parameter: "candidates"
            })
        );
        assert_eq!(b, before);
    }
}
