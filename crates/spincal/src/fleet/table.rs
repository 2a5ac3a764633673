//! The fleet table: every unit's sensor parameters with their standard errors, fleet statistics
//! per parameter, and the units that lie far from the fleet.
//!
//! ## The outlier rule
//!
//! Each sensor parameter is judged on its own, over the units that were calibrated (`n`).
//!
//! 1. **Fleet statistics.** The median `m` and the robust spread `S = 1.4826 · c(n) · MAD` (MAD
//!    the median absolute deviation from `m`, `c(n)` its small-sample correction from Croux and
//!    Rousseeuw: 1.196, 1.495, 1.363, 1.206, 1.200, 1.140, 1.129, 1.107 for n = 2 to 9, then
//!    n / (n − 0.8)).
//! 2. **Screen.** Units with `|x − m| > screen · S` (default 5) are left out of every other unit's
//!    reference, so that two faulty units cannot hide each other. The screen decides nothing by
//!    itself.
//! 3. **Test.** Unit `i` (value `x`, own standard error `σ`) is compared with its reference: the
//!    other units that passed the screen (`k` of them, mean `μ`, sample standard deviation `s`).
//!    If `i` were like them, `z = (x − μ) / √(s² (1 + 1/k) + σ²)` would follow Student's t with
//!    `k − 1` degrees of freedom (the prediction interval of a new draw; `σ²` added so that a
//!    parameter the unit's own campaign determined poorly is not called an outlier for that alone).
//!    The unit is flagged when `|z|` exceeds the t quantile at two-sided probability
//!    `false_alarm_probability` (default 1e-4: 9.1 against the 7 other units of an eight-unit fleet,
//!    6.2 against 11, about 3.9 for a large fleet). A fleet of `N` good units then raises about `12 · N · 1e-4` false flags over its
//!    twelve parameters.
//!
//! With a median absolute deviation alone, a fleet of eight units underestimates its spread by
//! half often enough that a good unit two standard deviations out would be flagged; the t quantile
//! on the reference's own standard deviation is what makes small fleets safe. No parameter is
//! judged with fewer than `min_units` calibrated units (default 5) or a reference of fewer than 3.

use serde::{Deserialize, Serialize};

use crate::correctors::physical::{SENSOR_PARAMS, SENSOR_PARAM_NAMES};
use crate::fleet::UnitOutcome;
use crate::metrics::student_t_quantile;

/// How far from the fleet a unit must lie to be flagged (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutlierSettings {
    /// Chance that a unit like the others is flagged on one parameter (two-sided).
    pub false_alarm_probability: f64,
    /// Units further than this many robust spreads from the median are left out of the others'
    /// references.
    pub screen: f64,
    /// Fewest calibrated units for a parameter to be judged at all.
    pub min_units: usize,
}

impl Default for OutlierSettings {
    fn default() -> Self {
        OutlierSettings {
            false_alarm_probability: 1e-4,
            screen: 5.0,
            min_units: 5,
        }
    }
}

/// One unit far from the fleet on one parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutlierFlag {
    pub unit: String,
    pub parameter: String,
    pub value: f64,
    pub std_error: Option<f64>,
    /// The other units it was compared with: how many, their mean and standard deviation.
    pub reference_units: usize,
    pub reference_mean: f64,
    pub reference_sd: f64,
    /// z of the module documentation, and the t quantile it exceeded.
    pub score: f64,
    pub critical: f64,
    /// In words, e.g. "bias_x (m/s²) = 9.6e-1 ± 2.2e-2: z = +16.1 against the 7 other units
    /// (mean 4.1e-2, sd 5.0e-2); flagged beyond 9.1".
    pub reason: String,
}

/// A parameter across the fleet.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterStats {
    pub parameter: String,
    /// Units whose value entered the statistics.
    pub units: usize,
    pub median: Option<f64>,
    /// Robust standard deviation, 1.4826 · c(n) · MAD.
    pub spread: Option<f64>,
    /// Units that passed the screen (the references are drawn from these), their mean and
    /// standard deviation.
    pub screened_units: usize,
    pub screened_mean: Option<f64>,
    pub screened_sd: Option<f64>,
    /// Where a further unit with a negligible standard error would be flagged, against all the
    /// screened units: below the first or above the second.
    pub limits: Option<[f64; 2]>,
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// Median of the units' own standard errors: compare with `spread` to see whether the units
    /// differ by more than their calibrations can tell.
    pub median_std_error: Option<f64>,
    /// Whether outliers were judged on this parameter (enough units).
    pub judged: bool,
}

