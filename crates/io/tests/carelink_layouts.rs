//! CareLink exports in the layouts real exports show and the shared
//! samples did not (see tests/data/PROVENANCE.md): a Paradigm Revel 723's
//! US export (GluGo, MIT) with a second header without its divider, a
//! trailing Sensor section without rows and wizards confirmed twice; a
//! MiniMed 780G in SmartGuard (synthetic, in the real 54-column layout)
//! with wizards not delivered; a Guardian 4 system's meal markers without
//! an amount and its injections (synthetic, in the real layout); the older CareLink Personal layout
//! (Tidepool's rows, BSD-2), refused by name.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_io::record::RecordKind;
use common::{fixture, opts, read};
use jiff::civil::datetime;

const REVEL: &str = "carelink_paradigm723_glugo.csv";
const NEW_YORK: &str = "America/New_York";

fn at_ny(y: i16, mo: i8, d: i8, h: i8, mi: i8, s: i8) -> jiff::Timestamp {
    datetime(y, mo, d, h, mi, s, 0)
        .to_zoned(abba_io::time::zone(NEW_YORK).unwrap())
        .unwrap()
        .timestamp()
}

fn ignored(b: &abba_io::Batch, what: &str) -> usize {
    b.records
        .iter()
        .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind.starts_with(what)))
        .count()
}

fn carbs(b: &abba_io::Batch) -> Vec<(jiff::Timestamp, f64)> {
    b.records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Carbs { grams } => Some((r.at, grams.0)),
            _ => None,
        })
        .collect()
}

#[test]
fn a_section_without_rows_is_skipped_and_year_first_dates_need_no_date_order() {
    // The export ends with the Sensor section's divider and header and no
    // row (a Paradigm without a sensor): the whole file was refused with
    // "every date could be day-first or month-first", its dates all
    // 2018/MM/DD.
    let b = read(&[(REVEL, fixture(REVEL))], &opts(NEW_YORK)).unwrap();
    assert_eq!(b.formats, vec![abba_io::Format::CareLink]);
    // Every pump row of both headers is read (35 rows).
    assert_eq!(
        b.records.first().unwrap().at,
        at_ny(2018, 9, 22, 11, 59, 51)
    );
    assert_eq!(
        b.records.last().unwrap().at,
        at_ny(2018, 10, 11, 18, 14, 22)
    );
    assert_eq!(b.count("bolus"), 6);
    assert_eq!(b.count("smbg"), 2);
    assert_eq!(b.count("suspend"), 2);
    assert_eq!(b.count("resume"), 1);
    // The empty section is named in a note, with its line.
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("line 47") && n.contains("Sensor") && n.contains("no rows")),
        "{:?}",
        b.notes
    );
}

/// The same person's export of September 2018 as it was committed after a
/// spreadsheet: the preamble and the Pump divider deleted (the header is
/// line 1), `0` for `0.00000`, `9/26/18` for `2018/09/26`, empty rows of
/// commas, the Sensor divider padded with commas (see PROVENANCE.md).
const REVEL_NO_PREAMBLE: &str = "carelink_paradigm723_glugo_no_preamble.csv";

