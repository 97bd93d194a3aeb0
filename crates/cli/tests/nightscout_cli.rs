//! `abba link` and `abba sync` against the Nightscout-compatible test
//! server of abba-nightscout's tests (on 127.0.0.1): the link is checked
//! and stored with no credential shown and the store file owner-only;
//! `abba sync` killed with SIGKILL at 20 moments spread over a whole sync,
//! then run to the end, gives the store one uninterrupted sync gives (the
//! file import of the same documents); each killed state is consistent.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use common::*;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn abba() -> Command {
    Command::new(env!("CARGO_BIN_EXE_abba"))
}

fn link_cli(db: &Path, url: &str) -> std::process::Output {
    let mut child = abba()
        .args(["link", "nightscout", "--db"])
        .arg(db)
        .args(["--person", "ana", "--url", url, "--api-secret", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    writeln!(child.stdin.take().unwrap(), "{SECRET}").unwrap();
    child.wait_with_output().unwrap()
}

fn sync_cli(db: &Path) -> Command {
    let mut c = abba();
    c.args(["sync", "--db"]).arg(db).args(["--person", "ana"]);
    c.stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

/// (records, marks) as the store holds them, and whether SQLite finds the
/// file sound.
fn state(db: &Path) -> (Vec<String>, Vec<(String, i64)>) {
    let conn = rusqlite::Connection::open(db).unwrap();
    let ok: String = conn
        .query_row("PRAGMA integrity_check", [], |r| r.get(0))
        .unwrap();
    assert_eq!(ok, "ok");
    let store = abba_store::Store::open(db).unwrap();
    let marks = store.link_marks("ana").unwrap().into_iter().collect();
    (records(&store), marks)
}

#[test]
fn link_list_and_sync_show_no_credential_and_the_store_is_owner_only() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (db, store) = store_with_person(dir.path(), "cli.db", &files);
    drop(store);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&db).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600, "the store file is owner-only");
    }
    let out = link_cli(&db, &srv.url);
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{text}");
    let hash = common::server::sha1_hex(SECRET);
    let list = abba()
        .args(["link", "--list", "--db"])
        .arg(&db)
        .output()
        .unwrap();
    let sync = sync_cli(&db).output().unwrap();
    assert!(
        sync.status.success(),
        "{}",
        String::from_utf8_lossy(&sync.stderr)
    );
    let all = [&out, &list, &sync]
        .iter()
        .map(|o| {
            String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr)
        })
        .collect::<String>();
    assert!(
        !all.contains(SECRET) && !all.contains(&hash),
        "no credential is printed"
    );
    assert!(all.contains("research software, not a medical device"));
    let list = String::from_utf8_lossy(&list.stdout);
    assert!(
        list.contains(&srv.url) && list.contains("api_secret_sha1"),
        "{list}"
    );

    // A wrong secret: a clear 401, nothing stored.
    let (db2, s2) = store_with_person(dir.path(), "wrong.db", &files);
    drop(s2);
    let mut child = abba()
        .args(["link", "nightscout", "--db"])
        .arg(&db2)
        .args(["--person", "ana", "--url", &srv.url, "--api-secret", "-"])
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    writeln!(child.stdin.take().unwrap(), "not-the-right-secret").unwrap();
    let wrong = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&wrong.stderr);
    assert!(!wrong.status.success());
    assert!(err.contains("401") && err.contains("API secret"), "{err}");
    assert!(!err.contains("not-the-right-secret"), "{err}");
}

/// A read-only token with `--write-back` is refused at link time, naming
/// what it may not do; a write-back that fails later says this sync's
/// records are in, not that the store holds only earlier syncs'.
#[test]
fn write_back_without_the_right_to_write_is_said_plainly() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (db, store) = store_with_person(dir.path(), "ro.db", &files);
    drop(store);
    let mut child = abba()
        .args(["link", "nightscout", "--db"])
        .arg(&db)
        .args([
            "--person",
            "ana",
            "--url",
            &srv.url,
            "--token",
            "-",
            "--write-back",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    writeln!(child.stdin.take().unwrap(), "reader-0123456789abcdef").unwrap();
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("may not create treatments") && err.contains("--write-back"),
        "{err}"
    );
    let mut store = abba_store::Store::open(&db).unwrap();
    assert!(store.link("ana").unwrap().is_none());
    // Stored directly (as a token whose rights were taken away later).
    let token = abba_nightscout::site::credential(Some("reader-0123456789abcdef"), None).unwrap();
    store.set_link("ana", &srv.url, &token, true).unwrap();
    drop(store);
    let sync = sync_cli(&db).output().unwrap();
    let err = String::from_utf8_lossy(&sync.stderr);
    assert!(!sync.status.success());
    assert!(
        err.contains("writing back failed for ana; this sync's records are in the store")
            && !err.contains("earlier syncs"),
        "{err}"
    );
    let store = abba_store::Store::open(&db).unwrap();
    assert!(!store.records("ana").unwrap().is_empty());
}

