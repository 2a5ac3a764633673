//! Fitting the turntable model to one or more recordings (SPEC §2, issue "foundation" point 6).
//!
//! Stages: rotation rate from the spectrum → a linear sinusoid fit at that rate per axis (starting
//! values, sense of rotation, noise level per axis) → bounded Nelder–Mead on the noise-weighted
//! squared error of the chosen axes (the paper's fminsearchbnd step) → Levenberg–Marquardt polish
//! with the analytic Jacobian → standard errors, correlations, and which parameters the data did
//! not determine (null directions of the column-scaled JᵀJ).
//!
//! Parameters: shared by all recordings: β and the three offsets (the sensor and its mounting);
//! per recording: r (or one shared r), ω, α, φ and, when fitted, a drift per axis.

use faer::{Mat, Side};
use serde::{Deserialize, Serialize};

use std::borrow::Cow;

use crate::input::inspect::{inspect, saturated_mask, Inspection};
use crate::input::recording::{Recording, STANDARD_GRAVITY};
use crate::metrics::FitSums;
use crate::optim::{
    levenberg_marquardt_normal, nelder_mead_bounded, Bounds, BoundsError, LmOptions, LmReport, LmStop,
    NelderMeadOptions, NelderMeadReport, NormalEquations, Observer,
};
use crate::turntable::model::{evaluate, for_each_derivative, for_each_sample, Direction, Mounting, Session};
use crate::turntable::moments::CostMoments;
use crate::turntable::spectrum::{estimate_rotation_rate, RateEstimate, RateSearch, SpectrumError};

/// Which axes enter the objective.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxesObjective {
    Xyz,
    Xy,
    /// The paper's choice when y drifts.
    X,
}

impl AxesObjective {
    pub fn axes(self) -> &'static [usize] {
        match self {
            AxesObjective::Xyz => &[0, 1, 2],
            AxesObjective::Xy => &[0, 1],
            AxesObjective::X => &[0],
        }
    }
    pub fn parse(text: &str) -> Option<AxesObjective> {
        match text {
            "xyz" => Some(AxesObjective::Xyz),
            "xy" => Some(AxesObjective::Xy),
            "x" => Some(AxesObjective::X),
            _ => None,
        }
    }
}

/// Whether to fit a linear drift per axis and recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DriftMode {
    Off,
    /// Fit drift terms and report where they are significant (the default).
    Fit,
}

/// A radius measured with a ruler: a Gaussian prior of standard deviation `tolerance_m`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RadiusPrior {
    pub value_m: f64,
    pub tolerance_m: f64,
}

