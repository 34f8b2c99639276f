//! The IWFQI paper's multitask Acrobot ([`awfqi::env::Acrobot`]) as a [`Domain`]: the
//! swing-up target (unit masses and lengths) and its two sources (a lighter swing-up arm,
//! and a rotate task), two torques, horizon 100, γ = 0.95, nine evaluation rollouts from
//! `[θ₁, 0, 0, 0]`, θ₁ ∈ {−2, −1.5, …, 2}, and the published configuration (reference
//! repository, folder `experiments/ICML2018/acrobot-multitask`).
//!
//! IWFQI's GPs are the published fixed isotropic kernels on `z = (θ₁, θ₂, θ̇₁, θ̇₂, a)`,
//! without noise: reward `2.03²·RBF(2.57)`, next-state coordinates `2.74²·RBF(1.51)`,
//! `2.14²·RBF(0.92)`, `2.42²·RBF(2.47)`, `3.14²·RBF(2.76)`, all four weighted.

use std::sync::Arc;

use awfqi::env::{
    ACROBOT_ACTIONS, ACROBOT_DISCOUNT, ACROBOT_EVALUATION_ANGLES, ACROBOT_HORIZON,
    ACROBOT_MAX_VELOCITY_1, ACROBOT_MAX_VELOCITY_2, Acrobot,
};
use rand_chacha::ChaCha8Rng;

use super::{Domain, IdealMeans, Published, Record, Task, Weighting};
use crate::gp_large::fixed::FixedKernel;
use crate::transfer::gp::GpSpec;
use crate::transfer::sources::{Generation, SourceLayout, SourceSet};
use crate::trees::TreeParams;

impl Task<4> for Acrobot<f64> {
    fn step(
        &self,
        state: [f64; 4],
        action: usize,
        _rng: &mut ChaCha8Rng,
    ) -> awfqi::Result<Record<4>> {
        Acrobot::step(self, state, action)
    }

    fn mean_reward(&self, state: [f64; 4], action: usize) -> awfqi::Result<f64> {
        if action >= ACROBOT_ACTIONS {
            return Err(awfqi::Error::OutOfRange {
                parameter: "action",
            });
        }
        Acrobot::mean_reward(self, state)
    }

    fn mean_next_state(&self, state: [f64; 4], action: usize) -> awfqi::Result<[f64; 4]> {
        Acrobot::mean_next_state(self, state, action)
    }

    fn initial_state(&self, rng: &mut ChaCha8Rng) -> [f64; 4] {
        Acrobot::initial_state(self, rng)
    }
}

/// `c²·RBF(ℓ)` over the five GP coordinates, no noise.
fn kernel(c: f64, length: f64) -> GpSpec {
    GpSpec::fixed(FixedKernel::isotropic(c * c, length, 5, 0.0), false)
}

const PUBLISHED: [&[u8]; 2] = [
    include_bytes!("../../data/iwfqi-sources/acrobot_source_1.csv.gz"),
    include_bytes!("../../data/iwfqi-sources/acrobot_source_2.csv.gz"),
];

/// Acrobot's state space: angles wrapped into [−π, π], velocities clipped into
/// [−4π, 4π] and [−9π, 9π] (as [`Acrobot::check_state`]).
fn state_space() -> [(f64, f64); 4] {
    use std::f64::consts::PI;
    [
        (-PI, PI),
        (-PI, PI),
        (-ACROBOT_MAX_VELOCITY_1, ACROBOT_MAX_VELOCITY_1),
        (-ACROBOT_MAX_VELOCITY_2, ACROBOT_MAX_VELOCITY_2),
    ]
}

/// The CSV layout of Acrobot's source files, with its state space.
pub fn layout() -> SourceLayout {
    SourceLayout::iwfqi(
        "acrobot",
        &["theta1", "theta2", "dtheta1", "dtheta2"],
        4,
        None,
    )
    .with_state_space(&state_space(), &[])
}

fn published() -> anyhow::Result<SourceSet<4>> {
    let texts = super::dam::gunzip(&PUBLISHED)?;
    SourceSet::from_texts(&texts, &layout(), ACROBOT_ACTIONS, "published")
}

/// Grid rows: θ₁, θ₂ from −π to π in steps of `spacing` (π/6: 13 values each), θ̇₁ and θ̇₂
/// at 9 evenly spaced values over their ranges, × both torques.
fn grid_rows(spacing: f64) -> anyhow::Result<Vec<([f64; 4], usize)>> {
    use std::f64::consts::PI;
    anyhow::ensure!(
        spacing.is_finite() && spacing > 0.0 && spacing <= 2.0 * PI,
        "Acrobot's grid spacing (angle step) must be in (0, 2π]"
    );
    let n = (2.0 * PI / spacing).round() as usize;
    let angles: Vec<f64> = (0..=n)
        .map(|i| (-PI + i as f64 * spacing).min(PI))
        .collect();
    let velocities =
        |max: f64| -> Vec<f64> { (0..9).map(|i| -max + i as f64 * max / 4.0).collect() };
    let (v1, v2) = (
        velocities(ACROBOT_MAX_VELOCITY_1),
        velocities(ACROBOT_MAX_VELOCITY_2),
    );
    let mut rows = Vec::new();
    for &t1 in &angles {
        for &t2 in &angles {
            for &w1 in &v1 {
                for &w2 in &v2 {
                    rows.extend((0..ACROBOT_ACTIONS).map(|a| ([t1, t2, w1, w2], a)));
                }
            }
        }
    }
    Ok(rows)
}

