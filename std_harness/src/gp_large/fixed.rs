//! Gaussian processes with a **fixed** kernel, as the reference's Dam and Acrobot
//! experiments configure them (scikit-learn kernels with `"fixed"` bounds, so no
//! hyperparameter search): a sum of constant × anisotropic RBF terms plus white noise,
//!
//! `k(z, z′) = Σ_j c_j·exp(−½ Σ_d ((z_d − z′_d)/ℓ_jd)²) + σ²ₙ·1{same training sample}`,
//!
//! with the reference's jitter `10⁻¹⁰` on the training diagonal, zero prior mean, targets
//! as given. Predictions are the posterior mean and the predictive std, which includes
//! `σ²ₙ` like [`super::LargeGp`]'s.
//!
//! **Exact splitting.** When one input coordinate takes a few distinct values (the action)
//! and every term's length scale along it is so short that `exp` of the smallest gap
//! underflows to exactly 0 (the Dam's reward kernel: ℓ = 0.0161 and 4.75·10⁻⁵ against
//! release gaps ≥ 2), the Gram matrix is block-diagonal in exact arithmetic *and* in
//! floating point; each value's points are then conditioned on their own (`n/8` points
//! instead of `n` for eight actions), which changes no prediction beyond rounding.
//!
//! **Jitter** \[CHOICE\]: a Gram matrix that is not numerically positive definite with
//! the reference's `10⁻¹⁰` (noise-free kernels on thousands of nearby points) is retried
//! with `10⁻⁸`, `10⁻⁶` and `10⁻⁴` (scikit-learn would raise); [`FixedGp::jitter`] says
//! which one conditioned it.
//!
//! **Predictive variance.** By default `σ²(z) = k(z, z) − ‖L⁻¹k*‖²`, the stable form.
//! [`PredictiveVariance::ExplicitInverse`] instead forms `K⁻¹ = L⁻ᵀL⁻¹` and computes
//! `k(z, z) − k*ᵀK⁻¹k*`, negatives set to 0, as scikit-learn up to 0.23 did and so as the
//! IWFQI reference's GPs did: on noise-free kernels over thousands of nearby points (the
//! Dam's reward GP) that form is mostly rounding error, and the published weights carry
//! it. An ablation for reproducing them, never the default.

use awfqi::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::{Mat, Par};

use super::JITTER;

/// One term `c·exp(−½ Σ_d ((z_d − z′_d)/ℓ_d)²)` of a fixed kernel.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RbfTerm {
    /// Signal variance `c > 0`.
    pub signal_variance: f64,
    /// Length scale per input coordinate (`ℓ_d > 0`; coordinates beyond the list are
    /// ignored, as if `ℓ_d = ∞`).
    pub length_scales: Vec<f64>,
}

/// A fixed kernel: RBF terms plus white noise (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FixedKernel {
    /// The RBF terms.
    pub terms: Vec<RbfTerm>,
    /// White-noise variance `σ²ₙ ≥ 0`.
    pub noise_variance: f64,
}

impl FixedKernel {
    /// `c·RBF(ℓ)` isotropic over the first `dims` coordinates, plus `noise_variance`.
    pub fn isotropic(signal_variance: f64, length_scale: f64, dims: usize, noise: f64) -> Self {
        Self {
            terms: vec![RbfTerm {
                signal_variance,
                length_scales: vec![length_scale; dims],
            }],
            noise_variance: noise,
        }
    }

    pub(super) fn validate(&self) -> Result<()> {
        if self.terms.is_empty() {
            return Err(Error::InvalidParameter { parameter: "terms" });
        }
        for t in &self.terms {
            let ok = t.signal_variance.is_finite()
                && t.signal_variance > 0.0
                && t.length_scales.iter().all(|l| l.is_finite() && *l > 0.0);
            if !ok {
                return Err(Error::InvalidParameter { parameter: "terms" });
            }
        }
        if !(self.noise_variance.is_finite() && self.noise_variance >= 0.0) {
            return Err(Error::InvalidParameter {
                parameter: "noise_variance",
            });
        }
        Ok(())
    }

    /// The covariance of two inputs (without the noise).
    pub fn covariance<const Z: usize>(&self, a: &[f64; Z], b: &[f64; Z]) -> f64 {
        self.terms
            .iter()
            .map(|t| {
                let q: f64 = t
                    .length_scales
                    .iter()
                    .zip(a.iter().zip(b))
                    .map(|(l, (x, y))| {
                        let u = (x - y) / l;
                        u * u
                    })
                    .sum();
                t.signal_variance * (-0.5 * q).exp()
            })
            .sum()
    }

