//! Dense lower Cholesky factor kept in place, over slices.
//!
//! Every function works on a row-major square buffer with `stride` columns of which only the
//! leading `n × n` lower triangle is used, so one copy of the code serves every capacity `N`
//! of [`Gp`](super::Gp). A function returns `false` when the arithmetic breaks down (a
//! pivot that is not positive and finite, or a non-finite solution), never a wrong number.
//!
//! The factorisation is row-oriented (Cholesky–Banachiewicz): row `i` of `L` depends only on
//! rows `< i`. Extending a factor by a row therefore performs exactly the arithmetic a full
//! factorisation would perform for that row, so growing a GP point by point gives the same
//! bits as refitting it.
//!
//! Dot products are plain sums in the working precision, split into four interleaved partial
//! sums (which lets a single-precision FPU pipeline them and cuts the worst-case rounding
//! bound from `n·ε` to about `(n/4 + 2)·ε`). No wider accumulator is used: on a Cortex-M4F an
//! `f64` accumulator would be software floating point.

use crate::float::Real;

/// `Σ aᵢ bᵢ` over the common length of `a` and `b` (callers pass equal lengths), summed as
/// four interleaved partial sums plus a tail.
#[inline]
pub(crate) fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    // Slice patterns rather than `chunks_exact().zip()`: the same sums in the same order,
    // without the iterator adapters a size-optimised build leaves as calls (most of the
    // cost of the short products of a prediction on a Cortex-M4F).
    let (mut a, mut b) = (a, b);
    let [mut s0, mut s1, mut s2, mut s3] = [T::ZERO; 4];
    while let ([p0, p1, p2, p3, ra @ ..], [q0, q1, q2, q3, rb @ ..]) = (a, b) {
        s0 += *p0 * *q0;
        s1 += *p1 * *q1;
        s2 += *p2 * *q2;
        s3 += *p3 * *q3;
        (a, b) = (ra, rb);
    }
    let mut tail = T::ZERO;
    while let ([p, ra @ ..], [q, rb @ ..]) = (a, b) {
        tail += *p * *q;
        (a, b) = (ra, rb);
    }
    ((s0 + s1) + (s2 + s3)) + tail
}

/// Row `i` of the buffer, columns `0..=i` (the stored part of a lower triangle).
#[inline]
fn lower_row<T>(l: &[T], stride: usize, i: usize) -> Option<&[T]> {
    let start = i.checked_mul(stride)?;
    l.get(start..start.checked_add(i)?.checked_add(1)?)
}

/// A pivot must exceed `PIVOT_GUARD · n · ε · K_ii` to count: below that, rounding in the
/// working precision dominates it (10 was measured as the smallest multiple that keeps the
/// f32 differential test's ill-conditioned classes within 1e-2 of the f64 reference).
pub(crate) const PIVOT_GUARD: f64 = 10.0;

/// Factorises rows `from..n` in place.
///
/// On entry rows `< from` hold the finished factor `L`, and each row `i` in `from..n` holds
/// the kernel matrix entries `K[i][0..=i]` in its columns `0..=i`. On success those rows
/// hold `L[i][0..=i]`. Returns `false` (rows `from..n` then hold garbage) when a pivot is not
/// positive and finite, or when the buffer is too small.
pub(crate) fn factor_rows<T: Real>(l: &mut [T], stride: usize, from: usize, n: usize) -> bool {
    if n > stride {
        return false;
    }
    for i in from..n {
        let Some(start) = i.checked_mul(stride) else {
            return false;
        };
        let Some((done, rest)) = l.split_at_mut_checked(start) else {
            return false;
        };
        let Some((diag, left)) = rest.get_mut(..=i).and_then(|r| r.split_last_mut()) else {
            return false;
        };
        for (j, previous) in done.chunks_exact(stride).enumerate() {
            let Some((&pivot, previous_left)) = previous.get(..=j).and_then(|r| r.split_last())
            else {
                return false;
            };
            let Some((head, tail)) = left.split_at_mut_checked(j) else {
                return false;
            };
            let Some(entry) = tail.first_mut() else {
                return false;
            };
            *entry = (*entry - dot(head, previous_left)) / pivot;
        }
        let pivot = *diag - dot(left, left);
        // A pivot within rounding of the diagonal entry is noise, not information: in f32 an
        // ill-conditioned matrix often "factorises" with such pivots and then yields wrong
        // numbers silently. Treating it as a breakdown makes the caller escalate the jitter.
        let floor = T::from_f64(PIVOT_GUARD) * T::from_usize(n) * T::EPSILON * *diag;
        if !(pivot > floor && pivot > T::ZERO && pivot.is_finite()) {
            return false;
        }
        *diag = pivot.sqrt();
    }
    true
}

