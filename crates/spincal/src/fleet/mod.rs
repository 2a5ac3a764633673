//! Fleets: many units, each calibrated from its own campaign (SPEC §7), then compared.
//!
//! - [`calibrate_unit`]: one unit from a campaign file, or a folder holding `campaign.toml`. The
//!   same numbers as `spincal calibrate --campaign` (both go through [`crate::campaign::run::calibrate_campaign_file`]);
//!   the unit's own work runs on one thread (a one-thread rayon pool), so a fleet's units never
//!   nest parallelism.
//! - [`calibrate_fleet`]: every unit, `threads` at a time (one unit per worker, units taken in
//!   order from a shared counter, outcomes collected in input order). A unit that fails (or even
//!   panics) is reported in its [`UnitOutcome`]; the others go on. Results do not depend on the
//!   thread count: each unit's result is that of [`calibrate_unit`] alone.
//! - [`table::fleet_table`]: every sensor parameter with its standard error per unit, fleet
//!   statistics and outliers (rule in [`fleet_table`]).
//!
//! Worker threads are plain scoped threads, not a rayon pool: a rayon worker that waits on
//! another pool (the unit's one-thread pool) steals further units meanwhile, and so would run
//! more units at once than it has threads.

mod table;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::campaign::params::Params;

use crate::campaign::choice::HeldOutScore;
use crate::campaign::file::{Campaign, CampaignError};
use crate::campaign::joint::JointParam;
use crate::campaign::run::{calibrate_campaign_file, CampaignRunError};
use crate::campaign::select::{CampaignOutput, CampaignResult};
use crate::correctors::model_file::CorrectorFile;
use crate::output::OutputError;
use crate::progress::{Observer, Progress};

pub use table::{fleet_table, FleetRow, FleetTable, OutlierFlag, OutlierSettings, ParameterStats};

/// The file a unit folder must hold.
pub(crate) const CAMPAIGN_FILE: &str = "campaign.toml";

/// Settings of a fleet calibration.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct FleetSettings {
    /// The campaign calibration of every unit. `joint.gravity_mps2` is replaced by each campaign
    /// file's own `gravity_mps2` (as `spincal calibrate --campaign` does).
    pub params: Params,
    /// Units calibrated at once by [`calibrate_fleet`]; `None`: the machine's available cores.
    pub threads: Option<usize>,
}

