//! The service's limits, each a named setting of `abba serve` with the
//! default given here.

use std::time::Duration;

/// How the service holds connections and requests.
#[derive(Debug, Clone, PartialEq)]
pub struct ServeSettings {
    /// A connection that has not sent a whole request head this long after
    /// it opened, or after its last response (keep-alive idle), is closed.
    /// hyper times both from the moment it waits for a head, so one
    /// setting covers the header-read and the idle keep-alive timeout.
    pub header_timeout: Duration,
    /// A request body that has not arrived whole this long after its head
    /// gets 408 (every form, an app's batch of events; `crate::deadline`);
    /// a clinic's upload only when no byte came for this long.
    pub body_timeout: Duration,
    /// A request not answered this long after its head gets 408 (a handler
    /// that runs away; the heaviest page is far below).
    pub request_timeout: Duration,
    /// A connection whose answer makes no progress this long (the client
    /// reads none of it, so the socket's buffers stay full) is closed, and
    /// its request's slot freed: hyper has no write timeout of its own,
    /// and a request for a large answer never read kept its connection in
    /// flight (never evicted) for as long as the client liked.
    pub write_timeout: Duration,
    /// Connections held at once. One more closes the connection that has
    /// done nothing the longest (no request in flight: a head not yet
    /// whole, or idle keep-alive) and is served; only when every
    /// connection has a request in flight is it answered 503 and closed
    /// (`crate::conns`).
    pub max_connections: usize,
    /// Connections held at once from one client address (an IPv6
    /// address's /64), so that one client cannot take every connection (a
    /// probe opened 8,300 idle ones in 0.3 s): one more closes that
    /// client's connection that has done nothing the longest, or, when
    /// each has a request in flight, is answered 503 and closed. Loopback
    /// is counted like any address, unless `behind_proxy`.
    pub max_connections_per_client: usize,
    /// Requests in flight at once; more get 503 with `Retry-After`.
    pub max_in_flight: usize,
    /// Requests in flight at once from one client (its address, an IPv6
    /// address's /64; behind a proxy, the address the proxy forwarded);
    /// more get 503 with `Retry-After`, so that one client cannot hold
    /// every slot of `max_in_flight`.
    pub max_in_flight_per_client: usize,
    /// Requests in flight at once from one client with one credential
    /// (one bearer token, one session cookie, or none), so that one
    /// person's app cannot hold every slot its address has (every app
    /// behind one NAT, or on this host); more get 503 with `Retry-After`.
    pub max_in_flight_per_token: usize,
    /// A reverse proxy on this host forwards every client
    /// (`abba serve --behind-proxy`): loopback peers are not limited per
    /// address at the connection level, and a loopback peer's requests are
    /// counted for the last address of its `X-Forwarded-For`
    /// (`crate::client`). Off: that header is never read.
    pub behind_proxy: bool,
    /// On SIGTERM or Ctrl-C, requests in flight get this long to finish;
    /// then the service stops anyway.
    pub shutdown_grace: Duration,
    /// The store's side.
    pub store: StoreSettings,
}

impl Default for ServeSettings {
    fn default() -> Self {
        Self {
            header_timeout: Duration::from_secs(10),
            body_timeout: Duration::from_secs(10),
            request_timeout: Duration::from_secs(60),
            write_timeout: Duration::from_secs(20),
            max_connections: 8192,
            max_connections_per_client: 256,
            max_in_flight: 256,
            max_in_flight_per_client: 64,
            max_in_flight_per_token: 16,
            behind_proxy: false,
            shutdown_grace: Duration::from_secs(10),
            store: StoreSettings::default(),
        }
    }
}

/// How the service uses the store and memory.
#[derive(Debug, Clone, PartialEq)]
pub struct StoreSettings {
    /// SQLite connections in the pool.
    pub connections: u32,
    /// How long a write waits for another writer (the CLI, another
    /// process) before the request gets 503; also the longest wait for a
    /// pooled connection.
    pub busy_timeout: Duration,
    /// The `Retry-After` (seconds) of a 503.
    pub retry_after: u64,
    /// Live advisors kept at most (least recently used dropped first).
    pub cache_persons: u64,
    /// Events the live advisors may hold together: a live advisor holds
    /// its person's whole log (about 80 bytes an event, BENCHMARKS.md), so
    /// a count of persons alone bounds nothing. Each person weighs its
    /// events, at least `cache_events / cache_persons`; a person with more
    /// events than this is not kept (rebuilt from the store's snapshot on
    /// each use).
    pub cache_events: u64,
    /// A live advisor unused this long is dropped.
    pub cache_idle: Duration,
    /// Failed authentications one client address (an IPv6 address: its
    /// /64) may make per window before its missing, malformed, unknown or
    /// revoked tokens get 429 for the rest of the window; a valid token
    /// from that address still gets in.
    pub auth_failures: u32,
    /// The window of `auth_failures`.
    pub auth_window: Duration,
    /// The URL persons reach the service at (`https://abba.clinic.example`,
    /// no trailing slash), for the sign-in links the clinic's page makes;
    /// without it a link names the request's `Host`, which a proxy may
    /// pass on from anyone (`abba serve --public-url`).
    pub public_url: Option<String>,
}

impl Default for StoreSettings {
    fn default() -> Self {
        Self {
            connections: 8,
            busy_timeout: Duration::from_secs(5),
            retry_after: 1,
            cache_persons: 1000,
            cache_events: 2_000_000,
            cache_idle: Duration::from_secs(30 * 60),
            auth_failures: 30,
            auth_window: Duration::from_secs(60),
            public_url: None,
        }
    }
}
