//! Fitting the thermal sensor model to still recordings that carry the sensor's temperature.
//!
//! Each still recording holds one orientation; its die temperature comes from its own reported
//! temperature, or from the track it continues when recordings follow each other on one clock
//! within the smoothing window ([`super::die_temperatures`]: a matter of the temperature's
//! estimate only, never of the bias). It is cut into windows of `window_s`, and each window's mean
//! reading is compared with the model's reading of gravity (`gravity` m/s²) along that
//! recording's direction, which is fitted too (two angles per recording). So a warm-up in one
//! orientation ties every axis's reading across temperature, and poses in several orientations at
//! several temperatures separate the bias's change from the gain's.
//!
//! **Power-on sessions** (as the campaign's joint fit has them, `campaign::joint::spread`): each
//! recording belongs to a session ([`fit_thermal_in_sessions`]; [`fit_thermal`] takes them all as
//! one). With two sessions or more, each carries a bias offset δ ~ N(0, σ²) about the unit's bias,
//! and σ is chosen by the windows' marginal likelihood (Laplace, about a first pass at the search
//! range's geometric middle; [`ThermalSessions`]). A bias that moved between power-ons is then not
//! read as a change with temperature, and one that did not (σ at the search's low end) leaves the
//! poses to inform β. No gap between recordings decides a session.
//!
//! **A nonlinearity** ([`ThermalSettings::fit_nonlinearity`], set by a campaign): each axis's q
//! is fitted in a first pass and taken out of the readings, so that neither the sessions'
//! offsets nor the lag take up the q·f² a pose carries.
//!
//! **Choices the data make.**
//! - The lag τ: the value on `lags_s` with the smallest residual, at the fixed orders (`orders`)
//!   or else the highest tried, with every recording in one session (an offset per pose file
//!   would take up what a wrong lag leaves in that pose). When that is the grid's top (and not 0), the grid is extended by
//!   doubling its top up to [`MAX_LAG_S`]; a lag still best at [`MAX_LAG_S`] (or at a top beyond
//!   it) is not determined by the recordings and the fit is refused ([`ThermalError::LagAtEdge`]).
//!   Whether the recordings can determine the lag at all is reported ([`ThermalFit::lag_rate_r2`]).
//! - The polynomial orders of β and ρ, per axis, by the campaign's one terms rule: from the
//!   highest orders, each axis's highest coefficient of β and of ρ is kept when its Wald statistic
//!   |c/se| reaches [`crate::metrics::TERM_FALSE_ALARM`]'s threshold, se from the larger of the
//!   classical and the block-robust variance (blocks of `smoothing_s` within a recording, where
//!   the die temperature's estimate errs together; the sandwich alone runs low, see `solve`); the ones that do not are dropped and the model refitted, until every axis's
//!   highest term passes ([`ThermalTerms`]). No held-out score decides an order.

use faer::prelude::Solve;
use faer::{Mat, Side};
use serde::{Deserialize, Serialize};

use super::{coefficientwise, ThermalDirection, ThermalModel, MAX_LAG_S, REFERENCE_PARAMS};
use crate::geometry::{cross, unit, M3};
use crate::input::recording::Recording;
use crate::metrics::{share_beyond_noise, term_threshold, TERM_FALSE_ALARM};
use crate::optim::{levenberg_marquardt_normal, LmOptions, NormalEquations};

/// How the thermal model is fitted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ThermalSettings {
    /// Length of the windows each still recording is averaged over, s.
    pub window_s: f64,
    /// Width of the window the reported temperature is smoothed over, s (see [`super`]); also
    /// the length of the blocks of the robust covariance.
    pub smoothing_s: f64,
    /// Candidate lags τ of the temperature sensor, s.
    pub lags_s: Vec<f64>,
    /// Highest order of β tried (0 to 3; 0 with `max_scale_order` 0 fits no thermal change).
    pub max_bias_order: usize,
    /// Highest order of ρ tried (0 to 3).
    pub max_scale_order: usize,
    /// T_ref, °C; the median die temperature of the windows when `None`.
    pub reference_c: Option<f64>,
    /// The orders of β and ρ (every axis), when fixed instead of chosen by the terms rule.
    pub orders: Option<[usize; 2]>,
    /// Take each axis's quadratic nonlinearity q (m_k = w_k + q_k·w_k² on the gained reading w)
    /// out of the readings first, fitted in a first pass as a nuisance and not saved:
    /// [`ThermalModel`] carries no q. On in a campaign, whose joint fit carries q and uses the
    /// thermal model only to take readings to T_ref: unmodelled, a pose's q·f² is constant in
    /// that pose, and the sessions' offsets take it up as a spread (see `QUADRATIC_PRIOR_SD_G`);
    /// a campaign's thermal stage always sets it. Off (the default)
    /// where the thermal model is the corrector on its own: its b, s and M fitted beside a q it
    /// does not apply would be worse than fitted without (measured: the worst of 20 units in
    /// `thermal_corrector_near_the_oracle_on_held_out_temperatures` went from 1.09 to 1.28× the
    /// oracle, 1 s means, on units with no q).
    pub fit_nonlinearity: bool,
}

impl Default for ThermalSettings {
    fn default() -> Self {
        ThermalSettings {
            window_s: 2.0,
            smoothing_s: 60.0,
            lags_s: vec![0.0, 10.0, 20.0, 40.0, 80.0],
            max_bias_order: 3,
            max_scale_order: 2,
            reference_c: None,
            orders: None,
            fit_nonlinearity: false,
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
    /// The sessions given do not match the recordings one for one.
    #[error("{sessions} sessions given for {recordings} still recordings: one per recording")]
    Sessions { sessions: usize, recordings: usize },
}

/// One term the rule tested: an axis's highest coefficient of β or ρ at the orders of that step.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TermTest {
    /// "bias" (β) or "gain" (ρ).
    pub part: String,
    pub axis: usize,
    /// The power of ΔT.
    pub order: usize,
    /// c/se on the robust covariance.
    pub z: f64,
    pub kept: bool,
}

/// Which thermal terms the model carries, by the terms rule (see the module documentation).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ThermalTerms {
    /// The orders of β per axis.
    pub bias_orders: [usize; 3],
    /// The orders of ρ per axis.
    pub scale_orders: [usize; 3],
    /// The |z| a term must reach.
    pub threshold: f64,
    /// Every test made, step by step (empty when the orders were fixed).
    pub tests: Vec<TermTest>,
    /// The rule, in words.
    pub rule: String,
}

