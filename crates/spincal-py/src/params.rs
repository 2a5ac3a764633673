//! Settings from Python values: a dict of changes (nested like the library's `Params`, the same
//! names as its serde form) merged into the library's defaults, then checked once by the library.
//! An unknown setting is refused with its path and the known names at that level.

use pyo3::prelude::*;
use serde_json::Value;

use spincal::campaign::params::Params;

use crate::errors::{self, usage};

/// The variant tag of the library's tagged enums (`network.mode`).
const TAGS: [&str; 2] = ["mode", "kind"];

/// Merges `patch` into `base` (objects key by key, anything else replaced). A patch that names
/// another variant of a tagged enum replaces the whole object.
fn merge(base: &mut Value, patch: &Value, path: &str) -> Result<(), String> {
    let (Some(base_map), Some(patch_map)) = (base.as_object_mut(), patch.as_object()) else {
        *base = patch.clone();
        return Ok(());
    };
    let other_variant = TAGS
        .iter()
        .any(|t| patch_map.get(*t).is_some_and(|v| base_map.get(*t) != Some(v)));
    if other_variant {
        *base = patch.clone();
        return Ok(());
    }
    for (key, value) in patch_map {
        let here = if path.is_empty() {
            key.clone()
        } else {
            format!("{path}.{key}")
        };
        match base_map.get_mut(key) {
            Some(slot) => merge(slot, value, &here)?,
            None => {
                let known: Vec<&str> = base_map.keys().map(String::as_str).collect();
                return Err(format!(
                    "unknown setting {here:?} (known here: {})",
                    known.join(", ")
                ));
            }
        }
    }
    Ok(())
}

/// The library's defaults with the changes of `changes_json` (a JSON object), checked.
pub fn params_from(changes_json: Option<&str>) -> PyResult<Params> {
    let Some(text) = changes_json else {
        return Ok(Params::default());
    };
    let mut base = serde_json::to_value(Params::default()).map_err(|e| usage(format!("params: {e}")))?;
    let changes: Value = serde_json::from_str(text).map_err(|e| usage(format!("params: {e}")))?;
    if !changes.is_object() {
        return Err(usage("params: expected a dict of settings"));
    }
    merge(&mut base, &changes, "").map_err(|e| usage(format!("params: {e}")))?;
    let params: Params = serde_json::from_value(base).map_err(|e| usage(format!("params: {e}")))?;
    params.check().map_err(errors::usage_error)?;
    Ok(params)
}

/// The library's default settings (`Params`) as JSON: what `spincal calibrate` runs.
#[pyfunction]
pub fn default_params() -> PyResult<String> {
    crate::json(&Params::default())
}

/// Checks a dict of changes (JSON) against the library: returns the complete settings as JSON.
#[pyfunction]
pub fn resolve_params(changes_json: &str) -> PyResult<String> {
    crate::json(&params_from(Some(changes_json))?)
}

/// The architectures of a named sweep: `small` (the default) or `full` (the paper's 165).
#[pyfunction]
pub fn sweep_grid(name: &str) -> PyResult<Vec<Vec<usize>>> {
    match name {
        "small" => Ok(spincal::correctors::ann::small_grid()),
        "full" => Ok(spincal::correctors::ann::default_grid()),
        other => Err(usage(format!(
            "sweep {other:?}: expected 'none', 'small' or 'full'"
        ))),
    }
}
