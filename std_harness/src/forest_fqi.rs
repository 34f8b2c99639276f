//! Fitted Q-iteration on Extra-Trees (spec §5), with the two variations the transfer
//! baselines need: IWFQI's weights and reward model (spec §7.2 step 5) and SDT's reward model
//! fitted on the target records only (spec §9).
//!
//! * **Plain FQI** ([`FqiOptions::plain`]): iteration 1 fits `y_i = r_i`; iteration
//!   `k = 2..N_it` fits `y_i = r_i + γ (1 − ω_i) max_a′ Q_{k−1}(s′_i, a′)`, unweighted. For an
//!   absorbing sample the max is not evaluated at all (it is multiplied by 0).
//! * **IWFQI** ([`FqiOptions::iwfqi`]): iteration 1 uses the reward weights `w_r` and gives
//!   the reward model `R̂ = Q₁`; every reward (target records included) is replaced by
//!   `R̂(s_i, a_i)`; iterations `2..N_it` use the transition weights `w_s`.
//! * **SDT** ([`FqiOptions::sdt`]): iteration 1 fits only the first `n` records (the target
//!   records, which come first in the union), unweighted; then every record of the union gets
//!   `R̂(s_i, a_i)` and iterations `2..N_it` run on the union, unweighted.
//!
//! Every variation is one [`FqiOptions`] value, so new combinations (weights with an SDT
//! prefix, say) need no new code. Each call starts from scratch: there is no warm start across
//! experiment steps (spec §5).

use crate::frozen_trees::FrozenActionForests;
use crate::trees::{ActionForests, DEFAULT_TREES, TreeParams};
use awfqi::model::Transition;
use awfqi::{Error, Result};
use rand_core::Rng;

/// FQI iterations of the reference experiments (spec §5: `N_it = 60`).
pub const DEFAULT_ITERATIONS: usize = 60;

/// Discount factor of the Puddle World (spec §2.1).
pub const DEFAULT_GAMMA: f64 = 0.99;

/// Transitions `(s, a, r, s′, ω)` as parallel columns (spec §1's records without the time
/// index). Records are kept in insertion order; IWFQI and SDT rely on the target records
/// coming first.
///
/// Memory: `(16·D + 17)` bytes per record (on a 64-bit host), in five vectors.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Dataset<const D: usize = 2> {
    /// States `s_i`.
    pub states: Vec<[f64; D]>,
    /// Actions `a_i`.
    pub actions: Vec<usize>,
    /// Observed rewards `r_i`.
    pub rewards: Vec<f64>,
    /// Next states `s′_i`.
    pub next_states: Vec<[f64; D]>,
    /// Absorbing flags `ω_i`.
    pub absorbing: Vec<bool>,
}

impl<const D: usize> Dataset<D> {
    /// An empty dataset.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of records.
    pub fn len(&self) -> usize {
        self.states.len()
    }

    /// `true` without records.
    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// Appends one record.
    pub fn push(&mut self, t: Transition<[f64; D], f64>) {
        self.states.push(t.state);
        self.actions.push(t.action);
        self.rewards.push(t.reward);
        self.next_states.push(t.next_state);
        self.absorbing.push(t.absorbing);
    }

    /// Appends all records of `other`, in order (e.g. a source after the target records).
    pub fn extend_from(&mut self, other: &Self) {
        self.states.extend_from_slice(&other.states);
        self.actions.extend_from_slice(&other.actions);
        self.rewards.extend_from_slice(&other.rewards);
        self.next_states.extend_from_slice(&other.next_states);
        self.absorbing.extend_from_slice(&other.absorbing);
    }

    /// Record `i`, or `None` when out of range.
    pub fn get(&self, i: usize) -> Option<Transition<[f64; D], f64>> {
        Some(Transition {
            state: *self.states.get(i)?,
            action: *self.actions.get(i)?,
            reward: *self.rewards.get(i)?,
            next_state: *self.next_states.get(i)?,
            absorbing: *self.absorbing.get(i)?,
        })
    }