/// The power-on sessions the fit saw, and the spread of their bias offsets.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ThermalSessions {
    /// Sessions among the still recordings (1: one bias, no offsets).
    pub count: usize,
    /// σ, the standard deviation of a session's bias offset, m/s² (0 with one session).
    pub spread_sd_mps2: f64,
    /// True when σ sits at the search's low end: no spread is seen.
    pub at_lower_bound: bool,
    /// Twice the log-likelihood gained over the search's low end (χ²₁-like; about 0 when no
    /// spread is seen).
    pub likelihood_ratio: f64,
    /// Each session's offset, m/s², in the order the sessions were first met.
    pub offsets_mps2: Vec<[f64; 3]>,
}

/// The fitted thermal model and how it was chosen.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThermalFit {
    pub model: ThermalModel,
    /// The highest order of β over the axes (`terms` has each axis's).
    pub bias_order: usize,
    /// The highest order of ρ over the axes.
    pub scale_order: usize,
    /// (τ, RMS residual at the fixed or the highest orders) for each lag tried (`lags_s`, then
    /// any the search extended it by).
    pub lag_scores: Vec<(f64, f64)>,
    /// Each term the rule dropped that the windows still saw, as the change of the coefficients
    /// its return would make (longer than the model's where the term is of a higher order; see
    /// `left_out_moves`). The campaign carries them into the rows' error bars.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub left_out_moves: Vec<ThermalDirection>,
    /// The terms rule's tests and the orders it kept.
    #[serde(default)]
    pub terms: ThermalTerms,
    #[serde(default)]
    pub sessions: ThermalSessions,
    /// RMS residual of the final fit, m/s².
    pub residual_rms_mps2: f64,
    /// Standard errors of β (per axis, per order) and ρ from the final fit's robust covariance
    /// (blocks of `smoothing_s`): windows whose die temperature is estimated from one stretch of
    /// the reported temperature err together, and the blocks let that in.
    pub bias_per_c_se: [Vec<f64>; 3],
    pub scale_per_c_se: [Vec<f64>; 3],
    /// The covariance of β and ρ, in the order β_x1, β_x2, …, β_z…, ρ_x1, …, ρ_z…: the variances
    /// of the standard errors above with the classical fit's correlations (empty where the fit's
    /// normal matrix is singular).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub coefficient_covariance: Vec<Vec<f64>>,
    pub windows: usize,
    /// Whether the recordings can determine the lag at all: R² of the die temperature's rate
    /// against the die temperature over the blocks of `smoothing_s` (each block's rate the slope
    /// of its windows' die temperatures in time), at the lag chosen; `None` with fewer than
    /// [`LAG_RATE_MIN_BLOCKS`] blocks or no change of temperature. Near 1, every recording changes
    /// temperature along one curve dT/dt = a + bT (warm-ups of one shape towards one
    /// temperature): a lag error δτ then moves every die estimate by δτ(a + bT), a linear map of
    /// T that β and ρ absorb, so the residual barely depends on the lag and its choice falls to
    /// the die estimate's edge effects (measured: 0 to 40 s for a true 20 s on the thermal
    /// tests' units, R² 1.000000 with the die logged). Still poses at a steady temperature at
    /// the warm-up's ends, or warm-ups of different rates, break the line.
    #[serde(default)]
    pub lag_rate_r2: Option<f64>,
    /// `lag_rate_r2` below [`LAG_RATE_R2_LIMIT`]: the recordings determine the lag.
    #[serde(default)]
    pub lag_determined: bool,
}

/// The R² of rate against temperature above which the lag is taken as not determined.
pub const LAG_RATE_R2_LIMIT: f64 = 0.98;

/// The fewest blocks `lag_rate_r2` is computed from.
pub const LAG_RATE_MIN_BLOCKS: usize = 10;

/// R² of the die temperature's rate against the die temperature, one point per block of
/// windows (three windows or more, spanning at least half the block's own length); `None`
/// with too few points or rates that do not vary (a campaign of steady temperatures).
fn rate_temperature_r2(windows: &[Window]) -> Option<f64> {
    let mut points: Vec<(f64, f64)> = Vec::new();
    let mut start = 0;
    while start < windows.len() {
        let block = windows[start].block;
        let end = start + windows[start..].iter().take_while(|w| w.block == block).count();
        let members = &windows[start..end];
        if members.len() >= 3 {
            let n = members.len() as f64;
            let mean_t = members.iter().map(|w| w.time_s).sum::<f64>() / n;
            let mean_c = members.iter().map(|w| w.die_c).sum::<f64>() / n;
            let sxx: f64 = members.iter().map(|w| (w.time_s - mean_t).powi(2)).sum();
            let sxy: f64 = members
                .iter()
                .map(|w| (w.time_s - mean_t) * (w.die_c - mean_c))
                .sum();
            if sxx > 0.0 {
                points.push((mean_c, sxy / sxx));
            }
        }
        start = end;
    }
    if points.len() < LAG_RATE_MIN_BLOCKS {
        return None;
    }
    let n = points.len() as f64;
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let syy: f64 = points.iter().map(|p| (p.1 - my).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    // Rates that do not vary (every block steady): nothing to tell a lag by.
    if syy / n < 1e-12 || sxx <= 0.0 {
        return None;
    }
    Some((sxy * sxy / (sxx * syy)).clamp(0.0, 1.0))
}

/// A window of one recording: its mean reading, its mean die temperature, its recording, its
/// session and its block of the robust covariance.
#[derive(Debug, Clone, Copy)]
struct Window {
    recording: usize,
    session: usize,
    block: usize,
    reading: [f64; 3],
    die_c: f64,
    /// The window's first sample's time, s.
    time_s: f64,
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
        Ok(())
    }
}

