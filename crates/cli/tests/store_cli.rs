//! `abba person new`, `import`, `advise`, `answer`, `history` from outside:
//! a first run, the notice on every human-readable output, errors that name
//! the file and field, and crash safety (SIGKILL during `abba import`).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;

use std::path::Path;
use std::process::Command;

use cli_common::abba;
use std::time::{Duration, Instant};

/// The output of `abba args`, which must succeed.
fn ok(args: &[&str]) -> String {
    cli_common::ok(&abba(args))
}

/// A fresh directory for `tag`, removed when dropped.
fn tmp(tag: &str) -> crate::cli_common::TmpPath {
    crate::cli_common::tmp_path(&format!("abba-store-cli-{tag}-"), "")
}

fn export(dir: &Path, name: &str, days: u32) -> Vec<String> {
    let out = dir.join(name);
    ok(&[
        "export",
        "--patient",
        "adult#002",
        "--days",
        &days.to_string(),
        "--tz",
        "Europe/Zurich",
        "--out",
        out.to_str().unwrap(),
    ]);
    ["entries.json", "treatments.json", "profile.json"]
        .iter()
        .map(|f| out.join(f).display().to_string())
        .collect()
}

const NOTICE: &str = "research software, not a medical device";
const CLINICIAN: &str = "belong with your clinician";

#[test]
fn a_first_run() {
    let dir = tmp("first");
    let db = dir.join("abba.db");
    let db = db.to_str().unwrap();
    let files = export(&dir, "ns", 12);
    let base = ["--db", db, "--person", "ana"];
    let text = ok(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "ana",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--basal",
        "1.0",
        "--carb-ratio",
        "10,12,11",
        "--basal-range",
        "0.8-1.2",
        "--carb-ratio-range",
        "8-14",
        "--basal-step",
        "0.01",
    ]);
    assert!(text.contains(NOTICE) && text.contains(CLINICIAN), "{text}");
    let mut import: Vec<&str> = vec!["import"];
    import.extend(base);
    import.extend(files.iter().map(String::as_str));
    // The export's pump profile (1.35 U/h, 8 g/U) differs from the values
    // given: the import stops with both, and nothing is imported.
    let out = abba(&import);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains("1.35")
            && err.contains("basal 1 U/h")
            && err.contains("--adopt-profile"),
        "{err}"
    );
    import.push("--keep-therapy");
    let text = ok(&import);
    assert!(
        text.contains("new records") && text.contains(NOTICE),
        "{text}"
    );
    let text = ok(&import);
    assert!(
        text.contains("Nothing new") && text.contains(NOTICE),
        "{text}"
    );
    let text = ok(&[&["advise"][..], &base].concat());
    assert!(text.contains(NOTICE) && text.contains(CLINICIAN), "{text}");
    assert!(text.contains("readings from"), "{text}");
    let json = ok(&[&["advise"][..], &base, &["--json"]].concat());
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["phase"]["phase"], "adapting");
    assert!(v["notice"].as_str().unwrap().contains(NOTICE));
    let basal = &v["settings"][0];
    // On this export ABBA's basal steps stay under the pump's 0.01 U/h
    // step (sub-step changes are carried, not lost): no answer is asked.
    // The answer path is then checked on the open suggestion it makes
    // when there is one.
    if basal["latest"]["status"] != "open" {
        assert_eq!(basal["latest"]["status"], "no_change", "{basal}");
        assert!(text.contains("smaller than one step"), "{text}");
        // `--accept` answers the open suggestions: refused when there is
        // none, done when a carb ratio's is open.
        let open = v["settings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|s| s["latest"]["status"] == "open");
        let out = abba(&[&["answer"][..], &base, &["--accept"]].concat());
        assert_eq!(
            out.status.success(),
            open,
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        let _ = std::fs::remove_dir_all(&dir);
        return;
    }
    assert!(text.contains("waiting for your answer"), "{text}");
    // Outside the clinician's bounds: refused, naming the flag.
    let out = abba(&[&["answer"][..], &base, &["--set", "basal=2.5"]].concat());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--set basal") && err.contains("bounds"),
        "{err}"
    );
    let text = ok(&[&["answer"][..], &base, &["--set", "basal=0.95"]].concat());
    assert!(
        text.contains("overridden") && text.contains(NOTICE),
        "{text}"
    );
    let text = ok(&[&["answer"][..], &base, &["--accept"]].concat());
    assert!(text.contains("accepted"), "{text}");
    let out = abba(&[&["answer"][..], &base, &["--reject"]].concat());
    assert!(
        !out.status.success() && String::from_utf8_lossy(&out.stderr).contains("nothing to answer")
    );
    let json = ok(&[&["advise"][..], &base, &["--json"]].concat());
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["settings"][0]["in_force"], 0.95);
    let text = ok(&[&["history"][..], &base].concat());
    assert!(
        text.contains(NOTICE) && text.contains("overridden") && text.contains("superseded"),
        "{text}"
    );
    let json = ok(&[&["history"][..], &base, &["--json"]].concat());
    let rows: Vec<serde_json::Value> = serde_json::from_str(&json).unwrap();
    assert!(rows
        .iter()
        .any(|r| r["status"] == "overridden" && r["in_force"] == 0.95));
    let _ = std::fs::remove_dir_all(&dir);
}

