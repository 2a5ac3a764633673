//! One file per subcommand: its clap arguments and a `run` function.

pub mod calibrate;
pub mod correct;
pub mod demo;
pub mod fit;
pub mod input;
pub mod sensitivity;
pub mod simulate;
pub mod strobe;
pub mod sweep;
pub mod sysid;
pub mod train;
