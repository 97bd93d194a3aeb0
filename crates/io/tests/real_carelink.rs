//! A real CareLink export of a Spanish Paradigm Veo 754 (HUPA-UCM, person
//! HUPA0001P, 16-19 June 2018; see tests/data/PROVENANCE.md): the pump's
//! low-glucose suspensions end at their resume rows, and carbohydrate in
//! exchanges is read only with `grams_per_exchange`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_io::record::{Record, RecordKind, TempRate};
use abba_io::ReadOptions;
use common::{fixture, opts, read};
use jiff::civil::datetime;

const FILE: &str = "carelink_veo754_hupa0001p.csv";
const TZ: &str = "Europe/Madrid";

fn with_exchanges(g: f64) -> ReadOptions {
    ReadOptions {
        grams_per_exchange: Some(g),
        ..opts(TZ)
    }
}

fn at(y: i16, mo: i8, d: i8, h: i8, mi: i8, s: i8) -> jiff::Timestamp {
    datetime(y, mo, d, h, mi, s, 0)
        .to_zoned(abba_io::time::zone(TZ).unwrap())
        .unwrap()
        .timestamp()
}

/// Basal delivered between `from` and `to` as the records say: the latest
/// `Basal Rate` row's rate, a temporary basal's rate for its duration,
/// nothing while suspended.
fn delivered(records: &[Record], from: jiff::Timestamp, to: jiff::Timestamp) -> f64 {
    let mut rate = None::<f64>;
    let mut temp: Option<(TempRate, jiff::Timestamp)> = None;
    let mut suspended = false;
    let mut total = 0.0;
    let mut last = from;
    let now = |rate: Option<f64>, temp: &Option<(TempRate, jiff::Timestamp)>, t| {
        let base = rate.expect("a rate is known at the start");
        match temp {
            Some((TempRate::Percent(p), end)) if t < *end => base * p / 100.0,
            Some((TempRate::Absolute(r), end)) if t < *end => r.0,
            _ => base,
        }
    };
    for r in records {
        if r.at > from && r.at < to {
            let h = r.at.duration_since(last).as_secs_f64() / 3600.0;
            if !suspended && h > 0.0 {
                total += now(rate, &temp, last) * h;
            }
            last = r.at;
        }
        if r.at >= to {
            break;
        }
        match &r.kind {
            RecordKind::Schedule { profile } => rate = Some(profile.basal.segments[0].1 .0),
            RecordKind::TempBasal {
                rate: t,
                duration_min,
            } => {
                let end = r.at + jiff::SignedDuration::from_mins(i64::from(*duration_min));
                temp = Some((*t, end));
            }
            RecordKind::Suspend { .. } => suspended = true,
            RecordKind::Resume => suspended = false,
            _ => {}
        }
    }
    if !suspended {
        total += now(rate, &temp, last) * to.duration_since(last).as_secs_f64() / 3600.0;
    }
    total
}

