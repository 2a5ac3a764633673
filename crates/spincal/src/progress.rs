//! One progress shape for every long operation: solvers, the turntable fit, network sweeps, the
//! whole calibration. The library never prints; it calls an [`Observer`], and the binary (or the
//! caller) decides what to show.
//!
//! ```
//! use spincal::progress::{silent, Progress};
//! let show = |p: Progress| {
//!     let _ = (p.stage, p.done, p.total, p.cost);
//! };
//! # let _ = show;
//! // Where nothing should be shown:
//! let observer: &spincal::progress::Observer = &silent;
//! observer(Progress::step("example", 1, None));
//! ```

/// Where a long operation stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress<'a> {
    /// What is running, for people: `"Nelder–Mead"`, `"turntable fit: Levenberg–Marquardt"`,
    /// `"network sweep"`.
    pub stage: &'a str,
    /// Steps done: solver iterations, sweep runs finished, stages finished.
    pub done: usize,
    /// Steps in all, where known beforehand (a sweep knows; an iterative solver does not).
    pub total: Option<usize>,
    /// The current objective where there is one (sum of squared residuals for least squares).
    pub cost: Option<f64>,
}

impl<'a> Progress<'a> {
    /// A step of a stage, without an objective.
    pub fn step(stage: &'a str, done: usize, total: Option<usize>) -> Progress<'a> {
        Progress {
            stage,
            done,
            total,
            cost: None,
        }
    }

    /// The same progress under another stage name (a caller naming what its solver is doing).
    pub fn in_stage(self, stage: &'a str) -> Progress<'a> {
        Progress { stage, ..self }
    }
}

/// Every long operation takes `observer: &Observer`. It must be `Sync` because sweeps report from
/// several threads; interior mutability (an atomic, a progress bar) carries state.
pub type Observer<'a> = dyn Fn(Progress<'_>) + Sync + 'a;

/// The observer that shows nothing: pass `&silent`.
pub fn silent(_: Progress<'_>) {}

/// Wall time of one stage of a calibration, s.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct StageTime {
    pub stage: String,
    pub seconds: f64,
}
