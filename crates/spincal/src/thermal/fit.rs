//! Fitting the thermal sensor model to still recordings that carry the sensor's temperature.
//!
//! Each still recording holds one orientation; its die temperature comes from its own reported
//! temperature, or from its session's when the recordings follow each other on one clock
//! ([`super::die_temperatures`]). It is cut into windows of `window_s`, and each
//! window's mean reading is compared with the model's reading of gravity (`gravity` m/s²) along
//! that recording's direction, which is fitted too (two angles per recording). So a warm-up in one
//! orientation ties every axis's reading across temperature, and poses in several orientations at
//! several temperatures separate the bias's change from the gain's.
//!
//! **Choices the data make.**
//! - The lag τ: the value on `lags_s` with the smallest residual, at the fixed orders (`orders`)
//!   or else the highest tried. When that is the grid's top (and not 0), the grid is extended by
//!   doubling its top up to [`MAX_LAG_S`]; a lag still best at [`MAX_LAG_S`] (or at a top beyond
//!   it) is not determined by the recordings and the fit is refused ([`ThermalError::LagAtEdge`]).
//! - The polynomial orders of β and ρ: fitted on the windows whose die temperature lies between the
//!   `held_out_fraction` and 1 − `held_out_fraction` quantiles, scored on the rest (the coldest and
//!   hottest bands) without truth: each held-out window is corrected and compared with gravity along
//!   its recording's mean corrected direction (magnitude and consistency). The simplest orders
//!   within 2 % of the best score win; the model is then refitted on every window.

use faer::prelude::Solve;
use faer::{Mat, MatMut, Side};
use serde::{Deserialize, Serialize};

use super::{ThermalModel, MAX_LAG_S, REFERENCE_PARAMS};
use crate::geometry::{cross, unit, M3};
use crate::input::recording::Recording;
use crate::optim::{levenberg_marquardt, LeastSquares, LmOptions};

/// How the thermal model is fitted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ThermalSettings {
    /// Length of the windows each still recording is averaged over, s.
    pub window_s: f64,
    /// Width of the window the reported temperature is smoothed over, s (see [`super`]).
    pub smoothing_s: f64,
    /// Candidate lags τ of the temperature sensor, s.
    pub lags_s: Vec<f64>,
    /// Highest order of β tried (0 to 3; 0 with `max_scale_order` 0 fits no thermal change).
    pub max_bias_order: usize,
    /// Highest order of ρ tried (0 to 3).
    pub max_scale_order: usize,
    /// Fraction of windows held out at each end of the temperature range to choose the orders.
    pub held_out_fraction: f64,
    /// T_ref, °C; the median die temperature of the windows when `None`.
    pub reference_c: Option<f64>,
    /// The orders of β and ρ, when fixed instead of chosen on the held-out bands.
    pub orders: Option<[usize; 2]>,
}

impl Default for ThermalSettings {
    fn default() -> Self {
        ThermalSettings {
            window_s: 2.0,
            smoothing_s: 60.0,
            lags_s: vec![0.0, 10.0, 20.0, 40.0, 80.0],
            max_bias_order: 3,
            max_scale_order: 2,
            held_out_fraction: 0.2,
            reference_c: None,
            orders: None,
        }
    }
}

/// Why a thermal fit cannot run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ThermalError {
    #[error("{file}: no temperature column (name one `temp`, `temperature` or `temp_c`, or list it as the last of `columns`)")]
    NoTemperature { file: String },
    #[error("{file}: shorter than one {window_s} s window")]
    TooShort { file: String, window_s: f64 },
    #[error("the still recordings span {span_c:.2} °C of die temperature; a thermal model needs at least {needed_c} °C (record a warm-up, or poses at several temperatures)")]
    NarrowRange { span_c: f64, needed_c: f64 },
    /// The fitted model breaks the plausibility limits ([`ThermalModel::check_plausible`]): it
    /// is not saved.
    #[error("the fitted thermal model is implausible ({field}: {reason}); it is not saved")]
    Implausible { field: String, reason: String },
    /// The lag fits best at the longest tried, [`MAX_LAG_S`] or the grid's top beyond it: the
    /// recordings do not determine it.
    #[error("the temperature sensor's lag fits best at {lag_s:.0} s, the longest tried (the grid is extended up to {max_lag_s:.0} s): the recordings do not determine it, so no thermal model is saved; record a longer warm-up or cool-down, still, so that the die's temperature settles within it")]
    LagAtEdge { lag_s: f64, max_lag_s: f64 },
    #[error("parameter thermal.{name} = {value}: {why}")]
    Setting {
        name: &'static str,
        value: String,
        why: &'static str,
    },
}

