//! Environment steps and queries from arbitrary states, actions and seeds: the spec's Puddle
//! World instances and custom ones (arbitrary goal and puddles), their oracle functions,
//! episodes and rollouts with arbitrary horizons and discounts under ε-greedy policies, and
//! the Grid World (thesis candidates and arbitrary sizes) through `GenerativeModel` and
//! `FiniteMdp`.
//!
//! Invariant: no panic; a success never carries a non-finite value or a state outside
//! [0, 10]² (outside the grid); errors are only the documented kinds.
#![no_main]

use awfqi::env::{Dynamics, EpisodeRecord, GridWorld, Puddle, PuddleWorld};
use awfqi::model::{FiniteMdp, GenerativeModel};
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use awfqi::{Error, prelude::Real};
use awfqi_fuzz::{Bytes, Kind, expect_kind, finite};
use libfuzzer_sys::fuzz_target;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

const STATE: &[Kind] = &[Kind::NonFinite, Kind::OutOfRange];

fn in_box<T: Real>(s: [T; 2]) -> bool {
    s.iter().all(|c| (0.0..=10.0).contains(&c.to_f64()))
}

fn puddle_world<T: Real>(b: &mut Bytes) -> PuddleWorld<T> {
    let dynamics = if b.bool() {
        Dynamics::PuddleBased
    } else {
        Dynamics::Shared
    };
    match b.u8() % 5 {
        0 => PuddleWorld::target(dynamics),
        1 => PuddleWorld::source_1(dynamics),
        2 => PuddleWorld::source_2(dynamics),
        3 => PuddleWorld::source_3(dynamics),
        _ => {
            let goal = [T::from_f64(b.num()), T::from_f64(b.num())];
            let count = b.index(11);
            let puddles: Vec<Puddle<T>> = (0..count)
                .map(|_| {
                    let mean = [T::from_f64(b.num()), T::from_f64(b.num())];
                    Puddle::new(mean, T::from_f64(b.num()))
                })
                .collect();
            match PuddleWorld::new(goal, &puddles, dynamics) {
                Ok(w) => w,
                Err(e) => {
                    expect_kind(
                        "PuddleWorld::new",
                        &e,
                        &[Kind::NonFinite, Kind::Capacity, Kind::Invalid],
                    );
                    PuddleWorld::target(dynamics)
                }
            }
        }
    }
}

fn puddle<T: Real>(b: &mut Bytes) {
    let world = puddle_world::<T>(b);
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(b.u16()));
    for _ in 0..8 {
        if b.is_empty() {
            break;
        }
        let state = [T::from_f64(b.num()), T::from_f64(b.num())];
        let action = b.index(6);
        let valid = world.check_state(state).is_ok();
        match b.u8() % 8 {
            0 => match world.query(state, action, &mut rng) {
                Ok(t) => {
                    finite("query", "reward", t.reward.to_f64());
                    assert!(in_box(t.next_state), "query: next state outside the box");
                    assert!(valid && action < 4);
                }
                Err(e) => expect_kind("query", &e, STATE),
            },
            1 => match world.mean_next_state(state, action) {
                Ok(s) => assert!(in_box(s)),
                Err(e) => expect_kind("mean_next_state", &e, STATE),
            },
            2 => match world.mean_reward(state) {
                Ok(r) => finite("mean_reward", "reward", r.to_f64()),
                Err(e) => expect_kind("mean_reward", &e, STATE),
            },
            3 => match world.step_length(state) {
                Ok(a) => assert!(
                    a.to_f64() > 0.0 && a.to_f64() <= 1.0,
                    "alpha {}",
                    a.to_f64()
                ),
                Err(e) => expect_kind("step_length", &e, STATE),
            },
            4 => match world.puddle_weight(state) {
                Ok(w) => {
                    finite("puddle_weight", "weight", w.to_f64());
                    assert!(w.to_f64() >= 0.0);
                }
                Err(e) => expect_kind("puddle_weight", &e, STATE),
            },
            5 => {
                if let Err(e) = world.in_goal(state) {
                    expect_kind("in_goal", &e, STATE);
                }
            }
            6 => {
                let horizon = b.index(60);
                let mut records = [EpisodeRecord::<T>::default(); 50];
                let epsilon = T::from_f64(b.num());
                let bad_action = b.index(6);
                let greedy = move |_: &[T; 2]| -> awfqi::Result<usize> { Ok(bad_action) };
                match EpsilonGreedyPolicy::new(greedy, epsilon, 4) {
                    Ok(mut policy) => {
                        match world.run_episode(&mut policy, horizon, &mut records, &mut rng) {
                            Ok(n) => {
                                assert!(n >= 1 && n <= horizon);
                                for r in &records[..n] {
                                    finite("run_episode", "reward", r.transition.reward.to_f64());
                                    assert!(in_box(r.transition.next_state));
                                }
                            }
                            Err(e) => expect_kind(
                                "run_episode",
                                &e,
                                &[Kind::Invalid, Kind::Capacity, Kind::OutOfRange],
                            ),
                        }
                    }
                    Err(e) => expect_kind(
                        "EpsilonGreedyPolicy::new",
                        &e,
                        &[Kind::NonFinite, Kind::OutOfRange],
                    ),
                }
            }
            _ => {
                let horizon = b.index(60);
                let discount = T::from_f64(b.num());
                let mut policy = UniformPolicy::new(4).expect("4 actions");
                match world.rollout(&mut policy, horizon, discount, &mut rng) {
                    Ok(r) => {
                        finite("rollout", "return", r.discounted_return.to_f64());
                        assert!(r.steps >= 1 && r.steps <= horizon);
                    }
                    Err(e) => expect_kind(
                        "rollout",
                        &e,
                        &[Kind::Invalid, Kind::NonFinite, Kind::OutOfRange],
                    ),
                }
            }
        }
    }
}

