//! The library's error type. Every variant names the file (where there is one)
//! and says what is wrong in one line, so the command line can print it as is.

use crate::decimal::shorten_numbers;
use std::path::PathBuf;

/// Errors from loading, indexing and analysing road networks, reading
/// scenarios and tables, and planning.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be opened or read.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error (kept out of the error chain: the
        /// message already says it).
        cause: std::io::Error,
    },
    /// The file's content is not a valid map of its format.
    #[error("{path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong, in one line.
        message: String,
    },
    /// Nothing drivable was left after filtering.
    #[error("{path}: the road network is empty after filtering ({detail})")]
    EmptyNetwork {
        /// The file.
        path: PathBuf,
        /// What was read and skipped.
        detail: String,
    },
    /// A scenario file is invalid: the message names the field and the problem.
    #[error("{path}: {message}")]
    Scenario {
        /// The scenario file.
        path: PathBuf,
        /// What is wrong, in one line.
        message: String,
    },
    /// A line of an input table (TRACK.csv, TRUTH.csv) is invalid.
    #[error("{path}:{line}: {message}")]
    Table {
        /// The file.
        path: PathBuf,
        /// The 1-based line number (the header is line 1).
        line: usize,
        /// What is wrong, in one line.
        message: String,
    },
    /// A parameter is outside its permitted range.
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// No plan can meet the requirement with the inputs given (the inputs
    /// are valid): the message says where and why.
    #[error("infeasible: {0}")]
    Infeasible(String),
}

impl Error {
    // The constructors print long numbers short (`1e300`, not 301 digits):
    // a message quotes the absurd value a file held, and Rust writes an
    // `f64` in full decimal form (see `decimal::shorten_numbers`).
    pub(crate) fn format(path: &std::path::Path, message: impl Into<String>) -> Self {
        Error::Format {
            path: path.to_path_buf(),
            message: shorten_numbers(&message.into()),
        }
    }

    pub(crate) fn scenario(path: &std::path::Path, message: impl Into<String>) -> Self {
        Error::Scenario {
            path: path.to_path_buf(),
            message: shorten_numbers(&message.into()),
        }
    }

    pub(crate) fn table(path: &std::path::Path, line: usize, message: impl Into<String>) -> Self {
        Error::Table {
            path: path.to_path_buf(),
            line,
            message: shorten_numbers(&message.into()),
        }
    }

    pub(crate) fn io(path: &std::path::Path, cause: std::io::Error) -> Self {
        Error::Io {
            path: path.to_path_buf(),
            cause,
        }
    }
}

/// Result with the library's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
