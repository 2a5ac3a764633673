//! Temperature checked like every other input (issue 47 item 2), on a simulated thermal campaign
//! (`spincal::simulate::thermal`, a short profile so that each calibration takes about a second):
//! a glitch, an implausible sample, a stuck sensor and kelvin in `calibrate`; a sensor reset in
//! `correct`'s row corrector; a thermal model edited to absurd values refused on read, by the fit's
//! own checks and by both flight-stack exports.

use std::path::Path;

use spincal::campaign::candidate::CandidateKind;
use spincal::campaign::file::Campaign;
use spincal::campaign::params::Params;
use spincal::campaign::run::{calibrate_campaign_file, CampaignRunError};
use spincal::campaign::select::{CampaignCalError, CampaignOutput};
use spincal::correctors::model_file::CorrectorFile;
use spincal::correctors::rows::{RowCorrector, RowOutcome, RowStatus, UnitFactors};
use spincal::input::recording::{Recording, STANDARD_GRAVITY};
use spincal::progress::silent;
use spincal::simulate::thermal::{simulate_thermal_campaign, ThermalCampaign, ThermalProfile};
use spincal::thermal::checks::FindingKind;
use spincal::thermal::flight_stacks::{self, ArduPilotTarget, FlightStackError, Px4Target};
use spincal::thermal::{fit_thermal, ThermalSettings};

/// The default unit, recorded at 10 Hz over 20-minute sessions: the same 15–40 °C warm-up.
fn profile() -> ThermalProfile {
    ThermalProfile {
        sample_rate_hz: 10.0,
        session_s: 1200.0,
        warmup_time_s: 450.0,
        ..ThermalProfile::default()
    }
}

const SEED: u64 = 7;

/// The campaign written as `simulate --thermal` writes it, with `edit` applied to the warm-up
/// file's lines (line 1 is the header) before it is read.
fn written(dir: &Path, edit: impl FnOnce(&mut Vec<String>)) -> (ThermalCampaign, Campaign) {
    let campaign = simulate_thermal_campaign(&profile(), SEED);
    campaign.write_folder(dir, SEED, &profile()).unwrap();
    let warmup = dir.join(&campaign.warmup.recording.source.name);
    let mut lines: Vec<String> = std::fs::read_to_string(&warmup)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    edit(&mut lines);
    std::fs::write(&warmup, lines.join("\n") + "\n").unwrap();
    let file = Campaign::read_path(&dir.join("campaign.toml")).unwrap();
    (campaign, file)
}

/// `line`'s temperature (the last column) replaced by `value`.
fn set_temperature(lines: &mut [String], line: usize, value: &str) {
    let mut fields: Vec<&str> = lines[line - 1].split(',').collect();
    *fields.last_mut().unwrap() = value;
    lines[line - 1] = fields.join(",");
}

/// The default candidates (`calibrate --campaign`'s), or only the physical model where what is
/// saved does not matter (faster).
fn calibrate(file: &Campaign, every_candidate: bool) -> Result<CampaignOutput, CampaignRunError> {
    let params = if every_candidate {
        Params::default()
    } else {
        Params {
            candidates: vec![CandidateKind::Physical],
            ..Params::default()
        }
    };
    calibrate_campaign_file(file, &params, &silent)
}

#[test]
fn a_glitch_and_an_implausible_sample_are_named_and_kept_out_of_the_fit() {
    let dir = tempfile::tempdir().unwrap();
    // One 95 °C sample and one −273 °C sample in the 12,000 of the warm-up.
    let (_, file) = written(dir.path(), |lines| {
        set_temperature(lines, 6001, "95");
        set_temperature(lines, 9001, "-273");
    });
    let out = calibrate(&file, true).unwrap();
    let r = &out.result;
    let thermal = r.thermal.as_ref().expect("a thermal model");
    let [lo, hi] = thermal.fit.model.fitted_range_c;
    assert!(lo > 14.0 && hi < 41.0, "fitted over {lo}–{hi} °C");
    let found: Vec<(FindingKind, usize, f64)> = r
        .temperature_findings
        .iter()
        .map(|f| (f.kind, f.line, f.value_c))
        .collect();
    assert_eq!(
        found,
        vec![
            (FindingKind::Glitch, 6001, 95.0),
            (FindingKind::Implausible, 9001, -273.0)
        ],
        "{:?}",
        r.temperature_findings
    );
    assert_eq!(r.temperature_masked_samples, 2);
    let named = r.temperature_findings[1].to_string();
    assert!(
        named.contains("warmup-00.csv:9001: temperature -273 °C"),
        "{named}"
    );
    // The saved model's range is the one `correct` and the exports use.
    let saved = out
        .saved
        .unwrap_or_else(|| panic!("nothing saved: {}", r.verdict));
    assert_eq!(saved.thermal.unwrap().fitted_range_c, [lo, hi]);
}

