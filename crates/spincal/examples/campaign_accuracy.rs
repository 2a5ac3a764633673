//! Measures campaign calibration against truth over several simulated units: for each seed, the
//! saved corrector's held-out RMS error per axis over the random floor (white noise + bias drift)
//! on the same samples, at worst over the held-out conditions and pooled over them, the
//! uncorrected error pooled the same way, and each candidate's mean held-out error.
//!
//! ```text
//! cargo run --release -p spincal --example campaign_accuracy -- 10
//! cargo run --release -p spincal --example campaign_accuracy -- 10 --drift-g 0 --bias-instability 0.001
//! ```
//! Options: `--first-seed N`, `--poses N` (still poses), `--drift-g X` (the sensor's bias drift
//! bound), `--bias-instability X` (the fit's, m/s²), `--q-prior X` (the nonlinearity prior's
//! width, 1/(m/s²)), `--detail` (every held-out row).

use spincal::campaign::params::Params;
use spincal::campaign::select::calibrate_campaign;
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};

fn main() {
    let mut setup = CampaignSetup::default();
    let mut settings = Params::default();
    let (mut seeds, mut first, mut detail) = (5u64, 0u64, false);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = |name: &str| -> f64 {
            match args.next().map(|v| v.parse::<f64>()) {
                Some(Ok(v)) if v.is_finite() && v >= 0.0 => v,
                _ => {
                    eprintln!("{name} needs a non-negative number");
                    std::process::exit(2)
                }
            }
        };
        match arg.as_str() {
            "--first-seed" => first = value("--first-seed") as u64,
            "--poses" => setup.poses = value("--poses") as usize,
            "--drift-g" => setup.sensor.bias_drift_g = value("--drift-g"),
            "--bias-instability" => settings.joint.bias_instability_mps2 = value("--bias-instability"),
            "--q-prior" => settings.joint.sensor_prior_sd[3] = value("--q-prior"),
            "--detail" => detail = true,
            n => match n.parse() {
                Ok(n) => seeds = n,
                Err(_) => {
                    eprintln!("unknown argument {n:?}");
                    std::process::exit(2)
                }
            },
        }
    }
    println!(
        "seed  saved            RMS / floor, x y z: worst condition | pooled | uncorrected pooled   mean RMS per candidate (m/s²)"
    );
    for seed in first..first + seeds {
        let sim = match simulate_campaign(&setup, seed) {
            Ok(sim) => sim,
            Err(e) => return eprintln!("{e}"),
        };
        let units = sim.unit_recordings(true);
        let out = match calibrate_campaign("unit", &units, &settings, &spincal::progress::silent) {
            Ok(out) => out,
            Err(e) => return eprintln!("seed {seed}: {e}"),
        };
        let r = &out.result;
        let saved = r.saved.clone().unwrap_or_else(|| "nothing".into());
        let mut worst = [0.0f64; 3];
        let (mut error_sq, mut floor_sq, mut raw_sq) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
        for h in r.held_out.iter().filter(|h| h.candidate == saved) {
            if let (Some(truth), Some(floor)) = (&h.truth, h.floor_mps2) {
                let rms = truth.rms_mps2;
                for k in 0..3 {
                    worst[k] = worst[k].max(rms[k] / floor[k]);
                    error_sq[k] += rms[k] * rms[k];
                    floor_sq[k] += floor[k] * floor[k];
                    raw_sq[k] += truth.uncorrected_rms_mps2[k].powi(2);
                }
            }
        }
        let pooled: [f64; 3] = std::array::from_fn(|k| (error_sq[k] / floor_sq[k]).sqrt());
        let raw: [f64; 3] = std::array::from_fn(|k| (raw_sq[k] / floor_sq[k]).sqrt());
        if detail {
            for h in &r.held_out {
                if let (Some(rms), Some(floor)) = (h.truth.as_ref().map(|t| t.rms_mps2), h.floor_mps2) {
                    println!(
                        "   {:<40} {:<16} {:.2} {:.2} {:.2}",
                        h.condition,
                        h.candidate,
                        rms[0] / floor[0],
                        rms[1] / floor[1],
                        rms[2] / floor[2]
                    );
                }
            }
        }
        let means: Vec<String> = r
            .candidates
            .iter()
            .map(|c| format!("{} {:.4}", c.candidate, c.mean_truth_rms_mps2.unwrap_or(f64::NAN)))
            .collect();
        println!(
            "{seed:<5} {saved:<16} {:.2} {:.2} {:.2}   {:.2} {:.2} {:.2}   {:.1} {:.1} {:.1}   {}",
            worst[0],
            worst[1],
            worst[2],
            pooled[0],
            pooled[1],
            pooled[2],
            raw[0],
            raw[1],
            raw[2],
            means.join(", ")
        );
    }
}
