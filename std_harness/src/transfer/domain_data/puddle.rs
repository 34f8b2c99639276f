//! Puddle World's source data: the reference runs' datasets of either dynamics variant
//! (spec §6), generated afresh by spec §6's procedure, and IWFQI's GPs fitted by marginal
//! likelihood (§4.2), transition weights on both coordinates in the puddle-based variant
//! (§7.6).

use awfqi::env::Dynamics;

use super::DomainData;
use crate::transfer::gp::{GpSpec, Weighting};
use crate::transfer::sources::{Generation, SourceLayout, SourceSet};

/// Puddle World's data with `dynamics`.
pub fn data(dynamics: Dynamics) -> DomainData<2> {
    let weighted = (dynamics == Dynamics::PuddleBased).then_some(GpSpec::fitted());
    DomainData {
        weighting: Weighting {
            reward: GpSpec::fitted(),
            transition: [weighted.clone(), weighted],
            transition_fallback: GpSpec::fitted(),
        },
        layout: SourceLayout::puddle(dynamics),
        published: match dynamics {
            Dynamics::Shared => || SourceSet::published(Dynamics::Shared),
            Dynamics::PuddleBased => || SourceSet::published(Dynamics::PuddleBased),
        },
        generation: Generation::puddle(),
    }
}