/// The orders tried and their held-out scores.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct OrderScore {
    pub bias_order: usize,
    pub scale_order: usize,
    /// RMS of the held-out windows' corrected readings against gravity, m/s².
    pub held_out_rms_mps2: f64,
}

/// The fitted thermal model and how it was chosen.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThermalFit {
    pub model: ThermalModel,
    pub bias_order: usize,
    pub scale_order: usize,
    /// (τ, RMS residual at the fixed or the highest orders) for each lag tried (`lags_s`, then
    /// any the search extended it by).
    pub lag_scores: Vec<(f64, f64)>,
    /// Every order pair tried on the held-out bands (empty when the orders were fixed).
    pub order_scores: Vec<OrderScore>,
    /// Die temperatures that bound the held-out bands, °C (below the first, above the second).
    pub held_out_bands_c: [f64; 2],
    /// RMS residual of the final fit, m/s².
    pub residual_rms_mps2: f64,
    /// Standard errors of β (per axis, per order) and ρ, from the final fit's curvature: they
    /// hold the die temperature as known. Its estimate's own error is not in them (measured: with
    /// a 20 s lag and 1 °C steps the 95 % intervals held the truth 79 % of the time, against 96 %
    /// with the die temperature logged exactly).
    pub bias_per_c_se: [Vec<f64>; 3],
    pub scale_per_c_se: [Vec<f64>; 3],
    pub windows: usize,
}

/// A window of one recording: its mean reading, its mean die temperature, its recording.
#[derive(Debug, Clone, Copy)]
struct Window {
    recording: usize,
    reading: [f64; 3],
    die_c: f64,
}

impl ThermalSettings {
    /// Checks every setting; the first that cannot be used is named.
    pub fn check(&self) -> Result<(), ThermalError> {
        let bad = |name, value: String, why| Err(ThermalError::Setting { name, value, why });
        if !(self.window_s.is_finite() && self.window_s > 0.0) {
            return bad(
                "window_s",
                self.window_s.to_string(),
                "must be a positive number of seconds",
            );
        }
        if !(self.smoothing_s.is_finite() && self.smoothing_s > 0.0) {
            return bad(
                "smoothing_s",
                self.smoothing_s.to_string(),
                "must be a positive number of seconds",
            );
        }
        if self.lags_s.is_empty() || self.lags_s.iter().any(|l| !(l.is_finite() && *l >= 0.0)) {
            return bad(
                "lags_s",
                format!("{:?}", self.lags_s),
                "must list at least one lag ≥ 0 s",
            );
        }
        if self.max_bias_order > 3 {
            return bad(
                "max_bias_order",
                self.max_bias_order.to_string(),
                "must be 0 to 3",
            );
        }
        if self.max_scale_order > 3 {
            return bad(
                "max_scale_order",
                self.max_scale_order.to_string(),
                "must be 0 to 3",
            );
        }
        if let Some(orders) = self.orders {
            if orders[0] > 3 || orders[1] > 3 {
                return bad("orders", format!("{orders:?}"), "each order must be 0 to 3");
            }
        }
        if !(0.0..0.5).contains(&self.held_out_fraction) {
            return bad(
                "held_out_fraction",
                self.held_out_fraction.to_string(),
                "must be in [0, 0.5)",
            );
        }
        Ok(())
    }
}

