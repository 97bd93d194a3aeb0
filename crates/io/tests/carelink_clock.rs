//! A MiniMed 780G export across the autumn change: the pump keeps summer
//! time until the person sets it back (two `New Device Time` rows, as
//! CareLink writes a setting), so the rows it wrote between the change
//! and the setting are placed at the offset its clock kept: the sensor's
//! 5-minute series runs on without a gap or a repeated hour, and the
//! breakfast bolus of that morning is at its own time. In spring (the
//! pump kept winter time) its rows in the hour the zone skips are read.

use crate::common::{fixture, opts, read};
use abba_io::record::RecordKind;

const F: &str = "carelink_780g_autumn_clock_synthetic.csv";
const TZ: &str = "Europe/Zurich";

/// The instants of the sensor readings, oldest first.
fn cgm_instants(b: &abba_io::Batch) -> Vec<jiff::Timestamp> {
    let mut t: Vec<jiff::Timestamp> = b
        .records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Cgm { .. }))
        .map(|r| r.at)
        .collect();
    t.sort();
    t
}

/// The sensor readings' 5-minute steps, each as its gap in seconds, where
/// one is not 300 s: `(instant before the step, gap)`.
fn odd_steps(t: &[jiff::Timestamp]) -> Vec<(String, i64)> {
    t.windows(2)
        .map(|w| (w[0], w[1].duration_since(w[0]).as_secs()))
        .filter(|&(_, s)| s != 300)
        .map(|(a, s)| (a.to_string(), s))
        .collect()
}

#[test]
fn the_pumps_summer_clock_after_the_autumn_change_is_placed_at_its_offset() {
    let b = read(&[(F, fixture(F))], &opts(TZ)).unwrap();
    let t = cgm_instants(&b);
    // Every reading written (2026-10-23 22:00 to 2026-10-26 10:55 UTC,
    // every 5 min), none an hour off: no gap, no reading twice.
    let text = String::from_utf8(fixture(F)).unwrap();
    let header: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("Index;"))
        .unwrap()
        .split(';')
        .collect();
    let sg = header
        .iter()
        .position(|h| h.starts_with("Sensor Glucose"))
        .unwrap();
    let written = text
        .lines()
        .filter(|l| !l.starts_with("Index;"))
        .filter(|l| l.split(';').nth(sg).is_some_and(|c| !c.is_empty()))
        .count();
    assert_eq!(t.len(), written);
    assert_eq!(odd_steps(&t), vec![]);
    assert_eq!(t[0].to_string(), "2026-10-23T22:00:00Z");
    // The breakfast bolus of the 25th, 08:30:10 on the pump's summer
    // clock, is 07:30:10 CET (06:30:10 UTC).
    let boluses: Vec<String> = b
        .records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Bolus { .. }))
        .map(|r| r.at.to_string())
        .filter(|t| t.starts_with("2026-10-25"))
        .collect();
    assert_eq!(boluses, ["2026-10-25T06:30:10Z", "2026-10-25T11:30:10Z"]);
    // Each section's note names the setting and the rows placed.
    let notes: Vec<&String> = b
        .notes
        .iter()
        .filter(|n| {
            n.contains("pump's clock was set from 2026-10-25T09:00:00 to 2026-10-25T08:00:00")
        })
        .collect();
    assert_eq!(notes.len(), 2, "{:?}", b.notes);
    assert!(
        notes[0].starts_with(F)
            && notes[0].contains("Pump section")
            && notes[0].contains("at the offset it kept (UTC+02:00)"),
        "{}",
        notes[0]
    );
    assert!(
        notes[1].contains("Sensor section") && notes[1].contains("72 rows"),
        "{}",
        notes[1]
    );
}

#[test]
fn without_the_setting_the_summer_clock_is_read_on_the_zone() {
    // The same rows without the New Device Time rows: nothing says the
    // pump kept summer time, so nothing is moved (and no note says so).
    let text = String::from_utf8(fixture(F)).unwrap();
    let without: String = text
        .split_inclusive('\n')
        .filter(|l| !l.contains("2026/10/25 08:00;"))
        .collect();
    let b = read(&[(F, without.into_bytes())], &opts(TZ)).unwrap();
    assert!(!b.notes.iter().any(|n| n.contains("pump's clock was set")));
    let steps = odd_steps(&cgm_instants(&b));
    assert!(!steps.is_empty(), "the hour off shows as a gap or a repeat");
}

