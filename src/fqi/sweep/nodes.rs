//! Where a model sweep's nodes lie and how a point's value is read from them: the one
//! interface the sweep's model fit and its value iteration are written against, so a grid
//! of corners ([`super::ModelSweep`]) and representative states placed from the records
//! ([`crate::fqi::AnchorSweep`]) share both.

use super::SweepNode;
use crate::float::Real;
use crate::fqi::{RewardModel, SampleSet};

/// What a node layout stores per node and action, for any scalar (so a Q-function type
/// names it without bounds). Sealed: public only so the sweep's types can name it.
pub trait Layout<T, const D: usize> {
    /// The model of one node and action: its reward and where its mean step lands, in the
    /// form the layout reads back cheaply in every iteration.
    type Entry;
}

/// A node layout and its interpolation. Sealed: public only so the sweep's types can name
/// it; its implementations live in this crate.
pub trait Nodes<T: Real, const D: usize>: Layout<T, D, Entry: Copy> {
    /// A fresh entry (reward 0).
    const EMPTY_ENTRY: Self::Entry;

    /// Number of nodes in use.
    fn len(&self) -> usize;

    /// The box every state and landing point is clamped into.
    fn bounds(&self) -> ([T; D], [T; D]);

    /// Which records a node's reward averages.
    fn rewards(&self) -> RewardModel;

    /// The least reward mass of a node with data.
    fn min_mass(&self) -> T;

    /// `true` when decisions look one step ahead from the state itself.
    fn lookahead(&self) -> bool;

    /// Places the nodes for a fit on the checked `sets` (nothing for a fixed layout).
    fn place<'s, I>(&mut self, _sets: I)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
    }

    /// Calls `f(node, weight)` for the nodes `state` (in the box) is interpolated from;
    /// the weights are non-negative and sum to 1.
    fn weights(&self, state: &[T; D], f: impl FnMut(usize, T));

    /// Calls `f(other)` for the nodes a node without data borrows from, nearest first
    /// (the fill's dilation runs over them).
    fn neighbours(&self, node: usize, f: impl FnMut(usize));

    /// The coordinates of `node`.
    fn position(&self, node: usize) -> [T; D];

    /// The entry's reward.
    fn reward(entry: &Self::Entry) -> T;

    /// Sets the entry's reward.
    fn set_reward(entry: &mut Self::Entry, reward: T);

    /// Forgets where the entry's step lands, before [`Nodes::land`] writes it axis by axis.
    fn start_landing(&mut self, entry: &mut Self::Entry);

    /// Axis `axis` of where `node`'s mean step `step` (on that axis) lands.
    fn land(&mut self, entry: &mut Self::Entry, node: usize, axis: usize, step: T);

    /// Called once every axis of `node`'s landing point is written.
    fn finish_landing(&mut self, _entry: &mut Self::Entry, _node: usize) {}

    /// `(V_{k−1}(y), Ω(y))` at the entry's landing point `y`: the nodes' `previous` and
    /// `absorbing` interpolated.
    fn ahead(&self, entry: &Self::Entry, nodes: &[SweepNode<T>]) -> (T, T);

    /// The entry's landing point (`None` when it cannot be read back).
    fn landing(&self, entry: &Self::Entry) -> Option<[T; D]>;
}