/// Windows of the still recordings with die temperatures for lag `lag_s`.
fn windows(
    stills: &[&Recording],
    settings: &ThermalSettings,
    lag_s: f64,
) -> Result<Vec<Window>, ThermalError> {
    if let Some(rec) = stills.iter().find(|r| r.temperature_c.is_none()) {
        return Err(ThermalError::NoTemperature {
            file: rec.source.name.clone(),
        });
    }
    let dies = super::die_temperatures(stills, lag_s, settings.smoothing_s);
    let mut out = Vec::new();
    for (r, (rec, die)) in stills.iter().zip(dies).enumerate() {
        let die = die.unwrap_or_default();
        let before = out.len();
        let mut start = 0;
        while start < rec.len() {
            let end_t = rec.time_s[start] + settings.window_s;
            let end = start + rec.time_s[start..].partition_point(|&t| t < end_t);
            if rec.time_s.get(end).is_none()
                && rec.time_s[end - 1] - rec.time_s[start] < 0.9 * settings.window_s
            {
                break;
            }
            let n = (end - start) as f64;
            let reading = std::array::from_fn(|k| rec.accel_mps2[k][start..end].iter().sum::<f64>() / n);
            let die_c = die[start..end].iter().sum::<f64>() / n;
            out.push(Window {
                recording: r,
                reading,
                die_c,
            });
            start = end;
        }
        if out.len() == before {
            return Err(ThermalError::TooShort {
                file: rec.source.name.clone(),
                window_s: settings.window_s,
            });
        }
    }
    Ok(out)
}

/// The least-squares problem over some windows (recordings renumbered to those present).
struct Problem<'a> {
    windows: &'a [Window],
    bias_order: usize,
    scale_order: usize,
    reference_c: f64,
    gravity: f64,
    /// Per recording: the starting direction and two unit vectors across it.
    frames: Vec<M3>,
}

fn frame(direction: [f64; 3]) -> M3 {
    let u = unit(direction);
    let helper = if u[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let e1 = unit(cross(&u, &helper));
    [u, e1, cross(&u, &e1)]
}

impl Problem<'_> {
    fn n_sensor(&self) -> usize {
        REFERENCE_PARAMS + 3 * (self.bias_order + self.scale_order)
    }

    fn model(&self, p: &[f64], lag_s: f64, smoothing_s: f64, range: [f64; 2]) -> ThermalModel {
        let (kb, ks) = (self.bias_order, self.scale_order);
        let beta = 9;
        let rho = 9 + 3 * kb;
        ThermalModel {
            reference_c: self.reference_c,
            bias_mps2: [p[0], p[1], p[2]],
            scale_error: [p[3], p[4], p[5]],
            misalignment_rad: [p[6], p[7], p[8]],
            bias_per_c: std::array::from_fn(|k| p[beta + k * kb..beta + (k + 1) * kb].to_vec()),
            scale_per_c: std::array::from_fn(|k| p[rho + k * ks..rho + (k + 1) * ks].to_vec()),
            lag_s,
            smoothing_s,
            fitted_range_c: range,
        }
    }

    /// The direction of recording `r` and its derivatives along the two angles.
    fn direction(&self, p: &[f64], r: usize) -> ([f64; 3], [[f64; 3]; 2]) {
        let o = self.n_sensor() + 2 * r;
        let [u0, e1, e2] = self.frames[r];
        let w: [f64; 3] = std::array::from_fn(|i| u0[i] + p[o] * e1[i] + p[o + 1] * e2[i]);
        let norm = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        let u = w.map(|x| x / norm);
        let d = |e: [f64; 3]| {
            let along = u[0] * e[0] + u[1] * e[1] + u[2] * e[2];
            std::array::from_fn(|i| (e[i] - u[i] * along) / norm)
        };
        (u, [d(e1), d(e2)])
    }
}

