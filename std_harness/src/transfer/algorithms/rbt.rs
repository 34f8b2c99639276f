//! RBT, relevance-based transfer (Lazaric et al. 2008), exactly as the reference implements
//! it (spec §8, with the deviations of §14.12 replicated): per source a task compliance
//! (how well the source explains the target samples), per source record a relevance (how
//! well the target samples explain it), then `⌊n_total·c_k⌋` records of source `k` drawn with
//! replacement ∝ relevance, appended to the target records for plain FQI.
//!
//! With `φ_δ(x) = exp(−x²/δ)` and `d_ij = ‖z^t_i − z^k_j‖` over `z = (s, value(a))` (the
//! action's value, as the reference's records hold it: the Dam's release, else the index):
//! - compliance: `W_ij = φ_sa(d_ij)/Σ_j′ φ_sa(d_ij′)`, `P_ij = φ_s′(‖s′^t_i − (s^t_i + s′^k_j −
//!   s^k_j)‖)`, `Q_ij = φ_r(|r^t_i − r^k_j|)`, `λ_i = (mean_j W_ij P_ij)(mean_j W_ij Q_ij)`,
//!   `Λ_k = p_k · mean_i λ_i` (or sums over `j`, [`ComplianceSum::Sums`]: the published
//!   Acrobot runs');
//! - relevance: the same with the roles reversed (`W′` normalised over target samples),
//!   `λ̃_j = λ′_j/Σλ′`, the average distance `D_j` of the lowest-weight target samples whose
//!   cumulative weight is `≤ μ`, and `ρ_j = exp(−((λ̃_j − 1)/D_j)²)` (0 when `D_j = 0`).

use rand_chacha::ChaCha8Rng;

use super::Experiment;
use super::episodic::{Episodic, EpisodicLearner};
use crate::domains::Record;
use crate::forest_fqi::{Dataset, FqiOptions};
use crate::transfer::protocol::Diagnostics;

/// How a target sample's compliance aggregates over a source's records (spec §8 step 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ComplianceSum {
    /// `λᵢ = (1/N_k Σ_j W_ij P_ij)(1/N_k Σ_j W_ij Q_ij)`: the spec's and the kept reference
    /// code's. `Λ_k` then carries a factor `1/N_k²`, which favours smaller sources.
    #[default]
    Means,
    /// `λᵢ = (Σ_j W_ij P_ij)(Σ_j W_ij Q_ij)`: what the published Acrobot RBT runs computed
    /// (their compliances are ours with means, times `N_k²`, renormalised;
    /// docs/results-paper-domains.md). Equal-sized sources give the same compliances either way.
    Sums,
}

impl ComplianceSum {
    /// `true` for the spec's [`ComplianceSum::Means`] (serde's `skip_serializing_if`).
    pub fn is_spec(&self) -> bool {
        *self == Self::Means
    }
}

/// RBT's parameters (spec §8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RbtParams {
    /// `δ_sa` of the state-action kernel (0.1).
    pub delta_sa: f64,
    /// `δ_s′` of the transition agreement (0.1).
    pub delta_s: f64,
    /// `δ_r` of the reward agreement (0.1).
    pub delta_r: f64,
    /// `μ`, the cumulative-weight cut of the average distance (0.8).
    pub mu: f64,
    /// `n_total`, source records transferred per step (500).
    pub n_total: usize,
    /// The task compliance's aggregate over a source's records (means).
    pub compliance: ComplianceSum,
}

impl RbtParams {
    /// The reference's values.
    pub fn published() -> Self {
        Self {
            delta_sa: 0.1,
            delta_s: 0.1,
            delta_r: 0.1,
            mu: 0.8,
            n_total: 500,
            compliance: ComplianceSum::Means,
        }
    }
}

fn phi(x: f64, delta: f64) -> f64 {
    (-x * x / delta).exp()
}

/// `‖z_a − z_b‖` over the states and the actions' `values`.
fn distance<const D: usize>(a: &Record<D>, b: &Record<D>, values: &[f64]) -> f64 {
    let state: f64 = a
        .state
        .iter()
        .zip(&b.state)
        .map(|(p, q)| (p - q).powi(2))
        .sum();
    let value = |r: &Record<D>| values.get(r.action).copied().unwrap_or(f64::NAN);
    (state + (value(a) - value(b)).powi(2)).sqrt()
}

/// `‖s′_a − (s_a + s′_b − s_b)‖`: how far `a`'s next state is from `a`'s state moved by
/// `b`'s displacement.
fn transition_gap<const D: usize>(a: &Record<D>, b: &Record<D>) -> f64 {
    (0..D)
        .map(|d| {
            let v = a.next_state[d] - (a.state[d] + b.next_state[d] - b.state[d]);
            v * v
        })
        .sum::<f64>()
        .sqrt()
}

