//! Calls of model identification: beliefs, query scores and query runs.

use super::*;

/// Identification and planning on the Grid World candidates.
pub(super) fn identification<T: Real>(rng: &mut ChaCha8Rng) {
    let candidates = GridWorld::<T>::thesis_candidates(opaque(false));
    let k = index(4).min(4);
    let cands = &candidates[..k];
    let model = candidates[index(2) % 4];
    keep(log_likelihood(
        &model,
        index(5),
        index(1),
        index(6),
        num::<T>(0.3),
    ));
    let weights = [num::<T>(1.0), num(2.0), num(0.0), num(1.0)];
    let mut belief = Belief::<T, 4>::from_weights(&weights[..k])
        .or_else(|_| Belief::uniform(index(4)))
        .unwrap_or_else(|_| loop {});
    keep(belief.update(cands, index(99), index(1), index(98), num(1.0)));
    let t = Transition {
        state: index(3),
        action: index(0),
        reward: num(0.2),
        next_state: index(4),
        absorbing: false,
    };
    keep(belief.observe(cands, &t));
    keep((
        belief.len(),
        belief.is_empty(),
        belief.observations(),
        belief.is_contradicted(),
    ));
    keep((
        belief.log_probabilities().len(),
        belief.log_prior().len(),
        belief.map(),
        belief.entropy(),
    ));
    let mut p = [T::ZERO; 4];
    keep(belief.probabilities(&mut p[..k]));
    let probabilities = belief.probability_array();
    let mut score = [T::ZERO; 400];
    keep(uniform_score(&mut score));
    keep(variance_score(cands, &probabilities[..k], &mut score));
    let config = MiConfig {
        samples: index(20),
        bins: index(16),
        reward_entropy: if opaque(true) {
            RewardEntropy::Differential
        } else {
            RewardEntropy::Literal
        },
        skip_identical_rewards: opaque(true),
    };
    keep(mutual_information_score(
        cands,
        &probabilities[..k],
        &config,
        rng,
        &mut score,
    ));
    let criterion = match index(1) {
        0 => Criterion::Uniform,
        1 => Criterion::Variance,
        _ => Criterion::MutualInformation(config),
    };
    keep(compute_score(
        &criterion,
        cands,
        &probabilities[..k],
        rng,
        &mut score,
    ));
    keep(draw_pair(&score, index(4), rng));
    let mut pairs = [StateAction {
        state: 0,
        action: 0,
    }; 4];
    keep(draw_pairs(&score, index(4), rng, &mut pairs));
    keep(pairs);
    let scoring = if opaque(true) {
        Scoring::Adaptive(criterion)
    } else {
        Scoring::Fixed
    };
    let mut seen = 0usize;
    keep(run_queries(
        cands,
        &model,
        &scoring,
        index(5),
        &mut belief,
        &mut score,
        rng,
        |i, _| seen += i,
    ));
    keep(seen);
    belief.reset();

    // Planning on the MAP candidate, then the belief-weighted policy.
    let chosen = &candidates[belief.map() % 4];
    let (mut values, mut q, mut policy) = ([T::ZERO; 100], [T::ZERO; 400], [0usize; 100]);
    let rule = StoppingRule {
        tolerance: num::<T>(1e-4),
        max_sweeps: index(200),
    };
    keep(StoppingRule::<T>::default());
    if let Ok(c) = value_iteration(chosen, num::<T>(0.9), rule, &mut values, &mut q) {
        keep((c.sweeps, c.residual, c.converged));
    }
    keep(backup(chosen, num::<T>(0.9), &values, index(5), index(2)));
    keep(q_from_values(chosen, num::<T>(0.9), &values, &mut q));
    keep(greedy_action(&q[..4]));
    keep(greedy_policy(&q, index(4), &mut policy));
    keep(evaluate_policy(
        chosen,
        &policy,
        num::<T>(0.9),
        rule,
        &mut values,
    ));
    let mut tables = [T::ZERO; 1600];
    for (k, table) in tables.chunks_exact_mut(400).enumerate() {
        if let Some(m) = candidates.get(k) {
            keep(q_from_values(m, num::<T>(0.9), &values, table));
        }
    }
    let mut scratch = [T::ZERO; 400];
    keep(belief_weighted_q(
        &tables[..400 * k],
        &probabilities[..k],
        &mut scratch,
    ));
    keep(belief_weighted_policy(
        &tables[..400 * k],
        &probabilities[..k],
        index(4),
        &mut scratch,
        &mut policy,
    ));
    keep(policy);
}
