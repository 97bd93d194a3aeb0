//! The HTTP server: the router with its layers (the per-client limits of
//! requests in flight among them), and the connection loop (hyper's
//! HTTP/1 server, its header-read timeout, the write timeout of each
//! connection, the registry of connections
//! that evicts the longest idle one at a limit: `crate::conns`, graceful
//! shutdown with a deadline).

use crate::client::ClientAddr;
use crate::error::{ApiError, ServiceError};
use crate::settings::ServeSettings;
use crate::state::AppState;
use axum::error_handling::HandleErrorLayer;
use axum::extract::{ConnectInfo, DefaultBodyLimit};
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::{BoxError, Extension, Router};
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;
use tower::{Layer, ServiceBuilder};
use tower_http::request_id::{MakeRequestUuid, PropagateRequestIdLayer, SetRequestIdLayer};
use tower_http::set_header::SetResponseHeaderLayer;
use tower_http::timeout::{RequestBodyTimeoutLayer, TimeoutLayer};
use tower_http::trace::TraceLayer;

/// Connections past the limit answered 503 at once, at most (more are
/// closed without an answer).
const AT_LIMIT_ANSWERS: usize = 64;

/// The most a request's head (its line and headers) may be: more is 431
/// and the connection closed. A connection's buffers hold at most twice
/// this (hyper reads ahead of its check, and reads a body in pieces no
/// larger). hyper's default (about 400 KiB a buffer) let each of the
/// 8,192 connections hold a head that large while its header timeout ran
/// (a probe's 200 KB header was read and served): 3 GiB; now 512 MiB at
/// most. A browser's head is a few KiB (nginx reads heads in buffers
/// of 8 KiB a line by default).
pub const MAX_HEAD_BYTES: usize = 32 * 1024;

/// The whole answer to a connection past the limit: the service's 503
/// body, `Retry-After: 1`, and the connection closed.
fn at_limit_response() -> Vec<u8> {
    let body = serde_json::json!({
        "status": 503,
        "code": "busy",
        "message": "the service is at its limit of connections; retry shortly",
    })
    .to_string();
    format!(
        "HTTP/1.1 503 Service Unavailable\r\ncontent-type: application/json\r\nretry-after: 1\r\ncache-control: no-store\r\nx-content-type-options: nosniff\r\ncontent-security-policy: default-src 'none'; frame-ancestors 'none'\r\ncontent-length: {}\r\nconnection: close\r\n\r\n{body}",
        body.len()
    )
    .into_bytes()
}

/// The router over a state, with the default settings.
pub fn router(state: AppState) -> Router {
    router_with(state, &ServeSettings::default())
}

/// Answers a request refused by a limit (in flight: 503; timeout: 408).
async fn refused(e: BoxError) -> Response {
    if e.is::<tower::load_shed::error::Overloaded>() {
        tracing::warn!("at the limit of requests in flight: 503");
        ApiError::busy("the service is at its limit of requests in flight", 1).into_response()
    } else {
        ApiError::internal(e).into_response()
    }
}

/// Requests in flight per client ([`ServeSettings::max_in_flight_per_client`])
/// and per client and credential ([`ServeSettings::max_in_flight_per_token`]).
/// An entry lives while a request of its key is in flight, so there are
/// never more than requests in flight (one per connection at most).
#[derive(Clone)]
struct PerClient {
    counts: Arc<std::sync::Mutex<Counts>>,
    /// Keys credentials (never stored): fresh per service.
    hasher: std::hash::RandomState,
}

#[derive(Default)]
struct Counts {
    client: std::collections::HashMap<std::net::IpAddr, usize>,
    token: std::collections::HashMap<(std::net::IpAddr, u64), usize>,
}

/// The credential key of anonymous requests that carry a body (and of the
/// sign-in form): their own share, apart from bodiless anonymous ones (0);
/// every other key is odd.
const ANONYMOUS_BODY: u64 = 2;

/// Which limit refused a request.
#[derive(Debug, PartialEq, Eq)]
enum Over {
    Client,
    Token,
}

/// A request counted for its client until dropped.
struct Counted {
    counts: Arc<std::sync::Mutex<Counts>>,
    key: std::net::IpAddr,
    token: u64,
}

fn down<K: std::hash::Hash + Eq>(map: &mut std::collections::HashMap<K, usize>, key: &K) {
    if let Some(n) = map.get_mut(key) {
        *n -= 1;
        if *n == 0 {
            map.remove(key);
        }
    }
}