/// One unit's row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FleetRow {
    pub unit: String,
    pub source: String,
    /// The unit's name in its campaign file (when it could be read and calibrated).
    pub campaign_unit: Option<String>,
    pub ok: bool,
    /// The saved corrector, if any.
    pub saved: Option<String>,
    /// The saved corrector's mean RMS error over the held-out conditions, m/s².
    pub held_out_rms_mps2: Option<f64>,
    /// The sensor parameters in the order of [`FleetTable::parameters`].
    pub values: Vec<Option<f64>>,
    pub std_errors: Vec<Option<f64>>,
    pub flags: Vec<OutlierFlag>,
    /// Why the unit failed, located.
    pub error: Option<String>,
}

/// The fleet table (fleet.json; [`FleetTable::to_csv`] gives fleet.csv).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FleetTable {
    /// The sensor parameters with their units: bias m/s², scale error (a fraction), misalignment
    /// rad, quadratic 1/(m/s²).
    pub parameters: Vec<String>,
    pub rows: Vec<FleetRow>,
    pub stats: Vec<ParameterStats>,
    /// Every flag of every row, in row order.
    pub outliers: Vec<OutlierFlag>,
    pub settings: OutlierSettings,
    /// The outlier rule in words.
    pub rule: String,
    pub units_ok: usize,
    pub units_failed: usize,
}

/// A parameter name with its unit stated: the names without one are dimensionless fractions.
pub(crate) fn parameter_label(k: usize) -> String {
    let name = SENSOR_PARAM_NAMES[k];
    if name.contains('(') {
        name.to_string()
    } else {
        format!("{name} (fraction)")
    }
}

/// The name's stem and its unit: "bias_x (m/s²)" → ("bias_x", "(m/s²)").
fn split_unit(label: &str) -> (&str, &str) {
    match label.find(" (") {
        Some(at) => (&label[..at], &label[at + 1..]),
        None => (label, ""),
    }
}

