//! The thermal model as ArduPilot's and PX4's parameter files, read back and applied as the
//! stacks do (their formulas written out here from AP_InertialSensor_tempcal.cpp and PX4's
//! TemperatureCompensation.cpp, not taken from the library): they equal spincal's bias change to
//! 1e-6 m/s² across the fitted range and hold its edge value beyond it. An independent numpy
//! readback (bench/thermal/flight_stack_readback.py, in float64 and in the stacks' float32) is
//! recorded in fixtures/flight_stacks/readback.csv (how: fixtures/flight_stacks/README.md).
//!
//! `SPINCAL_BLESS_FLIGHT_STACKS=1` rewrites the fixture's parameter files from the library; the
//! readback must then be rerun.

use std::collections::HashMap;
use std::path::PathBuf;

use spincal::input::recording::STANDARD_GRAVITY;
use spincal::thermal::flight_stacks::{
    self, ArduPilotTarget, FlightStackError, Px4Target, ARDUPILOT_REFERENCE_C,
};
use spincal::thermal::ThermalModel;

const AP: ArduPilotTarget = ArduPilotTarget { imu: 1 };
const PX4: Px4Target = Px4Target {
    accel: 0,
    device_id: 1_310_988,
    system_id: 1,
    component_id: 1,
};

/// A cubic bias change and a linear + quadratic gain change, of the size MEMS parts show.
fn model() -> ThermalModel {
    ThermalModel {
        reference_c: 25.0,
        bias_mps2: [0.05, -0.03, 0.08],
        scale_error: [0.004, -0.002, 0.006],
        misalignment_rad: [0.003, -0.002, 0.004],
        bias_per_c: [
            vec![0.0021, -4.0e-5, 6.0e-7],
            vec![-0.0013, 2.5e-5, -3.0e-7],
            vec![0.0035, 1.0e-5, 9.0e-7],
        ],
        scale_per_c: [vec![1.5e-4, -2.0e-6], vec![-8.0e-5, 3.0e-6], vec![2.0e-4, 1.0e-6]],
        lag_s: 18.0,
        smoothing_s: 60.0,
        fitted_range_c: [5.0, 55.0],
        uncertainty: None,
    }
}

/// The same model without its gain change: what the stacks can hold.
fn bias_only(m: &ThermalModel) -> ThermalModel {
    ThermalModel {
        scale_per_c: [vec![], vec![], vec![]],
        ..m.clone()
    }
}

fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/flight_stacks")
}

/// Mission Planner's and MAVProxy's reading: `#` lines skipped, `NAME,VALUE` (no exponent, which
/// ArduPilot's tools avoid).
fn read_ardupilot(text: &str) -> HashMap<String, f64> {
    let mut out = HashMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let (name, value) = line
            .split_once(',')
            .unwrap_or_else(|| panic!("not NAME,VALUE: {line}"));
        assert!(!value.contains(['e', 'E', ',']), "value {value} in {line}");
        assert!(
            out.insert(name.to_string(), value.parse::<f64>().unwrap())
                .is_none(),
            "twice: {name}"
        );
    }
    out
}

/// QGroundControl's reading: `#` lines skipped, five tab-separated fields.
fn read_px4(text: &str) -> HashMap<String, (f64, u8)> {
    let mut out = HashMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let fields: Vec<&str> = line.split('\t').collect();
        assert_eq!(fields.len(), 5, "{line}");
        assert_eq!(
            (fields[0], fields[1]),
            ("1", "1"),
            "system and component id: {line}"
        );
        let kind: u8 = fields[4].parse().unwrap();
        let value: f64 = fields[3].parse().unwrap();
        if kind == 6 {
            assert_eq!(value.fract(), 0.0, "an integer parameter: {line}");
        }
        out.insert(fields[2].to_string(), (value, kind));
    }
    out
}

