//! The joint fit's driver: checks, starting values, two weighted passes and the result.

// Per-axis and per-parameter arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use faer::Mat;

use super::covariance::{free_inverse, sandwich, Floor};
use super::input::{bias_random_walk, difference_noise, PoseInput, RunInput};
use super::kinematics::{mounting_matrix, PoseFrame};
use super::layout::{
    pose_offset, run_offset, session_times, sessions, GEOMETRY, POSE_PARAMS, POSE_PARAM_NAMES, RUN_PARAMS,
    RUN_PARAM_NAMES, SESSION_PARAMS,
};
use super::problem::{JointProblem, Want};
use super::result::{FitState, JointFit, JointParam, PoseFit, RunFit};
use super::settings::{JointSettings, SensorTerms};
use super::spread::{estimate_bias_spread, offset_count, BiasSpread};
use super::start::run_start;
use super::JointError;
use crate::correctors::physical::{SensorModel, SENSOR_PARAMS, SENSOR_PARAM_NAMES};
use crate::geometry::M3;
use crate::optim::{levenberg_marquardt_normal, LmOptions};
use crate::progress::Observer;
use crate::turntable::model::Direction;

/// The least share of a pose residual's variance taken as left by the fit (its leverage at most
/// 0.95), so that a pose the fit nearly interpolates does not inflate the component without bound.
const MIN_KEPT_VARIANCE: f64 = 0.05;

/// Fits the sensor model and every run and pose jointly.
pub fn fit_joint(
    runs: &[RunInput],
    poses: &[PoseInput],
    settings: &JointSettings,
    observer: &Observer,
) -> Result<JointFit, JointError> {
    fit_joint_from(runs, poses, settings, None, observer)
}

/// As [`fit_joint`], starting from another fit of the same runs and poses (its parameters, with
/// the terms this fit does not estimate set to zero): a nested model then starts in the basin the
/// larger one found.
pub fn fit_joint_from(
    runs: &[RunInput],
    poses: &[PoseInput],
    settings: &JointSettings,
    start: Option<&JointFit>,
    observer: &Observer,
) -> Result<JointFit, JointError> {
    fit_joint_with(runs, poses, settings, start, FitPurpose::Calibration, observer)
}

/// One run's geometry alone, as a rigid platter would move a perfect sensor: radius within its
/// tolerance, rate, platter tilt, mount rotation within its prior, wow, and no bias offset or
/// drift (held at zero). What this fit cannot explain is a sensor error it could not absorb:
/// the truth-free check of a corrected run.
pub(crate) fn fit_run_geometry(run: &RunInput, settings: &JointSettings) -> Result<JointFit, JointError> {
    let settings = JointSettings {
        terms: SensorTerms::NONE,
        ..settings.clone()
    };
    fit_joint_with(
        std::slice::from_ref(run),
        &[],
        &settings,
        None,
        FitPurpose::GeometryCheck,
        &crate::progress::silent,
    )
}

/// What a fit is for, which sets what it may move and how far it converges.
#[derive(Clone, Copy, PartialEq, Eq)]
enum FitPurpose {
    /// The sensor model: every free parameter, converged until no step moves the cost by 1e-12 of
    /// itself (standard errors and nested starts need the minimum itself).
    Calibration,
    /// A run's geometry alone (the runs' bias offsets and drifts held at zero), for its residual
    /// only: stopped once a step gains less than `GEOMETRY_COST_TOLERANCE` of the cost. A
    /// residual's RMS is then within about that share's square root of the minimum's, far inside
    /// the check's own standard error, while the flat valley of a badly corrected run no longer
    /// takes the iteration limit.
    GeometryCheck,
}

/// The relative cost decrease below which a geometry check stops (see `FitPurpose`).
const GEOMETRY_COST_TOLERANCE: f64 = 1e-7;

