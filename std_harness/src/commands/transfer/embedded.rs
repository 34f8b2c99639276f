//! The options of the core's algorithms: `awfqi-embedded`'s FQI approximator
//! ([`EmbeddedArgs`]) and `awfqi-adaptive`'s approximator and loop ([`AdaptiveArgs`]),
//! each under its own heading of every transfer command's `--help`.

use clap::{Args, ValueEnum};

use crate::transfer::algorithms::embedded::adaptive::{AdaptiveOptions, GpCapacity};
use crate::transfer::algorithms::embedded::{
    ADAPTIVE_SWEEP_CELLS, ADAPTIVE_TILES, ADAPTIVE_TILINGS, ADAPTIVE_TREE_NODES, ADAPTIVE_TREES,
    AnchorKnobs, EmbeddedConfig, EmbeddedQ, SweepKnobs, TILINGS, TreeKnobs,
};
use crate::transfer::score_tables::Mode;

/// The Q-function approximator of `awfqi-embedded`'s FQI.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EmbeddedQArg {
    /// One table of `--embedded-resolution` cells per axis (spec §5.1).
    Tabular,
    /// Tile coding: `--embedded-tilings` offset tilings of `--embedded-resolution` tiles
    /// per axis, averaged (the core's `TileFqi`).
    Tiles,
}

/// The Q-function approximator of `awfqi-adaptive`'s FQI.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum AdaptiveQArg {
    /// Tile coding: `--adaptive-tilings` offset tilings of `--adaptive-tiles` tiles per
    /// axis.
    Tiles,
    /// Kernel averaging over the `--adaptive-knn-neighbours` nearest records (the core's
    /// `KnnFqi`), uniform or Gaussian (`--adaptive-knn-bandwidth`).
    Knn,
    /// The mean of tiles and kernel averaging, each fitted on the same data.
    Hybrid,
    /// Per-action Extra-Trees forests in fixed memory (the core's `TreeFqi`):
    /// `--adaptive-trees` trees, streamed through a scratch tree of `--adaptive-tree-nodes`
    /// nodes (or stored, each of at most that many, with `--adaptive-tree-streamed false`).
    Trees,
    /// Value iteration on a grid model of the weighted records (the core's `SweepFqi`):
    /// `--adaptive-sweep-cells` cells per axis, nodes at their corners.
    Sweep,
    /// The same model at representative states placed from the records (the core's
    /// `AnchorFqi`): at most `--adaptive-anchors` nodes, a point read from its
    /// `--adaptive-anchor-neighbours` nearest; the other `--adaptive-sweep-*` options apply.
    Anchors,
}

/// Which records a model-sweep node's reward averages (the core's `RewardModel`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SweepRewardsArg {
    /// The action's own records.
    PerAction,
    /// Every action's records.
    Pooled,
    /// The action's own where it has some, every action's elsewhere.
    Backfilled,
}

impl From<SweepRewardsArg> for awfqi::fqi::RewardModel {
    fn from(r: SweepRewardsArg) -> Self {
        match r {
            SweepRewardsArg::PerAction => Self::PerAction,
            SweepRewardsArg::Pooled => Self::Pooled,
            SweepRewardsArg::Backfilled => Self::Backfilled,
        }
    }
}

/// `awfqi-embedded`'s options.
#[derive(Debug, Clone, Copy, Args)]
#[command(next_help_heading = "awfqi-embedded (the core's thesis AWFQI)")]
pub struct EmbeddedArgs {
    /// Q-function approximator of awfqi-embedded's FQI (`tabular`: the 11 × 11 table of
    /// spec §12.1, measured worse than tile coding).
    #[arg(long, value_enum, default_value = "tiles")]
    pub embedded_q: EmbeddedQArg,
    /// Cells (tabular) or tiles (tiles) per axis. Default: 11 for the table, 6 for tiles.
    #[arg(long)]
    pub embedded_resolution: Option<usize>,
    /// Offset tilings of `--embedded-q tiles`.
    #[arg(long, default_value_t = TILINGS)]
    pub embedded_tilings: usize,
}

