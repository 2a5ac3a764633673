//! The thermal model judged where it was not fitted: still poses in random orientations through a
//! third warm-up, on its coldest and hottest fifths of die temperature, against the oracle (the
//! true thermal model driven by the true die temperature) and the flight stacks' method (a per-axis
//! cubic of bias against the reported temperature, fitted to the warm-up, then a static
//! calibration on the poses it compensated).
//!
//! `cargo test --release -p spincal --test suite thermal -- --nocapture` prints the table for the
//! issue's 20 units (`SPINCAL_THERMAL_UNITS` changes the count).

// The elimination and the compensation index several arrays together.
#![allow(clippy::needless_range_loop)]

use rayon::prelude::*;
use spincal::campaign::candidate::CandidateKind;
use spincal::campaign::params::Params;
use spincal::campaign::prepare::UnitRecording;
use spincal::campaign::select::calibrate_campaign;
use spincal::correctors::model_file::CorrectorFile;
use spincal::correctors::rows::{RowCorrector, RowOutcome, RowStatus, UnitFactors};
use spincal::input::recording::Recording;
use spincal::input::recording::STANDARD_GRAVITY;
use spincal::progress::silent;
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};
use spincal::simulate::thermal::{
    sensor_reports, simulate_thermal_campaign, ThermalCampaign, ThermalProfile, ThermalRecording,
};
use spincal::thermal::{fit_thermal, ThermalError, ThermalFit, ThermalModel, ThermalSettings};

/// RMS over the held-out bands of 1 s means of (corrected − true) force, m/s², and the
/// per-sample RMS (noise in); `correct(j, i)` is sample i of held-out recording j, corrected. A
/// second holding a sample that is not finite (a row `correct` leaves outside the model's
/// temperature range, see `streamed`) is left out.
fn band_error(held_out: &[ThermalRecording], correct: impl Fn(usize, usize) -> [f64; 3]) -> (f64, f64) {
    let mut temps: Vec<f64> = held_out.iter().flat_map(|r| r.die_c.iter().copied()).collect();
    temps.sort_by(f64::total_cmp);
    let cold = temps[temps.len() / 5];
    let hot = temps[temps.len() * 4 / 5];
    let (mut block_sum, mut blocks, mut sample_sum, mut samples) = (0.0, 0usize, 0.0, 0usize);
    for (j, r) in held_out.iter().enumerate() {
        let rate = r.recording.sample_rate_hz().round() as usize;
        for start in (0..r.recording.len()).step_by(rate) {
            let end = (start + rate).min(r.recording.len());
            let mid = r.die_c[(start + end) / 2];
            if end - start < rate || (mid > cold && mid < hot) {
                continue;
            }
            let corrected: Vec<[f64; 3]> = (start..end).map(|i| correct(j, i)).collect();
            if corrected.iter().flatten().any(|v| !v.is_finite()) {
                continue;
            }
            let mut mean = [0.0; 3];
            for f in corrected {
                for k in 0..3 {
                    let e = f[k] - r.true_force_mps2[k];
                    mean[k] += e / (end - start) as f64;
                    sample_sum += e * e;
                }
                samples += 3;
            }
            block_sum += mean.iter().map(|e| e * e).sum::<f64>();
            blocks += 3;
        }
    }
    (
        (block_sum / blocks as f64).sqrt(),
        (sample_sum / samples as f64).sqrt(),
    )
}

fn reading(r: &Recording, i: usize) -> [f64; 3] {
    std::array::from_fn(|k| r.accel_mps2[k][i])
}

/// spincal's corrector: the thermal fit on the warm-up and the poses, applied with its own die
/// temperature estimate.
fn spincal_fit(campaign: &ThermalCampaign) -> ThermalModel {
    let stills: Vec<&Recording> = std::iter::once(&campaign.warmup)
        .chain(&campaign.poses)
        .map(|r| &r.recording)
        .collect();
    fit_thermal(&stills, &ThermalSettings::default(), STANDARD_GRAVITY)
        .expect("thermal fit")
        .model
}

fn applied(model: &ThermalModel, held_out: &[ThermalRecording]) -> Vec<Vec<[f64; 3]>> {
    let recordings: Vec<&Recording> = held_out.iter().map(|r| &r.recording).collect();
    let dies = model.die_temperatures(&recordings);
    held_out
        .iter()
        .zip(dies)
        .map(|(r, die)| {
            let (rec, die) = (&r.recording, die.unwrap());
            (0..rec.len())
                .map(|i| model.correct(reading(rec, i), die[i]))
                .collect()
        })
        .collect()
}

/// Least-squares polynomial of `order` in (x − x0): coefficients from the constant term up.
fn polyfit(x: &[f64], y: &[f64], x0: f64, order: usize) -> Vec<f64> {
    let n = order + 1;
    let mut a = vec![vec![0.0; n + 1]; n];
    for (&xi, &yi) in x.iter().zip(y) {
        let powers: Vec<f64> = (0..n).map(|j| (xi - x0).powi(j as i32)).collect();
        for r in 0..n {
            for c in 0..n {
                a[r][c] += powers[r] * powers[c];
            }
            a[r][n] += powers[r] * yi;
        }
    }
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&p, &q| a[p][col].abs().total_cmp(&a[q][col].abs()))
            .unwrap();
        a.swap(col, pivot);
        for r in 0..n {
            if r != col {
                let factor = a[r][col] / a[col][col];
                for c in col..=n {
                    a[r][c] -= factor * a[col][c];
                }
            }
        }
    }
    (0..n).map(|r| a[r][n] / a[r][r]).collect()
}

/// The flight stacks' method: per axis, a cubic of the warm-up's 2 s means against the reported
/// temperature, removed relative to the reference temperature; then a static calibration (bias,
/// scale, misalignment) of the compensated poses.
fn flight_stack(campaign: &ThermalCampaign, reference_c: f64) -> impl Fn(&Recording, usize) -> [f64; 3] {
    let w = &campaign.warmup.recording;
    let reported = w.temperature_c.as_ref().unwrap();
    let per = (2.0 * w.sample_rate_hz()).round() as usize;
    let mean = |v: &[f64], s: usize| v[s..s + per].iter().sum::<f64>() / per as f64;
    let starts: Vec<usize> = (0..w.len() - per).step_by(per).collect();
    let temps: Vec<f64> = starts.iter().map(|&s| mean(reported, s)).collect();
    let cubic: [Vec<f64>; 3] = std::array::from_fn(|k| {
        let y: Vec<f64> = starts.iter().map(|&s| mean(&w.accel_mps2[k], s)).collect();
        polyfit(&temps, &y, reference_c, 3)
    });
    let change = move |k: usize, t: f64| -> f64 {
        (1..4)
            .map(|j| cubic[k][j] * (t - reference_c).powi(j as i32))
            .sum()
    };
    let compensate = |r: &Recording| -> Recording {
        let mut out = r.clone();
        let reported = r.temperature_c.as_ref().unwrap();
        for k in 0..3 {
            for i in 0..r.len() {
                out.accel_mps2[k][i] -= change(k, reported[i]);
            }
        }
        out
    };
    let poses: Vec<Recording> = campaign.poses.iter().map(|p| compensate(&p.recording)).collect();
    let static_only = ThermalSettings {
        max_bias_order: 0,
        max_scale_order: 0,
        ..ThermalSettings::default()
    };
    let refs: Vec<&Recording> = poses.iter().collect();
    let model = fit_thermal(&refs, &static_only, STANDARD_GRAVITY)
        .expect("static fit")
        .model;
    move |r: &Recording, i: usize| {
        let t = r.temperature_c.as_ref().unwrap()[i];
        let m: [f64; 3] = std::array::from_fn(|k| r.accel_mps2[k][i] - change(k, t));
        model.correct(m, model.reference_c)
    }
}

