//! The tasks the transfer experiments run on, behind one abstraction: a [`Domain`] is a
//! target and its source MDPs ([`Task`]s, in `f64`), the action set, the horizon and
//! discount, the evaluation start states, and the configuration the published experiments
//! used ([`Published`]). A domain knows nothing of the experiments run on it: the
//! protocol, the algorithms, the source datasets and the result files are written above
//! it, once over `Domain<D>`, `D` the state dimension.
//!
//! - [`puddle`]: the continuous Puddle World (spec §2), both dynamics variants, D = 2;
//! - [`dam`]: the IWFQI paper's water reservoir, D = 2;
//! - [`acrobot`]: the IWFQI paper's multitask Acrobot, D = 4;
//! - [`unit_box`]: the plant suite's plants on the unit box (the zones and the thermal
//!   room, D = 3; the tanks, D = 4).
//!
//! Episodes and evaluation rollouts are run here, for every domain, with the core's
//! policies ([`awfqi::policy`]) and the same draw order as the core's Puddle World episode
//! runner: per step the policy first, then the task's step.

pub mod acrobot;
pub mod dam;
pub mod puddle;
pub mod unit_box;

use std::fmt::Debug;
use std::sync::Arc;

use awfqi::evaluation::Evaluation;
use awfqi::model::Transition;
use awfqi::policy::Policy;
use rand_chacha::ChaCha8Rng;

use crate::trees::TreeParams;

/// One transition record `(s, a, r, s′, ω)` in `f64`.
pub type Record<const D: usize> = Transition<[f64; D], f64>;

/// Score-table rows `(state, action)`.
pub type Rows<const D: usize> = Vec<([f64; D], usize)>;

/// Width of every GP input: the state, the action's value, then zeros (padding changes no
/// squared distance, so one GP type serves every state dimension up to 4).
pub const GP_INPUT: usize = 5;

/// A GP input `z = (s, value(a), 0, …)`.
pub type GpInput = [f64; GP_INPUT];

/// One MDP of an experiment (the target or a source), as the harness drives it: the core
/// plant's [`GenerativeModel::query`](awfqi::model::GenerativeModel::query), its mean
/// functions and its first state, under the same names, behind one object-safe trait in
/// `f64` with the harness's generator.
pub trait Task<const D: usize>: Send + Sync + Debug {
    /// One sampled transition from `state` under `action` (the generative model).
    ///
    /// Errors: the core's, for a state or action outside the task's spaces.
    fn query(
        &self,
        state: [f64; D],
        action: usize,
        rng: &mut ChaCha8Rng,
    ) -> awfqi::Result<Record<D>>;

    /// The noise-free mean reward `r̄(s, a)`.
    ///
    /// Errors: as [`Task::query`].
    fn mean_reward(&self, state: [f64; D], action: usize) -> awfqi::Result<f64>;

    /// The mean next state `s̄′(s, a)`.
    ///
    /// Errors: as [`Task::query`].
    fn mean_next_state(&self, state: [f64; D], action: usize) -> awfqi::Result<[f64; D]>;

    /// The first state of an episode (drawn from `rng` when the start is random).
    fn initial_state(&self, rng: &mut ChaCha8Rng) -> [f64; D];

    /// `true` when an episode ends on reaching `state` (Puddle World's goal, Acrobot's
    /// swing-up height; never elsewhere): what a planner on the mean model needs of the
    /// goal.
    fn ends_in(&self, _state: [f64; D]) -> bool {
        false
    }
}

/// How the ideal weights (spec §7.7) get the models' mean next states.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum IdealMeans {
    /// The exact mean functions ([`Task::mean_next_state`]).
    Exact,
    /// What the reference's `get_transition_mean` returns: one sampled step of each model
    /// (noise included), drawn once per experiment. The published Dam runs used it (the
    /// Dam's step is noisy); for noise-free dynamics it equals [`IdealMeans::Exact`].
    Sampled,
}

