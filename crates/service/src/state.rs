//! The service's state: a pool of SQLite connections (WAL: readers run
//! side by side, SQLite itself serialises writers), a lock per person (a
//! person's requests run one after another, different persons' never wait
//! for each other here) and the bounded cache of live advisors. Every
//! request's store work runs on tokio's blocking pool.

use crate::auth::{self, Caller, Need};
use crate::error::{ApiError, ServiceError};
use crate::settings::StoreSettings;
use abba_store::effect::{EffectPredictor, Effects, TwinCheck};
use abba_store::{Live, Store, StoreError};
use std::collections::HashMap;
use std::net::IpAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

/// Opens pooled connections: each one a [`Store`] in WAL mode with
/// `synchronous=FULL`, IMMEDIATE transactions and the service's busy
/// timeout.
#[derive(Debug)]
pub struct StoreManager {
    db: PathBuf,
    busy: Duration,
}

impl r2d2::ManageConnection for StoreManager {
    type Connection = Store;
    type Error = StoreError;

    fn connect(&self) -> Result<Store, StoreError> {
        Store::open_service(&self.db, self.busy)
    }

    fn is_valid(&self, conn: &mut Store) -> Result<(), StoreError> {
        conn.ping()
    }

    fn has_broken(&self, _conn: &mut Store) -> bool {
        false
    }
}

/// A pooled connection.
pub type Conn = r2d2::PooledConnection<StoreManager>;

/// A person's slot in the cache (taken out while a request uses it).
type Slot = Arc<Mutex<Option<Live>>>;

/// Failed authentications of one client in the current window.
#[derive(Debug, Clone, Copy)]
struct Failures {
    since: Instant,
    count: u32,
}

struct Inner {
    db: PathBuf,
    pool: r2d2::Pool<StoreManager>,
    locks: Mutex<HashMap<i64, Arc<Mutex<()>>>>,
    live: moka::sync::Cache<i64, Slot>,
    /// One permit: the request reading every person's log now
    /// ([`AppState::every_person`]).
    every_person: Arc<tokio::sync::Semaphore>,
    /// Failed authentications by client, at most [`MAX_FAILING_CLIENTS`].
    failures: moka::sync::Cache<IpAddr, Failures>,
    settings: StoreSettings,
    effects: std::sync::OnceLock<EffectSource>,
    refits: std::sync::OnceLock<crate::refit::RefitQueue>,
}

/// What predicts a suggestion's effect for the service (the `abba` binary
/// wires in the person's stored twin) and the twin check.
#[derive(Clone)]
pub struct EffectSource {
    /// The predictor (never fits inside a request).
    pub predictor: Arc<dyn EffectPredictor>,
    /// The twin check.
    pub check: TwinCheck,
}

impl std::fmt::Debug for EffectSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EffectSource")
            .field("check", &self.check)
            .finish_non_exhaustive()
    }
}

impl EffectSource {
    /// As the advice takes it.
    pub fn effects(&self) -> Effects<'_> {
        Effects {
            predictor: self.predictor.as_ref(),
            check: self.check,
        }
    }
}

/// Shared by every handler.
#[derive(Clone)]
pub struct AppState {
    inner: Arc<Inner>,
}