/// The same campaign with the true die temperature logged instead of the sensor's report.
fn with_die_logged(campaign: &ThermalCampaign) -> ThermalCampaign {
    let mut out = campaign.clone();
    for r in std::iter::once(&mut out.warmup)
        .chain(&mut out.poses)
        .chain(&mut out.held_out)
    {
        r.recording.temperature_c = Some(r.die_c.clone());
    }
    out
}

/// A unit's (oracle, spincal, flight stacks, die logged) errors and its (fitted, true) lag.
type UnitErrors = ([(f64, f64); 4], [f64; 2]);

#[test]
fn thermal_corrector_near_the_oracle_on_held_out_temperatures() {
    let units: u64 = std::env::var("SPINCAL_THERMAL_UNITS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20);
    let profile = ThermalProfile::default();
    println!("simulated ranges (SD): {profile:?}");
    println!(
        "unit  oracle   spincal  flight-stacks  spincal/oracle  excess ratio  die-logged  (1 s means, m/s²)"
    );
    // [1 s means, per sample] × [spincal/oracle, excess ratio, stepped over die-logged].
    let mut worst = [[0.0f64; 3]; 2];
    // Each unit's (oracle, spincal, flight stacks, die logged) errors and (fitted, true) lag,
    // units in parallel.
    let errors: Vec<UnitErrors> = (0..units)
        .into_par_iter()
        .map(|seed| {
            let campaign = simulate_thermal_campaign(&profile, 1000 + seed);
            let truth = &campaign.truth;
            let held_out = &campaign.held_out;
            let oracle = band_error(held_out, |j, i| {
                truth.correct(reading(&held_out[j].recording, i), held_out[j].die_c[i])
            });
            let model = spincal_fit(&campaign);
            let ours_values = applied(&model, &campaign.held_out);
            let ours = band_error(held_out, |j, i| ours_values[j][i]);
            let peer_correct = flight_stack(&campaign, model.reference_c);
            let peer = band_error(held_out, |j, i| peer_correct(&held_out[j].recording, i));
            let logged = with_die_logged(&campaign);
            let logged_model = spincal_fit(&logged);
            let logged_values = applied(&logged_model, &logged.held_out);
            let die_logged = band_error(&logged.held_out, |j, i| logged_values[j][i]);
            ([oracle, ours, peer, die_logged], [model.lag_s, truth.lag_s])
        })
        .collect();
    for (seed, &([oracle, ours, peer, die_logged], [lag, true_lag])) in errors.iter().enumerate() {
        println!("{seed:>4}  lag {lag:.0} s (true {true_lag:.1} s)");
        // Per sample (noise in), as the campaign's held-out figures; and of 1 s means, where the
        // white noise shrinks to a seventh and what is left is mostly the model's error.
        for (metric, pick) in [("per sample", 1usize), ("1 s means", 0)] {
            let e = |x: (f64, f64)| if pick == 1 { x.1 } else { x.0 };
            let excess = |x: f64| (x * x - e(oracle).powi(2)).max(0.0).sqrt();
            let ratio = e(ours) / e(oracle);
            let excess_ratio = excess(e(ours)) / excess(e(peer));
            let logged_ratio = e(ours) / e(die_logged);
            println!(
                "{seed:>4}  {:.5}  {:.5}  {:.5}        {ratio:.3}           {excess_ratio:.3}         {logged_ratio:.3}   ({metric})",
                e(oracle), e(ours), e(peer)
            );
            worst[pick][0] = worst[pick][0].max(ratio);
            worst[pick][1] = worst[pick][1].max(excess_ratio);
            worst[pick][2] = worst[pick][2].max(logged_ratio);
        }
    }
    for (metric, w) in [("1 s means", worst[0]), ("per sample", worst[1])] {
        println!(
            "worst, {metric}: spincal/oracle {:.3}, excess over the flight stacks' {:.3}, stepped-and-lagging over die-logged {:.3}",
            w[0], w[1], w[2]
        );
    }
    let [means, samples] = worst;
    // The goals, on the stricter 1 s means: within 1.25× the oracle; an excess over the
    // oracle at most half the flight stacks'. With the temperature in whole degrees through a 20 s
    // lag, within 5 % of the same campaign with the die temperature logged, per sample; of 1 s
    // means the worst of 20 units measured 6.9 %, so 10 % bounds that here.
    assert!(
        means[0] <= 1.25 && samples[0] <= 1.25,
        "spincal/oracle {} {}",
        means[0],
        samples[0]
    );
    assert!(
        means[1] <= 0.5 && samples[1] <= 0.5,
        "excess ratio {} {}",
        means[1],
        samples[1]
    );
    assert!(
        samples[2] <= 1.05 && means[2] <= 1.10,
        "stepped and lagging over die logged {} {}",
        samples[2],
        means[2]
    );
}

/// The thermal coefficients come back within their reported standard errors: at the simulated
/// orders and reference temperature, over 20 units with the die temperature logged, the 95 %
/// intervals of β₁, β₂, ρ₁ and ρ₂ on every axis hold the truth about 95 % of the time. The errors
/// hold the temperature as known: from a lagging sensor in whole degrees the same intervals hold
/// the truth about 79 % of the time (printed here, and stated in `ThermalFit`).
#[test]
fn thermal_coefficients_recovered_within_their_standard_errors() {
    let profile = ThermalProfile::default();
    let coverage = |die_logged: bool| {
        let z: Vec<f64> = (0..20u64)
            .into_par_iter()
            .flat_map_iter(|seed| {
                let simulated = simulate_thermal_campaign(&profile, 5000 + seed);
                let campaign = if die_logged {
                    with_die_logged(&simulated)
                } else {
                    simulated
                };
                let truth = campaign.truth.clone();
                let stills: Vec<&Recording> = std::iter::once(&campaign.warmup)
                    .chain(&campaign.poses)
                    .map(|r| &r.recording)
                    .collect();
                let settings = ThermalSettings {
                    orders: Some([2, 2]),
                    lags_s: vec![if die_logged { 0.0 } else { profile.sensor_lag_s }],
                    reference_c: Some(truth.reference_c),
                    ..ThermalSettings::default()
                };
                let fit = fit_thermal(&stills, &settings, STANDARD_GRAVITY).expect("thermal fit");
                let mut z = Vec::new();
                for k in 0..3 {
                    for j in 0..2 {
                        z.push(
                            (fit.model.bias_per_c[k][j] - truth.bias_per_c[k][j]) / fit.bias_per_c_se[k][j],
                        );
                        z.push(
                            (fit.model.scale_per_c[k][j] - truth.scale_per_c[k][j])
                                / fit.scale_per_c_se[k][j],
                        );
                    }
                }
                z
            })
            .collect();
        let covered = z.iter().filter(|z| z.abs() < 1.96).count() as f64 / z.len() as f64;
        let rms = (z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64).sqrt();
        println!(
            "die temperature {}: {} coefficients, 95 % intervals cover {covered:.3}, RMS z {rms:.2}",
            if die_logged {
                "logged"
            } else {
                "estimated (20 s lag, 1 °C steps)"
            },
            z.len()
        );
        covered
    };
    let logged = coverage(true);
    let estimated = coverage(false);
    // 240 draws: a binomial 95 % has SD 1.4 %, so [0.91, 0.99] fails a calibrated model rarely.
    assert!(
        (0.91..=0.99).contains(&logged),
        "coverage with the die temperature logged {logged}"
    );
    assert!(
        estimated < logged,
        "the temperature's estimate adds error the intervals leave out"
    );
}

/// A campaign of still recordings (the warm-up and the posed session) as the unit's recordings:
/// what `spincal calibrate --campaign` reads, with or without their temperature; with `truth`, also
/// the constant true force and the noise (the reading less the true model at the true die
/// temperature) that the campaign's truth check needs.
fn campaign_units(campaign: &ThermalCampaign, temperature: bool, truth: bool) -> Vec<UnitRecording> {
    let model = &campaign.truth;
    std::iter::once(&campaign.warmup)
        .chain(&campaign.poses)
        .enumerate()
        .map(|(i, r)| {
            let mut recording = r.recording.clone();
            if !temperature {
                recording.temperature_c = None;
            }
            let n = recording.len();
            let noise: Option<[Vec<f64>; 3]> = truth.then(|| {
                std::array::from_fn(|a| {
                    (0..n)
                        .map(|s| recording.accel_mps2[a][s] - model.reading(r.true_force_mps2, r.die_c[s])[a])
                        .collect()
                })
            });
            UnitRecording {
                name: format!("still-{i:02}.csv"),
                recording: recording.clone(),
                turntable: None,
                truth: truth.then(|| std::array::from_fn(|a| vec![r.true_force_mps2[a]; n])),
                floor_mps2: noise.as_ref().map(rms_per_axis),
                random_mps2: noise,
                session: None,
            }
        })
        .collect()
}

/// RMS of each axis.
fn rms_per_axis(values: &[Vec<f64>; 3]) -> [f64; 3] {
    values
        .each_ref()
        .map(|e| (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt())
}

/// `correct`'s row corrector for readings already in SI units (s, m/s², no gyro).
fn si_rows(file: &CorrectorFile) -> RowCorrector<'_> {
    let units = UnitFactors {
        time_to_s: 1.0,
        accel_to_mps2: 1.0,
        gyro_to_radps: 1.0,
    };
    RowCorrector::new(file, units, false).expect("no gyro")
}

/// Row `i` of `recording` through `rows`, with its reported temperature.
fn correct_row(rows: &mut RowCorrector<'_>, recording: &Recording, i: usize) -> RowOutcome {
    let temperature = recording.temperature_c.as_ref().map(|t| t[i]);
    rows.correct(
        Some(recording.time_s[i]),
        reading(recording, i),
        None,
        temperature,
        |_| String::new(),
    )
}

/// The mean predicted standard deviation per axis of the first fifth of the rows of `recording`
/// (its coldest, furthest from T_ref) that the thermal model corrects, streamed as `correct`
/// streams them.
fn mean_predicted_sd(file: &CorrectorFile, recording: &Recording) -> [f64; 3] {
    let mut rows = si_rows(file);
    let (mut sum, mut n) = ([0.0; 3], 0usize);
    for i in 0..recording.len() / 5 {
        if let RowOutcome::Corrected {
            status: RowStatus::Ok,
            predicted: Some(predicted),
            ..
        } = correct_row(&mut rows, recording, i)
        {
            (0..3).for_each(|k| sum[k] += predicted.sd_mps2[k]);
            n += 1;
        }
    }
    assert!(n > 0, "no row with a predicted error");
    sum.map(|v| v / n as f64)
}

/// The held-out session streamed through `spincal correct`'s row corrector in time order, as one
/// logger file (the causal die estimate runs across its poses), and the share of its rows outside
/// the model's temperature range: `correct` leaves those without the thermal correction and marks
/// them, and here they are NaN, to be judged apart (the goal is at temperatures between those
/// recorded).
fn streamed(file: &CorrectorFile, held_out: &[ThermalRecording]) -> (Vec<Vec<[f64; 3]>>, f64) {
    let mut rows = si_rows(file);
    let mut outside = 0usize;
    let out = held_out
        .iter()
        .map(|r| {
            let rec = &r.recording;
            (0..rec.len())
                .map(|i| match correct_row(&mut rows, rec, i) {
                    RowOutcome::Corrected {
                        status: RowStatus::OutsideTemperatureRange,
                        ..
                    } => {
                        outside += 1;
                        [f64::NAN; 3]
                    }
                    RowOutcome::Corrected { accel_mps2, .. } => accel_mps2,
                    RowOutcome::Refused(why) => panic!("row {i} refused: {why}"),
                })
                .collect()
        })
        .collect();
    let rows: usize = held_out.iter().map(|r| r.recording.len()).sum();
    (out, outside as f64 / rows as f64)
}

/// The campaign path end to end: still recordings with a logged temperature (whole degrees,
/// 20 s lag) give a thermal model in model.json with its fitted range, the campaign holds out
/// its coldest and hottest poses, and `correct`'s row corrector (causal die estimate) brings the
/// held-out session's coldest and hottest fifths near the oracle, far below the same campaign
/// calibrated without the temperature (its saved model, or the readings when it saves none).
#[test]
fn a_campaign_with_temperature_saves_a_thermal_model_that_holds_when_streamed() {
    let profile = ThermalProfile::default();
    let params = Params {
        candidates: vec![CandidateKind::Physical, CandidateKind::PhysicalLinear],
        ..Params::default()
    };
    let rows: Vec<[(f64, f64); 3]> = (0..5u64)
        .into_par_iter()
        .map(|seed| {
            let campaign = simulate_thermal_campaign(&profile, 3000 + seed);
            let (truth, held_out) = (&campaign.truth, &campaign.held_out);
            let oracle = band_error(held_out, |j, i| {
                truth.correct(reading(&held_out[j].recording, i), held_out[j].die_c[i])
            });
            let calibrated =
                calibrate_campaign("unit", &campaign_units(&campaign, true, false), &params, &silent)
                    .expect("campaign with temperature");
            let result = &calibrated.result;
            let thermal = result.thermal.as_ref().expect("a thermal model fitted");
            assert!(thermal.without_temperature.is_empty());
            let labels: Vec<&str> = result.conditions.iter().map(|c| c.label.as_str()).collect();
            assert!(
                labels.iter().any(|l| l.starts_with("coldest"))
                    && labels.iter().any(|l| l.starts_with("hottest")),
                "temperature bands held out: {labels:?}"
            );
            let file = calibrated
                .saved
                .as_ref()
                .unwrap_or_else(|| panic!("nothing saved: {}", result.verdict));
            let model = file
                .thermal
                .as_ref()
                .expect("model.json carries the thermal model");
            let [lo, hi] = model.fitted_range_c;
            assert!(hi - lo > 20.0, "fitted over {lo}–{hi} °C of a 25 °C warm-up");
            // The thermal coefficients' error carried into the rows' error bars: one direction
            // per coefficient kept and per left-out term the windows saw, and wider bars on the
            // held-out session (it starts cold, far from T_ref) than the same file without them.
            let uncertainty = model.uncertainty.as_ref().expect("model.json carries the thermal uncertainty");
            let kept: usize = thermal.fit.terms.bias_orders.iter().chain(&thermal.fit.terms.scale_orders).sum();
            assert_eq!(uncertainty.directions.len(), kept + thermal.fit.left_out_moves.len(), "seed {seed}");
            let mut without = file.clone();
            without.thermal.as_mut().unwrap().uncertainty = None;
            let (wide, narrow) = (
                mean_predicted_sd(file, &held_out[0].recording),
                mean_predicted_sd(&without, &held_out[0].recording),
            );
            assert!(
                (0..3).all(|k| wide[k] >= narrow[k]) && (0..3).any(|k| wide[k] > 1.05 * narrow[k]),
                "seed {seed}: row sd with the thermal part's uncertainty {wide:?}, without {narrow:?}"
            );
            assert!(
                result.verdict.contains("°C"),
                "the verdict states the range: {}",
                result.verdict
            );
            println!(
                "seed {seed}: thermal {} sessions, spread {:.2e} m/s² (LR {:.1}), orders β {:?} ρ {:?}, lag {} s",
                thermal.fit.sessions.count,
                thermal.fit.sessions.spread_sd_mps2,
                thermal.fit.sessions.likelihood_ratio,
                thermal.fit.terms.bias_orders,
                thermal.fit.terms.scale_orders,
                model.lag_s
            );
            let (ours_values, outside) = streamed(file, held_out);
            println!("seed {seed}: {:.2} % of the held-out rows outside the fitted range {:?}", 100.0 * outside, model.fitted_range_c);
            // The held-out session starts as cold as the calibration's: its first seconds may lie
            // below the range the die estimate gives (with a 20 s lag, 2.4 % of the rows, measured).
            assert!(outside <= 0.05, "seed {seed}: {outside} of the rows outside the range");
            let ours = band_error(held_out, |j, i| ours_values[j][i]);
            let plain =
                calibrate_campaign("unit", &campaign_units(&campaign, false, false), &params, &silent)
                    .expect("campaign without temperature");
            assert!(plain.result.thermal.is_none());
            // Without the temperature the verdict may save nothing: the user then has the readings.
            let without = match &plain.saved {
                Some(plain_file) => {
                    let (values, _) = streamed(plain_file, held_out);
                    band_error(held_out, |j, i| values[j][i])
                }
                None => band_error(held_out, |j, i| reading(&held_out[j].recording, i)),
            };
            [oracle, ours, without]
        })
        .collect();
    println!("seed  oracle   campaign+thermal  campaign without temperature  (1 s means; per sample)");
    let mut worst = [0.0f64; 2];
    for (seed, [oracle, ours, without]) in rows.iter().enumerate() {
        println!(
            "{seed:>4}  {:.5}  {:.5}           {:.5}          ({:.5} {:.5} {:.5} per sample)",
            oracle.0, ours.0, without.0, oracle.1, ours.1, without.1
        );
        worst[0] = worst[0].max(ours.0 / oracle.0);
        worst[1] = worst[1].max(ours.1 / oracle.1);
        assert!(
            without.0 > 2.0 * ours.0,
            "seed {seed}: temperature ignored {:.5} against {:.5}",
            without.0,
            ours.0
        );
    }
    println!(
        "worst campaign+thermal / oracle: {:.3} (1 s means), {:.3} (per sample)",
        worst[0], worst[1]
    );
    assert!(
        worst[0] <= 1.25 && worst[1] <= 1.25,
        "campaign+thermal / oracle {worst:?}"
    );
}

/// The thermal unit on the turntable: the default campaign's four runs (two speeds, two radii,
/// three mountings) with their true specific force read through the unit's true thermal model at
/// a different temperature each (a slow 2 °C drift over the run), the temperature logged as the
/// simulated sensor reports it (20 s lag, whole degrees), white noise as the still recordings.
/// Each run on its own clock, far from the still sessions'.
fn thermal_runs(campaign: &ThermalCampaign, profile: &ThermalProfile, seed: u64) -> Vec<UnitRecording> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let mut setup = CampaignSetup::default();
    setup.gyro.recorded = false;
    let sim = simulate_campaign(&setup, seed).expect("the default campaign");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let truth = &campaign.truth;
    sim.recordings
        .iter()
        .filter(|r| r.turntable.is_some())
        .zip([19.0, 26.0, 32.0, 37.0])
        .enumerate()
        .map(|(k, (r, start_c))| {
            let start_s = 10_000.0 * (k + 1) as f64;
            let time_s: Vec<f64> = r
                .recording
                .time_s
                .iter()
                .map(|t| t - r.recording.time_s[0] + start_s)
                .collect();
            let die: Vec<f64> = time_s
                .iter()
                .map(|t| start_c + 2.0 * (t - start_s) / 60.0)
                .collect();
            let dt = time_s[1] - time_s[0];
            let reported = sensor_reports(&die, dt, profile.sensor_lag_s, profile.resolution_c);
            let mut accel: [Vec<f64>; 3] = Default::default();
            let mut noise: [Vec<f64>; 3] = Default::default();
            for i in 0..time_s.len() {
                let f = std::array::from_fn(|a| r.true_accel_mps2[a][i]);
                let m = truth.reading(f, die[i]);
                for a in 0..3 {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    let e = profile.noise_mps2 * z;
                    accel[a].push(m[a] + e);
                    noise[a].push(e);
                }
            }
            let floor = rms_per_axis(&noise);
            UnitRecording {
                name: format!("{}.csv", r.name),
                recording: Recording {
                    time_s,
                    accel_mps2: accel,
                    gyro_radps: None,
                    temperature_c: Some(reported),
                    source: r.recording.source.clone(),
                },
                turntable: r.turntable.clone(),
                truth: Some(r.true_accel_mps2.clone()),
                floor_mps2: Some(floor),
                random_mps2: Some(noise),
                session: None,
            }
        })
        .collect()
}

