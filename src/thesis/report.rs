use crate::float::Real;
use crate::gp::Hyperparameters;
use core::fmt;

/// What one step did, and the warnings a step's numbers call for.
///
/// A kernel that runs on numbers it should not trust still runs: weights that collapsed onto
/// a handful of source records, sources discarded wholesale by the variance rule of §7.3, a
/// GP whose best fit the conditioning policy refused. [`StepReport`] carries the numbers
/// and [`StepReport::warnings`] names what is wrong with them, without allocating, so
/// firmware can log it with `defmt` or `core::fmt` and a host can print it.
///
/// What one step did: the diagnostics of §7.2 step 6 and §12 step 6, and what a user needs
/// to trust them ([`StepReport::warnings`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepReport<T, const I: usize> {
    /// Steps completed, this one included (`k`).
    pub step: usize,
    /// Generative-model queries spent in this step (the budget `n`).
    pub queries: usize,
    /// `|D₀|` after the step (`k·n`): the queries spent in the run.
    pub n_target_samples: usize,
    /// Number of source records.
    pub n_source_samples: usize,
    /// Records the target GP was fitted on (`min(|D₀|, N)`).
    pub gp_points: usize,
    /// The target GP's log marginal likelihood after the search.
    pub gp_log_likelihood: T,
    /// The target GP's hyperparameters after the search.
    pub gp_hyperparameters: Hyperparameters<T, I>,
    /// The diagonal jitter of the target reward GP's factor (the base jitter unless the
    /// factorisation had to escalate; see [`crate::gp::Gp::jitter`]).
    pub gp_jitter: T,
    /// The condition estimate of the target reward GP's factor
    /// ([`crate::gp::Gp::condition_estimate`]).
    pub gp_condition: T,
    /// GP fits of this step whose likelihood optimum the conditioning policy refused, so the
    /// best evaluated point it trusts was kept instead (see
    /// [`crate::gp::Gp::optimize_hyperparameters`]).
    pub gp_refused_fits: usize,
    /// Mean reward weight over all records, target ones (weight 1) included (`wr_mean`).
    pub wr_mean: T,
    /// Effective sample size of the reward weights over all records (`wr_eff`).
    pub wr_eff: T,
    /// Effective sample size of the source records' reward weights alone, out of
    /// `n_source_samples` (the number of equally weighted records they are worth).
    pub wr_source_eff: T,
    /// Source records whose reward weight the variance rule set to 0 (the mean estimator
    /// with the source posterior variance `σ_s² ≥ v_r`, §7.3).
    pub wr_discarded: usize,
    /// Source records whose reward weight reached the cap `w_max`.
    pub wr_capped: usize,
    /// Mean transition weight (1: transition weights are off).
    pub ws_mean: T,
    /// Effective sample size of the transition weights (all records).
    pub ws_eff: T,
    /// Effective sample size of the source records' transition weights alone
    /// (`n_source_samples` when transition weights are off).
    pub ws_source_eff: T,
    /// Source records whose transition weight the variance rule set to 0 (any next-state
    /// coordinate with `σ_s² ≥ v_s`).
    pub ws_discarded: usize,
    /// Source records whose transition weight reached the cap `w_max`.
    pub ws_capped: usize,
    /// How far the greedy verification rollouts of the step's last verified plan fell
    /// short of what its Q-function promised, per discounted rollout step
    /// ([`crate::adaptive::PlanCheck::shortfall`]; 0 for learners that do not verify).
    pub plan_shortfall: T,
    /// The standard deviation of the target's rewards in `D₀` (the shortfall's unit; 0 for
    /// learners that do not verify).
    pub reward_std: T,
}

/// Below this share of the source records, a weights' effective sample size counts as
/// collapsed (5 %: the sources are worth fewer than one record in twenty).
pub const COLLAPSED_SHARE: f64 = 0.05;

/// Above this share of the source records discarded by the variance rule, the weights'
/// noise variance counts as too small for the sources' posterior uncertainty (10 %).
pub const DISCARDED_SHARE: f64 = 0.1;

/// Which weights a [`Warning`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Weights {
    /// The reward weights (`v_r`, [`crate::thesis::AwfqiConfig::weights`]).
    Reward,
    /// The transition weights (`v_s`, [`crate::thesis::AwfqiBuilder::transition_weights`]).
    Transition,
}

