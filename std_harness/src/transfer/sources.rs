//! Source datasets of the transfer experiments (spec §6): reading them in the CSV layouts of
//! the published data (and a user's own data in that layout), writing them, and generating
//! fresh ones as each domain's paper describes.
//!
//! A dataset is a source MDP's records plus, per record, the posteriors of the source's GPs
//! (reward and some next-state coordinates) at the record's own input, as the reference
//! stored them. IWFQI and AWFQI read the reward posteriors (and the next-state ones with
//! transition weights); RBT and SDT only the records.
//!
//! Layout ([`SourceLayout`]): `t`, the state, `a`, `r`, the next state, `absorbing`, then
//! `(mean, std)` of the reward GP and of each stored next-state GP. Puddle World's files
//! (`std_harness/data/puddle-sources/`) and the IWFQI paper's Dam and Acrobot files
//! (`std_harness/data/iwfqi-sources/`, see its README) differ only in the column names
//! and in the Dam's `a`, which holds the release rather than the action index.
//!
//! The published datasets are embedded in the binary ([`SourceSet::published`] for Puddle
//! World, [`crate::transfer::domain_data::DomainData::published`] for every domain), so the experiments
//! run from a fresh clone.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, bail};
use awfqi::env::Dynamics;
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use awfqi::weights::Posterior;
use rand_chacha::ChaCha8Rng;

use super::gp::{GpOptions, Output, SourceGps, Weighting};
use crate::domains::{Domain, Task};
use crate::forest_fqi::{Dataset, FqiOptions, fqi};
use crate::trees::{ActionForests, TreeParams};

/// One record in `f64` (Puddle World's, by default).
pub type Record<const D: usize = 2> = crate::domains::Record<D>;

/// The CSV header of Puddle World's published layout (`std_harness/data/puddle-sources/README.md`).
pub const CSV_HEADER: &str = "t,s_x,s_y,a,r,next_s_x,next_s_y,absorbing,src_gp_r_mean,\
src_gp_r_std_noise_subtracted,src_gp_next_x_mean,src_gp_next_x_std_noise_subtracted,\
src_gp_next_y_mean,src_gp_next_y_std_noise_subtracted";

/// A stored std this far below 0 is read as its absolute value (numerical noise of a
/// noise-free GP, see [`SourceDataset::from_csv`]); anything more negative is an error.
pub const NEGATIVE_STD_TOLERANCE: f64 = 1e-6;

/// How one domain's source files are laid out.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceLayout {
    /// The header line (comma-separated column names).
    pub header: String,
    /// File name of source `k` is `<prefix><k>.csv`.
    pub file_prefix: String,
    /// Next-state coordinates with stored posteriors (the first this many).
    pub posterior_dims: usize,
    /// `Some(values)` when the `a` column holds the action's value (`values[a]`) rather
    /// than its index.
    pub action_values: Option<Vec<f64>>,
    /// The environment's state space, `[low, high]` per coordinate (a bound may be infinite,
    /// as the Dam's storage is above): every state and next state of a record must lie
    /// inside it (`None`: not checked).
    pub state_bounds: Option<Vec<(f64, f64)>>,
    /// State coordinates whose values are integers only (the Dam's day).
    pub integer_coordinates: Vec<usize>,
}

impl SourceLayout {
    /// Puddle World's published layout for `dynamics`.
    pub fn puddle(dynamics: Dynamics) -> Self {
        let prefix = match dynamics {
            Dynamics::Shared => "shared",
            Dynamics::PuddleBased => "puddle",
        };
        Self {
            header: CSV_HEADER.to_string(),
            file_prefix: format!("{prefix}_dynamics_source_"),
            posterior_dims: 2,
            action_values: None,
            state_bounds: Some(vec![(0.0, 10.0); 2]),
            integer_coordinates: Vec::new(),
        }
    }

