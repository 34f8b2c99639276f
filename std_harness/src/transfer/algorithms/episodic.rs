//! The episodic behaviour every forest-based algorithm shares: `D₀`, the last Q-function,
//! collection around it and its greedy action (spec §3.2), and the one implementation of
//! [`Learner`] for all of them ([`EpisodicLearner`]).

use rand_chacha::ChaCha8Rng;

use super::Experiment;
use crate::domains::{Domain, Record};
use crate::forest_fqi::{Dataset, FqiOptions, fqi};
use crate::joint_q::{ForestLayout, ForestQ, fqi_joint};
use crate::transfer::protocol::{Diagnostics, GreedyFn, Learner, Protocol, collect_episodes};

/// The episodic part every baseline shares: the domain, `D₀` and the last Q-function.
#[derive(Debug, Clone)]
pub struct Episodic<'e, const D: usize = 2> {
    /// The domain (its target is the task collected on).
    pub domain: &'e Domain<D>,
    /// The protocol.
    pub protocol: Protocol,
    /// `D₀`.
    pub data: Vec<Record<D>>,
    /// The Q-function of the last step (`None` before the first).
    pub q: Option<ForestQ<D>>,
}

impl<'e, const D: usize> Episodic<'e, D> {
    /// An empty run of `experiment`.
    pub fn new(experiment: &'e Experiment<D>) -> Self {
        Self {
            domain: &experiment.domain,
            protocol: experiment.protocol,
            data: Vec::new(),
            q: None,
        }
    }

    /// Appends this step's `B` episodes (uniform at step 1, then ε-greedy on the last Q).
    pub fn collect(&mut self, rng: &mut ChaCha8Rng) -> anyhow::Result<()> {
        let greedy = self
            .q
            .as_ref()
            .map(|q| move |s: &[f64; D]| q.greedy_action(s));
        let greedy: Option<GreedyFn<'_, D>> = greedy.as_ref().map(|g| g as GreedyFn<'_, D>);
        collect_episodes(self.domain, &self.protocol, greedy, rng, &mut self.data)
    }

    /// FQI options with the protocol's iterations, trees, tree limits and freezing schedule and the domain's
    /// discount and actions.
    pub fn options<'a>(&self, base: FqiOptions<'a>) -> FqiOptions<'a> {
        FqiOptions {
            iterations: self.protocol.iterations,
            n_trees: self.protocol.trees,
            tree: self.protocol.tree,
            freeze_after: self.protocol.freeze_trees_after,
            regrow_every: self.protocol.regrow_trees_every,
            gamma: self.domain.discount,
            num_actions: self.domain.num_actions(),
            ..base
        }
    }

    /// FQI on `data` with `options`, in the protocol's representation of Q: per-action
    /// forests (spec §5) or the reference's joint forest over state and action value.
    ///
    /// Errors: those of [`fqi`] and [`fqi_joint`].
    pub fn fit(
        &self,
        data: &Dataset<D>,
        options: &FqiOptions<'_>,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<ForestQ<D>> {
        Ok(match self.protocol.q_function {
            ForestLayout::PerAction => fqi(data, options, rng)?.q.into(),
            ForestLayout::Joint => {
                ForestQ::Joint(fqi_joint(data, options, &self.domain.action_values, rng)?)
            }
        })
    }

    /// The greedy action of the last Q (action 0 before the first fit).
    pub fn greedy_action(&self, s: &[f64; D]) -> usize {
        self.q.as_ref().map_or(0, |q| q.greedy_action(s))
    }
}

/// An algorithm whose `D₀` and Q-function live in an [`Episodic`] run (FQI, IWFQI and its
/// AWFQI variants, RBT, SDT): it says how a step learns, and its greedy action and target
/// samples are the run's. [`Learner`] is implemented once for all of them, below.
pub trait EpisodicLearner<const D: usize> {
    /// Step `k` (1-based): add this step's target data to the run and fit its Q-function on
    /// all of it.
    fn learn(&mut self, k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics>;

    /// The run.
    fn episodic(&self) -> &Episodic<'_, D>;
}

impl<const D: usize, L: EpisodicLearner<D>> Learner<D> for L {
    fn step(&mut self, k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        self.learn(k, rng)
    }

    fn greedy_action(&self, state: &[f64; D]) -> usize {
        self.episodic().greedy_action(state)
    }

    fn target_samples(&self) -> &[Record<D>] {
        &self.episodic().data
    }
}
