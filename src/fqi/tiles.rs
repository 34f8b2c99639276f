//! Weighted FQI with tile coding: several offset tilings of the state space, each a table
//! fitted like [`TabularFqi`](super::TabularFqi), whose values are averaged (spec §5.1).
//!
//! A single table trades resolution against data: fine cells hold few samples, and the
//! nearest-cell filling of the many empty ones decides the policy (on Puddle World, 21 × 21
//! cells gave returns far below 11 × 11). Tile coding keeps coarse tiles, so every tile
//! pools many samples, and gets its resolution from `k` copies of the tiling shifted by
//! fractions of a tile: the prediction at `s` is the mean over tilings of the value of the
//! tile containing `s`, a piecewise-constant function on pieces `k` times narrower than a
//! tile along each axis.
//!
//! Each tiling is fitted as a weighted mean (iteration 1 with the reward weights, later ones
//! with the transition weights, as IWFQI does), so the Q-function is a convex combination of
//! regression targets — an *averager* in Gordon's sense, for which FQI is a contraction and
//! cannot diverge. Iteration `k ≥ 2` regresses
//! `yᵢ = R̂(sᵢ, aᵢ) + γ (1 − ωᵢ) maxₐ′ Q_{k−1}(s′ᵢ, a′)` in every tiling, where `R̂` and
//! `Q_{k−1}` are the tiling averages; pairs without data in a tiling are filled per tiling
//! by the [`EmptyCells`] rule, exactly as in the table.
//!
//! **Geometry.** `n` tiles of width `wᵈ = (upperᵈ − lowerᵈ)/n` per axis; tiling `t` is
//! shifted down by `wᵈ · ((t·(2d + 1)) mod k)/k` on axis `d` (the asymmetric displacements
//! of Miller and Glanz, which avoid the diagonal artefacts of equal shifts) and has `n + 1`
//! tiles per axis so that it still covers the box. With `k = 1` the tiling is the table of
//! `n + 1` cells over `[lower, lower + (n + 1)·w]`.
//!
//! **Memory.** `k · (n + 1)^D · actions` [`FqiEntry`] (20 bytes in `f32`); tiling after
//! tiling, within a tiling `tile·actions + action`. Puddle World with `n = 5`, `k = 8` and 4
//! actions: 1 152 entries = 23 040 bytes in `f32`. Fit cost per iteration:
//! `O(samples · k · actions)`.

use super::argmax::ArgMax;
use super::entry::NIL;
use super::fill::{fill_empty, nearest_donors};
use super::iteration::{self, NoDraws, Regressor};
use super::samples::each;
use super::{EmptyCells, FqiConfig, FqiEntry, SampleSet};
use crate::error::ensure_finite;
use crate::error::{Error, Result};
use crate::float::Real;
use crate::fqi::CellGrid;
use rand_core::Rng;

/// The geometry of `k` offset tilings of the box `[lower, upper]`, `n` tiles per axis each
/// (see the module docs). Size: `3D` scalars and `D + 2` words.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Tilings<T, const D: usize> {
    lower: [T; D],
    width: [T; D],
    tiles: usize,
    count: usize,
    /// The index geometry shared by every tiling: `(n + 1)^D` tiles.
    layout: CellGrid<T, D>,
}

impl<T: Real, const D: usize> Tilings<T, D> {
    /// `count` tilings of `tiles` tiles per axis over the box `[lower, upper]`.
    ///
    /// Errors: non-finite bounds ([`Error::NonFinite`] naming `lower` or `upper`),
    /// `lower ≥ upper` on an axis, `tiles == 0` or `count == 0`
    /// ([`Error::InvalidParameter`] naming `upper`, `tiles` or `count`), more than
    /// `u32::MAX − 1` tiles per tiling ([`Error::CapacityExceeded`]).
    pub fn new(lower: [T; D], upper: [T; D], tiles: usize, count: usize) -> Result<Self> {
        if tiles == 0 {
            return Err(Error::InvalidParameter { parameter: "tiles" });
        }
        if count == 0 {
            return Err(Error::InvalidParameter { parameter: "count" });
        }
        let per_axis = tiles.checked_add(1).ok_or(Error::CapacityExceeded {
            capacity: usize::MAX,
        })?;
        // Validates the bounds (finite, increasing) and the tile count.
        CellGrid::new(lower, upper, [tiles; D])?;
        let mut width = lower;
        for ((w, &lo), &hi) in width.iter_mut().zip(&lower).zip(&upper) {
            *w = (hi - lo) / T::from_usize(tiles);
            ensure_finite(*w, "upper")?;
            if *w <= T::ZERO {
                return Err(Error::InvalidParameter { parameter: "upper" });
            }
        }
        let layout = CellGrid::new([T::ZERO; D], [T::ONE; D], [per_axis; D])?;
        Ok(Self {
            lower,
            width,
            tiles,
            count,
            layout,
        })
    }

