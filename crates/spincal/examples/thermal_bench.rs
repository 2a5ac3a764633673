//! Speed and accuracy benchmark of the thermal fit (`fit_thermal`) against numpy/scipy peers
//! (`bench/thermal/scipy_thermal.py`, `bench/thermal/flight_stack.py`).
//!
//! Usage: `thermal_bench SEED OUT_DIR [REPETITIONS] [DATA_DIR]`
//!
//! Without DATA_DIR, simulates one unit with the default `ThermalProfile` and writes it to
//! `OUT_DIR/data-SEED` exactly as `spincal simulate --thermal DIR --seed SEED` does (reused when
//! already there); with DATA_DIR, reads a folder that command wrote. Either way the recordings are
//! read back from their CSV files, so spincal fits what the peers read.
//!
//! The fit: the warm-up and the poses, the lag fixed at 20 s (the simulated sensor's) and the
//! orders at [2, 2] (the simulated model's), so `fit_thermal` does one Levenberg–Marquardt solve
//! from zero after cutting the windows. One warm-up call, then REPETITIONS timed calls (best and
//! median). The windowing alone (`die_temperatures` plus the 2 s means) is timed too.
//!
//! Written to OUT_DIR:
//! - `windows.csv`: `recording,ax,ay,az,die_c`, the windows as the fit cuts them, recomputed here
//!   with the public `spincal::thermal::die_temperatures` and the fit's windowing rule (checked:
//!   same count and same reference temperature as the fit's);
//! - `spincal_fit.json`: the fitted model, the standard errors, the residual RMS, the timing, the
//!   files fitted and the band error on the held-out poses (spincal's corrector and the oracle);
//! - `spincal_held_out.csv`: `file,sample,fx,fy,fz`, spincal's corrected force on every held-out
//!   sample (its own die-temperature estimate), for the peer to score with its own code.
//!
//! Run single-threaded (RAYON_NUM_THREADS=1, `taskset -c 1`); `fit_thermal` uses no rayon.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::json;
use spincal::input::recording::{ColumnMap, Recording, STANDARD_GRAVITY};
use spincal::simulate::thermal::{simulate_thermal_campaign, ThermalProfile, ThermalTruth};
use spincal::thermal::{die_temperatures, fit_thermal, ThermalModel, ThermalSettings};

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The folder's files whose names start with `prefix` (not the truth files), sorted.
fn files(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("cannot list the data folder")
        .map(|e| e.expect("folder entry").path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with(prefix) && name.ends_with(".csv") && !name.ends_with(".truth.csv")
        })
        .collect();
    out.sort();
    out
}

