//! The Q-function approximators of weighted FQI behind one type, so the AWFQI loop (and a
//! user) picks one by configuration: the table of [`CellGrid`] cells, tile coding
//! ([`Tilings`]), kernel averaging over the records ([`Neighbours`]), both averaged, or
//! Extra-Trees ([`ExtraTrees`]), or a model sweep ([`ModelSweep`]). The table and tiles keep
//! their values in [`FqiEntry`] storage, kernel averaging in [`KnnRecord`]s and links, the
//! trees in [`TreeRecord`]s and [`TreeNode`]s, the sweep in [`SweepEntry`]s and
//! [`SweepNode`]s ([`QStorage`] lends any of them). Only the trees draw random numbers,
//! from the caller's generator.

use super::iteration;
use super::{
    AnchorEntry, AnchorFqi, AnchorParts, AnchorSweep, CellGrid, ExtraTrees, FqiConfig, FqiEntry,
    HybridFqi, KnnFqi, KnnRecord, ModelSweep, Neighbours, SampleSet, SweepEntry, SweepFqi,
    SweepNode, TabularFqi, TileFqi, Tilings, TreeFqi, TreeNode, TreeRecord,
};
use crate::error::Result;
use crate::float::Real;
use rand_core::Rng;

/// The memory a [`QFunction`] is built in: FQI entries for a table or tiles, records and
/// links for kernel averaging, records and nodes for trees (what an approximator does not
/// use may be empty).
#[derive(Debug)]
pub struct QStorage<'a, T, const D: usize> {
    /// Entries of a table or tiles ([`Approximator::required_entries`]).
    pub entries: &'a mut [FqiEntry<T>],
    /// One record slot per sample a kernel-averaging fit may hold.
    pub records: &'a mut [KnnRecord<T, D>],
    /// Its links ([`Neighbours::required_links`] for the record slots).
    pub links: &'a mut [u16],
    /// One record slot per sample a tree fit may hold.
    pub tree_records: &'a mut [TreeRecord<T, D>],
    /// The trees' nodes ([`ExtraTrees::required_nodes`]).
    pub nodes: &'a mut [TreeNode<T>],
    /// A model sweep's entries ([`ModelSweep::required_entries`]).
    pub sweep_entries: &'a mut [SweepEntry<T, D>],
    /// A model sweep's nodes ([`ModelSweep::nodes`], [`AnchorSweep::nodes`]).
    pub sweep_nodes: &'a mut [SweepNode<T>],
    /// A sweep on anchors' entries ([`AnchorSweep::required_entries`]).
    pub anchor_entries: &'a mut [AnchorEntry<T>],
    /// Its node positions ([`AnchorSweep::nodes`]).
    pub anchor_positions: &'a mut [[T; D]],
    /// Its landing scratch ([`AnchorSweep::nodes`]).
    pub anchor_landings: &'a mut [[T; D]],
}

impl<T, const D: usize> Default for QStorage<'_, T, D> {
    /// No memory at all (fill in what the approximator uses).
    fn default() -> Self {
        Self {
            entries: &mut [],
            records: &mut [],
            links: &mut [],
            tree_records: &mut [],
            nodes: &mut [],
            sweep_entries: &mut [],
            sweep_nodes: &mut [],
            anchor_entries: &mut [],
            anchor_positions: &mut [],
            anchor_landings: &mut [],
        }
    }
}

impl<'a, T, const D: usize> From<&'a mut [FqiEntry<T>]> for QStorage<'a, T, D> {
    fn from(entries: &'a mut [FqiEntry<T>]) -> Self {
        Self {
            entries,
            ..Self::default()
        }
    }
}

/// An array of entries lends itself as a slice would (`&mut [FqiEntry<f32>; 484]`).
impl<'a, T, const D: usize, const E: usize> From<&'a mut [FqiEntry<T>; E]> for QStorage<'a, T, D> {
    fn from(entries: &'a mut [FqiEntry<T>; E]) -> Self {
        Self::from(entries.as_mut_slice())
    }
}

