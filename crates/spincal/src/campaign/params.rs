//! Every setting of a calibration, from one recording (the paper's protocol) or from a campaign:
//! one type with one set of defaults (what `spincal calibrate` runs), checked once by
//! [`Params::check`] before any work starts. The CLI and Python start from [`Params::default`]
//! and change only what their user named; an error names the parameter by its path here
//! (`network.restarts`), never a command-line flag.

use serde::{Deserialize, Serialize};

use crate::campaign::candidate::CandidateKind;
use crate::campaign::gyro::GyroSettings;
use crate::campaign::joint::JointSettings;
use crate::correctors::ann::{small_grid, LmSettings, SWEEP_HESSIAN_SAMPLES};
use crate::correctors::corrector::Axis;
use crate::correctors::division::DivisionMode;
use crate::sysid::{ModelKind, ModelSpec};
use crate::turntable::fit::FitOptions;

/// How the network of the paper's protocol is chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "mode", rename_all = "snake_case")]
pub enum NetworkChoice {
    /// Train every architecture of the grid; keep the best on validation. The sweep forms each
    /// epoch's JᵀJ from `hessian_samples` training samples (`None`: all; see
    /// [`LmSettings::hessian_samples`]); the chosen architecture is then trained exactly.
    Sweep {
        grid: Vec<Vec<usize>>,
        restarts: usize,
        hessian_samples: Option<usize>,
    },
    /// One architecture.
    Fixed { hidden: Vec<usize>, restarts: usize },
}

/// The settings of a calibration. Fields a path does not use are ignored by it: the paper's
/// protocol uses `seed` to `init_samples`, a campaign `joint` to `gyro`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Seed of every random choice (initial weights, the sysid models' starts).
    pub seed: u64,
    /// The turntable model's fit.
    pub fit: FitOptions,
    /// Axes a corrector corrects (a network and the linear map over them; one SISO model per
    /// axis for system identification).
    pub correct_axes: Vec<Axis>,
    pub network: NetworkChoice,
    /// Previous samples of each axis fed to the network.
    pub delays: usize,
    pub lm: LmSettings,
    /// How a recording is divided into training, validation and test (60/20/20).
    pub division: DivisionMode,
    /// The system-identification models scored beside the correctors (their seeds are `seed`).
    pub sysid: Vec<ModelSpec>,
    /// Measured outputs that start a sysid simulation.
    pub init_samples: usize,
    /// A campaign's joint sensor fit.
    pub joint: JointSettings,
    /// The corrector kinds a campaign compares on held-out conditions.
    pub candidates: Vec<CandidateKind>,
    /// A sensor parameter is "determined" when one standard error moves a 1 g reading by at most
    /// this, m/s².
    pub determined_tolerance_mps2: f64,
    pub gyro: GyroSettings,
    /// A campaign's thermal model, fitted when its still recordings carry a temperature over a
    /// few degrees.
    pub thermal: crate::thermal::ThermalSettings,
}

impl Default for Params {
    fn default() -> Self {
        let spec = |kind: ModelKind| {
            ModelSpec::new(kind, kind.default_orders()).expect("default orders fit the kind")
        };
        Params {
            seed: 1,
            fit: FitOptions::default(),
            correct_axes: vec![Axis::X, Axis::Y],
            network: NetworkChoice::Sweep {
                grid: small_grid(),
                restarts: 3,
                hessian_samples: Some(SWEEP_HESSIAN_SAMPLES),
            },
            delays: 0,
            lm: LmSettings::default(),
            division: DivisionMode::Contiguous,
            sysid: [ModelKind::Arx, ModelKind::Bj, ModelKind::Narx, ModelKind::Hw]
                .into_iter()
                .map(spec)
                .collect(),
            init_samples: 10,
            joint: JointSettings::default(),
            candidates: CandidateKind::ALL.to_vec(),
            determined_tolerance_mps2: 0.02,
            gyro: GyroSettings::default(),
            thermal: crate::thermal::ThermalSettings::default(),
        }
    }
}