/// `awfqi-adaptive`'s options.
#[derive(Debug, Clone, Copy, Args)]
#[command(next_help_heading = "awfqi-adaptive (the core's adaptive AWFQI)")]
pub struct AdaptiveArgs {
    /// Q-function approximator of awfqi-adaptive's FQI.
    #[arg(long, value_enum, default_value = "sweep")]
    pub adaptive_q: AdaptiveQArg,
    /// Cells per axis of `--adaptive-q sweep` (its nodes: one more per axis). Default: 12
    /// on Puddle World and Acrobot, 24 on the Dam (each chosen on the tuning runs).
    #[arg(long)]
    pub adaptive_sweep_cells: Option<usize>,
    /// `--adaptive-q sweep`: which records a node's reward averages (`pooled`: every
    /// action's, for rewards that depend on the state only; `backfilled`: the action's own
    /// where it has some, every action's elsewhere). Default: pooled on Puddle World and
    /// Acrobot, backfilled on the Dam (whose cost depends on the release).
    #[arg(long, value_enum)]
    pub adaptive_sweep_rewards: Option<SweepRewardsArg>,
    /// `--adaptive-q sweep`: the least reward weight of a node with data (a record at the
    /// node weighs 1).
    #[arg(long, default_value_t = 0.0)]
    pub adaptive_sweep_min_mass: f64,
    /// `--adaptive-q sweep`: decide by one step of lookahead at the state instead of
    /// interpolating the node Q-values.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = false)]
    pub adaptive_sweep_lookahead: bool,
    /// `--adaptive-q sweep`: value-iteration sweeps of the model (its planning horizon).
    /// Default: the core's FQI iterations (Puddle World: the thesis's 60; Acrobot:
    /// `--iterations`), 400 on the Dam (chosen on the tuning runs).
    #[arg(long)]
    pub adaptive_sweeps: Option<usize>,
    /// The node budget of `--adaptive-q anchors`.
    #[arg(long, default_value_t = 256)]
    pub adaptive_anchors: usize,
    /// `--adaptive-q anchors`: the nodes a point is read from (1 to 4).
    #[arg(long, default_value_t = 4)]
    pub adaptive_anchor_neighbours: usize,
    /// Tiles per axis of `--adaptive-q tiles` or `hybrid`.
    #[arg(long, default_value_t = ADAPTIVE_TILES)]
    pub adaptive_tiles: usize,
    /// Offset tilings of `--adaptive-q tiles` or `hybrid`.
    #[arg(long, default_value_t = ADAPTIVE_TILINGS)]
    pub adaptive_tilings: usize,
    /// Neighbours per prediction of `--adaptive-q knn` or `hybrid`.
    #[arg(long, default_value_t = 4)]
    pub adaptive_knn_neighbours: usize,
    /// Gaussian bandwidth of `--adaptive-q knn`, as a share of each coordinate's range
    /// (absent: the neighbours weigh equally).
    #[arg(long)]
    pub adaptive_knn_bandwidth: Option<f64>,
    /// Reach of `--adaptive-q knn`, as a share of each coordinate's range: an action whose
    /// nearest record is farther, where another's is nearer, is valued at most that one's
    /// value (absent: no cap).
    #[arg(long)]
    pub adaptive_knn_reach: Option<f64>,
    /// `--adaptive-q knn`: one ball for every action (the radius of the
    /// `--adaptive-knn-neighbours` nearest records of any action bounds every action's mean
    /// and acts as the reach).
    #[arg(long)]
    pub adaptive_knn_common_ball: bool,
    /// Trees per action of `--adaptive-q trees`.
    #[arg(long, default_value_t = ADAPTIVE_TREES)]
    pub adaptive_trees: usize,
    /// Node budget of `--adaptive-q trees`: of the scratch tree when streamed, of each tree
    /// when stored (at most 65 535; a tree is grown breadth first and cut when full).
    #[arg(long, default_value_t = ADAPTIVE_TREE_NODES)]
    pub adaptive_tree_nodes: usize,
    /// `min_samples_split` of `--adaptive-q trees`.
    #[arg(long, default_value_t = 2)]
    pub adaptive_tree_min_samples_split: usize,
    /// `min_samples_leaf` of `--adaptive-q trees`.
    #[arg(long, default_value_t = 1)]
    pub adaptive_tree_min_samples_leaf: usize,
    /// `--adaptive-q trees`: stream the trees (grow each in one scratch tree of
    /// `--adaptive-tree-nodes` nodes during FQI, and the final trees along each query's
    /// path), so the memory does not grow with `--adaptive-trees`; `false`: store every
    /// tree.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = true)]
    pub adaptive_tree_streamed: bool,
    /// Depth limit of `--adaptive-q trees` (absent: none; the root is at depth 0).
    #[arg(long)]
    pub adaptive_tree_max_depth: Option<usize>,
    /// Sub-batches (re-planning points) per step (absent: the core's schedule rule from the
    /// budget per step, `awfqi::adaptive::Schedule::rule`).
    #[arg(long)]
    pub adaptive_sub_batches: Option<usize>,
    /// Share of each sub-batch spent verifying the greedy policy (absent: the schedule
    /// rule's).
    #[arg(long)]
    pub adaptive_verify: Option<f64>,
    /// Where the verification rollouts start: `all` the domain's distinct evaluation start
    /// states (each for an equal share of a step's verification), `middle` the middle one
    /// alone.
    #[arg(long, value_enum, default_value_t = AdaptiveStartsArg::Middle)]
    pub adaptive_starts: AdaptiveStartsArg,
    /// Spend a sub-batch's drawn queries on more verification when its plan verified short
    /// of its promise (`AdaptiveConfig::safeguard`).
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().safeguard)]
    pub adaptive_safeguard: bool,
    /// Fade the sources' reward weights where the target has records: in a region (a cell
    /// of `--adaptive-fading-cells` per state coordinate, per action) where the target has
    /// answered, the source records weigh at most this many records in all (absent: no
    /// fading; `awfqi::adaptive::Fading`).
    #[arg(long)]
    pub adaptive_fading: Option<f64>,
    /// Cells per state coordinate of the fading's regions.
    #[arg(long, default_value_t = 10)]
    pub adaptive_fading_cells: usize,
    /// Score rows by residual surprise.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().surprise)]
    pub adaptive_surprise: bool,
    /// Scale scores by the residual GP's remaining variance.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().uncertainty)]
    pub adaptive_uncertainty: bool,
    /// Weight rows by closeness to the verified greedy paths.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().decision)]
    pub adaptive_decision: bool,
    /// Coverage floor (share of the drawn probability spread uniformly).
    #[arg(long, default_value_t = AdaptiveOptions::default().floor)]
    pub adaptive_floor: f64,
    /// Candidate rows scored per sub-batch.
    #[arg(long, default_value_t = AdaptiveOptions::default().candidates)]
    pub adaptive_candidates: usize,
    /// Relevance-kernel width (share of each state coordinate's range).
    #[arg(long, default_value_t = AdaptiveOptions::default().relevance_width)]
    pub adaptive_relevance_width: f64,
    /// Relabel contradicted source rewards by the target GP instead of down-weighting the
    /// records.
    #[arg(long, action = clap::ArgAction::Set, default_value_t = AdaptiveOptions::default().relabel)]
    pub adaptive_relabel: bool,
    /// After a target GP's first fit in a run, start each later search from its last
    /// hyperparameters with this many likelihood evaluations (the core's `Refit::Warm`); 0:
    /// every fit searches as the thesis does.
    #[arg(long, default_value_t = AdaptiveOptions::default().refit.map_or(0, |r| r.0))]
    pub adaptive_refit_evaluations: usize,
    /// Random restarts of those warm searches.
    #[arg(long, default_value_t = AdaptiveOptions::default().refit.map_or(0, |r| r.1))]
    pub adaptive_refit_restarts: usize,
    /// Points of the target GPs and of the sources' mean functions (16, 24, 32, 48 or 64).
    #[arg(long, default_value_t = AdaptiveOptions::default().gp_points)]
    pub adaptive_gp_points: GpCapacity,
    /// Also fit the same approximator on each run's target samples alone after every
    /// step and evaluate it on the same rollouts' noise (`fqi_same_samples` in the step
    /// records): FQI paired with the learner, on the very samples it queried.
    #[arg(long)]
    pub adaptive_same_samples_fqi: bool,
}

