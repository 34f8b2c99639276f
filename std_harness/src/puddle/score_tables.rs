//! Score tables of the AWFQI variants (spec §11): rows in one of three modes, the oracle
//! values (the sources' noise-free model functions) or the realistic ones (posterior means
//! of GPs fitted on each source's data), the population variance over the sources per row,
//! and drawing rows with probability proportional to `V_r`.
//!
//! A table is built once per experiment and shared by every run (§11.2 \[CHOICE\]).

use awfqi::alias::{AliasEntry, AliasTable};
use awfqi::env::{PUDDLE_ACTIONS, PuddleWorld};
use awfqi::score::{RowSet, ScoreTable, Scores};
use rand_chacha::ChaCha8Rng;

use super::gp::{GpOptions, SourceGps};
use super::sources::{Record, SourceSet};

/// Which rows a table has (§11.1); the thesis's settings 1–3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// The `(s, a)` of every source record (setting 1).
    Source,
    /// The 101 × 101 grid with spacing 0.1, borders included, × 4 actions (setting 2).
    Grid,
    /// Grid rows followed by source rows (setting 3).
    Both,
}

impl Mode {
    /// The name used in file names and tables.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Source => "source",
            Mode::Grid => "grid",
            Mode::Both => "both",
        }
    }
}

/// Grid spacing of the thesis (`dx = dy = 0.1`).
pub const GRID_SPACING: f64 = 0.1;

/// Each source's records, as the core's row sets borrow them.
fn source_slices(sources: &SourceSet) -> Vec<&[Record]> {
    sources
        .sources
        .iter()
        .map(|s| s.records.as_slice())
        .collect()
}

/// The core's row set of `mode` over the sources' records `slices` (§11.1).
fn row_set<'a>(
    mode: Mode,
    slices: &'a [&'a [Record]],
    spacing: f64,
) -> anyhow::Result<RowSet<'a, f64, 2>> {
    let grid = PuddleWorld::score_grid(spacing)?;
    Ok(match mode {
        Mode::Source => RowSet::source_data(slices)?,
        Mode::Grid => RowSet::grid(grid, PUDDLE_ACTIONS)?,
        Mode::Both => RowSet::both(grid, PUDDLE_ACTIONS, slices)?,
    })
}

/// The rows of `mode` as `(state, action)` pairs, in the order of §11.1.
pub fn rows(
    mode: Mode,
    sources: &SourceSet,
    spacing: f64,
) -> anyhow::Result<Vec<([f64; 2], usize)>> {
    let slices = source_slices(sources);
    Ok(row_set(mode, &slices, spacing)?.iter().collect())
}

/// A computed table: rows and their scores.
#[derive(Debug, Clone)]
pub struct ScoreTableData {
    /// The row mode.
    pub mode: Mode,
    /// `true` for the oracle table.
    pub oracle: bool,
    /// The rows.
    pub rows: Vec<([f64; 2], usize)>,
    /// Their scores `(V_r, V_x, V_y)`.
    pub values: Vec<Scores<f64, 2>>,
}

impl ScoreTableData {
    /// The oracle table (§11.2): values from the sources' noise-free model functions, with
    /// the core's score computation.
    pub fn oracle(mode: Mode, sources: &SourceSet, spacing: f64) -> anyhow::Result<Self> {
        let worlds = PuddleWorld::<f64>::sources(sources.dynamics);
        let slices = source_slices(sources);
        let set = row_set(mode, &slices, spacing)?;
        let mut values = vec![Scores::default(); set.len()];
        ScoreTable::compute(set, &worlds, &mut values)?;
        Ok(Self {
            mode,
            oracle: true,
            rows: set.iter().collect(),
            values,
        })
    }