/// Why one unit could not be calibrated; every message names the file (and line, key) at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FleetError {
    #[error("{folder}: no campaign file here; a unit folder must hold {CAMPAIGN_FILE} or exactly one other *.toml campaign file (give the campaign file itself or the folder that holds it)")]
    NoCampaign { folder: String },
    #[error("{folder}: several *.toml files ({files}) and no {CAMPAIGN_FILE}; name the unit's campaign file itself")]
    SeveralCampaigns { folder: String, files: String },
    #[error(transparent)]
    Campaign(#[from] CampaignError),
    #[error(transparent)]
    Run(#[from] CampaignRunError),
    #[error("{campaign}: cannot start the unit's worker thread: {message}")]
    Thread { campaign: String, message: String },
    #[error("{campaign}: internal error (a bug in spincal, please report it): {message}")]
    Panic { campaign: String, message: String },
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// One unit's calibration: everything `spincal calibrate --campaign` finds and writes.
#[derive(Debug, Clone, Serialize)]
pub struct UnitCalibration {
    /// The unit's name from its campaign file.
    pub unit: String,
    /// The campaign file.
    pub campaign: PathBuf,
    /// Every file read: the campaign file, its recordings and their truth and random-error files.
    pub inputs: Vec<PathBuf>,
    /// results.json: the joint fit (sensor parameters with robust standard errors), held-out
    /// scores of every candidate, the saved corrector's name and the verdict.
    pub result: CampaignResult,
    /// model.json, when a corrector held on every held-out condition.
    pub model: Option<CorrectorFile>,
}

impl UnitCalibration {
    /// The twelve sensor parameters (bias m/s², scale error, misalignment rad, quadratic
    /// 1/(m/s²)), each with its robust standard error.
    pub fn sensor_params(&self) -> &[JointParam] {
        &self.result.joint.sensor_params
    }

    /// The saved corrector's name (`physical`, `physical-linear`, `linear-12`), if any.
    pub fn saved(&self) -> Option<&str> {
        self.result.saved.as_deref()
    }

    /// Every candidate's RMS error on every held-out condition.
    pub fn held_out(&self) -> &[HeldOutScore] {
        &self.result.held_out
    }

    /// results.json's text, exactly as `spincal calibrate --campaign` writes it.
    pub fn results_json(&self) -> String {
        serde_json::to_string_pretty(&self.result).expect("results serialise") + "\n"
    }

    /// model.json's text, exactly as `spincal calibrate --campaign` writes it (when one was saved).
    pub fn model_json(&self) -> Option<String> {
        self.model.as_ref().map(|m| m.to_json() + "\n")
    }

    /// Writes results.json and (when saved) model.json into `dir` (created if missing), through
    /// `output::write_file`; refuses an output that is one of this unit's inputs.
    pub fn write(&self, dir: &Path) -> Result<(), FleetError> {
        let results = dir.join("results.json");
        let model = dir.join("model.json");
        let inputs: Vec<&Path> = self.inputs.iter().map(PathBuf::as_path).collect();
        crate::output::check_outputs(&inputs, &[&results, &model])?;
        crate::output::make_folders(dir).map_err(|source| OutputError::Io {
            path: dir.display().to_string(),
            source,
        })?;
        if let Some(text) = self.model_json() {
            crate::output::write_bytes(&model, text.as_bytes())?;
        }
        crate::output::write_bytes(&results, self.results_json().as_bytes())?;
        Ok(())
    }

    fn from_output(campaign: &Campaign, output: CampaignOutput) -> UnitCalibration {
        UnitCalibration {
            unit: campaign.unit.clone(),
            campaign: campaign.path.clone(),
            inputs: campaign.inputs(),
            result: output.result,
            model: output.saved,
        }
    }
}

/// One unit of a fleet: its name in the fleet, where it came from, and its calibration or the
/// located error that stopped it.
#[derive(Debug, Clone, Serialize)]
pub struct UnitOutcome {
    /// The unit's name in the fleet (`unit_label`, made unique): its output folder's name.
    pub unit: String,
    /// As given: a campaign file or a folder holding `campaign.toml`.
    pub source: PathBuf,
    pub result: Result<UnitCalibration, String>,
}

/// The `*.toml` files in `folder`, sorted.
fn toml_files(folder: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(folder)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "toml"))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    files
}

/// Whether `folder` holds a campaign file (`campaign.toml` or any `*.toml`).
fn holds_campaign(folder: &Path) -> bool {
    folder.join(CAMPAIGN_FILE).is_file() || !toml_files(folder).is_empty()
}

/// The campaign file of a source: the file itself; in a folder, `campaign.toml`, else the
/// folder's only `*.toml` file (the README's `unit.toml`, or any other name).
pub fn campaign_path(source: &Path) -> Result<PathBuf, FleetError> {
    if !source.is_dir() {
        return Ok(source.to_path_buf());
    }
    let preferred = source.join(CAMPAIGN_FILE);
    if preferred.is_file() {
        return Ok(preferred);
    }
    let mut files = toml_files(source);
    match files.len() {
        0 => Err(FleetError::NoCampaign {
            folder: source.display().to_string(),
        }),
        1 => Ok(files.remove(0)),
        _ => Err(FleetError::SeveralCampaigns {
            folder: source.display().to_string(),
            files: files
                .iter()
                .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
                .collect::<Vec<_>>()
                .join(", "),
        }),
    }
}