/// Solves `L b' = b` in place for entries `from..n`, assuming `b[..from]` is already solved.
///
/// Returns `false` when an entry of the solution is not finite or a buffer is too small.
pub(crate) fn forward_solve<T: Real>(
    l: &[T],
    stride: usize,
    from: usize,
    n: usize,
    b: &mut [T],
) -> bool {
    for i in from..n {
        let Some((&diag, left)) = lower_row(l, stride, i).and_then(|r| r.split_last()) else {
            return false;
        };
        let Some((solved, rest)) = b.split_at_mut_checked(i) else {
            return false;
        };
        let Some(entry) = rest.first_mut() else {
            return false;
        };
        *entry = (*entry - dot(left, solved)) / diag;
        if !entry.is_finite() {
            return false;
        }
    }
    true
}

/// Solves `Lᵀ x = b` in place for the leading `n` entries (back substitution, O(n²)).
///
/// Returns `false` when an entry of the solution is not finite or a buffer is too small.
pub(crate) fn backward_solve<T: Real>(l: &[T], stride: usize, n: usize, b: &mut [T]) -> bool {
    for i in (0..n).rev() {
        let Some(&diag) = l.get(i * stride + i) else {
            return false;
        };
        let mut sum = T::ZERO;
        for j in i + 1..n {
            let (Some(&lji), Some(&xj)) = (l.get(j * stride + i), b.get(j)) else {
                return false;
            };
            sum += lji * xj;
        }
        let Some(entry) = b.get_mut(i) else {
            return false;
        };
        *entry = (*entry - sum) / diag;
        if !entry.is_finite() {
            return false;
        }
    }
    true
}

/// `Σ ln L[i][i]` over `i < n`: half the log-determinant of `L Lᵀ`.
pub(crate) fn half_log_det<T: Real>(l: &[T], stride: usize, n: usize) -> T {
    let mut sum = T::ZERO;
    for i in 0..n {
        if let Some(&d) = l.get(i * stride + i) {
            sum += d.ln();
        }
    }
    sum
}

/// Removes the first row and column of the matrix `A = L Lᵀ`, updating the `n × n` factor in
/// place to the `(n−1) × (n−1)` factor of the trailing block, in O(n²).
///
/// The trailing block of `A` equals `L₂₂ L₂₂ᵀ + l lᵀ`, where `l` is the first column of `L`
/// below the diagonal, so the new factor is a rank-one *update* of `L₂₂` (no downdate, hence
/// stable). `work` must hold at least `n − 1` values; it is overwritten. Returns `false` on a
/// non-finite or non-positive pivot or a too-small buffer.
pub(crate) fn drop_first<T: Real>(l: &mut [T], stride: usize, n: usize, work: &mut [T]) -> bool {
    if n == 0 || n > stride {
        return false;
    }
    let m = n - 1;
    let Some(w) = work.get_mut(..m) else {
        return false;
    };
    // Gather l = L[1..n][0] and shift L[i+1][1..=i+1] into row i.
    for (i, wi) in w.iter_mut().enumerate() {
        let src = (i + 1) * stride;
        let Some(&first) = l.get(src) else {
            return false;
        };
        *wi = first;
        // Row i ends before row i + 1 starts, so the two ranges lie in disjoint halves.
        // (An element-wise copy: `copy_within` would keep a bounds-check panic path.)
        let dst = i * stride;
        let Some((head, tail)) = l.split_at_mut_checked(src) else {
            return false;
        };
        let (Some(to), Some(from)) = (head.get_mut(dst..dst + i + 1), tail.get(1..i + 2)) else {
            return false;
        };
        for (t, &f) in to.iter_mut().zip(from) {
            *t = f;
        }
    }
    rank_one_update(l, stride, m, w)
}