#[test]
fn every_low_glucose_suspension_ends_at_its_resume_row() {
    let b = read(&[(FILE, fixture(FILE))], &opts(TZ)).unwrap();
    // By hand from the schedule (0.85 U/h from 00:00, 0.65 from 03:00,
    // 0.50 from 05:00, 0.45 from 09:00, 1.10 from 17:00, 0.90 from 19:00,
    // 0.70 from 21:00: 15.55 U a day) less the suspensions:
    // 16/06 21:59:26 LOWSG_SUSPEND .. 22:28:07 USER_RESTART_BASAL (0.70 U/h),
    // 18/06 15:19:26 LOWSG_SUSPEND .. 15:57:38 USER_RESTART_BASAL (0.45),
    // 18/06 22:55:45 LOWSG_SUSPEND .. 19/06 00:55:00 AUTO_RESUME_COMPLETE
    // (0.70, then 0.85). The temporary basal of 18/06 03:36:55 (70 %, 4 h)
    // lies between the two stretches.
    let a = delivered(
        &b.records,
        at(2018, 6, 16, 21, 0, 0),
        at(2018, 6, 18, 3, 36, 55),
    );
    let by_hand_a = 2.1 - 0.70 * (28.0 + 41.0 / 60.0) / 60.0
        + 15.55
        + 2.55
        + 0.65 * (36.0 + 55.0 / 60.0) / 60.0;
    assert!((a - by_hand_a).abs() < 1e-6, "{a} vs {by_hand_a}");
    assert!((a - 20.2653).abs() < 1e-3, "{a}");
    let c = delivered(
        &b.records,
        at(2018, 6, 18, 7, 36, 55),
        at(2018, 6, 19, 21, 0, 0),
    );
    let by_hand_c = 0.50 * (83.0 + 5.0 / 60.0) / 60.0
        + (3.6 - 0.45 * (38.0 + 12.0 / 60.0) / 60.0)
        + 4.0
        + (2.1 - 0.70 * (64.0 + 15.0 / 60.0) / 60.0)
        + 0.85 * 125.0 / 60.0
        + 10.9;
    assert!((c - by_hand_c).abs() < 1e-6, "{c} vs {by_hand_c}");
    // Under the temporary basal the pump wrote the rate in effect (0,46
    // U/h at its start, 0,35 from 05:00): what it delivered, not 70 % of it.
    let temp = delivered(
        &b.records,
        at(2018, 6, 18, 3, 36, 55),
        at(2018, 6, 18, 7, 36, 55),
    );
    let by_hand_temp = 0.46 * (83.0 + 5.0 / 60.0) / 60.0 + 0.35 * (156.0 + 55.0 / 60.0) / 60.0;
    assert!(
        (temp - by_hand_temp).abs() < 1e-6,
        "{temp} vs {by_hand_temp}"
    );
    let all = delivered(
        &b.records,
        at(2018, 6, 16, 21, 0, 0),
        at(2018, 6, 19, 21, 0, 0),
    );
    assert!(
        (all - (by_hand_a + by_hand_temp + by_hand_c)).abs() < 1e-6,
        "{all}"
    );
    assert!((all - 43.8447).abs() < 1e-3, "{all}");
    // Every suspend state read as a suspension, every resume state as a
    // resumption; the NORMAL_PUMPING rows seconds after a resume are
    // counted, not read as a second resumption.
    let n = |k: &str| b.count(k);
    assert_eq!(n("suspend"), 9);
    assert_eq!(n("resume"), 3);
    let second = b
        .records
        .iter()
        .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind.starts_with("resume row while pumping")))
        .count();
    assert_eq!(second, 2);
    assert!(!b.records.iter().any(
        |r| matches!(&r.kind, RecordKind::Ignored { kind } if kind.contains("suspend state"))
    ));
}

#[test]
fn each_suspend_and_resume_state_maps_as_listed() {
    let text = String::from_utf8(fixture(FILE)).unwrap();
    // One state put in place of the 16/06 22:28:07 USER_RESTART_BASAL.
    let states = [
        ("USER_SUSPEND", "suspend"),
        ("ALARM_SUSPEND", "suspend"),
        ("NOTSEATED_SUSPEND", "suspend"),
        ("LOWSG_SUSPEND", "suspend"),
        ("LOW_SUSPEND_MODE_1", "suspend"),
        ("LOW_SUSPEND_NO_RESPONSE", "suspend"),
        ("LOW_SUSPEND_USER_SELECTED", "suspend"),
        ("NORMAL_PUMPING", "resume"),
        ("USER_RESTART_BASAL", "resume"),
        ("AUTO_RESUME_COMPLETE", "resume"),
        ("AUTO_RESUME_REDUCED", "resume"),
        ("LOW_SOMETHING_NEW", "unknown"),
    ];
    let line = text
        .lines()
        .find(|l| l.contains(";16/06/2018;22:28:07;") && l.contains("USER_RESTART_BASAL"))
        .unwrap();
    for (state, want) in states {
        let t = text.replace(line, &line.replace("USER_RESTART_BASAL", state));
        let b = read(&[("x.csv", t.into_bytes())], &opts(TZ)).unwrap();
        let r = b
            .records
            .iter()
            .find(|r| {
                r.at == at(2018, 6, 16, 22, 28, 7) && !matches!(r.kind, RecordKind::Schedule { .. })
            })
            .unwrap();
        let got = match &r.kind {
            RecordKind::Suspend { duration_min: None } => "suspend".to_string(),
            RecordKind::Resume => "resume".to_string(),
            RecordKind::Ignored { kind } if kind == &format!("unknown suspend state {state}") => {
                "unknown".to_string()
            }
            other => format!("{other:?}"),
        };
        assert_eq!(got, want, "{state}");
    }
}