#[test]
fn a_carelink_export_whose_preamble_was_deleted_is_still_carelink() {
    // It was taken for a plain CSV and refused for want of a "glucose"
    // column, naming CareLink's own columns as the choice; read as
    // CareLink (--format), its rows before the Sensor divider were all
    // counted as "row of an unknown CareLink section": no bolus, no note.
    // Saved as Excel's "CSV UTF-8", the file starts with a byte-order mark.
    let bom = [b"\xef\xbb\xbf".as_slice(), &fixture(REVEL_NO_PREAMBLE)].concat();
    let with_bom = read(&[("bom.csv", bom)], &opts(NEW_YORK)).unwrap();
    let b = read(
        &[(REVEL_NO_PREAMBLE, fixture(REVEL_NO_PREAMBLE))],
        &opts(NEW_YORK),
    )
    .unwrap();
    assert_eq!(with_bom.records, b.records);
    assert_eq!(b.formats, vec![abba_io::Format::CareLink]);
    // In the whole export the Sensor divider comes after 800 rows, beyond
    // what detection reads: the header alone tells CareLink.
    let pump_rows: Vec<u8> = String::from_utf8(fixture(REVEL_NO_PREAMBLE))
        .unwrap()
        .split_inclusive('\n')
        .take(25)
        .collect::<String>()
        .into_bytes();
    assert_eq!(
        abba_io::read::detect("rows.csv", &pump_rows).unwrap(),
        abba_io::Format::CareLink
    );
    // Its five Normal boluses (lines 2, 7, 13, 16, 24: 4.1, 2, 6.1, 1.6,
    // 0.6 U), the wizard's carbohydrate (25, 30 and 8 g), the user's
    // suspension (line 32) and the meter reading (line 35) are read.
    let boluses: Vec<f64> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Bolus { units, .. } => Some(units.0),
            _ => None,
        })
        .collect();
    let mut sorted = boluses.clone();
    sorted.sort_by(f64::total_cmp);
    assert_eq!(sorted, vec![0.6, 1.6, 2.0, 4.1, 6.1], "{boluses:?}");
    let grams: Vec<f64> = carbs(&b).into_iter().map(|(_, g)| g).collect();
    assert_eq!(grams, vec![8.0, 30.0, 25.0]);
    assert_eq!(b.count("suspend"), 1);
    assert_eq!(b.records.first().unwrap().at, at_ny(2018, 9, 5, 7, 45, 28));
    assert_eq!(b.records.last().unwrap().at, at_ny(2018, 9, 26, 14, 42, 33));
    // The section read as the pump's without its divider is named, and
    // the Sensor section without rows, each with its header's line.
    assert!(
        b.notes.iter().any(|n| n.contains("its header on line 1:")
            && n.contains("no section divider")
            && n.contains("read as the Pump section")),
        "{:?}",
        b.notes
    );
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("line 41") && n.contains("Sensor") && n.contains("no rows")),
        "{:?}",
        b.notes
    );
}

/// A MiniMed 780G in SmartGuard (auto mode), European layout (synthetic
/// values in the columns of a real 780G export; see PROVENANCE.md).
const SMARTGUARD: &str = "carelink_780g_smartguard_synthetic.csv";
const BERLIN: &str = "Europe/Berlin";

#[test]
fn smartguard_auto_mode_is_loop_evidence_and_a_780g_in_manual_mode_is_not() {
    use abba_io::automation::{Delivery, Evidence};
    let tz = abba_io::time::zone(BERLIN).unwrap();
    let bytes = fixture(SMARTGUARD);
    let e = Evidence::from_file(&bytes);
    // The auto correction (CLOSED_LOOP_AUTO_BOLUS) and the auto basal
    // micro-bolus (CLOSED_LOOP_AUTO_BASAL) are automatic doses.
    assert_eq!(e.smb, 2, "{e:?}");
    // Three boluses delivered in auto mode (CLOSED_LOOP_BG_CORRECTION_AND_
    // FOOD_BOLUS) and one daily total of auto insulin, named with the pump.
    let words = e.words().join("; ");
    assert!(
        words.contains("3 records from or naming SmartGuard auto mode")
            && words.contains("1 record from or naming SmartGuard auto mode")
            && words.contains("MiniMed 780G MMT-1886"),
        "{words}"
    );
    assert_eq!(e.delivery(), Delivery::ClosedLoop);
    // With the records' own counts (pump days, no short temp basals) the
    // file's evidence still makes it a loop: abba advises no basal.
    let b = read(&[(SMARTGUARD, bytes.clone())], &opts(BERLIN)).unwrap();
    let mut all = Evidence::from_records(&b.records, &tz);
    all.add_file(&e);
    assert_eq!(all.delivery(), Delivery::ClosedLoop);

    // A 780G in manual mode (its name in every divider, boluses from
    // BOLUS_WIZARD): the name alone is no loop, the pump runs open loop.
    let manual = fixture("carelink_780g_mmol_synthetic.csv");
    let m = Evidence::from_file(&manual);
    assert_eq!((m.smb, m.systems.len()), (0, 0), "{m:?}");
    let b = read(&[("manual.csv", manual)], &opts("Europe/Zurich")).unwrap();
    let mut all =
        Evidence::from_records(&b.records, &abba_io::time::zone("Europe/Zurich").unwrap());
    all.add_file(&m);
    assert_eq!(all.delivery(), Delivery::OpenLoop);
}