    /// The prior variance of a test point: `Σ c_j + σ²ₙ`.
    pub fn prior_variance(&self) -> f64 {
        self.terms.iter().map(|t| t.signal_variance).sum::<f64>() + self.noise_variance
    }

    /// `true` when two inputs whose coordinate `coord` differs by `gap` are exactly
    /// uncorrelated, whatever their other coordinates: every term's factor along `coord`
    /// underflows to 0.
    pub(super) fn uncorrelated_at(&self, coord: usize, gap: f64) -> bool {
        self.terms.iter().all(|t| match t.length_scales.get(coord) {
            Some(l) => {
                let u = gap / l;
                t.signal_variance * (-0.5 * u * u).exp() == 0.0
            }
            None => false,
        })
    }
}

/// How [`FixedGp`] computes its predictive variance (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PredictiveVariance {
    /// `k(z, z) − ‖L⁻¹k*‖²` (one triangular solve per query).
    #[default]
    Stable,
    /// `k(z, z) − k*ᵀ(L⁻ᵀL⁻¹)k*` with the inverse formed explicitly, negatives set to 0:
    /// scikit-learn ≤ 0.23's arithmetic, which the IWFQI reference ran.
    ExplicitInverse,
}

impl PredictiveVariance {
    /// Whether this is the default (kept out of result files).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// The points sharing one value of the split coordinate (or all points), conditioned.
#[derive(Debug, Clone)]
struct Block<const Z: usize> {
    key: f64,
    inputs: Vec<[f64; Z]>,
    /// Lower Cholesky factor of `K + (σ²ₙ + jitter) I`.
    factor: Mat<f64>,
    /// `K⁻¹y`.
    alpha: Vec<f64>,
    /// `K⁻¹ = L⁻ᵀL⁻¹`, formed only for [`PredictiveVariance::ExplicitInverse`].
    inverse: Option<Mat<f64>>,
}

/// A GP with a fixed kernel conditioned on its training data (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct FixedGp<const Z: usize> {
    kernel: FixedKernel,
    /// The coordinate the blocks split on, when they do.
    split: Option<usize>,
    blocks: Vec<Block<Z>>,
    jitter: f64,
    par: Par,
}

