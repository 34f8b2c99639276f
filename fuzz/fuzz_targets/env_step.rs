//! Environment steps and queries from arbitrary states, actions and seeds.
//!
//! Invariant: no panic; a success never carries a non-finite value or a state outside
//! [0, 10]²; errors are only the documented kinds for bad states and actions.
#![no_main]

use arbitrary::Arbitrary;
use awfqi::env::{Dynamics, FiniteMdp, GenerativeModel, GridWorld, PuddleWorld};
use awfqi::Error;
use libfuzzer_sys::fuzz_target;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

#[derive(Arbitrary, Debug)]
struct Input {
    seed: u64,
    instance: u8,
    puddle_based: bool,
    state: [f64; 2],
    action: usize,
    grid_state: usize,
    grid_index: u8,
    absorbing: bool,
}

fuzz_target!(|input: Input| {
    let mut rng = ChaCha8Rng::seed_from_u64(input.seed);
    let dynamics = if input.puddle_based { Dynamics::PuddleBased } else { Dynamics::Shared };
    let world = match input.instance % 4 {
        0 => PuddleWorld::<f64>::target(dynamics),
        1 => PuddleWorld::source_1(dynamics),
        2 => PuddleWorld::source_2(dynamics),
        _ => PuddleWorld::source_3(dynamics),
    };
    match world.query(input.state, input.action, &mut rng) {
        Ok(t) => {
            assert!(t.reward.is_finite());
            assert!(t.next_state.iter().all(|c| (0.0..=10.0).contains(c)));
        }
        Err(Error::NonFinite { .. } | Error::OutOfRange { .. }) => {}
        Err(other) => panic!("undocumented error {other:?}"),
    }
    let world32 = PuddleWorld::<f32>::target(dynamics);
    let s32 = [input.state[0] as f32, input.state[1] as f32];
    if let Ok(t) = world32.query(s32, input.action, &mut rng) {
        assert!(t.reward.is_finite() && t.next_state.iter().all(|c| c.is_finite()));
    }

    let grid = GridWorld::<f32>::thesis(usize::from(input.grid_index % 4), input.absorbing)
        .expect("the thesis candidates are valid");
    match grid.query(input.grid_state, input.action, &mut rng) {
        Ok(t) => {
            assert!(t.reward.is_finite() && t.next_state < grid.num_states());
        }
        Err(Error::OutOfRange { .. }) => {}
        Err(other) => panic!("undocumented error {other:?}"),
    }
});
