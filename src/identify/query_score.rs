use super::belief::positive_variance;
use super::{belief_total, dimensions};
use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::FiniteMdp;
use crate::rng;
use rand_core::Rng;

/// Largest number of histogram bins of the reward-entropy estimator (the histogram lives
/// on the stack: `4·MAX_BINS` = 512 bytes).
pub const MAX_BINS: usize = 128;

/// The score functions of spec §10.3: a distribution over state-action pairs that says
/// where querying the target is most useful for telling the candidates apart.
///
/// Every score is written into caller storage `out` with one entry per pair, index
/// `s·|𝒜| + a`, and is a distribution: non-negative and summing to 1 (up to rounding).
/// When a criterion finds no pair informative (all raw scores 0) the score is uniform,
/// spec §10.3's fall-back. The belief is passed as probabilities (one per candidate, not
/// necessarily normalised): the prior b⁰ for the thesis's one-shot design, the current
/// belief for adaptive scoring.
///
/// Storage: `out` only (|𝒮|·|𝒜| entries), plus a [`MAX_BINS`]-entry `u32` histogram on
/// the stack for the mutual-information score.
///
/// Which score to compute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Criterion {
    /// φ(s, a) = 1/(|𝒮||𝒜|): the baseline.
    Uniform,
    /// Inter-MDP variance of rewards plus that of transition probabilities, each
    /// normalised separately (thesis eqs. 4.6–4.8).
    Variance,
    /// Mutual information between the candidate identity and the observation (thesis
    /// eqs. 4.9–4.15): closed form for transitions, a binned Monte-Carlo estimate for
    /// rewards.
    MutualInformation(MiConfig),
}

/// How the mixture entropy h(R | s, a) enters the reward mutual information.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RewardEntropy {
    /// Spec §10.3 (the default): Î_R = max(0, Ĥ + ln Δ − Σ_θ b_θ ½ ln(2πe v_θ)), a
    /// differential-entropy estimate with the bin width Δ, clipped at 0.
    #[default]
    Differential,
    /// The thesis's eq. 4.14 literally: Î_R = Ĥ − Σ_θ b_θ ½ ln v_θ, without ln Δ, without
    /// ½ ln 2πe and without clipping. Because the score is normalised by a sum, the
    /// dropped constants change the distribution (spec §14 item 18). A pair whose total
    /// I_P + Î_R is negative gets weight 0.
    Literal,
}

/// Configuration of the mutual-information score.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MiConfig {
    /// Monte-Carlo draws m per state-action pair (default 1000, ≥ 1).
    pub samples: usize,
    /// Number of equal-width bins B shared by all pairs (default 30, 1..=[`MAX_BINS`]).
    pub bins: usize,
    /// Which reward-entropy formula (default: spec §10.3's).
    pub reward_entropy: RewardEntropy,
    /// When `true`, a pair at which every candidate with positive belief has the same
    /// reward mean and variance gets Î_R = 0 exactly — its true mutual information —
    /// without drawing, instead of the estimator's noise (≈ 0.006 nats on average for
    /// the spec's defaults). This changes the score (the estimator's noise is no longer
    /// spread over uninformative pairs) and makes it much cheaper where few pairs are
    /// informative. Default `false`, the spec's estimator.
    pub skip_identical_rewards: bool,
}

impl Default for MiConfig {
    fn default() -> Self {
        Self {
            samples: 1000,
            bins: 30,
            reward_entropy: RewardEntropy::Differential,
            skip_identical_rewards: false,
        }
    }
}

impl MiConfig {
    fn validate(&self) -> Result<()> {
        if self.samples == 0 || self.samples > u32::MAX as usize {
            return Err(Error::InvalidParameter {
                parameter: "samples",
            });
        }
        if self.bins == 0 {
            return Err(Error::InvalidParameter { parameter: "bins" });
        }
        if self.bins > MAX_BINS {
            return Err(Error::CapacityExceeded { capacity: MAX_BINS });
        }
        Ok(())
    }
}

