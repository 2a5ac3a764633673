//! The joint problem as the optimiser sees it: weighted residuals of runs, poses and priors,
//! accumulated into the normal equations (or the covariance's block scores) sample by sample.

// Per-axis and per-parameter arrays are indexed together; iterators would obscure that.
#![allow(clippy::needless_range_loop)]

use faer::Mat;

use super::covariance::jackknife_score;
use super::input::{PoseInput, RunInput};
use super::kinematics::{PoseFrame, RunGeometry};
use super::layout::{
    mid_time, pose_offset, run_offset, run_offset_at, session_offset, sessions, GEOMETRY, POSE_PARAMS,
    RUN_PARAMS, SESSION_PARAMS,
};
use super::placement::PLACEMENT_TIE_M;
use crate::correctors::physical::{SensorModel, SENSOR_PARAMS};
use crate::geometry::M3;
use crate::optim::NormalEquations;
use crate::turntable::model::for_each_rotation;

/// The problem as the optimiser sees it.
pub(crate) struct JointProblem<'a> {
    pub(super) runs: &'a [RunInput],
    pub(super) poses: &'a [PoseInput],
    pub(super) gravity: f64,
    pub(super) bias_sigma: f64,
    pub(super) mount_tilt_sigma: f64,
    /// Prior widths of bias, scale, misalignment and nonlinearity: the penalty's.
    pub(super) sensor_prior_sd: [f64; 4],
    /// The same priors' standard deviations as distributions, which the covariance takes
    /// ([`super::JointSettings::sensor_prior_is_bound`]).
    pub(super) sensor_prior_spread: [f64; 4],
    pub(super) sensor_free: [bool; SENSOR_PARAMS],
    pub(super) directions: Vec<f64>,
    pub(super) mountings: Vec<M3>,
    pub(super) pose_frames: Vec<PoseFrame>,
    /// Per pose and axis, the standard error of its mean (after the variance component), m/s².
    pub(super) pose_sigma: Vec<[f64; 3]>,
    /// Per pose, its time from the middle of its session, s.
    pub(super) pose_tau: Vec<f64>,
    /// Per run and axis, the residual noise, m/s².
    pub(super) run_sigma: Vec<[f64; 3]>,
    pub(super) block_samples: Vec<usize>,
    /// Per run, the first run of its placement, whose radius it shares (itself when first).
    pub(super) placement_leader: Vec<usize>,
}

/// A still session's drift rate has a prior of the bias instability per this many seconds.
pub(super) const SESSION_DRIFT_S: f64 = 100.0;
/// A run in a named session keeps its offset within the spread between sessions over this: one
/// power-on, up to the drift within it.
pub(super) const SESSION_TIE: f64 = 10.0;

/// Accumulates rows into a local dense system, then scatters it into the global one.
struct LocalSystem {
    index: Vec<usize>,
    /// The local JᵀJ, full (both triangles).
    gram: Mat<f64>,
    grad: Vec<f64>,
    sse: f64,
    /// Rows not yet added to `gram`: `filled` of [`BATCH_ROWS`].
    batch: Mat<f64>,
    residuals: Vec<f64>,
    filled: usize,
}

/// Rows are gathered this many at a time and their Gram matrix added by one matrix product
/// (faer's SIMD kernels): a rank-1 update per row was half of the joint fit's time.
const BATCH_ROWS: usize = 64;

impl LocalSystem {
    fn new(index: Vec<usize>) -> LocalSystem {
        let n = index.len();
        LocalSystem {
            index,
            gram: Mat::zeros(n, n),
            grad: vec![0.0; n],
            sse: 0.0,
            batch: Mat::zeros(BATCH_ROWS, n),
            residuals: vec![0.0; BATCH_ROWS],
            filled: 0,
        }
    }

    fn add_row(&mut self, row: &[f64], residual: f64) {
        for (a, v) in row.iter().enumerate() {
            self.batch[(self.filled, a)] = *v;
        }
        self.residuals[self.filled] = residual;
        self.filled += 1;
        self.sse += residual * residual;
        if self.filled == BATCH_ROWS {
            self.flush();
        }
    }