/// Where `awfqi-adaptive`'s verification rollouts start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AdaptiveStartsArg {
    /// Every distinct evaluation start state of the domain.
    All,
    /// The middle one of the evaluation start states alone.
    Middle,
}

impl AdaptiveArgs {
    /// The adaptive loop's knobs.
    pub fn options(&self) -> AdaptiveOptions {
        AdaptiveOptions {
            sub_batches: self.adaptive_sub_batches,
            verify: self.adaptive_verify,
            all_starts: self.adaptive_starts == AdaptiveStartsArg::All,
            safeguard: self.adaptive_safeguard,
            fading: self
                .adaptive_fading
                .map(|kappa| (kappa, self.adaptive_fading_cells)),
            surprise: self.adaptive_surprise,
            uncertainty: self.adaptive_uncertainty,
            decision: self.adaptive_decision,
            floor: self.adaptive_floor,
            candidates: self.adaptive_candidates,
            relevance_width: self.adaptive_relevance_width,
            relabel: self.adaptive_relabel,
            refit: (self.adaptive_refit_evaluations > 0).then_some((
                self.adaptive_refit_evaluations,
                self.adaptive_refit_restarts,
            )),
            gp_points: self.adaptive_gp_points,
            same_samples_fqi: self.adaptive_same_samples_fqi,
        }
    }

