//! A fixed-kernel GP whose training set only grows, kept conditioned at a fixed set of
//! query points: IWFQI's target GPs on the Dam and Acrobot, whose target records grow by
//! one batch a step while the source records they are predicted at never change.
//!
//! Refitting [`super::fixed::FixedGp`] every step costs `n³/3` for the factorisation and
//! `n²·q` for the predictive variances at `q` queries, again at every step (Acrobot: `n`
//! up to 9 640 target records, `q` = 8 400 source records, five GPs, twenty steps —
//! ≈ 4·10¹³ flops a run). Appending `Δ` points instead,
//!
//! - `L₂₁ = K₂₁L₁₁⁻ᵀ` and `L₂₂ = chol(K₂₂ + (σ²ₙ + jitter)I − L₂₁L₂₁ᵀ)` for the factor,
//! - `u₂ = L₂₂⁻¹(y₂ − L₂₁u₁)` for the whitened targets `u = L⁻¹y`,
//! - `V₂ = L₂₂⁻¹(K(X₂, Q) − L₂₁V₁)` for the rows of `V = L⁻¹K(X, Q)`,
//!
//! costs `n²Δ + nΔq`, and the posterior at query `j` is accumulated as rows arrive: mean
//! `Σᵢ Vᵢⱼuᵢ` (`= k*ᵀK⁻¹y`), predictive variance `Σ c + σ²ₙ − Σᵢ Vᵢⱼ²`. In exact
//! arithmetic this is the posterior of a refit on all points; in floating point it
//! differs by rounding (the factor's rows are computed in another order), so
//! \[CHOICE\] it is an option of the harness (`--fixed-gp incremental`, the default for
//! the fixed kernels; `refit` reconditions every step as the reference does).
//!
//! Splitting and jitter follow [`super::fixed::FixedGp`]: the same blocks when the
//! kernel decorrelates exactly along the split coordinate (checked again on every batch;
//! when a batch ends the separation, everything is reconditioned unsplit), and the same
//! jitter ladder `10⁻¹⁰, 10⁻⁸, 10⁻⁶, 10⁻⁴` (a batch that cannot be appended at the
//! current jitter reconditions all points at the next one).
//!
//! **Memory** ([`Storage`]). [`Storage::Stored`] keeps the square factor (`n²`) and `V`
//! (`n·q`) of every block in `f64` (Acrobot, `n` = 9 137, `q` = 8 400: 1.28 GB a GP).
//! [`Storage::Compact`] keeps only the factor's lower triangle, as one row panel
//! `[L₂₁ L₂₂]` per batch (`n²/2`: 0.33 GB), and recomputes the rows an append needs,
//! `L₂₁V₁ = (L₁₁⁻ᵀL₂₁ᵀ)ᵀK(X₁, Q)`, from kernel evaluations in column chunks: one more
//! triangular solve (`n²Δ`) and `n·q` kernel evaluations an append. The same posterior
//! in exact arithmetic; in floating point it differs by rounding.

use awfqi::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::prelude::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatRef, Par};

use super::JITTER;
use super::fixed::{FixedKernel, check_training, cholesky_lower, separable};

/// The largest jitter of the ladder (as [`super::fixed::FixedGp`]).
const MAX_JITTER: f64 = 1e-4;

/// What a [`GrowingFixedGp`] keeps between appends (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Storage {
    /// The square factor and `V = L⁻¹K(X, Q)`.
    #[default]
    Stored,
    /// The factor's lower triangle in row panels; `V`'s rows recomputed when needed.
    Compact,
}

/// The columns of `K(X₁, Q)` evaluated at a time by [`Storage::Compact`].
const QUERY_CHUNK: usize = 512;

/// The points sharing one value of the split coordinate (or all points), with the
/// posterior accumulated at the queries of that value (or all queries).
#[derive(Debug, Clone)]
struct Block<const Z: usize> {
    key: f64,
    inputs: Vec<[f64; Z]>,
    /// [`Storage::Stored`]: lower Cholesky factor of `K + (σ²ₙ + jitter) I` (zeros above
    /// the diagonal); empty for [`Storage::Compact`].
    factor: Mat<f64>,
    /// [`Storage::Compact`]: the same factor's rows, one panel `[L₂₁ L₂₂]` per batch
    /// (`Δ × (n + Δ)`, `n` the rows before it); empty for [`Storage::Stored`].
    rows: Vec<Mat<f64>>,
    /// `u = L⁻¹y`.
    whitened_targets: Vec<f64>,
    /// The queries this block predicts (indices into the GP's queries).
    queries: Vec<usize>,
    /// `V = L⁻¹K(X, Q)`, one row panel per appended batch ([`Storage::Stored`] only).
    panels: Vec<Mat<f64>>,
    /// `Σᵢ Vᵢⱼuᵢ` per query of the block.
    means: Vec<f64>,
    /// `Σᵢ Vᵢⱼ²` per query of the block.
    explained: Vec<f64>,
}

