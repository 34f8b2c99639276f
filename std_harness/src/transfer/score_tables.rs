//! Score tables of the AWFQI variants (spec §11), for every domain: rows in one of three
//! modes, the oracle values (the sources' noise-free mean rewards) or the realistic ones
//! (posterior means of reward GPs fitted on each source's data), the population variance
//! `V_r` over the sources per row, and drawing rows with probability proportional to `V_r`.
//!
//! Only `V_r` is computed: it alone drives sampling in the thesis's experiments (§11.3),
//! so the next-state columns `V_x, V_y` (and their GPs) are left out.
//!
//! A table is built once per experiment and shared by every run (§11.2 \[CHOICE\]).

use awfqi::alias::{AliasEntry, AliasTable};
use awfqi::prelude::{Real, Transition};
use awfqi::score::{PointGrid, RowSet};
use rand_chacha::ChaCha8Rng;

use super::gp::{GpOptions, Output, SourceGps, Weighting};
use super::sources::SourceSet;
use crate::domains::{Domain, GpInput, Record};

/// Which rows a table has (§11.1); the thesis's settings 1–3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// The `(s, a)` of every source record (setting 1).
    Source,
    /// The domain's grid × every action (setting 2; Puddle World's 101 × 101 grid with
    /// spacing 0.1, borders included).
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

/// The grid part of a score table's rows (§11.1): a core point grid with its action count
/// (the embedded path's `f32` grid) or explicit `(state, action)` pairs (a domain's
/// [`grid_rows`](crate::domains::Domain::grid_rows)).
#[derive(Debug, Clone, Copy)]
pub enum GridRows<'a, T, const D: usize> {
    /// Every point of the grid × every action.
    Points(PointGrid<T, D>, usize),
    /// The pairs as given.
    Pairs(&'a [([T; D], usize)]),
}

impl Mode {
    /// The rows of this mode as the core's [`RowSet`], in the order of §11.1: the grid rows
    /// (grid and both modes), then the `(s, a)` of every source record in order (source and
    /// both modes). The one place a mode becomes rows, for the `f64` tables and the kernel.
    ///
    /// Errors: those of [`RowSet::new`] (no rows at all, a non-finite state).
    pub fn row_set<'a, T: Real, const D: usize>(
        self,
        grid: GridRows<'a, T, D>,
        sources: &'a [&'a [Transition<[T; D], T>]],
    ) -> awfqi::Result<RowSet<'a, T, D>> {
        let (points, pairs) = match (self, grid) {
            (Mode::Source, _) => (None, &[][..]),
            (_, GridRows::Points(grid, actions)) => (Some((grid, actions)), &[][..]),
            (_, GridRows::Pairs(pairs)) => (None, pairs),
        };
        let sources = if self == Mode::Grid { &[][..] } else { sources };
        RowSet::new(points, pairs, sources)
    }
}

/// The rows of `mode` as `(state, action)` pairs ([`Mode::row_set`] with the domain's grid
/// rows at `spacing`).
pub fn rows<const D: usize>(
    domain: &Domain<D>,
    mode: Mode,
    sources: &SourceSet<D>,
    spacing: f64,
) -> anyhow::Result<Vec<([f64; D], usize)>> {
    let grid = match mode {
        Mode::Source => Vec::new(),
        Mode::Grid | Mode::Both => (domain.grid_rows)(spacing)?,
    };
    let slices: Vec<&[Record<D>]> = sources
        .sources
        .iter()
        .map(|s| s.records.as_slice())
        .collect();
    let rows = mode
        .row_set(GridRows::Pairs(&grid), &slices)
        .map_err(|e| anyhow::anyhow!("the score table's rows: {e}"))?;
    Ok(rows.iter().collect())
}

