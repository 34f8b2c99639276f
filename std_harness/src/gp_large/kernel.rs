//! The kernel's building blocks: squared distances, the branch-free exp, and the
//! vectorised kernel and gradient columns.

pub(super) fn squared_distance<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum()
}

/// `exp(x)` for `x ≤ 0` (any `x < −746`, and `−∞`, give 0), within 1 ulp of the exact value
/// (subnormal results correctly rounded from it), without branches so that a loop over a
/// slice vectorises. Used for the kernel matrix, where libm's scalar `exp` was 13 % of a fit.
///
/// fdlibm's method: `x = k ln 2 + r` with `|r| ≤ ln 2 / 2` (`k` rounded to nearest by the
/// `1.5·2⁵²` trick, `ln 2` split in two so that `x − k·ln2_hi` is exact), `exp(r)` from the
/// degree-5 Remez approximation `R(r²)` of `r (eʳ + 1)/(eʳ − 1)` evaluated as
/// `1 − ((lo − r c/(2 − c)) − hi)`, then scaled by `2^⌊k/2⌋ · 2^(k − ⌊k/2⌋)` (two exact powers of
/// two, so a subnormal result is rounded once). Plain multiplications and additions only
/// (no fused multiply-add), so every vector width gives bitwise the same results.
#[inline(always)]
pub(super) fn exp_nonpositive(x: f64) -> f64 {
    const LN2_HI: f64 = 0.6931471803691238;
    const LN2_LO: f64 = 1.9082149292705877e-10;
    const LOG2_E: f64 = std::f64::consts::LOG2_E;
    const P1: f64 = 0.16666666666666602;
    const P2: f64 = -0.0027777777777015593;
    const P3: f64 = 6.613756321437934e-5;
    const P4: f64 = -1.6533902205465252e-6;
    const P5: f64 = 4.1381367970572385e-8;
    /// Adding and subtracting it rounds an `|v| < 2⁵¹` to the nearest integer.
    const ROUND: f64 = 6_755_399_441_055_744.0;
    /// `2⁵² + 1023`: adding it puts a biased exponent `k + 1023 ∈ [0, 2047]` in the low bits.
    const BIAS: f64 = 4_503_599_627_371_519.0;
    let x = x.clamp(-746.0, 0.0);
    let k = (x * LOG2_E + ROUND) - ROUND;
    let hi = x - k * LN2_HI;
    let lo = k * LN2_LO;
    let r = hi - lo;
    let t = r * r;
    let c = r - t * (P1 + t * (P2 + t * (P3 + t * (P4 + t * P5))));
    let y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
    let k1 = (k * 0.5 + ROUND) - ROUND;
    let k2 = k - k1;
    let pow2 = |m: f64| f64::from_bits((m + BIAS).to_bits() << 52);
    y * pow2(k1) * pow2(k2)
}

/// Calls the AVX-512 build of a function when the CPU has AVX-512F, else its AVX2 build
/// when it has AVX2, else the portable one (on x86-64; elsewhere always the portable one).
macro_rules! widest_vectors {
    ($avx512:ident, $avx2:ident, $generic:ident, ($($arg:expr),*)) => {{
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F (checked just above).
            return unsafe { $avx512($($arg),*) };
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above).
            return unsafe { $avx2($($arg),*) };
        }
        $generic($($arg),*)
    }};
}

/// One column of the kernel matrix: `e = exp(k·d²)` ([`exp_nonpositive`]) and `out = c·e`.
#[inline(always)]
fn kernel_column_generic(k: f64, c: f64, d2: &[f64], e: &mut [f64], out: &mut [f64]) {
    for ((o, ev), &d) in out.iter_mut().zip(e.iter_mut()).zip(d2) {
        *ev = exp_nonpositive(k * d);
        *o = c * *ev;
    }
}

/// [`kernel_column_generic`] compiled for AVX2 (4 lanes).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn kernel_column_avx2(k: f64, c: f64, d2: &[f64], e: &mut [f64], out: &mut [f64]) {
    kernel_column_generic(k, c, d2, e, out);
}

/// [`kernel_column_generic`] compiled for AVX-512 (8 lanes; half the time of AVX2's).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn kernel_column_avx512(k: f64, c: f64, d2: &[f64], e: &mut [f64], out: &mut [f64]) {
    kernel_column_generic(k, c, d2, e, out);
}

/// [`kernel_column_generic`] with the widest vectors the CPU has (bitwise the same results).
pub(super) fn kernel_column(k: f64, c: f64, d2: &[f64], e: &mut [f64], out: &mut [f64]) {
    widest_vectors!(
        kernel_column_avx512,
        kernel_column_avx2,
        kernel_column_generic,
        (k, c, d2, e, out)
    )
}

/// One column's share of the gradient sums: `Σ tᵢ` and `Σ tᵢ d²ᵢ` with
/// `tᵢ = (αᵢ αⱼ − K⁻¹ᵢⱼ) eᵢ`, in 8 interleaved partial sums so that the loop vectorises.
#[inline(always)]
fn gradient_column_generic(
    kinv: &[f64],
    alpha: &[f64],
    aj: f64,
    e: &[f64],
    d2: &[f64],
) -> (f64, f64) {
    const LANES: usize = 8;
    let (mut se, mut sd) = ([0.0; LANES], [0.0; LANES]);
    let n = kinv.len().min(alpha.len()).min(e.len()).min(d2.len());
    let split = n - n % LANES;
    let (kinv, kinv_rest) = kinv[..n].split_at(split);
    let (alpha, alpha_rest) = alpha[..n].split_at(split);
    let (e, e_rest) = e[..n].split_at(split);
    let (d2, d2_rest) = d2[..n].split_at(split);
    for (((k, a), ev), d) in kinv
        .chunks_exact(LANES)
        .zip(alpha.chunks_exact(LANES))
        .zip(e.chunks_exact(LANES))
        .zip(d2.chunks_exact(LANES))
    {
        for l in 0..LANES {
            let t = (a[l] * aj - k[l]) * ev[l];
            se[l] += t;
            sd[l] += t * d[l];
        }
    }
    for (((&k, &a), &ev), &d) in kinv_rest.iter().zip(alpha_rest).zip(e_rest).zip(d2_rest) {
        let t = (a * aj - k) * ev;
        se[0] += t;
        sd[0] += t * d;
    }
    (se.iter().sum(), sd.iter().sum())
}

/// [`gradient_column_generic`] compiled for AVX-512.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn gradient_column_avx512(
    kinv: &[f64],
    alpha: &[f64],
    aj: f64,
    e: &[f64],
    d2: &[f64],
) -> (f64, f64) {
    gradient_column_generic(kinv, alpha, aj, e, d2)
}

/// [`gradient_column_generic`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn gradient_column_avx2(kinv: &[f64], alpha: &[f64], aj: f64, e: &[f64], d2: &[f64]) -> (f64, f64) {
    gradient_column_generic(kinv, alpha, aj, e, d2)
}

/// [`gradient_column_generic`] with the widest vectors the CPU has (bitwise the same results).
pub(super) fn gradient_column(
    kinv: &[f64],
    alpha: &[f64],
    aj: f64,
    e: &[f64],
    d2: &[f64],
) -> (f64, f64) {
    widest_vectors!(
        gradient_column_avx512,
        gradient_column_avx2,
        gradient_column_generic,
        (kinv, alpha, aj, e, d2)
    )
}