impl LeastSquares for Problem<'_> {
    fn n_params(&self) -> usize {
        self.n_sensor() + 2 * self.frames.len()
    }

    fn n_residuals(&self) -> usize {
        3 * self.windows.len()
    }

    fn residuals(&self, p: &[f64], out: &mut [f64]) {
        let model = self.model(p, 0.0, 0.0, [0.0; 2]);
        for (w, window) in self.windows.iter().enumerate() {
            let (u, _) = self.direction(p, window.recording);
            let predicted = model.reading(u.map(|x| x * self.gravity), window.die_c);
            for k in 0..3 {
                out[3 * w + k] = window.reading[k] - predicted[k];
            }
        }
    }

    fn jacobian(&self, p: &[f64], mut out: MatMut<'_, f64>) {
        let (kb, ks) = (self.bias_order, self.scale_order);
        let model = self.model(p, 0.0, 0.0, [0.0; 2]);
        let [m_yx, m_zx, m_zy] = model.misalignment_rad;
        let skew = [[1.0, 0.0, 0.0], [m_yx, 1.0, 0.0], [m_zx, m_zy, 1.0]];
        for c in 0..out.ncols() {
            for r in 0..out.nrows() {
                out[(r, c)] = 0.0;
            }
        }
        for (w, window) in self.windows.iter().enumerate() {
            let (u, du) = self.direction(p, window.recording);
            let f = u.map(|x| x * self.gravity);
            let v = [f[0], f[1] + m_yx * f[0], f[2] + m_zx * f[0] + m_zy * f[1]];
            let dt = window.die_c - self.reference_c;
            let rho = model.scale_change(window.die_c);
            let gain: [f64; 3] = std::array::from_fn(|k| (1.0 + model.scale_error[k]) * (1.0 + rho[k]));
            for k in 0..3 {
                let row = 3 * w + k;
                out[(row, k)] = -1.0;
                out[(row, 3 + k)] = -(1.0 + rho[k]) * v[k];
                let mut power = 1.0;
                for j in 0..kb.max(ks) {
                    power *= dt;
                    if j < kb {
                        out[(row, 9 + k * kb + j)] = -power;
                    }
                    if j < ks {
                        out[(row, 9 + 3 * kb + k * ks + j)] = -(1.0 + model.scale_error[k]) * power * v[k];
                    }
                }
                let o = self.n_sensor() + 2 * window.recording;
                for a in 0..2 {
                    let dv: f64 = (0..3).map(|i| skew[k][i] * du[a][i]).sum();
                    out[(row, o + a)] = -gain[k] * self.gravity * dv;
                }
            }
            out[(3 * w + 1, 6)] = -gain[1] * f[0];
            out[(3 * w + 2, 7)] = -gain[2] * f[0];
            out[(3 * w + 2, 8)] = -gain[2] * f[1];
        }
    }
}

struct Solved {
    params: Vec<f64>,
    rms: f64,
    covariance_diagonal: Vec<f64>,
}

/// Fits orders (`bias_order`, `scale_order`) to `windows` (their recordings renumbered).
fn solve(
    windows: &[Window],
    bias_order: usize,
    scale_order: usize,
    reference_c: f64,
    gravity: f64,
) -> (Problem<'_>, Solved) {
    let problem = problem(windows, bias_order, scale_order, reference_c, gravity);
    let p0 = vec![0.0; problem.n_params()];
    let report = levenberg_marquardt(&problem, &p0, &LmOptions::default(), &crate::progress::silent);
    let n_res = problem.n_residuals() as f64;
    let dof = (n_res - problem.n_params() as f64).max(1.0);
    let sigma2 = report.sse / dof;
    let covariance_diagonal = inverse_diagonal(&report.jtj)
        .map(|d| d.into_iter().map(|x| x * sigma2).collect())
        .unwrap_or_else(|| vec![f64::NAN; problem.n_params()]);
    let rms = (report.sse / n_res).sqrt();
    (
        problem,
        Solved {
            params: report.params,
            rms,
            covariance_diagonal,
        },
    )
}

/// The problem over `windows`, each recording's direction started at its windows' mean reading.
fn problem(
    windows: &[Window],
    bias_order: usize,
    scale_order: usize,
    reference_c: f64,
    gravity: f64,
) -> Problem<'_> {
    let n_recordings = windows.iter().map(|w| w.recording + 1).max().unwrap_or(0);
    let frames = (0..n_recordings)
        .map(|r| {
            let mut sum = [0.0; 3];
            for w in windows.iter().filter(|w| w.recording == r) {
                (0..3).for_each(|k| sum[k] += w.reading[k]);
            }
            frame(sum)
        })
        .collect();
    Problem {
        windows,
        bias_order,
        scale_order,
        reference_c,
        gravity,
        frames,
    }
}

/// The diagonal of H⁻¹ for a symmetric positive definite H.
fn inverse_diagonal(h: &Mat<f64>) -> Option<Vec<f64>> {
    let n = h.nrows();
    let inverse = h.llt(Side::Lower).ok()?.solve(Mat::<f64>::identity(n, n));
    Some((0..n).map(|i| inverse[(i, i)]).collect())
}

/// Renumbers the windows' recordings to those present, in order.
fn renumbered(windows: impl Iterator<Item = Window>) -> Vec<Window> {
    let mut map = std::collections::BTreeMap::new();
    let mut out: Vec<Window> = windows.collect();
    for w in &out {
        let next = map.len();
        map.entry(w.recording).or_insert(next);
    }
    for w in &mut out {
        w.recording = map[&w.recording];
    }
    out
}

