//! Every `abba` command README.md shows, taken from the README's own text
//! so that the README cannot rot:
//!
//! - each one is parsed by the real binary (its arguments, with `--help`
//!   appended: an unknown flag, a missing value or a value of the wrong
//!   type fails before the help is printed);
//! - the tour's and the first run's commands are run for real, in the
//!   README's order, in a fresh directory with the inputs the README
//!   names (a simulated export, the I/O tests' fixtures, a generated
//!   input file), and each must succeed;
//! - the rest are named below with why they are not run here and which
//!   test runs them, and a new README command that is in neither list
//!   fails this test.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;

use cli_common::abba;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A command of the README: its line and its arguments after `abba`.
#[derive(Debug, Clone)]
struct ReadmeCommand {
    line: usize,
    /// The `## ` heading it stands under.
    section: String,
    args: Vec<String>,
    /// `> FILE`: where the README sends its standard output.
    stdout_to: Option<String>,
}

impl ReadmeCommand {
    fn text(&self) -> String {
        format!("README.md:{}: abba {}", self.line, self.args.join(" "))
    }
    fn subcommand(&self) -> String {
        let mut words = self.args.iter().filter(|a| !a.starts_with('-'));
        let first = words.next().cloned().unwrap_or_default();
        match first.as_str() {
            "person" | "therapy" | "twin" | "store" => {
                format!("{first} {}", words.next().cloned().unwrap_or_default())
            }
            _ => first,
        }
    }
}

/// Commands that are parsed but not run here, with why and what runs them.
const NOT_RUN_HERE: &[(&str, &str)] = &[
    ("calibrate", "minutes of CPU; crates/trial/src/calibrate.rs tests a small calibration end to end"),
    ("twin fit", "the tour's abba.db is not made by the tour; crates/twin/tests/recovery.rs fits through the import path"),
    ("twin replay", "as twin fit; crates/twin/tests/recovery.rs"),
    ("autotune", "abba.db as above; crates/cli/tests/autotune_cli.rs runs both forms on oref0's own test day"),
    ("report", "abba.db as above; crates/cli/tests/report_cli.rs"),
    ("link", "needs a Nightscout site; crates/cli/tests/nightscout_cli.rs against the loopback server"),
    ("sync", "as link; crates/cli/tests/nightscout_cli.rs"),
    ("serve", "a long-running service; crates/cli/tests/serve_cli.rs, serve_output.rs"),
    ("token", "makes credentials for the service; crates/cli/tests/serve_cli.rs, nightscout_cli.rs"),
    ("app", "needs a running service; crates/cli/tests/app_cli.rs, app_e2e.rs"),
];

/// A trial that would take minutes here: the full four-arm trial.
fn is_full_autotune_trial(c: &ReadmeCommand) -> bool {
    c.subcommand() == "trial" && c.args.iter().any(|a| a.contains("autotune"))
}

