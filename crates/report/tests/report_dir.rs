//! The report folder is checked before a run, and a rerun replaces the
//! files abba wrote before (traces included) without touching others.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use abba_report::{ReportDir, ReportError, ReportFile, REPORT_FILES};

fn fresh(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("report_dir")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.parent().unwrap()).unwrap();
    dir
}

fn refused(path: &Path) -> String {
    match ReportDir::prepare(path) {
        Err(e @ (ReportError::OutDir { .. } | ReportError::OutDirIo { .. })) => e.to_string(),
        other => panic!("{}: expected a refusal, got {other:?}", path.display()),
    }
}

/// A minimal report: every file name, small contents, an abba manifest.
fn report(tag: &str) -> Vec<ReportFile> {
    REPORT_FILES
        .iter()
        .map(|name| ReportFile {
            name,
            bytes: if *name == "manifest.json" {
                format!("{{\"tool\": \"abba\", \"tag\": \"{tag}\"}}\n").into_bytes()
            } else {
                format!("{name} {tag}\n").into_bytes()
            },
        })
        .collect()
}

#[test]
fn a_new_folder_is_created_with_its_parents() {
    let dir = fresh("new").join("a/b");
    let out = ReportDir::prepare(&dir).unwrap();
    assert!(dir.is_dir());
    assert_eq!(out.path(), dir);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "no probe left");
}

#[test]
fn a_file_is_not_a_report_folder() {
    let file = fresh("afile");
    std::fs::write(&file, "mine").unwrap();
    let e = refused(&file);
    assert!(e.contains("afile") && e.contains("is not a folder"), "{e}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
    // Below a file, no folder can be created.
    let e = refused(&file.join("sub"));
    assert!(e.contains("cannot create it"), "{e}");
}

#[cfg(target_os = "linux")]
#[test]
fn a_folder_that_cannot_be_created_is_refused() {
    // /proc takes no new folders, not even from root.
    let e = refused(Path::new("/proc/abba-report-check"));
    assert!(
        e.contains("/proc/abba-report-check") && e.contains("cannot create it"),
        "{e}"
    );
}

#[cfg(unix)]
#[test]
fn a_read_only_folder_is_refused() {
    use std::os::unix::fs::PermissionsExt;
    let dir = fresh("read-only");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o555)).unwrap();
    // Root writes anyway: then there is nothing to refuse.
    let writable = std::fs::write(dir.join("x"), "").is_ok();
    let _ = std::fs::remove_file(dir.join("x"));
    let result = ReportDir::prepare(&dir);
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    if writable {
        eprintln!("running with write access to read-only folders (root): nothing to check");
        assert!(result.is_ok());
    } else {
        let e = result.unwrap_err().to_string();
        assert!(e.contains("cannot write into it"), "{e}");
    }
}

#[test]
fn a_folder_with_other_files_is_refused_and_left_alone() {
    let dir = fresh("foreign");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("thesis.tex"), "mine").unwrap();
    // A manifest.json that abba did not write does not make it a report.
    std::fs::write(dir.join("manifest.json"), "{\"tool\": \"other\"}").unwrap();
    let e = refused(&dir);
    assert!(
        e.contains("is not empty") && e.contains("thesis.tex") && e.contains("not an abba report"),
        "{e}"
    );
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
}

#[test]
fn a_rerun_replaces_what_abba_wrote_and_nothing_else() {
    let dir = fresh("rerun");
    let first = ReportDir::prepare(&dir).unwrap();
    first.write_report(&report("one")).unwrap();
    first
        .write_trace("adult-001-S1-abba", "csv\n", "{}\n")
        .unwrap();
    first
        .write_trace("adult-002-S1-abba", "csv\n", "{}\n")
        .unwrap();
    std::fs::write(dir.join("my-notes.txt"), "keep").unwrap();
    std::fs::write(dir.join("traces/plot.png"), "keep").unwrap();

    // The folder is now an abba report with other files in it: accepted.
    let again = ReportDir::prepare(&dir).unwrap();
    let written = again.write_report(&report("two")).unwrap();
    assert_eq!(written.len(), REPORT_FILES.len());
    for name in REPORT_FILES {
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        assert!(text.contains("two"), "{name}: {text}");
    }
    // The old traces are gone; files abba did not write stay.
    let mut traces: Vec<String> = std::fs::read_dir(dir.join("traces"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    traces.sort();
    assert_eq!(traces, ["plot.png"]);
    assert_eq!(
        std::fs::read_to_string(dir.join("my-notes.txt")).unwrap(),
        "keep"
    );

    // Without other files in it, traces/ itself goes.
    std::fs::remove_file(dir.join("traces/plot.png")).unwrap();
    again.write_trace("adult-003-S2-r2r", "csv\n", "").unwrap();
    again.write_report(&report("three")).unwrap();
    assert!(!dir.join("traces").exists());
}

#[test]
fn an_old_report_stays_until_the_new_one_is_written() {
    let dir = fresh("keep-until-written");
    ReportDir::prepare(&dir)
        .unwrap()
        .write_report(&report("old"))
        .unwrap();
    // Checking the folder for a new run removes nothing.
    ReportDir::prepare(&dir).unwrap();
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    assert!(text.contains("old"), "{text}");
}