/// A full thermal campaign (a still warm-up, 60 poses through a second warm-up, four turntable
/// runs at 19–39 °C) calibrated, and the saved corrector's RMS error against the true specific
/// force on each held-out condition and axis over the oracle's: the true thermal model at the true
/// die temperature leaves exactly the white noise, so the floor the campaign computes is the
/// oracle's error. Per seed: the saved kind, the ratios (3 per condition) and the conditions.
fn full_thermal_campaign(profile: &ThermalProfile) -> Vec<(u64, String, Vec<f64>, Vec<String>)> {
    (0..3u64)
        .into_par_iter()
        .map(|seed| {
            let campaign = simulate_thermal_campaign(profile, 4000 + seed);
            let mut units = campaign_units(&campaign, true, true);
            units.extend(thermal_runs(&campaign, profile, 4000 + seed));
            let out =
                calibrate_campaign("unit", &units, &Params::default(), &silent).expect("thermal campaign");
            let thermal = out.result.thermal.as_ref().expect("a thermal model");
            assert!(thermal.without_temperature.is_empty());
            println!(
                "seed {seed}: thermal lag {} s, orders β {:?} ρ {:?}, {} sessions, spread {:.2e} m/s² (LR {:.1}), range {:?}",
                thermal.fit.model.lag_s,
                thermal.fit.terms.bias_orders,
                thermal.fit.terms.scale_orders,
                thermal.fit.sessions.count,
                thermal.fit.sessions.spread_sd_mps2,
                thermal.fit.sessions.likelihood_ratio,
                thermal.fit.model.fitted_range_c
            );
            let saved = out
                .result
                .saved
                .clone()
                .unwrap_or_else(|| panic!("seed {seed}: nothing saved: {}", out.result.verdict));
            let mut ratios = Vec::new();
            let mut labels = Vec::new();
            for h in out.result.held_out.iter().filter(|h| h.candidate == saved) {
                let truth = h.truth.as_ref().expect("truth on every condition");
                let floor = h.floor_mps2.expect("a floor");
                ratios.extend((0..3).map(|k| truth.rms_mps2[k] / floor[k]));
                labels.push(h.condition.clone());
            }
            assert!(labels.iter().any(|l| l.starts_with("speed")), "{labels:?}");
            assert!(labels.iter().any(|l| l.starts_with("hottest")), "{labels:?}");
            (seed, saved, ratios, labels)
        })
        .collect()
}

