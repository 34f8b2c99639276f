//! One module per subcommand of `awfqi-harness`.

pub mod demo;
pub mod gp;