/// ArduPilot's TCal::correct_sensor: a − P(clamp(T) − 35) + P(clamp(T_cal) − 35).
fn apply_ardupilot(p: &HashMap<String, f64>, temp_c: f64, cal_temp_c: f64, a: [f64; 3]) -> [f64; 3] {
    let get = |name: &str| p[&format!("INS_TCAL1_{name}")];
    assert_eq!(get("ENABLE"), 1.0);
    let (low, high) = (get("TMIN"), get("TMAX"));
    let axes = ["X", "Y", "Z"];
    std::array::from_fn(|k| {
        let c: Vec<f64> = (1..=3).map(|j| get(&format!("ACC{j}_{}", axes[k]))).collect();
        let poly = |x: f64| (c[0] + (c[1] + c[2] * x) * x) * x * 1e-6;
        a[k] - poly(temp_c.clamp(low, high) - 35.0) + poly(cal_temp_c.clamp(low, high) - 35.0)
    })
}

/// PX4's calc_thermal_offsets_3D then Accelerometer::Correct (CAL_ACC offset 0, scale 1).
fn apply_px4(p: &HashMap<String, (f64, u8)>, temp_c: f64, a: [f64; 3]) -> [f64; 3] {
    let get = |name: &str| p[&format!("TC_A0_{name}")].0;
    assert_eq!(p["TC_A_ENABLE"], (1.0, 6));
    assert_eq!(p["TC_A0_ID"], (PX4.device_id as f64, 6));
    let (low, high, reference) = (get("TMIN"), get("TMAX"), get("TREF"));
    let d = if temp_c > high {
        high - reference
    } else if temp_c < low {
        low - reference
    } else {
        temp_c - reference
    };
    std::array::from_fn(|k| {
        let x: Vec<f64> = (0..4).map(|j| get(&format!("X{j}_{k}"))).collect();
        a[k] - (x[0] + x[1] * d + x[2] * d * d + x[3] * d * d * d)
    })
}

const READINGS: [[f64; 3]; 3] = [[0.0, 0.0, 9.8125], [-9.8125, 0.0, 0.0], [-3.25, 5.125, -7.875]];

fn close(a: [f64; 3], b: [f64; 3], tolerance: f64, what: &str) {
    for k in 0..3 {
        assert!(
            (a[k] - b[k]).abs() <= tolerance,
            "{what}: axis {k}: {} vs {}",
            a[k],
            b[k]
        );
    }
}

#[test]
fn the_stacks_formulas_on_the_exported_parameters_give_spincals_bias_change() {
    let m = model();
    let bias = bias_only(&m);
    let ap = read_ardupilot(&flight_stacks::ardupilot(&m, AP).unwrap().text);
    let px4 = read_px4(&flight_stacks::px4(&m, PX4).unwrap().text);
    let [low, high] = m.fitted_range_c;
    assert_eq!((ap["INS_TCAL1_TMIN"], ap["INS_TCAL1_TMAX"]), (low, high));
    // Whole range, every 0.05 °C: the stacks' correction is to_reference with ρ = 0.
    for i in 0..=1000 {
        let t = low + (high - low) * i as f64 / 1000.0;
        for a in READINGS {
            let want = bias.to_reference(a, t);
            close(
                apply_ardupilot(&ap, t, m.reference_c, a),
                want,
                1e-6,
                &format!("ArduPilot at {t} °C"),
            );
            close(apply_px4(&px4, t, a), want, 1e-6, &format!("PX4 at {t} °C"));
            // ArduPilot refers to its own accel calibration's temperature: spincal's reading there.
            let at_40 = bias.bias_change(40.0);
            let want_40 = std::array::from_fn(|k| want[k] + at_40[k]);
            close(
                apply_ardupilot(&ap, t, 40.0, a),
                want_40,
                1e-6,
                &format!("ArduPilot at {t} °C, cal 40 °C"),
            );
        }
    }
    // Beyond the range both hold the edge's correction where spincal's polynomial would go on.
    for (t, edge) in [(low - 12.0, low), (high + 15.0, high)] {
        let a = READINGS[2];
        let want = bias.to_reference(a, edge);
        close(
            apply_ardupilot(&ap, t, m.reference_c, a),
            want,
            1e-6,
            "ArduPilot beyond the range",
        );
        close(apply_px4(&px4, t, a), want, 1e-6, "PX4 beyond the range");
        let extrapolated = bias.to_reference(a, t);
        assert!(
            (0..3).any(|k| (extrapolated[k] - want[k]).abs() > 1e-3),
            "the clamp must matter for this check at {t} °C"
        );
        // A calibration temperature outside the range (ArduPilot's unset -300) is clamped too.
        let at_low = bias.bias_change(low);
        let want_low: [f64; 3] = std::array::from_fn(|k| want[k] + at_low[k]);
        close(
            apply_ardupilot(&ap, t, -300.0, a),
            want_low,
            1e-6,
            "ArduPilot, CALTEMP unset",
        );
    }
    // The ArduPilot polynomial really is re-centred: its first coefficient is β's slope at 35 °C.
    let slope_35 = (bias.bias_change(ARDUPILOT_REFERENCE_C + 1e-4)[0]
        - bias.bias_change(ARDUPILOT_REFERENCE_C - 1e-4)[0])
        / 2e-4;
    assert!((ap["INS_TCAL1_ACC1_X"] * 1e-6 - slope_35).abs() < 1e-9);
}

