//! Checks the truth-free held-out verdict against the truth it cannot see, over simulated campaigns.
//!
//! Each campaign is calibrated once; the verdict is made by physics alone (the truth never enters
//! it, which `tests/campaign.rs` checks bit for bit), and the same held-out samples are scored
//! against the true specific force beside it. Printed per campaign: what was saved, what the
//! same rule on truth-based scores would have saved, and, over the conditions of the physical
//! family, the truth-free figure (corrected over uncorrected residual RMS) against the truth-based
//! one. Then the totals: how often the choices agree (or the saved one is within 10 % of truth's
//! choice in error against truth), and how often the figures agree within a factor 2.
//!
//! `--detail` prints each candidate's mean held-out error against physics and against truth.
//!
//! `--units`: instead of the default campaign, sensors drawn independently and uniformly (bias to
//! ±0.08 m/s², scale errors to ±0.8 %, misalignment to ±0.6°, white noise 0.02 m/s², drift as the
//! default), each with 7 still poses and 4 turntable runs. Then also the oracle: the true static
//! parameters applied to the same held-out samples, and whether a model was saved for every unit
//! whose physical model removes at least half of the held-out error (with its error within 1.25×
//! the oracle's).
//!
//! ```text
//! cargo run --release -p spincal --example verdict_validation -- 20
//! cargo run --release -p spincal --example verdict_validation -- 10 --units --first-seed 100
//! ```

use rand::{Rng, SeedableRng};
use spincal::campaign::evaluate::conditions;
use spincal::campaign::params::Params;
use spincal::campaign::prepare::prepare;
use spincal::campaign::select::calibrate_campaign;
use spincal::campaign::verdict::combined;
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup, RunSetup, SimulatedCampaign};

/// An independently drawn unit: 7 poses and 4 runs (two speeds, two radii, z up and x up).
fn drawn_setup(seed: u64) -> CampaignSetup {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x005e_ed0f_ba5e);
    let g = spincal::input::recording::STANDARD_GRAVITY;
    let mut setup = CampaignSetup::default();
    setup.sensor.bias_g = std::array::from_fn(|_| rng.gen_range(-0.08..0.08) / g);
    setup.sensor.scale_error_pct = std::array::from_fn(|_| rng.gen_range(-0.8..0.8));
    setup.sensor.misalignment_deg = std::array::from_fn(|_| rng.gen_range(-0.6..0.6));
    setup.sensor.noise_g = 0.02 / g;
    setup.poses = 7;
    let axis = |t: &str| spincal::campaign::file::SignedAxis::parse(t).expect("a valid axis");
    let run = |rpm: f64, radius_m: f64, out: &str, up: &str| RunSetup {
        rpm,
        radius_m,
        out: axis(out),
        up: axis(up),
        ..RunSetup::default()
    };
    setup.runs = vec![
        run(100.0 / 3.0, 0.06, "+x", "+z"),
        run(45.0, 0.12, "+x", "+z"),
        run(100.0 / 3.0, 0.12, "+z", "+x"),
        run(45.0, 0.06, "+y", "+x"),
    ];
    setup
}

/// RMS over all axes and held-out samples of the true static model's correction against truth,
/// and of the uncorrected signal, per condition label.
fn oracle(sim: &SimulatedCampaign) -> Vec<(String, f64)> {
    let units = sim.unit_recordings(true);
    let Ok(prepared) = prepare(&units) else {
        return Vec::new();
    };
    let sensor = &sim.truth.sensor;
    let mut out = Vec::new();
    for c in conditions(&prepared) {
        let (mut sum, mut n) = (0.0, 0usize);
        let mut add = |m: [f64; 3], t: [f64; 3]| {
            if let Some(f) = sensor.correct(m) {
                sum += (0..3).map(|k| (f[k] - t[k]).powi(2)).sum::<f64>() / 3.0;
                n += 1;
            }
        };
        for &i in &c.runs {
            let run = &prepared.runs[i];
            let origin = &prepared.run_origin[i];
            let truth = units[origin.recording].truth.as_ref().expect("simulated");
            for s in (0..run.time_s.len()).filter(|&s| run.keep[s]) {
                let (a, t) = (&run.accel_mps2, origin.start + s);
                add(
                    [a[0][s], a[1][s], a[2][s]],
                    [truth[0][t], truth[1][t], truth[2][t]],
                );
            }
        }
        for &p in &c.poses {
            let o = &prepared.pose_origin[p];
            let unit = &units[o.recording];
            let (a, t) = (
                &unit.recording.accel_mps2,
                unit.truth.as_ref().expect("simulated"),
            );
            for s in o.start..o.end {
                add([a[0][s], a[1][s], a[2][s]], [t[0][s], t[1][s], t[2][s]]);
            }
        }
        out.push((c.label, (sum / n.max(1) as f64).sqrt()));
    }
    out
}