impl Drop for Counted {
    fn drop(&mut self) {
        let mut counts = self
            .counts
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        down(&mut counts.client, &self.key);
        down(&mut counts.token, &(self.key, self.token));
    }
}

impl PerClient {
    fn new() -> Self {
        Self {
            counts: Arc::default(),
            hasher: std::hash::RandomState::new(),
        }
    }

    /// The key of a request's credential: its bearer token (as the token
    /// check reads it, so that "bearer" and extra spaces make no other
    /// key; one key for every malformed header), else its session
    /// cookie's value, else none (0). A credential that is not valid is
    /// refused from the head (401, or 403 for a page's POST), so it holds a
    /// slot only that long.
    ///
    /// An anonymous request that carries a body, and the sign-in form
    /// whatever cookies come with it (its session cookie is not read
    /// before its body, so a made-up one must not buy another share), is
    /// [`ANONYMOUS_BODY`]: slow sign-in bodies fill that share and no
    /// other, and a bodiless anonymous request (`/healthz`, a page's GET)
    /// still gets in (a probe's slow sign-in forms had `/healthz` answered
    /// 503 from the same address).
    fn credential(&self, req: &axum::extract::Request) -> u64 {
        use std::hash::BuildHasher;
        let headers = req.headers();
        if req.method() == axum::http::Method::POST && req.uri().path() == "/signin" {
            return ANONYMOUS_BODY;
        }
        if let Some(a) = headers.get(header::AUTHORIZATION) {
            let token = a.to_str().ok().and_then(crate::auth::parse).unwrap_or("");
            return self.hasher.hash_one((1u8, token)) | 1;
        }
        let names = [
            crate::web::session::COOKIE,
            crate::web::session::HOST_COOKIE,
        ];
        let sessions: Vec<&str> = headers
            .get_all(header::COOKIE)
            .iter()
            .filter_map(|v| v.to_str().ok())
            .flat_map(|v| v.split(';'))
            .filter_map(|pair| pair.trim().split_once('='))
            .filter(|(name, _)| names.contains(name))
            .map(|(_, value)| value)
            .collect();
        if sessions.is_empty() {
            let has_body = headers.contains_key(header::TRANSFER_ENCODING)
                || headers
                    .get(header::CONTENT_LENGTH)
                    .is_some_and(|v| v.as_bytes() != b"0");
            if has_body {
                ANONYMOUS_BODY
            } else {
                0
            }
        } else {
            self.hasher.hash_one((2u8, sessions)) | 1
        }
    }

    /// Counts a request of client `ip` with credential `token`, or says
    /// which cap it is at.
    fn enter(
        &self,
        ip: std::net::IpAddr,
        token: u64,
        cap: usize,
        token_cap: usize,
    ) -> Result<Counted, Over> {
        let key = crate::state::client_key(ip);
        let mut counts = self
            .counts
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if counts.client.get(&key).copied().unwrap_or(0) >= cap {
            return Err(Over::Client);
        }
        if counts.token.get(&(key, token)).copied().unwrap_or(0) >= token_cap {
            return Err(Over::Token);
        }
        *counts.client.entry(key).or_insert(0) += 1;
        *counts.token.entry((key, token)).or_insert(0) += 1;
        Ok(Counted {
            counts: Arc::clone(&self.counts),
            key,
            token,
        })
    }
}

/// tower-http's timeout answers 408 with an empty body: give it ours.
async fn timeout_body(r: Response) -> Response {
    if r.status() == StatusCode::REQUEST_TIMEOUT && !r.headers().contains_key(header::CONTENT_TYPE)
    {
        return ApiError::timeout("the whole request").into_response();
    }
    r
}