/// The configuration of a domain's published experiments: the defaults of its command,
/// owned here once.
#[derive(Debug, Clone, PartialEq)]
pub struct Published {
    /// Steps `K`.
    pub steps: usize,
    /// Episodes per step `B`.
    pub episodes_per_step: usize,
    /// Runs.
    pub runs: usize,
    /// The discounted return the "time to threshold" metric waits for.
    pub threshold: f64,
    /// ε of the ε-greedy collection after the first step.
    pub epsilon: f64,
    /// FQI iterations.
    pub iterations: usize,
    /// Trees per forest.
    pub trees: usize,
    /// Growth limits of the trees.
    pub tree: TreeParams,
    /// IWFQI's `(v_r, v_s)`.
    pub variances: (f64, f64),
    /// The ideal weights' `(v_r, v_s)`.
    pub ideal_variances: (f64, f64),
    /// How the ideal weights get the mean next states.
    pub ideal_means: IdealMeans,
    /// The target GPs' training cap `max_gp`.
    pub max_gp: usize,
    /// RBT's `n_total`.
    pub rbt_total: usize,
}

/// A disc in the first two state coordinates worth marking on a map of the states (Puddle
/// World's puddles and goal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    /// What it is (`puddle`, `goal`).
    pub name: &'static str,
    /// Its centre.
    pub centre: [f64; 2],
    /// Its radius.
    pub radius: f64,
}

/// A task with its experiment constants (see the [module docs](self)).
#[derive(Debug, Clone)]
pub struct Domain<const D: usize> {
    /// The name in result files and titles (`puddle world`, `dam`, `acrobot`).
    pub name: &'static str,
    /// The command's name (`puddle`, `dam`, `acrobot`).
    pub command: &'static str,
    /// A name per state coordinate (CSV columns, plot axes).
    pub state_names: [&'static str; D],
    /// Range of each state coordinate (plots, score-table grids).
    pub state_bounds: [(f64, f64); D],
    /// The target task.
    pub target: Arc<dyn Task<D>>,
    /// The source tasks, in the order of the source datasets.
    pub sources: Vec<Arc<dyn Task<D>>>,
    /// The value each action takes as a GP and RBT coordinate (the Dam's release, else the
    /// index).
    pub action_values: Vec<f64>,
    /// Episode horizon `H`.
    pub horizon: usize,
    /// Discount factor `γ`.
    pub discount: f64,
    /// Start state of each evaluation rollout.
    pub evaluation_starts: Vec<[f64; D]>,
    /// `true` when the evaluation also records the average reward per step
    /// (`perf_avg_greedy`, the Dam's second criterion).
    pub average_reward: bool,
    /// The target's regions worth marking on a map of its states (none where the first two
    /// coordinates are no map).
    pub target_regions: Vec<Region>,
    /// The published configuration.
    pub published: Published,
    /// The grid rows `(state, action)` of the score tables for a spacing (grid and both
    /// modes, spec §11.1).
    pub grid_rows: fn(f64) -> anyhow::Result<Rows<D>>,
    /// The default spacing of [`Domain::grid_rows`].
    pub grid_spacing: f64,
}

/// What the evaluation rollouts of one step produced (spec §3.3): the core's
/// [`Evaluation`] and, where the domain records it, the average reward per step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepEvaluation {
    /// Discounted returns: mean, standard error, mean length, absorbed rollouts.
    pub returns: Evaluation<f64>,
    /// Mean and standard error of the average reward per step, when the domain records it.
    pub average_reward: Option<(f64, f64)>,
}

impl<const D: usize> Domain<D> {
    /// Number of actions.
    pub fn num_actions(&self) -> usize {
        self.action_values.len()
    }

    /// The GP input of `(state, action)`.
    pub fn gp_input(&self, state: &[f64; D], action: usize) -> GpInput {
        let mut z = [0.0; GP_INPUT];
        for (zi, &s) in z.iter_mut().zip(state) {
            *zi = s;
        }
        if let Some(slot) = z.get_mut(D) {
            *slot = self.action_values.get(action).copied().unwrap_or(f64::NAN);
        }
        z
    }

    /// The GP input of a record.
    pub fn input(&self, r: &Record<D>) -> GpInput {
        self.gp_input(&r.state, r.action)
    }

    /// Runs one episode of `policy` on `task` from its initial state, handing each record
    /// to `visit`, until an absorbing step or the horizon; returns the number of records.
    ///
    /// Errors: the first error of the policy, of a step or of `visit`.
    pub fn run_episode<P, F>(
        &self,
        task: &dyn Task<D>,
        policy: &mut P,
        rng: &mut ChaCha8Rng,
        visit: F,
    ) -> awfqi::Result<usize>
    where
        P: Policy<[f64; D]> + ?Sized,
        F: FnMut(usize, Record<D>) -> awfqi::Result<()>,
    {
        self.run_episode_of(task, self.horizon, policy, rng, visit)
    }

