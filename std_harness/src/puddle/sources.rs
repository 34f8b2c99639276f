//! Source datasets of the Puddle World transfer experiments (spec §6): reading them in the
//! CSV layout of the published data (and a user's own data in that layout), writing them,
//! and generating fresh ones.
//!
//! A dataset is the records of 20 greedy episodes of a learned policy on one source MDP,
//! plus, per record, the posteriors of three GPs fitted on that source (reward, next x,
//! next y) at the record's own `z = (s_x, s_y, a)`, with the noise standard deviation
//! subtracted from the predictive std (§4.2, §6 step 3). IWFQI and AWFQI read the reward
//! posteriors (and the next-state ones with transition weights); RBT and SDT only the
//! records.
//!
//! The published datasets of the reference runs are embedded in the binary
//! ([`SourceSet::published`]), so the experiments run from a fresh clone without the
//! `shared/` folder.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, bail};
use awfqi::env::{Dynamics, PUDDLE_HORIZON, PuddleWorld, Transition};
use awfqi::policy::{EpsilonGreedyPolicy, UniformPolicy};
use awfqi::weights::{NoiseSubtraction, Posterior};
use rand_chacha::ChaCha8Rng;

use super::gp::{GpOptions, SourceGps};
use crate::fqi::{Dataset, FqiOptions, fqi};
use crate::trees::ActionForests;

/// One Puddle World record in f64.
pub type Record = Transition<[f64; 2], f64>;

/// The CSV header of the published layout (`shared/data/puddle-sources/README.md`).
pub const CSV_HEADER: &str = "t,s_x,s_y,a,r,next_s_x,next_s_y,absorbing,src_gp_r_mean,\
src_gp_r_std_noise_subtracted,src_gp_next_x_mean,src_gp_next_x_std_noise_subtracted,\
src_gp_next_y_mean,src_gp_next_y_std_noise_subtracted";

/// Number of columns of the layout: the 8 record columns and 3 (mean, std) pairs.
const COLUMNS: usize = 14;

/// One source dataset with the stored source-GP posteriors (§6 step 4).
#[derive(Debug, Clone, PartialEq)]
pub struct SourceDataset {
    /// Time index of each record inside its episode.
    pub times: Vec<usize>,
    /// The records, in episode order.
    pub records: Vec<Record>,
    /// Posterior `(μ^s_r, σ^s_r)` of the source's reward GP at each record.
    pub reward: Vec<Posterior<f64>>,
    /// Posteriors of the next-x and next-y GPs at each record.
    pub next_state: [Vec<Posterior<f64>>; 2],
}

impl SourceDataset {
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
    pub fn dataset(&self) -> Dataset<2> {
        self.records.iter().copied().collect()
    }