#[test]
fn the_pumps_winter_clock_after_the_spring_change_is_placed_at_its_offset() {
    // 2026-03-29 02:00 CET -> 03:00 CEST; the pump keeps winter time until
    // set forward at 09:00 on its clock: its rows of 02:00-02:59 (an hour
    // that does not exist on the zone's clock) are read, not refused.
    const S: &str = "carelink_780g_spring_clock_synthetic.csv";
    let b = read(&[(S, fixture(S))], &opts(TZ)).unwrap();
    assert_eq!(b.unread.count, 0, "{:?}", b.notes);
    assert_eq!(odd_steps(&cgm_instants(&b)), vec![]);
    // The breakfast bolus of the 28th, 06:30:10 on the winter clock, is
    // 07:30:10 CEST (05:30:10 UTC).
    let breakfast = b
        .records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Bolus { .. }))
        .map(|r| r.at.to_string())
        .find(|t| t.starts_with("2026-03-29"));
    assert_eq!(breakfast.as_deref(), Some("2026-03-29T05:30:10Z"));
    assert!(
        b.notes.iter().any(
            |n| n.contains("set from 2026-03-29T09:00:00 to 2026-03-29T10:00:00")
                && n.contains("Sensor section")
        ),
        "{:?}",
        b.notes
    );
}

/// The autumn export with the pump's clock set back on 2026-11-03 (nine
/// days after the change, past the rows' end) instead of the 25th: the
/// two setting rows moved to the top of the Pump section (newest first),
/// and `extra` rows (newest first) above them.
fn set_late(extra: &str) -> Vec<u8> {
    let text = String::from_utf8(fixture(F)).unwrap();
    let setting = [
        "5,00000;2026/10/25;08:00:01;2026/10/25 08:00;",
        "6,00000;2026/10/25;09:00:00;2026/10/25 08:00;",
    ];
    let mut out = String::new();
    let mut pump_header = false;
    for line in text.split_inclusive('\n') {
        if setting.iter().any(|s| line.starts_with(s)) {
            continue;
        }
        out.push_str(line);
        if line.starts_with("Index;") && !pump_header {
            pump_header = true;
            out.push_str(extra);
            let tail = ";".repeat(39);
            out.push_str(&format!(
                "5,00000;2026/11/03;08:00:01;2026/11/03 08:00;{tail}\r\n"
            ));
            out.push_str(&format!(
                "6,00000;2026/11/03;09:00:00;2026/11/03 08:00;{tail}\r\n"
            ));
        }
    }
    assert!(!out.contains("2026/10/25 08:00;"));
    out.into_bytes()
}

#[test]
fn a_pump_clock_set_back_weeks_after_the_change_is_placed_at_its_offset_too() {
    let b = read(&[(F, set_late(""))], &opts(TZ)).unwrap();
    assert_eq!(b.unread.count, 0, "{:?}", b.notes);
    // Every row after the change was written on the summer clock: no gap,
    // no reading twice.
    assert_eq!(odd_steps(&cgm_instants(&b)), vec![]);
    // The boluses of the 25th and the 26th, on the summer clock.
    let boluses: Vec<String> = b
        .records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Bolus { .. }))
        .map(|r| r.at.to_string())
        .filter(|t| t.as_str() >= "2026-10-25")
        .collect();
    assert_eq!(
        boluses,
        [
            "2026-10-25T06:30:10Z",
            "2026-10-25T10:30:10Z",
            "2026-10-26T05:30:10Z"
        ]
    );
    assert!(
        b.notes.iter().any(|n| n
            .contains("pump's clock was set from 2026-11-03T09:00:00 to 2026-11-03T08:00:00")
            && n.contains("Sensor section")),
        "{:?}",
        b.notes
    );
    // Set forward again two days later (a trip there and back): not the
    // change's correction, nothing moved.
    let tail = ";".repeat(39);
    let back = format!(
        "7,00000;2026/11/05;19:00:01;2026/11/05 19:00;{tail}\r\n8,00000;2026/11/05;18:00:00;2026/11/05 19:00;{tail}\r\n"
    );
    let b = read(&[(F, set_late(&back))], &opts(TZ)).unwrap();
    assert!(
        !b.notes.iter().any(|n| n.contains("pump's clock was set")),
        "{:?}",
        b.notes
    );
}
