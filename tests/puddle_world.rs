//! Puddle World through the public API only: the four instances of spec §2.6 in both
//! dynamics variants, episodes into fixed storage, and the §3.3 evaluation protocol.

use awfqi::env::{
    ACTION_LEFT, ACTION_RIGHT, ACTION_UP, Dynamics, EpisodeRecord, PUDDLE_ACTIONS, PUDDLE_DISCOUNT,
    PUDDLE_HORIZON, PuddleWorld,
};
use awfqi::model::{GenerativeModel, Transition};
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use awfqi::{Result, prelude::Real};
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

fn all_instances<T: Real>() -> Vec<(&'static str, PuddleWorld<T>)> {
    let mut out = Vec::new();
    for dynamics in [Dynamics::Shared, Dynamics::PuddleBased] {
        let [s1, s2, s3] = PuddleWorld::sources(dynamics);
        out.push(("target", PuddleWorld::target(dynamics)));
        out.push(("source 1", s1));
        out.push(("source 2", s2));
        out.push(("source 3", s3));
    }
    out
}

/// Heads for the goal: up until one below the goal's height, then sideways towards it.
fn homing<T: Real>(goal: [T; 2]) -> impl FnMut(&[T; 2]) -> Result<usize> {
    move |s: &[T; 2]| {
        Ok(if s[1] < goal[1] - T::ONE {
            ACTION_UP
        } else if s[0] < goal[0] {
            ACTION_RIGHT
        } else {
            ACTION_LEFT
        })
    }
}

#[test]
fn every_instance_is_solvable_and_episodic_rewards_have_base_minus_one() {
    for (name, world) in all_instances::<f64>() {
        let mut policy = homing(world.goal());
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut records: Vec<EpisodeRecord<f64>> = Vec::with_capacity(PUDDLE_HORIZON);
        for _ in 0..10 {
            records.clear();
            let n = world
                .run_episode_with(&mut policy, PUDDLE_HORIZON, &mut rng, |r| {
                    if records.len() == PUDDLE_HORIZON {
                        return Err(awfqi::Error::CapacityExceeded { capacity: 50 });
                    }
                    records.push(r);
                    Ok(())
                })
                .unwrap();
            assert_eq!(n, records.len());
            let last = records.last().unwrap().transition;
            assert!(last.absorbing, "{name}: homing reaches the goal");
            for r in &records {
                let Transition { state, reward, .. } = r.transition;
                // In an episode the current state is never in the goal (spec §2.3), so
                // rewards are −1 − 100 W(s) + η with |η| < 6σ = 0.6.
                assert!(!world.in_goal(state).unwrap(), "{name}");
                let mean = -1.0 - 100.0 * world.puddle_weight(state).unwrap();
                assert!((reward - mean).abs() < 0.6, "{name}: {reward} vs {mean}");
                assert_eq!(world.mean_reward(state).unwrap(), mean);
            }
        }
    }
}

#[test]
fn puddle_based_dynamics_slow_the_agent_inside_puddles_only() {
    let shared = PuddleWorld::<f64>::target(Dynamics::Shared);
    let slow = PuddleWorld::<f64>::target(Dynamics::PuddleBased);
    // At a puddle centre the step shrinks to 1/(1 + 5 W) < 1, far from puddles it is ≈ 1.
    let centre = [6.0, 6.0];
    let w = slow.puddle_weight(centre).unwrap();
    assert_eq!(slow.step_length(centre).unwrap(), 1.0 / (1.0 + 5.0 * w));
    assert!(slow.step_length(centre).unwrap() < 0.5);
    assert!(slow.step_length([9.5, 0.5]).unwrap() > 0.9999);
    assert_eq!(shared.step_length(centre).unwrap(), 1.0);
    // The rewards of the two variants are the same function.
    for p in [[0.0, 0.0], [6.0, 6.0], [2.5, 7.5], [10.0, 10.0]] {
        assert_eq!(shared.mean_reward(p).unwrap(), slow.mean_reward(p).unwrap());
    }
}