    /// Parses the CSV layout (header line, then 14 numeric columns per row).
    ///
    /// Errors: a missing or different header, a row with another number of columns, a
    /// value that is not a finite number, an action outside 0..4, a negative std.
    pub fn from_csv(text: &str) -> anyhow::Result<Self> {
        let mut lines = text.lines();
        let header = lines.next().context("empty source file")?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let expected: Vec<&str> = CSV_HEADER.split(',').collect();
        if names != expected {
            bail!("unexpected header {header:?}; expected {CSV_HEADER:?}");
        }
        let mut data = Self {
            times: Vec::new(),
            records: Vec::new(),
            reward: Vec::new(),
            next_state: [Vec::new(), Vec::new()],
        };
        for (i, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let row = i + 2;
            let v: Vec<f64> = line
                .split(',')
                .map(|f| f.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .with_context(|| format!("line {row}: not a number"))?;
            if v.len() != COLUMNS {
                bail!("line {row}: {} columns instead of {COLUMNS}", v.len());
            }
            if v.iter().any(|x| !x.is_finite()) {
                bail!("line {row}: non-finite value");
            }
            let action = v[3];
            if !(0.0..4.0).contains(&action) || action.fract() != 0.0 {
                bail!("line {row}: action {action} is not 0, 1, 2 or 3");
            }
            if v[9] < 0.0 || v[11] < 0.0 || v[13] < 0.0 {
                bail!("line {row}: negative posterior std");
            }
            data.times.push(v[0] as usize);
            data.records.push(Transition {
                state: [v[1], v[2]],
                action: action as usize,
                reward: v[4],
                next_state: [v[5], v[6]],
                absorbing: v[7] != 0.0,
            });
            data.reward.push(Posterior::new(v[8], v[9]));
            data.next_state[0].push(Posterior::new(v[10], v[11]));
            data.next_state[1].push(Posterior::new(v[12], v[13]));
        }
        if data.records.is_empty() {
            bail!("source file has no records");
        }
        Ok(data)
    }

    /// The dataset in the CSV layout (full f64 precision, round-trips exactly).
    pub fn to_csv(&self) -> String {
        let mut out = String::from(CSV_HEADER);
        out.push('\n');
        for i in 0..self.records.len() {
            let r = &self.records[i];
            let [px, py] = [&self.next_state[0][i], &self.next_state[1][i]];
            let _ = writeln!(
                out,
                "{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?}",
                self.times[i] as f64,
                r.state[0],
                r.state[1],
                r.action as f64,
                r.reward,
                r.next_state[0],
                r.next_state[1],
                if r.absorbing { 1.0 } else { 0.0 },
                self.reward[i].mean,
                self.reward[i].std,
                px.mean,
                px.std,
                py.mean,
                py.std,
            );
        }
        out
    }
}

/// The three source datasets of one experiment, in order 1, 2, 3, and where they came from.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceSet {
    /// The dynamics variant the data were collected in.
    pub dynamics: Dynamics,
    /// Datasets of sources 1, 2, 3.
    pub sources: Vec<SourceDataset>,
    /// `published`, `generated (seed …)` or the directory they were read from.
    pub origin: String,
}

/// File name of source `k` (1-based) of a variant in the published layout.
pub fn file_name(dynamics: Dynamics, k: usize) -> String {
    let prefix = match dynamics {
        Dynamics::Shared => "shared",
        Dynamics::PuddleBased => "puddle",
    };
    format!("{prefix}_dynamics_source_{k}.csv")
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

impl SourceSet {
    /// The published source datasets of the reference runs (spec §6, embedded copies of
    /// `shared/data/puddle-sources/`).
    pub fn published(dynamics: Dynamics) -> anyhow::Result<Self> {
        let texts = match dynamics {
            Dynamics::Shared => PUBLISHED_SHARED,
            Dynamics::PuddleBased => PUBLISHED_PUDDLE,
        };
        let sources = texts
            .iter()
            .enumerate()
            .map(|(k, t)| SourceDataset::from_csv(t).with_context(|| file_name(dynamics, k + 1)))
            .collect::<anyhow::Result<_>>()?;
        Ok(Self {
            dynamics,
            sources,
            origin: "published".into(),
        })
    }

    /// Reads `<dir>/{shared|puddle}_dynamics_source_{1,2,3}.csv`.
    pub fn read_dir(dir: &Path, dynamics: Dynamics) -> anyhow::Result<Self> {
        let sources = (1..=3)
            .map(|k| {
                let path = dir.join(file_name(dynamics, k));
                let text = std::fs::read_to_string(&path)
                    .with_context(|| format!("reading {}", path.display()))?;
                SourceDataset::from_csv(&text).with_context(|| path.display().to_string())
            })
            .collect::<anyhow::Result<_>>()?;
        Ok(Self {
            dynamics,
            sources,
            origin: dir.display().to_string(),
        })
    }

    /// Writes the datasets into `dir` under the published file names.
    pub fn write_dir(&self, dir: &Path) -> anyhow::Result<()> {
        std::fs::create_dir_all(dir)?;
        for (k, s) in self.sources.iter().enumerate() {
            let path = dir.join(file_name(self.dynamics, k + 1));
            std::fs::write(&path, s.to_csv())
                .with_context(|| format!("writing {}", path.display()))?;
        }
        Ok(())
    }

    /// Total number of source records.
    pub fn total_records(&self) -> usize {
        self.sources.iter().map(SourceDataset::len).sum()
    }

    /// The records of all sources in order 1, 2, 3 (the order of every union, §7.2).
    pub fn union(&self) -> Dataset<2> {
        let mut data = Dataset::new();
        for s in &self.sources {
            data.extend_from(&s.dataset());
        }
        data
    }
}

/// How fresh source data are generated (spec §6).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Generation {
    /// Episodes per learning step of the source policy (50).
    pub batch: usize,
    /// Learning steps (5: uniform, then 4 ε-greedy).
    pub steps: usize,
    /// Greedy episodes stored (20).
    pub episodes: usize,
    /// ε of the learning steps after the first (0.3).
    pub epsilon: f64,
    /// FQI iterations and trees (60, 50).
    pub iterations: usize,
    /// Trees per forest.
    pub trees: usize,
    /// Source-GP fitting.
    pub gp: GpOptions,
}