/// A setting that cannot be used, by its path in [`Params`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("parameter {name} = {value}: {why}")]
pub struct ParamError {
    pub name: String,
    pub value: String,
    pub why: String,
}

fn refuse(name: impl Into<String>, value: impl std::fmt::Debug, why: impl Into<String>) -> ParamError {
    ParamError {
        name: name.into(),
        value: format!("{value:?}"),
        why: why.into(),
    }
}

/// Every value finite and positive.
fn positive<'a>(values: impl IntoIterator<Item = (&'a str, f64)>) -> Result<(), ParamError> {
    for (name, value) in values {
        if !(value.is_finite() && value > 0.0) {
            return Err(refuse(name, value, "must be finite and positive"));
        }
    }
    Ok(())
}

impl Params {
    /// Checks every setting; the first one that cannot be used is named.
    pub fn check(&self) -> Result<(), ParamError> {
        self.check_fit()?;
        self.check_axes()?;
        self.check_network()?;
        self.check_sysid()?;
        self.check_campaign()
    }

    /// At least one axis to correct, none named twice.
    fn check_axes(&self) -> Result<(), ParamError> {
        if self.correct_axes.is_empty() {
            return Err(refuse(
                "correct_axes",
                &self.correct_axes,
                "name at least one axis",
            ));
        }
        if (1..self.correct_axes.len()).any(|i| self.correct_axes[..i].contains(&self.correct_axes[i])) {
            return Err(refuse(
                "correct_axes",
                &self.correct_axes,
                "an axis is named twice",
            ));
        }
        Ok(())
    }

    /// A sweep's grid and restarts, or the fixed network's layers and restarts.
    fn check_network(&self) -> Result<(), ParamError> {
        let layers_ok = |hidden: &[usize]| hidden.iter().all(|&n| n > 0);
        match &self.network {
            NetworkChoice::Sweep {
                grid,
                restarts,
                hessian_samples,
            } => {
                if grid.is_empty() {
                    return Err(refuse("network.grid", grid, "name at least one architecture"));
                }
                if let Some(bad) = grid.iter().find(|h| !layers_ok(h)) {
                    return Err(refuse(
                        "network.grid",
                        bad,
                        "every hidden layer needs at least one neuron",
                    ));
                }
                if *restarts == 0 {
                    return Err(refuse("network.restarts", restarts, "must be at least 1"));
                }
                if *hessian_samples == Some(0) {
                    return Err(refuse(
                        "network.hessian_samples",
                        hessian_samples,
                        "must be at least 1 (None: every sample)",
                    ));
                }
            }
            NetworkChoice::Fixed { hidden, restarts } => {
                if !layers_ok(hidden) {
                    return Err(refuse(
                        "network.hidden",
                        hidden,
                        "every hidden layer needs at least one neuron",
                    ));
                }
                if *restarts == 0 {
                    return Err(refuse("network.restarts", restarts, "must be at least 1"));
                }
            }
        }
        Ok(())
    }

    /// System identification needs the contiguous division and a measured start.
    fn check_sysid(&self) -> Result<(), ParamError> {
        if !self.sysid.is_empty() && self.division != DivisionMode::Contiguous {
            return Err(refuse(
                "division",
                self.division,
                "system-identification models need the contiguous division (interleaved blocks break their dynamics); leave sysid empty or divide contiguously",
            ));
        }
        if !self.sysid.is_empty() && self.init_samples == 0 {
            return Err(refuse(
                "init_samples",
                self.init_samples,
                "a simulation starts from at least one measured output",
            ));
        }
        Ok(())
    }

