//! Reference implementations: f64, heap-allocated, written to be read and checked by eye,
//! never optimised. The core's differential tests compare against these.

pub mod gp;
pub mod identify;
