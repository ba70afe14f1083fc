//! Errors of the runner and the exit codes they map to: bad input ([`Error::Input`], naming the
//! file and the field) exits 2, everything else 1. Errors caused by another error keep it as
//! their [`std::error::Error::source`].

use std::fmt;
use std::path::{Path, PathBuf};

/// An error that ends the command, with its exit code.
#[derive(Debug)]
pub enum Error {
    /// Bad input (sweep file, arguments): exit code 2. `field` names the offending field.
    Input {
        /// File the error is in, if any.
        file: Option<String>,
        /// Dotted path of the offending field (or the option), empty for syntax errors.
        field: String,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// An operation on a file or directory failed.
    Io {
        /// What was done: `create`, `write`, `sync`, `rename`, `list`, …
        action: &'static str,
        /// On what.
        path: PathBuf,
        /// Where to, for a rename.
        to: Option<PathBuf>,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The HDF5 library failed (in the store crate, the only one that links it).
    Hdf5 {
        /// What was being done (`writing X.h5`), empty when not known.
        context: String,
        /// The library's error.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A stored JSON record could not be read.
    Json {
        /// Which record.
        what: String,
        /// The parser's error.
        source: serde_json::Error,
    },
    /// Another process holds the lock on the output's work directory.
    Locked {
        /// The output file.
        output: PathBuf,
        /// The lock file.
        lock: PathBuf,
        /// The pid the lock file names, if any.
        holder: Option<String>,
    },
    /// The worker threads could not be started.
    Threads {
        /// How many were asked for.
        jobs: usize,
        /// Rayon's error.
        source: rayon::ThreadPoolBuildError,
    },
    /// Anything else (files that do not fit together, a reference run that failed, …): exit
    /// code 1.
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

    /// Makes an I/O error of `action` on `path` (for `map_err`).
    pub fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> Error {
        let path = path.to_path_buf();
        move |source| Error::Io {
            action,
            path,
            to: None,
            source,
        }
    }

    /// Makes the I/O error of renaming `from` to `to` (for `map_err`).
    pub fn rename(from: &Path, to: &Path) -> impl FnOnce(std::io::Error) -> Error {
        let (path, to) = (from.to_path_buf(), to.to_path_buf());
        move |source| Error::Io {
            action: "rename",
            path,
            to: Some(to),
            source,
        }
    }

    /// Says what was being done when the HDF5 library failed (an HDF5 error without context).
    pub fn hdf5_context(self, context: impl FnOnce() -> String) -> Self {
        match self {
            Error::Hdf5 { context: c, source } if c.is_empty() => Error::Hdf5 {
                context: context(),
                source,
            },
            other => other,
        }
    }

    /// Exit code of this error.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input { .. } => crate::EXIT_BAD_INPUT,
            _ => crate::EXIT_ERROR,
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
            Error::Io {
                action,
                path,
                to,
                source,
            } => {
                write!(f, "cannot {action} {}", path.display())?;
                if let Some(to) = to {
                    write!(f, " to {}", to.display())?;
                }
                write!(f, ": {source}")
            }
            Error::Hdf5 { context, source } if context.is_empty() => {
                write!(f, "HDF5 error: {source}")
            }
            Error::Hdf5 { context, source } => write!(f, "HDF5 error ({context}): {source}"),
            Error::Json { what, source } => write!(f, "unreadable {what}: {source}"),
            Error::Locked {
                output,
                lock,
                holder,
            } => {
                let who = match holder {
                    Some(pid) => format!(" (pid {pid})"),
                    None => String::new(),
                };
                write!(
                    f,
                    "another chainsweep process{who} is working on {}: its lock {} is held; wait for it to finish or stop it, then run the same command again",
                    output.display(),
                    lock.display()
                )
            }
            Error::Threads { jobs, source } => {
                write!(f, "cannot start {jobs} worker threads: {source}")
            }
            Error::Other(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            Error::Hdf5 { source, .. } => Some(source.as_ref()),
            Error::Json { source, .. } => Some(source),
            Error::Threads { source, .. } => Some(source),
            Error::Input { .. } | Error::Locked { .. } | Error::Other(_) => None,
        }
    }
}

/// Result with the runner's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

/// A number as an error message shows it: plain, or in scientific notation when huge or tiny
/// (`1e308`, not 309 digits).
pub fn number_text(x: f64) -> String {
    if x != 0.0 && !(1e-4..1e9).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error as _;

    #[test]
    fn errors_keep_their_source_and_exit_code() {
        let e = Error::io("create", Path::new("/x/y"))(std::io::Error::new(
            std::io::ErrorKind::PermissionDenied,
            "denied",
        ));
        assert_eq!(e.to_string(), "cannot create /x/y: denied");
        assert_eq!(e.source().unwrap().to_string(), "denied");
        assert_eq!(e.exit_code(), crate::EXIT_ERROR);
        let e = Error::rename(Path::new("a"), Path::new("b"))(std::io::Error::other("full"));
        assert_eq!(e.to_string(), "cannot rename a to b: full");
        let e = Error::input("axes[0].values[2]", "must be > 0").in_file("s.json");
        assert_eq!(
            e.to_string(),
            "s.json: field `axes[0].values[2]`: must be > 0"
        );
        assert_eq!(e.exit_code(), crate::EXIT_BAD_INPUT);
        assert!(e.source().is_none());
    }
}
