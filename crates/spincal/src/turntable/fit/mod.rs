//! Fitting the turntable model to one or more recordings (SPEC §2, issue "foundation" point 6).
//!
//! Stages: rotation rate from the spectrum → a linear sinusoid fit at that rate per axis (starting
//! values, sense of rotation, noise level per axis) → bounded Nelder–Mead on the noise-weighted
//! squared error of the chosen axes (the paper's fminsearchbnd step) → Levenberg–Marquardt polish
//! with the analytic Jacobian → standard errors, correlations, and which parameters the data did
//! not determine (null directions of the column-scaled JᵀJ).
//!
//! Parameters: shared by all recordings: β and the three offsets (the sensor and its mounting);
//! per recording: r (or one shared r), ω, α, φ and, when fitted, a drift per axis. A recording
//! with a logging gap longer than two revolutions is cut there, each piece with its own φ
//! (`turntable::segments`).

use std::borrow::Cow;

use crate::input::inspect::{inspect, saturated_mask};
use crate::input::recording::Recording;
use crate::optim::{
    levenberg_marquardt_normal, nelder_mead_bounded, Bounds, LmOptions, LmReport, NelderMeadOptions,
    NelderMeadReport,
};
use crate::progress::Observer;
use findings::{drift_findings, estimates, recording_fits, remedy_for};
use parameters::{build_problem, parameter_table};
use pieces::cut_at_gaps;
use problem::Problem;
use start::first_look;

mod findings;
mod options;
mod parameters;
mod pieces;
mod problem;
mod result;
mod start;

pub use options::{AxesObjective, DriftMode, FitError, FitOptions, RadiusPrior};
pub use result::{
    parse_bounds, BoundsError, DriftFinding, FittedParam, RecordingFit, SegmentPhase, TurntableFit,
};

/// Fits the turntable model to the recordings jointly: a first look at each recording (rate,
/// sinusoid start, inspection), the parameter table, bounded Nelder–Mead on the moment cost, the
/// Levenberg–Marquardt polish on the exact residuals, then standard errors, identifiability, drift
/// findings and per-recording fits.
pub fn fit_turntable(
    recordings: &[&Recording],
    options: &FitOptions,
    observer: &Observer,
) -> Result<TurntableFit, FitError> {
    check_request(recordings, options)?;
    // Saturated samples carry the rail, not the motion: they are reported, then left out.
    let unsaturated: Vec<Cow<Recording>> = recordings
        .iter()
        .map(|rec| {
            let saturated = saturated_mask(rec, options.range_mps2);
            if saturated.iter().any(|s| *s) {
                Cow::Owned(rec.select(&saturated.iter().map(|s| !s).collect::<Vec<_>>()))
            } else {
                Cow::Borrowed(*rec)
            }
        })
        .collect();
    let looks = recordings
        .iter()
        .zip(&unsaturated)
        .map(|(rec, clean)| first_look(clean, inspect(rec, options.range_mps2), options))
        .collect::<Result<Vec<_>, _>>()?;
    let recordings: Vec<&Recording> = unsaturated.iter().map(|r| r.as_ref()).collect();
    let recordings = recordings.as_slice();
    let pieces = cut_at_gaps(recordings, &looks)?;
    let defs = parameter_table(recordings, options, &looks, &pieces)?;
    let bounds = Bounds {
        names: defs.iter().map(|d| d.name.clone()).collect(),
        lower: defs.iter().map(|d| d.lower).collect(),
        upper: defs.iter().map(|d| d.upper).collect(),
    };
    bounds.validate()?;
    let piece_refs: Vec<&Recording> = pieces.recordings.iter().map(|r| r.as_ref()).collect();
    let problem = build_problem(
        &piece_refs,
        pieces.recording_of.clone(),
        pieces.drift_origin.clone(),
        options,
        &looks,
        defs,
    );
    let start: Vec<f64> = problem.defs.iter().map(|d| d.start).collect();
    let (nm, lm) = solve(&problem, &start, &bounds, options, observer)?;
    let estimates = estimates(&problem, &bounds, &lm);
    let undetermined: Vec<String> = estimates
        .params
        .iter()
        .filter(|p| !p.determined)
        .map(|p| p.name.clone())
        .collect();
    let remedy = remedy_for(&undetermined, recordings.len(), options);
    let (mounting, sessions) = problem.unpack(&estimates.values);
    let drift = drift_findings(&problem, &estimates, recordings);
    let recording_fits = recording_fits(&problem, recordings, &looks, &sessions, &mounting);
    Ok(TurntableFit {
        gravity_mps2: options.gravity_mps2,
        axes: options.axes,
        mounting,
        recordings: recording_fits,
        params: estimates.params,
        correlation: estimates.correlation,
        undetermined,
        remedy,
        drift,
        cost_nelder_mead: nm.cost,
        cost_final: lm.sse,
        nelder_mead_iterations: nm.iterations,
        lm_iterations: lm.iterations,
        lm_stop: lm.stop,
        noise_mps2: looks.iter().map(|l| l.start.noise).collect(),
        start,
        split_recordings: pieces.cut,
    })
}

