//! The joint fit of one sensor model and every recording of a campaign (SPEC §7).
//!
//! Turntable run i, sample at τ = t − t_mid (platter frame P: x radial outward through the sensor,
//! z along the spindle, upwards; the platter turns by σω, σ = +1 counter-clockwise from above):
//! ```text
//! ϑ = ϑ₀ − σ ω τ                                   (direction of the tilt in P)
//! f_P = [−ω² r + g sin α cos ϑ,  g sin α sin ϑ,  g cos α]
//! f_B = Q · Rx(ε₁) Ry(ε₂) Rz(β) · f_P               (Q: the nominal `out`/`up` mounting)
//! m   = h(b + δᵢ + D (I + M) f_B)                  (the sensor model, `sensor.rs`)
//! ```
//! β turns the sensor about the spindle (free over the circle, so either sign convention for
//! "outward" fits), ε₁, ε₂ tilt it on its mount, δᵢ is the run's bias offset from the unit's bias.
//! Still pose p: f_B = g · ŵ with ŵ = normalise(w₀ + a e₁ + b e₂) (two angles about the pose's
//! first estimate), m̄ = h(b + δ_s + D (I + M) f_B), δ_s the offset of its session (the still
//! recording it came from: one sitting, one bias).
//!
//! Every residual is divided by its noise (per run and axis; for a pose, the mean's standard error
//! and the bias's wander about its session's line, from the random walk measured within the poses
//! (`bias_random_walk`) or from what the first pass left, whichever is larger), and priors enter
//! as residuals: (r − r_stated)/tolerance where the campaign states the radius (runs of one
//! placement tied to one radius, `placement.rs`) and δ/σ_bias (bias instability between recordings),
//! ε/σ_mount (how flat the sensor sits) and, for each free sensor term, its value over a
//! datasheet-sized width (bias 0.5 m/s², scale 0.02, misalignment 0.02 rad, nonlinearity from the
//! datasheet, about 10⁻⁴ /(m/s²)). The normal equations are accumulated per sample, never a
//! stored Jacobian, so memory is the recordings plus an n × n matrix.
//!
//! Standard errors are the sandwich H⁻¹ S H⁻¹ with S from scores summed over blocks of
//! consecutive samples (batch-means HAC): residuals coloured by wow, flutter or drift within a
//! block are accounted for; a pose and each prior are blocks of their own. A run's block score
//! is restored by the block jackknife (CR3; a run fits its own fifteen parameters from its few
//! blocks) and a pose's three residuals by its block of the hat matrix (CR2). The result is never
//! below the model's own H⁻¹: a run parameter's variance on the diagonal, the sensor's in every
//! direction (few blocks make a noisy estimate; white noise is the floor).

pub(crate) mod advice;
mod covariance;
mod fit;
mod input;
mod kinematics;
mod layout;
mod offset;
mod placement;
mod problem;
mod result;
mod settings;
mod spread;
mod start;

pub use advice::{Advice, HELD_POSE_DEG};
pub(crate) use fit::fit_run_geometry;
pub use fit::{fit_joint, fit_joint_from};
pub use input::{bias_random_walk, difference_noise, PoseInput, PoseWander, RunInput};
pub use kinematics::mounting_matrix;
pub(crate) use kinematics::rotation_of;
pub(crate) use layout::{mid_time, GEOMETRY};
pub use layout::{POSE_PARAMS, RUN_PARAMS, RUN_PARAM_NAMES};
pub use offset::{chip_offset, ChipOffset, OffsetComponent, TurnedPlacement, TURN_SD_DEG};
pub use placement::{check_placements, placement_fits, PlacementError, PlacementFit, RADIUS_FALSE_ALARM};
pub use result::{JointFit, JointParam, PoseFit, RunFit};
pub use settings::{JointSettings, SensorTerms, DEFAULT_NONLINEARITY_PCT_FS, DEFAULT_NONLINEARITY_RANGE_G};
pub use spread::BiasSpread;
pub use start::run_start;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum JointError {
    #[error("the campaign has no recordings the fit can use")]
    Empty,
    #[error("{name}: {why}")]
    Run { name: String, why: String },
    #[error("joint fit setting {name} = {value}: {why}")]
    Setting {
        name: &'static str,
        value: f64,
        why: &'static str,
    },
}