/// What appending a batch to a block produces, computed before anything is committed.
struct Growth {
    /// The new square factor ([`Storage::Stored`]) or the new row panel
    /// ([`Storage::Compact`]).
    factor: Mat<f64>,
    whitened_targets: Vec<f64>,
    panel: Mat<f64>,
}

/// A fixed-kernel GP conditioned on a growing training set, predicting at fixed queries
/// (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct GrowingFixedGp<const Z: usize> {
    kernel: FixedKernel,
    /// The coordinate asked to split on.
    requested_split: Option<usize>,
    /// The coordinate the blocks split on now.
    split: Option<usize>,
    queries: Vec<[f64; Z]>,
    inputs: Vec<[f64; Z]>,
    targets: Vec<f64>,
    blocks: Vec<Block<Z>>,
    jitter: f64,
    storage: Storage,
    par: Par,
}

impl<const Z: usize> GrowingFixedGp<Z> {
    /// A GP with `kernel` and no training points yet, to be predicted at `queries`;
    /// `split` as in [`super::fixed::FixedGp::fit`].
    ///
    /// Errors: an invalid kernel, non-finite queries.
    pub fn new(
        kernel: &FixedKernel,
        split: Option<usize>,
        queries: Vec<[f64; Z]>,
        par: Par,
    ) -> Result<Self> {
        kernel.validate()?;
        if queries.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                parameter: "queries",
            });
        }
        Ok(Self {
            kernel: kernel.clone(),
            requested_split: split.filter(|&c| c < Z),
            split: None,
            queries,
            inputs: Vec::new(),
            targets: Vec::new(),
            blocks: Vec::new(),
            jitter: JITTER,
            storage: Storage::default(),
            par,
        })
    }

    /// The same GP, keeping `storage` between appends; a GP that already holds points
    /// keeps the storage it has (its blocks are laid out for it).
    pub fn with_storage(mut self, storage: Storage) -> Self {
        if self.blocks.is_empty() {
            self.storage = storage;
        }
        self
    }

    /// What the GP keeps between appends.
    pub fn storage(&self) -> Storage {
        self.storage
    }

    /// Training points so far.
    pub fn len(&self) -> usize {
        self.inputs.len()
    }

    /// `true` before the first point.
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// The training inputs so far, in the order they were appended.
    pub fn inputs(&self) -> &[[f64; Z]] {
        &self.inputs
    }

    /// The query points.
    pub fn queries(&self) -> &[[f64; Z]] {
        &self.queries
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

    /// Conditions on `(inputs, targets)` as well as on every point so far.
    ///
    /// Errors (the GP unchanged): mismatched lengths, non-finite values, or a Gram
    /// matrix that is not positive definite even with jitter `10⁻⁴`.
    pub fn extend(&mut self, inputs: &[[f64; Z]], targets: &[f64]) -> Result<()> {
        check_training(inputs, targets)?;
        if inputs.is_empty() {
            return Ok(());
        }
        let mut all_inputs = self.inputs.clone();
        all_inputs.extend_from_slice(inputs);
        let split = self
            .requested_split
            .filter(|&c| separable(&all_inputs, &self.kernel, c));
        if self.blocks.is_empty() || split != self.split {
            let mut all_targets = self.targets.clone();
            all_targets.extend_from_slice(targets);
            return self.recondition(all_inputs, all_targets, split, JITTER);
        }
        match self.appended(inputs, targets, self.jitter) {
            Some(growths) => {
                self.commit(growths, inputs, targets);
                Ok(())
            }
            None => {
                let mut all_targets = self.targets.clone();
                all_targets.extend_from_slice(targets);
                let jitter = self.jitter * 100.0;
                self.recondition(all_inputs, all_targets, split, jitter)
            }
        }
    }

    /// Posterior means and predictive stds (including `σ²ₙ`) at the queries.
    ///
    /// Errors: no training points ([`Error::EmptyData`]); output lengths differ from the
    /// number of queries; a query whose split coordinate is correlated with more than its
    /// own block ([`Error::OutOfRange`] `queries`, as [`super::fixed::FixedGp::predict_into`]).
    pub fn posterior_into(&self, means: &mut [f64], stds: &mut [f64]) -> Result<()> {
        if self.blocks.is_empty() {
            return Err(Error::EmptyData);
        }
        if means.len() != self.queries.len() {
            return Err(Error::InvalidParameter { parameter: "means" });
        }
        if stds.len() != self.queries.len() {
            return Err(Error::InvalidParameter { parameter: "stds" });
        }
        if let Some(c) = self.split {
            for z in &self.queries {
                let correlated_elsewhere = self.blocks.iter().any(|b| {
                    b.key != z[c] && !self.kernel.uncorrelated_at(c, (b.key - z[c]).abs())
                });
                if correlated_elsewhere {
                    return Err(Error::OutOfRange {
                        parameter: "queries",
                    });
                }
            }
        }
        let prior = self.kernel.prior_variance();
        // Queries of a split value without training points keep the prior.
        means.fill(0.0);
        stds.fill(prior.sqrt());
        for block in &self.blocks {
            for (j, &q) in block.queries.iter().enumerate() {
                means[q] = block.means[j];
                stds[q] = (prior - block.explained[j]).max(0.0).sqrt();
            }
        }
        Ok(())
    }

    /// The growth of every block that `(inputs, targets)` reach at `jitter` (new split
    /// values start new blocks); `None` when one of them is not positive definite.
    fn appended(
        &self,
        inputs: &[[f64; Z]],
        targets: &[f64],
        jitter: f64,
    ) -> Option<Vec<(Option<usize>, f64, Growth)>> {
        let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
        for (i, x) in inputs.iter().enumerate() {
            let key = self.split.map_or(0.0, |c| x[c]);
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, members)) => members.push(i),
                None => groups.push((key, vec![i])),
            }
        }
        groups
            .into_iter()
            .map(|(key, members)| {
                let xs: Vec<[f64; Z]> = members.iter().map(|&i| inputs[i]).collect();
                let ys: Vec<f64> = members.iter().map(|&i| targets[i]).collect();
                let index = self.blocks.iter().position(|b| b.key == key);
                let own_queries;
                let queries = match index {
                    Some(b) => &self.blocks[b].queries,
                    None => {
                        own_queries = self.queries_of(key);
                        &own_queries
                    }
                };
                let grow = match self.storage {
                    Storage::Stored => grow,
                    Storage::Compact => grow_compact,
                };
                let growth = grow(
                    index.map(|b| &self.blocks[b]),
                    &xs,
                    &ys,
                    &self.kernel,
                    jitter,
                    &self.queries,
                    queries,
                    self.par,
                )?;
                Some((index, key, growth))
            })
            .collect()
    }

    /// The queries a block of split value `key` predicts (all of them without splitting).
    fn queries_of(&self, key: f64) -> Vec<usize> {
        match self.split {
            None => (0..self.queries.len()).collect(),
            Some(c) => (0..self.queries.len())
                .filter(|&q| self.queries[q][c] == key)
                .collect(),
        }
    }

    fn commit(
        &mut self,
        growths: Vec<(Option<usize>, f64, Growth)>,
        inputs: &[[f64; Z]],
        targets: &[f64],
    ) {
        for (index, key, growth) in growths {
            let b = match index {
                Some(b) => b,
                None => {
                    let queries = self.queries_of(key);
                    self.blocks.push(Block {
                        key,
                        inputs: Vec::new(),
                        factor: Mat::zeros(0, 0),
                        rows: Vec::new(),
                        whitened_targets: Vec::new(),
                        means: vec![0.0; queries.len()],
                        explained: vec![0.0; queries.len()],
                        queries,
                        panels: Vec::new(),
                    });
                    self.blocks.len() - 1
                }
            };
            let split = self.split;
            let block = &mut self.blocks[b];
            let panel = growth.panel.as_ref();
            for j in 0..panel.ncols() {
                let column = panel.col(j);
                let (mut mean, mut explained) = (0.0, 0.0);
                for (i, u) in growth.whitened_targets.iter().enumerate() {
                    let v = column[i];
                    mean += v * u;
                    explained += v * v;
                }
                block.means[j] += mean;
                block.explained[j] += explained;
            }
            block.whitened_targets.extend(growth.whitened_targets);
            match self.storage {
                Storage::Stored => {
                    block.factor = growth.factor;
                    block.panels.push(growth.panel);
                }
                Storage::Compact => block.rows.push(growth.factor),
            }
            let key_of = |x: &[f64; Z]| split.map_or(0.0, |c| x[c]);
            block
                .inputs
                .extend(inputs.iter().filter(|x| key_of(x) == key).copied());
        }
        self.inputs.extend_from_slice(inputs);
        self.targets.extend_from_slice(targets);
    }

    /// Conditions all points afresh, from `jitter` up the ladder; the GP is replaced only
    /// on success.
    fn recondition(
        &mut self,
        inputs: Vec<[f64; Z]>,
        targets: Vec<f64>,
        split: Option<usize>,
        mut jitter: f64,
    ) -> Result<()> {
        let mut fresh = Self {
            kernel: self.kernel.clone(),
            requested_split: self.requested_split,
            split,
            queries: Vec::new(),
            inputs: Vec::new(),
            targets: Vec::new(),
            blocks: Vec::new(),
            jitter,
            storage: self.storage,
            par: self.par,
        };
        // Borrowed, not cloned: the queries move back whatever happens.
        std::mem::swap(&mut fresh.queries, &mut self.queries);
        loop {
            fresh.jitter = jitter;
            if let Some(growths) = fresh.appended(&inputs, &targets, jitter) {
                fresh.commit(growths, &inputs, &targets);
                std::mem::swap(self, &mut fresh);
                return Ok(());
            }
            if jitter >= MAX_JITTER {
                std::mem::swap(&mut fresh.queries, &mut self.queries);
                return Err(Error::NotPositiveDefinite);
            }
            jitter *= 100.0;
        }
    }
}

