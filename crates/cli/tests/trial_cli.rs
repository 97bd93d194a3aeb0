//! `abba trial` end to end on a small trial: the report files, byte-identical
//! reruns, traces, and clear errors.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

use abba_trial::report::REPORT_FILES;

fn abba() -> Command {
    Command::new(env!("CARGO_BIN_EXE_abba"))
}

fn tmp(name: &str) -> crate::cli_common::TmpPath {
    crate::cli_common::tmp_path("abba-trial-cli-", name)
}

fn small_trial(out: &Path, threads: &str, extra: &[&str]) {
    let st = abba()
        .args([
            "trial",
            "--patients",
            "4",
            "--days",
            "16",
            "--scenarios",
            "S1,S3",
            "--quiet",
        ])
        .args(["--threads", threads, "--out"])
        .arg(out)
        .args(extra)
        .status()
        .unwrap();
    assert!(st.success());
}

#[test]
fn writes_the_report_and_reruns_byte_identical() {
    let (a, b) = (tmp("a"), tmp("b"));
    small_trial(&a, "1", &[]);
    small_trial(&b, "2", &[]);
    // Every file but the manifest, which records the run's wall time.
    for f in REPORT_FILES.into_iter().filter(|f| *f != "manifest.json") {
        let x = std::fs::read(a.join(f)).unwrap();
        let y = std::fs::read(b.join(f)).unwrap();
        assert!(!x.is_empty(), "{f} is empty");
        assert!(x == y, "{f} differs between a serial and a parallel run");
    }
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(a.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(manifest["seed"], 1);
    assert_eq!(manifest["knobs"]["abba"]["actor"]["theta_step_clip"], 0.01);
    assert!(manifest["run"]["wall_time_s"].is_number());
    // 4 patients x 2 scenarios x 3 arms x 2 weeks (W1, W2) + header.
    let rows = std::fs::read_to_string(a.join("patients.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 4 * 2 * 3 * 2);
}

#[test]
fn traces_every_minute_and_decision() {
    let out = tmp("traced");
    small_trial(&out, "0", &["--arms", "abba", "--trace", "adult#003"]);
    for s in ["S1", "S3"] {
        let csv =
            std::fs::read_to_string(out.join(format!("traces/adult-003-{s}-abba.csv"))).unwrap();
        assert_eq!(csv.lines().count(), 1 + 16 * 1440);
        let decisions =
            std::fs::read_to_string(out.join(format!("traces/adult-003-{s}-abba.decisions.jsonl")))
                .unwrap();
        // From D9 on: the basal update and three carb-ratio updates a day.
        assert!(
            decisions.lines().count() >= 4 * 7,
            "{s}: {} decisions",
            decisions.lines().count()
        );
        for line in decisions.lines() {
            let d: serde_json::Value = serde_json::from_str(line).unwrap();
            assert!(d["old"].is_number() && d["new"].is_number() && d["detail"].is_object());
        }
    }
}

#[test]
fn a_rerun_replaces_the_old_report_and_its_traces() {
    let out = tmp("rerun");
    small_trial(&out, "0", &["--arms", "standard", "--trace", "adult#002"]);
    assert!(out.join("traces/adult-002-S1-standard.csv").is_file());
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    small_trial(&out, "0", &["--arms", "standard"]);
    assert!(
        !out.join("traces").exists(),
        "traces of the first run are left in the new report"
    );
    assert!(out.join("summary.json").is_file());
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine"
    );
}

/// `abba trial` with the paper's full protocol (100 patients, 98 days, 12
/// arms: minutes of simulation) and `args`: it must fail at once, with a
/// message containing every one of `needles`, and never "File exists"
/// (what it said after a whole trial before the folder was checked first).
fn fails_before_the_run(args: &[&str], out: &Path, needles: &[&str]) {
    let result = abba()
        .args(["trial", "--quiet"])
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(
        !result.status.success(),
        "{args:?} {}: should fail",
        out.display()
    );
    for needle in needles {
        assert!(
            err.contains(needle),
            "{args:?}: expected {needle:?} in {err}"
        );
    }
    assert!(!err.contains("File exists"), "{err}");
}

#[test]
fn the_report_folder_and_traced_patients_are_checked_before_the_run() {
    let file = tmp("afile");
    std::fs::write(&file, "mine").unwrap();
    fails_before_the_run(&[], &file, &["afile", "is not a folder"]);
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");

    let foreign = tmp("foreign");
    std::fs::create_dir_all(&foreign).unwrap();
    std::fs::write(foreign.join("thesis.tex"), "mine").unwrap();
    fails_before_the_run(&[], &foreign, &["thesis.tex", "not an abba report"]);

    #[cfg(target_os = "linux")]
    fails_before_the_run(
        &[],
        Path::new("/proc/abba-trial-check"),
        &["/proc/abba-trial-check", "cannot create it"],
    );

    let untouched = tmp("never-created");
    fails_before_the_run(
        &["--trace", "adult#001,adult#101"],
        &untouched,
        &["no patient 'adult#101'", "adult#001 .. adult#100"],
    );
    assert!(!untouched.exists(), "a failed check created the folder");
}

#[test]
fn bad_options_are_clear_errors() {
    let cases: [(&[&str], &str); 4] = [
        (&["--scenarios", "S7"], "S7"),
        (&["--arms", "magic"], "magic"),
        (&["--days", "5"], "days"),
        (
            &["--patients", "3", "--days", "10", "--trace", "adult#099"],
            "adult#099",
        ),
    ];
    for (args, needle) in cases {
        let out = abba()
            .arg("trial")
            .args(args)
            .arg("--out")
            .arg(tmp("bad"))
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn the_defaults_are_the_paper_protocol() {
    let out = abba().args(["trial", "--print-config"]).output().unwrap();
    assert!(out.status.success());
    let c: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(c["seed"], 1);
    assert_eq!(c["population"], "adults");
    assert_eq!(c["patients"], 100);
    assert_eq!(c["days"], 98);
    assert_eq!(c["init_days"], 7);
    assert_eq!(c["scenarios"], serde_json::json!(["S1", "S2", "S3", "S4"]));
    assert_eq!(c["arms"], serde_json::json!(["abba", "standard", "r2r"]));
    // The printed configuration reads back as a configuration.
    let path = tmp("printed.json");
    std::fs::write(&path, &out.stdout).unwrap();
    let again = abba()
        .args(["trial", "--print-config", "--config"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(again.status.success());
    assert_eq!(again.stdout, out.stdout);
}

#[test]
fn a_population_brings_its_own_abba_defaults_unless_a_file_sets_them() {
    let window = |args: &[&str]| -> serde_json::Value {
        let out = abba().args(args).output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let c: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let f = &c["abba"]["features"];
        serde_json::json!([f["cgm_basal_window_min"], f["smbg_basal_window_min"]])
    };
    let adults = serde_json::json!([null, [-90, 450]]);
    let print = |p: &str| window(&["trial", "--print-config", "--population", p]);
    assert_eq!(print("adults"), adults);
    assert_eq!(
        print("adolescents"),
        serde_json::json!([[0, 420], [0, 450]])
    );
    assert_eq!(print("children"), serde_json::json!([[120, 420], [0, 450]]));
    assert_eq!(window(&["trial", "--print-config"]), adults);
    // A configuration file's knobs stay as written; the flag changes only
    // the cohort.
    let path = tmp("adult-defaults.json");
    let out = abba().args(["trial", "--print-config"]).output().unwrap();
    std::fs::write(&path, &out.stdout).unwrap();
    let p = path.to_str().unwrap();
    let args = [
        "trial",
        "--print-config",
        "--config",
        p,
        "--population",
        "children",
    ];
    assert_eq!(window(&args), adults);
}

#[test]
fn shards_and_merge_write_the_single_run_report() {
    let single = tmp("shard-single");
    small_trial(&single, "0", &[]);
    let parts = tmp("shard-parts");
    for i in 1..=3 {
        small_trial(&parts, "1", &["--shard", &format!("{i}/3")]);
    }
    let merged = tmp("shard-merged");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&parts)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert_eq!(files.len(), 3);
    let st = abba()
        .args(["trial", "merge", "--quiet", "--out"])
        .arg(&merged)
        .args(&files)
        .status()
        .unwrap();
    assert!(st.success());
    // Every file, the W1 block and report.html among them, but the manifest.
    for name in REPORT_FILES.into_iter().filter(|f| *f != "manifest.json") {
        let a = std::fs::read(single.join(name)).unwrap();
        let b = std::fs::read(merged.join(name)).unwrap();
        assert!(
            a == b,
            "{name} differs between the single run and the merge"
        );
    }
    // manifest.json differs only in its `run` section (wall time, threads).
    let read = |d: &Path| -> serde_json::Value {
        let mut v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("manifest.json")).unwrap()).unwrap();
        v.as_object_mut().unwrap().remove("run");
        v
    };
    assert_eq!(read(&single), read(&merged));
    // Two of three shards are refused, naming the missing one.
    let out = abba()
        .args(["trial", "merge", "--quiet", "--out"])
        .arg(tmp("shard-incomplete"))
        .args(&files[..2])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("shard 3/3 is missing"), "{err}");
}

#[test]
fn every_combination_of_scenarios_and_arms_runs() {
    // Issue 15 item 6: a set of scenarios all in one mode with the abba arm
    // used to panic on an empty list of first-week TE estimates.
    let scenarios = ["S1", "S2", "S3", "S4"];
    let arms = ["abba", "standard", "r2r"];
    for s_mask in 1u32..16 {
        let s: Vec<&str> = (0..4)
            .filter(|i| s_mask & (1 << i) != 0)
            .map(|i| scenarios[i])
            .collect();
        for a_mask in 1u32..8 {
            let a: Vec<&str> = (0..3)
                .filter(|i| a_mask & (1 << i) != 0)
                .map(|i| arms[i])
                .collect();
            let out = tmp(&format!("combo-{s_mask}-{a_mask}"));
            let run = abba()
                .args(["trial", "--patients", "1", "--days", "10", "--quiet"])
                .args(["--scenarios", &s.join(","), "--arms", &a.join(",")])
                .arg("--out")
                .arg(&out)
                .output()
                .unwrap();
            assert!(
                run.status.success(),
                "--scenarios {} --arms {}: {}",
                s.join(","),
                a.join(","),
                String::from_utf8_lossy(&run.stderr)
            );
            let summary: serde_json::Value =
                serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
            let arms_in_summary = summary["arms"]
                .as_object()
                .map(|m| m.len())
                .or_else(|| summary["arms"].as_array().map(|v| v.len()));
            assert_eq!(
                arms_in_summary,
                Some(s.len() * a.len()),
                "--scenarios {} --arms {}",
                s.join(","),
                a.join(",")
            );
        }
    }
}

#[test]
fn a_bad_configuration_fails_before_the_run_naming_file_and_field_once() {
    let mut c: serde_json::Value = serde_json::from_slice(
        &abba()
            .args(["trial", "--print-config"])
            .output()
            .unwrap()
            .stdout,
    )
    .unwrap();
    c["abba"]["critic"]["gamma"] = serde_json::json!(5);
    let path = tmp("gamma5.json");
    std::fs::write(&path, c.to_string()).unwrap();
    let out = tmp("gamma5-out");
    let run = abba()
        .args(["trial", "--quiet", "--config"])
        .arg(&path)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("gamma5.json"), "{err}");
    assert_eq!(err.matches("critic.gamma").count(), 1, "{err}");
    assert!(!out.exists(), "nothing should be written");
}
