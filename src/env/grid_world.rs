//! The finite Grid World of spec §10.4: candidate MDPs that share deterministic moves and
//! differ only in where their single rewarding goal cell is.

use crate::error::{Error, Result};
use crate::float::Real;
use crate::model::{FiniteMdp, GenerativeModel, Transition};
use crate::rng;
use rand_core::Rng;

/// Number of actions: 0 = x+1, 1 = x−1, 2 = y+1, 3 = y−1 (the Puddle World encoding).
pub const GRID_WORLD_ACTIONS: usize = 4;

/// A rectangular grid of cells `(x, y)`, state index `x + width·y`, with one goal cell
/// giving mean reward 1 (0 elsewhere) and Gaussian reward noise.
///
/// Moves go one cell in the action's direction; a move off the grid leaves the state
/// unchanged. By default the goal is not absorbing, so all candidates share their
/// transitions (the thesis setting); with `absorbing_goal` every action at the goal loops
/// back to it, which makes the candidates' transitions differ as well.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridWorld<T> {
    width: usize,
    height: usize,
    goal: usize,
    reward_variance: T,
    absorbing_goal: bool,
}

/// The goal cells of the thesis study's K = 4 candidates (spec §10.4).
pub const THESIS_GOALS: [(usize, usize); 4] = [(9, 9), (9, 0), (0, 9), (5, 5)];

impl<T: Real> GridWorld<T> {
    /// A `width × height` grid whose goal is cell `goal = (x, y)`.
    ///
    /// Errors: a zero dimension or a grid with more than `u32::MAX` cells
    /// ([`Error::InvalidParameter`]), a goal outside the grid ([`Error::OutOfRange`]), a
    /// non-finite or non-positive reward variance.
    pub fn new(
        width: usize,
        height: usize,
        goal: (usize, usize),
        reward_variance: T,
        absorbing_goal: bool,
    ) -> Result<Self> {
        if width == 0 {
            return Err(Error::InvalidParameter { parameter: "width" });
        }
        if height == 0 {
            return Err(Error::InvalidParameter {
                parameter: "height",
            });
        }
        let cells = width
            .checked_mul(height)
            .filter(|&c| c <= u32::MAX as usize);
        let Some(_) = cells else {
            return Err(Error::InvalidParameter {
                parameter: "height",
            });
        };
        if goal.0 >= width || goal.1 >= height {
            return Err(Error::OutOfRange { parameter: "goal" });
        }
        crate::error::ensure_finite(reward_variance, "reward_variance")?;
        if reward_variance <= T::ZERO {
            return Err(Error::InvalidParameter {
                parameter: "reward_variance",
            });
        }
        Ok(Self {
            width,
            height,
            goal: goal.0 + width * goal.1,
            reward_variance,
            absorbing_goal,
        })
    }

    /// Candidate `index` (0..4) of the thesis study: 10×10, goal `THESIS_GOALS[index]`,
    /// reward variance 0.25.
    ///
    /// Errors: `index >= 4` ([`Error::OutOfRange`]).
    pub fn thesis(index: usize, absorbing_goal: bool) -> Result<Self> {
        let goal = *THESIS_GOALS
            .get(index)
            .ok_or(Error::OutOfRange { parameter: "index" })?;
        Self::new(10, 10, goal, T::from_f64(0.25), absorbing_goal)
    }

    /// All four candidates of the thesis study, in the order of [`THESIS_GOALS`].
    pub fn thesis_candidates(absorbing_goal: bool) -> [Self; 4] {
        let make = |(x, y): (usize, usize)| Self {
            width: 10,
            height: 10,
            goal: x + 10 * y,
            reward_variance: T::from_f64(0.25),
            absorbing_goal,
        };
        THESIS_GOALS.map(make)
    }

    /// Width of the grid (cells along x).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height of the grid (cells along y).
    pub fn height(&self) -> usize {
        self.height
    }

    /// The goal's state index.
    pub fn goal(&self) -> usize {
        self.goal
    }

    /// Whether the goal loops to itself under every action.
    pub fn absorbing_goal(&self) -> bool {
        self.absorbing_goal
    }

    /// The state index of cell `(x, y)`.
    ///
    /// Errors: a cell outside the grid.
    pub fn state_of(&self, x: usize, y: usize) -> Result<usize> {
        if x < self.width && y < self.height {
            Ok(x + self.width * y)
        } else {
            Err(Error::OutOfRange { parameter: "cell" })
        }
    }

    /// The cell `(x, y)` of a state index.
    ///
    /// Errors: a state outside the grid.
    pub fn cell_of(&self, state: usize) -> Result<(usize, usize)> {
        self.check_state(state)?;
        self.split(state)
    }

