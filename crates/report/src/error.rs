//! Errors of abba-report.

use std::path::PathBuf;

use abba_core::CoreError;
use thiserror::Error;

/// What can go wrong while building or writing the report.
#[derive(Debug, Error)]
pub enum ReportError {
    /// A statistic or metric could not be computed (`what` says for which arm, week and metric).
    #[error("{what}: {source}")]
    Stats {
        /// Where: arm, week, metric.
        what: String,
        /// The underlying error.
        #[source]
        source: CoreError,
    },
    /// The results handed to the report are inconsistent (e.g. patients of
    /// one arm with different evaluation weeks, two arms with the same key).
    #[error("inconsistent trial results: {0}")]
    InconsistentResults(String),
    /// The compiled-in table of the paper could not be read.
    #[error("paper table {file}, line {line}: {reason}")]
    PaperTable {
        /// The table's file name.
        file: &'static str,
        /// Line number, from 1.
        line: usize,
        /// What was wrong, and what was expected.
        reason: String,
    },
    /// The report folder cannot be used (checked before a run: see
    /// [`crate::out_dir`]).
    #[error("report folder {}: {reason}", path.display())]
    OutDir {
        /// The folder given.
        path: PathBuf,
        /// What is wrong with it, and what to do.
        reason: String,
    },
    /// The report folder cannot be created, listed or written into
    /// (checked before a run).
    #[error("report folder {}: cannot {action} it: {source}", path.display())]
    OutDirIo {
        /// The folder given.
        path: PathBuf,
        /// What failed (`create`, `list the contents of`, `write into`).
        action: &'static str,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A file or directory could not be written or removed.
    #[error("cannot {action} {}: {source}", path.display())]
    Io {
        /// What was being done (`write`, `create`, `remove`).
        action: &'static str,
        /// The path.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A JSON document could not be serialized.
    #[error("cannot serialize {what} as JSON: {source}")]
    Json {
        /// Which document.
        what: &'static str,
        /// The underlying error.
        #[source]
        source: serde_json::Error,
    },
    /// A CSV table could not be written.
    #[error("cannot write CSV {what}: {reason}")]
    Csv {
        /// Which table.
        what: &'static str,
        /// The underlying error, as text.
        reason: String,
    },
    /// A figure could not be drawn.
    #[error("cannot draw figure {figure}: {reason}")]
    Plot {
        /// The figure's file name.
        figure: &'static str,
        /// The plotting backend's error, as text.
        reason: String,
    },
    /// An HTML page could not be rendered from its template.
    #[error("cannot render the HTML {page}: {reason}")]
    Template {
        /// Which page (`trial report`, `person report`).
        page: &'static str,
        /// The template engine's error, as text.
        reason: String,
    },
    /// The input of the person report is not usable.
    #[error("person report input: {0}")]
    PersonInput(String),
}

impl ReportError {
    /// An I/O error on `path` while doing `action`.
    pub fn io(action: &'static str, path: &std::path::Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| ReportError::Io {
            action,
            path,
            source,
        }
    }
}