#[test]
fn a_sync_that_cannot_prove_it_read_everything_fails_without_advice() {
    // 2,500 treatments at one `created_at` on a server serving 1,000 a
    // page that ignores `sort[_id]` and the bounds on `_id`: nothing proves
    // the pages hold all of them. The sync fails (exit code nonzero),
    // names the key, imports nothing and prints no advice.
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    let at = d.treatments[3]["created_at"].as_str().unwrap().to_string();
    d.treatments.extend(one_instant(2500, &at));
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    srv.with(|s| {
        s.ignores_sort = true;
        s.ignores_id_bounds = true;
    });
    let (db, store) = store_with_person(dir.path(), "cli.db", &files);
    drop(store);
    assert!(link_cli(&db, &srv.url).status.success());
    let sync = sync_cli(&db).output().unwrap();
    let out = String::from_utf8_lossy(&sync.stdout);
    let err = String::from_utf8_lossy(&sync.stderr);
    assert!(!sync.status.success(), "{out}{err}");
    assert!(
        err.contains("cannot prove it read everything")
            && err.contains(&at)
            && err.contains("find[_id]"),
        "{err}"
    );
    assert!(!out.contains("Basal") && !out.contains("Synced"), "{out}");
    assert_eq!(state(&db), (Vec::new(), Vec::new()));
    // Where the server honours the bounds but not the order, the ranges of
    // `_id` read everything: the sync succeeds with the file import's records.
    srv.with(|s| s.ignores_id_bounds = false);
    let sync = sync_cli(&db).output().unwrap();
    assert!(
        sync.status.success(),
        "{}",
        String::from_utf8_lossy(&sync.stderr)
    );
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_eq!(state(&db).0, records(&imported));
}

