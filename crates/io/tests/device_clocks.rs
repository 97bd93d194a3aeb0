//! The device's own UTC offsets, where exports carry them (Nightscout
//! `utcOffset` and offsets in `dateString` / `created_at`, Tidepool
//! `timezoneOffset`), become the file's clock stretches; the readers
//! never shift a time by them.

use abba_io::clocks::{away, ClockStretch};
use abba_io::read::read_all;
use abba_io::ReadOptions;
use jiff::tz::TimeZone;
use serde_json::json;

fn read(name: &str, v: serde_json::Value) -> abba_io::Batch {
    let opts = ReadOptions {
        tz: Some(TimeZone::get("Europe/Berlin").unwrap()),
        ..ReadOptions::default()
    };
    read_all(
        &[(name.to_string(), serde_json::to_vec(&v).unwrap())],
        &opts,
    )
    .unwrap()
}

#[test]
fn nightscout_offsets_from_utc_offset_and_date_strings() {
    let b = read(
        "entries.json",
        json!([
            {"type": "sgv", "sgv": 120, "date": 1_717_200_000_000i64, "utcOffset": 120},
            {"type": "sgv", "sgv": 121, "date": 1_717_200_300_000i64,
             "dateString": "2024-06-01T00:05:00.000Z"},
            {"type": "sgv", "sgv": 122, "date": 1_717_300_000_000i64,
             "dateString": "2024-06-02T00:06:40.000-0400"},
            {"type": "sgv", "sgv": 123, "date": 1_717_300_300_000i64, "utcOffset": -240},
        ]),
    );
    // The instants are the documents' own: nothing shifted.
    assert_eq!(b.records[2].at.as_millisecond(), 1_717_300_000_000);
    assert_eq!(
        b.clocks,
        vec![vec![
            ClockStretch {
                first_ms: 1_717_200_000_000,
                last_ms: 1_717_200_000_000,
                offset_s: 7200,
                count: 1
            },
            ClockStretch {
                first_ms: 1_717_300_000_000,
                last_ms: 1_717_300_300_000,
                offset_s: -14400,
                count: 2
            },
        ]]
    );
    let berlin = TimeZone::get("Europe/Berlin").unwrap();
    assert_eq!(away(&b.clocks[0], &berlin).len(), 1);
}

#[test]
fn tidepool_timezone_offsets() {
    let b = read(
        "tidepool.json",
        json!([
            {"type": "cbg", "units": "mg/dL", "value": 120, "id": "a",
             "time": "2024-06-10T12:00:00.000Z", "timezoneOffset": -240,
             "conversionOffset": 0},
            {"type": "cbg", "units": "mg/dL", "value": 125, "id": "b",
             "time": "2024-06-10T12:05:00.000Z", "timezoneOffset": -240,
             "conversionOffset": 0},
        ]),
    );
    assert_eq!(b.records.len(), 2);
    assert_eq!(b.clocks[0].len(), 1);
    assert_eq!(b.clocks[0][0].offset_s, -14400);
    assert_eq!(b.clocks[0][0].count, 2);
}