/// (mean, worst) of the ratios, printed with what was saved.
fn summary(what: &str, seed: u64, saved: &str, ratios: &[f64], conditions: usize) -> (f64, f64) {
    let worst = ratios.iter().copied().fold(0.0, f64::max);
    let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
    let over = ratios.iter().filter(|&&r| r > 1.25).count();
    println!(
        "{what}, seed {seed}: saved {saved}; held-out RMS / oracle over {conditions} conditions × 3 axes: mean {mean:.3}, worst {worst:.3}, {over} above 1.25"
    );
    (mean, worst)
}

/// The campaign issue's held-out goal in a world with thermal drift and a logged temperature:
/// within 1.25× the oracle on every held-out condition and axis, with the temperature as most IMUs
/// report it (finely resolved, here lagging the die by 20 s). With the temperature in whole
/// degrees, a one-minute run at a nearly constant temperature knows its die temperature only to
/// ±0.5 °C, which a bias slope of a few mg/°C turns into an error no corrector can remove: there
/// the ratios are held to what was measured.
#[test]
fn a_full_thermal_campaign_comes_near_the_oracle_on_every_held_out_condition() {
    let fine = ThermalProfile {
        resolution_c: 0.0,
        ..ThermalProfile::default()
    };
    for (seed, saved, ratios, labels) in full_thermal_campaign(&fine) {
        let (_, worst) = summary("finely resolved temperature", seed, &saved, &ratios, labels.len());
        assert!(worst <= 1.25, "seed {seed}: {worst}");
    }
    for (seed, saved, ratios, labels) in full_thermal_campaign(&ThermalProfile::default()) {
        let (mean, worst) = summary("1 °C steps", seed, &saved, &ratios, labels.len());
        // Measured (3 seeds): mean 1.06–1.12, worst 1.25–1.32, one of 39 figures above 1.25 in
        // each, always a turntable condition.
        assert!(
            mean <= 1.15 && worst <= 1.35,
            "seed {seed}: mean {mean}, worst {worst}"
        );
    }
}