/// Windows of the still recordings with die temperatures for lag `lag_s`; `sessions[r]` is
/// recording r's session (numbered from 0).
fn windows(
    stills: &[&Recording],
    sessions: &[usize],
    settings: &ThermalSettings,
    lag_s: f64,
) -> Result<Vec<Window>, ThermalError> {
    if let Some(rec) = stills.iter().find(|r| r.temperature_c.is_none()) {
        return Err(ThermalError::NoTemperature {
            file: rec.source.name.clone(),
        });
    }
    let dies = super::die_temperatures(stills, lag_s, settings.smoothing_s);
    let block_s = settings.smoothing_s.max(settings.window_s);
    let mut out = Vec::new();
    let mut block = 0;
    for (r, (rec, die)) in stills.iter().zip(dies).enumerate() {
        let die = die.unwrap_or_default();
        let before = out.len();
        let mut start = 0;
        let mut block_start = rec.time_s.first().copied().unwrap_or_default();
        while start < rec.len() {
            let end_t = rec.time_s[start] + settings.window_s;
            let end = start + rec.time_s[start..].partition_point(|&t| t < end_t);
            if rec.time_s.get(end).is_none()
                && rec.time_s[end - 1] - rec.time_s[start] < 0.9 * settings.window_s
            {
                break;
            }
            if rec.time_s[start] - block_start >= block_s {
                block += 1;
                block_start = rec.time_s[start];
            }
            let n = (end - start) as f64;
            let reading = std::array::from_fn(|k| rec.accel_mps2[k][start..end].iter().sum::<f64>() / n);
            let die_c = die[start..end].iter().sum::<f64>() / n;
            out.push(Window {
                recording: r,
                session: sessions[r],
                block,
                reading,
                die_c,
                time_s: rec.time_s[start],
            });
            start = end;
        }
        if out.len() == before {
            return Err(ThermalError::TooShort {
                file: rec.source.name.clone(),
                window_s: settings.window_s,
            });
        }
        block += 1;
    }
    Ok(out)
}

/// The orders of β and ρ, per axis.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Orders {
    bias: [usize; 3],
    scale: [usize; 3],
    /// q fitted as a nuisance (the first pass of [`ThermalSettings::fit_nonlinearity`]).
    quadratic: bool,
}

impl Orders {
    fn uniform(bias: usize, scale: usize) -> Orders {
        Orders {
            bias: [bias; 3],
            scale: [scale; 3],
            quadratic: false,
        }
    }

    fn terms(&self) -> usize {
        self.bias.iter().sum::<usize>() + self.scale.iter().sum::<usize>()
    }

    /// Where β_kj (j from 0 for ΔT¹) sits in the parameter vector.
    fn bias_index(&self, k: usize, j: usize) -> usize {
        REFERENCE_PARAMS + self.bias[..k].iter().sum::<usize>() + j
    }

    /// Where ρ_kj sits.
    fn scale_index(&self, k: usize, j: usize) -> usize {
        REFERENCE_PARAMS + self.bias.iter().sum::<usize>() + self.scale[..k].iter().sum::<usize>() + j
    }
}

/// The least-squares problem over the windows: the sensor's parameters, each session's bias
/// offset (when there are two sessions or more) and each recording's direction.
struct Problem<'a> {
    windows: &'a [Window],
    orders: Orders,
    reference_c: f64,
    gravity: f64,
    /// Per recording: the starting direction and two unit vectors across it.
    frames: Vec<M3>,
    /// Sessions with an offset (0 when every window is in one session).
    sessions: usize,
    /// Weight of each offset's prior row, s/σ (the windows' noise over the offsets' spread).
    prior_weight: f64,
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

/// Nonzero entries of one residual's Jacobian row: at most 9 + 6 terms + q + offset + 2 angles.
const ROW_ENTRIES: usize = 19;

/// The prior SD of each axis's quadratic nonlinearity q in the first pass of
/// [`ThermalSettings::fit_nonlinearity`], as a share of the reading at 1 g (1 %, twice a
/// consumer part's datasheet figure). q is a nuisance here (the campaign's joint fit carries
/// it): unmodelled, a pose's q·f² is constant in that pose, and the sessions' offsets take it up
/// as a spread (measured: 0.024 m/s² with LR 6170 on a unit of one power-on with q at 0.4 % of
/// 1 g), which frees the cold poses from the hot ones and leaves β to the warm-up alone. The
/// prior only keeps q finite where the poses' orientations do not determine it.
const QUADRATIC_PRIOR_SD_G: f64 = 0.01;