/// The router over a state: every endpoint (registered once, see
/// [`crate::openapi::api`]) behind the layers: request id and trace,
/// the in-flight limit, timeouts, body limit, the headers of every answer.
pub fn router_with(state: AppState, set: &ServeSettings) -> Router {
    use crate::routes;
    let (api, _) = crate::openapi::api().split_for_parts();
    let body_timeout = set.body_timeout;
    let per_client = PerClient::new();
    let client_cap = set.max_in_flight_per_client;
    let token_cap = set.max_in_flight_per_token;
    let behind_proxy = set.behind_proxy;
    let headers = ServiceBuilder::new()
        .layer(SetResponseHeaderLayer::overriding(
            header::CACHE_CONTROL,
            HeaderValue::from_static("no-store"),
        ))
        .layer(SetResponseHeaderLayer::overriding(
            header::X_CONTENT_TYPE_OPTIONS,
            HeaderValue::from_static("nosniff"),
        ))
        // The pages set their own CSP and referrer policy (crate::web).
        .layer(SetResponseHeaderLayer::if_not_present(
            header::CONTENT_SECURITY_POLICY,
            HeaderValue::from_static("default-src 'none'; frame-ancestors 'none'"),
        ))
        .layer(SetResponseHeaderLayer::if_not_present(
            header::REFERRER_POLICY,
            HeaderValue::from_static("no-referrer"),
        ));
    api.merge(crate::web::routes(state.clone()))
        .fallback(routes::not_found)
        .method_not_allowed_fallback(routes::method_not_allowed)
        .layer(DefaultBodyLimit::max(abba_api::MAX_BODY_BYTES))
        .layer(RequestBodyTimeoutLayer::new(set.body_timeout))
        .layer(axum::middleware::map_request(move |req| async move {
            crate::deadline::body_deadline(req, body_timeout)
        }))
        .layer(TimeoutLayer::with_status_code(
            StatusCode::REQUEST_TIMEOUT,
            set.request_timeout,
        ))
        // Outside the request timeout, so that its bare 408 gets the
        // service's body too.
        .layer(axum::middleware::map_response(timeout_body))
        .layer(
            ServiceBuilder::new()
                .layer(HandleErrorLayer::new(refused))
                .load_shed()
                .concurrency_limit(set.max_in_flight),
        )
        // One client's share of the slots above: a probe held every slot
        // with one token's slow bodies, and another person's events got
        // 503 for as long as it went on. Loopback is a client like any
        // other (the probe and the service on one host); behind a proxy,
        // the client is the one it forwarded (crate::client).
        .layer(axum::middleware::from_fn(
            move |req: axum::extract::Request, next: axum::middleware::Next| {
                let per_client = per_client.clone();
                async move {
                    let Some(client) = req.extensions().get::<ClientAddr>().copied() else {
                        return next.run(req).await;
                    };
                    let token = per_client.credential(&req);
                    match per_client.enter(client.0, token, client_cap, token_cap) {
                        Ok(_counted) => next.run(req).await,
                        Err(Over::Client) => {
                            tracing::warn!(client = %client.key(), "a client at its limit of requests in flight: 503");
                            ApiError::busy("this client is at its limit of requests in flight", 1)
                                .into_response()
                        }
                        Err(Over::Token) => {
                            tracing::warn!(client = %client.key(), "a client's credential at its limit of requests in flight: 503");
                            ApiError::busy(
                                "this client's token (or session) is at its limit of requests in flight",
                                1,
                            )
                            .into_response()
                        }
                    }
                }
            },
        ))
        // A declared length over the limit: 413 before the body is read.
        .layer(axum::middleware::from_fn(
            crate::body::refuse_declared_oversize,
        ))
        .layer(headers)
        .layer(PropagateRequestIdLayer::x_request_id())
        .layer(TraceLayer::new_for_http().make_span_with(request_span))
        .layer(SetRequestIdLayer::x_request_id(MakeRequestUuid))
        .layer(axum::middleware::map_request(safe_request_id))
        // Who the client is, for every limit above and the failed-token
        // limit (crate::client).
        .layer(axum::middleware::map_request(
            move |mut req: axum::extract::Request| async move {
                let peer = req
                    .extensions()
                    .get::<ConnectInfo<SocketAddr>>()
                    .map(|c| c.0.ip());
                if let Some(peer) = peer {
                    let client = ClientAddr::of(peer, req.headers(), behind_proxy);
                    req.extensions_mut().insert(client);
                    if behind_proxy && peer.is_loopback() {
                        req.extensions_mut().insert(crate::client::ViaProxy);
                    }
                }
                req
            },
        ))
        .with_state(state)
}