    /// The FQI approximator the options name (a model sweep's cells, reward model and
    /// sweeps the domain's `sweep` unless `--adaptive-sweep-cells`,
    /// `--adaptive-sweep-rewards` or `--adaptive-sweeps` name them).
    ///
    /// Errors: an approximator the core refuses (zero tiles, neighbours or trees, …).
    pub fn q(&self, sweep: SweepDefaults) -> anyhow::Result<EmbeddedQ> {
        let knn = || {
            EmbeddedQ::knn(
                self.adaptive_knn_neighbours,
                self.adaptive_knn_bandwidth,
                self.adaptive_knn_reach,
                self.adaptive_knn_common_ball,
            )
        };
        let tiles = || EmbeddedQ::tiles(Some(self.adaptive_tiles), self.adaptive_tilings);
        Ok(match self.adaptive_q {
            AdaptiveQArg::Tiles => tiles()?,
            AdaptiveQArg::Knn => knn()?,
            AdaptiveQArg::Hybrid => match (tiles()?, knn()?) {
                (EmbeddedQ::Tiles(n, t), EmbeddedQ::Knn(k, h, r, c)) => {
                    EmbeddedQ::Hybrid((n, t), (k, h, r, c))
                }
                _ => anyhow::bail!("--adaptive-q hybrid needs tiles and kNN"),
            },
            AdaptiveQArg::Trees => EmbeddedQ::trees(TreeKnobs {
                trees: self.adaptive_trees,
                nodes: self.adaptive_tree_nodes,
                min_samples_split: self.adaptive_tree_min_samples_split,
                min_samples_leaf: self.adaptive_tree_min_samples_leaf,
                max_depth: self.adaptive_tree_max_depth,
                streamed: self.adaptive_tree_streamed,
            })?,
            AdaptiveQArg::Sweep | AdaptiveQArg::Anchors => EmbeddedQ::sweep(SweepKnobs {
                cells: self.adaptive_sweep_cells.unwrap_or(sweep.cells),
                rewards: self
                    .adaptive_sweep_rewards
                    .map_or(sweep.rewards, Into::into),
                min_mass: self.adaptive_sweep_min_mass,
                lookahead: self.adaptive_sweep_lookahead,
                sweeps: self.adaptive_sweeps.or(sweep.sweeps),
                anchors: (self.adaptive_q == AdaptiveQArg::Anchors).then_some(AnchorKnobs {
                    nodes: self.adaptive_anchors,
                    neighbours: self.adaptive_anchor_neighbours,
                }),
            })?,
        })
    }
}

