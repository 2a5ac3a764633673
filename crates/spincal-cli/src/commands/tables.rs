//! The comparison of correctors as text and CSV, shared by `calibrate`, `compare` and `demo`.

use std::fmt::Write as _;

use spincal::campaign::paper::{ComparisonRow, CrossRow, PaperProtocol, PartScore};
use spincal::campaign::select::CampaignOutput;

fn fit_or_dash(score: Option<&PartScore>) -> String {
    match score {
        Some(s) if s.fit_percent_mean.is_finite() => format!("{:.2}", s.fit_percent_mean),
        _ => "—".into(),
    }
}

/// The table as CSV: one row per model, simulation and one-step columns, test RMSE, seconds.
pub fn table_csv(rows: &[ComparisonRow]) -> String {
    let mut text = String::from(
        "model,structure,kind,train_fit_sim,validation_fit_sim,test_fit_sim,train_fit_one_step,test_fit_one_step,test_rmse_mps2,seconds,failed\n",
    );
    for r in rows {
        let one = |s: &Option<PartScore>| {
            s.as_ref()
                .map(|s| s.fit_percent_mean.to_string())
                .unwrap_or_default()
        };
        text.push_str(&format!(
            "{},\"{}\",{},{},{},{},{},{},{},{},\"{}\"\n",
            r.model,
            r.structure.replace('"', "'"),
            r.kind,
            r.train.fit_percent_mean,
            r.validation.fit_percent_mean,
            r.test.fit_percent_mean,
            one(&r.train_one_step),
            one(&r.test_one_step),
            r.test.rmse_mps2_mean,
            r.seconds,
            r.failed.clone().unwrap_or_default().replace('"', "'")
        ));
    }
    text
}

/// Why a comparison row failed, and its warnings, as indented lines under the row.
pub fn row_notes(row: &ComparisonRow) -> String {
    let mut text = String::new();
    if let Some(why) = &row.failed {
        text.push_str(&format!("{:<12} not fitted: {why}\n", ""));
    }
    for warning in &row.warnings {
        text.push_str(&format!("{:<12} warning: {warning}\n", ""));
    }
    text
}

/// The cross-condition rows for people (empty when there was one recording).
pub fn cross_condition_text(rows: &[CrossRow]) -> String {
    let mut text = String::new();
    if !rows.is_empty() {
        text.push_str("\ncross-condition (trained on recording 1):\n");
        for c in rows {
            text.push_str(&format!(
                "{:<12} {:>9.2} %  on {}",
                c.model, c.score.fit_percent_mean, c.tested_on
            ));
            if let Some(a) = &c.against_uncorrected {
                text.push_str(&format!(
                    "  {:.2}× ± {:.2} uncorrected{}",
                    a.ratio,
                    a.ratio_se,
                    if a.worse { ", significantly worse" } else { "" }
                ));
            }
            if let Some(outside) = c.outside_training_range_percent.filter(|p| *p > 0.0) {
                text.push_str(&format!(
                    "  ({outside:.1} % of samples outside the training range)"
                ));
            }
            text.push('\n');
        }
    }
    text
}

/// The table for people.
pub fn table_text(result: &PaperProtocol) -> String {
    let mut text = format!(
        "{:<12} {:<34} {:>9} {:>9} {:>9} {:>10} {:>10} {:>11} {:>8}\n",
        "model",
        "structure",
        "train sim",
        "valid sim",
        "test sim",
        "train 1-st",
        "test 1-st",
        "test RMSE",
        "seconds"
    );
    for r in &result.comparison {
        let mut structure = r.structure.clone();
        structure.truncate(34);
        text.push_str(&format!(
            "{:<12} {:<34} {:>9} {:>9} {:>9} {:>10} {:>10} {:>11.5} {:>8.2}\n",
            r.model,
            structure,
            fit_or_dash(Some(&r.train)),
            fit_or_dash(Some(&r.validation)),
            fit_or_dash(Some(&r.test)),
            fit_or_dash(r.train_one_step.as_ref()),
            fit_or_dash(r.test_one_step.as_ref()),
            r.test.rmse_mps2_mean,
            r.seconds
        ));
        text.push_str(&row_notes(r));
    }
    text.push_str(
        "\nfit % = 100 (1 − ‖y − ŷ‖/‖y − ȳ‖), mean over the corrected axes; sim = simulation (infinite horizon), \
         1-st = one-step prediction (dynamic models only; static maps have one kind).\n",
    );
    text.push_str(&cross_condition_text(&result.cross_condition));
    text
}