/// A client's `X-Request-Id` is kept (a proxy's, for log correlation) only
/// when it is 1 to 64 letters, digits, `-`, `_` or `.`; any other is
/// dropped, so the service makes its own (a probe's `<script>` was echoed
/// back and written to the log).
async fn safe_request_id(mut req: axum::extract::Request) -> axum::extract::Request {
    let safe = |v: &HeaderValue| {
        let b = v.as_bytes();
        (1..=64).contains(&b.len())
            && b.iter()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, b'-' | b'_' | b'.'))
    };
    let headers = req.headers_mut();
    let all: Vec<HeaderValue> = headers.get_all("x-request-id").iter().cloned().collect();
    if all.len() != 1 || !safe(&all[0]) {
        headers.remove("x-request-id");
    }
    req
}

/// Serves `db` on `listen` until SIGTERM or Ctrl-C; `ready` is told the
/// address bound (useful with port 0). Refuses a store it cannot write.
pub fn serve(
    db: &Path,
    listen: &str,
    set: &ServeSettings,
    ready: impl FnOnce(SocketAddr),
) -> Result<(), ServiceError> {
    serve_with(db, listen, set, None, ready)
}

/// [`serve`] with each suggestion's predicted effect from `effects`.
pub fn serve_with(
    db: &Path,
    listen: &str,
    set: &ServeSettings,
    effects: Option<crate::state::EffectSource>,
    ready: impl FnOnce(SocketAddr),
) -> Result<(), ServiceError> {
    serve_with_twins(db, listen, set, effects, None, ready)
}

/// [`serve_with`], refitting each person's twin in the background after
/// their log changed through `refits` ([`crate::refit`]).
pub fn serve_with_twins(
    db: &Path,
    listen: &str,
    set: &ServeSettings,
    effects: Option<crate::state::EffectSource>,
    refits: Option<crate::refit::RefitQueue>,
    ready: impl FnOnce(SocketAddr),
) -> Result<(), ServiceError> {
    // Connections are file descriptors: allow as many as the hard limit.
    match rlimit::increase_nofile_limit(u64::MAX) {
        Ok(n) => tracing::info!(nofile = n, "open file limit"),
        Err(e) => tracing::warn!(error = %e, "cannot raise the open file limit"),
    }
    let state = AppState::open(db, set.store.clone())?;
    if let Some(e) = effects {
        state.set_effects(e)?;
    }
    if let Some(q) = refits {
        state.set_refits(q)?;
    }
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|source| ServiceError::Io {
            context: "starting the runtime".into(),
            source,
        })?;
    rt.block_on(async move {
        let listener = bind(listen).await.map_err(|source| ServiceError::Io {
            context: format!("binding {listen}"),
            source,
        })?;
        let addr = listener.local_addr().map_err(|source| ServiceError::Io {
            context: "reading the bound address".into(),
            source,
        })?;
        ready(addr);
        run(listener, router_with(state, set), set).await;
        Ok(())
    })
}

/// The listen queue of the service's socket. A burst of connections (a
/// flood of idle ones, many apps at once) waits there while the accept
/// loop takes them; past it the kernel drops their SYNs and each client
/// retries a second later. Linux caps it at `net.core.somaxconn` (4,096
/// since 5.4); tokio's `TcpListener::bind` asks for 1,024.
pub const LISTEN_BACKLOG: u32 = 4096;

/// Binds `listen` (`host:port`; each address a name resolves to is tried
/// in turn) with [`LISTEN_BACKLOG`] and `SO_REUSEADDR` on Unix, as
/// `TcpListener::bind` would.
pub async fn bind(listen: &str) -> std::io::Result<tokio::net::TcpListener> {
    let mut last = None;
    for addr in tokio::net::lookup_host(listen).await? {
        let socket = if addr.is_ipv4() {
            tokio::net::TcpSocket::new_v4()?
        } else {
            tokio::net::TcpSocket::new_v6()?
        };
        #[cfg(unix)]
        socket.set_reuseaddr(true)?;
        match socket.bind(addr) {
            Ok(()) => match socket.listen(LISTEN_BACKLOG) {
                Ok(l) => return Ok(l),
                Err(e) => last = Some(e),
            },
            Err(e) => last = Some(e),
        }
    }
    Err(last.unwrap_or_else(|| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{listen} resolves to no address"),
        )
    }))
}

/// Accepts connections until a shutdown signal, then gives those open
/// `shutdown_grace` to finish their requests.
pub async fn run(listener: tokio::net::TcpListener, router: Router, set: &ServeSettings) {
    run_until(listener, router, set, shutdown_signal()).await
}