/// The fit's stages: checks, starting values, a first pass at white-noise weights, reweighting
/// from its residuals, a second pass, then the robust covariance and the result.
fn fit_joint_with(
    runs: &[RunInput],
    poses: &[PoseInput],
    settings: &JointSettings,
    start: Option<&JointFit>,
    purpose: FitPurpose,
    observer: &Observer,
) -> Result<JointFit, JointError> {
    let run_offsets_free = purpose == FitPurpose::Calibration;
    check_inputs(runs, poses, settings)?;
    let (p, directions) = starting_values(runs, poses, settings, start);
    let mut problem = first_pass_problem(runs, poses, settings, directions);
    let free = free_parameters(p.len(), runs.len(), settings, run_offsets_free);
    let options = LmOptions {
        max_iterations: settings.max_iterations,
        cost_tolerance: match purpose {
            FitPurpose::Calibration => 1e-12,
            FitPurpose::GeometryCheck => GEOMETRY_COST_TOLERANCE,
        },
        step_tolerance: 1e-10,
        gradient_tolerance: 0.0,
        ..LmOptions::default()
    };
    // First pass with the white-noise weights, then reweight each run by its residual RMS (which
    // includes drift and unmodelled motion) and solve again from there.
    let first = levenberg_marquardt_normal(&problem, &p, Some(&free), &options, observer);
    let p = first.params;
    reweight_runs(&mut problem, &p);
    let walk = bias_random_walk(poses);
    reweight_poses(&mut problem, &p, &first.jtj, &free, walk);
    let estimated = (settings.estimate_bias_spread && run_offsets_free)
        .then(|| estimate_bias_spread(&problem, &p, &free))
        .flatten();
    let bias_spread = match estimated {
        Some(found) => {
            problem.bias_sigma = found.sd_mps2;
            found
        }
        _ => BiasSpread {
            sd_mps2: settings.bias_instability_mps2,
            estimated: false,
            at_lower_bound: false,
            offsets: offset_count(&problem),
            likelihood_ratio: 0.0,
        },
    };
    // The second pass starts at the first one's minimum: little damping, or the strongly
    // correlated bias, offset and drift directions crawl.
    let second = LmOptions {
        initial_damping: 1e-6,
        // The residuals are now weighted to about unit variance, so these are standard errors:
        // stop where no Gauss–Newton step would move a parameter by 1e-8 of its own. (The first
        // pass only sets the weights, which its last 1e-5 SE hardly move.)
        polish_se_tolerance: match purpose {
            FitPurpose::Calibration => 1e-8,
            // Only the residual is wanted, which the parameters' last standard errors hardly move.
            FitPurpose::GeometryCheck => 0.0,
        },
        ..options.clone()
    };
    let report = levenberg_marquardt_normal(&problem, &p, Some(&free), &second, observer);
    let p = report.params;
    let (cov, index) = robust_covariance(&problem, &p, &report.jtj, &free);
    let m_rows: usize = runs
        .iter()
        .map(|r| 3 * r.keep.iter().filter(|&&k| k).count())
        .sum::<usize>()
        + 3 * poses.len();
    let dof = m_rows.saturating_sub(index.len());
    let blocks = problem.block_samples.first().copied().unwrap_or(0);
    let (sensor_params, run_fits, pose_fits) = fitted_params(&problem, &p, &free, cov.as_ref(), &index);
    Ok(JointFit {
        sensor: SensorModel::from_params(&p),
        sensor_params,
        runs: run_fits,
        poses: pose_fits,
        terms: settings.terms,
        chi2: report.sse,
        dof,
        iterations: first.iterations + report.iterations,
        stop: report.stop,
        bias_spread,
        covariance: format!(
            "robust sandwich H⁻¹SH⁻¹, S from scores summed over blocks of {:.1} s ({} samples) of each run (each block's score restored by the block jackknife, CR3), each still pose and each prior a block of its own (batch-means HAC; a bound's prior at its rectangular spread), no variance below the model's own covariance (a run parameter's; every direction of the sensor's); each pose weighted by its mean's error and the bias's wander between poses ({})",
            settings.block_s,
            blocks,
            match walk {
                Some(d) => format!("random walk {d:.2e} (m/s²)²/s, measured within the poses"),
                None => "from the first pass's pose residuals".into(),
            }
        ),
        state: FitState {
            params: p,
            directions: problem.directions.clone(),
            mountings: problem.mountings.clone(),
            gravity: settings.gravity_mps2,
            covariance: cov,
            free_index: index,
        },
    })
}