/// Everything that can be set about a fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitOptions {
    pub axes: AxesObjective,
    pub drift: DriftMode,
    pub gravity_mps2: f64,
    /// Nominal speed: narrows the spectral search to ±10 % of it.
    pub rpm_hint: Option<f64>,
    /// A measured radius (applies to every recording).
    pub radius: Option<RadiusPrior>,
    /// One radius for all recordings (the sensor was not moved between them).
    pub shared_radius: bool,
    /// Fit the sensor offsets (else they are held at zero, the paper's model).
    pub fit_offsets: bool,
    /// Replacement bounds by parameter name: (name, lower, upper), SI units.
    pub bounds: Vec<(String, f64, f64)>,
    /// Sensor range, m/s², for the saturation check.
    pub range_mps2: Option<f64>,
    pub nelder_mead: NelderMeadOptions,
    pub lm: LmOptions,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            axes: AxesObjective::Xyz,
            drift: DriftMode::Fit,
            gravity_mps2: STANDARD_GRAVITY,
            rpm_hint: None,
            radius: None,
            shared_radius: true,
            fit_offsets: true,
            bounds: Vec::new(),
            range_mps2: None,
            // fminsearch's TolX; the Levenberg–Marquardt polish takes it from there.
            nelder_mead: NelderMeadOptions {
                tol_x: 1e-4,
                tol_f: 0.0,
                max_iterations_per_param: 200,
            },
            // A relative cost change of 1e-12 moves the parameters by about 1e-6 of their
            // standard errors; below it the sums' rounding decides, and iterations only churn.
            lm: LmOptions {
                cost_tolerance: 1e-12,
                ..LmOptions::default()
            },
        }
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    #[error("{file}: a{axis} is constant (a dead or disconnected channel): there is no rotation to fit on it; check the recording or leave the axis out of the objective (--objective-axes)")]
    ConstantAxis { file: String, axis: char },
    #[error("{file}: no rotation found: the strongest line in the search band ({rpm:.2} rpm) is only {peak_to_median:.1}× the spectrum's median (at least {MIN_PEAK_TO_MEDIAN} is needed); {advice}")]
    NoRotation {
        file: String,
        peak_to_median: f64,
        rpm: f64,
        /// What to check: the time column's flag when its stamps repeat, else whether the
        /// turntable was turning.
        advice: String,
    },
    #[error("{file}: {advice}")]
    Time { file: String, advice: String },
    #[error("{file}: {duration_s:.2} s is too short to measure the rotation rate (the spectrum holds fewer than 2 cycles of any line it finds, so a rate or rotation count read from it would be a guess); the turntable fit needs at least 3 rotations: record at least {:.1} s at 33⅓ rpm, {:.1} s at 45 rpm", 3.0 * 60.0 / (100.0 / 3.0), 3.0 * 60.0 / 45.0)]
    TooShortToMeasure { file: String, duration_s: f64 },
    #[error("no recordings to fit")]
    NoRecordings,
    #[error(transparent)]
    Spectrum(#[from] SpectrumError),
    #[error(transparent)]
    Bounds(#[from] BoundsError),
    #[error("{file}: only {rotations:.1} rotations ({basis}: {rpm:.2} rpm for {duration_s:.1} s); at least 3 are needed to fit the turntable")]
    TooFewRotations {
        file: String,
        /// Where the rate comes from: measured, or sought near the rate the user gave.
        basis: &'static str,
        rotations: f64,
        rpm: f64,
        duration_s: f64,
    },
    #[error("no parameter is called '{0}' (bounds can be set for: {1})")]
    UnknownParameter(String, String),
    #[error("radius prior {value_m} m ± {tolerance_m} m is invalid: the tolerance must be positive and the radius within [0, 2] m")]
    BadRadius { value_m: f64, tolerance_m: f64 },
    #[error(
        "{file}: the fit did not produce finite parameters (the data may not contain a turntable signal)"
    )]
    NotFinite { file: String },
}

/// One fitted parameter as reported.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FittedParam {
    pub name: String,
    pub value: f64,
    /// One standard error; `None` when the data do not determine the parameter.
    pub std_error: Option<f64>,
    pub unit: String,
    pub lower: f64,
    pub upper: f64,
    pub at_bound: bool,
    pub determined: bool,
}

/// Drift found on one axis of one recording.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DriftFinding {
    pub recording: usize,
    pub axis: char,
    /// Change over the whole recording, m/s².
    pub change_mps2: f64,
    pub std_error_mps2: f64,
    pub significant: bool,
}

/// Per-recording outcome.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RecordingFit {
    pub name: String,
    pub rate: RateEstimate,
    pub inspection: Inspection,
    pub session: Session,
    /// Model fit % per axis x, y, z (SPEC §4).
    pub fit_percent: [f64; 3],
    /// RMS of measured − model per axis, m/s².
    pub residual_rms_mps2: [f64; 3],
}

/// The complete result of a turntable fit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TurntableFit {
    pub gravity_mps2: f64,
    pub axes: AxesObjective,
    pub mounting: Mounting,
    pub recordings: Vec<RecordingFit>,
    /// Free parameters in fit order, with errors.
    pub params: Vec<FittedParam>,
    /// Correlation matrix of the free parameters (NaN rows for undetermined ones).
    pub correlation: Vec<Vec<f64>>,
    /// Names of parameters the data did not determine, and what to do about it.
    pub undetermined: Vec<String>,
    pub remedy: Option<String>,
    pub drift: Vec<DriftFinding>,
    /// Weighted squared error after Nelder–Mead and after Levenberg–Marquardt.
    pub cost_nelder_mead: f64,
    pub cost_final: f64,
    pub nelder_mead_iterations: usize,
    pub lm_iterations: usize,
    pub lm_stop: LmStop,
    /// Noise standard deviation per recording and axis used as weights, m/s².
    pub noise_mps2: Vec<[f64; 3]>,
    /// Starting values handed to Nelder–Mead (free parameters, SI), for reproduction by peers.
    pub start: Vec<f64>,
}