fn read(path: &Path) -> Recording {
    Recording::read_csv_path(path, &ColumnMap::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// (recording, mean reading, mean die temperature) per window: the fit's rule (consecutive windows
/// of `window_s` from each recording's first sample; a last one shorter than 0.9 of that dropped).
fn windows(stills: &[&Recording], settings: &ThermalSettings, lag_s: f64) -> Vec<(usize, [f64; 3], f64)> {
    let dies = die_temperatures(stills, lag_s, settings.smoothing_s);
    let mut out = Vec::new();
    for (r, (rec, die)) in stills.iter().zip(dies).enumerate() {
        let die = die.expect("a temperature column");
        let mut start = 0;
        while start < rec.len() {
            let end_t = rec.time_s[start] + settings.window_s;
            let end = start + rec.time_s[start..].partition_point(|&t| t < end_t);
            if end == rec.len() && rec.time_s[end - 1] - rec.time_s[start] < 0.9 * settings.window_s {
                break;
            }
            let n = (end - start) as f64;
            let mean: [f64; 3] =
                std::array::from_fn(|k| rec.accel_mps2[k][start..end].iter().sum::<f64>() / n);
            out.push((r, mean, die[start..end].iter().sum::<f64>() / n));
            start = end;
        }
    }
    out
}

/// The test's band error (tests/thermal.rs): RMS over the held-out poses' 1 s blocks whose middle
/// sample's true die temperature lies in the coldest or hottest fifth, of the block's mean error.
fn band_error(truth: &[Recording], corrected: &[Vec<[f64; 3]>]) -> f64 {
    let mut temps: Vec<f64> = truth
        .iter()
        .flat_map(|r| r.temperature_c.as_ref().unwrap().iter().copied())
        .collect();
    temps.sort_by(f64::total_cmp);
    let cold = temps[temps.len() / 5];
    let hot = temps[temps.len() * 4 / 5];
    let (mut sum, mut count) = (0.0, 0usize);
    for (t, c) in truth.iter().zip(corrected) {
        let die = t.temperature_c.as_ref().unwrap();
        let rate = t.sample_rate_hz().round() as usize;
        for start in (0..t.len()).step_by(rate) {
            let end = (start + rate).min(t.len());
            let mid = die[(start + end) / 2];
            if end - start < rate || (mid > cold && mid < hot) {
                continue;
            }
            for (k, axis) in t.accel_mps2.iter().enumerate() {
                let mean = (start..end).map(|i| c[i][k] - axis[i]).sum::<f64>() / (end - start) as f64;
                sum += mean * mean;
                count += 1;
            }
        }
    }
    (sum / count as f64).sqrt()
}

fn corrected(model: &ThermalModel, recs: &[Recording], dies: &[Vec<f64>]) -> Vec<Vec<[f64; 3]>> {
    recs.iter()
        .zip(dies)
        .map(|(r, die)| {
            (0..r.len())
                .map(|i| model.correct(std::array::from_fn(|k| r.accel_mps2[k][i]), die[i]))
                .collect()
        })
        .collect()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let usage = "usage: thermal_bench SEED OUT_DIR [REPETITIONS] [DATA_DIR]";
    let seed: u64 = args.next().expect(usage).parse().expect(usage);
    let out_dir = PathBuf::from(args.next().expect(usage));
    let reps: usize = args.next().map_or(5, |s| s.parse().expect(usage)).max(1);
    std::fs::create_dir_all(&out_dir).expect("cannot create the output directory");
    let data = match args.next() {
        Some(dir) => PathBuf::from(dir),
        None => {
            let dir = out_dir.join(format!("data-{seed}"));
            if !dir.join("truth.json").exists() {
                let profile = ThermalProfile::default();
                simulate_thermal_campaign(&profile, seed)
                    .write_folder(&dir, seed, &profile)
                    .expect("cannot write the simulated folder");
            }
            dir
        }
    };
    let truth: ThermalTruth =
        serde_json::from_str(&std::fs::read_to_string(data.join("truth.json")).expect("truth.json"))
            .expect("truth.json parses");

    let still_files: Vec<PathBuf> = files(&data, "warmup-")
        .into_iter()
        .chain(files(&data, "pose-"))
        .collect();
    let held_files = files(&data, "held-out-");
    let stills: Vec<Recording> = still_files.iter().map(|p| read(p)).collect();
    let held: Vec<Recording> = held_files.iter().map(|p| read(p)).collect();
    let held_truth: Vec<Recording> = held_files
        .iter()
        .map(|p| read(&p.with_extension("truth.csv")))
        .collect();
    let refs: Vec<&Recording> = stills.iter().collect();

    let lag_s = 20.0;
    let settings = ThermalSettings {
        lags_s: vec![lag_s],
        orders: Some([2, 2]),
        ..ThermalSettings::default()
    };

    // Warm-up, then the timed fits.
    let fit = fit_thermal(&refs, &settings, STANDARD_GRAVITY).expect("thermal fit");
    let mut times = Vec::with_capacity(reps);
    for _ in 0..reps {
        let t = Instant::now();
        let again = fit_thermal(&refs, &settings, STANDARD_GRAVITY).expect("thermal fit");
        times.push(t.elapsed().as_secs_f64());
        assert_eq!(again.model, fit.model, "the fit is deterministic");
    }
    let best = times.iter().copied().fold(f64::INFINITY, f64::min);
    let med = median(&mut times.clone());

    // The windows (timed alone: the part of fit_thermal before the solve).
    let mut window_times = Vec::with_capacity(reps);
    let mut cut = Vec::new();
    for _ in 0..reps {
        let t = Instant::now();
        cut = windows(&refs, &settings, lag_s);
        window_times.push(t.elapsed().as_secs_f64());
    }
    let window_best = window_times.iter().copied().fold(f64::INFINITY, f64::min);
    let window_median = median(&mut window_times);
    assert_eq!(cut.len(), fit.windows, "windows recomputed as the fit cuts them");
    let mut temps: Vec<f64> = cut.iter().map(|w| w.2).collect();
    temps.sort_by(f64::total_cmp);
    let reference = temps[((temps.len() - 1) as f64 * 0.5).round() as usize];
    assert_eq!(
        reference, fit.model.reference_c,
        "same reference temperature as the fit's"
    );
    let mut text = String::from("recording,ax,ay,az,die_c\n");
    for (r, m, d) in &cut {
        text += &format!("{r},{:e},{:e},{:e},{:e}\n", m[0], m[1], m[2], d);
    }
    std::fs::write(out_dir.join("windows.csv"), text).expect("windows.csv");

    // The held-out poses: spincal's corrector with its own die temperature; the oracle with the
    // true model and the true die temperature.
    let held_refs: Vec<&Recording> = held.iter().collect();
    let dies: Vec<Vec<f64>> = fit
        .model
        .die_temperatures(&held_refs)
        .into_iter()
        .map(|d| d.expect("a temperature column"))
        .collect();
    let ours = corrected(&fit.model, &held, &dies);
    let true_dies: Vec<Vec<f64>> = held_truth
        .iter()
        .map(|t| t.temperature_c.clone().unwrap())
        .collect();
    let oracle = corrected(&truth.model, &held, &true_dies);
    let ours_error = band_error(&held_truth, &ours);
    let oracle_error = band_error(&held_truth, &oracle);
    let mut out = std::io::BufWriter::new(
        std::fs::File::create(out_dir.join("spincal_held_out.csv")).expect("spincal_held_out.csv"),
    );
    writeln!(out, "file,sample,fx,fy,fz").unwrap();
    for (path, values) in held_files.iter().zip(&ours) {
        let name = path.file_name().unwrap().to_string_lossy();
        for (i, f) in values.iter().enumerate() {
            writeln!(out, "{name},{i},{:e},{:e},{:e}", f[0], f[1], f[2]).unwrap();
        }
    }
    out.flush().unwrap();

    let name = |p: &PathBuf| p.file_name().unwrap().to_string_lossy().into_owned();
    let report = json!({
        "seed": truth.seed,
        "data_dir": data.display().to_string(),
        "still_files": still_files.iter().map(name).collect::<Vec<_>>(),
        "held_out_files": held_files.iter().map(name).collect::<Vec<_>>(),
        "gravity_mps2": STANDARD_GRAVITY,
        "settings": settings,
        "model": fit.model,
        "bias_per_c_se": fit.bias_per_c_se,
        "scale_per_c_se": fit.scale_per_c_se,
        "residual_rms_mps2": fit.residual_rms_mps2,
        "windows": fit.windows,
        "held_out": {
            "spincal_band_rms_mps2": ours_error,
            "oracle_band_rms_mps2": oracle_error,
        },
        "timing": {
            "repetitions": reps,
            "best_s": best,
            "median_s": med,
            "windows_best_s": window_best,
            "windows_median_s": window_median,
        },
    });
    std::fs::write(
        out_dir.join("spincal_fit.json"),
        serde_json::to_string_pretty(&report).unwrap() + "\n",
    )
    .expect("spincal_fit.json");
    println!(
        "fit_thermal: best {best:.4} s, median {med:.4} s of {reps} (windows alone best {window_best:.4} s); {} windows, residual RMS {:.6} m/s²; held-out band RMS spincal {ours_error:.6}, oracle {oracle_error:.6} m/s²",
        fit.windows, fit.residual_rms_mps2
    );
}