/// Checks `out` against the number of pairs: shorter is [`Error::CapacityExceeded`],
/// longer is [`Error::InvalidParameter`] naming `scores`.
fn check_out<T>(out: &[T], pairs: usize) -> Result<()> {
    crate::planning::check_len(out.len(), pairs, "scores")
}

/// Normalises non-negative `out` to sum 1, or makes it uniform when it sums to 0.
fn normalise_or_uniform<T: Real>(out: &mut [T]) {
    let total: T = out.iter().copied().sum();
    if total > T::ZERO && total.is_finite() {
        out.iter_mut().for_each(|x| *x /= total);
    } else {
        let u = T::ONE / T::from_usize(out.len());
        out.iter_mut().for_each(|x| *x = u);
    }
}

/// The uniform score 1/(|𝒮||𝒜|) into all of `out`.
///
/// Errors: an empty `out` ([`Error::EmptyData`]).
pub fn uniform_score<T: Real>(out: &mut [T]) -> Result<()> {
    if out.is_empty() {
        return Err(Error::EmptyData);
    }
    let u = T::ONE / T::from_usize(out.len());
    out.iter_mut().for_each(|x| *x = u);
    Ok(())
}

/// Var_b[x_θ] = Σ b x² / W − (Σ b x / W)², computed on x_θ − x₀ so that values on which
/// all candidates agree give exactly 0 (no rounding residue that normalisation would
/// blow up into a spurious distribution). Clamped at 0.
struct ShiftedVariance<T> {
    reference: Option<T>,
    sum: T,
    sum_sq: T,
}

impl<T: Real> ShiftedVariance<T> {
    fn new() -> Self {
        Self {
            reference: None,
            sum: T::ZERO,
            sum_sq: T::ZERO,
        }
    }

    fn push(&mut self, weight: T, x: T) {
        let r = *self.reference.get_or_insert(x);
        let d = x - r;
        self.sum += weight * d;
        self.sum_sq += weight * d * d;
    }

    fn variance(&self, total_weight: T) -> T {
        let m = self.sum / total_weight;
        (self.sum_sq / total_weight - m * m).max(T::ZERO)
    }
}

/// Inter-MDP variance of the reward means at one pair.
fn reward_variance_term<T: Real, M: FiniteMdp<T>>(
    candidates: &[M],
    belief: &[T],
    total: T,
    s: usize,
    a: usize,
) -> Result<T> {
    let mut acc = ShiftedVariance::new();
    for (mdp, &b) in candidates.iter().zip(belief) {
        let r = crate::error::ensure_finite(mdp.reward_mean(s, a)?, "reward_mean")?;
        acc.push(b, r);
    }
    Ok(acc.variance(total))
}

/// Visits every s′ reachable from (s, a) under some candidate exactly once (the first
/// candidate listing it), handing `visit` the successor and a closure-free way to read
/// all candidates' probabilities for it.
fn for_each_union_successor<T: Real, M: FiniteMdp<T>, F: FnMut(usize) -> Result<()>>(
    candidates: &[M],
    s: usize,
    a: usize,
    mut visit: F,
) -> Result<()> {
    let mut failure: Option<Error> = None;
    for (k, mdp) in candidates.iter().enumerate() {
        mdp.for_each_successor(s, a, |next, p| {
            if failure.is_some() || p == T::ZERO {
                return;
            }
            // Skip s′ already visited through an earlier candidate.
            let mut seen = false;
            for earlier in candidates.iter().take(k) {
                match earlier.transition_probability(s, a, next) {
                    Ok(q) if q != T::ZERO => {
                        seen = true;
                        break;
                    }
                    Ok(_) => {}
                    Err(e) => {
                        failure = Some(e);
                        return;
                    }
                }
            }
            if !seen {
                if let Err(e) = visit(next) {
                    failure = Some(e);
                }
            }
        })?;
        if let Some(e) = failure {
            return Err(e);
        }
    }
    Ok(())
}

