//! The Dam's source data: the IWFQI paper's six published datasets (reference repository,
//! folder `experiments/ICML2018/dam`; see `std_harness/data/iwfqi-sources/README.md`),
//! generated afresh as one-step transitions from uniform states, and IWFQI's GPs: the
//! published fixed kernels on `z = (storage, day, release)`, the reward
//! `3.25²·RBF([3.2, 10⁵, 0.0161]) + 29²·RBF([323, 10⁵, 4.75·10⁻⁵])` without noise (its
//! release length scales make it exactly block-diagonal by release), and the storage
//! transition `213²·RBF(215) + White(4)`, noise subtracted; the day is not weighted.

use awfqi::env::{DAM_ACTIONS, DAM_DAYS, DAM_MAX_STORAGE, DAM_MIN_STORAGE, DAM_RELEASES};
use rand_chacha::ChaCha8Rng;

use super::{DomainData, gunzip};
use crate::gp_large::fixed::{FixedKernel, RbfTerm};
use crate::transfer::gp::{GpSpec, Weighting};
use crate::transfer::sources::{Generation, SourceLayout, SourceSet};

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
    include_bytes!("../../../data/iwfqi-sources/dam_source_1.csv.gz"),
    include_bytes!("../../../data/iwfqi-sources/dam_source_2.csv.gz"),
    include_bytes!("../../../data/iwfqi-sources/dam_source_3.csv.gz"),
    include_bytes!("../../../data/iwfqi-sources/dam_source_4.csv.gz"),
    include_bytes!("../../../data/iwfqi-sources/dam_source_5.csv.gz"),
    include_bytes!("../../../data/iwfqi-sources/dam_source_6.csv.gz"),
];

/// The CSV layout of the Dam's source files (`a` holds the release), with the Dam's state
/// space: a storage ≥ 0 and an integer day in 1..=360 (as [`awfqi::env::Dam::check_state`]).
/// The storage has no upper bound: 500 only forces a release of at least `s − 500`, and
/// the inflow can still push the next storage above it (the published files reach 532.7).
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

/// The Dam's data.
pub fn data() -> DomainData<2> {
    let storage = GpSpec::fixed(storage_kernel(), true);
    DomainData {
        weighting: Weighting {
            reward: GpSpec::fixed(reward_kernel(), false),
            transition: [Some(storage.clone()), None],
            transition_fallback: storage,
        },
        layout: layout(),
        published,
        generation: Generation::UniformTransitions {
            count: 10_800,
            state: uniform_state,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_sources_are_the_reference_data() {
        let set = published().unwrap();
        assert_eq!(set.sources.len(), 6);
        let domain = crate::domains::dam::domain();
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
}