/// Appends `(xs, ys)` to `old` (or starts a block) at `jitter`, predicting at `queries`
/// (indices into `all_queries`); `None` when the Schur complement is not positive definite
/// or the results are not finite.
#[allow(clippy::too_many_arguments)]
fn grow<const Z: usize>(
    old: Option<&Block<Z>>,
    xs: &[[f64; Z]],
    ys: &[f64],
    kernel: &FixedKernel,
    jitter: f64,
    all_queries: &[[f64; Z]],
    queries: &[usize],
    par: Par,
) -> Option<Growth> {
    let n = old.map_or(0, |b| b.inputs.len());
    let d = xs.len();
    let mut factor = Mat::<f64>::zeros(n + d, n + d);
    // L₂₁ᵀ = L₁₁⁻¹K₁₂.
    if let Some(old) = old {
        factor
            .submatrix_mut(0, 0, n, n)
            .copy_from(old.factor.as_ref());
        let mut cross = Mat::<f64>::from_fn(n, d, |i, j| kernel.covariance(&old.inputs[i], &xs[j]));
        solve_lower_triangular_in_place(old.factor.as_ref(), cross.as_mut(), par);
        factor
            .submatrix_mut(n, 0, d, n)
            .copy_from(cross.as_ref().transpose());
    }
    let schur = schur_factor(xs, kernel, jitter, factor.submatrix(n, 0, d, n), par)?;
    factor
        .submatrix_mut(n, n, d, d)
        .copy_from_triangular_lower(schur.as_ref());
    let l21 = factor.submatrix(n, 0, d, n);
    let l22 = factor.submatrix(n, n, d, d);
    let u2 = whiten_targets(old, ys, l21, l22, par);
    // V₂ = L₂₂⁻¹(K(X₂, Q) − L₂₁V₁), V₁ a stack of row panels.
    let mut panel = Mat::<f64>::from_fn(d, queries.len(), |i, j| {
        kernel.covariance(&xs[i], &all_queries[queries[j]])
    });
    if let Some(old) = old {
        let mut row = 0;
        for p in &old.panels {
            let rows = p.nrows();
            matmul(
                panel.as_mut(),
                Accum::Add,
                l21.submatrix(0, row, d, rows),
                p.as_ref(),
                -1.0,
                par,
            );
            row += rows;
        }
    }
    solve_lower_triangular_in_place(l22, panel.as_mut(), par);
    finished(factor, &u2, panel)
}