    /// `count` tilings of `tiles` tiles per axis over the cube `[lower, upper]^D`.
    ///
    /// Errors: as [`Tilings::new`].
    pub fn cube(lower: T, upper: T, tiles: usize, count: usize) -> Result<Self> {
        Self::new([lower; D], [upper; D], tiles, count)
    }

    /// Tiles per axis of the box (`n`; each tiling has `n + 1` to cover it when shifted).
    pub fn tiles(&self) -> usize {
        self.tiles
    }

    /// Number of tilings `k`.
    pub fn count(&self) -> usize {
        self.count
    }

    /// Tiles in one tiling, `(n + 1)^D`.
    pub fn tiles_per_tiling(&self) -> usize {
        self.layout.len()
    }

    /// The lower corner of tiling `t` (shifted down by its offset).
    fn origin(&self, t: usize) -> [T; D] {
        let k = self.count;
        let mut out = self.lower;
        for (d, (o, &w)) in out.iter_mut().zip(&self.width).enumerate() {
            let step = t.wrapping_mul(2 * d + 1).checked_rem(k).unwrap_or(0);
            *o -= w * T::from_usize(step) / T::from_usize(k);
        }
        out
    }

    /// Index (within its tiling) of the tile of tiling `t` that contains the finite state
    /// `state`; states outside the box are clamped into border tiles.
    fn tile_of(&self, t: usize, state: &[T; D]) -> usize {
        let origin = self.origin(t);
        let n = self.tiles + 1;
        let mut index = 0;
        let mut stride = 1;
        for ((&x, &o), &w) in state.iter().zip(&origin).zip(&self.width) {
            let u = (x - o) / w;
            // `as` saturates (negative and NaN → 0), then clamp: the floor, clamped.
            let i = (u.to_f64() as usize).min(n - 1);
            index += i * stride;
            stride *= n;
        }
        index
    }
}

/// A Q-function by tile coding ([`Tilings`]) with `actions` actions, fitted by weighted
/// FQI, over caller-provided [`FqiEntry`] storage (see the module docs).
#[derive(Debug)]
pub struct TileFqi<'a, T, const D: usize> {
    tilings: Tilings<T, D>,
    actions: usize,
    entries: &'a mut [FqiEntry<T>],
}

impl<'a, T: Real, const D: usize> TileFqi<'a, T, D> {
    /// Number of [`FqiEntry`] the tilings need with `actions` actions (`None` on overflow).
    pub fn required_entries(tilings: &Tilings<T, D>, actions: usize) -> Option<usize> {
        tilings
            .tiles_per_tiling()
            .checked_mul(actions)?
            .checked_mul(tilings.count)
    }

    /// A Q-function that is 0 everywhere, in the first
    /// [`required_entries`](Self::required_entries) entries of `storage`.
    ///
    /// Errors: `actions == 0` ([`Error::InvalidParameter`]); `storage` too short
    /// ([`Error::CapacityExceeded`] with its length), or more entries per tiling than
    /// `u32::MAX − 1`.
    pub fn new(
        tilings: Tilings<T, D>,
        actions: usize,
        storage: &'a mut [FqiEntry<T>],
    ) -> Result<Self> {
        if actions == 0 {
            return Err(Error::InvalidParameter {
                parameter: "actions",
            });
        }
        let limit = NIL as usize - 1;
        tilings
            .tiles_per_tiling()
            .checked_mul(actions)
            .filter(|&n| n <= limit)
            .ok_or(Error::CapacityExceeded { capacity: limit })?;
        let needed = Self::required_entries(&tilings, actions).ok_or(Error::CapacityExceeded {
            capacity: usize::MAX,
        })?;
        let have = storage.len();
        let entries = storage
            .get_mut(..needed)
            .ok_or(Error::CapacityExceeded { capacity: have })?;
        entries.fill(FqiEntry::EMPTY);
        Ok(Self {
            tilings,
            actions,
            entries,
        })
    }