/// A domain's default model sweep for `awfqi-adaptive`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepDefaults {
    /// Cells per axis.
    pub cells: usize,
    /// Which records a node's reward averages.
    pub rewards: awfqi::fqi::RewardModel,
    /// Value-iteration sweeps (`None`: FQI's iterations).
    pub sweeps: Option<usize>,
}

impl SweepDefaults {
    /// Puddle World's: [`ADAPTIVE_SWEEP_CELLS`] cells, pooled rewards (they depend on the
    /// state only).
    pub const PUDDLE: Self = Self {
        cells: ADAPTIVE_SWEEP_CELLS,
        rewards: awfqi::fqi::RewardModel::Pooled,
        sweeps: None,
    };
    /// The Dam's: 24 cells per axis (chosen on the tuning runs, `--seed 100`, 20 runs at
    /// 50 queries a step, among 4, 8, 12, 16, 24, 32: the best mean over 10 steps,
    /// `docs/results-active-paper-domains.md`), backfilled rewards (the cost depends on the
    /// release) and 400 value-iteration sweeps (chosen on the same runs among 60, 120, 200,
    /// 400: at γ = 0.999 the protocol's 60 iterations value only the next 60 days).
    pub const DAM: Self = Self {
        cells: 24,
        rewards: awfqi::fqi::RewardModel::Backfilled,
        sweeps: Some(400),
    };
    /// Acrobot's: [`ADAPTIVE_SWEEP_CELLS`] cells per axis (chosen on the tuning runs,
    /// `--seed 100`, 20 runs at 100 queries a step, among 3, 4, 6, 8, 12), pooled rewards
    /// (they depend on the state only).
    pub const ACROBOT: Self = Self {
        cells: ADAPTIVE_SWEEP_CELLS,
        rewards: awfqi::fqi::RewardModel::Pooled,
        sweeps: None,
    };
    /// The plant suite's unit-box plants' (the zones, the thermal room, the tanks): the
    /// zones firmware example's recommended sweep, 6 cells per axis of `[0, 1]^D`,
    /// backfilled rewards (their energy costs depend on the action).
    pub const UNIT_BOX: Self = Self {
        cells: 6,
        rewards: awfqi::fqi::RewardModel::Backfilled,
        sweeps: None,
    };
}

