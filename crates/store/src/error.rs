//! The one error type of abba-store.

use thiserror::Error;

/// Everything that can go wrong in the person store.
#[derive(Debug, Error)]
pub enum StoreError {
    /// The database said no (its own message; the same variant for every
    /// backend).
    #[error("database: {0}")]
    Db(crate::backend::DbError),
    /// The database file was written by a newer abba.
    #[error(
        "the database has schema version {found}; this abba knows up to {known} (use a newer abba)"
    )]
    NewerSchema {
        /// Version in the file.
        found: i64,
        /// Newest version this build knows.
        known: i64,
    },
    /// No such person.
    #[error("no person named \"{0}\" in this database (create one with `abba person new`)")]
    NoPerson(String),
    /// The person has no data yet (nothing to report on).
    #[error("person \"{0}\" has no data yet: import a device export with `abba import`, link Nightscout or enter readings in the app")]
    NoData(String),
    /// The name is taken.
    #[error(
        "a person named \"{0}\" already exists in this database (names are compared ignoring case)"
    )]
    PersonExists(String),
    /// The name looks like another person's ([`crate::person::name_looks`]).
    #[error(
        "the name \"{name}\"{} looks like the name of the existing person \"{existing}\"{} (names are compared as they look: letters of another script or width that look the same, ignoring case): choose a name that tells them apart",
        spelled(.name),
        spelled(.existing)
    )]
    PersonLookAlike {
        /// The new name.
        name: String,
        /// The existing person's name.
        existing: String,
    },
    /// A setting or an argument is not acceptable; names the field.
    #[error("{field}: {problem}")]
    Invalid {
        /// The field or flag.
        field: String,
        /// What is wrong and what was expected.
        problem: String,
    },
    /// An export's pump profile differs from the therapy the store holds
    /// (an import that was told to stop then): nothing was imported, and
    /// the importer chooses ([`crate::ProfileResolution`]). The message
    /// names the CLI's flags; a page shows [`StoreError::ProfileDiffers`]'s
    /// `difference` with its own choice.
    #[error("{origin}: {difference} Import again with --adopt-profile to put the pump's profile in force (what the pump runs), or with --keep-therapy to keep the store's values (profiles in the data are then not read as therapy).")]
    ProfileDiffers {
        /// Where the profile was read (file and row or document).
        origin: String,
        /// Both values and that nothing was imported.
        difference: String,
    },
    /// Reading or mapping device data failed (names file, line or path, field).
    #[error(transparent)]
    Io(#[from] abba_io::IoError),
    /// The advisor refused its configuration or state.
    #[error("advisor: {0}")]
    Advisor(#[from] abba_advisor::AdvisorError),
    /// A stored value could not be read back.
    #[error("stored {what} is unreadable: {detail}")]
    Corrupt {
        /// What was being read.
        what: String,
        /// The parser's message.
        detail: String,
    },
    /// An answer that cannot be recorded (nothing open, unknown setting...).
    #[error("{0}")]
    Answer(String),
    /// An app sequence number already held with another payload.
    #[error("events[{index}].seq: sequence number {seq} is already held with another payload")]
    SeqConflict {
        /// Index of the event in its batch.
        index: usize,
        /// The number.
        seq: u64,
    },
    /// A person fed by imports got app events, or the other way round.
    #[error("{0}")]
    Feed(String),
    /// No person with this id.
    #[error("no person with id {0}")]
    NoPersonId(i64),
    /// No such suggestion (names the field).
    #[error("{0}: no such suggestion")]
    NoSuggestion(String),
    /// No such token.
    #[error("no token with id {0}")]
    NoToken(i64),
    /// The last admin token that is not revoked.
    #[error("token {0} is the last admin token: issue another admin token (`abba token --admin`) before revoking it")]
    LastAdmin(i64),
}

impl StoreError {
    /// An [`StoreError::Invalid`].
    pub fn invalid(field: impl Into<String>, problem: impl Into<String>) -> Self {
        StoreError::Invalid {
            field: field.into(),
            problem: problem.into(),
        }
    }

    /// The database error's kind, if this is one.
    pub fn db_kind(&self) -> Option<crate::backend::DbErrorKind> {
        match self {
            StoreError::Db(e) => Some(e.kind),
            _ => None,
        }
    }

    /// True when the database stayed busy (another connection held the
    /// write lock longer than the busy timeout).
    pub fn is_busy(&self) -> bool {
        self.db_kind() == Some(crate::backend::DbErrorKind::Busy)
    }

    /// True when the store cannot be written (read-only file or folder,
    /// read-only medium, a read-only server).
    pub fn is_read_only(&self) -> bool {
        self.db_kind() == Some(crate::backend::DbErrorKind::ReadOnly)
    }

    /// A [`StoreError::Corrupt`] from a serde error.
    pub fn corrupt(what: &str, e: impl std::fmt::Display) -> Self {
        StoreError::Corrupt {
            what: what.into(),
            detail: e.to_string(),
        }
    }
}

/// " (spelled a\u{301})": a name's characters beyond ASCII as code
/// points, so that two names that look the same read differently; nothing
/// for an ASCII name.
fn spelled(name: &str) -> String {
    if name.is_ascii() {
        return String::new();
    }
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii() {
                c.to_string()
            } else {
                c.escape_unicode().to_string()
            }
        })
        .collect();
    format!(" (spelled {s})")
}
