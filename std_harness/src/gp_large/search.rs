//! The hyperparameter search of a fit: the optimisations of every start as the strategy
//! says, and the choice of the best.

use super::likelihood::NegativeLml;
use super::*;
use awfqi::Result;

/// The index of the first of the highest likelihood among the finished optimisations.
pub(super) fn best_run(runs: &[OptimizationRun]) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (i, run) in runs.iter().enumerate() {
        if run.merged_into.is_none()
            && run.log_marginal_likelihood.is_finite()
            && best.is_none_or(|b| run.log_marginal_likelihood > runs[b].log_marginal_likelihood)
        {
            best = Some(i);
        }
    }
    best
}

/// Optimises `starts` on `eval`'s data as `strategy` says (the first start is the initial
/// values, the others the restarts).
pub(super) fn search<const D: usize>(
    strategy: FitStrategy,
    (inputs, targets): (&[[f64; D]], &[f64]),
    eval: &mut LikelihoodEvaluator<'_, D>,
    starts: &[[f64; 3]],
    options: &FitOptions,
) -> Result<Vec<OptimizationRun>> {
    let (lower, upper) = options.bounds.log_bounds();
    let optimize_warm = |eval: &mut LikelihoodEvaluator<'_, D>,
                         start: &[f64; 3],
                         inverse_hessian: Option<&[[f64; 3]; 3]>| {
        let factorizations = eval.factorizations;
        let m = optimizer::minimize_warm(
            &mut NegativeLml { eval, stale: None },
            start,
            &lower,
            &upper,
            &options.optimizer,
            inverse_hessian,
        );
        OptimizationRun {
            start: *start,
            theta: m.x,
            log_marginal_likelihood: -m.f,
            evaluations: m.evaluations,
            factorizations: eval.factorizations - factorizations,
            gradients: m.gradients,
            stop: m.stop,
            screening: None,
            staging: None,
            merged_into: None,
            inverse_hessian: m.inverse_hessian,
        }
    };
    let optimize =
        |eval: &mut LikelihoodEvaluator<'_, D>, start: &[f64; 3]| optimize_warm(eval, start, None);
    // The screened and staged searches: `(subsample, merge radius, intermediate stage)`,
    // the stage being its size and whether it carries the curvature model (a staged
    // search with no more points than its stage is the screened one).
    let screening = match strategy {
        FitStrategy::Screened {
            subsample,
            merge_radius,
        } => Some((subsample.max(1), merge_radius, None)),
        FitStrategy::Staged {
            subsample,
            intermediate,
            merge_radius,
            warm_hessian,
        } => {
            let stage = (inputs.len() > intermediate && intermediate > subsample.max(1))
                .then_some((intermediate, warm_hessian));
            Some((subsample.max(1), merge_radius, stage))
        }
        FitStrategy::AllStarts => None,
    };
    let mut runs: Vec<OptimizationRun> = Vec::with_capacity(starts.len());
    match screening {
        Some((subsample, merge_radius, stage)) if inputs.len() > subsample => {
            let jitter = options.conditioning.jitter;
            let (a_inputs, a_targets) = evenly_spaced(inputs, targets, subsample);
            let mut a_eval = LikelihoodEvaluator::new(&a_inputs, &a_targets, options.parallelism)?
                .with_jitter(jitter);
            let (b_inputs, b_targets) = match stage {
                Some((intermediate, _)) => evenly_spaced(inputs, targets, intermediate),
                None => (Vec::new(), Vec::new()),
            };
            let mut b_eval = match stage {
                Some(_) => Some(
                    LikelihoodEvaluator::new(&b_inputs, &b_targets, options.parallelism)?
                        .with_jitter(jitter),
                ),
                None => None,
            };
            let close = |a: &[f64; 3], b: &[f64; 3]| {
                a.iter().zip(b).all(|(x, y)| (x - y).abs() <= merge_radius)
            };
            for start in starts {
                let screened = optimize(&mut a_eval, start);
                let end = screened.theta;
                let shared = runs.iter().position(|r| {
                    r.merged_into.is_none() && r.screening.is_some_and(|(e, _)| close(&e, &end))
                });
                let mut run = match (shared, stage, b_eval.as_mut()) {
                    (Some(j), _, _) => OptimizationRun {
                        merged_into: Some(j),
                        staging: None,
                        ..runs[j]
                    },
                    (None, Some((_, warm)), Some(b_eval)) => {
                        let h = carried_model(&screened, a_inputs.len(), b_inputs.len());
                        let staged = optimize_warm(b_eval, &end, warm.then_some(&h));
                        let mid = staged.theta;
                        let shared = runs.iter().position(|r| {
                            r.merged_into.is_none()
                                && r.staging.is_some_and(|(m, _)| close(&m, &mid))
                        });
                        let mut run = match shared {
                            Some(j) => OptimizationRun {
                                merged_into: Some(j),
                                ..runs[j]
                            },
                            None => {
                                let h = carried_model(&staged, b_inputs.len(), inputs.len());
                                optimize_warm(eval, &mid, warm.then_some(&h))
                            }
                        };
                        run.staging = Some((mid, staged.evaluations));
                        run
                    }
                    _ => optimize(eval, &end),
                };
                run.start = *start;
                run.screening = Some((end, screened.evaluations));
                runs.push(run);
            }
        }
        _ => {
            for start in starts {
                let run = optimize(eval, start);
                runs.push(run);
            }
        }
    }
    Ok(runs)
}

/// The inverse-Hessian model an optimisation on `from` points hands to the next stage on
/// `to` points: the negative log likelihood grows about linearly with the data, and its
/// curvature with it, so the inverse shrinks by `from / to`.
fn carried_model(run: &OptimizationRun, from: usize, to: usize) -> [[f64; 3]; 3] {
    let ratio = from as f64 / to as f64;
    run.inverse_hessian.map(|row| row.map(|v| v * ratio))
}

/// `m` of the points (`m < inputs.len()`), evenly spaced in the data's order: indices
/// `⌊i·n/m⌋`.
fn evenly_spaced<const D: usize>(
    inputs: &[[f64; D]],
    targets: &[f64],
    m: usize,
) -> (Vec<[f64; D]>, Vec<f64>) {
    let n = inputs.len();
    (0..m)
        .map(|i| (inputs[i * n / m], targets[i * n / m]))
        .unzip()
}
