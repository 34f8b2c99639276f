//! Tile coding and kernel averaging fitted side by side on the same data, their Q-values
//! averaged: an ensemble of two averagers, the tiles' coarse, consistent values where the
//! records are sparse and the records' local ones where they are dense. Memory: that of
//! both ([`TileFqi`]'s entries, [`KnnFqi`]'s records and links).

use super::argmax::ArgMax;
use super::iteration::{self, NoDraws, Regressor};
use super::{FqiConfig, KnnFqi, SampleSet, TileFqi};
use crate::error::{Error, Result};
use crate::float::Real;
use rand_core::Rng;

/// The mean of a tile-coding and a kernel-averaging Q-function, each fitted by weighted FQI
/// on the same sets (module docs).
#[derive(Debug)]
pub struct HybridFqi<'a, T, const D: usize> {
    tiles: TileFqi<'a, T, D>,
    knn: KnnFqi<'a, T, D>,
}

impl<'a, T: Real, const D: usize> HybridFqi<'a, T, D> {
    /// The ensemble of `tiles` and `knn`, which must have the same action count.
    ///
    /// Errors: different action counts ([`Error::InvalidParameter`] `actions`).
    pub fn new(tiles: TileFqi<'a, T, D>, knn: KnnFqi<'a, T, D>) -> Result<Self> {
        if tiles.actions() != knn.actions() {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        Ok(Self { tiles, knn })
    }

    /// The tile-coding half.
    pub fn tiles(&self) -> &TileFqi<'a, T, D> {
        &self.tiles
    }

    /// The kernel-averaging half.
    pub fn knn(&self) -> &KnnFqi<'a, T, D> {
        &self.knn
    }

    /// Number of actions.
    pub fn actions(&self) -> usize {
        self.tiles.actions()
    }

    /// Resets Q to 0 everywhere.
    pub fn clear(&mut self) {
        self.tiles.clear();
        self.knn.clear();
    }

    /// Fits both halves from scratch by weighted FQI on the union of `sets`.
    ///
    /// Everything is checked before either half changes. Errors: those of
    /// [`KnnFqi::fit`] (which include the tiles').
    pub fn fit(&mut self, sets: &[SampleSet<'_, T, D>], config: &FqiConfig<T>) -> Result<()> {
        self.fit_sets(sets.iter().copied(), config)
    }

    /// [`HybridFqi::fit`] on sets produced by an iterator (cloned once per pass).
    ///
    /// Errors: those of [`HybridFqi::fit`].
    pub fn fit_sets<'s, I>(&mut self, sets: I, config: &FqiConfig<T>) -> Result<()>
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        iteration::fit(self, sets, config, &mut NoDraws)
    }

    /// `Q(state, action)`: the mean of the halves.
    ///
    /// Errors: a non-finite state, an action `≥ actions`.
    pub fn value(&self, state: [T; D], action: usize) -> Result<T> {
        Ok((self.tiles.value(state, action)? + self.knn.value(state, action)?) / T::from_f64(2.0))
    }

    /// `maxₐ Q(state, a)`.
    ///
    /// Errors: a non-finite state.
    pub fn max_value(&self, state: [T; D]) -> Result<T> {
        let mut best = T::NEG_INFINITY;
        for a in 0..self.actions() {
            best = best.max(self.value(state, a)?);
        }
        Ok(best)
    }

    /// The greedy action: the largest mean value, ties to the smallest index.
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        let mut best = ArgMax::new();
        for a in 0..self.actions() {
            best.offer(a, self.value(state, a)?, true);
        }
        Ok(best.action())
    }
}

/// Both halves' regressions, one after the other (neither draws, so the order is free).
impl<T: Real, const D: usize> Regressor<T, D> for HybridFqi<'_, T, D> {
    fn actions(&self) -> usize {
        self.tiles.actions()
    }

    fn capacity(&self) -> Option<usize> {
        Regressor::capacity(&self.knn)
    }

    fn fit_reward_model<'s, I, R>(
        &mut self,
        sets: I,
        total: usize,
        config: &FqiConfig<T>,
        rng: &mut R,
    ) where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        self.knn.fit_reward_model(sets.clone(), total, config, rng);
        self.tiles.fit_reward_model(sets, total, config, rng);
    }

    fn bellman_iteration<'s, I, R>(&mut self, sets: I, k: usize, config: &FqiConfig<T>, rng: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        self.knn.bellman_iteration(sets.clone(), k, config, rng);
        self.tiles.bellman_iteration(sets, k, config, rng);
    }
}