#[test]
fn a_paradigm_wizard_run_again_before_its_bolus_is_one_meal() {
    // The Revel writes a wizard row each time the person confirms the
    // wizard: 06/10 15:39:17 and 15:39:19 the same 35 g (then one 5.8 U
    // bolus), 11/10 16:44:22 and 16:44:24 the same 15 g (one 2.5 U bolus),
    // 22/09 12:25:15 29 g then 12:25:28 25 g (one 4.5 U bolus, the second
    // row's estimate). One meal each, at the row the bolus followed.
    let b = read(&[(REVEL, fixture(REVEL))], &opts(NEW_YORK)).unwrap();
    assert_eq!(
        carbs(&b),
        vec![
            (at_ny(2018, 9, 22, 12, 25, 28), 25.0),
            (at_ny(2018, 10, 6, 14, 8, 49), 25.0),
            (at_ny(2018, 10, 6, 15, 39, 19), 35.0),
            (at_ny(2018, 10, 11, 15, 3, 52), 15.0),
            (at_ny(2018, 10, 11, 16, 44, 24), 15.0),
        ]
    );
    assert_eq!(
        ignored(&b, "bolus wizard row repeated with the same values"),
        2
    );
    assert_eq!(
        ignored(&b, "bolus wizard row changed and confirmed again"),
        1
    );
    // 06/10: one 35 g dinner, no 35 g snack beside it.
    let zone = abba_io::time::zone(NEW_YORK).unwrap();
    let s = b
        .to_events(&abba_io::events::PersonSettings::new(zone))
        .unwrap();
    let meals: Vec<(abba_core::MealSlot, f64)> = s
        .events
        .iter()
        .filter_map(|e| match e.kind {
            abba_core::EventKind::MealAnnounced { slot, carbs } => Some((slot, carbs.0)),
            _ => None,
        })
        .collect();
    // (22/09 has no glucose reading: the advisor's first day is 06/10.)
    use abba_core::MealSlot::{Dinner, Lunch};
    assert_eq!(
        meals,
        vec![(Lunch, 25.0), (Dinner, 35.0), (Lunch, 15.0), (Dinner, 15.0)]
    );
}

#[test]
fn a_780g_wizard_not_delivered_is_no_meal() {
    // Lunch: the wizard at 12:15:20 (40 g) and 12:16:55 (8 g) "Not
    // Delivered" (a low, the bolus declined), then 55 g delivered at
    // 12:20:41: one 55 g lunch.
    let b = read(&[(SMARTGUARD, fixture(SMARTGUARD))], &opts(BERLIN)).unwrap();
    let at = |h, mi, s| {
        datetime(2026, 3, 14, h, mi, s, 0)
            .to_zoned(abba_io::time::zone(BERLIN).unwrap())
            .unwrap()
            .timestamp()
    };
    assert_eq!(
        carbs(&b),
        vec![
            (at(7, 42, 10), 42.0),
            (at(12, 20, 41), 55.0),
            (at(19, 3, 20), 60.0)
        ]
    );
    assert_eq!(
        ignored(
            &b,
            "bolus wizard carbohydrate not delivered (BWZ Status Not Delivered)"
        ),
        2
    );
}

/// The older CareLink Personal export (2010-2014): a "Data Range" first
/// line, `Raw-Type` / `Raw-Values` columns, no section dividers (rows
/// picked from real exports by Tidepool, BSD-2; see PROVENANCE.md).
const PERSONAL_2014: &str = "carelink_personal_2014_tidepool.csv";

