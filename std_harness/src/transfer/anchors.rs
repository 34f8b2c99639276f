//! The plant suite's anchors: what a return of a plant is measured against. For every
//! plant, the random policy's return and the best known return, and the returns of the
//! hand-written controller and of dynamic programming on the true mean model.
//!
//! **Dynamic programming** ([`GridPlan`]): finite-horizon value iteration over the domain's
//! horizon on a grid of the declared state box, each grid point valued by
//! `max_a r̄(s, a) + γ·V_{t+1}(s̄′(s, a))` with the mean reward and mean next state of the
//! target ([`Task::mean_reward`], [`Task::mean_next_state`]), `V_{t+1}` interpolated
//! multilinearly between the grid points (clamped to the box) and zero past a goal
//! ([`Task::ends_in`]). Its policy acts in the continuous state by the same one-step
//! lookahead, so it is certainty-equivalent: optimal for the mean model, and the best known
//! policy of a plant whose noise is small. Resolutions double the cells per axis so that
//! the convergence can be read off.
//!
//! **Returns** ([`mean_return`]): the domain's evaluation (one rollout from each declared
//! start on the noisy target, discounted over the horizon) repeated from independent
//! streams `(seed, ANCHORS, repetition)`, so a value is reproducible by its seed and
//! repetitions; the standard error is that of one rollout over all of them.

use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::domains::{Domain, Task};

/// Stream purpose: the anchors' rollouts (see [`crate::transfer`]'s seeding).
pub const ANCHORS: u64 = 5;

/// A policy that may look at the time step (dynamic programming's does) and draw from the
/// rollout's stream (the random policy does).
pub type TimedPolicy<'a, const D: usize> =
    &'a (dyn Fn(&[f64; D], usize, &mut ChaCha8Rng) -> usize + Sync);

/// A mean and the standard error of one rollout's return over all rollouts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Mean discounted return.
    pub mean: f64,
    /// Its standard error.
    pub stderr: f64,
    /// Rollouts averaged.
    pub rollouts: usize,
}

/// The mean discounted return of `policy` on `domain`'s target: `repetitions` times one
/// rollout from each evaluation start, repetition `k` from the stream `(seed, ANCHORS, k)`
/// (see the [module docs](self)).
///
/// Errors: no evaluation starts; a step's error.
pub fn mean_return<const D: usize>(
    domain: &Domain<D>,
    policy: TimedPolicy<'_, D>,
    repetitions: usize,
    seed: u64,
) -> anyhow::Result<Estimate> {
    anyhow::ensure!(
        !domain.evaluation_starts.is_empty() && repetitions > 0,
        "no rollouts to average"
    );
    let returns: Vec<Vec<f64>> = (0..repetitions)
        .into_par_iter()
        .map(|k| {
            let mut rng = super::stream(seed, &[ANCHORS, k as u64]);
            domain
                .evaluation_starts
                .iter()
                .map(|&start| rollout(domain, policy, start, &mut rng))
                .collect::<anyhow::Result<Vec<f64>>>()
        })
        .collect::<anyhow::Result<_>>()?;
    let all: Vec<f64> = returns.into_iter().flatten().collect();
    let (mean, stderr) = super::results::mean_and_stderr(&all);
    Ok(Estimate {
        mean,
        stderr,
        rollouts: all.len(),
    })
}