/// A lag best at the top of the grid is not determined there: the grid is extended, doubling its
/// top, up to `MAX_LAG_S`. A sensor lagging its die by 150 s (the default grid stops at 80 s, which
/// fits best there): the grid is extended to 160 s, and 80 s, no longer at the top, is kept (the
/// residual is shallow in the lag: 2.0597e-3 against 2.0781e-3 m/s² at 160 s when measured). A grid
/// whose best (here only) lag lies at or beyond `MAX_LAG_S` is refused naming the lag and what to
/// record. (A sensor lagging 1200 s behaves as the 150 s one on these recordings: 80 s best after
/// the extension; the lag rule cannot see a lag the recordings do not show.)
#[test]
fn thermal_lag_at_the_grid_top_extends_the_grid_then_is_refused() {
    let fit = |lag_s: f64, settings: &ThermalSettings| {
        let profile = ThermalProfile {
            sensor_lag_s: lag_s,
            ..ThermalProfile::default()
        };
        let campaign = simulate_thermal_campaign(&profile, 7000);
        let stills: Vec<&Recording> = std::iter::once(&campaign.warmup)
            .chain(&campaign.poses)
            .map(|r| &r.recording)
            .collect();
        fit_thermal(&stills, settings, STANDARD_GRAVITY)
    };
    let default = ThermalSettings::default();
    let slow = fit(150.0, &default).expect("a 150 s lag is within the extended grid");
    println!(
        "150 s lag: fitted {} s; scores {:?}",
        slow.model.lag_s, slow.lag_scores
    );
    let tried: Vec<f64> = slow.lag_scores.iter().map(|s| s.0).collect();
    assert!(tried.contains(&160.0), "the grid was not extended: {tried:?}");
    assert!(
        slow.model.lag_s >= 80.0 && slow.model.lag_s < *tried.last().unwrap(),
        "{tried:?}"
    );
    let beyond = ThermalSettings {
        lags_s: vec![400.0],
        ..default.clone()
    };
    let e = fit(20.0, &beyond).expect_err("a lag at the grid's top beyond MAX_LAG_S is refused");
    println!("{e}");
    assert!(
        matches!(e, ThermalError::LagAtEdge { lag_s, max_lag_s } if lag_s == 400.0 && max_lag_s == spincal::thermal::MAX_LAG_S),
        "{e}"
    );
    assert!(
        e.to_string().contains("record a longer warm-up or cool-down"),
        "{e}"
    );
}

