//! The streamed forests' final trees: each grown lazily along a query's path from a split
//! stream of its own, seeded from the tree's seed (the module docs of [`super`]).

use super::growth::{Growth, Stats, best_split};
use super::{MIN_IMPURITY, TreeRecord};
use crate::float::Real;

/// SplitMix64's output function: a bijective mix of 64 bits.
pub(super) fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The random stream of one node of a streamed forest's final trees (SplitMix64 from the
/// node's seed): a node's draws depend only on its seed, so a query can grow the nodes on
/// its path alone and get the tree a full growth would.
pub(super) struct NodeStream(u64);

impl rand_core::TryRng for NodeStream {
    type Error = core::convert::Infallible;

    fn try_next_u32(&mut self) -> core::result::Result<u32, Self::Error> {
        Ok((self.try_next_u64()? >> 32) as u32)
    }

    fn try_next_u64(&mut self) -> core::result::Result<u64, Self::Error> {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        Ok(mix(self.0))
    }

    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> core::result::Result<(), Self::Error> {
        for chunk in dst.chunks_mut(8) {
            let bytes = self.try_next_u64()?.to_le_bytes();
            for (d, b) in chunk.iter_mut().zip(bytes) {
                *d = b;
            }
        }
        Ok(())
    }
}

/// The seed of tree `tree` of `action` in a streamed forest drawn with `seed`.
pub(super) fn tree_seed(seed: u64, action: usize, tree: usize) -> u64 {
    mix(seed ^ mix(((action as u64) << 32) ^ tree as u64 ^ 0x5851_F42D_4C95_7F2D))
}

/// The seed of a node's left (`right = false`) or right child.
pub(super) fn child_seed(seed: u64, right: bool) -> u64 {
    mix(seed
        ^ if right {
            0xD1B5_4A32_D192_ED03
        } else {
            0x8CB9_2BA7_2F3D_8DD7
        })
}

/// A node of a lazily grown tree with at most this many records lists them (indices on
/// the stack) instead of finding them by a scan of the action's records.
pub(super) const LISTED: usize = 192;

/// The records listed in `list[..k]`, in order.
pub(super) fn listed_members<'r, T: Real, const D: usize>(
    list: &'r [u16],
    k: usize,
    records: &'r [TreeRecord<T, D>],
) -> impl Iterator<Item = &'r TreeRecord<T, D>> + Clone {
    list.get(..k)
        .unwrap_or(&[])
        .iter()
        .filter_map(|&i| records.get(usize::from(i)))
}

/// The prediction at `state` of the tree that `seed` grows on `records` (one action's),
/// grown only along `state`'s path: at each node the records inside the node's box are
/// found by a scan (or, once few, kept in a list), the node's split drawn from its own
/// stream, and the walk goes to the child that holds `state`. Each level holds fewer
/// records than the last (both children of a split are non-empty), so the walk ends within
/// `records.len() + 1` levels. Members are visited in record order either way, so the sums
/// and the tree are the same.
pub(super) fn lazy_tree<T: Real, const D: usize>(
    records: &[TreeRecord<T, D>],
    state: &[T; D],
    seed: u64,
    growth: &Growth<T>,
) -> T {
    // The node's box: lo < x ≤ hi on every axis.
    let mut lo = [T::NEG_INFINITY; D];
    let mut hi = [T::INFINITY; D];
    let mut list = [0u16; LISTED];
    let mut listed: Option<usize> = None;
    let mut node_seed = seed;
    let impurity_floor = T::from_f64(MIN_IMPURITY);
    let mut value = T::ZERO;
    for depth in 0..=records.len() {
        let (lo_now, hi_now) = (lo, hi);
        let inside = move |r: &&TreeRecord<T, D>| {
            r.state
                .iter()
                .zip(lo_now.iter().zip(&hi_now))
                .all(|(&x, (&l, &h))| l < x && x <= h)
        };
        let st = match listed {
            Some(k) => Stats::of(listed_members(&list, k, records), growth.first),
            None => Stats::of(records.iter().filter(inside), growth.first),
        };
        value = st.mean();
        let splittable = st.n >= 2
            && depth < growth.max_depth
            && st.n >= growth.min_node
            && st.w > T::ZERO
            && st.impurity() > impurity_floor;
        if !splittable {
            return value;
        }
        if listed.is_none() && st.n <= LISTED {
            let mut k = 0;
            for (i, r) in records.iter().enumerate() {
                if inside(&r) {
                    if let (Some(slot), Ok(i)) = (list.get_mut(k), u16::try_from(i)) {
                        *slot = i;
                        k += 1;
                    }
                }
            }
            listed = Some(k);
        }
        let mut stream = NodeStream(node_seed);
        let split = match listed {
            Some(k) => best_split(listed_members(&list, k, records), &st, growth, &mut stream),
            None => best_split(records.iter().filter(inside), &st, growth, &mut stream),
        };
        let Some((feature, tau)) = split else {
            return value;
        };
        let right = state.get(feature).is_some_and(|&x| x > tau);
        let bound = if right {
            lo.get_mut(feature)
        } else {
            hi.get_mut(feature)
        };
        if let Some(b) = bound {
            *b = tau;
        }
        if let Some(k) = listed {
            // Keep the members on `state`'s side, in order.
            let mut kept = 0;
            for j in 0..k {
                let Some(&i) = list.get(j) else { break };
                let goes_right = records
                    .get(usize::from(i))
                    .is_some_and(|r| r.coordinate(feature) > tau);
                if goes_right == right {
                    if let Some(slot) = list.get_mut(kept) {
                        *slot = i;
                    }
                    kept += 1;
                }
            }
            listed = Some(kept);
        }
        node_seed = child_seed(node_seed, right);
    }
    value
}
