//! The exception hierarchy: every error the library reports becomes a subclass of
//! `spincal.Error` carrying the library's message unchanged (file, line, column, key or parameter),
//! and, where the library's error says so, the place as attributes: `path`, `line`, `column`
//! (1-based), `column_name`, `row` (0-based, for arrays and DataFrames) and `key` (a campaign file's
//! key or a model file's field). Unknown places are None.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

use spincal::campaign::file::CampaignError;
use spincal::campaign::load::LoadError;
use spincal::input::formats::FormatError as ReadError;
use spincal::input::recording::RecordingError;
use spincal::input::table::{Location, TableError};

create_exception!(
    spincal,
    Error,
    PyException,
    "Base class of every error spincal raises; the message names the file, line, column, key or parameter at fault, and the attributes `path`, `line`, `column`, `column_name`, `row` and `key` hold the place where it is known (else None)."
);
create_exception!(
    spincal,
    FormatError,
    Error,
    "A file or table could not be read: unknown format, bad number, missing column, time going backwards, bad campaign file."
);
create_exception!(
    spincal,
    ModelError,
    Error,
    "A saved corrector (model.json) is invalid, of another format version, or does not fit the data."
);
create_exception!(
    spincal,
    FitError,
    Error,
    "A fit or calibration could not be made from the data (too short, undetermined, not converging)."
);
create_exception!(
    spincal,
    UsageError,
    Error,
    "An argument is out of range or two arguments contradict each other."
);
create_exception!(
    spincal,
    OutputError,
    Error,
    "An output file could not be written (the previous file, if any, is kept)."
);

/// Which exception class an error maps to.
#[derive(Clone, Copy)]
pub enum Kind {
    Format,
    Model,
    Fit,
    Usage,
    Output,
}

/// Where an error lies, as far as the error says.
#[derive(Default, Debug, Clone)]
pub struct Place {
    pub path: Option<String>,
    pub line: Option<usize>,
    pub column: Option<usize>,
    pub column_name: Option<String>,
    pub row: Option<usize>,
    pub key: Option<String>,
}

impl Place {
    fn at(at: &Location) -> Place {
        Place {
            path: Some(at.file.clone()),
            line: Some(at.line),
            column: at.column,
            column_name: at.column_name.clone(),
            ..Place::default()
        }
    }

    fn file(file: &str) -> Place {
        Place {
            path: Some(file.to_string()),
            ..Place::default()
        }
    }

    fn file_line(file: &str, line: usize) -> Place {
        Place {
            path: Some(file.to_string()),
            line: Some(line),
            ..Place::default()
        }
    }
}

fn table_place(e: &TableError) -> Option<Place> {
    use TableError as T;
    Some(match e {
        T::Io { file, .. } | T::Empty { file } | T::NoData { file, .. } => Place::file(file),
        T::NotANumber { at, .. } | T::NonFinite { at, .. } | T::EmptyCell { at } | T::Ragged { at, .. } => {
            Place::at(at)
        }
        T::Truncated { file, line, .. } | T::NotText { file, line } => Place::file_line(file, *line),
        T::NoLabelColumn { file, .. } | T::NoColumn { file, .. } => Place::file(file),
        _ => return None,
    })
}

fn recording_place(e: &RecordingError) -> Option<Place> {
    use RecordingError as R;
    match e {
        R::Table(t) => table_place(t),
        R::NoSuchColumn { file, .. } | R::AmbiguousColumns { file, .. } | R::TooShort { file, .. } => {
            Some(Place::file(file))
        }
        R::Write { file, .. } => Some(Place::file(file)),
        R::TimeNotIncreasing { at, .. } | R::NonFiniteAfterConversion { at, .. } => Some(Place::at(at)),
        _ => None,
    }
}

fn read_place(e: &ReadError) -> Option<Place> {
    use ReadError as F;
    match e {
        F::Io { file, .. } | F::NoSampleRate { file } | F::MissingColumn { file, .. } => {
            Some(Place::file(file))
        }
        F::Table(t) => table_place(t),
        F::Recording(r) => recording_place(r),
        F::BadSampleRate { file, line, .. } => Some(Place::file_line(file, *line)),
        F::BadIndex {
            file, line, column, ..
        } => Some(Place {
            column_name: Some(column.clone()),
            ..Place::file_line(file, *line)
        }),
        _ => None,
    }
}

fn campaign_place(e: &CampaignError) -> Option<Place> {
    match e {
        CampaignError::Io { file, .. } => Some(Place::file(file)),
        CampaignError::Syntax {
            file, line, column, ..
        } => Some(Place {
            column: Some(*column),
            ..Place::file_line(file, *line)
        }),
        CampaignError::Entry { file, line, key, .. } => Some(Place {
            key: Some(key.clone()),
            ..Place::file_line(file, *line)
        }),
        _ => None,
    }
}

fn corrector_place(e: &spincal::correctors::model_file::CorrectorError) -> Option<Place> {
    use spincal::correctors::model_file::CorrectorError as C;
    match e {
        C::Read { file, .. }
        | C::Write { file, .. }
        | C::Parse { file, .. }
        | C::MissingVersion { file }
        | C::Version { file, .. } => Some(Place::file(file)),
        C::Invalid { file, field, .. } => Some(Place {
            key: Some(field.clone()),
            ..Place::file(file)
        }),
        _ => None,
    }
}

