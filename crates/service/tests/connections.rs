//! The connection and request limits hold for loopback clients too (a
//! probe on the service's own host comes from 127.0.0.1), over real
//! sockets: a flood of idle and half-sent connections is evicted, longest
//! idle first, while a polite client's `/healthz` and authenticated
//! requests answer at once; a connection with a request in flight is never
//! evicted; `X-Forwarded-For` counts only behind a proxy
//! (`ServeSettings::behind_proxy`), whose own connections are not limited
//! per address; one token's slow requests leave room for another's on the
//! same address.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_service::ServeSettings;
use common::sock::{closed, get, held_posts, timed};
use common::{Server, Svc};
use std::io::{Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The polite client's bound: each of its answers comes within this.
const POLITE: Duration = Duration::from_secs(1);

/// A connection to `to` from the loopback address `from` (all of
/// 127.0.0.0/8 is this host's on Linux).
async fn connect_from(from: Ipv4Addr, to: SocketAddr) -> std::io::Result<TcpStream> {
    let socket = tokio::net::TcpSocket::new_v4()?;
    socket.bind(SocketAddr::from((from, 0)))?;
    let stream = socket.connect(to).await?;
    let std = stream.into_std()?;
    std.set_nonblocking(false)?;
    Ok(std)
}

/// Opens connections to `to` until `stop` (or `max` of them), cycling
/// through `from`: two in three idle, one in three a request head sent
/// half (a slow loris); every 256, drops those the service closed. At most
/// 50 every 10 ms (5,000 a second): faster, the kernel's listen queue
/// (`server::LISTEN_BACKLOG`) fills and drops every client's SYN alike, a
/// second's wait the service never sees. Returns how many it opened and
/// those it still holds.
fn flood(
    to: SocketAddr,
    from: Vec<Ipv4Addr>,
    max: usize,
    stop: Arc<AtomicBool>,
) -> (usize, Vec<TcpStream>) {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let (mut opened, mut held) = (0, Vec::new());
        while !stop.load(Ordering::Relaxed) && opened < max {
            let Ok(mut s) = connect_from(from[opened % from.len()], to).await else {
                continue;
            };
            if opened % 3 == 2 {
                let _ = s.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n");
            }
            opened += 1;
            held.push(s);
            if opened % 50 == 0 {
                tokio::time::sleep(Duration::from_millis(10)).await;
            }
            if opened % 256 == 0 {
                held.retain(|s| !closed(s));
            }
        }
        (opened, held)
    })
}

