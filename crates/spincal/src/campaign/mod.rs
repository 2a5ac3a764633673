//! Calibrating a unit from a campaign (SPEC §7): still poses and turntable runs of one sensor,
//! one physical sensor model fitted jointly with every run, and correctors chosen on conditions
//! they never trained on.
//!
//! `file` reads the campaign file, `sensor` is the sensor model and its inverse (the `physical`
//! corrector), `joint` fits it.

pub mod file;
pub mod joint;
pub mod prepare;
pub mod sensor;

pub use file::{Campaign, CampaignEntry, CampaignError, EntryKind, SignedAxis, TurntableEntry};
pub use joint::{fit_joint, JointFit, JointSettings, PoseInput, RunInput, SensorTerms};
pub use sensor::{PhysicalCorrector, SensorModel};
