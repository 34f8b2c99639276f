//! The memory an adaptive run writes: one block with const-generic capacities (for a
//! `static`), or any owner that lends the same slices.

use super::candidates::Candidate;
use super::plausibility::SourceBelief;
use crate::float::Real;
use crate::fqi::{FqiEntry, QStorage};
use crate::gp::Gp;
use crate::model::Transition;
use crate::record_gp::{Dims, StatePlusAction};

/// All the memory an [`AdaptiveAwfqi`](super::AdaptiveAwfqi) run writes, as one block:
/// the target GP (`N` points of dimension `I = D + 1`), `Q` target samples (steps ×
/// budget), `W` reward weights (one per source record), `C` candidate slots (the candidates
/// scored per sub-batch, at most the number of rows), `E`
/// FQI entries, `B` path states (the budget) and `M` source beliefs (one per source).
///
/// [`AdaptiveStorage::new`] is `const` and all-zero, so the block can be a `static` in
/// `.bss`; the source records, their stored posteriors and the sources' mean functions are
/// read-only and can stay in flash.
#[derive(Debug, Clone)]
pub struct AdaptiveStorage<
    T,
    const D: usize,
    const I: usize,
    const N: usize,
    const Q: usize,
    const W: usize,
    const C: usize,
    const E: usize,
    const B: usize,
    const M: usize,
> {
    gp: Gp<T, N, I>,
    samples: [Transition<[T; D], T>; Q],
    weights: [T; W],
    candidates: [Candidate<T>; C],
    fqi: [FqiEntry<T>; E],
    path: [[T; D]; B],
    beliefs: [SourceBelief<T>; M],
}

impl<
    T: Real,
    const D: usize,
    const I: usize,
    const N: usize,
    const Q: usize,
    const W: usize,
    const C: usize,
    const E: usize,
    const B: usize,
    const M: usize,
> AdaptiveStorage<T, D, I, N, Q, W, C, E, B, M>
{
    /// Empty, all-zero storage. `I` must be `D + 1` ([`Dims`]).
    pub const fn new() -> Self
    where
        Dims<D, I>: StatePlusAction,
    {
        Self {
            gp: Gp::zeroed(),
            samples: [Transition::EMPTY; Q],
            weights: [T::ZERO; W],
            candidates: [Candidate::EMPTY; C],
            fqi: [FqiEntry::EMPTY; E],
            path: [[T::ZERO; D]; B],
            beliefs: [SourceBelief::EMPTY; M],
        }
    }

    /// The block as the slices a learner borrows.
    pub fn buffers(&mut self) -> AdaptiveBuffers<'_, T, D, I, N> {
        AdaptiveBuffers {
            gp: &mut self.gp,
            samples: &mut self.samples,
            weights: &mut self.weights,
            candidates: &mut self.candidates,
            fqi: QStorage::from(&mut self.fqi[..]),
            path: &mut self.path,
            beliefs: &mut self.beliefs,
        }
    }
}

impl<
    T: Real,
    const D: usize,
    const I: usize,
    const N: usize,
    const Q: usize,
    const W: usize,
    const C: usize,
    const E: usize,
    const B: usize,
    const M: usize,
> Default for AdaptiveStorage<T, D, I, N, Q, W, C, E, B, M>
where
    Dims<D, I>: StatePlusAction,
{
    fn default() -> Self {
        Self::new()
    }
}

/// The memory of an adaptive learner as borrowed slices, whatever owns it (an
/// [`AdaptiveStorage`], or a host's vectors sized at run time).
#[derive(Debug)]
pub struct AdaptiveBuffers<'a, T, const D: usize, const I: usize, const N: usize> {
    /// The target GP: the weights' reward GP during a re-plan, then the residual GP that
    /// scores the next sub-batch's rows.
    pub gp: &'a mut Gp<T, N, I>,
    /// Room for the target records of all steps (steps × budget).
    pub samples: &'a mut [Transition<[T; D], T>],
    /// Room for one reward weight per source record.
    pub weights: &'a mut [T],
    /// The candidate slots of a sub-batch (at least `min(candidates, rows)`).
    pub candidates: &'a mut [Candidate<T>],
    /// Room for the approximator: FQI entries (table, tiles) or records and links (kernel
    /// averaging: one record slot per target and source record).
    pub fqi: QStorage<'a, T, D>,
    /// Room for one step's verified states (at least the budget).
    pub path: &'a mut [[T; D]],
    /// One belief per source.
    pub beliefs: &'a mut [SourceBelief<T>],
}

impl<
    'a,
    T: Real,
    const D: usize,
    const I: usize,
    const N: usize,
    const Q: usize,
    const W: usize,
    const C: usize,
    const E: usize,
    const B: usize,
    const M: usize,
> From<&'a mut AdaptiveStorage<T, D, I, N, Q, W, C, E, B, M>> for AdaptiveBuffers<'a, T, D, I, N>
{
    fn from(storage: &'a mut AdaptiveStorage<T, D, I, N, Q, W, C, E, B, M>) -> Self {
        storage.buffers()
    }
}
