//! An attacker's probe, round six, over real sockets: a request head that
//! says two things (a request target naming another scheme or host than
//! the `Host` header, a body under a transfer coding besides `chunked`) is
//! refused with 400 before anything is read or stored, and its answer
//! carries no cookie.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_service::{auth, ServeSettings};
use abba_store::token::Role;
use common::sock::timed;
use common::{Server, Svc};

/// The status of an answer and its `Set-Cookie` lines.
fn status_and_cookies(answer: &str) -> (u16, Vec<String>) {
    let status = answer
        .get(9..12)
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no status: {answer}"));
    let cookies = answer
        .lines()
        .take_while(|l| !l.is_empty())
        .filter(|l| l.to_ascii_lowercase().starts_with("set-cookie:"))
        .map(str::to_string)
        .collect();
    (status, cookies)
}

/// `GET https://HOST/signin/{secret}` over plain HTTP is refused (400): it
/// was served with the sign-in cookie `Secure`, a plain client's say-so
/// taken for TLS, which only a trusted proxy may give. A target naming
/// another host than `Host` is refused too (the origin check and the
/// sign-in links read `Host`); the absolute form with this very host is
/// served, as HTTP/1.1 requires.
#[test]
fn a_request_target_naming_another_scheme_or_host_is_refused() {
    let svc = Svc::new();
    let secret = {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        auth::issue_signin(&mut store, Role::Admin).unwrap()
    };
    let server = Server::start(&svc.db, ServeSettings::default());
    let host = server.addr.to_string();
    let ask = |target: &str| {
        let (answer, _) = timed(
            server.addr,
            &format!("GET {target} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"),
        );
        status_and_cookies(&answer)
    };
    let (status, cookies) = ask(&format!("https://{host}/signin/{secret}"));
    assert_eq!((status, &cookies), (400, &vec![]), "https target");
    // Answered with the headers of every answer, though before the router.
    let (answer, _) = timed(
        server.addr,
        &format!(
            "GET https://{host}/healthz HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
        ),
    );
    let head = answer.to_ascii_lowercase();
    for line in [
        "cache-control: no-store",
        "x-content-type-options: nosniff",
        "content-security-policy: default-src 'none'",
    ] {
        assert!(head.contains(line), "{line}: {answer}");
    }
    let (status, _) = ask("http://evil.example/healthz");
    assert_eq!(status, 400, "another host");
    let (status, _) = ask(&format!("ftp://{host}/healthz"));
    assert_eq!(status, 400, "another scheme");
    // The absolute form with this host, and the path alone, are served;
    // the sign-in cookie is not Secure over plain HTTP.
    let (status, _) = ask(&format!("http://{host}/healthz"));
    assert_eq!(status, 200, "this host in absolute form");
    let (status, cookies) = ask(&format!("/signin/{secret}"));
    assert_eq!(status, 200);
    assert_eq!(cookies.len(), 1, "{cookies:?}");
    assert!(!cookies[0].contains("Secure"), "{cookies:?}");
}

/// A body under a transfer coding besides `chunked` (`gzip, chunked`) is
/// refused (400 naming `Transfer-Encoding`) and nothing is stored: hyper
/// reads the chunks and hands the body on still coded, and a reading sent
/// as plain JSON under `gzip` was stored (200) where the same body with
/// `Content-Encoding: gzip` is refused.
#[test]
fn a_body_under_a_transfer_coding_besides_chunked_is_refused() {
    let svc = Svc::new();
    let rt = tokio::runtime::Runtime::new().unwrap();
    let id = rt.block_on(svc.person("ana"));
    let (_, token) = rt.block_on(svc.token(id));
    let server = Server::start(&svc.db, ServeSettings::default());
    let body = serde_json::json!({"events": [common::cgm(1, 60, 150.0)]}).to_string();
    let post = |coding: &str| {
        let (answer, _) = timed(
            server.addr,
            &format!(
                "POST /v1/persons/{id}/events HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {token}\r\nContent-Type: application/json\r\nTransfer-Encoding: {coding}\r\nConnection: close\r\n\r\n{:x}\r\n{body}\r\n0\r\n\r\n",
                body.len()
            ),
        );
        answer
    };
    for coding in ["gzip, chunked", "deflate, chunked", "chunked, chunked"] {
        let answer = post(coding);
        let (status, _) = status_and_cookies(&answer);
        assert_eq!(status, 400, "{coding}: {answer}");
        assert!(
            answer.contains("\"path\":\"Transfer-Encoding\""),
            "{answer}"
        );
    }
    let store = abba_service::open_store(&svc.db).unwrap();
    let held = store.held_ranges(id as i64, 0, 10).unwrap();
    assert!(held.0.is_empty(), "nothing stored: {held:?}");
    drop(store);
    // `chunked` alone is read.
    let answer = post("chunked");
    assert_eq!(status_and_cookies(&answer).0, 200, "{answer}");
}