/// The most specific place any error in the chain names: the innermost one with a line, else the
/// innermost one (a campaign's missing recording: the campaign file's line that names it).
fn place_of(error: &(dyn std::error::Error + 'static)) -> Place {
    let mut found = Place::default();
    let mut current: Option<&(dyn std::error::Error + 'static)> = Some(error);
    while let Some(e) = current {
        let here = if let Some(t) = e.downcast_ref::<TableError>() {
            table_place(t)
        } else if let Some(r) = e.downcast_ref::<RecordingError>() {
            recording_place(r)
        } else if let Some(f) = e.downcast_ref::<ReadError>() {
            read_place(f)
        } else if let Some(f) = e.downcast_ref::<Box<ReadError>>() {
            read_place(f)
        } else if let Some(c) = e.downcast_ref::<CampaignError>() {
            campaign_place(c)
        } else if let Some(l) = e.downcast_ref::<LoadError>() {
            load_place(l)
        } else if let Some(c) = e.downcast_ref::<spincal::correctors::model_file::CorrectorError>() {
            corrector_place(c)
        } else if let Some(f) = e.downcast_ref::<spincal::fleet::FleetError>() {
            fleet_place(f)
        } else {
            None
        };
        if let Some(place) = here {
            if place.line.is_some() || found.line.is_none() {
                found = place;
            }
        }
        current = e.source();
    }
    found
}

/// A campaign entry that failed to load: the campaign file's line and key (the recording's own
/// place, when it names one, is found further down the chain).
fn load_place(e: &LoadError) -> Option<Place> {
    use LoadError as L;
    let (campaign, line, key) = match e {
        L::Recording { campaign, line, .. } => (campaign, *line, "file"),
        L::RawCounts { campaign, line, .. } => (campaign, *line, "accel_range_g"),
        L::RawGyroCounts { campaign, line, .. } => (campaign, *line, "gyro_range_dps"),
        L::Companion {
            campaign, line, key, ..
        }
        | L::CompanionLength {
            campaign, line, key, ..
        } => (campaign, *line, *key),
        L::GyroFile { campaign, line, .. } => (campaign, *line, "gyro_file"),
        _ => return None,
    };
    Some(Place {
        key: Some(key.to_string()),
        ..Place::file_line(campaign, line)
    })
}

fn fleet_place(e: &spincal::fleet::FleetError) -> Option<Place> {
    use spincal::fleet::FleetError as F;
    match e {
        F::Campaign(c) => campaign_place(c),
        F::Run(spincal::campaign::run::CampaignRunError::Load(l)) => {
            // A transparent wrapper: its source() skips the load error itself, so look inside.
            let inner = place_of(l);
            Some(inner).filter(|p| p.path.is_some()).or_else(|| load_place(l))
        }
        F::NoCampaign { folder } | F::SeveralCampaigns { folder, .. } => Some(Place::file(folder)),
        _ => None,
    }
}

/// The exception of `kind` with the error's message (its sources appended, as the CLI shows them)
/// and its place as attributes.
pub fn raise(kind: Kind, error: &(dyn std::error::Error + 'static)) -> PyErr {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(s) = source {
        let more = s.to_string();
        if !text.contains(&more) {
            text.push_str(": ");
            text.push_str(&more);
        }
        source = s.source();
    }
    with_place(kind, text, &place_of(error))
}

/// An exception of `kind` with `text` and the attributes of `place`.
pub fn with_place(kind: Kind, text: String, place: &Place) -> PyErr {
    let err = match kind {
        Kind::Format => FormatError::new_err(text),
        Kind::Model => ModelError::new_err(text),
        Kind::Fit => FitError::new_err(text),
        Kind::Usage => UsageError::new_err(text),
        Kind::Output => OutputError::new_err(text),
    };
    Python::attach(|py| {
        let value = err.value(py);
        // Setting an attribute on a fresh exception object cannot fail in practice; if it did,
        // the class's None stays, which is what an unknown place looks like.
        let _ = value.setattr("path", place.path.clone());
        let _ = value.setattr("line", place.line);
        let _ = value.setattr("column", place.column);
        let _ = value.setattr("column_name", place.column_name.clone());
        let _ = value.setattr("row", place.row);
        let _ = value.setattr("key", place.key.clone());
    });
    err
}

/// Shorthands: `result.map_err(fmt)?` and so on.
pub fn format(e: impl std::error::Error + 'static) -> PyErr {
    raise(Kind::Format, &e)
}
pub fn model(e: impl std::error::Error + 'static) -> PyErr {
    raise(Kind::Model, &e)
}
pub fn fit(e: impl std::error::Error + 'static) -> PyErr {
    raise(Kind::Fit, &e)
}
pub fn usage_error(e: impl std::error::Error + 'static) -> PyErr {
    raise(Kind::Usage, &e)
}
pub fn output(e: impl std::error::Error + 'static) -> PyErr {
    raise(Kind::Output, &e)
}
pub fn usage(text: impl Into<String>) -> PyErr {
    UsageError::new_err(text.into())
}

/// Registers the classes in the module, each with None for every place attribute.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let base = py.get_type::<Error>();
    for attribute in ["path", "line", "column", "column_name", "row", "key"] {
        base.setattr(attribute, py.None())?;
    }
    m.add("Error", base)?;
    m.add("FormatError", py.get_type::<FormatError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("FitError", py.get_type::<FitError>())?;
    m.add("UsageError", py.get_type::<UsageError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    Ok(())
}