/// README.md's first run, command by command: the therapy in force is
/// the exported pump profile's, suggestions are on the pump's steps, the
/// clinician's change is in force at once.
#[test]
fn the_readmes_first_run_puts_the_pumps_profile_in_force() {
    let dir = tmp("readme");
    let db = dir.join("ana.db");
    let db = db.to_str().unwrap();
    let files = export(&dir, "ns", 12);
    let profile = files[2].as_str();
    let base = ["--db", db, "--person", "ana"];
    let created = ok(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "ana",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--therapy-from",
        profile,
        "--basal-range",
        "1.0-1.7",
        "--carb-ratio-range",
        "6-12",
    ]);
    let mut import: Vec<&str> = vec!["import"];
    import.extend(base);
    import.extend(files.iter().map(String::as_str));
    ok(&import);
    let json = ok(&[&["advise"][..], &base, &["--json"]].concat());
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    // What the exported profile says (adult#002's standard therapy).
    let p: serde_json::Value = serde_json::from_slice(&std::fs::read(profile).unwrap()).unwrap();
    // The profile's start, told on the person's clock (not as a UTC instant).
    let since: jiff::Timestamp = p[0]["startDate"].as_str().unwrap().parse().unwrap();
    let zurich = jiff::tz::TimeZone::get("Europe/Zurich").unwrap();
    let local = since
        .to_zoned(zurich)
        .strftime("%Y-%m-%d %H:%M %Z")
        .to_string();
    assert!(
        created.contains(&format!("in force since {local})")),
        "{created}"
    );
    let store = &p[0]["store"]["abba"];
    let basal = store["basal"][0]["value"].as_f64().unwrap();
    let cr = store["carbratio"][0]["value"].as_f64().unwrap();
    let s = &v["settings"];
    let first = |i: usize| -> f64 {
        // The value in force before the first suggestion of the log.
        s[i]["latest"]["previous"]
            .as_f64()
            .unwrap_or(s[i]["in_force"].as_f64().unwrap())
    };
    let history = ok(&[&["history"][..], &base, &["--json"]].concat());
    let rows: Vec<serde_json::Value> = serde_json::from_str(&history).unwrap();
    let start = |k: &str| {
        rows.iter().find(|r| r["setting"] == k).unwrap()["previous"]
            .as_f64()
            .unwrap()
    };
    assert_eq!(start("basal"), basal, "{json}");
    assert_eq!(start("breakfast"), cr, "{json}");
    assert!((first(0) - basal).abs() <= basal * 0.05 + 1e-9);
    for r in &rows {
        let step = if r["setting"] == "basal" { 0.05 } else { 0.1 };
        let x = r["suggested"].as_f64().unwrap();
        assert!(((x / step).round() * step - x).abs() < 1e-9, "{r}");
    }
    let text = ok(&[
        &["therapy", "set"][..],
        &base,
        &["--basal", "1.3", "--carb-ratio", "8,8.5,8"],
    ]
    .concat());
    assert!(text.contains(NOTICE), "{text}");
    // A change dated as a UTC instant is told on the person's clock.
    let text = ok(&[
        &["therapy", "set"][..],
        &base,
        &["--carb-ratio", "8,8.5,8", "--at", "2026-01-10T11:00:00Z"],
    ]
    .concat());
    assert!(
        text.contains("in force from 2026-01-10 12:00 CET") && !text.contains("11:00:00Z"),
        "{text}"
    );
    let json = ok(&[&["advise"][..], &base, &["--json"]].concat());
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["settings"][0]["in_force"], 1.3, "{json}");
    assert_eq!(v["settings"][2]["in_force"], 8.5, "{json}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn errors_name_the_file_and_field() {
    let dir = tmp("errors");
    let db = dir.join("abba.db");
    let db = db.to_str().unwrap();
    let out = abba(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "ana",
        "--tz",
        "Mars/Olympus",
        "--mode",
        "cgm",
        "--basal",
        "1",
        "--carb-ratio",
        "10,10,10",
    ]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("--tz"));
    let out = abba(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "ana",
        "--tz",
        "UTC",
        "--mode",
        "cgm",
        "--basal",
        "1",
        "--carb-ratio",
        "10,10",
    ]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("--carb-ratio"));
    ok(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "ana",
        "--tz",
        "UTC",
        "--mode",
        "smbg",
        "--basal",
        "1",
        "--carb-ratio",
        "10,10,10",
    ]);
    let bad = dir.join("entries.json");
    std::fs::write(&bad, r#"[{"_id":"1","type":"sgv","sgv":120,"date":1777860000000},{"_id":"2","type":"sgv","sgv":"lots","date":1777860300000}]"#).unwrap();
    let out = abba(&[
        "import",
        "--db",
        db,
        "--person",
        "ana",
        bad.to_str().unwrap(),
    ]);
    // The unreadable item is left out and reported; the other is imported.
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success()
            && said.contains("Imported 1 new record ")
            && said.contains("entries.json: $[1], field \"sgv\""),
        "{said}"
    );
    let out = abba(&["advise", "--db", db, "--person", "nobody"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("nobody"));
    let _ = std::fs::remove_dir_all(&dir);
}

