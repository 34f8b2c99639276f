//! Environments: the tasks the algorithms learn in. They implement the interfaces of
//! [`crate::model`]: [`GenerativeModel`](crate::model::GenerativeModel), the one door through
//! which the algorithms touch a target task, and where known [`crate::model::SourceModel`]
//! and [`FiniteMdp`](crate::model::FiniteMdp).
//!
//! - [`PuddleWorld`]: the continuous 10×10 Puddle World of spec §2 (both dynamics variants).
//! - [`GridWorld`]: the finite 10×10 Grid World of spec §10.4, exposed as a [`FiniteMdp`](crate::model::FiniteMdp)
//!   whose exact transition probabilities and Gaussian reward models feed the
//!   identification scores and beliefs.
//! - [`Dam`]: the IWFQI paper's water reservoir (2-D state, eight releases).
//! - [`Acrobot`]: the IWFQI paper's multitask Acrobot (4-D state, two torques, swing-up or
//!   rotate).
//! - [`Zones`]: three heated zones in a row (3-D state, four actions; the zones firmware
//!   example's plant).
//! - [`Thermal`]: a heated room with a slow wall and a lagging heater element (3-D state,
//!   three commands).
//! - [`Tanks`]: two tanks in cascade with two ramping pumps (4-D state, nine actions).
//!
//! The last three live on the unit box `[0, 1]^D`; each has a target and sources that
//! agree with it on part of the problem (rewards or dynamics), and a hand-written
//! controller.
//!
//! A plant of your own joins the transfer path by implementing [`GenerativeModel`](crate::model::GenerativeModel) with a
//! state `[T; D]` (and, optionally, [`crate::model::SourceModel`] with its noise-free mean
//! functions, for oracle scores and ideal weights).

mod acrobot;
mod dam;
mod grid_world;
mod puddle;
mod tanks;
mod thermal;
mod unit_box;
mod zones;

pub use acrobot::*;
pub use dam::*;
pub use grid_world::GridWorld;
pub use grid_world::{GRID_WORLD_ACTIONS, THESIS_GOALS};
pub use puddle::*;
pub use tanks::*;
pub use thermal::*;
pub use zones::*;