fn median(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

/// The MAD's small-sample consistency factor c(n).
fn mad_correction(n: usize) -> f64 {
    const SMALL: [f64; 8] = [1.196, 1.495, 1.363, 1.206, 1.200, 1.140, 1.129, 1.107];
    match n {
        0 | 1 => 1.0,
        2..=9 => SMALL[n - 2],
        _ => n as f64 / (n as f64 - 0.8),
    }
}

/// Median and robust spread of finite values (`None` when there are none).
pub(crate) fn robust_centre_spread(values: &[f64]) -> Option<(f64, f64)> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let m = median(&v);
    let mut dev: Vec<f64> = v.iter().map(|x| (x - m).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let spread = 1.482_602_218_505_602 * mad_correction(v.len()) * median(&dev);
    Some((m, spread))
}

/// Mean and sample standard deviation (`None` below one and two values).
fn mean_sd(values: &[f64]) -> (Option<f64>, Option<f64>) {
    if values.is_empty() {
        return (None, None);
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let sd = (values.len() >= 2)
        .then(|| (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
    (Some(mean), sd)
}

fn fmt(v: f64) -> String {
    format!("{v:.6e}")
}

/// The fleet table of these outcomes.
pub fn fleet_table(units: &[UnitOutcome], settings: &OutlierSettings) -> FleetTable {
    let parameters: Vec<String> = (0..SENSOR_PARAMS).map(parameter_label).collect();
    let mut rows: Vec<FleetRow> = units.iter().map(fleet_row).collect();
    let mut stats = Vec::with_capacity(SENSOR_PARAMS);
    for (k, parameter) in parameters.iter().enumerate() {
        stats.push(parameter_stats(k, parameter, &mut rows, settings));
    }
    let outliers = rows.iter().flat_map(|r| r.flags.iter().cloned()).collect();
    let units_ok = rows.iter().filter(|r| r.ok).count();
    FleetTable {
        parameters,
        units_failed: rows.len() - units_ok,
        units_ok,
        rows,
        stats,
        outliers,
        rule: format!(
            "A unit is flagged on a parameter when z = (x − μ) / √(s²(1 + 1/k) + σ²) lies beyond Student's t quantile with k − 1 degrees of freedom at two-sided probability {}: x and σ the unit's value and standard error, μ and s the mean and standard deviation of the k other units within {} robust spreads (1.4826 × MAD) of the fleet median. Parameters are judged only with at least {} calibrated units.",
            settings.false_alarm_probability, settings.screen, settings.min_units
        ),
        settings: settings.clone(),
    }
}

/// A unit's row: its sensor parameters and what it saved, or why it failed.
fn fleet_row(u: &UnitOutcome) -> FleetRow {
    match &u.result {
        Ok(cal) => {
            let params = cal.sensor_params();
            let value = |k: usize| params.get(k).map(|p| p.value).filter(|v| v.is_finite());
            let se = |k: usize| params.get(k).and_then(|p| p.std_error).filter(|v| v.is_finite());
            let held_out = cal.saved().and_then(|name| {
                cal.result
                    .candidates
                    .iter()
                    .find(|c| c.candidate == name)
                    .and_then(|c| c.mean_rms_mps2)
            });
            FleetRow {
                unit: u.unit.clone(),
                source: u.source.display().to_string(),
                campaign_unit: Some(cal.unit.clone()),
                ok: true,
                saved: cal.saved().map(str::to_string),
                held_out_rms_mps2: held_out,
                values: (0..SENSOR_PARAMS).map(value).collect(),
                std_errors: (0..SENSOR_PARAMS).map(se).collect(),
                flags: Vec::new(),
                error: None,
            }
        }
        Err(message) => FleetRow {
            unit: u.unit.clone(),
            source: u.source.display().to_string(),
            campaign_unit: None,
            ok: false,
            saved: None,
            held_out_rms_mps2: None,
            values: vec![None; SENSOR_PARAMS],
            std_errors: vec![None; SENSOR_PARAMS],
            flags: Vec::new(),
            error: Some(message.clone()),
        },
    }
}

/// Parameter `k` over the fleet: its robust centre, the screened units' mean and limits; flags
/// the rows of units that lie beyond the others.
fn parameter_stats(
    k: usize,
    parameter: &str,
    rows: &mut [FleetRow],
    settings: &OutlierSettings,
) -> ParameterStats {
    let present: Vec<(usize, f64, Option<f64>)> = rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.values[k].map(|v| (i, v, r.std_errors[k])))
        .collect();
    let values: Vec<f64> = present.iter().map(|p| p.1).collect();
    let centre = robust_centre_spread(&values);
    let ses: Vec<f64> = present.iter().filter_map(|p| p.2).collect();
    let median_se = robust_centre_spread(&ses).map(|(m, _)| m);
    let judged = centre.is_some() && present.len() >= settings.min_units.max(1);
    // The screen: units within `screen` robust spreads of the median.
    let passes: Vec<bool> = match centre {
        Some((m, spread)) => present
            .iter()
            .map(|p| (p.1 - m).abs() <= settings.screen * spread)
            .collect(),
        None => vec![false; present.len()],
    };
    let screened: Vec<f64> = present
        .iter()
        .zip(&passes)
        .filter(|(_, &ok)| ok)
        .map(|(p, _)| p.1)
        .collect();
    let screened_units = screened.len();
    let (screened_mean, screened_sd) = mean_sd(&screened);
    let limits = match (screened_mean, screened_sd) {
        (Some(mean), Some(sd)) if judged && screened_units >= 3 => {
            let c = student_t_quantile(
                1.0 - settings.false_alarm_probability / 2.0,
                (screened_units - 1) as f64,
            );
            let half = c * sd * (1.0 + 1.0 / screened_units as f64).sqrt();
            Some([mean - half, mean + half])
        }
        _ => None,
    };
    if judged {
        flag_outliers(parameter, &present, &passes, rows, settings);
    }
    ParameterStats {
        parameter: parameter.to_string(),
        units: present.len(),
        median: centre.map(|c| c.0),
        spread: centre.map(|c| c.1),
        screened_units,
        screened_mean,
        screened_sd,
        limits,
        min: values.iter().copied().reduce(f64::min),
        max: values.iter().copied().reduce(f64::max),
        median_std_error: median_se,
        judged,
    }
}

/// Flags each unit whose value of the parameter lies beyond the prediction interval of the other
/// screened units (`passes`), on its row.
fn flag_outliers(
    parameter: &str,
    present: &[(usize, f64, Option<f64>)],
    passes: &[bool],
    rows: &mut [FleetRow],
    settings: &OutlierSettings,
) {
    for (j, &(i, x, se)) in present.iter().enumerate() {
        let reference: Vec<f64> = present
            .iter()
            .enumerate()
            .filter(|&(other, _)| other != j && passes[other])
            .map(|(_, p)| p.1)
            .collect();
        let k_ref = reference.len();
        let (Some(mean), Some(sd)) = mean_sd(&reference) else {
            continue;
        };
        if k_ref < 3 {
            continue;
        }
        let var = sd * sd;
        let scale = (var * (1.0 + 1.0 / k_ref as f64) + se.unwrap_or(0.0).powi(2)).sqrt();
        if scale.is_nan() || scale <= 0.0 {
            continue;
        }
        let z = (x - mean) / scale;
        let critical = student_t_quantile(1.0 - settings.false_alarm_probability / 2.0, (k_ref - 1) as f64);
        if z.abs() > critical {
            let flag = OutlierFlag {
                unit: rows[i].unit.clone(),
                parameter: parameter.to_string(),
                value: x,
                std_error: se,
                reference_units: k_ref,
                reference_mean: mean,
                reference_sd: var.sqrt(),
                score: z,
                critical,
                reason: format!(
                    "{} = {}{}: z = {:+.1} against the {} other units (mean {}, sd {}); flagged beyond {:.1}",
                    parameter,
                    fmt(x),
                    se.map_or(String::new(), |se| format!(" ± {}", fmt(se))),
                    z,
                    k_ref,
                    fmt(mean),
                    fmt(var.sqrt()),
                    critical
                ),
            };
            rows[i].flags.push(flag);
        }
    }
}

/// A CSV field, quoted when it must be (RFC 4180).
fn field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

fn number(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v}"))
}

impl FleetTable {
    /// fleet.csv: one row per unit, every number in full precision, units in the header (`bias_x
    /// (m/s²)` and its standard error `bias_x SE (m/s²)`, …); empty cells where a unit failed.
    pub fn to_csv(&self) -> String {
        let mut header = vec![
            "unit".to_string(),
            "source".into(),
            "status".into(),
            "saved".into(),
            "held_out_rms (m/s²)".into(),
        ];
        for p in &self.parameters {
            let (stem, unit) = split_unit(p);
            header.push(p.clone());
            header.push(format!("{stem} SE {unit}").trim_end().to_string());
        }
        header.push("outlier_parameters".into());
        header.push("error".into());
        let mut text = header.iter().map(|h| field(h)).collect::<Vec<_>>().join(",");
        text.push('\n');
        for row in &self.rows {
            let mut cells = vec![
                field(&row.unit),
                field(&row.source),
                if row.ok { "ok".into() } else { "failed".into() },
                field(row.saved.as_deref().unwrap_or("")),
                number(row.held_out_rms_mps2),
            ];
            for k in 0..self.parameters.len() {
                cells.push(number(row.values.get(k).copied().flatten()));
                cells.push(number(row.std_errors.get(k).copied().flatten()));
            }
            let flagged: Vec<&str> = row.flags.iter().map(|f| split_unit(&f.parameter).0).collect();
            cells.push(field(&flagged.join(";")));
            cells.push(field(row.error.as_deref().unwrap_or("")));
            text.push_str(&cells.join(","));
            text.push('\n');
        }
        text
    }

    /// The flagged units' names, in row order, each once.
    pub fn flagged_units(&self) -> Vec<&str> {
        self.rows
            .iter()
            .filter(|r| !r.flags.is_empty())
            .map(|r| r.unit.as_str())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robust_spread_of_a_normal_sample_is_about_its_sd_and_ignores_an_outlier() {
        // Normal quantiles at (i − 0.5)/n: a sample whose SD is about 1.
        let q = [-1.5341, -0.8871, -0.4888, -0.1573, 0.1573, 0.4888, 0.8871, 1.5341];
        let (m, s) = robust_centre_spread(&q).unwrap();
        assert!(m.abs() < 1e-12);
        assert!((s - 1.0).abs() < 0.2, "{s}");
        let mut with_outlier = q.to_vec();
        with_outlier[7] = 1000.0;
        let (m2, s2) = robust_centre_spread(&with_outlier).unwrap();
        assert!(m2.abs() < 0.2 && (s2 - s).abs() < 0.5, "{m2} {s2}");
        assert!(robust_centre_spread(&[f64::NAN]).is_none());
    }

    #[test]
    fn csv_fields_are_quoted_when_needed() {
        assert_eq!(field("a,b"), "\"a,b\"");
        assert_eq!(field("say \"x\""), "\"say \"\"x\"\"\"");
        assert_eq!(field("plain"), "plain");
        assert_eq!(split_unit("bias_x (m/s²)"), ("bias_x", "(m/s²)"));
        assert_eq!(parameter_label(3), "scale_error_x (fraction)");
    }
}