/// Something in a [`StepReport`] that calls for attention; `Display` says what and what to
/// try.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Warning<T> {
    /// The source records' weights collapsed: their effective sample size is below
    /// [`COLLAPSED_SHARE`] of the records, so FQI learns from a few of them (or, with a few
    /// at the cap, from those alone). Either the sources disagree with the target almost
    /// everywhere, or the weights' noise variance `v` is small for the rewards' scale.
    WeightsCollapsed {
        /// Reward or transition weights.
        weights: Weights,
        /// Their effective sample size.
        effective: T,
        /// The number of source records.
        records: usize,
        /// How many reached the cap `w_max`.
        capped: usize,
    },
    /// More than [`DISCARDED_SHARE`] of the source records were discarded by the variance
    /// rule (`σ_s² ≥ v`): their source GP is less certain than the noise `v` the estimator
    /// assumes, so they get weight 0 whatever the target says.
    RecordsDiscarded {
        /// Reward or transition weights.
        weights: Weights,
        /// Records discarded.
        discarded: usize,
        /// The number of source records.
        records: usize,
    },
    /// GP fits whose likelihood optimum the conditioning policy refused; each kept the best
    /// point it trusts, a worse fit than the data allow.
    GpOptimumRefused {
        /// How many fits of the step.
        fits: usize,
    },
    /// The step's last verified plan delivered, along its greedy verification rollouts,
    /// less than its Q-function promised by more than
    /// [`SHORTFALL_LIMIT`](crate::adaptive::safeguard::SHORTFALL_LIMIT) standard deviations
    /// of the target's rewards per step: it valued where it went from records the target
    /// contradicts, and its greedy policy may be poor.
    PlanVerifiedShort {
        /// The shortfall per discounted rollout step.
        shortfall: T,
        /// The standard deviation of the target's rewards.
        reward_std: T,
    },
}

impl<T: Real> fmt::Display for Warning<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = |w: &Weights| match w {
            Weights::Reward => "reward",
            Weights::Transition => "transition",
        };
        match self {
            Warning::WeightsCollapsed {
                weights,
                effective,
                records,
                capped,
            } => write!(
                f,
                "{} weights collapsed: the {records} source records are worth {} equally \
                 weighted ones ({capped} at the cap): the target contradicts the sources \
                 almost everywhere, or the weights' noise variance v is small for these \
                 outputs (AwfqiConfig::scaled derives it from the logs)",
                name(weights),
                crate::error::Number(effective.to_f64()),
            ),
            Warning::RecordsDiscarded {
                weights,
                discarded,
                records,
            } => write!(
                f,
                "{} weights: {discarded} of {records} source records discarded by the \
                 variance rule (source posterior variance ≥ v); a larger v, or the \
                 heuristic estimator, keeps them",
                name(weights),
            ),
            Warning::GpOptimumRefused { fits } => write!(
                f,
                "{fits} GP fit(s) kept a worse optimum: the best one needed more jitter or \
                 a worse condition than the conditioning policy trusts; a larger noise \
                 floor (the noise variance's lower bound) avoids it"
            ),
            Warning::PlanVerifiedShort {
                shortfall,
                reward_std,
            } => write!(
                f,
                "the greedy policy verified short of its promise: {} per step below its \
                 Q-function's values (target reward std {}); it relies on source records \
                 the target contradicts where it goes: more queries a step, or more \
                 verification (AdaptiveConfig::safeguard), may be needed",
                crate::error::Number(shortfall.to_f64()),
                crate::error::Number(reward_std.to_f64()),
            ),
        }
    }
}

impl<T: Real, const I: usize> StepReport<T, I> {
    /// The warnings of this step, in a fixed order (reward weights, transition weights,
    /// GP, verified plan), without allocating.
    ///
    /// ```
    /// # use awfqi::thesis::{StepReport, Warning};
    /// # fn log(report: &StepReport<f32, 3>) {
    /// for warning in report.warnings() {
    ///     // e.g. "reward weights collapsed: the 700 source records are worth 15 …"
    ///     println!("step {}: {warning}", report.step);
    /// }
    /// # }
    /// ```
    pub fn warnings(&self) -> Warnings<T> {
        let records = self.n_source_samples;
        let share = |x: f64| x / records.max(1) as f64;
        let collapsed = |effective: T| records > 0 && share(effective.to_f64()) < COLLAPSED_SHARE;
        let discarded = |count: usize| records > 0 && share(count as f64) > DISCARDED_SHARE;
        let mut list = [None; 6];
        if collapsed(self.wr_source_eff) {
            list[0] = Some(Warning::WeightsCollapsed {
                weights: Weights::Reward,
                effective: self.wr_source_eff,
                records,
                capped: self.wr_capped,
            });
        }
        if discarded(self.wr_discarded) {
            list[1] = Some(Warning::RecordsDiscarded {
                weights: Weights::Reward,
                discarded: self.wr_discarded,
                records,
            });
        }
        if collapsed(self.ws_source_eff) {
            list[2] = Some(Warning::WeightsCollapsed {
                weights: Weights::Transition,
                effective: self.ws_source_eff,
                records,
                capped: self.ws_capped,
            });
        }
        if discarded(self.ws_discarded) {
            list[3] = Some(Warning::RecordsDiscarded {
                weights: Weights::Transition,
                discarded: self.ws_discarded,
                records,
            });
        }
        if self.gp_refused_fits > 0 {
            list[4] = Some(Warning::GpOptimumRefused {
                fits: self.gp_refused_fits,
            });
        }
        let limit = T::from_f64(crate::adaptive::safeguard::SHORTFALL_LIMIT);
        if self.reward_std > T::ZERO && self.plan_shortfall > limit * self.reward_std {
            list[5] = Some(Warning::PlanVerifiedShort {
                shortfall: self.plan_shortfall,
                reward_std: self.reward_std,
            });
        }
        Warnings { list, next: 0 }
    }
}

