//! Plain FQI on the target's episodes (spec §5, §13.1): 60 iterations of per-action
//! Extra-Trees on `D₀` only, unweighted, from scratch every step.

use awfqi::env::PuddleWorld;
use rand_chacha::ChaCha8Rng;

use crate::fqi::{Dataset, FqiOptions, fqi};
use crate::puddle::protocol::{Diagnostics, Greedy, Learner, Protocol, collect_episodes};
use crate::puddle::sources::Record;
use crate::trees::ActionForests;

/// The episodic part every baseline shares: the target, `D₀` and the last Q-function.
#[derive(Debug, Clone)]
pub struct Episodic {
    /// The protocol.
    pub protocol: Protocol,
    /// The target task.
    pub target: PuddleWorld<f64>,
    /// `D₀`.
    pub data: Vec<Record>,
    /// The Q-function of the last step (`None` before the first).
    pub q: Option<ActionForests<2>>,
}

impl Episodic {
    /// An empty run.
    pub fn new(protocol: &Protocol) -> Self {
        Self {
            protocol: *protocol,
            target: protocol.target(),
            data: Vec::new(),
            q: None,
        }
    }

    /// Appends this step's `B` episodes (uniform at step 1, then ε-greedy on the last Q).
    pub fn collect(&mut self, rng: &mut ChaCha8Rng) -> anyhow::Result<()> {
        let greedy = self
            .q
            .as_ref()
            .map(|q| move |s: &[f64; 2]| q.greedy_action(s));
        let greedy: Option<Greedy<'_>> = greedy.as_ref().map(|g| g as Greedy<'_>);
        collect_episodes(&self.protocol, &self.target, greedy, rng, &mut self.data)
    }

    /// FQI options with the protocol's iterations and trees.
    pub fn options<'a>(&self, base: FqiOptions<'a>) -> FqiOptions<'a> {
        FqiOptions {
            iterations: self.protocol.iterations,
            n_trees: self.protocol.trees,
            ..base
        }
    }

    /// The greedy action of the last Q (action 0 before the first fit).
    pub fn greedy_action(&self, s: &[f64; 2]) -> usize {
        self.q.as_ref().map_or(0, |q| q.greedy_action(s))
    }
}

/// Plain FQI.
#[derive(Debug, Clone)]
pub struct Fqi {
    run: Episodic,
}

impl Fqi {
    /// A fresh run.
    pub fn new(protocol: &Protocol) -> Self {
        Self {
            run: Episodic::new(protocol),
        }
    }
}

impl Learner for Fqi {
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        self.run.collect(rng)?;
        let data: Dataset<2> = self.run.data.iter().copied().collect();
        let options = self.run.options(FqiOptions::plain());
        self.run.q = Some(fqi(&data, &options, rng)?.q);
        Ok(Diagnostics {
            n_source_samples: Some(0),
            ..Diagnostics::default()
        })
    }

    fn greedy_action(&self, state: &[f64; 2]) -> usize {
        self.run.greedy_action(state)
    }

    fn target_samples(&self) -> &[Record] {
        &self.run.data
    }
}
