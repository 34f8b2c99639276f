//! The conditioned GP ([`LargeGp`]): construction, fit, and prediction.

use super::conditioning::{check_condition, diagonal_condition};
use super::kernel::squared_distance;
use super::likelihood::validate_data;
use super::search::{best_run, search};
use super::*;
use awfqi::{Error, Result};
use faer::{Mat, Par};
use rand_core::Rng;

/// A prediction: mean and standard deviation (the std includes the noise).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpPrediction {
    /// Posterior mean `k*ᵀK⁻¹y`.
    pub mean: f64,
    /// `√max(c + σ²ₙ − k*ᵀK⁻¹k*, 0)`.
    pub std: f64,
}

/// A Gaussian process conditioned on its training data (see the [module docs](super)).
///
/// Memory: the `n × n` Cholesky factor (`8n²` bytes), the inputs and `K⁻¹y`.
#[derive(Debug, Clone)]
pub struct LargeGp<const D: usize> {
    pub(super) inputs: Vec<[f64; D]>,
    pub(super) hyper: GpHyperparameters,
    /// Lower Cholesky factor `L` of `K + (σ²ₙ + jitter) I` (lower triangle).
    pub(super) factor: Mat<f64>,
    /// `K⁻¹y`.
    pub(super) alpha: Vec<f64>,
    pub(super) lml: f64,
    pub(super) par: Par,
    pub(super) jitter: f64,
}

impl<const D: usize> LargeGp<D> {
    /// Conditions a GP with fixed hyperparameters on `(inputs, targets)` (all of them, no
    /// `max_points` cap).
    ///
    /// Errors: empty data ([`Error::EmptyData`]), mismatched lengths, non-finite values,
    /// invalid hyperparameters, a Gram matrix that is not positive definite
    /// ([`Error::NotPositiveDefinite`]).
    pub fn new(
        inputs: &[[f64; D]],
        targets: &[f64],
        hyper: GpHyperparameters,
        par: Par,
    ) -> Result<Self> {
        Self::new_with(inputs, targets, hyper, par, &LargeConditioning::default())
    }

    /// [`LargeGp::new`] under a conditioning policy.
    ///
    /// Errors: those of [`LargeGp::new`], an invalid policy ([`Error::InvalidParameter`]),
    /// a factor beyond the policy's condition limit ([`Error::IllConditioned`]).
    pub fn new_with(
        inputs: &[[f64; D]],
        targets: &[f64],
        hyper: GpHyperparameters,
        par: Par,
        conditioning: &LargeConditioning,
    ) -> Result<Self> {
        hyper.validate()?;
        conditioning.validate()?;
        let mut eval =
            LikelihoodEvaluator::new(inputs, targets, par)?.with_jitter(conditioning.jitter);
        let lml = eval
            .value(&hyper.to_log())
            .ok_or(Error::NotPositiveDefinite)?;
        check_condition(&eval.chol, conditioning)?;
        eval.finish_alpha();
        Ok(Self {
            inputs: inputs.to_vec(),
            hyper,
            alpha: eval.alpha.col_as_slice(0).to_vec(),
            factor: eval.chol,
            lml,
            par,
            jitter: conditioning.jitter,
        })
    }

    /// The jitter on the training diagonal of this fit.
    pub fn jitter(&self) -> f64 {
        self.jitter
    }

    /// The diagonal condition estimate `(max Lᵢᵢ / min Lᵢᵢ)²` of the factor (see
    /// [`LargeConditioning`]).
    pub fn condition_estimate(&self) -> f64 {
        diagonal_condition(&self.factor)
    }