/// The settings in range and every run with enough usable samples.
fn check_inputs(runs: &[RunInput], poses: &[PoseInput], settings: &JointSettings) -> Result<(), JointError> {
    if runs.is_empty() && poses.is_empty() {
        return Err(JointError::Empty);
    }
    for (name, value, ok, why) in [
        (
            "gravity_mps2",
            settings.gravity_mps2,
            settings.gravity_mps2 > 0.0,
            "must be positive",
        ),
        (
            "bias_instability_mps2",
            settings.bias_instability_mps2,
            settings.bias_instability_mps2 > 0.0,
            "must be positive",
        ),
        (
            "mount_tilt_rad",
            settings.mount_tilt_rad,
            settings.mount_tilt_rad > 0.0,
            "must be positive",
        ),
        (
            "block_s",
            settings.block_s,
            settings.block_s > 0.0,
            "must be positive",
        ),
    ] {
        if !(ok && value.is_finite()) {
            return Err(JointError::Setting { name, value, why });
        }
    }
    for run in runs {
        let used = run.keep.iter().filter(|&&k| k).count();
        if used < 100 {
            return Err(JointError::Run {
                name: run.name.clone(),
                why: format!("{used} usable samples; a turntable run needs at least 100"),
            });
        }
    }
    Ok(())
}

/// The parameter vector's start and each run's rotation sense: from `start` when it fits these
/// runs and poses (its terms this fit holds set to zero), else from each run's demodulation.
fn starting_values(
    runs: &[RunInput],
    poses: &[PoseInput],
    settings: &JointSettings,
    start: Option<&JointFit>,
) -> (Vec<f64>, Vec<f64>) {
    let g = settings.gravity_mps2;
    let mut p = vec![
        0.0;
        SENSOR_PARAMS
            + runs.len() * RUN_PARAMS
            + poses.len() * POSE_PARAMS
            + SESSION_PARAMS * sessions(runs, poses)
    ];
    let mut directions = Vec::with_capacity(runs.len());
    if let Some(previous) = start.filter(|f| f.state.params.len() == p.len()) {
        // A nested model starts where the full one ended (the runs' own starts are not needed).
        p.copy_from_slice(&previous.state.params);
        directions.clone_from(&previous.state.directions);
        for k in 0..SENSOR_PARAMS {
            if !settings.terms.free(k) {
                p[k] = 0.0;
            }
        }
    } else {
        for (i, run) in runs.iter().enumerate() {
            let (start, direction) = run_start(run, g);
            p[run_offset(i)..run_offset(i) + RUN_PARAMS].copy_from_slice(&start);
            directions.push(direction);
        }
    }
    (p, directions)
}

