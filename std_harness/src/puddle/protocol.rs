//! The common experiment protocol of spec §3: episodic data collection, greedy evaluation and
//! the per-step records every algorithm writes.
//!
//! A run resets the algorithm, then for step `k = 1..K`: collect (episodes, or generative
//! queries for the active algorithms), learn from scratch on all data, evaluate the greedy
//! policy with 5 rollouts from (0, 0) on the noisy target (`perf_disc_greedy`, §3.3), and
//! append a [`StepRecord`].

use std::time::Instant;

use awfqi::env::{Dynamics, PUDDLE_EVALUATION_ROLLOUTS, PUDDLE_HORIZON, PuddleWorld};
use awfqi::evaluation::{EvaluationProtocol, evaluate};
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::sources::Record;

/// The protocol's parameters (spec §3.2, §13).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Protocol {
    /// Dynamics variant of the target (and sources).
    #[serde(with = "dynamics_name")]
    pub dynamics: Dynamics,
    /// Steps `K`.
    pub steps: usize,
    /// Episodes per step `B` (the batch size).
    pub episodes_per_step: usize,
    /// ε of the ε-greedy collection policy after the first step (0.3).
    pub epsilon: f64,
    /// Greedy evaluation rollouts per step (5).
    pub rollouts: usize,
    /// FQI iterations (60).
    pub iterations: usize,
    /// Trees per forest (50).
    pub trees: usize,
}

impl Protocol {
    /// The reference protocol for a dynamics variant, `K` steps of `B` episodes.
    pub fn reference(dynamics: Dynamics, steps: usize, episodes_per_step: usize) -> Self {
        Self {
            dynamics,
            steps,
            episodes_per_step,
            epsilon: 0.3,
            rollouts: PUDDLE_EVALUATION_ROLLOUTS,
            iterations: 60,
            trees: 50,
        }
    }

    /// The active algorithms' per-step budget `n = H·B` (§12).
    pub fn budget(&self) -> usize {
        PUDDLE_HORIZON * self.episodes_per_step
    }

    /// The target task.
    pub fn target(&self) -> PuddleWorld<f64> {
        PuddleWorld::target(self.dynamics)
    }
}

/// Serde of [`Dynamics`] as `"shared"` / `"puddle"`.
pub mod dynamics_name {
    use awfqi::env::Dynamics;
    use serde::{Deserialize, Deserializer, Serializer};

    /// The name of a variant.
    pub fn name(d: Dynamics) -> &'static str {
        match d {
            Dynamics::Shared => "shared",
            Dynamics::PuddleBased => "puddle",
        }
    }

    /// Serializes a variant as its name.
    pub fn serialize<S: Serializer>(d: &Dynamics, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(name(*d))
    }

    /// Parses a variant's name.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Dynamics, D::Error> {
        match String::deserialize(d)?.as_str() {
            "shared" => Ok(Dynamics::Shared),
            "puddle" => Ok(Dynamics::PuddleBased),
            other => Err(serde::de::Error::custom(format!(
                "unknown dynamics {other}"
            ))),
        }
    }
}

/// Algorithm diagnostics of one step (§3.4); absent fields do not apply.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// Source records in the learning set (all for IWFQI/SDT, the resampled ones for RBT).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub n_source_samples: Option<usize>,
    /// Mean reward weight over all records (IWFQI, AWFQI).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wr_mean: Option<f64>,
    /// Effective sample size of the reward weights.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wr_eff: Option<f64>,
    /// Mean transition weight over all records.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ws_mean: Option<f64>,
    /// Effective sample size of the transition weights.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ws_eff: Option<f64>,
    /// Normalized task compliances (RBT).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub compliances: Option<Vec<f64>>,
    /// Size of the learning set (RBT, SDT).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub n_eff: Option<usize>,
    /// The target reward GP of the step (IWFQI, AWFQI).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reward_gp: Option<super::gp::GpSummary>,
}

/// One step's record (§3.3, §3.4), with the reference's field names.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepRecord {
    /// Step `k` (1-based).
    pub step: usize,
    /// `k·B` (equivalent episodes for the active algorithms).
    pub n_episodes: usize,
    /// `|D₀|`, the target records collected so far.
    pub n_target_samples: usize,
    /// Mean discounted return of the greedy rollouts.
    pub perf_disc_greedy_mean: f64,
    /// Population std of the returns / √rollouts (a standard error, §14.14).
    pub perf_disc_greedy_std: f64,
    /// Mean rollout length.
    pub perf_disc_greedy_steps: f64,
    /// Rollouts that reached the goal.
    pub perf_disc_greedy_goals: usize,
    /// Wall time of the step (collection, learning, evaluation), seconds. Not written to
    /// the result files (they are identical for identical seeds); see `timing.csv`.
    #[serde(skip)]
    pub seconds: f64,
    /// Algorithm diagnostics.
    #[serde(flatten)]
    pub diagnostics: Diagnostics,
}