impl Default for Generation {
    fn default() -> Self {
        Self {
            batch: 50,
            steps: 5,
            episodes: 20,
            epsilon: 0.3,
            iterations: 60,
            trees: 50,
            gp: GpOptions::reference(),
        }
    }
}

/// Appends one episode of `policy` on `env`, recording time indices.
fn episode<P: awfqi::policy::Policy<[f64; 2]>>(
    env: &PuddleWorld<f64>,
    policy: &mut P,
    rng: &mut ChaCha8Rng,
    times: &mut Vec<usize>,
    records: &mut Vec<Record>,
) -> anyhow::Result<()> {
    env.run_episode_with(policy, PUDDLE_HORIZON, rng, |r| {
        times.push(r.t);
        records.push(r.transition);
        Ok(())
    })?;
    Ok(())
}

/// Learns a source policy with FQI on Extra-Trees (§6 step 1: `steps` steps of `batch`
/// episodes, uniform then ε-greedy w.r.t. the last fit, learning from scratch each step).
pub fn learn_source_policy(
    env: &PuddleWorld<f64>,
    g: &Generation,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<ActionForests<2>> {
    let (mut times, mut records) = (Vec::new(), Vec::new());
    let mut q: Option<ActionForests<2>> = None;
    for _ in 0..g.steps {
        for _ in 0..g.batch {
            match &q {
                None => episode(
                    env,
                    &mut UniformPolicy::new(4)?,
                    rng,
                    &mut times,
                    &mut records,
                )?,
                Some(q) => {
                    let greedy = |s: &[f64; 2]| Ok(q.greedy_action(s));
                    let mut policy = EpsilonGreedyPolicy::new(greedy, g.epsilon, 4)?;
                    episode(env, &mut policy, rng, &mut times, &mut records)?;
                }
            }
        }
        let data: Dataset<2> = records.iter().copied().collect();
        let options = FqiOptions {
            iterations: g.iterations,
            n_trees: g.trees,
            ..FqiOptions::plain()
        };
        q = Some(fqi(&data, &options, rng)?.q);
    }
    q.context("no learning step")
}

/// Generates one source dataset (§6): a learned greedy policy's `episodes` episodes and the
/// three source GPs' noise-subtracted posteriors at the records.
pub fn generate_source(
    env: &PuddleWorld<f64>,
    g: &Generation,
    rng: &mut ChaCha8Rng,
) -> anyhow::Result<SourceDataset> {
    let q = learn_source_policy(env, g, rng)?;
    let (mut times, mut records) = (Vec::new(), Vec::new());
    let mut greedy = |s: &[f64; 2]| Ok(q.greedy_action(s));
    for _ in 0..g.episodes {
        episode(env, &mut greedy, rng, &mut times, &mut records)?;
    }
    // Source GPs use all records (§4.2: max_gp caps target GPs only).
    let all = GpOptions {
        max_gp: usize::MAX,
        ..g.gp
    };
    let gps = SourceGps::fit(&records, &all, rng)?;
    let [reward, next_x, next_y] = gps.posteriors_at(&records, NoiseSubtraction::Reference)?;
    Ok(SourceDataset {
        times,
        records,
        reward,
        next_state: [next_x, next_y],
    })
}

/// Generates the three source datasets of a variant, each from its own seeded stream.
pub fn generate(
    dynamics: Dynamics,
    g: &Generation,
    seed: u64,
    progress: impl Fn(usize) + Sync,
) -> anyhow::Result<SourceSet> {
    use rayon::prelude::*;
    let worlds = PuddleWorld::<f64>::sources(dynamics);
    let sources = worlds
        .par_iter()
        .enumerate()
        .map(|(k, env)| {
            let mut rng = super::stream(seed, &[super::SOURCE_GENERATION, k as u64]);
            let s = generate_source(env, g, &mut rng);
            progress(k);
            s
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(SourceSet {
        dynamics,
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
        let s = &SourceSet::published(Dynamics::Shared).unwrap().sources[2];
        let back = SourceDataset::from_csv(&s.to_csv()).unwrap();
        assert_eq!(&back, s);
        let header = format!("{CSV_HEADER}\n");
        assert!(SourceDataset::from_csv(&header).is_err(), "no records");
        assert!(SourceDataset::from_csv("a,b\n1,2\n").is_err(), "header");
        let row = "0,0,0,5,-1,0,1,0,-1,0.1,0,0.1,1,0.1";
        assert!(
            SourceDataset::from_csv(&format!("{header}{row}")).is_err(),
            "action"
        );
        let row = "0,0,0,2,-1,0,1,0,-1,-0.1,0,0.1,1,0.1";
        assert!(
            SourceDataset::from_csv(&format!("{header}{row}")).is_err(),
            "std"
        );
        let row = "0,0,0,2,-1,0,1,0,-1,0.1,0,0.1,1";
        assert!(
            SourceDataset::from_csv(&format!("{header}{row}")).is_err(),
            "width"
        );
        let row = "0,0,0,2,-1,0,1,1,-1,0.1,0,0.1,1,0.1";
        let one = SourceDataset::from_csv(&format!("{header}{row}")).unwrap();
        assert!(one.records[0].absorbing);
        assert_eq!(one.records[0].next_state, [0.0, 1.0]);
    }

    #[test]
    fn generation_follows_section_6_on_a_small_budget() {
        let g = Generation {
            batch: 4,
            steps: 2,
            episodes: 3,
            iterations: 3,
            trees: 3,
            gp: GpOptions {
                restarts: 0,
                ..GpOptions::reference()
            },
            ..Generation::default()
        };
        let env = PuddleWorld::<f64>::source_1(Dynamics::Shared);
        let mut rng = crate::puddle::stream(1, &[9]);
        let s = generate_source(&env, &g, &mut rng).unwrap();
        assert_eq!(s.episodes(), 3);
        assert!(s.len() >= 3 && s.len() <= 150);
        for i in 0..s.len() {
            for p in [&s.reward[i], &s.next_state[0][i], &s.next_state[1][i]] {
                assert!(p.mean.is_finite() && p.std >= 0.0);
            }
        }
        // The posterior means track the data (the GP interpolates the rewards).
        let err: f64 = s
            .records
            .iter()
            .zip(&s.reward)
            .map(|(r, p)| (r.reward - p.mean).abs())
            .sum::<f64>()
            / s.len() as f64;
        assert!(err < 2.0, "mean |r − μ| = {err}");
        assert_eq!(SourceDataset::from_csv(&s.to_csv()).unwrap(), s);
    }

    #[test]
    fn directories_round_trip() {
        let dir = std::env::temp_dir().join(format!("awfqi-sources-{}", std::process::id()));
        let set = SourceSet::published(Dynamics::PuddleBased).unwrap();
        set.write_dir(&dir).unwrap();
        let back = SourceSet::read_dir(&dir, Dynamics::PuddleBased).unwrap();
        assert_eq!(back.sources, set.sources);
        assert!(SourceSet::read_dir(&dir, Dynamics::Shared).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
