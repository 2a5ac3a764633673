//! The weighted least-squares problem over all recordings: its parameter table, the cost and
//! the normal equations accumulated sample by sample.

use faer::Mat;

use super::options::RadiusPrior;
use crate::input::recording::Recording;
use crate::optim::NormalEquations;
use crate::turntable::model::{for_each_derivative, for_each_sample_about, Direction, Mounting, Session};
use crate::turntable::moments::CostMoments;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Role {
    Beta,
    Offset(usize),
    /// Per recording (`None`: shared by all).
    Radius(Option<usize>),
    Omega(usize),
    Tilt(usize),
    /// Per piece: a recording cut at its logging gaps has one phase per segment.
    Phase(usize),
    Drift(usize, usize),
}

#[derive(Debug, Clone)]
pub(super) struct ParamDef {
    pub(super) name: String,
    pub(super) unit: &'static str,
    pub(super) role: Role,
    pub(super) lower: f64,
    pub(super) upper: f64,
    pub(super) start: f64,
}

/// The weighted least-squares problem over all recordings, each cut into pieces at its logging
/// gaps (a recording without one is one piece): the pieces of a recording share its parameters
/// but their phase.
pub(super) struct Problem<'a> {
    /// The pieces, in recording order.
    pub(super) recordings: &'a [&'a Recording],
    /// Per piece, its recording and the drift's time origin (the recording's middle when cut,
    /// else `None`: the piece's own middle).
    pub(super) recording_of: Vec<usize>,
    pub(super) drift_origin: Vec<Option<f64>>,
    pub(super) defs: Vec<ParamDef>,
    pub(super) directions: Vec<Direction>,
    pub(super) axes: &'static [usize],
    /// 1 / noise per piece and axis (its recording's).
    pub(super) weights: Vec<[f64; 3]>,
    pub(super) gravity: f64,
    pub(super) prior: Option<(usize, RadiusPrior)>,
    /// Per piece, the cost's moments when ω's bounds are narrow enough for them to pay off.
    pub(super) moments: Vec<Option<CostMoments>>,
}

impl Problem<'_> {
    /// The mounting and each piece's session.
    pub(super) fn unpack(&self, p: &[f64]) -> (Mounting, Vec<Session>) {
        let mut mounting = Mounting {
            beta_rad: 0.0,
            offset_mps2: [0.0; 3],
        };
        let mut sessions: Vec<Session> = self
            .directions
            .iter()
            .map(|&direction| Session {
                radius_m: 0.0,
                omega_radps: 0.0,
                tilt_rad: 0.0,
                phase_rad: 0.0,
                direction,
                drift_mps2_per_s: [0.0; 3],
            })
            .collect();
        let of = &self.recording_of;
        let pieces_of = |k: usize| (0..of.len()).filter(move |&piece| of[piece] == k);
        for (def, &v) in self.defs.iter().zip(p) {
            match def.role {
                Role::Beta => mounting.beta_rad = v,
                Role::Offset(a) => mounting.offset_mps2[a] = v,
                Role::Radius(None) => sessions.iter_mut().for_each(|s| s.radius_m = v),
                Role::Radius(Some(k)) => pieces_of(k).for_each(|i| sessions[i].radius_m = v),
                Role::Omega(k) => pieces_of(k).for_each(|i| sessions[i].omega_radps = v),
                Role::Tilt(k) => pieces_of(k).for_each(|i| sessions[i].tilt_rad = v),
                Role::Phase(piece) => sessions[piece].phase_rad = v,
                Role::Drift(k, a) => pieces_of(k).for_each(|i| sessions[i].drift_mps2_per_s[a] = v),
            }
        }
        (mounting, sessions)
    }

    fn rows_of(&self, k: usize) -> usize {
        self.recordings[k].len() * self.axes.len()
    }

    /// Σ residual² (Nelder–Mead calls this thousands of times): from the moments when ω is within
    /// their range, else summed over the samples.
    pub(super) fn cost(&self, p: &[f64]) -> f64 {
        let (mounting, sessions) = self.unpack(p);
        let mut total = 0.0;
        for (k, rec) in self.recordings.iter().enumerate() {
            // Unused axes get weight zero, so the per-sample work has no branches or axis loop.
            let w = [0, 1, 2].map(|a| {
                if self.axes.contains(&a) {
                    self.weights[k][a]
                } else {
                    0.0
                }
            });
            if let Some(moments) = self.moments[k].as_ref() {
                if moments.covers(sessions[k].omega_radps) {
                    total += moments.cost(&sessions[k], &mounting, self.gravity, w);
                    continue;
                }
            }
            let n = rec.len();
            let (x, y, z) = (
                &rec.accel_mps2[0][..n],
                &rec.accel_mps2[1][..n],
                &rec.accel_mps2[2][..n],
            );
            let origin = self.drift_origin[k];
            for_each_sample_about(
                &sessions[k],
                &mounting,
                self.gravity,
                &rec.time_s,
                origin,
                |i, m| {
                    let ex = w[0] * (m[0] - x[i]);
                    let ey = w[1] * (m[1] - y[i]);
                    let ez = w[2] * (m[2] - z[i]);
                    total += ex * ex + ey * ey + ez * ez;
                },
            );
        }
        if let Some((index, prior)) = self.prior {
            total += ((p[index] - prior.value_m) / prior.tolerance_m).powi(2);
        }
        total
    }
}

