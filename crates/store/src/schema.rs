//! The store's schema: one list of versioned steps for every backend.
//!
//! [`STEPS`] names the steps, oldest first; a store at version `v` has the
//! first `v` of them. Each backend spells a step in its own DDL
//! ([`crate::backend::sqlite::schema::ddl`],
//! [`crate::backend::postgres::schema::ddl`]) and applies it in one
//! transaction together with the new version number; a step may also have
//! a Rust part ([`code`]) run in that transaction through the backend-
//! neutral [`Db`]. Never edit or reorder a step that shipped; append.

use crate::backend::sqlite::Sqlite;
use crate::backend::{Conn, Db};
use crate::error::StoreError;
use std::path::Path;

pub use crate::backend::sqlite::Sync;

/// One step of the schema.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// 1: persons, imports, the record log, suggestions, answers, snapshots.
    Base,
    /// 2: the service: bearer tokens (SHA-256 only) and the app's events
    /// with their sequence numbers.
    Service,
    /// 3: record identity that survives re-exports (issue 21): Clarity
    /// rows re-keyed from their Index to their content ([`crate::log::rekey`]).
    Rekey,
    /// 4: a revision per person, bumped on every write to what a live
    /// advisor is built from, whoever writes.
    PersonRev,
    /// 5 (issue 22): the clinician's changes of therapy; what an import's
    /// files said about automated delivery.
    TherapyChanges,
    /// 6 (issue 23): names compared ignoring case without a scan.
    NameIndex,
    /// 7 (issue 25): a person's link to their Nightscout.
    Nightscout,
    /// 8 (issue 24): the web pages' one-time sign-in links and sessions.
    WebSessions,
    /// 9: names compared as they look: each person's confusable skeletons
    /// ([`crate::person::name_looks`]), indexed, filled for the persons
    /// stored ([`crate::person::fill_name_looks`]; persons whose names
    /// already look alike are kept, only new ones are refused).
    NameLooks,
    /// 10: the web forms' one-time submission keys ([`crate::submission`]):
    /// a form sent twice (a double click, a retry after a timeout) is
    /// recognised and stores nothing twice.
    WebSubmissions,
    /// 11: what a Nightscout link's first sync read whole before it
    /// failed part-way ([`crate::link`]): kept, not imported, until the
    /// rest is read; what the link's last successful sync could not look
    /// for (its warnings, shown with the link).
    NightscoutStaged,
}

/// The steps, oldest first.
pub const STEPS: &[Step] = &[
    Step::Base,
    Step::Service,
    Step::Rekey,
    Step::PersonRev,
    Step::TherapyChanges,
    Step::NameIndex,
    Step::Nightscout,
    Step::WebSessions,
    Step::NameLooks,
    Step::WebSubmissions,
    Step::NightscoutStaged,
];

/// Rust code run inside a step's transaction.
pub type MigrationCode = fn(&dyn Db) -> Result<(), StoreError>;

/// The Rust part of a step, if it has one.
pub fn code(step: Step) -> Option<MigrationCode> {
    match step {
        Step::Rekey => Some(crate::log::rekey as MigrationCode),
        Step::NameLooks => Some(crate::person::fill_name_looks as MigrationCode),
        _ => None,
    }
}

/// The version a step brings a store to (its 1-based place in the list).
pub fn version_of(step: Step) -> i64 {
    STEPS
        .iter()
        .position(|s| *s == step)
        .map_or(0, |i| i as i64 + 1)
}

/// The newest schema version this build knows.
pub fn current_version() -> i64 {
    STEPS.len() as i64
}

/// Opens (creating if needed) a store file: WAL journal, foreign keys on,
/// migrations applied.
pub fn open(path: &Path) -> Result<Conn, StoreError> {
    open_with(path, Sync::Normal)
}

/// Like [`open`], with the given synchronous level.
pub fn open_with(path: &Path, sync: Sync) -> Result<Conn, StoreError> {
    open_opts(path, sync, DEFAULT_BUSY)
}

/// How long a connection waits for another writer before SQLite answers
/// "busy" (the CLI's default; the service sets its own).
pub const DEFAULT_BUSY: std::time::Duration = std::time::Duration::from_secs(10);

/// Like [`open_with`], waiting at most `busy` for another writer (see
/// [`sqlite::Sqlite::open`]). A `path` that is a PostgreSQL URL
/// ([`crate::backend::postgres::is_url`]) opens that database instead (its
/// commits are always durable: `sync` does not apply).
pub fn open_opts(path: &Path, sync: Sync, busy: std::time::Duration) -> Result<Conn, StoreError> {
    if let Some(url) = path
        .to_str()
        .filter(|p| crate::backend::postgres::is_url(p))
    {
        let pg = crate::backend::postgres::Pg::open(url, busy)?;
        return Ok(Conn::Postgres(Box::new(pg)));
    }
    Ok(Conn::Sqlite(Sqlite::open(path, sync, busy)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_step_has_its_sqlite_ddl_and_a_fresh_file_reaches_the_newest_version() {
        for s in STEPS {
            assert!(
                !crate::backend::sqlite::schema::ddl(*s).trim().is_empty(),
                "{s:?}"
            );
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.db");
        drop(open(&path).unwrap());
        let v: i64 = rusqlite::Connection::open(&path)
            .unwrap()
            .pragma_query_value(None, "user_version", |r| r.get(0))
            .unwrap();
        assert_eq!(v, current_version());
        assert_eq!(version_of(Step::Rekey), 3);
    }
}
