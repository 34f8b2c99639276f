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
//! 4. transition weights likewise from target next-x / next-y GPs when on (`v_s`), their
//!    product per record; all 1 when off (the shared-dynamics configuration);
//! 5. weighted FQI on target then sources 1..3: iteration 1 fits the reward model with the
//!    reward weights, later iterations use its predictions and the transition weights.
//!
//! The ideal-weights variant (§7.7) computes the weights once, from the true noise-free
//! models, with the true variances 0.01 and 0.04 and no cap.
//!
//! Source records keep their own absorbing flags (§14.5).

use std::sync::Arc;

use awfqi::dataset::Output;
use awfqi::env::{GenerativeModel, PuddleWorld};
use awfqi::weights::{Estimator, WeightParams, WeightSummary, ideal_weight};
use rand_chacha::ChaCha8Rng;

use super::Experiment;
use super::fqi::Episodic;
use crate::fqi::{Dataset, FqiOptions, fqi};
use crate::puddle::gp::{RecordGp, input};
use crate::puddle::protocol::{Diagnostics, Learner};
use crate::puddle::score_tables::ScoreTableData;
use crate::puddle::sources::{Record, SourceSet};

/// Where the weights come from.
#[derive(Debug, Clone)]
enum Weights {
    /// Estimated every step from target GPs (§7.2–§7.3).
    Estimated {
        reward: WeightParams<f64>,
        transition: WeightParams<f64>,
        transition_on: bool,
    },
    /// Fixed ideal weights (§7.7), computed once: reward and transition weight per source
    /// record.
    Ideal {
        reward: Vec<f64>,
        transition: Vec<f64>,
    },
}

/// IWFQI or AWFQI.
#[derive(Debug, Clone)]
pub struct Iwfqi<'e> {
    experiment: &'e Experiment,
    run: Episodic,
    weights: Weights,
    /// The score table for active collection (AWFQI); `None` for episodes (IWFQI).
    table: Option<Arc<ScoreTableData>>,
    sources: Dataset<2>,
}

impl<'e> Iwfqi<'e> {
    /// IWFQI (or, with a `table`, AWFQI) with estimated weights.
    pub fn estimated(
        experiment: &'e Experiment,
        estimator: Estimator,
        table: Option<Arc<ScoreTableData>>,
    ) -> anyhow::Result<Self> {
        let (v_r, v_s) = experiment.options.variances.values();
        let cap = experiment.options.max_weight;
        // §12: AWFQI uses the shared-dynamics configuration (transition weights off).
        let transition_on = table.is_none() && experiment.transition_weights();
        Ok(Self {
            experiment,
            run: Episodic::new(&experiment.protocol),
            weights: Weights::Estimated {
                reward: WeightParams::new(estimator, v_r, cap)?,
                transition: WeightParams::new(estimator, v_s, cap)?,
                transition_on,
            },
            table,
            sources: experiment.sources.union(),
        })
    }

    /// IWFQI with the ideal weights of §7.7.
    pub fn ideal(experiment: &'e Experiment) -> anyhow::Result<Self> {
        let (reward, transition) = ideal_weights(&experiment.sources)?;
        Ok(Self {
            experiment,
            run: Episodic::new(&experiment.protocol),
            weights: Weights::Ideal { reward, transition },
            table: None,
            sources: experiment.sources.union(),
        })
    }

    /// AWFQI's collection (§12 steps 1–3): `n` rows drawn from the table, each queried once.
    fn query(&mut self, rng: &mut ChaCha8Rng) -> anyhow::Result<()> {
        let Some(table) = &self.table else {
            return self.run.collect(rng);
        };
        let rows = table.draw(self.run.protocol.budget(), rng)?;
        for r in rows {
            let (state, action) = table.rows[r];
            let record = self.run.target.query(state, action, rng)?;
            self.run.data.push(record);
        }
        Ok(())
    }

