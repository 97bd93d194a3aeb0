//! Opening a store: WAL mode and versioned migrations.
//!
//! Migrations are our own small versioned list: migration `i` (1-based) is
//! applied in one transaction together with `PRAGMA user_version = i`, so a
//! file is always at exactly one version. (A dependency such as
//! rusqlite_migration would pin us to its rusqlite version for what is a
//! dozen lines here.)

use crate::error::StoreError;
use rusqlite::Connection;
use std::path::Path;

/// The migrations, oldest first. Never edit one that shipped; append.
const MIGRATIONS: &[&str] = &[
    // 1: persons, imports, the record log, suggestions, answers, snapshots.
    "CREATE TABLE person (
        id INTEGER PRIMARY KEY,
        name TEXT NOT NULL UNIQUE,
        tz TEXT NOT NULL,
        mode TEXT NOT NULL CHECK (mode IN ('cgm', 'smbg')),
        first_day TEXT,
        settings TEXT NOT NULL,
        created_at TEXT NOT NULL
    );
    CREATE TABLE import (
        id INTEGER PRIMARY KEY,
        person_id INTEGER NOT NULL REFERENCES person(id),
        imported_at TEXT NOT NULL,
        files TEXT NOT NULL,
        formats TEXT NOT NULL,
        records_read INTEGER NOT NULL,
        records_added INTEGER NOT NULL,
        records_known INTEGER NOT NULL
    );
    CREATE TABLE record (
        person_id INTEGER NOT NULL REFERENCES person(id),
        source TEXT NOT NULL,
        source_id TEXT NOT NULL,
        at_ms INTEGER NOT NULL,
        kind TEXT NOT NULL,
        origin TEXT NOT NULL,
        import_id INTEGER NOT NULL REFERENCES import(id),
        PRIMARY KEY (person_id, source, source_id)
    ) WITHOUT ROWID;
    CREATE INDEX record_by_time ON record (person_id, at_ms);
    CREATE INDEX record_by_import ON record (import_id);
    CREATE TABLE suggestion (
        person_id INTEGER NOT NULL REFERENCES person(id),
        at_min INTEGER NOT NULL,
        parameter TEXT NOT NULL,
        old REAL NOT NULL,
        new REAL NOT NULL,
        skipped INTEGER NOT NULL,
        decision TEXT NOT NULL,
        PRIMARY KEY (person_id, at_min, parameter)
    ) WITHOUT ROWID;
    CREATE TABLE answer (
        id INTEGER PRIMARY KEY,
        person_id INTEGER NOT NULL REFERENCES person(id),
        at_min INTEGER NOT NULL,
        parameter TEXT NOT NULL,
        answer TEXT NOT NULL CHECK (answer IN ('accepted', 'rejected', 'overridden')),
        suggested REAL NOT NULL,
        previous REAL NOT NULL,
        in_force REAL NOT NULL,
        answered_at TEXT NOT NULL,
        UNIQUE (person_id, at_min, parameter)
    );
    CREATE TABLE snapshot (
        person_id INTEGER PRIMARY KEY REFERENCES person(id),
        events INTEGER NOT NULL,
        events_hash TEXT NOT NULL,
        answers TEXT NOT NULL,
        unused INTEGER NOT NULL,
        state TEXT NOT NULL
    );",
    // 2: the service: bearer tokens (SHA-256 only) and the app's events
    // with their sequence numbers.
    "CREATE TABLE token (
        id INTEGER PRIMARY KEY,
        hash_prefix INTEGER NOT NULL,
        hash BLOB NOT NULL UNIQUE,
        role TEXT NOT NULL CHECK (role IN ('admin', 'person')),
        person_id INTEGER REFERENCES person(id),
        created_at TEXT NOT NULL,
        revoked_at TEXT,
        CHECK ((role = 'admin') = (person_id IS NULL))
    );
    CREATE INDEX token_by_prefix ON token (hash_prefix);
    CREATE TABLE app_event (
        person_id INTEGER NOT NULL REFERENCES person(id),
        seq INTEGER NOT NULL,
        at_ms INTEGER NOT NULL,
        at_min INTEGER NOT NULL,
        tag TEXT NOT NULL,
        kind TEXT NOT NULL,
        hash BLOB NOT NULL,
        received_at TEXT NOT NULL,
        PRIMARY KEY (person_id, seq)
    ) WITHOUT ROWID;
    CREATE INDEX app_event_by_time ON app_event (person_id, at_min, seq);",
    // 3: record identity that survives re-exports (issue 21).
    crate::log::REKEY_MIGRATION,
    // 4: a revision per person, bumped by triggers on everything a live
    // advisor is built from (app events, records, answers, the person's
    // settings), whoever writes: the service sees a write by the CLI or
    // another process for that person only (SQLite's data_version is per
    // connection and says nothing about whom a write concerned).
    "CREATE TABLE person_rev (
        person_id INTEGER PRIMARY KEY REFERENCES person(id),
        rev INTEGER NOT NULL
    );
    CREATE TRIGGER rev_app_event_ins AFTER INSERT ON app_event BEGIN
        INSERT INTO person_rev VALUES (NEW.person_id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;
    CREATE TRIGGER rev_app_event_del AFTER DELETE ON app_event BEGIN
        INSERT INTO person_rev VALUES (OLD.person_id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;
    CREATE TRIGGER rev_record_ins AFTER INSERT ON record BEGIN
        INSERT INTO person_rev VALUES (NEW.person_id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;
    CREATE TRIGGER rev_record_upd AFTER UPDATE ON record BEGIN
        INSERT INTO person_rev VALUES (NEW.person_id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;
    CREATE TRIGGER rev_record_del AFTER DELETE ON record BEGIN
        INSERT INTO person_rev VALUES (OLD.person_id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;
    CREATE TRIGGER rev_answer_ins AFTER INSERT ON answer BEGIN
        INSERT INTO person_rev VALUES (NEW.person_id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;
    CREATE TRIGGER rev_answer_del AFTER DELETE ON answer BEGIN
        INSERT INTO person_rev VALUES (OLD.person_id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;
    CREATE TRIGGER rev_answer_upd AFTER UPDATE ON answer BEGIN
        INSERT INTO person_rev VALUES (NEW.person_id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;
    CREATE TRIGGER rev_person_upd AFTER UPDATE ON person BEGIN
        INSERT INTO person_rev VALUES (NEW.id, 1)
        ON CONFLICT (person_id) DO UPDATE SET rev = rev + 1;
    END;",
    // 5 (issue 22): the clinician's changes of therapy (`abba therapy
    // set`), in force from their time; what an import's files said about
    // automated delivery (SMB marks, loop uploaders), one row per content.
    "CREATE TABLE therapy_change (
        id INTEGER PRIMARY KEY,
        person_id INTEGER NOT NULL REFERENCES person(id),
        at_ms INTEGER NOT NULL,
        change TEXT NOT NULL,
        recorded_at TEXT NOT NULL
    );
    CREATE INDEX therapy_change_by_time ON therapy_change (person_id, at_ms);
    CREATE TABLE file_evidence (
        person_id INTEGER NOT NULL REFERENCES person(id),
        file_hash TEXT NOT NULL,
        file TEXT NOT NULL,
        evidence TEXT NOT NULL,
        PRIMARY KEY (person_id, file_hash)
    ) WITHOUT ROWID;",
    // 6 (issue 23): names compared ignoring case without a scan.
    crate::person::NAME_INDEX_MIGRATION,
    // 7 (issue 25): a person's link to their Nightscout: the URL, the
    // credential (an API secret only as its SHA-1 hex, an access token as
    // given), write-back, the last sync; per collection the high-water
    // mark (advanced only in the import's transaction); what abba wrote
    // there (one Note per suggestion, the `abba` profile).
    crate::link::MIGRATION,
    // 8 (issue 24): the web pages' one-time sign-in links and sessions,
    // both kept only as SHA-256 of their secrets.
    crate::session::MIGRATION,
];

/// The version a migration brings a file to (its 1-based place in the
/// list), found by its SQL.
pub fn migration_number(sql: &str) -> Option<i64> {
    MIGRATIONS
        .iter()
        .position(|m| *m == sql)
        .map(|i| i as i64 + 1)
}

/// The newest schema version this build knows.
pub fn current_version() -> i64 {
    MIGRATIONS.len() as i64
}

/// Opens (creating if needed) a store file: WAL journal, foreign keys on,
/// migrations applied.
pub fn open(path: &Path) -> Result<Connection, StoreError> {
    open_with(path, Sync::Normal)
}

/// How hard a commit waits for the disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sync {
    /// `synchronous=NORMAL`: in WAL mode a crash of the process loses
    /// nothing committed, a power loss may lose the last commits (the CLI).
    Normal,
    /// `synchronous=FULL`: every commit is on disk before it returns (the
    /// service, which acknowledges events only after COMMIT).
    Full,
}

/// Like [`open`], with the given synchronous level.
pub fn open_with(path: &Path, sync: Sync) -> Result<Connection, StoreError> {
    open_opts(path, sync, DEFAULT_BUSY)
}

/// How long a connection waits for another writer before SQLite answers
/// "busy" (the CLI's default; the service sets its own).
pub const DEFAULT_BUSY: std::time::Duration = std::time::Duration::from_secs(10);

/// Like [`open_with`], waiting at most `busy` for another writer.
///
/// Every transaction of the connection begins IMMEDIATE: it takes the
/// write lock at BEGIN (waiting up to `busy`), so a transaction that
/// reads and then writes is never refused half-way ("database is
/// locked" when a deferred read transaction is upgraded while another
/// connection writes, which no busy timeout can wait out).
pub fn open_opts(
    path: &Path,
    sync: Sync,
    busy: std::time::Duration,
) -> Result<Connection, StoreError> {
    create_owner_only(path)?;
    let mut conn = Connection::open(path)?;
    conn.busy_timeout(busy)?;
    conn.set_transaction_behavior(rusqlite::TransactionBehavior::Immediate);
    conn.pragma_update(None, "journal_mode", "WAL")?;
    let level = match sync {
        Sync::Normal => "NORMAL",
        Sync::Full => "FULL",
    };
    conn.pragma_update(None, "synchronous", level)?;
    conn.pragma_update(None, "foreign_keys", "ON")?;
    // 64 MiB of page cache: a person's whole log is read at every advice.
    conn.pragma_update(None, "cache_size", -65536)?;
    migrate(&mut conn)?;
    Ok(conn)
}

/// Creates a missing store file readable and writable by its owner only
/// (0600 on Unix; SQLite gives its `-wal` and `-shm` files the same
/// mode): it may hold a Nightscout access token. An existing file is left
/// as it is.
fn create_owner_only(path: &Path) -> Result<(), StoreError> {
    let mut o = std::fs::OpenOptions::new();
    o.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut o, 0o600);
    match o.open(path) {
        Ok(_) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        // Let SQLite say what is wrong (a missing folder, no permission).
        Err(_) => Ok(()),
    }
}

fn migrate(conn: &mut Connection) -> Result<(), StoreError> {
    let found: i64 = conn.pragma_query_value(None, "user_version", |r| r.get(0))?;
    if found > current_version() {
        return Err(StoreError::NewerSchema {
            found,
            known: current_version(),
        });
    }
    for (i, sql) in MIGRATIONS.iter().enumerate().skip(found as usize) {
        let tx = conn.transaction()?;
        tx.execute_batch(sql)?;
        if let Some(code) = crate::log::migration_code(sql) {
            code(&tx)?;
        }
        tx.pragma_update(None, "user_version", (i + 1) as i64)?;
        tx.commit()?;
    }
    Ok(())
}
