use spincal::campaign::prepare::UnitRecording;
use spincal::campaign::select::{calibrate_campaign, CampaignSettings};
use spincal::simulate::campaign::{simulate_campaign, CampaignSetup};

fn main() {
    let seed: u64 = std::env::args().nth(1).map_or(1, |s| s.parse().unwrap());
    let truth = std::env::var("NOTRUTH").is_err();
    let mut setup = CampaignSetup::default();
    if let Ok(g) = std::env::var("POSES") { setup.poses = g.parse().unwrap(); }
    if let Ok(g) = std::env::var("TILT") { for r in &mut setup.runs { r.tilt_deg = g.parse().unwrap(); } }
    let sim = simulate_campaign(&setup, seed).unwrap();
    let units: Vec<UnitRecording> = sim.recordings.iter().map(|r| UnitRecording {
        name: r.name.clone(), recording: r.recording.clone(), turntable: r.turntable.clone(),
        truth: truth.then(|| r.true_accel_mps2.clone()), floor_mps2: truth.then_some(r.floor_mps2) }).collect();
    let t = std::time::Instant::now();
    let out = calibrate_campaign("u", &units, &CampaignSettings::default(), &spincal::progress::silent).unwrap();
    eprintln!("{:?}", t.elapsed());
    for h in &out.result.held_out {
        eprintln!("{:40} {:16} {:?} unc {:?} floor {:?} {}", h.condition, h.candidate, h.rms_mps2.map(|r| r.map(|v| (v*1e4).round()/1e4)), h.uncorrected_rms_mps2.map(|v| (v*1e4).round()/1e4), h.floor_mps2.map(|r| r.map(|v| (v*1e4).round()/1e4)), h.against);
    }
    for c in &out.result.candidates { eprintln!("{:?}", c); }
    eprintln!("{}", out.result.verdict);
    eprintln!("undetermined {:?}", out.result.undetermined);
}
