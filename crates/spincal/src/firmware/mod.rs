//! A saved corrector as firmware source (`spincal export`): C99 in `float` and `double`, Rust
//! for the `no_std` crate `spincal-embedded`, and the values x-io Fusion takes.
//!
//! [`export_firmware`] turns a [`CorrectorFile`] into files (names and text); [`write_export`]
//! writes them. The coefficients are derived once (`plan`) by the library's own arithmetic, and
//! every generated function does the library stream's operations in its order, so:
//!
//! - the `double` C and the `f64` Rust give `spincal correct`'s corrections (tested to 1e-9
//!   relative on held-out recordings; the tests find them equal bit for bit);
//! - the `float` C and the `f32` Rust do the same operations in single precision (tested within
//!   2e-6 of full scale; they equal each other bit for bit); their tanh is a degree-8 version
//!   of the library's, within 2 ulps of the correctly rounded tanh;
//! - a network keeps its training envelope as `correct` does: outside its input range `ann`
//!   passes the reading through uncorrected and marks it invalid, `physical_ann` falls back to
//!   the physical correction outside its input range, its covered cells or its output range;
//! - a `physical` model or a `linear` map with its parameters' covariance (the models `correct`
//!   gives an error bar: `CorrectorModel::error_model`) gets the error bar too:
//!   `NAME_fXX_predicted_sd` in C and `Model::predicted_error` in Rust give `correct`'s
//!   `<column>_corrected_sd` (the Jacobian by `correct_with_jacobian`'s operations, √diag(J Σ Jᵀ)
//!   by `propagated_variance`'s, Σ a table in the coefficients) and `predicted_better`; every
//!   other model exports none, and its header says so.

mod c_source;
mod fusion;
mod numerics;
mod plan;
mod rust_source;

use std::path::{Path, PathBuf};

pub use fusion::{fusion_text, fusion_values, FusionCalibration, FusionValues, NotHeld};
pub use numerics::FloatError;
pub use plan::MAX_UNITS;

use crate::correctors::model_file::CorrectorFile;
use crate::output::OutputError;

/// The arithmetic of a C export.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Precision {
    /// IEEE single (`float`, `f32`): for FPUs without double precision (Cortex-M4F).
    Float,
    /// IEEE double (`double`, `f64`): `spincal correct`'s own arithmetic.
    Double,
}

impl Precision {
    pub fn c_type(self) -> &'static str {
        match self {
            Precision::Float => "float",
            Precision::Double => "double",
        }
    }

    /// `f32` or `f64`: the files' and symbols' suffix.
    pub fn suffix(self) -> &'static str {
        match self {
            Precision::Float => "f32",
            Precision::Double => "f64",
        }
    }
}

/// What to export.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportOptions {
    /// Prefix of the files and C symbols (`spincal` → `spincal_f32.h`, `spincal_f32_correct`):
    /// a C identifier.
    pub name: String,
    /// One or both precisions.
    pub precisions: Vec<Precision>,
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            name: "spincal".into(),
            precisions: vec![Precision::Float, Precision::Double],
        }
    }
}

