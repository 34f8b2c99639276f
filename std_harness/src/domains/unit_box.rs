//! The plant suite's plants on the unit box as [`Domain`]s: the zones
//! ([`awfqi::env::Zones`], D = 3), the thermal room ([`awfqi::env::Thermal`], D = 3) and
//! the tanks ([`awfqi::env::Tanks`], D = 4). Each declares its box `[0, 1]^D`, its actions,
//! horizon, discount and start states (the core's constants); an episode starts at one of
//! the declared start states drawn uniformly, and the evaluation runs one rollout from each
//! of them. Their configuration for the baselines ([`Published`]) is the Puddle World
//! reference's (60 iterations, 50 fully grown trees, ε = 0.3), with IWFQI's estimator
//! variances the plants' own noise variances.

use std::sync::Arc;

use awfqi::env::{
    TANKS_ACTIONS, TANKS_DISCOUNT, TANKS_HORIZON, TANKS_STARTS, THERMAL_ACTIONS, THERMAL_COMMANDS,
    THERMAL_DISCOUNT, THERMAL_HORIZON, THERMAL_STARTS, Tanks, Thermal, ZONES_ACTIONS,
    ZONES_DISCOUNT, ZONES_HORIZON, ZONES_STARTS, Zones,
};
use rand_chacha::ChaCha8Rng;

use super::{Domain, IdealMeans, Published, Record, Rows, Task};
use crate::trees::TreeParams;

/// One of `starts`, drawn uniformly (one `u64`).
fn draw_start<const D: usize>(starts: &[[f64; D]], rng: &mut ChaCha8Rng) -> [f64; D] {
    let i = awfqi::rng::uniform_index(rng, starts.len());
    starts.get(i).copied().unwrap_or([0.0; D])
}

/// `Task` for a unit-box plant of the core: its generative model, its mean functions and
/// a start drawn from its declared ones.
macro_rules! unit_box_task {
    ($plant:ty, $d:expr, $starts:expr) => {
        impl Task<$d> for $plant {
            fn query(
                &self,
                state: [f64; $d],
                action: usize,
                rng: &mut ChaCha8Rng,
            ) -> awfqi::Result<Record<$d>> {
                awfqi::model::GenerativeModel::query(self, state, action, rng)
            }

            fn mean_reward(&self, state: [f64; $d], action: usize) -> awfqi::Result<f64> {
                <$plant>::mean_reward(self, state, action)
            }

            fn mean_next_state(&self, state: [f64; $d], action: usize) -> awfqi::Result<[f64; $d]> {
                <$plant>::mean_next_state(self, state, action)
            }

            fn initial_state(&self, rng: &mut ChaCha8Rng) -> [f64; $d] {
                draw_start(&$starts, rng)
            }
        }
    };
}

unit_box_task!(Zones<f64>, 3, ZONES_STARTS);
unit_box_task!(Thermal<f64>, 3, THERMAL_STARTS);
unit_box_task!(Tanks<f64>, 4, TANKS_STARTS);

/// The grid of `[0, 1]^D` at `spacing` × every action, as score-table rows.
fn box_rows<const D: usize>(spacing: f64, actions: usize) -> anyhow::Result<Rows<D>> {
    anyhow::ensure!(
        spacing.is_finite() && spacing > 0.0 && spacing <= 1.0,
        "the unit box's grid spacing must be in (0, 1]"
    );
    let n = (1.0 / spacing).round() as usize + 1;
    let cells = n.pow(D as u32);
    anyhow::ensure!(
        cells * actions <= 2_000_000,
        "grid spacing {spacing} gives too many rows"
    );
    let mut rows = Vec::with_capacity(cells * actions);
    for index in 0..cells {
        let mut rest = index;
        let state: [f64; D] = std::array::from_fn(|_| {
            let i = rest % n;
            rest /= n;
            (i as f64 * spacing).min(1.0)
        });
        rows.extend((0..actions).map(|a| (state, a)));
    }
    Ok(rows)
}

