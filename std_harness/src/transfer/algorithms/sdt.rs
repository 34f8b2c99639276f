//! SDT, shared-dynamics transfer (Laroche & Barlier 2017) as the reference implements it
//! (spec §9): the reward model is fitted on the target records only, then every record of
//! the union of target and all source records gets the model's reward (the sources' own
//! rewards are discarded; their states, next states and absorbing flags are kept), and
//! iterations 2..N run on the union, unweighted.

use rand_chacha::ChaCha8Rng;

use super::Experiment;
use super::episodic::{Episodic, EpisodicLearner};
use crate::forest_fqi::{Dataset, FqiOptions};
use crate::transfer::protocol::Diagnostics;

/// SDT.
#[derive(Debug, Clone)]
pub struct Sdt<'e, const D: usize = 2> {
    run: Episodic<'e, D>,
    sources: Dataset<D>,
}

impl<'e, const D: usize> Sdt<'e, D> {
    /// A fresh run on the experiment's sources.
    pub fn new(experiment: &'e Experiment<D>) -> Self {
        Self {
            run: Episodic::new(experiment),
            sources: experiment.sources.union(),
        }
    }
}

impl<const D: usize> EpisodicLearner<D> for Sdt<'_, D> {
    fn learn(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        self.run.collect(rng)?;
        let mut union: Dataset<D> = self.run.data.iter().copied().collect();
        let n_target = union.len();
        union.extend_from(&self.sources);
        let options = self.run.options(FqiOptions::sdt(n_target));
        self.run.q = Some(self.run.fit(&union, &options, rng)?);
        Ok(Diagnostics {
            n_source_samples: Some(self.sources.len()),
            n_eff: Some(union.len()),
            ..Diagnostics::default()
        })
    }

    fn episodic(&self) -> &Episodic<'_, D> {
        &self.run
    }
}
