//! Multilinear interpolation on the sweep's node grid: the `2^D` corners of a point's cell
//! and their weights, and the look-ahead `(V_{k−1}(y), Ω(y))` at a record's landing point;
//! the grid as a [`Nodes`] layout.

use super::{FRAC_ONE, Layout, ModelSweep, Nodes, RewardModel, SweepEntry, SweepNode};
use crate::float::Real;

/// The nodes and interpolation weights of a point: the `2^D` corners of its cell.
struct Corners<T, const D: usize> {
    base: [usize; D],
    frac: [T; D],
}

impl<T: Real, const D: usize> Corners<T, D> {
    /// Number of corners.
    const COUNT: usize = 1 << D;

    /// Corner `k` (bit `d` set: the upper node on axis `d`): its node index in a grid of
    /// `dims` nodes per axis, and its weight.
    #[inline]
    fn corner(&self, k: usize, dims: &[usize; D]) -> (usize, T) {
        let mut index = 0;
        let mut stride = 1;
        let mut weight = T::ONE;
        for (d, ((&b, &f), &n)) in self.base.iter().zip(&self.frac).zip(dims).enumerate() {
            let up = (k >> d) & 1 == 1;
            index += (b + usize::from(up)) * stride;
            stride *= n;
            weight *= if up { f } else { T::ONE - f };
        }
        (index, weight)
    }
}

/// `(V_{k−1}(y), Ω(y))` at the landing point `y` of `entry`, from `nodes` in a grid of
/// `strides` (node index steps per axis). The inner loop of every iteration: written out for
/// `D = 2` (an in-order core does not unroll the general loop at `opt-level = "s"`).
#[inline]
fn ahead<T: Real, const D: usize>(
    entry: &SweepEntry<T, D>,
    nodes: &[SweepNode<T>],
    strides: &[usize; D],
) -> (T, T) {
    let scale = T::ONE / T::from_usize(usize::from(FRAC_ONE));
    let base = entry.base as usize;
    if let ([fx, fy], [_, sy]) = (entry.frac.as_slice(), strides.as_slice()) {
        let (fx, fy) = (
            T::from_usize(usize::from(*fx)) * scale,
            T::from_usize(usize::from(*fy)) * scale,
        );
        let (gx, gy) = (T::ONE - fx, T::ONE - fy);
        let (Some(low), Some(high)) = (
            nodes.get(base..base + 2),
            nodes.get(base + sy..base + sy + 2),
        ) else {
            return ahead_any(entry, nodes, strides);
        };
        if let ([a, b], [c, d]) = (low, high) {
            let v =
                gy * (gx * a.previous + fx * b.previous) + fy * (gx * c.previous + fx * d.previous);
            let omega = gy * (gx * a.absorbing + fx * b.absorbing)
                + fy * (gx * c.absorbing + fx * d.absorbing);
            return (v, omega);
        }
    }
    ahead_any(entry, nodes, strides)
}

/// [`ahead`] for any `D` (and for a landing cell on the last node of an axis, whose upper
/// corners carry weight 0 and may lie past the end).
fn ahead_any<T: Real, const D: usize>(
    entry: &SweepEntry<T, D>,
    nodes: &[SweepNode<T>],
    strides: &[usize; D],
) -> (T, T) {
    let scale = T::ONE / T::from_usize(usize::from(FRAC_ONE));
    let frac = entry.frac.map(|f| T::from_usize(usize::from(f)) * scale);
    let base = entry.base as usize;
    let (mut v, mut omega) = (T::ZERO, T::ZERO);
    for k in 0..Corners::<T, D>::COUNT {
        let mut index = base;
        let mut weight = T::ONE;
        for (d, (&f, &stride)) in frac.iter().zip(strides).enumerate() {
            if (k >> d) & 1 == 1 {
                index += stride;
                weight *= f;
            } else {
                weight *= T::ONE - f;
            }
        }
        if let Some(n) = nodes.get(index) {
            v += weight * n.previous;
            omega += weight * n.absorbing;
        }
    }
    (v, omega)
}

impl<T: Real, const D: usize> ModelSweep<T, D> {
    /// The interpolation corners of `state` (clamped into the box).
    #[inline]
    fn corners(&self, state: &[T; D]) -> Corners<T, D> {
        let mut base = [0usize; D];
        let mut frac = [T::ZERO; D];
        let (lower, upper, cells) = (self.cells.lower(), self.cells.upper(), self.cells.cells());
        for (((((b, f), &x), &lo), &hi), &n) in base
            .iter_mut()
            .zip(frac.iter_mut())
            .zip(state)
            .zip(&lower)
            .zip(&upper)
            .zip(&cells)
        {
            let t = (x - lo) / (hi - lo) * T::from_usize(n);
            // Truncation saturates (negative and NaN give 0), as `CellGrid` does.
            let i = t.to_usize_saturating().min(n.saturating_sub(1));
            *b = i;
            *f = (t - T::from_usize(i)).clamp_to(T::ZERO, T::ONE);
        }
        Corners { base, frac }
    }

