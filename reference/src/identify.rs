//! Reference implementation of finite-MDP identification (spec §10): dense tables, `f64`,
//! `Vec`, every formula written as it appears in the spec. Slow on purpose; it exists so
//! that the core's incremental, sparse, log-space and shifted computations can be checked
//! against something obviously right.

// Index loops mirror the subscripts of the spec's formulas; that is the point here.
#![allow(clippy::needless_range_loop)]

use awfqi::model::FiniteMdp;

/// A finite MDP copied into dense tables: `p[s][a][s′]`, `r[s][a]`, `v[s][a]`.
#[derive(Debug, Clone, PartialEq)]
pub struct TabularMdp {
    /// Transition probabilities p(s′ | s, a).
    pub p: Vec<Vec<Vec<f64>>>,
    /// Mean rewards r(s, a).
    pub r: Vec<Vec<f64>>,
    /// Reward variances v(s, a).
    pub v: Vec<Vec<f64>>,
    /// Initial state.
    pub initial_state: usize,
}

impl TabularMdp {
    /// Reads every probability, mean and variance of `mdp` (O(|𝒮|²|𝒜|) calls).
    pub fn from_model<M: FiniteMdp<f64>>(mdp: &M) -> Self {
        let (ns, na) = (mdp.num_states(), mdp.num_actions());
        let p = (0..ns)
            .map(|s| {
                (0..na)
                    .map(|a| {
                        (0..ns)
                            .map(|n| mdp.transition_probability(s, a, n).expect("valid index"))
                            .collect()
                    })
                    .collect()
            })
            .collect();
        let table = |f: &dyn Fn(usize, usize) -> f64| -> Vec<Vec<f64>> {
            (0..ns)
                .map(|s| (0..na).map(|a| f(s, a)).collect())
                .collect()
        };
        Self {
            p,
            r: table(&|s, a| mdp.reward_mean(s, a).expect("valid index")),
            v: table(&|s, a| mdp.reward_variance(s, a).expect("valid index")),
            initial_state: mdp.initial_state(),
        }
    }

    /// |𝒮|.
    pub fn num_states(&self) -> usize {
        self.r.len()
    }

    /// |𝒜|.
    pub fn num_actions(&self) -> usize {
        self.r.first().map_or(0, Vec::len)
    }
}

/// One observation (s, a, s′, r).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// State.
    pub state: usize,
    /// Action.
    pub action: usize,
    /// Observed next state.
    pub next_state: usize,
    /// Observed reward.
    pub reward: f64,
}

/// ln 𝒩(y; μ, v).
pub fn log_normal_density(y: f64, mean: f64, variance: f64) -> f64 {
    -0.5 * (2.0 * std::f64::consts::PI * variance).ln() - (y - mean).powi(2) / (2.0 * variance)
}

/// The batch posterior of spec §10.2 step 4:
/// ln b̃_θ = ln b⁰_θ + Σ_i [ln p_θ(S′ᵢ|sᵢ,aᵢ) + ln 𝒩(Rᵢ; r_θ, v_θ)], normalised; the prior
/// when every b̃_θ is 0.
pub fn posterior(candidates: &[TabularMdp], prior: &[f64], data: &[Observation]) -> Vec<f64> {
    let log_b: Vec<f64> = candidates
        .iter()
        .zip(prior)
        .map(|(m, &b0)| {
            let mut l = b0.ln();
            for o in data {
                l += m.p[o.state][o.action][o.next_state].ln()
                    + log_normal_density(o.reward, m.r[o.state][o.action], m.v[o.state][o.action]);
            }
            l
        })
        .collect();
    let top = log_b.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if top == f64::NEG_INFINITY {
        let total: f64 = prior.iter().sum();
        return prior.iter().map(|b| b / total).collect();
    }
    let unnormalised: Vec<f64> = log_b.iter().map(|l| (l - top).exp()).collect();
    let total: f64 = unnormalised.iter().sum();
    unnormalised.iter().map(|u| u / total).collect()
}

/// `Var_b[x]` = Σ b x² − (Σ b x)² with b normalised, computed two-pass (centred).
pub fn belief_variance(belief: &[f64], x: &[f64]) -> f64 {
    let total: f64 = belief.iter().sum();
    let mean: f64 = belief.iter().zip(x).map(|(b, x)| b * x).sum::<f64>() / total;
    belief
        .iter()
        .zip(x)
        .map(|(b, x)| b * (x - mean).powi(2))
        .sum::<f64>()
        / total
}

