use spincal::campaign::joint::{fit_joint, JointSettings, SensorTerms};
use spincal::campaign::prepare::{prepare, UnitRecording};
use spincal::campaign::SignedAxis;
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup, RunSetup};

fn main() {
    let seed: u64 = std::env::args().nth(1).map_or(1, |s| s.parse().unwrap());
    let mut setup = CampaignSetup::default();
    if let Ok(g) = std::env::var("POSES") { setup.poses = g.parse().unwrap(); }
    if let Ok(g) = std::env::var("TILT") { for r in &mut setup.runs { r.tilt_deg = g.parse().unwrap(); } }
    setup.runs.push(RunSetup { rpm: 78.0, radius_m: 0.10, out: SignedAxis::parse("+y").unwrap(), up: SignedAxis::parse("-x").unwrap(), ..RunSetup::default() });
    let sim = simulate_campaign(&setup, seed).unwrap();
    let units: Vec<UnitRecording> = sim.recordings.iter().map(|r| UnitRecording {
        name: r.name.clone(), recording: r.recording.clone(), turntable: r.turntable.clone(), truth: None, floor_mps2: None }).collect();
    let mut prep = prepare(&units).unwrap();
    prep.runs.pop();
    let last = sim.recordings.last().unwrap();
    for terms in [SensorTerms::ALL, SensorTerms::LINEAR] {
        let fit = fit_joint(&prep.runs, &prep.poses, &JointSettings { terms, ..JointSettings::default() }, &spincal::progress::silent).unwrap();
        let mut sums = [0.0; 3]; let mut unc = [0.0; 3];
        let n = last.recording.len();
        for s in 0..n {
            let m = [last.recording.accel_mps2[0][s], last.recording.accel_mps2[1][s], last.recording.accel_mps2[2][s]];
            let f = fit.sensor.correct(m).unwrap();
            for k in 0..3 { sums[k] += (f[k] - last.true_accel_mps2[k][s]).powi(2); unc[k] += (m[k] - last.true_accel_mps2[k][s]).powi(2); }
        }
        let rms = sums.map(|v| (v / n as f64).sqrt());
        let unc = unc.map(|v| (v / n as f64).sqrt());
        eprintln!("{:?}: rms {:?} unc {:?} floor {:?} ratio {:?}", terms.describe(), rms, unc, last.floor_mps2, [0,1,2].map(|k| rms[k]/last.floor_mps2[k]));
    }
}