#[test]
fn the_older_carelink_personal_layout_is_refused_by_name() {
    let bytes = fixture(PERSONAL_2014);
    // Without the "Data Range" line (as some copies have it) too.
    let text = String::from_utf8(bytes.clone()).unwrap();
    let headless = text.split_once('\n').unwrap().1.as_bytes().to_vec();
    for (name, b) in [("p.csv", bytes), ("q.csv", headless)] {
        // Detected (it was taken for a plain CSV), and with --format
        // carelink (it "read" every row as one of an unknown section).
        for format in [None, Some(abba_io::Format::CareLink)] {
            let o = abba_io::ReadOptions {
                format,
                ..opts(NEW_YORK)
            };
            let err = read(&[(name, b.clone())], &o).unwrap_err().to_string();
            assert!(
                err.starts_with(name) && err.contains("older CareLink Personal layout"),
                "{name} {format:?}: {err}"
            );
        }
    }
}

/// The older layout as CareLink Personal v1.0.1 wrote it in 2013-2015:
/// a title line and an 11-line preamble before the same `Raw-Type` table
/// (synthetic values in the layout of real exports; see PROVENANCE.md).
const PERSONAL_V101: &str = "carelink_personal_v101_synthetic.csv";

#[test]
fn the_older_carelink_personal_layout_with_its_v101_preamble_is_detected_and_refused() {
    let bytes = fixture(PERSONAL_V101);
    // Detected as CareLink (it was "cannot tell the format"), and refused
    // by name with --format carelink too (it was "no Pump or Sensor
    // section"), saying what the file shows of the layout.
    for format in [None, Some(abba_io::Format::CareLink)] {
        let o = abba_io::ReadOptions {
            format,
            ..opts(NEW_YORK)
        };
        let err = read(&[("v101.csv", bytes.clone())], &o)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("v101.csv")
                && err.contains("older CareLink Personal layout")
                && err.contains(
                    "its first line \"Medtronic Diabetes CareLink Personal Data Export File (v1.0.1)\""
                )
                && err.contains("its header on line 12 with Raw-Type and Raw-Values columns"),
            "{format:?}: {err}"
        );
    }
    assert_eq!(
        abba_io::read::detect("v101.csv", &bytes).unwrap(),
        abba_io::Format::CareLink
    );
}

#[test]
fn a_carelink_file_without_a_pump_or_sensor_section_reads_nothing_and_says_so() {
    // A header after the preamble and no divider: no section abba knows,
    // so nothing would be read; refused instead of an empty success.
    let text =
        "Last Name,First Name,Patient ID,Start Date,End Date,Device,Paradigm Revel - 723\r\n\
                \"A\",\"B\",\"\",\"7/27/18\",\"10/18/18\",\"Serial Number\",XXXXXX\r\n\
                Index,Date,Time,New Device Time,BG Reading (mg/dL),Basal Rate (U/h)\r\n\
                0.00000,2018/09/26,14:00:00,,,0.25\r\n";
    let err = read(&[("n.csv", text.into())], &opts(NEW_YORK))
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("n.csv") && err.contains("no Pump or Sensor section"),
        "{err}"
    );
}

/// A Guardian 4 system (CGM only, injections logged in the app as event
/// markers), in the layout of a real export (synthetic values; see
/// PROVENANCE.md).
const GUARDIAN: &str = "carelink_guardian4_synthetic.csv";

#[test]
fn a_meal_marker_of_one_gram_is_a_meal_without_its_amount() {
    // A real Guardian 4 export logs every meal as "Meal: 1.00grams" (23 of
    // 23) beside its injection of 8 to 25 U: the app's mark that a meal
    // happened, not its carbohydrate. As a 1 g meal it would teach the
    // advisor a carb ratio of 0.04 g/U.
    let b = read(&[(GUARDIAN, fixture(GUARDIAN))], &opts("Asia/Taipei")).unwrap();
    let noon = datetime(2025, 2, 11, 12, 20, 0, 0)
        .to_zoned(abba_io::time::zone("Asia/Taipei").unwrap())
        .unwrap()
        .timestamp();
    // The marker with a real amount is read.
    assert_eq!(carbs(&b), vec![(noon, 30.0)]);
    assert_eq!(ignored(&b, "event marker meal without its amount"), 3);
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("3 \"Meal:\" event markers") && n.contains("1 g or less")),
        "{:?}",
        b.notes
    );
    // The empty second Pump section is skipped, the sensor read.
    assert_eq!(b.count("cgm"), 24);
}

