//! The comparison of correctors as text and CSV, shared by `calibrate`, `compare` and `demo`.

use spincal::campaign::paper::{ComparisonRow, CrossRow, PaperProtocol, PartScore};

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
