//! One module per subcommand of `awfqi-harness`.

pub mod acrobot;
pub mod choices;
pub mod dam;
pub mod demo;
pub mod gp;
pub mod identify;
pub mod merge;
pub mod puddle;
pub mod suite;
pub mod transfer;