#[test]
fn the_files_hold_every_parameter_and_say_what_is_left_out() {
    let m = model();
    let ap = flight_stacks::ardupilot(&m, AP).unwrap();
    let px4 = flight_stacks::px4(&m, PX4).unwrap();
    let ap_params = read_ardupilot(&ap.text);
    assert_eq!(ap_params.len(), 3 + 9 + 9);
    for j in 1..=3 {
        for axis in ["X", "Y", "Z"] {
            assert!(ap_params.contains_key(&format!("INS_TCAL1_ACC{j}_{axis}")));
            assert_eq!(ap_params[&format!("INS_TCAL1_GYR{j}_{axis}")], 0.0);
        }
    }
    let px4_params = read_px4(&px4.text);
    assert_eq!(px4_params.len(), 5 + 12);
    assert_eq!(px4_params["TC_A0_TREF"], (m.reference_c, 9));
    for k in 0..3 {
        assert_eq!(px4_params[&format!("TC_A0_X0_{k}")], (0.0, 9));
        for j in 1..=3 {
            assert_eq!(px4_params[&format!("TC_A0_X{j}_{k}")].0, m.bias_per_c[k][j - 1]);
        }
    }
    // The gain change left out: largest |ρ_k|·g over the range, recomputed here on a finer grid.
    let [low, high] = m.fitted_range_c;
    for k in 0..3 {
        let largest = (0..=20_000)
            .map(|i| low + (high - low) * i as f64 / 20_000.0)
            .map(|t| m.scale_change(t)[k].abs() * STANDARD_GRAVITY)
            .fold(0.0, f64::max);
        let stated = ap.left_out.gain_change_mps2[k];
        assert!(
            (stated - largest).abs() <= 1e-6 * largest,
            "axis {k}: {stated} vs {largest}"
        );
        assert!(largest > 1e-3, "a gain change worth stating");
    }
    for file in [&ap.text, &px4.text] {
        assert!(
            file.starts_with("# spincal "),
            "spincal's mark, so a rerun may replace it"
        );
        let stated = format!("{:.3e}", ap.left_out.gain_change_mps2[0]);
        assert!(file.contains("gain's change") && file.contains(&stated), "{file}");
        assert!(file.contains("lag") && file.contains("no gyro terms"));
    }
}

