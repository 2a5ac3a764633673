//! `spincal export` end to end: every corrector kind trained on a simulated recording, exported
//! by the binary, the C compiled with the host compiler (`-std=c99 -Wall -Wextra -Werror
//! -pedantic`) and the Rust linked from a `#![no_std]` staticlib (with its own panic handler, so
//! a std anywhere below it would not link), both run on held-out recordings and compared with
//! the library's correction: double within 1e-9 relative, float within 2e-6 of full scale, the
//! flags (valid, outside the training range, gyro) equal; for the physical models with a
//! campaign's covariance also the error bar `correct` writes (each axis's predicted standard
//! deviation: double within 1e-9 relative, float within 1e-5 relative) and its
//! `predicted_better` (float: equal but within rounding of its threshold). The same float C built for a
//! Cortex-M4F and run under QEMU gives the host float build's outputs. And the Fusion values,
//! put through Fusion's formula written out here, give the physical-linear correction.
//!
//! `SPINCAL_FIRMWARE_KEEP=DIR` keeps the exports and the check library in DIR (bench/embedded
//! measures them).

use std::path::{Path, PathBuf};
use std::process::Command;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use spincal::campaign::joint::{fit_joint, JointSettings, PoseInput};

use spincal::correctors::ann::{AnnProblem, LmSettings};
use spincal::correctors::corrector::{Axis, Corrector};
use spincal::correctors::division::DivisionMode;
use spincal::correctors::gyro::{GyroInputUnit, GyroModel};
use spincal::correctors::linear::LinearModel;
use spincal::correctors::model_file::{CorrectorFile, CorrectorModel, Uncorrected};
use spincal::correctors::physical::{predicted_to_help, PhysicalCorrector, SensorModel, SensorUncertainty};
use spincal::correctors::physical_ann::{InputCoverage, PhysicalAnnCorrector};
use spincal::correctors::rows::{PredictedError, RowCorrector, RowOutcome, UnitFactors};
use spincal::correctors::static_cal::{StaticCalibration, StaticModel};
use spincal::firmware::{export_firmware, fusion_values, ExportOptions};
use spincal::input::recording::{Recording, STANDARD_GRAVITY};
use spincal::simulate::campaign::profile_sensor_model;
use spincal::simulate::{simulate, SensorProfile, TurntableSetup};

/// The kinds, by the name their files and symbols get.
const KINDS: [&str; 7] = [
    "physical",
    "physical_linear",
    "linear",
    "static",
    "ann",
    "physical_ann",
    "uncorrected",
];

/// Held-out samples run through every build.
struct Samples {
    accel: Vec<[f64; 3]>,
    gyro: Vec<[f64; 3]>,
    /// Where the still poses at new orientations lie in `accel`.
    poses: std::ops::Range<usize>,
}

fn setup(seed_shift: f64, duration_s: f64) -> TurntableSetup {
    TurntableSetup {
        duration_s,
        radius_m: 0.10 + seed_shift,
        beta_deg: 3.0 + 100.0 * seed_shift,
        ..TurntableSetup::default()
    }
}

/// The gyroscope's calibration every exported model carries.
fn gyro_model() -> GyroModel {
    GyroModel {
        bias_radps: [0.012, -0.008, 0.004],
        sensitivity: [
            [1.004, 0.003, -0.002],
            [0.001, 0.996, 0.004],
            [-0.003, 0.002, 1.002],
        ],
        input_unit: GyroInputUnit::RadPerS,
    }
}

/// A campaign's joint fit of `sensor` from 24 still poses at random orientations, each its own
/// file (800 samples of 0.02 m/s² noise): its sensor model and robust parameter covariance.
fn campaign_fit(sensor: &SensorModel) -> (SensorModel, SensorUncertainty) {
    let mut rng = ChaCha8Rng::seed_from_u64(46);
    let (samples, noise_mps2) = (800, 0.02);
    let se = noise_mps2 / (samples as f64).sqrt();
    let poses: Vec<PoseInput> = (0..24)
        .map(|p| {
            let d: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(&mut rng));
            let norm = d.iter().map(|v| v * v).sum::<f64>().sqrt();
            let clean = sensor.measure(d.map(|v| STANDARD_GRAVITY * v / norm));
            PoseInput {
                name: format!("pose {p}"),
                mean_mps2: clean.map(|v| {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    v + se * z
                }),
                sigma_mean_mps2: [se; 3],
                samples,
                time_s: 20.0 * p as f64,
                session: p,
                gyro_mean_radps: None,
                gyro_sigma_mean_radps: None,
                wander: None,
            }
        })
        .collect();
    let fit = fit_joint(&[], &poses, &JointSettings::default(), &spincal::progress::silent).unwrap();
    let covariance = fit.sensor_covariance().expect("the fit's covariance");
    (
        fit.sensor,
        SensorUncertainty {
            covariance,
            noise_sd_mps2: [noise_mps2; 3],
            session_spread_mps2: None,
        },
    )
}

