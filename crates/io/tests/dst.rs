//! Daylight saving: a week across each transition in Europe/Zurich and
//! America/New_York. Wall-time exports (Clarity) and instant exports
//! (Nightscout) lose, duplicate or reorder no reading; days have 23 and 25
//! hours; the advisor's clock stays in order.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use std::collections::BTreeMap;

use abba_io::events::PersonSettings;
use abba_io::record::RecordKind;
use common::{opts, read};
use jiff::civil::{date, Date};
use jiff::{SignedDuration, Timestamp};

/// 5-minute instants over seven local days, from local midnight 3 days
/// before `transition` to local midnight 4 days after it.
fn week(tz: &str, transition: Date) -> Vec<Timestamp> {
    let zone = abba_io::time::zone(tz).unwrap();
    let midnight = |days: i64| {
        transition
            .checked_add(jiff::Span::new().days(days))
            .unwrap()
            .to_zoned(zone.clone())
            .unwrap()
            .timestamp()
    };
    let (start, end) = (midnight(-3), midnight(4));
    (0..)
        .map(|i| start.checked_add(SignedDuration::from_mins(5 * i)).unwrap())
        .take_while(|t| *t < end)
        .collect()
}

/// A Clarity export of `instants` as the device writes them: local wall times.
fn clarity(tz: &str, instants: &[Timestamp]) -> Vec<u8> {
    let zone = abba_io::time::zone(tz).unwrap();
    let mut s = String::from("Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID\n");
    for (i, t) in instants.iter().enumerate() {
        let wall = zone.to_datetime(*t).strftime("%Y-%m-%dT%H:%M:%S");
        s.push_str(&format!(
            "{},{wall},EGV,,,,G6,{},,,,,,X\n",
            i + 1,
            100 + i % 50
        ));
    }
    s.into_bytes()
}

fn nightscout(instants: &[Timestamp]) -> Vec<u8> {
    let v: Vec<serde_json::Value> = instants
        .iter()
        .enumerate()
        .rev()
        .map(|(i, t)| serde_json::json!({"_id": format!("e{i}"), "type": "sgv", "sgv": 100 + i % 50, "date": t.as_millisecond()}))
        .collect();
    serde_json::to_vec(&v).unwrap()
}

fn check(tz: &str, transition: Date, hours_that_day: i64) {
    let instants = week(tz, transition);
    let zone = abba_io::time::zone(tz).unwrap();
    for (name, bytes) in [
        ("clarity.csv", clarity(tz, &instants)),
        ("entries.json", nightscout(&instants)),
    ] {
        let b = read(&[(name, bytes)], &opts(tz)).unwrap();
        let got: Vec<Timestamp> = b
            .records
            .iter()
            .filter(|r| matches!(r.kind, RecordKind::Cgm { .. }))
            .map(|r| r.at)
            .collect();
        assert_eq!(
            got, instants,
            "{tz} {transition} {name}: readings lost, duplicated or moved"
        );
        // Grouped by the person's local day.
        let mut per_day: BTreeMap<Date, usize> = BTreeMap::new();
        for t in &got {
            *per_day.entry(zone.to_datetime(*t).date()).or_default() += 1;
        }
        assert_eq!(per_day.len(), 7);
        assert_eq!(
            per_day[&transition],
            (hours_that_day * 12) as usize,
            "{tz} {transition} {name}"
        );
        for (d, n) in &per_day {
            if *d != transition {
                assert_eq!(*n, 288, "{tz} {d} {name}");
            }
        }
        // The advisor's clock: strictly increasing, nothing rejected.
        let stream = b.to_events(&PersonSettings::new(zone.clone())).unwrap();
        assert!(
            stream.rejected.is_empty(),
            "{tz} {name}: {:?}",
            stream.rejected
        );
        let cgm: Vec<_> = stream
            .events
            .iter()
            .filter(|e| matches!(e.kind, abba_core::EventKind::Cgm(_)))
            .map(|e| e.at)
            .collect();
        assert_eq!(cgm.len(), instants.len());
        assert!(
            cgm.windows(2).all(|w| w[0] < w[1]),
            "{tz} {name}: advisor times out of order"
        );
        // Day 4 (index 3) is the transition day; its minutes stay inside the day.
        let on_day: Vec<_> = cgm.iter().filter(|t| t.day_index() == 3).collect();
        assert_eq!(on_day.len(), (hours_that_day * 12) as usize);
        assert!(on_day
            .iter()
            .all(|t| (0..1440).contains(&t.minute_of_day())));
        // Days close at the 6 local midnights inside the week.
        assert_eq!(stream.counts.get("day_closed"), Some(&6), "{tz} {name}");
    }
}