/// A unit's name from its source: a folder's name; for `…/campaign.toml`, its folder's name; for
/// any other file, its stem.
pub(crate) fn unit_label(source: &Path) -> String {
    let named = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
    let label = if source.is_dir() {
        named(source)
    } else if source.file_name().is_some_and(|n| n == CAMPAIGN_FILE) {
        source.parent().and_then(named)
    } else {
        source.file_stem().map(|n| n.to_string_lossy().into_owned())
    };
    match label {
        Some(l) if !l.is_empty() && l != "." && l != ".." => l,
        _ => "unit".into(),
    }
}

/// The labels of a fleet's sources, made unique by `-2`, `-3`, … in input order.
pub fn unit_labels(sources: &[PathBuf]) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(sources.len());
    for source in sources {
        let base = unit_label(source);
        let mut label = base.clone();
        let mut n = 1;
        while out.contains(&label) {
            n += 1;
            label = format!("{base}-{n}");
        }
        out.push(label);
    }
    out
}

/// Every file a fleet run into `out` writes: `fleet.csv`, `fleet.json`, `fleet.html`, then per
/// unit label `<label>/model.json`, `results.json` and `report.html`.
pub fn fleet_outputs(out: &Path, labels: &[String]) -> Vec<PathBuf> {
    let mut outputs: Vec<PathBuf> = ["fleet.csv", "fleet.json", "fleet.html"]
        .iter()
        .map(|n| out.join(n))
        .collect();
    for label in labels {
        for name in ["model.json", "results.json", "report.html"] {
            outputs.push(out.join(label).join(name));
        }
    }
    outputs
}

/// The files every readable campaign among `sources` names (a source that cannot be read is
/// left out here: it fails as its own unit when calibrated).
pub fn campaign_inputs(sources: &[PathBuf]) -> Vec<PathBuf> {
    let mut inputs = Vec::new();
    for source in sources {
        if let Ok(campaign) = campaign_path(source).and_then(|p| Ok(Campaign::read_path(&p)?)) {
            inputs.extend(campaign.inputs());
        }
    }
    inputs
}

/// The failed units of a fleet run as one message (`k of n units failed:` then `  unit: why`
/// per line); `None` when every unit was calibrated.
pub fn failures(outcomes: &[UnitOutcome]) -> Option<String> {
    let failed: Vec<String> = outcomes
        .iter()
        .filter_map(|o| o.result.as_ref().err().map(|e| format!("  {}: {e}", o.unit)))
        .collect();
    (!failed.is_empty()).then(|| {
        format!(
            "{} of {} units failed:\n{}",
            failed.len(),
            outcomes.len(),
            failed.join("\n")
        )
    })
}

/// The units a fleet run calibrates, and the folders it leaves out with the reason.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sources {
    /// In order: each path as given, or a fleet folder's sub-folders in name order.
    pub units: Vec<PathBuf>,
    /// (folder, why) for each sub-folder of a fleet folder that is not a unit.
    pub skipped: Vec<(PathBuf, String)>,
}

/// The units named by `paths`: each as given, except a folder holding no campaign file whose
/// sub-folders hold one (a fleet, as `spincal simulate --fleet` writes): it stands for its
/// sub-folders in name order. Every such sub-folder is a unit, one without a campaign file too
/// (it fails as its own unit, so nothing is left out unseen), apart from hidden folders and the
/// folders in `exclude` (the run's output folder), which are listed in `skipped` with the reason.
/// Anything else (a missing path, a folder holding nothing) stays, to fail as its own unit.
pub fn expand_sources(paths: &[PathBuf], exclude: &[&Path]) -> Sources {
    let mut sources = Sources::default();
    let excluded = |p: &Path| {
        let canonical = std::fs::canonicalize(p).ok();
        exclude
            .iter()
            .any(|e| canonical.is_some() && std::fs::canonicalize(e).ok() == canonical)
    };
    for path in paths {
        if path.is_dir() && !holds_campaign(path) {
            let mut folders: Vec<PathBuf> = std::fs::read_dir(path)
                .map(|entries| {
                    entries
                        .filter_map(Result::ok)
                        .map(|e| e.path())
                        .filter(|p| p.is_dir())
                        .collect()
                })
                .unwrap_or_default();
            folders.sort();
            if folders.iter().any(|f| holds_campaign(f)) {
                for folder in folders {
                    let hidden = folder
                        .file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with('.'));
                    if excluded(&folder) {
                        sources
                            .skipped
                            .push((folder, "the run's own output folder".into()));
                    } else if hidden {
                        sources.skipped.push((folder, "a hidden folder".into()));
                    } else {
                        sources.units.push(folder);
                    }
                }
                continue;
            }
        }
        sources.units.push(path.clone());
    }
    sources
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".into())
}

