//! The common experiment protocol of spec §3, for every domain: episodic data collection,
//! greedy evaluation and the per-step records every algorithm writes.
//!
//! A run resets the algorithm, then for step `k = 1..K`: collect (episodes, or generative
//! queries for the active algorithms), learn from scratch on all data, evaluate the greedy
//! policy with one rollout from each of the domain's evaluation start states on the noisy
//! target (`perf_disc_greedy`, §3.3), and append a [`StepRecord`].

use std::time::Instant;

use awfqi::env::Dynamics;
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::domains::{Domain, Record};
use crate::joint_q::ForestLayout;
use crate::trees::TreeParams;

/// The protocol's parameters (spec §3.2, §13).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Protocol {
    /// Puddle World's dynamics variant (absent for the other domains).
    #[serde(
        default,
        with = "dynamics_name",
        skip_serializing_if = "Option::is_none"
    )]
    pub dynamics: Option<Dynamics>,
    /// Steps `K`.
    pub steps: usize,
    /// Episodes per step `B` (the batch size).
    pub episodes_per_step: usize,
    /// ε of the ε-greedy collection policy after the first step (0.3).
    pub epsilon: f64,
    /// GreedyFn evaluation rollouts per step (5).
    pub rollouts: usize,
    /// FQI iterations (60).
    pub iterations: usize,
    /// Trees per forest (50).
    pub trees: usize,
    /// Growth limits of the trees (absent when fully grown, spec §4.1).
    #[serde(default, skip_serializing_if = "TreeParams::is_fully_grown")]
    pub tree: TreeParams,
    /// The collection policy of step 1 (absent when uniform, spec §3.2).
    #[serde(default, skip_serializing_if = "FirstStep::is_uniform")]
    pub first_step: FirstStep,
    /// How FQI represents Q (absent when per action, spec §5; `joint` is the reference
    /// code's single forest over state and action value on the Dam, an ablation).
    #[serde(default, skip_serializing_if = "ForestLayout::is_per_action")]
    pub q_function: ForestLayout,
    /// FQI keeps the trees of this iteration and only refits their leaf values afterwards
    /// (absent: new trees every iteration, spec §5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub freeze_trees_after: Option<usize>,
    /// With `freeze_trees_after`: FQI grows and freezes new trees every this many
    /// iterations after it (absent: frozen once).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub regrow_trees_every: Option<usize>,
    /// Generative-model queries per step of the active algorithms (absent: `H·B`, §12).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub queries_per_step: Option<usize>,
    /// Episodes of the episodic algorithms cut to this many steps (absent: the domain's
    /// horizon), so that they get as many target samples as a query budget.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub episode_length: Option<usize>,
}

/// The collection policy of step 1, before any Q-function is learned.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FirstStep {
    /// Each action with probability 1/n (spec §3.2).
    #[default]
    Uniform,
    /// The reference code's step 1: ε-greedy around a Q-function that is zero everywhere,
    /// whose greedy action is the first one (ties go to the smallest index), so action 0
    /// is taken with probability 1 − ε + ε/n. An ablation, not the spec's protocol.
    ZeroQ,
}

impl FirstStep {
    /// Whether this is the spec's uniform first step (kept out of the result files).
    pub fn is_uniform(&self) -> bool {
        *self == Self::Uniform
    }
}

impl Protocol {
    /// Puddle World's published protocol for a dynamics variant, `K` steps of `B` episodes.
    pub fn puddle_world(dynamics: Dynamics, steps: usize, episodes_per_step: usize) -> Self {
        let domain = crate::domains::puddle::domain(dynamics);
        Self {
            dynamics: Some(dynamics),
            ..Self::published(&domain, steps, episodes_per_step)
        }
    }

    /// A domain's published protocol with `K` steps of `B` episodes.
    pub fn published<const D: usize>(domain: &Domain<D>, steps: usize, episodes: usize) -> Self {
        let p = &domain.published;
        Self {
            dynamics: None,
            steps,
            episodes_per_step: episodes,
            epsilon: p.epsilon,
            rollouts: domain.evaluation_starts.len(),
            iterations: p.iterations,
            trees: p.trees,
            tree: p.tree,
            first_step: FirstStep::Uniform,
            q_function: ForestLayout::PerAction,
            freeze_trees_after: None,
            regrow_trees_every: None,
            queries_per_step: None,
            episode_length: None,
        }
    }
}

