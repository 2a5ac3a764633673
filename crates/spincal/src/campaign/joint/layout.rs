//! Where each parameter sits in the joint fit's vector: the sensor's, then each run's, each
//! pose's and each still session's; and the times the recordings' parameters refer to.

use super::input::{PoseInput, RunInput};
use crate::correctors::physical::SENSOR_PARAMS;

/// Parameters per turntable run: r, ω, α, ϑ₀, β, ε₁, ε₂, wow (2), δ (3), drift rate (3).
pub const RUN_PARAMS: usize = 15;
/// Geometric parameters per run (all but the offsets), which come first.
pub(crate) const GEOMETRY: usize = 9;
/// Names and units of a run's parameters.
pub const RUN_PARAM_NAMES: [&str; RUN_PARAMS] = [
    "radius (m)",
    "omega (rad/s)",
    "tilt (rad)",
    "tilt_direction (rad)",
    "beta (rad)",
    "mount_tilt_1 (rad)",
    "mount_tilt_2 (rad)",
    "wow_cos",
    "wow_sin",
    "offset_x (m/s²)",
    "offset_y (m/s²)",
    "offset_z (m/s²)",
    "drift_x (m/s² per s)",
    "drift_y (m/s² per s)",
    "drift_z (m/s² per s)",
];
/// Parameters per still pose: two angles of gravity's direction. The bias offset δ (3) belongs
/// to the pose's power-on session, shared by its poses (and by the runs the campaign puts in it).
pub const POSE_PARAMS: usize = 2;
pub(super) const POSE_PARAM_NAMES: [&str; POSE_PARAMS] = ["direction_1 (rad)", "direction_2 (rad)"];

/// Where a run's or a pose's parameters start in the parameter vector.
pub(crate) fn run_offset(i: usize) -> usize {
    SENSOR_PARAMS + i * RUN_PARAMS
}

pub(super) fn pose_offset(n_runs: usize, p: usize) -> usize {
    SENSOR_PARAMS + n_runs * RUN_PARAMS + p * POSE_PARAMS
}

/// Parameters per still session: bias offset δ (3) and drift rate (3) about its middle.
pub(super) const SESSION_PARAMS: usize = 6;

pub(super) fn session_offset(n_runs: usize, n_poses: usize, session: usize) -> usize {
    SENSOR_PARAMS + n_runs * RUN_PARAMS + n_poses * POSE_PARAMS + SESSION_PARAMS * session
}

/// A run's bias offset at τ: δ + d τ.
pub(super) fn run_offset_at(p: &[f64], o: usize, tau: f64) -> [f64; 3] {
    std::array::from_fn(|k| p[o + GEOMETRY + k] + p[o + GEOMETRY + 3 + k] * tau)
}

/// Each pose's time from the middle of its session.
pub(super) fn session_times(poses: &[PoseInput]) -> Vec<f64> {
    poses
        .iter()
        .map(|pose| {
            let times = poses
                .iter()
                .filter(|q| q.session == pose.session)
                .map(|q| q.time_s);
            let (lo, hi) = times.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
                (a.min(t), b.max(t))
            });
            pose.time_s - 0.5 * (lo + hi)
        })
        .collect()
}

/// The number of power-on sessions: every pose's and every run's that names one.
pub(super) fn sessions(runs: &[RunInput], poses: &[PoseInput]) -> usize {
    let of_poses = poses.iter().map(|p| p.session + 1);
    let of_runs = runs.iter().filter_map(|r| r.session.map(|s| s + 1));
    of_poses.chain(of_runs).max().unwrap_or(0)
}

pub(crate) fn mid_time(t: &[f64]) -> f64 {
    match (t.first(), t.last()) {
        (Some(a), Some(b)) => 0.5 * (a + b),
        _ => 0.0,
    }
}