/// A Guardian system's `Insulin: N` markers are injections logged in its
/// app (a real Guardian Connect export, GlucoseDAO/cgm_format's
/// `medtronics_test_livia.csv`, MIT, has 387 beside its meals): the data
/// show multiple daily injections, not "no insulin records", and
/// carbohydrate with an injection beside it is a meal even after a low
/// reading (there, 87 of 205 meals were taken for hypoglycaemia
/// treatments).
#[test]
fn injections_logged_as_event_markers_are_injections_and_insulin_at_the_meal() {
    use abba_io::automation::{Delivery, Evidence};
    use abba_io::rescue::Rescue;
    let taipei = abba_io::time::zone("Asia/Taipei").unwrap();
    let text = String::from_utf8(fixture(GUARDIAN)).unwrap();
    let b = read(
        &[(GUARDIAN, text.clone().into_bytes())],
        &opts("Asia/Taipei"),
    )
    .unwrap();
    let e = Evidence::from_records(&b.records, &taipei);
    assert_eq!(e.injection_markers, 4);
    assert_eq!(e.delivery(), Delivery::Injections, "{:?}", e.words());
    assert!(e
        .words()
        .iter()
        .any(|w| w.starts_with("4 injections logged as event markers")));
    // A sensor reading of 62 mg/dL five minutes before the 12:20 meal,
    // which has its injection (Insulin: 6.00) at 12:20.
    let template = text
        .lines()
        .find(|l| l.contains(",2025/02/11,18:12:12,"))
        .unwrap();
    let low = template
        .replace("18:12:12", "12:15:00")
        .replace(",163,", ",62,");
    let with_low = text.replacen(template, &format!("{low}\r\n{template}"), 1);
    let noon = datetime(2025, 2, 11, 12, 20, 0, 0)
        .to_zoned(taipei.clone())
        .unwrap()
        .timestamp();
    let b = read(
        &[(GUARDIAN, with_low.clone().into_bytes())],
        &opts("Asia/Taipei"),
    )
    .unwrap();
    assert_eq!(b.count("cgm"), 25);
    assert!(
        !Rescue::new(&b.records).is_rescue(noon),
        "a meal, with its injection"
    );
    // Without the injection, the same carbohydrate treats the low.
    let without = with_low.replace("Insulin: 6.00", "Exercise: 30");
    let b = read(&[(GUARDIAN, without.into_bytes())], &opts("Asia/Taipei")).unwrap();
    assert!(Rescue::new(&b.records).is_rescue(noon));
}

#[test]
fn therapy_from_a_smartguard_export_refuses_the_basal_rate_rows() {
    // In auto mode the Basal Rate rows are the manual pattern the pump
    // did not run: no basal schedule from them, and the reason given.
    let meals = abba_io::meals::MealWindows::default();
    let why = abba_io::therapy::carelink_settings(
        SMARTGUARD,
        &fixture(SMARTGUARD),
        &opts(BERLIN),
        &meals,
    )
    .unwrap()
    .unwrap_err();
    assert!(why.contains("SmartGuard auto mode"), "{why}");
    assert!(why.contains("not designed for a closed loop"), "{why}");
    let e = abba_io::therapy::therapy_from_contents(
        &[(SMARTGUARD.to_string(), fixture(SMARTGUARD))],
        &opts(BERLIN),
        &meals,
        Some([10.0, 12.0, 12.0]),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("SmartGuard auto mode"), "{e}");
}

/// A MiniMed 780G switching modes (synthetic values in the columns of a
/// real 780G export; see PROVENANCE.md): SmartGuard auto mode on
/// 2026-03-09, manual mode 2026-03-10 to 03-12 (the pattern's `Basal Rate`
/// rows, `BOLUS_WIZARD` boluses), auto mode again from the morning of
/// 03-13 to the end (14th, 20:00).
const MIXED: &str = "carelink_780g_mixed_modes_synthetic.csv";