/// [`grow`] for [`Storage::Compact`]: the old factor as row panels, `L₂₁V₁` recomputed
/// as `(L₁₁⁻ᵀL₂₁ᵀ)ᵀK(X₁, Q)`; the growth's `factor` is the new row panel `[L₂₁ L₂₂]`.
#[allow(clippy::too_many_arguments)]
fn grow_compact<const Z: usize>(
    old: Option<&Block<Z>>,
    xs: &[[f64; Z]],
    ys: &[f64],
    kernel: &FixedKernel,
    jitter: f64,
    all_queries: &[[f64; Z]],
    queries: &[usize],
    par: Par,
) -> Option<Growth> {
    let n = old.map_or(0, |b| b.inputs.len());
    let d = xs.len();
    // L₂₁ᵀ = L₁₁⁻¹K₁₂.
    let mut l21t = Mat::<f64>::zeros(n, d);
    if let Some(old) = old {
        l21t = Mat::<f64>::from_fn(n, d, |i, j| kernel.covariance(&old.inputs[i], &xs[j]));
        forward_solve(&old.rows, l21t.as_mut(), par);
    }
    let schur = schur_factor(xs, kernel, jitter, l21t.transpose(), par)?;
    let mut row_panel = Mat::<f64>::zeros(d, n + d);
    row_panel
        .submatrix_mut(0, 0, d, n)
        .copy_from(l21t.transpose());
    row_panel
        .submatrix_mut(0, n, d, d)
        .copy_from_triangular_lower(schur.as_ref());
    let l22 = row_panel.submatrix(0, n, d, d);
    let u2 = whiten_targets(old, ys, l21t.transpose(), l22, par);
    // V₂ = L₂₂⁻¹(K(X₂, Q) − L₂₁V₁), with L₂₁V₁ = (L₁₁⁻ᵀL₂₁ᵀ)ᵀK(X₁, Q).
    let mut panel = Mat::<f64>::from_fn(d, queries.len(), |i, j| {
        kernel.covariance(&xs[i], &all_queries[queries[j]])
    });
    if let Some(old) = old {
        backward_solve(&old.rows, l21t.as_mut(), par);
        let weights = l21t;
        let scaled = Scaled::new(kernel, &old.inputs);
        let mut cross = Mat::<f64>::zeros(n, QUERY_CHUNK.min(queries.len()));
        let mut start = 0;
        for chunk in queries.chunks(QUERY_CHUNK) {
            cross.truncate(n, chunk.len());
            for (col, &q) in chunk.iter().enumerate() {
                scaled.covariances_into(&all_queries[q], cross.col_as_slice_mut(col));
            }
            matmul(
                panel.submatrix_mut(0, start, d, chunk.len()),
                Accum::Add,
                weights.transpose(),
                cross.as_ref(),
                -1.0,
                par,
            );
            start += chunk.len();
        }
    }
    solve_lower_triangular_in_place(l22, panel.as_mut(), par);
    finished(row_panel, &u2, panel)
}