#[test]
fn zurich_spring_forward_day_has_23_hours() {
    check("Europe/Zurich", date(2024, 3, 31), 23);
}

#[test]
fn zurich_fall_back_day_has_25_hours() {
    check("Europe/Zurich", date(2024, 10, 27), 25);
}

#[test]
fn new_york_spring_forward_day_has_23_hours() {
    check("America/New_York", date(2024, 3, 10), 23);
}

#[test]
fn new_york_fall_back_day_has_25_hours() {
    check("America/New_York", date(2024, 11, 3), 25);
}

#[test]
fn a_repeated_hour_out_of_device_order_is_reported_not_reordered() {
    // 01:30 (first pass), 01:40, then a row at 01:10 after 01:40 of the
    // *second* pass, then 01:05: neither instant of 01:05 follows the row
    // before it.
    let s = "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL)\n\
             1,2024-11-03T01:30:00,EGV,,,,G6,100\n2,2024-11-03T01:40:00,EGV,,,,G6,101\n3,2024-11-03T01:10:00,EGV,,,,G6,102\n4,2024-11-03T01:50:00,EGV,,,,G6,103\n5,2024-11-03T01:05:00,EGV,,,,G6,104\n";
    // The row is left out and reported; the rows before and after it are read.
    let (b, err) = common::read_in_part(&[("c.csv", s.into())], &opts("America/New_York"));
    assert!(
        err.contains("c.csv: line 6") && err.contains("occurs twice"),
        "{err}"
    );
    assert_eq!(b.count("cgm"), 4);
    // A wall time in the spring gap does not exist.
    let s = "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL)\n1,2024-03-10T02:30:00,EGV,,,,G6,100\n";
    let err = read(&[("c.csv", s.into())], &opts("America/New_York"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("line 2") && err.contains("does not exist"),
        "{err}"
    );
}

#[test]
fn a_clarity_export_across_the_autumn_change_is_placed_by_the_transmitter_clock() {
    // Clarity lists rows by wall time: the two passes through 01:00-02:00
    // of 2023-11-05 (America/Chicago) interleave, each wall time twice
    // (the second pass sometimes first). The transmitter's clock (seconds,
    // one per reading every 300) tells the passes apart: 3600 s apart.
    const F: &str = "clarity_g6_autumn_fold_synthetic.csv";
    let b = read(&[(F, common::fixture(F))], &opts("America/Chicago")).unwrap();
    let cgm: Vec<(Timestamp, f64)> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Cgm { glucose } => Some((r.at, glucose.mg_dl.0)),
            _ => None,
        })
        .collect();
    assert_eq!(cgm.len(), 48);
    let first: Timestamp = "2023-11-05T04:03:41Z".parse().unwrap();
    for (i, (t, g)) in cgm.iter().enumerate() {
        // Every reading at its true instant, 5 minutes apart, in the
        // order the sensor read them (118 falling to 89, then rising).
        assert_eq!(*t, first + SignedDuration::from_mins(5 * i as i64), "{i}");
        let want = if i < 30 { 118 - i } else { 88 + (i - 30) * 2 };
        assert_eq!(*g, want as f64, "{i}");
    }
    // The app's entries: before and after the repeated hour read; the one
    // inside it has no transmitter time and the file's order cannot tell
    // its pass: reported with its line, not read.
    let carbs: Vec<Timestamp> = b
        .records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Carbs { .. }))
        .map(|r| r.at)
        .collect();
    assert_eq!(
        carbs,
        vec!["2023-11-05T05:20:05Z".parse::<Timestamp>().unwrap()]
    );
    assert_eq!(b.count("bolus"), 1);
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("line 48") && n.contains("Carbs") && n.contains("not read")),
        "{:?}",
        b.notes
    );
}