impl Problem<'_> {
    /// b, s, M, β, ρ and q when fitted (not in the model saved).
    fn n_sensor(&self) -> usize {
        REFERENCE_PARAMS + self.orders.terms() + if self.orders.quadratic { 3 } else { 0 }
    }

    fn quadratic_index(&self, k: usize) -> usize {
        REFERENCE_PARAMS + self.orders.terms() + k
    }

    /// Weight of q's prior rows: a window's noise guessed at 1 mg over q's prior SD.
    fn quadratic_prior_weight(&self) -> f64 {
        1e-3 * self.gravity / (QUADRATIC_PRIOR_SD_G / self.gravity)
    }

    fn offset_index(&self, session: usize, k: usize) -> usize {
        self.n_sensor() + 3 * session + k
    }

    fn direction_index(&self, r: usize) -> usize {
        self.n_sensor() + 3 * self.sessions + 2 * r
    }

    fn n_params(&self) -> usize {
        self.n_sensor() + 3 * self.sessions + 2 * self.frames.len()
    }

    fn n_residuals(&self) -> usize {
        3 * self.windows.len()
    }

    fn model(&self, p: &[f64], lag_s: f64, smoothing_s: f64, range: [f64; 2]) -> ThermalModel {
        let o = &self.orders;
        ThermalModel {
            reference_c: self.reference_c,
            bias_mps2: [p[0], p[1], p[2]],
            scale_error: [p[3], p[4], p[5]],
            misalignment_rad: [p[6], p[7], p[8]],
            bias_per_c: std::array::from_fn(|k| (0..o.bias[k]).map(|j| p[o.bias_index(k, j)]).collect()),
            scale_per_c: std::array::from_fn(|k| (0..o.scale[k]).map(|j| p[o.scale_index(k, j)]).collect()),
            lag_s,
            smoothing_s,
            fitted_range_c: range,
            uncertainty: None,
        }
    }

    /// The direction of recording `r` and its derivatives along the two angles.
    fn direction(&self, p: &[f64], r: usize) -> ([f64; 3], [[f64; 3]; 2]) {
        let o = self.direction_index(r);
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

    /// Calls `f(window, residual, row)` for every data residual with its Jacobian row's nonzero
    /// entries (column, ∂r/∂p): the Jacobian is never stored.
    fn visit(&self, p: &[f64], mut f: impl FnMut(usize, f64, &[(usize, f64)])) {
        let o = self.orders;
        let model = self.model(p, 0.0, 0.0, [0.0; 2]);
        let [m_yx, m_zx, m_zy] = model.misalignment_rad;
        let skew = [[1.0, 0.0, 0.0], [m_yx, 1.0, 0.0], [m_zx, m_zy, 1.0]];
        let mut row: Vec<(usize, f64)> = Vec::with_capacity(ROW_ENTRIES);
        for (w, window) in self.windows.iter().enumerate() {
            let (u, du) = self.direction(p, window.recording);
            let force = u.map(|x| x * self.gravity);
            let predicted = model.reading(force, window.die_c);
            let v = [
                force[0],
                force[1] + m_yx * force[0],
                force[2] + m_zx * force[0] + m_zy * force[1],
            ];
            let dt = window.die_c - self.reference_c;
            let rho = model.scale_change(window.die_c);
            let gain: [f64; 3] = std::array::from_fn(|k| (1.0 + model.scale_error[k]) * (1.0 + rho[k]));
            for k in 0..3 {
                row.clear();
                // q on the gained reading w: m = b + β + w + q·w²; what moves w moves the
                // reading by (1 + 2qw).
                let w_k = gain[k] * v[k];
                let q = if o.quadratic {
                    p[self.quadratic_index(k)]
                } else {
                    0.0
                };
                let curve = 1.0 + 2.0 * q * w_k;
                let mut residual = window.reading[k] - predicted[k] - q * w_k * w_k;
                if o.quadratic {
                    row.push((self.quadratic_index(k), -w_k * w_k));
                }
                row.push((k, -1.0));
                row.push((3 + k, -curve * (1.0 + rho[k]) * v[k]));
                let mut power = 1.0;
                for j in 0..o.bias[k].max(o.scale[k]) {
                    power *= dt;
                    if j < o.bias[k] {
                        row.push((o.bias_index(k, j), -power));
                    }
                    if j < o.scale[k] {
                        row.push((
                            o.scale_index(k, j),
                            -curve * (1.0 + model.scale_error[k]) * power * v[k],
                        ));
                    }
                }
                match k {
                    1 => row.push((6, -curve * gain[1] * force[0])),
                    2 => {
                        row.push((7, -curve * gain[2] * force[0]));
                        row.push((8, -curve * gain[2] * force[1]));
                    }
                    _ => {}
                }
                if self.sessions > 0 {
                    let i = self.offset_index(window.session, k);
                    residual -= p[i];
                    row.push((i, -1.0));
                }
                let d = self.direction_index(window.recording);
                for a in 0..2 {
                    let dv: f64 = (0..3).map(|i| skew[k][i] * du[a][i]).sum();
                    row.push((d + a, -curve * gain[k] * self.gravity * dv));
                }
                f(w, residual, &row);
            }
        }
    }

    /// The data's normal equations (JᵀJ, Jᵀr) and ‖r‖², without the offsets' prior.
    fn data_normal(&self, p: &[f64], jtj: &mut Mat<f64>, jtr: &mut [f64]) -> f64 {
        let n = self.n_params();
        *jtj = Mat::zeros(n, n);
        jtr.iter_mut().for_each(|g| *g = 0.0);
        let mut sse = 0.0;
        self.visit(p, |_, r, row| {
            sse += r * r;
            for &(a, va) in row {
                jtr[a] += va * r;
                for &(b, vb) in row {
                    jtj[(a, b)] += va * vb;
                }
            }
        });
        sse
    }

    fn data_sse(&self, p: &[f64]) -> f64 {
        let mut sse = 0.0;
        self.visit(p, |_, r, _| sse += r * r);
        sse
    }

    /// The offsets' and q's prior rows' ‖r‖².
    fn prior_sse(&self, p: &[f64]) -> f64 {
        let w2 = self.prior_weight * self.prior_weight;
        let offsets: f64 = (0..3 * self.sessions)
            .map(|i| w2 * p[self.n_sensor() + i].powi(2))
            .sum();
        offsets + self.quadratic_prior(p, None)
    }

    /// q's prior rows: their ‖r‖², added to the normal equations when given.
    fn quadratic_prior(&self, p: &[f64], normal: Option<(&mut Mat<f64>, &mut [f64])>) -> f64 {
        if !self.orders.quadratic {
            return 0.0;
        }
        let w2 = self.quadratic_prior_weight().powi(2);
        let indices = (0..3).map(|k| self.quadratic_index(k));
        if let Some((jtj, jtr)) = normal {
            for i in indices.clone() {
                jtj[(i, i)] += w2;
                jtr[i] += w2 * p[i];
            }
        }
        indices.map(|i| w2 * p[i] * p[i]).sum()
    }
}

impl NormalEquations for Problem<'_> {
    fn n_params(&self) -> usize {
        Problem::n_params(self)
    }

    fn sse(&self, p: &[f64]) -> f64 {
        self.data_sse(p) + self.prior_sse(p)
    }

    fn normal_equations(&self, p: &[f64], jtj: &mut Mat<f64>, jtr: &mut [f64]) -> f64 {
        let sse = self.data_normal(p, jtj, jtr);
        let w2 = self.prior_weight * self.prior_weight;
        for i in self.n_sensor()..self.n_sensor() + 3 * self.sessions {
            jtj[(i, i)] += w2;
            jtr[i] += w2 * p[i];
        }
        self.quadratic_prior(p, Some((jtj, jtr)));
        sse + self.prior_sse(p)
    }
}

struct Solved {
    params: Vec<f64>,
    /// RMS of the data's residuals (the offsets' prior rows left out).
    rms: f64,
    /// The robust covariance's diagonal.
    covariance_diagonal: Vec<f64>,
    /// The correlations of the classical covariance H⁻¹ (every parameter's), `None` where H is
    /// singular.
    correlation: Option<Mat<f64>>,
    sessions: ThermalSessions,
}

impl Solved {
    /// The covariance of the parameters at `index`: the classical correlations scaled to the
    /// variances `covariance_diagonal` holds (the larger of the classical and the robust one, as
    /// the terms rule reads them), so it is a covariance whatever the sandwich's own shape.
    fn covariance_on(&self, index: &[usize]) -> Option<Vec<Vec<f64>>> {
        let correlation = self.correlation.as_ref()?;
        let sd: Vec<f64> = index
            .iter()
            .map(|&i| self.covariance_diagonal[i].sqrt())
            .collect();
        sd.iter().all(|v| v.is_finite()).then(|| {
            index
                .iter()
                .enumerate()
                .map(|(a, &i)| {
                    index
                        .iter()
                        .enumerate()
                        .map(|(b, &j)| sd[a] * sd[b] * correlation[(i, j)])
                        .collect()
                })
                .collect()
        })
    }
}