/// The population variance of `values` as the core's score table computes it (shifted
/// two-pass: `d_j = v_j − v_1`, `mean(d²) − mean(d)²`, clipped at 0), so that the tables
/// of every domain share the core's numbers.
fn population_variance(values: impl Iterator<Item = f64>) -> f64 {
    let (mut first, mut s, mut q, mut m) = (None, 0.0, 0.0, 0.0);
    for v in values {
        let f = *first.get_or_insert(v);
        let d = v - f;
        s += d;
        q += d * d;
        m += 1.0;
    }
    let mean = s / m;
    (q / m - mean * mean).max(0.0)
}

/// A computed table: rows and their scores `V_r`.
#[derive(Debug, Clone)]
pub struct ScoreTableData<const D: usize = 2> {
    /// The row mode.
    pub mode: Mode,
    /// `true` for the oracle table.
    pub oracle: bool,
    /// The rows.
    pub rows: Vec<([f64; D], usize)>,
    /// Their scores `V_r`.
    pub reward_variance: Vec<f64>,
}

impl<const D: usize> ScoreTableData<D> {
    /// The oracle table (§11.2): `V_r` of the sources' noise-free mean rewards.
    ///
    /// Errors: a row outside a source's state space; non-finite values.
    pub fn oracle(
        domain: &Domain<D>,
        mode: Mode,
        sources: &SourceSet<D>,
        spacing: f64,
    ) -> anyhow::Result<Self> {
        let rows = rows(domain, mode, sources, spacing)?;
        let reward_variance = rows
            .iter()
            .map(|&(s, a)| {
                let values = domain
                    .sources
                    .iter()
                    .map(|m| m.mean_reward(s, a))
                    .collect::<awfqi::Result<Vec<f64>>>()?;
                let v = population_variance(values.into_iter());
                anyhow::ensure!(v.is_finite(), "non-finite oracle score at {s:?}, {a}");
                Ok(v)
            })
            .collect::<anyhow::Result<_>>()?;
        Ok(Self {
            mode,
            oracle: true,
            rows,
            reward_variance,
        })
    }