/// At least one recording and a radius prior that makes sense.
fn check_request(recordings: &[&Recording], options: &FitOptions) -> Result<(), FitError> {
    if recordings.is_empty() {
        return Err(FitError::NoRecordings);
    }
    if let Some(prior) = options.radius {
        if !(prior.tolerance_m > 0.0 && (0.0..=2.0).contains(&prior.value_m)) {
            return Err(FitError::BadRadius {
                value_m: prior.value_m,
                tolerance_m: prior.tolerance_m,
            });
        }
    }
    Ok(())
}

/// Bounded Nelder–Mead from the start, then the Levenberg–Marquardt polish.
fn solve(
    problem: &Problem,
    start: &[f64],
    bounds: &Bounds,
    options: &FitOptions,
    observer: &Observer,
) -> Result<(NelderMeadReport, LmReport), FitError> {
    let nm_options = NelderMeadOptions {
        tol_f: if options.nelder_mead.tol_f > 0.0 {
            options.nelder_mead.tol_f
        } else {
            1e-9 * problem.cost(start)
        },
        ..options.nelder_mead.clone()
    };
    let nm = nelder_mead_bounded(&mut |p| problem.cost(p), start, bounds, &nm_options, &|pr| {
        observer(pr.in_stage("turntable fit: Nelder–Mead"))
    })?;
    let lm_options = LmOptions {
        lower: Some(bounds.lower.clone()),
        upper: Some(bounds.upper.clone()),
        ..options.lm.clone()
    };
    let lm = levenberg_marquardt_normal(problem, &nm.params, None, &lm_options, &|pr| {
        observer(pr.in_stage("turntable fit: Levenberg–Marquardt"))
    });
    if lm.params.iter().any(|v| !v.is_finite()) {
        return Err(FitError::NotFinite {
            file: problem.recordings[0].source.name.clone(),
        });
    }
    Ok((nm, lm))
}

#[cfg(test)]
mod tests {
    use super::start::FirstLook;
    use super::*;
    use crate::input::recording::STANDARD_GRAVITY;
    use crate::optim::NormalEquations;
    use crate::turntable::model::{evaluate, Direction, Mounting, Session};
    use faer::Mat;

