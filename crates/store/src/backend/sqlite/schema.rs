//! SQLite's schema: the DDL of each step of [`crate::schema::STEPS`], and
//! the migration that brings a file to the newest version.
//!
//! A file's version is `PRAGMA user_version`; step `i` (1-based) is applied
//! in one transaction together with `PRAGMA user_version = i`, so a file is
//! always at exactly one version. (A dependency such as
//! rusqlite_migration would pin us to its rusqlite version for what is a
//! dozen lines here.)

use super::{err, SqliteDb};
use crate::error::StoreError;
use crate::schema::{Step, STEPS};
use rusqlite::Connection;

/// The SQLite DDL of a step. Never edit one that shipped; append a step.
pub fn ddl(step: Step) -> &'static str {
    match step {
        Step::Base => BASE,
        Step::Service => SERVICE,
        // Its work is Rust ([`crate::log::rekey`]); nothing to create.
        Step::Rekey => "SELECT 1;",
        Step::PersonRev => PERSON_REV,
        Step::TherapyChanges => THERAPY,
        Step::NameIndex => NAME_INDEX,
        Step::Nightscout => NIGHTSCOUT,
        Step::WebSessions => WEB_SESSIONS,
        Step::NameLooks => NAME_LOOKS,
        Step::WebSubmissions => WEB_SUBMISSIONS,
        Step::NightscoutStaged => NIGHTSCOUT_STAGED,
    }
}

/// Persons, imports, the record log, suggestions, answers, snapshots.
const BASE: &str = "CREATE TABLE person (
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
    );";

/// The service: bearer tokens (SHA-256 only) and the app's events with
/// their sequence numbers.
const SERVICE: &str = "CREATE TABLE token (
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
    CREATE INDEX app_event_by_time ON app_event (person_id, at_min, seq);";

/// A revision per person, bumped by triggers on everything a live
/// advisor is built from (app events, records, answers, the person's
/// settings), whoever writes: the service sees a write by the CLI or
/// another process for that person only (SQLite's data_version is per
/// connection and says nothing about whom a write concerned).
const PERSON_REV: &str = "CREATE TABLE person_rev (
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
    END;";

/// The clinician's changes of therapy (`abba therapy set`), in force from
/// their time; what an import's files said about automated delivery (SMB
/// marks, loop uploaders), one row per content.
const THERAPY: &str = "CREATE TABLE therapy_change (
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
    ) WITHOUT ROWID;";

/// Names compared ignoring case without a scan: SQLite's `lower()` folds
/// ASCII only, so names of ASCII characters are found by their folded
/// form, and the others (which may fold to ASCII: the Kelvin sign is a K)
/// are the rows of a partial index.
const NAME_INDEX: &str = "CREATE INDEX IF NOT EXISTS person_by_folded_name ON person (lower(name));
    CREATE INDEX IF NOT EXISTS person_not_ascii ON person (name) WHERE name GLOB '*[^ -~]*';";

/// A person's link to their Nightscout: the URL, the credential (an API
/// secret only as its SHA-1 hex, an access token as given), write-back,
/// the last sync; per collection the high-water mark (advanced only in the
/// import's transaction); what abba wrote there (one Note per suggestion,
/// the `abba` profile).
const NIGHTSCOUT: &str = "CREATE TABLE nightscout_link (
        person_id INTEGER PRIMARY KEY REFERENCES person(id),
        url TEXT NOT NULL,
        credential_kind TEXT NOT NULL CHECK (credential_kind IN ('api_secret_sha1', 'token')),
        credential TEXT NOT NULL,
        write_back INTEGER NOT NULL,
        created_at TEXT NOT NULL,
        last_sync_at TEXT,
        last_success_at TEXT,
        last_error TEXT,
        failures INTEGER NOT NULL DEFAULT 0
    );
    CREATE TABLE nightscout_mark (
        person_id INTEGER NOT NULL REFERENCES person(id),
        collection TEXT NOT NULL,
        mark_ms INTEGER NOT NULL,
        PRIMARY KEY (person_id, collection)
    ) WITHOUT ROWID;
    CREATE TABLE nightscout_written (
        person_id INTEGER NOT NULL REFERENCES person(id),
        what TEXT NOT NULL CHECK (what IN ('note', 'profile')),
        key TEXT NOT NULL,
        remote_id TEXT NOT NULL,
        content TEXT NOT NULL,
        written_at TEXT NOT NULL,
        PRIMARY KEY (person_id, what, key)
    ) WITHOUT ROWID;";