#[test]
fn a_bias_beyond_the_cubic_is_refused_by_parameter() {
    let mut m = model();
    m.bias_per_c[1] = vec![-0.0013, 2.5e-5, -3.0e-7, 4.0e-9];
    for result in [flight_stacks::ardupilot(&m, AP), flight_stacks::px4(&m, PX4)] {
        let err = result.unwrap_err();
        assert!(
            matches!(
                err,
                FlightStackError::BiasOrder {
                    axis: 1,
                    order: 4,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("thermal.bias_per_c[1][3]"), "{err}");
    }
    // Zeros past the cubic are no term.
    m.bias_per_c[1] = vec![-0.0013, 2.5e-5, -3.0e-7, 0.0];
    assert!(flight_stacks::ardupilot(&m, AP).is_ok());
    // Targets the stacks do not have.
    assert!(flight_stacks::ardupilot(&m, ArduPilotTarget { imu: 4 }).is_err());
    let no_id = Px4Target { device_id: 0, ..PX4 };
    assert!(matches!(
        flight_stacks::px4(&m, no_id),
        Err(FlightStackError::Target { .. })
    ));
}

/// The numpy readback of the fixture's files agrees with spincal: its float64 columns to 1e-6,
/// its float32 columns (the stacks' own arithmetic) to a few float32 roundings of the reading.
#[test]
fn numpy_readback_of_the_exported_files_agrees_with_spincal() {
    let m = model();
    let bias = bias_only(&m);
    let ap = flight_stacks::ardupilot(&m, AP).unwrap();
    let px4 = flight_stacks::px4(&m, PX4).unwrap();
    let dir = fixtures();
    if std::env::var("SPINCAL_BLESS_FLIGHT_STACKS").is_ok_and(|v| v == "1") {
        std::fs::write(dir.join("ardupilot.param"), &ap.text).unwrap();
        std::fs::write(dir.join("px4.params"), &px4.text).unwrap();
    }
    // The readback was made from these files; they must hold what the library writes now.
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    assert_eq!(
        read_ardupilot(&read("ardupilot.param")),
        read_ardupilot(&ap.text),
        "rerun the readback (README.md)"
    );
    assert_eq!(
        read_px4(&read("px4.params")),
        read_px4(&px4.text),
        "rerun the readback (README.md)"
    );

    let [low, high] = m.fitted_range_c;
    let text = read("readback.csv");
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("stack,temp_c,caltemp_c,mx,my,mz,out_x,out_y,out_z,out32_x,out32_y,out32_z")
    );
    let (mut counts, mut outside) = (HashMap::new(), 0);
    for line in lines {
        let (stack, rest) = line.split_once(',').unwrap();
        let v: Vec<f64> = rest.split(',').map(|x| x.parse().unwrap()).collect();
        let (t, cal, a) = (v[0], v[1], [v[2], v[3], v[4]]);
        let clamped = t.clamp(low, high);
        let mut want = bias.to_reference(a, clamped);
        if stack == "ardupilot" {
            let at_cal = bias.bias_change(cal.clamp(low, high));
            want = std::array::from_fn(|k| want[k] + at_cal[k]);
        } else {
            assert_eq!(stack, "px4");
        }
        close(
            [v[5], v[6], v[7]],
            want,
            1e-6,
            &format!("{stack} float64 at {t} °C"),
        );
        for k in 0..3 {
            let bound = 4.0 * f64::from(f32::EPSILON) * (a[k].abs() + 1.0);
            assert!(
                (v[8 + k] - want[k]).abs() <= bound,
                "{stack} float32 at {t} °C axis {k}: {} vs {}",
                v[8 + k],
                want[k]
            );
        }
        *counts.entry(stack.to_string()).or_insert(0) += 1;
        outside += usize::from(t != clamped);
    }
    assert!(
        counts["ardupilot"] >= 3 * 80 * 3 && counts["px4"] >= 80 * 3,
        "{counts:?}"
    );
    assert!(outside > 100, "rows beyond the range: {outside}");
}