/// Σ_{s′} Var_b[p_θ(s′|s, a)] at one pair, summed over the union of successors.
fn transition_variance_term<T: Real, M: FiniteMdp<T>>(
    candidates: &[M],
    belief: &[T],
    total: T,
    s: usize,
    a: usize,
) -> Result<T> {
    let mut sum = T::ZERO;
    for_each_union_successor(candidates, s, a, |next| {
        let mut acc = ShiftedVariance::new();
        for (mdp, &b) in candidates.iter().zip(belief) {
            let p = mdp.transition_probability(s, a, next)?;
            acc.push(b, crate::error::ensure_finite(p, "transition_probability")?);
        }
        sum += acc.variance(total);
        Ok(())
    })?;
    Ok(sum)
}

/// The variance-based score (thesis eqs. 4.6–4.8, spec §10.3): φ_r + φ_p, each term
/// normalised over all pairs (a term whose total is 0 is dropped), then normalised to a
/// distribution. Deterministic: uses no randomness.
///
/// Errors: see [`compute_score`].
pub fn variance_score<T: Real, M: FiniteMdp<T>>(
    candidates: &[M],
    belief: &[T],
    out: &mut [T],
) -> Result<()> {
    let (_, actions, pairs) = dimensions(candidates)?;
    let total = belief_total(belief, candidates.len())?;
    check_out(out, pairs)?;
    // Pass 1: transition terms into `out`, totals of both terms.
    let (mut reward_total, mut transition_total) = (T::ZERO, T::ZERO);
    for (i, slot) in out.iter_mut().enumerate() {
        let (s, a) = (i / actions, i % actions);
        reward_total += reward_variance_term(candidates, belief, total, s, a)?;
        let p = transition_variance_term(candidates, belief, total, s, a)?;
        transition_total += p;
        *slot = p;
    }
    // Pass 2: φ_r + φ_p, recomputing the cheap reward term.
    for (i, slot) in out.iter_mut().enumerate() {
        let (s, a) = (i / actions, i % actions);
        let phi_p = if transition_total > T::ZERO {
            *slot / transition_total
        } else {
            T::ZERO
        };
        let phi_r = if reward_total > T::ZERO {
            reward_variance_term(candidates, belief, total, s, a)? / reward_total
        } else {
            T::ZERO
        };
        *slot = phi_r + phi_p;
    }
    normalise_or_uniform(out);
    Ok(())
}

/// I(S′; θ | s, a) = Σ_θ b_θ Σ_{s′} p_θ(s′) ln(p_θ(s′)/p̄(s′)) in closed form, 0 ln 0 = 0.
/// A successor on which every candidate with mass agrees contributes exactly 0.
fn transition_information<T: Real, M: FiniteMdp<T>>(
    candidates: &[M],
    belief: &[T],
    total: T,
    s: usize,
    a: usize,
) -> Result<T> {
    let mut info = T::ZERO;
    for_each_union_successor(candidates, s, a, |next| {
        let mut mean = T::ZERO;
        let mut first: Option<T> = None;
        let mut all_agree = true;
        for (mdp, &b) in candidates.iter().zip(belief) {
            if b == T::ZERO {
                continue;
            }
            let p = mdp.transition_probability(s, a, next)?;
            let p = crate::error::ensure_finite(p, "transition_probability")?;
            all_agree &= *first.get_or_insert(p) == p;
            mean += b * p;
        }
        if all_agree {
            return Ok(());
        }
        let mean = mean / total;
        for (mdp, &b) in candidates.iter().zip(belief) {
            let p = mdp.transition_probability(s, a, next)?;
            if b > T::ZERO && p > T::ZERO {
                info += b / total * p * (p / mean).ln();
            }
        }
        Ok(())
    })?;
    Ok(info.max(T::ZERO))
}

