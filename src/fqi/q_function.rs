//! The Q-function approximators of weighted FQI behind one type, so the AWFQI loop (and a
//! user) picks one by configuration: the table of [`CellGrid`] cells or tile coding
//! ([`Tilings`]). Both keep their values in the same [`FqiEntry`] storage.

use super::{CellGrid, FqiConfig, FqiEntry, SampleSet, TabularFqi, TileFqi, Tilings};
use crate::{Real, Result};

/// Which approximator, and its geometry: what a caller chooses before storage exists.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Approximator<T, const D: usize> {
    /// One table of cells ([`TabularFqi`]).
    Table(CellGrid<T, D>),
    /// Averaged offset tilings ([`TileFqi`]).
    Tiles(Tilings<T, D>),
}

impl<T: Real, const D: usize> From<CellGrid<T, D>> for Approximator<T, D> {
    fn from(grid: CellGrid<T, D>) -> Self {
        Approximator::Table(grid)
    }
}

impl<T: Real, const D: usize> From<Tilings<T, D>> for Approximator<T, D> {
    fn from(tilings: Tilings<T, D>) -> Self {
        Approximator::Tiles(tilings)
    }
}

impl<T: Real, const D: usize> Approximator<T, D> {
    /// Number of [`FqiEntry`] it needs with `actions` actions (`None` on overflow).
    pub fn required_entries(&self, actions: usize) -> Option<usize> {
        match self {
            Approximator::Table(grid) => TabularFqi::required_entries(grid, actions),
            Approximator::Tiles(tilings) => TileFqi::required_entries(tilings, actions),
        }
    }

    /// A Q-function that is 0 everywhere in `storage`.
    ///
    /// Errors: those of [`TabularFqi::new`] or [`TileFqi::new`].
    pub fn build(self, actions: usize, storage: &mut [FqiEntry<T>]) -> Result<QFunction<'_, T, D>> {
        Ok(match self {
            Approximator::Table(grid) => {
                QFunction::Tabular(TabularFqi::new(grid, actions, storage)?)
            }
            Approximator::Tiles(tilings) => {
                QFunction::Tiles(TileFqi::new(tilings, actions, storage)?)
            }
        })
    }
}

/// A fitted (or fresh) Q-function of either approximator.
#[derive(Debug)]
pub enum QFunction<'a, T, const D: usize> {
    /// A table of cells.
    Tabular(TabularFqi<'a, T, D>),
    /// Tile coding.
    Tiles(TileFqi<'a, T, D>),
}

impl<'a, T: Real, const D: usize> QFunction<'a, T, D> {
    /// Number of actions.
    pub fn actions(&self) -> usize {
        match self {
            QFunction::Tabular(q) => q.actions(),
            QFunction::Tiles(q) => q.actions(),
        }
    }

    /// The storage in use (layout per approximator: [`TabularFqi::entries`],
    /// [`TileFqi::entries`]).
    pub fn entries(&self) -> &[FqiEntry<T>] {
        match self {
            QFunction::Tabular(q) => q.entries(),
            QFunction::Tiles(q) => q.entries(),
        }
    }

    /// The table, if this is one.
    pub fn as_tabular(&self) -> Option<&TabularFqi<'a, T, D>> {
        match self {
            QFunction::Tabular(q) => Some(q),
            QFunction::Tiles(_) => None,
        }
    }

    /// Resets Q to 0 everywhere.
    pub fn clear(&mut self) {
        match self {
            QFunction::Tabular(q) => q.clear(),
            QFunction::Tiles(q) => q.clear(),
        }
    }

    /// Fits Q from scratch by weighted FQI on sets produced by an iterator.
    ///
    /// Errors: those of [`TabularFqi::fit`].
    pub fn fit_sets<'s, I>(&mut self, sets: I, config: &FqiConfig<T>) -> Result<()>
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        match self {
            QFunction::Tabular(q) => q.fit_sets(sets, config),
            QFunction::Tiles(q) => q.fit_sets(sets, config),
        }
    }

    /// Fits Q from scratch by weighted FQI on the union of `sets`.
    ///
    /// Errors: those of [`TabularFqi::fit`].
    pub fn fit(&mut self, sets: &[SampleSet<'_, T, D>], config: &FqiConfig<T>) -> Result<()> {
        self.fit_sets(sets.iter().copied(), config)
    }

    /// `Q(state, action)`.
    ///
    /// Errors: a non-finite state, an action `≥ actions`.
    pub fn value(&self, state: [T; D], action: usize) -> Result<T> {
        match self {
            QFunction::Tabular(q) => q.value(state, action),
            QFunction::Tiles(q) => q.value(state, action),
        }
    }

    /// `maxₐ Q(state, a)`.
    ///
    /// Errors: a non-finite state.
    pub fn max_value(&self, state: [T; D]) -> Result<T> {
        match self {
            QFunction::Tabular(q) => q.max_value(state),
            QFunction::Tiles(q) => q.max_value(state),
        }
    }

    /// The greedy action (ties: an action with data first, then the smallest index).
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        match self {
            QFunction::Tabular(q) => q.greedy_action(state),
            QFunction::Tiles(q) => q.greedy_action(state),
        }
    }
}

/// A Q-function that can act greedily on `D`-dimensional states: what evaluation needs
/// ([`crate::evaluation::evaluate_greedy`]), whichever approximator is behind it.
pub trait Greedy<T, const D: usize> {
    /// The greedy action in `state` (ties as the approximator breaks them).
    ///
    /// Errors: a non-finite state.
    fn greedy(&self, state: [T; D]) -> Result<usize>;
}

impl<T: Real, const D: usize> Greedy<T, D> for TabularFqi<'_, T, D> {
    fn greedy(&self, state: [T; D]) -> Result<usize> {
        self.greedy_action(state)
    }
}

impl<T: Real, const D: usize> Greedy<T, D> for TileFqi<'_, T, D> {
    fn greedy(&self, state: [T; D]) -> Result<usize> {
        self.greedy_action(state)
    }
}

impl<T: Real, const D: usize> Greedy<T, D> for QFunction<'_, T, D> {
    fn greedy(&self, state: [T; D]) -> Result<usize> {
        self.greedy_action(state)
    }
}