/// The search's range for σ, as multiples of g: the joint fit's (10 µg to 5 % of g).
const SPREAD_SEARCH_G: (f64, f64) = (1e-5, 0.05);
/// Log-spaced trial values of σ before the golden-section refinement.
const SPREAD_GRID: usize = 24;

/// Fits `orders` to `windows`. With two sessions or more: a first pass with the offsets' spread
/// at the search range's geometric middle, σ by the marginal likelihood about it, then the fit at
/// that σ.
fn solve(windows: &[Window], orders: Orders, reference_c: f64, gravity: f64) -> (Problem<'_>, Solved) {
    let mut problem = problem(windows, orders, reference_c, gravity);
    let lm = |problem: &Problem<'_>, p0: &[f64]| {
        levenberg_marquardt_normal(problem, p0, None, &LmOptions::default(), &crate::progress::silent)
    };
    let n_res = problem.n_residuals() as f64;
    let dof = (n_res - problem.n_params() as f64).max(1.0);
    let mut report = lm(&problem, &vec![0.0; problem.n_params()]);
    let mut sessions = ThermalSessions {
        count: problem.sessions.max(1),
        ..ThermalSessions::default()
    };
    if problem.sessions > 0 {
        let noise2 = problem.data_sse(&report.params) / dof;
        if let Some(mut spread) = estimate_spread(&problem, &report.params, noise2) {
            problem.prior_weight = (noise2.sqrt() / spread.spread_sd_mps2).min(1e12);
            report = lm(&problem, &report.params);
            let so = problem.n_sensor();
            spread.offsets_mps2 = (0..problem.sessions)
                .map(|s| std::array::from_fn(|k| report.params[so + 3 * s + k]))
                .collect();
            sessions = spread;
        }
    }
    let sse = problem.data_sse(&report.params);
    // The larger of the classical and the block-robust variance, per parameter: the sandwich
    // lets in what the die temperature's estimate errs together, but with a block per pose and
    // two angles fitted to each it runs low (measured: 79 % coverage of 95 % intervals with the
    // die temperature logged exactly, where the classical one covers 95 %).
    let n = problem.n_params();
    let (covariance_diagonal, correlation) = match report.jtj.llt(Side::Lower) {
        Ok(llt) => {
            let inverse = llt.solve(Mat::<f64>::identity(n, n));
            let robust = robust_covariance_diagonal(&problem, &report.params, &inverse);
            let diagonal = (0..n)
                .map(|i| (inverse[(i, i)] * sse / dof).max(robust[i]))
                .collect();
            let sd: Vec<f64> = (0..n)
                .map(|i| inverse[(i, i)].max(f64::MIN_POSITIVE).sqrt())
                .collect();
            let correlation = Mat::from_fn(n, n, |i, j| inverse[(i, j)] / (sd[i] * sd[j]));
            (diagonal, Some(correlation))
        }
        Err(_) => (vec![f64::NAN; n], None),
    };
    (
        problem,
        Solved {
            params: report.params,
            rms: (sse / n_res).sqrt(),
            covariance_diagonal,
            correlation,
            sessions,
        },
    )
}

/// The spread σ of the sessions' offsets by the marginal likelihood of the windows (Laplace about
/// `p`; `noise2` the variance of a window's residual):
/// log L(σ) = −½ min S(σ)/s² − ½ log det(JᵀJ + λP) − 3S log σ, λ = s²/σ², P the offsets.
/// The offsets enter the residuals linearly, so the expansion holds them exactly.
fn estimate_spread(problem: &Problem<'_>, p: &[f64], noise2: f64) -> Option<ThermalSessions> {
    let n = problem.n_params();
    let (mut h, mut g) = (Mat::zeros(n, n), vec![0.0; n]);
    let sse = problem.data_normal(p, &mut h, &mut g);
    // q's prior is fixed: part of every σ's normal equations.
    let sse = sse + problem.quadratic_prior(p, Some((&mut h, &mut g)));
    let offsets: Vec<usize> = (problem.n_sensor()..problem.n_sensor() + 3 * problem.sessions).collect();
    let log_likelihood = |log_sigma: f64| -> Option<f64> {
        let lambda = noise2 / (2.0 * log_sigma).exp();
        let mut a = h.clone();
        let mut b = g.clone();
        let mut quadratic = 0.0;
        for &i in &offsets {
            a[(i, i)] += lambda;
            b[i] += lambda * p[i];
            quadratic += lambda * p[i] * p[i];
        }
        // Scaled to a unit diagonal: the offsets' direction of the bias is nearly flat when σ is
        // wide.
        let d: Vec<f64> = (0..n).map(|i| a[(i, i)].max(f64::MIN_POSITIVE).sqrt()).collect();
        let scaled = Mat::from_fn(n, n, |i, j| a[(i, j)] / (d[i] * d[j]));
        let rhs = Mat::from_fn(n, 1, |i, _| b[i] / d[i]);
        let llt = scaled.llt(Side::Lower).ok()?;
        let x = llt.solve(&rhs);
        let reduction: f64 = (0..n).map(|i| rhs[(i, 0)] * x[(i, 0)]).sum();
        let l = llt.L();
        let log_det: f64 = (0..n).map(|i| 2.0 * l[(i, i)].ln() + 2.0 * d[i].ln()).sum();
        let min_sse = sse + quadratic - reduction;
        let value = -0.5 * min_sse / noise2 - 0.5 * log_det - offsets.len() as f64 * log_sigma;
        value.is_finite().then_some(value)
    };
    let (lo, hi) = (
        (SPREAD_SEARCH_G.0 * problem.gravity).ln(),
        (SPREAD_SEARCH_G.1 * problem.gravity).ln(),
    );
    let step = (hi - lo) / (SPREAD_GRID - 1) as f64;
    let grid: Vec<(f64, f64)> = (0..SPREAD_GRID)
        .filter_map(|i| {
            let x = lo + step * i as f64;
            log_likelihood(x).map(|v| (x, v))
        })
        .collect();
    let &(best, _) = grid.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    let value_at = |x: f64| log_likelihood(x).unwrap_or(f64::NEG_INFINITY);
    let x = crate::optim::golden_section_max(value_at, (best - step).max(lo), (best + step).min(hi), 30);
    let at_lower = log_likelihood(lo)?;
    Some(ThermalSessions {
        count: problem.sessions,
        spread_sd_mps2: x.exp(),
        at_lower_bound: x <= lo + 0.05 * step,
        likelihood_ratio: (2.0 * (value_at(x) - at_lower)).max(0.0),
        offsets_mps2: Vec::new(),
    })
}