/// Like [`run`], stopping when `stop` resolves.
pub async fn run_until(
    listener: tokio::net::TcpListener,
    router: Router,
    set: &ServeSettings,
    stop: impl std::future::Future<Output = ()>,
) {
    let registry = crate::conns::Registry::new(set.max_connections, set.max_connections_per_client);
    let refusals = Arc::new(tokio::sync::Semaphore::new(AT_LIMIT_ANSWERS));
    let at_limit: Arc<[u8]> = at_limit_response().into();
    let graceful = hyper_util::server::graceful::GracefulShutdown::new();
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(set.header_timeout)
        .max_header_size(MAX_HEAD_BYTES)
        .max_buf_size(2 * MAX_HEAD_BYTES)
        .keep_alive(true);
    let mut full_logged = false;
    tokio::pin!(stop);
    loop {
        let (stream, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(x) => x,
                Err(e) => {
                    // Out of file descriptors and the like: pause, go on.
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(std::time::Duration::from_millis(20)).await;
                    continue;
                }
            },
            _ = &mut stop => break,
        };
        // Counted for its address (loopback too: a probe on this host),
        // but for a reverse proxy on this host (`--behind-proxy`).
        let client = (!(set.behind_proxy && peer.ip().is_loopback()))
            .then(|| crate::state::client_key(peer.ip()));
        let open = match registry.admit(client) {
            Ok(open) => open,
            Err(crate::conns::Refused::Client) => {
                tracing::debug!(client = %crate::state::client_key(peer.ip()), "each connection of a client at its limit has a request in flight: 503");
                refuse_connection(stream, &refusals, &at_limit);
                continue;
            }
            Err(crate::conns::Refused::Service) => {
                if !full_logged {
                    tracing::warn!(
                        max = set.max_connections,
                        "at the connection limit with a request in flight on each: new connections get 503 and are closed"
                    );
                    full_logged = true;
                }
                refuse_connection(stream, &refusals, &at_limit);
                continue;
            }
        };
        full_logged = false;
        let svc = tracked(
            Extension(ConnectInfo(peer)).layer(router.clone()),
            Arc::clone(open.conn()),
        );
        // A write that makes no progress for `write_timeout` ends the
        // connection (and frees its slot): the stall of a client that asks
        // for a large answer and never reads it.
        let mut stream = tokio_io_timeout::TimeoutStream::new(stream);
        stream.set_write_timeout(Some(set.write_timeout));
        let conn = http.serve_connection(
            TokioIo::new(Box::pin(stream)),
            TowerToHyperService::new(svc),
        );
        let conn = graceful.watch(conn);
        tokio::spawn(async move {
            let state = Arc::clone(open.conn());
            let mut conn = std::pin::pin!(conn);
            let mut evicted = std::pin::pin!(state.evicted());
            let mut told = false;
            // The connection first (a head already sent puts its request in
            // flight), then marked read, then its eviction: closed unless a
            // request came in that same instant (served, then closed).
            let ended = std::future::poll_fn(|cx| {
                use std::future::Future;
                if let std::task::Poll::Ready(r) = conn.as_mut().poll(cx) {
                    return std::task::Poll::Ready(Some(r));
                }
                state.mark_polled();
                told = told || evicted.as_mut().poll(cx).is_ready();
                if told && state.may_close() {
                    return std::task::Poll::Ready(None);
                }
                std::task::Poll::Pending
            })
            .await;
            match ended {
                Some(Err(e)) => tracing::debug!(client = %peer, error = %e, "connection ended"),
                Some(Ok(())) => {}
                None => {
                    tracing::debug!(client = %peer, "closed, without a request in flight, to make room for a new connection")
                }
            }
            drop(open);
        });
        // Let the new connection read what it was sent before the next
        // accept may evict it: a client's head already in the socket puts
        // its request in flight at this first poll (a flood from the same
        // address accepted 128 at a time evicted a polite newcomer before
        // its head was read).
        tokio::task::yield_now().await;
    }
    drop(listener);
    tracing::info!("stopping: waiting for requests in flight");
    tokio::select! {
        _ = graceful.shutdown() => tracing::info!("every connection closed"),
        _ = tokio::time::sleep(set.shutdown_grace) => {
            tracing::warn!(grace_s = set.shutdown_grace.as_secs_f64(), "grace period over: stopping with connections open");
        }
    }
}

