//! Multilinear interpolation on the sweep's node grid: the `2^D` corners of a point's cell
//! and their weights, and the look-ahead `(V_{k−1}(y), Ω(y))` at a record's landing point.

use super::{FRAC_ONE, SweepEntry, SweepNode};
use crate::float::Real;

/// The nodes and interpolation weights of a point: the `2^D` corners of its cell.
pub(super) struct Corners<T, const D: usize> {
    pub(super) base: [usize; D],
    pub(super) frac: [T; D],
}

impl<T: Real, const D: usize> Corners<T, D> {
    /// Number of corners.
    pub(super) const COUNT: usize = 1 << D;

    /// Corner `k` (bit `d` set: the upper node on axis `d`): its node index in a grid of
    /// `dims` nodes per axis, and its weight.
    #[inline]
    pub(super) fn corner(&self, k: usize, dims: &[usize; D]) -> (usize, T) {
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
pub(super) fn ahead<T: Real, const D: usize>(
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
pub(super) fn ahead_any<T: Real, const D: usize>(
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
