//! The IWFQI paper's water reservoir ([`awfqi::env::Dam`]) as a [`Domain`]: the target
//! (inflow profile 1, α = 0.3, β = 0.7) and its six sources, the eight releases, horizon
//! 360, γ = 0.999, ten evaluation rollouts from (200, 1) scored by discounted return and by
//! average reward, and the published configuration (reference repository, folder
//! `experiments/ICML2018/dam`; see `std_harness/data/iwfqi-sources/README.md`).
//!
//! IWFQI's GPs are the published fixed kernels on `z = (storage, day, release)`: the
//! reward `3.25²·RBF([3.2, 10⁵, 0.0161]) + 29²·RBF([323, 10⁵, 4.75·10⁻⁵])` without noise
//! (its release length scales make it exactly block-diagonal by release), and the storage
//! transition `213²·RBF(215) + White(4)`, noise subtracted; the day is not weighted.

use std::io::Read;
use std::sync::Arc;

use awfqi::env::{
    DAM_ACTIONS, DAM_DAYS, DAM_DISCOUNT, DAM_EVALUATION_STATE, DAM_HORIZON, DAM_MAX_STORAGE,
    DAM_MIN_STORAGE, DAM_RELEASES, Dam,
};
use rand_chacha::ChaCha8Rng;

use super::{Domain, IdealMeans, Published, Record, Task, Weighting};
use crate::gp_large::fixed::{FixedKernel, RbfTerm};
use crate::transfer::gp::GpSpec;
use crate::transfer::sources::{Generation, SourceLayout, SourceSet};
use crate::trees::TreeParams;

impl Task<2> for Dam<f64> {
    fn step(
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

/// The published reward kernel (see the [module docs](self)).
pub fn reward_kernel() -> FixedKernel {
    FixedKernel {
        terms: vec![
            RbfTerm {
                signal_variance: 3.25 * 3.25,
                length_scales: vec![3.2, 1e5, 0.0161],
            },
            RbfTerm {
                signal_variance: 29.0 * 29.0,
                length_scales: vec![323.0, 1e5, 4.75e-5],
            },
        ],
        noise_variance: 0.0,
    }
}

/// The published storage-transition kernel `213²·RBF(215) + White(4)`.
pub fn storage_kernel() -> FixedKernel {
    FixedKernel::isotropic(213.0 * 213.0, 215.0, 3, 4.0)
}

const PUBLISHED: [&[u8]; 6] = [
    include_bytes!("../../data/iwfqi-sources/dam_source_1.csv.gz"),
    include_bytes!("../../data/iwfqi-sources/dam_source_2.csv.gz"),
    include_bytes!("../../data/iwfqi-sources/dam_source_3.csv.gz"),
    include_bytes!("../../data/iwfqi-sources/dam_source_4.csv.gz"),
    include_bytes!("../../data/iwfqi-sources/dam_source_5.csv.gz"),
    include_bytes!("../../data/iwfqi-sources/dam_source_6.csv.gz"),
];

/// Decompresses embedded gzip files.
pub(super) fn gunzip(files: &[&[u8]]) -> anyhow::Result<Vec<String>> {
    files
        .iter()
        .map(|bytes| {
            let mut text = String::new();
            flate2::read::GzDecoder::new(*bytes).read_to_string(&mut text)?;
            Ok(text)
        })
        .collect()
}

/// The CSV layout of the Dam's source files (`a` holds the release), with the Dam's state
/// space: a storage ≥ 0 and an integer day in 1..=360 (as [`Dam::check_state`]). The storage
/// has no upper bound: 500 only forces a release of at least `s − 500`, and the inflow can
/// still push the next storage above it (the published files reach 532.7).
pub fn layout() -> SourceLayout {
    SourceLayout::iwfqi("dam", &["storage", "day"], 1, Some(DAM_RELEASES.to_vec()))
        .with_state_space(&[(0.0, f64::INFINITY), (1.0, DAM_DAYS as f64)], &[1])
}

fn published() -> anyhow::Result<SourceSet<2>> {
    SourceSet::from_texts(&gunzip(&PUBLISHED)?, &layout(), DAM_ACTIONS, "published")
}

/// The published data's states: storage ~ U[50, 500), day uniform in 1..=360.
fn uniform_state(rng: &mut ChaCha8Rng) -> Vec<f64> {
    let u = awfqi::rng::uniform_f64(rng);
    let storage = DAM_MIN_STORAGE + (DAM_MAX_STORAGE - DAM_MIN_STORAGE) * u;
    let day = 1 + awfqi::rng::uniform_index(rng, DAM_DAYS);
    vec![storage, day as f64]
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
    let storage = GpSpec::fixed(storage_kernel(), true);
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
        weighting: Weighting {
            reward: GpSpec::fixed(reward_kernel(), false),
            transition: [Some(storage.clone()), None],
            transition_fallback: storage,
        },
        published: Published {
            steps: 10,
            episodes_per_step: 1,
            runs: 20,
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
        source_layout: layout(),
        load_published: published,
        generation: Generation::UniformTransitions {
            count: 10_800,
            state: uniform_state,
        },
        grid_rows,
        grid_spacing: 10.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_sources_are_the_reference_data() {
        let set = published().unwrap();
        assert_eq!(set.sources.len(), 6);
        let domain = domain();
        for (s, model) in set.sources.iter().zip(&domain.sources) {
            assert_eq!(s.len(), 10_800);
            assert_eq!(s.next_state.len(), 1);
            // One-step transitions from uniformly drawn states; the rewards are the
            // model's, exactly.
            assert!(s.times.iter().all(|&t| t == 0));
            for r in s.records.iter().step_by(97) {
                assert!((50.0..500.0).contains(&r.state[0]));
                assert_eq!(model.mean_reward(r.state, r.action).unwrap(), r.reward);
            }
        }
    }

    #[test]
    fn grid_covers_every_day_storage_and_release() {
        let rows = grid_rows(10.0).unwrap();
        assert_eq!(rows.len(), 360 * 51 * 8);
        assert_eq!(rows[0], ([0.0, 1.0], 0));
        assert_eq!(rows[8 * 51 - 1], ([500.0, 1.0], 7));
        assert!(grid_rows(0.0).is_err());
    }
}