impl TurntableFit {
    /// The fitted model at the samples of recording `k`, m/s², including the sensor's offsets and
    /// drift: what the sensor should read (used for the model-against-measurement fit).
    pub fn model(&self, k: usize, time_s: &[f64]) -> [Vec<f64>; 3] {
        let mut out = [Vec::new(), Vec::new(), Vec::new()];
        evaluate(
            &self.recordings[k].session,
            &self.mounting,
            self.gravity_mps2,
            time_s,
            &mut out,
        );
        out
    }

    /// The reference acceleration at the samples of recording `k`, m/s²: the turntable's physical
    /// specific force alone. Offsets and drift are sensor errors, so they are left out; the
    /// correctors learn to remove them.
    pub fn reference(&self, k: usize, time_s: &[f64]) -> [Vec<f64>; 3] {
        let session = Session {
            drift_mps2_per_s: [0.0; 3],
            ..self.recordings[k].session
        };
        let mounting = Mounting {
            offset_mps2: [0.0; 3],
            ..self.mounting
        };
        let mut out = [Vec::new(), Vec::new(), Vec::new()];
        evaluate(&session, &mounting, self.gravity_mps2, time_s, &mut out);
        out
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    Beta,
    Offset(usize),
    Radius(Option<usize>),
    Omega(usize),
    Tilt(usize),
    Phase(usize),
    Drift(usize, usize),
}

#[derive(Debug, Clone)]
struct ParamDef {
    name: String,
    unit: &'static str,
    role: Role,
    lower: f64,
    upper: f64,
    start: f64,
}

/// The weighted least-squares problem over all recordings.
struct Problem<'a> {
    recordings: &'a [&'a Recording],
    defs: Vec<ParamDef>,
    directions: Vec<Direction>,
    axes: &'static [usize],
    /// 1 / noise per recording and axis.
    weights: Vec<[f64; 3]>,
    gravity: f64,
    prior: Option<(usize, RadiusPrior)>,
    n_recordings: usize,
    /// Per recording, the cost's moments when ω's bounds are narrow enough for them to pay off.
    moments: Vec<Option<CostMoments>>,
}

impl Problem<'_> {
    fn unpack(&self, p: &[f64]) -> (Mounting, Vec<Session>) {
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
        for (def, &v) in self.defs.iter().zip(p) {
            match def.role {
                Role::Beta => mounting.beta_rad = v,
                Role::Offset(a) => mounting.offset_mps2[a] = v,
                Role::Radius(None) => sessions.iter_mut().for_each(|s| s.radius_m = v),
                Role::Radius(Some(k)) => sessions[k].radius_m = v,
                Role::Omega(k) => sessions[k].omega_radps = v,
                Role::Tilt(k) => sessions[k].tilt_rad = v,
                Role::Phase(k) => sessions[k].phase_rad = v,
                Role::Drift(k, a) => sessions[k].drift_mps2_per_s[a] = v,
            }
        }
        (mounting, sessions)
    }

    fn rows_of(&self, k: usize) -> usize {
        self.recordings[k].len() * self.axes.len()
    }

    /// Σ residual² (Nelder–Mead calls this thousands of times): from the moments when ω is within
    /// their range, else summed over the samples.
    fn cost(&self, p: &[f64]) -> f64 {
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
            for_each_sample(&sessions[k], &mounting, self.gravity, &rec.time_s, |i, m| {
                let ex = w[0] * (m[0] - x[i]);
                let ey = w[1] * (m[1] - y[i]);
                let ez = w[2] * (m[2] - z[i]);
                total += ex * ex + ey * ey + ez * ez;
            });
        }
        if let Some((index, prior)) = self.prior {
            total += ((p[index] - prior.value_m) / prior.tolerance_m).powi(2);
        }
        total
    }
}