/// The service of one connection: each request marks the connection busy
/// (`crate::conns`) from its head until its answer's body is sent or
/// dropped; the request of a connection evicted as its head arrived is
/// served and the connection closed after it.
fn tracked<S>(
    svc: S,
    conn: Arc<crate::conns::Conn>,
) -> impl tower::Service<
    axum::http::Request<hyper::body::Incoming>,
    Response = Response,
    Error = std::convert::Infallible,
    Future = impl Send,
> + Clone
where
    S: tower::Service<
            axum::http::Request<hyper::body::Incoming>,
            Response = Response,
            Error = std::convert::Infallible,
        > + Clone
        + Send
        + 'static,
    S::Future: Send,
{
    tower::service_fn(move |req: axum::http::Request<hyper::body::Incoming>| {
        let svc = svc.clone();
        let refused = crate::head::refused(&req);
        let busy = refused.is_none().then(|| conn.start_request()).flatten();
        async move {
            if let Some(e) = refused {
                tracing::debug!(why = %e.message, "a request's head refused: 400");
                return Ok(closing(e));
            }
            let Some(busy) = busy else {
                return Ok(closing(ApiError::busy(
                    "this connection was closed to make room; retry on a new one",
                    1,
                )));
            };
            let last = busy.is_last();
            let mut r = tower::ServiceExt::oneshot(svc, req).await?;
            if last {
                // Evicted as its head arrived: closed after this answer.
                r.headers_mut()
                    .insert(header::CONNECTION, HeaderValue::from_static("close"));
            }
            Ok(r.map(|body| axum::body::Body::new(Held { body, _busy: busy })))
        }
    })
}

