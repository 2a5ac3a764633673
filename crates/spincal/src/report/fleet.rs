//! The fleet summary (fleet.html): one self-contained page from a [`FleetTable`], the table as
//! fleet.json holds it and each sensor parameter's distribution across units as a plot, flagged
//! units highlighted.
//!
//! As in the calibration report, every number shown is written as `<span data-json="/pointer"
//! data-digits="d">`, the place in fleet.json it comes from.

use super::escape;
use crate::fleet::FleetTable;
use crate::report::plot::{Figure, Legend, LinePlot, LineStyle, PlotError, Rgb, Series};

/// Flagged units are drawn in this colour (vermilion), the others in blue.
const FLAGGED: Rgb = Rgb(213, 94, 0);
const GOOD: Rgb = Rgb(0, 114, 178);
const CENTRE: Rgb = Rgb(0, 0, 0);
/// Error bars are drawn for fleets up to this size (beyond it they hide the points).
const MAX_ERROR_BARS: usize = 200;

fn num(pointer: &str, value: Option<f64>) -> String {
    match value {
        Some(v) if v.is_finite() => {
            format!(r#"<span data-json="{pointer}" data-digits="6">{v:.6e}</span>"#)
        }
        _ => "–".into(),
    }
}

/// The distribution of parameter `k` across units: each unit's value with ±1 SE bars, the fleet
/// median and the flagging limits against the screened units (for a unit whose own error is
/// negligible; each unit is judged against the others, see `fleet::table`).
pub fn parameter_plot(table: &FleetTable, k: usize) -> Option<LinePlot> {
    let name = table.parameters.get(k)?;
    let stats = table.stats.get(k)?;
    let mut good = (Vec::new(), Vec::new());
    let mut flagged = (Vec::new(), Vec::new());
    let mut bars = Vec::new();
    for (i, row) in table.rows.iter().enumerate() {
        let Some(v) = row.values.get(k).copied().flatten() else {
            continue;
        };
        let x = (i + 1) as f64;
        let is_flagged = row.flags.iter().any(|f| &f.parameter == name);
        let target = if is_flagged { &mut flagged } else { &mut good };
        target.0.push(x);
        target.1.push(v);
        if let Some(se) = row.std_errors.get(k).copied().flatten() {
            bars.push((x, v - se, v + se, is_flagged));
        }
    }
    if good.0.is_empty() && flagged.0.is_empty() {
        return None;
    }
    let n = table.rows.len().max(1) as f64;
    let mut plot = LinePlot::new(name.clone(), "unit (row of the table)", name.clone())
        .x_range(0.5, n + 0.5)
        .legend(Legend::UpperRight)
        .size(760, 240);
    plot.decimate = false;
    if bars.len() <= MAX_ERROR_BARS {
        for (x, lo, hi, is_flagged) in bars {
            plot = plot.series(
                Series::new("", vec![x, x], vec![lo, hi])
                    .color(if is_flagged { FLAGGED } else { GOOD })
                    .width(1),
            );
        }
    }
    if let (Some(m), Some(s)) = (stats.median, stats.spread) {
        plot = plot.series(
            Series::new("fleet median", vec![0.5, n + 0.5], vec![m, m])
                .color(CENTRE)
                .style(LineStyle::Dashed)
                .width(1),
        );
        let _ = s;
        if let Some([lo, hi]) = stats.limits {
            for (label, y) in [("flagging limits".to_string(), hi), (String::new(), lo)] {
                plot = plot.series(
                    Series::new(label, vec![0.5, n + 0.5], vec![y, y])
                        .color(Rgb(150, 150, 150))
                        .style(LineStyle::Dashed)
                        .width(1),
                );
            }
        }
    }
    if !good.0.is_empty() {
        plot = plot.series(
            Series::new("unit ± 1 SE", good.0, good.1)
                .color(GOOD)
                .style(LineStyle::Markers),
        );
    }
    if !flagged.0.is_empty() {
        plot = plot.series(
            Series::new("flagged", flagged.0, flagged.1)
                .color(FLAGGED)
                .style(LineStyle::Markers),
        );
    }
    Some(plot)
}

/// fleet.html.
pub fn fleet_html(table: &FleetTable) -> Result<String, PlotError> {
    let mut h = String::new();
    h.push_str(
        "<!doctype html><html><head><meta charset=\"utf-8\"><meta name=\"generator\" content=\"spincal\"><title>spincal fleet</title>\
         <style>body{font-family:sans-serif;max-width:80em;margin:2em auto}table{border-collapse:collapse;font-size:90%}\
         td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}th{background:#eee}td.name{text-align:left}\
         tr.flagged td{background:#fde3d4}tr.failed td{color:#b00}figure{margin:1em 0}</style></head><body>",
    );
    h.push_str(&format!(
        "<h1>Fleet calibration</h1><p>{} units: <span data-json=\"/units_ok\" data-digits=\"0\">{}</span> calibrated, \
         <span data-json=\"/units_failed\" data-digits=\"0\">{}</span> failed, {} flagged.</p>",
        table.rows.len(),
        table.units_ok,
        table.units_failed,
        table.flagged_units().len()
    ));
    h.push_str(&format!("<p>{}</p>", escape(&table.rule)));
    units_section(table, &mut h);
    flagged_section(table, &mut h);
    statistics_section(table, &mut h);
    plots_section(table, &mut h)?;
    parameters_section(table, &mut h);
    h.push_str("</body></html>\n");
    Ok(h)
}

/// One row per unit: its status, saved corrector, held-out error and flags.
fn units_section(table: &FleetTable, h: &mut String) {
    h.push_str("<h2>Units</h2><table><tr><th>row</th><th>unit</th><th>status</th><th>saved corrector</th><th>held-out RMS, m/s²</th><th>flagged on</th></tr>");
    for (i, row) in table.rows.iter().enumerate() {
        let class = if !row.ok {
            " class=\"failed\""
        } else if !row.flags.is_empty() {
            " class=\"flagged\""
        } else {
            ""
        };
        let status = match &row.error {
            Some(e) => format!("failed: {}", escape(e)),
            None => "ok".into(),
        };
        let flags: Vec<String> = row.flags.iter().map(|f| escape(&f.parameter)).collect();
        h.push_str(&format!(
            "<tr{class}><td>{}</td><td class=\"name\">{}</td><td class=\"name\">{status}</td><td class=\"name\">{}</td><td>{}</td><td class=\"name\">{}</td></tr>",
            i + 1,
            escape(&row.unit),
            escape(row.saved.as_deref().unwrap_or("–")),
            num(&format!("/rows/{i}/held_out_rms_mps2"), row.held_out_rms_mps2),
            flags.join(", ")
        ));
    }
    h.push_str("</table>");
}

/// Why each flagged unit was flagged.
fn flagged_section(table: &FleetTable, h: &mut String) {
    if !table.outliers.is_empty() {
        h.push_str("<h2>Flagged</h2><ul>");
        for f in &table.outliers {
            h.push_str(&format!(
                "<li><b>{}</b>: {}</li>",
                escape(&f.unit),
                escape(&f.reason)
            ));
        }
        h.push_str("</ul>");
    }
}

/// Each parameter's fleet statistics.
fn statistics_section(table: &FleetTable, h: &mut String) {
    h.push_str("<h2>Fleet statistics</h2><table><tr><th>parameter</th><th>units</th><th>median</th><th>spread (robust SD)</th><th>screened units</th><th>their SD</th><th>median SE</th><th>min</th><th>max</th><th>judged</th></tr>");
    for (k, s) in table.stats.iter().enumerate() {
        h.push_str(&format!(
            "<tr><td class=\"name\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&s.parameter),
            s.units,
            num(&format!("/stats/{k}/median"), s.median),
            num(&format!("/stats/{k}/spread"), s.spread),
            s.screened_units,
            num(&format!("/stats/{k}/screened_sd"), s.screened_sd),
            num(&format!("/stats/{k}/median_std_error"), s.median_std_error),
            num(&format!("/stats/{k}/min"), s.min),
            num(&format!("/stats/{k}/max"), s.max),
            if s.judged { "yes" } else { "no" }
        ));
    }
    h.push_str("</table>");
}

/// Each parameter's plot across the fleet.
fn plots_section(table: &FleetTable, h: &mut String) -> Result<(), PlotError> {
    h.push_str("<h2>Each parameter across the fleet</h2><p>One point per calibrated unit (x: its row in the table above) with ±1 standard error; the dashed black line is the fleet median, the grey ones the flagging limits (against every unit that passed the screen) for a unit whose own error is negligible. Flagged units are drawn in orange.</p>");
    for k in 0..table.parameters.len() {
        if let Some(plot) = parameter_plot(table, k) {
            h.push_str(&format!(
                "<figure>{}<figcaption>{}</figcaption></figure>\n",
                plot.to_svg()?,
                escape(&table.parameters[k])
            ));
        }
    }
    Ok(())
}

/// Every unit's parameters with their standard errors.
fn parameters_section(table: &FleetTable, h: &mut String) {
    h.push_str("<h2>Every parameter with its standard error</h2><table><tr><th>unit</th>");
    for p in &table.parameters {
        h.push_str(&format!("<th>{}</th><th>SE</th>", escape(p)));
    }
    h.push_str("</tr>");
    for (i, row) in table.rows.iter().enumerate() {
        h.push_str(&format!("<tr><td class=\"name\">{}</td>", escape(&row.unit)));
        for k in 0..table.parameters.len() {
            let flagged = row.flags.iter().any(|f| f.parameter == table.parameters[k]);
            let style = if flagged {
                " style=\"background:#fde3d4\""
            } else {
                ""
            };
            h.push_str(&format!(
                "<td{style}>{}</td><td>{}</td>",
                num(
                    &format!("/rows/{i}/values/{k}"),
                    row.values.get(k).copied().flatten()
                ),
                num(
                    &format!("/rows/{i}/std_errors/{k}"),
                    row.std_errors.get(k).copied().flatten()
                )
            ));
        }
        h.push_str("</tr>");
    }
    h.push_str("</table>");
}
