//! Fleets: finding each unit's inputs, calibrating one unit and the fleet's summary table.

use std::path::PathBuf;

use pyo3::prelude::*;

use spincal::campaign::file::Campaign;
use spincal::correctors::model_file::CorrectorFile;

use crate::errors::usage;
use crate::simulation::with_overrides;
use crate::{errors, json, long};

/// A fleet error as the right exception: files and campaign entries → FormatError, the
/// calibration → FitError.
fn fleet_error(e: spincal::fleet::FleetError) -> PyErr {
    use spincal::campaign::run::CampaignRunError as R;
    use spincal::fleet::FleetError as F;
    match &e {
        F::NoCampaign { .. } | F::Campaign(_) | F::Run(R::Load(_)) => errors::format(e),
        F::Run(R::Calibration { .. }) => errors::fit(e),
        _ => errors::Error::new_err(e.to_string()),
    }
}

/// A unit's campaign file and every file it reads (campaign file, recordings, truth files), so a
/// driver can ship them to a worker: (campaign file, [inputs]).
#[pyfunction]
pub(crate) fn campaign_inputs(source: PathBuf) -> PyResult<(PathBuf, Vec<PathBuf>)> {
    let path = spincal::fleet::campaign_path(&source).map_err(fleet_error)?;
    let campaign = Campaign::read_path(&path).map_err(errors::format)?;
    Ok((path, campaign.inputs()))
}

/// The unit label of each source, unique in the fleet (a folder's name, …).
#[pyfunction]
pub(crate) fn unit_labels(sources: Vec<PathBuf>) -> Vec<String> {
    spincal::fleet::unit_labels(&sources)
}

/// Calibrates one unit (a campaign file or a folder holding campaign.toml) on one thread, as
/// `spincal calibrate --campaign`: returns (unit, results.json text, model.json text or None).
#[pyfunction]
#[pyo3(signature = (source, *, progress = None))]
pub(crate) fn calibrate_unit(
    py: Python<'_>,
    source: PathBuf,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<(String, String, Option<String>)> {
    let settings = spincal::fleet::FleetSettings::default();
    let unit = long::run(py, progress.as_ref(), |observer| {
        spincal::fleet::calibrate_unit(&source, &settings, observer)
    })?
    .map_err(fleet_error)?;
    Ok((unit.unit.clone(), unit.results_json(), unit.model_json()))
}

/// One unit's outcome as the driver has it: (label, source, results.json or None, model.json or
/// None, error message or None).
type OutcomeTuple = (String, PathBuf, Option<String>, Option<String>, Option<String>);

/// The fleet table (every sensor parameter with its standard error per unit, fleet statistics,
/// outliers) from the units' outcomes; `outliers_json` overrides the library's OutlierSettings.
/// Returns (table JSON, table CSV, fleet.html).
#[pyfunction]
#[pyo3(signature = (outcomes, *, outliers_json = None))]
pub(crate) fn fleet_table(
    outcomes: Vec<OutcomeTuple>,
    outliers_json: Option<&str>,
) -> PyResult<(String, String, String)> {
    use spincal::fleet::{OutlierSettings, UnitCalibration, UnitOutcome};
    let settings = with_overrides(OutlierSettings::default(), outliers_json, "outlier settings")?;
    let mut units = Vec::with_capacity(outcomes.len());
    for (label, source, results, model, error) in outcomes {
        let result = match (results, error) {
            (Some(text), None) => {
                let result: spincal::campaign::select::CampaignResult = serde_json::from_str(&text)
                    .map_err(|e| usage(format!("{label}: results.json is not a campaign result: {e}")))?;
                let model = model
                    .map(|m| CorrectorFile::from_json(&m, &format!("{label}/model.json")))
                    .transpose()
                    .map_err(errors::model)?;
                Ok(UnitCalibration {
                    unit: result.unit.clone(),
                    campaign: source.clone(),
                    inputs: Vec::new(),
                    result,
                    model,
                })
            }
            (_, Some(message)) => Err(message),
            (None, None) => return Err(usage(format!("{label}: neither a result nor an error"))),
        };
        units.push(UnitOutcome {
            unit: label,
            source,
            result,
        });
    }
    let table = spincal::fleet::fleet_table(&units, &settings);
    let html = spincal::report::fleet::fleet_html(&table)
        .map_err(|e| errors::Error::new_err(format!("drawing fleet.html: {e}")))?;
    Ok((json(&table)?, table.to_csv(), html))
}
