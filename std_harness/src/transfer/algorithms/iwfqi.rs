//! IWFQI (spec §7) and AWFQI (spec §12), which is IWFQI on generative-model queries drawn
//! from a score table instead of episodes.
//!
//! One step (§7.2):
//! 1. collect: `B` episodes (IWFQI), or `n = H·B` rows drawn from the score table with
//!    probability ∝ `V_r` and queried on the target's generative model (AWFQI);
//! 2. fit the target reward GP (fresh hyperparameters, restarts, last `max_gp` records) and
//!    predict it at every source's `z`, noise-subtracted per source batch;
//! 3. reward weights of the source records with the estimator (mean or heuristic, `v_r`,
//!    `w_max`); target records weigh 1;
//! 4. transition weights likewise from target GPs of the weighted next-state coordinates
//!    (`v_s`; Puddle World's x and y in the puddle-based variant, the Dam's storage,
//!    Acrobot's four), their product per record; all 1 when off (the shared-dynamics
//!    configuration);
//! 5. weighted FQI on target then sources 1..m: iteration 1 fits the reward model with the
//!    reward weights, later iterations use its predictions and the transition weights.
//!
//! The GPs are the domain's ([`crate::transfer::gp::Weighting`]): fitted by marginal likelihood
//! for Puddle World, the published fixed kernels for the Dam and Acrobot. The
//! ideal-weights variant (§7.7) computes the weights once per experiment, from the true
//! models, with the domain's ideal variances (Puddle World's true 0.01 and 0.04) and no
//! cap.
//!
//! Source records keep their own absorbing flags (§14.5).

use std::sync::Arc;

use awfqi::weights::{Estimator, Posterior, WeightParams, WeightSummary, ideal_weight};
use rand_chacha::ChaCha8Rng;

use super::Experiment;
use super::episodic::{Episodic, EpisodicLearner};
use crate::domains::{Domain, GpInput, IdealMeans};
use crate::forest_fqi::{Dataset, FqiOptions};
use crate::transfer::gp::{GpOptions, GpSearch, GpSummary, GrowingRecordGp, Output, RecordGp};
use crate::transfer::protocol::Diagnostics;
use crate::transfer::score_tables::ScoreTableData;
use crate::transfer::sources::SourceSet;

/// Where the weights come from.
#[derive(Debug, Clone)]
enum Weights {
    /// Estimated every step from target GPs (§7.2–§7.3), transition weights on the listed
    /// state coordinates.
    Estimated {
        reward: WeightParams<f64>,
        transition: WeightParams<f64>,
        transition_dims: Vec<usize>,
    },
    /// Fixed ideal weights (§7.7), computed once per experiment: reward and transition
    /// weight per source record.
    Ideal(Arc<(Vec<f64>, Vec<f64>)>),
}

/// IWFQI or AWFQI.
#[derive(Debug, Clone)]
pub struct Iwfqi<'e, const D: usize = 2> {
    experiment: &'e Experiment<D>,
    run: Episodic<'e, D>,
    weights: Weights,
    /// The score table for active collection (AWFQI); `None` for episodes (IWFQI).
    table: Option<Arc<ScoreTableData<D>>>,
    sources: Dataset<D>,
    /// The target GPs' options (the experiment's, with the search this learner runs).
    gp: GpOptions,
    /// Fixed-kernel target GPs kept conditioned between steps
    /// ([`FixedGpUpdate::storage`](crate::transfer::gp::FixedGpUpdate::storage) says how), by output.
    growing: Vec<(Output, GrowingRecordGp)>,
}