#[test]
fn a_stuck_warm_up_is_named_and_used_without_its_temperature() {
    let dir = tempfile::tempdir().unwrap();
    let (_, file) = written(dir.path(), |lines| {
        for line in 2..=lines.len() {
            set_temperature(lines, line, "25");
        }
    });
    let r = calibrate(&file, false).unwrap().result;
    let stuck: Vec<_> = r
        .temperature_findings
        .iter()
        .filter(|f| f.kind == FindingKind::Stuck)
        .collect();
    assert_eq!(stuck.len(), 1, "{:?}", r.temperature_findings);
    assert!(stuck[0].file.ends_with("warmup-00.csv"), "{}", stuck[0].file);
    assert!(stuck[0].to_string().contains("stuck sensor"), "{}", stuck[0]);
    let thermal = r.thermal.expect("the poses still give a thermal model");
    assert_eq!(thermal.without_temperature, vec![stuck[0].file.clone()]);
}

#[test]
fn kelvin_under_a_celsius_name_is_refused_naming_kelvin() {
    let dir = tempfile::tempdir().unwrap();
    let (_, file) = written(dir.path(), |lines| {
        for line in 2..=lines.len() {
            let value: f64 = lines[line - 1].rsplit(',').next().unwrap().parse().unwrap();
            set_temperature(lines, line, &format!("{}", value + 273.15));
        }
    });
    let e = calibrate(&file, false).unwrap_err();
    assert!(
        matches!(
            &e,
            CampaignRunError::Calibration {
                source: CampaignCalError::Temperature(_),
                ..
            }
        ),
        "{e}"
    );
    let message = e.to_string();
    for part in ["warmup-00.csv", "temp_c", "kelvin", "temp_k"] {
        assert!(message.contains(part), "{part} in {message}");
    }
}

fn reading(r: &Recording, i: usize) -> [f64; 3] {
    std::array::from_fn(|k| r.accel_mps2[k][i])
}

#[test]
fn a_sensor_reset_in_correct_marks_its_rows() {
    // The true model as model.json would hold it, and a held-out pose whose temperature steps back
    // 10 °C for a minute (a reset), as a logger streams it.
    let campaign = simulate_thermal_campaign(&profile(), SEED);
    let mut file = CorrectorFile::new(spincal::correctors::model_file::CorrectorModel::Static(Box::new(
        spincal::correctors::static_cal::StaticCalibration::identity(STANDARD_GRAVITY),
    )));
    let mut model = campaign.truth.clone();
    model.smoothing_s = 60.0;
    file.thermal = Some(model);
    let poses: Vec<&Recording> = campaign.held_out[20..30].iter().map(|r| &r.recording).collect();
    let mut rows = RowCorrector::new(&file, UnitFactors::SI, false).unwrap();
    let (mut statuses, mut times) = (Vec::new(), Vec::new());
    for rec in poses {
        for i in 0..rec.len() {
            let t = rec.time_s[i];
            let reported = rec.temperature_c.as_ref().unwrap()[i];
            let reset = (700.0..760.0).contains(&t);
            let temperature = if reset { reported - 10.0 } else { reported };
            match rows.correct(Some(t), reading(rec, i), None, Some(temperature), |_| {
                String::new()
            }) {
                RowOutcome::Corrected { status, valid, .. } => {
                    assert_eq!(valid, status == RowStatus::Ok);
                    statuses.push(status);
                }
                RowOutcome::Refused(why) => panic!("refused: {why}"),
            }
            times.push(t);
        }
    }
    let during: Vec<RowStatus> = times
        .iter()
        .zip(&statuses)
        .filter(|(t, _)| (700.0..760.0).contains(*t))
        .map(|(_, s)| *s)
        .collect();
    assert!(!during.is_empty());
    assert!(
        during.iter().all(|s| *s == RowStatus::SuspectTemperature),
        "{:?}",
        during.iter().find(|s| **s != RowStatus::SuspectTemperature)
    );
    // Before and after (past the estimator's start), the rows are corrected as trained.
    let others = times
        .iter()
        .zip(&statuses)
        .filter(|(t, _)| !(700.0..760.0).contains(*t) && **t > times[0] + 60.0);
    assert!(others.clone().count() > 1000);
    assert!(
        others.clone().all(|(_, s)| *s == RowStatus::Ok),
        "{:?}",
        others.clone().find(|(_, s)| **s != RowStatus::Ok)
    );
}