impl Problem<'_> {
    fn n_residuals(&self) -> usize {
        (0..self.n_recordings).map(|k| self.rows_of(k)).sum::<usize>() + usize::from(self.prior.is_some())
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
            for_each_sample(&sessions[k], &mounting, self.gravity, &rec.time_s, |i, m| {
                for &a in self.axes {
                    let r = w[a] * (m[a] - rec.accel_mps2[a][i]);
                    total += r * r;
                }
            });
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
        for (k, rec) in self.recordings.iter().enumerate() {
            let radius_col = column(Role::Radius(Some(k))).or_else(|| column(Role::Radius(None)));
            let role_cols = [
                radius_col,
                column(Role::Omega(k)),
                column(Role::Tilt(k)),
                column(Role::Phase(k)),
                column(Role::Beta),
            ];
            let offset_cols = [0, 1, 2].map(|a| column(Role::Offset(a)));
            let drift_cols = [0, 1, 2].map(|a| column(Role::Drift(k, a)));
            let weights = self.weights[k];
            // Per axis, the rows' seven derivative slots (radius, ω, tilt, phase, β, offset,
            // drift) always land in the same columns: accumulate a dense 7 × 7 block per axis
            // (fixed indices, no branches in the sample loop) and scatter it once.
            let mut block = [[[0.0f64; SLOTS]; SLOTS]; 3];
            let mut block_r = [[0.0f64; SLOTS]; 3];
            for_each_derivative(&sessions[k], &mounting, self.gravity, &rec.time_s, |i, d| {
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
            });
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

/// Starting values for one recording from a linear fit of mean + sine + cosine (+ slope) at ω.
struct SinusoidFit {
    mean: [f64; 3],
    sin: [f64; 3],
    cos: [f64; 3],
    noise: [f64; 3],
}

fn sinusoid_fit(rec: &Recording, omega: f64) -> SinusoidFit {
    let t0 = rec.time_s[0];
    let t_mid = 0.5 * (t0 + rec.time_s[rec.len() - 1]);
    let mut out = SinusoidFit {
        mean: [0.0; 3],
        sin: [0.0; 3],
        cos: [0.0; 3],
        noise: [0.0; 3],
    };
    // Columns 1, sin, cos, t − t_mid: solve the 4×4 normal equations (well conditioned here).
    for a in 0..3 {
        let y = &rec.accel_mps2[a];
        let mut ata = Mat::<f64>::zeros(4, 4);
        let mut aty = Mat::<f64>::zeros(4, 1);
        crate::turntable::model::for_each_rotation(&rec.time_s, t0, omega, 0.0, |i, s, c| {
            let row = [1.0, s, c, rec.time_s[i] - t_mid];
            for p in 0..4 {
                aty[(p, 0)] += row[p] * y[i];
                for q in 0..4 {
                    ata[(p, q)] += row[p] * row[q];
                }
            }
        });
        let coef = match ata.llt(Side::Lower) {
            Ok(llt) => faer::prelude::Solve::solve(&llt, &aty),
            Err(_) => Mat::zeros(4, 1),
        };
        let mut sse = 0.0;
        crate::turntable::model::for_each_rotation(&rec.time_s, t0, omega, 0.0, |i, s, c| {
            let m =
                coef[(0, 0)] + coef[(1, 0)] * s + coef[(2, 0)] * c + coef[(3, 0)] * (rec.time_s[i] - t_mid);
            sse += (y[i] - m) * (y[i] - m);
        });
        out.mean[a] = coef[(0, 0)];
        out.sin[a] = coef[(1, 0)];
        out.cos[a] = coef[(2, 0)];
        out.noise[a] = (sse / (rec.len() as f64 - 4.0)).sqrt().max(1e-6);
    }
    out
}

fn wrap_angle(x: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut y = x.rem_euclid(two_pi);
    if y > std::f64::consts::PI {
        y -= two_pi;
    }
    y
}

/// A turntable's line stands far above the spectrum's median (hundreds of times in real
/// recordings); below this the data hold no rotation.
const MIN_PEAK_TO_MEDIAN: f64 = 8.0;

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
    let defs = parameter_table(recordings, options, &looks)?;
    let bounds = Bounds {
        names: defs.iter().map(|d| d.name.clone()).collect(),
        lower: defs.iter().map(|d| d.lower).collect(),
        upper: defs.iter().map(|d| d.upper).collect(),
    };
    bounds.validate()?;
    let problem = build_problem(recordings, options, &looks, defs);
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
    let drift = drift_findings(&problem, &estimates);
    let recording_fits = recording_fits(&problem, &looks, &sessions, &mounting);
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

/// What one recording shows before any fit.
struct FirstLook {
    rate: RateEstimate,
    start: SinusoidFit,
    inspection: Inspection,
    direction: Direction,
}

/// The rotation rate from the spectrum (at least three turns are needed), a sinusoid fit at that
/// rate for the starting values, and the sense of rotation. A constant axis in the objective, or
/// a spectrum without a clear peak, is refused: there is no rotation to fit.
fn first_look(rec: &Recording, inspection: Inspection, options: &FitOptions) -> Result<FirstLook, FitError> {
    let search = match options.rpm_hint {
        Some(rpm) => RateSearch {
            min_rpm: 0.9 * rpm,
            max_rpm: 1.1 * rpm,
        },
        None => RateSearch::default(),
    };
    if let Some(advice) = crate::input::inspect::time_advice(rec) {
        return Err(FitError::Time {
            file: rec.source.name.clone(),
            advice,
        });
    }
    let rate = estimate_rotation_rate(rec, search)?;
    if let Some(axis) = inspection
        .constant_axes
        .iter()
        .find(|a| options.axes.axes().contains(&(**a as usize - 'x' as usize)))
    {
        return Err(FitError::ConstantAxis {
            file: rec.source.name.clone(),
            axis: *axis,
        });
    }
    let rotations = rec.duration_s() * rate.frequency_hz;
    // A line with fewer than 2 cycles in the window is not resolved: its frequency, and so the
    // rotation count, is not measured. Say so rather than give the count.
    // Three turns at the slowest record speed, 16⅔ rpm, take 10.8 s: a longer recording with no
    // resolved line is not turning (below), not short.
    if rotations < 2.0 && rec.duration_s() < 3.0 * 60.0 / (50.0 / 3.0) && options.rpm_hint.is_none() {
        return Err(FitError::TooShortToMeasure {
            file: rec.source.name.clone(),
            duration_s: rec.duration_s(),
        });
    }
    if (2.0..3.0).contains(&rotations) || (rotations < 3.0 && options.rpm_hint.is_some()) {
        return Err(FitError::TooFewRotations {
            file: rec.source.name.clone(),
            basis: if options.rpm_hint.is_some() {
                "the rate found within 10 % of the rpm given"
            } else {
                "measured"
            },
            rotations,
            rpm: rate.rpm,
            duration_s: rec.duration_s(),
        });
    }
    if rotations < 2.0 || rate.peak_to_median.is_nan() || rate.peak_to_median < MIN_PEAK_TO_MEDIAN {
        return Err(FitError::NoRotation {
            file: rec.source.name.clone(),
            peak_to_median: rate.peak_to_median,
            rpm: rate.rpm,
            advice: crate::input::inspect::repeated_stamps_advice(rec)
                .unwrap_or_else(|| "was the turntable turning?".to_string()),
        });
    }
    let start = sinusoid_fit(rec, rate.omega_radps);
    // Sense of rotation: y leads x by a quarter turn for s = +1 (see the model's equations).
    let direction = Direction::from_sign(start.cos[1] * start.sin[0] - start.sin[1] * start.cos[0]);
    Ok(FirstLook {
        rate,
        start,
        inspection,
        direction,
    })
}

/// Every free parameter with its unit, bounds and starting value: shared ones first (β, offsets,
/// a shared radius), then each recording's; the user's `--bounds` replace the defaults.
fn parameter_table(
    recordings: &[&Recording],
    options: &FitOptions,
    looks: &[FirstLook],
) -> Result<Vec<ParamDef>, FitError> {
    let mut defs = shared_parameters(options, looks);
    for k in 0..recordings.len() {
        defs.extend(recording_parameters(k, recordings, options, looks));
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
fn beta_start(looks: &[FirstLook]) -> f64 {
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

/// Recording `k`'s own parameters: its radius (when not shared), ω, tilt, phase and drift.
fn recording_parameters(
    k: usize,
    recordings: &[&Recording],
    options: &FitOptions,
    looks: &[FirstLook],
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
    defs.push(ParamDef {
        name: format!("phase{suffix}"),
        unit: "rad",
        role: Role::Phase(k),
        lower: -2.0 * pi,
        upper: 2.0 * pi,
        start: wrap_angle(s.cos[0].atan2(s.sin[0]) + beta0),
    });
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

/// The least-squares problem: residuals weighted by each recording's noise, the radius prior,
/// and the per-block moments that make Nelder–Mead's cost O(blocks).
fn build_problem<'a>(
    recordings: &'a [&'a Recording],
    options: &FitOptions,
    looks: &[FirstLook],
    defs: Vec<ParamDef>,
) -> Problem<'a> {
    let prior = options.radius.and_then(|p| {
        defs.iter()
            .position(|d| matches!(d.role, Role::Radius(_)))
            .map(|i| (i, p))
    });
    let n = recordings.len();
    Problem {
        recordings,
        directions: looks.iter().map(|l| l.direction).collect(),
        axes: options.axes.axes(),
        weights: looks.iter().map(|l| l.start.noise.map(|v| 1.0 / v)).collect(),
        gravity: options.gravity_mps2,
        prior,
        n_recordings: n,
        moments: (0..n)
            .map(|k| {
                let omega = defs.iter().find(|d| d.role == Role::Omega(k))?;
                let centre = 0.5 * (omega.lower + omega.upper);
                CostMoments::new(recordings[k], centre, 0.5 * (omega.upper - omega.lower).abs())
            })
            .collect(),
        defs,
    }
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

/// The fitted values (angles wrapped) with standard errors and correlations.
struct Estimates {
    values: Vec<f64>,
    params: Vec<FittedParam>,
    correlation: Vec<Vec<f64>>,
}

/// Standard errors from σ²(JᵀJ)⁺; parameters in null directions of the scaled JᵀJ are reported as
/// not determined, with no standard error and NaN correlations.
fn estimates(problem: &Problem, bounds: &Bounds, lm: &LmReport) -> Estimates {
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
fn drift_findings(problem: &Problem, estimates: &Estimates) -> Vec<DriftFinding> {
    let mut drift = Vec::new();
    for (i, def) in problem.defs.iter().enumerate() {
        if let Role::Drift(k, a) = def.role {
            let span = problem.recordings[k].duration_s();
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

/// The fitted model against each recording: fit % and residual RMS per axis.
fn recording_fits(
    problem: &Problem,
    looks: &[FirstLook],
    sessions: &[Session],
    mounting: &Mounting,
) -> Vec<RecordingFit> {
    let mut fits = Vec::new();
    for (k, rec) in problem.recordings.iter().enumerate() {
        // The model is compared sample by sample, never stored (it would be as large as the
        // recording).
        let mut sums = [0, 1, 2].map(|a| FitSums::new(&rec.accel_mps2[a]));
        for_each_sample(
            &sessions[k],
            mounting,
            problem.gravity,
            &rec.time_s,
            |i, model| {
                for (a, sums) in sums.iter_mut().enumerate() {
                    sums.add(rec.accel_mps2[a][i], model[a]);
                }
            },
        );
        fits.push(RecordingFit {
            name: rec.source.name.clone(),
            rate: looks[k].rate.clone(),
            inspection: looks[k].inspection.clone(),
            session: sessions[k],
            fit_percent: sums.map(|s| s.fit_percent()),
            residual_rms_mps2: sums.map(|s| s.rmse()),
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

fn remedy_for(undetermined: &[String], recordings: usize, options: &FitOptions) -> Option<String> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::turntable::model::Direction;

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
        let defs = parameter_table(&recordings, &options, &looks).unwrap();
        let problem = build_problem(&recordings, &options, &looks, defs);
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