/// A thermal unit written from first principles here (not `spincal::simulate`): reading
/// m = b + δ_session + β(ΔT) + (1 + s)(1 + ρ(ΔT)) f, ΔT = T − 25 °C, with a warm-up in one
/// orientation then `poses` still poses at random orientations through a second warm-up, the
/// temperature reported exactly, white noise 0.02 m/s² at 50 Hz. `beta[k]` and `rho[k]` are the
/// coefficients of ΔT¹, ΔT², …; `offsets[s]` is power-on session s's bias offset: the warm-up is
/// session 0, the poses split in time order among the others; `quadratic[k]` is q of
/// m_k = w_k + q_k·w_k² on the gained reading w (1/(m/s²)). Returns the still recordings and each
/// one's session.
fn first_principles_unit(
    seed: u64,
    beta: [&[f64]; 3],
    rho: [&[f64]; 3],
    offsets: &[[f64; 3]],
    poses: usize,
    quadratic: [f64; 3],
) -> (Vec<Recording>, Vec<usize>) {
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, StandardNormal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let (rate, noise, g) = (50.0, 0.02, STANDARD_GRAVITY);
    let bias = [0.05, -0.08, 0.12];
    let scale = [0.004, -0.003, 0.005];
    let warm = |t: f64| 15.0 + 25.0 * (1.0 - (-t / 600.0).exp());
    let record = |t0: f64, seconds: f64, u: [f64; 3], offset: [f64; 3], rng: &mut rand_chacha::ChaCha8Rng| {
        let n = (seconds * rate) as usize;
        let time_s: Vec<f64> = (0..n).map(|i| t0 + i as f64 / rate).collect();
        let temperature: Vec<f64> = time_s.iter().map(|&t| warm(t % 3000.0)).collect();
        let accel: [Vec<f64>; 3] = std::array::from_fn(|k| {
            temperature
                .iter()
                .map(|&temp| {
                    let dt = temp - 25.0;
                    let z: f64 = StandardNormal.sample(rng);
                    let w = (1.0 + scale[k]) * (1.0 + polynomial_change(rho[k], dt)) * g * u[k];
                    bias[k]
                        + offset[k]
                        + polynomial_change(beta[k], dt)
                        + w
                        + quadratic[k] * w * w
                        + noise * z
                })
                .collect()
        });
        Recording {
            time_s,
            accel_mps2: accel,
            gyro_radps: None,
            temperature_c: Some(temperature),
            source: Default::default(),
        }
    };
    let mut recordings = vec![record(0.0, 1200.0, [0.6, 0.48, 0.64], offsets[0], &mut rng)];
    let mut sessions = vec![0];
    for i in 0..poses {
        let mut u: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(&mut rng));
        let norm = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        u = u.map(|x| x / norm);
        // Poses in time order through the sessions: a session's poses share a stretch of
        // temperature, as when the cold poses are recorded one day and the hot ones another.
        let session = if offsets.len() > 1 {
            1 + i * (offsets.len() - 1) / poses
        } else {
            0
        };
        let start = 3000.0 + 2400.0 * i as f64 / poses as f64 + rng.gen_range(0.0..5.0);
        recordings.push(record(start, 20.0, u, offsets[session], &mut rng));
        sessions.push(session);
    }
    (recordings, sessions)
}

/// β₁ of the terms-rule unit per axis, m/s²/°C; its ρ₁ is `TERMS_UNIT_RHO1`.
const TERMS_UNIT_BETA1: [f64; 3] = [
    2e-3 * STANDARD_GRAVITY,
    -1e-3 * STANDARD_GRAVITY,
    1.5e-3 * STANDARD_GRAVITY,
];
const TERMS_UNIT_RHO1: [f64; 3] = [1e-4, -2e-4, 1.5e-4];

/// The thermal fit (lag 0, T_ref 25 °C; at `orders` when given, else by the terms rule) of the
/// terms-rule unit: `first_principles_unit` of draw `seed`, one session, 24 poses, β and ρ linear
/// but for β₂ on x at `beta2_x`.
fn terms_unit_fit(seed: u64, beta2_x: f64, orders: Option<[usize; 2]>) -> ThermalFit {
    let [b, r] = [TERMS_UNIT_BETA1, TERMS_UNIT_RHO1];
    let (stills, _) = first_principles_unit(
        seed,
        [&[b[0], beta2_x], &[b[1]], &[b[2]]],
        [&[r[0]], &[r[1]], &[r[2]]],
        &[[0.0; 3]],
        24,
        [0.0; 3],
    );
    let refs: Vec<&Recording> = stills.iter().collect();
    let settings = ThermalSettings {
        lags_s: vec![0.0],
        reference_c: Some(25.0),
        orders,
        ..ThermalSettings::default()
    };
    fit_thermal(&refs, &settings, STANDARD_GRAVITY).expect("thermal fit")
}

