//! The open connections: a bounded registry of each one's client and state
//! (waiting for its first request's head, idle between requests, or a
//! request in flight, and since when), and the eviction that keeps one
//! client from stalling the others.
//!
//! When a new connection would pass the service's limit
//! ([`ServeSettings::max_connections`]) or its client's
//! ([`ServeSettings::max_connections_per_client`]), the connection that has
//! done nothing the longest (no request in flight: a head not yet whole,
//! a slow-loris's half-sent one included, or idle keep-alive) is closed
//! and the newcomer accepted; a connection whose task has not yet read
//! from it (a newcomer whose head waits in its socket while a flood is
//! accepted) goes last. Only when every connection in the way has a
//! request in flight is the newcomer refused (503). A request in flight
//! is never cut: a connection's state changes by compare-and-swap, so
//! either its request starts first (and the connection is not chosen) or
//! its eviction does; a head that arrived before the connection's task
//! saw its eviction is still served, as that connection's last request
//! (then it closes).
//!
//! Bounds: the registry holds at most `max_connections` entries (and one
//! count per client with a connection open), each about a hundred bytes
//! (8,192: under a megabyte); a connection leaves it when it ends or is
//! evicted (an evicted one serving its last request is bounded by the
//! limits of requests in flight). Its lock is taken only
//! when a connection opens or ends, never across an await and never by a
//! request (a request changes its connection's state with atomics); an
//! eviction scans the entries once (8,192 at most: tens of microseconds,
//! only when a limit is reached).
//!
//! [`ServeSettings::max_connections`]: crate::ServeSettings::max_connections
//! [`ServeSettings::max_connections_per_client`]: crate::ServeSettings::max_connections_per_client

use std::collections::HashMap;
use std::net::IpAddr;
use std::sync::atomic::{AtomicU64, AtomicU8, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

/// Waiting for the first request's head (or part of it).
const FRESH: u8 = 0;
/// Idle between requests (keep-alive), or waiting for the next head.
const IDLE: u8 = 1;
/// A request in flight: from its head to the end of its answer's body.
const IN_FLIGHT: u8 = 2;
/// Chosen for eviction: closed at its task's next turn.
const EVICTED: u8 = 3;
/// Evicted, but a request's head had arrived before its task saw the
/// eviction: that one request is served, then the connection closed.
const LAST: u8 = 4;

/// What a connection is doing, as the registry sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConnState {
    /// Waiting for its first request's head.
    Fresh,
    /// Idle between requests (keep-alive).
    Idle,
    /// A request in flight.
    InFlight,
    /// Closed to make room.
    Evicted,
    /// Evicted with the one request whose head had already arrived in
    /// flight: closed after its answer.
    EvictedServingLast,
}

/// One connection's state, shared by the registry, the connection's task
/// and its requests.
#[derive(Debug)]
pub struct Conn {
    state: AtomicU8,
    /// Milliseconds from the registry's epoch to the last change of state.
    since_ms: AtomicU64,
    epoch: Instant,
    evict: tokio::sync::Notify,
    /// The connection's task has read what the client sent so far at least
    /// once (a head already there is then a request in flight).
    polled: std::sync::atomic::AtomicBool,
    /// An evicted connection's last request started: its task lets it end.
    served_last: std::sync::atomic::AtomicBool,
}

impl Conn {
    fn now_ms(&self) -> u64 {
        u64::try_from(self.epoch.elapsed().as_millis()).unwrap_or(u64::MAX)
    }

    /// What the connection is doing.
    pub fn state(&self) -> ConnState {
        match self.state.load(Ordering::Acquire) {
            FRESH => ConnState::Fresh,
            IDLE => ConnState::Idle,
            IN_FLIGHT => ConnState::InFlight,
            LAST => ConnState::EvictedServingLast,
            _ => ConnState::Evicted,
        }
    }

    /// Marks a request in flight until the returned guard is dropped (at
    /// the end of its answer's body). On a connection just evicted whose
    /// task had not yet seen it (the head arrived in that same instant),
    /// the request is its last ([`InFlight::is_last`]: answered, then the
    /// connection closed); `None` after that one.
    pub fn start_request(self: &Arc<Self>) -> Option<InFlight> {
        let mut cur = self.state.load(Ordering::Acquire);
        loop {
            let next = match cur {
                LAST => return None,
                EVICTED if self.served_last.load(Ordering::Acquire) => return None,
                EVICTED => LAST,
                _ => IN_FLIGHT,
            };
            match self
                .state
                .compare_exchange_weak(cur, next, Ordering::AcqRel, Ordering::Acquire)
            {
                Ok(_) => break,
                Err(now) => cur = now,
            }
        }
        let last = cur == EVICTED;
        if last {
            self.served_last.store(true, Ordering::Release);
        }
        self.since_ms.store(self.now_ms(), Ordering::Release);
        Some(InFlight {
            conn: Arc::clone(self),
            last,
        })
    }

