//! `spincal sensitivity`: the paper's Table 1 for any nominal values.

use clap::Args;
use spincal::input::recording::STANDARD_GRAVITY;
use spincal::turntable::sensitivity::{sensitivity_table, SensitivityInput};

use crate::ui::{self, UsageError};

#[derive(Args, Debug)]
#[command(after_help = "Example (the paper's Table 1, with its rounded ω and g):\n  \
                        spincal sensitivity --radius 0.10 --tilt-deg 5 --omega 3.49 --gravity 9.81 --vary 15")]
pub struct SensitivityArgs {
    /// Sensor distance from the spindle, m.
    #[arg(long, default_value_t = 0.10, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub radius: f64,
    /// Platter tilt, deg.
    #[arg(long, default_value_t = 5.0, value_parser = super::values::finite, allow_negative_numbers = true)]
    pub tilt_deg: f64,
    /// Speed, rpm (ignored when --omega is given).
    #[arg(long, default_value_t = 33.3, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub rpm: f64,
    /// Speed, rad/s.
    #[arg(long, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub omega: Option<f64>,
    /// Sensor x axis from the radial direction, deg.
    #[arg(long, default_value_t = 0.0, value_parser = super::values::finite, allow_negative_numbers = true)]
    pub beta_deg: f64,
    /// Local gravity, m/s².
    #[arg(long, default_value_t = STANDARD_GRAVITY, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub gravity: f64,
    /// Change applied to each parameter, ± %.
    #[arg(long, default_value_t = 15.0, value_parser = super::values::positive, allow_negative_numbers = true)]
    pub vary: f64,
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: SensitivityArgs) -> anyhow::Result<()> {
    if !(args.vary > 0.0 && args.vary < 100.0) {
        return Err(UsageError(format!("--vary {}: expected a percentage in (0, 100)", args.vary)).into());
    }
    let omega = args.omega.unwrap_or(args.rpm * 2.0 * std::f64::consts::PI / 60.0);
    let rows = sensitivity_table(&SensitivityInput {
        radius_m: args.radius,
        tilt_rad: args.tilt_deg.to_radians(),
        omega_radps: omega,
        beta_rad: args.beta_deg.to_radians(),
        gravity_mps2: args.gravity,
        vary: args.vary / 100.0,
    });
    if args.json {
        return ui::print_json(&rows);
    }
    let mut text = format!(
        "r = {} m, α = {}°, ω = {:.4} rad/s ({:.3} rpm), β = {}°, g = {} m/s²; each parameter ±{}%\n\n",
        args.radius,
        args.tilt_deg,
        omega,
        omega * 60.0 / (2.0 * std::f64::consts::PI),
        args.beta_deg,
        args.gravity,
        args.vary
    );
    text.push_str("parameter  change        value      mean a_x (g)  ampl. a_x (g)  ampl. a_y (g)\n");
    for r in &rows {
        text.push_str(&format!(
            "{:<9} {:>+6.1}% {:>10.4} {:<5} {:>12.4} {:>14.4} {:>14.4}\n",
            r.parameter, r.change_pct, r.value, r.unit, r.mean_ax_g, r.amplitude_ax_g, r.amplitude_ay_g
        ));
    }
    ui::print(&text)
}
