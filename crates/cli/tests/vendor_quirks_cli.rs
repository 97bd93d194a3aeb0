//! `abba import` on vendor exports' quirks, run as a user would: a
//! Tidepool export of a pump whose bolus wizard counts exchanges, and a
//! CareLink export across the autumn change whose pump kept summer time
//! until set by hand.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common::{abba, new_cgm_person, ok, tmp_path, TmpPath};

const IO_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../io/tests/data");

/// A fresh directory for `tag`, removed when dropped.
fn tmp(tag: &str) -> TmpPath {
    tmp_path(&format!("abba-vendor-quirks-{tag}-"), "")
}

/// A CGM person `name` in zone `tz` with a flat `basal` (U/h) and
/// 10 g/U, in store `db`.
fn new_person(db: &str, name: &str, tz: &str, basal: &str) {
    new_cgm_person(db, name, tz, basal, "10,10,10");
}

/// The `abba events --json` answer for `file` with `extra` flags.
fn events(file: &str, tz: &str, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["events", "--tz", tz, "--json", "--input", file];
    args.extend_from_slice(extra);
    serde_json::from_str(&ok(&abba(&args))).unwrap()
}

#[test]
fn a_tidepool_wizard_in_exchanges_is_imported_only_with_grams_per_exchange() {
    let dir = tmp("tidepool-exchanges");
    let db = dir.join("a.db");
    let db = db.to_str().unwrap();
    let file = format!("{IO_DATA}/tidepool_medtronic_exchanges_synthetic.json");
    new_person(db, "ana", "Europe/Madrid", "0.85");
    let text = ok(&abba(&["import", "--db", db, "--person", "ana", &file]));
    assert!(
        text.contains("2 bolus wizard records (`wizard`) in exchanges")
            && text.contains("--grams-per-exchange"),
        "{text}"
    );
    // No meal was read from them; with 12 g an exchange, 48 g and 66 g.
    let v = events(&file, "Europe/Madrid", &[]);
    assert_eq!(v["mapping"]["counts"].get("meal_announced"), None, "{v}");
    let v = events(&file, "Europe/Madrid", &["--grams-per-exchange", "12"]);
    let grams: Vec<f64> = v["records"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["kind"]["type"] == "carbs")
        .map(|r| r["kind"]["grams"].as_f64().unwrap())
        .collect();
    assert_eq!(grams, vec![48.0, 66.0], "{v}");
}

#[test]
fn a_carelink_pump_clock_set_back_after_the_autumn_change_imports_without_a_repeated_hour() {
    let dir = tmp("carelink-autumn");
    let db = dir.join("c.db");
    let db = db.to_str().unwrap();
    let file = format!("{IO_DATA}/carelink_780g_autumn_clock_synthetic.csv");
    ok(&abba(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "carl",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--therapy-from",
        &file,
        // The export has no dinner wizard event.
        "--carb-ratio",
        "10,12,12",
    ]));
    let text = ok(&abba(&["import", "--db", db, "--person", "carl", &file]));
    assert!(
        text.contains("the pump's clock was set from 2026-10-25T09:00:00 to 2026-10-25T08:00:00")
            && text.contains("at the offset it kept (UTC+02:00)"),
        "{text}"
    );
    // Every reading in a minute of its own: none rejected as a second
    // reading of a minute (as the repeated hour would be).
    let v = events(&file, "Europe/Zurich", &[]);
    assert_eq!(
        v["mapping"]["rejected"].as_array().map(Vec::len),
        Some(0),
        "{}",
        v["mapping"]
    );
}

#[test]
fn a_clarity_export_in_italian_imports_its_readings_below_and_above_the_range() {
    let dir = tmp("clarity-italian");
    let db = dir.join("i.db");
    let db = db.to_str().unwrap();
    let file = format!("{IO_DATA}/clarity_g7_italian_synthetic.csv");
    new_person(db, "paola", "Europe/Rome", "0.8");
    let text = ok(&abba(&["import", "--db", db, "--person", "paola", &file]));
    // "Basso" and "Alto" are the sensor's limits: no row left out.
    assert!(!text.contains("could not be read"), "{text}");
    let v = events(&file, "Europe/Rome", &[]);
    let censors: Vec<(String, f64)> = v["records"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["kind"]["type"] == "cgm")
        .filter(|r| r["kind"]["glucose"]["censor"] != "exact")
        .map(|r| {
            (
                r["kind"]["glucose"]["censor"].as_str().unwrap().to_string(),
                r["kind"]["glucose"]["mg_dl"].as_f64().unwrap(),
            )
        })
        .collect();
    let want: Vec<(String, f64)> = [
        ("below", 40.0),
        ("below", 40.0),
        ("above", 400.0),
        ("above", 400.0),
    ]
    .iter()
    .map(|(c, v)| (c.to_string(), *v))
    .collect();
    assert_eq!(censors, want, "{v}");
}