/// A campaign's fit details and per-condition tables (`calibrate --campaign --tables`).
pub fn campaign_tables_text(output: &CampaignOutput) -> String {
    let r = &output.result;
    let mut text = String::from("\n");
    let spread = &r.joint.bias_spread;
    let _ = writeln!(
        text,
        "bias offsets between power-on sessions: {}",
        match (spread.estimated, spread.at_lower_bound) {
            (false, _) => format!("σ = {:.4} m/s² (given)", spread.sd_mps2),
            (true, true) => format!(
                "none seen (σ below {:.5} m/s², from {} offsets)",
                spread.sd_mps2, spread.offsets
            ),
            (true, false) => format!(
                "σ = {:.4} m/s² (from {} offsets; likelihood ratio against none {:.1})",
                spread.sd_mps2, spread.offsets, spread.likelihood_ratio
            ),
        }
    );
    if let Some(rule) = &r.terms_rule {
        let z = rule.nonlinearity_z;
        let _ = writeln!(
            text,
            "nonlinearity q: {} (|q/se| {:.1} {:.1} {:.1} against {:.2})",
            if rule.keeps_nonlinearity {
                "kept"
            } else {
                "left out"
            },
            z[0].abs(),
            z[1].abs(),
            z[2].abs(),
            rule.threshold
        );
    }
    text.push('\n');
    text.push_str("held-out condition            corrector        residual vs physics x y z (m/s²)  uncorrected              ratio (95 % bound) predicted  vs truth\n");
    for h in &r.held_out {
        let (rms, uncorrected, ratio) = match &h.physics {
            Some(p) => (
                fmt3(&p.rms_mps2),
                fmt3(&p.uncorrected_rms_mps2),
                format!(
                    "{:.2} ≤{:.2}{}",
                    p.ratio,
                    p.upper_ratio,
                    if p.worse { " worse" } else { "" }
                ),
            ),
            None => (h.note.clone().unwrap_or_default(), String::new(), String::new()),
        };
        let predicted = h
            .predicted
            .as_ref()
            .map_or(String::new(), |p| format!("{:.2}", p.ratio));
        let truth = h
            .truth
            .as_ref()
            .map_or(String::new(), |t| format!("{:.2}", t.ratio));
        let _ = writeln!(
            text,
            "{:<29} {:<16} {:<33} {:<24} {:<18} {:<10} {}",
            h.condition, h.candidate, rms, uncorrected, ratio, predicted, truth
        );
    }
    if let Some(g) = &r.gyro {
        text.push_str("\ngyroscope run                            rate from accel (rad/s)  raw gyro       calibrated gyro\n");
        for c in &g.rate_checks {
            let rel = |v: f64| 100.0 * (v.abs() / c.accel_rate_radps - 1.0);
            let _ = writeln!(
                text,
                "  {:<40} {:<24.6} {:.6} ({:+.3} %)  {:.6} ({:+.4} %)",
                c.run,
                c.accel_rate_radps,
                c.raw_gyro_rate_radps,
                rel(c.raw_gyro_rate_radps),
                c.calibrated_gyro_rate_radps,
                rel(c.calibrated_gyro_rate_radps)
            );
        }
    }
    text
}

fn fmt3(v: &[f64; 3]) -> String {
    format!("{:.4} {:.4} {:.4}", v[0], v[1], v[2])
}