/// The diagonal of the block sandwich H⁻¹ (Σ_b g_b g_bᵀ) H⁻¹, g_b the data's Jᵀr over block b,
/// H the normal matrix with the offsets' prior (`inverse` is H⁻¹), scaled by B/(B − 1) for B
/// blocks.
fn robust_covariance_diagonal(problem: &Problem<'_>, p: &[f64], inverse: &Mat<f64>) -> Vec<f64> {
    let n = problem.n_params();
    let mut meat = Mat::<f64>::zeros(n, n);
    let mut score = vec![0.0; n];
    let mut touched: Vec<usize> = Vec::new();
    let mut current = usize::MAX;
    let mut blocks = 0usize;
    let flush = |score: &mut Vec<f64>, touched: &mut Vec<usize>, meat: &mut Mat<f64>| {
        touched.sort_unstable();
        touched.dedup();
        for &a in touched.iter() {
            for &b in touched.iter() {
                meat[(a, b)] += score[a] * score[b];
            }
        }
        for &a in touched.iter() {
            score[a] = 0.0;
        }
        touched.clear();
    };
    let windows = problem.windows;
    problem.visit(p, |w, r, row| {
        if windows[w].block != current {
            flush(&mut score, &mut touched, &mut meat);
            current = windows[w].block;
            blocks += 1;
        }
        for &(a, va) in row {
            score[a] += va * r;
            touched.push(a);
        }
    });
    flush(&mut score, &mut touched, &mut meat);
    let factor = blocks as f64 / (blocks.max(2) - 1) as f64;
    let left = inverse * &meat;
    (0..n)
        .map(|i| factor * (0..n).map(|k| left[(i, k)] * inverse[(k, i)]).sum::<f64>())
        .collect()
}

/// The problem over `windows`, each recording's direction started at its windows' mean reading.
fn problem(windows: &[Window], orders: Orders, reference_c: f64, gravity: f64) -> Problem<'_> {
    let n_recordings = windows.iter().map(|w| w.recording + 1).max().unwrap_or(0);
    let n_sessions = windows.iter().map(|w| w.session + 1).max().unwrap_or(0);
    let frames = (0..n_recordings)
        .map(|r| {
            let mut sum = [0.0; 3];
            for w in windows.iter().filter(|w| w.recording == r) {
                (0..3).for_each(|k| sum[k] += w.reading[k]);
            }
            frame(sum)
        })
        .collect();
    // The first pass's spread: the search range's geometric middle, relative to a window's
    // noise guessed at 1 mg (the pass only sets where the likelihood is expanded).
    let middle = (SPREAD_SEARCH_G.0 * SPREAD_SEARCH_G.1).sqrt() * gravity;
    Problem {
        windows,
        orders,
        reference_c,
        gravity,
        frames,
        sessions: if n_sessions > 1 { n_sessions } else { 0 },
        prior_weight: 1e-3 * gravity / middle,
    }
}