fn check(db: &Path, allowed: &[i64]) -> i64 {
    let conn = rusqlite::Connection::open(db).unwrap();
    let ok: String = conn
        .query_row("PRAGMA integrity_check", [], |r| r.get(0))
        .unwrap();
    assert_eq!(ok, "ok");
    let mut st = conn.prepare("SELECT i.records_added, (SELECT count(*) FROM record r WHERE r.import_id = i.id) FROM import i").unwrap();
    let rows: Vec<(i64, i64)> = st
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .collect::<Result<_, _>>()
        .unwrap();
    for (added, present) in &rows {
        assert!(
            *added > 0 && added == present,
            "an import is partly present: {added} recorded, {present} present"
        );
    }
    let orphans: i64 = conn
        .query_row(
            "SELECT count(*) FROM record WHERE import_id NOT IN (SELECT id FROM import)",
            [],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(orphans, 0);
    let n: i64 = conn
        .query_row("SELECT count(*) FROM record", [], |r| r.get(0))
        .unwrap();
    assert!(
        allowed.contains(&n),
        "{n} records: not one of the whole imports {allowed:?}"
    );
    n
}

/// Kills `abba import` with SIGKILL at pseudo-random points, 40 times
/// (bounded: each import takes a fraction of a second), checking after
/// each kill that the file passes `PRAGMA integrity_check` and that every
/// import is wholly present or wholly absent.
#[test]
fn sigkill_during_import_leaves_whole_imports_only() {
    const KILLS: u32 = 40;
    let dir = tmp("kill");
    let small = export(&dir, "small", 20);
    let big = export(&dir, "big", 30);
    // A person "p" in a new store (CGM, 1 U/h, 10 g/U).
    let new_person = |db: &str, tz: &str| {
        ok(&[
            "person",
            "new",
            "--db",
            db,
            "--name",
            "p",
            "--tz",
            tz,
            "--mode",
            "cgm",
            "--basal",
            "1",
            "--carb-ratio",
            "10,10,10",
        ]);
    };
    // Reference counts from clean imports.
    let count = |files: &[String]| -> i64 {
        let db = dir.join(format!("ref{}.db", files.len() + files[0].len()));
        let db = db.to_str().unwrap().to_string();
        new_person(&db, "Europe/Zurich");
        // The store keeps its values (the export's profile says 1.35 U/h).
        let mut a = vec![
            "import",
            "--db",
            &db,
            "--person",
            "p",
            "--json",
            "--keep-therapy",
        ];
        a.extend(files.iter().map(String::as_str));
        let v: serde_json::Value = serde_json::from_str(&ok(&a)).unwrap();
        v["added"].as_i64().unwrap()
    };
    let n_small = count(&small);
    let n_big = count(&big);
    let db = dir.join("abba.db");
    let dbs = db.to_str().unwrap().to_string();
    new_person(&dbs, "Europe/Zurich");
    // How long a whole import of the big export takes (process included):
    // the fastest of three, so that one import slowed by the other tests
    // running beside this one does not push most kills past the end.
    let mut full = u64::MAX;
    for i in 0..3 {
        let probe = dir.join(format!("probe{i}.db"));
        let probe = probe.to_str().unwrap().to_string();
        new_person(&probe, "UTC");
        let mut a = vec![
            "import",
            "--db",
            probe.as_str(),
            "--person",
            "p",
            "--keep-therapy",
        ];
        a.extend(big.iter().map(String::as_str));
        let t = Instant::now();
        ok(&a);
        full = full.min(t.elapsed().as_micros() as u64);
    }
    let allowed = [0, n_small, n_big];
    let mut seed: u64 = 0x5eed;
    let (mut interrupted, mut completed) = (0, 0);
    let mut last = 0;
    for k in 0..KILLS {
        let files = if k % 2 == 0 { &small } else { &big };
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let delay = Duration::from_micros((seed >> 20) % (full * 3 / 2 + 1));
        let mut child = Command::new(env!("CARGO_BIN_EXE_abba"))
            .args(["import", "--db", &dbs, "--person", "p", "--keep-therapy"])
            .args(files)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(delay);
        child.kill().unwrap(); // SIGKILL
        let status = child.wait().unwrap();
        let n = check(&db, &allowed);
        if status.success() || n != last {
            completed += 1;
        } else {
            interrupted += 1;
        }
        last = n;
        // Start over now and then so that imports keep having work to do.
        if k % 8 == 7 {
            let conn = rusqlite::Connection::open(&db).unwrap();
            conn.execute_batch("DELETE FROM record; DELETE FROM import;")
                .unwrap();
            last = 0;
        }
    }
    eprintln!("{KILLS} SIGKILLs: {interrupted} killed `abba import` before it finished, {completed} came after it had finished");
    assert!(
        interrupted >= 5,
        "only {interrupted} kills interrupted an import"
    );
    // A clean import afterwards completes the log.
    let mut a = vec!["import", "--db", dbs.as_str(), "--person", "p"];
    a.extend(big.iter().map(String::as_str));
    ok(&a);
    assert_eq!(check(&db, &allowed), n_big);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn advise_counts_down_the_first_week_in_words() {
    let dir = tmp("first-week");
    let files = export(&dir, "x", 9);
    // Keep the export's first three days (Nightscout's `date` in ms): two
    // whole local days in Zurich.
    let first: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(&files[0]).unwrap()).unwrap();
    let start = first
        .iter()
        .map(|e| e["date"].as_i64().unwrap())
        .min()
        .unwrap();
    let cut = start + 3 * 86_400_000 - 1;
    for f in &files[..2] {
        let docs: Vec<serde_json::Value> =
            serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap();
        let kept: Vec<&serde_json::Value> = docs
            .iter()
            .filter(|d| {
                d["date"]
                    .as_i64()
                    .or_else(|| {
                        d["created_at"]
                            .as_str()
                            .and_then(|t| t.parse::<jiff::Timestamp>().ok())
                            .map(|t| t.as_millisecond())
                    })
                    .is_none_or(|ms| ms <= cut)
            })
            .collect();
        std::fs::write(f, serde_json::to_string(&kept).unwrap()).unwrap();
    }
    let db = dir.join("p.db");
    let db = db.to_str().unwrap();
    ok(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "fw",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--therapy-from",
        &files[2],
    ]);
    ok(&["import", "--db", db, "--person", "fw", &files[0], &files[1]]);
    let text = ok(&["advise", "--db", db, "--person", "fw"]);
    assert!(
        text.contains("First week: 2 day(s) collected, 5 to go"),
        "{text}"
    );
    assert!(text.contains(NOTICE), "{text}");
}