/// The per-sample compliance of `a` (one record) against all of `others`, the roles as in
/// §8 step 2 (`a` a target record, `others` a source) or step 3 (reversed), with means over
/// `others` or, for `sum`, sums. Returns the normalised kernel weights `W_a·` too.
fn sample_compliance<const D: usize>(
    a: &Record<D>,
    others: &[Record<D>],
    values: &[f64],
    p: &RbtParams,
    sum: ComplianceSum,
) -> (f64, Vec<f64>) {
    let mut w: Vec<f64> = others
        .iter()
        .map(|b| phi(distance(a, b, values), p.delta_sa))
        .collect();
    let total: f64 = w.iter().sum();
    if total > 0.0 {
        w.iter_mut().for_each(|x| *x /= total);
    } else {
        w.iter_mut().for_each(|x| *x = 0.0);
    }
    let n = match sum {
        ComplianceSum::Means => others.len() as f64,
        ComplianceSum::Sums => 1.0,
    };
    let (mut wp, mut wq) = (0.0, 0.0);
    for (b, &wb) in others.iter().zip(&w) {
        wp += wb * phi(transition_gap(a, b), p.delta_s);
        wq += wb * phi((a.reward - b.reward).abs(), p.delta_r);
    }
    ((wp / n) * (wq / n), w)
}

/// The task compliance `Λ_k = p_k · mean_i λ_i` of a source (§8 step 2), actions valued
/// by `values`, `λ_i` aggregated as `p.compliance` says.
pub fn task_compliance<const D: usize>(
    target: &[Record<D>],
    source: &[Record<D>],
    values: &[f64],
    prior: f64,
    p: &RbtParams,
) -> f64 {
    if target.is_empty() || source.is_empty() {
        return 0.0;
    }
    let sum: f64 = target
        .iter()
        .map(|t| sample_compliance(t, source, values, p, p.compliance).0)
        .sum();
    prior * sum / target.len() as f64
}

/// The unnormalised relevances `ρ_j` of a source's records (§8 step 3), actions valued by
/// `values`.
pub fn relevances<const D: usize>(
    target: &[Record<D>],
    source: &[Record<D>],
    values: &[f64],
    p: &RbtParams,
) -> Vec<f64> {
    if target.is_empty() {
        return vec![0.0; source.len()];
    }
    let mut compliance = Vec::with_capacity(source.len());
    let mut avg_distance = Vec::with_capacity(source.len());
    let mut order: Vec<usize> = (0..target.len()).collect();
    for s in source {
        // (Means or sums: a common factor 1/N_t² that λ̃'s normalisation cancels.)
        let (lambda, w) = sample_compliance(s, target, values, p, ComplianceSum::Means);
        compliance.push(lambda);
        // Average distance: target samples by ascending weight; keep the prefix whose
        // cumulative weight is ≤ μ; divide the kept distances' sum by ι + 1, ι the first
        // position of the largest kept cumulative sum.
        order.sort_by(|&a, &b| w[a].total_cmp(&w[b]));
        let (mut cumulative, mut sum, mut best, mut iota) = (0.0, 0.0, f64::NEG_INFINITY, 0);
        for (pos, &i) in order.iter().enumerate() {
            cumulative += w[i];
            if cumulative > p.mu {
                break;
            }
            sum += distance(&target[i], s, values);
            if cumulative > best {
                best = cumulative;
                iota = pos;
            }
        }
        avg_distance.push(sum / (iota + 1) as f64);
    }
    let total: f64 = compliance.iter().sum();
    compliance
        .iter()
        .zip(&avg_distance)
        .map(|(&l, &d)| {
            let normalised = if total > 0.0 { l / total } else { 0.0 };
            if d == 0.0 {
                0.0
            } else {
                (-((normalised - 1.0) / d).powi(2)).exp()
            }
        })
        .collect()
}

/// Draws `n` indices with replacement with probabilities ∝ `weights` (uniform when they sum
/// to 0 [CHOICE]), one uniform per draw by inversion of the cumulative sum.
fn draw_with_replacement(weights: &[f64], n: usize, rng: &mut ChaCha8Rng) -> Vec<usize> {
    let total: f64 = weights.iter().sum();
    let cumulative: Vec<f64> = if total > 0.0 {
        weights
            .iter()
            .scan(0.0, |c, &w| {
                *c += w / total;
                Some(*c)
            })
            .collect()
    } else {
        (1..=weights.len())
            .map(|i| i as f64 / weights.len() as f64)
            .collect()
    };
    (0..n)
        .map(|_| {
            let u = awfqi::rng::uniform_f64(rng);
            cumulative
                .partition_point(|&c| c <= u)
                .min(weights.len() - 1)
        })
        .collect()
}

/// RBT.
#[derive(Debug, Clone)]
pub struct Rbt<'e, const D: usize = 2> {
    experiment: &'e Experiment<D>,
    run: Episodic<'e, D>,
    params: RbtParams,
}

impl<'e, const D: usize> Rbt<'e, D> {
    /// A fresh run with the reference parameters and the experiment's `n_total`.
    pub fn new(experiment: &'e Experiment<D>) -> Self {
        Self {
            experiment,
            run: Episodic::new(experiment),
            params: RbtParams {
                n_total: experiment.options.rbt_total,
                compliance: experiment.options.rbt_compliance,
                ..RbtParams::published()
            },
        }
    }
}

