//! The same event reaching the store twice by different routes, through
//! `abba import` and `abba advise` (fixtures in `crates/io/tests/data`,
//! see its PROVENANCE.md): AndroidAPS's pump events uploaded again under
//! other documents after an NSClient reset are counted once across
//! imports; a CareLink export and the same pump's days in Nightscout are
//! both stored, and each day's insulin comes from the source that covers
//! it more fully, whichever came first, said with the import and the advice.
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
    cli_common::new_cgm_person(db, name, tz, "0.85", "10,12,11");
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

/// What a store holds and makes of person `name`'s log: every stored
/// record, the events' hash ([`abba_store::replay::events_hash`]), the
/// bolus events and their insulin (boluses of one minute are one event,
/// their units added), and `abba advise --json`.
struct Made {
    stored: Vec<abba_io::Record>,
    events_hash: String,
    bolus_events: usize,
    bolus_units: f64,
    advice: serde_json::Value,
}

fn made(db: &str, name: &str) -> Made {
    let store = abba_store::Store::open(std::path::Path::new(db)).unwrap();
    let events = store.events(name).unwrap();
    let advice =
        serde_json::from_str(&ok(&["advise", "--db", db, "--person", name, "--json"])).unwrap();
    Made {
        stored: store.records(name).unwrap(),
        events_hash: abba_store::replay::events_hash(&events),
        bolus_events: events
            .iter()
            .filter(|e| matches!(e.kind, abba_core::EventKind::Bolus(_)))
            .count(),
        bolus_units: events
            .iter()
            .map(|e| match e.kind {
                abba_core::EventKind::Bolus(u) => u.0,
                _ => 0.0,
            })
            .sum(),
        advice,
    }
}

/// The stored boluses of `m` on the local days (in `tz`) that `keep`
/// takes: how many, and their units.
fn stored_boluses(m: &Made, tz: &str, keep: impl Fn(jiff::civil::Date) -> bool) -> (usize, f64) {
    let zone = jiff::tz::TimeZone::get(tz).unwrap();
    m.stored
        .iter()
        .filter_map(|r| match r.kind {
            abba_io::RecordKind::Bolus { units } if keep(zone.to_datetime(r.at).date()) => {
                Some(units.0)
            }
            _ => None,
        })
        .fold((0, 0.0), |(n, u), b| (n + 1, u + b))
}

/// The sources whose insulin is used, by local day in `tz`
/// ([`abba_store::Store::used_records`]).
fn insulin_used(
    db: &str,
    name: &str,
    tz: &str,
) -> std::collections::BTreeMap<jiff::civil::Date, std::collections::BTreeSet<abba_io::Source>> {
    let store = abba_store::Store::open(std::path::Path::new(db)).unwrap();
    let zone = jiff::tz::TimeZone::get(tz).unwrap();
    let mut out: std::collections::BTreeMap<_, std::collections::BTreeSet<_>> = Default::default();
    for r in store.used_records(name).unwrap().records {
        if abba_store::one_source::DataClass::of(&r.kind)
            == Some(abba_store::one_source::DataClass::Insulin)
        {
            out.entry(zone.to_datetime(r.at).date())
                .or_default()
                .insert(r.source);
        }
    }
    out
}

/// `files` imported into a new store, person `p`, each list one import in
/// turn; the last import's output and what the store makes of the log.
fn imported(dir: &std::path::Path, db: &str, tz: &str, imports: &[&[&str]]) -> (String, Made) {
    let db = dir.join(db);
    let db = db.to_str().unwrap();
    person(db, "p", tz);
    let mut last = String::new();
    for files in imports {
        last = import(db, "p", files);
    }
    (last, made(db, "p"))
}

