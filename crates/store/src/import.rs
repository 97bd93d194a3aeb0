//! Importing device exports: one transaction per import; a record already
//! in the log (same source, same id) is counted, never added twice.

use crate::error::StoreError;
use crate::log::key;
use crate::person::{self, Person};
use abba_io::read::Batch;
use rusqlite::{params, Connection};
use serde::Serialize;

/// What one import did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportSummary {
    /// Row id of the import (`None`: nothing new, nothing recorded).
    pub import_id: Option<i64>,
    /// The files.
    pub files: Vec<String>,
    /// Records read from the files (after removing exact duplicates between them).
    pub read: usize,
    /// Records new to the log.
    pub added: usize,
    /// Records the log already held.
    pub known: usize,
    /// Exact duplicates between the files themselves, by kind.
    pub duplicates_in_files: usize,
    /// Day 1 of the person's clock (set by the first import).
    pub first_day: Option<String>,
}

/// Adds `batch` to `person`'s log in one transaction. Everything is read
/// and checked before the transaction starts; the transaction either
/// commits every new record and the import row, or nothing.
pub fn import(
    conn: &mut Connection,
    person: &Person,
    batch: &Batch,
) -> Result<ImportSummary, StoreError> {
    let mut rows = Vec::with_capacity(batch.records.len());
    for r in &batch.records {
        let (source, id) = key(r)?;
        let kind = serde_json::to_string(&r.kind).map_err(|e| StoreError::corrupt("record", e))?;
        rows.push((source, id, r.at.as_millisecond(), kind, batch.origin(r)));
    }
    // Day 1: the local date of the first glucose reading (a profile or a
    // pump record months before the first reading does not start it); an
    // import without glucose leaves day 1 open.
    let first_useful = abba_io::events::first_glucose(&batch.records);
    let first_day = match (person.first_day, first_useful) {
        (Some(d), _) => Some(d),
        (None, Some(r)) => Some(person.tz.to_datetime(r.at).date()),
        (None, None) => None,
    };
    let tx = conn.transaction()?;
    if crate::app::count(&tx, person.id)? > 0 {
        return Err(StoreError::Feed(format!(
            "{} is fed by the app through the service; imports and app events do not mix",
            person.name
        )));
    }
    let now = jiff::Timestamp::now().to_string();
    let files = serde_json::to_string(&batch.files).map_err(|e| StoreError::corrupt("files", e))?;
    let formats =
        serde_json::to_string(&batch.formats).map_err(|e| StoreError::corrupt("formats", e))?;
    tx.execute(
        "INSERT INTO import (person_id, imported_at, files, formats, records_read, records_added, records_known) VALUES (?1, ?2, ?3, ?4, ?5, 0, 0)",
        params![person.id, now, files, formats, rows.len() as i64],
    )?;
    let import_id = tx.last_insert_rowid();
    let mut added = 0usize;
    {
        let mut st = tx.prepare(
            "INSERT OR IGNORE INTO record (person_id, source, source_id, at_ms, kind, origin, import_id) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
        )?;
        for (source, id, at_ms, kind, origin) in &rows {
            added += st.execute(params![
                person.id, source, id, at_ms, kind, origin, import_id
            ])?;
        }
    }
    let known = rows.len() - added;
    let import_id = if added == 0 {
        // Nothing new: leave no trace beyond saying so.
        tx.execute("DELETE FROM import WHERE id = ?1", params![import_id])?;
        None
    } else {
        tx.execute(
            "UPDATE import SET records_added = ?1, records_known = ?2 WHERE id = ?3",
            params![added as i64, known as i64, import_id],
        )?;
        if let (None, Some(d)) = (person.first_day, first_day) {
            person::set_first_day(&tx, person.id, d)?;
        }
        Some(import_id)
    };
    tx.commit()?;
    Ok(ImportSummary {
        import_id,
        files: batch.files.clone(),
        read: rows.len(),
        added,
        known,
        duplicates_in_files: batch.duplicates.values().sum(),
        first_day: first_day.map(|d| d.to_string()),
    })
}

/// One past import.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportRow {
    /// Row id.
    pub id: i64,
    /// When (UTC).
    pub imported_at: String,
    /// Files (JSON list as stored).
    pub files: String,
    /// Records read.
    pub read: i64,
    /// Records added.
    pub added: i64,
}

/// The person's imports, oldest first.
pub fn imports(conn: &Connection, person: i64) -> Result<Vec<ImportRow>, StoreError> {
    let mut st = conn.prepare(
        "SELECT id, imported_at, files, records_read, records_added FROM import WHERE person_id = ?1 ORDER BY id",
    )?;
    let v = st
        .query_map(params![person], |r| {
            Ok(ImportRow {
                id: r.get(0)?,
                imported_at: r.get(1)?,
                files: r.get(2)?,
                read: r.get(3)?,
                added: r.get(4)?,
            })
        })?
        .collect::<Result<Vec<_>, _>>()?;
    Ok(v)
}