    /// Checks that the columns have equal lengths, actions are `< num_actions` and every
    /// number is finite.
    ///
    /// Errors: [`Error::InvalidParameter`] (a column's length), [`Error::OutOfRange`]
    /// (`actions`), [`Error::NonFinite`] (naming the column).
    pub fn validate(&self, num_actions: usize) -> Result<()> {
        let n = self.states.len();
        for (len, parameter) in [
            (self.actions.len(), "actions"),
            (self.rewards.len(), "rewards"),
            (self.next_states.len(), "next_states"),
            (self.absorbing.len(), "absorbing"),
        ] {
            if len != n {
                return Err(Error::InvalidParameter { parameter });
            }
        }
        if self.actions.iter().any(|&a| a >= num_actions) {
            return Err(Error::OutOfRange {
                parameter: "actions",
            });
        }
        if self.states.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                parameter: "states",
            });
        }
        if self.rewards.iter().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                parameter: "rewards",
            });
        }
        if self.next_states.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                parameter: "next_states",
            });
        }
        Ok(())
    }
}

impl<const D: usize> FromIterator<Transition<[f64; D], f64>> for Dataset<D> {
    fn from_iter<I: IntoIterator<Item = Transition<[f64; D], f64>>>(iter: I) -> Self {
        let mut data = Self::new();
        for t in iter {
            data.push(t);
        }
        data
    }
}

/// Where the rewards of iterations `2..N_it` come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rewards {
    /// The observed rewards `r_i` in every iteration (plain FQI, spec §5).
    Observed,
    /// `r̂_i = Q₁(s_i, a_i)`, the first iteration's forests at each record (IWFQI, spec §7.2
    /// step 5).
    FirstIterationModel,
}

/// How one FQI run is configured. Build it with [`FqiOptions::plain`],
/// [`FqiOptions::iwfqi`] or [`FqiOptions::sdt`] and adjust the public fields.
#[derive(Debug, Clone, Copy)]
pub struct FqiOptions<'a> {
    /// Number of iterations `N_it ≥ 1` (default 60).
    pub iterations: usize,
    /// Trees per forest `M ≥ 1` (default 50).
    pub n_trees: usize,
    /// Discount `γ ∈ [0, 1]` (default 0.99).
    pub gamma: f64,
    /// Number of actions (default 4); actions are `0..num_actions`.
    pub num_actions: usize,
    /// Sample weights of iteration 1 (`None`: all 1). One per record of the dataset.
    pub reward_weights: Option<&'a [f64]>,
    /// Sample weights of iterations `2..N_it` (`None`: all 1). One per record.
    pub transition_weights: Option<&'a [f64]>,
    /// The rewards of iterations `2..N_it`.
    pub rewards: Rewards,
    /// Iteration 1 fits only the first this many records (`None`: all). With
    /// [`Rewards::FirstIterationModel`] this is SDT's reward model on the target records.
    pub first_iteration_records: Option<usize>,
    /// Growth limits of every forest (default: fully grown trees, spec §4.1).
    pub tree: TreeParams,
    /// Keep the trees of this iteration (≥ 2), grown without the impurity stop
    /// ([`crate::trees::Forest::refit_fine`]), and only refit their leaf values in later
    /// iterations ([`crate::frozen_trees`]; `None`, the default: every iteration grows new
    /// trees, spec §5). An option, not the spec's FQI.
    pub freeze_after: Option<usize>,
    /// With [`FqiOptions::freeze_after`] `= K`: grow new trees (again without the impurity
    /// stop) and freeze them every this many iterations after `K` (iterations `K + R`,
    /// `K + 2R`, …), so the averaging operator follows the changing targets at a fraction
    /// of the faithful cost (`None`: frozen once, at `K`). An option, not the spec's FQI.
    pub regrow_every: Option<usize>,
}

impl<'a> FqiOptions<'a> {
    /// Plain FQI (spec §5): 60 iterations, 50 trees, `γ = 0.99`, 4 actions, unweighted,
    /// observed rewards.
    pub fn plain() -> Self {
        Self {
            iterations: DEFAULT_ITERATIONS,
            n_trees: DEFAULT_TREES,
            gamma: DEFAULT_GAMMA,
            num_actions: 4,
            reward_weights: None,
            transition_weights: None,
            rewards: Rewards::Observed,
            first_iteration_records: None,
            tree: TreeParams::FULLY_GROWN,
            freeze_after: None,
            regrow_every: None,
        }
    }

    /// IWFQI's weighted FQI (spec §7.2 step 5): reward weights in iteration 1, then the
    /// reward model's rewards and the transition weights.
    pub fn iwfqi(reward_weights: &'a [f64], transition_weights: &'a [f64]) -> Self {
        Self {
            reward_weights: Some(reward_weights),
            transition_weights: Some(transition_weights),
            rewards: Rewards::FirstIterationModel,
            ..Self::plain()
        }
    }