    /// The realistic table (§11.2): `V_r` of the posterior means of each source's reward
    /// GP (`gps[j]` fitted on source `j` only).
    pub fn realistic(
        domain: &Domain<D>,
        mode: Mode,
        sources: &SourceSet<D>,
        gps: &[SourceGps],
        spacing: f64,
    ) -> anyhow::Result<Self> {
        use rayon::prelude::*;
        let rows = rows(domain, mode, sources, spacing)?;
        let zs: Vec<GpInput> = rows.iter().map(|(s, a)| domain.gp_input(s, *a)).collect();
        // predictions[j][row]: the reward GP is the first of each source's.
        let predictions: Vec<Vec<f64>> = gps.par_iter().map(|g| g.gps[0].means(&zs)).collect();
        let reward_variance = (0..rows.len())
            .map(|i| population_variance(predictions.iter().map(|p| p[i])))
            .collect();
        Ok(Self {
            mode,
            oracle: false,
            rows,
            reward_variance,
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
        if self.reward_variance.iter().all(|&x| x <= 0.0) {
            vec![1.0; self.reward_variance.len()]
        } else {
            self.reward_variance.clone()
        }
    }

    /// Draws `n` rows i.i.d. with replacement with probability ∝ `V_r` (§12 step 1), one
    /// `u64` per draw. Returns the drawn row indices.
    pub fn draw(&self, n: usize, rng: &mut ChaCha8Rng) -> anyhow::Result<Vec<usize>> {
        let mut storage = vec![AliasEntry::<f64>::default(); self.len()];
        let alias = AliasTable::build(self.sampling_weights(), &mut storage)?;
        Ok((0..n).map(|_| alias.sample(rng)).collect())
    }
}

/// Fits the realistic tables' source reward GPs (on all the source's records whatever
/// `options.max_gp` says), each source from its own stream (seed, SCORE_TABLE, source), in
/// parallel.
pub fn fit_source_gps<const D: usize>(
    domain: &Domain<D>,
    weighting: &Weighting<D>,
    sources: &SourceSet<D>,
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
            SourceGps::fit(
                domain,
                weighting,
                &s.records,
                &[Output::Reward],
                &all,
                &mut rng,
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domains::puddle;
    use awfqi::env::Dynamics;
    use rand_core::SeedableRng;

    #[test]
    fn row_counts_follow_the_modes() {
        let domain = puddle::domain(Dynamics::Shared);
        let sources = SourceSet::published(Dynamics::Shared).unwrap();
        assert_eq!(
            rows(&domain, Mode::Grid, &sources, 0.1).unwrap().len(),
            40_804
        );
        assert_eq!(
            rows(&domain, Mode::Source, &sources, 0.1).unwrap().len(),
            1033
        );
        let both = rows(&domain, Mode::Both, &sources, 0.1).unwrap();
        assert_eq!(both.len(), 40_804 + 1033);
        assert_eq!(both[40_804], (sources.sources[0].records[0].state, 2));
        // Grid coordinates are 0.1 × integer, action fastest.
        assert_eq!(both[4 * 101 + 1], ([0.0, 0.1], 1));
        assert_eq!(both[4 * 100 + 3], ([10.0, 0.0], 3));
    }

    #[test]
    fn population_variance_is_the_shifted_two_pass_one() {
        assert_eq!(population_variance([3.0, 3.0, 3.0].into_iter()), 0.0);
        let v = population_variance([1.0, 2.0, 6.0].into_iter());
        assert!((v - 42.0 / 9.0).abs() < 1e-12, "{v}");
        // Large close values keep their variance (a naive E[x²] − E[x]² loses it).
        let v = population_variance([1e9 + 1.0, 1e9 + 2.0].into_iter());
        assert!((v - 0.25).abs() < 1e-9, "{v}");
    }

    #[test]
    fn oracle_grid_table_concentrates_where_the_sources_disagree() {
        let domain = puddle::domain(Dynamics::Shared);
        let sources = SourceSet::published(Dynamics::Shared).unwrap();
        let table = ScoreTableData::oracle(&domain, Mode::Grid, &sources, 0.1).unwrap();
        // At (2, 2) source 2 has a puddle (r̄ = −22.53) and sources 1, 3 do not
        // (r̄ = −1.000074): population variance = (2/9)·(21.527397)² ≈ 102.98.
        let i = table
            .rows
            .iter()
            .position(|&(s, a)| (s[0] - 2.0).abs() < 1e-9 && (s[1] - 2.0).abs() < 1e-9 && a == 0)
            .unwrap();
        let d: f64 = -22.527471 + 1.000074;
        assert!((table.reward_variance[i] - 2.0 / 9.0 * d * d).abs() < 1e-3);
        // The same numbers as the core's score table.
        let worlds = awfqi::env::PuddleWorld::<f64>::sources(Dynamics::Shared);
        let grid = awfqi::env::PuddleWorld::score_grid(0.1).unwrap();
        let set = awfqi::score::RowSet::grid(grid, 4).unwrap();
        let mut storage = vec![awfqi::score::Scores::default(); set.len()];
        awfqi::score::ScoreTable::compute(set, &worlds, &mut storage).unwrap();
        for (ours, core) in table.reward_variance.iter().zip(&storage) {
            assert_eq!(ours.to_bits(), core.reward.to_bits());
        }
        // Drawing follows V_r: the draws land where V_r is large.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let draws = table.draw(2000, &mut rng).unwrap();
        let v = &table.reward_variance;
        let mean_score: f64 = draws.iter().map(|&d| v[d]).sum::<f64>() / 2000.0;
        // Under P ∝ V the expected score of a draw is ΣV²/ΣV, with variance ΣV³/ΣV − (ΣV²/ΣV)².
        let moment = |p: i32| v.iter().map(|x| x.powi(p)).sum::<f64>();
        let expected = moment(2) / moment(1);
        let se = ((moment(3) / moment(1) - expected * expected) / 2000.0).sqrt();
        assert!(
            (mean_score - expected).abs() < 5.0 * se,
            "{mean_score} vs {expected} ± {se}"
        );
    }
}
