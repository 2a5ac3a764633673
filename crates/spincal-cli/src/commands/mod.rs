//! One file per subcommand: its clap arguments and a `run` function.

pub mod correct;
pub mod strobe;
pub mod sweep;
pub mod train;
