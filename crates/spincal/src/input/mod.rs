//! Reading recordings: the delimited-text parser, the `Recording` type (SI units inside), the
//! file formats, and what is in a file before anything is fitted.

pub mod decimal;
pub mod formats;
pub mod gyro_file;
pub mod inspect;
pub mod limits;
pub mod recording;
pub mod table;