/// RMS of held-out windows corrected by `model`, against gravity along each recording's mean
/// corrected direction.
fn held_out_rms(model: &ThermalModel, windows: &[Window], gravity: f64) -> f64 {
    let corrected: Vec<[f64; 3]> = windows
        .iter()
        .map(|w| model.correct(w.reading, w.die_c))
        .collect();
    let mut directions = std::collections::BTreeMap::<usize, [f64; 3]>::new();
    for (w, f) in windows.iter().zip(&corrected) {
        let d = directions.entry(w.recording).or_insert([0.0; 3]);
        (0..3).for_each(|k| d[k] += f[k]);
    }
    let mut sum = 0.0;
    for (w, f) in windows.iter().zip(&corrected) {
        let u = unit(directions[&w.recording]);
        sum += (0..3).map(|k| (f[k] - gravity * u[k]).powi(2)).sum::<f64>();
    }
    (sum / (3 * windows.len()).max(1) as f64).sqrt()
}

fn quantile(values: &[f64], q: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

/// The narrowest die-temperature span a thermal model is fitted over, °C.
pub(crate) const MIN_SPAN_C: f64 = 3.0;

/// Fits the thermal model to still recordings (each in one orientation) that carry a temperature.
/// The temperatures are taken as given: a campaign checks them first
/// ([`super::checks`], masking glitches, resets and implausible values). A model that breaks the
/// plausibility limits ([`ThermalModel::check_plausible`]) is refused; so is one whose lag fits
/// best at the top of `lags_s` extended up to [`MAX_LAG_S`] ([`ThermalError::LagAtEdge`]).
pub fn fit_thermal(
    stills: &[&Recording],
    settings: &ThermalSettings,
    gravity: f64,
) -> Result<ThermalFit, ThermalError> {
    settings.check()?;
    // The lag: at the fixed or the highest orders, on every window.
    let (kb, ks) = match settings.orders {
        Some([kb, ks]) => (kb, ks),
        None => (settings.max_bias_order, settings.max_scale_order),
    };
    let (lag_scores, all, at_best_lag, lag_s) = best_lag(stills, settings, (kb, ks), gravity)?;
    let temps: Vec<f64> = all.iter().map(|w| w.die_c).collect();
    let search = OrderSearch {
        settings,
        reference_c: settings.reference_c.unwrap_or_else(|| quantile(&temps, 0.5)),
        lag_s,
        range: [quantile(&temps, 0.0), quantile(&temps, 1.0)],
        gravity,
    };
    let bands = [
        quantile(&temps, settings.held_out_fraction),
        quantile(&temps, 1.0 - settings.held_out_fraction),
    ];
    let order_scores = search.order_scores(&all, bands, (kb, ks));
    let chosen = chosen_orders(&order_scores, (kb, ks));
    // The lag's fit at these orders is the final one when they are the orders it used.
    let (reference_c, range) = (search.reference_c, search.range);
    let (problem, solved) = if chosen == (kb, ks) {
        (problem(&all, kb, ks, reference_c, gravity), at_best_lag)
    } else {
        solve(&all, chosen.0, chosen.1, reference_c, gravity)
    };
    let model = problem.model(&solved.params, lag_s, settings.smoothing_s, range);
    model.check_plausible().map_err(|e| ThermalError::Implausible {
        field: e.field,
        reason: e.reason,
    })?;
    let se = |o: usize, k: usize, order: usize| -> Vec<f64> {
        (0..order)
            .map(|j| solved.covariance_diagonal[o + k * order + j].max(0.0).sqrt())
            .collect()
    };
    Ok(ThermalFit {
        bias_per_c_se: std::array::from_fn(|k| se(9, k, chosen.0)),
        scale_per_c_se: std::array::from_fn(|k| se(9 + 3 * chosen.0, k, chosen.1)),
        model,
        bias_order: chosen.0,
        scale_order: chosen.1,
        lag_scores,
        order_scores,
        held_out_bands_c: bands,
        residual_rms_mps2: solved.rms,
        windows: all.len(),
    })
}

/// (lag, residual RMS) per lag tried.
type LagScores = Vec<(f64, f64)>;

/// Each lag's residual RMS at `orders` (bias, scale) on every window, the windows and fit of the
/// best lag, and the best lag. A best lag at the grid's top is not determined (0 is a physical
/// bound, not an edge: a sensor may not lag): the grid is extended by doubling its top up to
/// [`MAX_LAG_S`], and a lag still best at the top is refused.
fn best_lag(
    stills: &[&Recording],
    settings: &ThermalSettings,
    (kb, ks): (usize, usize),
    gravity: f64,
) -> Result<(LagScores, Vec<Window>, Solved, f64), ThermalError> {
    let mut lag_scores = Vec::new();
    let mut best: Option<(f64, Vec<Window>, Solved, f64)> = None;
    let mut grid = settings.lags_s.clone();
    let mut next = 0;
    while next < grid.len() {
        let lag = grid[next];
        next += 1;
        let all = windows(stills, settings, lag)?;
        let temps: Vec<f64> = all.iter().map(|w| w.die_c).collect();
        let (lo, hi) = (quantile(&temps, 0.0), quantile(&temps, 1.0));
        if kb + ks > 0 && hi - lo < MIN_SPAN_C {
            return Err(ThermalError::NarrowRange {
                span_c: hi - lo,
                needed_c: MIN_SPAN_C,
            });
        }
        let reference = settings.reference_c.unwrap_or_else(|| quantile(&temps, 0.5));
        let (_, solved) = solve(&all, kb, ks, reference, gravity);
        lag_scores.push((lag, solved.rms));
        if best.as_ref().is_none_or(|(rms, ..)| solved.rms < *rms) {
            best = Some((solved.rms, all, solved, lag));
        }
        if next == grid.len() {
            let top = grid.iter().copied().fold(0.0, f64::max);
            let at_top = best.as_ref().is_some_and(|b| b.3 == top && top > 0.0);
            if at_top && top < MAX_LAG_S {
                grid.push((2.0 * top).min(MAX_LAG_S));
            } else if at_top {
                return Err(ThermalError::LagAtEdge {
                    lag_s: top,
                    max_lag_s: MAX_LAG_S,
                });
            }
        }
    }
    let (_, all, at_best_lag, lag_s) = best.expect("at least one lag (checked)");
    Ok((lag_scores, all, at_best_lag, lag_s))
}

/// What every order's held-out score shares: the lag and temperatures the model is made at.
struct OrderSearch<'a> {
    settings: &'a ThermalSettings,
    reference_c: f64,
    lag_s: f64,
    range: [f64; 2],
    gravity: f64,
}