/// A tree storage block lends itself as [`TreeStorage::storage`](super::TreeStorage::storage)
/// does, so `build(actions, &mut trees)` reads like `build(actions, &mut entries)`.
impl<'a, T: Real, const D: usize, const R: usize, const N: usize>
    From<&'a mut super::TreeStorage<T, D, R, N>> for QStorage<'a, T, D>
{
    fn from(storage: &'a mut super::TreeStorage<T, D, R, N>) -> Self {
        storage.storage()
    }
}

/// A kernel-averaging storage block lends itself as
/// [`KnnStorage::storage`](super::KnnStorage::storage) does.
impl<'a, T: Real, const D: usize, const R: usize, const L: usize>
    From<&'a mut super::KnnStorage<T, D, R, L>> for QStorage<'a, T, D>
{
    fn from(storage: &'a mut super::KnnStorage<T, D, R, L>) -> Self {
        storage.storage()
    }
}

/// A model sweep's storage block lends itself as
/// [`SweepStorage::storage`](super::SweepStorage::storage) does.
impl<'a, T: Real, const D: usize, const E: usize, const K: usize>
    From<&'a mut super::SweepStorage<T, D, E, K>> for QStorage<'a, T, D>
{
    fn from(storage: &'a mut super::SweepStorage<T, D, E, K>) -> Self {
        storage.storage()
    }
}

/// A sweep on anchors' storage block lends itself as
/// [`AnchorStorage::storage`](super::AnchorStorage::storage) does.
impl<'a, T: Real, const D: usize, const E: usize, const M: usize>
    From<&'a mut super::AnchorStorage<T, D, E, M>> for QStorage<'a, T, D>
{
    fn from(storage: &'a mut super::AnchorStorage<T, D, E, M>) -> Self {
        storage.storage()
    }
}

/// Which approximator, and its geometry: what a caller chooses before storage exists.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Approximator<T, const D: usize> {
    /// One table of cells ([`TabularFqi`]).
    Table(CellGrid<T, D>),
    /// Averaged offset tilings ([`TileFqi`]).
    Tiles(Tilings<T, D>),
    /// Kernel averaging over the `k` nearest records ([`KnnFqi`]).
    Knn(Neighbours<T, D>),
    /// Both tile coding and kernel averaging, each fitted by FQI on the same data, their
    /// Q-values averaged (an ensemble of two averagers: the tiles' coarse, consistent
    /// values where the records are sparse, the records' local ones where they are dense).
    Hybrid(Tilings<T, D>, Neighbours<T, D>),
    /// Per-action Extra-Trees forests ([`TreeFqi`]).
    Trees(ExtraTrees),
    /// Value iteration on a grid model of the records ([`SweepFqi`]).
    Sweep(ModelSweep<T, D>),
    /// Value iteration on a model of the records at representative states placed from
    /// them, within a node budget ([`AnchorFqi`]).
    Anchors(AnchorSweep<T, D>),
}

impl<T: Real, const D: usize> From<AnchorSweep<T, D>> for Approximator<T, D> {
    fn from(anchors: AnchorSweep<T, D>) -> Self {
        Approximator::Anchors(anchors)
    }
}

impl<T: Real, const D: usize> From<ModelSweep<T, D>> for Approximator<T, D> {
    fn from(sweep: ModelSweep<T, D>) -> Self {
        Approximator::Sweep(sweep)
    }
}

impl<T: Real, const D: usize> From<ExtraTrees> for Approximator<T, D> {
    fn from(forests: ExtraTrees) -> Self {
        Approximator::Trees(forests)
    }
}

impl<T: Real, const D: usize> From<Neighbours<T, D>> for Approximator<T, D> {
    fn from(neighbours: Neighbours<T, D>) -> Self {
        Approximator::Knn(neighbours)
    }
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
    /// Number of [`FqiEntry`] it needs with `actions` actions (`None` on overflow; 0 for
    /// kernel averaging and trees, which need records and links or nodes instead).
    pub fn required_entries(&self, actions: usize) -> Option<usize> {
        match self {
            Approximator::Table(grid) => TabularFqi::required_entries(grid, actions),
            Approximator::Tiles(tilings) => TileFqi::required_entries(tilings, actions),
            Approximator::Knn(_) => Some(0),
            Approximator::Hybrid(tilings, _) => TileFqi::required_entries(tilings, actions),
            Approximator::Trees(_) | Approximator::Sweep(_) | Approximator::Anchors(_) => Some(0),
        }
    }