/// The SmartGuard export (2026-03-14, auto mode) with `manual_days` days
/// of manual mode after it (a basal rate row and a `BOLUS_WIZARD` bolus a
/// day), newest first at the top of its Pump section as CareLink writes.
fn smartguard_then_manual(manual_days: i64) -> String {
    let text = std::fs::read_to_string(format!("{IO_DATA}/carelink_780g_smartguard_synthetic.csv"))
        .unwrap();
    let header = text.lines().find(|l| l.starts_with("Index;")).unwrap();
    let names: Vec<&str> = header.split(';').collect();
    let col = |name: &str| names.iter().position(|h| h.starts_with(name)).unwrap();
    let mut rows = String::new();
    for d in (1..=manual_days).rev() {
        let day = jiff::civil::date(2026, 3, 14)
            .checked_add(jiff::Span::new().days(d))
            .unwrap()
            .strftime("%Y/%m/%d")
            .to_string();
        for (time, cells) in [
            (
                "12:20:10",
                vec![
                    ("Bolus Type", "Normal"),
                    ("Bolus Volume Selected", "4,0"),
                    ("Bolus Volume Delivered", "4,0"),
                    ("Bolus Source", "BOLUS_WIZARD"),
                ],
            ),
            ("06:00:00", vec![("Basal Rate", "0,900")]),
        ] {
            let mut r = vec![String::new(); names.len()];
            (r[0], r[1], r[2]) = ("0,00000".into(), day.clone(), time.into());
            for (name, v) in cells {
                r[col(name)] = v.into();
            }
            rows.push_str(&(r.join(";") + "\r\n"));
        }
    }
    let at = text.find(header).unwrap() + header.len();
    let at = at + text[at..].find('\n').unwrap() + 1;
    format!("{}{rows}{}", &text[..at], &text[at..])
}

/// `abba advise --json`'s delivery for a person in Berlin fed `csv`.
fn delivery_of(tag: &str, csv: &str) -> serde_json::Value {
    let dir = tmp(tag);
    std::fs::create_dir_all(&*dir).unwrap();
    let db = dir.join("s.db");
    let db = db.to_str().unwrap();
    let file = dir.join("carelink.csv");
    std::fs::write(&file, csv).unwrap();
    new_person(db, "sam", "Europe/Berlin", "0.8");
    ok(&abba(&[
        "import",
        "--db",
        db,
        "--person",
        "sam",
        "--keep-therapy",
        file.to_str().unwrap(),
    ]));
    let json = ok(&abba(&["advise", "--db", db, "--person", "sam", "--json"]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["delivery"].clone()
}

/// A MiniMed 780G whose SmartGuard ran until 2026-03-14 and then only
/// manual mode: 35 days after it the loop is past (advice given, its last
/// mark said: the daily auto insulin total, at the end of its day); 20
/// days after it, a closed loop.
#[test]
fn a_780g_back_in_manual_mode_for_more_than_28_days_is_advised_and_its_loop_said() {
    let v = delivery_of("smartguard-past", &smartguard_then_manual(35));
    assert_eq!(v["kind"], "open_loop", "{v}");
    assert_eq!(v["basal_suggestions"], true, "{v}");
    let words = v["evidence"].to_string();
    assert!(
        words.contains("a loop's automated deliveries or marks until 2026-03-14T22:59:59.999Z, before the last 28 days of the data: a past loop"),
        "{v}"
    );
    let v = delivery_of("smartguard-recent", &smartguard_then_manual(20));
    assert_eq!(v["kind"], "closed_loop", "{v}");
    assert_eq!(v["basal_suggestions"], false, "{v}");
}