    /// The IWFQI-paper layout of `name`'s files: `t,<state>,a,r,next_<state>,absorbing,
    /// src_gp_r_mean,src_gp_r_std`, then `src_gp_next_<k>_mean,src_gp_next_<k>_std` for
    /// each of the first `posterior_dims` state coordinates.
    pub fn iwfqi(
        name: &str,
        state: &[&str],
        posterior_dims: usize,
        action_values: Option<Vec<f64>>,
    ) -> Self {
        let mut cols = vec!["t".to_string()];
        cols.extend(state.iter().map(|s| s.to_string()));
        cols.extend(["a".into(), "r".into()]);
        cols.extend(state.iter().map(|s| format!("next_{s}")));
        cols.extend(["absorbing", "src_gp_r_mean", "src_gp_r_std"].map(String::from));
        for k in 0..posterior_dims {
            cols.push(format!("src_gp_next_{k}_mean"));
            cols.push(format!("src_gp_next_{k}_std"));
        }
        Self {
            header: cols.join(","),
            file_prefix: format!("{name}_source_"),
            posterior_dims,
            action_values,
            state_bounds: None,
            integer_coordinates: Vec::new(),
        }
    }

    /// The layout with the environment's state space checked on every state and next
    /// state: `bounds` per coordinate, `integer` the coordinates that take integers only.
    pub fn with_state_space(mut self, bounds: &[(f64, f64)], integer: &[usize]) -> Self {
        self.state_bounds = Some(bounds.to_vec());
        self.integer_coordinates = integer.to_vec();
        self
    }

    /// File name of source `k` (1-based).
    pub fn file_name(&self, k: usize) -> String {
        format!("{}{k}.csv", self.file_prefix)
    }

    fn columns<const D: usize>(&self) -> usize {
        2 * D + 6 + 2 * self.posterior_dims
    }

    /// The action index of an `a` cell.
    fn action(&self, value: f64, num_actions: usize) -> Option<usize> {
        match &self.action_values {
            Some(values) => values.iter().position(|&v| v == value),
            None => (value.fract() == 0.0 && value >= 0.0 && value < num_actions as f64)
                .then_some(value as usize),
        }
    }

    /// The `a` cell of an action index.
    fn action_cell(&self, action: usize) -> f64 {
        match &self.action_values {
            Some(values) => values.get(action).copied().unwrap_or(f64::NAN),
            None => action as f64,
        }
    }
}

/// One source dataset with the stored source-GP posteriors (§6 step 4).
#[derive(Debug, Clone, PartialEq)]
pub struct SourceDataset<const D: usize = 2> {
    /// Time index of each record inside its episode.
    pub times: Vec<usize>,
    /// The records, in episode order.
    pub records: Vec<Record<D>>,
    /// Posterior `(μ^s_r, σ^s_r)` of the source's reward GP at each record.
    pub reward: Vec<Posterior<f64>>,
    /// Posteriors of the stored next-state GPs at each record, one vector per coordinate
    /// (the first `posterior_dims` coordinates of the layout).
    pub next_state: Vec<Vec<Posterior<f64>>>,
}

impl<const D: usize> SourceDataset<D> {
    /// Number of records.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// `true` without records.
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Number of episodes (records with `t = 0`).
    pub fn episodes(&self) -> usize {
        self.times.iter().filter(|&&t| t == 0).count()
    }

    /// The records as an FQI dataset.
    pub fn dataset(&self) -> Dataset<D> {
        self.records.iter().copied().collect()
    }