fn quantile(values: &[f64], q: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

/// The narrowest die-temperature span a thermal model is fitted over, °C.
pub(crate) const MIN_SPAN_C: f64 = 3.0;

/// Fits the thermal model to still recordings (each in one orientation) that carry a temperature,
/// all of one power-on session ([`fit_thermal_in_sessions`] otherwise).
/// The temperatures are taken as given: a campaign checks them first
/// ([`super::checks`], masking glitches, resets and implausible values). A model that breaks the
/// plausibility limits ([`ThermalModel::check_plausible`]) is refused; so is one whose lag fits
/// best at the top of `lags_s` extended up to [`MAX_LAG_S`] ([`ThermalError::LagAtEdge`]).
pub fn fit_thermal(
    stills: &[&Recording],
    settings: &ThermalSettings,
    gravity: f64,
) -> Result<ThermalFit, ThermalError> {
    fit_thermal_in_sessions(stills, &vec![0; stills.len()], settings, gravity)
}

/// [`fit_thermal`] with each recording's power-on session: `sessions[r]` labels recording r's
/// (recordings with equal labels share one; any numbers). Sessions' bias offsets and their
/// spread are fitted as the module documentation says.
pub fn fit_thermal_in_sessions(
    stills: &[&Recording],
    sessions: &[usize],
    settings: &ThermalSettings,
    gravity: f64,
) -> Result<ThermalFit, ThermalError> {
    settings.check()?;
    if sessions.len() != stills.len() {
        return Err(ThermalError::Sessions {
            sessions: sessions.len(),
            recordings: stills.len(),
        });
    }
    // Sessions numbered from 0 in the order first met.
    let mut labels: Vec<usize> = Vec::new();
    let sessions: Vec<usize> = sessions
        .iter()
        .map(|s| {
            labels.iter().position(|l| l == s).unwrap_or_else(|| {
                labels.push(*s);
                labels.len() - 1
            })
        })
        .collect();
    // The lag: at the fixed or the highest orders, on every window.
    let (kb, ks) = match settings.orders {
        Some([kb, ks]) => (kb, ks),
        None => (settings.max_bias_order, settings.max_scale_order),
    };
    // With `fit_nonlinearity`, the readings with q's term taken out, and the fit as without it.
    let linearised: Vec<Recording>;
    let linearised_refs: Vec<&Recording>;
    let stills: &[&Recording] = if settings.fit_nonlinearity {
        linearised = without_nonlinearity(stills, settings, gravity)?;
        linearised_refs = linearised.iter().collect();
        &linearised_refs
    } else {
        stills
    };
    let highest = Orders::uniform(kb, ks);
    // The lag on one session: a session's offset is constant, the lag's trace is not, but an
    // offset per pose file would take up the error a wrong lag leaves in that pose (measured: it
    // moved the lag from 20 s to 40 s on a unit with none, 1.65× the oracle on a run).
    let one = vec![0; stills.len()];
    let (lag_scores, all, at_best_lag, lag_s) = best_lag(stills, &one, settings, highest, gravity)?;
    let temps: Vec<f64> = all.iter().map(|w| w.die_c).collect();
    let reference_c = settings.reference_c.unwrap_or_else(|| quantile(&temps, 0.5));
    let (all, at_best_lag) = if labels.len() > 1 {
        let all = windows(stills, &sessions, settings, lag_s)?;
        let (_, solved) = solve(&all, highest, reference_c, gravity);
        (all, solved)
    } else {
        (all, at_best_lag)
    };
    let range = [quantile(&temps, 0.0), quantile(&temps, 1.0)];
    let lag_rate_r2 = rate_temperature_r2(&all);
    let (orders, problem, solved, tests) = if settings.orders.is_some() {
        let problem = problem(&all, highest, reference_c, gravity);
        (highest, problem, at_best_lag, Vec::new())
    } else {
        kept_terms(&all, highest, at_best_lag, reference_c, gravity)
    };
    let model = problem.model(&solved.params, lag_s, settings.smoothing_s, range);
    model.check_plausible().map_err(|e| ThermalError::Implausible {
        field: e.field,
        reason: e.reason,
    })?;
    let se = |i: usize| solved.covariance_diagonal[i].max(0.0).sqrt();
    let threshold = term_threshold();
    let coefficients: Vec<usize> = (0..3)
        .flat_map(|k| (0..orders.bias[k]).map(move |j| orders.bias_index(k, j)))
        .chain((0..3).flat_map(|k| (0..orders.scale[k]).map(move |j| orders.scale_index(k, j))))
        .collect();
    let left_out_moves = left_out_moves(&all, orders, &model, &tests, reference_c, gravity);
    Ok(ThermalFit {
        left_out_moves,
        coefficient_covariance: solved.covariance_on(&coefficients).unwrap_or_default(),
        bias_per_c_se: std::array::from_fn(|k| {
            (0..orders.bias[k]).map(|j| se(orders.bias_index(k, j))).collect()
        }),
        scale_per_c_se: std::array::from_fn(|k| {
            (0..orders.scale[k])
                .map(|j| se(orders.scale_index(k, j)))
                .collect()
        }),
        model,
        bias_order: orders.bias.into_iter().max().unwrap_or(0),
        scale_order: orders.scale.into_iter().max().unwrap_or(0),
        lag_scores,
        terms: ThermalTerms {
            bias_orders: orders.bias,
            scale_orders: orders.scale,
            threshold,
            tests,
            rule: if settings.orders.is_some() {
                "the orders were fixed by the settings".into()
            } else {
                format!(
                    "from bias order {kb} and gain order {ks}, each axis's highest coefficient of β and of ρ is kept where |c/se| ≥ {threshold:.2} (a Wald test at two-sided false-alarm probability {TERM_FALSE_ALARM:e} on the fit's robust covariance, blocks of {:.0} s), else dropped and the model refitted",
                    settings.smoothing_s.max(settings.window_s)
                )
            },
        },
        sessions: solved.sessions,
        residual_rms_mps2: solved.rms,
        windows: all.len(),
        lag_rate_r2,
        lag_determined: lag_rate_r2.is_some_and(|r2| r2 < LAG_RATE_R2_LIMIT),
    })
}

/// The still recordings with q's term taken out, for [`ThermalSettings::fit_nonlinearity`]: q
/// and b fitted once, at the lag and the per-axis orders the fit without q chooses (one session;
/// the terms rule has dropped what the windows do not determine), then every
/// reading m becomes m − q(m − b)², to first order the reading of a linear sensor (what is left,
/// 2q(m − b)·β and the like, is small beside the noise). Left free, or held, inside every later
/// fit, q's curvature gave a weight to the directions no window determines (ρ₂ where the poses
/// sit at two temperatures only: a ΔT⁴ trace) and the solve ran off to gains changing by 50–196 %
/// (measured on bench/thermal/campaign.sh's seed 10); taken out, the problem is linear in them
/// again and the terms rule drops them as it did.
fn without_nonlinearity(
    stills: &[&Recording],
    settings: &ThermalSettings,
    gravity: f64,
) -> Result<Vec<Recording>, ThermalError> {
    let plain = ThermalSettings {
        fit_nonlinearity: false,
        ..settings.clone()
    };
    // The orders and the lag as without q (one session); a fit that cannot be made leaves the
    // readings as they are, for the main fit to say why.
    let Ok(first) = fit_thermal(stills, &plain, gravity) else {
        return Ok(stills.iter().map(|r| (*r).clone()).collect());
    };
    let one = vec![0; stills.len()];
    let all = windows(stills, &one, settings, first.model.lag_s)?;
    let orders = Orders {
        bias: first.terms.bias_orders,
        scale: first.terms.scale_orders,
        quadratic: true,
    };
    let (problem, solved) = solve(&all, orders, first.model.reference_c, gravity);
    let q: [f64; 3] = std::array::from_fn(|k| solved.params[problem.quadratic_index(k)]);
    let b = [solved.params[0], solved.params[1], solved.params[2]];
    Ok(stills
        .iter()
        .map(|rec| {
            let mut out = (*rec).clone();
            for k in 0..3 {
                for m in out.accel_mps2[k].iter_mut() {
                    *m -= q[k] * (*m - b[k]).powi(2);
                }
            }
            out
        })
        .collect())
}

/// The terms the rule dropped that the windows still saw: per axis and part, the last order
/// dropped, added back alone. Where its |z| then exceeds 1, the thermal model with it minus the
/// kept one, scaled by √(1 − 1/z²): the share of its squared move that noise alone would not make
/// (E[z²] = 1 where the term is zero), as for a left-out q (`campaign::candidate`'s
/// error_bar_covariance). A term the windows cannot determine (z NaN or near zero, the gain's
/// curvature of a warm-up in one orientation) gives none.
fn left_out_moves(
    all: &[Window],
    orders: Orders,
    kept: &ThermalModel,
    tests: &[TermTest],
    reference_c: f64,
    gravity: f64,
) -> Vec<ThermalDirection> {
    tests
        .iter()
        .filter(|t| !t.kept)
        .filter_map(|t| {
            let gain = t.part == "gain";
            let mut with = orders;
            let order = if gain {
                &mut with.scale[t.axis]
            } else {
                &mut with.bias[t.axis]
            };
            if t.order != *order + 1 {
                return None;
            }
            *order = t.order;
            let (problem, solved) = solve(all, with, reference_c, gravity);
            let index = if gain {
                with.scale_index(t.axis, t.order - 1)
            } else {
                with.bias_index(t.axis, t.order - 1)
            };
            let z = solved.params[index] / solved.covariance_diagonal[index].sqrt();
            // A NaN z (a term the windows do not determine) gives no move either.
            let share = share_beyond_noise(z * z, 1);
            if share <= 0.0 {
                return None;
            }
            let moved = problem.model(&solved.params, kept.lag_s, kept.smoothing_s, kept.fitted_range_c);
            let scale = share.sqrt();
            let change = |with: f64, without: f64| scale * (with - without);
            Some(ThermalDirection {
                bias_per_c: coefficientwise(&moved.bias_per_c, &kept.bias_per_c, change),
                scale_per_c: coefficientwise(&moved.scale_per_c, &kept.scale_per_c, change),
                sensor: Vec::new(),
            })
        })
        .collect()
}

/// The terms rule, per axis: each axis's β and ρ have their own order, because their drifts
/// differ by axis (a consumer part's z axis drifts most) and the accelerometer's q is kept per
/// axis by the same rule. Only the highest coefficient of each is tested, the lower ones kept
/// under it: powers of ΔT are correlated, so a middle term alone says little, and a polynomial
/// with a gap is not a lower order. Every failing top term is dropped at once, then the model is
/// refitted, until all pass.
fn kept_terms<'a>(
    all: &'a [Window],
    highest: Orders,
    at_highest: Solved,
    reference_c: f64,
    gravity: f64,
) -> (Orders, Problem<'a>, Solved, Vec<TermTest>) {
    let threshold = term_threshold();
    let mut orders = highest;
    let mut problem = problem(all, orders, reference_c, gravity);
    let mut solved = at_highest;
    let mut tests = Vec::new();
    loop {
        let z = |i: usize| solved.params[i] / solved.covariance_diagonal[i].sqrt();
        let mut next = orders;
        for k in 0..3 {
            for gain in [false, true] {
                let order = if gain { orders.scale[k] } else { orders.bias[k] };
                if order == 0 {
                    continue;
                }
                let index = if gain {
                    orders.scale_index(k, order - 1)
                } else {
                    orders.bias_index(k, order - 1)
                };
                let z = z(index);
                // NaN (a term the windows do not determine) fails too.
                let kept = z.abs() >= threshold;
                tests.push(TermTest {
                    part: if gain { "gain" } else { "bias" }.into(),
                    axis: k,
                    order,
                    z,
                    kept,
                });
                if !kept && gain {
                    next.scale[k] -= 1;
                } else if !kept {
                    next.bias[k] -= 1;
                }
            }
        }
        if next == orders {
            return (orders, problem, solved, tests);
        }
        orders = next;
        (problem, solved) = solve(all, orders, reference_c, gravity);
    }
}

