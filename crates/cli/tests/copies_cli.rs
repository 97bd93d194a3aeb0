//! The same event reaching the store twice by different routes, through
//! `abba import` and `abba advise` (fixtures in `crates/io/tests/data`,
//! see its PROVENANCE.md): AndroidAPS's pump events uploaded again under
//! other documents after an NSClient reset are counted once across
//! imports; a CareLink export and the same pump's days in Nightscout give
//! each day's insulin from one source, whichever comes first, and say so.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;

use cli_common::abba;

fn ok(args: &[&str]) -> String {
    cli_common::ok(&abba(args))
}

fn data(name: &str) -> String {
    format!("{}/../io/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// A new person `name` in `tz` in the store `db`.
fn person(db: &str, name: &str, tz: &str) {
    ok(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        name,
        "--tz",
        tz,
        "--mode",
        "cgm",
        "--basal",
        "0.85",
        "--carb-ratio",
        "10,12,11",
    ]);
}

fn import(db: &str, name: &str, files: &[&str]) -> String {
    // The pump's profile is not what these tests are about.
    let mut args = vec!["import", "--db", db, "--person", name, "--keep-therapy"];
    args.extend_from_slice(files);
    let text = ok(&args);
    assert!(
        text.contains("research software, not a medical device"),
        "{text}"
    );
    text
}

/// The person's stored boluses (instant, units) and their bolus events
/// as the advisor's replay gets them.
fn boluses(db: &str, name: &str) -> (Vec<(jiff::Timestamp, f64)>, usize) {
    let store = abba_store::Store::open(std::path::Path::new(db)).unwrap();
    let records = store
        .records(name)
        .unwrap()
        .into_iter()
        .filter_map(|r| match r.kind {
            abba_io::RecordKind::Bolus { units } => Some((r.at, units.0)),
            _ => None,
        })
        .collect();
    let events = store
        .events(name)
        .unwrap()
        .iter()
        .filter(|e| matches!(e.kind, abba_core::EventKind::Bolus(_)))
        .count();
    (records, events)
}

/// CGM entries every 5 min over 2026-11-20 to 22 UTC, as xDrip+ uploads them.
fn entries() -> String {
    let start: i64 = 1_795_132_800_000; // 2026-11-20T00:00:00Z
    let items: Vec<String> = (0..(3 * 288))
        .map(|i| {
            let ms = start + i * 300_000;
            format!(
                "{{\"_id\":\"6740a1b2c3d4e5f6a7{i:06x}\",\"device\":\"xDrip-DexcomG6\",\"date\":{ms},\"sgv\":{},\"type\":\"sgv\"}}",
                110 + (i % 36) * 2
            )
        })
        .collect();
    format!("[{}]", items.join(",\n"))
}

#[test]
fn androidaps_events_uploaded_again_after_a_reset_are_counted_once_across_imports() {
    let dir = cli_common::tmp_path("abba-copies-aaps-", "");
    std::fs::create_dir_all(&*dir).unwrap();
    let db = dir.join("a.db");
    let db = db.to_str().unwrap();
    let e = dir.join("entries.json");
    std::fs::write(&e, entries()).unwrap();
    let before = data("nightscout_treatments_aaps_before_reset_synthetic.json");
    let after = data("nightscout_treatments_aaps_after_reset_synthetic.json");
    // The second upload alone: four boluses, none dropped by the reader.
    person(db, "alone", "Europe/Zurich");
    import(db, "alone", &[e.to_str().unwrap(), &after]);
    let (alone, _) = boluses(db, "alone");
    assert_eq!(alone.len(), 4, "{alone:?}");

    person(db, "lu", "Europe/Zurich");
    import(db, "lu", &[e.to_str().unwrap(), &before]);
    let (first, _) = boluses(db, "lu");
    assert_eq!(first.len(), 3, "{first:?}");
    let text = import(db, "lu", &[&after]);
    assert!(text.contains("Imported 1 new record"), "{text}");
    assert!(
        text.contains("3 records of the known records are copies of doses already stored"),
        "{text}"
    );
    let (both, events) = boluses(db, "lu");
    // Each pump event once: the three of the first upload and the new one.
    assert_eq!(both.len(), 4, "{both:?}");
    assert_eq!(events, 4);
    let total: f64 = both.iter().map(|b| b.1).sum();
    let alone_total: f64 = alone.iter().map(|b| b.1).sum();
    assert!((total - alone_total).abs() < 1e-9, "{total} {alone_total}");
    let advice: serde_json::Value =
        serde_json::from_str(&ok(&["advise", "--db", db, "--person", "lu", "--json"])).unwrap();
    assert_eq!(advice["data"]["events"]["bolus"], 4, "{}", advice["data"]);
    // The same files once more: nothing new.
    let again = import(db, "lu", &[&before, &after]);
    assert!(again.contains("Nothing new"), "{again}");
    assert_eq!(boluses(db, "lu").0.len(), 4);
}

#[test]
fn a_carelink_export_and_the_same_pump_in_nightscout_count_each_days_insulin_once() {
    let dir = cli_common::tmp_path("abba-copies-carelink-", "");
    std::fs::create_dir_all(&*dir).unwrap();
    let db = dir.join("a.db");
    let db = db.to_str().unwrap();
    let carelink = data("carelink_630g_us_synthetic.csv");
    let ns = data("nightscout_treatments_600series_synthetic.json");
    let tz = "America/Chicago";
    person(db, "cl", tz);
    import(db, "cl", &[&carelink]);
    let (pump, _) = boluses(db, "cl");
    person(db, "nsonly", tz);
    import(db, "nsonly", &[&ns]);
    let (uploaded, _) = boluses(db, "nsonly");
    assert_eq!(uploaded.len(), 7);
    let day = |t: jiff::Timestamp| t.to_zoned(jiff::tz::TimeZone::get(tz).unwrap()).date();
    let pump_days: std::collections::BTreeSet<_> = pump.iter().map(|b| day(b.0)).collect();
    let new_days = uploaded
        .iter()
        .filter(|b| !pump_days.contains(&day(b.0)))
        .count();
    assert_eq!(new_days, 1);

    // CareLink first, then Nightscout: the days CareLink holds keep its
    // insulin; Nightscout's bolus of another day is added.
    person(db, "a", tz);
    import(db, "a", &[&carelink]);
    let text = import(db, "a", &[&ns]);
    assert!(
        text.contains("6 insulin records from nightscout (2025-03-15 to 2025-03-16) not stored")
            && text.contains("those days' insulin comes from carelink")
            && text.contains(
                "carbohydrate records from nightscout (2025-03-15 to 2025-03-16) not stored"
            ),
        "{text}"
    );
    let (a, events) = boluses(db, "a");
    assert_eq!(a.len(), pump.len() + new_days, "{a:?}");
    assert_eq!(events, a.len());
    let advice: serde_json::Value =
        serde_json::from_str(&ok(&["advise", "--db", db, "--person", "a", "--json"])).unwrap();
    assert_eq!(
        advice["data"]["events"]["bolus"],
        a.len(),
        "{}",
        advice["data"]
    );

    // Nightscout first, then CareLink: the same count, never the sum.
    person(db, "b", tz);
    import(db, "b", &[&ns]);
    let text = import(db, "b", &[&carelink]);
    assert!(
        text.contains("insulin records from carelink (2025-03-15 to 2025-03-16) not stored")
            && text.contains("insulin comes from nightscout"),
        "{text}"
    );
    let (b, _) = boluses(db, "b");
    assert_eq!(b.len(), a.len(), "{b:?}");

    // Both in one import: the first file named holds the overlap.
    person(db, "c", tz);
    import(db, "c", &[&carelink, &ns]);
    assert_eq!(boluses(db, "c").0, a);
}

#[test]
fn a_dose_edited_in_the_app_between_two_clarity_exports_replaces_the_stored_one() {
    let dir = cli_common::tmp_path("abba-copies-clarity-", "");
    std::fs::create_dir_all(&*dir).unwrap();
    let db = dir.join("a.db");
    let db = db.to_str().unwrap();
    let first = data("clarity_g7_events_synthetic.csv");
    // The later export: renumbered (a row more before them) and the 4 U
    // event edited to 5 U; the other dose of that minute unchanged.
    let text = std::fs::read_to_string(&first).unwrap();
    let mut lines: Vec<String> = text.split("\r\n").map(String::from).collect();
    let edited = lines
        .iter()
        .position(|l| l.contains("\"Insulin\"") && l.contains(",\"4\","))
        .unwrap();
    lines[edited] = lines[edited].replace(",\"4\",", ",\"5\",");
    for l in lines.iter_mut().skip(1).filter(|l| !l.is_empty()) {
        let (index, rest) = l[1..].split_once('"').unwrap();
        *l = format!("\"{}\"{rest}", index.parse::<u32>().unwrap() + 1);
    }
    lines.insert(
        1,
        "\"1\",\"\",\"FirstName\",\"\",\"Anonymous\",\"\",\"\",\"\",\"\",\"\",\"\",\"\",\"\",\"\""
            .into(),
    );
    let later = dir.join("clarity_later.csv");
    std::fs::write(&later, lines.join("\r\n")).unwrap();
    let later = later.to_str().unwrap();

    person(db, "cl", "America/Chicago");
    import(db, "cl", &[&first]);
    let doses = |db: &str| -> Vec<f64> {
        let store = abba_store::Store::open(std::path::Path::new(db)).unwrap();
        let mut u: Vec<f64> = store
            .records("cl")
            .unwrap()
            .into_iter()
            .filter_map(|r| match r.kind {
                abba_io::RecordKind::Bolus { units } => Some(units.0),
                _ => None,
            })
            .collect();
        u.sort_by(f64::total_cmp);
        u
    };
    assert_eq!(doses(db), [1.5, 4.0]);
    let text = import(db, "cl", &[later]);
    assert!(
        text.contains("1 record of the newer versions are doses or carbohydrate edited"),
        "{text}"
    );
    // The edit replaced the 4 U; the other dose of the minute stayed.
    assert_eq!(doses(db), [1.5, 5.0]);
    // The later export again: nothing new.
    assert!(import(db, "cl", &[later]).contains("Nothing new"));
    assert_eq!(doses(db), [1.5, 5.0]);
}