/// The problem weighted by each run's white noise (first differences) and each pose's mean's
/// standard error.
fn first_pass_problem<'a>(
    runs: &'a [RunInput],
    poses: &'a [PoseInput],
    settings: &JointSettings,
    directions: Vec<f64>,
) -> JointProblem<'a> {
    let g = settings.gravity_mps2;
    let mountings: Vec<M3> = runs
        .iter()
        .map(|r| mounting_matrix(r.entry.out, r.entry.up))
        .collect();
    let block_samples = runs
        .iter()
        .map(|r| {
            let rate = crate::input::recording::sample_interval(&r.time_s);
            ((settings.block_s / rate).round() as usize).max(10)
        })
        .collect();
    JointProblem {
        runs,
        poses,
        gravity: g,
        bias_sigma: settings.bias_instability_mps2,
        mount_tilt_sigma: settings.mount_tilt_rad,
        sensor_prior_sd: settings.sensor_prior_sd,
        sensor_prior_spread: std::array::from_fn(|g| {
            let sd = settings.sensor_prior_sd[g];
            if settings.sensor_prior_is_bound[g] {
                sd / 3f64.sqrt()
            } else {
                sd
            }
        }),
        sensor_free: std::array::from_fn(|k| settings.terms.free(k)),
        directions,
        mountings,
        pose_frames: poses.iter().map(|p| PoseFrame::new(p.mean_mps2)).collect(),
        pose_sigma: poses.iter().map(|p| p.sigma_mean_mps2).collect(),
        pose_tau: session_times(poses),
        run_sigma: runs
            .iter()
            .map(|r| difference_noise(&r.accel_mps2, &r.keep))
            .collect(),
        block_samples,
        placement_leader: super::placement::placement_leaders(runs),
    }
}

/// Which parameters the fit estimates: the chosen sensor terms, and every recording's parameter
/// except, when `run_offsets_free` is false, the runs' bias offsets and drifts.
fn free_parameters(n: usize, n_runs: usize, settings: &JointSettings, run_offsets_free: bool) -> Vec<bool> {
    let run_params_end = run_offset(n_runs);
    let is_run_offset = |k: usize| {
        (SENSOR_PARAMS..run_params_end).contains(&k) && (k - SENSOR_PARAMS) % RUN_PARAMS >= GEOMETRY
    };
    (0..n)
        .map(|k| {
            if k < SENSOR_PARAMS {
                settings.terms.free(k)
            } else {
                run_offsets_free || !is_run_offset(k)
            }
        })
        .collect()
}

/// Each run's weights from its residual RMS at `p` (drift and unmodelled motion included).
fn reweight_runs(problem: &mut JointProblem<'_>, p: &[f64]) {
    for i in 0..problem.runs.len() {
        let mut sums = [0.0f64; 3];
        let mut n = 0.0f64;
        problem.run_residuals(p, i, |_, r| {
            for k in 0..3 {
                sums[k] += r[k] * r[k];
            }
            n += 1.0;
        });
        problem.run_sigma[i] = sums.map(|s| (s / n.max(1.0)).sqrt().max(1e-6));
    }
}

/// Poses scatter by more than their means' noise when the bias wanders between them: a variance
/// component per session and axis, from the residuals divided by the share of their variance
/// the fit leaves them (1 − leverage; about 1/3 when only a pose's own two angles took theirs,
/// far less when the poses alone determine the sensor).
fn reweight_poses(
    problem: &mut JointProblem<'_>,
    p: &[f64],
    jtj: &Mat<f64>,
    free: &[bool],
    walk: Option<f64>,
) {
    let poses = problem.poses;
    let index: Vec<usize> = (0..p.len()).filter(|&k| free[k]).collect();
    let leverage = free_inverse(jtj, &index).map(|inverse| {
        let hat = problem.pose_hat(p, &inverse);
        hat.iter()
            .map(|h| [h[0][0], h[1][1], h[2][2]])
            .collect::<Vec<_>>()
    });
    for session in 0..sessions(problem.runs, poses) {
        let members: Vec<usize> = (0..poses.len())
            .filter(|&i| poses[i].session == session)
            .collect();
        if members.len() < 2 {
            continue;
        }
        // A random walk of rate D leaves, about the session's fitted line over its span T, a
        // mean squared deviation of D·T/15 at the poses.
        let span = members
            .iter()
            .map(|&i| poses[i].time_s)
            .fold(f64::NEG_INFINITY, f64::max)
            - members
                .iter()
                .map(|&i| poses[i].time_s)
                .fold(f64::INFINITY, f64::min);
        let walked = walk.map_or(0.0, |d| d * span / 15.0);
        let mut extra = [0.0f64; 3];
        for &i in &members {
            let r = problem.pose_residual(p, i);
            for k in 0..3 {
                // A residual keeps 1 − h of its variance; the rest went into the fit.
                let kept = match &leverage {
                    Some(h) => (1.0 - h[i][k]).max(MIN_KEPT_VARIANCE),
                    None => 1.0 / 3.0,
                };
                extra[k] += r[k] * r[k] / kept - poses[i].sigma_mean_mps2[k].powi(2);
            }
        }
        for &i in &members {
            for k in 0..3 {
                let component = (extra[k] / members.len() as f64).max(walked);
                problem.pose_sigma[i][k] = (poses[i].sigma_mean_mps2[k].powi(2) + component).sqrt();
            }
        }
    }
}

