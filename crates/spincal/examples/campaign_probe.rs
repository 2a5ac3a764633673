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
    if std::env::var("NODRIFT").is_ok() {
        setup.sensor.bias_drift_g = 0.0;
    }
    let sim = simulate_campaign(&setup, seed).unwrap();
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
    let prep = prepare(&units).unwrap();
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
