//! Errors of the runner and the exit codes they map to.

use std::fmt;

/// An error that ends the command, with its exit code.
#[derive(Debug)]
pub enum Error {
    /// Bad input (sweep file, arguments): exit code 2. `field` names the offending field.
    Input {
        /// File the error is in, if any.
        file: Option<String>,
        /// Dotted path of the offending field, empty for syntax errors.
        field: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// Any other failure (I/O, HDF5, lock held by another process): exit code 1.
    Other(String),
}

impl Error {
    /// Bad input naming a field.
    pub fn input(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Input {
            file: None,
            field: field.into(),
            message: message.into(),
        }
    }

    /// Attaches the file name to an input error.
    pub fn in_file(self, path: &str) -> Self {
        match self {
            Error::Input { field, message, .. } => Error::Input {
                file: Some(path.to_string()),
                field,
                message,
            },
            other => other,
        }
    }

    /// Exit code of this error.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input { .. } => crate::EXIT_BAD_INPUT,
            Error::Other(_) => crate::EXIT_ERROR,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Input {
                file,
                field,
                message,
            } => {
                if let Some(file) = file {
                    write!(f, "{file}: ")?;
                }
                if field.is_empty() {
                    write!(f, "{message}")
                } else {
                    write!(f, "field `{field}`: {message}")
                }
            }
            Error::Other(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for Error {}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Other(format!("I/O error: {e}"))
    }
}

impl From<hdf5::Error> for Error {
    fn from(e: hdf5::Error) -> Self {
        Error::Other(format!("HDF5 error: {e}"))
    }
}

/// Result with the runner's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

/// Wraps an I/O error with what was being done.
pub fn io_ctx<T>(r: std::io::Result<T>, what: impl FnOnce() -> String) -> Result<T> {
    r.map_err(|e| Error::Other(format!("{}: {e}", what())))
}
