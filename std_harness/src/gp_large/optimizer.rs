//! Box-constrained quasi-Newton minimisation for a handful of parameters: a projected BFGS
//! method ("L-BFGS-B-lite").
//!
//! Spec §4.2 fits the GP hyperparameters with "a box-constrained quasi-Newton method (the
//! reference uses L-BFGS-B) … with the analytic gradient". argmin 0.11 has L-BFGS without
//! bounds only (an L-BFGS-B solver was proposed upstream but is not released), and the
//! problem has 3 parameters, so a dense projected BFGS is simpler than a limited-memory
//! method and converges the same way:
//!
//! 1. Variables at a bound whose gradient pushes outwards are held fixed (the binding set).
//! 2. The step on the free variables is `d = −H g` with the dense BFGS inverse-Hessian
//!    approximation `H` (reset to the identity when `d` is not a descent direction).
//! 3. A backtracking line search along the projected path `P(x + α d)` accepts the first
//!    `α` with the Armijo decrease `f(x⁺) ≤ f(x) + 10⁻⁴ gᵀ(x⁺ − x)`; the first iteration
//!    starts from `α = min(1, 1/‖d‖)` as L-BFGS-B does, later ones from 1.
//! 4. `H` is updated with `s = x⁺ − x`, `y = g⁺ − g` restricted to the free variables when
//!    `sᵀy > 0` (scaled by `sᵀy/yᵀy` before the first update), and reset to the identity
//!    whenever the binding set changes. Without the reset a variable that reaches its bound
//!    leaves a curvature model scaled for it, and the free variables crawl (thousands of
//!    tiny steps were observed on the GP likelihood when `σ²ₙ` hit its upper bound).
//!
//! It stops with scipy's L-BFGS-B defaults: projected-gradient infinity norm `≤ 10⁻⁵`
//! (`gtol`) or relative decrease `(f_k − f_{k+1}) / max(|f_k|, |f_{k+1}|, 1) ≤ 2.22·10⁻⁹`
//! (`ftol`, i.e. `factr = 10⁷`), or after `max_iterations` / `max_evaluations`.
//!
//! The objective is split in two calls, [`Objective::value`] and [`Objective::gradient`]
//! (at the point of the last value), so a rejected line-search trial costs a value only: for
//! the GP a value is one Cholesky factorisation (`n³/3`), a gradient another `2n³/3`.

/// A function to minimise, evaluated in two stages.
pub trait Objective<const K: usize> {
    /// `f(x)`, or `None` when it cannot be evaluated there (treated as `+∞`).
    fn value(&mut self, x: &[f64; K]) -> Option<f64>;
    /// `∇f` at the point of the last successful [`Objective::value`] call.
    fn gradient(&mut self) -> [f64; K];
}

/// Stopping rules of [`minimize`] (defaults: scipy's L-BFGS-B).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Stop when the projected gradient's infinity norm is at most this (`gtol`, `10⁻⁵`).
    pub gradient_tolerance: f64,
    /// Stop when the relative decrease of `f` is at most this (`ftol`, `2.22·10⁻⁹`).
    pub relative_decrease_tolerance: f64,
    /// Most iterations (15 000).
    pub max_iterations: usize,
    /// Most value evaluations (15 000).
    pub max_evaluations: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            gradient_tolerance: 1e-5,
            relative_decrease_tolerance: 1e7 * f64::EPSILON,
            max_iterations: 15_000,
            max_evaluations: 15_000,
        }
    }
}

/// Why [`minimize`] stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// The projected gradient is below its tolerance.
    Gradient,
    /// The relative decrease of `f` is below its tolerance.
    Decrease,
    /// The line search found no decrease (the point is optimal to working precision, or the
    /// gradient is inaccurate).
    LineSearch,
    /// The iteration or evaluation budget is spent.
    Budget,
    /// `f` cannot be evaluated at the (projected) starting point.
    StartFailed,
}

/// The result of [`minimize`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Minimum<const K: usize> {
    /// The best point found (inside the box).
    pub x: [f64; K],
    /// `f(x)` (`+∞` when the start failed).
    pub f: f64,
    /// Value evaluations spent.
    pub evaluations: usize,
    /// Gradient evaluations spent.
    pub gradients: usize,
    /// Iterations taken.
    pub iterations: usize,
    /// Why it stopped.
    pub stop: Stop,
    /// The inverse-Hessian model at the end (the identity when no curvature pair was
    /// accepted since the last reset), to warm-start a related problem
    /// ([`minimize_warm`]).
    pub inverse_hessian: [[f64; K]; K],
}