/// Normalises to sum 1, or uniform when the sum is 0.
fn normalise(mut w: Vec<f64>) -> Vec<f64> {
    let total: f64 = w.iter().sum();
    if total > 0.0 {
        w.iter_mut().for_each(|x| *x /= total);
    } else {
        let n = w.len() as f64;
        w.iter_mut().for_each(|x| *x = 1.0 / n);
    }
    w
}

/// The variance score of spec §10.3 (index s·|𝒜| + a).
pub fn variance_score(candidates: &[TabularMdp], belief: &[f64]) -> Vec<f64> {
    let m0 = &candidates[0];
    let (ns, na) = (m0.num_states(), m0.num_actions());
    let mut reward_term = Vec::new();
    let mut transition_term = Vec::new();
    for s in 0..ns {
        for a in 0..na {
            let r: Vec<f64> = candidates.iter().map(|m| m.r[s][a]).collect();
            reward_term.push(belief_variance(belief, &r));
            let mut t = 0.0;
            for n in 0..ns {
                let p: Vec<f64> = candidates.iter().map(|m| m.p[s][a][n]).collect();
                t += belief_variance(belief, &p);
            }
            transition_term.push(t);
        }
    }
    let phi = |term: &[f64]| -> Vec<f64> {
        let total: f64 = term.iter().sum();
        if total > 0.0 {
            term.iter().map(|x| x / total).collect()
        } else {
            vec![0.0; term.len()]
        }
    };
    let (pr, pp) = (phi(&reward_term), phi(&transition_term));
    normalise(pr.iter().zip(&pp).map(|(a, b)| a + b).collect())
}

/// I(S′; θ | s, a) of spec §10.3 in closed form, per pair.
pub fn transition_information(candidates: &[TabularMdp], belief: &[f64]) -> Vec<f64> {
    let total: f64 = belief.iter().sum();
    let b: Vec<f64> = belief.iter().map(|x| x / total).collect();
    let m0 = &candidates[0];
    let (ns, na) = (m0.num_states(), m0.num_actions());
    let mut out = Vec::new();
    for s in 0..ns {
        for a in 0..na {
            let mut info = 0.0;
            for n in 0..ns {
                let mean: f64 = candidates
                    .iter()
                    .zip(&b)
                    .map(|(m, w)| w * m.p[s][a][n])
                    .sum();
                for (m, w) in candidates.iter().zip(&b) {
                    let p = m.p[s][a][n];
                    if p > 0.0 && *w > 0.0 {
                        info += w * p * (p / mean).ln();
                    }
                }
            }
            out.push(info);
        }
    }
    out
}

/// The exact reward mutual information h(mixture) − Σ_θ b_θ ½ ln(2πe v_θ) at one pair, with
/// the mixture entropy integrated by the midpoint rule on a fine grid (±12 sd).
pub fn reward_information_exact(means: &[f64], variances: &[f64], belief: &[f64]) -> f64 {
    let total: f64 = belief.iter().sum();
    let sd_max = variances.iter().copied().fold(0.0, f64::max).sqrt();
    let lo = means.iter().copied().fold(f64::INFINITY, f64::min) - 12.0 * sd_max;
    let hi = means.iter().copied().fold(f64::NEG_INFINITY, f64::max) + 12.0 * sd_max;
    let steps = 200_000;
    let dx = (hi - lo) / steps as f64;
    let mut h = 0.0;
    for i in 0..steps {
        let x = lo + (i as f64 + 0.5) * dx;
        let f: f64 = means
            .iter()
            .zip(variances)
            .zip(belief)
            .map(|((&m, &v), &b)| b / total * log_normal_density(x, m, v).exp())
            .sum();
        if f > 0.0 {
            h -= f * f.ln() * dx;
        }
    }
    let conditional: f64 = variances
        .iter()
        .zip(belief)
        .map(|(&v, &b)| {
            b / total * 0.5 * (2.0 * std::f64::consts::PI * std::f64::consts::E * v).ln()
        })
        .sum();
    h - conditional
}

