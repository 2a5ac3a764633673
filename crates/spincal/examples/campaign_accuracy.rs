//! Measures campaign calibration against truth over several simulated units: for each seed, the
//! saved corrector's held-out RMS error per axis over the random floor (white noise + bias drift),
//! and each candidate's mean held-out error.
//!
//! ```text
//! cargo run --release -p spincal --example campaign_accuracy -- 10
//! ```

use spincal::campaign::{calibrate_campaign, CampaignSettings};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    let mut setup = CampaignSetup::default();
    let mut settings = CampaignSettings::default();
    if let Ok(v) = std::env::var("POSES") {
        setup.poses = v.parse().unwrap();
    }
    if let Ok(v) = std::env::var("Q_SD") {
        settings.joint.sensor_prior_sd[3] = v.parse().unwrap();
    }
    if let Ok(v) = std::env::var("BIAS_SIGMA") {
        settings.joint.bias_instability_mps2 = v.parse().unwrap();
    }
    if let Some(drift) = std::env::args().nth(2).and_then(|s| s.parse().ok()) {
        setup.sensor.bias_drift_g = drift;
    }
    println!(
        "seed  saved            RMS / floor, x y z: worst condition | pooled | uncorrected pooled   mean RMS per candidate (m/s²)"
    );
    let first: u64 = std::env::var("FIRST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
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
            if let (Some(rms), Some(floor)) = (h.rms_mps2, h.floor_mps2) {
                for k in 0..3 {
                    worst[k] = worst[k].max(rms[k] / floor[k]);
                    error_sq[k] += rms[k] * rms[k];
                    floor_sq[k] += floor[k] * floor[k];
                    raw_sq[k] += h.uncorrected_rms_mps2[k].powi(2);
                }
            }
        }
        let pooled: [f64; 3] = std::array::from_fn(|k| (error_sq[k] / floor_sq[k]).sqrt());
        let raw: [f64; 3] = std::array::from_fn(|k| (raw_sq[k] / floor_sq[k]).sqrt());
        if std::env::var_os("SPINCAL_DIAG").is_some() {
            for h in &r.held_out {
                if let (Some(rms), Some(floor)) = (h.rms_mps2, h.floor_mps2) {
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
            .map(|c| format!("{} {:.4}", c.candidate, c.mean_rms_mps2.unwrap_or(f64::NAN)))
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