/// Calibrates one unit from a campaign file, or a folder holding `campaign.toml`, on one thread.
/// The numbers are those of `spincal calibrate --campaign` on the same file (results.json equal
/// apart from the wall times `seconds_total` and `stage_seconds`).
pub fn calibrate_unit(
    source: &Path,
    settings: &FleetSettings,
    observer: &Observer,
) -> Result<UnitCalibration, FleetError> {
    let path = campaign_path(source)?;
    let campaign = Campaign::read_path(&path)?;
    let name = campaign.path.display().to_string();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .thread_name(|_| "spincal-unit".into())
        .build()
        .map_err(|e| FleetError::Thread {
            campaign: name.clone(),
            message: e.to_string(),
        })?;
    let run = || {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            calibrate_campaign_file(&campaign, &settings.params, observer)
        }))
    };
    let output = pool.install(run).map_err(|payload| FleetError::Panic {
        campaign: name,
        message: panic_message(payload.as_ref()),
    })??;
    Ok(UnitCalibration::from_output(&campaign, output))
}

/// What [`calibrate_fleet`] reports: the unit's index in `sources`, and its progress. When a unit
/// ends, its last report is the stage `"done"` or `"failed"` with `done == total == 1`.
pub(crate) type FleetObserver<'a> = dyn Fn(usize, Progress<'_>) + Sync + 'a;

