//! The one error type of abba-io: every message names the file and, where
//! there is one, the line or JSON path and the field.

use std::fmt;

/// Where in a file a record or an error sits.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Place {
    /// The whole file (no finer position).
    File,
    /// A 1-based line of a text file (CRLF and LF count alike).
    Line(u64),
    /// A JSON path such as `$[12].insulin` (the field is given separately).
    Json(String),
    /// A row of a workbook's sheet: the sheet's name and Excel's 1-based
    /// row number (the column is given as the field).
    Sheet {
        /// The sheet's name.
        sheet: String,
        /// Excel's row number (1 is the header row).
        row: u32,
    },
}

/// A position in an input: file name and place.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Location {
    /// The file as the user named it.
    pub file: String,
    /// Line or JSON path.
    pub place: Place,
}

impl Location {
    /// A line of `file`.
    pub fn line(file: &str, line: u64) -> Self {
        Self {
            file: file.to_string(),
            place: Place::Line(line),
        }
    }
    /// A JSON path in `file`.
    pub fn json(file: &str, path: impl Into<String>) -> Self {
        Self {
            file: file.to_string(),
            place: Place::Json(path.into()),
        }
    }
    /// A row of a sheet of the workbook `file`.
    pub fn sheet(file: &str, sheet: &str, row: u32) -> Self {
        Self {
            file: file.to_string(),
            place: Place::Sheet {
                sheet: sheet.to_string(),
                row,
            },
        }
    }
    /// The whole of `file`.
    pub fn file(file: &str) -> Self {
        Self {
            file: file.to_string(),
            place: Place::File,
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.place {
            Place::File => write!(f, "{}", self.file),
            Place::Line(n) => write!(f, "{}: line {n}", self.file),
            Place::Json(p) => write!(f, "{}: {p}", self.file),
            Place::Sheet { sheet, row } => write!(f, "{}: sheet \"{sheet}\", row {row}", self.file),
        }
    }
}

/// Everything that can go wrong reading, mapping or writing device data.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The file could not be opened or read.
    #[error("cannot read {file}: {source}")]
    Open {
        /// The file.
        file: String,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// A file could not be written.
    #[error("cannot write {file}: {source}")]
    Write {
        /// The file.
        file: String,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// A value or row that breaks the format's rules or a plausibility limit.
    #[error("{at}, field \"{field}\": {message}")]
    Invalid {
        /// File and line or JSON path.
        at: Location,
        /// The column or JSON field.
        field: String,
        /// What was found and what was expected.
        message: String,
    },
    /// The file as a whole: unknown format, missing header, wrong layout.
    #[error("{file}: {message}")]
    Format {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// Glucose units missing or implausible for the declared unit.
    #[error("{file}: {message}")]
    Units {
        /// The file.
        file: String,
        /// What is wrong and which unit the data looks like.
        message: String,
    },
    /// Bad person settings (time zone, meal windows, first day).
    #[error("settings: {0}")]
    Settings(String),
}

impl IoError {
    /// An [`IoError::Invalid`] at `at` for `field`.
    pub fn invalid(at: Location, field: &str, message: impl Into<String>) -> Self {
        Self::Invalid {
            at,
            field: field.to_string(),
            message: message.into(),
        }
    }
    /// An [`IoError::Format`] for `file`.
    pub fn format(file: &str, message: impl Into<String>) -> Self {
        Self::Format {
            file: file.to_string(),
            message: message.into(),
        }
    }
}
