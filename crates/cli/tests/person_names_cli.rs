//! `abba person new --name`: the same rules as the service's
//! `POST /v1/persons` (one home, abba-store): trimmed, no control or
//! hidden characters, unique ignoring case; refusals name `--name`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;
use crate::service_common;

use cli_common::abba;
use service_common::TempDir;

fn person_new(db: &str, name: &str) -> (bool, String, String) {
    let out = abba(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        name,
        "--tz",
        "UTC",
        "--mode",
        "cgm",
        "--basal",
        "1.0",
        "--carb-ratio",
        "10,12,11",
    ]);
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

#[test]
fn names_are_checked_trimmed_and_unique_ignoring_case() {
    let dir = TempDir::new("person-names");
    let db = dir.0.join("store.db");
    let db = db.to_str().unwrap();
    for bad in [
        "\u{1b}[2J\u{1b}[Hcleared",
        "two\nlines",
        "rtl\u{202e}txt",
        "\t",
    ] {
        let (ok, _, err) = person_new(db, bad);
        assert!(!ok, "{bad:?} accepted");
        assert!(err.contains("--name"), "{bad:?}: {err}");
        // The refusal does not send the raw escape sequence to the terminal.
        assert!(!err.contains('\u{1b}'), "{bad:?}: {err}");
    }
    let (ok, _, err) = person_new(db, "  Zoë  ");
    assert!(ok, "{err}");
    let (ok, _, err) = person_new(db, "ZOË");
    assert!(
        !ok && err.contains("\"Zoë\"") && err.contains("ignoring case"),
        "{err}"
    );
    // Found by the trimmed name.
    let out = abba(&["advise", "--db", db, "--person", "Zoë"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