impl<const Z: usize> FixedGp<Z> {
    /// Conditions a GP with `kernel` on `(inputs, targets)`; when `split` names a
    /// coordinate along which the kernel decorrelates exactly, each of its values is
    /// conditioned separately.
    ///
    /// Errors: empty data, mismatched lengths, non-finite values, an invalid kernel, or a
    /// Gram matrix that is not positive definite even with jitter `10⁻⁴`.
    pub fn fit(
        inputs: &[[f64; Z]],
        targets: &[f64],
        kernel: &FixedKernel,
        split: Option<usize>,
        par: Par,
    ) -> Result<Self> {
        kernel.validate()?;
        if inputs.is_empty() {
            return Err(Error::EmptyData);
        }
        check_training(inputs, targets)?;
        let split = split.filter(|&c| c < Z && separable(inputs, kernel, c));
        let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
        for (i, x) in inputs.iter().enumerate() {
            let key = split.map_or(0.0, |c| x[c]);
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, members)) => members.push(i),
                None => groups.push((key, vec![i])),
            }
        }
        let mut jitter = JITTER;
        loop {
            let blocks: Option<Vec<Block<Z>>> = groups
                .iter()
                .map(|(key, members)| {
                    let xs: Vec<[f64; Z]> = members.iter().map(|&i| inputs[i]).collect();
                    let ys: Vec<f64> = members.iter().map(|&i| targets[i]).collect();
                    condition(*key, xs, &ys, kernel, jitter, par)
                })
                .collect();
            if let Some(blocks) = blocks {
                return Ok(Self {
                    kernel: kernel.clone(),
                    split,
                    blocks,
                    jitter,
                    par,
                });
            }
            if jitter >= 1e-4 {
                return Err(Error::NotPositiveDefinite);
            }
            jitter *= 100.0;
        }
    }

    /// The same GP, predicting its variance by `variance` (forms each block's `K⁻¹` for
    /// [`PredictiveVariance::ExplicitInverse`]: `n²` more memory per block).
    pub fn with_variance(mut self, variance: PredictiveVariance) -> Self {
        for block in &mut self.blocks {
            block.inverse = match variance {
                PredictiveVariance::Stable => None,
                PredictiveVariance::ExplicitInverse => {
                    Some(explicit_inverse(block.factor.as_ref(), self.par))
                }
            };
        }
        self
    }

    /// Number of training points.
    pub fn len(&self) -> usize {
        self.blocks.iter().map(|b| b.inputs.len()).sum()
    }

    /// `false`: a fitted GP has points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The kernel.
    pub fn kernel(&self) -> &FixedKernel {
        &self.kernel
    }

    /// The diagonal jitter that conditioned the Gram matrix (`10⁻¹⁰` unless retried).
    pub fn jitter(&self) -> f64 {
        self.jitter
    }

    /// Number of independently conditioned blocks (1 without splitting).
    pub fn blocks(&self) -> usize {
        self.blocks.len()
    }

    /// Posterior means and predictive stds (including `σ²ₙ`) at `zs`.
    ///
    /// Errors: output lengths differ from `zs.len()`; a test point whose split
    /// coordinate is correlated with more than its own block (a value between the
    /// training values) ([`Error::OutOfRange`] `zs`).
    pub fn predict_into(&self, zs: &[[f64; Z]], means: &mut [f64], stds: &mut [f64]) -> Result<()> {
        if means.len() != zs.len() {
            return Err(Error::InvalidParameter { parameter: "means" });
        }
        if stds.len() != zs.len() {
            return Err(Error::InvalidParameter { parameter: "stds" });
        }
        let prior = self.kernel.prior_variance();
        // Each test point goes to the block of its split value; points of a value absent
        // from the training data (and uncorrelated with every block) keep the prior.
        let mut by_block: Vec<Vec<usize>> = vec![Vec::new(); self.blocks.len()];
        for (q, z) in zs.iter().enumerate() {
            match self.split {
                None => by_block[0].push(q),
                Some(c) => {
                    let mut own = None;
                    for (b, block) in self.blocks.iter().enumerate() {
                        if block.key == z[c] {
                            own = Some(b);
                        } else if !self.kernel.uncorrelated_at(c, (block.key - z[c]).abs()) {
                            return Err(Error::OutOfRange { parameter: "zs" });
                        }
                    }
                    match own {
                        Some(b) => by_block[b].push(q),
                        None => {
                            means[q] = 0.0;
                            stds[q] = prior.sqrt();
                        }
                    }
                }
            }
        }
        const CHUNK: usize = 256;
        for (block, queries) in self.blocks.iter().zip(&by_block) {
            let n = block.inputs.len();
            let mut cross = Mat::<f64>::zeros(n, CHUNK.min(queries.len()).max(1));
            for chunk in queries.chunks(CHUNK) {
                cross.truncate(n, chunk.len());
                for (col, &q) in chunk.iter().enumerate() {
                    let column = cross.col_as_slice_mut(col);
                    for (v, x) in column.iter_mut().zip(&block.inputs) {
                        *v = self.kernel.covariance(x, &zs[q]);
                    }
                    means[q] = column.iter().zip(&block.alpha).map(|(a, b)| a * b).sum();
                }
                if let Some(inverse) = &block.inverse {
                    // scikit-learn's `k** − einsum(K* K⁻¹, K*)`, negatives to 0.
                    let mut product = Mat::<f64>::zeros(n, chunk.len());
                    faer::linalg::matmul::matmul(
                        product.as_mut(),
                        faer::Accum::Replace,
                        inverse.as_ref(),
                        cross.as_ref(),
                        1.0,
                        self.par,
                    );
                    for (col, &q) in chunk.iter().enumerate() {
                        let v: f64 = cross
                            .col_as_slice(col)
                            .iter()
                            .zip(product.col_as_slice(col))
                            .map(|(a, b)| a * b)
                            .sum();
                        stds[q] = (prior - v).max(0.0).sqrt();
                    }
                    continue;
                }
                faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                    block.factor.as_ref(),
                    cross.as_mut(),
                    self.par,
                );
                for (col, &q) in chunk.iter().enumerate() {
                    let v: f64 = cross.col_as_slice(col).iter().map(|x| x * x).sum();
                    stds[q] = (prior - v).max(0.0).sqrt();
                }
            }
        }
        Ok(())
    }
}

