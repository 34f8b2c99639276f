//! Drawing state-action pairs from a score (spec §10.2 step 2).

use crate::error::{Error, Result};

use crate::float::Real;

use crate::rng;
use rand_core::Rng;

/// A state-action pair, the unit of a generative-model query.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StateAction {
    /// State index.
    pub state: usize,
    /// Action index.
    pub action: usize,
}

/// Checks a score and says whether it has positive mass.
fn check_score<T: Real>(score: &[T], num_actions: usize) -> Result<bool> {
    if num_actions == 0 {
        return Err(Error::InvalidParameter {
            parameter: "num_actions",
        });
    }
    if score.is_empty() {
        return Err(Error::EmptyData);
    }
    if score.len() % num_actions != 0 {
        return Err(Error::InvalidParameter {
            parameter: "scores",
        });
    }
    let mut positive = false;
    for &w in score {
        crate::error::ensure_finite(w, "scores")?;
        if w < T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "scores",
            });
        }
        positive |= w > T::ZERO;
    }
    Ok(positive)
}

/// One draw, the score already checked.
fn draw_checked<T: Real, R: Rng + ?Sized>(
    score: &[T],
    num_actions: usize,
    positive: bool,
    rng: &mut R,
) -> Result<StateAction> {
    let index = if positive {
        rng::categorical(rng, score)?
    } else {
        // Spec §10.3: a score with total 0 is sampled uniformly.
        let u: f64 = rng::uniform_f64(rng);
        ((u * score.len() as f64) as usize).min(score.len() - 1)
    };
    // Checked division: `num_actions > 0` was checked, but only a checked form leaves no
    // division-by-zero panic path for the no-panic proof.
    match (
        index.checked_div(num_actions),
        index.checked_rem(num_actions),
    ) {
        (Some(state), Some(action)) => Ok(StateAction { state, action }),
        _ => Err(Error::InvalidParameter {
            parameter: "num_actions",
        }),
    }
}

/// Draws one pair with probability proportional to `score` (index `s·|𝒜| + a`, need not
/// be normalised); uniformly when all weights are 0. Consumes one `u64`.
///
/// Errors: `num_actions == 0`, an empty score, a length that is not a multiple of
/// `num_actions`, a negative or non-finite weight.
pub fn draw_pair<T: Real, R: Rng + ?Sized>(
    score: &[T],
    num_actions: usize,
    rng: &mut R,
) -> Result<StateAction> {
    let positive = check_score(score, num_actions)?;
    draw_checked(score, num_actions, positive, rng)
}

/// Fills `out` with `out.len()` i.i.d. draws from `score` (with replacement), one `u64`
/// each. The score is checked once, before anything is written.
///
/// Errors: as [`draw_pair`].
pub fn draw_pairs<T: Real, R: Rng + ?Sized>(
    score: &[T],
    num_actions: usize,
    rng: &mut R,
    out: &mut [StateAction],
) -> Result<()> {
    let positive = check_score(score, num_actions)?;
    for slot in out.iter_mut() {
        *slot = draw_checked(score, num_actions, positive, rng)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    #[test]
    fn draws_follow_the_score() {
        let score = [0.0f64, 0.5, 0.0, 0.0, 0.25, 0.25];
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut pairs = [StateAction::default(); 20_000];
        draw_pairs(&score, 2, &mut rng, &mut pairs).unwrap();
        let mut counts = [0usize; 6];
        for p in &pairs {
            assert!(p.state < 3 && p.action < 2);
            counts[p.state * 2 + p.action] += 1;
        }
        assert_eq!((counts[0], counts[2], counts[3]), (0, 0, 0));
        // Binomial sd of the 0.5 cell: sqrt(n/4) ≈ 71; allow 5 sd.
        assert!((counts[1] as f64 - 10_000.0).abs() < 355.0, "{counts:?}");
        assert!((counts[4] as f64 - 5_000.0).abs() < 310.0, "{counts:?}");
    }

    #[test]
    fn an_all_zero_score_is_sampled_uniformly() {
        let score = [0.0f32; 8];
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut seen = [0usize; 8];
        for _ in 0..8000 {
            let p = draw_pair(&score, 4, &mut rng).unwrap();
            seen[p.state * 4 + p.action] += 1;
        }
        // Expected 1000 each, sd ≈ 30.
        assert!(seen.iter().all(|&c| (850..1150).contains(&c)), "{seen:?}");
    }

    #[test]
    fn bad_scores_are_rejected_before_writing() {
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut out = [StateAction {
            state: 9,
            action: 9,
        }; 2];
        for (score, n) in [
            (&[1.0f64, -1.0][..], 2),
            (&[1.0, f64::NAN][..], 2),
            (&[1.0, 1.0, 1.0][..], 2),
            (&[][..], 2),
            (&[1.0, 1.0][..], 0),
        ] {
            assert!(draw_pairs(score, n, &mut rng, &mut out).is_err());
        }
        assert_eq!(
            out,
            [StateAction {
                state: 9,
                action: 9
            }; 2]
        );
    }
}
