//! `abba app` as a user runs it: against a running `abba serve`, with the
//! admin token; `--compare` checks the run against the in-process trial.
//! Bad input is refused before anything is created.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::service_common;

use abba_client::Client;
use service_common::{abba_bin, admin_token, Server, TempDir};
use std::process::Command;

fn app(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(abba_bin())
        .arg("app")
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn abba_app_runs_a_patient_through_the_service_and_compares() {
    let dir = TempDir::new("app-cli");
    let db = dir.0.join("abba.db");
    let token = admin_token(&db);
    let server = Server::start(&db);
    let url = server.url();
    let (ok, out, err) = app(&[
        "--url",
        &url,
        "--token",
        &token,
        "--patient",
        "adult#002",
        "--scenario",
        "S2",
        "--days",
        "12",
        "--name",
        "ben",
        "--compare",
    ]);
    assert!(ok, "stdout:\n{out}\nstderr:\n{err}");
    assert!(
        out.contains("research software, not a medical device"),
        "{out}"
    );
    assert!(out.contains("adult#002 (S2 smbg)"), "{out}");
    let line = out
        .lines()
        .find(|l| l.starts_with("compare:"))
        .unwrap_or_else(|| panic!("no compare line in\n{out}"));
    let n: usize = line.split_whitespace().nth(2).unwrap().parse().unwrap();
    assert!(n > 0, "{line}");
    assert!(line.ends_with("equal the in-process trial's"), "{line}");
    // The person exists in the service with what the run posted.
    let admin = Client::new(&url, Some(&token)).unwrap();
    let history = admin.history(1).unwrap();
    assert_eq!(history.suggestions.len(), n);

    // Refused with a reason: a name taken, a patient not in the cohort,
    // a URL this client cannot use, a wrong token.
    let (ok, _, err) = app(&[
        "--url", &url, "--token", &token, "--days", "9", "--name", "ben",
    ]);
    assert!(!ok && err.contains("409"), "{err}");
    let (ok, _, err) = app(&["--url", &url, "--token", &token, "--patient", "adult#999x"]);
    assert!(!ok && err.contains("no patient 'adult#999x'"), "{err}");
    let (ok, _, err) = app(&["--url", "https://127.0.0.1:1", "--token", &token]);
    assert!(!ok && err.contains("plain HTTP"), "{err}");
    let (ok, _, err) = app(&["--url", &url, "--token", "abba_nope", "--days", "9"]);
    assert!(!ok && err.contains("401"), "{err}");
}
