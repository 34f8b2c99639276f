//! The per-action Q-function of FQI ([`ActionForests`]).

use super::forest::{Forest, validate};
use super::params::TreeParams;
use awfqi::{Error, Result};
use rand_core::Rng;

/// The Q-function of FQI on a continuous state space: one independent [`Forest`] per action
/// (spec §4.1), trained on the samples of that action with the state as input.
///
/// Memory: the forests' nodes (see [`Forest`]), plus per-action gathering buffers.
#[derive(Debug, Clone)]
pub struct ActionForests<const D: usize = 2> {
    forests: Vec<Forest<D>>,
    /// The growth limits of every refit.
    params: TreeParams,
    /// Per-action gathered training data, reused across refits.
    buffers: Vec<ActionBuffer<D>>,
}

#[derive(Debug, Clone, Default)]
struct ActionBuffer<const D: usize> {
    states: Vec<[f64; D]>,
    targets: Vec<f64>,
    weights: Vec<f64>,
}

impl<const D: usize> ActionForests<D> {
    /// `num_actions` empty forests: `Q ≡ 0` (the `Q₀` of FQI).
    pub fn zero(num_actions: usize) -> Self {
        Self::zero_with(num_actions, TreeParams::FULLY_GROWN)
    }

    /// [`ActionForests::zero`] whose refits grow trees with the limits `params`.
    pub fn zero_with(num_actions: usize, params: TreeParams) -> Self {
        Self {
            params,
            forests: (0..num_actions).map(|_| Forest::empty()).collect(),
            buffers: (0..num_actions).map(|_| ActionBuffer::default()).collect(),
        }
    }

