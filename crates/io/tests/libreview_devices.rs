//! LibreView exports as accounts outside the shared samples write them:
//! a Taiwanese account's export (Traditional Chinese header, year-first
//! times) in which a second phone uploaded the same sensor's history for
//! eight hours (synthetic values in the layout of a real export, see
//! tests/data/PROVENANCE.md).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_io::record::RecordKind;
use abba_io::Format;
use common::{fixture, opts, read};
use jiff::civil::datetime;

const TWO_DEVICES: &str = "libreview_zh_tw_two_devices_synthetic.csv";
const TAIPEI: &str = "Asia/Taipei";

fn at(y: i16, mo: i8, d: i8, h: i8, mi: i8) -> jiff::Timestamp {
    datetime(y, mo, d, h, mi, 0, 0)
        .to_zoned(abba_io::time::zone(TAIPEI).unwrap())
        .unwrap()
        .timestamp()
}

/// The CGM readings read, in time order: (instant, mg/dL).
fn cgm(b: &abba_io::Batch) -> Vec<(jiff::Timestamp, f64)> {
    let mut v: Vec<(jiff::Timestamp, f64)> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Cgm { glucose } => Some((r.at, glucose.mg_dl.0)),
            _ => None,
        })
        .collect();
    v.sort_by_key(|x| x.0);
    v
}

#[test]
fn a_libreview_export_in_traditional_chinese_is_read() {
    // It was taken for a plain CSV and refused: "no time column".
    let bytes = fixture(TWO_DEVICES);
    assert_eq!(
        abba_io::read::detect(TWO_DEVICES, &bytes).unwrap(),
        Format::LibreView
    );
    let b = read(&[(TWO_DEVICES, bytes)], &opts(TAIPEI)).unwrap();
    assert_eq!(b.formats, vec![Format::LibreView]);
    let cgm = cgm(&b);
    // The first phone's history, every 15 min from 00:07 on 18 November
    // to 23:52 on the 19th (Taipei, UTC+8), in mg/dL as its header says.
    assert_eq!(cgm.first().unwrap(), &(at(2026, 11, 18, 0, 7), 116.0));
    assert_eq!(cgm.last().unwrap().0, at(2026, 11, 19, 23, 52));
    // Scans (record type 1) are counted, not read as CGM.
    let scans = b
        .records
        .iter()
        .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == "scan glucose"))
        .count();
    assert_eq!(scans, 4);
}

#[test]
fn a_second_devices_copy_of_the_sensor_history_is_counted_not_read_twice() {
    // The second phone's 33 historic rows (lines 202-234, 12:08 to 20:08
    // on 18 November) each lie one minute after a reading of the first
    // phone: read as CGM as well, that stretch held two readings every
    // 15 minutes (the day's CGM count, and the sensor's period abba
    // derives from the readings, counted them twice).
    let b = read(&[(TWO_DEVICES, fixture(TWO_DEVICES))], &opts(TAIPEI)).unwrap();
    let cgm = cgm(&b);
    // The first phone's two days every 15 min, each read once.
    assert_eq!(cgm.len(), 2 * 96);
    assert!(cgm
        .windows(2)
        .all(|w| w[1].0.duration_since(w[0].0).as_secs() == 900));
    // Its readings over the stretch are the ones read (12:07 is its).
    assert!(cgm.iter().any(|c| c.0 == at(2026, 11, 18, 12, 7)));
    assert!(!cgm.iter().any(|c| c.0 == at(2026, 11, 18, 12, 8)));
    // Nothing is lost: the copies are counted by what they are.
    let copies: Vec<jiff::Timestamp> = b
        .records
        .iter()
        .filter(|r| {
            matches!(&r.kind, RecordKind::Ignored { kind }
                if kind == abba_io::read::libreview_devices::SECOND_DEVICE)
        })
        .map(|r| r.at)
        .collect();
    assert_eq!(copies.len(), 33);
    assert_eq!(copies.iter().min(), Some(&at(2026, 11, 18, 12, 8)));
    assert_eq!(copies.iter().max(), Some(&at(2026, 11, 18, 20, 8)));
    // And reported, with the devices, lines and times.
    assert!(
        b.notes.iter().any(|n| n.starts_with(TWO_DEVICES)
            && n.contains(
                "33 historic glucose rows of device \"5c0ffee0-5678-4abc-9def-00000000b002\""
            )
            && n.contains("lines 202-234, 2026-11-18 12:08 to 2026-11-18 20:08")
            && n.contains("\"5C0FFEE0-1234-4ABC-9DEF-00000000A001\", is read")
            && n.contains("15-minute period")),
        "{:?}",
        b.notes
    );
}

#[test]
fn a_phone_changed_between_two_stretches_is_read_whole() {
    // The second phone's rows moved after the first phone's last reading
    // (a phone changed, no overlap): every reading of both is read.
    let text = String::from_utf8(fixture(TWO_DEVICES)).unwrap();
    let moved: String = text
        .split_inclusive("\r\n")
        .map(|l| {
            if l.contains("00000000b002") {
                l.replace("2026-11-18 ", "2026-11-20 ")
            } else {
                l.to_string()
            }
        })
        .collect();
    let b = read(&[("moved.csv", moved.into_bytes())], &opts(TAIPEI)).unwrap();
    assert_eq!(cgm(&b).len(), 2 * 96 + 33);
    assert!(
        !b.notes
            .iter()
            .any(|n| n.contains("historic glucose rows of device")),
        "{:?}",
        b.notes
    );
}
