//! Keeping every linked person current (`abba serve --sync-every`): every
//! tick, the links that are due are synced, at most `concurrency` at once,
//! each on its own store connection. A link that failed waits longer
//! before its next try: the interval doubled per failure in a row, at most
//! [`MAX_BACKOFF`]. Outcomes are recorded on the link (last sync, error,
//! failures), which the API and `abba link --list` show; nothing is printed.

use crate::sync::{sync, SyncOptions};
use abba_store::link::Link;
use abba_store::Store;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
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

/// One round: syncs the links of `db` that are due; returns how many were
/// synced (successfully or not).
pub fn round(db: &Path, bg: &Background) -> Result<usize, abba_store::StoreError> {
    let now = jiff::Timestamp::now();
    let due: Vec<String> = Store::open(db)?
        .links()?
        .into_iter()
        .filter(|l| due(l, bg.every, now))
        .map(|l| l.person)
        .collect();
    let n = due.len();
    for chunk in due.chunks(bg.concurrency.max(1)) {
        std::thread::scope(|s| {
            for person in chunk {
                s.spawn(move || {
                    // The outcome is recorded on the link by `sync`.
                    if let Ok(mut store) = Store::open(db) {
                        let _ = sync(&mut store, person, &bg.sync);
                    }
                });
            }
        });
    }
    Ok(n)
}

/// Runs rounds until `stop` is set (checked every 200 ms).
pub fn run(db: &Path, bg: &Background, stop: &AtomicBool) {
    let tick = Duration::from_millis(200);
    let round_every = bg.every.min(Duration::from_secs(30));
    let mut since = round_every;
    while !stop.load(Ordering::Relaxed) {
        if since >= round_every {
            let _ = round(db, bg);
            since = Duration::ZERO;
        }
        std::thread::sleep(tick);
        since += tick;
    }
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
}