    /// [`Domain::run_episode`] cut to at most `length` steps (an episode of
    /// `--episode-length`).
    ///
    /// Errors: as [`Domain::run_episode`].
    pub fn run_episode_of<P, F>(
        &self,
        task: &dyn Task<D>,
        length: usize,
        policy: &mut P,
        rng: &mut ChaCha8Rng,
        visit: F,
    ) -> awfqi::Result<usize>
    where
        P: Policy<[f64; D]> + ?Sized,
        F: FnMut(usize, Record<D>) -> awfqi::Result<()>,
    {
        let start = task.initial_state(rng);
        self.run_for(task, start, length, policy, rng, visit)
    }

    /// [`Domain::run_episode`] from a given first state.
    ///
    /// Errors: as [`Domain::run_episode`].
    pub fn run_from<P, F>(
        &self,
        task: &dyn Task<D>,
        start: [f64; D],
        policy: &mut P,
        rng: &mut ChaCha8Rng,
        visit: F,
    ) -> awfqi::Result<usize>
    where
        P: Policy<[f64; D]> + ?Sized,
        F: FnMut(usize, Record<D>) -> awfqi::Result<()>,
    {
        self.run_for(task, start, self.horizon, policy, rng, visit)
    }

    /// [`Domain::run_from`] for at most `length` steps.
    fn run_for<P, F>(
        &self,
        task: &dyn Task<D>,
        start: [f64; D],
        length: usize,
        policy: &mut P,
        rng: &mut ChaCha8Rng,
        mut visit: F,
    ) -> awfqi::Result<usize>
    where
        P: Policy<[f64; D]> + ?Sized,
        F: FnMut(usize, Record<D>) -> awfqi::Result<()>,
    {
        let mut state = start;
        for t in 0..length {
            let action = policy.action(&state, rng)?;
            let record = task.query(state, action, rng)?;
            visit(t, record)?;
            if record.absorbing {
                return Ok(t + 1);
            }
            state = record.next_state;
        }
        Ok(length)
    }

    /// Evaluates the deterministic policy `greedy` on the target (spec §3.3): one rollout
    /// from each evaluation start state, scored by its discounted return (and, when the
    /// domain records it, its average reward per step).
    ///
    /// Errors: no start states ([`awfqi::Error::EmptyData`]); the first error of a step.
    pub fn evaluate(
        &self,
        greedy: &dyn Fn(&[f64; D]) -> usize,
        rng: &mut ChaCha8Rng,
    ) -> awfqi::Result<StepEvaluation> {
        if self.evaluation_starts.is_empty() {
            return Err(awfqi::Error::EmptyData);
        }
        let mut policy = |s: &[f64; D]| Ok(greedy(s));
        let (mut sum, mut sum_sq, mut steps, mut goals) = (0.0, 0.0, 0.0, 0);
        let (mut avg_sum, mut avg_sq) = (0.0, 0.0);
        for &start in &self.evaluation_starts {
            let (mut ret, mut weight, mut total, mut absorbed) = (0.0, 1.0, 0.0, false);
            let n = self.run_from(&*self.target, start, &mut policy, rng, |_, r| {
                ret += weight * r.reward;
                weight *= self.discount;
                total += r.reward;
                absorbed = r.absorbing;
                Ok(())
            })?;
            sum += ret;
            sum_sq += ret * ret;
            steps += n as f64;
            goals += usize::from(absorbed);
            let average = total / n as f64;
            avg_sum += average;
            avg_sq += average * average;
        }
        let n = self.evaluation_starts.len() as f64;
        let stats = |sum: f64, sq: f64| {
            let mean = sum / n;
            let variance = (sq / n - mean * mean).max(0.0);
            (mean, (variance / n).sqrt())
        };
        let (mean_return, standard_error) = stats(sum, sum_sq);
        Ok(StepEvaluation {
            returns: Evaluation {
                mean_return,
                standard_error,
                mean_steps: steps / n,
                absorbed: goals,
            },
            average_reward: self.average_reward.then(|| stats(avg_sum, avg_sq)),
        })
    }
}