fn dot<const K: usize>(a: &[f64; K], b: &[f64; K]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn project<const K: usize>(x: &[f64; K], lower: &[f64; K], upper: &[f64; K]) -> [f64; K] {
    let mut p = *x;
    for ((v, &l), &u) in p.iter_mut().zip(lower).zip(upper) {
        *v = v.max(l).min(u);
    }
    p
}

/// The variables not held at a bound: those the gradient does not push outwards there.
fn free_variables<const K: usize>(
    x: &[f64; K],
    g: &[f64; K],
    lower: &[f64; K],
    upper: &[f64; K],
) -> [bool; K] {
    std::array::from_fn(|i| !((x[i] <= lower[i] && g[i] > 0.0) || (x[i] >= upper[i] && g[i] < 0.0)))
}

/// Minimises `objective` over the box `lower ≤ x ≤ upper` from `start` (projected into the
/// box first). See the [module docs](self) for the method.
///
/// `lower[i] ≤ upper[i]` must hold; a fixed coordinate (`lower[i] == upper[i]`) stays there.
pub fn minimize<const K: usize, F: Objective<K>>(
    objective: &mut F,
    start: &[f64; K],
    lower: &[f64; K],
    upper: &[f64; K],
    options: &Options,
) -> Minimum<K> {
    minimize_warm(objective, start, lower, upper, options, None)
}

/// [`minimize`] with the first iterations' curvature model given: `inverse_hessian` (e.g.
/// the [`Minimum::inverse_hessian`] of the same function on less data, rescaled) replaces
/// the scaled identity, so the first step is a quasi-Newton step instead of a unit-length
/// gradient step. `None` is [`minimize`]. The model is dropped, as any, when the binding
/// set changes or when it gives no descent direction.
pub fn minimize_warm<const K: usize, F: Objective<K>>(
    objective: &mut F,
    start: &[f64; K],
    lower: &[f64; K],
    upper: &[f64; K],
    options: &Options,
    inverse_hessian: Option<&[[f64; K]; K]>,
) -> Minimum<K> {
    let mut x = project(start, lower, upper);
    let mut result = Minimum {
        x,
        f: f64::INFINITY,
        evaluations: 1,
        gradients: 0,
        iterations: 0,
        stop: Stop::StartFailed,
        inverse_hessian: [[0.0; K]; K],
    };
    let Some(mut fx) = objective.value(&x) else {
        return result;
    };
    let mut g = objective.gradient();
    result.gradients = 1;
    result.f = fx;
    let identity = {
        let mut h = [[0.0; K]; K];
        for (i, row) in h.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        h
    };
    let scaled = |gamma: f64| identity.map(|row| row.map(|v| v * gamma));
    // The inverse-Hessian model, and whether it still is an unscaled identity (no curvature
    // information at all).
    let mut h = inverse_hessian.copied().unwrap_or(identity);
    let mut blind = inverse_hessian.is_none();
    // The binding set at the start is taken as the one the given model was built for.
    let mut previous_free = match inverse_hessian {
        Some(_) => free_variables(&x, &g, lower, upper),
        None => [true; K],
    };
    loop {
        // Projected gradient P(x − g) − x and the free variables.
        let mut pg_norm = 0.0f64;
        for i in 0..K {
            let pg = (x[i] - g[i]).max(lower[i]).min(upper[i]) - x[i];
            pg_norm = pg_norm.max(pg.abs());
        }
        let free = free_variables(&x, &g, lower, upper);
        if pg_norm <= options.gradient_tolerance {
            result.stop = Stop::Gradient;
            break;
        }
        if result.iterations >= options.max_iterations
            || result.evaluations >= options.max_evaluations
        {
            result.stop = Stop::Budget;
            break;
        }
        result.iterations += 1;
        // A new binding set starts a new curvature model from scratch: the old one mixes in
        // coordinates that no longer move, or misses ones that now do, and even its scale can
        // be off by orders of magnitude (it is set by the stiffest coordinate).
        let reset = |h: &mut [[f64; K]; K], blind: &mut bool| {
            *h = identity;
            *blind = true;
        };
        if free != previous_free {
            reset(&mut h, &mut blind);
            previous_free = free;
        }
        let direction = |h: &[[f64; K]; K]| {
            let mut d = [0.0; K];
            for i in (0..K).filter(|&i| free[i]) {
                d[i] = -(0..K)
                    .filter(|&j| free[j])
                    .map(|j| h[i][j] * g[j])
                    .sum::<f64>();
            }
            d
        };
        let mut d = direction(&h);
        let descent = dot(&g, &d);
        if descent >= 0.0 || descent.is_nan() {
            reset(&mut h, &mut blind);
            d = direction(&h);
        }
        let slope = dot(&g, &d);
        // Without curvature information the first trial moves a unit distance at most.
        let mut alpha = if blind {
            (1.0 / dot(&d, &d).sqrt()).min(1.0)
        } else {
            1.0
        };
        let point = |alpha: f64| {
            let mut t = x;
            for i in 0..K {
                t[i] += alpha * d[i];
            }
            project(&t, lower, upper)
        };
        // Backtracking along the projected path, with safeguarded quadratic interpolation.
        let mut accepted = None;
        let mut first_trial = true;
        for _ in 0..40 {
            if result.evaluations >= options.max_evaluations {
                break;
            }
            let trial = point(alpha);
            if trial == x {
                break;
            }
            let step: [f64; K] = std::array::from_fn(|i| trial[i] - x[i]);
            result.evaluations += 1;
            let f_trial = objective.value(&trial);
            if let Some(f_trial) = f_trial
                && f_trial <= fx + 1e-4 * dot(&g, &step)
            {
                accepted = Some((trial, f_trial, first_trial));
                break;
            }
            first_trial = false;
            alpha = match f_trial {
                Some(f_trial) if f_trial.is_finite() => {
                    let q = -slope * alpha * alpha / (2.0 * (f_trial - fx - slope * alpha));
                    q.clamp(0.1 * alpha, 0.5 * alpha)
                }
                _ => 0.1 * alpha,
            };
        }
        let Some((mut x_new, mut f_new, first_trial)) = accepted else {
            result.stop = Stop::LineSearch;
            break;
        };
        let mut g_new = objective.gradient();
        result.gradients += 1;
        // The full step was accepted but the path is still steep (the curvature condition
        // gᵀ(new)·d ≥ 0.9·gᵀd fails): extrapolate while the value keeps falling, as a Wolfe
        // line search would. This crosses the likelihood's flat regions in few iterations.
        if first_trial {
            for _ in 0..6 {
                let steep = dot(&g_new, &d);
                if steep >= 0.9 * slope
                    || steep.is_nan()
                    || result.evaluations >= options.max_evaluations
                {
                    break;
                }
                alpha *= 4.0;
                let trial = point(alpha);
                if trial == x_new {
                    break;
                }
                result.evaluations += 1;
                match objective.value(&trial) {
                    Some(f_trial) if f_trial < f_new => {
                        x_new = trial;
                        f_new = f_trial;
                        g_new = objective.gradient();
                        result.gradients += 1;
                    }
                    // No further decrease: keep the accepted point and its gradient (the
                    // objective's state is not needed again before the next value).
                    _ => break,
                }
            }
        }
        // Curvature pairs on the free coordinates only (bound ones have s = 0; their
        // gradient change says nothing about the free subspace).
        let s: [f64; K] = std::array::from_fn(|i| x_new[i] - x[i]);
        let y: [f64; K] = std::array::from_fn(|i| if free[i] { g_new[i] - g[i] } else { 0.0 });
        let decrease = (fx - f_new) / fx.abs().max(f_new.abs()).max(1.0);
        x = x_new;
        fx = f_new;
        g = g_new;
        result.x = x;
        result.f = fx;
        if decrease <= options.relative_decrease_tolerance {
            result.stop = Stop::Decrease;
            break;
        }
        let sy = dot(&s, &y);
        if sy > 1e-10 * dot(&s, &s).sqrt() * dot(&y, &y).sqrt() {
            let scale = sy / dot(&y, &y);
            if blind {
                h = scaled(scale);
                blind = false;
            }
            // H ← (I − ρ s yᵀ) H (I − ρ y sᵀ) + ρ s sᵀ.
            let rho = 1.0 / sy;
            let hy: [f64; K] = std::array::from_fn(|i| dot(&h[i], &y));
            let yhy = dot(&y, &hy);
            for i in 0..K {
                for j in 0..K {
                    h[i][j] += -rho * (s[i] * hy[j] + hy[i] * s[j])
                        + (rho * rho * yhy + rho) * s[i] * s[j];
                }
            }
        }
    }
    result.x = x;
    result.f = fx;
    result.inverse_hessian = h;
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closure objective with an analytic gradient, counting calls.
    struct Fun<F: FnMut(&[f64; 2]) -> (f64, [f64; 2])> {
        f: F,
        last: [f64; 2],
    }

    impl<F: FnMut(&[f64; 2]) -> (f64, [f64; 2])> Objective<2> for Fun<F> {
        fn value(&mut self, x: &[f64; 2]) -> Option<f64> {
            let (v, g) = (self.f)(x);
            self.last = g;
            Some(v)
        }
        fn gradient(&mut self) -> [f64; 2] {
            self.last
        }
    }

    fn rosenbrock(x: &[f64; 2]) -> (f64, [f64; 2]) {
        let (a, b) = (x[0], x[1]);
        (
            (1.0 - a).powi(2) + 100.0 * (b - a * a).powi(2),
            [
                -2.0 * (1.0 - a) - 400.0 * a * (b - a * a),
                200.0 * (b - a * a),
            ],
        )
    }

    #[test]
    fn a_warm_curvature_model_reaches_the_same_minimum_in_fewer_evaluations() {
        // An ill-scaled quadratic: the identity's first steps are poor, its inverse
        // Hessian is exact.
        let quadratic = |x: &[f64; 2]| {
            let (a, b) = (x[0] - 3.0, x[1] + 1.0);
            (
                50.0 * a * a + 0.5 * b * b + 0.5 * a * b,
                [100.0 * a + 0.5 * b, b + 0.5 * a],
            )
        };
        let (lower, upper) = ([-10.0; 2], [10.0; 2]);
        let options = Options::default();
        let mut cold = Fun {
            f: quadratic,
            last: [0.0; 2],
        };
        let a = minimize(&mut cold, &[0.0, 0.0], &lower, &upper, &options);
        // The exact inverse of [[100, 0.5], [0.5, 1]].
        let det = 100.0 - 0.25;
        let inverse = [[1.0 / det, -0.5 / det], [-0.5 / det, 100.0 / det]];
        let mut warm = Fun {
            f: quadratic,
            last: [0.0; 2],
        };
        let b = minimize_warm(
            &mut warm,
            &[0.0, 0.0],
            &lower,
            &upper,
            &options,
            Some(&inverse),
        );
        for m in [&a, &b] {
            assert!(
                (m.x[0] - 3.0).abs() < 1e-6 && (m.x[1] + 1.0).abs() < 1e-5,
                "{m:?}"
            );
        }
        assert!(
            b.evaluations < a.evaluations,
            "{} vs {}",
            b.evaluations,
            a.evaluations
        );
        assert!(b.evaluations <= 3, "{b:?}");
        // `None` is the cold start, to the bit.
        let mut again = Fun {
            f: quadratic,
            last: [0.0; 2],
        };
        let c = minimize_warm(&mut again, &[0.0, 0.0], &lower, &upper, &options, None);
        assert_eq!(c, a);
    }

    #[test]
    fn unconstrained_rosenbrock_reaches_its_minimum() {
        let mut obj = Fun {
            f: rosenbrock,
            last: [0.0; 2],
        };
        let m = minimize(
            &mut obj,
            &[-1.2, 1.0],
            &[-5.0, -5.0],
            &[5.0, 5.0],
            &Options::default(),
        );
        assert!(
            (m.x[0] - 1.0).abs() < 1e-3 && (m.x[1] - 1.0).abs() < 1e-3,
            "{m:?}"
        );
        assert!(m.f < 1e-6);
    }

    #[test]
    fn active_bound_is_found() {
        // Rosenbrock restricted to x₀ ≤ 0.5: the minimum is on the bound, at x₀ = 0.5,
        // x₁ = 0.25 (f = 0.25).
        let mut obj = Fun {
            f: rosenbrock,
            last: [0.0; 2],
        };
        let m = minimize(
            &mut obj,
            &[-1.2, 1.0],
            &[-5.0, -5.0],
            &[0.5, 5.0],
            &Options::default(),
        );
        assert_eq!(m.x[0], 0.5);
        assert!((m.x[1] - 0.25).abs() < 1e-4, "{m:?}");
        assert!((m.f - 0.25).abs() < 1e-6);
    }

    #[test]
    fn quadratic_with_minimum_outside_the_box_stops_at_the_corner() {
        // f = (x₀ − 3)² + (x₁ + 2)², box [0, 1]²: the minimum is the corner (1, 0).
        let mut obj = Fun {
            f: |x: &[f64; 2]| {
                (
                    (x[0] - 3.0).powi(2) + (x[1] + 2.0).powi(2),
                    [2.0 * (x[0] - 3.0), 2.0 * (x[1] + 2.0)],
                )
            },
            last: [0.0; 2],
        };
        let m = minimize(
            &mut obj,
            &[0.5, 0.5],
            &[0.0; 2],
            &[1.0; 2],
            &Options::default(),
        );
        assert_eq!(m.x, [1.0, 0.0]);
        assert_eq!(m.stop, Stop::Gradient);
        // The start is projected into the box; a fixed coordinate stays fixed.
        let m = minimize(
            &mut obj,
            &[9.0, -9.0],
            &[0.0, 0.3],
            &[1.0, 0.3],
            &Options::default(),
        );
        assert_eq!(m.x, [1.0, 0.3]);
    }
}