/// The mixed export with the 780G's `BOLUS_WIZARD` boluses of `days` made
/// auto mode's (`CLOSED_LOOP_BG_CORRECTION_AND_FOOD_BOLUS`) and the
/// `Basal Rate` rows at `drop` (date;time) left out.
fn mixed_with(days: &[&str], drop: &[&str]) -> Vec<u8> {
    let text = String::from_utf8(fixture(MIXED)).unwrap();
    let lines: Vec<String> = text
        .split("\r\n")
        .filter(|l| !drop.iter().any(|d| l.contains(&format!(";{d};;;;;0,"))))
        .map(|l| {
            if days.iter().any(|d| l.contains(&format!(";{d};"))) {
                l.replace("BOLUS_WIZARD", "CLOSED_LOOP_BG_CORRECTION_AND_FOOD_BOLUS")
            } else {
                l.to_string()
            }
        })
        .collect();
    lines.join("\r\n").into_bytes()
}

#[test]
fn therapy_from_a_780g_switching_modes_reads_the_manual_days_and_names_the_auto_ones() {
    let meals = abba_io::meals::MealWindows::default();
    let c = abba_io::therapy::carelink_settings(MIXED, &fixture(MIXED), &opts(BERLIN), &meals)
        .unwrap()
        .unwrap();
    // The latest full day in manual mode, 03-12: the pattern's segments,
    // not the auto days' irregular rows.
    assert_eq!(c.day.to_string(), "2026-03-12");
    assert_eq!(
        c.basal,
        vec![(0, 0.65), (360, 0.9), (720, 0.8), (1200, 0.7)]
    );
    // The wizard's ratios (it runs in both modes).
    assert_eq!(c.carb_ratio, [Some(10.0), Some(12.0), Some(11.0)]);
    let [note] = &c.notes[..] else {
        panic!("{:?}", c.notes)
    };
    for part in [
        "SmartGuard auto mode (a closed loop, MiniMed 780G MMT-1886) on 2026-03-09 (4 CLOSED_LOOP_* rows from 2026-03-09 07:43 to 2026-03-09 19:05 local time, 1 daily auto insulin totals); 2026-03-13 to 2026-03-14 (5 CLOSED_LOOP_* rows from 2026-03-13 08:23 to 2026-03-14 13:10 local time, 2 daily auto insulin totals)",
        "not read as the basal schedule",
        "no basal advice",
        "the one of 2026-03-12, the latest full day in manual mode",
    ] {
        assert!(note.contains(part), "{part}: {note}");
    }
    let t = abba_io::therapy::therapy_from_contents(
        &[(MIXED.to_string(), fixture(MIXED))],
        &opts(BERLIN),
        &meals,
        None,
    )
    .unwrap();
    assert!(
        t.origin.contains("of 2026-03-12 (manual mode)"),
        "{}",
        t.origin
    );
    assert_eq!(t.notes, c.notes);
    // The advice side still sees the file as a closed loop.
    use abba_io::automation::{Delivery, Evidence};
    assert_eq!(
        Evidence::from_file(&fixture(MIXED)).delivery(),
        Delivery::ClosedLoop
    );
}

#[test]
fn a_manual_day_whose_midnight_rate_was_written_in_auto_mode_is_not_read() {
    let meals = abba_io::meals::MealWindows::default();
    let settings = |bytes: Vec<u8>| {
        abba_io::therapy::carelink_settings(MIXED, &bytes, &opts(BERLIN), &meals).unwrap()
    };
    // 03-11 and 03-12 in auto mode: 03-10 is the manual day, its rate at
    // midnight the row of 00:00 that day.
    let c = settings(mixed_with(&["2026/03/11", "2026/03/12"], &[])).unwrap();
    assert_eq!(c.day.to_string(), "2026-03-10");
    assert_eq!(c.basal[0], (0, 0.65));
    // Without that row, 03-10's midnight rate is the auto day's last row
    // (0.6 at 21:20 on 03-09): no manual day, and the auto stretches named.
    let why = settings(mixed_with(
        &["2026/03/11", "2026/03/12"],
        &["2026/03/10;00:00:00"],
    ))
    .unwrap_err();
    for part in [
        "SmartGuard auto mode",
        "not designed for a closed loop",
        "auto mode on 2026-03-09 (",
        "; 2026-03-11 to 2026-03-14 (",
        "no full local day in manual mode",
    ] {
        assert!(why.contains(part), "{part}: {why}");
    }
}