/// The Acrobot domain with the published configuration.
pub fn domain() -> Domain<4> {
    Domain {
        name: "acrobot",
        command: "acrobot",
        state_names: ["theta1", "theta2", "dtheta1", "dtheta2"],
        state_bounds: state_space(),
        target: Arc::new(Acrobot::<f64>::target()),
        sources: Acrobot::<f64>::sources()
            .into_iter()
            .map(|a| Arc::new(a) as Arc<dyn Task<4>>)
            .collect(),
        action_values: (0..ACROBOT_ACTIONS).map(|a| a as f64).collect(),
        horizon: ACROBOT_HORIZON,
        discount: ACROBOT_DISCOUNT,
        evaluation_starts: ACROBOT_EVALUATION_ANGLES
            .iter()
            .map(|&t| [t, 0.0, 0.0, 0.0])
            .collect(),
        average_reward: false,
        weighting: Weighting {
            reward: kernel(2.03, 2.57),
            transition: [
                Some(kernel(2.74, 1.51)),
                Some(kernel(2.14, 0.92)),
                Some(kernel(2.42, 2.47)),
                // The published 3.14 (a fitted value, not π).
                #[allow(clippy::approx_constant)]
                Some(kernel(3.14, 2.76)),
            ],
            transition_fallback: kernel(2.74, 1.51),
        },
        published: Published {
            steps: 20,
            episodes_per_step: 10,
            runs: 20,
            epsilon: 0.1,
            iterations: 50,
            trees: 50,
            tree: TreeParams {
                min_samples_split: 5,
                min_samples_leaf: 2,
            },
            variances: (0.01, 1.0),
            // What the published result file records (`acrobot-multitask/results/
            // wfqi-ideal.json` @ c1a1f7d: `var_rw` 0.0001, `var_st` 1.0, batch 10, 20 steps);
            // the run script stored at 8d9352e says 0.1², 0.1² with batch 20 and 10 steps,
            // a configuration whose results are not published.
            ideal_variances: (0.0001, 1.0),
            ideal_means: IdealMeans::Exact,
            max_gp: 10_000,
            // The published RBT result file (`lazaric2008.json` @ c1a1f7d) records
            // `n_sample_total` 8000 (7 999 source records a step, batch 10, 20 steps); the
            // run script at 8d9352e says 10 000 with batch 20 and 10 steps, unpublished.
            rbt_total: 8_000,
        },
        source_layout: layout(),
        load_published: published,
        generation: Generation::LearnedPolicy {
            batch: 100,
            steps: 5,
            episodes: vec![100, 50],
            epsilon: 0.1,
            iterations: 50,
            trees: 50,
            tree: TreeParams {
                min_samples_split: 5,
                min_samples_leaf: 2,
            },
        },
        grid_rows,
        grid_spacing: std::f64::consts::PI / 6.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_sources_are_the_reference_data() {
        let set = published().unwrap();
        let lens: Vec<usize> = set.sources.iter().map(|s| s.len()).collect();
        assert_eq!(lens, vec![3400, 5000]);
        // Source 1 holds 100 episodes, source 2 50 of the full 100 steps.
        assert_eq!(set.sources[0].episodes(), 100);
        assert_eq!(set.sources[1].episodes(), 50);
        let domain = domain();
        for (s, model) in set.sources.iter().zip(&domain.sources) {
            assert_eq!(s.next_state.len(), 4);
            // The records are the model's steps (noise-free dynamics).
            for r in s.records.iter().step_by(53) {
                let mut rng = crate::transfer::stream(0, &[]);
                let t = model.step(r.state, r.action, &mut rng).unwrap();
                assert!((t.reward - r.reward).abs() < 1e-12);
                for d in 0..4 {
                    assert!(
                        (t.next_state[d] - r.next_state[d]).abs() < 1e-9,
                        "{t:?} vs {r:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn grid_has_thirteen_angles_and_nine_velocities() {
        let rows = grid_rows(std::f64::consts::PI / 6.0).unwrap();
        assert_eq!(rows.len(), 13 * 13 * 9 * 9 * 2);
        assert_eq!(
            rows[0].0,
            [
                -std::f64::consts::PI,
                -std::f64::consts::PI,
                -ACROBOT_MAX_VELOCITY_1,
                -ACROBOT_MAX_VELOCITY_2
            ]
        );
        let last = rows.last().unwrap().0;
        assert!(
            (last[0] - std::f64::consts::PI).abs() < 1e-12
                && (last[3] - ACROBOT_MAX_VELOCITY_2).abs() < 1e-9
        );
    }
}
