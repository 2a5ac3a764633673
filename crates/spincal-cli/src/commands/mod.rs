//! One file per subcommand: its clap arguments and a `run` function.

pub mod allan;
pub mod calibrate;
pub mod compare;
pub mod correct;
pub mod demo;
pub mod fit;
pub mod input;
pub mod inspect;
pub mod sensitivity;
pub mod simulate;
pub mod static_cal;
pub mod strobe;
pub mod sweep;
pub mod sysid;
pub mod tables;
pub mod train;
pub mod values;

pub use input::{format_line, InputArgs};