/// One rollout's discounted return from `start` (the domain's evaluation, timed).
fn rollout<const D: usize>(
    domain: &Domain<D>,
    policy: TimedPolicy<'_, D>,
    start: [f64; D],
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<f64> {
    let (mut state, mut total, mut weight) = (start, 0.0, 1.0);
    for t in 0..domain.horizon {
        let action = policy(&state, t, rng);
        let record = domain.target.query(state, action, rng)?;
        total += weight * record.reward;
        weight *= domain.discount;
        if record.absorbing {
            break;
        }
        state = record.next_state;
    }
    Ok(total)
}

/// The uniformly random policy's return ([`mean_return`]; each action one draw from the
/// rollout's stream before the step's).
///
/// Errors: those of [`mean_return`].
pub fn random_return<const D: usize>(
    domain: &Domain<D>,
    repetitions: usize,
    seed: u64,
) -> anyhow::Result<Estimate> {
    let n = domain.num_actions();
    let random =
        move |_: &[f64; D], _: usize, rng: &mut ChaCha8Rng| awfqi::rng::uniform_index(rng, n);
    mean_return(domain, &random, repetitions, seed)
}

/// A deterministic rule of the state as a [`TimedPolicy`].
pub fn rule<const D: usize>(
    f: fn(&[f64; D]) -> usize,
) -> impl Fn(&[f64; D], usize, &mut ChaCha8Rng) -> usize + Sync {
    move |s, _, _| f(s)
}

/// Finite-horizon value iteration on the mean model over a grid (see the [module
/// docs](self)).
#[derive(Debug, Clone)]
pub struct GridPlan<const D: usize> {
    lower: [f64; D],
    upper: [f64; D],
    /// Grid points per axis.
    points: [usize; D],
    /// `V_t` at every grid point, `t = 0..=H` (`V_H = 0`), time after time.
    values: Vec<f32>,
    states: usize,
}

impl<const D: usize> GridPlan<D> {
    /// Solves `domain`'s target on `cells[d]` cells per axis of its state box (points at
    /// the cells' corners).
    ///
    /// Errors: a cell count of 0 or a grid above 10⁸ values; a mean function's error at a
    /// grid point.
    pub fn solve(domain: &Domain<D>, cells: [usize; D]) -> anyhow::Result<Self> {
        anyhow::ensure!(cells.iter().all(|&c| c >= 1), "at least one cell per axis");
        let points = cells.map(|c| c + 1);
        let states: usize = points.iter().product();
        let horizon = domain.horizon;
        anyhow::ensure!(
            states.saturating_mul(horizon + 1) <= 100_000_000,
            "grid of {states} points × {horizon} steps is too large"
        );
        let mut plan = Self {
            lower: domain.state_bounds.map(|b| b.0),
            upper: domain.state_bounds.map(|b| b.1),
            points,
            values: vec![0.0; states * (horizon + 1)],
            states,
        };
        for t in (0..horizon).rev() {
            let next: Vec<f64> = (0..states)
                .into_par_iter()
                .map(|i| {
                    let s = plan.point(i);
                    plan.best(domain, &s, t).map(|(_, v)| v)
                })
                .collect::<anyhow::Result<_>>()?;
            let at = t * states;
            for (slot, v) in plan.values[at..at + states].iter_mut().zip(next) {
                *slot = v as f32;
            }
        }
        Ok(plan)
    }

    /// The grid point of flat index `i` (first axis fastest).
    fn point(&self, mut i: usize) -> [f64; D] {
        std::array::from_fn(|d| {
            let n = self.points[d];
            let k = i % n;
            i /= n;
            self.lower[d] + (self.upper[d] - self.lower[d]) * k as f64 / (n - 1) as f64
        })
    }

    /// `V_t(state)`, interpolated multilinearly (the state clamped into the box); 0 at the
    /// horizon.
    pub fn value(&self, t: usize, state: &[f64; D]) -> f64 {
        let Some(layer) = self.values.get(t * self.states..(t + 1) * self.states) else {
            return 0.0;
        };
        let mut base = 0usize;
        let mut stride = 1usize;
        let mut frac = [0.0; D];
        let mut strides = [0usize; D];
        for d in 0..D {
            let n = self.points[d];
            let span = self.upper[d] - self.lower[d];
            let x = ((state[d] - self.lower[d]) / span).clamp(0.0, 1.0) * (n - 1) as f64;
            let k = (x.floor() as usize).min(n.saturating_sub(2));
            frac[d] = if n > 1 { x - k as f64 } else { 0.0 };
            base += k * stride;
            strides[d] = if n > 1 { stride } else { 0 };
            stride *= n;
        }
        let mut total = 0.0;
        for corner in 0..(1usize << D) {
            let (mut index, mut weight) = (base, 1.0);
            for d in 0..D {
                if corner >> d & 1 == 1 {
                    index += strides[d];
                    weight *= frac[d];
                } else {
                    weight *= 1.0 - frac[d];
                }
            }
            if weight > 0.0 {
                total += weight * f64::from(layer.get(index).copied().unwrap_or(0.0));
            }
        }
        total
    }

    /// The best action at `state` at time `t` and its value by one-step lookahead on the
    /// mean model.
    ///
    /// Errors: a mean function's error.
    fn best(&self, domain: &Domain<D>, state: &[f64; D], t: usize) -> anyhow::Result<(usize, f64)> {
        let task: &dyn Task<D> = &*domain.target;
        let mut best = (0, f64::NEG_INFINITY);
        for a in 0..domain.num_actions() {
            let r = task.mean_reward(*state, a)?;
            let next = task.mean_next_state(*state, a)?;
            let future = if task.ends_in(next) {
                0.0
            } else {
                self.value(t + 1, &next)
            };
            let q = r + domain.discount * future;
            if q > best.1 {
                best = (a, q);
            }
        }
        Ok(best)
    }

    /// The plan's action at `state` at time `t` (action 0 where a mean function fails).
    pub fn action(&self, domain: &Domain<D>, state: &[f64; D], t: usize) -> usize {
        self.best(domain, state, t).map_or(0, |(a, _)| a)
    }
}

/// One dynamic-programming result: the cells per axis and the plan's return.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanReturn {
    /// Cells per axis.
    pub cells: Vec<usize>,
    /// The plan's return on the noisy target.
    pub value: Estimate,
}

