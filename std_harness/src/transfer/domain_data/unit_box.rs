//! The unit-box plants' source data ([`crate::domains::unit_box`]): none published, so
//! always generated afresh from the source plants with the experiment's seed — one-step
//! transitions from states and actions drawn uniformly (the zones: 2 × 300 records, as the
//! zones firmware example logs; the thermal room: 3 × 400; the tanks: 3 × 400) — and
//! IWFQI's GPs fitted by marginal likelihood (§4.2), on the reward and, where a source's
//! dynamics differ from the target's (the thermal room, the tanks), on every next-state
//! coordinate.

use rand_chacha::ChaCha8Rng;

use super::DomainData;
use crate::transfer::gp::{GpSpec, Weighting};
use crate::transfer::sources::{Generation, SourceLayout};

/// Records per source of the zones.
pub const ZONES_RECORDS: usize = 300;
/// Records per source of the thermal room and the tanks.
pub const RECORDS: usize = 400;

/// A state drawn uniformly from `[0, 1]^D`.
fn uniform<const D: usize>(rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..D).map(|_| awfqi::rng::uniform_f64(rng)).collect()
}

/// The data of `domain`: `count` records per source, transitions weighted or not.
fn data<const D: usize>(
    count: usize,
    transitions: bool,
    layout: fn() -> SourceLayout,
) -> DomainData<D> {
    let weighted = transitions.then(GpSpec::fitted);
    DomainData {
        weighting: Weighting {
            reward: GpSpec::fitted(),
            transition: std::array::from_fn(|_| weighted.clone()),
            transition_fallback: GpSpec::fitted(),
        },
        layout: layout(),
        published: || {
            anyhow::bail!("this plant has no published source data: use --sources generate")
        },
        generation: Generation::UniformTransitions {
            count,
            state: uniform::<D>,
        },
    }
}

/// The CSV layout of `name`'s files over the unit box.
fn layout_of(name: &str, state: &[&str], transitions: bool) -> SourceLayout {
    let dims = if transitions { state.len() } else { 0 };
    SourceLayout::iwfqi(name, state, dims, None)
        .with_state_space(&vec![(0.0, 1.0); state.len()], &[])
}

/// The zones' data (rewards weighted only: the buildings share their physics).
pub fn zones() -> DomainData<3> {
    data(ZONES_RECORDS, false, || {
        layout_of("zones", &["zone1", "zone2", "zone3"], false)
    })
}

/// The thermal room's data.
pub fn thermal() -> DomainData<3> {
    data(RECORDS, true, || {
        layout_of("thermal", &["room", "wall", "element"], true)
    })
}

/// The tanks' data.
pub fn tanks() -> DomainData<4> {
    data(RECORDS, true, || {
        layout_of("tanks", &["level1", "level2", "pump1", "pump2"], true)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_sources_are_the_source_plants_and_reproducible() {
        let domain = crate::domains::unit_box::thermal();
        let data = thermal();
        let Generation::UniformTransitions { count, state } = data.generation else {
            panic!("uniform transitions");
        };
        assert_eq!(count, RECORDS);
        // A few records per source (the GP fits on 400 are slow in a debug build).
        let few = Generation::UniformTransitions { count: 12, state };
        let generate = |seed| {
            crate::transfer::sources::generate(
                &domain,
                &data.weighting,
                &data.layout,
                &few,
                &crate::transfer::gp::GpOptions {
                    restarts: 0,
                    ..crate::transfer::gp::GpOptions::published()
                },
                seed,
            )
            .unwrap()
        };
        let a = generate(5);
        let lens: Vec<usize> = a.sources.iter().map(|s| s.len()).collect();
        assert_eq!(lens, vec![12; 3]);
        let b = generate(5);
        assert_eq!(a.sources[2].records, b.sources[2].records);
        assert_ne!(a.sources[0].records, generate(6).sources[0].records);
        // Every record is its source plant's step: the leaky room's (the third source)
        // mean next room temperature lies within 5 noise s.d. of the record's.
        for r in &a.sources[2].records {
            let mean = domain.sources[2]
                .mean_next_state(r.state, r.action)
                .unwrap();
            assert!(
                (mean[0].clamp(0.0, 1.0) - r.next_state[0]).abs() < 0.05,
                "{r:?}"
            );
        }
        assert!(published_of(&data).is_err());
    }

    fn published_of<const D: usize>(
        data: &DomainData<D>,
    ) -> anyhow::Result<crate::transfer::sources::SourceSet<D>> {
        (data.published)()
    }
}
