use std::io::Write as _;

use super::*;
use crate::correctors::model_file::CorrectorModel;
use crate::correctors::static_cal::StaticCalibration;

/// A static calibration that removes a bias of 0.5 m/s² on x (its input in m/s²).
fn bias_model() -> CorrectorFile {
    let mut cal = StaticCalibration::identity(9.81);
    cal.bias = [0.5, 0.0, 0.0];
    CorrectorFile::new(CorrectorModel::Static(Box::new(cal)))
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let path = dir.join(name);
    std::fs::File::create(&path)
        .and_then(|mut f| f.write_all(text.as_bytes()))
        .expect("a temporary file");
    path
}

fn corrected(model: &CorrectorFile, input: &Path, options: &ReadOptions) -> (String, StreamSummary) {
    let mut out = Vec::new();
    let summary = correct_to_writer(model, input, options, None, &mut out).expect("corrected");
    (String::from_utf8(out).expect("UTF-8"), summary)
}

#[test]
fn every_row_comes_out_in_its_order_with_refusals_and_skips_in_place() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let input = write(
        dir.path(),
        "rec.csv",
        "t,ax,ay,az\n0.00,1.5,0,9.81\n0.02,1.5,0,9.81\n0.01,1.5,0,9.81\n0.03,,0,9.81\n0.04,abc,0,9.81\n0.05,0.5,0,9.81\n",
    );
    let (text, summary) = corrected(&bias_model(), &input, &ReadOptions::default());
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "t,ax,ay,az,ax_corrected_mps2,ay_corrected_mps2,az_corrected_mps2,valid,status"
    );
    assert_eq!(lines.len(), 7, "{text}");
    assert!(
        lines[1].starts_with("0.00,1.5,0,9.81,1,0,9.81,1,ok"),
        "{}",
        lines[1]
    );
    // A static calibration needs no time: a row whose time goes backwards is corrected.
    assert!(
        lines[3].starts_with("0.01,1.5,0,9.81,1,0,9.81,1,ok"),
        "{}",
        lines[3]
    );
    assert!(
        lines[4].contains(",0,skipped: line 5: column 2 (ax) is empty"),
        "{}",
        lines[4]
    );
    assert!(
        lines[5].starts_with("0.04,abc,0,9.81,,,,0,\"refused: line 6"),
        "{}",
        lines[5]
    );
    assert!(
        lines[5].contains("column 2 (ax): 'abc' is not a number"),
        "{}",
        lines[5]
    );
    assert!(
        lines[6].starts_with("0.05,0.5,0,9.81,0,0,9.81,1,ok"),
        "{}",
        lines[6]
    );
    assert_eq!((summary.rows, summary.refused, summary.skipped), (6, 1, 1));
    assert!(summary
        .refusals()
        .is_some_and(|r| r.contains("1 of 6 rows refused")));
    assert!(summary
        .warnings()
        .iter()
        .any(|w| w.contains("1 of 6 rows have no value")));
}

#[test]
fn a_file_read_whole_names_its_columns_as_the_stream_does_and_agrees_on_the_values() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let input = write(
        dir.path(),
        "rec.csv",
        "t_s,ax_mps2,ay_mps2,az_mps2\n0,1.5,0,9.81\n0.01,2.5,0.25,9.75\n",
    );
    let model = bias_model();
    let (streamed, _) = corrected(&model, &input, &ReadOptions::default());
    // A sample rate needs the whole file: the same rows, through the common reader.
    let options = ReadOptions {
        sample_rate_hz: Some(100.0),
        ..ReadOptions::default()
    };
    assert!(reads_whole_file(&input, &options).expect("a readable file"));
    let (whole, summary) = corrected(&model, &input, &options);
    let header = whole.lines().next().expect("a header");
    assert_eq!(
        header,
        "line,t_s,ax_mps2,ay_mps2,az_mps2,ax_corrected_mps2,ay_corrected_mps2,az_corrected_mps2,valid,status"
    );
    let corrected_of = |text: &str| -> Vec<Vec<f64>> {
        text.lines()
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                f[f.len() - 5..f.len() - 2]
                    .iter()
                    .map(|v| v.parse().expect("a number"))
                    .collect()
            })
            .collect()
    };
    assert_eq!(corrected_of(&streamed), corrected_of(&whole));
    assert_eq!(corrected_of(&whole)[1], vec![2.0, 0.25, 9.75]);
    assert_eq!(summary.rows, 2);
}

