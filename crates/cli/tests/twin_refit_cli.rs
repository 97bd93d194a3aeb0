//! The twin refitted when new data arrive (issue 27, item 1), with the real
//! wiring: `abba serve` over a person fed through the API by the reference
//! app (`abba app`, a simulated patient's days), the person's twin fitted
//! once by `abba twin fit`; then a day of new readings posted through the
//! API leads, without any further request, to twin revision 2 whose data
//! range covers the new day, fitted by the service's background worker.
//! Before the twin existed, the app's imports made none.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;
use crate::service_common;

use cli_common::{abba, ok};
use serde_json::{json, Value};
use service_common::{admin_token, Server, TempDir};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

fn http(addr: &str, method: &str, path: &str, token: &str, body: &str) -> (String, Value) {
    let mut s = TcpStream::connect(addr).unwrap();
    let req = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\
         Authorization: Bearer {token}\r\nContent-Type: application/json\r\n\
         Content-Length: {}\r\n\r\n{body}",
        body.len()
    );
    s.write_all(req.as_bytes()).unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    let status = out.lines().next().unwrap_or_default().to_string();
    let json = out
        .split("\r\n\r\n")
        .nth(1)
        .and_then(|b| serde_json::from_str(b).ok())
        .unwrap_or(Value::Null);
    (status, json)
}

fn twin(db: &Path) -> Option<Value> {
    let p = format!("{}.twins/ana.json", db.display());
    let text = std::fs::read_to_string(p).ok()?;
    serde_json::from_str(&text).ok()
}

#[test]
fn new_data_through_the_api_refit_the_stored_twin_in_the_background() {
    let dir = TempDir::new("twin-refit");
    let db = dir.0.join("abba.db");
    let admin = admin_token(&db);
    let server = Server::start(&db);
    // 16 days of a simulated patient, posted through the API as an app would.
    let run = abba(&[
        "app",
        "--url",
        &server.url(),
        "--token",
        &admin,
        "--patient",
        "adult#004",
        "--scenario",
        "S1",
        "--days",
        "16",
        "--name",
        "ana",
    ]);
    ok(&run);
    // No twin was asked for: the service made none.
    assert!(twin(&db).is_none(), "a twin made unasked");

    let db_s = db.to_str().unwrap();
    ok(&abba(&["twin", "fit", "--db", db_s, "--person", "ana"]));
    let first = twin(&db).unwrap();
    assert_eq!(first["revision"], 1);
    let end = |t: &Value| {
        t["data"]["start_minute"].as_i64().unwrap() + 1440 * t["data"]["days"].as_i64().unwrap()
    };

    // A new day of readings through the API.
    let token = ok(&abba(&["token", "--db", db_s, "--person", "ana"]));
    let token = token.trim();
    let (status, sync) = http(&server.addr, "GET", "/v1/persons/1/sync", token, "");
    assert!(status.contains("200"), "{status} {sync}");
    let mut seq = sync["last_seq"].as_u64().unwrap();
    // Day 1 of `abba app` (its --first-day default), in UTC.
    let day1: jiff::Timestamp = "2026-03-02T00:00:00Z".parse().unwrap();
    let at = |m: i64| (day1 + jiff::SignedDuration::from_mins(m)).to_string();
    let mut events = Vec::new();
    let new_day = 16 * 1440;
    let last = new_day + 1435;
    for m in (new_day..=last).step_by(5) {
        seq += 1;
        let g = 140.0 + 40.0 * ((m as f64) / 180.0).sin();
        events.push(json!({"seq": seq, "at": at(m), "event": {"type": "cgm", "mg_dl": g}}));
    }
    seq += 1;
    events.push(json!({"seq": seq, "at": at(new_day + 1440), "event": {"type": "day_closed"}}));
    assert!(
        end(&first) <= last,
        "the new day is past the first twin's window"
    );
    let body = json!({ "events": events }).to_string();
    let (status, ack) = http(&server.addr, "POST", "/v1/persons/1/events", token, &body);
    assert!(status.contains("200"), "{status} {ack}");
    // The service answers while it refits.
    let (status, _) = http(&server.addr, "GET", "/healthz", token, "");
    assert!(status.contains("200"), "{status}");

    // No further request: the twin is refitted in the background.
    let start = Instant::now();
    let refitted = loop {
        if let Some(t) = twin(&db).filter(|t| t["revision"] == 2) {
            break t;
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "no refit after 300 s"
        );
        std::thread::sleep(Duration::from_millis(200));
    };
    assert!(
        end(&refitted) > last,
        "the refitted twin's window ({}) covers the new day (last reading at {last})",
        end(&refitted)
    );
    assert_ne!(
        refitted["data"]["events_hash"],
        first["data"]["events_hash"]
    );
    // The advice now uses the new revision: no longer "older than the data".
    let (status, advice) = http(&server.addr, "GET", "/v1/persons/1/advice", token, "");
    assert!(status.contains("200"), "{status}");
    let text = advice.to_string();
    assert!(!text.contains("\"outdated\""), "{advice:#}");
}
