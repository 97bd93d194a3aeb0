//! `abba token` and `abba serve` as processes: a token printed once, the
//! service answering on a real socket, and a graceful stop on SIGTERM.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};

fn get(addr: &str, path: &str, token: Option<&str>) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    let auth = token.map_or(String::new(), |t| format!("Authorization: Bearer {t}\r\n"));
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: x\r\n{auth}Connection: close\r\n\r\n"
    )
    .unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    out
}

#[test]
fn token_then_serve_then_sigterm() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("clinic.db");
    let bin = env!("CARGO_BIN_EXE_abba");
    let out = Command::new(bin)
        .args(["token", "--db", db.to_str().unwrap(), "--admin"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let token = String::from_utf8(out.stdout).unwrap().trim().to_string();
    assert!(token.starts_with("abba_") && token.len() == 69, "{token}");
    // Only the hash is in the file.
    let bytes = std::fs::read(&db).unwrap();
    let wal = std::fs::read(dir.path().join("clinic.db-wal")).unwrap_or_default();
    let needle = token.as_bytes();
    for b in [&bytes, &wal] {
        assert!(
            !b.windows(needle.len()).any(|w| w == needle),
            "the token is stored in clear"
        );
    }
    // Neither or both of --admin and --person: refused.
    let out = Command::new(bin)
        .args(["token", "--db", db.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!out.status.success());

    let mut child = Command::new(bin)
        .args([
            "serve",
            "--db",
            db.to_str().unwrap(),
            "--listen",
            "127.0.0.1:0",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    let addr = first
        .split("http://")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .to_string();
    let notice = lines.next().unwrap().unwrap();
    assert!(notice.contains("not a medical device"));
    let health = get(&addr, "/healthz", None);
    assert!(health.starts_with("HTTP/1.1 200"), "{health}");
    assert!(health.contains("not a medical device"));
    let doc = get(&addr, "/v1/openapi.json", Some(&token));
    assert!(doc.starts_with("HTTP/1.1 200"), "{doc}");
    let doc = get(&addr, "/v1/openapi.json", None);
    assert!(doc.starts_with("HTTP/1.1 401"), "{doc}");
    let status = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let exit = child.wait().unwrap();
    assert!(exit.success(), "{exit:?}");
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(rest.iter().any(|l| l.contains("stopped")), "{rest:?}");
}