/// A poisoned lock guards nothing a panic could have left half-done (the
/// store's transactions roll back; a live advisor is taken out of the
/// cache while used, so a panic drops it): carry on.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl AppState {
    /// The state over the store file `db` (created if missing); refuses a
    /// store that cannot be written.
    pub fn open(db: &Path, settings: StoreSettings) -> Result<Self, ServiceError> {
        // The first connection migrates the file; then the pool opens the rest.
        let first = Store::open_service(db, settings.busy_timeout)?;
        check_writable(&first, db)?;
        drop(first);
        let pool = r2d2::Pool::builder()
            .max_size(settings.connections)
            .min_idle(Some(1))
            .connection_timeout(settings.busy_timeout)
            .build(StoreManager {
                db: db.to_path_buf(),
                busy: settings.busy_timeout,
            })
            .map_err(|e| ServiceError::Pool(e.to_string()))?;
        // Weighed by events, each person at least `floor`: both the
        // persons' count and their events together stay bounded.
        let floor = (settings.cache_events / settings.cache_persons.max(1)).max(1);
        let live = moka::sync::Cache::builder()
            .max_capacity(settings.cache_events)
            .weigher(move |_: &i64, slot: &Slot| {
                let events = lock(slot).as_ref().map_or(0, |l| l.stream.events.len());
                u32::try_from((events as u64).max(floor)).unwrap_or(u32::MAX)
            })
            .time_to_idle(settings.cache_idle)
            // LRU: the person who just wrote is kept (moka's default
            // TinyLFU may refuse a newcomer).
            .eviction_policy(moka::policy::EvictionPolicy::lru())
            .build();
        Ok(Self {
            inner: Arc::new(Inner {
                db: db.to_path_buf(),
                pool,
                locks: Mutex::new(HashMap::new()),
                live,
                every_person: Arc::new(tokio::sync::Semaphore::new(1)),
                failures: failures_table(settings.auth_window),
                settings,
                effects: std::sync::OnceLock::new(),
                refits: std::sync::OnceLock::new(),
            }),
        })
    }

    /// Puts each suggestion's predicted effect into the advice from now on
    /// (once; a second call is refused).
    pub fn set_effects(&self, source: EffectSource) -> Result<(), ServiceError> {
        self.inner
            .effects
            .set(source)
            .map_err(|_| ServiceError::Pool("the effect predictor is already set".into()))
    }

    /// Refits a person's twin in the background after each write that may
    /// change their log, from now on (once; a second call is refused).
    pub fn set_refits(&self, refits: crate::refit::RefitQueue) -> Result<(), ServiceError> {
        self.inner
            .refits
            .set(refits)
            .map_err(|_| ServiceError::Pool("the twin refit worker is already set".into()))
    }

    /// Asks for a background refit of `person`'s twin (when a refit worker
    /// is set and the person has a twin; never waits for the refit).
    pub fn log_changed(&self, person: &str) {
        if let Some(q) = self.inner.refits.get() {
            q.schedule(person);
        }
    }

    /// The effect predictor and the twin check, when one is set.
    pub fn effects(&self) -> Option<EffectSource> {
        self.inner.effects.get().cloned()
    }

    /// The store file.
    pub fn db(&self) -> &Path {
        &self.inner.db
    }

    /// The settings.
    pub fn settings(&self) -> &StoreSettings {
        &self.inner.settings
    }

    /// Live advisors in the cache now (after its pending evictions ran).
    pub fn cached_persons(&self) -> u64 {
        self.inner.live.run_pending_tasks();
        self.inner.live.entry_count()
    }

    /// Events the cached live advisors hold together (after the pending
    /// evictions ran).
    pub fn cached_events(&self) -> u64 {
        self.inner.live.run_pending_tasks();
        self.inner
            .live
            .iter()
            .map(|(_, slot)| {
                lock(&slot)
                    .as_ref()
                    .map_or(0, |l| l.stream.events.len() as u64)
            })
            .sum()
    }

    /// True when the person's live advisor is in the cache.
    pub fn is_cached(&self, id: i64) -> bool {
        self.inner.live.run_pending_tasks();
        self.inner.live.contains_key(&id)
    }

    /// Runs `f` on the blocking pool with a pooled connection.
    pub async fn store<T: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Store) -> Result<T, ApiError> + Send + 'static,
    ) -> Result<T, ApiError> {
        let s = self.clone();
        tokio::task::spawn_blocking(move || {
            let mut conn = s.conn()?;
            f(&mut conn)
        })
        .await
        .map_err(ApiError::internal)?
    }

    /// Runs `f`, work that reads every person's log (the clinic's list
    /// replays each one), like [`AppState::store`] but one such request at
    /// a time, from its start on the blocking pool to its end (past the
    /// request's timeout, which cannot stop it); another waits at most the
    /// busy timeout, then 503 with `Retry-After`. Its cost grows with every
    /// person's data (fifteen persons with a year each: 2.5 s), and
    /// sixteen clinic lists at once (one session's share of requests in
    /// flight) held every pooled connection: another person's sync and
    /// `/healthz` got 503 for as long.
    pub async fn every_person<T: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Store) -> Result<T, ApiError> + Send + 'static,
    ) -> Result<T, ApiError> {
        let set = &self.inner.settings;
        let sem = Arc::clone(&self.inner.every_person);
        let permit = tokio::time::timeout(set.busy_timeout, sem.acquire_owned())
            .await
            .map_err(|_| {
                ApiError::busy(
                    "another request is reading every person's data (the clinic's list)",
                    set.retry_after,
                )
            })?
            .map_err(ApiError::internal)?;
        let s = self.clone();
        tokio::task::spawn_blocking(move || {
            let _permit = permit;
            let mut conn = s.conn()?;
            f(&mut conn)
        })
        .await
        .map_err(ApiError::internal)?
    }

    /// Runs `f` on the blocking pool with the person's lock held, a pooled
    /// connection and the person's live state: the cached one when it is
    /// still the store's (same revision), else rebuilt. With `keep` the
    /// state goes (back) into the cache afterwards; without, a state that
    /// was not cached is built in a read transaction and dropped (read-only
    /// requests never fill the cache). On an error the state is dropped
    /// (the next request rebuilds it from the store).
    pub async fn person<T: Send + 'static>(
        &self,
        id: i64,
        keep: bool,
        f: impl FnOnce(&mut Store, &mut Live) -> Result<T, ApiError> + Send + 'static,
    ) -> Result<T, ApiError> {
        let s = self.clone();
        tokio::task::spawn_blocking(move || {
            let person_lock = s.person_lock(id);
            let _held = s.lock_person(&person_lock)?;
            let mut conn = s.conn()?;
            let cached = s.inner.live.remove(&id).and_then(|slot| lock(&slot).take());
            let was_cached = cached.is_some();
            let mut live = match cached {
                Some(l) if l.rev == conn.person_rev(id)? => l,
                _ if keep => conn.live(id)?,
                _ => conn.live_read(id)?,
            };
            let out = f(&mut conn, &mut live);
            if out.is_ok() && keep {
                // A write: the person's twin may be older than the log now.
                s.log_changed(&live.person.name);
            }
            if out.is_ok() && (keep || was_cached) {
                s.inner.live.insert(id, Arc::new(Mutex::new(Some(live))));
            }
            out
        })
        .await
        .map_err(ApiError::internal)?
    }

    /// Drops a person's live state (rebuilt on next use).
    pub fn forget(&self, id: i64) {
        self.inner.live.invalidate(&id);
    }

    fn conn(&self) -> Result<Conn, ApiError> {
        self.inner.pool.get().map_err(|e| {
            tracing::warn!(error = %e, "no store connection free");
            ApiError::busy(
                "the store is busy: no connection came free in time",
                self.inner.settings.retry_after,
            )
        })
    }

    /// Takes a person's lock, waiting at most the store's busy timeout: a
    /// person whose earlier requests still run (a long report of a large
    /// log, many requests at once) gets 503 with `Retry-After`, not a wait
    /// until the request timeout's 408 on a blocking thread (a service
    /// probe queued seven reports of one person: the last waited 60 s). The
    /// wait polls, so no thread is parked past its deadline.
    fn lock_person<'a>(&self, m: &'a Mutex<()>) -> Result<MutexGuard<'a, ()>, ApiError> {
        let set = &self.inner.settings;
        let deadline = Instant::now() + set.busy_timeout;
        loop {
            match m.try_lock() {
                Ok(held) => return Ok(held),
                Err(std::sync::TryLockError::Poisoned(p)) => return Ok(p.into_inner()),
                Err(std::sync::TryLockError::WouldBlock) => {}
            }
            if Instant::now() >= deadline {
                return Err(ApiError::busy(
                    "this person's earlier requests are still running",
                    set.retry_after,
                ));
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }

    fn person_lock(&self, id: i64) -> Arc<Mutex<()>> {
        let mut locks = lock(&self.inner.locks);
        if locks.len() > 4 * self.inner.settings.cache_persons as usize + 1024 {
            // Locks nobody holds or waits for are only kept for reuse.
            locks.retain(|_, l| Arc::strong_count(l) > 1);
        }
        Arc::clone(locks.entry(id).or_default())
    }

    /// Checks the request's `Authorization` header value against what the
    /// endpoint needs. A client (by address; an IPv6 address by its /64)
    /// that failed more than the settings allow in the current window is
    /// answered 429 for a missing, malformed, unknown or revoked token; a
    /// valid token is never refused for its address's failures (behind a
    /// proxy or a carrier's NAT every client shares one address, and one
    /// client's 30 bad tokens would lock every app out). Only a token of
    /// the documented form is looked up then.
    pub async fn authorize(
        &self,
        header: Option<String>,
        peer: Option<IpAddr>,
        need: Need,
    ) -> Result<Caller, ApiError> {
        let client = peer.map(client_key);
        let limited = client.and_then(|c| self.check_failures(c).err());
        if let Some(too_many) = &limited {
            if header.as_deref().and_then(auth::parse).is_none() {
                return Err(too_many.clone());
            }
        }
        let out = self
            .store(move |store| auth::authorize(store, header.as_deref(), need))
            .await;
        if let (Some(c), Err(e)) = (client, &out) {
            if e.status == axum::http::StatusCode::UNAUTHORIZED {
                if let Some(too_many) = limited {
                    return Err(too_many);
                }
                self.note_failure(c);
            }
        }
        out
    }

    /// The URL persons reach the service at, if one was given.
    pub fn public_url(&self) -> Option<&str> {
        self.inner.settings.public_url.as_deref()
    }

    fn check_failures(&self, ip: IpAddr) -> Result<(), ApiError> {
        let set = &self.inner.settings;
        if let Some(f) = self.inner.failures.get(&ip) {
            let elapsed = f.since.elapsed();
            if elapsed < set.auth_window && f.count >= set.auth_failures {
                let wait = (set.auth_window - elapsed).as_secs().max(1);
                return Err(ApiError::too_many(wait));
            }
        }
        Ok(())
    }

    fn note_failure(&self, ip: IpAddr) {
        let window = self.inner.settings.auth_window;
        let f = self
            .inner
            .failures
            .entry(ip)
            .and_upsert_with(|old| match old.map(|e| e.into_value()) {
                Some(f) if f.since.elapsed() < window => Failures {
                    count: f.count.saturating_add(1),
                    ..f
                },
                _ => Failures {
                    since: Instant::now(),
                    count: 1,
                },
            })
            .into_value();
        if f.count == self.inner.settings.auth_failures {
            tracing::warn!(client = %ip, "too many failed authentications: slowed down");
        }
    }

    /// Clients whose failed authentications are counted now (after the
    /// table's pending evictions ran): at most [`MAX_FAILING_CLIENTS`].
    pub fn failing_clients(&self) -> u64 {
        self.inner.failures.run_pending_tasks();
        self.inner.failures.entry_count()
    }

    /// Whether the store answers and can be written (for `/healthz`):
    /// `Err` says why not.
    pub async fn store_health(&self) -> Result<(), String> {
        let db = self.inner.db.clone();
        let s = self.clone();
        tokio::task::spawn_blocking(move || {
            let conn = s.conn().map_err(|e| e.message)?;
            conn.ping()
                .map_err(|e| format!("the store does not answer: {e}"))?;
            check_writable(&conn, &db).map_err(|e| e.to_string())
        })
        .await
        .map_err(|e| e.to_string())?
    }
}