/// What can stop an export.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FirmwareError {
    /// The model contradicts its own structure (`field` is its path in the file).
    #[error("{file}: invalid corrector: {field}: {reason}")]
    Invalid {
        file: String,
        field: String,
        reason: String,
    },
    /// The model is valid but beyond what the firmware code holds.
    #[error("{file}: cannot export: {field}: {reason}")]
    TooLarge {
        file: String,
        field: String,
        reason: String,
    },
    #[error("`name` {name:?}: not a C identifier (letters, digits and _, not starting with a digit)")]
    Name { name: String },
    #[error("no precision asked for: export float, double or both")]
    NoPrecision,
    #[error("{dir}: cannot create the output folder: {source}")]
    Folder {
        dir: String,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Output(#[from] OutputError),
}

impl FirmwareError {
    fn in_file(self, file: &str) -> FirmwareError {
        match self {
            FirmwareError::Invalid { field, reason, .. } => FirmwareError::Invalid {
                file: file.into(),
                field,
                reason,
            },
            FirmwareError::TooLarge { field, reason, .. } => FirmwareError::TooLarge {
                file: file.into(),
                field,
                reason,
            },
            other => other,
        }
    }
}

/// An export: its files, in writing order, and the Fusion values (also in `fusion.txt`).
#[derive(Debug, Clone)]
pub struct FirmwareExport {
    /// The exported kind (`physical-linear` for a physical model without quadratic term).
    pub kind: String,
    /// (file name, text).
    pub files: Vec<(String, String)>,
    pub fusion: FusionValues,
    /// How far the float export lands from the double correction over the training range
    /// (measured whether or not float was exported).
    pub float_error: FloatError,
}

impl FirmwareExport {
    /// The float export's error in words (one line).
    pub fn float_error_text(&self) -> String {
        let e = &self.float_error;
        let m = e.max_abs_mps2;
        let mut text = format!(
            "float export: at most {:.2e}, {:.2e}, {:.2e} m/s² (x, y, z) from the double correction over {} ({} grid points",
            m[0], m[1], m[2], e.over, e.points
        );
        if e.flags_differ > 0 {
            text.push_str(&format!(
                "; {} more within rounding of an envelope's edge, flagged differently",
                e.flags_differ
            ));
        }
        text.push(')');
        if let Some(rel) = e.sd_max_rel {
            text.push_str(&format!(
                "; its predicted standard deviation within {rel:.1e} of the double's (relative)"
            ));
            if e.better_differ > 0 {
                text.push_str(&format!(
                    ", predicted_better differing at {} grid points within rounding of its threshold",
                    e.better_differ
                ));
            }
        }
        text
    }
}

/// The firmware sources of `model`; `source` names the model in errors and in the files'
/// first line.
pub fn export_firmware(
    model: &CorrectorFile,
    source: &str,
    options: &ExportOptions,
) -> Result<FirmwareExport, FirmwareError> {
    let name = &options.name;
    let identifier = name
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !identifier {
        return Err(FirmwareError::Name { name: name.clone() });
    }
    if options.precisions.is_empty() {
        return Err(FirmwareError::NoPrecision);
    }
    if model.thermal.is_some() {
        return Err(FirmwareError::TooLarge {
            file: source.into(),
            field: "thermal".into(),
            reason: "the firmware code has no temperature correction yet, and without it the model is wrong away from its reference temperature; calibrate without a temperature column for a model the firmware can hold".into(),
        });
    }
    let plan = plan::Plan::of(model).map_err(|e| e.in_file(source))?;
    let provenance = format!(
        "exported by spincal {} from {} (written by spincal {})",
        env!("CARGO_PKG_VERSION"),
        source.replace("*/", "* /"),
        model.spincal_version.replace("*/", "* /")
    );
    let mut precisions = options.precisions.clone();
    precisions.sort_by_key(|p| p.suffix());
    precisions.dedup();
    // Every coefficient must be a finite literal in each precision asked for (C has no
    // literal for infinity: `inff` does not compile, and an overflow would be one).
    for &precision in &precisions {
        if let Some((field, value)) = c_source::unwritable(&plan, precision) {
            return Err(FirmwareError::TooLarge {
                file: source.into(),
                field,
                reason: format!(
                    "{value:e} is not a finite {} ({}), so the {} export cannot hold it; the model's coefficients are far outside what a calibration gives: refit it{}",
                    precision.c_type(),
                    match precision {
                        Precision::Float => "|x| < 3.4e38",
                        Precision::Double => "|x| < 1.8e308",
                    },
                    precision.suffix(),
                    match precision {
                        Precision::Float => ", or export double only",
                        Precision::Double => "",
                    }
                ),
            });
        }
    }
    let float_error = numerics::float_error(&plan, &model.corrector);
    let mut files = Vec::new();
    for &precision in &precisions {
        files.extend(c_source::files(&plan, name, precision, &provenance));
    }
    files.push((
        format!("{name}_model.rs"),
        rust_source::file(&plan, &precisions, &provenance),
    ));
    let fusion = fusion_values(model);
    files.push(("fusion.txt".into(), fusion_text(&fusion)));
    let mut export = FirmwareExport {
        kind: plan.kind,
        files,
        fusion,
        float_error,
    };
    // The float header states its own error.
    let note = export.float_error_text().replace("*/", "* /");
    let header = format!("{name}_f32.h");
    if let Some((_, text)) = export.files.iter_mut().find(|(n, _)| *n == header) {
        *text = format!(
            "/* {note} */
{text}"
        );
    }
    Ok(export)
}

/// Writes every file of `export` into `dir` (created if missing), each through a temporary file
/// renamed when complete; returns their paths.
pub fn write_export(export: &FirmwareExport, dir: &Path) -> Result<Vec<PathBuf>, FirmwareError> {
    crate::output::make_folders(dir).map_err(|source| FirmwareError::Folder {
        dir: dir.display().to_string(),
        source,
    })?;
    let mut written = Vec::new();
    for (name, text) in &export.files {
        let path = dir.join(name);
        crate::output::write_bytes(&path, text.as_bytes())?;
        written.push(path);
    }
    Ok(written)
}

/// `text` wrapped at about 80 columns, each new line started with `continuation` (a generated
/// comment's `\n * ` or `\n// `).
fn wrap_words(text: &str, continuation: &str) -> String {
    let mut out = String::new();
    let mut line = 0;
    for word in text.split(' ') {
        if line > 0 && line + word.len() > 80 {
            out.push_str(continuation);
            line = 0;
        } else if line > 0 {
            out.push(' ');
            line += 1;
        }
        out.push_str(word);
        line += word.len();
    }
    out
}

// The network's tanh constants, one copy (the no_std crate's), written out by the C export.
use spincal_embedded::{LN2_HI, LN2_HI_F, LN2_LO, LN2_LO_F, ROUNDER, ROUNDER_F, TANH_C, TANH_C_F};

#[cfg(test)]
mod tests {
    use super::*;

    /// The C tanh's constants are the network's: the double tanh written with them, as the C
    /// export writes it, gives the library's bits.
    #[test]
    fn tanh_constants_are_the_networks() {
        fn tanh(x: f64) -> f64 {
            let magnitude = x.abs();
            let y = -2.0 * if magnitude > 20.0 { 20.0 } else { magnitude };
            let shifted = y * std::f64::consts::LOG2_E + ROUNDER;
            let k = shifted - ROUNDER;
            let r = (y - k * LN2_HI) - k * LN2_LO;
            let (r2, t) = (r * r, &TANH_C);
            let r4 = r2 * r2;
            let pair = |j: usize| t[j] + t[j + 1] * r;
            let low = (pair(0) + pair(2) * r2) + (pair(4) + pair(6) * r2) * r4;
            let p = low + (pair(8) + pair(10) * r2) * (r4 * r4);
            let expm1_r = r + r2 * p;
            let scale = f64::from_bits((shifted.to_bits().wrapping_sub(ROUNDER.to_bits()) + 1023) << 52);
            let u = scale * expm1_r + (scale - 1.0);
            (-u / (2.0 + u)).copysign(x)
        }
        for i in -3000..3000 {
            let x = i as f64 / 137.0;
            assert_eq!(
                tanh(x).to_bits(),
                crate::correctors::ann::network::tanh(x).to_bits(),
                "{x}"
            );
        }
    }

    use crate::correctors::model_file::CorrectorModel;
    use crate::correctors::physical::{
        predicted_to_help, PhysicalCorrector, SensorModel, SensorUncertainty, SENSOR_PARAMS,
    };
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A physical model with a covariance A Aᵀ of strongly correlated parameters (seeded), q's
    /// rows included; `quadratic` false: physical-linear.
    fn physical_with_covariance(quadratic: bool) -> PhysicalCorrector {
        let mut rng = ChaCha8Rng::seed_from_u64(46);
        // Standard errors of bias, scale, misalignment and q as a campaign leaves them.
        let se = [
            3e-3, 3e-3, 3e-3, 4e-4, 4e-4, 4e-4, 5e-4, 5e-4, 5e-4, 3e-5, 3e-5, 3e-5,
        ];
        let a: Vec<[f64; SENSOR_PARAMS]> = (0..SENSOR_PARAMS)
            .map(|i| std::array::from_fn(|_| se[i] * rng.gen_range(-1.0..1.0)))
            .collect();
        let covariance = std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..SENSOR_PARAMS).map(|l| a[i][l] * a[j][l]).sum())
        });
        PhysicalCorrector {
            sensor: SensorModel {
                bias_mps2: [0.04, -0.06, 0.08],
                scale_error: [0.004, -0.006, 0.003],
                misalignment_rad: [0.005, -0.003, 0.004],
                quadratic_per_mps2: if quadratic { [6e-4, -6e-4, 3e-4] } else { [0.0; 3] },
            },
            gravity_mps2: 9.81,
            input_range_mps2: [[-12.0, 12.0]; 3],
            uncertainty: Some(SensorUncertainty {
                covariance,
                noise_sd_mps2: [0.02; 3],
                session_spread_mps2: None,
            }),
        }
    }

    /// The no_std crate's f64 error bar is the library's bit for bit (the C double export does
    /// its operations: tests/firmware.rs), the flag `predicted_to_help`'s, for physical and
    /// physical-linear, and both values of the flag occur.
    #[test]
    fn the_embedded_error_bar_is_the_librarys() {
        for quadratic in [true, false] {
            let p = physical_with_covariance(quadratic);
            let file = CorrectorFile::new(CorrectorModel::Physical(Box::new(p.clone())));
            let plan = plan::Plan::of(&file).unwrap();
            let plan::AccelPlan::Physical(ph) = &plan.accel else {
                panic!("a physical plan")
            };
            let embedded = spincal_embedded::Physical {
                bias: ph.bias,
                one_plus_scale: ph.one_plus_scale,
                misalignment: ph.misalignment,
                quadratic: ph.quadratic,
                lower: ph.lower,
                upper: ph.upper,
            };
            let covariance = plan.covariance.expect("the covariance");
            let mut flags = [0usize; 2];
            for m in fusion::grid(&[[-14.0, 14.0]; 3]) {
                let sd = p.predicted_sd(m).unwrap();
                let f = p.sensor.correct(m).unwrap();
                let better = (0..3).all(|k| predicted_to_help(f[k] - m[k], sd[k]));
                let ours = embedded.predicted_error(&covariance, m).unwrap();
                assert_eq!(ours.sd.map(f64::to_bits), sd.map(f64::to_bits), "{m:?}");
                assert_eq!(ours.better, better, "{m:?}");
                flags[usize::from(better)] += 1;
            }
            assert!(flags[0] > 0 && flags[1] > 0, "{flags:?}");
        }
    }

    /// A linear map of the three axes with a covariance A Aᵀ (seeded), as a campaign's linear-12.
    fn linear_with_covariance() -> crate::correctors::linear::LinearModel {
        let p = physical_with_covariance(false);
        crate::correctors::linear::LinearModel {
            axes: crate::correctors::corrector::Axis::ALL.to_vec(),
            offset_mps2: vec![-0.04, 0.06, -0.08],
            matrix: vec![
                vec![0.996, 0.0, 0.0],
                vec![-0.005, 1.006, 0.0],
                vec![0.003, -0.004, 0.997],
            ],
            training: None,
            uncertainty: p.uncertainty,
        }
    }

    /// The no_std crate's f64 error bar of a linear map is the library's bit for bit, the flag
    /// `predicted_to_help`'s on the library's correction, and both values of the flag occur.
    #[test]
    fn the_embedded_linear_error_bar_is_the_librarys() {
        let l = linear_with_covariance();
        let file = CorrectorFile::new(CorrectorModel::Linear(Box::new(l.clone())));
        let plan = plan::Plan::of(&file).unwrap();
        let plan::AccelPlan::Linear(lp) = &plan.accel else {
            panic!("a linear plan")
        };
        let embedded = spincal_embedded::Linear {
            axes: [0, 1, 2],
            n_axes: 3,
            offset: [lp.offset[0], lp.offset[1], lp.offset[2]],
            matrix: std::array::from_fn(|i| [lp.matrix[i][0], lp.matrix[i][1], lp.matrix[i][2]]),
        };
        let covariance = plan.covariance.expect("the covariance");
        let error_model = file.corrector.error_model().expect("an error model");
        let mut flags = [0usize; 2];
        for m in fusion::grid(&[[-14.0, 14.0]; 3]) {
            let sd = error_model.predicted_sd(m).unwrap();
            let f = l.apply(m);
            let better = (0..3).all(|k| predicted_to_help(f[k] - m[k], sd[k]));
            let ours = embedded.predicted_error(&covariance, m).unwrap();
            assert_eq!(ours.sd.map(f64::to_bits), sd.map(f64::to_bits), "{m:?}");
            assert_eq!(ours.better, better, "{m:?}");
            flags[usize::from(better)] += 1;
        }
        assert!(flags[0] > 0 && flags[1] > 0, "{flags:?}");
        // A map of fewer axes has no error bar.
        let two = spincal_embedded::Linear {
            n_axes: 2,
            ..embedded
        };
        assert_eq!(two.predicted_error(&covariance, [0.0, 0.0, 9.8]), None);
    }

    /// The export carries the error bar exactly where `correct` writes one, and says so where not.
    #[test]
    fn the_error_bar_is_exported_only_where_correct_writes_one() {
        let text = |file: &CorrectorFile, name: &str| {
            let export = export_firmware(file, "m.json", &ExportOptions::default()).unwrap();
            let get = |n: String| {
                export
                    .files
                    .iter()
                    .find(|(f, _)| *f == n)
                    .map(|(_, t)| t.clone())
                    .unwrap()
            };
            (
                get(format!("spincal_{name}.h")),
                get(format!("spincal_{name}.c")),
                get("spincal_model.rs".into()),
                export,
            )
        };
        let with = physical_with_covariance(true);
        let file = CorrectorFile::new(CorrectorModel::Physical(Box::new(with.clone())));
        let (header, source, rust, export) = text(&file, "f32");
        assert!(header.contains("#define SPINCAL_F32_PREDICTS_SD 1"), "{header}");
        assert!(header.contains("unsigned spincal_f32_predicted_sd("), "{header}");
        assert!(
            source.contains("float phys_covariance") || header.contains("float phys_covariance[12][12];")
        );
        assert!(source.contains("sqrtf(sum > 0 ? sum : 0)"), "{source}");
        assert!(rust.contains("pub static COVARIANCE_F32: spincal_embedded::Covariance<f32>"));
        assert!(rust.contains("covariance: Some(&COVARIANCE_F64)"));
        let rel = export
            .float_error
            .sd_max_rel
            .expect("the float error bar's error");
        assert!(rel < 1e-5, "{:?}", export.float_error);
        assert!(export
            .float_error_text()
            .contains("predicted standard deviation within"));

        // A linear map with a covariance: its own field and Jacobian, the shared loop.
        let file = CorrectorFile::new(CorrectorModel::Linear(Box::new(linear_with_covariance())));
        let (header, source, rust, export) = text(&file, "f64");
        assert!(header.contains("#define SPINCAL_F64_PREDICTS_SD 1"), "{header}");
        assert!(header.contains("double lin_covariance[12][12];"), "{header}");
        assert!(source.contains("jac[k][3 + 3 * k + j] = m[j];"), "{source}");
        assert!(source.contains("c->lin_covariance[a][b]") && !source.contains("phys_"));
        assert!(
            rust.contains("linear map's parameter covariance in f64"),
            "{rust}"
        );
        assert!(rust.contains("covariance: Some(&COVARIANCE_F32)"));
        assert!(
            export.float_error.sd_max_rel.is_some_and(|r| r < 1e-5),
            "{:?}",
            export.float_error
        );
        let without = crate::correctors::linear::LinearModel {
            uncertainty: None,
            ..linear_with_covariance()
        };
        let file = CorrectorFile::new(CorrectorModel::Linear(Box::new(without)));
        let (header, _, rust, _) = text(&file, "f32");
        assert!(header.contains("#define SPINCAL_F32_PREDICTS_SD 0"), "{header}");
        assert!(
            header.contains("linear map carries no parameter covariance"),
            "{header}"
        );
        assert!(rust.contains("covariance: None"));

        // Without a covariance, and a physical_ann whose physical part has one: nothing new.
        let without = PhysicalCorrector {
            uncertainty: None,
            ..with.clone()
        };
        let file = CorrectorFile::new(CorrectorModel::Physical(Box::new(without)));
        let (header, source, rust, export) = text(&file, "f64");
        assert!(header.contains("#define SPINCAL_F64_PREDICTS_SD 0"), "{header}");
        assert!(header.contains("carries no parameter covariance"), "{header}");
        assert!(!source.contains("predicted_sd") && !source.contains("phys_covariance"));
        assert!(!rust.contains("COVARIANCE") && rust.contains("covariance: None"));
        assert_eq!(export.float_error.sd_max_rel, None);
        let coverage = crate::correctors::physical_ann::InputCoverage::of(&[
            vec![0.0, 1.0],
            vec![0.0, 1.0],
            vec![9.0, 9.8],
        ]);
        use crate::correctors::ann::{AnnModel, Network, Scaling};
        use crate::correctors::corrector::Axis;
        let unit = || Scaling {
            min: vec![-1.0; 3],
            max: vec![1.0; 3],
        };
        // A 3-2-3 network of zero weights: its shape is what matters here.
        let network = AnnModel {
            axes: Axis::ALL.to_vec(),
            delays: 0,
            input_scaling: unit(),
            output_scaling: unit(),
            network: Network {
                inputs: 3,
                hidden: vec![2],
                outputs: 3,
                weights: vec![0.0; 2 * 4 + 3 * 3],
            },
            training: None,
        };
        let pa = crate::correctors::physical_ann::PhysicalAnnCorrector {
            physical: with,
            network,
            coverage,
        };
        let file = CorrectorFile::new(CorrectorModel::PhysicalAnn(Box::new(pa)));
        let (header, source, rust, _) = text(&file, "f32");
        assert!(header.contains("#define SPINCAL_F32_PREDICTS_SD 0"), "{header}");
        assert!(
            header.contains("error bar for a physical model or a linear map with a"),
            "{header}"
        );
        assert!(!source.contains("phys_covariance") && !rust.contains("COVARIANCE"));
    }

    #[test]
    fn names_must_be_c_identifiers() {
        let file = CorrectorFile::new(crate::correctors::model_file::CorrectorModel::Static(Box::new(
            crate::correctors::static_cal::StaticCalibration::identity(9.81),
        )));
        for bad in ["", "9lives", "a-b", "é"] {
            let options = ExportOptions {
                name: bad.into(),
                ..ExportOptions::default()
            };
            assert!(matches!(
                export_firmware(&file, "m.json", &options),
                Err(FirmwareError::Name { .. })
            ));
        }
        let export = export_firmware(&file, "m.json", &ExportOptions::default()).unwrap();
        let names: Vec<&str> = export.files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "spincal_f32.h",
                "spincal_f32.c",
                "spincal_f64.h",
                "spincal_f64.c",
                "spincal_model.rs",
                "fusion.txt"
            ]
        );
    }
}