    /// Adds the gathered rows to JᵀJ and Jᵀr.
    fn flush(&mut self) {
        if self.filled == 0 {
            return;
        }
        let rows = self.batch.as_ref().subrows(0, self.filled);
        faer::linalg::matmul::matmul(
            self.gram.as_mut(),
            faer::Accum::Add,
            rows.transpose(),
            rows,
            1.0,
            faer::Par::Seq,
        );
        for (a, g) in self.grad.iter_mut().enumerate() {
            let column = rows.col(a);
            *g += (0..self.filled)
                .map(|i| column[i] * self.residuals[i])
                .sum::<f64>();
        }
        self.filled = 0;
    }

    fn scatter(&mut self, jtj: &mut Mat<f64>, jtr: &mut [f64]) {
        self.flush();
        let n = self.index.len();
        for a in 0..n {
            jtr[self.index[a]] += self.grad[a];
            for b in a..n {
                let v = self.gram[(a, b)];
                let (i, j) = (self.index[a], self.index[b]);
                jtj[(i, j)] += v;
                if i != j {
                    jtj[(j, i)] += v;
                }
            }
        }
    }
}

/// A weighted row of axis `k` up to the recording's own offsets: ∂m_k/∂(b, s, M, q) given u_k
/// and f_B, then the recording's parameters through `derivatives` (∂f_B per parameter, in the
/// order they follow the sensor's). `slope` is h'(u_k)·weight.
#[allow(clippy::too_many_arguments)]
fn model_row(
    row: &mut [f64],
    k: usize,
    sensor: &SensorModel,
    slope: f64,
    weight: f64,
    u: f64,
    force: &[f64; 3],
    derivatives: &[[f64; 3]],
) {
    row.fill(0.0);
    let scale = 1.0 + sensor.scale_error[k];
    row[k] = slope;
    row[3 + k] = slope * sensor.skewed(*force)[k];
    match k {
        1 => row[6] = slope * scale * force[0],
        2 => {
            row[7] = slope * scale * force[0];
            row[8] = slope * scale * force[1];
        }
        _ => {}
    }
    row[9 + k] = weight * u * u;
    for (j, dj) in derivatives.iter().enumerate() {
        row[SENSOR_PARAMS + j] = slope * scale * sensor.skewed(*dj)[k];
    }
}

/// What one evaluation of the problem produces.
pub(crate) enum Want<'a> {
    Sse,
    Normal(&'a mut Mat<f64>, &'a mut [f64]),
    /// Σ over blocks of s sᵀ (s: the block's score Jᵀr), into the matrix; a pose's three
    /// residuals first multiplied by `pose_restore`, (I − H_bb)^(−½) over the pose's block of the
    /// hat matrix (CR2: few poses and many parameters leave residuals well below the noise that
    /// made them, and a pose's own angles take all but its radial part).
    ///
    /// A run's block score is first divided by what the fit left of it (CR3, the block
    /// jackknife, in parameter space): s̃ = (I − A P)⁻¹ s, with A the block's JᵀJ and P the
    /// inverse normal matrix over the run's and the sensor's parameters (`inverse`, n × n, zero
    /// where fixed). A run of a few blocks fits its own fifteen parameters from them, which leaves
    /// the raw scores far below the noise that made them: on a 30 s phone run of six 5 s blocks
    /// the rate's standard error came out a third of the Cramér–Rao bound.
    Meat {
        meat: &'a mut Mat<f64>,
        pose_restore: &'a [[[f64; 3]; 3]],
        inverse: &'a Mat<f64>,
    },
}

