//! The command line's closed choices (`--algorithms`, `--gp-search`, `--criteria`, …):
//! the types live with the code that uses them and know nothing of `clap`; here each gets
//! the name it goes by on the command line and the help line `--help` shows.

use clap::ValueEnum;
use clap::builder::PossibleValue;

use crate::domains::IdealMeans;
use crate::gp_large::fixed::PredictiveVariance;
use crate::identification::{CriterionName, Design, PolicyName};
use crate::joint_q::ForestLayout;
use crate::transfer::algorithms::rbt::ComplianceSum;
use crate::transfer::algorithms::{Algorithm, Variances};
use crate::transfer::gp::{FixedGpUpdate, GpSearch};
use crate::transfer::protocol::FirstStep;
use crate::transfer::score_tables::Mode;

/// `clap::ValueEnum` for a type defined below `commands/`: each member with its name on
/// the command line and its help line.
macro_rules! choices {
    ($($t:ty { $($member:path => $name:literal: $help:literal,)+ })+) => {$(
        impl ValueEnum for $t {
            fn value_variants<'a>() -> &'a [Self] {
                &[$($member),+]
            }

            fn to_possible_value(&self) -> Option<PossibleValue> {
                Some(match self {
                    $($member => PossibleValue::new($name).help($help),)+
                })
            }
        }
    )+};
}

choices! {
    Variances {
        Variances::Published => "published":
            "The published runs' values (Puddle World: v_r = 0.1, v_s = 0.2)",
        Variances::Corrected => "corrected":
            "Puddle World's true noise variances v_r = 0.01, v_s = 0.04",
    }
    IdealMeans {
        IdealMeans::Exact => "exact": "The models' exact mean next states",
        IdealMeans::Sampled => "sampled":
            "One sampled step of each model, drawn once per experiment (the reference's)",
    }
    Mode {
        Mode::Source => "source": "The (s, a) of every source record (thesis setting 1)",
        Mode::Grid => "grid": "The domain's grid × every action (setting 2)",
        Mode::Both => "both": "Grid rows followed by source rows (setting 3)",
    }
    GpSearch {
        GpSearch::Spec => "spec": "Every start optimised on all the data (spec §4.2)",
        GpSearch::Screened => "screened":
            "Starts screened on a 300-point subsample, then refined on all the data",
        GpSearch::Staged => "staged":
            "Screened, then refined on 1 000 points, then on all the data",
    }
    FixedGpUpdate {
        FixedGpUpdate::Incremental => "incremental":
            "Append each step's records to the factor (the refit's posterior to rounding)",
        FixedGpUpdate::Compact => "compact":
            "As incremental, holding only the factor's triangle (≈ 30 % of the memory)",
        FixedGpUpdate::Refit => "refit":
            "Recondition on all target records every step, as the reference does",
    }
    PredictiveVariance {
        PredictiveVariance::Stable => "stable": "K** − ‖L⁻¹k*‖²",
        PredictiveVariance::ExplicitInverse => "explicit-inverse":
            "K** − k*ᵀK⁻¹k* with K⁻¹ formed, negatives set to 0 (scikit-learn ≤ 0.23's)",
    }
    ForestLayout {
        ForestLayout::PerAction => "per-action": "One forest per action (spec §5)",
        ForestLayout::Joint => "joint":
            "One forest over (state, action value); 2-D states only, an ablation",
    }
    FirstStep {
        FirstStep::Uniform => "uniform": "Each action with probability 1/n (spec §3.2)",
        FirstStep::ZeroQ => "zero-q":
            "Ε-greedy around a zero Q-function, as the reference code (an ablation)",
    }
    ComplianceSum {
        ComplianceSum::Means => "means": "Means over a source's records (spec §8)",
        ComplianceSum::Sums => "sums": "Sums, as the published Acrobot RBT runs computed",
    }
    CriterionName {
        CriterionName::Uniform => "uniform": "Uniform over all state-action pairs",
        CriterionName::Variance => "variance": "Inter-MDP variance, from the prior (thesis)",
        CriterionName::Mi => "mi":
            "Mutual information with the spec's binned estimator, from the prior (thesis)",
        CriterionName::MiLiteral => "mi-literal":
            "Mutual information with the thesis's literal eq. 4.14, from the prior",
        CriterionName::MiSkip => "mi-skip":
            "Mutual information from the prior, exactly 0 where the rewards coincide",
        CriterionName::Adaptive => "adaptive":
            "Mutual information recomputed with the current belief before every query",
        CriterionName::AdaptiveVariance => "adaptive-variance":
            "Inter-MDP variance recomputed with the current belief before every query",
    }
    PolicyName {
        PolicyName::Map => "map": "The optimal policy of the MAP candidate (thesis)",
        PolicyName::Belief => "belief": "Greedy in the belief-weighted Q*",
    }
    Design {
        Design::Independent => "independent":
            "Each budget is its own experiment with its own query stream",
        Design::Nested => "nested": "Budget n uses the first n queries of one sequence",
    }
}

/// The algorithms, from their table ([`Algorithm::ALL`], names and descriptions).
impl ValueEnum for Algorithm {
    fn value_variants<'a>() -> &'a [Self] {
        &Algorithm::ALL
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(PossibleValue::new(self.name()).help(self.description()))
    }
}
