//! `abba store check`: what in a store cannot be right, and the one
//! repair it offers.
//!
//! An event dated more than [`abba_core::limits::FUTURE_SKEW_MINUTES`]
//! after the clock of the check cannot have happened yet: a device clock
//! gone wrong, stored by an older abba that did not refuse it. Left in the
//! log it stays the person's latest event for good (every real decision
//! after it would come "before" it). The check lists every such event
//! (app events and imported records) with the database's own integrity
//! check (SQLite's `PRAGMA integrity_check`);
//! [`Store::remove_future`] deletes exactly those events, in one
//! transaction, with the answers to suggestions after the check's clock
//! and the person's stored suggestions and snapshot (both are caches,
//! rebuilt from the log on next use).

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use crate::store::Store;

/// One event dated in the future.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FutureEvent {
    /// The person's name.
    pub person: String,
    /// The person's row id.
    pub person_id: i64,
    /// `app` (posted by the person's app) or `record` (imported).
    pub origin: &'static str,
    /// The app's sequence number, or the record's source and id.
    pub id: String,
    /// The event's kind.
    pub kind: String,
    /// Its instant (UTC).
    pub at: jiff::Timestamp,
}

/// What the check found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CheckReport {
    /// The clock the check compared with.
    pub now: jiff::Timestamp,
    /// SQLite's `PRAGMA integrity_check` lines ("ok" when sound).
    pub integrity: Vec<String>,
    /// Events dated more than the skew after `now`, by person and time.
    pub future: Vec<FutureEvent>,
}

impl CheckReport {
    /// True when nothing is wrong.
    pub fn ok(&self) -> bool {
        self.integrity == ["ok"] && self.future.is_empty()
    }
}

fn limit_ms(now: jiff::Timestamp) -> i64 {
    now.as_millisecond() + abba_core::limits::FUTURE_SKEW_MINUTES * 60_000
}

fn instant(ms: i64) -> Result<jiff::Timestamp, StoreError> {
    jiff::Timestamp::from_millisecond(ms).map_err(|e| StoreError::corrupt("event instant", e))
}

fn future_events(conn: &dyn Db, now: jiff::Timestamp) -> Result<Vec<FutureEvent>, StoreError> {
    let limit = limit_ms(now);
    let mut out = Vec::new();
    for r in conn.rows(Q::FutureAppEvents, args![limit])? {
        let (person, person_id, seq, kind, at) =
            (r.text(0)?, r.int(1)?, r.int(2)?, r.text(3)?, r.int(4)?);
        out.push(FutureEvent {
            person,
            person_id,
            origin: "app",
            id: format!("seq {seq}"),
            kind,
            at: instant(at)?,
        });
    }
    for r in conn.rows(Q::FutureRecords, args![limit])? {
        let (person, person_id, source, source_id, kind, at) = (
            r.text(0)?,
            r.int(1)?,
            r.text(2)?,
            r.text(3)?,
            r.text(4)?,
            r.int(5)?,
        );
        out.push(FutureEvent {
            person,
            person_id,
            origin: "record",
            id: format!("{source} {source_id}"),
            kind,
            at: instant(at)?,
        });
    }
    Ok(out)
}

impl Store {
    /// Checks the store against the clock `now` (reads only).
    pub fn check(&self, now: jiff::Timestamp) -> Result<CheckReport, StoreError> {
        let integrity = self.conn.integrity()?;
        Ok(CheckReport {
            now,
            integrity,
            future: future_events(&self.conn, now)?,
        })
    }

    /// Deletes every event dated more than the skew after `now` (one
    /// transaction): those app events and records, the answers to
    /// suggestions decided after `now`, and the stored suggestions and
    /// snapshot of each person concerned (rebuilt from the log on next
    /// use). Returns what was deleted.
    pub fn remove_future(&mut self, now: jiff::Timestamp) -> Result<Vec<FutureEvent>, StoreError> {
        let tx = self.conn.transaction()?;
        let found = future_events(&tx, now)?;
        let limit = limit_ms(now);
        let mut persons: Vec<i64> = found.iter().map(|f| f.person_id).collect();
        persons.sort_unstable();
        persons.dedup();
        for &id in &persons {
            let p = crate::person::load_by_id(&tx, id)?;
            tx.execute(Q::AppEventDeleteAfter, args![id, limit])?;
            tx.execute(Q::RecordDeleteAfter, args![id, limit])?;
            if let Some(clock) = crate::advise::clock(&p) {
                let minute = clock.timestamp(instant(limit)?).0;
                tx.execute(Q::AnswerDeleteAfter, args![id, minute])?;
            }
            tx.execute(Q::SuggestionDeleteAll, args![id])?;
            tx.execute(Q::SnapshotDelete, args![id])?;
        }
        tx.commit()?;
        self.cache.clear();
        Ok(found)
    }
}