impl<'e, const D: usize> Iwfqi<'e, D> {
    /// IWFQI (or, with a `table`, AWFQI) with estimated weights, its target GPs fitted with
    /// `gp` (the experiment's options with this algorithm's search).
    pub fn estimated(
        experiment: &'e Experiment<D>,
        estimator: Estimator,
        table: Option<Arc<ScoreTableData<D>>>,
        gp: GpOptions,
    ) -> anyhow::Result<Self> {
        let (v_r, v_s) = experiment.variances()?;
        let cap = experiment.options.max_weight;
        // §12: AWFQI uses the shared-dynamics configuration (transition weights off).
        let transition_dims = if table.is_none() {
            experiment.transition_dims()
        } else {
            Vec::new()
        };
        Ok(Self {
            experiment,
            run: Episodic::new(experiment),
            weights: Weights::Estimated {
                reward: WeightParams::new(estimator, v_r, cap)?,
                transition: WeightParams::new(estimator, v_s, cap)?,
                transition_dims,
            },
            table,
            sources: experiment.sources.union(),
            gp,
            growing: Vec::new(),
        })
    }

    /// IWFQI with the ideal weights of §7.7 (computed once per experiment).
    pub fn ideal(experiment: &'e Experiment<D>) -> anyhow::Result<Self> {
        let weights = experiment
            .ideal_weights
            .clone()
            .ok_or_else(|| anyhow::anyhow!("no ideal weights in the experiment"))?;
        Ok(Self {
            experiment,
            run: Episodic::new(experiment),
            weights: Weights::Ideal(weights),
            table: None,
            sources: experiment.sources.union(),
            gp: experiment.options.gp.resolved(GpSearch::Spec),
            growing: Vec::new(),
        })
    }

    /// AWFQI's collection (§12 steps 1–3): `n` rows drawn from the table, each queried once.
    fn query(&mut self, rng: &mut ChaCha8Rng) -> anyhow::Result<()> {
        let Some(table) = &self.table else {
            return self.run.collect(rng);
        };
        let rows = table.draw(self.experiment.budget(), rng)?;
        for r in rows {
            let (state, action) = table.rows[r];
            let record = self.run.domain.target.query(state, action, rng)?;
            self.run.data.push(record);
        }
        Ok(())
    }