impl Problem<'_> {
    pub(super) fn n_residuals(&self) -> usize {
        (0..self.recordings.len()).map(|k| self.rows_of(k)).sum::<usize>() + usize::from(self.prior.is_some())
    }
}

/// Derivative slots per residual row in [`Problem`]'s normal equations.
const SLOTS: usize = 7;

/// The normal equations sample by sample: each residual row has at most seven nonzero
/// derivatives (radius, ω, tilt, phase, β, offset, drift), added into JᵀJ and Jᵀr as they are
/// made, so the fit's memory does not grow with the recording (the whole Jacobian would take
/// 8 bytes × parameters per row).
impl NormalEquations for Problem<'_> {
    fn n_params(&self) -> usize {
        self.defs.len()
    }

    fn sse(&self, p: &[f64]) -> f64 {
        let (mounting, sessions) = self.unpack(p);
        let mut total = 0.0;
        for (k, rec) in self.recordings.iter().enumerate() {
            let w = self.weights[k];
            let origin = self.drift_origin[k];
            for_each_sample_about(
                &sessions[k],
                &mounting,
                self.gravity,
                &rec.time_s,
                origin,
                |i, m| {
                    for &a in self.axes {
                        let r = w[a] * (m[a] - rec.accel_mps2[a][i]);
                        total += r * r;
                    }
                },
            );
        }
        if let Some((index, prior)) = self.prior {
            total += ((p[index] - prior.value_m) / prior.tolerance_m).powi(2);
        }
        total
    }

    fn normal_equations(&self, p: &[f64], jtj: &mut Mat<f64>, jtr: &mut [f64]) -> f64 {
        let n = self.defs.len();
        let (mounting, sessions) = self.unpack(p);
        // Row-major n × n accumulator (upper triangle), mirrored into `jtj` at the end.
        let mut upper = vec![0.0; n * n];
        jtr.fill(0.0);
        let mut total = 0.0;
        let column = |role: Role| self.defs.iter().position(|d| d.role == role);
        for (piece, rec) in self.recordings.iter().enumerate() {
            let k = self.recording_of[piece];
            let radius_col = column(Role::Radius(Some(k))).or_else(|| column(Role::Radius(None)));
            let role_cols = [
                radius_col,
                column(Role::Omega(k)),
                column(Role::Tilt(k)),
                column(Role::Phase(piece)),
                column(Role::Beta),
            ];
            let offset_cols = [0, 1, 2].map(|a| column(Role::Offset(a)));
            let drift_cols = [0, 1, 2].map(|a| column(Role::Drift(k, a)));
            let weights = self.weights[piece];
            // Per axis, the rows' seven derivative slots (radius, ω, tilt, phase, β, offset,
            // drift) always land in the same columns: accumulate a dense 7 × 7 block per axis
            // (fixed indices, no branches in the sample loop) and scatter it once.
            let mut block = [[[0.0f64; SLOTS]; SLOTS]; 3];
            let mut block_r = [[0.0f64; SLOTS]; 3];
            let origin = self.drift_origin[piece];
            for_each_derivative(
                &sessions[piece],
                &mounting,
                self.gravity,
                &rec.time_s,
                origin,
                |i, d| {
                    for &a in self.axes {
                        let w = weights[a];
                        let r = w * (d.value[a] - rec.accel_mps2[a][i]);
                        total += r * r;
                        let v = [
                            w * d.radius[a],
                            w * d.omega[a],
                            w * d.tilt[a],
                            w * d.phase[a],
                            w * d.beta[a],
                            w,
                            w * d.drift,
                        ];
                        // The full square (fixed bounds unroll and vectorise); the scatter reads
                        // the upper triangle.
                        let (b, br) = (&mut block[a], &mut block_r[a]);
                        for x in 0..SLOTS {
                            br[x] += v[x] * r;
                            for y in 0..SLOTS {
                                b[x][y] += v[x] * v[y];
                            }
                        }
                    }
                },
            );
            for &a in self.axes {
                let cols = [
                    role_cols[0],
                    role_cols[1],
                    role_cols[2],
                    role_cols[3],
                    role_cols[4],
                    offset_cols[a],
                    drift_cols[a],
                ];
                for x in 0..SLOTS {
                    let Some(cx) = cols[x] else { continue };
                    jtr[cx] += block_r[a][x];
                    for y in x..SLOTS {
                        let Some(cy) = cols[y] else { continue };
                        let (lo, hi) = if cx <= cy { (cx, cy) } else { (cy, cx) };
                        // Two slots in one column (never, but harmless) add both cross terms.
                        let factor = if x != y && cx == cy { 2.0 } else { 1.0 };
                        upper[lo * n + hi] += factor * block[a][x][y];
                    }
                }
            }
        }
        if let Some((index, prior)) = self.prior {
            let r = (p[index] - prior.value_m) / prior.tolerance_m;
            let j = 1.0 / prior.tolerance_m;
            total += r * r;
            jtr[index] += j * r;
            upper[index * n + index] += j * j;
        }
        for a in 0..n {
            for b in a..n {
                jtj[(a, b)] = upper[a * n + b];
                jtj[(b, a)] = upper[a * n + b];
            }
        }
        total
    }
}
