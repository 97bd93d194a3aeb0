//! `abba events`, `abba export` and `abba metrics` on device exports, run
//! as a user would.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;

use cli_common::{abba, ok};

const IO_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../io/tests/data");

fn nightscout() -> Vec<String> {
    ["entries", "treatments", "profile"]
        .iter()
        .map(|n| format!("{IO_DATA}/nightscout_{n}_synthetic.json"))
        .collect()
}

#[test]
fn events_prints_counts_ignored_kinds_and_the_meal_rule() {
    let files = nightscout();
    let mut args = vec!["events", "--tz", "Europe/Zurich", "--input"];
    args.extend(files.iter().map(String::as_str));
    let text = ok(&abba(&args));
    for part in [
        "research software",
        "\"cgm\": 859",
        "\"meal_announced\": 11",
        "\"Sensor Start\": 1",
        "meal rule: carbohydrate entries are breakfast 05:00-10:30",
        "rejected: 0",
    ] {
        assert!(text.contains(part), "lacks {part}:\n{text}");
    }
    let mut listed = args.clone();
    listed.push("--list");
    let list = ok(&abba(&listed));
    assert!(
        list.contains("advisor events (day and local minute):")
            && list.contains("D1 00:00 Cgm(MgDl("),
        "{}",
        &list[..list.len().min(3000)]
    );
    args.push("--json");
    let v: serde_json::Value = serde_json::from_str(&ok(&abba(&args))).unwrap();
    assert_eq!(v["mapping"]["counts"]["cgm"], 859);
    assert_eq!(
        v["records"].as_array().unwrap().len(),
        859 + 3 + 11 + 11 + 3 + 1 + 2
    );
}

