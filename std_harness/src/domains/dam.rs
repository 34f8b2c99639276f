//! The IWFQI paper's water reservoir ([`awfqi::env::Dam`]) as a [`Domain`]: the target
//! (inflow profile 1, α = 0.3, β = 0.7) and its six sources, the eight releases, horizon
//! 360, γ = 0.999, ten evaluation rollouts from (200, 1) scored by discounted return and by
//! average reward, and the published configuration (reference repository, folder
//! `experiments/ICML2018/dam`; see `std_harness/data/iwfqi-sources/README.md`).

use std::sync::Arc;

use awfqi::env::{
    DAM_ACTIONS, DAM_DAYS, DAM_DISCOUNT, DAM_EVALUATION_STATE, DAM_HORIZON, DAM_MAX_STORAGE,
    DAM_RELEASES, Dam,
};
use rand_chacha::ChaCha8Rng;

use super::{Domain, IdealMeans, Published, Record, Task};
use crate::trees::TreeParams;

impl Task<2> for Dam<f64> {
    fn query(
        &self,
        state: [f64; 2],
        action: usize,
        rng: &mut ChaCha8Rng,
    ) -> awfqi::Result<Record<2>> {
        Dam::step(self, state, action, rng)
    }

    fn mean_reward(&self, state: [f64; 2], action: usize) -> awfqi::Result<f64> {
        Dam::mean_reward(self, state, action)
    }

    fn mean_next_state(&self, state: [f64; 2], action: usize) -> awfqi::Result<[f64; 2]> {
        Dam::mean_next_state(self, state, action)
    }

    fn initial_state(&self, rng: &mut ChaCha8Rng) -> [f64; 2] {
        Dam::initial_state(self, rng)
    }
}

/// Grid rows: every day × storage `0, spacing, …, 500` × the eight releases.
fn grid_rows(spacing: f64) -> anyhow::Result<Vec<([f64; 2], usize)>> {
    anyhow::ensure!(
        spacing.is_finite() && spacing > 0.0 && spacing <= DAM_MAX_STORAGE,
        "the Dam's grid spacing (storage step) must be in (0, 500]"
    );
    let n = (DAM_MAX_STORAGE / spacing).round() as usize;
    let mut rows = Vec::with_capacity(DAM_DAYS * (n + 1) * DAM_ACTIONS);
    for day in 1..=DAM_DAYS {
        for i in 0..=n {
            let storage = (i as f64 * spacing).min(DAM_MAX_STORAGE);
            rows.extend((0..DAM_ACTIONS).map(|a| ([storage, day as f64], a)));
        }
    }
    Ok(rows)
}

/// The Dam domain with the published configuration.
pub fn domain() -> Domain<2> {
    Domain {
        name: "dam",
        command: "dam",
        state_names: ["storage", "day"],
        state_bounds: [(0.0, DAM_MAX_STORAGE), (1.0, DAM_DAYS as f64)],
        target: Arc::new(Dam::<f64>::target()),
        sources: Dam::<f64>::sources()
            .into_iter()
            .map(|d| Arc::new(d) as Arc<dyn Task<2>>)
            .collect(),
        action_values: DAM_RELEASES.to_vec(),
        horizon: DAM_HORIZON,
        discount: DAM_DISCOUNT,
        evaluation_starts: vec![DAM_EVALUATION_STATE; 10],
        average_reward: true,
        target_regions: Vec::new(),
        published: Published {
            steps: 10,
            episodes_per_step: 1,
            runs: 20,
            threshold: -1000.0,
            epsilon: 0.3,
            iterations: 60,
            trees: 100,
            tree: TreeParams {
                min_samples_split: 20,
                min_samples_leaf: 1,
            },
            variances: (0.25, 4.0),
            ideal_variances: (0.25, 4.0),
            ideal_means: IdealMeans::Sampled,
            max_gp: 10_000,
            rbt_total: 60_000,
        },
        grid_rows,
        grid_spacing: 10.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_covers_every_day_storage_and_release() {
        let rows = grid_rows(10.0).unwrap();
        assert_eq!(rows.len(), 360 * 51 * 8);
        assert_eq!(rows[0], ([0.0, 1.0], 0));
        assert_eq!(rows[8 * 51 - 1], ([500.0, 1.0], 7));
        assert!(grid_rows(0.0).is_err());
    }
}