/// Replaces the factor of `A` (`m × m`) by the factor of `A + w wᵀ`, in place, O(m²).
/// `w` is overwritten. Returns `false` on a non-positive or non-finite pivot.
fn rank_one_update<T: Real>(l: &mut [T], stride: usize, m: usize, w: &mut [T]) -> bool {
    for k in 0..m {
        let (Some(&lkk), Some(&wk)) = (l.get(k * stride + k), w.get(k)) else {
            return false;
        };
        let r = (lkk * lkk + wk * wk).sqrt();
        if !(r > T::ZERO && r.is_finite() && lkk > T::ZERO) {
            return false;
        }
        let cos = r / lkk;
        let sin = wk / lkk;
        if let Some(d) = l.get_mut(k * stride + k) {
            *d = r;
        }
        for i in k + 1..m {
            let (Some(lik), Some(wi)) = (l.get_mut(i * stride + k), w.get_mut(i)) else {
                return false;
            };
            let updated = (*lik + sin * *wi) / cos;
            *wi = cos * *wi - sin * updated;
            *lik = updated;
            if !updated.is_finite() {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fills the lower triangle of a row-major `stride × stride` buffer from a full matrix.
    fn load(a: &[&[f64]], stride: usize) -> [f64; 16] {
        let mut l = [f64::NAN; 16];
        for (i, row) in a.iter().enumerate() {
            for j in 0..=i {
                l[i * stride + j] = row[j];
            }
        }
        l
    }

    #[test]
    fn dot_matches_the_naive_sum_for_every_length() {
        let a: [f64; 11] = core::array::from_fn(|i| i as f64 + 0.5);
        let b: [f64; 11] = core::array::from_fn(|i| 2.0 - i as f64);
        for n in 0..=11 {
            let naive: f64 = (0..n).map(|i| a[i] * b[i]).sum();
            assert!((dot(&a[..n], &b[..n]) - naive).abs() < 1e-12);
        }
    }

    #[test]
    fn factors_a_hand_computed_3x3() {
        // A = L Lᵀ with L = [[2,0,0],[1,3,0],[-1,2,1]].
        let a: [&[f64]; 3] = [&[4.0, 2.0, -2.0], &[2.0, 10.0, 5.0], &[-2.0, 5.0, 6.0]];
        let mut l = load(&a, 4);
        assert!(factor_rows(&mut l, 4, 0, 3));
        let expected = [[2.0, 0.0, 0.0], [1.0, 3.0, 0.0], [-1.0, 2.0, 1.0]];
        for i in 0..3 {
            for j in 0..=i {
                assert!((l[i * 4 + j] - expected[i][j]).abs() < 1e-14);
            }
        }
        assert!((half_log_det(&l, 4, 3) - 6.0f64.ln()).abs() < 1e-14);
        // Solve L z = [2, 7, 5]: z = [1, 2, 2].
        let mut b = [2.0, 7.0, 5.0];
        assert!(forward_solve(&l, 4, 0, 3, &mut b));
        assert_eq!(b, [1.0, 2.0, 2.0]);
    }

    #[test]
    fn rejects_indefinite_and_non_finite_matrices() {
        let a: [&[f64]; 2] = [&[1.0, 2.0], &[2.0, 1.0]];
        let mut l = load(&a, 4);
        assert!(!factor_rows(&mut l, 4, 0, 2));
        let a: [&[f64]; 2] = [&[1.0, 0.0], &[f64::NAN, 1.0]];
        let mut l = load(&a, 4);
        assert!(!factor_rows(&mut l, 4, 0, 2));
        let a: [&[f64]; 1] = [&[0.0]];
        let mut l = load(&a, 4);
        assert!(!factor_rows(&mut l, 4, 0, 1));
        // A buffer too small for the requested rows is a failure, not a panic.
        assert!(!factor_rows(&mut [1.0f64; 3], 2, 0, 2));
        assert!(!factor_rows(&mut [1.0f64; 4], 2, 0, 3));
    }

    #[test]
    fn dropping_the_first_point_equals_factoring_the_trailing_block() {
        let a: [&[f64]; 4] = [
            &[4.0, 2.0, -2.0, 1.0],
            &[2.0, 10.0, 5.0, 0.5],
            &[-2.0, 5.0, 6.0, -1.0],
            &[1.0, 0.5, -1.0, 3.0],
        ];
        let mut l = load(&a, 4);
        assert!(factor_rows(&mut l, 4, 0, 4));
        let mut work = [0.0; 4];
        assert!(drop_first(&mut l, 4, 4, &mut work));
        let trailing: [&[f64]; 3] = [&[10.0, 5.0, 0.5], &[5.0, 6.0, -1.0], &[0.5, -1.0, 3.0]];
        let mut fresh = load(&trailing, 4);
        assert!(factor_rows(&mut fresh, 4, 0, 3));
        for i in 0..3 {
            for j in 0..=i {
                assert!((l[i * 4 + j] - fresh[i * 4 + j]).abs() < 1e-13, "{i},{j}");
            }
        }
    }
}