    /// Fits one forest of `n_trees` trees per action `0..num_actions` on the samples taken
    /// with that action, with sample `weights`.
    ///
    /// The forests are fitted in action order, each drawing its tree seeds from `rng`; an
    /// action without samples (or with total weight 0) gets a forest that predicts 0.
    ///
    /// Errors: as [`Forest::fit`], plus `num_actions == 0`
    /// ([`Error::InvalidParameter`]) and an action `≥ num_actions` ([`Error::OutOfRange`]).
    #[allow(clippy::too_many_arguments)]
    pub fn fit<R: Rng + ?Sized>(
        num_actions: usize,
        states: &[[f64; D]],
        actions: &[usize],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        rng: &mut R,
    ) -> Result<Self> {
        if num_actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "num_actions",
            });
        }
        let mut q = Self::zero(num_actions);
        q.refit(states, actions, targets, weights, n_trees, rng)?;
        Ok(q)
    }

    /// [`ActionForests::fit`] in place with this Q-function's number of actions, reusing its
    /// buffers. On error nothing is changed.
    pub fn refit<R: Rng + ?Sized>(
        &mut self,
        states: &[[f64; D]],
        actions: &[usize],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        rng: &mut R,
    ) -> Result<()> {
        self.refit_stopping(states, actions, targets, weights, n_trees, true, rng)
    }

    /// [`ActionForests::refit`] without the impurity stop ([`Forest::refit_fine`]).
    ///
    /// Errors: as [`ActionForests::refit`].
    pub fn refit_fine<R: Rng + ?Sized>(
        &mut self,
        states: &[[f64; D]],
        actions: &[usize],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        rng: &mut R,
    ) -> Result<()> {
        self.refit_stopping(states, actions, targets, weights, n_trees, false, rng)
    }

    #[allow(clippy::too_many_arguments)]
    fn refit_stopping<R: Rng + ?Sized>(
        &mut self,
        states: &[[f64; D]],
        actions: &[usize],
        targets: &[f64],
        weights: &[f64],
        n_trees: usize,
        impurity_stop: bool,
        rng: &mut R,
    ) -> Result<()> {
        if actions.len() != states.len() {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        if actions.iter().any(|&a| a >= self.forests.len()) {
            return Err(Error::OutOfRange {
                parameter: "actions",
            });
        }
        if n_trees == 0 {
            return Err(Error::InvalidParameter {
                parameter: "n_trees",
            });
        }
        validate(states, targets, weights)?;
        for buf in &mut self.buffers {
            buf.states.clear();
            buf.targets.clear();
            buf.weights.clear();
        }
        for (((s, &a), &y), &w) in states.iter().zip(actions).zip(targets).zip(weights) {
            let buf = &mut self.buffers[a];
            buf.states.push(*s);
            buf.targets.push(y);
            buf.weights.push(w);
        }
        for (forest, buf) in self.forests.iter_mut().zip(&self.buffers) {
            forest.refit_stopping(
                &buf.states,
                &buf.targets,
                &buf.weights,
                n_trees,
                &self.params,
                impurity_stop,
                rng,
            )?;
        }
        Ok(())
    }

    /// Number of actions.
    pub fn num_actions(&self) -> usize {
        self.forests.len()
    }

    /// The forest of `action`, or `None` when out of range.
    pub fn forest(&self, action: usize) -> Option<&Forest<D>> {
        self.forests.get(action)
    }

    /// The forest of `action`, mutable (a frozen structure's new leaf values), or `None`.
    pub(crate) fn forest_mut(&mut self, action: usize) -> Option<&mut Forest<D>> {
        self.forests.get_mut(action)
    }

    /// `Q(state, action)`.
    ///
    /// Errors: `action ≥ num_actions` ([`Error::OutOfRange`]).
    pub fn predict(&self, state: &[f64; D], action: usize) -> Result<f64> {
        self.forests
            .get(action)
            .map(|f| f.predict(state))
            .ok_or(Error::OutOfRange {
                parameter: "action",
            })
    }

    /// `max_a Q(state, a)` (0 with no actions).
    pub fn max_over_actions(&self, state: &[f64; D]) -> f64 {
        self.best(state).map_or(0.0, |(_, v)| v)
    }

    /// `argmax_a Q(state, a)`, ties broken by the smallest action index (spec §3.1).
    pub fn greedy_action(&self, state: &[f64; D]) -> usize {
        self.best(state).map_or(0, |(a, _)| a)
    }

    /// The first action of largest value and that value.
    fn best(&self, state: &[f64; D]) -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for (a, f) in self.forests.iter().enumerate() {
            let v = f.predict(state);
            if best.is_none_or(|(_, b)| v > b) {
                best = Some((a, v));
            }
        }
        best
    }

    /// `Q(states[i], actions[i])` for every `i`, into `out` (batch form of
    /// [`ActionForests::predict`], same values).
    ///
    /// Errors: mismatched lengths ([`Error::InvalidParameter`]), an action out of range
    /// ([`Error::OutOfRange`]).
    pub fn predict_actions_into(
        &self,
        states: &[[f64; D]],
        actions: &[usize],
        out: &mut [f64],
    ) -> Result<()> {
        if actions.len() != states.len() {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        if out.len() != states.len() {
            return Err(Error::InvalidParameter { parameter: "out" });
        }
        if actions.iter().any(|&a| a >= self.forests.len()) {
            return Err(Error::OutOfRange {
                parameter: "actions",
            });
        }
        let mut xs = Vec::new();
        let mut idx = Vec::new();
        let mut vals = Vec::new();
        for (a, forest) in self.forests.iter().enumerate() {
            xs.clear();
            idx.clear();
            for (i, (s, &b)) in states.iter().zip(actions).enumerate() {
                if b == a {
                    xs.push(*s);
                    idx.push(i);
                }
            }
            vals.resize(xs.len(), 0.0);
            forest.predict_into(&xs, &mut vals)?;
            for (&i, &v) in idx.iter().zip(&vals) {
                out[i] = v;
            }
        }
        Ok(())
    }

    /// `max_a Q(states[i], a)` for every `i`, into `out` (batch form of
    /// [`ActionForests::max_over_actions`], same values). `scratch` must have the length
    /// of `states`; it is overwritten.
    ///
    /// Errors: mismatched lengths ([`Error::InvalidParameter`]).
    pub fn max_over_actions_into(
        &self,
        states: &[[f64; D]],
        out: &mut [f64],
        scratch: &mut [f64],
    ) -> Result<()> {
        if out.len() != states.len() {
            return Err(Error::InvalidParameter { parameter: "out" });
        }
        if scratch.len() != states.len() {
            return Err(Error::InvalidParameter {
                parameter: "scratch",
            });
        }
        if self.forests.is_empty() {
            out.fill(0.0);
            return Ok(());
        }
        for (a, forest) in self.forests.iter().enumerate() {
            if a == 0 {
                forest.predict_into(states, out)?;
            } else {
                forest.predict_into(states, scratch)?;
                for (o, &v) in out.iter_mut().zip(scratch.iter()) {
                    if v > *o {
                        *o = v;
                    }
                }
            }
        }
        Ok(())
    }
}
