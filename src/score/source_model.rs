//! The realistic source model (§11.2): a source's mean functions estimated by GPs fitted on
//! its records alone.

use crate::error::Result;
use crate::float::Real;
use crate::gp::Gp;
use crate::model::{SourceMeans, SourceModel};
use crate::record_gp::{Dims, InputDim, StatePlusAction, input};

/// The realistic model of one source (§11.2): the posterior means of GPs fitted on that
/// source's records only, at `z = (s, a)` (`I = D + 1`).
///
/// The next-state GPs are optional: without them `ρ_s′ = 0`, so the next-state scores are
/// 0, which saves `D` GP fits per source when only `V_r` drives sampling (the thesis's
/// choice). Borrows the GPs; size: `D + 2` pointers.
#[derive(Debug, Clone, Copy)]
pub struct GpSourceModel<'g, T, const N: usize, const D: usize, const I: usize> {
    reward: &'g Gp<T, N, I>,
    next_state: Option<[&'g Gp<T, N, I>; D]>,
}

impl<'g, T: Real, const N: usize, const D: usize, const I: usize> GpSourceModel<'g, T, N, D, I> {
    /// A model from the source's reward GP and, optionally, one GP per next-state
    /// coordinate.
    pub fn new(reward: &'g Gp<T, N, I>, next_state: Option<[&'g Gp<T, N, I>; D]>) -> Self {
        let () = InputDim::<D, I>::CHECK;
        Self { reward, next_state }
    }
}

impl<T: Real, const N: usize, const D: usize, const I: usize> SourceModel<T, D>
    for GpSourceModel<'_, T, N, D, I>
where
    Dims<D, I>: StatePlusAction,
{
    fn predict(&self, state: [T; D], action: usize) -> Result<SourceMeans<T, D>> {
        let z = input(state, action);
        let reward = self.reward.predict(&z)?.mean;
        let mut next_state = [T::ZERO; D];
        if let Some(gps) = self.next_state {
            for (n, gp) in next_state.iter_mut().zip(gps) {
                *n = gp.predict(&z)?.mean;
            }
        }
        Ok(SourceMeans { reward, next_state })
    }
}