/// A flood of idle and half-sent connections from 127.0.0.1 and four more
/// loopback addresses, far past both limits, goes on while a polite client
/// on 127.0.0.1 asks `/healthz` and an authenticated endpoint again and
/// again: each answers 200 within [`POLITE`]; the flooder's connections are
/// the ones closed, and the service never holds more than its limit of
/// them (its registry of connections is capped at `max_connections`).
/// Before eviction (loopback not counted, newcomers refused at the limit)
/// the polite client got 503 until the header timeout freed slots.
#[test]
fn a_loopback_flood_of_idle_connections_does_not_stall_a_polite_client() {
    let _ = rlimit::increase_nofile_limit(u64::MAX);
    let svc = Svc::new();
    let (max_connections, per_client) = (512, 256);
    let server = Server::start(
        &svc.db,
        ServeSettings {
            max_connections,
            max_connections_per_client: per_client,
            // Longer than the test: only eviction frees a slot.
            header_timeout: Duration::from_secs(60),
            ..ServeSettings::default()
        },
    );
    let stop = Arc::new(AtomicBool::new(false));
    let from: Vec<Ipv4Addr> = (1..=5).map(|i| Ipv4Addr::new(127, 0, 0, i)).collect();
    let flooder = {
        let (addr, stop) = (server.addr, Arc::clone(&stop));
        std::thread::spawn(move || flood(addr, from, 100_000, stop))
    };
    // The flood is past both limits before the first polite request.
    std::thread::sleep(Duration::from_millis(300));
    let auth = format!("Authorization: Bearer {}\r\n", svc.admin);
    let mut worst = Duration::ZERO;
    for round in 0..8 {
        for (what, request) in [
            ("/healthz", get("/healthz", "")),
            ("an authenticated GET", get("/v1/openapi.json", &auth)),
        ] {
            let (answer, took) = timed(server.addr, &request);
            assert!(
                answer.starts_with("HTTP/1.1 200"),
                "round {round}, {what}: {}",
                answer
            );
            assert!(took < POLITE, "round {round}, {what} took {took:?}");
            worst = worst.max(took);
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    stop.store(true, Ordering::Relaxed);
    let (opened, held) = flooder.join().unwrap();
    // The listen queue's last connections are accepted (each evicting
    // another), then the service holds at most its limit, and at most its
    // share from each address.
    let froms: Vec<Ipv4Addr> = (1..=5).map(|i| Ipv4Addr::new(127, 0, 0, i)).collect();
    let count = || {
        let open: Vec<&TcpStream> = held.iter().filter(|s| !closed(s)).collect();
        let most = froms
            .iter()
            .map(|f| {
                let f = std::net::IpAddr::V4(*f);
                open.iter()
                    .filter(|s| s.local_addr().unwrap().ip() == f)
                    .count()
            })
            .max()
            .unwrap_or(0);
        (open.len(), most)
    };
    let drained = Instant::now() + Duration::from_secs(5);
    let (mut open, mut most) = count();
    while (open > max_connections || most > per_client) && Instant::now() < drained {
        std::thread::sleep(Duration::from_millis(50));
        (open, most) = count();
    }
    println!(
        "{opened} flood connections from 5 loopback addresses; {open} still open; slowest polite answer {worst:?}"
    );
    assert!(
        opened > 3 * max_connections,
        "the flood went on past the limit: {opened}"
    );
    assert!(
        open <= max_connections,
        "the service holds at most its limit: {open} open"
    );
    assert!(
        most <= per_client,
        "each address holds at most its share: {most} open"
    );
}

/// A slow but valid upload (a person created with a body sent in pieces
/// over about a second) holds its connection with a request in flight:
/// the idle connections opened meanwhile past the limit evict each other,
/// never it, a polite `/healthz` is served, and the upload completes.
/// When every connection has a request in flight, a newcomer gets 503.
#[test]
fn a_connection_with_a_request_in_flight_is_never_evicted() {
    let svc = Svc::new();
    let server = Server::start(
        &svc.db,
        ServeSettings {
            max_connections: 3,
            header_timeout: Duration::from_secs(60),
            ..ServeSettings::default()
        },
    );
    let body = r#"{"name": "slow upload", "tz": "UTC", "mode": "cgm", "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10, 12, 11]}}"#;
    let upload = |name: &str| {
        let body = body.replace("slow upload", name);
        let mut s = TcpStream::connect(server.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let head = format!(
            "POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
            svc.admin,
            body.len()
        );
        s.write_all(head.as_bytes()).unwrap();
        (s, body)
    };
    let (mut slow, body) = upload("slow upload");
    let mut idle = Vec::new();
    let chunks: Vec<&[u8]> = body.as_bytes().chunks(body.len().div_ceil(5)).collect();
    for chunk in &chunks {
        std::thread::sleep(Duration::from_millis(200));
        slow.write_all(chunk)
            .expect("the slow upload's connection stays open");
        idle.extend((0..10).map(|_| TcpStream::connect(server.addr).unwrap()));
        let (answer, took) = timed(server.addr, &get("/healthz", ""));
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(took < POLITE, "/healthz took {took:?}");
    }
    let mut answer = String::new();
    slow.read_to_string(&mut answer).unwrap();
    assert!(
        answer.starts_with("HTTP/1.1 201"),
        "the slow upload: {answer}"
    );
    std::thread::sleep(Duration::from_millis(200));
    let open = idle.iter().filter(|s| !closed(s)).count();
    assert!(open <= 3, "the idle ones were evicted: {open} of 50 open");
    // Three uploads in flight: nothing to evict, the fourth gets 503.
    let held: Vec<_> = (0..3).map(|i| upload(&format!("held {i}")).0).collect();
    std::thread::sleep(Duration::from_millis(300));
    let (answer, _) = timed(server.addr, &get("/healthz", ""));
    assert!(answer.starts_with("HTTP/1.1 503"), "{answer}");
    assert!(answer.contains("retry-after: 1"), "{answer}");
    drop(held);
}

/// Two stalled requests (a valid token, a body that never comes) of the
/// client `forwarded` hold its share of requests in flight (2 here); the
/// answer to `/healthz` with `X-Forwarded-For: probe` then.
fn healthz_beside_a_full_share(behind_proxy: bool, forwarded: &str, probe: &str) -> String {
    let svc = Svc::new();
    let server = Server::start(
        &svc.db,
        ServeSettings {
            max_in_flight_per_client: 2,
            max_in_flight_per_token: 100,
            behind_proxy,
            ..ServeSettings::default()
        },
    );
    let stalled = held_posts(server.addr, &svc.admin, 2, |_| {
        format!("X-Forwarded-For: {forwarded}\r\n")
    });
    std::thread::sleep(Duration::from_millis(300));
    let (answer, _) = timed(
        server.addr,
        &get("/healthz", &format!("X-Forwarded-For: {probe}\r\n")),
    );
    drop(stalled);
    answer
}

/// Without `behind_proxy` a forged `X-Forwarded-For` changes nothing:
/// every loopback request is 127.0.0.1's, one share. With it, two
/// forwarded clients get a share each; a client's own entry before the
/// one the proxy appended changes nothing.
#[test]
fn x_forwarded_for_counts_only_behind_a_proxy() {
    let forged = healthz_beside_a_full_share(false, "203.0.113.1", "203.0.113.2");
    assert!(forged.starts_with("HTTP/1.1 503"), "{forged}");
    assert!(forged.contains("this client is at its limit"), "{forged}");
    let other = healthz_beside_a_full_share(true, "203.0.113.1", "203.0.113.2");
    assert!(other.starts_with("HTTP/1.1 200"), "{other}");
    let same = healthz_beside_a_full_share(true, "203.0.113.1", "203.0.113.2, 203.0.113.1");
    assert!(same.starts_with("HTTP/1.1 503"), "{same}");
}

/// Every client on 127.0.0.1 (no proxy): one token's slow requests, more
/// than the address's 64 slots, hold at most `max_in_flight_per_token` (16)
/// of them, the rest answered 503 with `Retry-After` at once, and another
/// person's app on the same address is served within [`POLITE`] meanwhile
/// (without the token's share it got 503 until the slow bodies' timeout).
#[test]
fn one_tokens_slow_requests_leave_room_for_another_tokens() {
    let svc = Svc::new();
    let rt = tokio::runtime::Runtime::new().unwrap();
    let (person, token) = rt.block_on(async {
        let id = svc.person("ana").await;
        (id, svc.token(id).await.1)
    });
    let set = ServeSettings::default();
    let server = Server::start(&svc.db, set.clone());
    let slow = set.max_in_flight_per_client + 16;
    let flood: Vec<TcpStream> = (0..slow)
        .map(|_| {
            let mut s = TcpStream::connect(server.addr).unwrap();
            s.write_all(format!(
                "POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {}\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{{",
                svc.admin
            ).as_bytes()).unwrap();
            s
        })
        .collect();
    std::thread::sleep(Duration::from_millis(300));
    let auth = format!("Authorization: Bearer {token}\r\n");
    let mut worst = Duration::ZERO;
    for _ in 0..5 {
        let (answer, took) = timed(
            server.addr,
            &get(&format!("/v1/persons/{person}/sync"), &auth),
        );
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(took < POLITE, "took {took:?}");
        worst = worst.max(took);
    }
    let refused = flood
        .iter()
        .filter(|s| {
            // Their answers came at once: whatever is not there now was not refused.
            s.set_nonblocking(true).unwrap();
            let mut b = [0u8; 12];
            (&**s).read_exact(&mut b).is_ok() && &b == b"HTTP/1.1 503"
        })
        .count();
    println!("one token's {slow} slow requests: {refused} refused; the other token's slowest answer {worst:?}");
    assert_eq!(refused, slow - set.max_in_flight_per_token);
}

/// The answer to a `/healthz` on a new loopback connection while four
/// others each hold a request in flight (nothing to evict), with a
/// per-address limit of two connections.
fn healthz_beside_four_busy_connections(behind_proxy: bool) -> String {
    let svc = Svc::new();
    let server = Server::start(
        &svc.db,
        ServeSettings {
            max_connections_per_client: 2,
            behind_proxy,
            ..ServeSettings::default()
        },
    );
    let busy = held_posts(server.addr, &svc.admin, 4, |i| {
        format!("X-Forwarded-For: 203.0.113.{i}\r\n")
    });
    std::thread::sleep(Duration::from_millis(300));
    let (answer, _) = timed(server.addr, &get("/healthz", ""));
    drop(busy);
    answer
}

/// Loopback holds at most its share of connections like any address; a
/// reverse proxy on this host (`behind_proxy`) carries every client's
/// connections, so its own are not limited per address (only by
/// `max_connections`).
#[test]
fn a_local_proxys_connections_are_not_limited_per_address() {
    let alone = healthz_beside_four_busy_connections(false);
    assert!(alone.starts_with("HTTP/1.1 503"), "{alone}");
    let proxied = healthz_beside_four_busy_connections(true);
    assert!(proxied.starts_with("HTTP/1.1 200"), "{proxied}");
}