fn grid(b: &mut Bytes) {
    let absorbing = b.bool();
    let world = if b.bool() {
        let (w, h) = (b.index(13), b.index(13));
        let goal = (b.index(14), b.index(14));
        match GridWorld::<f32>::new(w, h, goal, b.num() as f32, absorbing) {
            Ok(g) => g,
            Err(e) => {
                expect_kind(
                    "GridWorld::new",
                    &e,
                    &[Kind::Invalid, Kind::OutOfRange, Kind::NonFinite],
                );
                return;
            }
        }
    } else {
        match GridWorld::<f32>::thesis(b.index(6), absorbing) {
            Ok(g) => g,
            Err(e) => {
                expect_kind("GridWorld::thesis", &e, &[Kind::OutOfRange]);
                return;
            }
        }
    };
    let mut rng = ChaCha8Rng::seed_from_u64(u64::from(b.u16()));
    let states = world.num_states();
    for _ in 0..8 {
        if b.is_empty() {
            break;
        }
        let (s, a, s2) = (usize::from(b.u8()), b.index(6), usize::from(b.u8()));
        let valid = s < states && a < 4;
        match world.query(s, a, &mut rng) {
            Ok(t) => {
                assert!(valid && t.reward.is_finite() && t.next_state < states);
            }
            Err(e) => {
                assert!(!valid);
                expect_kind("grid query", &e, &[Kind::OutOfRange]);
            }
        }
        match world.transition_probability(s, a, s2) {
            Ok(p) => assert!(p == 0.0 || p == 1.0),
            Err(e) => assert!(matches!(e, Error::OutOfRange { .. })),
        }
        let mut total = 0.0f32;
        match world.for_each_successor(s, a, |n, p| {
            assert!(n < states);
            total += p;
        }) {
            Ok(()) => assert!((total - 1.0).abs() < 1e-6),
            Err(e) => expect_kind("for_each_successor", &e, &[Kind::OutOfRange]),
        }
        match (world.reward_mean(s, a), world.reward_variance(s, a)) {
            (Ok(m), Ok(v)) => assert!(m.is_finite() && v > 0.0 && v.is_finite()),
            (Err(e), Err(_)) => expect_kind("reward_mean", &e, &[Kind::OutOfRange]),
            _ => panic!("reward_mean and reward_variance disagree on validity"),
        }
        if let Ok((x, y)) = world.cell_of(s) {
            assert_eq!(world.state_of(x, y), Ok(s));
        }
        if let Ok(n) = world.next_state(s, a) {
            assert!(n < states);
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut b = Bytes::new(data);
    match b.u8() % 3 {
        0 => puddle::<f64>(&mut b),
        1 => puddle::<f32>(&mut b),
        _ => grid(&mut b),
    }
    // A policy of 0 actions is refused, never a division by zero later.
    assert!(matches!(
        UniformPolicy::new(0),
        Err(Error::InvalidParameter { .. })
    ));
});