/// A store the service could not write would take events it cannot keep:
/// refuse it (the file or its folder read-only, a read-only medium).
fn check_writable(store: &Store, db: &Path) -> Result<(), ServiceError> {
    let read_only = store.is_read_only()?;
    if store.backend() != "sqlite" {
        // A server: no file here to look at; it says itself.
        return match read_only {
            true => Err(ServiceError::ReadOnly(db.to_path_buf())),
            false => Ok(()),
        };
    }
    let meta = std::fs::metadata(db).map_err(|source| ServiceError::Io {
        context: format!("reading {}", db.display()),
        source,
    })?;
    let dir_ro = db
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .and_then(|p| std::fs::metadata(p).ok())
        .is_some_and(|m| m.permissions().readonly());
    if read_only || meta.permissions().readonly() || dir_ro {
        return Err(ServiceError::ReadOnly(db.to_path_buf()));
    }
    Ok(())
}

/// The most clients whose failed authentications are counted at once
/// (about 100 bytes each). A table without a bound was swept whole on
/// every failure once it held 100,000 clients of the current minute, under
/// the lock every authentication takes: failures from that many addresses
/// (an IPv6 /44 holds a million /64s; 127.0.0.0/8 on the service's own
/// host sixteen million addresses) made each request wait for the sweep.
/// Past the bound the client unseen longest is forgotten (its count starts
/// again), each in constant time.
pub const MAX_FAILING_CLIENTS: u64 = 100_000;