/// The ArduPilot and PX4 files of `m`.
fn stacks(
    m: &spincal::thermal::ThermalModel,
) -> (
    Result<flight_stacks::StackFile, FlightStackError>,
    Result<flight_stacks::StackFile, FlightStackError>,
) {
    let px4 = Px4Target {
        accel: 0,
        device_id: 1,
        system_id: 1,
        component_id: 1,
    };
    (
        flight_stacks::ardupilot(m, ArduPilotTarget { imu: 1 }),
        flight_stacks::px4(m, px4),
    )
}

#[test]
fn an_absurd_thermal_model_is_refused_on_read_and_by_both_exports() {
    let campaign = simulate_thermal_campaign(&profile(), SEED);
    let mut model = campaign.truth.clone();
    model.smoothing_s = 60.0;
    let (a, p) = stacks(&model);
    a.unwrap();
    p.unwrap();
    // A bias coefficient edited to 1e9 m/s² per °C.
    model.bias_per_c[2][0] = 1e9;
    let mut file = CorrectorFile::new(spincal::correctors::model_file::CorrectorModel::Static(Box::new(
        spincal::correctors::static_cal::StaticCalibration::identity(STANDARD_GRAVITY),
    )));
    file.thermal = Some(model.clone());
    let e = CorrectorFile::from_json(&file.to_json(), "model.json").unwrap_err();
    let message = e.to_string();
    assert!(
        message.contains("model.json") && message.contains("thermal.bias_per_c[2]"),
        "{message}"
    );
    let (a, p) = stacks(&model);
    for e in [a.unwrap_err(), p.unwrap_err()] {
        assert!(matches!(e, FlightStackError::Implausible { .. }), "{e}");
        assert!(
            e.to_string().contains("bias_per_c[2]") && e.to_string().contains("correct refuses"),
            "{e}"
        );
    }
    // A fitted range beyond what a die reaches is refused the same way.
    let mut wide = campaign.truth.clone();
    wide.fitted_range_c = [-89.5, 40.0];
    assert_eq!(wide.check_plausible().unwrap_err().field, "fitted_range_c");
}

#[test]
fn a_grid_that_brackets_the_lag_finds_it() {
    // The sensor lags 20 s. (A lag at the top of its grid is not refused yet: on the default
    // grid 3 of the 20 units of `thermal::thermal_corrector_near_the_oracle_on_held_out_temperatures`
    // fit 80 s and still meet its goal.)
    let campaign = simulate_thermal_campaign(&profile(), SEED);
    let stills: Vec<&Recording> = std::iter::once(&campaign.warmup)
        .chain(&campaign.poses)
        .map(|r| &r.recording)
        .collect();
    let settings = ThermalSettings {
        lags_s: vec![0.0, 10.0, 20.0, 40.0],
        orders: Some([2, 2]),
        ..ThermalSettings::default()
    };
    let fit = fit_thermal(&stills, &settings, STANDARD_GRAVITY).unwrap();
    assert_eq!(fit.model.lag_s, 20.0);
}