/// `L₂₂ = chol(K₂₂ + (σ²ₙ + jitter) I − L₂₁L₂₁ᵀ)` for the appended inputs `xs`, `l21`
/// being `d × n` (`n = 0` on a first block); `None` when not positive definite.
fn schur_factor<const Z: usize>(
    xs: &[[f64; Z]],
    kernel: &FixedKernel,
    jitter: f64,
    l21: MatRef<'_, f64>,
    par: Par,
) -> Option<Mat<f64>> {
    let d = xs.len();
    let diagonal = kernel.covariance(&xs[0], &xs[0]) + kernel.noise_variance + jitter;
    let mut schur = Mat::<f64>::from_fn(d, d, |i, j| {
        if i == j {
            diagonal
        } else {
            kernel.covariance(&xs[i], &xs[j])
        }
    });
    if l21.ncols() > 0 {
        matmul(schur.as_mut(), Accum::Add, l21, l21.transpose(), -1.0, par);
    }
    cholesky_lower(schur.as_mut(), par)?;
    Some(schur)
}

/// `u₂ = L₂₂⁻¹(y₂ − L₂₁u₁)`, `u₁` the old block's whitened targets.
fn whiten_targets<const Z: usize>(
    old: Option<&Block<Z>>,
    ys: &[f64],
    l21: MatRef<'_, f64>,
    l22: MatRef<'_, f64>,
    par: Par,
) -> Mat<f64> {
    let mut u2 = Mat::<f64>::from_fn(l22.nrows(), 1, |i, _| ys[i]);
    if let Some(old) = old {
        let u1 = MatRef::from_column_major_slice(&old.whitened_targets, l21.ncols(), 1);
        matmul(u2.as_mut(), Accum::Add, l21, u1, -1.0, par);
    }
    solve_lower_triangular_in_place(l22, u2.as_mut(), par);
    u2
}