/// Training data of a fixed GP: as many targets as inputs, every value finite.
pub(super) fn check_training<const Z: usize>(inputs: &[[f64; Z]], targets: &[f64]) -> Result<()> {
    if targets.len() != inputs.len() {
        return Err(Error::InvalidParameter {
            parameter: "targets",
        });
    }
    if inputs
        .iter()
        .flatten()
        .chain(targets)
        .any(|v| !v.is_finite())
    {
        return Err(Error::NonFinite {
            parameter: "inputs",
        });
    }
    Ok(())
}

/// Cholesky factor of the symmetric matrix whose lower triangle `m` holds, in place;
/// `None` when it is not numerically positive definite.
pub(super) fn cholesky_lower(m: faer::MatMut<'_, f64>, par: Par) -> Option<()> {
    let mut scratch = MemBuffer::new(
        faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
            m.nrows(),
            par,
            Default::default(),
        ),
    );
    faer::linalg::cholesky::llt::factor::cholesky_in_place(
        m,
        Default::default(),
        par,
        MemStack::new(&mut scratch),
        Default::default(),
    )
    .ok()
    .map(|_| ())
}

/// `true` when the distinct values of coordinate `c` are all far enough apart for the
/// kernel to decorrelate them exactly (and there are at least two).
pub(super) fn separable<const Z: usize>(
    inputs: &[[f64; Z]],
    kernel: &FixedKernel,
    c: usize,
) -> bool {
    let mut values: Vec<f64> = inputs.iter().map(|x| x[c]).collect();
    values.sort_by(f64::total_cmp);
    values.dedup();
    let min_gap = values
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    values.len() > 1 && kernel.uncorrelated_at(c, min_gap)
}

/// `K⁻¹ = L⁻ᵀL⁻¹` from the lower factor `L`, as scikit-learn formed it: `L⁻ᵀ` by an
/// upper-triangular solve against the identity, then the product with its transpose.
fn explicit_inverse(factor: faer::MatRef<'_, f64>, par: Par) -> Mat<f64> {
    let n = factor.nrows();
    let mut l_inv_t = Mat::<f64>::identity(n, n);
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(
        factor.transpose(),
        l_inv_t.as_mut(),
        par,
    );
    let mut inverse = Mat::<f64>::zeros(n, n);
    faer::linalg::matmul::matmul(
        inverse.as_mut(),
        faer::Accum::Replace,
        l_inv_t.as_ref(),
        l_inv_t.as_ref().transpose(),
        1.0,
        par,
    );
    inverse
}

