//! The library's error type.
//!
//! Every error that comes from user input names where it came from: the file, the line
//! (1-based, as an editor shows it) and the field or column.

use std::path::PathBuf;

/// The name errors give to data that came from memory (text or bytes given in code) instead
/// of a file: ``<in memory>:3: field `x`: ...``.
pub const IN_MEMORY: &str = "<in memory>";

/// Where in an input file a problem sits.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// The file that was read.
    pub file: PathBuf,
    /// 1-based line number, when known.
    pub line: Option<usize>,
    /// The field (robot files) or column (CSV files), when known.
    pub field: Option<String>,
}

impl Location {
    /// A whole file, with no line or field.
    pub fn file(file: impl Into<PathBuf>) -> Self {
        Location {
            file: file.into(),
            line: None,
            field: None,
        }
    }

    /// A field or column on a 1-based `line` of `file`.
    pub fn at(file: impl Into<PathBuf>, line: usize, field: impl Into<String>) -> Self {
        Location {
            file: file.into(),
            line: Some(line),
            field: Some(field.into()),
        }
    }
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if let Some(field) = &self.field {
            // A field name from a hostile file can be a megabyte long.
            let n = field.chars().count();
            if n > 60 {
                let head: String = field.chars().take(60).collect();
                write!(f, ": field `{head}...` ({n} characters)")?;
            } else {
                write!(f, ": field `{field}`")?;
            }
        }
        Ok(())
    }
}

/// Everything that can go wrong in the library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    /// (The OS error is part of the message, not a separate cause: a chain printer would
    /// print it twice.)
    #[error("{path}: {cause}")]
    Io {
        /// The file or directory that was being read or written.
        path: PathBuf,
        /// The operating system's error.
        cause: std::io::Error,
    },

    /// Input that does not parse or does not make sense, with its location.
    #[error("{location}: {message}")]
    Input {
        /// Where in the input the problem sits.
        location: Location,
        /// What is wrong there.
        message: String,
    },

    /// A robot model that is inconsistent (not tied to a file).
    #[error("invalid robot model: {0}")]
    Model(String),

    /// The robot's structure does not admit the requested closed-form solution.
    #[error("no closed-form inverse kinematics for this robot: {0}")]
    NoClosedForm(String),

    /// A numerical solve did not reach its tolerance.
    #[error("{0}")]
    NotConverged(String),

    /// Arguments that do not fit together (lengths, counts).
    #[error("{0}")]
    Invalid(String),
}

impl Error {
    /// An [`Error::Input`] at `location`.
    pub fn input(location: Location, message: impl Into<String>) -> Self {
        Error::Input {
            location,
            message: message.into(),
        }
    }

    /// An [`Error::Io`] on `path`.
    pub fn io(path: impl Into<PathBuf>, cause: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            cause,
        }
    }
}

/// The library's result type, with [`Error`] as its error.
pub type Result<T> = std::result::Result<T, Error>;