    /// 20 s at 100 Hz of the model itself plus deterministic pseudo-noise (a hash of the index;
    /// the simulator lives above this module).
    fn recording(rpm: f64, phase: f64) -> Recording {
        let session = Session {
            radius_m: 0.1,
            omega_radps: rpm * std::f64::consts::TAU / 60.0,
            tilt_rad: 0.02,
            phase_rad: phase,
            direction: Direction::Cw,
            drift_mps2_per_s: [1e-4, -2e-4, 5e-5],
        };
        let mounting = Mounting {
            beta_rad: 0.05,
            offset_mps2: [0.03, -0.02, 0.05],
        };
        let time_s: Vec<f64> = (0..2000).map(|i| i as f64 * 0.01).collect();
        let mut accel = [Vec::new(), Vec::new(), Vec::new()];
        evaluate(&session, &mounting, STANDARD_GRAVITY, &time_s, &mut accel);
        for (k, axis) in accel.iter_mut().enumerate() {
            for (i, v) in axis.iter_mut().enumerate() {
                let h = ((i * 3 + k) as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 11;
                *v += 0.02 * (h as f64 / (1u64 << 53) as f64 - 0.5);
            }
        }
        Recording {
            time_s,
            accel_mps2: accel,
            gyro_radps: None,
            temperature_c: None,
            source: Default::default(),
        }
    }

    /// The residual vector, as the whole-Jacobian formulation had it (recording, axis, sample).
    fn residual_vector(problem: &Problem, p: &[f64]) -> Vec<f64> {
        let (mounting, sessions) = problem.unpack(p);
        let mut out = Vec::new();
        for (k, rec) in problem.recordings.iter().enumerate() {
            let mut model = [Vec::new(), Vec::new(), Vec::new()];
            evaluate(&sessions[k], &mounting, problem.gravity, &rec.time_s, &mut model);
            for &a in problem.axes {
                let w = problem.weights[k][a];
                out.extend(model[a].iter().zip(&rec.accel_mps2[a]).map(|(m, x)| w * (m - x)));
            }
        }
        if let Some((index, prior)) = problem.prior {
            out.push((p[index] - prior.value_m) / prior.tolerance_m);
        }
        out
    }

    #[test]
    fn streamed_normal_equations_equal_those_of_the_whole_jacobian() {
        let a = recording(33.333, 0.4);
        let b = recording(45.0, 1.9);
        let recordings = [&a, &b];
        let options = FitOptions {
            radius: Some(RadiusPrior {
                value_m: 0.1,
                tolerance_m: 0.002,
            }),
            ..FitOptions::default()
        };
        let looks: Vec<FirstLook> = recordings
            .iter()
            .map(|r| first_look(r, inspect(r, None), &options).unwrap())
            .collect();
        let pieces = cut_at_gaps(&recordings, &looks).unwrap();
        let defs = parameter_table(&recordings, &options, &looks, &pieces).unwrap();
        let problem = build_problem(&recordings, vec![0, 1], vec![None, None], &options, &looks, defs);
        let n = problem.defs.len();
        // Away from the start, so every derivative matters.
        let p: Vec<f64> = problem
            .defs
            .iter()
            .enumerate()
            .map(|(i, d)| d.start + 1e-3 * (i as f64 + 1.0) * (d.upper - d.lower).abs().min(1.0))
            .collect();
        let mut jtj = Mat::zeros(n, n);
        let mut jtr = vec![0.0; n];
        let sse = problem.normal_equations(&p, &mut jtj, &mut jtr);
        let r = residual_vector(&problem, &p);
        let expected_sse: f64 = r.iter().map(|v| v * v).sum();
        assert!((sse / expected_sse - 1.0).abs() < 1e-12);
        assert!((problem.sse(&p) / expected_sse - 1.0).abs() < 1e-12);
        // Central differences of the residual vector give the Jacobian column by column.
        let columns: Vec<Vec<f64>> = (0..n)
            .map(|k| {
                let h = 1e-6 * p[k].abs().max(1e-3);
                let (mut up, mut down) = (p.clone(), p.clone());
                up[k] += h;
                down[k] -= h;
                let (ru, rd) = (residual_vector(&problem, &up), residual_vector(&problem, &down));
                ru.iter().zip(&rd).map(|(u, d)| (u - d) / (2.0 * h)).collect()
            })
            .collect();
        for i in 0..n {
            let g: f64 = columns[i].iter().zip(&r).map(|(j, r)| j * r).sum();
            let scale = jtr[i].abs().max(1.0);
            assert!((jtr[i] - g).abs() < 1e-5 * scale, "Jᵀr[{i}] {} vs {g}", jtr[i]);
            for k in 0..n {
                let h: f64 = columns[i].iter().zip(&columns[k]).map(|(a, b)| a * b).sum();
                let scale = (jtj[(i, i)] * jtj[(k, k)]).sqrt().max(1e-300);
                assert!(
                    (jtj[(i, k)] - h).abs() < 1e-5 * scale,
                    "JᵀJ[{i},{k}] {} vs {h}",
                    jtj[(i, k)]
                );
            }
        }
    }
}
