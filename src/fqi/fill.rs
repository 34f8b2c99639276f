//! Pairs of a table (or of one tiling) without data: the nearest pair with data of the same
//! action, found once per fit, and the [`EmptyCells`] rule that fills them from it.

use super::CellGrid;
use super::config::EmptyCells;
use super::entry::{FqiEntry, NIL};
use crate::float::Real;

/// Sets every entry's `donor` to the entry index of the nearest entry with the same action
/// for which `has_data` holds (itself if it holds), or [`NIL`] when the action has none.
///
/// Nearest in cell-index units, Euclidean; ties go to the smallest cell index. Shells of
/// growing Chebyshev radius are scanned around the cell until the radius exceeds the best
/// distance found, so the search is exact and costs O(d^D) for a cell at distance d.
pub(super) fn nearest_donors<T: Real, const D: usize>(
    grid: &CellGrid<T, D>,
    actions: usize,
    entries: &mut [FqiEntry<T>],
    has_data: impl Fn(&FqiEntry<T>) -> bool,
) {
    let cells = grid.len();
    for action in 0..actions {
        let visited = |cell: usize, entries: &[FqiEntry<T>]| {
            entries.get(cell * actions + action).is_some_and(&has_data)
        };
        let any = (0..cells).any(|c| visited(c, entries));
        for cell in 0..cells {
            let donor = if !any {
                NIL
            } else if visited(cell, entries) {
                (cell * actions + action) as u32
            } else {
                nearest_visited(grid, cell, |c| visited(c, entries))
                    .map_or(NIL, |c| (c * actions + action) as u32)
            };
            if let Some(e) = entries.get_mut(cell * actions + action) {
                e.donor = donor;
            }
        }
    }
}

/// The nearest cell to `cell` (not itself) for which `visited` holds; see
/// [`nearest_donors`].
pub(super) fn nearest_visited<T: Real, const D: usize>(
    grid: &CellGrid<T, D>,
    cell: usize,
    visited: impl Fn(usize) -> bool,
) -> Option<usize> {
    let dims = grid.cells();
    let centre = grid.coordinates(cell)?.map(|c| c as isize);
    let max_radius = dims.iter().copied().max().unwrap_or(0) as isize;
    let mut best: Option<(isize, usize)> = None;
    for r in 1..=max_radius {
        if let Some((bd, _)) = best {
            if r * r > bd {
                break;
            }
        }
        // The part of the cube [c − r, c + r] inside the grid, as offsets (lo ≤ 0 ≤ hi).
        let mut lo = [0isize; D];
        let mut hi = [0isize; D];
        for (((l, h), &c), &n) in lo.iter_mut().zip(hi.iter_mut()).zip(&centre).zip(&dims) {
            *l = (-r).max(-c);
            *h = r.min(n as isize - 1 - c);
        }
        for_each_on_shell(r, &lo, &hi, |offset| {
            let mut index = 0usize;
            let mut stride = 1usize;
            let mut d2 = 0isize;
            for ((&o, &c), &n) in offset.iter().zip(&centre).zip(&dims) {
                index += (c + o) as usize * stride;
                stride *= n;
                d2 += o * o;
            }
            if !visited(index) {
                return;
            }
            let better = match best {
                None => true,
                Some((bd, bc)) => d2 < bd || (d2 == bd && index < bc),
            };
            if better {
                best = Some((d2, index));
            }
        });
    }
    best.map(|(_, c)| c)
}

/// Calls `visit` with every offset `o` with `lo ≤ o ≤ hi` (per axis) whose largest
/// |coordinate| is exactly `r`: the Chebyshev shell of radius `r`, clipped. An odometer runs
/// over the first `D − 1` axes; the last axis takes every value when an earlier one is on
/// the shell already, else only `±r`, so each offset of the shell is visited once.
fn for_each_on_shell<const D: usize>(
    r: isize,
    lo: &[isize; D],
    hi: &[isize; D],
    mut visit: impl FnMut(&[isize; D]),
) {
    let Some((&last_lo, &last_hi)) = lo.last().zip(hi.last()) else {
        return;
    };
    let prefix = D - 1;
    let mut offset = *lo;
    loop {
        let on_shell = offset.iter().take(prefix).any(|o| o.abs() == r);
        if on_shell {
            for o in last_lo..=last_hi {
                if let Some(slot) = offset.last_mut() {
                    *slot = o;
                }
                visit(&offset);
            }
        } else {
            for o in [-r, r] {
                if (last_lo..=last_hi).contains(&o) {
                    if let Some(slot) = offset.last_mut() {
                        *slot = o;
                    }
                    visit(&offset);
                }
            }
        }
        // Advance the odometer over the prefix axes.
        let mut k = 0;
        loop {
            if k == prefix {
                return;
            }
            match (offset.get_mut(k), lo.get(k), hi.get(k)) {
                (Some(o), Some(&l), Some(&h)) => {
                    if *o < h {
                        *o += 1;
                        break;
                    }
                    *o = l;
                }
                _ => return,
            }
            k += 1;
        }
    }
}

/// For every entry without data, sets `field` from its donor (or to the configured value,
/// or 0 when there is no donor).
pub(super) fn fill_empty<T: Real>(
    entries: &mut [FqiEntry<T>],
    actions: usize,
    empty: EmptyCells<T>,
    has_data: impl Fn(&FqiEntry<T>) -> bool,
    field: impl Fn(&mut FqiEntry<T>) -> &mut T,
) {
    for i in 0..entries.len() {
        let Some(e) = entries.get(i) else { break };
        if has_data(e) {
            continue;
        }
        let donor = e.donor as usize;
        let value = match empty {
            EmptyCells::Value(v) => v,
            EmptyCells::Nearest => entries.get_mut(donor).map_or(T::ZERO, |d| *field(d)),
            EmptyCells::CappedNearest => {
                let nearest = entries.get_mut(donor).map_or(T::ZERO, |d| *field(d));
                // The lowest value among the actions with data in the same cell, if any.
                let start = i - i.checked_rem(actions).unwrap_or(0);
                let mut cap = T::INFINITY;
                for j in start..start + actions {
                    if let Some(other) = entries.get_mut(j) {
                        if has_data(other) {
                            cap = cap.min(*field(other));
                        }
                    }
                }
                nearest.min(cap)
            }
        };
        if let Some(e) = entries.get_mut(i) {
            *field(e) = value;
        }
    }
}