/// Common histogram range of spec §10.3: [min r − 4√v_max, max r + 4√v_max] over all
/// candidates and pairs. Returns (lower edge, bin width).
fn common_bins<T: Real, M: FiniteMdp<T>>(
    candidates: &[M],
    pairs: usize,
    actions: usize,
    bins: usize,
) -> Result<(T, T)> {
    let (mut lo, mut hi, mut v_max) = (T::INFINITY, T::NEG_INFINITY, T::ZERO);
    for i in 0..pairs {
        let (s, a) = (i / actions, i % actions);
        for mdp in candidates {
            let r = crate::error::ensure_finite(mdp.reward_mean(s, a)?, "reward_mean")?;
            let v = positive_variance(mdp.reward_variance(s, a)?)?;
            lo = lo.min(r);
            hi = hi.max(r);
            v_max = v_max.max(v);
        }
    }
    let four_sd = T::from_f64(4.0) * v_max.sqrt();
    let (lo, hi) = (lo - four_sd, hi + four_sd);
    let width = (hi - lo) / T::from_usize(bins);
    if width.is_finite() && width > T::ZERO && lo.is_finite() {
        Ok((lo, width))
    } else {
        Err(Error::NonFinite {
            parameter: "reward_mean",
        })
    }
}

/// Whether every candidate with positive belief has the same reward mean and variance.
fn rewards_identical<T: Real, M: FiniteMdp<T>>(
    candidates: &[M],
    belief: &[T],
    s: usize,
    a: usize,
) -> Result<bool> {
    let mut first: Option<(T, T)> = None;
    for (mdp, &b) in candidates.iter().zip(belief) {
        if b > T::ZERO {
            let rv = (mdp.reward_mean(s, a)?, mdp.reward_variance(s, a)?);
            if *first.get_or_insert(rv) != rv {
                return Ok(false);
            }
        }
    }
    Ok(true)
}

/// θ ~ b for a checked belief with total `total`: one `u64`, as [`rng::categorical`] but
/// without re-validating the weights on every draw (this is the estimator's inner loop).
fn pick<T: Real, R: Rng + ?Sized>(belief: &[T], total: T, rng: &mut R) -> usize {
    let target = rng::uniform::<T, R>(rng) * total;
    let mut cumulative = T::ZERO;
    let mut last_positive = 0;
    for (k, &b) in belief.iter().enumerate() {
        if b > T::ZERO {
            cumulative += b;
            last_positive = k;
            if target < cumulative {
                return k;
            }
        }
    }
    last_positive
}

/// The binned Monte-Carlo estimate of the reward mutual information at one pair.
#[allow(clippy::too_many_arguments)]
fn reward_information<T: Real, M: FiniteMdp<T>, R: Rng + ?Sized>(
    candidates: &[M],
    belief: &[T],
    total: T,
    config: &MiConfig,
    (lo, width): (T, T),
    s: usize,
    a: usize,
    rng: &mut R,
) -> Result<T> {
    let mut counts = [0u32; MAX_BINS];
    let counts = counts
        .get_mut(..config.bins)
        .ok_or(Error::CapacityExceeded { capacity: MAX_BINS })?;
    let last = T::from_usize(config.bins - 1);
    for _ in 0..config.samples {
        let mdp = candidates
            .get(pick(belief, total, rng))
            .ok_or(Error::OutOfRange {
                parameter: "belief",
            })?;
        let mean = mdp.reward_mean(s, a)?;
        let sd = positive_variance(mdp.reward_variance(s, a)?)?.sqrt();
        let r = rng::normal(rng, mean, sd)?;
        // Samples outside the range go to the edge bins. Clamping before the cast makes
        // the truncation a floor (the value is non-negative) without libm's `floor`.
        let position = ((r - lo) / width).clamp_to(T::ZERO, last);
        let bin = position.to_f64() as usize;
        if let Some(c) = counts.get_mut(bin) {
            *c += 1;
        }
    }
    let m = T::from_usize(config.samples);
    let plug_in: T = counts
        .iter()
        .filter(|&&c| c > 0)
        .map(|&c| {
            let p = T::from_usize(c as usize) / m;
            -(p * p.ln())
        })
        .sum();
    let half = T::from_f64(0.5);
    let mut conditional = T::ZERO;
    for (mdp, &b) in candidates.iter().zip(belief) {
        if b > T::ZERO {
            conditional += b / total * half * mdp.reward_variance(s, a)?.ln();
        }
    }
    Ok(match config.reward_entropy {
        RewardEntropy::Differential => {
            let two_pi_e = T::from_f64(2.0 * core::f64::consts::PI * core::f64::consts::E);
            (plug_in + width.ln() - conditional - half * two_pi_e.ln()).max(T::ZERO)
        }
        RewardEntropy::Literal => plug_in - conditional,
    })
}