    /// SDT (spec §9): iteration 1 on the first `target_records` records only, then the reward
    /// model's rewards on all records, unweighted.
    pub fn sdt(target_records: usize) -> Self {
        Self {
            rewards: Rewards::FirstIterationModel,
            first_iteration_records: Some(target_records),
            ..Self::plain()
        }
    }

    /// Whether iteration `iteration` grows trees to be frozen (without the impurity stop):
    /// `K`, then every `R` after it, never the last iteration (nothing would use them).
    pub(crate) fn freezes_at(&self, iteration: usize) -> bool {
        let Some(k) = self.freeze_after else {
            return false;
        };
        let scheduled = iteration == k
            || self
                .regrow_every
                .is_some_and(|r| iteration > k && (iteration - k).is_multiple_of(r));
        scheduled && iteration < self.iterations
    }

    pub(crate) fn validate(&self, n: usize) -> Result<()> {
        if self.iterations == 0 {
            return Err(Error::InvalidParameter {
                parameter: "iterations",
            });
        }
        if self.n_trees == 0 {
            return Err(Error::InvalidParameter {
                parameter: "n_trees",
            });
        }
        if self.num_actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "num_actions",
            });
        }
        self.tree.validate()?;
        if self.freeze_after.is_some_and(|k| k < 2) {
            return Err(Error::InvalidParameter {
                parameter: "freeze_after",
            });
        }
        if self
            .regrow_every
            .is_some_and(|r| r == 0 || self.freeze_after.is_none())
        {
            return Err(Error::InvalidParameter {
                parameter: "regrow_every",
            });
        }
        if !(0.0..=1.0).contains(&self.gamma) {
            return Err(Error::OutOfRange { parameter: "gamma" });
        }
        for (w, parameter) in [
            (self.reward_weights, "reward_weights"),
            (self.transition_weights, "transition_weights"),
        ] {
            if let Some(w) = w {
                if w.len() != n {
                    return Err(Error::InvalidParameter { parameter });
                }
                if w.iter().any(|v| !v.is_finite()) {
                    return Err(Error::NonFinite { parameter });
                }
                if w.iter().any(|&v| v < 0.0) {
                    return Err(Error::InvalidParameter { parameter });
                }
            }
        }
        if self.first_iteration_records.is_some_and(|m| m > n) {
            return Err(Error::OutOfRange {
                parameter: "first_iteration_records",
            });
        }
        Ok(())
    }
}

/// The result of [`fqi`].
#[derive(Debug, Clone)]
pub struct FqiOutput<const D: usize = 2> {
    /// `Q_{N_it}`: act greedily (or ε-greedily) on it.
    pub q: ActionForests<D>,
    /// The rewards iterations `2..N_it` used: `R̂(s_i, a_i)` per record with
    /// [`Rewards::FirstIterationModel`], `None` with [`Rewards::Observed`].
    pub model_rewards: Option<Vec<f64>>,
}

