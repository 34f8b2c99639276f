//! `awfqi-kernel`: the core's embedded AWFQI path ([`awfqi::Awfqi`]) on the same
//! protocol as the std algorithms, so the cost of the embedded path is measured, not guessed.
//!
//! The kernel runs as it would on a microcontroller, in `f32`, with everything in fixed
//! storage: a target reward GP of capacity [`GP_POINTS`] fitted on an even spread of `D₀`
//! (the core's [`SubsetRule::Spread`]) with the core's bounded Nelder–Mead search,
//! weighted FQI by tile coding ([`TILINGS`] offset tilings of [`TILES`] × [`TILES`] tiles;
//! `--kernel-q tabular` for the [`CELLS`] × [`CELLS`] table) instead of Extra-Trees,
//! transition weights on request (`--transition-weights true`), and a score table
//! with the setting's rows whose values come from one fixed-capacity reward GP per source
//! (realistic table, `V_r` only). The source records and their stored reward posteriors are
//! the experiment's source data, converted to `f32`. Budget, steps, evaluation and records
//! are the protocol's.

use std::time::Instant;

use awfqi::env::{PUDDLE_ACTIONS, PuddleWorld};
use awfqi::{
    AliasEntry, Approximator, Awfqi, AwfqiBuffers, AwfqiConfig, CellGrid, Estimator, FqiEntry, Gp,
    GpTraining, Posterior, RowSet, ScoreTable, Scores, SubsetRule, Tilings, Transition,
    WeightParams,
};
use rand_chacha::ChaCha8Rng;

use super::Experiment;
use crate::puddle::protocol::{Diagnostics, StepRecord, evaluate_step};
use crate::puddle::score_tables::Mode;
use crate::puddle::sources::{Record, SourceSet};

/// FQI cells per axis (cells about one unit step wide; see `tests/awfqi_puddle.rs`).
pub const CELLS: usize = 11;
/// Tiles per axis of `--kernel-q tiles` by default, and tilings: chosen on a tuning seed
/// (`--seed 1`: 3–21 tiles × 4, 8, 16 tilings) and measured on the evaluation seeds
/// (`docs/algorithms.md` §12.1).
pub const TILES: usize = 6;
/// Offset tilings of `--kernel-q tiles` by default.
pub const TILINGS: usize = 4;

/// The Q-function approximator of the kernel's FQI (`--kernel-q`, `--kernel-resolution`,
/// `--kernel-tilings`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KernelQFunction {
    /// A table of this many cells per axis.
    Tabular(usize),
    /// Tile coding: tiles per axis, tilings.
    Tiles(usize, usize),
}

impl KernelQFunction {
    /// The approximator the options name.
    ///
    /// Errors: a zero resolution or tiling count.
    pub fn from_args(
        q: crate::commands::transfer::KernelQ,
        resolution: Option<usize>,
        tilings: usize,
    ) -> anyhow::Result<Self> {
        use crate::commands::transfer::KernelQ;
        let out = match q {
            KernelQ::Tabular => Self::Tabular(resolution.unwrap_or(CELLS)),
            KernelQ::Tiles => Self::Tiles(resolution.unwrap_or(TILES), tilings),
        };
        match out {
            Self::Tabular(0) | Self::Tiles(0, _) => {
                anyhow::bail!("--kernel-resolution must be at least 1")
            }
            Self::Tiles(_, 0) => anyhow::bail!("--kernel-tilings must be at least 1"),
            _ => Ok(out),
        }
    }

    /// The core's approximator over Puddle World's `[0, 10]²`.
    fn approximator(self) -> anyhow::Result<Approximator<T, 2>> {
        Ok(match self {
            Self::Tabular(n) => CellGrid::cube(0.0, 10.0, n)?.into(),
            Self::Tiles(n, k) => Tilings::cube(0.0, 10.0, n, k)?.into(),
        })
    }
}
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