/// The thermal terms rule (issue 46 item 3) can fail both ways: over 60 draws of a unit whose β
/// is linear on y and z and whose ρ is linear on every axis, with β₂ on x set at 5 of its
/// standard errors, the fit (from orders 3 and 2) keeps β₂ on x in at least 90 % of draws and a
/// term that is zero (β₂, β₃ on y and z; ρ₂ anywhere; β₃ on x) in at most 5 % of the axis-draws.
#[test]
fn thermal_terms_rule_keeps_a_five_se_term_and_drops_a_zero_one() {
    let fit = terms_unit_fit;
    // Per draw: β₂'s standard error at the true orders with β₂ = 0, then the same draw (same
    // orientations and noise) with β₂ at 5 of them, fitted by the rule. At β₂ = 0 its error over
    // its standard error has an RMS within [0.7, 1.4] (too large an error bar fails as well as
    // too small).
    let draws = 60u64;
    let runs: Vec<(f64, f64, [usize; 3], [usize; 3])> = (0..draws)
        .into_par_iter()
        .map(|seed| {
            let zero = fit(9100 + seed, 0.0, Some([2, 1]));
            let se = zero.bias_per_c_se[0][1];
            let f = fit(9100 + seed, 5.0 * se, None);
            (
                zero.model.bias_per_c[0][1] / se,
                se,
                f.terms.bias_orders,
                f.terms.scale_orders,
            )
        })
        .collect();
    let rms_z = (runs.iter().map(|r| r.0 * r.0).sum::<f64>() / draws as f64).sqrt();
    let mut se: Vec<f64> = runs.iter().map(|r| r.1).collect();
    se.sort_by(f64::total_cmp);
    let kept: Vec<([usize; 3], [usize; 3])> = runs.iter().map(|r| (r.2, r.3)).collect();
    let power = kept.iter().filter(|(b, _)| b[0] >= 2).count() as f64 / draws as f64;
    let zero_kept = kept
        .iter()
        .map(|(b, s)| {
            usize::from(b[0] > 2)
                + usize::from(b[1] > 1)
                + usize::from(b[2] > 1)
                + s.iter().filter(|&&o| o > 1).count()
        })
        .sum::<usize>();
    let false_alarms = zero_kept as f64 / (6 * draws) as f64;
    let linear_lost = kept
        .iter()
        .filter(|(b, s)| b.contains(&0) || s.contains(&0))
        .count();
    println!(
        "β₂ on x at 5 se (median se {:.3e} m/s²/°C²): kept in {:.0} % of {draws} draws; zero terms kept in {:.1} % of axis-draws; a linear term lost in {linear_lost}",
        se[se.len() / 2],
        100.0 * power,
        100.0 * false_alarms
    );
    println!("β₂ (zero) at the true orders: RMS of estimate/se {rms_z:.2} over {draws} draws");
    assert!((0.7..=1.4).contains(&rms_z), "RMS z {rms_z}");
    assert!(power >= 0.9, "β₂ at 5 se kept in {power}");
    assert!(false_alarms <= 0.05, "zero terms kept in {false_alarms}");
    assert_eq!(linear_lost, 0, "a linear term far above its error was dropped");
}

/// The change from T_ref to `dt` of a polynomial without constant (β₁, β₂, … of ΔT¹, ΔT², …).
fn polynomial_change(coefficients: &[f64], dt: f64) -> f64 {
    coefficients.iter().rev().fold(0.0, |acc, c| (acc + c) * dt)
}