    /// Parses `layout` (header line, then numeric rows) for a domain of `num_actions`
    /// actions.
    ///
    /// Errors, each naming the line and the field: a missing or different header (the
    /// column set), a row with another number of columns, a value that is not a finite
    /// number, a time index that is not a non-negative integer, a state or next state outside
    /// the layout's state space (or not an integer in an integer coordinate), an action that is not one of the domain's, an absorbing flag
    /// other than 0 or 1, a std below −[`NEGATIVE_STD_TOLERANCE`] (one within it is read as
    /// its absolute value).
    pub fn from_csv(text: &str, layout: &SourceLayout, num_actions: usize) -> anyhow::Result<Self> {
        let mut lines = text.lines();
        let header = lines.next().context("empty source file (no header line)")?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let expected: Vec<&str> = layout.header.split(',').collect();
        if names != expected {
            let missing: Vec<&str> = expected
                .iter()
                .filter(|e| !names.contains(e))
                .copied()
                .collect();
            let unknown: Vec<String> = names
                .iter()
                .filter(|n| !expected.contains(n))
                .map(|n| shown(n))
                .collect();
            bail!(
                "line 1: unexpected header {} (missing columns {missing:?}, unknown columns \
                 [{}]); expected {:?}",
                shown(header),
                unknown.join(", "),
                layout.header
            );
        }
        let columns = layout.columns::<D>();
        let mut data = Self {
            times: Vec::new(),
            records: Vec::new(),
            reward: Vec::new(),
            next_state: vec![Vec::new(); layout.posterior_dims],
        };
        for (i, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let row = i + 2;
            let cells: Vec<&str> = line.split(',').map(str::trim).collect();
            if cells.len() != columns {
                bail!("line {row}: {} columns instead of {columns}", cells.len());
            }
            let mut v = Vec::with_capacity(columns);
            for (cell, name) in cells.iter().zip(&expected) {
                let x: f64 = cell.parse().with_context(|| {
                    format!(
                        "line {row}, field `{name}`: {} is not a number",
                        shown(cell)
                    )
                })?;
                if !x.is_finite() {
                    bail!("line {row}, field `{name}`: non-finite value {cell}");
                }
                v.push(x);
            }
            let field = |k: usize| expected.get(k).copied().unwrap_or("?");
            if v[0] < 0.0 || v[0].fract() != 0.0 {
                bail!(
                    "line {row}, field `{}`: time index {} is not a non-negative integer",
                    field(0),
                    v[0]
                );
            }
            if let Some(bounds) = &layout.state_bounds {
                for (d, &(low, high)) in bounds.iter().enumerate().take(D) {
                    for k in [1 + d, D + 3 + d] {
                        if !(low..=high).contains(&v[k]) {
                            bail!(
                                "line {row}, field `{}`: {} is outside the state space [{low}, {high}]",
                                field(k),
                                v[k]
                            );
                        }
                    }
                }
            }
            for &d in layout.integer_coordinates.iter().filter(|&&d| d < D) {
                for k in [1 + d, D + 3 + d] {
                    if v[k].fract() != 0.0 {
                        bail!(
                            "line {row}, field `{}`: {} is not an integer (the state space \
                             holds whole values only in this coordinate)",
                            field(k),
                            v[k]
                        );
                    }
                }
            }
            let a = v[D + 1];
            let Some(action) = layout.action(a, num_actions) else {
                bail!(
                    "line {row}, field `{}`: action {a} is not one of the domain's {num_actions} actions",
                    field(D + 1)
                );
            };
            let absorbing = v[2 * D + 3];
            if absorbing != 0.0 && absorbing != 1.0 {
                bail!(
                    "line {row}, field `{}`: absorbing flag {absorbing} is not 0 or 1",
                    field(2 * D + 3)
                );
            }
            let mut posteriors = v[2 * D + 4..].to_vec();
            for (j, s) in posteriors.iter_mut().enumerate().skip(1).step_by(2) {
                if *s < -NEGATIVE_STD_TOLERANCE {
                    bail!(
                        "line {row}, field `{}`: negative posterior std {s}",
                        field(2 * D + 4 + j)
                    );
                }
                // Acrobot's noise-free source GPs store stds within ±10⁻⁶ of 0 at their own
                // training points (numerical noise, some negative). Only σ² enters the
                // weight estimators, so |σ| keeps every weight as the reference computed it.
                *s = s.abs();
            }
            data.times.push(v[0] as usize);
            data.records.push(Record::<D> {
                state: std::array::from_fn(|d| v[1 + d]),
                action,
                reward: v[D + 2],
                next_state: std::array::from_fn(|d| v[D + 3 + d]),
                absorbing: absorbing == 1.0,
            });
            data.reward
                .push(Posterior::new(posteriors[0], posteriors[1]));
            for (k, column) in data.next_state.iter_mut().enumerate() {
                column.push(Posterior::new(posteriors[2 + 2 * k], posteriors[3 + 2 * k]));
            }
        }
        if data.records.is_empty() {
            bail!("source file has no records");
        }
        Ok(data)
    }

    /// The dataset in `layout` (full f64 precision, round-trips exactly).
    pub fn to_csv(&self, layout: &SourceLayout) -> String {
        let mut out = layout.header.clone();
        out.push('\n');
        for (i, r) in self.records.iter().enumerate() {
            let mut cells = vec![self.times[i] as f64];
            cells.extend(r.state);
            cells.extend([layout.action_cell(r.action), r.reward]);
            cells.extend(r.next_state);
            cells.push(if r.absorbing { 1.0 } else { 0.0 });
            cells.extend([self.reward[i].mean, self.reward[i].std]);
            for column in self.next_state.iter().take(layout.posterior_dims) {
                cells.extend([column[i].mean, column[i].std]);
            }
            let line: Vec<String> = cells.iter().map(|c| format!("{c:?}")).collect();
            let _ = writeln!(out, "{}", line.join(","));
        }
        out
    }
}