/// The baselines' configuration (see the [module docs](self)) with IWFQI's `(v_r, v_s)`
/// and the metric's threshold (halfway from the random policy's return to the best known,
/// the plant suite's anchors).
fn published(steps: usize, variances: (f64, f64), threshold: f64) -> Published {
    Published {
        steps,
        episodes_per_step: 1,
        runs: 10,
        threshold,
        epsilon: 0.3,
        iterations: 60,
        trees: 50,
        tree: TreeParams::FULLY_GROWN,
        variances,
        ideal_variances: variances,
        ideal_means: IdealMeans::Exact,
        max_gp: 4000,
        rbt_total: 500,
    }
}

/// The zones: the target building and the east and west wings.
pub fn zones() -> Domain<3> {
    Domain {
        name: "zones",
        command: "zones",
        state_names: ["zone 1", "zone 2", "zone 3"],
        state_bounds: [(0.0, 1.0); 3],
        target: Arc::new(Zones::<f64>::target()),
        sources: Zones::<f64>::sources()
            .into_iter()
            .map(|p| Arc::new(p) as Arc<dyn Task<3>>)
            .collect(),
        action_values: (0..ZONES_ACTIONS).map(|a| a as f64).collect(),
        horizon: ZONES_HORIZON,
        discount: ZONES_DISCOUNT,
        evaluation_starts: ZONES_STARTS.to_vec(),
        average_reward: false,
        target_regions: Vec::new(),
        published: published(2, (0.05 * 0.05, 0.02 * 0.02), -7.7),
        grid_rows: |spacing| box_rows::<3>(spacing, ZONES_ACTIONS),
        grid_spacing: 0.1,
    }
}

/// The thermal room: the target, another tariff, the leaky room.
pub fn thermal() -> Domain<3> {
    Domain {
        name: "thermal",
        command: "thermal",
        state_names: ["room", "wall", "element"],
        state_bounds: [(0.0, 1.0); 3],
        target: Arc::new(Thermal::<f64>::target()),
        sources: Thermal::<f64>::sources()
            .into_iter()
            .map(|p| Arc::new(p) as Arc<dyn Task<3>>)
            .collect(),
        action_values: THERMAL_COMMANDS.to_vec(),
        horizon: THERMAL_HORIZON,
        discount: THERMAL_DISCOUNT,
        evaluation_starts: THERMAL_STARTS.to_vec(),
        average_reward: false,
        target_regions: Vec::new(),
        published: published(2, (0.02 * 0.02, 0.01 * 0.01), -3.2),
        grid_rows: |spacing| box_rows::<3>(spacing, THERMAL_ACTIONS),
        grid_spacing: 0.1,
    }
}

/// The tanks: the target, another recipe, the worn pump.
pub fn tanks() -> Domain<4> {
    Domain {
        name: "tanks",
        command: "tanks",
        state_names: ["level 1", "level 2", "pump 1", "pump 2"],
        state_bounds: [(0.0, 1.0); 4],
        target: Arc::new(Tanks::<f64>::target()),
        sources: Tanks::<f64>::sources()
            .into_iter()
            .map(|p| Arc::new(p) as Arc<dyn Task<4>>)
            .collect(),
        action_values: (0..TANKS_ACTIONS).map(|a| a as f64).collect(),
        horizon: TANKS_HORIZON,
        discount: TANKS_DISCOUNT,
        evaluation_starts: TANKS_STARTS.to_vec(),
        average_reward: false,
        target_regions: Vec::new(),
        published: published(4, (0.02 * 0.02, 0.01 * 0.01), -9.8),
        grid_rows: |spacing| box_rows::<4>(spacing, TANKS_ACTIONS),
        grid_spacing: 0.2,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_rows_cover_every_corner_and_action() {
        let rows = box_rows::<3>(0.5, 2).unwrap();
        assert_eq!(rows.len(), 27 * 2);
        assert_eq!(rows[0], ([0.0; 3], 0));
        assert_eq!(rows[53], ([1.0; 3], 1));
        assert!(box_rows::<3>(0.0, 2).is_err());
    }

    #[test]
    fn episodes_start_at_a_declared_start() {
        let d = tanks();
        let mut rng = crate::transfer::stream(1, &[]);
        for _ in 0..20 {
            let s = d.target.initial_state(&mut rng);
            assert!(TANKS_STARTS.contains(&s));
        }
    }
}