/// Runs FQI on `data` as `options` say (see the [module docs](self)), drawing all randomness
/// from `rng`.
///
/// Errors: an invalid dataset ([`Dataset::validate`]) or invalid options (zero iterations,
/// trees or actions, `γ ∉ [0, 1]`, weights of the wrong length, negative or non-finite,
/// `first_iteration_records > data.len()`).
pub fn fqi<const D: usize, R: Rng + ?Sized>(
    data: &Dataset<D>,
    options: &FqiOptions<'_>,
    rng: &mut R,
) -> Result<FqiOutput<D>> {
    data.validate(options.num_actions)?;
    let n = data.len();
    options.validate(n)?;
    let ones = vec![1.0; n];
    let reward_weights = options.reward_weights.unwrap_or(&ones);
    let transition_weights = options.transition_weights.unwrap_or(&ones);

    // Iteration 1: y = r.
    let m = options.first_iteration_records.unwrap_or(n);
    let mut q = ActionForests::zero_with(options.num_actions, options.tree);
    q.refit(
        &data.states[..m],
        &data.actions[..m],
        &data.rewards[..m],
        &reward_weights[..m],
        options.n_trees,
        rng,
    )?;
    let model_rewards = match options.rewards {
        Rewards::Observed => None,
        Rewards::FirstIterationModel => {
            let mut r_hat = vec![0.0; n];
            q.predict_actions_into(&data.states, &data.actions, &mut r_hat)?;
            Some(r_hat)
        }
    };
    let rewards = model_rewards.as_deref().unwrap_or(&data.rewards);

    // Iterations 2..N_it: only non-absorbing records of positive weight need
    // max_a′ Q(s′, a′) (a record of weight 0 adds exactly 0 to every sum of the fit, so its
    // target is never read; it keeps its reward).
    // They are visited in a space-filling-curve order of their next states: neighbouring
    // queries walk a tree along similar paths, so the lanes of a batch walk
    // (`Forest::predict_into`) end at similar depths. Each query's value does not depend on
    // the order.
    let live = live_in_locality_order(data, transition_weights);
    let live_next: Vec<[f64; D]> = live.iter().map(|&i| data.next_states[i]).collect();
    let mut max_q = vec![0.0; live.len()];
    let mut scratch = vec![0.0; live.len()];
    let mut targets = vec![0.0; n];
    let mut next = ActionForests::zero_with(options.num_actions, options.tree);
    let mut frozen: Option<FrozenActionForests> = None;
    for iteration in 2..=options.iterations {
        match &frozen {
            Some(f) => f.max_over_actions_into(&q, &mut max_q, &mut scratch)?,
            None => q.max_over_actions_into(&live_next, &mut max_q, &mut scratch)?,
        }
        targets.copy_from_slice(rewards);
        for (&i, &v) in live.iter().zip(&max_q) {
            targets[i] += options.gamma * v;
        }
        // The structure to be frozen is grown without the impurity stop, so that it stays
        // fine where this iteration's targets happen to be constant.
        let freezing = options.freezes_at(iteration);
        match &mut frozen {
            Some(f) if !freezing => f.refit(&mut q, &targets)?,
            _ => {
                let (s, a, w, m) = (
                    &data.states,
                    &data.actions,
                    transition_weights,
                    options.n_trees,
                );
                if freezing {
                    next.refit_fine(s, a, &targets, w, m, rng)?;
                } else {
                    next.refit(s, a, &targets, w, m, rng)?;
                }
                std::mem::swap(&mut q, &mut next);
            }
        }
        if freezing {
            frozen = Some(FrozenActionForests::new(
                &q,
                &data.states,
                &data.actions,
                transition_weights,
                &live_next,
            )?);
        }
    }
    Ok(FqiOutput { q, model_rewards })
}

/// The indices of the non-absorbing records of positive `weights`, ordered by the Morton
/// key of their next states ([`morton_key`]), the order in which FQI asks for
/// `max_a′ Q(s′, a′)`.
pub(crate) fn live_in_locality_order<const D: usize>(
    data: &Dataset<D>,
    weights: &[f64],
) -> Vec<usize> {
    let mut live: Vec<usize> = (0..data.len())
        .filter(|&i| !data.absorbing[i] && weights[i] > 0.0)
        .collect();
    let bounds = bounding_box(live.iter().map(|&i| &data.next_states[i]));
    live.sort_by_key(|&i| morton_key(&data.next_states[i], &bounds));
    live
}

/// Per-coordinate `(min, max)` of the first two coordinates of `points` (`(0, 0)` when
/// there are none), the box [`morton_key`] quantises over.
fn bounding_box<'a, const D: usize>(points: impl Iterator<Item = &'a [f64; D]>) -> [(f64, f64); 2] {
    let mut bounds = [(f64::INFINITY, f64::NEG_INFINITY); 2];
    for p in points {
        for (b, &v) in bounds.iter_mut().zip(p.iter()) {
            *b = (b.0.min(v), b.1.max(v));
        }
    }
    bounds.map(|(lo, hi)| if lo <= hi { (lo, hi) } else { (0.0, 0.0) })
}

/// A Z-order (Morton) key of the first two coordinates of `x`, each quantised to 16 bits
/// over its range in `bounds` (values outside are clamped), for ordering queries by
/// locality.
fn morton_key<const D: usize>(x: &[f64; D], bounds: &[(f64, f64); 2]) -> u32 {
    let quantise = |v: f64, (lo, hi): (f64, f64)| {
        let span = hi - lo;
        let t = if span > 0.0 { (v - lo) / span } else { 0.0 };
        (t.clamp(0.0, 1.0) * 65535.0) as u32
    };
    let spread = |mut v: u32| {
        v &= 0xffff;
        v = (v | (v << 8)) & 0x00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333;
        (v | (v << 1)) & 0x5555_5555
    };
    let a = x.first().map_or(0, |&v| quantise(v, bounds[0]));
    let b = x.get(1).map_or(0, |&v| quantise(v, bounds[1]));
    spread(a) | (spread(b) << 1)
}

#[cfg(test)]
mod tests;