    /// Fits the hyperparameters by maximising the log marginal likelihood on the last
    /// `options.max_points` samples (spec §4.2), then conditions on those samples.
    ///
    /// Draws `3 · options.restarts` uniforms from `rng` (restart starts, in order).
    ///
    /// Errors: as [`LargeGp::new`], plus invalid options (`max_points == 0`, bad bounds or
    /// initial values), and [`Error::NotPositiveDefinite`] when no start could be evaluated.
    pub fn fit<R: Rng + ?Sized>(
        inputs: &[[f64; D]],
        targets: &[f64],
        options: &FitOptions,
        rng: &mut R,
    ) -> Result<(Self, FitReport)> {
        validate_data(inputs, targets)?;
        options.initial.validate()?;
        options.bounds.validate()?;
        options.conditioning.validate()?;
        if options.max_points == 0 {
            return Err(Error::InvalidParameter {
                parameter: "max_points",
            });
        }
        let skip = inputs.len().saturating_sub(options.max_points);
        let (inputs, targets) = (&inputs[skip..], &targets[skip..]);
        let (lower, upper) = options.bounds.log_bounds();
        let mut starts = vec![options.initial.to_log()];
        for _ in 0..options.restarts {
            starts.push(std::array::from_fn(|i| {
                lower[i] + awfqi::rng::uniform_f64(rng) * (upper[i] - lower[i])
            }));
        }
        // The comparison search first, on its own evaluator, dropped before the kept search
        // allocates its buffers (both are `3n²` f64).
        let comparison = match options.compare {
            Some(other) => {
                let clock = std::time::Instant::now();
                let mut other_eval =
                    LikelihoodEvaluator::new(inputs, targets, options.parallelism)?
                        .with_jitter(options.conditioning.jitter);
                let runs = search(other, (inputs, targets), &mut other_eval, &starts, options)?;
                let lml =
                    best_run(&runs).map_or(f64::NEG_INFINITY, |b| runs[b].log_marginal_likelihood);
                Some((
                    lml,
                    other_eval.factorizations,
                    clock.elapsed().as_secs_f64(),
                ))
            }
            None => None,
        };
        let clock = std::time::Instant::now();
        let mut eval = LikelihoodEvaluator::new(inputs, targets, options.parallelism)?
            .with_jitter(options.conditioning.jitter);
        let runs = search(
            options.strategy,
            (inputs, targets),
            &mut eval,
            &starts,
            options,
        )?;
        let best = best_run(&runs);
        let best = best.ok_or(Error::NotPositiveDefinite)?;
        let theta = runs[best].theta;
        let factorizations = eval.factorizations;
        let seconds = clock.elapsed().as_secs_f64();
        let lml = eval.value(&theta).ok_or(Error::NotPositiveDefinite)?;
        check_condition(&eval.chol, &options.conditioning)?;
        eval.finish_alpha();
        let comparison =
            comparison.map(
                |(other_lml, other_factorizations, other_seconds)| SearchComparison {
                    log_marginal_likelihood: runs[best].log_marginal_likelihood,
                    other_log_marginal_likelihood: other_lml,
                    factorizations,
                    other_factorizations,
                    seconds,
                    other_seconds,
                },
            );
        let gp = Self {
            inputs: inputs.to_vec(),
            hyper: GpHyperparameters::from_log(&theta),
            alpha: eval.alpha.col_as_slice(0).to_vec(),
            factor: eval.chol,
            lml,
            par: options.parallelism,
            jitter: options.conditioning.jitter,
        };
        Ok((
            gp,
            FitReport {
                runs,
                best,
                comparison,
            },
        ))
    }

    /// Number of training points.
    pub fn len(&self) -> usize {
        self.inputs.len()
    }

    /// `false`: a GP always has training points.
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// The hyperparameters in use.
    pub fn hyperparameters(&self) -> GpHyperparameters {
        self.hyper
    }

    /// The training inputs (after the `max_points` cap).
    pub fn inputs(&self) -> &[[f64; D]] {
        &self.inputs
    }

    /// The log marginal likelihood of the training data.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.lml
    }

    /// Prediction at one input (mean and std including the noise).
    pub fn predict(&self, z: &[f64; D]) -> GpPrediction {
        let mut means = [0.0];
        let mut stds = [0.0];
        self.predict_into(std::slice::from_ref(z), &mut means, &mut stds)
            .expect("lengths match");
        GpPrediction {
            mean: means[0],
            std: stds[0],
        }
    }

    /// Predictions at many inputs into `means` and `stds` (blocked: one triangular solve
    /// per block of 256 inputs).
    ///
    /// Errors: output lengths differ from `zs.len()` ([`Error::InvalidParameter`]).
    pub fn predict_into(&self, zs: &[[f64; D]], means: &mut [f64], stds: &mut [f64]) -> Result<()> {
        if means.len() != zs.len() {
            return Err(Error::InvalidParameter { parameter: "means" });
        }
        if stds.len() != zs.len() {
            return Err(Error::InvalidParameter { parameter: "stds" });
        }
        const BLOCK: usize = 256;
        let n = self.inputs.len();
        let c = self.hyper.signal_variance;
        let k = -0.5 / (self.hyper.length_scale * self.hyper.length_scale);
        let prior = c + self.hyper.noise_variance;
        let mut cross = Mat::<f64>::zeros(n, BLOCK.min(zs.len()));
        for ((block, mb), sb) in zs
            .chunks(BLOCK)
            .zip(means.chunks_mut(BLOCK))
            .zip(stds.chunks_mut(BLOCK))
        {
            let m = block.len();
            cross.truncate(n, m);
            for (q, z) in block.iter().enumerate() {
                let col = cross.col_as_slice_mut(q);
                for (v, x) in col.iter_mut().zip(&self.inputs) {
                    *v = c * (k * squared_distance(x, z)).exp();
                }
                mb[q] = col.iter().zip(&self.alpha).map(|(a, b)| a * b).sum();
            }
            faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                self.factor.as_ref(),
                cross.as_mut(),
                self.par,
            );
            for (q, s) in sb.iter_mut().enumerate() {
                let v: f64 = cross.col_as_slice(q).iter().map(|x| x * x).sum();
                *s = (prior - v).max(0.0).sqrt();
            }
        }
        Ok(())
    }
}
