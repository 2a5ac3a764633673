//! The free parameters' table: units, bounds and starting values, shared ones first, and the
//! problem built from it.

use super::options::{DriftMode, FitError, FitOptions};
use super::pieces::Pieces;
use super::problem::{ParamDef, Problem, Role};
use super::start::{wrap_angle, FirstLook};
use crate::input::recording::Recording;
use crate::turntable::moments::CostMoments;

/// Every free parameter with its unit, bounds and starting value: shared ones first (β, offsets,
/// a shared radius), then each recording's (a phase per piece of a recording cut at a gap); the
/// user's `--bounds` replace the defaults.
pub(super) fn parameter_table(
    recordings: &[&Recording],
    options: &FitOptions,
    looks: &[FirstLook],
    pieces: &Pieces,
) -> Result<Vec<ParamDef>, FitError> {
    let mut defs = shared_parameters(options, looks);
    for k in 0..recordings.len() {
        defs.extend(recording_parameters(k, recordings, options, looks, pieces));
    }
    for (name, lower, upper) in &options.bounds {
        let Some(def) = defs.iter_mut().find(|d| &d.name == name) else {
            let names: Vec<&str> = defs.iter().map(|d| d.name.as_str()).collect();
            return Err(FitError::UnknownParameter(name.clone(), names.join(", ")));
        };
        def.lower = *lower;
        def.upper = *upper;
        def.start = def.start.clamp(lower.min(*upper), upper.max(*lower));
    }
    Ok(defs)
}

/// The radius's bounds: ±10 tolerances around a measured radius, else 0–0.5 m.
fn radius_bounds(options: &FitOptions) -> (f64, f64) {
    match options.radius {
        Some(p) => (
            (p.value_m - 10.0 * p.tolerance_m).max(0.0),
            p.value_m + 10.0 * p.tolerance_m,
        ),
        None => (0.0, 0.5),
    }
}

/// The measured radius, else the one the mean levels imply (ω²r from the x and y means).
fn radius_start(options: &FitOptions, look: &FirstLook) -> f64 {
    options.radius.map(|p| p.value_m).unwrap_or_else(|| {
        let s = &look.start;
        (s.mean[0].hypot(s.mean[1]) / look.rate.omega_radps.powi(2)).clamp(0.002, 0.49)
    })
}

/// β's start: the first recording's mean levels are ω²r cos β + b_x and ω²r sin β + b_y, taken
/// with zero offsets.
pub(super) fn beta_start(looks: &[FirstLook]) -> f64 {
    let s0 = &looks[0].start;
    s0.mean[1].atan2(s0.mean[0])
}

/// β, the sensor offsets and (when shared) the radius.
fn shared_parameters(options: &FitOptions, looks: &[FirstLook]) -> Vec<ParamDef> {
    let g = options.gravity_mps2;
    let pi = std::f64::consts::PI;
    let mut defs = vec![ParamDef {
        name: "beta".into(),
        unit: "rad",
        role: Role::Beta,
        lower: -2.0 * pi,
        upper: 2.0 * pi,
        start: beta_start(looks),
    }];
    if options.fit_offsets {
        for &a in options.axes.axes() {
            defs.push(ParamDef {
                name: format!("offset_{}", ['x', 'y', 'z'][a]),
                unit: "m/s²",
                role: Role::Offset(a),
                lower: -0.5 * g,
                upper: 0.5 * g,
                start: 0.0,
            });
        }
    }
    if options.shared_radius {
        let (lower, upper) = radius_bounds(options);
        defs.push(ParamDef {
            name: "radius".into(),
            unit: "m",
            role: Role::Radius(None),
            lower,
            upper,
            start: radius_start(options, &looks[0]),
        });
    }
    defs
}