#[test]
fn a_carelink_export_and_the_same_pump_in_nightscout_count_each_days_insulin_once() {
    let dir = cli_common::tmp_path("abba-copies-carelink-", "");
    std::fs::create_dir_all(&*dir).unwrap();
    let carelink = data("carelink_630g_us_synthetic.csv");
    let ns = data("nightscout_treatments_600series_synthetic.json");
    let tz = "America/Chicago";
    // Each export alone.
    let (_, pump) = imported(&dir, "pump.db", tz, &[&[&carelink]]);
    let (_, uploaded) = imported(&dir, "ns.db", tz, &[&[&ns]]);
    let zone = jiff::tz::TimeZone::get(tz).unwrap();
    let pump_days: std::collections::BTreeSet<jiff::civil::Date> = pump
        .stored
        .iter()
        .filter(|r| matches!(r.kind, abba_io::RecordKind::Bolus { .. }))
        .map(|r| zone.to_datetime(r.at).date())
        .collect();
    let pump_all = stored_boluses(&pump, tz, |_| true);
    let ns_elsewhere = stored_boluses(&uploaded, tz, |d| !pump_days.contains(&d));
    assert_eq!(uploaded.bolus_events, 7);
    assert_eq!(ns_elsewhere.0, 1);

    // CareLink then Nightscout, Nightscout then CareLink, both in one
    // import: every record stored, the same events, the same advice.
    let (ab, a) = imported(&dir, "a.db", tz, &[&[&carelink], &[&ns]]);
    let (ba, b) = imported(&dir, "b.db", tz, &[&[&ns], &[&carelink]]);
    let (_, c) = imported(&dir, "c.db", tz, &[&[&ns, &carelink]]);
    for m in [&a, &b, &c] {
        assert_eq!(m.stored.len(), pump.stored.len() + uploaded.stored.len());
    }
    assert_eq!(a.stored, b.stored);
    assert_eq!(a.stored, c.stored);
    assert_eq!(a.events_hash, b.events_hash);
    assert_eq!(a.events_hash, c.events_hash);
    assert_eq!(a.advice, b.advice);
    assert_eq!(a.advice, c.advice);
    // Each dose once: the pump's, and Nightscout's bolus of another day
    // (boluses of one minute are one event: the units tell a dose counted
    // twice).
    assert_eq!(a.bolus_events, pump.bolus_events + ns_elsewhere.0);
    assert!((a.bolus_units - (pump_all.1 + ns_elsewhere.1)).abs() < 1e-9);
    assert!((pump.bolus_units - pump_all.1).abs() < 1e-9);
    assert_eq!(a.advice["data"]["events"]["bolus"], a.bolus_events);
    // The days both hold tie (three boluses each, the same span) and take
    // the pump's export (the fixed order's first); both orders say so.
    for text in [&ab, &ba] {
        assert!(
            text.contains(
                "6 insulin records from nightscout (2 days, 2025-03-15 to 2025-03-16) stored, \
                 not used: on those days carelink covers the insulin more fully and is used"
            ) && text.contains(
                "carbohydrate records from nightscout (2 days, 2025-03-15 to 2025-03-16) stored, not used"
            ),
            "{text}"
        );
    }
    let notes = a.advice["notes"].to_string();
    assert!(
        notes.contains(
            "6 insulin records from nightscout (2 days, 2025-03-15 to 2025-03-16) stored, not used"
        ),
        "{notes}"
    );

    // The same files once more: nothing new, nothing changed.
    let db = dir.join("a.db");
    let db = db.to_str().unwrap();
    let again = import(db, "p", &[&ns, &carelink]);
    assert!(again.contains("Nothing new"), "{again}");
    let after = made(db, "p");
    assert_eq!(after.stored, a.stored);
    assert_eq!(after.events_hash, a.events_hash);
}

