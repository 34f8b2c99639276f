//! The log marginal likelihood and its gradient ([`LikelihoodEvaluator`]), and the
//! memoised objective the optimiser minimises, and the check of a training set both need.

use super::kernel::*;
use super::*;
use awfqi::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::triangular::BlockStructure;
use faer::{Accum, Mat, Par};

const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// Evaluates the log marginal likelihood and its gradient at many `θ` for fixed data,
/// reusing its buffers. The numerical heart of [`LargeGp::fit`], public for tests and
/// benchmarks.
pub struct LikelihoodEvaluator<'a, const D: usize> {
    pub(super) targets: &'a [f64],
    /// Squared distances, strict lower triangle packed column by column.
    pub(super) d2: Vec<f64>,
    /// `exp(−d²/(2ℓ²))` at the last evaluated `θ`, same layout.
    pub(super) e: Vec<f64>,
    /// `K`, then `L` in the lower triangle; after a gradient, `K⁻¹`.
    pub(super) chol: Mat<f64>,
    /// `L⁻¹` during a gradient.
    pub(super) inv: Mat<f64>,
    /// `L⁻¹y` after a value, `K⁻¹y` after [`LikelihoodEvaluator::finish_alpha`] (a
    /// one-column matrix for faer's solves).
    pub(super) alpha: Mat<f64>,
    pub(super) scratch: MemBuffer,
    pub(super) par: Par,
    /// `θ` and the kernel values of the last successful value evaluation.
    pub(super) last: Option<[f64; 3]>,
    /// Every `θ` evaluated through [`NegativeLml`] with its value, so that a repeated point
    /// (line searches of different starts often end on the same corner of the box) costs
    /// no factorisation.
    pub(super) memo: Vec<([f64; 3], Option<f64>)>,
    /// Cholesky factorisations done (every [`LikelihoodEvaluator::value`] call).
    pub(super) factorizations: usize,
    /// Added to the training diagonal ([`JITTER`] unless set by [`Self::with_jitter`]).
    pub(super) jitter: f64,
}