/// The growth, or `None` when a whitened target or a panel entry is not finite.
fn finished(factor: Mat<f64>, u2: &Mat<f64>, panel: Mat<f64>) -> Option<Growth> {
    let whitened_targets = u2.col_as_slice(0).to_vec();
    let finite = whitened_targets.iter().all(|v| v.is_finite())
        && (0..panel.ncols()).all(|j| panel.col_as_slice(j).iter().all(|v| v.is_finite()));
    finite.then_some(Growth {
        factor,
        whitened_targets,
        panel,
    })
}

/// Training inputs divided by each RBF term's length scales, so that a column of
/// `K(X₁, Q)` costs no division: `n·q` kernel evaluations an append
/// ([`Storage::Compact`]). Equal to [`FixedKernel::covariance`] to rounding.
struct Scaled<const Z: usize> {
    /// Per term: signal variance, `1/ℓ_d` (0 beyond the listed coordinates), and the
    /// scaled inputs.
    terms: Vec<(f64, [f64; Z], Vec<[f64; Z]>)>,
}

impl<const Z: usize> Scaled<Z> {
    fn new(kernel: &FixedKernel, inputs: &[[f64; Z]]) -> Self {
        let terms = kernel
            .terms
            .iter()
            .map(|t| {
                let mut inverse = [0.0; Z];
                for (v, l) in inverse.iter_mut().zip(&t.length_scales) {
                    *v = 1.0 / l;
                }
                let scaled = inputs
                    .iter()
                    .map(|x| core::array::from_fn(|d| x[d] * inverse[d]))
                    .collect();
                (t.signal_variance, inverse, scaled)
            })
            .collect();
        Self { terms }
    }

    /// `out[i] = k(xᵢ, z)` for every training input `xᵢ`.
    fn covariances_into(&self, z: &[f64; Z], out: &mut [f64]) {
        out.fill(0.0);
        for (c, inverse, scaled) in &self.terms {
            let zs: [f64; Z] = core::array::from_fn(|d| z[d] * inverse[d]);
            for (v, x) in out.iter_mut().zip(scaled) {
                let mut q = 0.0;
                for d in 0..Z {
                    let u = x[d] - zs[d];
                    q += u * u;
                }
                *v += c * (-0.5 * q).exp();
            }
        }
    }
}

/// `B ← L⁻¹B` for the lower factor `L` held as row panels (each `Δ × (r + Δ)`, `r` the
/// rows above it).
fn forward_solve(rows: &[Mat<f64>], mut b: faer::MatMut<'_, f64>, par: Par) {
    let mut r = 0;
    for p in rows {
        let d = p.nrows();
        let (done, rest) = b.rb_mut().split_at_row_mut(r);
        let mut this = rest.subrows_mut(0, d);
        if r > 0 {
            matmul(
                this.rb_mut(),
                Accum::Add,
                p.submatrix(0, 0, d, r),
                done.rb(),
                -1.0,
                par,
            );
        }
        solve_lower_triangular_in_place(p.submatrix(0, r, d, d), this, par);
        r += d;
    }
}

/// `B ← L⁻ᵀB` for the lower factor `L` held as row panels (as [`forward_solve`]).
fn backward_solve(rows: &[Mat<f64>], mut b: faer::MatMut<'_, f64>, par: Par) {
    let mut end = b.nrows();
    for p in rows.iter().rev() {
        let d = p.nrows();
        let r = end - d;
        let (mut above, rest) = b.rb_mut().split_at_row_mut(r);
        let mut this = rest.subrows_mut(0, d);
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            p.submatrix(0, r, d, d).transpose(),
            this.rb_mut(),
            par,
        );
        if r > 0 {
            matmul(
                above.rb_mut(),
                Accum::Add,
                p.submatrix(0, 0, d, r).transpose(),
                this.rb(),
                -1.0,
                par,
            );
        }
        end = r;
    }
}

#[cfg(test)]
mod tests;
