//! Plain FQI on the target's episodes (spec §5, §13.1): per-action Extra-Trees on `D₀`
//! only, unweighted, from scratch every step.

use rand_chacha::ChaCha8Rng;

use super::Experiment;
use crate::domains::{Domain, Record};
use crate::fqi::{Dataset, FqiOptions, fqi};
use crate::puddle::protocol::{Diagnostics, Greedy, Learner, Protocol, collect_episodes};
use crate::trees::ActionForests;

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
    pub q: Option<ActionForests<D>>,
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
        let greedy: Option<Greedy<'_, D>> = greedy.as_ref().map(|g| g as Greedy<'_, D>);
        collect_episodes(self.domain, &self.protocol, greedy, rng, &mut self.data)
    }

    /// FQI options with the protocol's iterations, trees and tree limits and the domain's
    /// discount and actions.
    pub fn options<'a>(&self, base: FqiOptions<'a>) -> FqiOptions<'a> {
        FqiOptions {
            iterations: self.protocol.iterations,
            n_trees: self.protocol.trees,
            tree: self.protocol.tree,
            gamma: self.domain.discount,
            num_actions: self.domain.num_actions(),
            ..base
        }
    }

    /// The greedy action of the last Q (action 0 before the first fit).
    pub fn greedy_action(&self, s: &[f64; D]) -> usize {
        self.q.as_ref().map_or(0, |q| q.greedy_action(s))
    }
}

/// Plain FQI.
#[derive(Debug, Clone)]
pub struct Fqi<'e, const D: usize = 2> {
    run: Episodic<'e, D>,
}

impl<'e, const D: usize> Fqi<'e, D> {
    /// A fresh run.
    pub fn new(experiment: &'e Experiment<D>) -> Self {
        Self {
            run: Episodic::new(experiment),
        }
    }
}

impl<const D: usize> Learner<D> for Fqi<'_, D> {
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        self.run.collect(rng)?;
        let data: Dataset<D> = self.run.data.iter().copied().collect();
        let options = self.run.options(FqiOptions::plain());
        self.run.q = Some(fqi(&data, &options, rng)?.q);
        Ok(Diagnostics {
            n_source_samples: Some(0),
            ..Diagnostics::default()
        })
    }

    fn greedy_action(&self, state: &[f64; D]) -> usize {
        self.run.greedy_action(state)
    }

    fn target_samples(&self) -> &[Record<D>] {
        &self.run.data
    }
}
