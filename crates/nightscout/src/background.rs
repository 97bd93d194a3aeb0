//! Keeping every linked person current (`abba serve --sync-every`): the
//! links that are due are synced, at most `concurrency` at once, each on
//! its own store connection; a slot freed is taken by the next person due
//! at once, so a slow or stalled site holds its own slot only. A link that failed waits longer
//! before its next try: the interval doubled per failure in a row, at most
//! [`MAX_BACKOFF`]. Outcomes are recorded on the link (last sync, error,
//! failures), which the API and `abba link --list` show, and logged
//! through `tracing`. A failure that could not be recorded on the link (the
//! store could not be opened or written) is kept in memory and backs off
//! the same way, until an attempt's outcome is recorded.
//!
//! Service replicas on one PostgreSQL database each run the rounds; a
//! person's sync is claimed first ([`Store::claim`], an advisory lock held
//! by the sync's connection), so one replica at a time syncs a person, and
//! the link is read again under the claim (a sync another replica just
//! finished leaves it not due).

use crate::sync::{sync_and_record, SyncOptions};
use abba_store::link::Link;
use abba_store::Store;
use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// The longest wait after failures.
pub const MAX_BACKOFF: Duration = Duration::from_secs(6 * 3600);

/// How to keep the links current.
#[derive(Debug, Clone)]
pub struct Background {
    /// The interval between syncs of one person.
    pub every: Duration,
    /// Syncs at once.
    pub concurrency: usize,
    /// How each sync runs.
    pub sync: SyncOptions,
}

/// The wait after the last sync of `link` before the next one.
pub fn wait_for(link: &Link, every: Duration) -> Duration {
    let doubled = every.saturating_mul(1u32 << link.failures.min(16));
    doubled.min(MAX_BACKOFF.max(every))
}

/// Whether `link` is due at `now`.
pub fn due(link: &Link, every: Duration, now: jiff::Timestamp) -> bool {
    let Some(last) = link
        .last_sync_at
        .as_deref()
        .and_then(|t| t.parse::<jiff::Timestamp>().ok())
    else {
        return true;
    };
    let wait =
        jiff::SignedDuration::try_from(wait_for(link, every)).unwrap_or(jiff::SignedDuration::MAX);
    now.duration_since(last) >= wait
}

/// The failures of persons a round could not record on their link (the
/// store could not be opened or written): kept here, so that they back
/// off all the same, and recorded when the store can be written again.
#[derive(Debug, Default)]
pub struct Unrecorded {
    by_person: Mutex<HashMap<String, Attempt>>,
}

#[derive(Debug, Clone)]
struct Attempt {
    at: jiff::Timestamp,
    error: String,
    failures: u32,
}

impl Unrecorded {
    fn get(&self, person: &str) -> Option<Attempt> {
        self.by_person.lock().ok()?.get(person).cloned()
    }
    fn set(&self, person: &str, at: jiff::Timestamp, error: String) {
        if let Ok(mut m) = self.by_person.lock() {
            let failures = m.get(person).map_or(0, |a| a.failures) + 1;
            m.insert(
                person.to_string(),
                Attempt {
                    at,
                    error,
                    failures,
                },
            );
        }
    }
    fn clear(&self, person: &str) {
        if let Ok(mut m) = self.by_person.lock() {
            m.remove(person);
        }
    }
}

/// `link` with the attempts kept in memory that are newer than its own.
fn with_unrecorded(mut link: Link, mem: &Unrecorded) -> Link {
    if let Some(a) = mem.get(&link.person) {
        let newer = link
            .last_sync_at
            .as_deref()
            .and_then(|t| t.parse::<jiff::Timestamp>().ok())
            .is_none_or(|t| a.at > t);
        if newer {
            link.last_sync_at = Some(a.at.to_string());
            link.last_error = Some(a.error);
            link.failures = link.failures.saturating_add(a.failures);
        }
    }
    link
}

/// Records a failure that happened before the sync could record it
/// itself (the person's store connection could not be opened): on the
/// link when the store can be written, else in `mem`.
fn record_failure(db: &Path, person: &str, error: String, mem: &Unrecorded) {
    let at = jiff::Timestamp::now();
    tracing::warn!(person, error = %error, "background Nightscout sync failed");
    let recorded = Store::open(db).and_then(|mut s| s.record_sync(person, at, Some(&error)));
    match recorded {
        Ok(()) => mem.clear(person),
        Err(e) => {
            tracing::warn!(person, error = %e, "the failure could not be recorded on the link; kept in memory");
            mem.set(person, at, error);
        }
    }
}

