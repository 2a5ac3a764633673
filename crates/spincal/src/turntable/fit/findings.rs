//! What a finished fit found: estimates with standard errors and correlations, drift, each
//! recording's fit, the covariance and which parameters the data left undetermined.

use faer::{Mat, Side};

use super::options::FitOptions;
use super::problem::{Problem, Role};
use super::result::{DriftFinding, FittedParam, RecordingFit, SegmentPhase};
use super::start::{wrap_angle, FirstLook};
use crate::input::recording::{Recording, STANDARD_GRAVITY};
use crate::metrics::FitSums;
use crate::optim::{Bounds, LmReport, NormalEquations};
use crate::turntable::model::{for_each_sample_about, Mounting, Session};

/// The fitted values (angles wrapped) with standard errors and correlations.
pub(super) struct Estimates {
    pub(super) values: Vec<f64>,
    pub(super) params: Vec<FittedParam>,
    pub(super) correlation: Vec<Vec<f64>>,
}

/// Standard errors from σ²(JᵀJ)⁺; parameters in null directions of the scaled JᵀJ are reported as
/// not determined, with no standard error and NaN correlations.
pub(super) fn estimates(problem: &Problem, bounds: &Bounds, lm: &LmReport) -> Estimates {
    let dof = (problem.n_residuals() as f64 - problem.n_params() as f64).max(1.0);
    let (covariance, null_params) = covariance(&lm.jtj, lm.sse / dof);
    let mut params = Vec::new();
    let mut values = lm.params.clone();
    for (i, def) in problem.defs.iter().enumerate() {
        let determined = !null_params[i];
        let at_bound = bounds.at_bound(i, values[i]);
        if matches!(def.role, Role::Beta | Role::Phase(_)) {
            values[i] = wrap_angle(values[i]);
        }
        params.push(FittedParam {
            name: def.name.clone(),
            value: values[i],
            std_error: determined.then(|| covariance[(i, i)].max(0.0).sqrt()),
            unit: def.unit.to_string(),
            lower: def.lower,
            upper: def.upper,
            at_bound,
            determined,
        });
    }
    let correlation = (0..values.len())
        .map(|i| {
            (0..values.len())
                .map(|j| {
                    if null_params[i] || null_params[j] {
                        f64::NAN
                    } else {
                        covariance[(i, j)] / (covariance[(i, i)] * covariance[(j, j)]).sqrt()
                    }
                })
                .collect()
        })
        .collect();
    Estimates {
        values,
        params,
        correlation,
    }
}

/// Each drift term as a change over its recording; significant beyond 5 standard errors and 1 mg.
pub(super) fn drift_findings(
    problem: &Problem,
    estimates: &Estimates,
    recordings: &[&Recording],
) -> Vec<DriftFinding> {
    let mut drift = Vec::new();
    for (i, def) in problem.defs.iter().enumerate() {
        if let Role::Drift(k, a) = def.role {
            let span = recordings[k].duration_s();
            let se = estimates.params[i].std_error.unwrap_or(f64::NAN) * span;
            let change = estimates.values[i] * span;
            drift.push(DriftFinding {
                recording: k,
                axis: ['x', 'y', 'z'][a],
                change_mps2: change,
                std_error_mps2: se,
                significant: change.abs() > 5.0 * se && change.abs() > 1e-3 * STANDARD_GRAVITY,
            });
        }
    }
    drift
}

