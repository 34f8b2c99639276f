//! Types of other crates in and out of the core, each behind its Cargo feature (none is a
//! dependency without it).
//!
//! - `nalgebra` (feature `nalgebra`): a controller whose states are
//!   `nalgebra::SVector`s reads all Q-values of a state as one vector, asks the greedy
//!   action or a value with its own state type, and hands its `SVector` plant to a learner.
//! - `heapless` (feature `heapless`): a step report's warnings as a
//!   `heapless::Vec` to keep, queue or send, refused with a typed error rather than cut
//!   short when the vector is too small.

#[cfg(feature = "heapless")]
#[cfg_attr(docsrs, doc(cfg(feature = "heapless")))]
pub mod heapless;
#[cfg(feature = "nalgebra")]
#[cfg_attr(docsrs, doc(cfg(feature = "nalgebra")))]
pub mod nalgebra;
