//! The verification phase: rollouts of the current greedy policy in the generative model
//! from the plant's start states, each visited state kept as this step's path (the
//! relevance kernel's centres), each greedy rollout checked against the plan's promise
//! ([`super::safeguard`]).

use super::ValidAdaptiveConfig;
use super::evidence::Evidence;
use super::safeguard::{PlanCheck, Rollout};
use super::schedule;
use crate::error::{Error, Result};
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
    /// The rollouts' start states (empty: the configuration's start alone).
    starts: &'a [[T; D]],
    /// The start of the next rollout, an index into `starts` (cycles over the run).
    next: usize,
    /// The greedy rollouts of the current sub-batch against the plan's promise.
    check: PlanCheck<T>,
}

impl<'a, T: Real, const D: usize> Verification<'a, T, D> {
    /// An empty path over `path`.
    ///
    /// Errors: `path` shorter than `budget` ([`crate::Error::BufferTooSmall`]).
    pub(super) fn new(path: &'a mut [[T; D]], budget: usize) -> Result<Self> {
        short(path.len(), budget, buffer::PATH)?;
        Ok(Self {
            path,
            len: 0,
            starts: &[],
            next: 0,
            check: PlanCheck::empty(),
        })
    }

    /// Verifies from every state of `starts`.
    ///
    /// Errors: `starts` empty ([`Error::EmptyData`]) or with a non-finite coordinate
    /// ([`Error::NonFinite`] `start`); nothing changes then.
    pub(super) fn set_starts(&mut self, starts: &'a [[T; D]]) -> Result<()> {
        if starts.is_empty() {
            return Err(Error::EmptyData);
        }
        for s in starts {
            crate::error::ensure_all_finite(s, "start")?;
        }
        self.starts = starts;
        self.next = 0;
        Ok(())
    }

    /// The rollouts' start states (`start` alone without [`Verification::set_starts`]).
    pub(super) fn starts<'s>(&'s self, start: &'s [T; D]) -> &'s [[T; D]] {
        if self.starts.is_empty() {
            core::slice::from_ref(start)
        } else {
            self.starts
        }
    }

    /// Forgets the path (a new step).
    pub(super) fn clear(&mut self) {
        self.len = 0;
    }

    /// A new run: the path forgotten, the next rollout from the first start.
    pub(super) fn reset(&mut self) {
        self.len = 0;
        self.next = 0;
        self.check = PlanCheck::empty();
    }

    /// A new sub-batch: no rollout checked yet.
    pub(super) fn start_check(&mut self) {
        self.check = PlanCheck::empty();
    }

    /// The greedy rollouts of the current sub-batch against the plan's promise.
    pub(super) fn check(&self) -> &PlanCheck<T> {
        &self.check
    }

    /// The states verified in the current step.
    pub(super) fn states(&self) -> &[[T; D]] {
        self.path.get(..self.len).unwrap_or(&[])
    }

    /// `n` queries along rollouts from the start states, cycling over them (greedy for the
    /// first rollout of the call from each start, ε-greedy after; each at most
    /// [`schedule::rollout_length`] steps), each state kept in the path and each record in
    /// `run`'s `D₀`; each greedy rollout of a fitted plan is checked against its promise.
    pub(super) fn run<G, R, const I: usize, const N: usize>(
        &mut self,
        n: usize,
        checks: bool,
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
        let m = self.starts(&config.start).len().max(1);
        let length =
            schedule::rollout_length(config.awfqi.budget, config.verify, config.horizon, m);
        let gamma = config.awfqi.fqi.discount();
        let mut left = n;
        let mut rollouts = 0usize;
        while left > 0 {
            let first = rollouts < m;
            let mut state = self
                .starts(&config.start)
                .get(self.next % m)
                .copied()
                .unwrap_or(config.start);
            self.next = (self.next + 1) % m;
            rollouts += 1;
            let mut checked: Option<Rollout<T>> = None;
            let mut absorbed = false;
            for t in 0..length {
                if left == 0 {
                    break;
                }
                let explore = !first && crate::rng::uniform::<T, R>(rng) < config.epsilon;
                let action = if explore {
                    crate::rng::uniform_index(rng, actions)
                } else {
                    run.fqi.greedy_action(state)?
                };
                if t == 0 && first && checks {
                    checked = Some(Rollout::new(run.fqi.value(state, action)?));
                }
                let record = run.target.query(state, action, rng)?;
                evidence.append(config, run, record)?;
                if let Some(slot) = self.path.get_mut(self.len) {
                    *slot = state;
                    self.len += 1;
                }
                if let Some(c) = checked.as_mut() {
                    c.step(record.reward, gamma);
                }
                left -= 1;
                if record.absorbing {
                    absorbed = true;
                    break;
                }
                state = record.next_state;
            }
            if let Some(c) = checked {
                let v = if absorbed {
                    T::ZERO
                } else {
                    run.fqi.max_value(state)?
                };
                c.finish(v, &mut self.check);
            }
        }
        Ok(())
    }
}
