//! `abba serve` never dies of its output: with its stdout closed by
//! whoever started it (a pipe whose reader went away), it keeps
//! answering, and stops cleanly on SIGTERM though its last line ("stopped")
//! cannot be written.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};

fn get(addr: &str, path: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    out
}

#[test]
fn serve_keeps_serving_after_its_stdout_is_closed() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("clinic.db");
    let errors = dir.path().join("serve.stderr");
    let mut child = Command::new(env!("CARGO_BIN_EXE_abba"))
        .args(["serve", "--db"])
        .arg(&db)
        .args(["--listen", "127.0.0.1:0"])
        .env("RUST_LOG", "info")
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(&errors).unwrap())
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    // The reader is dropped with the line: the pipe is closed.
    let addr = first
        .split("http://")
        .nth(1)
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .to_string();
    for _ in 0..20 {
        let health = get(&addr, "/healthz");
        assert!(health.starts_with("HTTP/1.1 200"), "{health}");
    }
    let status = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let exit = child.wait().unwrap();
    let stderr = std::fs::read_to_string(&errors).unwrap();
    assert!(exit.success(), "{exit:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}