    /// True when the connection was evicted and its task may close it now:
    /// no request in flight, and none served since the eviction (whose
    /// answer may still be on its way out; hyper closes after it).
    pub fn may_close(&self) -> bool {
        self.state.load(Ordering::Acquire) == EVICTED && !self.served_last.load(Ordering::Acquire)
    }

    /// Resolves once the connection is chosen for eviction.
    pub async fn evicted(&self) {
        self.evict.notified().await;
    }

    /// Says the connection's task has read what the client sent so far:
    /// from now on it may be evicted before a connection whose task has
    /// not run yet (a newcomer whose head is waiting in its socket while
    /// a flood is accepted).
    pub fn mark_polled(&self) {
        self.polled.store(true, Ordering::Release);
    }

    /// Evicts the connection if it has no request in flight.
    fn try_evict(&self) -> bool {
        let mut cur = self.state.load(Ordering::Acquire);
        loop {
            if cur != FRESH && cur != IDLE {
                return false;
            }
            match self.state.compare_exchange_weak(
                cur,
                EVICTED,
                Ordering::AcqRel,
                Ordering::Acquire,
            ) {
                Ok(_) => {
                    // A stored permit: the task sees it even if it is not
                    // waiting yet.
                    self.evict.notify_one();
                    return true;
                }
                Err(now) => cur = now,
            }
        }
    }
}

/// A request in flight on its connection; the connection is idle again
/// when this is dropped.
#[derive(Debug)]
pub struct InFlight {
    conn: Arc<Conn>,
    last: bool,
}

impl InFlight {
    /// The connection was evicted as this request's head arrived: its
    /// answer closes it (`Connection: close`).
    pub fn is_last(&self) -> bool {
        self.last
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        let c = &self.conn;
        c.since_ms.store(c.now_ms(), Ordering::Release);
        let (from, to) = if self.last {
            (LAST, EVICTED)
        } else {
            (IN_FLIGHT, IDLE)
        };
        let _ = c
            .state
            .compare_exchange(from, to, Ordering::AcqRel, Ordering::Acquire);
    }
}

/// A registered connection.
struct Entry {
    /// Its client's key, `None` when it is not counted per client (a
    /// reverse proxy on this host, `--behind-proxy`).
    client: Option<IpAddr>,
    conn: Arc<Conn>,
}

#[derive(Default)]
struct Inner {
    conns: HashMap<u64, Entry>,
    per_client: HashMap<IpAddr, usize>,
    next_id: u64,
    evicted: u64,
}

/// Why a new connection was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refused {
    /// Every connection of its client has a request in flight.
    Client,
    /// Every connection has a request in flight.
    Service,
}

/// The open connections and their limits.
pub struct Registry {
    inner: Mutex<Inner>,
    epoch: Instant,
    max: usize,
    max_per_client: usize,
}

