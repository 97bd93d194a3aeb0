//! Lost acknowledgements, deterministically: a loopback proxy between the
//! reference client and the real `abba serve` forwards every request but
//! swallows the response of every [`DROP_EVERY`]-th one (the service did
//! the work and committed; the app hears nothing, as when a phone loses
//! its connection at the wrong moment). The simulated patient's run must
//! still give exactly the in-process trial's decisions: the app re-syncs
//! instead of re-sending what is held, fetches the suggestions whose
//! acknowledgement was lost, and recognises answers an earlier attempt
//! stored. The test requires each of the three to have happened.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::service_common;

// The CLI's reference app (`abba app`), compiled into this test binary (tests/main.rs).
use crate::remote;

use abba_client::{Client, Retry};
use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::{ArmKind, RawTrialConfig};
use abba_trial::runner::build_cohort;
use abba_trial::TrialConfig;
use remote::RemoteApp;
use service_common::{admin_token, Server, TempDir};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// Every this-many-th request through the proxy gets no response.
const DROP_EVERY: u64 = 7;

/// One HTTP/1.1 message (head and a Content-Length body) from `r`, or
/// `None` at the end of the stream.
fn read_message(r: &mut BufReader<TcpStream>) -> Option<Vec<u8>> {
    let mut head = Vec::new();
    loop {
        let mut line = Vec::new();
        if r.read_until(b'\n', &mut line).ok()? == 0 {
            return None;
        }
        head.extend_from_slice(&line);
        if line == b"\r\n" {
            break;
        }
    }
    let text = String::from_utf8_lossy(&head).to_ascii_lowercase();
    assert!(
        !text.contains("transfer-encoding: chunked"),
        "the proxy reads Content-Length bodies only"
    );
    let len = text
        .lines()
        .find_map(|l| l.strip_prefix("content-length:"))
        .map_or(0, |v| v.trim().parse::<usize>().unwrap());
    let mut body = vec![0; len];
    r.read_exact(&mut body).ok()?;
    head.extend_from_slice(&body);
    Some(head)
}

/// Starts the proxy to `upstream`; returns its address and the count of
/// responses dropped.
fn proxy(upstream: String) -> (String, Arc<AtomicU64>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    let seen = Arc::new(AtomicU64::new(0));
    let dropped = Arc::new(AtomicU64::new(0));
    let d = dropped.clone();
    std::thread::spawn(move || {
        for client in listener.incoming() {
            let Ok(client) = client else { continue };
            let (upstream, seen, dropped) = (upstream.clone(), seen.clone(), d.clone());
            std::thread::spawn(move || {
                let mut from_client = BufReader::new(client.try_clone().unwrap());
                let mut to_client = client;
                let server = TcpStream::connect(&upstream).unwrap();
                let mut from_server = BufReader::new(server.try_clone().unwrap());
                let mut to_server = server;
                while let Some(request) = read_message(&mut from_client) {
                    to_server.write_all(&request).unwrap();
                    let Some(response) = read_message(&mut from_server) else {
                        return;
                    };
                    if (seen.fetch_add(1, Ordering::SeqCst) + 1).is_multiple_of(DROP_EVERY) {
                        // The service answered; the app never hears it.
                        dropped.fetch_add(1, Ordering::SeqCst);
                        let _ = to_client.shutdown(std::net::Shutdown::Both);
                        return;
                    }
                    if to_client.write_all(&response).is_err() {
                        return;
                    }
                }
            });
        }
    });
    (addr, dropped)
}

#[test]
fn lost_acknowledgements_change_nothing() {
    let (scenario, patient_no, days) = (ScenarioId::S1, 3, 16);
    let config = TrialConfig::try_from(RawTrialConfig {
        patients: patient_no as u32,
        days,
        calibrate_te_ref: false,
        scenarios: vec![scenario],
        arms: vec![ArmKind::Abba],
        ..RawTrialConfig::default()
    })
    .unwrap();
    let cohort = build_cohort(&config).unwrap();
    let vp = &cohort.patients[patient_no as usize - 1];
    let planned = config.planned_scenario(scenario).unwrap().clone();
    let decisions = remote::in_process_decisions(&config, vp, patient_no, &planned).unwrap();
    assert!(decisions.len() > 20, "{} decisions", decisions.len());

    let dir = TempDir::new("app-lost-acks");
    let db = dir.0.join("abba.db");
    let token = admin_token(&db);
    let server = Server::start(&db);
    let admin = Client::new(&server.url(), Some(&token)).unwrap();
    let first_day: jiff::civil::Date = "2026-03-02".parse().unwrap();
    let body = remote::person_body(&config, vp, patient_no, &planned, first_day, "lossy").unwrap();
    let created = admin.create_person(&body).unwrap();
    let issued = admin.issue_token(created.id).unwrap();

    let (proxy_addr, dropped) = proxy(server.addr.clone());
    let app = RemoteApp {
        client: Client::new(&format!("http://{proxy_addr}"), Some(&issued.token)).unwrap(),
        person: created.id,
        first_day,
        retry: Retry {
            first_wait: Duration::from_millis(1),
            max_wait: Duration::from_millis(10),
            give_up_after: Duration::from_secs(30),
        },
    };
    let run = remote::run_remote(&config, vp, patient_no, &planned, &app).unwrap();
    let o = run.outbox;
    eprintln!(
        "{} responses dropped: {} posts failed, {} events found held by sync, {} suggestions fetched, {} answers recognised as stored",
        dropped.load(Ordering::SeqCst),
        o.failures,
        o.held_on_sync,
        o.fetched_suggestions,
        run.answers_recovered
    );

    // Exactly the in-process decisions, in order, despite the losses.
    assert_eq!(
        remote::compare(&decisions, &run.suggestions),
        Ok(decisions.len())
    );
    // Each recovery path was taken.
    assert!(
        o.held_on_sync > 0,
        "no committed batch had its acknowledgement lost"
    );
    assert!(o.fetched_suggestions > 0, "no suggestion had to be fetched");
    assert!(
        run.answers_recovered > 0,
        "no answer was recognised as stored"
    );
    // Every event once, every change answered once (accepted).
    assert_eq!(o.acked + o.held_on_sync, o.pushed);
    let direct = admin.with_token(&issued.token);
    let sync = direct.sync(created.id, 0).unwrap();
    assert_eq!(sync.held.len(), 1);
    assert_eq!((sync.held[0].first, sync.held[0].last), (0, o.pushed - 1));
    let history = direct.history(created.id).unwrap();
    assert_eq!(history.suggestions.len(), decisions.len());
    let changes: Vec<_> = history
        .suggestions
        .iter()
        .filter(|s| !s.no_update && s.value != s.previous)
        .collect();
    assert!(!changes.is_empty());
    assert!(changes.iter().all(|s| s.status == "accepted"));
    assert_eq!(run.answers_posted as usize, changes.len());
}