/// The web pages' one-time sign-in links and sessions, both kept only as
/// SHA-256 of their secrets.
const WEB_SESSIONS: &str = "CREATE TABLE signin_link (
        id INTEGER PRIMARY KEY,
        hash BLOB NOT NULL UNIQUE,
        role TEXT NOT NULL CHECK (role IN ('admin', 'person')),
        person_id INTEGER REFERENCES person(id),
        created_ms INTEGER NOT NULL,
        expires_ms INTEGER NOT NULL,
        used_ms INTEGER,
        CHECK ((role = 'admin') = (person_id IS NULL))
    );
    CREATE TABLE web_session (
        id INTEGER PRIMARY KEY,
        hash BLOB NOT NULL UNIQUE,
        role TEXT NOT NULL CHECK (role IN ('admin', 'person')),
        person_id INTEGER REFERENCES person(id),
        csrf TEXT NOT NULL,
        created_ms INTEGER NOT NULL,
        seen_ms INTEGER NOT NULL,
        expires_ms INTEGER NOT NULL,
        revoked_ms INTEGER,
        CHECK ((role = 'admin') = (person_id IS NULL))
    );
    CREATE INDEX web_session_by_person ON web_session (person_id);";

/// What each person's name looks like: its two confusable skeletons
/// ([`crate::person::name_looks`]), filled in Rust for the persons stored
/// ([`crate::person::fill_name_looks`]). The indexes are not unique:
/// persons stored before whose names look alike stay; a new name is
/// refused in the creation's write transaction.
const NAME_LOOKS: &str = "ALTER TABLE person ADD COLUMN skeleton_folded TEXT;
    ALTER TABLE person ADD COLUMN skeleton_cased TEXT;
    CREATE INDEX person_by_skeleton_folded ON person (skeleton_folded);
    CREATE INDEX person_by_skeleton_cased ON person (skeleton_cased);";

/// The web forms' one-time submissions ([`crate::submission`]): the
/// SHA-256 of a form's key, action and fields, what it did (its outcome),
/// when; kept a week.
const WEB_SUBMISSIONS: &str = "CREATE TABLE web_submission (
        person_id INTEGER NOT NULL REFERENCES person(id),
        key BLOB NOT NULL,
        outcome TEXT NOT NULL,
        at_ms INTEGER NOT NULL,
        PRIMARY KEY (person_id, key)
    ) WITHOUT ROWID;";

/// What a link's first sync read whole before it failed part-way: per
/// collection, the documents (a JSON array), kept until the rest is read
/// and all are imported at once. The last successful sync's warnings (a
/// JSON array of texts; NULL: none).
const NIGHTSCOUT_STAGED: &str = "CREATE TABLE nightscout_staged (
        person_id INTEGER NOT NULL REFERENCES person(id),
        collection TEXT NOT NULL,
        docs TEXT NOT NULL,
        PRIMARY KEY (person_id, collection)
    ) WITHOUT ROWID;
    ALTER TABLE nightscout_link ADD COLUMN last_warnings TEXT;";

/// Applies every step the file does not have yet, each in its own
/// transaction with its Rust part ([`crate::schema::code`]); refuses a
/// file written by a newer abba.
pub fn migrate(conn: &mut Connection) -> Result<(), StoreError> {
    let found: i64 = conn
        .pragma_query_value(None, "user_version", |r| r.get(0))
        .map_err(err)?;
    if found > crate::schema::current_version() {
        return Err(StoreError::NewerSchema {
            found,
            known: crate::schema::current_version(),
        });
    }
    for (i, step) in STEPS.iter().enumerate().skip(found as usize) {
        let tx = conn.transaction().map_err(err)?;
        tx.execute_batch(ddl(*step)).map_err(err)?;
        if let Some(code) = crate::schema::code(*step) {
            code(&SqliteDb(&tx))?;
        }
        tx.pragma_update(None, "user_version", (i + 1) as i64)
            .map_err(err)?;
        tx.commit().map_err(err)?;
    }
    Ok(())
}
