//! `awfqi-kernel`: the core's embedded AWFQI path ([`awfqi::Awfqi`]) on the same
//! protocol as the std algorithms, so the cost of the embedded path is measured, not guessed.
//!
//! The kernel runs as it would on a microcontroller, in `f32`, with everything in fixed
//! storage: a target reward GP of capacity [`GP_POINTS`] fitted on an even spread of `D₀`
//! (the core's [`SubsetRule::Spread`]) with the core's bounded Nelder–Mead search, tabular
//! weighted FQI on [`CELLS`] × [`CELLS`] cells instead of Extra-Trees, and a score table
//! with the setting's rows whose values come from one fixed-capacity reward GP per source
//! (realistic table, `V_r` only). The source records and their stored reward posteriors are
//! the experiment's source data, converted to `f32`. Budget, steps, evaluation and records
//! are the protocol's: the kernel is a [`Learner`] that
//! [`protocol::run`](crate::transfer::protocol::run) drives like every other algorithm.

use std::time::Instant;

use awfqi::env::{Dynamics, PUDDLE_ACTIONS, PuddleWorld};
use awfqi::{
    AliasEntry, Awfqi, AwfqiBuffers, AwfqiConfig, CellGrid, FqiEntry, Gp, GpTraining, Posterior,
    RowSet, ScoreTable, Scores, SubsetRule, Transition,
};
use rand_chacha::ChaCha8Rng;

use super::Experiment;
use crate::transfer::gp::GpSummary;
use crate::transfer::protocol::{Diagnostics, Learner};
use crate::transfer::score_tables::{GridRows, Mode};
use crate::transfer::sources::{Record, SourceSet};

/// FQI cells per axis by default (cells about one unit step wide; see
/// `tests/awfqi_puddle.rs`).
pub const CELLS: usize = 11;
/// Capacity of every kernel GP.
pub const GP_POINTS: usize = 64;

type T = f32;
type Record32 = Transition<[T; 2], T>;

fn to_f32(r: &Record) -> Record32 {
    Transition {
        state: r.state.map(|x| x as T),
        action: r.action,
        reward: r.reward as T,
        next_state: r.next_state.map(|x| x as T),
        absorbing: r.absorbing,
    }
}

fn to_f64(r: &Record32) -> Record {
    Transition {
        state: r.state.map(f64::from),
        action: r.action,
        reward: f64::from(r.reward),
        next_state: r.next_state.map(f64::from),
        absorbing: r.absorbing,
    }
}

/// Everything that configures the kernel path, in one place: options the kernel gains
/// (another approximator, transition weights, …) belong here.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelConfig {
    /// Row mode of the score table.
    pub mode: Mode,
    /// Grid spacing of the score table.
    pub spacing: f64,
    /// FQI cells per axis of the tabular Q-function.
    pub cells: usize,
}

impl KernelConfig {
    /// The kernel with the setting's score table (`mode`, `spacing`) and [`CELLS`] cells per
    /// axis.
    pub fn new(mode: Mode, spacing: f64) -> Self {
        Self {
            mode,
            spacing,
            cells: CELLS,
        }
    }
}

/// What the kernel path builds once per experiment and shares by all runs (§11.2): the
/// `f32` source data with their stored posteriors, and the values of its realistic score
/// table.
#[derive(Debug, Clone)]
pub struct KernelSetup {
    /// The kernel's configuration.
    pub config: KernelConfig,
    records: Vec<Vec<Record32>>,
    /// Stored reward posteriors of all sources, source after source.
    posteriors: Vec<Posterior<T>>,
    values: Vec<Scores<T, 2>>,
    /// Wall time of the set-up (source GP fits and score table), seconds.
    pub setup_seconds: f64,
}

impl KernelSetup {
    /// Converts the sources and builds the realistic score table from one
    /// `Gp<f32, 64, 3>` reward GP per source (an even spread of its records, the core's
    /// published training, [`ScoreTable::realistic`]), from the stream `rng`.
    pub fn new(
        sources: &SourceSet,
        config: KernelConfig,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Self> {
        let start = Instant::now();
        let records: Vec<Vec<Record32>> = sources
            .sources
            .iter()
            .map(|s| s.records.iter().map(to_f32).collect())
            .collect();
        let posteriors = sources
            .sources
            .iter()
            .flat_map(|s| &s.reward)
            .map(|p| Posterior::new(p.mean as T, p.std as T))
            .collect();
        let slices: Vec<&[Record32]> = records.iter().map(Vec::as_slice).collect();
        let rows = row_set(&config, &slices)?;
        let mut values = vec![Scores::ZERO; rows.len()];
        let mut scratch = vec![AliasEntry::EMPTY; rows.len()];
        let mut gp = Box::new(Gp::<T, GP_POINTS, 3>::empty());
        ScoreTable::realistic(
            rows,
            &slices,
            &mut gp,
            &GpTraining::published(),
            SubsetRule::Spread,
            &mut values,
            &mut scratch,
            rng,
            |_, _| Ok(()),
        )?;
        Ok(Self {
            config,
            records,
            posteriors,
            values,
            setup_seconds: start.elapsed().as_secs_f64(),
        })
    }

    /// The kernel's fixed parameters for the result files.
    pub fn parameters(&self) -> serde_json::Value {
        let cells = self.config.cells;
        serde_json::json!({
            "scalar": "f32",
            "fqi_cells": [cells, cells],
            "gp_capacity": GP_POINTS,
            "gp_subset": "spread",
            "gp_search": "core Nelder-Mead, 10 restarts",
            "score_rows": self.values.len(),
            "score_spacing": self.config.spacing,
        })
    }

    /// The source records, one slice per source (what the kernel borrows).
    fn source_slices(&self) -> Vec<&[Record32]> {
        self.records.iter().map(Vec::as_slice).collect()
    }
}

fn row_set<'a>(
    config: &KernelConfig,
    slices: &'a [&'a [Record32]],
) -> anyhow::Result<RowSet<'a, T, 2>> {
    let grid = PuddleWorld::score_grid(config.spacing as T)?;
    let grid = GridRows::Points(grid, PUDDLE_ACTIONS);
    Ok(config.mode.row_set(grid, slices)?)
}