impl Want<'_> {
    /// A prior `value / sigma` as one more residual on parameter `param`; returns its square.
    fn add_prior(&mut self, param: usize, value: f64, sigma: f64) -> f64 {
        let r = value / sigma;
        match self {
            Want::Sse => {}
            Want::Normal(jtj, jtr) => {
                jtj[(param, param)] += 1.0 / (sigma * sigma);
                jtr[param] += r / sigma;
            }
            // A prior's information is its stated variance, not the realised score².
            Want::Meat { meat, .. } => meat[(param, param)] += 1.0 / (sigma * sigma),
        }
        r * r
    }

    /// A tie `(p[a] − p[b]) / sigma` as one more residual (`difference` = p[a] − p[b]); returns
    /// its square.
    fn add_tie(&mut self, a: usize, b: usize, difference: f64, sigma: f64) -> f64 {
        let r = difference / sigma;
        let w = 1.0 / (sigma * sigma);
        match self {
            Want::Sse => {}
            Want::Normal(jtj, jtr) => {
                jtj[(a, a)] += w;
                jtj[(b, b)] += w;
                jtj[(a, b)] -= w;
                jtj[(b, a)] -= w;
                jtr[a] += r / sigma;
                jtr[b] -= r / sigma;
            }
            Want::Meat { meat, .. } => {
                meat[(a, a)] += w;
                meat[(b, b)] += w;
                meat[(a, b)] -= w;
                meat[(b, a)] -= w;
            }
        }
        r * r
    }
}