    /// The realistic table (§11.2): values from the posterior means of each source's GPs
    /// (`gps[j]` fitted on source `j` only), population variance over the sources.
    pub fn realistic(
        mode: Mode,
        sources: &SourceSet,
        gps: &[SourceGps],
        spacing: f64,
    ) -> anyhow::Result<Self> {
        use rayon::prelude::*;
        let rows = rows(mode, sources, spacing)?;
        let zs: Vec<[f64; 3]> = rows.iter().map(|(s, a)| [s[0], s[1], *a as f64]).collect();
        // predictions[j][output][row]
        let predictions: Vec<[Vec<f64>; 3]> = gps.par_iter().map(|g| g.means_at(&zs)).collect();
        let m = predictions.len() as f64;
        let variance = |output: usize, row: usize| {
            // Population variance over the sources, on values shifted by the first source's
            // (exactly 0 where all agree; accurate for large close values).
            let first = predictions[0][output][row];
            let (mut s, mut q) = (0.0, 0.0);
            for p in &predictions {
                let d = p[output][row] - first;
                s += d;
                q += d * d;
            }
            let mean = s / m;
            (q / m - mean * mean).max(0.0)
        };
        let values = (0..rows.len())
            .map(|i| Scores {
                reward: variance(0, i),
                next_state: [variance(1, i), variance(2, i)],
            })
            .collect();
        Ok(Self {
            mode,
            oracle: false,
            rows,
            values,
        })
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// `true` without rows (never, for a built table).
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// The sampling weights of §11.3: `V_r`, or all 1 when it sums to 0 \[CHOICE\].
    pub fn sampling_weights(&self) -> Vec<f64> {
        let w: Vec<f64> = self.values.iter().map(|v| v.reward).collect();
        if w.iter().all(|&x| x <= 0.0) {
            vec![1.0; w.len()]
        } else {
            w
        }
    }

    /// Draws `n` rows i.i.d. with replacement with probability ∝ `V_r` (§12 step 1), one
    /// `u64` per draw.
    /// Returns the drawn row indices.
    pub fn draw(&self, n: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Vec<usize>> {
        let mut storage = vec![AliasEntry::<f64>::default(); self.len()];
        let alias = AliasTable::build(self.sampling_weights(), &mut storage)?;
        Ok((0..n).map(|_| alias.sample(rng)).collect())
    }
}

/// Fits the realistic tables' source GPs (reward, next x, next y per source, on all its
/// records whatever `options.max_gp` says), each source from its own stream (seed, SCORE_TABLE, source), in parallel.
pub fn fit_source_gps(
    sources: &SourceSet,
    options: &GpOptions,
    seed: u64,
) -> anyhow::Result<Vec<SourceGps>> {
    use rayon::prelude::*;
    sources
        .sources
        .par_iter()
        .enumerate()
        .map(|(k, s)| {
            let mut rng = super::stream(seed, &[super::SCORE_TABLE, k as u64]);
            // Source GPs use all the source's records (§4.2: max_gp caps target GPs only).
            let all = GpOptions {
                max_gp: usize::MAX,
                ..*options
            };
            SourceGps::fit(&s.records, &all, &mut rng)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use awfqi::env::Dynamics;
    use rand_core::SeedableRng;

    #[test]
    fn row_counts_follow_the_modes() {
        let sources = SourceSet::published(Dynamics::Shared).unwrap();
        assert_eq!(rows(Mode::Grid, &sources, 0.1).unwrap().len(), 40_804);
        assert_eq!(rows(Mode::Source, &sources, 0.1).unwrap().len(), 1033);
        let both = rows(Mode::Both, &sources, 0.1).unwrap();
        assert_eq!(both.len(), 40_804 + 1033);
        assert_eq!(both[40_804], (sources.sources[0].records[0].state, 2));
        // Grid coordinates are 0.1 × integer, action fastest.
        assert_eq!(both[4 * 101 + 1], ([0.0, 0.1], 1));
        assert_eq!(both[4 * 100 + 3], ([10.0, 0.0], 3));
    }

    #[test]
    fn oracle_grid_table_concentrates_where_the_sources_disagree() {
        let sources = SourceSet::published(Dynamics::Shared).unwrap();
        let table = ScoreTableData::oracle(Mode::Grid, &sources, 0.1).unwrap();
        // Shared dynamics: the mean next states agree, so V_x = V_y = 0 exactly.
        assert!(table.values.iter().all(|v| v.next_state == [0.0, 0.0]));
        // At (2, 2) source 2 has a puddle (r̄ = −22.53) and sources 1, 3 do not
        // (r̄ = −1.000074): population variance = (2/9)·(21.527397)² ≈ 102.98.
        let i = table
            .rows
            .iter()
            .position(|&(s, a)| (s[0] - 2.0).abs() < 1e-9 && (s[1] - 2.0).abs() < 1e-9 && a == 0)
            .unwrap();
        let d: f64 = -22.527471 + 1.000074;
        assert!((table.values[i].reward - 2.0 / 9.0 * d * d).abs() < 1e-3);
        // Drawing follows V_r: the draws land where V_r is large.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let draws = table.draw(2000, &mut rng).unwrap();
        let mean_score: f64 = draws.iter().map(|&d| table.values[d].reward).sum::<f64>() / 2000.0;
        // Under P ∝ V the expected score of a draw is ΣV²/ΣV, with variance ΣV³/ΣV − (ΣV²/ΣV)².
        let moment = |p: i32| table.values.iter().map(|v| v.reward.powi(p)).sum::<f64>();
        let expected = moment(2) / moment(1);
        let se = ((moment(3) / moment(1) - expected * expected) / 2000.0).sqrt();
        assert!(
            (mean_score - expected).abs() < 5.0 * se,
            "{mean_score} vs {expected} ± {se}"
        );
    }
}