impl<'a, const D: usize> LikelihoodEvaluator<'a, D> {
    /// Prepares the evaluation on `(inputs, targets)`.
    ///
    /// Errors: empty data ([`Error::EmptyData`](awfqi::Error::EmptyData)), mismatched lengths,
    /// non-finite values.
    pub fn new(inputs: &[[f64; D]], targets: &'a [f64], par: Par) -> Result<Self> {
        validate_data(inputs, targets)?;
        let n = inputs.len();
        let mut d2 = Vec::with_capacity(n * (n - 1) / 2);
        for j in 0..n {
            for i in j + 1..n {
                d2.push(squared_distance(&inputs[i], &inputs[j]));
            }
        }
        let scratch = MemBuffer::new(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                n,
                par,
                Default::default(),
            ),
        );
        Ok(Self {
            targets,
            e: vec![0.0; d2.len()],
            d2,
            chol: Mat::zeros(n, n),
            inv: Mat::zeros(n, n),
            alpha: Mat::zeros(n, 1),
            scratch,
            par,
            last: None,
            memo: Vec::new(),
            factorizations: 0,
            jitter: JITTER,
        })
    }

    /// The same evaluator with `jitter` on the training diagonal instead of [`JITTER`].
    pub fn with_jitter(mut self, jitter: f64) -> Self {
        self.jitter = jitter;
        self
    }

    /// The log marginal likelihood at `θ = (ln c, ln ℓ, ln σ²ₙ)`, or `None` when the Gram
    /// matrix is not positive definite (the reference then reports `−∞`).
    pub fn value(&mut self, theta: &[f64; 3]) -> Option<f64> {
        self.last = None;
        self.factorizations += 1;
        let n = self.targets.len();
        let h = GpHyperparameters::from_log(theta);
        let c = h.signal_variance;
        let k = -0.5 / (h.length_scale * h.length_scale);
        let mut p = 0;
        for j in 0..n {
            let col = self.chol.col_as_slice_mut(j);
            col[j] = c + h.noise_variance + self.jitter;
            let len = n - j - 1;
            kernel_column(
                k,
                c,
                &self.d2[p..p + len],
                &mut self.e[p..p + len],
                &mut col[j + 1..],
            );
            p += len;
        }
        faer::linalg::cholesky::llt::factor::cholesky_in_place(
            self.chol.as_mut(),
            Default::default(),
            self.par,
            MemStack::new(&mut self.scratch),
            Default::default(),
        )
        .ok()?;
        // yᵀK⁻¹y = ‖L⁻¹y‖²: the backward solve for α = K⁻¹y waits for a gradient.
        self.alpha.col_as_slice_mut(0).copy_from_slice(self.targets);
        faer::linalg::triangular_solve::solve_lower_triangular_in_place(
            self.chol.as_ref(),
            self.alpha.as_mut(),
            self.par,
        );
        let fit: f64 = self.alpha.col_as_slice(0).iter().map(|w| w * w).sum();
        let log_det: f64 = (0..n).map(|i| self.chol[(i, i)].ln()).sum();
        let lml = -0.5 * fit - log_det - 0.5 * n as f64 * LN_2PI;
        if !lml.is_finite() {
            return None;
        }
        self.last = Some(*theta);
        Some(lml)
    }

    /// `α = K⁻¹y` from `L⁻¹y` (in `alpha` after a value) by the backward solve with `Lᵀ`; `L`
    /// must still be in `chol` (no gradient since the value).
    pub(super) fn finish_alpha(&mut self) {
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            self.chol.as_ref().transpose(),
            self.alpha.as_mut(),
            self.par,
        );
    }

    /// `∂ LML / ∂θ` at the `θ` of the last successful [`LikelihoodEvaluator::value`]
    /// (`½ tr((ααᵀ − K⁻¹) ∂K/∂θ_k)` with `α = K⁻¹y`), or `None` without one. Overwrites the
    /// factor, so it can be called once per value.
    pub fn gradient(&mut self) -> Option<[f64; 3]> {
        let theta = self.last.take()?;
        let n = self.targets.len();
        let h = GpHyperparameters::from_log(&theta);
        self.finish_alpha();
        // K⁻¹ = L⁻ᵀ L⁻¹ into the lower triangle of `chol`.
        faer::linalg::triangular_inverse::invert_lower_triangular(
            self.inv.as_mut(),
            self.chol.as_ref(),
            self.par,
        );
        faer::linalg::matmul::triangular::matmul(
            self.chol.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            self.inv.as_ref().transpose(),
            BlockStructure::TriangularUpper,
            self.inv.as_ref(),
            BlockStructure::TriangularLower,
            1.0,
            self.par,
        );
        let alpha = self.alpha.col_as_slice(0);
        // Diagonal (e = 1, d² = 0) and strict lower triangle (counted twice by symmetry).
        let mut diag = 0.0;
        let (mut off_e, mut off_ed2) = (0.0, 0.0);
        let mut p = 0;
        for j in 0..n {
            let col = self.chol.col_as_slice(j);
            let w = alpha[j] * alpha[j] - col[j];
            diag += w;
            let len = n - j - 1;
            let (d2, e) = (&self.d2[p..p + len], &self.e[p..p + len]);
            let (se, sd) = gradient_column(&col[j + 1..], &alpha[j + 1..], alpha[j], e, d2);
            off_e += se;
            off_ed2 += sd;
            p += len;
        }
        let c = h.signal_variance;
        let l2 = h.length_scale * h.length_scale;
        Some([
            0.5 * c * (diag + 2.0 * off_e),
            c * off_ed2 / l2,
            0.5 * h.noise_variance * diag,
        ])
    }
}

/// Minimises `−LML` through the evaluator, answering a `θ` evaluated before (bitwise the
/// same) from the evaluator's memo: the optimiser sees exactly the values it would have
/// computed, and a gradient at a memoised point refactorises first.
pub(super) struct NegativeLml<'e, 'a, const D: usize> {
    pub(super) eval: &'e mut LikelihoodEvaluator<'a, D>,
    /// The last value came from the memo at this `θ`: the factor in `eval` is not its.
    pub(super) stale: Option<[f64; 3]>,
}

impl<const D: usize> optimizer::Objective<3> for NegativeLml<'_, '_, D> {
    fn value(&mut self, x: &[f64; 3]) -> Option<f64> {
        if let Some(&(_, v)) = self.eval.memo.iter().find(|(t, _)| t == x) {
            self.stale = Some(*x);
            return v.map(|v| -v);
        }
        self.stale = None;
        let v = self.eval.value(x);
        self.eval.memo.push((*x, v));
        v.map(|v| -v)
    }
    fn gradient(&mut self) -> [f64; 3] {
        if let Some(x) = self.stale.take() {
            self.eval.value(&x);
        }
        self.eval
            .gradient()
            .map_or([f64::NAN; 3], |g| [-g[0], -g[1], -g[2]])
    }
}

/// Checks a training set: non-empty, one target per input, every number finite.
pub(super) fn validate_data<const D: usize>(inputs: &[[f64; D]], targets: &[f64]) -> Result<()> {
    if inputs.is_empty() {
        return Err(Error::EmptyData);
    }
    if targets.len() != inputs.len() {
        return Err(Error::InvalidParameter {
            parameter: "targets",
        });
    }
    if inputs.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            parameter: "inputs",
        });
    }
    if targets.iter().any(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            parameter: "targets",
        });
    }
    Ok(())
}