impl JointProblem<'_> {
    pub(crate) fn n_params(&self) -> usize {
        SENSOR_PARAMS
            + self.runs.len() * RUN_PARAMS
            + self.poses.len() * POSE_PARAMS
            + SESSION_PARAMS * sessions(self.runs, self.poses)
    }

    pub(crate) fn geometry(&self, p: &[f64], i: usize) -> RunGeometry {
        let o = run_offset(i);
        RunGeometry::new(
            &self.mountings[i],
            &p[o..o + RUN_PARAMS],
            self.directions[i],
            self.gravity,
        )
    }

    /// The parameters a still pose's residuals depend on: the sensor's, its two angles and its
    /// session's offset and drift rate (the order of [`JointProblem::pose_rows`]' entries).
    fn pose_index(&self, pi: usize) -> Vec<usize> {
        let o = pose_offset(self.runs.len(), pi);
        let so = session_offset(self.runs.len(), self.poses.len(), self.poses[pi].session);
        (0..SENSOR_PARAMS)
            .chain(o..o + POSE_PARAMS)
            .chain(so..so + SESSION_PARAMS)
            .collect()
    }

    /// Pose `pi`'s weighted residual rows, one per axis: `visit(axis, row over pose_index, r)`.
    fn pose_rows(
        &self,
        p: &[f64],
        sensor: &SensorModel,
        pi: usize,
        mut visit: impl FnMut(usize, &[f64], f64),
    ) {
        let pose = &self.poses[pi];
        let o = pose_offset(self.runs.len(), pi);
        let so = session_offset(self.runs.len(), self.poses.len(), pose.session);
        let (force, d) = self.pose_frames[pi].force(p[o], p[o + 1], self.gravity);
        let dt = self.pose_tau[pi];
        let delta: [f64; 3] = std::array::from_fn(|k| p[so + k] + p[so + 3 + k] * dt);
        let u = sensor.linear_response(force, delta);
        let mut row = vec![0.0; SENSOR_PARAMS + POSE_PARAMS + SESSION_PARAMS];
        for k in 0..3 {
            let q = sensor.quadratic_per_mps2[k];
            let w = 1.0 / self.pose_sigma[pi][k];
            let r = (u[k] + q * u[k] * u[k] - pose.mean_mps2[k]) * w;
            let slope = (1.0 + 2.0 * q * u[k]) * w;
            model_row(&mut row, k, sensor, slope, w, u[k], &force, &d);
            row[SENSOR_PARAMS + POSE_PARAMS + k] = slope;
            row[SENSOR_PARAMS + POSE_PARAMS + 3 + k] = slope * dt;
            visit(k, &row, r);
        }
    }

    /// Each pose's block of the hat matrix, H_bb = J_b (JᵀJ)⁻¹ J_bᵀ over its three axes and the
    /// free parameters, with `inverse` the weighted normal matrix's inverse at `p` (n × n, zero
    /// where fixed): what the fit itself absorbs of that pose's residual. Its diagonal is each
    /// axis's leverage.
    pub(super) fn pose_hat(&self, p: &[f64], inverse: &Mat<f64>) -> Vec<[[f64; 3]; 3]> {
        let sensor = SensorModel::from_params(p);
        let mut out = Vec::with_capacity(self.poses.len());
        for pi in 0..self.poses.len() {
            let columns = self.pose_index(pi);
            let mut rows = [const { Vec::new() }; 3];
            self.pose_rows(p, &sensor, pi, |k, row, _| rows[k] = row.to_vec());
            let hat = std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    let mut sum = 0.0;
                    for (a, &ka) in columns.iter().enumerate() {
                        for (b, &kb) in columns.iter().enumerate() {
                            sum += rows[i][a] * inverse[(ka, kb)] * rows[j][b];
                        }
                    }
                    sum
                })
            });
            out.push(hat);
        }
        out
    }

    /// Model − measured mean of pose `i`, m/s².
    pub(crate) fn pose_residual(&self, p: &[f64], i: usize) -> [f64; 3] {
        let sensor = SensorModel::from_params(p);
        let o = pose_offset(self.runs.len(), i);
        let so = session_offset(self.runs.len(), self.poses.len(), self.poses[i].session);
        let (force, _) = self.pose_frames[i].force(p[o], p[o + 1], self.gravity);
        let dt = self.pose_tau[i];
        let u = sensor.linear_response(force, std::array::from_fn(|k| p[so + k] + p[so + 3 + k] * dt));
        std::array::from_fn(|k| {
            u[k] + sensor.quadratic_per_mps2[k] * u[k] * u[k] - self.poses[i].mean_mps2[k]
        })
    }

    /// Residuals of run i, per sample and axis (unweighted, model − measured), with a callback.
    pub(crate) fn run_residuals(&self, p: &[f64], i: usize, mut f: impl FnMut(usize, [f64; 3])) {
        let sensor = SensorModel::from_params(p);
        let geo = self.geometry(p, i);
        let run = &self.runs[i];
        let o = run_offset(i);
        let mid = mid_time(&run.time_s);
        for (s, &t) in run.time_s.iter().enumerate() {
            if !run.keep[s] {
                continue;
            }
            let delta = run_offset_at(p, o, t - mid);
            let u = sensor.linear_response(geo.force(t - mid), delta);
            let r: [f64; 3] = std::array::from_fn(|k| {
                u[k] + sensor.quadratic_per_mps2[k] * u[k] * u[k] - run.accel_mps2[k][s]
            });
            f(s, r);
        }
    }

    pub(crate) fn evaluate(&self, p: &[f64], mut want: Want<'_>) -> f64 {
        let sensor = SensorModel::from_params(p);
        let mut sse = 0.0;
        if let Want::Normal(jtj, jtr) = &mut want {
            jtj.fill(0.0);
            jtr.fill(0.0);
        }
        if let Want::Meat { meat, .. } = &mut want {
            meat.fill(0.0);
        }
        // `sse` is carried through the stages in order: one running sum, as in a single loop.
        for i in 0..self.runs.len() {
            sse = self.run_terms(p, i, &sensor, &mut want, sse);
        }
        for pi in 0..self.poses.len() {
            sse = self.pose_terms(p, pi, &sensor, &mut want, sse);
        }
        self.sensor_and_session_priors(p, &mut want, sse)
    }

    /// Run `i`'s samples and priors, into `want`; returns `sse` with their squares added.
    fn run_terms(&self, p: &[f64], i: usize, sensor: &SensorModel, want: &mut Want<'_>, mut sse: f64) -> f64 {
        let scale = sensor.scale_error.map(|s| 1.0 + s);
        let run = &self.runs[i];
        let o = run_offset(i);
        let geo = self.geometry(p, i);
        let mid = mid_time(&run.time_s);
        let index: Vec<usize> = (0..SENSOR_PARAMS).chain(o..o + RUN_PARAMS).collect();
        let mut local = LocalSystem::new(index.clone());
        let mut block = vec![0.0; index.len()];
        let mut block_jtj = Mat::<f64>::zeros(index.len(), index.len());
        let mut in_block = 0;
        let mut row = vec![0.0; index.len()];
        let sigma = self.run_sigma[i];
        let want_rows = !matches!(*want, Want::Sse);
        // sin ωτ and cos ωτ by the turntable model's block recurrence (exact sin_cos every 64
        // samples, or every sample off a uniform grid).
        for_each_rotation(&run.time_s, mid, geo.omega, 0.0, |s, s1, c1| {
            if !run.keep[s] {
                return;
            }
            let tau = run.time_s[s] - mid;
            let delta = run_offset_at(p, o, tau);
            if !want_rows {
                let u = sensor.linear_response(geo.force_at(s1, c1), delta);
                for k in 0..3 {
                    let r =
                        (u[k] + sensor.quadratic_per_mps2[k] * u[k] * u[k] - run.accel_mps2[k][s]) / sigma[k];
                    sse += r * r;
                }
                return;
            }
            let (force, d) = geo.force_and_derivatives_at(tau, s1, c1);
            let skewed = sensor.skewed(force);
            let u: [f64; 3] = std::array::from_fn(|k| sensor.bias_mps2[k] + delta[k] + scale[k] * skewed[k]);
            for k in 0..3 {
                let q = sensor.quadratic_per_mps2[k];
                let w = 1.0 / sigma[k];
                let r = (u[k] + q * u[k] * u[k] - run.accel_mps2[k][s]) * w;
                let slope = (1.0 + 2.0 * q * u[k]) * w;
                model_row(&mut row, k, sensor, slope, w, u[k], &force, &d);
                row[SENSOR_PARAMS + GEOMETRY + k] = slope;
                row[SENSOR_PARAMS + GEOMETRY + 3 + k] = slope * tau;
                match &mut *want {
                    Want::Meat { .. } => {
                        for (a, (b, v)) in block.iter_mut().zip(&row).enumerate() {
                            *b += v * r;
                            if *v != 0.0 {
                                for (c, w) in row.iter().enumerate().skip(a) {
                                    block_jtj[(a, c)] += v * w;
                                }
                            }
                        }
                    }
                    _ => local.add_row(&row, r),
                }
            }
            in_block += 1;
            if in_block == self.block_samples[i] {
                if let Want::Meat { meat, inverse, .. } = &mut *want {
                    add_block_score(meat, inverse, &index, &block, &mut block_jtj);
                }
                block.fill(0.0);
                in_block = 0;
            }
        });
        if in_block > 0 {
            if let Want::Meat { meat, inverse, .. } = &mut *want {
                add_block_score(meat, inverse, &index, &block, &mut block_jtj);
            }
        }
        // Priors: the radius within its stated tolerance and that of its placement's first run,
        // the run's bias offset within the instability.
        let entry = &run.entry;
        if let Some(stated) = entry.radius {
            sse += want.add_prior(o, p[o] - stated.value_m, stated.tolerance_m);
        }
        let leader = run_offset(self.placement_leader[i]);
        if leader != o {
            sse += want.add_tie(o, leader, p[o] - p[leader], PLACEMENT_TIE_M);
        }
        sse += want.add_prior(o + 5, p[o + 5], self.mount_tilt_sigma);
        sse += want.add_prior(o + 6, p[o + 6], self.mount_tilt_sigma);
        for k in 0..3 {
            let own = o + GEOMETRY + k;
            sse += match run.session {
                // One power-on: the run's offset is its session's, up to the drift within it.
                Some(session) => {
                    let shared = session_offset(self.runs.len(), self.poses.len(), session) + k;
                    want.add_tie(own, shared, p[own] - p[shared], self.bias_sigma / SESSION_TIE)
                }
                None => want.add_prior(own, p[own], self.bias_sigma),
            };
        }
        if let Want::Normal(jtj, jtr) = &mut *want {
            local.scatter(jtj, jtr);
            sse += local.sse;
        }
        sse
    }

    /// Pose `pi`'s residuals, into `want`; returns `sse` with their squares added.
    fn pose_terms(
        &self,
        p: &[f64],
        pi: usize,
        sensor: &SensorModel,
        want: &mut Want<'_>,
        mut sse: f64,
    ) -> f64 {
        if matches!(*want, Want::Sse) {
            sse += self
                .pose_residual(p, pi)
                .iter()
                .zip(&self.pose_sigma[pi])
                .map(|(r, sigma)| (r / sigma).powi(2))
                .sum::<f64>();
            return sse;
        }
        let index = self.pose_index(pi);
        let mut local = LocalSystem::new(index.clone());
        let mut block = vec![0.0; index.len()];
        let restore = match &*want {
            Want::Meat { pose_restore, .. } => pose_restore.get(pi).copied(),
            _ => None,
        };
        let mut rows = [const { Vec::new() }; 3];
        let mut residual = [0.0; 3];
        self.pose_rows(p, sensor, pi, |k, row, r| {
            local.add_row(row, r);
            if restore.is_some() {
                rows[k] = row.to_vec();
                residual[k] = r;
            }
        });
        if let Some(restore) = restore {
            for (k, row) in rows.iter().enumerate() {
                let r: f64 = (0..3).map(|j| restore[k][j] * residual[j]).sum();
                for (b, v) in block.iter_mut().zip(row) {
                    *b += v * r;
                }
            }
        }
        match &mut *want {
            Want::Normal(jtj, jtr) => {
                local.scatter(jtj, jtr);
                sse += local.sse;
            }
            Want::Meat { meat, .. } => add_outer(meat, &index, &block),
            Want::Sse => {}
        }
        sse
    }

    /// The sensor's and the still sessions' priors, into `want`; returns `sse` with their squares
    /// added.
    fn sensor_and_session_priors(&self, p: &[f64], want: &mut Want<'_>, mut sse: f64) -> f64 {
        // Weak priors on the sensor's terms (0 ± a datasheet-sized width): where the campaign says
        // nothing they keep a term near zero instead of wandering; where it speaks they are
        // negligible.
        for k in 0..SENSOR_PARAMS {
            if !self.sensor_free[k] {
                continue;
            }
            let sd = self.sensor_prior_sd[k / 3];
            let sigma = match want {
                // The penalty's score, p/σ², varies as the term does between units: spread²/σ⁴,
                // the information of a prior of width σ²/spread.
                Want::Meat { .. } => sd * sd / self.sensor_prior_spread[k / 3],
                _ => sd,
            };
            sse += want.add_prior(k, p[k], sigma);
        }
        // Each still session's bias offset within the instability, and its drift rate within the
        // instability per SESSION_DRIFT_S (poses alone say little about a slope).
        for session in 0..sessions(self.runs, self.poses) {
            let so = session_offset(self.runs.len(), self.poses.len(), session);
            for k in 0..SESSION_PARAMS {
                let param = so + k;
                let sigma = if k < 3 {
                    self.bias_sigma
                } else {
                    self.bias_sigma / SESSION_DRIFT_S
                };
                sse += want.add_prior(param, p[param], sigma);
            }
        }
        sse
    }
}