/// The mutual-information score (thesis eqs. 4.9–4.15, spec §10.3):
/// φ ∝ I_P + Î_R with I_P in closed form and Î_R the binned Monte-Carlo estimate with
/// `config.samples` draws and `config.bins` common bins.
///
/// Randomness: pairs are visited in index order; at each, unless skipped (see
/// [`MiConfig::skip_identical_rewards`]), `samples` times one `u64` for a draw of θ from
/// the belief then one [`rng::normal`] reward.
/// So the same generator state gives the same score.
///
/// Errors: see [`compute_score`].
pub fn mutual_information_score<T: Real, M: FiniteMdp<T>, R: Rng + ?Sized>(
    candidates: &[M],
    belief: &[T],
    config: &MiConfig,
    rng: &mut R,
    out: &mut [T],
) -> Result<()> {
    config.validate()?;
    let (_, actions, pairs) = dimensions(candidates)?;
    let total = belief_total(belief, candidates.len())?;
    check_out(out, pairs)?;
    let bins = common_bins(candidates, pairs, actions, config.bins)?;
    for (i, slot) in out.iter_mut().enumerate() {
        let (s, a) = (i / actions, i % actions);
        let info_p = transition_information(candidates, belief, total, s, a)?;
        let info_r =
            if config.skip_identical_rewards && rewards_identical(candidates, belief, s, a)? {
                T::ZERO
            } else {
                reward_information(candidates, belief, total, config, bins, s, a, rng)?
            };
        *slot = (info_p + info_r).max(T::ZERO);
    }
    normalise_or_uniform(out);
    Ok(())
}