/// (lag, residual RMS) per lag tried.
type LagScores = Vec<(f64, f64)>;

/// Each lag's residual RMS at `orders` on every window, the windows and fit of the best lag, and
/// the best lag. A best lag at the grid's top is not determined (0 is a physical bound, not an
/// edge: a sensor may not lag): the grid is extended by doubling its top up to [`MAX_LAG_S`],
/// and a lag still best at the top is refused.
fn best_lag(
    stills: &[&Recording],
    sessions: &[usize],
    settings: &ThermalSettings,
    orders: Orders,
    gravity: f64,
) -> Result<(LagScores, Vec<Window>, Solved, f64), ThermalError> {
    let mut lag_scores = Vec::new();
    let mut best: Option<(f64, Vec<Window>, Solved, f64)> = None;
    let mut grid = settings.lags_s.clone();
    let mut next = 0;
    while next < grid.len() {
        let lag = grid[next];
        next += 1;
        let all = windows(stills, sessions, settings, lag)?;
        let temps: Vec<f64> = all.iter().map(|w| w.die_c).collect();
        let (lo, hi) = (quantile(&temps, 0.0), quantile(&temps, 1.0));
        if orders.terms() > 0 && hi - lo < MIN_SPAN_C {
            return Err(ThermalError::NarrowRange {
                span_c: hi - lo,
                needed_c: MIN_SPAN_C,
            });
        }
        let reference = settings.reference_c.unwrap_or_else(|| quantile(&temps, 0.5));
        let (_, solved) = solve(&all, orders, reference, gravity);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// 2 s windows of one recording from `t0` for `seconds`, the die at `die(t)`, blocks of 60 s
    /// numbered from `block`.
    fn windows_of(
        recording: usize,
        block: usize,
        t0: f64,
        seconds: f64,
        die: impl Fn(f64) -> f64,
    ) -> Vec<Window> {
        (0..(seconds / 2.0) as usize)
            .map(|i| {
                let t = t0 + 2.0 * i as f64;
                Window {
                    recording,
                    session: 0,
                    block: block + ((t - t0) / 60.0) as usize,
                    reading: [0.0; 3],
                    die_c: die(t),
                    time_s: t,
                }
            })
            .collect()
    }

    #[test]
    fn the_lag_is_undetermined_when_every_recording_warms_along_one_curve() {
        let warm = |t: f64| 40.0 - 25.0 * (-t / 600.0).exp();
        // Two warm-ups of one shape (rate = (40 − T)/600): a line.
        let mut one_shape = windows_of(0, 0, 0.0, 1800.0, warm);
        one_shape.extend(windows_of(1, 100, 5000.0, 1800.0, |t| warm(t - 5000.0)));
        let r2 = rate_temperature_r2(&one_shape).unwrap();
        assert!(r2 > 0.999, "{r2}");
        // Still poses held at a steady temperature at both ends: rate 0 where the warm-up's is
        // largest, and the line breaks.
        let mut with_steady = windows_of(0, 0, 0.0, 1800.0, warm);
        for (i, c) in [15.0, 15.0, 15.0, 40.0, 40.0, 40.0].into_iter().enumerate() {
            with_steady.extend(windows_of(
                1 + i,
                100 + 10 * i,
                5000.0 + 100.0 * i as f64,
                60.0,
                |_| c,
            ));
        }
        let r2 = rate_temperature_r2(&with_steady).unwrap();
        assert!(r2 < LAG_RATE_R2_LIMIT, "{r2}");
        // Nothing changes temperature: no rate to tell a lag by.
        assert_eq!(
            rate_temperature_r2(&windows_of(0, 0, 0.0, 1800.0, |_| 25.0)),
            None
        );
    }
}