/// The source datasets of one experiment, in order, and where they came from.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceSet<const D: usize = 2> {
    /// The datasets of sources 1, 2, ….
    pub sources: Vec<SourceDataset<D>>,
    /// `published`, `generated (seed …)` or the directory they were read from.
    pub origin: String,
}

/// File name of Puddle World's source `k` (1-based) of a variant in the published layout.
pub fn file_name(dynamics: Dynamics, k: usize) -> String {
    SourceLayout::puddle(dynamics).file_name(k)
}

const PUBLISHED_SHARED: [&str; 3] = [
    include_str!("../../data/puddle-sources/shared_dynamics_source_1.csv"),
    include_str!("../../data/puddle-sources/shared_dynamics_source_2.csv"),
    include_str!("../../data/puddle-sources/shared_dynamics_source_3.csv"),
];
const PUBLISHED_PUDDLE: [&str; 3] = [
    include_str!("../../data/puddle-sources/puddle_dynamics_source_1.csv"),
    include_str!("../../data/puddle-sources/puddle_dynamics_source_2.csv"),
    include_str!("../../data/puddle-sources/puddle_dynamics_source_3.csv"),
];

impl SourceSet<2> {
    /// Puddle World's published source datasets of the reference runs (spec §6, embedded
    /// copies of `std_harness/data/puddle-sources/`).
    pub fn published(dynamics: Dynamics) -> anyhow::Result<Self> {
        let texts = match dynamics {
            Dynamics::Shared => PUBLISHED_SHARED,
            Dynamics::PuddleBased => PUBLISHED_PUDDLE,
        };
        Self::from_texts(&texts, &SourceLayout::puddle(dynamics), 4, "published")
    }

    /// Reads Puddle World's `<dir>/{shared|puddle}_dynamics_source_{1,2,3}.csv`.
    pub fn read_dir(dir: &Path, dynamics: Dynamics) -> anyhow::Result<Self> {
        Self::read_layout(dir, &SourceLayout::puddle(dynamics), 3, 4)
    }
}

impl<const D: usize> SourceSet<D> {
    /// Parses the texts of sources 1, 2, … in `layout`.
    pub fn from_texts<S: AsRef<str>>(
        texts: &[S],
        layout: &SourceLayout,
        num_actions: usize,
        origin: &str,
    ) -> anyhow::Result<Self> {
        let sources = texts
            .iter()
            .enumerate()
            .map(|(k, t)| {
                SourceDataset::from_csv(t.as_ref(), layout, num_actions)
                    .with_context(|| layout.file_name(k + 1))
            })
            .collect::<anyhow::Result<_>>()?;
        Ok(Self {
            sources,
            origin: origin.into(),
        })
    }