/// Computes the score of `criterion` for the belief `belief` into `out`.
///
/// Errors (nothing is written for the first five):
/// - no candidates, or candidates of different |𝒮| or |𝒜|;
/// - `belief` not one finite, non-negative entry per candidate with a positive sum
///   ([`Error::InvalidParameter`] / [`Error::NonFinite`] naming `belief`);
/// - `out` shorter than |𝒮|·|𝒜| ([`Error::CapacityExceeded`]) or longer
///   ([`Error::InvalidParameter`] naming `scores`);
/// - a bad [`MiConfig`] (`samples == 0`, `bins == 0`, `bins > MAX_BINS`);
/// - candidate models with non-finite values or a non-positive reward variance (for
///   the mutual-information score);
/// - errors of the candidate models (then `out` may be partly written).
pub fn compute_score<T: Real, M: FiniteMdp<T>, R: Rng + ?Sized>(
    criterion: &Criterion,
    candidates: &[M],
    belief: &[T],
    rng: &mut R,
    out: &mut [T],
) -> Result<()> {
    match criterion {
        Criterion::Uniform => {
            let (_, _, pairs) = dimensions(candidates)?;
            belief_total(belief, candidates.len())?;
            check_out(out, pairs)?;
            uniform_score(out)
        }
        Criterion::Variance => variance_score(candidates, belief, out),
        Criterion::MutualInformation(config) => {
            mutual_information_score(candidates, belief, config, rng, out)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::env::GridWorld;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    const PRIOR: [f64; 4] = [0.25; 4];

    fn assert_distribution(score: &[f64]) {
        assert!(score.iter().all(|&x| x >= 0.0 && x.is_finite()));
        let total: f64 = score.iter().sum();
        assert!((total - 1.0).abs() < 1e-12, "sums to {total}");
    }

    #[test]
    fn variance_score_puts_equal_mass_on_the_goal_cells_only() {
        let c = GridWorld::<f64>::thesis_candidates(false);
        let mut out = [0.0; 400];
        variance_score(&c, &PRIOR, &mut out).unwrap();
        assert_distribution(&out);
        // Reward variance at a goal is 1/4·(1 − 1/4) = 3/16 for all 16 goal pairs; the
        // transitions are shared, so the transition term is dropped: 1/16 each.
        for (i, &x) in out.iter().enumerate() {
            let is_goal = c.iter().any(|g| g.goal() == i / 4);
            let want = if is_goal { 1.0 / 16.0 } else { 0.0 };
            assert!((x - want).abs() < 1e-15, "pair {i}: {x}");
        }
    }

    #[test]
    fn variance_score_with_absorbing_goals_adds_the_transition_term() {
        // At a goal g_k under an action that leaves it, candidate k stays (p=1 at g_k)
        // and the others move to the neighbour n (p=1 at n). Σ_{s'} Var = 2·(3/16) =
        // 3/8 for the 4 leaving actions... unless the move hits a wall (then all stay).
        let c = GridWorld::<f64>::thesis_candidates(true);
        let mut out = [0.0; 400];
        variance_score(&c, &PRIOR, &mut out).unwrap();
        assert_distribution(&out);
        // Leaving moves: (9,9): x−1, y−1 → 2; (9,0): x−1, y+1 → 2; (0,9): x+1, y−1 → 2;
        // (5,5): all 4. Total 10 pairs with equal transition variance 3/8.
        let leaving = [
            (99, 1),
            (99, 3),
            (9, 1),
            (9, 2),
            (90, 0),
            (90, 3),
            (55, 0),
            (55, 1),
            (55, 2),
            (55, 3),
        ];
        for (i, &x) in out.iter().enumerate() {
            let (s, a) = (i / 4, i % 4);
            let is_goal = c.iter().any(|g| g.goal() == s);
            let phi_r = if is_goal { 1.0 / 16.0 } else { 0.0 };
            let phi_p = if leaving.contains(&(s, a)) { 0.1 } else { 0.0 };
            assert!(
                (x - (phi_r + phi_p) / 2.0).abs() < 1e-15,
                "pair ({s},{a}): {x}"
            );
        }
    }

    #[test]
    fn uniform_score_is_flat() {
        let c = GridWorld::<f32>::thesis_candidates(false);
        let mut out = [0.0f32; 400];
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        compute_score(&Criterion::Uniform, &c, &[0.25f32; 4], &mut rng, &mut out).unwrap();
        assert!(out.iter().all(|&x| x == 1.0 / 400.0));
    }

    #[test]
    fn mutual_information_concentrates_on_goals_and_is_a_distribution() {
        let c = GridWorld::<f64>::thesis_candidates(false);
        let mut out = [0.0; 400];
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        mutual_information_score(&c, &PRIOR, &MiConfig::default(), &mut rng, &mut out).unwrap();
        assert_distribution(&out);
        let goal_mass: f64 = (0..400)
            .filter(|i| c.iter().any(|g| g.goal() == i / 4))
            .map(|i| out[i])
            .sum();
        // 16 goal pairs of 400: far above their uniform share of 4%.
        assert!(goal_mass > 0.3, "goal mass {goal_mass}");
        // With the exact shortcut only the goal pairs remain.
        let config = MiConfig {
            skip_identical_rewards: true,
            ..MiConfig::default()
        };
        mutual_information_score(&c, &PRIOR, &config, &mut rng, &mut out).unwrap();
        assert_distribution(&out);
        for (i, &x) in out.iter().enumerate() {
            let is_goal = c.iter().any(|g| g.goal() == i / 4);
            assert_eq!(x > 0.0, is_goal, "pair {i}");
        }
    }

    #[test]
    fn literal_variant_is_a_distribution_and_nearly_flat() {
        let c = GridWorld::<f64>::thesis_candidates(false);
        let mut out = [0.0; 400];
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let config = MiConfig {
            reward_entropy: RewardEntropy::Literal,
            ..MiConfig::default()
        };
        mutual_information_score(&c, &PRIOR, &config, &mut rng, &mut out).unwrap();
        assert_distribution(&out);
        // Every pair keeps the large constant Ĥ − ½ ln v ≈ 3.2, so the largest weight is
        // within a small factor of uniform (spec §14 item 18).
        let max = out.iter().copied().fold(0.0, f64::max);
        assert!(max < 2.0 / 400.0, "max {max}");
    }

    #[test]
    fn transition_information_matches_the_closed_form() {
        // Absorbing goals, uniform prior: at a leaving pair of goal k, candidate k puts
        // p=1 on g_k, the others p=1 on the neighbour: p̄ = (1/4, 3/4).
        // I = 1/4 ln 4 + 3/4 ln(4/3).
        let c = GridWorld::<f64>::thesis_candidates(true);
        let info = transition_information(&c, &PRIOR, 1.0, 55, 0).unwrap();
        let want = 0.25 * 4f64.ln() + 0.75 * (4.0f64 / 3.0).ln();
        assert!((info - want).abs() < 1e-14, "{info} vs {want}");
        assert_eq!(transition_information(&c, &PRIOR, 1.0, 0, 0).unwrap(), 0.0);
    }

    #[test]
    fn same_seed_same_score_and_bad_inputs_are_rejected() {
        let c = GridWorld::<f32>::thesis_candidates(false);
        let b = [0.25f32; 4];
        let mut x = [0.0f32; 400];
        let mut y = [0.0f32; 400];
        let config = Criterion::MutualInformation(MiConfig {
            samples: 50,
            ..MiConfig::default()
        });
        compute_score(&config, &c, &b, &mut ChaCha8Rng::seed_from_u64(4), &mut x).unwrap();
        compute_score(&config, &c, &b, &mut ChaCha8Rng::seed_from_u64(4), &mut y).unwrap();
        assert_eq!(x, y);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut small = [7.0f32; 399];
        assert_eq!(
            compute_score(&Criterion::Variance, &c, &b, &mut rng, &mut small),
            Err(Error::CapacityExceeded { capacity: 399 })
        );
        assert!(small.iter().all(|&v| v == 7.0));
        let mut big = [7.0f32; 401];
        assert_eq!(
            compute_score(&Criterion::Uniform, &c, &b, &mut rng, &mut big),
            Err(Error::InvalidParameter {
                parameter: "scores"
            })
        );
        for bad in [
            [0.0f32; 4],
            [0.5, -0.5, 0.5, 0.5],
            [f32::NAN, 0.0, 0.0, 1.0],
        ] {
            assert!(compute_score(&Criterion::Variance, &c, &bad, &mut rng, &mut x).is_err());
        }
        assert_eq!(
            compute_score(&Criterion::Variance, &c, &b[..3], &mut rng, &mut x),
            Err(Error::InvalidParameter {
                parameter: "belief"
            })
        );
        for cfg in [
            MiConfig {
                samples: 0,
                ..MiConfig::default()
            },
            MiConfig {
                bins: 0,
                ..MiConfig::default()
            },
        ] {
            assert!(mutual_information_score(&c, &b, &cfg, &mut rng, &mut x).is_err());
        }
        assert_eq!(
            mutual_information_score(
                &c,
                &b,
                &MiConfig {
                    bins: MAX_BINS + 1,
                    ..MiConfig::default()
                },
                &mut rng,
                &mut x
            ),
            Err(Error::CapacityExceeded { capacity: MAX_BINS })
        );
        let none: [GridWorld<f32>; 0] = [];
        assert_eq!(
            compute_score(&Criterion::Variance, &none, &[], &mut rng, &mut x),
            Err(Error::EmptyData)
        );
    }

    #[test]
    fn a_sharp_belief_has_no_informative_pair_and_falls_back_to_uniform() {
        let c = GridWorld::<f64>::thesis_candidates(false);
        let mut out = [0.0; 400];
        variance_score(&c, &[0.0, 1.0, 0.0, 0.0], &mut out).unwrap();
        assert!(out.iter().all(|&x| (x - 1.0 / 400.0).abs() < 1e-18));
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let config = MiConfig {
            skip_identical_rewards: true,
            ..MiConfig::default()
        };
        mutual_information_score(&c, &[0.0, 1.0, 0.0, 0.0], &config, &mut rng, &mut out).unwrap();
        assert!(out.iter().all(|&x| (x - 1.0 / 400.0).abs() < 1e-18));
    }
}