#[test]
fn events_needs_a_zone() {
    let files = nightscout();
    let out = abba(&["events", "--input", &files[0]]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--tz"));
}

#[test]
fn metrics_reads_a_clarity_export_and_reports_coverage() {
    let f = format!("{IO_DATA}/clarity_export_synthetic.csv");
    let text = ok(&abba(&["metrics", "--input", &f, "--tz", "Europe/Zurich"]));
    assert!(
        text.contains("3922 readings") && text.contains("coverage") && text.contains("longest gap"),
        "{text}"
    );
    assert!(
        text.contains("5 readings were reported only as Low/High"),
        "{text}"
    );
    // --from/--to keep the chosen local days only: 288 EGV rows are dated 1961-04-13.
    let one = ok(&abba(&[
        "metrics",
        "--input",
        &f,
        "--tz",
        "Europe/Zurich",
        "--from",
        "1961-04-13",
        "--to",
        "1961-04-13",
    ]));
    assert!(
        one.contains("288 readings from 1961-04-13T00:01:50"),
        "{one}"
    );
}

#[test]
fn export_writes_nightscout_that_events_reads_back() {
    let dir = std::env::temp_dir().join(format!("abba_export_cli_{}", std::process::id()));
    let d = dir.to_str().unwrap();
    let text = ok(&abba(&[
        "export",
        "--patient",
        "adult#002",
        "--days",
        "9",
        "--tz",
        "Europe/Zurich",
        "--start",
        "2026-02-02",
        "--out",
        d,
    ]));
    assert!(text.contains("research software"), "{text}");
    let files: Vec<String> = ["entries", "treatments", "profile"]
        .iter()
        .map(|n| format!("{d}/{n}.json"))
        .collect();
    let mut args = vec![
        "events",
        "--tz",
        "Europe/Zurich",
        "--first-day",
        "2026-02-02",
        "--json",
        "--input",
    ];
    args.extend(files.iter().map(String::as_str));
    let v: serde_json::Value = serde_json::from_str(&ok(&abba(&args))).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let counts = &v["mapping"]["counts"];
    // D2..D9 (the trial's shortest plan) at one CGM reading every 5 minutes.
    assert_eq!(counts["cgm"], 8 * 288, "{counts}");
    assert_eq!(counts["meal_announced"], 8 * 3, "{counts}");
    assert_eq!(v["mapping"]["rejected"].as_array().unwrap().len(), 0);
}

#[test]
fn metrics_reads_abbas_own_simulate_output() {
    let dir = std::env::temp_dir().join(format!("abba_sim_out_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out_csv = dir.join("day.csv");
    let f = out_csv.to_str().unwrap();
    ok(&abba(&[
        "simulate",
        "--patient",
        "adult#001",
        "--day",
        "standard",
        "--out",
        f,
    ]));
    // Plasma and subcutaneous glucose are both there: the user chooses.
    let both = abba(&["metrics", "--input", f]);
    assert!(!both.status.success());
    assert!(String::from_utf8_lossy(&both.stderr).contains("--glucose-column"));
    let v: serde_json::Value = serde_json::from_str(&ok(&abba(&[
        "metrics",
        "--input",
        f,
        "--glucose-column",
        "gs_mg_dl",
        "--json",
    ])))
    .unwrap();
    // The mean of the gs_mg_dl column, computed here from the file.
    let text = std::fs::read_to_string(&out_csv).unwrap();
    let col = text
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "gs_mg_dl")
        .unwrap();
    let gs: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect();
    std::fs::remove_dir_all(&dir).ok();
    let want = gs.iter().sum::<f64>() / gs.len() as f64;
    let mean = v["mean_mg_dl"].as_f64().unwrap();
    assert!((mean - want).abs() < 1e-6, "{mean} vs {want}");
}

#[test]
fn events_of_one_pump_by_two_routes_count_each_dose_once_and_say_what_was_set_aside() {
    let carelink = format!("{IO_DATA}/carelink_630g_us_synthetic.csv");
    let ns = format!("{IO_DATA}/nightscout_treatments_600series_synthetic.json");
    let run = |files: &[&str]| -> serde_json::Value {
        let mut args = vec!["events", "--tz", "America/Chicago", "--json", "--input"];
        args.extend_from_slice(files);
        serde_json::from_str(&ok(&abba(&args))).unwrap()
    };
    let units = |v: &serde_json::Value| -> f64 {
        v["records"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|r| r["kind"]["type"] == "bolus")
            .map(|r| r["kind"]["units"].as_f64().unwrap())
            .sum()
    };
    let pump = run(&[&carelink]);
    let both = run(&[&ns, &carelink]);
    // The files' order changes where each record was read, not the events
    // nor what was set aside.
    let other = run(&[&carelink, &ns]);
    assert!(both["mapping"]["events"] == other["mapping"]["events"]);
    assert!(both["set_aside"] == other["set_aside"]);
    // Nightscout adds only its bolus of 2025-03-17, a day the export does
    // not reach (07:35 in Chicago, 4.8 U).
    assert!((units(&both) - (units(&pump) + 4.8)).abs() < 1e-9);
    assert_eq!(both["set_aside"][0]["count"], 6, "{}", both["set_aside"]);
    let mut args = vec!["events", "--tz", "America/Chicago", "--input"];
    args.extend([carelink.as_str(), ns.as_str()]);
    let text = ok(&abba(&args));
    assert!(
        text.contains(
            "note: 6 insulin records from nightscout (2 days, 2025-03-15 to 2025-03-16) read, not used"
        ),
        "{text}"
    );
}

#[test]
fn metrics_of_one_sensor_by_two_routes_count_each_reading_once() {
    let dir = cli_common::tmp_path("abba-metrics-two-routes-", "");
    std::fs::create_dir_all(&*dir).unwrap();
    // 2026-05-04 in Zurich (UTC+2): Clarity's EGVs every 5 min, and the
    // same readings in Nightscout, uploaded 20 s later.
    let start = 1_777_845_600_000_i64; // 2026-05-04T00:00:00+02:00
    let mut clarity = String::from(
        "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID\r\n",
    );
    let mut entries = Vec::new();
    for k in 0..288_i64 {
        let g = 100 + (k * 7) % 90;
        clarity.push_str(&format!(
            "{},2026-05-04T{:02}:{:02}:00,EGV,,,,android G6,{g},,,,,{},8ABCDE\r\n",
            k + 1,
            k * 5 / 60,
            k * 5 % 60,
            4_000_000 + k * 300
        ));
        let ms = start + k * 300_000 + 20_000;
        entries.push(
            serde_json::json!({"_id": format!("{ms:024x}"), "type": "sgv", "sgv": g, "date": ms}),
        );
    }
    let c = dir.join("clarity.csv");
    let n = dir.join("entries.json");
    std::fs::write(&c, clarity).unwrap();
    std::fs::write(&n, serde_json::to_vec(&entries).unwrap()).unwrap();
    let (c, n) = (c.to_str().unwrap(), n.to_str().unwrap());
    let out = abba(&["metrics", "--tz", "Europe/Zurich", "--input", c, n]);
    let text = ok(&out);
    assert!(
        text.contains("288 readings from 2026-05-04T00:00"),
        "{text}"
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("288 CGM glucose records from nightscout (2026-05-04) read, not used: on that day clarity covers"),
        "{err}"
    );
}