    /// The unique successor of `(state, action)`: moves are deterministic.
    ///
    /// Errors: `state` or `action` out of range.
    pub fn next_state(&self, state: usize, action: usize) -> Result<usize> {
        self.check(state, action)?;
        if self.absorbing_goal && state == self.goal {
            return Ok(state);
        }
        let (x, y) = self.split(state)?;
        let (nx, ny) = match action {
            0 if x + 1 < self.width => (x + 1, y),
            1 if x > 0 => (x - 1, y),
            2 if y + 1 < self.height => (x, y + 1),
            3 if y > 0 => (x, y - 1),
            _ => (x, y),
        };
        Ok(nx + self.width * ny)
    }

    /// `(state % width, state / width)`; checked division, so no division-by-zero panic
    /// path survives (the constructor already guarantees `width > 0`).
    fn split(&self, state: usize) -> Result<(usize, usize)> {
        match (state.checked_rem(self.width), state.checked_div(self.width)) {
            (Some(x), Some(y)) => Ok((x, y)),
            _ => Err(Error::OutOfRange { parameter: "state" }),
        }
    }

    fn check_state(&self, state: usize) -> Result<()> {
        if state < self.width * self.height {
            Ok(())
        } else {
            Err(Error::OutOfRange { parameter: "state" })
        }
    }

    fn check(&self, state: usize, action: usize) -> Result<()> {
        self.check_state(state)?;
        if action < GRID_WORLD_ACTIONS {
            Ok(())
        } else {
            Err(Error::OutOfRange {
                parameter: "action",
            })
        }
    }
}

impl<T: Real> FiniteMdp<T> for GridWorld<T> {
    fn num_states(&self) -> usize {
        self.width * self.height
    }

    fn num_actions(&self) -> usize {
        GRID_WORLD_ACTIONS
    }

    fn initial_state(&self) -> usize {
        0
    }

    fn transition_probability(&self, state: usize, action: usize, next_state: usize) -> Result<T> {
        self.check_state(next_state)
            .map_err(|_| Error::OutOfRange {
                parameter: "next_state",
            })?;
        Ok(if self.next_state(state, action)? == next_state {
            T::ONE
        } else {
            T::ZERO
        })
    }

    fn for_each_successor<F: FnMut(usize, T)>(
        &self,
        state: usize,
        action: usize,
        mut visit: F,
    ) -> Result<()> {
        visit(self.next_state(state, action)?, T::ONE);
        Ok(())
    }

    fn reward_mean(&self, state: usize, action: usize) -> Result<T> {
        self.check(state, action)?;
        Ok(if state == self.goal { T::ONE } else { T::ZERO })
    }

    fn reward_variance(&self, state: usize, action: usize) -> Result<T> {
        self.check(state, action)?;
        Ok(self.reward_variance)
    }
}

impl<T: Real> GenerativeModel<T> for GridWorld<T> {
    type State = usize;

    fn num_actions(&self) -> usize {
        GRID_WORLD_ACTIONS
    }