/// Recording `k`'s own parameters: its radius (when not shared), ω, tilt, phase (one per piece)
/// and drift.
fn recording_parameters(
    k: usize,
    recordings: &[&Recording],
    options: &FitOptions,
    looks: &[FirstLook],
    pieces: &Pieces,
) -> Vec<ParamDef> {
    let g = options.gravity_mps2;
    let pi = std::f64::consts::PI;
    let suffix = if recordings.len() > 1 {
        format!("[{}]", k + 1)
    } else {
        String::new()
    };
    let (s, w) = (&looks[k].start, looks[k].rate.omega_radps);
    let beta0 = beta_start(looks);
    let axes = options.axes.axes();
    let mut defs = Vec::new();
    if !options.shared_radius {
        let (lower, upper) = radius_bounds(options);
        defs.push(ParamDef {
            name: format!("radius{suffix}"),
            unit: "m",
            role: Role::Radius(Some(k)),
            lower,
            upper,
            start: radius_start(options, &looks[k]),
        });
    }
    defs.push(ParamDef {
        name: format!("omega{suffix}"),
        unit: "rad/s",
        role: Role::Omega(k),
        lower: 0.97 * w,
        upper: 1.03 * w,
        start: w,
    });
    // Amplitude A = g sin α; x = A sin(u): sin-coefficient A cos(φ−β), cos-coefficient A sin(φ−β).
    let amplitude = if axes.contains(&1) {
        0.5 * (s.sin[0].hypot(s.cos[0]) + s.sin[1].hypot(s.cos[1]))
    } else {
        s.sin[0].hypot(s.cos[0])
    };
    defs.push(ParamDef {
        name: format!("tilt{suffix}"),
        unit: "rad",
        role: Role::Tilt(k),
        lower: 0.0,
        upper: 30f64.to_radians(),
        start: (amplitude / g).clamp(0.0, 0.49).asin(),
    });
    let own: Vec<usize> = (0..pieces.recording_of.len())
        .filter(|&piece| pieces.recording_of[piece] == k)
        .collect();
    for (j, &piece) in own.iter().enumerate() {
        let name = if own.len() > 1 {
            format!("phase{suffix}_segment{}", j + 1)
        } else {
            format!("phase{suffix}")
        };
        defs.push(ParamDef {
            name,
            unit: "rad",
            role: Role::Phase(piece),
            lower: -2.0 * pi,
            upper: 2.0 * pi,
            start: pieces.phase_start[piece].unwrap_or_else(|| wrap_angle(s.cos[0].atan2(s.sin[0]) + beta0)),
        });
    }
    if options.drift == DriftMode::Fit {
        let span = recordings[k].duration_s();
        for &a in axes {
            defs.push(ParamDef {
                name: format!("drift_{}{suffix}", ['x', 'y', 'z'][a]),
                unit: "m/s³",
                role: Role::Drift(k, a),
                lower: -0.2 * g / span,
                upper: 0.2 * g / span,
                start: 0.0,
            });
        }
    }
    defs
}

/// The least-squares problem over the pieces: residuals weighted by each recording's noise, the
/// radius prior, and the per-block moments that make Nelder–Mead's cost O(blocks) (for whole
/// recordings; a cut recording's pieces keep its drift origin, which the moments do not know).
pub(super) fn build_problem<'a>(
    pieces: &'a [&'a Recording],
    recording_of: Vec<usize>,
    drift_origin: Vec<Option<f64>>,
    options: &FitOptions,
    looks: &[FirstLook],
    defs: Vec<ParamDef>,
) -> Problem<'a> {
    let prior = options.radius.and_then(|p| {
        defs.iter()
            .position(|d| matches!(d.role, Role::Radius(_)))
            .map(|i| (i, p))
    });
    Problem {
        recordings: pieces,
        directions: recording_of.iter().map(|&k| looks[k].direction).collect(),
        axes: options.axes.axes(),
        weights: recording_of
            .iter()
            .map(|&k| looks[k].start.noise.map(|v| 1.0 / v))
            .collect(),
        gravity: options.gravity_mps2,
        prior,
        moments: (0..pieces.len())
            .map(|piece| {
                if drift_origin[piece].is_some() {
                    return None;
                }
                let omega = defs.iter().find(|d| d.role == Role::Omega(recording_of[piece]))?;
                let centre = 0.5 * (omega.lower + omega.upper);
                CostMoments::new(pieces[piece], centre, 0.5 * (omega.upper - omega.lower).abs())
            })
            .collect(),
        recording_of,
        drift_origin,
        defs,
    }
}