/// Splits a shell line into words: single and double quotes, no
/// expansion (a `$VAR` stays as written, which is what a parse check
/// needs).
fn shell_words(s: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quote: Option<char> = None;
    let mut any = false;
    for ch in s.chars() {
        match quote {
            Some(q) if ch == q => quote = None,
            Some(_) => cur.push(ch),
            None if ch == '"' || ch == '\'' => {
                quote = Some(ch);
                any = true;
            }
            None if ch.is_whitespace() => {
                if any || !cur.is_empty() {
                    out.push(std::mem::take(&mut cur));
                    any = false;
                }
            }
            None => cur.push(ch),
        }
    }
    if any || !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// The part of a line before a `#` comment outside quotes.
fn without_comment(s: &str) -> &str {
    let mut quote: Option<char> = None;
    for (i, ch) in s.char_indices() {
        match quote {
            Some(q) if ch == q => quote = None,
            Some(_) => {}
            None if ch == '"' || ch == '\'' => quote = Some(ch),
            None if ch == '#' && (i == 0 || s[..i].ends_with(' ')) => return &s[..i],
            None => {}
        }
    }
    s
}

/// Every `abba ...` (or `cargo run ... -p abba -- ...`) command in the
/// README's shell blocks, continuation lines joined.
fn readme_commands(readme: &str) -> Vec<ReadmeCommand> {
    let mut out = Vec::new();
    let mut in_shell = false;
    let mut pending: Option<(usize, String)> = None;
    let mut section = String::new();
    for (i, raw) in readme.lines().enumerate() {
        let line_no = i + 1;
        let t = raw.trim();
        if let Some(h) = raw.strip_prefix("## ") {
            if !in_shell {
                section = h.trim().to_string();
            }
        }
        if let Some(lang) = t.strip_prefix("```") {
            in_shell = !in_shell && (lang == "sh" || lang == "bash");
            continue;
        }
        if !in_shell {
            continue;
        }
        let (start, mut text) = match pending.take() {
            Some((l, s)) => (l, s + " " + t),
            None => (line_no, t.to_string()),
        };
        if let Some(cont) = text.strip_suffix('\\') {
            pending = Some((start, cont.trim_end().to_string()));
            continue;
        }
        text = without_comment(&text).trim().to_string();
        if text.starts_with("abba()") {
            continue;
        }
        let rest = if let Some(r) = text.strip_prefix("abba ") {
            r.to_string()
        } else if let Some(pos) = text.find("-p abba -- ") {
            text[pos + "-p abba -- ".len()..].to_string()
        } else if text.ends_with("-p abba") && text.contains("cargo run") {
            String::new()
        } else {
            continue;
        };
        // `$(...)` and a trailing `&`.
        let rest = rest
            .trim()
            .trim_end_matches('&')
            .trim()
            .trim_end_matches(')');
        let (rest, stdout_to) = match rest.split_once(" > ") {
            Some((cmd, file)) => (cmd.to_string(), Some(file.trim().to_string())),
            None => (rest.to_string(), None),
        };
        let args = shell_words(&rest);
        if args.is_empty() {
            continue;
        }
        out.push(ReadmeCommand {
            line: start,
            section: section.clone(),
            args,
            stdout_to,
        });
    }
    out
}

fn readme() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md");
    std::fs::read_to_string(&path).expect("README.md beside the workspace")
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../io/tests/data")
        .join(name)
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("abba-readme-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn the_readme_shows_the_commands_this_test_knows() {
    let cmds = readme_commands(&readme());
    assert!(
        cmds.len() >= 35,
        "found only {} commands: {cmds:?}",
        cmds.len()
    );
    // The two set-up commands and the first run are among them.
    let has = |s: &str| cmds.iter().any(|c| c.args.join(" ") == s);
    assert!(has("trial"), "the main job");
    assert!(has("advise --db ana.db --person ana"));
    for c in &cmds {
        let sub = c.subcommand();
        assert!(
            runs_here(c)
                || NOT_RUN_HERE.iter().any(|(n, _)| *n == sub)
                || is_full_autotune_trial(c),
            "{}: a README command neither run here nor named in NOT_RUN_HERE",
            c.text()
        );
    }
}

#[test]
fn every_readme_command_parses() {
    for c in readme_commands(&readme()) {
        let mut args = c.args.clone();
        args.push("--help".into());
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = abba(&refs);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && stdout.contains("Usage: abba"),
            "{} does not parse: {}{}",
            c.text(),
            stdout,
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// The commands run for real: the tour's stand-alone ones and the first
/// run's file-based ones.
fn runs_here(c: &ReadmeCommand) -> bool {
    let sub = c.subcommand();
    let db_of = |c: &ReadmeCommand| {
        c.args
            .windows(2)
            .find(|w| w[0] == "--db")
            .map(|w| w[1].clone())
    };
    match sub.as_str() {
        "simulate" | "cohort" | "metrics" | "events" | "export" => true,
        "trial" => !is_full_autotune_trial(c),
        "person new" | "import" | "advise" | "answer" | "history" | "therapy set" => {
            db_of(c).as_deref() == Some("ana.db")
        }
        _ => false,
    }
}

/// A day of per-minute inputs: a 60 g breakfast and its bolus, basal
/// insulin throughout.
fn inputs_csv() -> String {
    let mut s = String::from("minute,cho_g_per_min,insulin_u_per_min\n");
    for m in 0..1440 {
        let cho = if (420..432).contains(&m) { 5.0 } else { 0.0 };
        let bolus = if m == 420 { 6.0 } else { 0.0 };
        s.push_str(&format!("{m},{cho},{}\n", 1.0 / 60.0 + bolus));
    }
    s
}

/// Fourteen days of 5-minute CGM readings from 2024-03-01 (mg/dL).
fn cgm_csv() -> String {
    let mut s = String::from("time,glucose\n");
    let start = jiff::civil::date(2024, 3, 1).at(0, 0, 0, 0);
    for i in 0..(14 * 288) {
        let t = start + jiff::Span::new().minutes(5 * i);
        let g = 140.0 + 40.0 * (i as f64 / 288.0 * std::f64::consts::TAU).sin();
        s.push_str(&format!("{},{g:.0}\n", t.strftime("%Y-%m-%d %H:%M")));
    }
    s
}

fn run_in(dir: &Path, c: &ReadmeCommand) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_abba"))
        .args(&c.args)
        .current_dir(dir)
        .env_remove("RUST_BACKTRACE")
        .output()
        .expect("run abba")
}

fn must_succeed(c: &ReadmeCommand, out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{} failed: {}{}",
        c.text(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_readmes_tour_and_first_run_run() {
    let dir = tmp("run");
    // The inputs the tour names, made or copied.
    std::fs::write(dir.join("my-inputs.csv"), inputs_csv()).unwrap();
    std::fs::write(dir.join("cgm.csv"), cgm_csv()).unwrap();
    for (from, to) in [
        ("clarity_export_synthetic.csv", "Clarity_Export.csv"),
        ("nightscout_entries_synthetic.json", "entries.json"),
        ("nightscout_treatments_synthetic.json", "treatments.json"),
        ("nightscout_profile_synthetic.json", "profile.json"),
    ] {
        std::fs::copy(fixture(from), dir.join(to)).unwrap();
    }
    let cmds: Vec<ReadmeCommand> = readme_commands(&readme())
        .into_iter()
        .filter(runs_here)
        .collect();
    // The first run's `ns/` is its own export (12 days of adult#002); the
    // tour's `export --out ns/` (14 days of adult#001) comes before it, so
    // the first run gets its own directory.
    let person_dir = dir.join("first-run");
    std::fs::create_dir_all(&person_dir).unwrap();
    let mut ran = 0;
    for c in &cmds {
        let here = if c.section.contains("first run") {
            &person_dir
        } else {
            &dir
        };
        if c.subcommand() == "answer" {
            answer_alternative(here, c);
            ran += 1;
            continue;
        }
        let out = run_in(here, c);
        must_succeed(c, &out);
        if let Some(file) = &c.stdout_to {
            std::fs::write(here.join(file), &out.stdout).unwrap();
        }
        ran += 1;
    }
    assert!(ran >= 20, "ran only {ran} commands");
    // What the README says these produce.
    for f in [
        "day.csv",
        "bg.csv",
        "adults20.csv",
        "day15.csv",
        "adults.csv",
        "ns/entries.json",
        "trial.json",
        "small/table1.md",
        "abba-out/report.html",
        "traced/traces/adult-003-S1-abba.csv",
    ] {
        assert!(dir.join(f).is_file(), "README names {f}: not made");
    }
    assert!(person_dir.join("ana.db").is_file());
    assert!(person_dir.join("ns/profile.json").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The README's three answers are alternatives (accept, keep, own values):
/// each is run on its own copy of the store as it is after `advise`. With
/// a suggestion waiting each must succeed; with none (a change below one
/// pump step asks nothing) each must say so and change nothing.
fn answer_alternative(dir: &Path, c: &ReadmeCommand) {
    let copy = dir.join(format!("answer-{}", c.line));
    std::fs::create_dir_all(&copy).unwrap();
    std::fs::copy(dir.join("ana.db"), copy.join("ana.db")).unwrap();
    let advise = Command::new(env!("CARGO_BIN_EXE_abba"))
        .args(["advise", "--db", "ana.db", "--person", "ana", "--json"])
        .current_dir(&copy)
        .output()
        .unwrap();
    let advice = String::from_utf8_lossy(&advise.stdout).replace(' ', "");
    let waiting = advice.contains("\"status\":\"open\"");
    let out = run_in(&copy, c);
    if waiting {
        must_succeed(c, &out);
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains("nothing to answer"),
            "{}: no suggestion waiting, and the error does not say so: {err}",
            c.text()
        );
    }
}