    /// The node coordinate of `node` on `axis`.
    fn coordinate(&self, node: usize, axis: usize) -> usize {
        let stride = self.strides.get(axis).copied().unwrap_or(1).max(1);
        let n = self.nodes.cells().get(axis).copied().unwrap_or(1).max(1);
        (node / stride) % n
    }
}

/// The grid: nodes at the corners of the cells, a point read from the `2^D` corners of its
/// cell, a landing point kept as its cell's lowest node and its fixed-point position there.
impl<T, const D: usize> Layout<T, D> for ModelSweep<T, D> {
    type Entry = SweepEntry<T, D>;
}

impl<T: Real, const D: usize> Nodes<T, D> for ModelSweep<T, D> {
    const EMPTY_ENTRY: Self::Entry = SweepEntry::EMPTY;

    fn len(&self) -> usize {
        self.nodes.len()
    }

    fn bounds(&self) -> ([T; D], [T; D]) {
        (self.cells.lower(), self.cells.upper())
    }

    fn rewards(&self) -> RewardModel {
        self.rewards
    }

    fn min_mass(&self) -> T {
        self.min_mass
    }

    fn lookahead(&self) -> bool {
        self.lookahead
    }

    #[inline]
    fn weights(&self, state: &[T; D], mut f: impl FnMut(usize, T)) {
        let dims = self.nodes.cells();
        let c = self.corners(state);
        for k in 0..Corners::<T, D>::COUNT {
            let (i, phi) = c.corner(k, &dims);
            f(i, phi);
        }
    }

    /// The axis neighbours, below then above on each axis in turn.
    fn neighbours(&self, node: usize, mut f: impl FnMut(usize)) {
        let dims = self.nodes.cells();
        for (axis, (&n, &stride)) in dims.iter().zip(&self.strides).enumerate() {
            let c = self.coordinate(node, axis);
            if c > 0 {
                f(node - stride);
            }
            if c + 1 < n {
                f(node + stride);
            }
        }
    }

    fn position(&self, node: usize) -> [T; D] {
        let coordinates = self.nodes.coordinates(node).unwrap_or([0; D]);
        let (lower, upper, cells) = (self.cells.lower(), self.cells.upper(), self.cells.cells());
        let mut out = lower;
        for ((((o, &k), &lo), &hi), &n) in out
            .iter_mut()
            .zip(&coordinates)
            .zip(&lower)
            .zip(&upper)
            .zip(&cells)
        {
            *o = lo + (hi - lo) * (T::from_usize(k) / T::from_usize(n));
        }
        out
    }

    fn reward(entry: &Self::Entry) -> T {
        entry.reward
    }

    fn set_reward(entry: &mut Self::Entry, reward: T) {
        entry.reward = reward;
    }

    fn start_landing(&mut self, entry: &mut Self::Entry) {
        entry.base = 0;
    }

    /// The landing cell's coordinate on `axis` into `base`, the position in it into
    /// `frac[axis]` (rounded to the nearest step of the fixed point, within `[0, 1]`).
    fn land(&mut self, entry: &mut Self::Entry, node: usize, axis: usize, step: T) {
        let stride = self.strides.get(axis).copied().unwrap_or(0);
        let (lo, hi, n_cells) = (
            self.cells.lower().get(axis).copied().unwrap_or(T::ZERO),
            self.cells.upper().get(axis).copied().unwrap_or(T::ONE),
            self.cells.cells().get(axis).copied().unwrap_or(1),
        );
        let scale = T::from_usize(usize::from(FRAC_ONE));
        let width = (hi - lo) / T::from_usize(n_cells);
        let k = self.coordinate(node, axis);
        let y = (lo + width * T::from_usize(k) + step).clamp_to(lo, hi);
        let t = (y - lo) / (hi - lo) * T::from_usize(n_cells);
        let cell = t.to_usize_saturating().min(n_cells.saturating_sub(1));
        let f = (t - T::from_usize(cell)).clamp_to(T::ZERO, T::ONE);
        let fixed = (f * scale + T::from_f64(0.5))
            .to_usize_saturating()
            .min(usize::from(FRAC_ONE));
        entry.base += (cell * stride) as u32;
        if let Some(slot) = entry.frac.get_mut(axis) {
            *slot = fixed as u16;
        }
    }

    #[inline]
    fn ahead(&self, entry: &Self::Entry, nodes: &[SweepNode<T>]) -> (T, T) {
        ahead(entry, nodes, &self.strides)
    }

    fn landing(&self, entry: &Self::Entry) -> Option<[T; D]> {
        let base = self.nodes.coordinates(entry.base as usize)?;
        let (lower, upper, cells) = (self.cells.lower(), self.cells.upper(), self.cells.cells());
        let scale = T::from_usize(usize::from(FRAC_ONE));
        let mut out = lower;
        for (d, o) in out.iter_mut().enumerate() {
            let (b, f, lo, hi, n) = (
                *base.get(d)?,
                *entry.frac.get(d)?,
                *lower.get(d)?,
                *upper.get(d)?,
                *cells.get(d)?,
            );
            let t = T::from_usize(b) + T::from_usize(usize::from(f)) / scale;
            *o = lo + (hi - lo) * (t / T::from_usize(n));
        }
        Some(out)
    }
}
