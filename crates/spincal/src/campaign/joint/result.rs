//! The joint fit's result and what it answers about the fitted runs.

// Per-axis and per-parameter arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use faer::Mat;
use serde::{Deserialize, Serialize};

use super::kinematics::RunGeometry;
use super::layout::{mid_time, run_offset, RUN_PARAMS};
use super::settings::SensorTerms;
use crate::correctors::physical::SensorModel;
use crate::geometry::M3;
use crate::optim::LmStop;
use crate::turntable::model::Direction;

/// A fitted parameter with its robust standard error.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JointParam {
    pub name: String,
    pub value: f64,
    /// Robust (block HAC) standard error; `None` when fixed or not determined.
    pub std_error: Option<f64>,
    /// Whether the parameter was estimated (false: held at its nominal value).
    pub free: bool,
}

/// One run's fitted geometry.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunFit {
    pub name: String,
    pub direction: Direction,
    pub params: Vec<JointParam>,
    /// Residual RMS per axis, m/s².
    pub residual_rms_mps2: [f64; 3],
    pub samples_used: usize,
}

/// One pose's fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PoseFit {
    pub name: String,
    pub params: Vec<JointParam>,
    /// Fitted specific force in the body frame, m/s².
    pub specific_force_mps2: [f64; 3],
}

/// The joint fit's result.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JointFit {
    pub sensor: SensorModel,
    pub sensor_params: Vec<JointParam>,
    pub runs: Vec<RunFit>,
    pub poses: Vec<PoseFit>,
    pub terms: SensorTerms,
    /// Weighted sum of squares and its degrees of freedom.
    pub chi2: f64,
    pub dof: usize,
    pub iterations: usize,
    pub stop: LmStop,
    /// The spread of the bias offsets between power-on sessions the fit used.
    pub bias_spread: super::BiasSpread,
    /// How the standard errors were formed, in words.
    pub covariance: String,
    #[serde(skip)]
    pub(super) state: FitState,
}

/// What the corrector selection needs besides the numbers shown.
#[derive(Debug, Clone, Default)]
pub(crate) struct FitState {
    pub(super) params: Vec<f64>,
    pub(super) directions: Vec<f64>,
    pub(super) mountings: Vec<M3>,
    pub(super) gravity: f64,
    /// The robust covariance over the free parameters `free_index` (in that order).
    pub(super) covariance: Option<Mat<f64>>,
    pub(super) free_index: Vec<usize>,
}

impl JointFit {
    /// The fitted true specific force of run `i` at the given times (body frame, m/s²): the
    /// reference correctors learn from. `time_s` on the run's own clock.
    pub fn run_reference(&self, i: usize, time_s: &[f64]) -> [Vec<f64>; 3] {
        let st = &self.state;
        let o = run_offset(i);
        let geo = RunGeometry::new(
            &st.mountings[i],
            &st.params[o..o + RUN_PARAMS],
            st.directions[i],
            st.gravity,
        );
        let mid = mid_time(time_s);
        let mut out = [
            vec![0.0; time_s.len()],
            vec![0.0; time_s.len()],
            vec![0.0; time_s.len()],
        ];
        for (s, &t) in time_s.iter().enumerate() {
            let f = geo.force(t - mid);
            for k in 0..3 {
                out[k][s] = f[k];
            }
        }
        out
    }

    /// Run `i`'s fitted parameters (r, ω, α, ϑ₀, β, ε₁, ε₂, w_c, w_s, δ, drift).
    pub fn run_params(&self, i: usize) -> &[f64] {
        let o = run_offset(i);
        &self.state.params[o..o + RUN_PARAMS]
    }

    /// The platter's speed ω(τ) at τ (seconds from the run's middle) with run parameters `run`
    /// (as [`JointFit::run_params`]), rad/s.
    pub fn run_rate(&self, i: usize, run: &[f64], tau: f64) -> f64 {
        self.geometry_of(i, run).kinematics(tau).rate
    }

    /// The direction of run `i`'s rotation vector in the body frame (the spindle, signed by the
    /// direction of rotation), a unit vector.
    pub fn run_spindle(&self, i: usize, run: &[f64]) -> [f64; 3] {
        self.geometry_of(i, run).angular_rate_direction()
    }

    fn geometry_of(&self, i: usize, run: &[f64]) -> RunGeometry {
        let st = &self.state;
        RunGeometry::new(&st.mountings[i], run, st.directions[i], st.gravity)
    }
}