/// A caller written against the trait only, as the active algorithms will be.
fn query_all_actions<M: GenerativeModel<f32, State = [f32; 2]>>(
    model: &M,
    state: [f32; 2],
    rng: &mut ChaCha8Rng,
) -> Vec<Transition<[f32; 2], f32>> {
    (0..model.num_actions())
        .map(|a| model.query(state, a, rng).unwrap())
        .collect()
}

#[test]
fn generative_model_answers_from_any_state_in_the_box() {
    let world = PuddleWorld::<f32>::source_2(Dynamics::PuddleBased);
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for state in [[0.0, 0.0], [10.0, 10.0], [4.2, 9.9], [7.0, 0.3]] {
        let ts = query_all_actions(&world, state, &mut rng);
        assert_eq!(ts.len(), PUDDLE_ACTIONS);
        for (a, t) in ts.iter().enumerate() {
            assert_eq!((t.state, t.action), (state, a));
            assert!(t.next_state.iter().all(|c| (0.0..=10.0).contains(c)));
            assert_eq!(t.absorbing, world.in_goal(t.next_state).unwrap());
        }
    }
}

#[test]
fn evaluation_rollouts_rank_a_detour_policy_above_the_uniform_one() {
    let world = PuddleWorld::<f64>::target(Dynamics::Shared);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let evaluate = |policy: &mut dyn FnMut(&mut ChaCha8Rng) -> f64, rng: &mut ChaCha8Rng| {
        (0..5).map(|_| policy(rng)).sum::<f64>() / 5.0
    };
    // Around the puddles: right along the bottom, up the right edge, left along the top.
    let mut detour = |s: &[f64; 2]| -> Result<usize> {
        Ok(if s[0] < 9.0 && s[1] < 9.0 {
            ACTION_RIGHT
        } else if s[1] < 9.0 {
            ACTION_UP
        } else {
            ACTION_LEFT
        })
    };
    let detour_mean = evaluate(
        &mut |rng| {
            world
                .rollout(&mut detour, PUDDLE_HORIZON, PUDDLE_DISCOUNT, rng)
                .unwrap()
                .discounted_return
        },
        &mut rng,
    );
    let mut uniform = UniformPolicy::new(PUDDLE_ACTIONS).unwrap();
    let uniform_mean = evaluate(
        &mut |rng| {
            world
                .rollout(&mut uniform, PUDDLE_HORIZON, PUDDLE_DISCOUNT, rng)
                .unwrap()
                .discounted_return
        },
        &mut rng,
    );
    // A random walk from (0, 0) essentially never reaches (5, 10) in 50 steps, so its return
    // is at most −Σ_{t<50} 0.99ᵗ ≈ −39.5 (every reward is −1 − penalty + noise).
    let floor = -(1.0 - 0.99f64.powi(50)) / 0.01;
    assert!(uniform_mean < floor + 1.0, "uniform {uniform_mean}");
    // The detour takes ≈ 22 steps and stays about 3 away from every puddle centre (penalty
    // per step below 100·(1/(2π·0.8))·e^{−3²/1.6}·2 ≈ 0.15): return ≈ −20.
    assert!(detour_mean > -25.0, "detour {detour_mean}");
    assert!(detour_mean > floor + 10.0);
}

#[test]
fn epsilon_greedy_episodes_in_f32_are_reproducible() {
    let world = PuddleWorld::<f32>::target(Dynamics::PuddleBased);
    let episode = |seed| {
        let greedy = homing(world.goal());
        let mut policy = EpsilonGreedyPolicy::new(greedy, 0.3f32, PUDDLE_ACTIONS).unwrap();
        let mut records = [EpisodeRecord::default(); PUDDLE_HORIZON];
        let n = world
            .run_episode(
                &mut policy,
                PUDDLE_HORIZON,
                &mut records,
                &mut ChaCha8Rng::seed_from_u64(seed),
            )
            .unwrap();
        records[..n].to_vec()
    };
    let a = episode(10);
    assert_eq!(a, episode(10));
    assert_ne!(a, episode(11));
    assert!(a.iter().enumerate().all(|(t, r)| r.t == t));
}