/// Runs `abba ARGS`, which must fail with `needle` in its error.
fn refused(args: &[&str], needle: &str) {
    let out = abba(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains(needle), "{err}");
}

/// Every flag a reader's error names is one `abba import` takes: a
/// LibreView export whose dates do not tell their order (a FreeStyle
/// Libre 2 reader's file of the first days of a month, day-first) and a
/// Nightscout BG Check without `units` (AndroidAPS writes mmol/L ones).
#[test]
fn the_flags_an_import_error_names_are_flags_of_abba_import() {
    let dir = tmp("import-flags");
    let db = dir.join("abba.db");
    let db = db.to_str().unwrap();
    ok(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "lea",
        "--tz",
        "Europe/Budapest",
        "--mode",
        "cgm",
        "--basal",
        "0.9",
        "--carb-ratio",
        "10,12,11",
    ]);
    // A reader's file (the layout of LibreView's export, mmol/L), 2 to 6
    // June, one historic reading every 15 minutes.
    let mut csv =
        String::from("Glucose Data,Generated on,07-06-2022 10:00 UTC,Generated by,Someone\n");
    csv.push_str("Device,Serial Number,Device Timestamp,Record Type,Historic Glucose mmol/L,Scan Glucose mmol/L,Non-numeric Rapid-Acting Insulin,Rapid-Acting Insulin (units),Non-numeric Food,Carbohydrates (grams),Carbohydrates (servings),Non-numeric Long-Acting Insulin,Long-Acting Insulin Value (units),Notes,Strip Glucose mmol/L,Ketone mmol/L,Meal Insulin (units),Correction Insulin (units),User Change Insulin (units)\n");
    for day in 2..=6 {
        for q in 0..96 {
            let g = 6.0 + f64::from(q % 12) * 0.2;
            csv.push_str(&format!(
                "FreeStyle Libre 2,A1B2C3D4-0000-0000-0000-000000000001,{day:02}-06-2022 {:02}:{:02},0,{g:.1},,,,,,,,,,,,,,\n",
                q / 4,
                (q % 4) * 15
            ));
        }
    }
    let libre = dir.join("libre2.csv");
    std::fs::write(&libre, csv).unwrap();
    let libre = libre.to_str().unwrap();
    refused(
        &["import", "--db", db, "--person", "lea", libre],
        "--date-order",
    );
    let s = ok(&[
        "import",
        "--db",
        db,
        "--person",
        "lea",
        "--date-order",
        "day-first",
        libre,
    ]);
    assert!(s.contains("Imported 480 new records"), "{s}");
    let s = ok(&["advise", "--db", db, "--person", "lea"]);
    assert!(s.contains("from 2022-06-02"), "{s}");
    // A BG Check without units: refused, then read in the unit given.
    let treatments = dir.join("treatments.json");
    std::fs::write(
        &treatments,
        r#"[{"_id":"5f0000000000000000000001","eventType":"BG Check","glucose":5.5,"glucoseType":"Finger","created_at":"2022-06-06T10:02:00.000Z"}]"#,
    )
    .unwrap();
    let treatments = treatments.to_str().unwrap();
    refused(
        &["import", "--db", db, "--person", "lea", treatments],
        "--units",
    );
    let s = ok(&[
        "import", "--db", db, "--person", "lea", "--units", "mmol/L", treatments,
    ]);
    assert!(s.contains("Imported 1 new record "), "{s}");
    refused(
        &[
            "import",
            "--db",
            db,
            "--person",
            "lea",
            "--date-order",
            "sideways",
            libre,
        ],
        "expected day-first or month-first",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `person new --therapy-from` on AndroidAPS treatments whose last Profile
/// Switch (80 % for 2 h) is still running at the end: the person gets the
/// permanent profile, and the output says why the 80 % one was not taken.
#[test]
fn person_new_from_an_export_ending_in_a_temporary_profile_takes_the_permanent_one() {
    let dir = tmp("aaps-temporary");
    let db = dir.join("a.db");
    let treatments = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../io/tests/data/nightscout_treatments_aaps_profile_switch_synthetic.json"
    );
    let text = ok(&[
        "person",
        "new",
        "--db",
        db.to_str().unwrap(),
        "--name",
        "ida",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--therapy-from",
        treatments,
    ]);
    assert!(
        text.contains("basal schedule 00:00 0.8, 06:00 1, 12:00 0.9, 18:00 0.85 U/h")
            && text.contains("carb ratios 10/12/11 g/U"),
        "{text}"
    );
    assert!(
        text.contains("Note: A temporary profile")
            && text.contains("was still running at the end of the data")
            && text.contains("not taken as the person's settings"),
        "{text}"
    );
    // Kept with the person's settings, for the clinic's page.
    let p = abba_store::Store::open(&db).unwrap().person("ida").unwrap();
    assert!(
        p.settings.therapy_notes.len() == 1
            && p.settings.therapy_notes[0].starts_with("A temporary profile"),
        "{:?}",
        p.settings.therapy_notes
    );
}