/// (I − H_bb)^(−½) for a pose's block H_bb of the hat matrix, each eigenvalue of I − H_bb taken
/// as at least [`MIN_KEPT_VARIANCE`]: a residual vector that keeps the share λ of its variance
/// along an eigenvector is scaled back by 1/√λ there (CR2). A diagonal per-axis correction would
/// scale a random orientation's radial residual, all that its own angles leave, by up to √3.
fn restoring(hat: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let kept = Mat::from_fn(3, 3, |i, j| {
        f64::from(u8::from(i == j)) - 0.5 * (hat[i][j] + hat[j][i])
    });
    let identity = std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j))));
    let Ok(eigen) = kept.self_adjoint_eigen(faer::Side::Lower) else {
        return identity;
    };
    let (u, lambda) = (eigen.U(), eigen.S());
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            (0..3)
                .map(|k| u[(i, k)] * u[(j, k)] / lambda[k].max(MIN_KEPT_VARIANCE).sqrt())
                .sum()
        })
    })
}

/// The sandwich covariance over the free parameters at `p` and those parameters' indices.
fn robust_covariance(
    problem: &JointProblem<'_>,
    p: &[f64],
    jtj: &Mat<f64>,
    free: &[bool],
) -> (Option<Mat<f64>>, Vec<usize>) {
    let n = p.len();
    let index: Vec<usize> = (0..n).filter(|&k| free[k]).collect();
    let Some(full) = free_inverse(jtj, &index) else {
        return (None, index);
    };
    let model = model_covariance(problem, &full);
    let pose_restore: Vec<[[f64; 3]; 3]> = problem.pose_hat(p, &full).iter().map(restoring).collect();
    let mut meat = Mat::<f64>::zeros(n, n);
    problem.evaluate(
        p,
        Want::Meat {
            meat: &mut meat,
            pose_restore: &pose_restore,
            inverse: &full,
        },
    );
    let runs = SENSOR_PARAMS..run_offset(problem.runs.len());
    let floor = |k: usize| match k {
        k if k < SENSOR_PARAMS => Floor::EveryDirection,
        k if runs.contains(&k) => Floor::Variance,
        _ => Floor::None,
    };
    (sandwich(&full, &meat, &model, &index, floor), index)
}

/// The model's own covariance of the penalised estimate, H⁻¹ (H − Δ) H⁻¹ = H⁻¹ − H⁻¹ Δ H⁻¹
/// (`full`: H⁻¹), where each sensor prior's score has the variance its spread gives,
/// spread²/σ⁴, not its penalty's 1/σ² (Δ the difference, on the diagonal; zero where they agree).
/// Where the prior decides a term this is spread², where the data do it is theirs.
fn model_covariance(problem: &JointProblem<'_>, full: &Mat<f64>) -> Mat<f64> {
    let n = full.nrows();
    let mut model = full.clone();
    for k in (0..SENSOR_PARAMS).filter(|&k| problem.sensor_free[k]) {
        let (sd, spread) = (problem.sensor_prior_sd[k / 3], problem.sensor_prior_spread[k / 3]);
        let delta = (1.0 - (spread / sd).powi(2)) / (sd * sd);
        if delta == 0.0 {
            continue;
        }
        for a in 0..n {
            for b in 0..n {
                model[(a, b)] -= delta * full[(a, k)] * full[(k, b)];
            }
        }
    }
    model
}

