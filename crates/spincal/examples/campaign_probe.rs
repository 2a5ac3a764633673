use spincal::campaign::joint::{fit_joint, JointSettings};
use spincal::campaign::prepare::{prepare, UnitRecording};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};

fn main() {
    let seed: u64 = std::env::args().nth(1).map_or(1, |s| s.parse().unwrap());
    let mut setup = CampaignSetup::default();
    if std::env::var("IDEAL").is_ok() {
        setup.sensor.bias_drift_g = 0.0;
        for r in &mut setup.runs {
            r.wow_pct = 0.0;
            r.flutter_pct = 0.0;
        }
    }
    if let Ok(g) = std::env::var("POSES") { setup.poses = g.parse().unwrap(); }
    if let Ok(g) = std::env::var("TILT") { for r in &mut setup.runs { r.tilt_deg = g.parse().unwrap(); } }
    if std::env::var("NODRIFT").is_ok() {
        setup.sensor.bias_drift_g = 0.0;
    }
    let mut sim = simulate_campaign(&setup, seed).unwrap();
    let units: Vec<UnitRecording> = sim
        .recordings
        .iter()
        .map(|r| UnitRecording {
            name: r.name.clone(),
            recording: r.recording.clone(),
            turntable: r.turntable.clone(),
            truth: None,
            floor_mps2: None,
        })
        .collect();
    let mut prep = prepare(&units).unwrap();
    if let Ok(keep) = std::env::var("RUNS") {
        let keep: Vec<usize> = keep.split(',').map(|v| v.parse().unwrap()).collect();
        prep.runs = prep.runs.iter().enumerate().filter(|(i, _)| keep.contains(i)).map(|(_, r)| r.clone()).collect();
        let truth_runs = sim.truth.runs.clone();
        sim.truth.runs = truth_runs.iter().enumerate().filter(|(i, _)| keep.contains(i)).map(|(_, r)| *r).collect();
    }
    let t = std::time::Instant::now();
    let fit = fit_joint(
        &prep.runs,
        &prep.poses,
        &JointSettings::default(),
        &spincal::progress::silent,
    )
    .unwrap();
    eprintln!(
        "{:?} iterations {} stop {:?} chi2 {} dof {}",
        t.elapsed(),
        fit.iterations,
        fit.stop,
        fit.chi2,
        fit.dof
    );
    let truth = sim.truth.sensor.params();
    for (k, p) in fit.sensor_params.iter().enumerate() {
        let se = p.std_error.unwrap_or(f64::NAN);
        eprintln!(
            "{:28} {:12.6} ± {:10.6}  true {:12.6}  z {:6.2}",
            p.name,
            p.value,
            se,
            truth[k],
            (p.value - truth[k]) / se
        );
    }
    for (i, r) in fit.runs.iter().enumerate() {
        eprintln!("{} {:?} rms {:?}", r.name, r.direction, r.residual_rms_mps2);
        for (j, p) in r.params.iter().enumerate() {
            let tv = sim.truth.runs[i][j];
            let se = p.std_error.unwrap_or(f64::NAN);
            let mut d = p.value - tv;
            if j == 3 || j == 4 {
                d = (d + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI;
            }
            eprintln!(
                "   {:24} {:12.6} ± {:10.6}  true {:12.6}  z {:6.2}",
                p.name,
                p.value,
                se,
                tv,
                d / se
            );
        }
    }
}