/// Serde of an optional [`Dynamics`] as `"shared"` / `"puddle"`.
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
    pub fn serialize<S: Serializer>(d: &Option<Dynamics>, s: S) -> Result<S::Ok, S::Error> {
        match d {
            Some(d) => s.serialize_str(name(*d)),
            None => s.serialize_none(),
        }
    }

    /// Parses a variant's name.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Dynamics>, D::Error> {
        match Option::<String>::deserialize(d)?.as_deref() {
            None => Ok(None),
            Some("shared") => Ok(Some(Dynamics::Shared)),
            Some("puddle") => Ok(Some(Dynamics::PuddleBased)),
            Some(other) => Err(serde::de::Error::custom(format!(
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
    /// How far the step's last verified plan fell short of its promise, in standard
    /// deviations of the target's rewards (the adaptive kernel).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plan_shortfall: Option<f64>,
    /// The step's warnings (`awfqi::StepReport::warnings`), as printed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warnings: Option<Vec<String>>,
    /// Mean discounted return of FQI on this learner's target samples alone, with the
    /// learner's own approximator, evaluated on the same rollouts' noise as the learner
    /// (a paired baseline; `awfqi-adaptive` with `--adaptive-same-samples-fqi`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fqi_same_samples: Option<f64>,
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
    /// Mean over the rollouts of the average reward per step (the Dam's second criterion,
    /// `perf_avg_greedy`; from the same rollouts).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub perf_avg_greedy_mean: Option<f64>,
    /// Its standard error.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub perf_avg_greedy_std: Option<f64>,
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
pub trait Learner<const D: usize = 2> {
    /// Step `k` (1-based): collect this step's target data and learn from scratch on all of
    /// it.
    fn step(&mut self, k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics>;

    /// The greedy action in `state` (ties to the smallest index).
    fn greedy_action(&self, state: &[f64; D]) -> usize;

    /// The target records collected so far (`D₀`).
    fn target_samples(&self) -> &[Record<D>];

    /// The greedy action of FQI on [`Learner::target_samples`] alone, where the learner
    /// fits one (its paired baseline, evaluated on the same rollouts' noise); `None`
    /// otherwise.
    fn same_samples_action(&self, _state: &[f64; D]) -> Option<usize> {
        None
    }
}

/// Runs `K` steps of `learner` and evaluates after each; `after_step` sees each record.
pub fn run<const D: usize>(
    domain: &Domain<D>,
    protocol: &Protocol,
    learner: &mut dyn Learner<D>,
    rng: &mut ChaCha8Rng,
    mut after_step: impl FnMut(&StepRecord),
) -> anyhow::Result<Vec<StepRecord>> {
    let mut steps = Vec::with_capacity(protocol.steps);
    for k in 1..=protocol.steps {
        let start = Instant::now();
        let mut diagnostics = learner.step(k, rng)?;
        let probe = domain
            .evaluation_starts
            .first()
            .copied()
            .unwrap_or([0.0; D]);
        if learner.same_samples_action(&probe).is_some() {
            // From a copy of the generator: the same rollouts' noise as the learner's
            // evaluation below, which draws as if the baseline were not there.
            let mut paired = rng.clone();
            let baseline = |s: &[f64; D]| learner.same_samples_action(s).unwrap_or(0);
            let eval = domain.evaluate(&baseline, &mut paired)?;
            diagnostics.fqi_same_samples = Some(eval.returns.mean_return);
        }
        let greedy = |s: &[f64; D]| learner.greedy_action(s);
        let n_target = learner.target_samples().len();
        let record = evaluate_step(
            domain,
            protocol,
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
pub fn evaluate_step<const D: usize>(
    domain: &Domain<D>,
    protocol: &Protocol,
    k: usize,
    greedy: &dyn Fn(&[f64; D]) -> usize,
    n_target_samples: usize,
    diagnostics: Diagnostics,
    start: Instant,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<StepRecord> {
    let eval = domain.evaluate(greedy, rng)?;
    Ok(StepRecord {
        step: k,
        n_episodes: k * protocol.episodes_per_step,
        n_target_samples,
        perf_disc_greedy_mean: eval.returns.mean_return,
        perf_disc_greedy_std: eval.returns.standard_error,
        perf_disc_greedy_steps: eval.returns.mean_steps,
        perf_disc_greedy_goals: eval.returns.absorbed,
        perf_avg_greedy_mean: eval.average_reward.map(|a| a.0),
        perf_avg_greedy_std: eval.average_reward.map(|a| a.1),
        seconds: start.elapsed().as_secs_f64(),
        diagnostics,
    })
}

/// A greedy policy: the action in a state.
pub type GreedyFn<'a, const D: usize = 2> = &'a dyn Fn(&[f64; D]) -> usize;

/// Appends `B` episodes on the target to `data` (§3.2; each cut to
/// [`Protocol::episode_length`] steps when set): uniform at step 1 (`greedy` is
/// `None`; or ε-greedy around a zero Q-function with [`FirstStep::ZeroQ`]), ε-greedy around
/// `greedy` afterwards.
pub fn collect_episodes<const D: usize>(
    domain: &Domain<D>,
    protocol: &Protocol,
    greedy: Option<GreedyFn<'_, D>>,
    rng: &mut ChaCha8Rng,
    data: &mut Vec<Record<D>>,
) -> anyhow::Result<()> {
    let n = domain.num_actions();
    let length = protocol.episode_length.unwrap_or(domain.horizon);
    for _ in 0..protocol.episodes_per_step {
        let visit = |_t: usize, r: Record<D>| {
            data.push(r);
            Ok(())
        };
        match (greedy, protocol.first_step) {
            (None, FirstStep::Uniform) => {
                let mut uniform = UniformPolicy::new(n)?;
                domain.run_episode_of(&*domain.target, length, &mut uniform, rng, visit)?;
            }
            (None, FirstStep::ZeroQ) => {
                let zero_q = |_: &[f64; D]| Ok(0);
                let mut policy = EpsilonGreedyPolicy::new(zero_q, protocol.epsilon, n)?;
                domain.run_episode_of(&*domain.target, length, &mut policy, rng, visit)?;
            }
            (Some(g), _) => {
                let inner = |s: &[f64; D]| Ok(g(s));
                let mut policy = EpsilonGreedyPolicy::new(inner, protocol.epsilon, n)?;
                domain.run_episode_of(&*domain.target, length, &mut policy, rng, visit)?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domains::puddle;
    use rand_core::SeedableRng;

    /// A learner that always goes right then up, to exercise the loop.
    struct Fixed {
        data: Vec<Record<2>>,
        protocol: Protocol,
        domain: Domain<2>,
    }

    impl Learner for Fixed {
        fn step(&mut self, k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
            let g = |s: &[f64; 2]| if s[0] < 4.5 { 0 } else { 2 };
            let greedy: Option<GreedyFn<'_>> = if k == 1 { None } else { Some(&g) };
            collect_episodes(&self.domain, &self.protocol, greedy, rng, &mut self.data)?;
            Ok(Diagnostics::default())
        }
        fn greedy_action(&self, s: &[f64; 2]) -> usize {
            if s[0] < 4.5 { 0 } else { 2 }
        }
        fn target_samples(&self) -> &[Record<2>] {
            &self.data
        }
    }

    #[test]
    fn first_step_policies_take_the_first_action_at_their_rates() {
        // Dam episodes are 360 steps long: 10 of them give 3600 actions.
        let domain = crate::domains::dam::domain();
        let mut protocol = Protocol::published(&domain, 1, 10);
        let share_of_first_action = |protocol: &Protocol| {
            let mut rng = ChaCha8Rng::seed_from_u64(3);
            let mut data = Vec::new();
            collect_episodes(&domain, protocol, None, &mut rng, &mut data).unwrap();
            assert_eq!(data.len(), 3600);
            data.iter().filter(|r| r.action == 0).count() as f64 / data.len() as f64
        };
        // Uniform: 1/8. Zero Q: 1 − ε + ε/8 = 0.7375 with ε = 0.3. Binomial s.d. ≤ 0.008.
        assert!((share_of_first_action(&protocol) - 0.125).abs() < 0.03);
        protocol.first_step = FirstStep::ZeroQ;
        assert!((share_of_first_action(&protocol) - 0.7375).abs() < 0.03);
        // The default stays out of the result files, the ablation is recorded.
        let json = serde_json::to_value(protocol).unwrap();
        assert_eq!(json["first_step"], "zero-q");
        protocol.first_step = FirstStep::Uniform;
        assert!(
            serde_json::to_value(protocol)
                .unwrap()
                .get("first_step")
                .is_none()
        );
    }

    #[test]
    fn records_count_episodes_and_samples() {
        let protocol = Protocol::puddle_world(Dynamics::Shared, 3, 2);
        let domain = puddle::domain(Dynamics::Shared);
        let mut learner = Fixed {
            data: Vec::new(),
            protocol,
            domain: domain.clone(),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut seen = 0;
        let steps = run(&domain, &protocol, &mut learner, &mut rng, |_| seen += 1).unwrap();
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
            assert_eq!(s.perf_avg_greedy_mean, None);
        }
        let last = steps.last().unwrap().n_target_samples;
        assert_eq!(last, learner.data.len());
        // The same seed gives the same records.
        let mut again = Fixed {
            data: Vec::new(),
            protocol,
            domain: domain.clone(),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let steps2 = run(&domain, &protocol, &mut again, &mut rng, |_| ()).unwrap();
        for (a, b) in steps.iter().zip(&steps2) {
            assert_eq!(a.perf_disc_greedy_mean, b.perf_disc_greedy_mean);
        }
    }

    /// The harness's evaluation replays the core's Puddle World evaluation draw for draw.
    #[test]
    fn puddle_evaluation_is_the_cores() {
        let domain = puddle::domain(Dynamics::PuddleBased);
        let greedy = |s: &[f64; 2]| if s[1] < 9.0 { 2 } else { 0 };
        let mut a = ChaCha8Rng::seed_from_u64(4);
        let ours = domain.evaluate(&greedy, &mut a).unwrap();
        let target = awfqi::env::PuddleWorld::<f64>::target(Dynamics::PuddleBased);
        let mut b = ChaCha8Rng::seed_from_u64(4);
        let mut policy = |s: &[f64; 2]| Ok(greedy(s));
        let protocol = target.evaluation_protocol();
        let core = awfqi::evaluation::evaluate(&target, &mut policy, &protocol, &mut b).unwrap();
        assert_eq!(
            ours.returns.mean_return.to_bits(),
            core.mean_return.to_bits()
        );
        assert_eq!(
            ours.returns.standard_error.to_bits(),
            core.standard_error.to_bits()
        );
        assert_eq!(ours.returns.mean_steps, core.mean_steps);
        assert_eq!(ours.returns.absorbed, core.absorbed);
        assert_eq!(a, b);
    }
}
