//! `spincal simulate`: a 3DM-GX1-like sensor on a turntable, with a JSON sidecar of the truth.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use spincal::input::recording::AccelUnit;
use spincal::simulate::{simulate, SensorProfile, TurntableSetup};
use spincal::turntable::model::Direction;

use super::values::{AccelUnitArg, DirectionArg};
use crate::ui::{self, UsageError};

#[derive(Args, Debug)]
#[command(
    after_help = "Examples:\n  spincal simulate -o rec33.csv --rpm 33.333 --radius 0.10 --tilt-deg 1.5 --seed 7\n  \
                        writes rec33.csv (t_s, ax_g, ay_g, az_g) and rec33.truth.json\n  \
                        spincal simulate --campaign unit7 --seed 7\n  \
                        writes unit7/campaign.toml, still poses and turntable runs with their true specific force\n  \
                        spincal simulate --fleet 8 --faulty 3 --out fleet8 --seed 7\n  \
                        writes fleet8/unit-01 … unit-08 (campaign folders, each unit with its own sensor errors;\n  \
                        unit-03 with +0.1 g bias on x and +5 % scale error on y) and fleet8/fleet-truth.json\n  \
                        spincal simulate --thermal warm7 --seed 7\n  \
                        writes warm7/: a warm-up, still poses and held-out poses through 25 °C warm-ups, each\n  \
                        with the temperature as a lagging 1 °C sensor reports it, their truth and truth.json\n  \
                        spincal simulate --phone phone7 --seed 7\n  \
                        writes phone7/: a phone's still poses and turntable runs as phyphox zips, campaign.toml\n  \
                        (no radius: the chip's is found) and truth.json"
)]
pub struct SimulateArgs {
    /// Output CSV.
    #[arg(short, long, required_unless_present_any = ["campaign", "fleet", "thermal", "phone"])]
    pub output: Option<PathBuf>,
    /// Write a whole campaign of one unit into this folder instead (campaign.toml, still poses and
    /// turntable runs in m/s², each with its true specific force, and truth.json).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["output", "fleet"])]
    pub campaign: Option<PathBuf>,
    /// Write a thermal campaign into this folder instead: a unit whose bias and gain follow its
    /// die temperature, recorded through three warm-ups from a cold start (a still warm-up, still
    /// poses, held-out poses in random orientations), with the temperature as its sensor reports
    /// it (lagging, in whole degrees), the truth per sample, truth.json and campaign.toml (the
    /// warm-up and the poses, for `calibrate --campaign`). --setup takes the ThermalProfile as
    /// JSON (coefficient ranges, warm-up, sensor lag and resolution).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["output", "fleet", "campaign"])]
    pub thermal: Option<PathBuf>,
    /// Write a phone session into this folder instead: still poses (six at about 45°) and
    /// turntable runs at 33⅓ and 45 rpm in two placements (the phone turned 180°), the platter 1 %
    /// fast, each recording a phyphox simple-experiment zip (accelerometer at 100 Hz and gyroscope
    /// at 200 Hz on their own jittered clocks, a consumer part's errors and noise), the chip off the
    /// phone's centre; campaign.toml states no radius, truth.json holds the chip's. --setup takes
    /// the PhoneSetup as JSON (`"app": "sensor-logger"` writes Sensor Logger zips).
    #[arg(long, value_name = "DIR", conflicts_with_all = ["output", "fleet", "campaign", "thermal"])]
    pub phone: Option<PathBuf>,
    /// Write a fleet of N units into --out DIR instead: one campaign folder per unit (unit-01, …),
    /// each unit's sensor drawn around the default one (bias sd 0.005 g, scale error sd 0.3 %,
    /// misalignment sd 0.2° per axis), and fleet-truth.json.
    #[arg(long, value_name = "N", conflicts_with = "output", requires = "out", value_parser = clap::value_parser!(u64).range(1..=10000))]
    pub fleet: Option<u64>,
    /// With --fleet: the folder the unit folders go into.
    #[arg(long, value_name = "DIR", requires = "fleet")]
    pub out: Option<PathBuf>,
    /// With --fleet: units made faulty (+0.1 g bias on x, +5 % scale error on y), numbered from 1
    /// as their folders (unit-03 is 3); comma-separated.
    #[arg(long, value_name = "K", requires = "fleet", value_delimiter = ',')]
    pub faulty: Vec<usize>,
    /// With --campaign or --fleet: the campaign setup as JSON (fields of CampaignSetup; defaults
    /// otherwise); with --thermal a ThermalProfile, with --phone a PhoneSetup.
    #[arg(long)]
    pub setup: Option<PathBuf>,
    /// Truth sidecar (default: the output name with .truth.json).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Random seed: the same seed gives the same file.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Sensor profile JSON (fields of SensorProfile; missing ones take the 3DM-GX1 defaults).
    #[arg(long)]
    pub sensor: Option<PathBuf>,
    /// A perfect sensor apart from bias, noise and quantisation.
    #[arg(long)]
    pub ideal: bool,
    /// Nominal speed, rpm.
    #[arg(long, default_value_t = 100.0 / 3.0, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub rpm: f64,
    /// Sensor distance from the spindle, m.
    #[arg(long, default_value_t = 0.10, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub radius: f64,
    /// Platter tilt, deg.
    #[arg(long, default_value_t = 1.0, value_parser = super::values::finite, allow_negative_numbers = true)]
    pub tilt_deg: f64,
    /// Downhill direction relative to the sensor at t = 0, deg.
    #[arg(long, default_value_t = 30.0, value_parser = super::values::finite, allow_negative_numbers = true)]
    pub tilt_azimuth_deg: f64,
    /// Sensor x axis from the radial direction, deg.
    #[arg(long, default_value_t = 3.0, value_parser = super::values::finite, allow_negative_numbers = true)]
    pub beta_deg: f64,
    /// Sense of rotation seen from above: cw (record players) or ccw.
    #[arg(long, value_enum, default_value = "cw")]
    pub direction: DirectionArg,
    /// Steady speed error, %.
    #[arg(long, default_value_t = 0.5, value_parser = super::values::finite, allow_negative_numbers = true)]
    pub speed_error_pct: f64,
    /// Wow, % peak (once per revolution).
    #[arg(long, default_value_t = 0.1, value_parser = super::values::non_negative, allow_negative_numbers = true)]
    pub wow_pct: f64,
    /// Flutter, % peak, at 6 Hz.
    #[arg(long, default_value_t = 0.05, value_parser = super::values::non_negative, allow_negative_numbers = true)]
    pub flutter_pct: f64,
    /// Recording length, s.
    #[arg(long, default_value_t = 60.0, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub duration: f64,
    /// Sample rate, Hz (overrides the profile).
    #[arg(long, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// White noise, g RMS (overrides the profile).
    #[arg(long, value_parser = super::values::non_negative, allow_negative_numbers = true)]
    pub noise_g: Option<f64>,
    /// Unit written to the CSV: g or mps2.
    #[arg(long, value_enum, default_value = "g")]
    pub unit: AccelUnitArg,
    /// Print a JSON summary instead of text.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: SimulateArgs) -> anyhow::Result<()> {
    if let (Some(units), Some(out)) = (args.fleet, &args.out) {
        return super::fleet::simulate(
            units as usize,
            out,
            args.seed,
            &args.faulty,
            args.setup.as_deref(),
            args.json,
        );
    }
    if let Some(dir) = &args.thermal {
        return simulate_thermal(dir, args.seed, args.setup.as_deref(), args.json);
    }
    if let Some(dir) = &args.phone {
        return super::phone::simulate(dir, args.seed, args.setup.as_deref(), args.json);
    }
    if args.setup.is_some() && args.campaign.is_none() {
        return Err(UsageError("--setup needs --campaign, --fleet, --thermal or --phone".into()).into());
    }
    if let Some(dir) = &args.campaign {
        return super::campaign::simulate(dir, args.seed, args.setup.as_deref(), args.json);
    }
    let Some(output) = args.output.clone() else {
        return Err(UsageError("give -o FILE (or --campaign DIR)".into()).into());
    };
    let mut sensor = match &args.sensor {
        Some(path) => super::values::read_json_file::<SensorProfile>(path, "a sensor profile")?,
        None if args.ideal => SensorProfile::ideal(),
        None => SensorProfile::default(),
    };
    if let Some(rate) = args.rate {
        sensor.sample_rate_hz = rate;
    }
    if let Some(noise) = args.noise_g {
        sensor.noise_g = noise;
    }
    let direction: Direction = args.direction.into();
    let unit: AccelUnit = args.unit.into();
    let table = TurntableSetup {
        radius_m: args.radius,
        rpm: args.rpm,
        tilt_deg: args.tilt_deg,
        tilt_azimuth_deg: args.tilt_azimuth_deg,
        beta_deg: args.beta_deg,
        direction,
        speed_error_pct: args.speed_error_pct,
        wow_pct: args.wow_pct,
        flutter_pct: args.flutter_pct,
        duration_s: args.duration,
        ..TurntableSetup::default()
    };
    let truth_path = args
        .truth
        .clone()
        .unwrap_or_else(|| output.with_extension("truth.json"));
    let sensor_file: Vec<&std::path::Path> = args.sensor.iter().map(|p| p.as_path()).collect();
    super::check_outputs(&sensor_file, &[&output, &truth_path])?;
    let sim = simulate(&sensor, &table, args.seed).map_err(|e| UsageError(e.to_string()))?;
    sim.recording.write_csv_path(&output, unit)?;
    let truth = spincal::simulate::truth_json(&sim.truth, &output)
        .with_context(|| format!("reading back {}", output.display()))?;
    super::write_text(&truth_path, &truth)?;
    if args.json {
        return ui::print_json(&serde_json::json!({
            "recording": output,
            "truth": truth_path,
            "samples": sim.recording.len(),
            "saturated_samples": sim.truth.saturated_samples,
        }));
    }
    ui::print(&format!(
        "wrote {} ({} samples at {} Hz, {:.1} s; {} saturated) and {}\n",
        output.display(),
        sim.recording.len(),
        sensor.sample_rate_hz,
        sim.recording.duration_s(),
        sim.truth.saturated_samples,
        truth_path.display()
    ))
}