    /// Draws `S′ ~ p(· | s, a)` (deterministic here) and `R ~ 𝒩(r(s, a), v)` independently;
    /// consumes the draws of one standard normal. `absorbing` is set when `S′` is an
    /// absorbing goal.
    fn query<R: Rng + ?Sized>(
        &self,
        state: usize,
        action: usize,
        rng: &mut R,
    ) -> Result<Transition<usize, T>> {
        let next_state = self.next_state(state, action)?;
        let mean = self.reward_mean(state, action)?;
        let reward = rng::normal(rng, mean, self.reward_variance.sqrt())?;
        Ok(Transition {
            state,
            action,
            reward,
            next_state,
            absorbing: self.absorbing_goal && next_state == self.goal,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_chacha::ChaCha8Rng;
    use rand_core::SeedableRng;

    #[test]
    fn every_transition_row_sums_to_one() {
        for absorbing in [false, true] {
            for mdp in GridWorld::<f64>::thesis_candidates(absorbing) {
                for s in 0..100 {
                    for a in 0..4 {
                        let total: f64 = (0..100)
                            .map(|n| mdp.transition_probability(s, a, n).unwrap())
                            .sum();
                        assert_eq!(total, 1.0, "row ({s},{a}) absorbing={absorbing}");
                        let mut visited = 0.0;
                        mdp.for_each_successor(s, a, |n, p| {
                            assert_eq!(mdp.transition_probability(s, a, n).unwrap(), p);
                            visited += p;
                        })
                        .unwrap();
                        assert_eq!(visited, 1.0);
                    }
                }
            }
        }
    }

    #[test]
    fn moves_follow_the_action_encoding_and_stop_at_walls() {
        let g = GridWorld::<f32>::thesis(0, false).unwrap();
        let s = g.state_of(3, 4).unwrap();
        assert_eq!(g.cell_of(g.next_state(s, 0).unwrap()).unwrap(), (4, 4));
        assert_eq!(g.cell_of(g.next_state(s, 1).unwrap()).unwrap(), (2, 4));
        assert_eq!(g.cell_of(g.next_state(s, 2).unwrap()).unwrap(), (3, 5));
        assert_eq!(g.cell_of(g.next_state(s, 3).unwrap()).unwrap(), (3, 3));
        assert_eq!(g.next_state(0, 1).unwrap(), 0, "left wall");
        assert_eq!(g.next_state(0, 3).unwrap(), 0, "bottom wall");
        assert_eq!(g.next_state(99, 0).unwrap(), 99, "right wall");
        assert_eq!(g.next_state(99, 2).unwrap(), 99, "top wall");
        // Non-absorbing goal: the agent walks off it.
        assert_eq!(g.next_state(99, 1).unwrap(), 98);
    }

    #[test]
    fn absorbing_goal_loops_and_candidates_then_differ_in_transitions() {
        let [a, b, ..] = GridWorld::<f64>::thesis_candidates(true);
        assert_eq!(a.next_state(99, 1).unwrap(), 99);
        assert_eq!(b.next_state(99, 1).unwrap(), 98);
        assert_eq!(a.transition_probability(99, 1, 99).unwrap(), 1.0);
        assert_eq!(b.transition_probability(99, 1, 99).unwrap(), 0.0);
    }

    #[test]
    fn rewards_are_one_at_the_goal_only() {
        let c = GridWorld::<f64>::thesis_candidates(false);
        assert_eq!(c[3].goal(), 55);
        for s in 0..100 {
            for a in 0..4 {
                let want = if s == 55 { 1.0 } else { 0.0 };
                assert_eq!(c[3].reward_mean(s, a).unwrap(), want);
                assert_eq!(c[3].reward_variance(s, a).unwrap(), 0.25);
            }
        }
    }

    #[test]
    fn sampled_rewards_have_the_model_mean_and_variance() {
        let g = GridWorld::<f64>::thesis(0, false).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let n = 20_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let t = g.query(99, 2, &mut rng).unwrap();
            assert_eq!(t.next_state, 99);
            assert!(!t.absorbing);
            sum += t.reward;
            sum2 += t.reward * t.reward;
        }
        let mean = sum / n as f64;
        let var = sum2 / n as f64 - mean * mean;
        // Standard error of the mean: 0.5/sqrt(n) = 0.0035.
        assert!((mean - 1.0).abs() < 0.018, "mean {mean}");
        assert!((var - 0.25).abs() < 0.015, "variance {var}");
    }

    #[test]
    fn bad_arguments_are_typed_errors() {
        let g = GridWorld::<f32>::thesis(1, true).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        assert_eq!(
            g.query(100, 0, &mut rng),
            Err(Error::OutOfRange { parameter: "state" })
        );
        assert_eq!(
            g.query(0, 4, &mut rng),
            Err(Error::OutOfRange {
                parameter: "action"
            })
        );
        assert_eq!(
            g.transition_probability(0, 0, 100),
            Err(Error::OutOfRange {
                parameter: "next_state"
            })
        );
        assert_eq!(
            GridWorld::<f32>::thesis(4, false),
            Err(Error::OutOfRange { parameter: "index" })
        );
        assert_eq!(
            GridWorld::new(0, 3, (0, 0), 0.25f32, false),
            Err(Error::InvalidParameter { parameter: "width" })
        );
        assert_eq!(
            GridWorld::new(3, 3, (3, 0), 0.25f32, false),
            Err(Error::OutOfRange { parameter: "goal" })
        );
        assert_eq!(
            GridWorld::new(3, 3, (0, 0), 0.0f32, false),
            Err(Error::InvalidParameter {
                parameter: "reward_variance"
            })
        );
        assert_eq!(
            GridWorld::new(3, 3, (0, 0), f32::NAN, false),
            Err(Error::NonFinite {
                parameter: "reward_variance"
            })
        );
        assert_eq!(
            g.cell_of(100),
            Err(Error::OutOfRange { parameter: "state" })
        );
        assert_eq!(
            g.state_of(10, 0),
            Err(Error::OutOfRange { parameter: "cell" })
        );
        // Query on the absorbing goal reports absorption.
        let t = g.query(90, 0, &mut rng);
        assert!(t.is_ok());
        let goal = GridWorld::<f32>::thesis(2, true).unwrap();
        assert!(goal.query(90, 0, &mut rng).unwrap().absorbing);
    }
}