/// The CareLink export cut at 10:00 of its last day (2025-03-16), as an
/// export made that morning.
fn carelink_until_ten(dir: &std::path::Path) -> String {
    let text = std::fs::read_to_string(data("carelink_630g_us_synthetic.csv")).unwrap();
    let kept: Vec<&str> = text
        .lines()
        .filter(|l| {
            let f: Vec<&str> = l.split(',').collect();
            !(f.len() > 2 && f[1] == "03/16/25" && f[2] > "10:00:00")
        })
        .collect();
    assert!(kept.len() < text.lines().count());
    let path = dir.join("carelink_until_ten.csv");
    std::fs::write(
        &path,
        kept.join("\n")
            .replace("03/16/25 23:59:59", "03/16/25 10:00:00"),
    )
    .unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn a_partial_export_beside_nightscouts_whole_day_uses_nightscout_that_day_only() {
    let dir = cli_common::tmp_path("abba-copies-partial-", "");
    std::fs::create_dir_all(&*dir).unwrap();
    let partial = carelink_until_ten(&dir);
    let ns = data("nightscout_treatments_600series_synthetic.json");
    let tz = "America/Chicago";
    let (_, pump) = imported(&dir, "pump.db", tz, &[&[&partial]]);
    let (_, uploaded) = imported(&dir, "ns.db", tz, &[&[&ns]]);
    let (partial_first, a) = imported(&dir, "a.db", tz, &[&[&partial], &[&ns]]);
    let (ns_first, b) = imported(&dir, "b.db", tz, &[&[&ns], &[&partial]]);
    // Nothing is lost from the store, whichever came first.
    for m in [&a, &b] {
        assert_eq!(m.stored.len(), pump.stored.len() + uploaded.stored.len());
    }
    assert_eq!(a.stored, b.stored);
    assert_eq!(a.events_hash, b.events_hash);
    assert_eq!(a.advice, b.advice);
    // The morning's export holds one bolus of 2025-03-16, Nightscout three:
    // that day's insulin is Nightscout's; the export's earlier days are
    // the export's.
    let day = |d: &str| d.parse::<jiff::civil::Date>().unwrap();
    let used = insulin_used(dir.join("a.db").to_str().unwrap(), "p", tz);
    let only = |s: abba_io::Source| std::collections::BTreeSet::from([s]);
    assert_eq!(used[&day("2025-03-16")], only(abba_io::Source::Nightscout));
    for d in ["2025-03-13", "2025-03-14", "2025-03-15"] {
        assert_eq!(used[&day(d)], only(abba_io::Source::CareLink), "{d}");
    }
    assert_eq!(
        used,
        insulin_used(dir.join("b.db").to_str().unwrap(), "p", tz)
    );
    // Each dose once: the export's boluses but that morning's, and
    // Nightscout's of 2025-03-16 and 2025-03-17.
    let sixteenth = day("2025-03-16");
    let earlier = stored_boluses(&pump, tz, |d| d < sixteenth);
    let later = stored_boluses(&uploaded, tz, |d| d >= sixteenth);
    assert_eq!(a.bolus_events, earlier.0 + later.0);
    assert!((a.bolus_units - (earlier.1 + later.1)).abs() < 1e-9);
    assert_eq!(stored_boluses(&uploaded, tz, |d| d == sixteenth).0, 3);
    assert_eq!(stored_boluses(&pump, tz, |d| d == sixteenth).0, 1);
    let said = "1 insulin record from carelink (2025-03-16) stored, not used: on that day \
                nightscout covers the insulin more fully and is used";
    for text in [&partial_first, &ns_first] {
        assert!(text.contains(said), "{text}");
    }
    // The advice and the person's report say it too.
    let advice = ok(&[
        "advise",
        "--db",
        dir.join("a.db").to_str().unwrap(),
        "--person",
        "p",
    ]);
    assert!(advice.contains(said), "{advice}");
    let page = dir.join("report.html");
    ok(&[
        "report",
        "--db",
        dir.join("a.db").to_str().unwrap(),
        "--person",
        "p",
        "--out",
        page.to_str().unwrap(),
    ]);
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains("1 insulin record from carelink (2025-03-16) stored, not used"),
        "the report's notes"
    );
    // autotune --db tunes from the records used, and says what it set aside.
    let tuned: serde_json::Value = serde_json::from_str(&ok(&[
        "autotune",
        "--db",
        dir.join("a.db").to_str().unwrap(),
        "--person",
        "p",
        "--isf",
        "50",
        "--json",
    ]))
    .unwrap();
    assert!(
        tuned["notes"].to_string().contains(said),
        "{}",
        tuned["notes"]
    );
}