impl OrderSearch<'_> {
    /// The orders up to (`kb`, `ks`) (none when the settings fix them): fitted inside the `bands`,
    /// scored on the coldest and hottest windows.
    fn order_scores(&self, all: &[Window], bands: [f64; 2], (kb, ks): (usize, usize)) -> Vec<OrderScore> {
        let inside = renumbered(
            all.iter()
                .copied()
                .filter(|w| w.die_c >= bands[0] && w.die_c <= bands[1]),
        );
        let outside = renumbered(
            all.iter()
                .copied()
                .filter(|w| w.die_c < bands[0] || w.die_c > bands[1]),
        );
        let mut order_scores = Vec::new();
        let candidates = if self.settings.orders.is_some() {
            Vec::new()
        } else {
            (0..=kb).flat_map(|b| (0..=ks).map(move |s| (b, s))).collect()
        };
        for (bias_order, scale_order) in candidates {
            let score = if outside.is_empty() || inside.is_empty() {
                f64::NAN
            } else {
                let (problem, solved) =
                    solve(&inside, bias_order, scale_order, self.reference_c, self.gravity);
                held_out_rms(
                    &problem.model(&solved.params, self.lag_s, self.settings.smoothing_s, self.range),
                    &outside,
                    self.gravity,
                )
            };
            order_scores.push(OrderScore {
                bias_order,
                scale_order,
                held_out_rms_mps2: score,
            });
        }
        order_scores
    }
}

/// The lowest orders within 2 % of the best held-out score, or `max` when none was scored.
fn chosen_orders(order_scores: &[OrderScore], max: (usize, usize)) -> (usize, usize) {
    let best_score = order_scores
        .iter()
        .map(|s| s.held_out_rms_mps2)
        .filter(|s| s.is_finite())
        .fold(f64::INFINITY, f64::min);
    order_scores
        .iter()
        .filter(|s| s.held_out_rms_mps2 <= 1.02 * best_score)
        .min_by_key(|s| (s.bias_order + s.scale_order, s.bias_order))
        .map(|s| (s.bias_order, s.scale_order))
        .unwrap_or(max)
}