/// The fitted model against each recording (over its pieces): fit % and residual RMS per axis,
/// and a cut recording's phase per segment.
pub(super) fn recording_fits(
    problem: &Problem,
    recordings: &[&Recording],
    looks: &[FirstLook],
    sessions: &[Session],
    mounting: &Mounting,
) -> Vec<RecordingFit> {
    let mut fits = Vec::new();
    for (k, rec) in recordings.iter().enumerate() {
        let pieces: Vec<usize> = (0..problem.recordings.len())
            .filter(|&piece| problem.recording_of[piece] == k)
            .collect();
        // The model is compared sample by sample, never stored (it would be as large as the
        // recording).
        let mut sums = [0, 1, 2].map(|a| FitSums::new(&rec.accel_mps2[a]));
        for &piece in &pieces {
            let data = problem.recordings[piece];
            let origin = problem.drift_origin[piece];
            for_each_sample_about(
                &sessions[piece],
                mounting,
                problem.gravity,
                &data.time_s,
                origin,
                |i, model| {
                    for (a, sums) in sums.iter_mut().enumerate() {
                        sums.add(data.accel_mps2[a][i], model[a]);
                    }
                },
            );
        }
        let cut = problem.drift_origin[pieces[0]].is_some();
        fits.push(RecordingFit {
            name: rec.source.name.clone(),
            rate: looks[k].rate.clone(),
            inspection: looks[k].inspection.clone(),
            session: sessions[pieces[0]],
            fit_percent: sums.map(|s| s.fit_percent()),
            residual_rms_mps2: sums.map(|s| s.rmse()),
            segments: if cut {
                pieces
                    .iter()
                    .map(|&piece| {
                        let time = &problem.recordings[piece].time_s;
                        SegmentPhase {
                            start_s: time[0],
                            end_s: time[time.len() - 1],
                            phase_rad: wrap_angle(sessions[piece].phase_rad),
                        }
                    })
                    .collect()
            } else {
                Vec::new()
            },
            drift_origin_s: problem.drift_origin[pieces[0]],
        });
    }
    fits
}

/// Scaled pseudo-inverse covariance σ²(JᵀJ)⁺ and the parameters caught in null directions.
fn covariance(jtj: &Mat<f64>, sigma2: f64) -> (Mat<f64>, Vec<bool>) {
    let n = jtj.nrows();
    let scale: Vec<f64> = (0..n)
        .map(|i| {
            if jtj[(i, i)] > 0.0 {
                1.0 / jtj[(i, i)].sqrt()
            } else {
                0.0
            }
        })
        .collect();
    let scaled = Mat::from_fn(n, n, |i, j| jtj[(i, j)] * scale[i] * scale[j]);
    let mut null = vec![false; n];
    let mut cov = Mat::<f64>::zeros(n, n);
    for i in 0..n {
        if scale[i] == 0.0 {
            null[i] = true;
        }
    }
    let Ok(eigen) = scaled.self_adjoint_eigen(Side::Lower) else {
        return (cov, vec![true; n]);
    };
    let values = eigen.S();
    let vectors = eigen.U();
    let largest = (0..n).map(|k| values[k]).fold(0.0f64, f64::max);
    for k in 0..n {
        let lambda = values[k];
        if lambda <= 1e-10 * largest {
            for i in 0..n {
                if vectors[(i, k)].abs() > 0.05 {
                    null[i] = true;
                }
            }
            continue;
        }
        for i in 0..n {
            for j in 0..n {
                cov[(i, j)] += vectors[(i, k)] * vectors[(j, k)] / lambda;
            }
        }
    }
    for i in 0..n {
        for j in 0..n {
            cov[(i, j)] *= sigma2 * scale[i] * scale[j];
        }
    }
    (cov, null)
}

pub(super) fn remedy_for(undetermined: &[String], recordings: usize, options: &FitOptions) -> Option<String> {
    if undetermined.is_empty() {
        return None;
    }
    let mut text = format!("the data do not determine {}: ", undetermined.join(", "));
    if recordings == 1 {
        text.push_str(
            "from one recording at one radius and speed the constant ω²r cos β cannot be told apart from \
             the x offset (nor ω²r sin β from the y offset, nor β from the phase). ",
        );
    }
    if options.radius.is_none() {
        text.push_str("Give the radius measured with a ruler (--radius 0.10 --radius-tol 0.005) ");
        text.push_str("and add ");
    } else {
        text.push_str("Add ");
    }
    text.push_str(
        "a recording at another speed or radius, fitted jointly (the offsets are shared); \
         or hold the offsets at zero (--no-offsets) as the paper does.",
    );
    Some(text)
}
