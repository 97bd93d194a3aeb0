//! Refitting a person's twin when their log changed, in the background.
//!
//! After a write that may change a person's log (the app's events or
//! answers, an import, a change of therapy, a Nightscout sync), the
//! service calls [`RefitQueue::schedule`] with the person's name. A person
//! without a twin is never queued (no twin is made unasked). The queue is
//! bounded and coalesces: a person already waiting is not queued twice, so
//! a burst of imports costs at most the refit running now and one more on
//! the data as it is when that one starts. One dedicated thread refits one
//! person at a time, each on its own store connection; requests never wait
//! for it (scheduling is a lock and a file check). Before a refit the
//! worker claims the job ([`abba_store::Store::claim`]): replicas sharing
//! one PostgreSQL store never refit the same person at once (the claim
//! lasts as long as the refit's connection).
//!
//! What a refit does is the wiring's ([`TwinRefitter`]: the `abba` binary
//! applies abba-twin's refit rule). A failed refit is logged and stores
//! nothing, so the old twin stays; until a new revision is stored the
//! advice says the twin is older than the data. A panic inside a refit is
//! caught and logged like a failure: the worker goes on.

use abba_store::effect::{RefitOutcome, TwinRefitter};
use abba_store::Store;
use std::collections::{HashSet, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

/// Persons waiting for a refit at most (more are refused and logged: the
/// next change of their log schedules them again).
pub const QUEUE_MAX: usize = 1024;

/// What [`RefitQueue::schedule`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheduled {
    /// Queued.
    Queued,
    /// Already waiting: nothing more to do.
    Coalesced,
    /// The person has no twin: none is made.
    NoTwin,
    /// The queue is full (logged).
    Full,
}

/// Refits so far (for logs and tests).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RefitCounts {
    /// New revisions stored.
    pub refitted: u64,
    /// Refits that found the twin current.
    pub unchanged: u64,
    /// Refits that failed (nothing stored).
    pub failed: u64,
    /// Refits another replica held the claim for (skipped).
    pub skipped: u64,
    /// Persons waiting now.
    pub waiting: usize,
    /// Whether a refit is running now.
    pub running: bool,
}

#[derive(Default)]
struct Queue {
    order: VecDeque<String>,
    waiting: HashSet<String>,
    running: bool,
    counts: RefitCounts,
    stopped: bool,
}

struct Shared {
    db: PathBuf,
    refitter: Arc<dyn TwinRefitter>,
    queue: Mutex<Queue>,
    wake: Condvar,
}

/// The refit worker's handle (cheap to clone; the worker stops when
/// [`RefitQueue::stop`] is called or every handle is dropped).
#[derive(Clone)]
pub struct RefitQueue {
    shared: Arc<Shared>,
}

impl std::fmt::Debug for RefitQueue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RefitQueue")
            .field("db", &self.shared.db)
            .field("counts", &self.counts())
            .finish_non_exhaustive()
    }
}

fn lock(m: &Mutex<Queue>) -> MutexGuard<'_, Queue> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl RefitQueue {
    /// Starts the worker over the store `db` with `refitter`.
    pub fn start(db: &Path, refitter: Arc<dyn TwinRefitter>) -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            db: db.to_path_buf(),
            refitter,
            queue: Mutex::new(Queue::default()),
            wake: Condvar::new(),
        });
        let worker = Arc::clone(&shared);
        std::thread::Builder::new()
            .name("abba-twin-refit".into())
            .spawn(move || work(&worker))?;
        Ok(Self { shared })
    }

    /// Asks for a refit of `person`'s twin (never waits for one).
    pub fn schedule(&self, person: &str) -> Scheduled {
        if !self.shared.refitter.has_twin(person) {
            return Scheduled::NoTwin;
        }
        let mut q = lock(&self.shared.queue);
        if q.waiting.contains(person) {
            return Scheduled::Coalesced;
        }
        if q.order.len() >= QUEUE_MAX {
            drop(q);
            tracing::warn!(
                person,
                "the twin refit queue is full: this refit is not queued (the next change of the log asks again)"
            );
            return Scheduled::Full;
        }
        q.waiting.insert(person.to_string());
        q.order.push_back(person.to_string());
        drop(q);
        self.shared.wake.notify_one();
        Scheduled::Queued
    }

    /// Refits so far, and what is waiting or running now.
    pub fn counts(&self) -> RefitCounts {
        let q = lock(&self.shared.queue);
        RefitCounts {
            waiting: q.order.len(),
            running: q.running,
            ..q.counts
        }
    }

    /// Stops the worker after the refit it is running (the waiting ones
    /// are dropped).
    pub fn stop(&self) {
        lock(&self.shared.queue).stopped = true;
        self.shared.wake.notify_all();
    }
}

/// The worker: one refit at a time until stopped or every handle is gone.
fn work(shared: &Arc<Shared>) {
    loop {
        let person = {
            let mut q = lock(&shared.queue);
            loop {
                if q.stopped || Arc::strong_count(shared) == 1 {
                    return;
                }
                if let Some(p) = q.order.pop_front() {
                    // From now on a change of this person's log queues
                    // another refit (on the data as it will be then).
                    q.waiting.remove(&p);
                    q.running = true;
                    break p;
                }
                q = shared
                    .wake
                    .wait_timeout(q, Duration::from_millis(500))
                    .unwrap_or_else(PoisonError::into_inner)
                    .0;
            }
        };
        let outcome =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| refit_one(shared, &person)))
                .unwrap_or_else(|_| Err("the refit panicked".into()));
        let mut q = lock(&shared.queue);
        q.running = false;
        match outcome {
            Ok(Some(RefitOutcome::Refitted { revision, grade })) => {
                q.counts.refitted += 1;
                tracing::info!(person, revision, grade, "twin refitted on the new data");
            }
            Ok(Some(RefitOutcome::Unchanged { revision })) => {
                q.counts.unchanged += 1;
                tracing::debug!(person, revision, "twin already fitted on this log");
            }
            Ok(Some(RefitOutcome::NoTwin)) => {}
            Ok(None) => q.counts.skipped += 1,
            Err(e) => {
                q.counts.failed += 1;
                tracing::warn!(person, error = %e, "twin refit failed: the old twin is kept");
            }
        }
    }
}

/// One refit under the person's claim; `None` when another process holds
/// it.
fn refit_one(shared: &Shared, person: &str) -> Result<Option<RefitOutcome>, String> {
    let store =
        Store::open(&shared.db).map_err(|e| format!("the store could not be opened: {e}"))?;
    match store.claim(&format!("twin refit {person}")) {
        Ok(true) => {}
        Ok(false) => {
            tracing::info!(
                person,
                "the twin refit runs on another replica: skipped here"
            );
            return Ok(None);
        }
        Err(e) => return Err(format!("the refit could not be claimed: {e}")),
    }
    shared.refitter.refit(&store, person).map(Some)
}
