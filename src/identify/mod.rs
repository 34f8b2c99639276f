//! Finite-MDP identification (spec §10, thesis §4.1): which of K fully known candidate
//! MDPs is the target, from a budget of generative-model queries?
//!
//! The pieces, each in its own module:
//! - [`Belief`]: the posterior over the candidates, in log space (fixed capacity `K`).
//! - [`Criterion`]: where to query — the uniform, inter-MDP-variance and
//!   mutual-information scores of §10.3, written into caller storage, one weight per
//!   state-action pair at index `s·|𝒜| + a`.
//! - [`draw_pair`] / [`draw_pairs`]: i.i.d. state-action pairs from a score.
//! - [`run_queries`]: the query loop, either with a fixed score (the thesis: computed
//!   once from the prior b⁰) or **adaptive**, recomputing the score with the current
//!   belief before every query (beyond the thesis).
//! - [`belief_weighted_q`] / [`belief_weighted_policy`]: the greedy policy of
//!   Σ_θ b_θ Q*_θ, an answer to the open problem of the thesis's eq. 4.16 that hedges
//!   between candidates while the belief is not yet sharp (the MAP policy is
//!   [`Belief::map`] followed by [`crate::planning::value_iteration`]).
//!
//! All candidates must share |𝒮| and |𝒜|.
//!
//! ```
//! use awfqi::env::GridWorld;
//! use awfqi::model::FiniteMdp;
//! use awfqi::identify::{Belief, Criterion, Scoring, compute_score, run_queries};
//! use awfqi::planning::{StoppingRule, greedy_policy, value_iteration};
//! use rand_chacha::ChaCha8Rng;
//! use rand_core::SeedableRng;
//!
//! // The thesis's four Grid World candidates; the target is secretly number 2.
//! let candidates = GridWorld::<f32>::thesis_candidates(false);
//! let target = &candidates[2];
//! let mut rng = ChaCha8Rng::seed_from_u64(0);
//!
//! // One-shot design: the variance score from the uniform prior, then 16 queries.
//! let mut belief = Belief::<f32, 4>::uniform(4)?;
//! let mut score = [0.0f32; 400];
//! compute_score(&Criterion::Variance, &candidates, &[0.25; 4], &mut rng, &mut score)?;
//! run_queries(&candidates, target, &Scoring::Fixed, 16, &mut belief, &mut score, &mut rng,
//!     |_, _| {})?;
//! let guess = belief.map();
//! assert_eq!(guess, 2);
//!
//! // Plan in the MAP candidate: Q* and its greedy policy, all in caller storage.
//! let (mut v, mut q, mut policy) = ([0.0f32; 100], [0.0f32; 400], [0usize; 100]);
//! value_iteration(&candidates[guess], 0.9, StoppingRule::default(), &mut v, &mut q)?;
//! greedy_policy(&q, 4, &mut policy)?;
//! # Ok::<(), awfqi::Error>(())
//! ```

mod belief;
mod draw;
mod policy;
mod procedure;
mod query_score;

pub use belief::{Belief, log_likelihood};
pub use draw::{StateAction, draw_pair, draw_pairs};
pub use policy::{belief_weighted_policy, belief_weighted_q};
pub use procedure::{Scoring, run_queries};
pub use query_score::{
    Criterion, MAX_BINS, MiConfig, RewardEntropy, compute_score, mutual_information_score,
    uniform_score, variance_score,
};

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::FiniteMdp;

/// |𝒮|, |𝒜| and |𝒮|·|𝒜| shared by all `candidates`.
///
/// Errors: no candidates ([`Error::EmptyData`]), an empty state or action space, or
/// candidates of different sizes ([`Error::InvalidParameter`] naming `candidates`).
pub(crate) fn dimensions<T: Real, M: FiniteMdp<T>>(
    candidates: &[M],
) -> Result<(usize, usize, usize)> {
    let first = candidates.first().ok_or(Error::EmptyData)?;
    let pairs = crate::planning::pair_count(first)?;
    let (s, a) = (first.num_states(), first.num_actions());
    if candidates
        .iter()
        .any(|m| m.num_states() != s || m.num_actions() != a)
    {
        return Err(Error::InvalidParameter {
            parameter: "candidates",
        });
    }
    Ok((s, a, pairs))
}

/// Checks a belief given as probabilities (one per candidate, non-negative, finite, not
/// all zero; they need not sum to 1) and returns their sum W.
pub(crate) fn belief_total<T: Real>(belief: &[T], candidates: usize) -> Result<T> {
    if belief.len() != candidates {
        return Err(Error::InvalidParameter {
            parameter: "belief",
        });
    }
    for &b in belief {
        crate::error::ensure_finite(b, "belief")?;
        if b < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "belief",
            });
        }
    }
    let total: T = belief.iter().copied().sum();
    if total > T::ZERO && total.is_finite() {
        Ok(total)
    } else {
        Err(Error::InvalidParameter {
            parameter: "belief",
        })
    }
}