    /// A Q-function that is 0 everywhere in `storage`: for a table or tiles, entries as an
    /// array or a slice (`&mut [FqiEntry<T>; E]`, `&mut [FqiEntry<T>]`); for trees or kernel
    /// averaging or a model sweep, a [`TreeStorage`](super::TreeStorage),
    /// [`KnnStorage`](super::KnnStorage) or [`SweepStorage`](super::SweepStorage) block (or
    /// its `storage()`); any [`QStorage`].
    ///
    /// ```
    /// use awfqi::prelude::{Approximator, CellGrid, FqiEntry};
    /// # fn main() -> awfqi::Result<()> {
    /// let mut entries = [FqiEntry::<f32>::EMPTY; 4 * 4 * 2]; // 4 × 4 cells, 2 actions
    /// let grid = CellGrid::cube(0.0, 1.0, 4)?;
    /// let q = Approximator::Table(grid).build(2, &mut entries)?; // the array itself
    /// assert_eq!(q.value([0.3, 0.9], 1)?, 0.0);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// Errors: those of [`TabularFqi::new`], [`TileFqi::new`], [`KnnFqi::new`] or
    /// [`TreeFqi::new`].
    pub fn build<'a>(
        self,
        actions: usize,
        storage: impl Into<QStorage<'a, T, D>>,
    ) -> Result<QFunction<'a, T, D>> {
        let storage = storage.into();
        Ok(match self {
            Approximator::Table(grid) => {
                QFunction::Tabular(TabularFqi::new(grid, actions, storage.entries)?)
            }
            Approximator::Tiles(tilings) => {
                QFunction::Tiles(TileFqi::new(tilings, actions, storage.entries)?)
            }
            Approximator::Knn(neighbours) => QFunction::Knn(KnnFqi::new(
                neighbours,
                actions,
                storage.records,
                storage.links,
            )?),
            Approximator::Hybrid(tilings, neighbours) => QFunction::Hybrid(HybridFqi::new(
                TileFqi::new(tilings, actions, storage.entries)?,
                KnnFqi::new(neighbours, actions, storage.records, storage.links)?,
            )?),
            Approximator::Trees(forests) => QFunction::Trees(TreeFqi::new(
                forests,
                actions,
                storage.tree_records,
                storage.nodes,
            )?),
            Approximator::Sweep(sweep) => QFunction::Sweep(SweepFqi::new(
                sweep,
                actions,
                storage.sweep_entries,
                storage.sweep_nodes,
            )?),
            Approximator::Anchors(anchors) => QFunction::Anchors(AnchorFqi::new(
                anchors,
                actions,
                AnchorParts {
                    entries: storage.anchor_entries,
                    nodes: storage.sweep_nodes,
                    positions: storage.anchor_positions,
                    landings: storage.anchor_landings,
                },
            )?),
        })
    }
}

/// Calls `$body` with `$q` bound to the approximator behind a [`QFunction`] (`$self` or
/// `&mut $self`): the one place that lists the variants for the methods every approximator
/// has.
macro_rules! each {
    ($self:expr, $q:ident => $body:expr) => {
        match $self {
            QFunction::Tabular($q) => $body,
            QFunction::Tiles($q) => $body,
            QFunction::Knn($q) => $body,
            QFunction::Hybrid($q) => $body,
            QFunction::Trees($q) => $body,
            QFunction::Sweep($q) => $body,
            QFunction::Anchors($q) => $body,
        }
    };
}