/// What the kernel path builds once per experiment and shares by all runs (§11.2): the
/// `f32` source data with their stored posteriors, and the values of its realistic score
/// table.
#[derive(Debug, Clone)]
pub struct KernelSetup {
    /// Row mode of the score table.
    pub mode: Mode,
    /// Grid spacing of the score table.
    pub spacing: f64,
    records: Vec<Vec<Record32>>,
    /// Stored reward posteriors of all sources, source after source.
    posteriors: Vec<Posterior<T>>,
    values: Vec<Scores<T, 2>>,
    /// Stored next-state posteriors of all sources, record after record, 2 per record
    /// (empty when the sources have none).
    transition_posteriors: Vec<Posterior<T>>,
    /// Wall time of the set-up (source GP fits and score table), seconds.
    pub setup_seconds: f64,
    /// The FQI approximator.
    pub q: KernelQFunction,
}

impl KernelSetup {
    /// Converts the sources and builds the realistic score table from one
    /// `Gp<f32, 64, 3>` reward GP per source (an even spread of its records, the core's
    /// reference training, [`ScoreTable::realistic`]), from the stream `rng`.
    pub fn new(
        sources: &SourceSet,
        mode: Mode,
        spacing: f64,
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
        let rows = row_set(mode, spacing, &slices)?;
        let mut values = vec![Scores::ZERO; rows.len()];
        let mut scratch = vec![AliasEntry::EMPTY; rows.len()];
        let mut gp = Box::new(Gp::<T, GP_POINTS, 3>::empty());
        ScoreTable::realistic(
            rows,
            &slices,
            &mut gp,
            &GpTraining::reference(),
            SubsetRule::Spread,
            &mut values,
            &mut scratch,
            rng,
            |_, _| Ok(()),
        )?;
        let transition_posteriors = sources
            .sources
            .iter()
            .flat_map(|s| {
                (0..s.records.len()).flat_map(move |i| {
                    s.next_state
                        .iter()
                        .filter_map(move |dim| dim.get(i))
                        .map(|p| Posterior::new(p.mean as T, p.std as T))
                })
            })
            .collect();
        Ok(Self {
            mode,
            spacing,
            records,
            posteriors,
            values,
            transition_posteriors,
            setup_seconds: start.elapsed().as_secs_f64(),
            q: KernelQFunction::Tiles(TILES, TILINGS),
        })
    }

    /// The same set-up with another FQI approximator.
    pub fn with_q(self, q: KernelQFunction) -> Self {
        Self { q, ..self }
    }

    /// The kernel's fixed parameters for the result files.
    pub fn parameters(&self) -> serde_json::Value {
        let mut out = serde_json::json!({
            "scalar": "f32",
            "gp_capacity": GP_POINTS,
            "gp_subset": "spread",
            "gp_search": "core Nelder-Mead, 10 restarts",
            "score_rows": self.values.len(),
            "score_spacing": self.spacing,
        });
        match self.q {
            KernelQFunction::Tabular(n) => out["fqi_cells"] = serde_json::json!([n, n]),
            KernelQFunction::Tiles(n, k) => {
                out["fqi_tiles"] = serde_json::json!([n, n]);
                out["fqi_tilings"] = k.into();
            }
        }
        out
    }
}

fn row_set<'a>(
    mode: Mode,
    spacing: f64,
    slices: &'a [&'a [Record32]],
) -> anyhow::Result<RowSet<'a, T, 2>> {
    let grid = PuddleWorld::score_grid(spacing as T)?;
    Ok(match mode {
        Mode::Source => RowSet::source_data(slices)?,
        Mode::Grid => RowSet::grid(grid, PUDDLE_ACTIONS)?,
        Mode::Both => RowSet::both(grid, PUDDLE_ACTIONS, slices)?,
    })
}

