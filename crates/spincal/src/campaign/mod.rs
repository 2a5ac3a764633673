//! Calibrating a unit from a campaign (SPEC §7): still poses and turntable runs of one sensor,
//! one physical sensor model fitted jointly with every run, and correctors chosen on conditions
//! they never trained on.
//!
//! `file` reads the campaign file, `prepare` cuts recordings into runs and poses, `checks` holds
//! them against physics before any fit, `thermal` takes them to a reference temperature, `joint` fits
//! the sensor model (`correctors::physical`) jointly with them, `candidate` is the one trait every
//! corrector kind implements (the paper's kinds in `series_candidates`), `evaluate` trains each
//! on what it may see and scores it on what it may not (held-out conditions, or the paper's
//! split), `verdict` judges a held-out condition by physics alone (and, in simulations, against
//! truth too), `choice` decides what is saved and `select` runs it all. `params` holds the
//! settings of every calibration, a campaign's or the paper's one-recording protocol
//! (`crate::calibrate`). `template` writes the commented campaign files `spincal init` starts
//! from; `unit_name` names a unit nobody named after its folder.

pub mod candidate;
pub mod checks;
pub mod choice;
pub mod error_map;
pub mod evaluate;
pub mod file;
pub mod gyro;
pub mod joint;
pub mod load;
pub mod paper;
pub mod params;
pub mod prepare;
pub mod run;
pub mod select;
pub mod series_candidates;
pub mod template;
pub mod thermal;
pub mod unit_name;
pub mod verdict;
