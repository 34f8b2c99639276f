//! The verification phase: rollouts of the current greedy policy in the generative model,
//! each visited state kept as this step's path (the relevance kernel's centres).

use super::ValidAdaptiveConfig;
use super::evidence::Evidence;
use crate::error::Result;
use crate::float::Real;
use crate::model::GenerativeModel;
use crate::record_gp::{Dims, StatePlusAction};
use crate::thesis::builder::{buffer, short};
use crate::thesis::transfer::Transfer;
use rand_core::Rng;

/// The states verified in the current step, in a buffer with room for one budget.
#[derive(Debug)]
pub(super) struct Verification<'a, T, const D: usize> {
    path: &'a mut [[T; D]],
    len: usize,
}

impl<'a, T: Real, const D: usize> Verification<'a, T, D> {
    /// An empty path over `path`.
    ///
    /// Errors: `path` shorter than `budget` ([`crate::Error::BufferTooSmall`]).
    pub(super) fn new(path: &'a mut [[T; D]], budget: usize) -> Result<Self> {
        short(path.len(), budget, buffer::PATH)?;
        Ok(Self { path, len: 0 })
    }

    /// Forgets the path (a new step).
    pub(super) fn clear(&mut self) {
        self.len = 0;
    }

    /// The states verified in the current step.
    pub(super) fn states(&self) -> &[[T; D]] {
        self.path.get(..self.len).unwrap_or(&[])
    }

    /// `n` queries along greedy rollouts from the start state (ε-greedy after the first
    /// rollout of the call), each state kept in the path and each record in `run`'s `D₀`.
    pub(super) fn run<G, R, const I: usize, const N: usize>(
        &mut self,
        n: usize,
        config: &ValidAdaptiveConfig<T, D, I>,
        run: &mut Transfer<'_, T, G, D, I, N>,
        evidence: &mut Evidence<'_, T, N, I>,
        rng: &mut R,
    ) -> Result<()>
    where
        G: GenerativeModel<T, State = [T; D]>,
        R: Rng + ?Sized,
        Dims<D, I>: StatePlusAction,
    {
        let actions = run.target.num_actions();
        let mut left = n;
        let mut first = true;
        while left > 0 {
            let mut state = config.start;
            for _ in 0..config.horizon {
                if left == 0 {
                    break;
                }
                let explore = !first && crate::rng::uniform::<T, R>(rng) < config.epsilon;
                let action = if explore {
                    crate::rng::uniform_index(rng, actions)
                } else {
                    run.fqi.greedy_action(state)?
                };
                let record = run.target.query(state, action, rng)?;
                evidence.append(config, run, record)?;
                if let Some(slot) = self.path.get_mut(self.len) {
                    *slot = state;
                    self.len += 1;
                }
                left -= 1;
                if record.absorbing {
                    break;
                }
                state = record.next_state;
            }
            first = false;
        }
        Ok(())
    }
}