/// A fitted (or fresh) Q-function of any approximator.
#[derive(Debug)]
pub enum QFunction<'a, T, const D: usize> {
    /// A table of cells.
    Tabular(TabularFqi<'a, T, D>),
    /// Tile coding.
    Tiles(TileFqi<'a, T, D>),
    /// Kernel averaging over the records.
    Knn(KnnFqi<'a, T, D>),
    /// The mean of tile coding and kernel averaging.
    Hybrid(HybridFqi<'a, T, D>),
    /// Per-action Extra-Trees forests.
    Trees(TreeFqi<'a, T, D>),
    /// A model sweep.
    Sweep(SweepFqi<'a, T, D>),
    /// A model sweep on anchors.
    Anchors(AnchorFqi<'a, T, D>),
}

impl<'a, T: Real, const D: usize> QFunction<'a, T, D> {
    /// Number of actions.
    pub fn actions(&self) -> usize {
        each!(self, q => q.actions())
    }

    /// The entries in use (layout per approximator: [`TabularFqi::entries`],
    /// [`TileFqi::entries`]; none for kernel averaging or trees, see [`KnnFqi::records`],
    /// [`TreeFqi::records`]).
    pub fn entries(&self) -> &[FqiEntry<T>] {
        match self {
            QFunction::Tabular(q) => q.entries(),
            QFunction::Tiles(q) => q.entries(),
            QFunction::Hybrid(q) => q.tiles().entries(),
            QFunction::Knn(_)
            | QFunction::Trees(_)
            | QFunction::Sweep(_)
            | QFunction::Anchors(_) => &[],
        }
    }

    /// The table, if this is one.
    pub fn as_tabular(&self) -> Option<&TabularFqi<'a, T, D>> {
        match self {
            QFunction::Tabular(q) => Some(q),
            QFunction::Tiles(_)
            | QFunction::Knn(_)
            | QFunction::Hybrid(_)
            | QFunction::Trees(_)
            | QFunction::Sweep(_)
            | QFunction::Anchors(_) => None,
        }
    }

    /// Resets Q to 0 everywhere.
    pub fn clear(&mut self) {
        each!(self, q => q.clear())
    }

    /// Fits Q from scratch by weighted FQI on sets produced by an iterator; the trees draw
    /// their randomness from `rng` (the other approximators draw nothing).
    ///
    /// Errors: those of [`TabularFqi::fit`], and for the approximators that keep the
    /// records more records than slots ([`crate::Error::CapacityExceeded`]).
    pub fn fit_sets<'s, I, R>(&mut self, sets: I, config: &FqiConfig<T>, rng: &mut R) -> Result<()>
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        each!(self, q => iteration::fit(q, sets, config, rng))
    }

    /// Fits Q from scratch by weighted FQI on the union of `sets` (randomness as
    /// [`QFunction::fit_sets`]).
    ///
    /// Errors: those of [`QFunction::fit_sets`].
    pub fn fit<R: Rng + ?Sized>(
        &mut self,
        sets: &[SampleSet<'_, T, D>],
        config: &FqiConfig<T>,
        rng: &mut R,
    ) -> Result<()> {
        self.fit_sets(sets.iter().copied(), config, rng)
    }

    /// `Q(state, action)`.
    ///
    /// Errors: a non-finite state, an action `≥ actions`.
    pub fn value(&self, state: [T; D], action: usize) -> Result<T> {
        each!(self, q => q.value(state, action))
    }

    /// `maxₐ Q(state, a)`.
    ///
    /// Errors: a non-finite state.
    pub fn max_value(&self, state: [T; D]) -> Result<T> {
        each!(self, q => q.max_value(state))
    }

    /// The greedy action (ties as the approximator breaks them: an action with data first,
    /// then the smallest index).
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        each!(self, q => q.greedy_action(state))
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

/// [`Greedy`] by each type's own `greedy_action`.
macro_rules! greedy_by_greedy_action {
    ($($q:ident),*) => {$(
        impl<T: Real, const D: usize> Greedy<T, D> for $q<'_, T, D> {
            fn greedy(&self, state: [T; D]) -> Result<usize> {
                self.greedy_action(state)
            }
        }
    )*};
}

greedy_by_greedy_action!(
    TabularFqi, TileFqi, KnnFqi, HybridFqi, TreeFqi, SweepFqi, AnchorFqi, QFunction
);