/// A Clarity export (Chicago): EGVs every 5 min from 06:00 to 09:00 of
/// 2025-03-13 (the pump export's first day: both orders start day 1 there)
/// and two insulin doses typed into the Dexcom app on 2025-03-15.
fn clarity_with_two_doses(dir: &std::path::Path) -> String {
    let mut s = String::from(
        "\"Index\",\"Timestamp (YYYY-MM-DDThh:mm:ss)\",\"Event Type\",\"Event Subtype\",\"Patient Info\",\"Device Info\",\"Source Device ID\",\"Glucose Value (mg/dL)\",\"Insulin Value (u)\",\"Carb Value (grams)\",\"Duration (hh:mm:ss)\",\"Glucose Rate of Change (mg/dL/min)\",\"Transmitter Time (Long Integer)\",\"Transmitter ID\"\r\n\
         \"1\",\"\",\"Device\",\"\",\"\",\"Dexcom G7 Mobile App\",\"android G7\",\"\",\"\",\"\",\"\",\"\",\"\",\"\"\r\n",
    );
    let mut index = 2;
    for m in (0..180).step_by(5) {
        s.push_str(&format!(
            "\"{index}\",\"2025-03-13T{:02}:{:02}:00\",\"EGV\",\"\",\"\",\"\",\"android G7\",\"{}\",\"\",\"\",\"\",\"\",\"{}\",\"SY7G2K\"\r\n",
            6 + m / 60,
            m % 60,
            110 + m % 40,
            600_000 + m * 60
        ));
        index += 1;
    }
    for (at, units) in [("08:02:00", "5"), ("12:12:00", "5")] {
        s.push_str(&format!(
            "\"{index}\",\"2025-03-15T{at}\",\"Insulin\",\"Fast-Acting\",\"\",\"\",\"android G7\",\"\",\"{units}\",\"\",\"\",\"\",\"\",\"\"\r\n"
        ));
        index += 1;
    }
    let path = dir.join("clarity_two_doses.csv");
    std::fs::write(&path, s).unwrap();
    path.to_str().unwrap().to_string()
}

#[test]
fn two_doses_typed_into_clarity_give_way_to_the_pumps_export_of_that_day() {
    let dir = cli_common::tmp_path("abba-copies-typed-", "");
    std::fs::create_dir_all(&*dir).unwrap();
    let clarity = clarity_with_two_doses(&dir);
    let carelink = data("carelink_630g_us_synthetic.csv");
    let tz = "America/Chicago";
    let (_, pump) = imported(&dir, "pump.db", tz, &[&[&carelink]]);
    let (_, typed) = imported(&dir, "typed.db", tz, &[&[&clarity]]);
    assert_eq!(typed.bolus_events, 2);
    let (clarity_first, a) = imported(&dir, "a.db", tz, &[&[&clarity], &[&carelink]]);
    let (_, b) = imported(&dir, "b.db", tz, &[&[&carelink], &[&clarity]]);
    for m in [&a, &b] {
        assert_eq!(m.stored.len(), pump.stored.len() + typed.stored.len());
    }
    assert_eq!(a.stored, b.stored);
    assert_eq!(a.events_hash, b.events_hash);
    assert_eq!(a.advice, b.advice);
    // The pump's three boluses of 2025-03-15 are used, not the two typed.
    let used = insulin_used(dir.join("a.db").to_str().unwrap(), "p", tz);
    assert_eq!(
        used[&"2025-03-15".parse::<jiff::civil::Date>().unwrap()],
        std::collections::BTreeSet::from([abba_io::Source::CareLink])
    );
    assert_eq!(a.bolus_events, pump.bolus_events);
    assert!((a.bolus_units - pump.bolus_units).abs() < 1e-9);
    assert!((pump.bolus_units - stored_boluses(&pump, tz, |_| true).1).abs() < 1e-9);
    assert!(
        clarity_first.contains(
            "2 insulin records from clarity (2025-03-15) stored, not used: on that day carelink \
             covers the insulin more fully and is used"
        ),
        "{clarity_first}"
    );
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