/// The embedded path's configuration for a score table of `mode` at `spacing`, with the
/// domain's default model sweep.
///
/// Errors: those of [`EmbeddedQ::tabular`], [`EmbeddedQ::tiles`] and [`AdaptiveArgs::q`],
/// each naming its option.
pub fn embedded_config(
    embedded: &EmbeddedArgs,
    adaptive: &AdaptiveArgs,
    mode: Mode,
    spacing: f64,
    sweep: SweepDefaults,
) -> anyhow::Result<EmbeddedConfig> {
    use anyhow::Context;
    let q = match embedded.embedded_q {
        EmbeddedQArg::Tabular => EmbeddedQ::tabular(embedded.embedded_resolution),
        EmbeddedQArg::Tiles => {
            EmbeddedQ::tiles(embedded.embedded_resolution, embedded.embedded_tilings)
        }
    }
    .context("--embedded-q, --embedded-resolution, --embedded-tilings")?;
    let adaptive_q = adaptive.q(sweep).context("--adaptive-q and its options")?;
    Ok(EmbeddedConfig::new(mode, spacing)
        .with_q(q)
        .with_adaptive_q(adaptive_q))
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        adaptive: AdaptiveArgs,
    }

    fn q(words: &[&str], sweep: SweepDefaults) -> anyhow::Result<EmbeddedQ> {
        let cli = Cli::try_parse_from([&["cli"], words].concat())?;
        cli.adaptive.q(sweep)
    }

    fn iterations(q: EmbeddedQ) -> usize {
        q.fqi(awfqi::fqi::FqiConfig::published())
            .unwrap()
            .iterations()
    }

    #[test]
    fn the_sweeps_default_to_the_domains_and_the_option_overrides_them() {
        assert_eq!(iterations(q(&[], SweepDefaults::PUDDLE).unwrap()), 60);
        assert_eq!(iterations(q(&[], SweepDefaults::ACROBOT).unwrap()), 60);
        assert_eq!(iterations(q(&[], SweepDefaults::DAM).unwrap()), 400);
        for sweep in [SweepDefaults::PUDDLE, SweepDefaults::DAM] {
            let q = q(&["--adaptive-sweeps", "7"], sweep).unwrap();
            assert!(matches!(
                q,
                EmbeddedQ::Sweep(SweepKnobs {
                    sweeps: Some(7),
                    ..
                })
            ));
            assert_eq!(iterations(q), 7);
        }
    }

    #[test]
    fn the_sweeps_keep_the_rest_of_fqi() {
        let fqi = awfqi::fqi::FqiConfig::new(0.999, 60, awfqi::fqi::EmptyCells::Value(-2.0))
            .unwrap()
            .with_min_weight(0.25)
            .unwrap();
        let q = q(&["--adaptive-sweeps", "9"], SweepDefaults::PUDDLE).unwrap();
        let got = q.fqi(fqi).unwrap();
        assert_eq!(got.iterations(), 9);
        assert!((got.discount() - 0.999).abs() < 1e-7);
        assert!((got.min_weight() - 0.25).abs() < 1e-7);
        assert_eq!(got.empty_cells(), awfqi::fqi::EmptyCells::Value(-2.0));
    }

    #[test]
    fn the_sweeps_are_the_sweeps_only() {
        let tiles = q(
            &["--adaptive-q", "tiles", "--adaptive-sweeps", "9"],
            SweepDefaults::DAM,
        )
        .unwrap();
        assert_eq!(
            iterations(tiles),
            60,
            "other approximators run FQI's iterations"
        );
    }

    fn gp_points(words: &[&str]) -> Result<GpCapacity, clap::Error> {
        let cli = Cli::try_parse_from([&["cli"], words].concat())?;
        Ok(cli.adaptive.options().gp_points)
    }

    #[test]
    fn the_gp_capacity_is_parsed_once_into_its_variant() {
        assert_eq!(gp_points(&[]).unwrap(), GpCapacity::P32);
        for capacity in GpCapacity::ALL {
            let n = capacity.points().to_string();
            assert_eq!(gp_points(&["--adaptive-gp-points", &n]).unwrap(), capacity);
        }
        let err = gp_points(&["--adaptive-gp-points", "20"])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("--adaptive-gp-points") && err.contains("16, 24, 32, 48, 64"),
            "{err}"
        );
    }

    #[test]
    fn anchors_are_the_sweep_on_a_node_budget() {
        let words = [
            "--adaptive-q",
            "anchors",
            "--adaptive-anchors",
            "64",
            "--adaptive-anchor-neighbours",
            "2",
            "--adaptive-sweeps",
            "7",
        ];
        let anchors = q(&words, SweepDefaults::ACROBOT).unwrap();
        assert!(matches!(
            anchors,
            EmbeddedQ::Sweep(SweepKnobs {
                anchors: Some(AnchorKnobs {
                    nodes: 64,
                    neighbours: 2
                }),
                sweeps: Some(7),
                ..
            })
        ));
        assert_eq!(iterations(anchors), 7);
        assert!(matches!(
            q(&[], SweepDefaults::ACROBOT).unwrap(),
            EmbeddedQ::Sweep(SweepKnobs { anchors: None, .. })
        ));
        for bad in [
            ["--adaptive-anchors", "0"],
            ["--adaptive-anchor-neighbours", "5"],
        ] {
            let words = [&["--adaptive-q", "anchors"][..], &bad[..]].concat();
            assert!(q(&words, SweepDefaults::ACROBOT).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn zero_sweeps_are_refused() {
        let err = q(&["--adaptive-sweeps", "0"], SweepDefaults::PUDDLE).unwrap_err();
        assert!(format!("{err:#}").contains("iterations"), "{err:#}");
        assert!(q(&["--adaptive-sweeps", "-1"], SweepDefaults::PUDDLE).is_err());
    }
}
