//! Reference Gaussian-process regression: f64, `Vec`, a plain textbook Cholesky.
//!
//! This is the independent yardstick the core's `awfqi::gp::Gp` is compared against. It is
//! written to be checked by eye against the formulas, never for speed, and shares no code
//! with the core.
//!
//! Model (the same as the core's, `docs/algorithms.md` §4.2 with one length scale per
//! dimension):
//!
//! * kernel `k(x, x') = c · exp(−½ Σ_d ((x_d − x'_d) / l_d)²)`;
//! * training matrix `K = [k(x_i, x_j)] + (s2 + extra_diagonal) · I`, where `s2` is the noise
//!   variance and `extra_diagonal` is a jitter the caller may add to reproduce a core fit
//!   that reported one (0 for [`ReferenceGp::fit`]);
//! * `K = L Lᵀ` by the Cholesky–Banachiewicz algorithm, with **no** jitter escalation: a
//!   pivot that is not strictly positive (or not finite) is an error;
//! * `α = K⁻¹ y` by one forward and one backward triangular solve;
//! * predictive mean `μ(x*) = k*ᵀ α`;
//! * latent variance `c − vᵀv` with `v = L⁻¹ k*` (the noise is not included), clipped at 0;
//! * log marginal likelihood `−½ yᵀα − Σ_i ln L_ii − (n/2) ln 2π`.
//!
//! Zero prior mean, targets neither centred nor scaled, as in the spec.

// Index loops on purpose: the code follows the textbook formulas subscript by subscript.
#![allow(clippy::needless_range_loop)]

use std::f64::consts::PI;

/// Kernel hyperparameters of the reference GP (one length scale per input dimension).
#[derive(Debug, Clone, PartialEq)]
pub struct Hyperparameters {
    /// Signal variance `c > 0` (the prior variance of the latent function).
    pub signal_variance: f64,
    /// Length scales `l_d > 0`; their count is the input dimension.
    pub length_scales: Vec<f64>,
    /// Noise variance `s2 ≥ 0`, added to the diagonal of the training matrix only.
    pub noise_variance: f64,
}

impl Hyperparameters {
    /// Checks that every value is finite and in range, so the formulas below are defined.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.signal_variance.is_finite() && self.signal_variance > 0.0) {
            return Err(format!(
                "signal_variance must be finite and > 0, got {}",
                self.signal_variance
            ));
        }
        if self.length_scales.is_empty() {
            return Err("length_scales must have at least one entry".into());
        }
        if let Some(l) = self
            .length_scales
            .iter()
            .find(|l| !(l.is_finite() && **l > 0.0))
        {
            return Err(format!("length_scales must be finite and > 0, got {l}"));
        }
        if !(self.noise_variance.is_finite() && self.noise_variance >= 0.0) {
            return Err(format!(
                "noise_variance must be finite and >= 0, got {}",
                self.noise_variance
            ));
        }
        Ok(())
    }

    /// Input dimension `D` (the number of length scales).
    pub fn dim(&self) -> usize {
        self.length_scales.len()
    }
}

/// The squared-exponential ARD kernel `c · exp(−½ Σ_d ((a_d − b_d) / l_d)²)`, without noise.
pub fn kernel(a: &[f64], b: &[f64], hyper: &Hyperparameters) -> f64 {
    let mut squared_distance = 0.0;
    for d in 0..hyper.dim() {
        let scaled = (a[d] - b[d]) / hyper.length_scales[d];
        squared_distance += scaled * scaled;
    }
    hyper.signal_variance * (-0.5 * squared_distance).exp()
}

/// The training matrix `K = [k(x_i, x_j)] + (s2 + extra_diagonal) · I`, as rows.
pub fn training_matrix(
    x: &[Vec<f64>],
    hyper: &Hyperparameters,
    extra_diagonal: f64,
) -> Vec<Vec<f64>> {
    let n = x.len();
    let mut k = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..n {
            k[i][j] = kernel(&x[i], &x[j], hyper);
        }
        k[i][i] += hyper.noise_variance + extra_diagonal;
    }
    k
}

/// Why a Cholesky factorisation failed: the first pivot `K_jj − Σ_k L_jk²` that was not
/// strictly positive and finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NotPositiveDefinite {
    /// Row of the failing pivot.
    pub row: usize,
    /// The pivot value (≤ 0 or not finite).
    pub pivot: f64,
}

