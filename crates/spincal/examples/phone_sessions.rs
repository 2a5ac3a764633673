//! The chip's radius and the gyroscope's scale about the spindle from simulated phone sessions
//! (issue 48, "What it must show"), written as the apps write them and calibrated from the zips
//! exactly as `spincal calibrate --campaign` does.
//!
//! Each seed is `spincal simulate --phone` (the library's `simulate::phone`, its default setup:
//! twelve still poses, six of them about 45°, and 30-s runs at 33⅓ and 45 rpm in two placements
//! turned 180°, the platter 1 % fast, no radius stated), written once as phyphox zips and once as
//! Sensor Logger zips (the same samples). Printed per seed and app: each placement's chip radius
//! against the truth (error and error over the stated standard error), the gyroscope's scale about
//! the spindle (error in % and in standard errors), what was saved, and the seconds the
//! calibration took; then whether the goals hold on every seed (radius within 2 mm and within 3
//! standard errors; the scale within 0.1 %).
//!
//! ```text
//! cargo run --release -p spincal --example phone_sessions -- 1-5
//! cargo run --release -p spincal --example phone_sessions -- 1-5 --turn 90 --app phyphox
//! ```

use spincal::campaign::file::{Campaign, SignedAxis};
use spincal::campaign::params::Params;
use spincal::campaign::run::calibrate_campaign_file;
use spincal::simulate::phone::{simulate_phone, PhoneApp, PhoneSetup};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds = args
        .first()
        .and_then(|r| {
            let (a, b) = r.split_once('-').unwrap_or((r, r));
            Some(a.parse::<u64>().ok()?..=b.parse::<u64>().ok()?)
        })
        .unwrap_or(1..=5);
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let apps: Vec<PhoneApp> = match value("--app").as_deref() {
        Some("phyphox") => vec![PhoneApp::Phyphox],
        Some("sensor-logger") => vec![PhoneApp::SensorLogger],
        _ => vec![PhoneApp::Phyphox, PhoneApp::SensorLogger],
    };
    let mut setup = PhoneSetup::default();
    if value("--turn").as_deref() == Some("90") {
        // The second placement turned 90°: its x axis points away from the spindle.
        setup.placements[1].out = SignedAxis { axis: 0, sign: 1 };
    }
    println!(
        "| seed | app | placement A: fitted − true (error/se) | placement B | gyro scale about the spindle: error (error/se) | saved | s |"
    );
    println!("|---|---|---|---|---|---|---|");
    let (mut radius_ok, mut z_ok, mut scale_ok, mut cases) = (0, 0, 0, 0);
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    for seed in seeds {
        for &app in &apps {
            let setup = PhoneSetup { app, ..setup.clone() };
            let session = simulate_phone(&setup, seed).expect("a valid setup");
            let dir = tempfile_dir(seed, app);
            session.write_folder(&dir, true).expect("the session is written");
            let campaign = Campaign::read_path(&dir.join("campaign.toml")).expect("the campaign reads");
            let started = std::time::Instant::now();
            let output = calibrate_campaign_file(&campaign, &Params::default(), &spincal::progress::silent)
                .expect("the campaign calibrates");
            let seconds = started.elapsed().as_secs_f64();
            let score = session.truth.score(&output.result);
            let mut cells = Vec::new();
            let mut all_radius = true;
            let mut all_z = true;
            for p in &score.placements {
                let (e, z) = (p.error_m().unwrap_or(f64::NAN), p.z().unwrap_or(f64::NAN));
                all_radius &= e.abs() <= 2e-3;
                all_z &= z.abs() <= 3.0;
                worst.0 = worst.0.max(e.abs());
                worst.1 = worst.1.max(z.abs());
                cells.push(format!("{:+.2} mm ({z:+.2})", 1e3 * e));
            }
            let gyro = score.gyro.as_ref().map_or("not calibrated".to_string(), |g| {
                worst.2 = worst.2.max(g.error_pct().abs());
                if g.error_pct().abs() <= 0.1 {
                    scale_ok += 1;
                }
                format!("{:+.3} % ({:+.2})", g.error_pct(), g.z().unwrap_or(f64::NAN))
            });
            cases += 1;
            radius_ok += usize::from(all_radius);
            z_ok += usize::from(all_z);
            let app_name = match app {
                PhoneApp::Phyphox => "phyphox",
                PhoneApp::SensorLogger => "Sensor Logger",
            };
            println!(
                "| {seed} | {app_name} | {} | {} | {gyro} | {} | {seconds:.1} |",
                cells.first().map_or("—", String::as_str),
                cells.get(1).map_or("—", String::as_str),
                output.result.saved.as_deref().unwrap_or("nothing"),
            );
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
    println!(
        "\nradius within 2 mm: {radius_ok}/{cases}; within 3 standard errors: {z_ok}/{cases}; gyro scale within 0.1 %: {scale_ok}/{cases}"
    );
    println!(
        "worst: radius error {:.2} mm, {:.2} standard errors; gyro scale error {:.3} %",
        1e3 * worst.0,
        worst.1,
        worst.2
    );
}

/// A fresh folder under the system's temporary directory for one seed and app.
fn tempfile_dir(seed: u64, app: PhoneApp) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "spincal-phone-sessions-{}-{seed}-{app:?}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}
