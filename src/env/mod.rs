//! Environments: the tasks the algorithms learn in. They implement the interfaces of
//! [`crate::model`] (re-exported here): [`GenerativeModel`], the one door through which the
//! algorithms touch a target task, and where known [`crate::model::SourceModel`] and
//! [`FiniteMdp`].
//!
//! - [`PuddleWorld`]: the continuous 10×10 Puddle World of spec §2 (both dynamics variants).
//! - [`GridWorld`]: the finite 10×10 Grid World of spec §10.4, exposed as a [`FiniteMdp`]
//!   whose exact transition probabilities and Gaussian reward models feed the
//!   identification scores and beliefs.
//! - [`Dam`]: the IWFQI paper's water reservoir (2-D state, eight releases).
//! - [`Acrobot`]: the IWFQI paper's multitask Acrobot (4-D state, two torques, swing-up or
//!   rotate).
//!
//! A plant of your own joins the transfer path by implementing [`GenerativeModel`] with a
//! state `[T; D]` (and, optionally, [`crate::model::SourceModel`] with its noise-free mean
//! functions, for oracle scores and ideal weights).

mod acrobot;
mod dam;
mod grid_world;
mod puddle;

pub use acrobot::*;
pub use dam::*;
pub use grid_world::GridWorld;
pub use grid_world::{GRID_WORLD_ACTIONS, THESIS_GOALS};
pub use puddle::*;
