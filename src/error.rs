//! The error type of the library, and the exit status each kind maps to.

use std::fmt;
use std::path::PathBuf;

/// Everything that can go wrong, split by who has to act on it.
#[derive(Debug)]
pub enum Error {
    /// A scene file that cannot be read as TOML or fails validation. The message already names
    /// the file and the line:column or the field path.
    Scene(String),
    /// A bad command-line argument (frame spec, chunk, override value).
    Usage(String),
    /// An input/output failure on a path (reading the scene, writing a frame).
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Any other failure while producing output (an encoder error, for example).
    Output { path: PathBuf, message: String },
    /// The machine could not give what a run needs (worker threads, for example).
    Resource(String),
}

impl Error {
    /// The process exit status for this error: 2 for bad input (nothing was written),
    /// 1 for everything else.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Scene(_) | Error::Usage(_) => 2,
            Error::Io { .. } | Error::Output { .. } | Error::Resource(_) => 1,
        }
    }

    /// Convenience constructor for an I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Error {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Scene(m) => write!(f, "{m}"),
            Error::Usage(m) | Error::Resource(m) => write!(f, "{m}"),
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Error::Output { path, message } => write!(f, "{}: {message}", path.display()),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}