    /// Reads `<dir>/<prefix><k>.csv` for `k = 1..=count`.
    pub fn read_layout(
        dir: &Path,
        layout: &SourceLayout,
        count: usize,
        num_actions: usize,
    ) -> anyhow::Result<Self> {
        let sources = (1..=count)
            .map(|k| {
                let path = dir.join(layout.file_name(k));
                let text = read_text(&path)?;
                SourceDataset::from_csv(&text, layout, num_actions)
                    .with_context(|| format!("{}", path.display()))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        Ok(Self {
            sources,
            origin: dir.display().to_string(),
        })
    }

    /// Writes the datasets into `dir` under `layout`'s file names, each atomically.
    ///
    /// Errors: a file there already holds other data (it is left as it is), or a write
    /// fails. A file that already holds these data is left untouched.
    pub fn write_dir(&self, dir: &Path, layout: &SourceLayout) -> anyhow::Result<()> {
        std::fs::create_dir_all(dir)?;
        for (k, s) in self.sources.iter().enumerate() {
            let path = dir.join(layout.file_name(k + 1));
            let csv = s.to_csv(layout);
            match std::fs::read(&path) {
                // Another shard of the same configuration wrote them already.
                Ok(old) if old == csv.as_bytes() => continue,
                Ok(_) => bail!(
                    "{} holds other source data (another --seed or generation budget?); \
                     nothing was replaced: use another --out or move it away",
                    path.display()
                ),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => bail!("reading {}: {e}", path.display()),
            }
            crate::store::write_atomic(&path, csv.as_bytes())?;
        }
        Ok(())
    }

    /// Total number of source records.
    pub fn total_records(&self) -> usize {
        self.sources.iter().map(SourceDataset::len).sum()
    }

    /// The records of all sources in order 1, 2, … (the order of every union, §7.2).
    pub fn union(&self) -> Dataset<D> {
        let mut data = Dataset::new();
        for s in &self.sources {
            data.extend_from(&s.dataset());
        }
        data
    }
}

/// The most characters of a value an error message shows.
const SHOWN_CHARS: usize = 80;

/// `value` as an error message quotes it: at most [`SHOWN_CHARS`] characters, the rest cut
/// with an ellipsis and counted, so a field of megabytes does not fill the terminal.
fn shown(value: &str) -> String {
    match value.char_indices().nth(SHOWN_CHARS) {
        None => format!("{value:?}"),
        Some((end, _)) => format!("{:?}… ({} bytes in all)", &value[..end], value.len()),
    }
}

/// The file at `path` as text. Errors name the file, and for bytes that are not UTF-8 the
/// line and the byte in it.
fn read_text(path: &Path) -> anyhow::Result<String> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    String::from_utf8(bytes).map_err(|e| {
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = 1 + valid.iter().filter(|&&b| b == b'\n').count();
        let column = 1 + valid.iter().rev().take_while(|&&b| b != b'\n').count();
        anyhow::anyhow!(
            "{}: line {line}, byte {column}: not UTF-8 text (a source file is UTF-8 CSV)",
            path.display()
        )
    })
}

/// How fresh source data are generated.
#[derive(Debug, Clone)]
pub enum Generation {
    /// Spec §6 (Puddle World; Acrobot alike): learn a policy with FQI (`steps` steps of
    /// `batch` episodes, uniform then ε-greedy), then record `episodes[k]` episodes of its
    /// greedy policy on source `k`.
    LearnedPolicy {
        /// Episodes per learning step.
        batch: usize,
        /// Learning steps.
        steps: usize,
        /// Greedy episodes stored, per source.
        episodes: Vec<usize>,
        /// ε of the learning steps after the first.
        epsilon: f64,
        /// FQI iterations.
        iterations: usize,
        /// Trees per forest.
        trees: usize,
        /// Growth limits of the trees.
        tree: TreeParams,
    },
    /// The reference's Dam data: `count` independent one-step transitions per source from
    /// states drawn by `state` and uniform actions (time index 0 on every record).
    UniformTransitions {
        /// Transitions per source.
        count: usize,
        /// The state sampler.
        state: fn(&mut ChaCha8Rng) -> Vec<f64>,
    },
}

impl Generation {
    /// Spec §6's Puddle World generation: 5 × 50 learning episodes, 60 iterations, 50
    /// trees, ε = 0.3, 20 greedy episodes per source.
    pub fn puddle() -> Self {
        Generation::LearnedPolicy {
            batch: 50,
            steps: 5,
            episodes: vec![20; 3],
            epsilon: 0.3,
            iterations: 60,
            trees: 50,
            tree: TreeParams::FULLY_GROWN,
        }
    }