/// One round: syncs the links of `db` that are due; returns how many were
/// synced (successfully or not). A person whose sync could not even
/// start (the store could not be opened for it) has the failure recorded
/// on the link, or kept in `mem` when the store cannot be written, and
/// backs off like any failed sync.
pub fn round(
    db: &Path,
    bg: &Background,
    mem: &Unrecorded,
) -> Result<usize, abba_store::StoreError> {
    round_with(db, bg, mem, &|_| {})
}

/// [`round`], telling `after_import` the name of each person whose sync
/// changed their log (records added, updated or deleted): the service
/// refits their twin then.
pub fn round_with(
    db: &Path,
    bg: &Background,
    mem: &Unrecorded,
    after_import: &(dyn Fn(&str) + Sync),
) -> Result<usize, abba_store::StoreError> {
    let due_now = due_persons(db, bg, mem, &HashSet::new())?;
    let n = due_now.len();
    for chunk in due_now.chunks(bg.concurrency.max(1)) {
        std::thread::scope(|s| {
            for person in chunk {
                s.spawn(move || sync_one(db, bg, mem, person, after_import));
            }
        });
    }
    Ok(n)
}

/// The persons whose links are due now, but those in `busy`.
fn due_persons(
    db: &Path,
    bg: &Background,
    mem: &Unrecorded,
    busy: &HashSet<String>,
) -> Result<Vec<String>, abba_store::StoreError> {
    let now = jiff::Timestamp::now();
    Ok(Store::open(db)?
        .links()?
        .into_iter()
        .map(|l| with_unrecorded(l, mem))
        .filter(|l| !busy.contains(&l.person) && due(l, bg.every, now))
        .map(|l| l.person)
        .collect())
}

/// One person's sync on its own store connection, its outcome recorded
/// on the link (or kept in `mem`).
fn sync_one(
    db: &Path,
    bg: &Background,
    mem: &Unrecorded,
    person: &str,
    after_import: &(dyn Fn(&str) + Sync),
) {
    let mut store = match Store::open(db) {
        Ok(s) => s,
        Err(e) => {
            record_failure(
                db,
                person,
                format!("the store could not be opened for the sync: {e}"),
                mem,
            );
            return;
        }
    };
    // One replica at a time: the claim lasts as long as
    // this connection; under it the link must still be due.
    match store.claim(&format!("nightscout sync {person}")) {
        Ok(true) => {}
        Ok(false) => return,
        Err(e) => {
            record_failure(
                db,
                person,
                format!("the sync could not be claimed: {e}"),
                mem,
            );
            return;
        }
    }
    match store.link(person) {
        Ok(Some(l)) => {
            if !due(&with_unrecorded(l, mem), bg.every, jiff::Timestamp::now()) {
                return;
            }
        }
        Ok(None) => return,
        Err(e) => {
            record_failure(db, person, format!("the link could not be read: {e}"), mem);
            return;
        }
    }
    // The outcome is recorded on the link; when it cannot
    // be, it is kept in memory.
    let a = sync_and_record(&mut store, person, &bg.sync);
    if let Ok(r) = &a.result {
        let imported = r.import.import.as_ref();
        if r.import.deleted > 0 || imported.is_some_and(|i| i.added > 0 || i.updated > 0) {
            after_import(person);
        }
        for w in &r.warnings {
            tracing::warn!(person, warning = %w, "a background Nightscout sync could not check everything");
        }
        if !r.gone.is_empty() {
            tracing::warn!(person, documents = r.gone.len(), ids = ?r.gone, "documents no longer on the Nightscout site (deleted through API v1): their records are kept");
        }
    }
    match (a.result, a.recorded) {
        (Ok(_), Ok(())) => mem.clear(person),
        (Err(e), Ok(())) => {
            mem.clear(person);
            tracing::warn!(person, error = %e, "background Nightscout sync failed");
        }
        (Ok(r), Err(e)) => {
            // The import is in; only its record is not: once
            // more on a fresh connection, else the next round
            // syncs again (and finds nothing new).
            mem.clear(person);
            let again = Store::open(db)
                .and_then(|mut s| s.record_success(person, jiff::Timestamp::now(), &r.warnings));
            if let Err(e2) = again {
                tracing::warn!(person, error = %e, again = %e2, "a background Nightscout sync succeeded but could not be recorded on the link");
            }
        }
        (Err(e), Err(_)) => record_failure(db, person, e.to_string(), mem),
    }
}

/// Runs rounds until `stop` is set (checked every 200 ms). A round that
/// cannot read the links (the store cannot be opened) is logged and
/// tried again at the next round.
pub fn run(db: &Path, bg: &Background, stop: &AtomicBool) {
    run_with(db, bg, stop, &|_| {});
}