/// The plug-in entropy −Σ p̂ ln p̂ of `samples` binned into `bins` equal bins of `width`
/// from `lo` (outliers to the edge bins), plus ln `width`: spec §10.3 steps 2–4.
pub fn binned_differential_entropy(samples: &[f64], lo: f64, width: f64, bins: usize) -> f64 {
    let mut counts = vec![0usize; bins];
    for &x in samples {
        let k = ((x - lo) / width).floor().clamp(0.0, (bins - 1) as f64) as usize;
        counts[k] += 1;
    }
    let m = samples.len() as f64;
    let h: f64 = counts
        .iter()
        .filter(|&&c| c > 0)
        .map(|&c| {
            let p = c as f64 / m;
            -p * p.ln()
        })
        .sum();
    h + width.ln()
}

/// The mutual-information score with exact reward information (no Monte Carlo): the
/// quantity the core's binned estimator approximates.
pub fn mutual_information_score_exact(candidates: &[TabularMdp], belief: &[f64]) -> Vec<f64> {
    let info_p = transition_information(candidates, belief);
    let m0 = &candidates[0];
    let (ns, na) = (m0.num_states(), m0.num_actions());
    let mut w = Vec::new();
    for s in 0..ns {
        for a in 0..na {
            let means: Vec<f64> = candidates.iter().map(|m| m.r[s][a]).collect();
            let vars: Vec<f64> = candidates.iter().map(|m| m.v[s][a]).collect();
            let info_r = reward_information_exact(&means, &vars, belief).max(0.0);
            w.push(info_p[s * na + a] + info_r);
        }
    }
    normalise(w)
}

/// Value iteration as spec §10.2 states it (synchronous sweeps from V ≡ 0, stop when
/// ‖V_{k+1} − V_k‖∞ < `tolerance` or after `max_sweeps`). Returns `(V, Q[s][a])`.
pub fn value_iteration(
    mdp: &TabularMdp,
    gamma: f64,
    tolerance: f64,
    max_sweeps: usize,
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let (ns, na) = (mdp.num_states(), mdp.num_actions());
    let mut v = vec![0.0; ns];
    let mut q = vec![vec![0.0; na]; ns];
    for _ in 0..max_sweeps {
        for s in 0..ns {
            for a in 0..na {
                q[s][a] = mdp.r[s][a] + gamma * (0..ns).map(|n| mdp.p[s][a][n] * v[n]).sum::<f64>();
            }
        }
        let next: Vec<f64> = q
            .iter()
            .map(|row| row.iter().copied().fold(f64::NEG_INFINITY, f64::max))
            .collect();
        let change = next
            .iter()
            .zip(&v)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        v = next;
        if change < tolerance {
            break;
        }
    }
    (v, q)
}

/// The greedy policy of Q, ties to the smallest action.
pub fn greedy(q: &[Vec<f64>]) -> Vec<usize> {
    q.iter()
        .map(|row| {
            let mut best = 0;
            for (a, &x) in row.iter().enumerate() {
                if x > row[best] {
                    best = a;
                }
            }
            best
        })
        .collect()
}

/// V^π by solving (I − γ P_π) V = r_π directly (Gaussian elimination with partial
/// pivoting): an independent check of the core's iterative evaluation.
pub fn policy_value_direct(mdp: &TabularMdp, policy: &[usize], gamma: f64) -> Vec<f64> {
    let n = mdp.num_states();
    let mut a = vec![vec![0.0; n + 1]; n];
    for s in 0..n {
        let act = policy[s];
        for t in 0..n {
            a[s][t] = if s == t { 1.0 } else { 0.0 } - gamma * mdp.p[s][act][t];
        }
        a[s][n] = mdp.r[s][act];
    }
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .expect("non-empty");
        a.swap(col, pivot);
        for row in 0..n {
            if row != col {
                let f = a[row][col] / a[col][col];
                for k in col..=n {
                    a[row][k] -= f * a[col][k];
                }
            }
        }
    }
    (0..n).map(|s| a[s][n] / a[s][s]).collect()
}

/// The belief-weighted greedy policy: argmax_a Σ_θ b_θ Q_θ(s, a), ties to the smallest
/// action.
pub fn belief_weighted_policy(q_tables: &[Vec<Vec<f64>>], belief: &[f64]) -> Vec<usize> {
    let total: f64 = belief.iter().sum();
    let ns = q_tables[0].len();
    let na = q_tables[0][0].len();
    let mixed: Vec<Vec<f64>> = (0..ns)
        .map(|s| {
            (0..na)
                .map(|a| {
                    q_tables
                        .iter()
                        .zip(belief)
                        .map(|(q, b)| b / total * q[s][a])
                        .sum()
                })
                .collect()
        })
        .collect();
    greedy(&mixed)
}
