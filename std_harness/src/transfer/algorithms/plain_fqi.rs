//! Plain FQI on the target's episodes (spec §5, §13.1): per-action Extra-Trees on `D₀`
//! only, unweighted, from scratch every step (or, with the protocol's
//! [`crate::joint_q::ForestLayout::Joint`] ablation, one forest over state and action
//! value).

use rand_chacha::ChaCha8Rng;

use super::Experiment;
use super::episodic::{Episodic, EpisodicLearner};
use crate::forest_fqi::{Dataset, FqiOptions};
use crate::transfer::protocol::Diagnostics;

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

impl<const D: usize> EpisodicLearner<D> for Fqi<'_, D> {
    fn learn(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        self.run.collect(rng)?;
        let data: Dataset<D> = self.run.data.iter().copied().collect();
        let options = self.run.options(FqiOptions::plain());
        self.run.q = Some(self.run.fit(&data, &options, rng)?);
        Ok(Diagnostics {
            n_source_samples: Some(0),
            ..Diagnostics::default()
        })
    }

    fn episodic(&self) -> &Episodic<'_, D> {
        &self.run
    }
}
