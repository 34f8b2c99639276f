//! One module per subcommand of `awfqi-harness`.

pub mod demo;
pub mod gp;
pub mod identify;
pub mod puddle;
