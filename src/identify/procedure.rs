//! The query loop of spec §10.2 steps 1–4, fixed or adaptive.

use super::{Belief, Criterion, compute_score, draw_pair};
use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::{FiniteMdp, GenerativeModel};
use rand_core::Rng;

/// Where the scores of [`run_queries`] come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Scoring {
    /// The thesis's one-shot design: the caller's `score` (for example
    /// [`compute_score`] with the prior b⁰) is used for every query.
    Fixed,
    /// Beyond the thesis: before every query the score of this criterion is recomputed
    /// with the current belief, so the budget follows what is still uncertain.
    Adaptive(Criterion),
}

/// Spends `budget` queries of `model`: for each, draw a pair from the score, query it, and
/// update `belief` with the observation; then calls `after_query(i, belief)` with the
/// number of queries done so far (1..=budget).
///
/// With [`Scoring::Fixed`] the pairs are i.i.d. from `score` and a prefix of the loop is
/// the same procedure with a smaller budget (draw and query interleave). With
/// [`Scoring::Adaptive`] `score` is scratch storage overwritten before every query.
///
/// Randomness, per query: the score's draws (adaptive mutual information only), one
/// `u64` for the pair, then the model's draws.
///
/// Errors: `score` not |𝒮|·|𝒜| entries; a belief with a different number of candidates;
/// a fixed score that is not a valid weight vector; model or score errors. The belief
/// holds the updates of the queries completed before an error.
#[allow(clippy::too_many_arguments)]
pub fn run_queries<T, M, G, R, F, const K: usize>(
    candidates: &[M],
    model: &G,
    scoring: &Scoring,
    budget: usize,
    belief: &mut Belief<T, K>,
    score: &mut [T],
    rng: &mut R,
    mut after_query: F,
) -> Result<()>
where
    T: Real,
    M: FiniteMdp<T>,
    G: GenerativeModel<T, State = usize>,
    R: Rng + ?Sized,
    F: FnMut(usize, &Belief<T, K>),
{
    let (_, actions, pairs) = super::dimensions(candidates)?;
    crate::planning::check_len(score.len(), pairs, "scores")?;
    if candidates.len() != belief.len() {
        return Err(Error::InvalidParameter {
            parameter: "candidates",
        });
    }
    if model.num_actions() != actions {
        return Err(Error::InvalidParameter { parameter: "model" });
    }
    for done in 1..=budget {
        if let Scoring::Adaptive(criterion) = scoring {
            let probabilities = belief.probability_array();
            let live = probabilities.get(..belief.len()).unwrap_or(&[]);
            compute_score(criterion, candidates, live, rng, score)?;
        }
        let pair = draw_pair(score, actions, rng)?;
        let transition = model.query(pair.state, pair.action, rng)?;
        belief.observe(candidates, &transition)?;
        after_query(done, belief);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::GridWorld;
    use crate::identify::MiConfig;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    #[test]
    fn variance_guided_queries_identify_every_candidate_quickly() {
        let c = GridWorld::<f64>::thesis_candidates(false);
        for truth in 0..4 {
            for scoring in [
                Scoring::Fixed,
                Scoring::Adaptive(Criterion::Variance),
                Scoring::Adaptive(Criterion::MutualInformation(MiConfig {
                    samples: 200,
                    skip_identical_rewards: true,
                    ..MiConfig::default()
                })),
            ] {
                let mut rng = ChaCha8Rng::seed_from_u64(10 + truth as u64);
                let mut belief = Belief::<f64, 4>::uniform(4).unwrap();
                let mut score = [0.0; 400];
                crate::identify::query_score::variance_score(&c, &[0.25; 4], &mut score).unwrap();
                let mut entropies = [0.0; 40];
                run_queries(
                    &c,
                    &c[truth],
                    &scoring,
                    40,
                    &mut belief,
                    &mut score,
                    &mut rng,
                    |i, b| entropies[i - 1] = b.entropy(),
                )
                .unwrap();
                assert_eq!(belief.observations(), 40);
                assert_eq!(belief.map(), truth, "{scoring:?}");
                assert!(belief.probability_array()[truth] > 0.99, "{scoring:?}");
                assert!(entropies[39] < entropies[0]);
            }
        }
    }

    #[test]
    fn mismatched_storage_is_rejected_before_querying() {
        let c = GridWorld::<f32>::thesis_candidates(false);
        let mut belief = Belief::<f32, 4>::uniform(4).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut score = [0.0f32; 399];
        assert!(
            run_queries(
                &c,
                &c[0],
                &Scoring::Fixed,
                3,
                &mut belief,
                &mut score,
                &mut rng,
                |_, _| {}
            )
            .is_err()
        );
        let mut b3 = Belief::<f32, 4>::uniform(3).unwrap();
        let mut score = [1.0f32; 400];
        assert!(
            run_queries(
                &c,
                &c[0],
                &Scoring::Fixed,
                3,
                &mut b3,
                &mut score,
                &mut rng,
                |_, _| {}
            )
            .is_err()
        );
        assert_eq!(b3.observations(), 0);
    }
}