impl<const D: usize> EpisodicLearner<D> for Rbt<'_, D> {
    fn learn(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        use rayon::prelude::*;
        self.run.collect(rng)?;
        let sources = &self.experiment.sources.sources;
        let target = &self.run.data;
        let prior = 1.0 / sources.len() as f64;
        let p = self.params;
        let values = &self.experiment.domain.action_values;
        // Pure functions of the data: parallel over sources without touching the stream.
        let per_source: Vec<(f64, Vec<f64>)> = sources
            .par_iter()
            .map(|s| {
                (
                    task_compliance(target, &s.records, values, prior, &p),
                    relevances(target, &s.records, values, &p),
                )
            })
            .collect();
        let total: f64 = per_source.iter().map(|(l, _)| l).sum();
        let compliances: Vec<f64> = per_source
            .iter()
            .map(|(l, _)| if total > 0.0 { l / total } else { prior })
            .collect();
        let mut union: Dataset<D> = target.iter().copied().collect();
        let mut transferred = 0;
        for ((s, (_, rho)), &c) in sources.iter().zip(&per_source).zip(&compliances) {
            let n_k = (p.n_total as f64 * c).floor() as usize;
            for j in draw_with_replacement(rho, n_k, rng) {
                union.push(s.records[j]);
            }
            transferred += n_k;
        }
        let options = self.run.options(FqiOptions::plain());
        self.run.q = Some(self.run.fit(&union, &options, rng)?);
        Ok(Diagnostics {
            n_source_samples: Some(transferred),
            compliances: Some(compliances),
            n_eff: Some(union.len()),
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
    use awfqi::model::Transition;
    use rand_core::SeedableRng;

    fn row(v: [f64; 6]) -> Record<2> {
        Transition {
            state: [v[0], v[1]],
            action: v[2] as usize,
            reward: v[3],
            next_state: [v[4], v[5]],
            absorbing: false,
        }
    }

    /// The golden example of spec §8.
    #[test]
    fn golden_example() {
        let target: Vec<Record<2>> = [
            [1.65, 2.15, 0.0, -0.99, 2.65, 2.15],
            [1.81, 1.63, 0.0, -0.85, 2.81, 1.63],
            [1.27, 1.94, 0.0, -0.92, 2.27, 1.94],
            [1.31, 2.68, 1.0, -0.99, 1.31, 3.68],
        ]
        .map(row)
        .to_vec();
        let source: Vec<Record<2>> = [
            [0.21, 0.26, 0.0, -0.84, 1.51, 0.56],
            [0.06, 2.5, 1.0, -1.28, 0.36, 3.8],
            [2.33, 2.61, 0.0, -1.01, 3.63, 2.91],
            [2.94, 2.4, 1.0, -1.4, 3.24, 3.7],
            [1.38, 2.34, 1.0, -1.24, 1.68, 3.64],
        ]
        .map(row)
        .to_vec();
        let p = RbtParams {
            delta_sa: 0.5,
            delta_s: 0.5,
            delta_r: 0.5,
            mu: 0.8,
            n_total: 500,
            compliance: ComplianceSum::Means,
        };
        let values = [0.0, 1.0];
        let lambda = task_compliance(&target, &source, &values, 1.0 / 3.0, &p);
        assert!((lambda - 0.005649023346879907).abs() < 1e-14, "{lambda}");
        // Sums over the 5 source records: the same terms without the two 1/5 factors.
        let sums = RbtParams {
            compliance: ComplianceSum::Sums,
            ..p
        };
        let lambda_sums = task_compliance(&target, &source, &values, 1.0 / 3.0, &sums);
        assert!(
            (lambda_sums - 25.0 * 0.005649023346879907).abs() < 1e-13,
            "{lambda_sums}"
        );
        assert_eq!(
            relevances(&target, &source, &values, &sums),
            relevances(&target, &source, &values, &p)
        );
        let rho = relevances(&target, &source, &values, &p);
        let want = [
            0.9154365889774161,
            0.8447503965500835,
            0.7117785651264192,
            0.7603385213038983,
            0.6035843186291722,
        ];
        for (a, b) in rho.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{rho:?}");
        }
    }

    #[test]
    fn draws_follow_the_weights() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let draws = draw_with_replacement(&[0.0, 1.0, 3.0], 8000, &mut rng);
        let mut counts = [0usize; 3];
        for d in draws {
            counts[d] += 1;
        }
        assert_eq!(counts[0], 0);
        // Binomial(8000, 3/4): std 38.7; allow 5 std.
        assert!((counts[2] as f64 - 6000.0).abs() < 194.0, "{counts:?}");
        let uniform = draw_with_replacement(&[0.0, 0.0], 1000, &mut rng);
        assert!(uniform.contains(&0) && uniform.contains(&1));
    }
}