/// Something the protocol can run: it collects and learns one step at a time and acts
/// greedily on what it learned.
pub trait Learner {
    /// Step `k` (1-based): collect this step's target data and learn from scratch on all of
    /// it.
    fn step(&mut self, k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics>;

    /// The greedy action in `state` (ties to the smallest index).
    fn greedy_action(&self, state: &[f64; 2]) -> usize;

    /// The target records collected so far (`D₀`).
    fn target_samples(&self) -> &[Record];
}

/// Runs `K` steps of `learner` and evaluates after each; `after_step` sees each record.
pub fn run(
    protocol: &Protocol,
    learner: &mut dyn Learner,
    rng: &mut ChaCha8Rng,
    mut after_step: impl FnMut(&StepRecord),
) -> anyhow::Result<Vec<StepRecord>> {
    let target = protocol.target();
    let mut steps = Vec::with_capacity(protocol.steps);
    for k in 1..=protocol.steps {
        let start = Instant::now();
        let diagnostics = learner.step(k, rng)?;
        let greedy = |s: &[f64; 2]| learner.greedy_action(s);
        let n_target = learner.target_samples().len();
        let record = evaluate_step(
            protocol,
            &target,
            k,
            &greedy,
            n_target,
            diagnostics,
            start,
            rng,
        )?;
        after_step(&record);
        steps.push(record);
    }
    Ok(steps)
}

/// Evaluates the greedy policy `greedy` after step `k` (§3.3) and builds the step's record;
/// `start` is when the step began.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_step(
    protocol: &Protocol,
    target: &PuddleWorld<f64>,
    k: usize,
    greedy: &dyn Fn(&[f64; 2]) -> usize,
    n_target_samples: usize,
    diagnostics: Diagnostics,
    start: Instant,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<StepRecord> {
    let mut policy = |s: &[f64; 2]| Ok(greedy(s));
    let rollouts = EvaluationProtocol {
        rollouts: protocol.rollouts,
        ..target.evaluation_protocol()
    };
    let eval = evaluate(target, &mut policy, &rollouts, rng)?;
    Ok(StepRecord {
        step: k,
        n_episodes: k * protocol.episodes_per_step,
        n_target_samples,
        perf_disc_greedy_mean: eval.mean_return,
        perf_disc_greedy_std: eval.standard_error,
        perf_disc_greedy_steps: eval.mean_steps,
        perf_disc_greedy_goals: eval.absorbed,
        seconds: start.elapsed().as_secs_f64(),
        diagnostics,
    })
}

/// A greedy policy: the action in a state.
pub type Greedy<'a> = &'a dyn Fn(&[f64; 2]) -> usize;

/// Appends `B` episodes to `data` (§3.2): uniform at step 1 (`greedy` is `None`), ε-greedy
/// around `greedy` afterwards.
pub fn collect_episodes(
    protocol: &Protocol,
    target: &PuddleWorld<f64>,
    greedy: Option<Greedy<'_>>,
    rng: &mut ChaCha8Rng,
    data: &mut Vec<Record>,
) -> anyhow::Result<()> {
    for _ in 0..protocol.episodes_per_step {
        let visit = |r: awfqi::env::EpisodeRecord<f64>| {
            data.push(r.transition);
            Ok(())
        };
        match greedy {
            None => {
                let mut uniform = UniformPolicy::new(4)?;
                target.run_episode_with(&mut uniform, PUDDLE_HORIZON, rng, visit)?;
            }
            Some(g) => {
                let inner = |s: &[f64; 2]| Ok(g(s));
                let mut policy = EpsilonGreedyPolicy::new(inner, protocol.epsilon, 4)?;
                target.run_episode_with(&mut policy, PUDDLE_HORIZON, rng, visit)?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::SeedableRng;

    /// A learner that always goes right then up, to exercise the loop.
    struct Fixed {
        data: Vec<Record>,
        protocol: Protocol,
    }

    impl Learner for Fixed {
        fn step(&mut self, k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
            let target = self.protocol.target();
            let g = |s: &[f64; 2]| if s[0] < 4.5 { 0 } else { 2 };
            let greedy: Option<Greedy<'_>> = if k == 1 { None } else { Some(&g) };
            collect_episodes(&self.protocol, &target, greedy, rng, &mut self.data)?;
            Ok(Diagnostics::default())
        }
        fn greedy_action(&self, s: &[f64; 2]) -> usize {
            if s[0] < 4.5 { 0 } else { 2 }
        }
        fn target_samples(&self) -> &[Record] {
            &self.data
        }
    }

    #[test]
    fn records_count_episodes_and_samples() {
        let protocol = Protocol::reference(Dynamics::Shared, 3, 2);
        let mut learner = Fixed {
            data: Vec::new(),
            protocol,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut seen = 0;
        let steps = run(&protocol, &mut learner, &mut rng, |_| seen += 1).unwrap();
        assert_eq!(seen, 3);
        for (i, s) in steps.iter().enumerate() {
            assert_eq!(s.step, i + 1);
            assert_eq!(s.n_episodes, 2 * (i + 1));
            // Every episode starts at (0, 0): count them in the data.
            let starts = learner.data[..s.n_target_samples]
                .iter()
                .filter(|r| r.state == [0.0, 0.0])
                .count();
            assert!(starts >= 2 * (i + 1));
            // The fixed policy reaches the goal in every rollout, after at least 12 steps of
            // reward ≤ −1 (return below −(1 − 0.99¹²)/0.01 = −11.4).
            assert_eq!(s.perf_disc_greedy_goals, 5);
            assert!(s.perf_disc_greedy_mean < -11.4);
            assert!(s.perf_disc_greedy_steps >= 12.0 && s.perf_disc_greedy_steps <= 25.0);
        }
        let last = steps.last().unwrap().n_target_samples;
        assert_eq!(last, learner.data.len());
        // The same seed gives the same records.
        let mut again = Fixed {
            data: Vec::new(),
            protocol,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let steps2 = run(&protocol, &mut again, &mut rng, |_| ()).unwrap();
        for (a, b) in steps.iter().zip(&steps2) {
            assert_eq!(a.perf_disc_greedy_mean, b.perf_disc_greedy_mean);
        }
    }
}