/// Plain Cholesky–Banachiewicz: returns the lower-triangular `L` (as full rows, zeros above
/// the diagonal) with `a = L Lᵀ`, or the first pivot that is not strictly positive.
pub fn cholesky(a: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, NotPositiveDefinite> {
    let n = a.len();
    let mut l = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if !(s > 0.0 && s.is_finite()) {
                    return Err(NotPositiveDefinite { row: i, pivot: s });
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    Ok(l)
}

/// Solves `L z = b` for lower-triangular `L` (forward substitution).
pub fn solve_lower(l: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let n = b.len();
    let mut z = vec![0.0; n];
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * z[k];
        }
        z[i] = s / l[i][i];
    }
    z
}

/// Solves `Lᵀ x = z` for lower-triangular `L` (backward substitution).
pub fn solve_upper_transposed(l: &[Vec<f64>], z: &[f64]) -> Vec<f64> {
    let n = z.len();
    let mut x = vec![0.0; n];
    for i in (0..n).rev() {
        let mut s = z[i];
        for k in (i + 1)..n {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    x
}

/// How hard a case is numerically, for sorting cases into "well-conditioned" and "hard".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Condition {
    /// Smallest Cholesky pivot `L_ii²` (the remaining variance of a point given the ones
    /// before it, noise included); ≤ 0 when the factorisation failed.
    pub min_pivot: f64,
    /// Largest diagonal entry of `K`.
    pub max_diagonal: f64,
    /// The 1-norm condition number `‖K‖₁ · ‖K⁻¹‖₁`, with `K⁻¹` formed explicitly from the
    /// Cholesky factor; `+∞` when the factorisation failed. For a symmetric positive
    /// definite matrix it lies within a factor `n` of the 2-norm condition number.
    pub condition_number: f64,
}

/// Reports the conditioning of the training matrix of a case (see [`Condition`]).
///
/// Returns an error only for invalid input (as [`ReferenceGp::fit_with_diagonal`] does); a
/// matrix that is not positive definite is reported as `condition_number = ∞`.
pub fn condition(
    x: &[Vec<f64>],
    hyper: &Hyperparameters,
    extra_diagonal: f64,
) -> Result<Condition, String> {
    validate_inputs(x, None, hyper, extra_diagonal)?;
    let k = training_matrix(x, hyper, extra_diagonal);
    let n = k.len();
    let max_diagonal = (0..n).map(|i| k[i][i]).fold(f64::NEG_INFINITY, f64::max);
    let l = match cholesky(&k) {
        Ok(l) => l,
        Err(failure) => {
            return Ok(Condition {
                min_pivot: failure.pivot,
                max_diagonal,
                condition_number: f64::INFINITY,
            });
        }
    };
    let min_pivot = (0..n)
        .map(|i| l[i][i] * l[i][i])
        .fold(f64::INFINITY, f64::min);
    // K⁻¹ column by column: K⁻¹ e_j = L⁻ᵀ L⁻¹ e_j.
    let mut inverse_column_sums = vec![0.0; n];
    for (j, sum) in inverse_column_sums.iter_mut().enumerate() {
        let mut e = vec![0.0; n];
        e[j] = 1.0;
        let column = solve_upper_transposed(&l, &solve_lower(&l, &e));
        *sum = column.iter().map(|v| v.abs()).sum();
    }
    let norm_inverse = inverse_column_sums.iter().cloned().fold(0.0, f64::max);
    let norm_k = (0..n)
        .map(|j| (0..n).map(|i| k[i][j].abs()).sum::<f64>())
        .fold(0.0, f64::max);
    Ok(Condition {
        min_pivot,
        max_diagonal,
        condition_number: norm_k * norm_inverse,
    })
}

/// A fitted reference GP: the training data, the Cholesky factor and `α = K⁻¹ y`.
#[derive(Debug, Clone)]
pub struct ReferenceGp {
    x: Vec<Vec<f64>>,
    hyper: Hyperparameters,
    extra_diagonal: f64,
    l: Vec<Vec<f64>>,
    alpha: Vec<f64>,
    log_marginal_likelihood: f64,
}

impl ReferenceGp {
    /// Fits the GP exactly as the formulas say, with nothing added to the diagonal beyond
    /// the noise variance.
    pub fn fit(x: &[Vec<f64>], y: &[f64], hyper: &Hyperparameters) -> Result<Self, String> {
        Self::fit_with_diagonal(x, y, hyper, 0.0)
    }

    /// Fits the GP with `extra_diagonal` added to the training diagonal on top of the
    /// noise variance — use it to reproduce a core fit that reported a jitter.
    ///
    /// Errors (as text): empty data, mismatched lengths or dimensions, non-finite values,
    /// invalid hyperparameters, or a training matrix that is not positive definite.
    pub fn fit_with_diagonal(
        x: &[Vec<f64>],
        y: &[f64],
        hyper: &Hyperparameters,
        extra_diagonal: f64,
    ) -> Result<Self, String> {
        validate_inputs(x, Some(y), hyper, extra_diagonal)?;
        let k = training_matrix(x, hyper, extra_diagonal);
        let l = cholesky(&k).map_err(|failure| {
            format!(
                "not positive definite: Cholesky pivot {} at row {}",
                failure.pivot, failure.row
            )
        })?;
        let alpha = solve_upper_transposed(&l, &solve_lower(&l, y));
        let n = y.len() as f64;
        let data_fit: f64 = y.iter().zip(&alpha).map(|(yi, ai)| yi * ai).sum();
        let log_det_half: f64 = (0..l.len()).map(|i| l[i][i].ln()).sum();
        let log_marginal_likelihood = -0.5 * data_fit - log_det_half - 0.5 * n * (2.0 * PI).ln();
        Ok(Self {
            x: x.to_vec(),
            hyper: hyper.clone(),
            extra_diagonal,
            l,
            alpha,
            log_marginal_likelihood,
        })
    }

    /// Predictive mean and latent variance (noise excluded, clipped at 0) at `x_star`.
    ///
    /// Panics if `x_star` has fewer coordinates than the input dimension (this is test
    /// code; [`ReferenceGp::check_point`] validates first).
    pub fn predict(&self, x_star: &[f64]) -> (f64, f64) {
        let k_star: Vec<f64> = self
            .x
            .iter()
            .map(|xi| kernel(xi, x_star, &self.hyper))
            .collect();
        let mean: f64 = k_star.iter().zip(&self.alpha).map(|(k, a)| k * a).sum();
        let v = solve_lower(&self.l, &k_star);
        let explained: f64 = v.iter().map(|vi| vi * vi).sum();
        let latent_variance = (self.hyper.signal_variance - explained).max(0.0);
        (mean, latent_variance)
    }

    /// Checks that a test point has the input dimension and finite coordinates.
    pub fn check_point(&self, x_star: &[f64]) -> Result<(), String> {
        if x_star.len() != self.hyper.dim() {
            return Err(format!(
                "test point has {} coordinates, expected {}",
                x_star.len(),
                self.hyper.dim()
            ));
        }
        if x_star.iter().any(|v| !v.is_finite()) {
            return Err("test point has a non-finite coordinate".into());
        }
        Ok(())
    }

    /// `−½ yᵀK⁻¹y − ½ ln det K − (n/2) ln 2π`.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.log_marginal_likelihood
    }

    /// The amount added to the diagonal beyond the noise variance.
    pub fn extra_diagonal(&self) -> f64 {
        self.extra_diagonal
    }

    /// Number of training points.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// `true` when there are no training points (never, for a successful fit).
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
}