fn simulate_thermal(
    dir: &std::path::Path,
    seed: u64,
    setup: Option<&std::path::Path>,
    json: bool,
) -> anyhow::Result<()> {
    use spincal::simulate::thermal::{simulate_thermal_campaign, ThermalProfile};
    let profile: ThermalProfile = super::values::read_json_or_default(setup, "a thermal profile")?;
    profile.check().map_err(|e| UsageError(e.to_string()))?;
    let campaign = simulate_thermal_campaign(&profile, seed);
    match campaign.write_folder(dir, seed, &profile) {
        Err(e @ spincal::simulate::fleet::WriteError::Exists { .. }) => {
            return Err(UsageError(e.to_string()).into())
        }
        Err(e) => return Err(e.into()),
        Ok(()) => {}
    }
    let files = 1 + campaign.poses.len() + campaign.held_out.len();
    if json {
        return ui::print_json(&serde_json::json!({
            "folder": dir,
            "recordings": files,
            "truth": dir.join("truth.json"),
            "campaign": dir.join("campaign.toml"),
        }));
    }
    ui::print(&format!(
        "wrote {}: warmup-00.csv, {} still poses and {} held-out poses (t_s, ax/ay/az_mps2, temp_c as reported), each with its .truth.csv (true force, die temperature), truth.json and campaign.toml (calibrate it with `spincal calibrate --campaign {}`)\n",
        dir.display(),
        campaign.poses.len(),
        campaign.held_out.len(),
        dir.join("campaign.toml").display()
    ))
}