/// Every kind trained on one simulated recording (small networks, few epochs: a test of the
/// export, not of training), and held-out samples from two other recordings (one like the
/// training run, one at another radius and mounting) plus readings beyond the training range.
fn models_and_samples() -> (Vec<(&'static str, CorrectorFile)>, Samples, f64) {
    let profile = SensorProfile::default();
    let train = simulate(&profile, &setup(0.0, 20.0), 11).unwrap();
    let measured = &train.recording;
    let reference = Recording {
        accel_mps2: train.true_accel_mps2.clone(),
        ..measured.clone()
    };
    let range: [[f64; 2]; 3] = std::array::from_fn(|k| {
        let v = &measured.accel_mps2[k];
        [
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ]
    });
    // The physical models as a campaign saves them: the joint fit's sensor with its covariance
    // (physical-linear keeps the fuller fit's, q's rows included, as the campaign does).
    let truth = profile_sensor_model(&profile);
    let (sensor, uncertainty) = campaign_fit(&truth);
    let physical = PhysicalCorrector {
        sensor,
        gravity_mps2: STANDARD_GRAVITY,
        input_range_mps2: range,
        uncertainty: Some(uncertainty),
    };
    let physical_linear = PhysicalCorrector {
        sensor: SensorModel {
            quadratic_per_mps2: [0.0; 3],
            ..sensor
        },
        ..physical.clone()
    };
    // A linear map with a covariance, as a campaign's linear-12 saves it (the physical fit's
    // numbers stand in for one of the same size): the error bar is exported for it too.
    let linear = LinearModel {
        uncertainty: physical.uncertainty.clone(),
        ..LinearModel::fit(measured, &reference, &Axis::ALL, DivisionMode::Contiguous).unwrap()
    };
    let settings = LmSettings {
        max_epochs: 40,
        ..LmSettings::default()
    };
    let ann = AnnProblem::new(
        measured,
        &reference,
        &[Axis::X, Axis::Y],
        2,
        DivisionMode::Contiguous,
    )
    .unwrap()
    .train(&[5], 1, 7, &settings)
    .unwrap();
    // The network on top of physics, trained as the campaign does: physical correction in,
    // what it left against the reference out.
    let mut input: [Vec<f64>; 3] = Default::default();
    let mut residual: [Vec<f64>; 3] = Default::default();
    for i in 0..measured.len() {
        let m = [0, 1, 2].map(|k| measured.accel_mps2[k][i]);
        if let Some(p) = physical.sensor.correct(m) {
            for k in 0..3 {
                input[k].push(p[k]);
                residual[k].push(reference.accel_mps2[k][i] - p[k]);
            }
        }
    }
    let coverage = InputCoverage::of(&input);
    let as_recording = |columns: [Vec<f64>; 3]| Recording {
        time_s: (0..columns[0].len()).map(|i| i as f64).collect(),
        accel_mps2: columns,
        gyro_radps: None,
        temperature_c: None,
        source: Default::default(),
    };
    let network = AnnProblem::new(
        &as_recording(input),
        &as_recording(residual),
        &Axis::ALL,
        0,
        DivisionMode::Interleaved { block_len: 20 },
    )
    .unwrap()
    .train(&[6], 1, 5, &settings)
    .unwrap();
    let physical_ann = PhysicalAnnCorrector {
        // Its physical part keeps the covariance, but `correct` gives physical_ann no error
        // bar, so neither may the exports.
        physical: physical.clone(),
        network,
        coverage,
    };
    let still = StaticCalibration {
        model: StaticModel::Nonlinear,
        bias: [0.05, -0.03, 0.08],
        scale: [1.003, 0.997, 1.001],
        misalignment: [0.004, -0.002, 0.003],
        nonlinearity: [2e-4, -3e-4, 1e-4],
        gravity_mps2: STANDARD_GRAVITY,
        input_unit: "m/s^2".into(),
    };
    let with_gyro = |model: CorrectorModel| {
        let mut file = CorrectorFile::new(model);
        file.gyro = Some(gyro_model());
        file
    };
    let models = vec![
        (
            "physical",
            with_gyro(CorrectorModel::Physical(Box::new(physical))),
        ),
        (
            "physical_linear",
            with_gyro(CorrectorModel::Physical(Box::new(physical_linear))),
        ),
        ("linear", with_gyro(CorrectorModel::Linear(Box::new(linear)))),
        ("static", with_gyro(CorrectorModel::Static(Box::new(still)))),
        ("ann", with_gyro(CorrectorModel::Ann(Box::new(ann)))),
        (
            "physical_ann",
            with_gyro(CorrectorModel::PhysicalAnn(Box::new(physical_ann))),
        ),
        // A gyro part saved alone (format 3): the accelerometer passes as read, the gyro is the
        // library's.
        (
            "uncorrected",
            with_gyro(CorrectorModel::Uncorrected(Box::new(Uncorrected {
                reason: "no accelerometer correction shown to help".into(),
            }))),
        ),
    ];

    let like_training = simulate(&profile, &setup(0.0, 6.0), 12).unwrap();
    let elsewhere = simulate(&profile, &setup(0.03, 6.0), 13).unwrap();
    let mut accel = Vec::new();
    for rec in [&like_training.recording, &elsewhere.recording] {
        for i in 0..rec.len() {
            accel.push([0, 1, 2].map(|k| rec.accel_mps2[k][i]));
        }
    }
    // Still poses at new orientations: gravity around the x–z and y–z circles, 2° apart. Near
    // −x and −y the correction (bias against scale) passes zero, so `predicted_better` turns.
    let first_pose = accel.len();
    for i in 0..360 {
        let angle = (2 * (i % 180)) as f64 * std::f64::consts::PI / 180.0;
        let (c, s) = (STANDARD_GRAVITY * angle.cos(), STANDARD_GRAVITY * angle.sin());
        accel.push(truth.measure(if i < 180 { [c, 0.0, s] } else { [0.0, c, s] }));
    }
    let poses = first_pose..accel.len();
    // Beyond the training range, and past the quadratic's turning point (z = −g/(4q) region).
    for i in 0..40 {
        let s = 1.0 + i as f64 * 0.1;
        accel.push([3.0 * s, -2.5 * s, 9.0 + s]);
    }
    let q = sensor.quadratic_per_mps2[2];
    assert!(q.abs() > 1e-6, "the fit's q_z {q}");
    accel.push([0.0, 0.0, -1.0 / (4.0 * q) - 50.0 * q.signum()]);
    let gyro = (0..accel.len())
        .map(|i| {
            let t = i as f64 * 0.01;
            [
                0.3 * (t * 1.3).sin(),
                -0.2 * (t * 0.7).cos(),
                3.49 + 0.01 * t.sin(),
            ]
        })
        .collect();
    let full_scale = profile.range_g * STANDARD_GRAVITY;
    (models, Samples { accel, gyro, poses }, full_scale)
}

/// This test's own folder (`name`), its exports from an earlier run removed.
fn work_dir(name: &str) -> PathBuf {
    let base = match std::env::var_os("SPINCAL_FIRMWARE_KEEP") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_TARGET_TMPDIR")).join("firmware"),
    };
    let dir = base.join(name);
    let _ = std::fs::remove_dir_all(dir.join("exports"));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn run(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Each kind's model file exported by the binary into `dir/exports/KIND`.
fn export_all(dir: &Path, models: &[(&str, CorrectorFile)]) {
    for (kind, file) in models {
        let model = dir.join(format!("{kind}.json"));
        file.write_path(&model).unwrap();
        let out = dir.join("exports").join(kind);
        let printed = run(Command::new(env!("CARGO_BIN_EXE_spincal")).args([
            "export",
            "--model",
            model.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--name",
            kind,
        ]));
        assert!(printed.contains("x-io Fusion"), "{printed}");
        assert!(printed.contains("float export: at most"), "{printed}");
        for suffix in ["f32.h", "f32.c", "f64.h", "f64.c", "model.rs"] {
            assert!(out.join(format!("{kind}_{suffix}")).is_file(), "{kind}_{suffix}");
        }
    }
}

/// The `#![no_std]` staticlib holding every kind's Rust export: one `KIND_rs_f32` and
/// `KIND_rs_f64` per kind correcting n samples from a fresh state. Returns the library's path.
fn build_no_std_library(dir: &Path) -> PathBuf {
    let project = dir.join("no-std-check");
    std::fs::create_dir_all(project.join("src")).unwrap();
    let embedded = Path::new(env!("CARGO_MANIFEST_DIR")).join("../spincal-embedded");
    std::fs::write(
        project.join("Cargo.toml"),
        format!(
            "[package]\nname = \"no-std-check\"\nversion = \"0.0.0\"\nedition = \"2021\"\n\n\
             [lib]\ncrate-type = [\"staticlib\"]\n\n\
             [dependencies]\nspincal-embedded = {{ path = {:?} }}\n\n\
             [profile.release]\npanic = \"abort\"\n\n[profile.dev]\npanic = \"abort\"\n\n[workspace]\n",
            embedded.canonicalize().unwrap()
        ),
    )
    .unwrap();
    let lock = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../Cargo.lock");
    std::fs::copy(lock, project.join("Cargo.lock")).unwrap();
    let mut lib = String::from(
        "#![no_std]\n\
         // No std anywhere below: a second panic handler (std's) would not link.\n\
         #[panic_handler]\nfn panic(_: &core::panic::PanicInfo) -> ! {\n    loop {}\n}\n\n\
         // The host's precompiled core refers to it even with panic = abort; never called.\n\
         #[no_mangle]\npub extern \"C\" fn rust_eh_personality() {}\n\n",
    );
    for kind in KINDS {
        let source = dir.join("exports").join(kind).join(format!("{kind}_model.rs"));
        lib.push_str(&format!(
            "#[allow(dead_code)]\nmod m_{kind} {{\n    include!({:?});\n}}\n",
            source.canonicalize().unwrap()
        ));
        for (t, upper) in [("f32", "F32"), ("f64", "F64")] {
            lib.push_str(&format!(
                "/// # Safety\n/// n samples of 3 values at accel and gyro, 6 n values at out, n at flags.\n\
                 #[no_mangle]\npub unsafe extern \"C\" fn {kind}_rs_{t}(n: usize, accel: *const {t}, gyro: *const {t}, out: *mut {t}, flags: *mut u32) {{\n    \
                 let (accel, gyro) = (core::slice::from_raw_parts(accel, 3 * n), core::slice::from_raw_parts(gyro, 3 * n));\n    \
                 let (out, flags) = (core::slice::from_raw_parts_mut(out, 6 * n), core::slice::from_raw_parts_mut(flags, n));\n    \
                 let mut state = m_{kind}::State{upper}::new();\n    \
                 for i in 0..n {{\n        \
                 let a = [accel[3 * i], accel[3 * i + 1], accel[3 * i + 2]];\n        \
                 let g = [gyro[3 * i], gyro[3 * i + 1], gyro[3 * i + 2]];\n        \
                 let c = m_{kind}::MODEL_{upper}.correct(&mut state, a, Some(g));\n        \
                 out[6 * i..6 * i + 3].copy_from_slice(&c.accel);\n        \
                 out[6 * i + 3..6 * i + 6].copy_from_slice(&c.gyro.unwrap_or(g));\n        \
                 flags[i] = u32::from(c.valid) | u32::from(c.outside_training_range) << 1 | u32::from(c.gyro.is_some()) << 2;\n    \
                 }}\n}}\n\n\
                 /// # Safety\n/// n samples of 3 values at accel and at sd, n at flags.\n\
                 #[no_mangle]\npub unsafe extern \"C\" fn {kind}_rs_sd_{t}(n: usize, accel: *const {t}, sd: *mut {t}, flags: *mut u32) {{\n    \
                 let accel = core::slice::from_raw_parts(accel, 3 * n);\n    \
                 let (sd, flags) = (core::slice::from_raw_parts_mut(sd, 3 * n), core::slice::from_raw_parts_mut(flags, n));\n    \
                 for i in 0..n {{\n        \
                 // The error bar with the C export's bits: SD 8, BETTER 16.\n        \
                 let p = m_{kind}::MODEL_{upper}.predicted_error([accel[3 * i], accel[3 * i + 1], accel[3 * i + 2]]);\n        \
                 sd[3 * i..3 * i + 3].copy_from_slice(&p.map_or([0.0; 3], |p| p.sd));\n        \
                 flags[i] = p.map_or(0, |p| 8 | u32::from(p.better) << 4);\n    \
                 }}\n}}\n\n"
            ));
        }
    }
    std::fs::write(project.join("src/lib.rs"), lib).unwrap();
    let target = project.join("target");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let build = |offline: bool| {
        let mut cmd = Command::new(&cargo);
        cmd.current_dir(&project)
            .env("CARGO_TARGET_DIR", &target)
            .env_remove("RUSTFLAGS")
            .env_remove("CARGO_ENCODED_RUSTFLAGS")
            .args(["build", "--release", "--quiet"]);
        if offline {
            cmd.arg("--offline");
        }
        cmd.output().unwrap()
    };
    let out = build(true);
    let out = if out.status.success() { out } else { build(false) };
    assert!(
        out.status.success(),
        "the no_std check library does not build:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    target.join("release/libno_std_check.a")
}

/// The C driver: reads `n` then n lines of accel and gyro, runs the float and double C exports
/// and the Rust exports, prints per sample `flags a0 a1 a2 g0 g1 g2 sd_flags sd0 sd1 sd2` for
/// each of the four (the error bar's flags and values 0 where the export has none).
fn driver(kind: &str) -> String {
    let upper = kind.to_ascii_uppercase();
    format!(
        "#include <stdio.h>\n#include <stdlib.h>\n#include \"{kind}_f32.h\"\n#include \"{kind}_f64.h\"\n\
         void {kind}_rs_f32(size_t n, const float *accel, const float *gyro, float *out, unsigned *flags);\n\
         void {kind}_rs_f64(size_t n, const double *accel, const double *gyro, double *out, unsigned *flags);\n\
         void {kind}_rs_sd_f32(size_t n, const float *accel, float *sd, unsigned *flags);\n\
         void {kind}_rs_sd_f64(size_t n, const double *accel, double *sd, unsigned *flags);\n\
         int main(void)\n{{\n    size_t n, i;\n    int k;\n    double *a, *g, *o64, *sd64;\n    float *a32, *g32, *o32, *sd32;\n    \
         unsigned *f32, *f64, *p32, *p64;\n    \
         {kind}_f32_state s32;\n    {kind}_f64_state s64;\n    \
         if (scanf(\"%lu\", (unsigned long *)&n) != 1) {{\n        return 2;\n    }}\n    \
         a = malloc(3 * n * sizeof *a);\n    g = malloc(3 * n * sizeof *g);\n    o64 = malloc(6 * n * sizeof *o64);\n    sd64 = malloc(3 * n * sizeof *sd64);\n    \
         a32 = malloc(3 * n * sizeof *a32);\n    g32 = malloc(3 * n * sizeof *g32);\n    o32 = malloc(6 * n * sizeof *o32);\n    sd32 = malloc(3 * n * sizeof *sd32);\n    \
         f32 = malloc(n * sizeof *f32);\n    f64 = malloc(n * sizeof *f64);\n    p32 = malloc(n * sizeof *p32);\n    p64 = malloc(n * sizeof *p64);\n    \
         for (i = 0; i < 3 * n; i += 3) {{\n        \
         if (scanf(\"%lf %lf %lf %lf %lf %lf\", &a[i], &a[i + 1], &a[i + 2], &g[i], &g[i + 1], &g[i + 2]) != 6) {{\n            return 3;\n        }}\n        \
         for (k = 0; k < 3; ++k) {{\n            a32[i + k] = (float)a[i + k];\n            g32[i + k] = (float)g[i + k];\n        }}\n    }}\n    \
         {kind}_f32_init(&s32);\n    {kind}_f64_init(&s64);\n    \
         for (i = 0; i < n; ++i) {{\n        float ao[3], go[3] = {{0, 0, 0}}, e32[3] = {{0, 0, 0}};\n        \
         double bo[3], ho[3] = {{0, 0, 0}}, e64[3] = {{0, 0, 0}};\n        unsigned q32 = 0, q64 = 0;\n        \
         unsigned c32 = {kind}_f32_correct(&{kind}_f32_model, &s32, &a32[3 * i], &g32[3 * i], ao, go);\n        \
         unsigned c64 = {kind}_f64_correct(&{kind}_f64_model, &s64, &a[3 * i], &g[3 * i], bo, ho);\n\
         #if {upper}_F32_PREDICTS_SD\n        q32 = {kind}_f32_predicted_sd(&{kind}_f32_model, &a32[3 * i], e32);\n#endif\n\
         #if {upper}_F64_PREDICTS_SD\n        q64 = {kind}_f64_predicted_sd(&{kind}_f64_model, &a[3 * i], e64);\n#endif\n        \
         printf(\"%u %.9g %.9g %.9g %.9g %.9g %.9g %u %.9g %.9g %.9g \", c32, ao[0], ao[1], ao[2], go[0], go[1], go[2], q32, e32[0], e32[1], e32[2]);\n        \
         printf(\"%u %.17g %.17g %.17g %.17g %.17g %.17g %u %.17g %.17g %.17g\\n\", c64, bo[0], bo[1], bo[2], ho[0], ho[1], ho[2], q64, e64[0], e64[1], e64[2]);\n    }}\n    \
         {kind}_rs_f32(n, a32, g32, o32, f32);\n    {kind}_rs_f64(n, a, g, o64, f64);\n    \
         {kind}_rs_sd_f32(n, a32, sd32, p32);\n    {kind}_rs_sd_f64(n, a, sd64, p64);\n    \
         for (i = 0; i < n; ++i) {{\n        \
         const float *r = &o32[6 * i], *e = &sd32[3 * i];\n        const double *d = &o64[6 * i], *h = &sd64[3 * i];\n        \
         printf(\"%u %.9g %.9g %.9g %.9g %.9g %.9g %u %.9g %.9g %.9g \", f32[i], r[0], r[1], r[2], r[3], r[4], r[5], p32[i], e[0], e[1], e[2]);\n        \
         printf(\"%u %.17g %.17g %.17g %.17g %.17g %.17g %u %.17g %.17g %.17g\\n\", f64[i], d[0], d[1], d[2], d[3], d[4], d[5], p64[i], h[0], h[1], h[2]);\n    }}\n    \
         free(a);\n    free(g);\n    free(o64);\n    free(sd64);\n    free(a32);\n    free(g32);\n    free(o32);\n    free(sd32);\n    \
         free(f32);\n    free(f64);\n    free(p32);\n    free(p64);\n    return 0;\n}}\n"
    )
}

/// One build's output for one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Out {
    flags: u32,
    accel: [f64; 3],
    gyro: [f64; 3],
    /// The error bar's bits (SD 8: given; BETTER 16: `predicted_better`), 0 without one.
    sd_flags: u32,
    /// Predicted standard deviation per axis, m/s² (0 without one).
    sd: [f64; 3],
}

fn parse(fields: &[&str]) -> Out {
    let v: Vec<f64> = fields[1..7].iter().map(|t| t.parse().unwrap()).collect();
    let sd: Vec<f64> = fields[8..11].iter().map(|t| t.parse().unwrap()).collect();
    Out {
        flags: fields[0].parse().unwrap(),
        accel: [v[0], v[1], v[2]],
        gyro: [v[3], v[4], v[5]],
        sd_flags: fields[7].parse().unwrap(),
        sd: [sd[0], sd[1], sd[2]],
    }
}

/// The library's correction of the samples, sample by sample through the corrector's stream:
/// what `spincal correct` writes (values, `valid`, `extrapolated`, and through the row
/// corrector `<column>_corrected_sd` and `predicted_better`) and its gyro correction.
fn library(file: &CorrectorFile, samples: &Samples) -> Vec<Out> {
    let mut stream = file.corrector.stream();
    let mut rows = RowCorrector::new(file, UnitFactors::SI, false).unwrap();
    let gyro = file
        .gyro
        .as_ref()
        .and_then(|g| g.corrector())
        .expect("a gyro model");
    samples
        .accel
        .iter()
        .zip(&samples.gyro)
        .map(|(&a, &w)| {
            let c = stream.correct_sample(a);
            let predicted = match rows.correct(None, a, None, None, |_| String::new()) {
                RowOutcome::Corrected { predicted, .. } => predicted,
                // `correct` refuses a row beyond ±500 g (rows::MAX_CORRECTED_ACCEL_MPS2: the
                // sample past the quadratic's turning point); the firmware has no such bound, so
                // there its error bar is held against the model's own covariance.
                RowOutcome::Refused(why) if why.contains("beyond ±500 g") => {
                    file.corrector.error_model().and_then(|model| {
                        let sd_mps2 = model.predicted_sd(a)?;
                        let better = (0..3).all(|k| predicted_to_help(c.accel_mps2[k] - a[k], sd_mps2[k]));
                        Some(PredictedError { sd_mps2, better })
                    })
                }
                RowOutcome::Refused(why) => panic!("{a:?} refused: {why}"),
            };
            Out {
                flags: u32::from(c.valid) | u32::from(c.outside_training_range) << 1 | 4,
                accel: c.accel_mps2,
                gyro: gyro.correct(w),
                sd_flags: predicted.map_or(0, |p| 8 | u32::from(p.better) << 4),
                sd: predicted.map_or([0.0; 3], |p| p.sd_mps2),
            }
        })
        .collect()
}

/// How far the float export's predicted standard deviation may lie from the library's,
/// relative (the sum J Σ Jᵀ cancels between correlated parameters, in single precision).
const SD_FLOAT_REL: f64 = 1e-5;

/// Where the float's `predicted_better` may differ from the library's: some axis's correction c
/// has |c² − 2 sd²| / (c² + 2 sd²) below this (c, a difference of two floats near the reading,
/// carries the reading's rounding).
const BETTER_ROUNDING: f64 = 1e-3;

const C_FLAGS: [&str; 7] = [
    "-std=c99",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-pedantic",
    "-O2",
    "-ffp-contract=off",
];

#[test]
fn every_kind_exported_to_c_and_no_std_rust_matches_the_library() {
    let dir = work_dir("host");
    let (models, samples, full_scale) = models_and_samples();
    export_all(&dir, &models);
    let library_a = build_no_std_library(&dir);
    let gyro_scale = samples.gyro.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut input = format!("{}\n", samples.accel.len());
    for (a, g) in samples.accel.iter().zip(&samples.gyro) {
        input.push_str(&format!(
            "{:?} {:?} {:?} {:?} {:?} {:?}\n",
            a[0], a[1], a[2], g[0], g[1], g[2]
        ));
    }
    let input_file = dir.join("held_out.txt");
    std::fs::write(&input_file, &input).unwrap();
    println!("kind             double: max rel. diff (C, Rust)   float accel: max diff / full scale (C, Rust)   float gyro (C, Rust)   outside");
    for (kind, file) in &models {
        let exports = dir.join("exports").join(kind);
        std::fs::write(exports.join("driver.c"), driver(kind)).unwrap();
        let binary = exports.join("driver");
        run(Command::new("cc")
            .current_dir(&exports)
            .args(C_FLAGS)
            .args(["driver.c", &format!("{kind}_f32.c"), &format!("{kind}_f64.c")])
            .arg(&library_a)
            .args(["-lm", "-o"])
            .arg(&binary));
        let printed = run(Command::new("sh").arg("-c").arg(format!(
            "{:?} < {:?}",
            binary.display().to_string(),
            input_file.display().to_string()
        )));
        let lines: Vec<&str> = printed.lines().collect();
        let n = samples.accel.len();
        assert_eq!(
            lines.len(),
            2 * n,
            "{kind}: {} lines for {n} samples",
            lines.len()
        );
        let expected = library(file, &samples);
        let mut worst_double = [0.0f64; 2];
        let mut worst_float = [0.0f64; 2];
        let mut worst_gyro = [0.0f64; 2];
        let mut outside = 0;
        let (mut worst_sd_double, mut worst_sd_float) = ([0.0f64; 2], [0.0f64; 2]);
        let (mut with_sd, mut better, mut better_rounding) = (0, 0, [0usize; 2]);
        for i in 0..n {
            let e = expected[i];
            outside += usize::from(e.flags & 2 != 0);
            // The float C and the f32 Rust do the same operations: the same bits (%.9g
            // round-trips a float).
            let (c_float, rust_float) = (lines[i].split(' ').take(11), lines[n + i].split(' ').take(11));
            assert!(
                c_float.eq(rust_float),
                "{kind}, sample {i}: float C and f32 Rust differ"
            );
            for (b, line) in [lines[i], lines[n + i]].iter().enumerate() {
                let fields: Vec<&str> = line.split_whitespace().collect();
                let (single, double) = (parse(&fields[..11]), parse(&fields[11..]));
                let language = ["C", "Rust"][b];
                assert_eq!(
                    double.flags, e.flags,
                    "{kind} {language} double, sample {i}: flags"
                );
                assert_eq!(
                    single.flags, e.flags,
                    "{kind} {language} float, sample {i}: flags"
                );
                let scale = e.accel.iter().fold(1e-3f64, |m, v| m.max(v.abs()));
                let gscale = e.gyro.iter().fold(1e-3f64, |m, v| m.max(v.abs()));
                for k in 0..3 {
                    let rel = ((double.accel[k] - e.accel[k]) / scale)
                        .abs()
                        .max(((double.gyro[k] - e.gyro[k]) / gscale).abs());
                    worst_double[b] = worst_double[b].max(rel);
                    // Readings beyond full scale (the test's extremes) count relative to themselves.
                    let fs = ((single.accel[k] - e.accel[k]) / full_scale.max(e.accel[k].abs())).abs();
                    worst_float[b] = worst_float[b].max(fs);
                    worst_gyro[b] = worst_gyro[b].max(((single.gyro[k] - e.gyro[k]) / gyro_scale).abs());
                }
                // The error bar: the double's flags equal, the float's SD bit equal and its
                // BETTER bit equal unless the correction lies within rounding of √2 sd.
                assert_eq!(
                    double.sd_flags, e.sd_flags,
                    "{kind} {language} double, sample {i}: error bar flags"
                );
                assert_eq!(
                    single.sd_flags & 8,
                    e.sd_flags & 8,
                    "{kind} {language} float, sample {i}: error bar given"
                );
                if single.sd_flags != e.sd_flags {
                    let margin = (0..3)
                        .map(|k| {
                            let c = e.accel[k] - samples.accel[i][k];
                            let twice = 2.0 * e.sd[k] * e.sd[k];
                            (c * c - twice).abs() / (c * c + twice)
                        })
                        .fold(f64::INFINITY, f64::min);
                    assert!(
                        margin < BETTER_ROUNDING,
                        "{kind} {language} float, sample {i}: predicted_better differs {margin:e} from its threshold"
                    );
                    better_rounding[b] += 1;
                }
                for k in 0..3 {
                    let rel = |x: f64| {
                        if x == e.sd[k] {
                            0.0
                        } else {
                            ((x - e.sd[k]) / e.sd[k]).abs()
                        }
                    };
                    worst_sd_double[b] = worst_sd_double[b].max(rel(double.sd[k]));
                    worst_sd_float[b] = worst_sd_float[b].max(rel(single.sd[k]));
                }
            }
            if e.sd_flags & 8 != 0 {
                with_sd += 1;
                better += usize::from(e.sd_flags & 16 != 0);
            }
        }
        if with_sd > 0 {
            println!(
                "{kind:16} error bar: double max rel. diff {:9.2e} {:9.2e}, float {:9.2e} {:9.2e} (C, Rust); predicted_better on {better} of {with_sd}, float flag within rounding of the threshold on {} {}",
                worst_sd_double[0], worst_sd_double[1], worst_sd_float[0], worst_sd_float[1], better_rounding[0], better_rounding[1]
            );
        }
        println!(
            "{kind:16} {:9.2e} {:9.2e}                 {:9.2e} {:9.2e}                              {:9.2e} {:9.2e}    {outside}/{n}",
            worst_double[0], worst_double[1], worst_float[0], worst_float[1], worst_gyro[0], worst_gyro[1]
        );
        for b in 0..2 {
            let language = ["C", "Rust"][b];
            assert!(
                worst_double[b] <= 1e-9,
                "{kind}: double {language} off by {:e} relative",
                worst_double[b]
            );
            assert!(
                worst_float[b] <= 2e-6,
                "{kind}: float {language} off by {:e} of full scale",
                worst_float[b]
            );
            assert!(
                worst_gyro[b] <= 2e-6,
                "{kind}: float {language} gyro off by {:e} of full scale",
                worst_gyro[b]
            );
            assert!(
                worst_sd_double[b] <= 1e-9,
                "{kind}: double {language} error bar off by {:e} relative",
                worst_sd_double[b]
            );
            assert!(
                worst_sd_float[b] <= SD_FLOAT_REL,
                "{kind}: float {language} error bar off by {:e} relative",
                worst_sd_float[b]
            );
        }
        // The models `correct` gives an error bar have one in every build, the others none.
        let has_error_bar = file.corrector.error_model().is_some();
        assert_eq!(
            has_error_bar,
            matches!(*kind, "physical" | "physical_linear" | "linear"),
            "{kind}"
        );
        if has_error_bar {
            // All but physical's reading past the turning point, and both values of the flag.
            assert_eq!(with_sd, n - usize::from(*kind == "physical"), "{kind}");
            assert!(
                better > 0 && better < with_sd,
                "{kind}: predicted_better on {better} of {with_sd}"
            );
        } else {
            assert_eq!(with_sd, 0, "{kind}");
        }
        // The error the export states for its float build, measured on its training range.
        let stated = export_firmware(file, kind, &ExportOptions::default())
            .unwrap()
            .float_error;
        let worst_stated = stated.max_abs_mps2.iter().fold(0.0f64, |m, v| m.max(*v));
        println!(
            "{kind:16} stated float error {worst_stated:.2e} m/s² over {} grid points ({} flagged differently)",
            stated.points, stated.flags_differ
        );
        assert!(stated.points > 100, "{kind}: {stated:?}");
        assert!(worst_stated <= 2e-6 * full_scale, "{kind}: {stated:?}");
        assert_eq!(stated.sd_max_rel.is_some(), has_error_bar, "{kind}: {stated:?}");
        if let Some(rel) = stated.sd_max_rel {
            println!(
                "{kind:16} stated float error bar error {rel:.2e} relative ({} grid points with predicted_better flagged differently)",
                stated.better_differ
            );
            assert!(rel <= SD_FLOAT_REL, "{kind}: {stated:?}");
        }
        if *kind == "physical_ann" || *kind == "ann" {
            // Both sides of the envelope were exercised.
            assert!(
                outside > 0 && outside < n,
                "{kind}: {outside} of {n} samples outside"
            );
        }
    }
}

/// Fusion's inertial calibration as its documentation defines it:
/// calibrated = M · ((uncalibrated − offset) ⊙ sensitivity), in g.
fn fusion(m: [[f64; 3]; 3], sensitivity: [f64; 3], offset: [f64; 3], u: [f64; 3]) -> [f64; 3] {
    let v = [
        (u[0] - offset[0]) * sensitivity[0],
        (u[1] - offset[1]) * sensitivity[1],
        (u[2] - offset[2]) * sensitivity[2],
    ];
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

#[test]
fn fusion_values_reproduce_the_physical_linear_correction() {
    let g = STANDARD_GRAVITY;
    let sensor = SensorModel {
        bias_mps2: [0.04, -0.06, 0.08],
        scale_error: [0.004, -0.006, 0.003],
        misalignment_rad: [0.005, -0.003, 0.004],
        quadratic_per_mps2: [0.0; 3],
    };
    let physical = PhysicalCorrector {
        sensor,
        gravity_mps2: g,
        input_range_mps2: [[-15.0, 15.0]; 3],
        uncertainty: None,
    };
    let mut file = CorrectorFile::new(CorrectorModel::Physical(Box::new(physical.clone())));
    file.gyro = Some(gyro_model());
    let values = fusion_values(&file);
    let acc = values.accelerometer.as_ref().expect("accelerometer values");
    assert_eq!(acc.input_unit, "g");
    assert!(
        values.not_held.is_empty(),
        "physical-linear is affine: {:?}",
        values.not_held
    );
    let mut worst = 0.0f64;
    for i in 0..200 {
        let t = i as f64 * 0.37;
        let m = [
            12.0 * t.sin(),
            -9.0 * (1.3 * t).cos(),
            9.8 + 3.0 * (0.7 * t).sin(),
        ];
        let ours = sensor.correct(m).unwrap();
        let theirs = fusion(acc.misalignment, acc.sensitivity, acc.offset, m.map(|v| v / g)).map(|v| v * g);
        for k in 0..3 {
            worst = worst.max((ours[k] - theirs[k]).abs());
        }
    }
    assert!(
        worst < 1e-6,
        "Fusion's formula is {worst:e} m/s² from physical-linear"
    );

    // The gyroscope in deg/s.
    let gyro = values.gyroscope.as_ref().expect("gyroscope values");
    let corrector = gyro_model().corrector().unwrap();
    let deg = 180.0 / std::f64::consts::PI;
    let w = [0.3, -1.2, 3.4];
    let ours = corrector.correct(w).map(|v| v * deg);
    let theirs = fusion(
        gyro.misalignment,
        gyro.sensitivity,
        gyro.offset,
        w.map(|v| v * deg),
    );
    for k in 0..3 {
        assert!((ours[k] - theirs[k]).abs() < 1e-9, "{ours:?} {theirs:?}");
    }

    // With the quadratic term, Fusion's values are the linear part and the term's effect is
    // stated: at least what it does at the range's ends.
    let mut quadratic = physical;
    quadratic.sensor.quadratic_per_mps2 = [6e-4, -6e-4, 3e-4];
    let values = fusion_values(&CorrectorFile::new(CorrectorModel::Physical(Box::new(
        quadratic.clone(),
    ))));
    let effect = values.not_held[0].max_effect_mps2;
    let at_end = (quadratic.sensor.correct([15.0, 0.0, 0.0]).unwrap()[0]
        - sensor.correct([15.0, 0.0, 0.0]).unwrap()[0])
        .abs();
    assert!(
        effect[0] >= at_end * 0.999 && at_end > 0.1,
        "{effect:?} vs {at_end}"
    );
}

/// The ARM toolchain and QEMU, or why not.
fn arm_tools() -> Result<(), String> {
    for tool in ["arm-none-eabi-gcc", "qemu-system-arm"] {
        match Command::new(tool).arg("--version").output() {
            Ok(out) if out.status.success() => {}
            _ => {
                return Err(format!(
                    "{tool} is not installed (bash scripts/setup.sh installs it)"
                ))
            }
        }
    }
    let newlib = Command::new("arm-none-eabi-gcc")
        .args([
            "-mcpu=cortex-m4",
            "-mthumb",
            "-mfloat-abi=hard",
            "-mfpu=fpv4-sp-d16",
        ])
        .arg("-print-file-name=librdimon.a")
        .output()
        .ok()
        .map(|out| PathBuf::from(String::from_utf8_lossy(&out.stdout).trim()));
    if !newlib.is_some_and(|path| path.is_absolute() && path.is_file()) {
        return Err("newlib's semihosting library (libnewlib-arm-none-eabi) is not installed".into());
    }
    Ok(())
}

/// A reset handler that enables the FPU before newlib's start-up, and the vector table.
const STARTUP: &str = "extern void _start(void);\n\
static void reset(void)\n{\n    *(volatile unsigned long *)0xE000ED88UL |= 0xFUL << 20; /* CPACR: CP10, CP11 */\n    \
__asm volatile(\"dsb\\n\\tisb\");\n    _start();\n    for (;;) {\n    }\n}\n\
static void fault(void)\n{\n    for (;;) {\n    }\n}\n\
__attribute__((section(\".vectors\"), used)) static void (*const vectors[16])(void) = {\n    \
(void (*)(void))0x20010000UL, reset, fault, fault, fault, fault, fault, 0, 0, 0, 0, fault, fault, 0, fault, fault,\n};\n";

/// A driver with the samples compiled in (no file system on the target): prints the float
/// export's `flags a0 a1 a2 g0 g1 g2` per sample, and `sd_flags sd0 sd1 sd2` where it gives an
/// error bar.
fn embedded_driver(kind: &str, samples: &Samples, n: usize) -> String {
    let upper = kind.to_ascii_uppercase();
    let mut data = String::new();
    for i in 0..n {
        let (a, g) = (samples.accel[i], samples.gyro[i]);
        data.push_str(&format!(
            "    {{{:?}f, {:?}f, {:?}f, {:?}f, {:?}f, {:?}f}},\n",
            a[0] as f32, a[1] as f32, a[2] as f32, g[0] as f32, g[1] as f32, g[2] as f32
        ));
    }
    format!(
        "#include <stdio.h>\n#include <stdint.h>\n#include \"{kind}_f32.h\"\nstatic const float samples[{n}][6] = {{\n{data}}};\n\
         /* The bits of a float (newlib's printf has no %a). */\n\
         static unsigned long bits(float x)\n{{\n    union {{\n        float f;\n        uint32_t u;\n    }} v;\n    v.f = x;\n    return (unsigned long)v.u;\n}}\n\
         int main(void)\n{{\n    {kind}_f32_state s;\n    int i;\n    {kind}_f32_init(&s);\n    \
         for (i = 0; i < {n}; ++i) {{\n        float a[3], g[3];\n        \
         unsigned f = {kind}_f32_correct(&{kind}_f32_model, &s, &samples[i][0], &samples[i][3], a, g);\n        \
         printf(\"%u %08lx %08lx %08lx %08lx %08lx %08lx\", f, bits(a[0]), bits(a[1]), bits(a[2]), bits(g[0]), bits(g[1]), bits(g[2]));\n\
         #if {upper}_F32_PREDICTS_SD\n        \
         {{\n            float sd[3];\n            unsigned p = {kind}_f32_predicted_sd(&{kind}_f32_model, &samples[i][0], sd);\n            \
         printf(\" %u %08lx %08lx %08lx\", p, bits(sd[0]), bits(sd[1]), bits(sd[2]));\n        }}\n\
         #endif\n        \
         printf(\"\\n\");\n    }}\n    \
         return 0;\n}}\n"
    )
}

#[test]
fn float_export_on_a_cortex_m4f_under_qemu_matches_the_host() {
    if let Err(why) = arm_tools() {
        if std::env::var_os("SPINCAL_REQUIRE_ARM").is_some() {
            panic!("SPINCAL_REQUIRE_ARM is set, but {why}");
        }
        println!("skipped: {why}");
        return;
    }
    let dir = work_dir("cortex-m4");
    let (models, samples, _) = models_and_samples();
    export_all(&dir, &models);
    let n = 300.min(samples.accel.len());
    // The held-out recordings' first samples, every fourth still pose (where predicted_better
    // turns), and the ones beyond the training range at the end.
    let poses: Vec<[f64; 3]> = samples.accel[samples.poses.clone()]
        .iter()
        .step_by(4)
        .copied()
        .collect();
    let accel: Vec<[f64; 3]> = samples.accel[..n - 41 - poses.len()]
        .iter()
        .chain(&poses)
        .chain(&samples.accel[samples.accel.len() - 41..])
        .copied()
        .collect();
    let picked = Samples {
        poses: n - 41 - poses.len()..n - 41,
        accel,
        gyro: samples.gyro[..n].to_vec(),
    };
    std::fs::write(dir.join("startup.c"), STARTUP).unwrap();
    for (kind, _) in &models {
        let exports = dir.join("exports").join(kind);
        std::fs::write(exports.join("main.c"), embedded_driver(kind, &picked, n)).unwrap();
        let host = exports.join("host");
        run(Command::new("cc")
            .current_dir(&exports)
            .args(C_FLAGS)
            .args(["main.c", &format!("{kind}_f32.c"), "-lm", "-o"])
            .arg(&host));
        let elf = exports.join("m4.elf");
        run(Command::new("arm-none-eabi-gcc")
            .current_dir(&exports)
            .args(C_FLAGS)
            .args([
                "-mcpu=cortex-m4",
                "-mthumb",
                "-mfloat-abi=hard",
                "-mfpu=fpv4-sp-d16",
                "--specs=rdimon.specs",
            ])
            .args(["main.c", &format!("{kind}_f32.c")])
            .arg(dir.join("startup.c"))
            .args(["-Wl,--section-start=.vectors=0", "-lm", "-o"])
            .arg(&elf));
        let on_host = run(&mut Command::new(&host));
        let on_m4 = run(Command::new("timeout")
            .args(["60", "qemu-system-arm", "-M", "mps2-an386", "-cpu", "cortex-m4"])
            .args([
                "-semihosting",
                "-nographic",
                "-monitor",
                "none",
                "-serial",
                "none",
                "-kernel",
            ])
            .arg(&elf));
        assert_eq!(on_m4.lines().count(), n, "{kind}: QEMU printed:\n{on_m4}");
        // The error bar is compared too where the export gives one.
        let fields = if matches!(*kind, "physical" | "physical_linear" | "linear") {
            11
        } else {
            7
        };
        assert!(
            on_host.lines().all(|l| l.split(' ').count() == fields),
            "{kind}: expected {fields} fields a line:\n{on_host}"
        );
        // The floats' bits: equal text is equal bits.
        let differing = on_host.lines().zip(on_m4.lines()).filter(|(h, m)| h != m).count();
        println!(
            "{kind}: Cortex-M4F under QEMU and the host agree bit for bit on {} of {n} samples",
            n - differing
        );
        assert_eq!(
            differing, 0,
            "{kind}: {differing} of {n} samples differ between the host and the Cortex-M4F"
        );
    }
}