/// A fleet observer that shows nothing.
pub fn silent_fleet(_: usize, _: Progress<'_>) {}

/// Calibrates every unit, `settings.threads` at a time, each on one thread. Outcomes come in the
/// order of `sources`; a unit's failure is its own.
pub fn calibrate_fleet(
    sources: &[PathBuf],
    settings: &FleetSettings,
    observer: &FleetObserver,
) -> Vec<UnitOutcome> {
    let labels = unit_labels(sources);
    let n = sources.len();
    let threads = settings
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |t| t.get()))
        .clamp(1, n.max(1));
    let slots: Mutex<Vec<Option<Result<UnitCalibration, String>>>> = Mutex::new(vec![None; n]);
    let next = AtomicUsize::new(0);
    let work = || loop {
        let i = next.fetch_add(1, Ordering::Relaxed);
        if i >= n {
            break;
        }
        let result = calibrate_unit(&sources[i], settings, &|p: Progress<'_>| observer(i, p))
            .map_err(|e| e.to_string());
        observer(
            i,
            Progress::step(if result.is_ok() { "done" } else { "failed" }, 1, Some(1)),
        );
        if let Ok(mut slots) = slots.lock() {
            slots[i] = Some(result);
        }
    };
    std::thread::scope(|scope| {
        let spawned = (0..threads)
            .filter(|_| {
                std::thread::Builder::new()
                    .name("spincal-fleet".into())
                    .spawn_scoped(scope, work)
                    .is_ok()
            })
            .count();
        if spawned == 0 {
            work();
        }
    });
    let slots = slots
        .into_inner()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    slots
        .into_iter()
        .zip(sources)
        .zip(labels)
        .map(|((slot, source), unit)| UnitOutcome {
            unit,
            source: source.clone(),
            result: slot.unwrap_or_else(|| {
                Err(format!(
                    "{}: not calibrated (its worker stopped)",
                    source.display()
                ))
            }),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_campaigns_inputs_include_its_truth_and_random_error_files() {
        let text = "unit = \"u\"\n[[recording]]\nfile = \"still.csv\"\nkind = \"static\"\ntruth = \"still.truth.csv\"\nrandom_error = \"still.random.csv\"\n";
        let campaign = Campaign::parse(text, Path::new("d/c.toml")).unwrap();
        let names: Vec<String> = campaign
            .inputs()
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "d/c.toml",
                "d/still.csv",
                "d/still.truth.csv",
                "d/still.random.csv"
            ]
        );
    }

    #[test]
    fn labels_come_from_folders_and_files_and_are_unique() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("imu-7");
        std::fs::create_dir(&a).unwrap();
        let sources = vec![
            a.clone(),
            a.join("campaign.toml"),
            dir.path().join("line-3.toml"),
            dir.path().join("x").join("imu-7.toml"),
        ];
        assert_eq!(unit_labels(&sources), ["imu-7", "imu-7-2", "line-3", "imu-7-3"]);
    }

    #[test]
    fn a_folder_of_unit_folders_expands_in_name_order() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["b", "a", "c"] {
            std::fs::create_dir(dir.path().join(name)).unwrap();
        }
        std::fs::write(dir.path().join("b").join(CAMPAIGN_FILE), "").unwrap();
        std::fs::write(dir.path().join("a").join(CAMPAIGN_FILE), "").unwrap();
        let empty = dir.path().join("c");
        let got = expand_sources(&[dir.path().to_path_buf(), empty.clone()], &[]);
        // c holds no campaign: it is a unit all the same (it fails as one), never left out.
        assert_eq!(
            got.units,
            [dir.path().join("a"), dir.path().join("b"), empty.clone(), empty]
        );
        assert!(got.skipped.is_empty());
    }

    #[test]
    fn any_single_toml_is_a_units_campaign_and_skipped_folders_are_listed() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["u1", "u2", "u3", ".cache", "out"] {
            std::fs::create_dir(dir.path().join(name)).unwrap();
        }
        std::fs::write(dir.path().join("u1").join("unit.toml"), "").unwrap();
        std::fs::write(dir.path().join("u3").join("a.toml"), "").unwrap();
        std::fs::write(dir.path().join("u3").join("b.toml"), "").unwrap();
        let out = dir.path().join("out");
        let got = expand_sources(&[dir.path().to_path_buf()], &[&out]);
        let names: Vec<_> = got.units.iter().map(|p| unit_label(p)).collect();
        assert_eq!(names, ["u1", "u2", "u3"]);
        let skipped: Vec<_> = got
            .skipped
            .iter()
            .map(|(p, why)| (unit_label(p), why.as_str()))
            .collect();
        assert_eq!(
            skipped,
            [
                (".cache".to_string(), "a hidden folder"),
                ("out".to_string(), "the run's own output folder")
            ]
        );
        assert_eq!(
            campaign_path(&dir.path().join("u1")).unwrap(),
            dir.path().join("u1").join("unit.toml")
        );
        let e = campaign_path(&dir.path().join("u2")).unwrap_err().to_string();
        assert!(e.contains("u2") && e.contains("no campaign file"), "{e}");
        let e = campaign_path(&dir.path().join("u3")).unwrap_err().to_string();
        assert!(e.contains("a.toml, b.toml"), "{e}");
    }

    #[test]
    fn a_folder_without_a_campaign_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let e = calibrate_unit(dir.path(), &FleetSettings::default(), &crate::progress::silent)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&dir.path().display().to_string()) && e.contains("campaign.toml"),
            "{e}"
        );
    }
}