/// A run block's score into the meat, divided by what the fit left of it (see [`Want::Meat`]);
/// `block_jtj` holds the block's JᵀJ in its upper triangle and is cleared. Kept as it is where
/// the block alone determines a direction (I − A P singular): nothing is left to judge it by.
fn add_block_score(
    meat: &mut Mat<f64>,
    inverse: &Mat<f64>,
    index: &[usize],
    score: &[f64],
    block_jtj: &mut Mat<f64>,
) {
    let k = index.len();
    let a = Mat::from_fn(k, k, |r, c| {
        if r <= c {
            block_jtj[(r, c)]
        } else {
            block_jtj[(c, r)]
        }
    });
    let p = Mat::from_fn(k, k, |r, c| inverse[(index[r], index[c])]);
    match jackknife_score(&a, &p, score) {
        Some(corrected) => add_outer(meat, index, &corrected),
        None => add_outer(meat, index, score),
    }
    block_jtj.fill(0.0);
}

fn add_outer(meat: &mut Mat<f64>, index: &[usize], score: &[f64]) {
    for (a, &i) in index.iter().enumerate() {
        if score[a] == 0.0 {
            continue;
        }
        for (b, &j) in index.iter().enumerate() {
            meat[(i, j)] += score[a] * score[b];
        }
    }
}

impl NormalEquations for JointProblem<'_> {
    fn n_params(&self) -> usize {
        JointProblem::n_params(self)
    }
    fn sse(&self, p: &[f64]) -> f64 {
        self.evaluate(p, Want::Sse)
    }
    fn normal_equations(&self, p: &[f64], jtj: &mut Mat<f64>, jtr: &mut [f64]) -> f64 {
        self.evaluate(p, Want::Normal(jtj, jtr))
    }
}
