//! The continuous Puddle World of spec §2 as a [`Domain`]: target and sources of §2.6 in
//! either dynamics variant, 4 actions, horizon 50, γ = 0.99, 5 evaluation rollouts from
//! (0, 0), and the published configuration: the thesis's setting 2 (b) (§13.2) with the
//! reference runs' FQI (§13.1).

use std::sync::Arc;

use awfqi::env::{
    Dynamics, PUDDLE_ACTIONS, PUDDLE_DISCOUNT, PUDDLE_EVALUATION_ROLLOUTS, PUDDLE_GOAL_RADIUS,
    PUDDLE_HORIZON, PUDDLE_INITIAL_STATE, PuddleWorld,
};
use rand_chacha::ChaCha8Rng;

use super::{Domain, IdealMeans, Published, Record, Region, Task};
use crate::trees::TreeParams;

impl Task<2> for PuddleWorld<f64> {
    fn query(
        &self,
        state: [f64; 2],
        action: usize,
        rng: &mut ChaCha8Rng,
    ) -> awfqi::Result<Record<2>> {
        PuddleWorld::step(self, state, action, rng)
    }

    fn mean_reward(&self, state: [f64; 2], action: usize) -> awfqi::Result<f64> {
        if action >= PUDDLE_ACTIONS {
            return Err(awfqi::Error::OutOfRange {
                parameter: "action",
            });
        }
        PuddleWorld::mean_reward(self, state)
    }

    fn mean_next_state(&self, state: [f64; 2], action: usize) -> awfqi::Result<[f64; 2]> {
        PuddleWorld::mean_next_state(self, state, action)
    }

    /// s₀ = (0, 0); draws nothing.
    fn initial_state(&self, _rng: &mut ChaCha8Rng) -> [f64; 2] {
        PUDDLE_INITIAL_STATE
    }

    fn ends_in(&self, state: [f64; 2]) -> bool {
        PuddleWorld::in_goal(self, state).unwrap_or(false)
    }
}

/// Grid spacing of the thesis's score tables (`dx = dy = 0.1`).
pub const GRID_SPACING: f64 = 0.1;

/// Puddle World with `dynamics`: the target and sources 1–3 of spec §2.6.
pub fn domain(dynamics: Dynamics) -> Domain<2> {
    let sources: Vec<Arc<dyn Task<2>>> = PuddleWorld::<f64>::sources(dynamics)
        .into_iter()
        .map(|w| Arc::new(w) as Arc<dyn Task<2>>)
        .collect();
    Domain {
        name: "puddle world",
        command: "puddle",
        state_names: ["x", "y"],
        state_bounds: [(0.0, 10.0), (0.0, 10.0)],
        target: Arc::new(PuddleWorld::<f64>::target(dynamics)),
        sources,
        action_values: (0..PUDDLE_ACTIONS).map(|a| a as f64).collect(),
        horizon: PUDDLE_HORIZON,
        discount: PUDDLE_DISCOUNT,
        evaluation_starts: vec![PUDDLE_INITIAL_STATE; PUDDLE_EVALUATION_ROLLOUTS],
        average_reward: false,
        target_regions: target_regions(dynamics),
        published: Published {
            // The thesis's Chapter 5, setting 2 (b): one episode per step, 10 runs (the
            // IWFQI reference configuration has 10 episodes and 20 runs, spec §13.1).
            steps: 6,
            episodes_per_step: 1,
            runs: 10,
            threshold: -25.0,
            epsilon: 0.3,
            iterations: 60,
            trees: 50,
            tree: TreeParams::FULLY_GROWN,
            variances: (0.1, 0.2),
            ideal_variances: (0.01, 0.04),
            ideal_means: IdealMeans::Exact,
            max_gp: crate::gp_large::MAX_GP,
            rbt_total: 500,
        },
        grid_rows,
        grid_spacing: GRID_SPACING,
    }
}

/// The target's puddles, each a disc of one standard deviation around its centre, and its
/// goal region.
fn target_regions(dynamics: Dynamics) -> Vec<Region> {
    let target = PuddleWorld::<f64>::target(dynamics);
    target
        .puddles()
        .map(|p| Region {
            name: "puddle",
            centre: p.mean,
            radius: p.variance.sqrt(),
        })
        .chain(std::iter::once(Region {
            name: "goal",
            centre: target.goal(),
            radius: PUDDLE_GOAL_RADIUS,
        }))
        .collect()
}

/// Spec §11.1's grid rows: `(0.1 i, 0.1 j)` for `i, j ∈ 0..=10/spacing`, borders included,
/// × 4 actions, in the core's order.
fn grid_rows(spacing: f64) -> anyhow::Result<Vec<([f64; 2], usize)>> {
    let grid = PuddleWorld::score_grid(spacing)?;
    Ok(awfqi::score::RowSet::grid(grid, PUDDLE_ACTIONS)?
        .iter()
        .collect())
}