    /// The tilings.
    pub fn tilings(&self) -> &Tilings<T, D> {
        &self.tilings
    }

    /// Number of actions.
    pub fn actions(&self) -> usize {
        self.actions
    }

    /// The entries, tiling after tiling, `tile·actions + action` within a tiling.
    pub fn entries(&self) -> &[FqiEntry<T>] {
        self.entries
    }

    /// Resets Q to 0 everywhere.
    pub fn clear(&mut self) {
        self.entries.fill(FqiEntry::EMPTY);
    }

    /// Fits Q from scratch by weighted FQI on the union of `sets` (module docs).
    ///
    /// Everything is checked before the entries change. Errors: those of
    /// [`TabularFqi::fit`](super::TabularFqi::fit).
    pub fn fit(&mut self, sets: &[SampleSet<'_, T, D>], config: &FqiConfig<T>) -> Result<()> {
        self.fit_sets(sets.iter().copied(), config)
    }

    /// [`TileFqi::fit`] on sets produced by an iterator (cloned once per pass).
    ///
    /// Errors: those of [`TileFqi::fit`].
    pub fn fit_sets<'s, I>(&mut self, sets: I, config: &FqiConfig<T>) -> Result<()>
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
    {
        iteration::fit(self, sets, config, &mut NoDraws)
    }

    /// Runs `f` on every tiling's entries with the shared layout.
    fn for_each_tiling(&mut self, mut f: impl FnMut(&CellGrid<T, D>, usize, &mut [FqiEntry<T>])) {
        let per = self.tilings.tiles_per_tiling() * self.actions;
        if per == 0 {
            return;
        }
        for chunk in self.entries.chunks_mut(per) {
            f(&self.tilings.layout, self.actions, chunk);
        }
    }

    /// The entry index of `(tiling t, tile containing state, action)`.
    fn index(&self, t: usize, state: &[T; D], action: usize) -> usize {
        let per = self.tilings.tiles_per_tiling() * self.actions;
        t * per + self.tilings.tile_of(t, state) * self.actions + action
    }

    /// The mean over tilings of `field` of the tiles containing `state`, for `action`.
    fn average(&self, state: &[T; D], action: usize, field: impl Fn(&FqiEntry<T>) -> T) -> T {
        let mut sum = T::ZERO;
        for t in 0..self.tilings.count {
            if let Some(e) = self.entries.get(self.index(t, state, action)) {
                sum += field(e);
            }
        }
        sum / T::from_usize(self.tilings.count)
    }

    fn max_value_finite(&self, state: &[T; D]) -> T {
        (0..self.actions)
            .map(|a| self.average(state, a, |e| e.q))
            .fold(T::NEG_INFINITY, |m, q| if q > m { q } else { m })
    }

    /// `Q(state, action)`: the mean over tilings.
    ///
    /// Errors: a non-finite state, an action `≥ actions`.
    pub fn value(&self, state: [T; D], action: usize) -> Result<T> {
        crate::error::ensure_all_finite(&state, "state")?;
        if action >= self.actions {
            return Err(Error::OutOfRange {
                parameter: "action",
            });
        }
        Ok(self.average(&state, action, |e| e.q))
    }

    /// `maxₐ Q(state, a)`.
    ///
    /// Errors: a non-finite state.
    pub fn max_value(&self, state: [T; D]) -> Result<T> {
        crate::error::ensure_all_finite(&state, "state")?;
        Ok(self.max_value_finite(&state))
    }

    /// `true` when some tiling had a sample of positive transition weight for `action` in
    /// the tile containing `state` (the value is fitted there, not only filled).
    fn has_data(&self, state: &[T; D], action: usize) -> bool {
        (0..self.tilings.count).any(|t| {
            self.entries
                .get(self.index(t, state, action))
                .is_some_and(FqiEntry::has_data)
        })
    }

    /// The greedy action `argmaxₐ Q(state, a)`, with the table's tie rule: an action with
    /// data in some tiling first, then the smallest index.
    ///
    /// Errors: a non-finite state.
    pub fn greedy_action(&self, state: [T; D]) -> Result<usize> {
        crate::error::ensure_all_finite(&state, "state")?;
        let mut best = ArgMax::new();
        for a in 0..self.actions {
            best.offer(
                a,
                self.average(&state, a, |e| e.q),
                self.has_data(&state, a),
            );
        }
        Ok(best.action())
    }
}

impl<T: Real, const D: usize> Regressor<T, D> for TileFqi<'_, T, D> {
    fn actions(&self) -> usize {
        self.actions
    }