/// The table of failed authentications: bounded, its entries gone a
/// window after their last failure.
fn failures_table(window: Duration) -> moka::sync::Cache<IpAddr, Failures> {
    moka::sync::Cache::builder()
        .max_capacity(MAX_FAILING_CLIENTS)
        .time_to_live(window)
        // LRU: a client failing now is counted (moka's default TinyLFU
        // may refuse a newcomer, which would then never be limited).
        .eviction_policy(moka::policy::EvictionPolicy::lru())
        .build()
}

/// The key of a client's failed authentications: its IPv4 address, or the
/// /64 network of an IPv6 address (one host holds a whole /64).
pub(crate) fn client_key(ip: IpAddr) -> IpAddr {
    match ip {
        IpAddr::V4(_) => ip,
        IpAddr::V6(v6) => match v6.to_ipv4_mapped() {
            Some(v4) => IpAddr::V4(v4),
            None => {
                let s = v6.segments();
                IpAddr::V6(std::net::Ipv6Addr::new(s[0], s[1], s[2], s[3], 0, 0, 0, 0))
            }
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Failures from more clients than [`MAX_FAILING_CLIENTS`] within one
    /// window (each from its own address) keep the table at its bound, and
    /// the client failing now is still counted and limited. The unbounded
    /// table was swept whole on each failure past 100,000 clients, under
    /// the lock every authentication takes: these failures took a minute
    /// (about a millisecond each past the 100,000th, the lock held).
    #[test]
    fn failures_from_more_clients_than_the_bound_keep_the_table_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let db = dir.path().join("store.db");
        let settings = StoreSettings {
            auth_failures: 3,
            ..StoreSettings::default()
        };
        let state = AppState::open(&db, settings).unwrap();
        let clients = MAX_FAILING_CLIENTS as u32 + 50_000;
        let start = Instant::now();
        for i in 0..clients {
            state.note_failure(IpAddr::V4(std::net::Ipv4Addr::from(0x0a00_0000 + i)));
        }
        let took = start.elapsed();
        assert!(
            state.failing_clients() <= MAX_FAILING_CLIENTS,
            "{} clients counted",
            state.failing_clients()
        );
        let last = IpAddr::V4(std::net::Ipv4Addr::from(0x0a00_0000 + clients - 1));
        assert!(state.check_failures(last).is_ok(), "one failure so far");
        state.note_failure(last);
        state.note_failure(last);
        assert_eq!(
            state.check_failures(last).map_err(|e| e.status),
            Err(axum::http::StatusCode::TOO_MANY_REQUESTS),
            "the client failing now is limited"
        );
        // Each failure in constant time: well under a millisecond each
        // (the sweep took about one each past the 100,000th).
        assert!(
            took < Duration::from_secs(60),
            "{clients} failures took {took:?}"
        );
    }
}