/// The warnings of a [`StepReport`], an iterator over [`Warning`]s held inline.
#[derive(Debug, Clone)]
pub struct Warnings<T> {
    list: [Option<Warning<T>>; 6],
    next: usize,
}

impl<T: Copy> Iterator for Warnings<T> {
    type Item = Warning<T>;

    fn next(&mut self) -> Option<Warning<T>> {
        while let Some(slot) = self.list.get(self.next) {
            self.next += 1;
            if let Some(w) = *slot {
                return Some(w);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;
    use std::vec::Vec;

    fn healthy() -> StepReport<f32, 3> {
        StepReport {
            step: 2,
            queries: 50,
            n_target_samples: 100,
            n_source_samples: 700,
            gp_points: 64,
            gp_log_likelihood: -12.0,
            gp_hyperparameters: Hyperparameters::isotropic(1.0, 1.0, 0.1),
            gp_jitter: 1e-10,
            gp_condition: 40.0,
            gp_refused_fits: 0,
            wr_mean: 0.8,
            wr_eff: 500.0,
            wr_source_eff: 400.0,
            wr_discarded: 3,
            wr_capped: 0,
            ws_mean: 1.0,
            ws_eff: 800.0,
            ws_source_eff: 700.0,
            ws_discarded: 0,
            ws_capped: 0,
            plan_shortfall: 0.1,
            reward_std: 1.0,
        }
    }

    #[test]
    fn a_plan_short_of_its_promise_is_named() {
        let mut r = healthy();
        r.plan_shortfall = 0.6;
        let w: Vec<_> = r.warnings().collect();
        assert_eq!(
            w,
            [Warning::PlanVerifiedShort {
                shortfall: 0.6,
                reward_std: 1.0
            }]
        );
        assert!(
            w[0].to_string()
                .starts_with("the greedy policy verified short")
        );
        r.plan_shortfall = 0.5;
        assert_eq!(r.warnings().count(), 0);
        // Learners that do not verify report a zero std: never a warning.
        r.plan_shortfall = 5.0;
        r.reward_std = 0.0;
        assert_eq!(r.warnings().count(), 0);
    }

    #[test]
    fn a_healthy_step_has_no_warning() {
        assert_eq!(healthy().warnings().count(), 0);
    }

    #[test]
    fn each_threshold_is_named_once_crossed() {
        // 15 of 700 source records (2 %) is below the 5 % of a collapse; 35 (5 %) is not.
        let mut r = healthy();
        r.wr_source_eff = 15.0;
        r.wr_capped = 4;
        let w: Vec<_> = r.warnings().collect();
        assert_eq!(
            w,
            [Warning::WeightsCollapsed {
                weights: Weights::Reward,
                effective: 15.0,
                records: 700,
                capped: 4
            }]
        );
        let text = w[0].to_string();
        assert!(text.starts_with("reward weights collapsed"), "{text}");
        assert!(text.contains("700") && text.contains(" 15 ") && text.contains("4 at the cap"));
        r.wr_source_eff = 35.0;
        assert_eq!(r.warnings().count(), 0);
        // 71 of 700 discarded (10.1 %) is more than 10 %; 70 is not.
        let mut r = healthy();
        r.ws_discarded = 71;
        r.ws_source_eff = 20.0;
        r.gp_refused_fits = 2;
        let w: Vec<_> = r.warnings().collect();
        assert_eq!(
            w,
            [
                Warning::WeightsCollapsed {
                    weights: Weights::Transition,
                    effective: 20.0,
                    records: 700,
                    capped: 0
                },
                Warning::RecordsDiscarded {
                    weights: Weights::Transition,
                    discarded: 71,
                    records: 700
                },
                Warning::GpOptimumRefused { fits: 2 },
            ]
        );
        assert!(w[1].to_string().contains("71 of 700"));
        assert!(w[2].to_string().starts_with("2 GP fit(s)"));
        r.ws_discarded = 70;
        assert_eq!(r.warnings().count(), 2);
    }

    #[test]
    fn no_source_records_no_weight_warnings() {
        let mut r = healthy();
        r.n_source_samples = 0;
        r.wr_source_eff = 0.0;
        r.ws_source_eff = 0.0;
        assert_eq!(r.warnings().count(), 0);
    }
}