/// A treatment uploaded late (dated 36 h before the newest, inserted
/// after the first sync): `abba sync` says so in words, not only in its
/// JSON report.
#[test]
fn sync_says_late_uploads_in_words() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (db, store) = store_with_person(dir.path(), "late.db", &files);
    drop(store);
    assert!(link_cli(&db, &srv.url).status.success());
    let first = sync_cli(&db).output().unwrap();
    assert!(first.status.success());
    assert!(!String::from_utf8_lossy(&first.stdout).contains("uploaded late"));
    let now = jiff::Timestamp::now().as_millisecond();
    srv.with(|s| {
        s.add(
            "treatments",
            vec![serde_json::json!({"_id": object_id(now, 1),
                "eventType": "Correction Bolus", "created_at": "2026-01-13T09:54:00.000Z",
                "insulin": 1.5, "enteredBy": "Careportal", "utcOffset": 60})],
        )
    });
    let two = sync_cli(&db).output().unwrap();
    let out = String::from_utf8_lossy(&two.stdout);
    assert!(two.status.success(), "{out}");
    let line = out
        .lines()
        .find(|l| l.starts_with("Synced"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(line.contains("uploaded late"), "{line}");
    let json = sync_cli(&db).arg("--json").output().unwrap();
    let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
    assert!(v["collections"][1]["late"].as_u64().unwrap() >= 1, "{v}");
}

#[test]
fn sync_killed_20_times_then_completed_gives_the_same_store() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(3);
    let files = export(dir.path(), &d);
    let srv = server(&d, 200);
    // Slow pages, so that the kills land in every phase of a sync.
    srv.with(|s| s.page_delay = Duration::from_millis(40));

    // The reference: one uninterrupted sync, which equals the file import.
    let (reference, s) = store_with_person(dir.path(), "reference.db", &files);
    drop(s);
    assert!(link_cli(&reference, &srv.url).status.success());
    // Its length, and when its import committed (the marks appear).
    let t0 = Instant::now();
    let mut child = sync_cli(&reference).spawn().unwrap();
    let conn = rusqlite::Connection::open(&reference).unwrap();
    let mut commit = None;
    while child.try_wait().unwrap().is_none() {
        let n: i64 = conn
            .query_row("SELECT count(*) FROM nightscout_mark", [], |r| r.get(0))
            .unwrap_or(0);
        if n > 0 && commit.is_none() {
            commit = Some(t0.elapsed());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let whole = t0.elapsed();
    let commit = commit.unwrap_or(whole);
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (want, want_marks) = state(&reference);
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_eq!(want, records(&imported));

    let (db, s) = store_with_person(dir.path(), "killed.db", &files);
    drop(s);
    assert!(link_cli(&db, &srv.url).status.success());
    // 20 kills at moments spread over a sync (one seed: the same moments
    // every run): the first 10 before the reference's commit (fetching,
    // reading, importing), the others over the whole of the last run that
    // completed (the later syncs, the overlap only, are shorter).
    let mut x: u64 = 0x2545_f491_4f6c_dd1d;
    let mut span = whole;
    let (mut killed, mut attempts, mut before_commit) = (0, 0, 0);
    while killed < 20 {
        attempts += 1;
        assert!(attempts <= 80, "only {killed} kills in {attempts} runs");
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        // (The first ten within the first half of the reference's time to
        // its commit: a run on a loaded machine may be faster than the
        // reference, and once one kill lands after a commit every later
        // run starts from the committed records, so a draw near the end
        // of the window could leave no kill before a commit at all.)
        let within = if killed < 10 { commit / 2 } else { span };
        let at = Duration::from_micros(x % (within.as_micros() as u64 + 1));
        let t = Instant::now();
        let mut child = sync_cli(&db).spawn().unwrap();
        std::thread::sleep(at);
        if child.try_wait().unwrap().is_none() {
            child.kill().unwrap(); // SIGKILL
            killed += 1;
        } else {
            span = t.elapsed();
        }
        child.wait().unwrap();
        // Whole or absent: the records and the marks of a sync commit together.
        let (got, marks) = state(&db);
        if got.is_empty() {
            assert!(marks.is_empty(), "marks without records");
            before_commit += 1;
        } else {
            assert_eq!(got, want, "a killed sync left part of its records");
            assert_eq!(marks, want_marks);
        }
    }
    assert!(before_commit > 0, "no kill landed before the first commit");
    let out = sync_cli(&db).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(state(&db), (want, want_marks));
    assert!(whole < Duration::from_secs(60), "a sync took {whole:?}");
}

#[test]
fn serve_syncs_every_linked_person_in_the_background() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (db, s) = store_with_person(dir.path(), "serve.db", &files);
    drop(s);
    assert!(link_cli(&db, &srv.url).status.success());
    let too_often = abba()
        .args(["serve", "--db"])
        .arg(&db)
        .args(["--listen", "127.0.0.1:0", "--sync-every", "10s"])
        .output()
        .unwrap();
    assert!(!too_often.status.success());
    assert!(String::from_utf8_lossy(&too_often.stderr).contains("at least 1m"));
    let token = abba()
        .args(["token", "--db"])
        .arg(&db)
        .args(["--person", "ana"])
        .output()
        .unwrap();
    let token = String::from_utf8_lossy(&token.stdout).trim().to_string();
    // The service's log in a file, to say why if the sync does not come.
    let log = dir.path().join("serve.stderr");
    let mut child = abba()
        .args(["serve", "--db"])
        .arg(&db)
        .args(["--listen", "127.0.0.1:0", "--sync-every", "5m"])
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let mut line = String::new();
    let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
    std::io::BufRead::read_line(&mut out, &mut line).unwrap();
    // What it prints next is read too (the service does not need it: see
    // serve_output.rs).
    std::thread::spawn(move || std::io::copy(&mut out, &mut std::io::sink()));
    let addr = line
        .split("http://")
        .nth(1)
        .unwrap_or_else(|| panic!("{line:?}: {}", std::fs::read_to_string(&log).unwrap()))
        .split_whitespace()
        .next()
        .unwrap()
        .to_string();
    // The link as the background sync records it, read on a read-only
    // connection (which takes no lock a writer waits for).
    let read_link = || -> Option<(Option<String>, Option<String>, Option<String>)> {
        let conn =
            rusqlite::Connection::open_with_flags(&db, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
                .ok()?;
        conn.query_row(
            "SELECT last_sync_at, last_success_at, last_error FROM nightscout_link",
            [],
            |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
        )
        .ok()
    };
    // A wait for an event, not a timing: generous, so that a loaded
    // machine does not fail it.
    let t0 = Instant::now();
    let synced = loop {
        match read_link() {
            Some(l) if l.0.is_some() => break l,
            _ if t0.elapsed() > Duration::from_secs(300) => {
                panic!(
                    "no background sync in {:?}; the service said: {}",
                    t0.elapsed(),
                    std::fs::read_to_string(&log).unwrap()
                )
            }
            _ => std::thread::sleep(Duration::from_millis(100)),
        }
    };
    assert!(
        synced.1.is_some(),
        "{synced:?}; the service said: {}",
        std::fs::read_to_string(&log).unwrap()
    );
    let store = abba_store::Store::open(&db).unwrap();
    assert!(!store.records("ana").unwrap().is_empty());
    // The service shows the last sync on the person's advice.
    let mut conn = std::net::TcpStream::connect(&addr).unwrap();
    write!(
        conn,
        "GET /v1/persons/1/advice HTTP/1.1\r\nHost: {addr}\r\nAuthorization: Bearer {token}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut answer = String::new();
    std::io::Read::read_to_string(&mut conn, &mut answer).unwrap();
    let _ = child.kill();
    let _ = child.wait();
    let body = answer.split("\r\n\r\n").nth(1).unwrap_or("");
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    let v: serde_json::Value = serde_json::from_str(body).unwrap();
    assert_eq!(v["nightscout"]["url"], srv.url.as_str(), "{v}");
    assert!(v["nightscout"]["last_success_at"].is_string(), "{v}");
    assert!(v["nightscout"].get("credential").is_none());
}