/// A term the rule drops still enters the error bars where the windows see it: over 40 draws of
/// the unit above with β₂ on x at 2 of its standard errors (the rule keeps it in few of them),
/// the error of x's fitted bias change at 10 °C either side of T_ref over the sd that the kept
/// coefficients' covariance and the left-out moves predict has an RMS within 0.7–1.4; the kept
/// coefficients' covariance alone errs narrow (above 1.4).
#[test]
fn thermal_error_bars_hold_a_left_out_term() {
    let fit = terms_unit_fit;
    let beta1 = TERMS_UNIT_BETA1;
    let draws = 40u64;
    // Per draw and ΔT: (error, sd with the left-out moves, sd without), and whether a move was made.
    type Draw = (Vec<(f64, f64, f64)>, bool);
    let per_draw: Vec<Draw> = (0..draws)
        .into_par_iter()
        .map(|seed| {
            let se = fit(9300 + seed, 0.0, Some([2, 1])).bias_per_c_se[0][1];
            let beta2 = 2.0 * se;
            let f = fit(9300 + seed, beta2, None);
            let kept = f.terms.bias_orders[0];
            let c = &f.coefficient_covariance;
            let rows = [-10.0f64, 10.0]
                .iter()
                .map(|&dt| {
                    let phi: Vec<f64> = (1..=kept as i32).map(|j| dt.powi(j)).collect();
                    let own: f64 = (0..kept)
                        .flat_map(|a| (0..kept).map(move |b| (a, b)))
                        .map(|(a, b)| phi[a] * phi[b] * c[a][b])
                        .sum();
                    let moves: f64 = f
                        .left_out_moves
                        .iter()
                        .map(|m| polynomial_change(&m.bias_per_c[0], dt).powi(2))
                        .sum();
                    let error = polynomial_change(&f.model.bias_per_c[0], dt)
                        - polynomial_change(&[beta1[0], beta2], dt);
                    (error, (own + moves).sqrt(), own.sqrt())
                })
                .collect();
            (rows, !f.left_out_moves.is_empty())
        })
        .collect();
    let rms = |pick: fn(&(f64, f64, f64)) -> f64| {
        let z: Vec<f64> = per_draw
            .iter()
            .flat_map(|(rows, _)| rows.iter().map(pick))
            .collect();
        (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt()
    };
    let with = rms(|r| r.0 / r.1);
    let without = rms(|r| r.0 / r.2);
    let moved = per_draw.iter().filter(|(_, m)| *m).count();
    println!("β₂ on x at 2 se over {draws} draws: a left-out move in {moved}; RMS of error/sd {with:.2} with the moves, {without:.2} without");
    assert!(
        moved * 2 >= draws as usize,
        "a move in only {moved} draws: the test has no power"
    );
    assert!((0.7..=1.4).contains(&with), "with the left-out moves: {with}");
    assert!(without > 1.4, "without them: {without} (the test has no power)");
}

/// Power-on sessions in the thermal fit (issue 46 items 2 and 6): a warm-up and 24 poses through
/// a second warm-up, the poses in three power-on sessions whose bias offsets differ by 0.05 m/s²
/// (the warm-up a fourth), the truth's β linear. Fitted as one session, the offsets between the
/// poses' sessions read as a change with temperature; with the sessions named, the spread found
/// is above zero and β₁ comes back within four of its standard errors on every axis, where the
/// one-session fit misses it by more than four of them on some axis, in each of three draws.
#[test]
fn thermal_fit_separates_session_offsets_from_the_change_with_temperature() {
    let settings = ThermalSettings {
        lags_s: vec![0.0],
        reference_c: Some(25.0),
        orders: Some([1, 1]),
        ..ThermalSettings::default()
    };
    let beta1 = [
        2e-3 * STANDARD_GRAVITY,
        -1e-3 * STANDARD_GRAVITY,
        1.5e-3 * STANDARD_GRAVITY,
    ];
    let offsets = [
        [0.0; 3],
        [0.05, -0.04, 0.03],
        [-0.05, 0.02, -0.05],
        [0.02, 0.05, 0.04],
    ];
    for seed in 0..3u64 {
        let (stills, sessions) = first_principles_unit(
            9500 + seed,
            [&[beta1[0]], &[beta1[1]], &[beta1[2]]],
            [&[1e-4], &[-2e-4], &[1.5e-4]],
            &offsets,
            24,
            [0.0; 3],
        );
        let refs: Vec<&Recording> = stills.iter().collect();
        let named = spincal::thermal::fit_thermal_in_sessions(&refs, &sessions, &settings, STANDARD_GRAVITY)
            .expect("thermal fit in sessions");
        let one = fit_thermal(&refs, &settings, STANDARD_GRAVITY).expect("thermal fit, one session");
        // Both errors in the named fit's standard errors: the one-session fit's own are widened
        // by its misfit (the blocks see the offsets), which is not what is judged here.
        let z = |f: &spincal::thermal::ThermalFit| -> [f64; 3] {
            std::array::from_fn(|k| (f.model.bias_per_c[k][0] - beta1[k]) / named.bias_per_c_se[k][0])
        };
        println!(
            "seed {seed}: sessions {} spread {:.4} m/s² (LR {:.1}); β₁ error / se named {:?}, one session {:?}",
            named.sessions.count,
            named.sessions.spread_sd_mps2,
            named.sessions.likelihood_ratio,
            z(&named).map(|v| (v * 10.0).round() / 10.0),
            z(&one).map(|v| (v * 10.0).round() / 10.0)
        );
        assert_eq!(named.sessions.count, 4);
        assert!(
            !named.sessions.at_lower_bound && named.sessions.spread_sd_mps2 > 0.01,
            "seed {seed}: spread {:?}",
            named.sessions
        );
        assert!(
            z(&named).iter().all(|z| z.abs() < 4.0),
            "seed {seed}: {:?}",
            z(&named)
        );
        let worst_one = z(&one).iter().fold(0.0f64, |a, z| a.max(z.abs()));
        assert!(
            worst_one > 4.0,
            "seed {seed}: one session's β₁ off by only {worst_one} se"
        );
    }
}

/// A nonlinearity is not a session offset: a unit of one power-on with q at 0.4 % of the reading
/// at 1 g (a consumer part's), each pose its own file and so its own session as a campaign
/// without `session` labels has it. A pose's q·f² is constant in that pose; unmodelled, the
/// offsets took it up as a spread (0.024 m/s² with LR 6170 measured on bench/thermal/campaign.sh's
/// seed 2), which freed each pose from the others and left β to the warm-up. With q fitted as a
/// nuisance (`fit_nonlinearity`, as a campaign fits it) the spread stays at the noise's scale and
/// β₁ comes back within four standard errors, in each of three draws; without, the spread is
/// printed (the old behaviour, not asserted).
#[test]
fn thermal_fit_does_not_read_a_nonlinearity_as_session_offsets() {
    let settings = ThermalSettings {
        lags_s: vec![0.0],
        reference_c: Some(25.0),
        orders: Some([1, 1]),
        fit_nonlinearity: true,
        ..ThermalSettings::default()
    };
    let beta1 = [
        2e-3 * STANDARD_GRAVITY,
        -1e-3 * STANDARD_GRAVITY,
        1.5e-3 * STANDARD_GRAVITY,
    ];
    let q = 0.004 / STANDARD_GRAVITY;
    for seed in 0..3u64 {
        let (stills, _) = first_principles_unit(
            9600 + seed,
            [&[beta1[0]], &[beta1[1]], &[beta1[2]]],
            [&[1e-4], &[-2e-4], &[1.5e-4]],
            &[[0.0; 3]],
            24,
            [q, -q, 0.75 * q],
        );
        let refs: Vec<&Recording> = stills.iter().collect();
        let each_its_own: Vec<usize> = (0..refs.len()).collect();
        let fit =
            spincal::thermal::fit_thermal_in_sessions(&refs, &each_its_own, &settings, STANDARD_GRAVITY)
                .expect("thermal fit");
        let z: [f64; 3] =
            std::array::from_fn(|k| (fit.model.bias_per_c[k][0] - beta1[k]) / fit.bias_per_c_se[k][0]);
        println!(
            "seed {seed}: {} sessions, spread {:.2e} m/s² (LR {:.1}); β₁ error / se {:?}",
            fit.sessions.count,
            fit.sessions.spread_sd_mps2,
            fit.sessions.likelihood_ratio,
            z.map(|v| (v * 10.0).round() / 10.0)
        );
        // A 20 s pose's mean at 50 Hz has a noise of 0.02/√1000 m/s²: no spread above 3 mm/s².
        assert!(
            fit.sessions.spread_sd_mps2 < 3e-3,
            "seed {seed}: spread {:?}",
            fit.sessions
        );
        assert!(z.iter().all(|z| z.abs() < 4.0), "seed {seed}: {z:?}");
        let without = ThermalSettings {
            fit_nonlinearity: false,
            ..settings.clone()
        };
        let old = spincal::thermal::fit_thermal_in_sessions(&refs, &each_its_own, &without, STANDARD_GRAVITY)
            .expect("thermal fit without q");
        println!(
            "seed {seed}, q not fitted: spread {:.2e} m/s² (LR {:.1})",
            old.sessions.spread_sd_mps2, old.sessions.likelihood_ratio
        );
    }
}

/// The lag's identifiability is reported: the thermal tests' units warm along one curve (every
/// warm-up the same exponential towards one temperature, so the die's rate is a linear function
/// of its temperature), where a lag error only rescales the temperature axis; the fit says the
/// lag is not determined there (`lag_rate_r2` above `LAG_RATE_R2_LIMIT`), for the die logged and
/// for the default sensor (20 s lag, 1 °C steps).
#[test]
fn thermal_lag_on_warm_ups_of_one_shape_is_reported_undetermined() {
    let campaign = simulate_thermal_campaign(&ThermalProfile::default(), 1000);
    for (what, campaign) in [
        ("reported", campaign.clone()),
        ("die logged", with_die_logged(&campaign)),
    ] {
        let stills: Vec<&Recording> = std::iter::once(&campaign.warmup)
            .chain(&campaign.poses)
            .map(|r| &r.recording)
            .collect();
        let fit = fit_thermal(&stills, &ThermalSettings::default(), STANDARD_GRAVITY).expect("thermal fit");
        println!(
            "{what}: lag {} s, R² of rate on temperature {:?}",
            fit.model.lag_s, fit.lag_rate_r2
        );
        let r2 = fit.lag_rate_r2.expect("blocks with a changing temperature");
        assert!(r2 > spincal::thermal::LAG_RATE_R2_LIMIT, "{what}: {r2}");
        assert!(!fit.lag_determined);
    }
}