/// [`run`], with [`round_with`]'s `after_import`. Syncs run in at most
/// `concurrency` slots, each taken by the next due person as soon as it
/// is free: a site that is slow or stalled (each call has its timeouts)
/// holds its own slot only, and the others' syncs go on at their times.
pub fn run_with(
    db: &Path,
    bg: &Background,
    stop: &AtomicBool,
    after_import: &(dyn Fn(&str) + Sync),
) {
    let tick = Duration::from_millis(200);
    let round_every = bg.every.min(Duration::from_secs(30));
    let slots = bg.concurrency.max(1);
    let mem = Unrecorded::default();
    let busy: Mutex<HashSet<String>> = Mutex::new(HashSet::new());
    // Persons left waiting for a slot at the last look: looked at again as
    // soon as one is free.
    let waiting = AtomicBool::new(false);
    let mem = &mem;
    let busy = &busy;
    let waiting = &waiting;
    std::thread::scope(|s| {
        let mut since = round_every;
        while !stop.load(Ordering::Relaxed) {
            let in_flight = busy.lock().map_or(slots, |b| b.len());
            let free = slots.saturating_sub(in_flight);
            if free > 0 && (since >= round_every || waiting.load(Ordering::Relaxed)) {
                let taken = busy.lock().map(|b| b.clone()).unwrap_or_default();
                match due_persons(db, bg, mem, &taken) {
                    Ok(due_now) => {
                        waiting.store(due_now.len() > free, Ordering::Relaxed);
                        for person in due_now.into_iter().take(free) {
                            if let Ok(mut b) = busy.lock() {
                                b.insert(person.clone());
                            }
                            s.spawn(move || {
                                sync_one(db, bg, mem, &person, after_import);
                                if let Ok(mut b) = busy.lock() {
                                    b.remove(&person);
                                }
                            });
                        }
                    }
                    Err(e) => {
                        tracing::warn!(error = %e, "a background Nightscout round could not read the links")
                    }
                }
                if since >= round_every {
                    since = Duration::ZERO;
                }
            }
            std::thread::sleep(tick);
            since += tick;
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use abba_store::link::Credential;

    fn link(last: Option<&str>, failures: u32) -> Link {
        Link {
            person: "ana".into(),
            url: "https://x.example".into(),
            credential: Credential::Token("t".into()),
            write_back: false,
            created_at: "2026-01-01T00:00:00Z".into(),
            last_sync_at: last.map(String::from),
            last_success_at: None,
            last_error: None,
            failures,
            warnings: Vec::new(),
        }
    }

    #[test]
    fn failures_back_off_up_to_a_limit() {
        let every = Duration::from_secs(300);
        assert_eq!(wait_for(&link(None, 0), every), every);
        assert_eq!(wait_for(&link(None, 3), every), every * 8);
        assert_eq!(wait_for(&link(None, 40), every), MAX_BACKOFF);
        let now: jiff::Timestamp = "2026-01-01T01:00:00Z".parse().unwrap();
        assert!(due(&link(None, 0), every, now));
        assert!(due(&link(Some("2026-01-01T00:54:00Z"), 0), every, now));
        assert!(!due(&link(Some("2026-01-01T00:54:00Z"), 1), every, now));
        assert!(due(&link(Some("2026-01-01T00:50:00Z"), 1), every, now));
    }

    #[test]
    fn failures_kept_in_memory_back_off_a_link_never_synced() {
        let every = Duration::from_secs(300);
        let mem = Unrecorded::default();
        let at: jiff::Timestamp = "2026-01-01T00:58:00Z".parse().unwrap();
        mem.set("ana", at, "the store could not be opened".into());
        mem.set("ana", at, "the store could not be opened".into());
        let l = with_unrecorded(link(None, 0), &mem);
        assert_eq!(l.failures, 2);
        assert_eq!(l.last_sync_at.as_deref(), Some("2026-01-01T00:58:00Z"));
        assert!(l
            .last_error
            .as_deref()
            .unwrap()
            .contains("could not be opened"));
        // 2 failures: 4 x 5 min after the attempt.
        let soon: jiff::Timestamp = "2026-01-01T01:10:00Z".parse().unwrap();
        let later: jiff::Timestamp = "2026-01-01T01:18:00Z".parse().unwrap();
        assert!(!due(&l, every, soon));
        assert!(due(&l, every, later));
        // An attempt recorded on the link after it wins.
        let newer = with_unrecorded(link(Some("2026-01-01T00:59:00Z"), 0), &mem);
        assert_eq!(newer.failures, 0);
        mem.clear("ana");
        assert_eq!(with_unrecorded(link(None, 0), &mem).failures, 0);
    }
}
