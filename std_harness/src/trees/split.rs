//! The split search of a node (spec §4.1): candidate thresholds, the best valid
//! candidate, and the partition of the node's records.

use super::CONSTANT_FEATURE_TOLERANCE;
use super::layout::Record;
use rand_chacha::ChaCha8Rng;
use rand_core::Rng;

/// Weighted sums of a node: `W = Σw`, `S = Σwy`, `Q = Σwy²`, and per-feature min and max.
pub(super) struct NodeStats<const D: usize> {
    pub(super) w: f64,
    pub(super) s: f64,
    pub(super) q: f64,
    pub(super) lo: [f64; D],
    pub(super) hi: [f64; D],
}

/// The features in a uniformly random order (Fisher–Yates).
#[inline]
pub(super) fn feature_order<const D: usize>(rng: &mut ChaCha8Rng) -> [usize; D] {
    let mut order = [0usize; D];
    for (i, o) in order.iter_mut().enumerate() {
        *o = i;
    }
    for i in (1..D).rev() {
        // Lemire's multiply-shift: an index in 0..=i from 32 random bits.
        let j = ((u64::from(rng.next_u32()) * (i as u64 + 1)) >> 32) as usize;
        order.swap(i, j);
    }
    order
}

/// Draws the random trial order of the features and the candidate threshold of every
/// non-constant one (§4.1): uniform in `[lo, hi)`. A feature that is not a candidate keeps
/// τ = −∞, which sends everything right, so its sums are computed but never valid. `None`
/// when every feature is constant. Both split searches draw through here.
#[inline]
fn candidate_thresholds<const D: usize>(
    st: &NodeStats<D>,
    rng: &mut ChaCha8Rng,
) -> Option<([usize; D], [f64; D], [bool; D])> {
    let order = feature_order::<D>(rng);
    let mut thresholds = [f64::NEG_INFINITY; D];
    let mut is_candidate = [false; D];
    for &f in &order {
        let (lo, hi) = (st.lo[f], st.hi[f]);
        if hi <= lo + CONSTANT_FEATURE_TOLERANCE {
            continue;
        }
        let mut tau = lo + awfqi::rng::uniform_f64(rng) * (hi - lo);
        if tau >= hi {
            // Rounding can reach hi; scikit-learn then uses lo.
            tau = lo;
        }
        thresholds[f] = tau;
        is_candidate[f] = true;
    }
    is_candidate
        .contains(&true)
        .then_some((order, thresholds, is_candidate))
}

/// Draws the candidate splits of a node and returns the best valid one, if any.
#[inline(never)]
pub(super) fn best_split<const D: usize>(
    records: &[Record<D>],
    st: &NodeStats<D>,
    rng: &mut ChaCha8Rng,
) -> Option<(usize, f64)> {
    let (order, thresholds, is_candidate) = candidate_thresholds(st, rng)?;
    // One pass accumulates both children of every feature's candidate, indexed by feature
    // (a fixed index per lane, so the compiler keeps the sums in vector registers). Each
    // side is summed on its own (never as total − other side), so a child of zero weight
    // has exactly W = 0; and W > 0 implies the child is non-empty, so no counts are needed.
    let mut wl = [0.0f64; D];
    let mut sl = [0.0f64; D];
    let mut wr = [0.0f64; D];
    let mut sr = [0.0f64; D];
    for r in records {
        let (w, wy) = (r.w.to_bits(), (r.w * r.y).to_bits());
        for d in 0..D {
            let left = r.x[d] <= thresholds[d];
            // All-ones when left: masking the bits selects the value or +0 without a branch
            // (a multiplication by a 0/1 factor compiles to a branch here).
            let mask = 0u64.wrapping_sub(u64::from(left));
            wl[d] += f64::from_bits(w & mask);
            sl[d] += f64::from_bits(wy & mask);
            wr[d] += f64::from_bits(w & !mask);
            sr[d] += f64::from_bits(wy & !mask);
        }
    }
    // Every feature's score at once (the divisions in vector lanes; invalid candidates'
    // scores are computed and ignored), then the first valid candidate of highest score,
    // in trial order.
    let mut scores = [0.0f64; D];
    for d in 0..D {
        scores[d] = sl[d] * sl[d] / wl[d] + sr[d] * sr[d] / wr[d];
    }
    let mut best: Option<(usize, f64)> = None;
    let mut best_score = f64::NEG_INFINITY;
    for &f in &order {
        if !is_candidate[f] || wl[f] <= 0.0 || wr[f] <= 0.0 {
            continue;
        }
        let score = scores[f];
        if score > best_score {
            best_score = score;
            best = Some((f, thresholds[f]));
        }
    }
    best
}

/// [`best_split`] with the `min_samples_leaf` rule: the same draws, and a candidate is
/// valid only when both children also keep at least `min_leaf` samples.
#[inline(never)]
pub(super) fn best_split_counted<const D: usize>(
    records: &[Record<D>],
    st: &NodeStats<D>,
    min_leaf: usize,
    rng: &mut ChaCha8Rng,
) -> Option<(usize, f64)> {
    let (order, thresholds, is_candidate) = candidate_thresholds(st, rng)?;
    let (mut wl, mut sl, mut wr, mut sr) = ([0.0f64; D], [0.0f64; D], [0.0f64; D], [0.0f64; D]);
    let mut nl = [0usize; D];
    for r in records {
        let wy = r.w * r.y;
        for d in 0..D {
            if r.x[d] <= thresholds[d] {
                wl[d] += r.w;
                sl[d] += wy;
                nl[d] += 1;
            } else {
                wr[d] += r.w;
                sr[d] += wy;
            }
        }
    }
    let n = records.len();
    let mut best: Option<(usize, f64)> = None;
    let mut best_score = f64::NEG_INFINITY;
    for &f in &order {
        let too_small = nl[f] < min_leaf || n - nl[f] < min_leaf;
        if !is_candidate[f] || too_small || wl[f] <= 0.0 || wr[f] <= 0.0 {
            continue;
        }
        let score = sl[f] * sl[f] / wl[f] + sr[f] * sr[f] / wr[f];
        if score > best_score {
            best_score = score;
            best = Some((f, thresholds[f]));
        }
    }
    best
}

/// Copies `src` into `dst` with the records of `x[feature] ≤ threshold` first (in order)
/// and the others after them (in reverse order); returns the number of the former.
/// Branch-free: every record is written to both ends and one cursor advances.
#[inline(never)]
pub(super) fn partition_into<const D: usize>(
    src: &[Record<D>],
    dst: &mut [Record<D>],
    feature: usize,
    threshold: f64,
) -> usize {
    let mut l = 0;
    let mut r = dst.len();
    for rec in src {
        let left = usize::from(rec.x[feature] <= threshold);
        // Before each record, r − l = records left to place ≥ 1, so both slots are valid.
        dst[l] = *rec;
        dst[r - 1] = *rec;
        l += left;
        r -= 1 - left;
    }
    l
}
