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
    let dir = cli_common::tmp_path(&format!("abba-uploaders-{tag}-"), "");
    std::fs::create_dir_all(&*dir).unwrap();
    let db = dir.join("a.db");
    let db = db.to_str().unwrap();
    let e = dir.join("entries.json");
    std::fs::write(&e, entries()).unwrap();
    let t = dir.join("treatments.json");
    std::fs::write(&t, treatments).unwrap();
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
    let status = data("nightscout_devicestatus_aaps_open_loop_synthetic.json");
    let text = ok(&[
        "import",
        "--db",
        db,
        "--person",
        "lu",
        e.to_str().unwrap(),
        t.to_str().unwrap(),
        &status,
    ]);
    assert!(
        text.contains("research software, not a medical device"),
        "{text}"
    );
    let json = ok(&["advise", "--db", db, "--person", "lu", "--json"]);
    serde_json::from_str(&json).unwrap()
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
        words(&v).contains("of AndroidAPS in open loop")
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