fn main() {
    let (mut seeds, mut first, mut drawn, mut detail) = (20u64, 0u64, false, false);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--units" => drawn = true,
            "--detail" => detail = true,
            "--first-seed" => match args.next().and_then(|v| v.parse().ok()) {
                Some(v) => first = v,
                None => return eprintln!("--first-seed needs a number"),
            },
            n => match n.parse() {
                Ok(n) => seeds = n,
                Err(_) => return eprintln!("unknown argument {n:?}"),
            },
        }
    }
    let settings = Params::default();
    let (mut agree, mut campaigns) = (0usize, 0usize);
    let (mut within, mut figures) = (0usize, 0usize);
    let (mut owed, mut owed_saved, mut owed_near_oracle) = (0usize, 0usize, 0usize);
    println!("seed  saved            truth would save  agrees  physical family: truth-free / truth figure per condition");
    for seed in first..first + seeds {
        let setup = if drawn {
            drawn_setup(seed)
        } else {
            CampaignSetup::default()
        };
        let sim = match simulate_campaign(&setup, seed) {
            Ok(sim) => sim,
            Err(e) => return eprintln!("seed {seed}: {e}"),
        };
        let out = match calibrate_campaign(
            "unit",
            &sim.unit_recordings(true),
            &settings,
            &spincal::progress::silent,
        ) {
            Ok(out) => out,
            Err(e) => {
                eprintln!("seed {seed}: {e}");
                continue;
            }
        };
        let r = &out.result;
        let check = r.truth_check.as_ref();
        campaigns += 1;
        agree += usize::from(check.is_some_and(|c| c.agrees));
        let mut cells = Vec::new();
        for h in &r.held_out {
            if !h.candidate.starts_with("physical") || h.candidate == "physical-ann" {
                continue;
            }
            if let (Some(p), Some(t)) = (&h.predicted, &h.truth) {
                let factor = p.ratio / t.ratio;
                figures += 1;
                within += usize::from((0.5..=2.0).contains(&factor));
                cells.push(format!("{:.2}/{:.2}", p.ratio, t.ratio));
            }
        }
        println!(
            "{seed:<5} {:<16} {:<17} {:<7} {}",
            r.saved.as_deref().unwrap_or("nothing"),
            check.and_then(|c| c.would_save.as_deref()).unwrap_or("nothing"),
            check.map_or("–", |c| if c.agrees { "yes" } else { "no" }),
            cells.join(" ")
        );
        if detail {
            for c in &r.candidates {
                println!(
                    "      {:<16} physics mean {:.4}  truth mean {:.4}  eligible {}  {}",
                    c.candidate,
                    c.mean_rms_mps2.unwrap_or(f64::NAN),
                    c.mean_truth_rms_mps2.unwrap_or(f64::NAN),
                    c.eligible,
                    c.why_not.as_deref().unwrap_or("")
                );
            }
        }
        if drawn {
            // The unit is owed a model when its physical model removes at least half of the
            // held-out error against truth (pooled over conditions).
            let pooled = |name: &str, uncorrected: bool| {
                let rows: Vec<f64> = r
                    .held_out
                    .iter()
                    .filter(|h| h.candidate == name)
                    .filter_map(|h| h.truth.as_ref())
                    .map(|t| {
                        combined(if uncorrected {
                            t.uncorrected_rms_mps2
                        } else {
                            t.rms_mps2
                        })
                        .powi(2)
                    })
                    .collect();
                (rows.iter().sum::<f64>() / rows.len().max(1) as f64).sqrt()
            };
            let (physical, raw) = (pooled("physical", false), pooled("physical", true));
            let oracle_rows = oracle(&sim);
            let oracle_pooled = (oracle_rows.iter().map(|(_, v)| v * v).sum::<f64>()
                / oracle_rows.len().max(1) as f64)
                .sqrt();
            let saved_error = r.saved.as_deref().map(|s| pooled(s, false));
            println!(
                "      held-out RMS against truth: uncorrected {raw:.4}, physical {physical:.4}, saved {}, oracle (true static model) {oracle_pooled:.4} m/s²{}",
                saved_error.map_or("–".into(), |v| format!("{v:.4}")),
                saved_error.map_or(String::new(), |v| format!(" ({:.2}× the oracle)", v / oracle_pooled))
            );
            if physical <= 0.5 * raw {
                owed += 1;
                if let Some(v) = saved_error {
                    owed_saved += 1;
                    owed_near_oracle += usize::from(v <= 1.25 * oracle_pooled);
                }
            }
        }
    }
    println!("\nchoice agrees with truth's (or within 10 % of its error against truth): {agree}/{campaigns}");
    println!("physical-family figures within a factor 2 of the truth-based ones: {within}/{figures}");
    if drawn {
        println!(
            "units whose physical model removes half the held-out error: {owed}; a model saved for {owed_saved}; within 1.25× the oracle: {owed_near_oracle}"
        );
    }
}