fn validate_inputs(
    x: &[Vec<f64>],
    y: Option<&[f64]>,
    hyper: &Hyperparameters,
    extra_diagonal: f64,
) -> Result<(), String> {
    hyper.validate()?;
    if !(extra_diagonal.is_finite() && extra_diagonal >= 0.0) {
        return Err(format!(
            "extra diagonal must be finite and >= 0, got {extra_diagonal}"
        ));
    }
    if x.is_empty() {
        return Err("empty data: at least one training point is required".into());
    }
    if let Some(y) = y {
        if y.len() != x.len() {
            return Err(format!("{} inputs but {} targets", x.len(), y.len()));
        }
        if y.iter().any(|v| !v.is_finite()) {
            return Err("non-finite target in y".into());
        }
    }
    for (i, row) in x.iter().enumerate() {
        if row.len() != hyper.dim() {
            return Err(format!(
                "x[{i}] has {} coordinates, expected {}",
                row.len(),
                hyper.dim()
            ));
        }
        if row.iter().any(|v| !v.is_finite()) {
            return Err(format!("x[{i}] has a non-finite coordinate"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hyper(c: f64, l: &[f64], s2: f64) -> Hyperparameters {
        Hyperparameters {
            signal_variance: c,
            length_scales: l.to_vec(),
            noise_variance: s2,
        }
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    #[test]
    fn ard_kernel_by_hand() {
        let h = hyper(2.0, &[1.0, 2.0], 0.3);
        // ((1-0)/1)² + ((0-4)/2)² = 1 + 4 = 5.
        let expected = 2.0 * (-2.5f64).exp();
        assert!(close(kernel(&[1.0, 0.0], &[0.0, 4.0], &h), expected, 1e-15));
        assert_eq!(kernel(&[3.0, 3.0], &[3.0, 3.0], &h), 2.0);
    }

    #[test]
    fn one_point_by_hand() {
        let (c, s2, y0, l) = (2.0, 0.5, 1.5, 0.8);
        let h = hyper(c, &[l], s2);
        let gp = ReferenceGp::fit(&[vec![0.3]], &[y0], &h).unwrap();
        // K = c + s2, α = y0 / (c + s2).
        let lml = -0.5 * y0 * y0 / (c + s2) - 0.5 * (c + s2).ln() - 0.5 * (2.0 * PI).ln();
        assert!(close(gp.log_marginal_likelihood(), lml, 1e-14));
        // At x* = 1.3: k* = c · exp(−½ (1/l)²).
        let k = c * (-0.5 / (l * l)).exp();
        let (mean, var) = gp.predict(&[1.3]);
        assert!(close(mean, k * y0 / (c + s2), 1e-14));
        assert!(close(var, c - k * k / (c + s2), 1e-14));
        // At the training point the latent variance is c·s2/(c+s2).
        let (mean, var) = gp.predict(&[0.3]);
        assert!(close(mean, c * y0 / (c + s2), 1e-14));
        assert!(close(var, c * s2 / (c + s2), 1e-14));
    }

    #[test]
    fn two_points_by_hand() {
        // c = 1, l = 1, s2 = 1, x = 0 and 1: K = [[2, r], [r, 2]] with r = e^{-1/2}.
        let h = hyper(1.0, &[1.0], 1.0);
        let r = (-0.5f64).exp();
        let det = 4.0 - r * r;
        let gp = ReferenceGp::fit(&[vec![0.0], vec![1.0]], &[1.0, -1.0], &h).unwrap();
        // y = (1, −1): α = (1, −1) / (2 − r), yᵀα = 2 / (2 − r).
        let lml = -1.0 / (2.0 - r) - 0.5 * det.ln() - (2.0 * PI).ln();
        assert!(close(gp.log_marginal_likelihood(), lml, 1e-14));
        // x* = 0: k* = (1, r); mean = (1 − r)/(2 − r); k*ᵀK⁻¹k* = 2/(4 − r²).
        let (mean, var) = gp.predict(&[0.0]);
        assert!(close(mean, (1.0 - r) / (2.0 - r), 1e-14));
        assert!(close(var, 1.0 - 2.0 / det, 1e-14));
        // x* = 0.5: k* = (q, q) with q = e^{-1/8}; mean 0 by symmetry; variance
        // 1 − q² (2·2 − 2r) / (4 − r²) = 1 − 2q²/(2 + r).
        let q = (-0.125f64).exp();
        let (mean, var) = gp.predict(&[0.5]);
        assert!(mean.abs() < 1e-15);
        assert!(close(var, 1.0 - 2.0 * q * q / (2.0 + r), 1e-14));
    }

    #[test]
    fn condition_of_two_points_by_hand() {
        // K = [[2, r], [r, 2]]: ‖K‖₁ = 2 + r, ‖K⁻¹‖₁ = (2 + r)/(4 − r²), so κ₁ = (2+r)/(2−r).
        let h = hyper(1.0, &[1.0], 1.0);
        let r = (-0.5f64).exp();
        let cond = condition(&[vec![0.0], vec![1.0]], &h, 0.0).unwrap();
        assert!(close(cond.condition_number, (2.0 + r) / (2.0 - r), 1e-14));
        // Pivots: 2 and 2 − r²/2.
        assert!(close(cond.min_pivot, 2.0 - r * r / 2.0, 1e-14));
        assert_eq!(cond.max_diagonal, 2.0);
        // One point: κ = 1.
        let one = condition(&[vec![5.0]], &h, 0.0).unwrap();
        assert!(close(one.condition_number, 1.0, 1e-15));
    }

    #[test]
    fn extra_diagonal_acts_as_extra_noise() {
        let x = [vec![0.0, 1.0], vec![0.5, 0.2], vec![2.0, -1.0]];
        let y = [0.3, -1.2, 2.0];
        let a =
            ReferenceGp::fit_with_diagonal(&x, &y, &hyper(1.5, &[0.7, 1.3], 0.1), 0.05).unwrap();
        let b = ReferenceGp::fit(&x, &y, &hyper(1.5, &[0.7, 1.3], 0.15)).unwrap();
        assert!(close(
            a.log_marginal_likelihood(),
            b.log_marginal_likelihood(),
            1e-13
        ));
        let (ma, va) = a.predict(&[0.1, 0.1]);
        let (mb, vb) = b.predict(&[0.1, 0.1]);
        assert!(close(ma, mb, 1e-13) && close(va, vb, 1e-13));
    }

    #[test]
    fn nearly_noiseless_interpolates_the_data() {
        let x = [vec![0.0], vec![0.7], vec![1.9], vec![3.0]];
        let y = [1.0, -0.5, 0.25, 2.0];
        let gp = ReferenceGp::fit(&x, &y, &hyper(1.0, &[1.0], 1e-10)).unwrap();
        for (xi, yi) in x.iter().zip(&y) {
            let (mean, var) = gp.predict(xi);
            assert!((mean - yi).abs() < 1e-6, "{mean} vs {yi}");
            assert!(var < 1e-8);
        }
    }

    #[test]
    fn cholesky_reconstructs_and_solves() {
        let a = vec![
            vec![4.0, 2.0, 0.4],
            vec![2.0, 5.0, 1.0],
            vec![0.4, 1.0, 3.0],
        ];
        let l = cholesky(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let llt: f64 = (0..3).map(|k| l[i][k] * l[j][k]).sum();
                assert!(close(llt, a[i][j], 1e-15));
            }
        }
        let b = [1.0, -2.0, 0.5];
        let x = solve_upper_transposed(&l, &solve_lower(&l, &b));
        for i in 0..3 {
            let ax: f64 = (0..3).map(|j| a[i][j] * x[j]).sum();
            assert!(close(ax, b[i], 1e-14));
        }
    }

    #[test]
    fn duplicate_points_without_noise_are_not_positive_definite() {
        let h = hyper(1.0, &[1.0], 0.0);
        let x = [vec![0.5], vec![0.5]];
        let err = ReferenceGp::fit(&x, &[1.0, 2.0], &h).unwrap_err();
        assert!(err.contains("not positive definite"), "{err}");
        let cond = condition(&x, &h, 0.0).unwrap();
        assert!(cond.condition_number.is_infinite());
        assert!(cond.min_pivot <= 0.0);
    }

    #[test]
    fn invalid_inputs_are_errors() {
        let h = hyper(1.0, &[1.0], 0.1);
        assert!(ReferenceGp::fit(&[], &[], &h).is_err());
        assert!(ReferenceGp::fit(&[vec![0.0]], &[1.0, 2.0], &h).is_err());
        assert!(ReferenceGp::fit(&[vec![0.0, 1.0]], &[1.0], &h).is_err());
        assert!(ReferenceGp::fit(&[vec![f64::NAN]], &[1.0], &h).is_err());
        assert!(ReferenceGp::fit(&[vec![0.0]], &[f64::INFINITY], &h).is_err());
        assert!(ReferenceGp::fit(&[vec![0.0]], &[1.0], &hyper(0.0, &[1.0], 0.1)).is_err());
        assert!(ReferenceGp::fit(&[vec![0.0]], &[1.0], &hyper(1.0, &[-1.0], 0.1)).is_err());
        assert!(ReferenceGp::fit(&[vec![0.0]], &[1.0], &hyper(1.0, &[1.0], -0.1)).is_err());
        assert!(ReferenceGp::fit_with_diagonal(&[vec![0.0]], &[1.0], &h, f64::NAN).is_err());
    }
}