#[test]
fn exchanges_are_read_as_grams_only_with_grams_per_exchange() {
    let text = String::from_utf8(fixture(FILE)).unwrap();
    // The column's exchanges, summed from the file's own cells.
    let header: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("Index;"))
        .unwrap()
        .split(';')
        .collect();
    let col = header
        .iter()
        .position(|h| *h == "BWZ Carb Input (exchanges)")
        .unwrap();
    let cells: Vec<f64> = text
        .lines()
        .filter(|l| !l.starts_with("Index;"))
        .filter_map(|l| {
            l.split(';')
                .nth(col)
                .filter(|c| !c.is_empty())
                .map(|c| c.parse().unwrap())
        })
        .collect();
    let exchanges: f64 = cells.iter().sum();
    assert_eq!(exchanges, 28.0); // 4 + 3 + 3 + 4 + 2.5 + 0 + 3 + 4 + 2.5 + 2

    let without = read(&[(FILE, fixture(FILE))], &opts(TZ)).unwrap();
    assert_eq!(without.count("carbs"), 0);
    assert!(without.count("bolus") > 0 && without.count("basal_schedule") > 0);
    assert_eq!(without.notes.len(), 1, "{:?}", without.notes);
    let note = &without.notes[0];
    assert!(
        note.starts_with(FILE)
            && note.contains("BWZ Carb Input (exchanges)")
            && note.contains("--grams-per-exchange"),
        "{note}"
    );

    for g in [10.0, 12.0, 15.0] {
        let b = read(&[(FILE, fixture(FILE))], &with_exchanges(g)).unwrap();
        let grams: Vec<f64> = b
            .records
            .iter()
            .filter_map(|r| match &r.kind {
                RecordKind::Carbs { grams } => Some(grams.0),
                _ => None,
            })
            .collect();
        assert_eq!(grams.len(), cells.iter().filter(|&&c| c > 0.0).count());
        assert!((grams.iter().sum::<f64>() - exchanges * g).abs() < 1e-9);
        assert!(b.notes.is_empty(), "{:?}", b.notes);
        let lunch = b
            .records
            .iter()
            .find(|r| {
                r.at == at(2018, 6, 19, 14, 37, 28) && matches!(r.kind, RecordKind::Carbs { .. })
            })
            .unwrap();
        assert!(matches!(lunch.kind, RecordKind::Carbs { grams } if grams.0 == 4.0 * g));
    }
}

#[test]
fn the_wizard_ratio_in_units_per_exchange_becomes_grams_per_unit() {
    let meals = abba_io::meals::MealWindows::default();
    let bytes = fixture(FILE);
    let t = abba_io::therapy::carelink_settings(FILE, &bytes, &with_exchanges(10.0), &meals)
        .unwrap()
        .unwrap();
    // Latest wizard event per window: none at breakfast (05:00-10:30);
    // lunch 19/06 14:37:28 at 1,30 U/Ex; dinner 18/06 21:18:06 at 0,90 U/Ex.
    assert_eq!(t.carb_ratio[0], None);
    assert!((t.carb_ratio[1].unwrap() - 10.0 / 1.3).abs() < 1e-9);
    assert!((t.carb_ratio[2].unwrap() - 10.0 / 0.9).abs() < 1e-9);
    // The basal schedule of 18/06 from its Basal Rate rows but those the Veo
    // writes for the rate in effect (0 at the suspensions of 15:19 and
    // 22:55, 0,46 and 0,35 U/h under the 70 % temporary basal of
    // 03:36:55-07:36:55). The 05:00 change to 0,50 is hidden by the
    // temporary basal: the rate is known again at its end.
    assert_eq!(t.day.to_string(), "2018-06-18");
    assert_eq!(
        t.basal,
        vec![
            (0, 0.85),
            (180, 0.65),
            (456, 0.50),
            (540, 0.45),
            (1020, 1.10),
            (1140, 0.90),
            (1260, 0.70)
        ]
    );
    let t = abba_io::therapy::carelink_settings(FILE, &bytes, &with_exchanges(12.0), &meals)
        .unwrap()
        .unwrap();
    assert!((t.carb_ratio[1].unwrap() - 12.0 / 1.3).abs() < 1e-9);
    // Without the option the ratios are not read, and the origin says why.
    let t = abba_io::therapy::carelink_settings(FILE, &bytes, &opts(TZ), &meals)
        .unwrap()
        .unwrap();
    assert_eq!(t.carb_ratio, [None; 3]);
    assert!(t.origin.contains("BWZ Carb Ratio (U/Ex)"), "{}", t.origin);
}