    /// The target GP of `output` on this step's `D₀`, as posteriors at each source's
    /// `zs` (noise-subtracted per source), and its summary. A fixed kernel is appended to
    /// (unless [`FixedGpUpdate::Refit`](crate::transfer::gp::FixedGpUpdate::Refit)) while it can be; otherwise the GP is refitted.
    fn target_posteriors(
        &mut self,
        output: Output,
        zs: &[Vec<GpInput>],
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<(Vec<Vec<Posterior<f64>>>, GpSummary)> {
        let domain = &*self.experiment.domain;
        let weighting = &self.experiment.data.weighting;
        let noise = self.experiment.options.noise;
        let target = &self.run.data;
        // The growing GP keeps no `K⁻¹`, so the explicit-inverse variance always refits.
        let storage = self.gp.fixed_update.storage();
        if let (Some(storage), true) = (storage, self.gp.fixed_variance.is_default()) {
            let index = match self.growing.iter().position(|(o, _)| *o == output) {
                Some(i) => Some(i),
                None => {
                    let spec = weighting.gp_spec(output);
                    GrowingRecordGp::new(domain, &spec, output, zs, storage)
                        .transpose()?
                        .map(|gp| {
                            self.growing.push((output, gp));
                            self.growing.len() - 1
                        })
                }
            };
            if let Some(i) = index {
                let gp = &mut self.growing[i].1;
                if gp.update(domain, target, self.gp.max_gp)? {
                    return Ok((gp.posteriors(noise), gp.summary()));
                }
                // Beyond `max_gp` (or not a continuation): refitted from here on.
                self.growing.remove(i);
            }
        }
        let spec = weighting.gp_spec(output);
        let gp = RecordGp::fit_records(domain, target, output, &spec, &self.gp, rng)?;
        let posteriors = zs
            .iter()
            .map(|zs| gp.posteriors(zs, spec.noise(noise)))
            .collect();
        Ok((posteriors, gp.summary()))
    }

    /// The reward and transition weights of the source records for this step's `D₀`, and
    /// the target reward GP's summary.
    fn source_weights(
        &mut self,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<(Vec<f64>, Vec<f64>, Option<GpSummary>)> {
        let (reward, transition, transition_dims) = match &self.weights {
            Weights::Ideal(w) => {
                return Ok((w.0.clone(), w.1.clone(), None));
            }
            Weights::Estimated {
                reward,
                transition,
                transition_dims,
            } => (*reward, *transition, transition_dims.clone()),
        };
        let domain = &*self.experiment.domain;
        let sources = &self.experiment.sources.sources;
        let zs: Vec<Vec<GpInput>> = sources
            .iter()
            .map(|s| s.records.iter().map(|r| domain.input(r)).collect())
            .collect();
        let (reward_posteriors, summary) = self.target_posteriors(Output::Reward, &zs, rng)?;
        let mut wr = Vec::with_capacity(self.sources.len());
        for (s, post) in sources.iter().zip(&reward_posteriors) {
            let ys: Vec<f64> = s.records.iter().map(|r| r.reward).collect();
            let mut out = vec![0.0; ys.len()];
            reward.weights_into(&ys, post, &s.reward, &mut out)?;
            wr.extend(out);
        }
        let mut ws = vec![1.0; self.sources.len()];
        for d in transition_dims {
            let output = Output::NextState(d);
            let (posteriors, _) = self.target_posteriors(output, &zs, rng)?;
            let mut offset = 0;
            for (k, (s, post)) in sources.iter().zip(&posteriors).enumerate() {
                let stored = s.next_state.get(d).ok_or_else(|| {
                    anyhow::anyhow!(
                        "source {} stores no GP posteriors of next-state coordinate {d}",
                        k + 1
                    )
                })?;
                let ys = s
                    .records
                    .iter()
                    .map(|r| output.of(r))
                    .collect::<awfqi::Result<Vec<f64>>>()?;
                let mut out = vec![0.0; ys.len()];
                transition.weights_into(&ys, post, stored, &mut out)?;
                for (w, o) in ws[offset..offset + out.len()].iter_mut().zip(out) {
                    *w *= o;
                }
                offset += s.len();
            }
        }
        Ok((wr, ws, Some(summary)))
    }
}

/// One step's weighted FQI input: the union of target and source records, its reward and
/// transition weights, and the target reward GP's summary.
pub type WeightedStep<const D: usize> = (Dataset<D>, Vec<f64>, Vec<f64>, Option<GpSummary>);

impl<const D: usize> Iwfqi<'_, D> {
    /// One step's data for its weighted FQI (§7.2 steps 1–4): collects, then returns the
    /// union of all target records and the sources (target first), its reward and
    /// transition weights (1 for target records), and the target reward GP's summary.
    pub fn collect_weighted(&mut self, rng: &mut ChaCha8Rng) -> anyhow::Result<WeightedStep<D>> {
        self.query(rng)?;
        let (wr_source, ws_source, gp) = self.source_weights(rng)?;
        let n_target = self.run.data.len();
        let mut union: Dataset<D> = self.run.data.iter().copied().collect();
        union.extend_from(&self.sources);
        let mut wr = vec![1.0; n_target];
        wr.extend_from_slice(&wr_source);
        let mut ws = vec![1.0; n_target];
        ws.extend_from_slice(&ws_source);
        Ok((union, wr, ws, gp))
    }
}

/// The ideal weights of §7.7 for every source record, in order: reward weights with
/// variance `v_r` and transition weights (product over the state coordinates) with `v_s`,
/// from the target's and the record's source's models; uncapped. With
/// [`IdealMeans::Sampled`] the models' "mean" next states are one sampled step each (the
/// reference's `get_transition_mean`), target first, drawn from `rng`.
pub fn ideal_weights<const D: usize>(
    domain: &Domain<D>,
    sources: &SourceSet<D>,
    (v_r, v_s): (f64, f64),
    means: IdealMeans,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<(Vec<f64>, Vec<f64>)> {
    anyhow::ensure!(
        sources.sources.len() == domain.sources.len(),
        "{} source datasets for {} source models",
        sources.sources.len(),
        domain.sources.len()
    );
    let target = &*domain.target;
    let (mut wr, mut ws) = (Vec::new(), Vec::new());
    for (s, model) in sources.sources.iter().zip(&domain.sources) {
        for r in &s.records {
            let (r0, rk) = (
                target.mean_reward(r.state, r.action)?,
                model.mean_reward(r.state, r.action)?,
            );
            wr.push(ideal_weight(r.reward, r0, rk, v_r)?);
            let (m0, mk) = match means {
                IdealMeans::Exact => (
                    target.mean_next_state(r.state, r.action)?,
                    model.mean_next_state(r.state, r.action)?,
                ),
                IdealMeans::Sampled => (
                    target.query(r.state, r.action, rng)?.next_state,
                    model.query(r.state, r.action, rng)?.next_state,
                ),
            };
            let mut w = 1.0;
            for d in 0..D {
                w *= ideal_weight(r.next_state[d], m0[d], mk[d], v_s)?;
            }
            ws.push(w);
        }
    }
    Ok((wr, ws))
}

impl<const D: usize> EpisodicLearner<D> for Iwfqi<'_, D> {
    fn learn(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        let (union, wr, ws, gp) = self.collect_weighted(rng)?;
        let options = self.run.options(FqiOptions::iwfqi(&wr, &ws));
        self.run.q = Some(self.run.fit(&union, &options, rng)?);
        let summary = |w: &[f64]| -> anyhow::Result<(f64, f64)> {
            let mut s = WeightSummary::<f64>::new();
            s.add(w)?;
            Ok((s.mean(), s.effective_sample_size()))
        };
        let (wr_mean, wr_eff) = summary(&wr)?;
        let (ws_mean, ws_eff) = summary(&ws)?;
        Ok(Diagnostics {
            n_source_samples: Some(self.sources.len()),
            wr_mean: Some(wr_mean),
            wr_eff: Some(wr_eff),
            ws_mean: Some(ws_mean),
            ws_eff: Some(ws_eff),
            reward_gp: gp,
            ..Diagnostics::default()
        })
    }

    fn episodic(&self) -> &Episodic<'_, D> {
        &self.run
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domains::puddle;
    use awfqi::env::{Dynamics, PuddleWorld};
    use rand_core::SeedableRng;

    fn weights(dynamics: Dynamics) -> (SourceSet<2>, Vec<f64>, Vec<f64>) {
        let sources = SourceSet::published(dynamics).unwrap();
        let domain = puddle::domain(dynamics);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let (wr, ws) =
            ideal_weights(&domain, &sources, (0.01, 0.04), IdealMeans::Exact, &mut rng).unwrap();
        (sources, wr, ws)
    }

    #[test]
    fn ideal_weights_follow_the_model_differences() {
        let (sources, wr, ws) = weights(Dynamics::Shared);
        assert_eq!(wr.len(), sources.total_records());
        // Shared dynamics: the mean next states agree, so every transition weight is 1.
        assert!(ws.iter().all(|&w| w == 1.0));
        // Source 1 differs from the target only by the (1, 4) puddle: far from it the
        // weight is ≈ 1 (the mean rewards agree to < 1e-3).
        let target = PuddleWorld::<f64>::target(Dynamics::Shared);
        let s1 = PuddleWorld::<f64>::source_1(Dynamics::Shared);
        for (r, &w) in sources.sources[0].records.iter().zip(&wr) {
            let (a, b) = (
                target.mean_reward(r.state).unwrap(),
                s1.mean_reward(r.state).unwrap(),
            );
            // Closed form of §7.7: exp(((r − b)² − (r − a)²) / (2·0.01)).
            let want = (((r.reward - b).powi(2) - (r.reward - a).powi(2)) / 0.02).exp();
            assert!((w - want).abs() <= 1e-9 * want.max(1.0));
        }
        // Puddle-based dynamics: transition weights differ from 1 near puddles.
        let (_, _, ws) = weights(Dynamics::PuddleBased);
        assert!(ws.iter().any(|&w| (w - 1.0).abs() > 0.1));
    }
}
