//! One file per subcommand: its clap arguments and a `run` function.
pub mod sysid;