/// Carbohydrate at an instant (local Madrid time), if any.
fn carbs_at(b: &abba_io::Batch, t: jiff::Timestamp) -> Vec<f64> {
    b.records
        .iter()
        .filter(|r| r.at == t)
        .filter_map(|r| match &r.kind {
            RecordKind::Carbs { grams } => Some(grams.0),
            _ => None,
        })
        .collect()
}

#[test]
fn meal_markers_in_exchanges_are_carbohydrate_only_with_grams_per_exchange() {
    // HUPA0006P's export: `Meal: 2.00exchanges` markers (a hard error for
    // the whole file before).
    const F: &str = "carelink_veo754_hupa0006p_markers.csv";
    let without = read(&[(F, fixture(F))], &opts(TZ)).unwrap();
    let counted = without
        .records
        .iter()
        .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind.starts_with("event marker meal in exchanges")))
        .count();
    assert_eq!(counted, 2);
    assert_eq!(without.count("carbs"), 0);
    assert_eq!(without.notes.len(), 1, "{:?}", without.notes);
    assert!(
        without.notes[0].contains("(3 rows)"),
        "{}",
        without.notes[0]
    );
    let b = read(&[(F, fixture(F))], &with_exchanges(10.0)).unwrap();
    assert_eq!(carbs_at(&b, at(2018, 7, 14, 4, 30, 53)), vec![20.0]);
    assert_eq!(carbs_at(&b, at(2018, 7, 14, 3, 17, 56)), vec![10.0]);
    assert_eq!(carbs_at(&b, at(2018, 7, 14, 0, 16, 32)), vec![30.0]);
    assert_eq!(b.count("carbs"), 3);
}

#[test]
fn the_older_freestyle_libre_software_spanish_export_reads() {
    // HUPA0003P's sensor export: `ID`, `Hora`, `Histórico glucosa (mg/dL)`,
    // `Glucosa leída (mg/dL)` (scans), tab-separated, no metadata line.
    const F: &str = "libreview_freestyle_hupa0003p.csv";
    let text = String::from_utf8(fixture(F)).unwrap();
    let of_type = |t: &str| {
        text.lines()
            .filter(|l| l.split('\t').nth(2) == Some(t))
            .count()
    };
    let b = read(&[(F, fixture(F))], &opts(TZ)).unwrap();
    assert_eq!(b.formats, vec![abba_io::Format::LibreView]);
    assert_eq!(b.count("cgm"), of_type("0"));
    assert_eq!(of_type("0"), 15);
    let scans = b
        .records
        .iter()
        .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == "scan glucose"))
        .count();
    assert_eq!(scans, of_type("1"));
    // The food row (type 5) of 01:46: 16 g.
    let t = datetime(2018, 6, 19, 1, 46, 0, 0)
        .to_zoned(abba_io::time::zone(TZ).unwrap())
        .unwrap()
        .timestamp();
    assert_eq!(carbs_at(&b, t), vec![16.0]);
}

#[test]
fn a_suspension_and_a_resumption_in_one_second_leave_the_pump_running() {
    // HUPA0006P, 16/07/2018 21:55:00 ALARM_SUSPEND (battery alarm), then
    // from 01:27:17 five ALARM_SUSPEND / NORMAL_PUMPING pairs each in one
    // second (the resume row listed first), the clock set back two minutes
    // at 01:32, and the pump's own 1.1 and 0.9 U/h rows at 01:31, 01:32 and
    // 02:00 (written only while it delivers).
    const F: &str = "carelink_veo754_hupa0006p_alarms.csv";
    let b = read(&[(F, fixture(F))], &opts(TZ)).unwrap();
    let d = delivered(
        &b.records,
        at(2018, 7, 16, 21, 55, 0),
        at(2018, 7, 17, 5, 0, 0),
    );
    // By hand: nothing until 01:27:17, 1.1 U/h to 02:00, 0.9 U/h to 05:00.
    let by_hand = 1.1 * (32.0 + 43.0 / 60.0) / 60.0 + 0.9 * 3.0;
    assert!((d - by_hand).abs() < 1e-6, "{d} vs {by_hand}");
}