/// Conditions one block; `None` when its Gram matrix is not positive definite.
fn condition<const Z: usize>(
    key: f64,
    inputs: Vec<[f64; Z]>,
    targets: &[f64],
    kernel: &FixedKernel,
    jitter: f64,
    par: Par,
) -> Option<Block<Z>> {
    let n = inputs.len();
    let mut factor = Mat::<f64>::zeros(n, n);
    let diagonal = kernel.covariance(&inputs[0], &inputs[0]) + kernel.noise_variance + jitter;
    for j in 0..n {
        let col = factor.col_as_slice_mut(j);
        col[j] = diagonal;
        for i in j + 1..n {
            col[i] = kernel.covariance(&inputs[i], &inputs[j]);
        }
    }
    cholesky_lower(factor.as_mut(), par)?;
    let mut alpha = Mat::<f64>::zeros(n, 1);
    alpha.col_as_slice_mut(0).copy_from_slice(targets);
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        factor.as_ref(),
        alpha.as_mut(),
        par,
    );
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(
        factor.as_ref().transpose(),
        alpha.as_mut(),
        par,
    );
    let alpha = alpha.col_as_slice(0).to_vec();
    alpha.iter().all(|a| a.is_finite()).then_some(Block {
        key,
        inputs,
        factor,
        alpha,
        inverse: None,
    })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// Points with a three-valued third coordinate (the "action").
    pub(crate) fn points(n: usize) -> (Vec<[f64; 3]>, Vec<f64>) {
        let xs: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                [
                    i as f64 * 0.37 % 5.0,
                    (i * 7 % 11) as f64,
                    [0.0, 3.0, 5.0][i % 3],
                ]
            })
            .collect();
        let ys = xs
            .iter()
            .map(|x| (x[0] + x[2]).sin() - 0.1 * x[1])
            .collect();
        (xs, ys)
    }

    /// The dense posterior, computed naively (Gaussian elimination on the full system).
    #[allow(clippy::needless_range_loop)]
    fn dense(xs: &[[f64; 3]], ys: &[f64], k: &FixedKernel, z: &[f64; 3]) -> (f64, f64) {
        let n = xs.len();
        let mut a = vec![vec![0.0; n + 2]; n];
        for i in 0..n {
            for j in 0..n {
                a[i][j] = k.covariance(&xs[i], &xs[j]);
            }
            a[i][i] += k.noise_variance + JITTER;
            a[i][n] = ys[i];
            a[i][n + 1] = k.covariance(&xs[i], z);
        }
        for c in 0..n {
            let p = a[c][c];
            for r in c + 1..n {
                let f = a[r][c] / p;
                for j in c..n + 2 {
                    a[r][j] -= f * a[c][j];
                }
            }
        }
        let mut sol = vec![[0.0; 2]; n];
        for r in (0..n).rev() {
            for (m, col) in [n, n + 1].into_iter().enumerate() {
                let mut v = a[r][col];
                for j in r + 1..n {
                    v -= a[r][j] * sol[j][m];
                }
                sol[r][m] = v / a[r][r];
            }
        }
        let kz: Vec<f64> = xs.iter().map(|x| k.covariance(x, z)).collect();
        let mean: f64 = kz.iter().zip(&sol).map(|(a, s)| a * s[0]).sum();
        let var: f64 = k.prior_variance() - kz.iter().zip(&sol).map(|(a, s)| a * s[1]).sum::<f64>();
        (mean, var.max(0.0).sqrt())
    }

    #[test]
    fn predictions_match_the_dense_posterior_and_splitting_is_exact() {
        let (xs, ys) = points(60);
        let anisotropic = FixedKernel {
            terms: vec![
                RbfTerm {
                    signal_variance: 2.0,
                    length_scales: vec![1.3, 1e5, 0.0161],
                },
                RbfTerm {
                    signal_variance: 0.5,
                    length_scales: vec![4.0, 1e5, 4.75e-5],
                },
            ],
            noise_variance: 0.0,
        };
        let iso = FixedKernel::isotropic(1.5, 2.0, 3, 0.3);
        let tests = [
            [1.1, 2.0, 3.0],
            [4.9, 8.0, 0.0],
            [2.5, 1.0, 5.0],
            [7.0, 0.0, 10.0],
        ];
        for (kernel, blocks) in [(&anisotropic, 3), (&iso, 1)] {
            let gp = FixedGp::fit(&xs, &ys, kernel, Some(2), Par::Seq).unwrap();
            assert_eq!(gp.blocks(), blocks);
            assert_eq!(gp.len(), 60);
            assert_eq!(gp.jitter(), JITTER);
            let mut m = [0.0; 4];
            let mut s = [0.0; 4];
            gp.predict_into(&tests, &mut m, &mut s).unwrap();
            for (q, z) in tests.iter().enumerate() {
                let (mean, std) = dense(&xs, &ys, kernel, z);
                assert!(
                    (m[q] - mean).abs() < 1e-6 * mean.abs().max(1.0),
                    "{q}: {} vs {mean}",
                    m[q]
                );
                assert!((s[q] - std).abs() < 1e-5, "{q}: {} vs {std}", s[q]);
            }
        }
        // A value between the training actions is correlated with two blocks: refused.
        let gp = FixedGp::fit(&xs, &ys, &anisotropic, Some(2), Par::Seq).unwrap();
        let (mut m, mut s) = ([0.0], [0.0]);
        assert!(
            gp.predict_into(&[[1.0, 1.0, 3.00001]], &mut m, &mut s)
                .is_err()
        );
        // The noise is part of the predictive std: at a training point of a noisy GP the
        // std is at least σₙ.
        let noisy = FixedGp::fit(&xs, &ys, &iso, None, Par::Seq).unwrap();
        noisy.predict_into(&xs[..1], &mut m, &mut s).unwrap();
        assert!(s[0] >= 0.3f64.sqrt() - 1e-12);
    }

    #[test]
    fn explicit_inverse_variance_is_the_same_posterior_when_well_conditioned() {
        let (xs, ys) = points(60);
        let iso = FixedKernel::isotropic(1.5, 2.0, 3, 0.3);
        let tests = [[1.1, 2.0, 3.0], [4.9, 8.0, 0.0], [2.5, 1.0, 5.0], xs[7]];
        let stable = FixedGp::fit(&xs, &ys, &iso, None, Par::Seq).unwrap();
        let explicit = stable
            .clone()
            .with_variance(PredictiveVariance::ExplicitInverse);
        let (mut m1, mut s1, mut m2, mut s2) = ([0.0; 4], [0.0; 4], [0.0; 4], [0.0; 4]);
        stable.predict_into(&tests, &mut m1, &mut s1).unwrap();
        explicit.predict_into(&tests, &mut m2, &mut s2).unwrap();
        assert_eq!(m1, m2, "the means do not depend on the variance's form");
        for (q, z) in tests.iter().enumerate() {
            let (_, std) = dense(&xs, &ys, &iso, z);
            assert!((s2[q] - std).abs() < 1e-9, "{q}: {} vs {std}", s2[q]);
        }
        // Back to the stable form: the inverse is dropped, the stds are the stable ones.
        let back = explicit.with_variance(PredictiveVariance::Stable);
        back.predict_into(&tests, &mut m2, &mut s2).unwrap();
        assert_eq!(s1, s2);
    }

    #[test]
    fn explicit_inverse_variance_shows_rounding_on_dense_noise_free_points() {
        // 300 noise-free points 0.1 apart under a length scale of 3.2 (the Dam reward
        // kernel's short term along the storage): the Gram matrix is numerically singular
        // but for the jitter. At a training point the exact std is 0; the stable form stays
        // near it, the explicit inverse returns rounding error of a larger size, but never
        // a negative variance or a NaN.
        let k = FixedKernel {
            terms: vec![RbfTerm {
                signal_variance: 3.25 * 3.25,
                length_scales: vec![3.2, 1e5, 1e5],
            }],
            noise_variance: 0.0,
        };
        let xs: Vec<[f64; 3]> = (0..300).map(|i| [i as f64 * 0.1, 1.0, 0.0]).collect();
        let ys: Vec<f64> = xs.iter().map(|x| (x[0] / 5.0).sin() * 10.0).collect();
        let stable = FixedGp::fit(&xs, &ys, &k, None, Par::Seq).unwrap();
        let explicit = stable
            .clone()
            .with_variance(PredictiveVariance::ExplicitInverse);
        let (mut m1, mut s1) = (vec![0.0; 300], vec![0.0; 300]);
        let (mut m2, mut s2) = (vec![0.0; 300], vec![0.0; 300]);
        stable.predict_into(&xs, &mut m1, &mut s1).unwrap();
        explicit.predict_into(&xs, &mut m2, &mut s2).unwrap();
        let worst = |s: &[f64]| s.iter().fold(0.0f64, |a, &b| a.max(b));
        assert!(s2.iter().all(|s| s.is_finite() && *s >= 0.0));
        assert!(worst(&s1) < 1e-3, "{}", worst(&s1));
        assert!(
            worst(&s2) > 10.0 * worst(&s1),
            "{} {}",
            worst(&s2),
            worst(&s1)
        );
    }

    #[test]
    fn bad_input_is_an_error_and_duplicates_get_more_jitter() {
        let k = FixedKernel::isotropic(1.0, 1.0, 3, 0.0);
        assert!(FixedGp::<3>::fit(&[], &[], &k, None, Par::Seq).is_err());
        assert!(FixedGp::fit(&[[0.0; 3]], &[f64::NAN], &k, None, Par::Seq).is_err());
        assert!(FixedGp::fit(&[[0.0; 3]], &[1.0, 2.0], &k, None, Par::Seq).is_err());
        let bad = FixedKernel::isotropic(-1.0, 1.0, 3, 0.0);
        assert!(FixedGp::fit(&[[0.0; 3]], &[1.0], &bad, None, Par::Seq).is_err());
        // 200 copies of one point without noise: singular at 1e-10 in floating point?
        // Whatever jitter it needed, the mean at the point is the common target.
        let xs = vec![[0.5, 0.5, 1.0]; 200];
        let ys = vec![2.0; 200];
        let gp = FixedGp::fit(&xs, &ys, &k, None, Par::Seq).unwrap();
        assert!(gp.jitter() >= JITTER && gp.jitter() <= 1e-4);
        let (mut m, mut s) = ([0.0], [0.0]);
        gp.predict_into(&xs[..1], &mut m, &mut s).unwrap();
        assert!((m[0] - 2.0).abs() < 1e-3, "{}", m[0]);
    }
}
