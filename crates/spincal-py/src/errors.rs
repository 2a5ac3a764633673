//! The exception hierarchy: every error the library reports becomes a subclass of
//! `spincal.Error` carrying the library's message unchanged (file, line, column, key or parameter).

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _spincal,
    Error,
    PyException,
    "Base class of every error spincal raises; the message names the file, line, column, key or parameter at fault."
);
create_exception!(
    _spincal,
    FormatError,
    Error,
    "A file or table could not be read: unknown format, bad number, missing column, time going backwards, bad campaign file."
);
create_exception!(
    _spincal,
    ModelError,
    Error,
    "A saved corrector (model.json) is invalid, of another format version, or does not fit the data."
);
create_exception!(
    _spincal,
    FitError,
    Error,
    "A fit or calibration could not be made from the data (too short, undetermined, not converging)."
);
create_exception!(
    _spincal,
    UsageError,
    Error,
    "An argument is out of range or two arguments contradict each other."
);
create_exception!(
    _spincal,
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

/// The exception of `kind` with the error's message (its sources appended, as the CLI shows them).
pub fn raise(kind: Kind, error: &dyn std::error::Error) -> PyErr {
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
    let text = text;
    match kind {
        Kind::Format => FormatError::new_err(text),
        Kind::Model => ModelError::new_err(text),
        Kind::Fit => FitError::new_err(text),
        Kind::Usage => UsageError::new_err(text),
        Kind::Output => OutputError::new_err(text),
    }
}

/// Shorthands: `result.map_err(fmt)?` and so on.
pub fn format(e: impl std::error::Error) -> PyErr {
    raise(Kind::Format, &e)
}
pub fn model(e: impl std::error::Error) -> PyErr {
    raise(Kind::Model, &e)
}
pub fn fit(e: impl std::error::Error) -> PyErr {
    raise(Kind::Fit, &e)
}
pub fn usage_error(e: impl std::error::Error) -> PyErr {
    raise(Kind::Usage, &e)
}
pub fn output(e: impl std::error::Error) -> PyErr {
    raise(Kind::Output, &e)
}
pub fn usage(text: impl Into<String>) -> PyErr {
    UsageError::new_err(text.into())
}

/// Registers the classes in the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("Error", py.get_type::<Error>())?;
    m.add("FormatError", py.get_type::<FormatError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("FitError", py.get_type::<FitError>())?;
    m.add("UsageError", py.get_type::<UsageError>())?;
    m.add("OutputError", py.get_type::<OutputError>())?;
    Ok(())
}