    /// The reward and transition weights of the source records for this step's `D₀`, and
    /// the target reward GP's summary.
    fn source_weights(
        &self,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<(Vec<f64>, Vec<f64>, Option<crate::puddle::gp::GpSummary>)> {
        let (reward, transition, transition_on) = match &self.weights {
            Weights::Ideal { reward, transition } => {
                return Ok((reward.clone(), transition.clone(), None));
            }
            Weights::Estimated {
                reward,
                transition,
                transition_on,
            } => (reward, transition, *transition_on),
        };
        let options = &self.experiment.options;
        let sources = &self.experiment.sources.sources;
        let target = &self.run.data;
        let gp = RecordGp::fit(target, Output::Reward, &options.gp, rng)?;
        let mut wr = Vec::with_capacity(self.sources.len());
        for s in sources {
            let zs: Vec<[f64; 3]> = s.records.iter().map(input).collect();
            let post = gp.posteriors(&zs, options.noise);
            let ys: Vec<f64> = s.records.iter().map(|r| r.reward).collect();
            let mut out = vec![0.0; ys.len()];
            reward.weights_into(&ys, &post, &s.reward, &mut out)?;
            wr.extend(out);
        }
        let mut ws = vec![1.0; self.sources.len()];
        if transition_on {
            for d in 0..2 {
                let output = Output::NextState(d);
                let gp_d = RecordGp::fit(target, output, &options.gp, rng)?;
                let mut offset = 0;
                for s in sources {
                    let zs: Vec<[f64; 3]> = s.records.iter().map(input).collect();
                    let post = gp_d.posteriors(&zs, options.noise);
                    let ys: Vec<f64> = s.records.iter().map(|r| r.next_state[d]).collect();
                    let mut out = vec![0.0; ys.len()];
                    transition.weights_into(&ys, &post, &s.next_state[d], &mut out)?;
                    for (w, o) in ws[offset..offset + out.len()].iter_mut().zip(out) {
                        *w *= o;
                    }
                    offset += s.len();
                }
            }
        }
        Ok((wr, ws, Some(gp.summary())))
    }
}

/// The ideal weights of §7.7 for every source record, in order: reward weights with the
/// true variance 0.01 and transition weights (product over x and y) with 0.04, from the
/// target's and the record's source's noise-free models; uncapped.
pub fn ideal_weights(sources: &SourceSet) -> anyhow::Result<(Vec<f64>, Vec<f64>)> {
    let target = PuddleWorld::<f64>::target(sources.dynamics);
    let worlds = PuddleWorld::<f64>::sources(sources.dynamics);
    let (mut wr, mut ws) = (Vec::new(), Vec::new());
    for (s, world) in sources.sources.iter().zip(&worlds) {
        for r in &s.records {
            let (r0, rk) = (target.mean_reward(r.state)?, world.mean_reward(r.state)?);
            wr.push(ideal_weight(r.reward, r0, rk, 0.01)?);
            let m0 = target.mean_next_state(r.state, r.action)?;
            let mk = world.mean_next_state(r.state, r.action)?;
            let mut w = 1.0;
            for d in 0..2 {
                w *= ideal_weight(r.next_state[d], m0[d], mk[d], 0.04)?;
            }
            ws.push(w);
        }
    }
    Ok((wr, ws))
}

impl Learner for Iwfqi<'_> {
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        self.query(rng)?;
        let (wr_source, ws_source, gp) = self.source_weights(rng)?;
        let n_target = self.run.data.len();
        let mut union: Dataset<2> = self.run.data.iter().copied().collect();
        union.extend_from(&self.sources);
        let mut wr = vec![1.0; n_target];
        wr.extend_from_slice(&wr_source);
        let mut ws = vec![1.0; n_target];
        ws.extend_from_slice(&ws_source);
        let options = self.run.options(FqiOptions::iwfqi(&wr, &ws));
        self.run.q = Some(fqi(&union, &options, rng)?.q);
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

    fn greedy_action(&self, state: &[f64; 2]) -> usize {
        self.run.greedy_action(state)
    }

    fn target_samples(&self) -> &[Record] {
        &self.run.data
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use awfqi::env::Dynamics;

    #[test]
    fn ideal_weights_follow_the_model_differences() {
        let sources = SourceSet::published(Dynamics::Shared).unwrap();
        let (wr, ws) = ideal_weights(&sources).unwrap();
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
        let puddle = SourceSet::published(Dynamics::PuddleBased).unwrap();
        let (_, ws) = ideal_weights(&puddle).unwrap();
        assert!(ws.iter().any(|&w| (w - 1.0).abs() > 0.1));
    }
}