/// `person new --therapy-from` on a MiniMed 780G export switching between
/// SmartGuard auto mode and manual mode: the manual days' schedule is the
/// therapy, the auto days are named, and the advice still sees a closed
/// loop (no basal advice).
#[test]
fn person_new_from_a_780g_switching_modes_takes_the_manual_schedule_and_keeps_the_loop() {
    let dir = tmp("780g-modes");
    let db = dir.join("m.db");
    let db = db.to_str().unwrap();
    let csv = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../io/tests/data/carelink_780g_mixed_modes_synthetic.csv"
    );
    let text = ok(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "mo",
        "--tz",
        "Europe/Berlin",
        "--mode",
        "cgm",
        "--therapy-from",
        csv,
    ]);
    assert!(
        text.contains("basal schedule 00:00 0.65, 06:00 0.9, 12:00 0.8, 20:00 0.7 U/h")
            && text.contains("the Basal Rate rows of 2026-03-12 (manual mode)")
            && text.contains("Note: ")
            && text.contains(
                "SmartGuard auto mode (a closed loop, MiniMed 780G MMT-1886) on 2026-03-09"
            ),
        "{text}"
    );
    ok(&["import", "--db", db, "--person", "mo", csv]);
    let json = ok(&["advise", "--db", db, "--person", "mo", "--json"]);
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["delivery"]["kind"], "closed_loop", "{json}");
}