    /// In every tiling: `R̂_t` into `reward` and `q`, `Σ w_s` into `weight`.
    fn fit_reward_model<'s, I, R>(&mut self, sets: I, _: usize, config: &FqiConfig<T>, _: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        self.entries.fill(FqiEntry::EMPTY);
        for (s, reward, w_r, w_s) in each(sets) {
            for t in 0..self.tilings.count {
                let i = self.index(t, &s.state, s.action);
                if let Some(e) = self.entries.get_mut(i) {
                    e.add_reward(reward, w_r, w_s);
                }
            }
        }
        for e in self.entries.iter_mut() {
            e.close_reward_model(config.min_weight());
        }
        let empty = config.empty_cells();
        self.for_each_tiling(|grid, actions, entries| {
            nearest_donors(grid, actions, entries, |e| e.next > T::ZERO);
            fill_empty(
                entries,
                actions,
                empty,
                |e| e.next > T::ZERO,
                |e| &mut e.reward,
            );
        });
        for e in self.entries.iter_mut() {
            e.q = e.reward;
        }
    }

    /// Every tiling regresses `r̂ + γ(1−ω)V_{k−1}(s′)`.
    fn bellman_iteration<'s, I, R>(&mut self, sets: I, k: usize, config: &FqiConfig<T>, _: &mut R)
    where
        I: Iterator<Item = SampleSet<'s, T, D>> + Clone,
        T: 's,
        R: Rng + ?Sized,
    {
        if k == 2 {
            self.for_each_tiling(|grid, actions, entries| {
                nearest_donors(grid, actions, entries, |e| e.weight > T::ZERO);
            });
        }
        for e in self.entries.iter_mut() {
            e.next = T::ZERO;
        }
        let gamma = config.discount();
        for (s, _, _, w_s) in each(sets) {
            if w_s <= T::ZERO {
                continue;
            }
            let mut y = self.average(&s.state, s.action, |e| e.reward);
            if !s.absorbing {
                y += gamma * self.max_value_finite(&s.next_state);
            }
            for t in 0..self.tilings.count {
                let i = self.index(t, &s.state, s.action);
                if let Some(e) = self.entries.get_mut(i) {
                    e.next += w_s * y;
                }
            }
        }
        for e in self.entries.iter_mut() {
            if e.weight > T::ZERO {
                e.q = e.next / e.weight;
            }
        }
        let empty: EmptyCells<T> = config.empty_cells();
        self.for_each_tiling(|_, actions, entries| {
            fill_empty(
                entries,
                actions,
                empty,
                |e| e.weight > T::ZERO,
                |e| &mut e.q,
            );
        });
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::fqi::TabularFqi;
    use crate::model::Transition;
    use rand_chacha::ChaCha8Rng;
    use rand_core::{Rng, SeedableRng};
    use std::vec;
    use std::vec::Vec;

    type S1 = Transition<[f64; 1], f64>;

    /// Deterministic chain of 5 unit cells on [0, 5], states at the centres `c + 0.5`:
    /// action 0 moves right (reaching cell 4 is absorbing), action 1 left (clipped at 0),
    /// reward −1 per move.
    fn chain() -> Vec<S1> {
        let at = |c: usize| [c as f64 + 0.5];
        let mut v = Vec::new();
        for c in 0..4 {
            v.push(Transition {
                state: at(c),
                action: 0,
                reward: -1.0,
                next_state: at(c + 1),
                absorbing: c + 1 == 4,
            });
            v.push(Transition {
                state: at(c),
                action: 1,
                reward: -1.0,
                next_state: at(c.saturating_sub(1)),
                absorbing: false,
            });
        }
        v
    }

    #[test]
    fn two_tilings_on_a_chain_give_q_star_at_the_states_and_the_mean_between() {
        // Tiles of width 1; tiling 1 is shifted by half a tile, so every tile of either
        // tiling holds exactly one chain state: both tilings agree on Q* at the states,
        // and halfway between two states the prediction is the mean of their values.
        let gamma = 0.9f64;
        let tilings = Tilings::<f64, 1>::cube(0.0, 5.0, 5, 2).unwrap();
        assert_eq!(TileFqi::required_entries(&tilings, 2), Some(2 * 6 * 2));
        let mut storage = vec![FqiEntry::EMPTY; 24];
        let mut fqi = TileFqi::new(tilings, 2, &mut storage).unwrap();
        let samples = chain();
        let config = FqiConfig::new(gamma, 80, EmptyCells::Nearest).unwrap();
        fqi.fit(&[SampleSet::unweighted(&samples)], &config)
            .unwrap();
        let v_star = |c: usize| -(1.0 - gamma.powi(4 - c as i32)) / (1.0 - gamma);
        for c in 0..4 {
            let s = [c as f64 + 0.5];
            let right = fqi.value(s, 0).unwrap();
            let left = fqi.value(s, 1).unwrap();
            assert!((right - v_star(c)).abs() < 1e-9, "Q({c}, right) = {right}");
            let want_left = -1.0 + gamma * v_star(c.saturating_sub(1));
            assert!((left - want_left).abs() < 1e-9, "Q({c}, left) = {left}");
            assert_eq!(fqi.greedy_action(s).unwrap(), 0);
            assert!((fqi.max_value(s).unwrap() - v_star(c)).abs() < 1e-9);
        }
        for c in 0..3 {
            let mid = fqi.value([c as f64 + 1.0], 0).unwrap();
            let want = (v_star(c) + v_star(c + 1)) / 2.0;
            assert!(
                (mid - want).abs() < 1e-9,
                "between {c} and {}: {mid}",
                c + 1
            );
        }
    }

    fn random_samples(rng: &mut ChaCha8Rng, n: usize) -> Vec<Transition<[f64; 2], f64>> {
        let mut u =
            |lo: f64, hi: f64| lo + (hi - lo) * (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        (0..n)
            .map(|_| Transition {
                state: [u(0.0, 4.0), u(-1.0, 1.0)],
                action: (u(0.0, 3.0) as usize).min(2),
                reward: u(-2.0, 1.0),
                next_state: [u(0.0, 4.0), u(-1.0, 1.0)],
                absorbing: u(0.0, 1.0) < 0.1,
            })
            .collect()
    }

    #[test]
    fn one_tiling_is_the_table_of_its_tiles() {
        // k = 1: the tiling is a table of n + 1 cells over [lower, lower + (n + 1)·w]; the
        // tabular FQI on that grid is an independent reference (different regression of
        // the reward, same values), with weights, every fill rule and a minimum weight.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for (round, empty) in [
            EmptyCells::Nearest,
            EmptyCells::CappedNearest,
            EmptyCells::Value(-3.0),
        ]
        .into_iter()
        .enumerate()
        {
            let samples = random_samples(&mut rng, 60);
            let wr: Vec<f64> = (0..60).map(|i| ((i * 7) % 5) as f64 * 0.4).collect();
            let ws: Vec<f64> = (0..60).map(|i| ((i * 3) % 4) as f64 * 0.5).collect();
            let tilings = Tilings::new([0.0, -1.0], [4.0, 1.0], 4, 1).unwrap();
            let grid = CellGrid::new([0.0, -1.0], [5.0, 1.5], [5, 5]).unwrap();
            let config = FqiConfig::new(0.95, 30, empty)
                .unwrap()
                .with_min_weight(if round == 1 { 0.5 } else { 0.0 })
                .unwrap();
            let sets = [SampleSet::weighted(&samples, Some(&wr), Some(&ws))];
            let mut a = vec![FqiEntry::EMPTY; 75];
            let mut b = vec![FqiEntry::EMPTY; 75];
            let mut tiles = TileFqi::new(tilings, 3, &mut a).unwrap();
            let mut table = TabularFqi::new(grid, 3, &mut b).unwrap();
            tiles.fit(&sets, &config).unwrap();
            table.fit(&sets, &config).unwrap();
            for (x, y) in tiles.entries().iter().zip(table.entries()) {
                assert!(
                    (x.q() - y.q()).abs() < 1e-9 * (1.0 + y.q().abs()),
                    "{x:?} {y:?}"
                );
            }
            for s in &samples {
                assert_eq!(
                    tiles.greedy_action(s.next_state).unwrap(),
                    table.greedy_action(s.next_state).unwrap()
                );
            }
        }
    }

    #[test]
    fn offsets_follow_the_asymmetric_displacements() {
        // k = 4, n = 4 over [0, 4]²: tiling t is shifted by (t mod 4, 3t mod 4)/4 tiles.
        let tilings = Tilings::<f64, 2>::cube(0.0, 4.0, 4, 4).unwrap();
        assert_eq!(tilings.origin(0), [0.0, 0.0]);
        assert_eq!(tilings.origin(1), [-0.25, -0.75]);
        assert_eq!(tilings.origin(2), [-0.5, -0.5]);
        assert_eq!(tilings.origin(3), [-0.75, -0.25]);
        // (0.1, 0.1) in tiling 1: u = (0.35, 0.85) → tile (0, 0); (0.3, 0.3): (0.55, 1.05)
        // → tile (0, 1) = index 5.
        assert_eq!(tilings.tile_of(1, &[0.1, 0.1]), 0);
        assert_eq!(tilings.tile_of(1, &[0.3, 0.3]), 5);
        // Outside the box: clamped into border tiles.
        assert_eq!(tilings.tile_of(0, &[-7.0, 100.0]), 5 * 4);
        assert_eq!(tilings.tiles_per_tiling(), 25);
    }

    #[test]
    fn bad_input_is_refused_and_leaves_the_fit_intact() {
        assert_eq!(
            Tilings::<f32, 2>::cube(0.0, 1.0, 0, 2),
            Err(Error::InvalidParameter { parameter: "tiles" })
        );
        assert_eq!(
            Tilings::<f32, 2>::cube(0.0, 1.0, 3, 0),
            Err(Error::InvalidParameter { parameter: "count" })
        );
        assert!(Tilings::<f32, 2>::cube(1.0, 1.0, 3, 2).is_err());
        assert!(Tilings::<f32, 2>::cube(f32::NAN, 1.0, 3, 2).is_err());
        assert!(Tilings::<f32, 2>::cube(0.0, 1.0, usize::MAX, 2).is_err());
        assert!(Tilings::<f32, 4>::cube(0.0, 1.0, 1 << 10, 2).is_err());
        let tilings = Tilings::<f64, 2>::cube(0.0, 4.0, 3, 2).unwrap();
        let mut short = vec![FqiEntry::EMPTY; 2 * 16 * 3 - 1];
        assert_eq!(
            TileFqi::new(tilings, 3, &mut short).err(),
            Some(Error::CapacityExceeded { capacity: 95 })
        );
        assert_eq!(
            TileFqi::new(tilings, 0, &mut short).err(),
            Some(Error::InvalidParameter {
                parameter: "actions"
            })
        );
        let mut storage = vec![FqiEntry::EMPTY; 96];
        let mut fqi = TileFqi::new(tilings, 3, &mut storage).unwrap();
        let mut samples = random_samples(&mut ChaCha8Rng::seed_from_u64(3), 20);
        let config = FqiConfig::published();
        fqi.fit(&[SampleSet::unweighted(&samples)], &config)
            .unwrap();
        let before = fqi.entries().to_vec();
        samples[5].reward = f64::NAN;
        assert_eq!(
            fqi.fit(&[SampleSet::unweighted(&samples)], &config),
            Err(Error::NonFinite {
                parameter: "reward"
            })
        );
        samples[5].reward = 0.0;
        samples[6].action = 3;
        assert_eq!(
            fqi.fit(&[SampleSet::unweighted(&samples)], &config),
            Err(Error::OutOfRange {
                parameter: "action"
            })
        );
        assert_eq!(fqi.fit(&[], &config), Err(Error::EmptyData));
        assert!(fqi.entries() == &before[..]);
        assert!(fqi.value([f64::NAN, 0.0], 0).is_err());
        assert!(fqi.value([0.0, 0.0], 3).is_err());
        assert!(fqi.greedy_action([0.0, f64::INFINITY]).is_err());
        assert!(fqi.max_value([f64::NAN, 0.0]).is_err());
        fqi.clear();
        assert!(fqi.entries().iter().all(|e| e.q() == 0.0));
    }
}