/// Solves `domain` at every resolution of `resolutions` and measures each plan's return.
///
/// Errors: those of [`GridPlan::solve`] and [`mean_return`].
pub fn plan_returns<const D: usize>(
    domain: &Domain<D>,
    resolutions: &[[usize; D]],
    repetitions: usize,
    seed: u64,
) -> anyhow::Result<Vec<PlanReturn>> {
    resolutions
        .iter()
        .map(|cells| {
            let plan = GridPlan::solve(domain, *cells)?;
            let policy = |s: &[f64; D], t: usize, _: &mut ChaCha8Rng| plan.action(domain, s, t);
            Ok(PlanReturn {
                cells: cells.to_vec(),
                value: mean_return(domain, &policy, repetitions, seed)?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domains::unit_box;

    #[test]
    fn interpolation_is_exact_on_a_linear_value() {
        let mut plan = GridPlan::<3> {
            lower: [0.0; 3],
            upper: [1.0; 3],
            points: [3, 5, 2],
            values: vec![0.0; 30],
            states: 30,
        };
        for i in 0..30 {
            let p = plan.point(i);
            plan.values[i] = (1.0 + 2.0 * p[0] - p[1] + 0.5 * p[2]) as f32;
        }
        let s = [0.3, 0.55, 0.8];
        assert!((plan.value(0, &s) - (1.0 + 0.6 - 0.55 + 0.4)).abs() < 1e-6);
        // Past the horizon (no layer): zero; outside the box: clamped.
        assert_eq!(plan.value(1, &s), 0.0);
        assert!((plan.value(0, &[2.0, 0.0, 0.0]) - 3.0).abs() < 1e-6);
    }

    #[test]
    fn value_iteration_converges_as_the_grid_doubles_on_the_zones() {
        // The zones' mean model at 5, 10 and 20 cells per axis: the value at the first
        // start moves by less between 10 and 20 than between 5 and 10, and by less than
        // 2 % of its size.
        let domain = unit_box::zones();
        let start = domain.evaluation_starts[0];
        let v: Vec<f64> = [5, 10, 20]
            .iter()
            .map(|&n| GridPlan::solve(&domain, [n; 3]).unwrap().value(0, &start))
            .collect();
        assert!((v[2] - v[1]).abs() < (v[1] - v[0]).abs(), "{v:?}");
        assert!((v[2] - v[1]).abs() < 0.02 * v[2].abs(), "{v:?}");
        // The plan beats the thermostat, which beats the random policy.
        let plan = GridPlan::solve(&domain, [10; 3]).unwrap();
        let dp = mean_return(&domain, &|s, t, _| plan.action(&domain, s, t), 20, 1).unwrap();
        let thermostat = rule(awfqi::env::zones_thermostat::<f64>);
        let rule = mean_return(&domain, &thermostat, 20, 1).unwrap();
        let random = random_return(&domain, 20, 1).unwrap();
        assert!(
            dp.mean > rule.mean && rule.mean > random.mean,
            "{dp:?} {rule:?} {random:?}"
        );
    }

    #[test]
    fn returns_are_reproducible_by_seed() {
        let domain = unit_box::thermal();
        let a = random_return(&domain, 8, 3).unwrap();
        let b = random_return(&domain, 8, 3).unwrap();
        let c = random_return(&domain, 8, 4).unwrap();
        assert_eq!(a.mean.to_bits(), b.mean.to_bits());
        assert_ne!(a.mean.to_bits(), c.mean.to_bits());
        assert_eq!(a.rollouts, 8 * 4);
    }
}
