//! A fleet of simulated units: each unit is the campaign of [`super::campaign`] with its own
//! sensor, drawn around a nominal sensor, and a few units made deliberately faulty.
//!
//! Unit `i`'s sensor is the nominal [`SensorProfile`](crate::simulate::SensorProfile) with, independently per axis (and per
//! misalignment angle), a normal draw added: bias sd `bias_sd_g`, scale error sd
//! `scale_sd_pct`, misalignment sd `misalignment_sd_deg` ([`UnitSpread`]). A faulty unit has
//! [`FaultSetup`] added on top (by default +0.1 g bias on x and +5 % scale error on y: about
//! twenty times the fleet's spread). Every draw comes from one `ChaCha8Rng` seeded by the caller; each
//! unit's campaign gets its own seed from it, so the fleet is the same for the same seed.

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::input::recording::{AccelUnit, RecordingError};
use crate::output::OutputError;
use crate::simulate::campaign::{simulate_campaign, CampaignSetup, CampaignTruth, SimulatedCampaign};
use crate::simulate::SimulationError;

/// How far units scatter around the nominal sensor (standard deviations of normal draws).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UnitSpread {
    /// Bias, g, per axis.
    pub bias_sd_g: f64,
    /// Scale-factor error, %, per axis.
    pub scale_sd_pct: f64,
    /// Misalignment, deg, per angle.
    pub misalignment_sd_deg: f64,
}

impl Default for UnitSpread {
    fn default() -> Self {
        UnitSpread {
            bias_sd_g: 0.005,
            scale_sd_pct: 0.3,
            misalignment_sd_deg: 0.2,
        }
    }
}

/// What a faulty unit has on top of its own draw.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FaultSetup {
    /// Added bias per axis, g.
    pub bias_g: [f64; 3],
    /// Added scale-factor error per axis, %.
    pub scale_error_pct: [f64; 3],
}

impl Default for FaultSetup {
    /// +0.1 g bias on x and +5 % scale error on y: about twenty times the fleet's standard
    /// deviation of each (and several times the bias drift's bound).
    fn default() -> Self {
        FaultSetup {
            bias_g: [0.1, 0.0, 0.0],
            scale_error_pct: [0.0, 5.0, 0.0],
        }
    }
}

/// A fleet: how many units, their campaign, their scatter, which are faulty and how.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FleetSetup {
    pub units: usize,
    /// Every unit's campaign; its `sensor` is the nominal sensor the units scatter around and its
    /// `unit` is replaced by `unit-01`, `unit-02`, …
    pub campaign: CampaignSetup,
    pub spread: UnitSpread,
    /// Indices (0-based) of the faulty units.
    pub faulty: Vec<usize>,
    pub fault: FaultSetup,
}

impl Default for FleetSetup {
    fn default() -> Self {
        FleetSetup {
            units: 8,
            campaign: CampaignSetup::default(),
            spread: UnitSpread::default(),
            faulty: Vec::new(),
            fault: FaultSetup::default(),
        }
    }
}

/// One simulated unit.
#[derive(Debug, Clone)]
pub struct SimulatedUnit {
    /// `unit-01`, …: the folder name and the campaign's unit name.
    pub name: String,
    pub faulty: bool,
    pub campaign: SimulatedCampaign,
}

/// The truth of one unit (its campaign's truth, which carries the seed and the setup).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct UnitTruth {
    pub name: String,
    pub faulty: bool,
    pub truth: CampaignTruth,
}

/// A simulated fleet.
#[derive(Debug, Clone)]
pub struct SimulatedFleet {
    pub seed: u64,
    pub setup: FleetSetup,
    pub units: Vec<SimulatedUnit>,
}

impl SimulatedFleet {
    /// The names of the units made faulty, in fleet order.
    pub fn faulty_names(&self) -> Vec<&str> {
        self.units
            .iter()
            .filter(|u| u.faulty)
            .map(|u| u.name.as_str())
            .collect()
    }

    /// The truth of every unit, in order (for `fleet-truth.json`).
    pub fn truth(&self) -> Vec<UnitTruth> {
        self.units
            .iter()
            .map(|u| UnitTruth {
                name: u.name.clone(),
                faulty: u.faulty,
                truth: u.campaign.truth.clone(),
            })
            .collect()
    }
}