/// `--age-group child`: the trial's defaults for children in the stored
/// advisor configuration, basal updates that learn from 02:00-07:00 in
/// CGM mode and say so; a group abba does not know is refused by name.
#[test]
fn a_child_gets_the_childrens_basal_hours() {
    let dir = tmp("child");
    let db = dir.join("kid.db");
    let db = db.to_str().unwrap();
    let files = export(&dir, "ns", 12);
    let new = |group: &str| {
        abba(&[
            "person",
            "new",
            "--db",
            db,
            "--name",
            "kid",
            "--tz",
            "Europe/Zurich",
            "--mode",
            "cgm",
            "--therapy-from",
            files[2].as_str(),
            "--age-group",
            group,
        ])
    };
    let out = new("toddler");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--age-group") && err.contains("child"),
        "{err}"
    );
    let text = cli_common::ok(&new("child"));
    assert!(
        text.contains("age group child: the basal rate learns from 02:00 to 07:00"),
        "{text}"
    );
    let store = abba_store::Store::open(Path::new(db)).unwrap();
    let p = store.person("kid").unwrap();
    assert_eq!(p.settings.age_group, abba_advisor::AgeGroup::Child);
    let f = &p.settings.advisor.features;
    assert_eq!(f.cgm_basal_window_min, Some([120, 420]));
    assert_eq!(f.smbg_basal_window_min, Some([0, 450]));
    drop(store);
    let base = ["--db", db, "--person", "kid"];
    let mut import: Vec<&str> = vec!["import"];
    import.extend(base);
    import.extend(files.iter().map(String::as_str));
    ok(&import);
    let history = ok(&[&["history"][..], &base, &["--json"]].concat());
    let rows: Vec<serde_json::Value> = serde_json::from_str(&history).unwrap();
    let basal: Vec<&serde_json::Value> = rows
        .iter()
        .filter(|r| r["setting"] == "basal" && r["no_update"] == false)
        .collect();
    assert!(!basal.is_empty(), "{history}");
    for r in basal {
        let data = r["data"].as_str().unwrap();
        assert!(
            data.contains(" 02:00 to ") && data.ends_with(" 07:00"),
            "{r}"
        );
        assert!(
            r["reasons"].as_array().unwrap().iter().any(|x| x
                == "The basal rate learns from the readings from 02:00 to 07:00 only: the advisor's defaults for children."),
            "{r}"
        );
    }
    let text = ok(&[&["advise"][..], &base].concat());
    assert!(text.contains("defaults for children"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The probe's import: a reading at -99999999999999 ms (year -1199) beside
/// a true one is refused with its place, the rest imported, and day 1 is the
/// true reading's date (no million day closings); `person new
/// --first-day` outside 1990-01-01..tomorrow is refused, naming the range.
#[test]
fn a_record_before_1990_is_refused_and_day_1_stays_true() {
    let dir = tmp("too-old");
    let db = dir.join("abba.db");
    let db = db.to_str().unwrap();
    let new = |name: &str, first_day: Option<&str>| {
        let mut a = vec![
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
            "1",
            "--carb-ratio",
            "10,10,10",
        ];
        if let Some(d) = first_day {
            a.extend(["--first-day", d]);
        }
        abba(&a)
    };
    for day in ["9999-12-31", "0001-01-01"] {
        let out = new("bo", Some(day));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success()
                && err.contains("--first-day")
                && err.contains("expected a date from 1990-01-01"),
            "{err}"
        );
    }
    let out = new("ana", None);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let file = dir.join("entries.json");
    std::fs::write(
        &file,
        r#"[{"sgv":120,"date":-99999999999999,"type":"sgv"},{"_id":"2","type":"sgv","sgv":130,"date":1777860000000}]"#,
    )
    .unwrap();
    let out = ok(&[
        "import",
        "--db",
        db,
        "--person",
        "ana",
        file.to_str().unwrap(),
    ]);
    assert!(
        out.contains("1 record dated before 1990-01-01")
            && out.contains("entries.json: $[0]")
            && out.contains("Day 1 of the advisor: 2026-05-04."),
        "{out}"
    );
}