    /// The campaign's settings: joint fit, candidates, gyroscope and thermal model.
    fn check_campaign(&self) -> Result<(), ParamError> {
        let j = &self.joint;
        positive([
            ("joint.gravity_mps2", j.gravity_mps2),
            ("joint.bias_instability_mps2", j.bias_instability_mps2),
            ("joint.mount_tilt_rad", j.mount_tilt_rad),
            ("joint.block_s", j.block_s),
        ])?;
        if self.candidates.is_empty() {
            return Err(refuse(
                "candidates",
                &self.candidates,
                "at least one corrector kind must be compared",
            ));
        }
        positive([("determined_tolerance_mps2", self.determined_tolerance_mps2)])?;
        let g = &self.gyro;
        positive([
            ("gyro.bias_instability_radps", g.bias_instability_radps),
            ("gyro.prior_sd[0]", g.prior_sd[0]),
            ("gyro.prior_sd[1]", g.prior_sd[1]),
            ("gyro.block_s", g.block_s),
            ("gyro.reference_rate_radps", g.reference_rate_radps),
            ("gyro.determined_tolerance_radps", g.determined_tolerance_radps),
        ])?;
        match self.thermal.check() {
            Err(crate::thermal::ThermalError::Setting { name, value, why }) => Err(ParamError {
                name: format!("thermal.{name}"),
                value,
                why: why.to_string(),
            }),
            Err(other) => Err(refuse("thermal", &self.thermal, other.to_string())),
            Ok(()) => Ok(()),
        }
    }

    fn check_fit(&self) -> Result<(), ParamError> {
        let f = &self.fit;
        positive([("fit.gravity_mps2", f.gravity_mps2)])?;
        if let Some(rpm) = f.rpm_hint {
            positive([("fit.rpm_hint", rpm)])?;
        }
        if let Some(radius) = f.radius {
            positive([("fit.radius.value_m", radius.value_m)])?;
            if !(radius.tolerance_m.is_finite() && radius.tolerance_m >= 0.0) {
                return Err(refuse(
                    "fit.radius.tolerance_m",
                    radius.tolerance_m,
                    "must be finite and not negative",
                ));
            }
        }
        if let Some(range) = f.range_mps2 {
            positive([("fit.range_mps2", range)])?;
        }
        for (name, lower, upper) in &f.bounds {
            if !(lower.is_finite() && upper.is_finite() && lower < upper) {
                return Err(refuse(
                    format!("fit.bounds.{name}"),
                    (lower, upper),
                    "needs finite bounds with lower < upper",
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_pass_their_own_check_and_round_trip_through_json() {
        let params = Params::default();
        params.check().unwrap();
        let json = serde_json::to_string(&params).unwrap();
        let back: Params = serde_json::from_str(&json).unwrap();
        assert_eq!(serde_json::to_string(&back).unwrap(), json);
        // A partial file takes the defaults for what it leaves out.
        let partial: Params = serde_json::from_str(r#"{"seed": 9, "delays": 2}"#).unwrap();
        assert_eq!((partial.seed, partial.delays), (9, 2));
        assert!(
            serde_json::from_str::<Params>(r#"{"restarts": 2}"#).is_err(),
            "unknown keys are refused"
        );
    }

    #[test]
    fn a_setting_that_cannot_be_used_is_named_by_its_path() {
        type Spoil = fn(&mut Params);
        let cases: [(&str, Spoil); 7] = [
            ("network.restarts", |p| {
                p.network = NetworkChoice::Fixed {
                    hidden: vec![4],
                    restarts: 0,
                }
            }),
            ("network.grid", |p| {
                p.network = NetworkChoice::Sweep {
                    grid: vec![vec![3, 0]],
                    restarts: 1,
                    hessian_samples: None,
                }
            }),
            ("correct_axes", |p| p.correct_axes = vec![Axis::X, Axis::X]),
            ("division", |p| {
                p.division = DivisionMode::Interleaved { block_len: 50 }
            }),
            ("joint.block_s", |p| p.joint.block_s = f64::NAN),
            ("fit.radius.tolerance_m", |p| {
                p.fit.radius = Some(crate::turntable::fit::RadiusPrior {
                    value_m: 0.1,
                    tolerance_m: -1.0,
                })
            }),
            ("gyro.prior_sd[1]", |p| p.gyro.prior_sd[1] = 0.0),
        ];
        for (name, spoil) in cases {
            let mut params = Params::default();
            spoil(&mut params);
            let error = params.check().unwrap_err();
            assert_eq!(error.name, name, "{error}");
            assert!(
                error.to_string().starts_with(&format!("parameter {name} = ")),
                "{error}"
            );
        }
    }
}
