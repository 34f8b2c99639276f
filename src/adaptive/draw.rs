//! The drawn queries: a fresh subset of candidate rows scored by where the target
//! surprised the sources, where they disagree and where the residual GP is unsure, near this
//! step's verified states; then the queries drawn from those scores.

use super::ValidAdaptiveConfig;
use super::candidates::{self, Candidate};
use super::evidence::Evidence;
use crate::error::{Error, Result};
use crate::float::Real;
use crate::gp::Hyperparameters;
use crate::model::GenerativeModel;
use crate::record_gp::{Dims, StatePlusAction, input};
use crate::score::RowSet;
use crate::thesis::builder::{buffer, short};
use crate::thesis::transfer::Transfer;
use crate::weights::{NoiseSubtraction, StdTransform};
use rand_core::Rng;

/// The candidate slots of a sub-batch.
#[derive(Debug)]
pub(super) struct Draw<'a, T> {
    slots: &'a mut [Candidate<T>],
}

impl<'a, T: Real> Draw<'a, T> {
    /// The draw over `slots`, which must hold the `needed` candidates of a sub-batch.
    ///
    /// Errors: `slots` shorter than `needed` ([`Error::BufferTooSmall`]).
    pub(super) fn new(slots: &'a mut [Candidate<T>], needed: usize) -> Result<Self> {
        short(slots.len(), needed, buffer::CANDIDATES)?;
        Ok(Self { slots })
    }

    /// `n` queries drawn from a fresh candidate subset of `rows` by the adaptive score;
    /// `residual` when `run.gp` holds the residual GP of the last re-plan, `path` the states
    /// verified in this step.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run<G, R, const D: usize, const I: usize, const N: usize>(
        &mut self,
        n: usize,
        config: &ValidAdaptiveConfig<T, D, I>,
        rows: &RowSet<'_, T, D>,
        path: &[[T; D]],
        residual: bool,
        run: &mut Transfer<'_, T, G, D, I, N>,
        evidence: &mut Evidence<'_, T, N, I>,
        rng: &mut R,
    ) -> Result<()>
    where
        G: GenerativeModel<T, State = [T; D]>,
        R: Rng + ?Sized,
        Dims<D, I>: StatePlusAction,
    {
        if n == 0 {
            return Ok(());
        }
        let count = rows.len();
        let c = config.candidates.min(count);
        let capacity = self.slots.len();
        let slots = self
            .slots
            .get_mut(..c)
            .ok_or(Error::CapacityExceeded { capacity })?;
        let totals = {
            let residual = residual.then_some(&*run.gp);
            let mut smallest = T::INFINITY;
            // Pass 1: rows and the factors that do not depend on the batch.
            for slot in slots.iter_mut() {
                let row = crate::rng::uniform_index(rng, count);
                let (state, action) = rows
                    .row(row)
                    .ok_or(Error::OutOfRange { parameter: "row" })?;
                let z = input(state, action);
                let relevance = if config.decision {
                    candidates::relevance(&state, path, &config.bounds, config.relevance_width)
                } else {
                    T::ONE
                };
                let (_, disagreement) = evidence.spread(&z)?;
                let (surprise, variance) = match residual {
                    Some(gp) => {
                        let p = gp.predict(&z)?;
                        smallest = smallest.min(p.noisy_variance);
                        let s = if config.surprise {
                            p.mean.squared()
                        } else {
                            T::ZERO
                        };
                        (s, p.noisy_variance)
                    }
                    None => (T::ZERO, T::ZERO),
                };
                *slot = Candidate {
                    row,
                    relevance,
                    score: surprise + disagreement,
                    variance,
                };
            }
            // Pass 2: the uncertainty factor needs the batch's smallest variance.
            match residual {
                Some(gp) if config.uncertainty => {
                    let hyper: &Hyperparameters<T, I> = gp.hyperparameters();
                    let signal = hyper.signal_variance.max(T::MIN_POSITIVE);
                    let transform = StdTransform::new(
                        NoiseSubtraction::Reference,
                        hyper.noise_variance,
                        smallest,
                    )?;
                    let share = move |v: T| transform.apply(v).squared() / signal;
                    let u = move |v: T| share(v).min(T::ONE);
                    candidates::finish_scores(slots, Some(&u))
                }
                _ => candidates::finish_scores(slots, None),
            }
        };
        // Pass 3: the queries, each drawn by a scan of the slots' probabilities (a few
        // queries per sub-batch: cheaper in memory than a table, and as fast).
        let floor = config.floor;
        let probability = |s: &Candidate<T>| candidates::probability(s, totals, floor, c);
        let total = slots.iter().map(probability).fold(T::ZERO, |a, p| a + p);
        for _ in 0..n {
            let u = crate::rng::uniform::<T, R>(rng) * total;
            let mut row = slots.last().map_or(0, |s| s.row);
            let mut sum = T::ZERO;
            for s in slots.iter() {
                sum += probability(s);
                if u < sum {
                    row = s.row;
                    break;
                }
            }
            let (state, action) = rows
                .row(row)
                .ok_or(Error::OutOfRange { parameter: "row" })?;
            let record = run.target.query(state, action, rng)?;
            evidence.append(config, run, record)?;
        }
        Ok(())
    }
}
