//! The greedy choice every approximator makes the same way (spec §3.1): the largest Q, ties
//! first to an action that has data where the state is, then to the smallest index.

use crate::float::Real;

/// The running greedy choice over actions offered in index order, from 0.
///
/// The data rule only matters for filled values: under
/// [`EmptyCells::CappedNearest`](super::EmptyCells::CappedNearest) an untried action can
/// equal the worst tried one, and must not win the tie by its index alone (a source dataset
/// from a deterministic policy tries one action per cell). An approximator without such
/// filling offers every action as having data: ties then go to the smallest index.
pub(super) struct ArgMax<T> {
    action: usize,
    q: T,
    has_data: bool,
}

impl<T: Real> ArgMax<T> {
    pub(super) fn new() -> Self {
        Self {
            action: 0,
            q: T::NEG_INFINITY,
            has_data: false,
        }
    }

    /// Offers `action` with value `q`; action 0 is always taken.
    pub(super) fn offer(&mut self, action: usize, q: T, has_data: bool) {
        let better = action == 0 || q > self.q || (q == self.q && has_data && !self.has_data);
        if better {
            self.action = action;
            self.q = q;
            self.has_data = has_data;
        }
    }

    /// The greedy action so far.
    pub(super) fn action(&self) -> usize {
        self.action
    }
}
