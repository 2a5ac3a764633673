//! Measures campaign calibration against truth over several simulated units: for each seed, the
//! saved corrector's held-out RMS error per axis over the random floor (white noise + bias drift),
//! and each candidate's mean held-out error.
//!
//! ```text
//! cargo run --release -p spincal --example campaign_accuracy -- 10
//! ```

use spincal::campaign::prepare::UnitRecording;
use spincal::campaign::{calibrate_campaign, CampaignSettings};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};

fn main() {
    let seeds: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(5);
    println!("seed  saved            worst held-out RMS / floor (x y z)   mean RMS per candidate (m/s²)");
    for seed in 0..seeds {
        let sim = match simulate_campaign(&CampaignSetup::default(), seed) {
            Ok(sim) => sim,
            Err(e) => return eprintln!("{e}"),
        };
        let units: Vec<UnitRecording> = sim
            .recordings
            .iter()
            .map(|r| UnitRecording {
                name: r.name.clone(),
                recording: r.recording.clone(),
                turntable: r.turntable.clone(),
                truth: Some(r.true_accel_mps2.clone()),
                floor_mps2: Some(r.floor_mps2),
            })
            .collect();
        let out = match calibrate_campaign(
            "unit",
            &units,
            &CampaignSettings::default(),
            &spincal::progress::silent,
        ) {
            Ok(out) => out,
            Err(e) => return eprintln!("seed {seed}: {e}"),
        };
        let r = &out.result;
        let saved = r.saved.clone().unwrap_or_else(|| "nothing".into());
        let mut worst = [0.0f64; 3];
        for h in r.held_out.iter().filter(|h| h.candidate == saved) {
            if let (Some(rms), Some(floor)) = (h.rms_mps2, h.floor_mps2) {
                for k in 0..3 {
                    worst[k] = worst[k].max(rms[k] / floor[k]);
                }
            }
        }
        let means: Vec<String> = r
            .candidates
            .iter()
            .map(|c| format!("{} {:.4}", c.candidate, c.mean_rms_mps2.unwrap_or(f64::NAN)))
            .collect();
        println!(
            "{seed:<5} {saved:<16} {:.2} {:.2} {:.2}                       {}",
            worst[0],
            worst[1],
            worst[2],
            means.join(", ")
        );
    }
}
