//! An attacker's probe from this host, round two, over real sockets: a
//! client that asks for a large answer and never reads it is closed after
//! the write timeout and its connection's slot freed; slow sign-in forms
//! from one address take their own share and leave `/healthz` and the
//! pages' GETs answered; `X-Forwarded-Proto` is read only from a proxy
//! `--behind-proxy` trusts.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_service::{auth, ServeSettings};
use abba_store::token::Role;
use axum::body::Bytes;
use common::sock::{connect_from, get, timed_from};
use common::{Server, Svc};
use std::io::{Read, Write};
use std::net::Ipv4Addr;
use std::time::{Duration, Instant};

/// The polite client's bound: each of its answers comes within this.
const POLITE: Duration = Duration::from_secs(1);

/// 64 KiB of an answer.
static CHUNK: [u8; 64 * 1024] = [b'x'; 64 * 1024];

/// A large answer (`chunks` times 64 KiB), made as it is sent.
struct Large {
    chunks: usize,
}

impl http_body::Body for Large {
    type Data = Bytes;
    type Error = std::convert::Infallible;

    fn poll_frame(
        mut self: std::pin::Pin<&mut Self>,
        _: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Option<Result<http_body::Frame<Bytes>, Self::Error>>> {
        if self.chunks == 0 {
            return std::task::Poll::Ready(None);
        }
        self.chunks -= 1;
        std::task::Poll::Ready(Some(Ok(http_body::Frame::data(Bytes::from_static(&CHUNK)))))
    }
}

/// A client that asks for a large answer (1 GiB) and reads none of it
/// holds its connection with a request in flight, which is never evicted:
/// with one connection per address, its address's next connection is
/// refused (503) while it stalls, and another address is served at once.
/// Within the write timeout (and a margin) the stalled connection is
/// closed, its slot free for its address again, and the client sees its
/// connection end without the whole answer. Without the write timeout
/// (hyper has none) the address got 503 for as long as the client liked.
#[test]
fn a_client_that_never_reads_its_answer_is_closed_and_its_slot_freed() {
    let write_timeout = Duration::from_millis(800);
    let set = ServeSettings {
        write_timeout,
        max_connections_per_client: 1,
        ..ServeSettings::default()
    };
    let router = axum::Router::new()
        .route(
            "/large",
            axum::routing::get(|| async { axum::body::Body::new(Large { chunks: 16 * 1024 }) }),
        )
        .route("/small", axum::routing::get(|| async { "small" }));
    let server = Server::start_router(router, set);
    let (stalling, polite) = (Ipv4Addr::new(127, 0, 0, 3), Ipv4Addr::new(127, 0, 0, 4));
    let mut stalled = connect_from(stalling, server.addr, Some(4096));
    stalled
        .write_all(b"GET /large HTTP/1.1\r\nHost: x\r\n\r\n")
        .unwrap();
    std::thread::sleep(Duration::from_millis(200));
    let (refused, _) = timed_from(stalling, server.addr, &get("/small", ""));
    assert!(
        refused.starts_with("HTTP/1.1 503"),
        "the stalled connection is in flight, its address at its limit: {refused}"
    );
    let (served, took) = timed_from(polite, server.addr, &get("/small", ""));
    assert!(served.starts_with("HTTP/1.1 200"), "{served}");
    assert!(took < POLITE, "another client waited {took:?}");
    let t = Instant::now();
    loop {
        let (answer, _) = timed_from(stalling, server.addr, &get("/small", ""));
        if answer.starts_with("HTTP/1.1 200") {
            break;
        }
        assert!(
            t.elapsed() < write_timeout + Duration::from_secs(2),
            "the stalled connection still holds its address's slot after {:?}: {answer}",
            t.elapsed()
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    stalled
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    let mut got = 0usize;
    let mut buf = vec![0u8; 1 << 16];
    let ended = loop {
        match stalled.read(&mut buf) {
            Ok(0) => break true,
            Ok(n) => got += n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                break false
            }
            Err(_) => break true,
        }
    };
    assert!(ended, "the stalled connection is closed");
    assert!(
        got < 16 * 1024 * CHUNK.len(),
        "it never got its whole answer ({got} bytes)"
    );
}

/// Slow sign-in forms from one address (two without a cookie, three with
/// made-up session cookies, each its own key before) take the share of
/// anonymous bodies and no more: the three past it get 503 at once, and
/// `/healthz` and the sign-in page from the same address answer 200 within
/// [`POLITE`] while the two bodies trickle. Before, the two filled the
/// anonymous share and `/healthz` got 503 (or the made-up cookies filled
/// the address's cap).
#[test]
fn slow_sign_in_forms_leave_healthz_and_pages_answered() {
    let svc = Svc::new();
    let set = ServeSettings {
        max_in_flight_per_client: 4,
        max_in_flight_per_token: 2,
        ..ServeSettings::default()
    };
    let server = Server::start(&svc.db, set);
    let from = Ipv4Addr::new(127, 0, 0, 5);
    let form = |cookie: &str| {
        format!(
            "POST /signin HTTP/1.1\r\nHost: x\r\n{cookie}Content-Type: application/x-www-form-urlencoded\r\nContent-Length: 200\r\nConnection: close\r\n\r\ncsrf="
        )
    };
    let mut slow = Vec::new();
    for i in 0..5 {
        let cookie = if i < 2 {
            String::new()
        } else {
            format!("Cookie: abba_session={}\r\n", format!("{i:x}").repeat(64))
        };
        let mut s = connect_from(from, server.addr, None);
        s.write_all(form(&cookie).as_bytes()).unwrap();
        slow.push(s);
        std::thread::sleep(Duration::from_millis(50));
    }
    std::thread::sleep(Duration::from_millis(200));
    for path in ["/healthz", "/signin"] {
        let (answer, took) = timed_from(from, server.addr, &get(path, ""));
        assert!(answer.starts_with("HTTP/1.1 200"), "{path}: {answer}");
        assert!(took < POLITE, "{path} waited {took:?}");
    }
    for (i, s) in slow.iter_mut().enumerate().skip(2) {
        s.set_read_timeout(Some(POLITE)).unwrap();
        let mut out = Vec::new();
        let _ = s.read_to_end(&mut out);
        let out = String::from_utf8_lossy(&out);
        assert!(
            out.starts_with("HTTP/1.1 503"),
            "slow form {i} past the anonymous bodies' share: {out}"
        );
    }
}

/// The `Set-Cookie` of a sign-in page asked from 127.0.0.1 with
/// `X-Forwarded-Proto: https`.
fn signin_cookie(svc: &Svc, behind_proxy: bool) -> String {
    let secret = {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        auth::issue_signin(&mut store, Role::Admin).unwrap()
    };
    let set = ServeSettings {
        behind_proxy,
        ..ServeSettings::default()
    };
    let server = Server::start(&svc.db, set);
    let (answer, _) = timed_from(
        Ipv4Addr::LOCALHOST,
        server.addr,
        &get(&format!("/signin/{secret}"), "X-Forwarded-Proto: https\r\n"),
    );
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    answer
        .lines()
        .find(|l| l.to_ascii_lowercase().starts_with("set-cookie:"))
        .unwrap_or_default()
        .to_string()
}

/// `X-Forwarded-Proto: https` makes the cookies `Secure` only from a proxy
/// `--behind-proxy` trusts; without the flag any local process (a probe on
/// this host) could say it, and it is not read (before, every loopback
/// peer was trusted).
#[test]
fn forwarded_proto_is_read_only_behind_a_proxy() {
    let svc = Svc::new();
    let plain = signin_cookie(&svc, false);
    assert!(plain.contains("abba_signin="), "{plain}");
    assert!(!plain.contains("Secure"), "without --behind-proxy: {plain}");
    let proxied = signin_cookie(&svc, true);
    assert!(proxied.contains("Secure"), "behind a proxy: {proxied}");
}

/// Odd and hostile requests from 127.0.0.1, each on its own connection:
/// oversized and duplicated headers, `Transfer-Encoding` with
/// `Content-Length`, absurd lengths, HTTP/1.0 without `Host`, pipelining,
/// NUL and CR in paths, traversal in each route with a path parameter,
/// thousands of query parameters and cookies, deep JSON into each JSON
/// body, a form's body past its limit without a length. Each gets its
/// answer (the given status, or any below 500) within two seconds, never a
/// 5xx; a head over [`abba_service::server::MAX_HEAD_BYTES`] is 431 (it
/// was read whole, 200 KB of it, and served: 400 KiB per connection), and
/// a form's body sent without a length is read no further than a form's
/// limit (413; it was read to 1 MiB); a missing (HTTP/1.1), doubled or
/// malformed `Host` is 400 (each was served).
#[test]
fn an_attackers_odd_requests_get_a_clear_answer_never_a_5xx_or_a_hang() {
    let svc = Svc::new();
    let rt = tokio::runtime::Runtime::new().unwrap();
    let id = rt.block_on(svc.person("ana"));
    let (_, tok) = rt.block_on(svc.token(id));
    let server = Server::start(&svc.db, ServeSettings::default());
    let auth = format!("Authorization: Bearer {tok}\r\n");
    let adm = format!("Authorization: Bearer {}\r\n", svc.admin);
    let close = "Connection: close\r\n";
    let many_q: String = (0..3000).map(|i| format!("a{i}=1&")).collect();
    let many_cookies: String = (0..500).map(|i| format!("c{i}=v; ")).collect();
    let deep = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
    let deep_obj = format!("{}1{}", "{\"a\":".repeat(5000), "}".repeat(5000));
    let json = |method: &str, path: &str, who: &str, body: &str| {
        format!("{method} {path} HTTP/1.1\r\nHost: x\r\n{who}Content-Type: application/json\r\nContent-Length: {}\r\n{close}\r\n{body}", body.len()).into_bytes()
    };
    let get = |path: &str, headers: &str| {
        format!("GET {path} HTTP/1.1\r\nHost: x\r\n{headers}{close}\r\n").into_bytes()
    };
    let events = format!("/v1/persons/{id}/events");
    let probes: Vec<(&str, Vec<u8>, Option<u16>)> = vec![
        ("a 40 KB header", get("/healthz", &format!("X-A: {}\r\n", "a".repeat(40_000))), Some(431)),
        ("a 20 KB head", get("/healthz", &format!("X-A: {}\r\n", "a".repeat(20_000))), Some(200)),
        ("500 headers", get("/healthz", &"X-A: 1\r\n".repeat(500)), Some(431)),
        ("two Hosts", get("/healthz", "Host: y\r\n"), Some(400)),
        ("two lengths", format!("POST {events} HTTP/1.1\r\nHost: x\r\n{auth}Content-Length: 2\r\nContent-Length: 3\r\n\r\n[]").into_bytes(), Some(400)),
        ("chunked and a length", format!("POST {events} HTTP/1.1\r\nHost: x\r\n{auth}Content-Type: application/json\r\nTransfer-Encoding: chunked\r\nContent-Length: 5\r\n\r\n2\r\n[]\r\n0\r\n\r\n").into_bytes(), Some(400)),
        ("an absurd length", format!("POST {events} HTTP/1.1\r\nHost: x\r\n{auth}Content-Length: 99999999999999999999999\r\n\r\n").into_bytes(), Some(400)),
        ("a negative length", format!("POST {events} HTTP/1.1\r\nHost: x\r\n{auth}Content-Length: -1\r\n\r\n").into_bytes(), Some(400)),
        ("50 MB expecting 100", format!("POST {events} HTTP/1.1\r\nHost: x\r\n{auth}Expect: 100-continue\r\nContent-Length: 50000000\r\n\r\n").into_bytes(), Some(413)),
        ("HTTP/1.0 without Host", b"GET /healthz HTTP/1.0\r\n\r\n".to_vec(), Some(200)),
        ("HTTP/1.1 without Host", b"GET /signin HTTP/1.1\r\nConnection: close\r\n\r\n".to_vec(), Some(400)),
        ("pipelined", b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\nGET /signin HTTP/1.1\r\nHost: x\r\n\r\nGET /nope HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".to_vec(), Some(200)),
        ("NUL in the path", b"GET /sig\0nin HTTP/1.1\r\nHost: x\r\n\r\n".to_vec(), Some(400)),
        ("CR in the path", b"GET /sig\rnin HTTP/1.1\r\nHost: x\r\n\r\n".to_vec(), Some(400)),
        ("escaped NUL CR LF", get("/signin/%00%0d%0a", ""), Some(403)),
        ("traversal, sign-in", get("/signin/..%2f..%2fetc%2fpasswd", ""), Some(403)),
        ("traversal, raw", get("/../../etc/passwd", ""), Some(404)),
        ("traversal, style", get(&format!("{}/..%2f..%2fCargo.toml", abba_web::STYLE_PATH), ""), Some(404)),
        ("traversal, person", get("/v1/persons/..%2f1/history", &adm), Some(404)),
        ("a huge person id", get("/v1/persons/99999999999999999999999/history", &adm), Some(404)),
        ("traversal, token", format!("DELETE /v1/tokens/..%2f HTTP/1.1\r\nHost: x\r\n{adm}{close}\r\n").into_bytes(), Some(404)),
        ("traversal, clinic", get("/clinic/persons/%2e%2e", ""), None),
        ("NUL, clinic report", get("/clinic/persons/1%00/report", ""), None),
        ("3,000 query parameters", get(&format!("/v1/persons/{id}/history?{many_q}"), &auth), Some(400)),
        ("a query parameter twice", get(&format!("/v1/persons/{id}/history?limit=1&limit=2"), &auth), Some(400)),
        ("500 cookies", get("/", &format!("Cookie: {many_cookies}\r\n")), None),
        ("a cookie not UTF-8", b"GET / HTTP/1.1\r\nHost: x\r\nCookie: abba_session=\xff\xfe\r\nConnection: close\r\n\r\n".to_vec(), None),
        ("a token not UTF-8", b"GET /v1/persons/1/history HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer \xff\xfe\r\nConnection: close\r\n\r\n".to_vec(), Some(401)),
        ("deep arrays, events", json("POST", &events, &auth, &deep), Some(400)),
        ("deep objects, persons", json("POST", "/v1/persons", &adm, &deep_obj), Some(400)),
        ("deep objects, answers", json("POST", &format!("/v1/persons/{id}/answers"), &auth, &deep_obj), Some(400)),
        ("deep objects, bounds", json("PUT", &format!("/v1/persons/{id}/bounds"), &adm, &deep_obj), Some(400)),
        ("deep objects, therapy", json("POST", &format!("/v1/persons/{id}/therapy"), &adm, &deep_obj), None),
        ("deep objects, sync", json("GET", &format!("/v1/persons/{id}/sync"), &auth, &deep_obj), None),
        ("a form's 900 KB without a length", format!("POST /signin HTTP/1.1\r\nHost: x\r\nOrigin: http://x\r\nContent-Type: application/x-www-form-urlencoded\r\nTransfer-Encoding: chunked\r\n{close}\r\n{:x}\r\n{}\r\n0\r\n\r\n", 900_000, "a".repeat(900_000)).into_bytes(), Some(413)),
        ("an unknown method", b"FOO /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".to_vec(), Some(405)),
        ("an absolute URI", b"GET http://evil.example/healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".to_vec(), None),
        ("CONNECT", b"CONNECT evil.example:443 HTTP/1.1\r\nHost: evil.example:443\r\nConnection: close\r\n\r\n".to_vec(), None),
        ("OPTIONS *", b"OPTIONS * HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n".to_vec(), None),
        ("Host with markup", b"GET /signin HTTP/1.1\r\nHost: <script>\r\nConnection: close\r\n\r\n".to_vec(), Some(400)),
        ("Host with a user", b"GET /signin HTTP/1.1\r\nHost: evil@x\r\nConnection: close\r\n\r\n".to_vec(), Some(400)),
        ("Host with a port", b"GET /signin HTTP/1.1\r\nHost: [::1]:8080\r\nConnection: close\r\n\r\n".to_vec(), Some(200)),
    ];
    for (name, request, want) in probes {
        let t = Instant::now();
        let mut s = connect_from(Ipv4Addr::LOCALHOST, server.addr, None);
        s.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
        let _ = s.write_all(&request);
        let mut out = Vec::new();
        let _ = s.read_to_end(&mut out);
        let text = String::from_utf8_lossy(&out);
        let statuses: Vec<u16> = text
            .lines()
            .filter_map(|l| {
                l.strip_prefix("HTTP/1.1 ")
                    .or_else(|| l.strip_prefix("HTTP/1.0 "))
            })
            .filter_map(|l| l.get(..3)?.parse().ok())
            .collect();
        assert!(
            !statuses.is_empty(),
            "{name}: no answer in {:?}",
            t.elapsed()
        );
        assert!(
            t.elapsed() < Duration::from_secs(2),
            "{name}: {:?}",
            t.elapsed()
        );
        assert!(
            statuses.iter().all(|&c| c < 500),
            "{name}: {statuses:?}\n{text}"
        );
        if let Some(want) = want {
            assert_eq!(
                statuses[0],
                want,
                "{name}: {}",
                text.lines().next().unwrap_or("")
            );
        }
    }
}