#[test]
fn a_headerless_stream_needs_its_unit_and_the_file_is_left_as_it_was_on_failure() {
    let dir = tempfile::tempdir().expect("a temporary folder");
    let input = write(dir.path(), "bare.csv", "0,1,0,9.8\n0.01,1,0,9.8\n");
    // Any model but a static calibration takes m/s²: a linear map.
    let model = CorrectorFile::new(CorrectorModel::Linear(Box::new(
        crate::correctors::linear::LinearModel {
            axes: vec![crate::correctors::corrector::Axis::X],
            offset_mps2: vec![0.0],
            matrix: vec![vec![1.0, 0.0, 0.0]],
            training: None,
            uncertainty: None,
        },
    )));
    let previous = write(dir.path(), "out.csv", "earlier output\n");
    let e = correct_to_path(&model, &input, &ReadOptions::default(), None, &previous).expect_err("no unit");
    assert!(matches!(e, CorrectError::UnitUnknown { .. }), "{e}");
    assert!(e.is_usage());
    assert_eq!(
        std::fs::read_to_string(&previous).expect("kept"),
        "earlier output\n"
    );
}

/// A physical model with a covariance: each corrected axis gets its predicted standard deviation
/// (in the file's unit) and the row the flag `predicted_better`; a refused row leaves them empty.
#[test]
fn a_model_with_a_covariance_writes_each_rows_error_bar_and_flag() {
    use crate::correctors::physical::{PhysicalCorrector, SensorModel, SensorUncertainty, SENSOR_PARAMS};
    let mut covariance = [[0.0; SENSOR_PARAMS]; SENSOR_PARAMS];
    // Bias x ± 0.01 m/s², scale z ± 0.001.
    covariance[0][0] = 1e-4;
    covariance[5][5] = 1e-6;
    let physical = PhysicalCorrector {
        sensor: SensorModel {
            bias_mps2: [0.5, 0.0, 0.0],
            ..SensorModel::IDEAL
        },
        gravity_mps2: 9.81,
        input_range_mps2: [[-10.0, 10.0]; 3],
        uncertainty: Some(SensorUncertainty {
            covariance,
            noise_sd_mps2: [0.02; 3],
            session_spread_mps2: None,
        }),
    };
    let model = CorrectorFile::new(CorrectorModel::Physical(Box::new(physical.clone())));
    let dir = tempfile::tempdir().expect("a temporary folder");
    // In g: the sd comes out in g too.
    let input = write(dir.path(), "rec.csv", "t,ax,ay,az\n0,0.1,0,1\n0.01,nan,0,1\n");
    let mut options = ReadOptions::default();
    options.columns.accel_unit = Some(crate::input::recording::AccelUnit::G);
    let (text, _) = corrected(&model, &input, &options);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "t,ax,ay,az,ax_corrected_g,ay_corrected_g,az_corrected_g,ax_corrected_sd_g,ay_corrected_sd_g,az_corrected_sd_g,predicted_better,valid,status"
    );
    let fields: Vec<f64> = lines[1].split(',').take(11).map(|v| v.parse().unwrap()).collect();
    let g = crate::input::recording::STANDARD_GRAVITY;
    let sd = physical.predicted_sd([0.1 * g, 0.0, g]).unwrap();
    for k in 0..3 {
        assert_eq!(fields[7 + k], sd[k] * (1.0 / g), "axis {k}: {}", lines[1]);
    }
    assert!(
        (fields[7] - 0.01 / g).abs() < 1e-12 && (fields[9] - 0.001).abs() < 1e-9,
        "{}",
        lines[1]
    );
    // y is not corrected at all: no correction cannot be predicted to beat none.
    assert_eq!(fields[10], 0.0, "{}", lines[1]);
    assert!(
        lines[2].contains(",,,,,,,0,\"refused") || lines[2].contains(",,,,,,,0,refused"),
        "{}",
        lines[2]
    );
}

/// One rule whatever the input's names: spincal's axis, `corrected`, the unit the values are in.
#[test]
fn corrected_columns_are_named_by_axis_and_unit() {
    use crate::correctors::corrector::Axis;
    let names = super::corrected_column_names(&[Axis::X, Axis::Z], "g", Some("dps"), true);
    assert_eq!(
        names,
        [
            "ax_corrected_g",
            "az_corrected_g",
            "gx_corrected_dps",
            "gy_corrected_dps",
            "gz_corrected_dps",
            "ax_corrected_sd_g",
            "az_corrected_sd_g",
            "predicted_better"
        ]
    );
    assert_eq!(
        super::corrected_column_names(&[Axis::Y], "mps2", None, false),
        ["ay_corrected_mps2"]
    );
}
