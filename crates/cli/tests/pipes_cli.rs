//! A command that prints ends quietly when its reader goes away
//! (`abba events ... | head`): no panic message, exit 0 or the SIGPIPE
//! status, for every printing command tried here.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::io::Read;
use std::process::{Command, Stdio};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../io/tests/data");

/// Runs `abba args`, reads `keep` bytes of its output and closes the pipe;
/// returns the exit status and the standard error.
fn closed_early(args: &[&str], keep: usize) -> (std::process::ExitStatus, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_abba"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = child.stdout.take().unwrap();
    let mut buf = vec![0u8; keep];
    out.read_exact(&mut buf).unwrap();
    drop(out);
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (child.wait().unwrap(), err)
}

#[test]
fn printing_commands_end_quietly_when_the_reader_goes_away() {
    let entries = format!("{DATA}/nightscout_entries_synthetic.json");
    let clarity = format!("{DATA}/clarity_export_synthetic.csv");
    for args in [
        vec![
            "events",
            "--input",
            &entries,
            "--tz",
            "Europe/Zurich",
            "--list",
        ],
        vec![
            "events",
            "--input",
            &clarity,
            "--tz",
            "Europe/Zurich",
            "--json",
        ],
        vec!["cohort", "--size", "40", "--json"],
    ] {
        let (status, err) = closed_early(&args, 16);
        assert!(
            !err.contains("panicked") && !err.contains("Broken pipe"),
            "{args:?}: {err}"
        );
        #[cfg(unix)]
        {
            use std::os::unix::process::ExitStatusExt;
            assert!(
                status.success() || status.signal() == Some(13),
                "{args:?}: {status:?} {err}"
            );
        }
        #[cfg(not(unix))]
        let _ = status;
    }
}