/// One run of the kernel on the protocol: the builder's set-up from the shared source data
/// and score values, then `K` steps of [`Awfqi::step`], each followed by the protocol's
/// evaluation (in `f64`, of the greedy policy of the kernel's `f32` table). Returns the step
/// records and `D₀`.
pub fn run(
    experiment: &Experiment,
    rng: &mut ChaCha8Rng,
    mut after_step: impl FnMut(&StepRecord),
) -> anyhow::Result<(Vec<StepRecord>, Vec<Record>)> {
    let setup = experiment
        .kernel
        .as_ref()
        .ok_or_else(|| anyhow::anyhow!("no kernel set-up"))?;
    let protocol = &experiment.protocol;
    let slices: Vec<&[Record32]> = setup.records.iter().map(Vec::as_slice).collect();
    let rows = row_set(setup.mode, setup.spacing, &slices)?;
    let budget = experiment.budget();
    // The kernel's memory, sized at run time.
    let mut gp = Box::new(Gp::<T, GP_POINTS, 3>::empty());
    let mut samples = vec![Transition::EMPTY; protocol.steps * budget];
    let mut weights = vec![0.0; setup.posteriors.len()];
    let mut alias = vec![AliasEntry::EMPTY; rows.len()];
    let approximator = setup.q.approximator()?;
    let entries = approximator
        .required_entries(PUDDLE_ACTIONS)
        .ok_or_else(|| anyhow::anyhow!("FQI approximator too large"))?;
    let mut fqi = vec![FqiEntry::EMPTY; entries];
    // Transition weights only on request (`--transition-weights true`), on every
    // coordinate, with the estimator variance v_s of the experiment: the active algorithms
    // run without them (§12), and on this small-GP path they were measured to hurt under
    // puddle-based dynamics (§12.1).
    let transition_weights = experiment.options.transition_weights == Some(true);
    let mut ws = vec![
        0.0;
        if transition_weights {
            setup.posteriors.len()
        } else {
            0
        }
    ];
    let (_, v_s) = experiment.variances()?;
    let buffers = AwfqiBuffers {
        gp: &mut gp,
        samples: &mut samples,
        weights: &mut weights,
        alias: &mut alias,
        fqi: &mut fqi,
    };
    let dynamics = protocol
        .dynamics
        .ok_or_else(|| anyhow::anyhow!("awfqi-kernel runs on Puddle World only"))?;
    let mut builder = Awfqi::builder(
        AwfqiConfig::thesis(budget).validate()?,
        approximator,
        &slices,
        rows,
    )
    .stored_posteriors(&setup.posteriors)
    .stored_scores(&setup.values);
    if transition_weights {
        if setup.transition_posteriors.len() != 2 * setup.posteriors.len() {
            anyhow::bail!("transition weights need the sources' stored next-state posteriors");
        }
        builder = builder.transition_weights(
            WeightParams::new(Estimator::Mean, v_s as T, 1000.0)?,
            &setup.transition_posteriors,
            &mut ws,
        );
    }
    let mut kernel = builder.build(PuddleWorld::target(dynamics), buffers, rng)?;
    let mut steps = Vec::new();
    for k in 1..=protocol.steps {
        let start = Instant::now();
        let report = kernel.step(rng)?;
        let diagnostics = Diagnostics {
            n_source_samples: Some(report.n_source_samples),
            wr_mean: Some(f64::from(report.wr_mean)),
            wr_eff: Some(f64::from(report.wr_eff)),
            ws_mean: Some(f64::from(report.ws_mean)),
            ws_eff: Some(f64::from(report.ws_eff)),
            reward_gp: Some(crate::puddle::gp::GpSummary {
                points: report.gp_points,
                signal_variance: f64::from(report.gp_hyperparameters.signal_variance),
                length_scale: f64::from(report.gp_hyperparameters.length_scales[0]),
                noise_variance: f64::from(report.gp_hyperparameters.noise_variance),
                log_marginal_likelihood: f64::from(report.gp_log_likelihood),
            }),
            ..Diagnostics::default()
        };
        let q = kernel.q();
        let greedy = |s: &[f64; 2]| q.greedy_action([s[0] as T, s[1] as T]).unwrap_or(0);
        let record = evaluate_step(
            &experiment.domain,
            protocol,
            k,
            &greedy,
            report.n_target_samples,
            diagnostics,
            start,
            rng,
        )?;
        after_step(&record);
        steps.push(record);
    }
    let collected = kernel.target_samples().iter().map(to_f64).collect();
    Ok((steps, collected))
}