/// The sensor's, each run's and each pose's parameters with their standard errors, and each
/// run's residual RMS.
fn fitted_params(
    problem: &JointProblem<'_>,
    p: &[f64],
    free: &[bool],
    cov: Option<&Mat<f64>>,
    index: &[usize],
) -> (Vec<JointParam>, Vec<RunFit>, Vec<PoseFit>) {
    let (runs, poses, g) = (problem.runs, problem.poses, problem.gravity);
    let se = |k: usize| -> Option<f64> {
        let pos = index.iter().position(|&i| i == k)?;
        let v = cov?[(pos, pos)];
        (v.is_finite() && v >= 0.0).then(|| v.sqrt())
    };
    let param = |name: &str, k: usize| JointParam {
        name: name.to_string(),
        value: p[k],
        std_error: se(k),
        free: free[k],
    };
    let sensor_params = (0..SENSOR_PARAMS)
        .map(|k| param(SENSOR_PARAM_NAMES[k], k))
        .collect();
    let run_fits = runs
        .iter()
        .enumerate()
        .map(|(i, run)| {
            let o = run_offset(i);
            let mut sums = [0.0f64; 3];
            let mut count = 0usize;
            problem.run_residuals(p, i, |_, r| {
                for k in 0..3 {
                    sums[k] += r[k] * r[k];
                }
                count += 1;
            });
            RunFit {
                name: run.name.clone(),
                direction: Direction::from_sign(problem.directions[i]),
                params: (0..RUN_PARAMS)
                    .map(|j| param(RUN_PARAM_NAMES[j], o + j))
                    .collect(),
                residual_rms_mps2: sums.map(|s| (s / count.max(1) as f64).sqrt()),
                samples_used: count,
            }
        })
        .collect();
    let pose_fits = poses
        .iter()
        .enumerate()
        .map(|(pi, pose)| {
            let o = pose_offset(runs.len(), pi);
            PoseFit {
                name: pose.name.clone(),
                params: (0..POSE_PARAMS)
                    .map(|j| param(POSE_PARAM_NAMES[j], o + j))
                    .collect(),
                specific_force_mps2: problem.pose_frames[pi].force(p[o], p[o + 1], g).0,
            }
        })
        .collect();
    (sensor_params, run_fits, pose_fits)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CR2 on a pose's block: the radial residual a pose's own angles leave, which keeps the share
    /// 1 − h of the noise's variance, is scaled back by 1/√(1 − h) whatever the pose's
    /// orientation; a per-axis correction scales it by √(axes it touches) times that.
    #[test]
    fn a_restored_pose_residual_has_the_noises_variance() {
        for (n, h) in [
            ([0.6, 0.0, 0.8], 0.3),
            ([0.48, 0.6, 0.64], 0.7),
            ([0.0, 0.0, 1.0], 0.1),
        ] {
            // I − H_bb = (1 − h) n nᵀ: the angles take the two directions across the force n.
            let hat: [[f64; 3]; 3] = std::array::from_fn(|i| {
                std::array::from_fn(|j| f64::from(u8::from(i == j)) - (1.0 - h) * n[i] * n[j])
            });
            let r = restoring(&hat);
            let restored: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| r[i][j] * n[j]).sum());
            let norm = restored.iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((norm - 1.0 / (1.0 - h).sqrt()).abs() < 1e-9, "{n:?}: {norm}");
            let per_axis = (0..3)
                .map(|k| n[k] * n[k] / (1.0 - hat[k][k]).max(MIN_KEPT_VARIANCE))
                .sum::<f64>()
                .sqrt();
            let touched = n.iter().filter(|v| v.abs() > 0.0).count() as f64;
            assert!(
                (per_axis - touched.sqrt() * norm).abs() < 1e-9,
                "{n:?}: per axis {per_axis}"
            );
        }
    }
}