    /// The same with `iterations` and `trees` (the command's budget knobs) and, when
    /// given, fewer episodes (for quick looks).
    pub fn with_budget(&self, iterations: usize, trees: usize) -> Self {
        match self.clone() {
            Generation::LearnedPolicy {
                batch,
                steps,
                episodes,
                epsilon,
                tree,
                ..
            } => Generation::LearnedPolicy {
                batch,
                steps,
                episodes,
                epsilon,
                iterations,
                trees,
                tree,
            },
            other => other,
        }
    }
}

/// Learns a source policy with FQI on Extra-Trees (§6 step 1: `steps` steps of `batch`
/// episodes, uniform then ε-greedy w.r.t. the last fit, learning from scratch each step).
#[allow(clippy::too_many_arguments)]
pub fn learn_source_policy<const D: usize>(
    domain: &Domain<D>,
    env: &dyn Task<D>,
    batch: usize,
    steps: usize,
    epsilon: f64,
    options: &FqiOptions<'_>,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<ActionForests<D>> {
    let mut records: Vec<Record<D>> = Vec::new();
    let mut q: Option<ActionForests<D>> = None;
    let n = domain.num_actions();
    for _ in 0..steps {
        for _ in 0..batch {
            let push = |_t: usize, r: Record<D>| {
                records.push(r);
                Ok(())
            };
            match &q {
                None => domain.run_episode(env, &mut UniformPolicy::new(n)?, rng, push)?,
                Some(q) => {
                    let greedy = |s: &[f64; D]| Ok(q.greedy_action(s));
                    let mut policy = EpsilonGreedyPolicy::new(greedy, epsilon, n)?;
                    domain.run_episode(env, &mut policy, rng, push)?
                }
            };
        }
        let data: Dataset<D> = records.iter().copied().collect();
        q = Some(fqi(&data, options, rng)?.q);
    }
    q.context("no learning step")
}

/// Generates source `k`'s dataset as `generation` says, with the posteriors of
/// `weighting`'s source GPs at the records that `layout` stores (source GPs use every
/// record: `max_gp` caps target GPs only, §4.2).
pub fn generate_source<const D: usize>(
    domain: &Domain<D>,
    weighting: &Weighting<D>,
    layout: &SourceLayout,
    k: usize,
    generation: &Generation,
    gp: &GpOptions,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<SourceDataset<D>> {
    let env = &*domain.sources[k];
    let (mut times, mut records) = (Vec::new(), Vec::new());
    match generation {
        Generation::LearnedPolicy {
            batch,
            steps,
            episodes,
            epsilon,
            iterations,
            trees,
            tree,
        } => {
            let options = FqiOptions {
                iterations: *iterations,
                n_trees: *trees,
                gamma: domain.discount,
                num_actions: domain.num_actions(),
                tree: *tree,
                ..FqiOptions::plain()
            };
            let q = learn_source_policy(domain, env, *batch, *steps, *epsilon, &options, rng)?;
            let mut greedy = |s: &[f64; D]| Ok(q.greedy_action(s));
            for _ in 0..episodes.get(k).copied().unwrap_or(0) {
                domain.run_episode(env, &mut greedy, rng, |t, r| {
                    times.push(t);
                    records.push(r);
                    Ok(())
                })?;
            }
        }
        Generation::UniformTransitions { count, state } => {
            let n = domain.num_actions();
            for _ in 0..*count {
                let s = state(rng);
                let s: [f64; D] = std::array::from_fn(|d| s.get(d).copied().unwrap_or(0.0));
                let a = awfqi::rng::uniform_index(rng, n);
                times.push(0);
                records.push(env.query(s, a, rng)?);
            }
        }
    }
    if records.is_empty() {
        bail!("source {} generated no records", k + 1);
    }
    let all = GpOptions {
        max_gp: usize::MAX,
        ..*gp
    };
    let outputs = layout.posterior_outputs();
    let gps = SourceGps::fit(domain, weighting, &records, &outputs, &all, rng)?;
    let mut posteriors = gps.posteriors_at(domain, &records)?;
    let reward = posteriors.remove(0);
    Ok(SourceDataset {
        times,
        records,
        reward,
        next_state: posteriors,
    })
}

impl SourceLayout {
    /// The GP outputs a dataset of this layout stores: the reward, then each stored
    /// next-state coordinate.
    pub fn posterior_outputs(&self) -> Vec<Output> {
        std::iter::once(Output::Reward)
            .chain((0..self.posterior_dims).map(Output::NextState))
            .collect()
    }
}

/// Generates every source dataset of `domain` (with `weighting`'s GPs, the posteriors
/// `layout` stores), each from its own seeded stream (seed, SOURCE_GENERATION, source), in
/// parallel.
pub fn generate<const D: usize>(
    domain: &Domain<D>,
    weighting: &Weighting<D>,
    layout: &SourceLayout,
    generation: &Generation,
    gp: &GpOptions,
    seed: u64,
) -> anyhow::Result<SourceSet<D>> {
    use rayon::prelude::*;
    let sources = (0..domain.sources.len())
        .into_par_iter()
        .map(|k| {
            let mut rng = super::stream(seed, &[super::SOURCE_GENERATION, k as u64]);
            generate_source(domain, weighting, layout, k, generation, gp, &mut rng)
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(SourceSet {
        sources,
        origin: format!("generated (seed {seed})"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_data_have_the_documented_sizes_and_shapes() {
        let shared = SourceSet::published(Dynamics::Shared).unwrap();
        let lens: Vec<usize> = shared.sources.iter().map(SourceDataset::len).collect();
        assert_eq!(lens, vec![291, 423, 319]);
        let puddle = SourceSet::published(Dynamics::PuddleBased).unwrap();
        let lens: Vec<usize> = puddle.sources.iter().map(SourceDataset::len).collect();
        assert_eq!(lens, vec![306, 454, 311]);
        for s in shared.sources.iter().chain(&puddle.sources) {
            // 20 episodes, each ending at its goal: exactly 20 absorbing records, each the
            // last of its episode.
            assert_eq!(s.episodes(), 20);
            assert_eq!(s.records.iter().filter(|r| r.absorbing).count(), 20);
            for (i, r) in s.records.iter().enumerate() {
                let last = s.times.get(i + 1).is_none_or(|&t| t == 0);
                assert_eq!(r.absorbing, last, "record {i}");
                if !last {
                    assert_eq!(r.next_state, s.records[i + 1].state);
                }
            }
        }
        // §6: source 1's shared-dynamics data contain no "down" action.
        assert!(shared.sources[0].records.iter().all(|r| r.action != 3));
    }

    #[test]
    fn csv_round_trips_exactly_and_rejects_bad_rows() {
        let layout = SourceLayout::puddle(Dynamics::Shared);
        let s = &SourceSet::published(Dynamics::Shared).unwrap().sources[2];
        let back = SourceDataset::from_csv(&s.to_csv(&layout), &layout, 4).unwrap();
        assert_eq!(&back, s);
        let parse = |t: &str| SourceDataset::<2>::from_csv(t, &layout, 4);
        let header = format!("{CSV_HEADER}\n");
        assert!(parse(&header).is_err(), "no records");
        assert!(parse("a,b\n1,2\n").is_err(), "header");
        let row = "0,0,0,5,-1,0,1,0,-1,0.1,0,0.1,1,0.1";
        assert!(parse(&format!("{header}{row}")).is_err(), "action");
        let row = "0,0,0,2,-1,0,1,0,-1,-0.1,0,0.1,1,0.1";
        assert!(parse(&format!("{header}{row}")).is_err(), "std");
        let row = "0,0,0,2,-1,0,1,0,-1,-5e-7,0,0.1,1,0.1";
        let tiny = parse(&format!("{header}{row}")).unwrap();
        assert_eq!(tiny.reward[0].std, 5e-7, "numerical noise is read as |σ|");
        let row = "0,0,0,2,-1,0,1,0,-1,0.1,0,0.1,1";
        assert!(parse(&format!("{header}{row}")).is_err(), "width");
        let row = "0,0,0,2,-1,0,1,1,-1,0.1,0,0.1,1,0.1";
        let one = parse(&format!("{header}{row}")).unwrap();
        assert!(one.records[0].absorbing);
        assert_eq!(one.records[0].next_state, [0.0, 1.0]);
    }

    #[test]
    fn value_coded_actions_and_fewer_posteriors_round_trip() {
        let layout = SourceLayout::iwfqi("dam", &["storage", "day"], 1, Some(vec![0.0, 3.0, 5.0]));
        assert_eq!(
            layout.header,
            "t,storage,day,a,r,next_storage,next_day,absorbing,src_gp_r_mean,src_gp_r_std,\
             src_gp_next_0_mean,src_gp_next_0_std"
        );
        let text = format!(
            "{}\n0.0,100.5,3.0,5.0,-2.5,101.0,4.0,0.0,-2.4,0.5,100.9,0.01\n",
            layout.header
        );
        let d = SourceDataset::<2>::from_csv(&text, &layout, 3).unwrap();
        assert_eq!(d.records[0].action, 2);
        assert_eq!(d.next_state.len(), 1);
        assert_eq!(d.next_state[0][0], Posterior::new(100.9, 0.01));
        assert_eq!(d.to_csv(&layout), text);
        // A release that is not one of the domain's is refused.
        let bad = text.replace(",5.0,-2.5", ",4.0,-2.5");
        assert!(SourceDataset::<2>::from_csv(&bad, &layout, 3).is_err());
    }

    #[test]
    fn directories_round_trip() {
        let dir = std::env::temp_dir().join(format!("awfqi-sources-{}", std::process::id()));
        let set = SourceSet::published(Dynamics::PuddleBased).unwrap();
        set.write_dir(&dir, &SourceLayout::puddle(Dynamics::PuddleBased))
            .unwrap();
        let back = SourceSet::read_dir(&dir, Dynamics::PuddleBased).unwrap();
        assert_eq!(back.sources, set.sources);
        assert!(SourceSet::read_dir(&dir, Dynamics::Shared).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