/// The memory one run of the kernel writes, on the heap and sized at run time: what a
/// firmware holds in an [`awfqi::AwfqiStorage`].
#[derive(Debug)]
pub struct KernelMemory {
    gp: Box<Gp<T, GP_POINTS, 3>>,
    samples: Vec<Record32>,
    weights: Vec<T>,
    alias: Vec<AliasEntry<T>>,
    fqi: Vec<FqiEntry<T>>,
}

impl KernelMemory {
    /// Room for `steps × budget` target samples, one weight per stored posterior, one alias
    /// entry per score row and the FQI table of `setup`'s configuration.
    pub fn new(setup: &KernelSetup, steps: usize, budget: usize) -> Self {
        let cells = setup.config.cells;
        Self {
            gp: Box::new(Gp::<T, GP_POINTS, 3>::empty()),
            samples: vec![Transition::EMPTY; steps * budget],
            weights: vec![0.0; setup.posteriors.len()],
            alias: vec![AliasEntry::EMPTY; setup.values.len()],
            fqi: vec![FqiEntry::EMPTY; cells * cells * PUDDLE_ACTIONS],
        }
    }

    fn buffers(&mut self) -> AwfqiBuffers<'_, T, 2, 3, GP_POINTS> {
        AwfqiBuffers {
            gp: &mut self.gp,
            samples: &mut self.samples,
            weights: &mut self.weights,
            alias: &mut self.alias,
            fqi: &mut self.fqi,
        }
    }
}

/// `awfqi-kernel` as a [`Learner`]: each protocol step is one [`Awfqi::step`] (score →
/// draw → query → weights → weighted FQI); the greedy action is the `f32` table's, and `D₀`
/// is kept in `f64` for the result files.
pub struct KernelLearner<'a> {
    kernel: Awfqi<'a, T, PuddleWorld<T>, 2, 3, GP_POINTS>,
    collected: Vec<Record>,
}

impl<'a> KernelLearner<'a> {
    /// The builder's set-up from the shared source data and score values (`sources` are
    /// `setup`'s [`KernelSetup::source_slices`]) over `memory`, with a per-step budget, on
    /// the Puddle World target of `dynamics`, from the stream `rng`.
    fn new(
        setup: &'a KernelSetup,
        sources: &'a [&'a [Record32]],
        memory: &'a mut KernelMemory,
        budget: usize,
        dynamics: Dynamics,
        rng: &mut ChaCha8Rng,
    ) -> anyhow::Result<Self> {
        let cells = setup.config.cells;
        let kernel = Awfqi::builder(
            AwfqiConfig::thesis(budget).validate()?,
            CellGrid::cube(0.0, 10.0, cells)?,
            sources,
            row_set(&setup.config, sources)?,
        )
        .stored_posteriors(&setup.posteriors)
        .stored_scores(&setup.values)
        .build(PuddleWorld::target(dynamics), memory.buffers(), rng)?;
        Ok(Self {
            kernel,
            collected: Vec::new(),
        })
    }
}

impl Learner for KernelLearner<'_> {
    fn step(&mut self, _k: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Diagnostics> {
        let report = self.kernel.step(rng)?;
        let new = &self.kernel.target_samples()[self.collected.len()..];
        self.collected.extend(new.iter().map(to_f64));
        let hyper = &report.gp_hyperparameters;
        Ok(Diagnostics {
            n_source_samples: Some(report.n_source_samples),
            wr_mean: Some(f64::from(report.wr_mean)),
            wr_eff: Some(f64::from(report.wr_eff)),
            ws_mean: Some(f64::from(report.ws_mean)),
            ws_eff: Some(f64::from(report.ws_eff)),
            reward_gp: Some(GpSummary {
                points: report.gp_points,
                signal_variance: f64::from(hyper.signal_variance),
                length_scale: f64::from(hyper.length_scales[0]),
                noise_variance: f64::from(hyper.noise_variance),
                log_marginal_likelihood: f64::from(report.gp_log_likelihood),
            }),
            ..Diagnostics::default()
        })
    }

    fn greedy_action(&self, s: &[f64; 2]) -> usize {
        let state = [s[0] as T, s[1] as T];
        self.kernel.q().greedy_action(state).unwrap_or(0)
    }

    fn target_samples(&self) -> &[Record] {
        &self.collected
    }
}

/// Hands a fresh kernel learner for one run of `experiment` to `f`: the kernel borrows its
/// memory and the source data for the whole run, so they live in this frame while
/// [`protocol::run`](crate::transfer::protocol::run) drives the learner inside `f`.
pub fn with_learner(
    experiment: &Experiment,
    rng: &mut ChaCha8Rng,
    f: &mut dyn FnMut(&mut dyn Learner, &mut ChaCha8Rng) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let setup = experiment
        .kernel
        .as_deref()
        .ok_or_else(|| anyhow::anyhow!("no kernel set-up"))?;
    let dynamics = experiment
        .protocol
        .dynamics
        .ok_or_else(|| anyhow::anyhow!("awfqi-kernel runs on Puddle World only"))?;
    let budget = experiment.budget();
    let sources = setup.source_slices();
    let mut memory = KernelMemory::new(setup, experiment.protocol.steps, budget);
    let mut learner = KernelLearner::new(setup, &sources, &mut memory, budget, dynamics, rng)?;
    f(&mut learner, rng)
}