/// An error answered before the router (whose layers set the headers of
/// every other answer): with those headers, and the connection closed
/// after it. A refused head's 400 came without them.
fn closing(e: ApiError) -> Response {
    let mut r = e.into_response();
    let h = r.headers_mut();
    for (name, value) in [
        (header::CONNECTION, "close"),
        (header::CACHE_CONTROL, "no-store"),
        (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        (
            header::CONTENT_SECURITY_POLICY,
            "default-src 'none'; frame-ancestors 'none'",
        ),
        (header::REFERRER_POLICY, "no-referrer"),
    ] {
        h.insert(name, HeaderValue::from_static(value));
    }
    r
}

/// An answer's body holding its connection busy until it is sent whole or
/// dropped.
struct Held {
    body: axum::body::Body,
    _busy: crate::conns::InFlight,
}

impl http_body::Body for Held {
    type Data = axum::body::Bytes;
    type Error = axum::Error;

    fn poll_frame(
        self: std::pin::Pin<&mut Self>,
        cx: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Option<Result<http_body::Frame<Self::Data>, Self::Error>>> {
        std::pin::Pin::new(&mut self.get_mut().body).poll_frame(cx)
    }

    fn is_end_stream(&self) -> bool {
        self.body.is_end_stream()
    }

    fn size_hint(&self) -> http_body::SizeHint {
        self.body.size_hint()
    }
}

/// A connection past a limit is told so (503 with Retry-After, as for
/// requests in flight) rather than reset, as long as few such answers are
/// under way (`refusals`); each gets a second, then it is closed.
fn refuse_connection(
    stream: tokio::net::TcpStream,
    refusals: &Arc<tokio::sync::Semaphore>,
    at_limit: &Arc<[u8]>,
) {
    let Ok(refusal) = Arc::clone(refusals).try_acquire_owned() else {
        return;
    };
    let at_limit = Arc::clone(at_limit);
    tokio::spawn(async move {
        use tokio::io::AsyncWriteExt;
        let mut stream = stream;
        let _ = tokio::time::timeout(
            std::time::Duration::from_secs(1),
            stream.write_all(&at_limit[..]),
        )
        .await;
        drop(refusal);
    });
}

/// Resolves on Ctrl-C or SIGTERM.
async fn shutdown_signal() {
    let ctrl_c = async {
        // If the handler cannot be installed, wait for SIGTERM only.
        if tokio::signal::ctrl_c().await.is_err() {
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
}

#[cfg(test)]
mod per_client_tests {
    use super::{Over, PerClient};
    use std::net::IpAddr;

    /// A client holds at most its cap, one credential of it at most its
    /// own; a slot comes back when its request ends; an IPv6 client is its
    /// /64 (one host holds a whole /64), another address is counted apart.
    #[test]
    fn a_client_and_its_token_hold_at_most_their_caps_and_get_slots_back() {
        let p = PerClient::new();
        let a: IpAddr = "2001:db8:1:2::10".parse().unwrap();
        let same_64: IpAddr = "2001:db8:1:2:ffff::1".parse().unwrap();
        let other: IpAddr = "198.51.100.9".parse().unwrap();
        let first = p.enter(a, 1, 3, 2).unwrap();
        let second = p.enter(same_64, 1, 3, 2).unwrap();
        assert_eq!(
            p.enter(a, 1, 3, 2).err(),
            Some(Over::Token),
            "one token's share"
        );
        let third = p.enter(a, 5, 3, 2).unwrap();
        assert_eq!(
            p.enter(a, 7, 3, 2).err(),
            Some(Over::Client),
            "a /64 is one client"
        );
        assert!(p.enter(other, 1, 3, 2).is_ok(), "another client is apart");
        drop(first);
        let fourth = p.enter(same_64, 1, 3, 2);
        assert!(fourth.is_ok(), "a slot comes back");
        drop((second, third, fourth));
        let counts = p.counts.lock().unwrap();
        assert!(
            counts.client.is_empty() && counts.token.is_empty(),
            "no entry is kept for a client with nothing in flight"
        );
    }

    /// One token is one key however its header is spelled, and one
    /// session one key whatever other cookies come with it; a request
    /// without either is anonymous (0), or, with a body, in the share of
    /// anonymous bodies.
    #[test]
    fn a_credential_is_one_key_however_it_is_sent() {
        let p = PerClient::new();
        let req = |method: &str, path: &str, lines: &[(&str, &str)]| {
            let mut r = axum::http::Request::builder().method(method).uri(path);
            for (k, v) in lines {
                r = r.header(*k, *v);
            }
            p.credential(&r.body(axum::body::Body::empty()).unwrap())
        };
        let key = |lines: &[(&str, &str)]| req("GET", "/", lines);
        let token = format!("abba_{}", "0a".repeat(32));
        let other = format!("abba_{}", "1b".repeat(32));
        let a = key(&[("authorization", &format!("Bearer {token}"))]);
        assert_eq!(a, key(&[("authorization", &format!("bearer   {token} "))]));
        assert_ne!(a, key(&[("authorization", &format!("Bearer {other}"))]));
        assert_eq!(
            key(&[("authorization", "Bearer x")]),
            key(&[("authorization", "Basic y")]),
            "every malformed header is one key"
        );
        let s = key(&[("cookie", "abba_session=abc")]);
        assert_eq!(
            s,
            key(&[("cookie", "x=1; abba_session=abc"), ("cookie", "y=2")])
        );
        assert_ne!(s, key(&[("cookie", "abba_session=abd")]));
        assert_eq!(key(&[("cookie", "x=1")]), 0);
        assert_eq!(key(&[]), 0);
        assert_eq!(key(&[("content-length", "0")]), 0);
        // An anonymous body, and the sign-in form whatever its cookies,
        // have their own share.
        let body = super::ANONYMOUS_BODY;
        assert_eq!(key(&[("content-length", "120")]), body);
        assert_eq!(key(&[("transfer-encoding", "chunked")]), body);
        assert_eq!(
            req("POST", "/signin", &[("cookie", "abba_session=made-up")]),
            body
        );
        assert_ne!(s, body);
    }
}

/// The trace's span of a request: its method and path, a sign-in link's
/// secret (`/signin/{secret}`, a credential until it is used) replaced by
/// `…`, and no query string.
fn request_span(req: &axum::http::Request<axum::body::Body>) -> tracing::Span {
    let path = logged_path(req.uri().path());
    tracing::debug_span!("request", method = %req.method(), path = %path, version = ?req.version())
}

/// [`request_span`]'s path.
fn logged_path(path: &str) -> std::borrow::Cow<'_, str> {
    match path.strip_prefix("/signin/") {
        Some(rest) if !rest.is_empty() => "/signin/…".into(),
        _ => path.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::logged_path;

    #[test]
    fn a_sign_in_links_secret_is_never_in_the_trace() {
        let secret = "ab".repeat(32);
        let path = format!("/signin/{secret}");
        let logged = logged_path(&path);
        assert!(!logged.contains(&secret), "{logged}");
        assert_eq!(logged, "/signin/…");
        assert_eq!(logged_path("/signin"), "/signin");
        assert_eq!(logged_path("/v1/persons/3/events"), "/v1/persons/3/events");
    }
}