/// Writing a simulated campaign or fleet.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WriteError {
    #[error(
        "{path} already exists: spincal does not replace files in a campaign folder; choose an empty folder"
    )]
    Exists { path: String },
    #[error("{path}: cannot create the folder: {message}")]
    Folder { path: String, message: String },
    #[error("{path}: cannot write the archive: {message}")]
    Archive { path: String, message: String },
    #[error(transparent)]
    Recording(#[from] RecordingError),
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// Creates `dir` for a simulation's `files`, refusing when any of them is already there.
pub(crate) fn create_folder_for(dir: &Path, files: &[PathBuf]) -> Result<(), WriteError> {
    if let Some(existing) = files.iter().find(|p| p.exists()) {
        return Err(WriteError::Exists {
            path: existing.display().to_string(),
        });
    }
    crate::output::make_folders(dir).map_err(|e| WriteError::Folder {
        path: dir.display().to_string(),
        message: e.to_string(),
    })
}

/// Unit numbers as the folders name them (1-based: `unit-01` is 1) as the zero-based indices
/// of [`FleetSetup::faulty`]; `Err` holds the first number that is not a unit of `units`.
pub fn faulty_indices(units: usize, numbers: &[usize]) -> Result<Vec<usize>, usize> {
    match numbers.iter().find(|&&k| k == 0 || k > units) {
        Some(&bad) => Err(bad),
        None => Ok(numbers.iter().map(|k| k - 1).collect()),
    }
}

/// Simulates the fleet. Deterministic for a given seed.
pub fn simulate_fleet(setup: &FleetSetup, seed: u64) -> Result<SimulatedFleet, SimulationError> {
    let invalid = |name, value, why| Err(SimulationError::Invalid { name, value, why });
    if setup.units == 0 {
        return invalid("units", 0.0, "a fleet needs at least one unit");
    }
    if let Some(&bad) = setup.faulty.iter().find(|&&i| i >= setup.units) {
        return invalid(
            "faulty",
            bad as f64,
            "names a unit past the last (units count from 0)",
        );
    }
    let spread = &setup.spread;
    for (name, v) in [
        ("spread.bias_sd_g", spread.bias_sd_g),
        ("spread.scale_sd_pct", spread.scale_sd_pct),
        ("spread.misalignment_sd_deg", spread.misalignment_sd_deg),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return invalid(name, v, "must be finite and not negative");
        }
    }
    let fault = &setup.fault;
    if fault
        .bias_g
        .iter()
        .chain(&fault.scale_error_pct)
        .any(|v| !v.is_finite())
    {
        return invalid("fault", f64::NAN, "every fault value must be finite");
    }
    let normal = |sd: f64| {
        Normal::new(0.0, sd).map_err(|_| SimulationError::Invalid {
            name: "spread",
            value: sd,
            why: "not a valid standard deviation",
        })
    };
    let (bias, scale, mis) = (
        normal(spread.bias_sd_g)?,
        normal(spread.scale_sd_pct)?,
        normal(spread.misalignment_sd_deg)?,
    );
    let width = setup.units.to_string().len().max(2);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut units = Vec::with_capacity(setup.units);
    for i in 0..setup.units {
        let mut campaign = setup.campaign.clone();
        let name = format!("unit-{:0width$}", i + 1);
        campaign.unit = name.clone();
        let sensor = &mut campaign.sensor;
        for k in 0..3 {
            sensor.bias_g[k] += bias.sample(&mut rng);
            sensor.scale_error_pct[k] += scale.sample(&mut rng);
        }
        for k in 0..6 {
            sensor.misalignment_deg[k] += mis.sample(&mut rng);
        }
        let faulty = setup.faulty.contains(&i);
        if faulty {
            for k in 0..3 {
                sensor.bias_g[k] += fault.bias_g[k];
                sensor.scale_error_pct[k] += fault.scale_error_pct[k];
            }
        }
        let unit_seed: u64 = rng.gen();
        units.push(SimulatedUnit {
            name,
            faulty,
            campaign: simulate_campaign(&campaign, unit_seed)?,
        });
    }
    Ok(SimulatedFleet {
        seed,
        setup: setup.clone(),
        units,
    })
}

impl SimulatedCampaign {
    /// The files [`SimulatedCampaign::write_folder`] writes into `dir`.
    pub fn folder_files(&self, dir: &Path) -> Vec<PathBuf> {
        let mut files = vec![dir.join("campaign.toml"), dir.join("truth.json")];
        for r in &self.recordings {
            files.push(dir.join(format!("{}.csv", r.name)));
            files.push(dir.join(format!("{}.truth.csv", r.name)));
            files.push(dir.join(format!("{}.random.csv", r.name)));
        }
        files
    }