impl Registry {
    /// A registry of at most `max` connections, `max_per_client` of them
    /// from one client.
    pub fn new(max: usize, max_per_client: usize) -> Arc<Self> {
        Arc::new(Self {
            inner: Mutex::new(Inner::default()),
            epoch: Instant::now(),
            max,
            max_per_client,
        })
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Connections registered now.
    pub fn len(&self) -> usize {
        self.lock().conns.len()
    }

    /// True when no connection is registered.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Connections evicted so far.
    pub fn evicted(&self) -> u64 {
        self.lock().evicted
    }

    /// Registers a new connection of `client` (its key; `None`: not
    /// counted per client), evicting the longest non-productive connection
    /// in the way (of that client when the client is at its limit, of
    /// anyone when the service is), or refuses it when every one in the
    /// way has a request in flight.
    pub fn admit(self: &Arc<Self>, client: Option<IpAddr>) -> Result<Open, Refused> {
        let mut g = self.lock();
        if let Some(c) = client {
            if g.per_client.get(&c).copied().unwrap_or(0) >= self.max_per_client
                && !Self::evict_one(&mut g, Some(c))
            {
                return Err(Refused::Client);
            }
        }
        if g.conns.len() >= self.max && !Self::evict_one(&mut g, None) {
            return Err(Refused::Service);
        }
        let conn = Arc::new(Conn {
            state: AtomicU8::new(FRESH),
            since_ms: AtomicU64::new(0),
            epoch: self.epoch,
            evict: tokio::sync::Notify::new(),
            polled: std::sync::atomic::AtomicBool::new(false),
            served_last: std::sync::atomic::AtomicBool::new(false),
        });
        conn.since_ms.store(conn.now_ms(), Ordering::Release);
        let id = g.next_id;
        g.next_id += 1;
        g.conns.insert(
            id,
            Entry {
                client,
                conn: Arc::clone(&conn),
            },
        );
        if let Some(c) = client {
            *g.per_client.entry(c).or_insert(0) += 1;
        }
        Ok(Open {
            id,
            conn,
            registry: Arc::clone(self),
        })
    }

    /// Evicts the connection (of `client`, or anyone's) without a request
    /// in flight whose state has not changed the longest, one whose task
    /// has read from it first; false when there is none.
    fn evict_one(g: &mut Inner, client: Option<IpAddr>) -> bool {
        loop {
            let oldest = g
                .conns
                .iter()
                .filter(|(_, e)| client.is_none() || e.client == client)
                .filter(|(_, e)| matches!(e.conn.state(), ConnState::Fresh | ConnState::Idle))
                .min_by_key(|(id, e)| {
                    let c = &e.conn;
                    let unread = !c.polled.load(Ordering::Acquire);
                    (unread, c.since_ms.load(Ordering::Acquire), **id)
                })
                .map(|(id, _)| *id);
            let Some(id) = oldest else {
                return false;
            };
            // Its request may have started since the scan: then look again.
            if g.conns.get(&id).is_some_and(|e| e.conn.try_evict()) {
                Self::remove(g, id);
                g.evicted += 1;
                return true;
            }
        }
    }

    fn remove(g: &mut Inner, id: u64) {
        if let Some(e) = g.conns.remove(&id) {
            if let Some(c) = e.client {
                if let Some(n) = g.per_client.get_mut(&c) {
                    *n -= 1;
                    if *n == 0 {
                        g.per_client.remove(&c);
                    }
                }
            }
        }
    }
}

/// An open connection, registered until dropped.
pub struct Open {
    id: u64,
    conn: Arc<Conn>,
    registry: Arc<Registry>,
}

impl Open {
    /// The connection's shared state (for its requests).
    pub fn conn(&self) -> &Arc<Conn> {
        &self.conn
    }
}

impl Drop for Open {
    fn drop(&mut self) {
        let mut g = self.registry.lock();
        Registry::remove(&mut g, self.id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ip(s: &str) -> Option<IpAddr> {
        Some(s.parse().unwrap())
    }

    /// At a client's limit the oldest idle connection of that client goes
    /// (not another client's, not one with a request in flight); when
    /// every one is busy the newcomer is refused; entries never pass the
    /// limit.
    #[test]
    fn the_oldest_idle_connection_of_the_client_in_the_way_is_evicted() {
        let r = Registry::new(10, 2);
        let other = r.admit(ip("192.0.2.1")).unwrap();
        let a1 = r.admit(ip("198.51.100.7")).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(5));
        let a2 = r.admit(ip("198.51.100.7")).unwrap();
        let busy = a2.conn().start_request().unwrap();
        let a3 = r.admit(ip("198.51.100.7")).unwrap();
        assert_eq!(a1.conn().state(), ConnState::Evicted);
        assert!(a1.conn().may_close());
        let last = a1.conn().start_request().unwrap();
        assert!(last.is_last(), "a head there as it was evicted is its last");
        assert!(!a1.conn().may_close(), "its answer is let out");
        drop(last);
        assert!(a1.conn().start_request().is_none(), "then it runs nothing");
        assert_eq!(a2.conn().state(), ConnState::InFlight);
        assert_eq!(other.conn().state(), ConnState::Fresh);
        assert_eq!(r.len(), 3);
        let _b3 = a3.conn().start_request().unwrap();
        assert_eq!(
            r.admit(ip("198.51.100.7")).err(),
            Some(Refused::Client),
            "every one of the client's connections is busy"
        );
        drop(busy);
        assert_eq!(a2.conn().state(), ConnState::Idle);
        let _a4 = r.admit(ip("198.51.100.7")).unwrap();
        assert_eq!(a2.conn().state(), ConnState::Evicted);
        drop((a1, a2));
        assert_eq!(r.len(), 3);
    }

    /// A connection whose task has not read from it yet goes after every
    /// one that has, however old (its head may be waiting in its socket).
    #[test]
    fn a_connection_not_yet_read_goes_last() {
        let r = Registry::new(10, 2);
        let unread = r.admit(ip("198.51.100.7")).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(5));
        let read = r.admit(ip("198.51.100.7")).unwrap();
        read.conn().mark_polled();
        let _new = r.admit(ip("198.51.100.7")).unwrap();
        assert_eq!(read.conn().state(), ConnState::Evicted);
        assert_eq!(unread.conn().state(), ConnState::Fresh);
    }

    /// At the service's limit the longest idle connection goes, whoever's;
    /// a connection not counted per client is still counted there.
    #[test]
    fn at_the_services_limit_the_longest_idle_goes() {
        let r = Registry::new(2, 10);
        let proxy = r.admit(None).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(5));
        let b = r.admit(ip("192.0.2.1")).unwrap();
        let _busy = b.conn().start_request().unwrap();
        let c = r.admit(ip("192.0.2.2")).unwrap();
        assert_eq!(proxy.conn().state(), ConnState::Evicted);
        let _busy_c = c.conn().start_request().unwrap();
        assert_eq!(r.admit(ip("192.0.2.3")).err(), Some(Refused::Service));
        assert_eq!(r.len(), 2);
        assert_eq!(r.evicted(), 1);
    }
}
