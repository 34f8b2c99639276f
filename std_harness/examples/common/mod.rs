//! Inputs shared by the GP timing examples (`gp_timing`, `gp_eval_count`,
//! `gp_eval_timing`); included with `#[path]`, not an example itself.

#![allow(dead_code)]

use awfqi::env::{Dynamics, PUDDLE_HORIZON, PuddleWorld};
use awfqi::policy::UniformPolicy;
use rand_chacha::ChaCha8Rng;
use rand_core::SeedableRng;

/// The sizes given on the command line, or `default` when there are none.
pub fn sizes_from_args(default: &[usize]) -> Vec<usize> {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|s| s.parse().expect("sizes are positive integers"))
        .collect();
    if args.is_empty() {
        default.to_vec()
    } else {
        args
    }
}

/// At least `n` reward-like GP samples `((s_x, s_y, a), r)` from uniform-policy episodes on
/// the shared-dynamics Puddle World target (seed 0): the data a target reward GP sees.
pub fn uniform_reward_data(n: usize) -> (Vec<[f64; 3]>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let target = PuddleWorld::<f64>::target(Dynamics::Shared);
    let mut uniform = UniformPolicy::new(4).expect("4 actions");
    let (mut zs, mut ys) = (Vec::new(), Vec::new());
    while zs.len() < n {
        target
            .run_episode_with(&mut uniform, PUDDLE_HORIZON, &mut rng, |r| {
                let t = r.transition;
                zs.push([t.state[0], t.state[1], t.action as f64]);
                ys.push(t.reward);
                Ok(())
            })
            .expect("valid episode");
    }
    (zs, ys)
}