    /// Writes campaign.toml, one CSV per recording (m/s²), its true specific force
    /// (`<name>.truth.csv`), its random error (`<name>.random.csv`) and truth.json into `dir`. Refuses to replace a file already there
    /// unless `replace` (a folder this program made itself, such as the demo's).
    pub fn write_folder(&self, dir: &Path, replace: bool) -> Result<(), WriteError> {
        let files = if replace {
            Vec::new()
        } else {
            self.folder_files(dir)
        };
        create_folder_for(dir, &files)?;
        for (i, r) in self.recordings.iter().enumerate() {
            r.recording
                .write_csv_path(&dir.join(format!("{}.csv", r.name)), AccelUnit::Mps2)?;
            self.truth_recording(i)
                .write_csv_path(&dir.join(format!("{}.truth.csv", r.name)), AccelUnit::Mps2)?;
            self.random_recording(i)
                .write_csv_path(&dir.join(format!("{}.random.csv", r.name)), AccelUnit::Mps2)?;
        }
        let truth = serde_json::to_string_pretty(&self.truth).expect("the truth serialises") + "\n";
        crate::output::write_bytes(&dir.join("truth.json"), truth.as_bytes())?;
        crate::output::write_bytes(&dir.join("campaign.toml"), self.campaign_toml().as_bytes())?;
        Ok(())
    }
}

impl SimulatedFleet {
    /// Writes one campaign folder per unit (`dir/unit-01`, …) and `dir/fleet-truth.json` (every
    /// unit's truth and whether it is faulty). Refuses to replace any file already there. Returns
    /// the unit folders in order.
    pub fn write_folders(&self, dir: &Path) -> Result<Vec<PathBuf>, WriteError> {
        let truth_path = dir.join("fleet-truth.json");
        if truth_path.exists() {
            return Err(WriteError::Exists {
                path: truth_path.display().to_string(),
            });
        }
        for unit in &self.units {
            let folder = dir.join(&unit.name);
            if let Some(existing) = unit.campaign.folder_files(&folder).iter().find(|p| p.exists()) {
                return Err(WriteError::Exists {
                    path: existing.display().to_string(),
                });
            }
        }
        let mut folders = Vec::with_capacity(self.units.len());
        for unit in &self.units {
            let folder = dir.join(&unit.name);
            unit.campaign.write_folder(&folder, false)?;
            folders.push(folder);
        }
        let truth = serde_json::json!({
            "seed": self.seed,
            "setup": self.setup,
            "units": self.truth(),
        });
        let text = serde_json::to_string_pretty(&truth).expect("the truth serialises") + "\n";
        crate::output::write_bytes(&truth_path, text.as_bytes())?;
        Ok(folders)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::campaign::RunSetup;

    fn short() -> FleetSetup {
        FleetSetup {
            units: 4,
            campaign: CampaignSetup {
                poses: 6,
                runs: vec![RunSetup {
                    duration_s: 4.0,
                    ..RunSetup::default()
                }],
                ..CampaignSetup::default()
            },
            faulty: vec![2],
            ..FleetSetup::default()
        }
    }

    #[test]
    fn units_differ_the_faulty_one_carries_the_fault_and_the_seed_repeats() {
        let a = simulate_fleet(&short(), 9).unwrap();
        let b = simulate_fleet(&short(), 9).unwrap();
        let names: Vec<&str> = a.units.iter().map(|u| u.name.as_str()).collect();
        assert_eq!(names, ["unit-01", "unit-02", "unit-03", "unit-04"]);
        for (x, y) in a.units.iter().zip(&b.units) {
            assert_eq!(x.campaign.truth.setup, y.campaign.truth.setup);
            assert_eq!(
                x.campaign.recordings[0].recording,
                y.campaign.recordings[0].recording
            );
        }
        let bias: Vec<f64> = a
            .units
            .iter()
            .map(|u| u.campaign.truth.setup.sensor.bias_g[0])
            .collect();
        assert!(bias.windows(2).all(|w| w[0] != w[1]), "{bias:?}");
        let nominal = CampaignSetup::default().sensor;
        for u in &a.units {
            let d = u.campaign.truth.setup.sensor.bias_g[0] - nominal.bias_g[0];
            assert_eq!(u.faulty, u.name == "unit-03");
            // Good units within 5 sd of nominal; the faulty one 0.1 g out, give or take its draw.
            if u.faulty {
                assert!((d - 0.1).abs() < 0.025, "{d}");
            } else {
                assert!(d.abs() < 0.025, "{d}");
            }
        }
    }

    #[test]
    fn a_faulty_index_past_the_fleet_is_refused() {
        let setup = FleetSetup {
            faulty: vec![4],
            ..short()
        };
        let e = simulate_fleet(&setup, 1).unwrap_err().to_string();
        assert!(e.contains("faulty"), "{e}");
    }
}
