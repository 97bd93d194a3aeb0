//! `abba import` and `abba advise` on what loop apps upload to Nightscout,
//! in their real layouts (fixtures in `crates/io/tests/data`, see its
//! PROVENANCE.md): AndroidAPS in open loop is open-loop pump therapy and
//! gets advice; the same person with AndroidAPS's loop closed, or with no
//! record of its running mode, is a closed loop and does not.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;

use cli_common::abba;

/// The output of `abba args`, which must succeed.
fn ok(args: &[&str]) -> String {
    cli_common::ok(&abba(args))
}

fn data(name: &str) -> String {
    format!("{}/../io/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// CGM entries every 5 min from 2026-11-15 20:00 to 2026-11-18 22:55 UTC
/// (Europe/Zurich, UTC+1), as xDrip+ uploads them.
fn entries() -> String {
    let start: i64 = 1_794_772_800_000; // 2026-11-15T20:00:00Z
    let items: Vec<String> = (0..(3 * 288 + 36))
        .rev()
        .map(|i| {
            let ms = start + i * 300_000;
            let t = jiff::Timestamp::from_millisecond(ms).unwrap();
            format!(
                "{{\"_id\":\"6736e0a1f2c3b4a5d6{i:06x}\",\"device\":\"xDrip-DexcomG6\",\"date\":{ms},\"dateString\":\"{t}\",\"sgv\":{},\"direction\":\"Flat\",\"type\":\"sgv\",\"utcOffset\":60}}",
                110 + (i % 36) * 2
            )
        })
        .collect();
    format!("[{}]", items.join(",\n"))
}

/// `abba advise --json` for a new person fed `treatments` (text) beside
/// the entries and AndroidAPS's device status.
fn advise(tag: &str, treatments: &str) -> serde_json::Value {
    let status = std::fs::read_to_string(data(
        "nightscout_devicestatus_aaps_open_loop_synthetic.json",
    ))
    .unwrap();
    advise_files(
        tag,
        &[
            ("treatments.json", treatments.to_string()),
            ("devicestatus.json", status),
        ],
    )
    .1
}

/// `abba advise --json` for a new person fed `files` (name, text) beside
/// the entries, with what `abba import` printed.
fn advise_files(tag: &str, files: &[(&str, String)]) -> (String, serde_json::Value) {
    let dir = cli_common::tmp_path(&format!("abba-uploaders-{tag}-"), "");
    std::fs::create_dir_all(&*dir).unwrap();
    let db = dir.join("a.db");
    let db = db.to_str().unwrap();
    let e = dir.join("entries.json");
    std::fs::write(&e, entries()).unwrap();
    let mut paths = vec![e.to_str().unwrap().to_string()];
    for (name, text) in files {
        let f = dir.join(name);
        std::fs::write(&f, text).unwrap();
        paths.push(f.to_str().unwrap().to_string());
    }
    ok(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "lu",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--basal",
        "0.85",
        "--carb-ratio",
        "10,12,11",
    ]);
    let mut args = vec!["import", "--db", db, "--person", "lu"];
    // Loop's settings hold its therapy: put in force.
    if files.iter().any(|(name, _)| *name == "profile.json") {
        args.push("--adopt-profile");
    }
    args.extend(paths.iter().map(String::as_str));
    let text = ok(&args);
    assert!(
        text.contains("research software, not a medical device"),
        "{text}"
    );
    let json = ok(&["advise", "--db", db, "--person", "lu", "--json"]);
    (text, serde_json::from_str(&json).unwrap())
}

fn words(v: &serde_json::Value) -> String {
    v["delivery"]["evidence"].to_string()
}

#[test]
fn androidaps_in_open_loop_gets_advice_and_closed_or_unknown_does_not() {
    let open = std::fs::read_to_string(data("nightscout_treatments_aaps_open_loop_synthetic.json"))
        .unwrap();
    let v = advise("open", &open);
    assert_eq!(v["delivery"]["kind"], "open_loop", "{}", v["delivery"]);
    assert_eq!(
        v["delivery"]["basal_suggestions"], true,
        "{}",
        v["delivery"]
    );
    assert!(
        words(&v).contains("a loop app in open loop (1 record of open loop; the latest record of its mode: AndroidAPS's running mode OPEN_LOOP")
            && words(&v).contains("the person decides"),
        "{}",
        v["delivery"]
    );
    // The same person with the loop closed: AndroidAPS's running mode says so.
    let closed = open.replacen("\"mode\":\"OPEN_LOOP\"", "\"mode\":\"CLOSED_LOOP\"", 1);
    assert_ne!(closed, open);
    let v = advise("closed", &closed);
    assert_eq!(v["delivery"]["kind"], "closed_loop", "{}", v["delivery"]);
    assert_eq!(
        v["delivery"]["basal_suggestions"], false,
        "{}",
        v["delivery"]
    );
    assert!(
        words(&v).contains("AndroidAPS's running mode CLOSED_LOOP"),
        "{}",
        v["delivery"]
    );
    // No record of the running mode (AndroidAPS before 3.4): the safe side.
    let mut docs: Vec<serde_json::Value> = serde_json::from_str(&open).unwrap();
    docs.retain(|d| d["mode"] != "OPEN_LOOP");
    let unknown = serde_json::to_string(&docs).unwrap();
    let v = advise("unknown", &unknown);
    assert_eq!(v["delivery"]["kind"], "closed_loop", "{}", v["delivery"]);
    assert!(
        words(&v).contains("no record of its running mode"),
        "{}",
        v["delivery"]
    );
}

/// The fixture `name` as text.
fn text(name: &str) -> String {
    std::fs::read_to_string(data(name)).unwrap()
}

/// Loop's settings as a Nightscout profile (the fixture's document) from
/// `at` (UTC), closed loop on or off.
fn loop_settings(at: &str, dosing_enabled: bool) -> serde_json::Value {
    let docs: Vec<serde_json::Value> =
        serde_json::from_str(&text("nightscout_profile_loop_open_loop_synthetic.json")).unwrap();
    let mut d = docs[0].clone();
    let t: jiff::Timestamp = at.parse().unwrap();
    d["startDate"] = at.into();
    d["created_at"] = at.into();
    d["mills"] = t.as_millisecond().to_string().into();
    d["loopSettings"]["dosingEnabled"] = dosing_enabled.into();
    d["_id"] = format!("6740{:020x}", t.as_second()).into();
    d
}

/// Loop's own temporary basals (`automatic` true, as Loop enacts them)
/// every 30 min from `from` for `n` half hours.
fn loop_temp_basals(from: &str, n: i64) -> Vec<serde_json::Value> {
    let start: jiff::Timestamp = from.parse().unwrap();
    (0..n)
        .map(|i| {
            let t = start + jiff::SignedDuration::from_mins(30 * i);
            serde_json::json!({
                "_id": format!("6741{:020x}", t.as_second()),
                "temp": "absolute", "rate": 0.35 + 0.05 * (i % 7) as f64,
                "absolute": 0.35 + 0.05 * (i % 7) as f64, "duration": 30,
                "amount": 0.2, "automatic": true, "eventType": "Temp Basal",
                "created_at": t.to_string(), "timestamp": t.to_string(),
                "enteredBy": "loop://iPhone", "insulinType": "Novolog",
                "syncIdentifier": format!("{:032x}", t.as_second()), "utcOffset": 0
            })
        })
        .collect()
}

/// Loop's files for the three days: its treatments with `more`, its
/// device status, its settings `profiles`.
fn loop_files(
    more: Vec<serde_json::Value>,
    profiles: Vec<serde_json::Value>,
) -> Vec<(&'static str, String)> {
    let mut treatments: Vec<serde_json::Value> =
        serde_json::from_str(&text("nightscout_treatments_loop_open_loop_synthetic.json")).unwrap();
    treatments.extend(more);
    let mut files = vec![
        (
            "treatments.json",
            serde_json::to_string(&treatments).unwrap(),
        ),
        (
            "devicestatus.json",
            text("nightscout_devicestatus_loop_open_loop_synthetic.json"),
        ),
    ];
    if !profiles.is_empty() {
        files.push(("profile.json", serde_json::to_string(&profiles).unwrap()));
    }
    files
}

fn assert_delivery(v: &serde_json::Value, kind: &str, basal: bool) {
    assert_eq!(v["delivery"]["kind"], kind, "{}", v["delivery"]);
    assert_eq!(
        v["delivery"]["basal_suggestions"], basal,
        "{}",
        v["delivery"]
    );
}

fn assert_words(v: &serde_json::Value, text: &str) {
    assert!(words(v).contains(text), "{text}: {}", v["delivery"]);
}

/// Loop with closed loop off uploads its recommendation and the `enacted`
/// it would give in its device status, as with closed loop on; its
/// settings (a Nightscout profile) tell the mode, and its treatments hold
/// no dose it gave on its own.
#[test]
fn loop_with_closed_loop_off_gets_advice_and_its_settings_tell_the_mode() {
    let open = loop_settings("2026-11-14T18:02:00Z", false);
    let (imported, v) = advise_files("loop-open", &loop_files(Vec::new(), vec![open.clone()]));
    assert_delivery(&v, "open_loop", true);
    assert_words(
        &v,
        "a loop app in open loop (1 record of open loop; the latest record of its mode: Loop's settings with closed loop off (a Nightscout profile with loopSettings.dosingEnabled false) at 2026-11-14T18:02:00Z) and no automated delivery",
    );
    // The device status is counted, named as Loop's.
    assert_words(&v, "6 records from or naming devicestatus.loop");
    assert!(!imported.contains("closed loop"), "{imported}");
    // Without its settings nothing tells the mode: the safe side.
    let (imported, v) = advise_files("loop-unknown", &loop_files(Vec::new(), Vec::new()));
    assert_delivery(&v, "closed_loop", false);
    assert_words(&v, "no record of its running mode");
    assert!(imported.contains("closed loop"), "{imported}");
    // Closed loop on in its settings: no basal advice.
    let closed = loop_settings("2026-11-14T18:02:00Z", true);
    let (_, v) = advise_files("loop-closed", &loop_files(Vec::new(), vec![closed]));
    assert_delivery(&v, "closed_loop", false);
    assert_words(
        &v,
        "the loop app's latest mode is closed loop (Loop's settings with closed loop on",
    );
    // Turned on at the end of the data, after weeks off: held at once,
    // though no dose of the loop is in the data yet.
    let on = loop_settings("2026-11-18T20:00:00Z", true);
    let (_, v) = advise_files("loop-on", &loop_files(Vec::new(), vec![on, open]));
    assert_delivery(&v, "closed_loop", false);
    assert_words(&v, "at 2026-11-18T20:00:00Z");
}

/// A person who looped with Loop and turned closed loop off: Loop's own
/// temporary basals within the last 28 days of the data hold the advice;
/// once they all lie before them the loop is named as past and advice is
/// given. A loop's dose after the settings say off holds it again.
#[test]
fn loop_turned_off_gets_advice_once_its_doses_are_past_the_last_four_weeks() {
    // The data end 2026-11-18 22:55 UTC: the last 28 days from 2026-10-21 22:55.
    let since_september = loop_settings("2026-09-01T08:00:00Z", true);
    // Looped until 2026-10-10 13:30, then off.
    let off = loop_settings("2026-10-10T14:00:00Z", false);
    let (imported, v) = advise_files(
        "loop-past",
        &loop_files(
            loop_temp_basals("2026-10-10T08:00:00Z", 12),
            vec![off, since_september.clone()],
        ),
    );
    assert_delivery(&v, "open_loop", true);
    assert_words(&v, "a loop's automated deliveries or marks until 2026-10-10T13:30:00Z, before the last 28 days of the data: a past loop, not counted");
    assert_words(&v, "the latest record of its mode: Loop's settings with closed loop off (a Nightscout profile with loopSettings.dosingEnabled false) at 2026-10-10T14:00:00Z");
    assert!(!imported.contains("closed loop"), "{imported}");
    // Looped until 2026-11-10 13:30, then off: within the last 28 days.
    let off = loop_settings("2026-11-10T14:00:00Z", false);
    let (imported, v) = advise_files(
        "loop-recent",
        &loop_files(
            loop_temp_basals("2026-11-10T08:00:00Z", 12),
            vec![off.clone(), since_september],
        ),
    );
    assert_delivery(&v, "closed_loop", false);
    assert_words(&v, "12 automated basal records");
    assert_words(&v, "the loop app's latest mode is open loop (Loop's settings with closed loop off (a Nightscout profile with loopSettings.dosingEnabled false) at 2026-11-10T14:00:00Z), but the marks above show the loop closed within the last 28 days of the data (the last at 2026-11-10T13:30:00Z)");
    assert!(imported.contains("closed loop"), "{imported}");
    // Off in its settings since 2026-11-10, but a dose Loop gave on its
    // own on the last evening: the loop runs.
    let (_, v) = advise_files(
        "loop-dose-after",
        &loop_files(loop_temp_basals("2026-11-18T21:00:00Z", 1), vec![off]),
    );
    assert_delivery(&v, "closed_loop", false);
    assert_words(&v, "1 automated basal records");
}

/// Trio uploads `enacted` in its device status only with closed loop on.
#[test]
fn trio_in_open_loop_gets_advice_and_an_enacted_dose_stops_it() {
    let status = text("nightscout_devicestatus_trio_open_loop_synthetic.json");
    let (_, v) = advise_files("trio-open", &[("devicestatus.json", status.clone())]);
    assert_delivery(&v, "open_loop", true);
    assert_words(
        &v,
        "a loop app in open loop (6 records of open loop; the latest record of its mode: Trio's device status with a suggestion and nothing enacted (Trio uploads enacted only with closed loop on) at 2026-11-18T22:55:00Z)",
    );
    // Closed loop turned on for the last loop cycle: it enacted.
    let mut docs: Vec<serde_json::Value> = serde_json::from_str(&status).unwrap();
    let suggested = docs[0]["openaps"]["suggested"].clone();
    docs[0]["openaps"]["enacted"] = suggested;
    let (_, v) = advise_files(
        "trio-closed",
        &[("devicestatus.json", serde_json::to_string(&docs).unwrap())],
    );
    assert_delivery(&v, "closed_loop", false);
    assert_words(&v, "the loop app's latest mode is closed loop (Trio's device status with an enacted dose (closed loop on) at 2026-11-18T22:55:00Z)");
}
