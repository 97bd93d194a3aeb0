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
