//! AndroidAPS's treatments in Nightscout, each in AndroidAPS's own field
//! layout (`nightscout_treatments_aaps_synthetic.json`, see
//! PROVENANCE.md): percent and absolute temp basals with AndroidAPS's
//! converted `rate`, suspensions written as temp basals, an extended bolus
//! run as a temp basal, documents deleted in AndroidAPS (`isValid: false`).

use crate::common;
use abba_io::record::{RecordKind, TempRate};
use abba_io::ReadOptions;
use common::{fixture, read};

/// The fixture's records as (UTC time, kind), oldest first.
fn records() -> Vec<(String, RecordKind)> {
    let b = read(
        &[(
            "treatments.json",
            fixture("nightscout_treatments_aaps_synthetic.json"),
        )],
        &ReadOptions::default(),
    )
    .unwrap();
    b.records
        .iter()
        .map(|r| (r.at.to_string(), r.kind.clone()))
        .collect()
}

fn at(records: &[(String, RecordKind)], t: &str) -> RecordKind {
    let found: Vec<&RecordKind> = records
        .iter()
        .filter(|(at, _)| at == t)
        .map(|(_, k)| k)
        .collect();
    assert_eq!(found.len(), 1, "{t}: {found:?}");
    found[0].clone()
}

fn temp(rate: TempRate, duration_min: u32) -> RecordKind {
    RecordKind::TempBasal { rate, duration_min }
}

#[test]
fn a_percent_temp_basal_is_its_percentage_never_the_rate_beside_it() {
    let r = records();
    // `percent` 20 beside AndroidAPS's converted `rate` 0.96 U/h.
    assert_eq!(
        at(&r, "2026-03-10T21:40:00Z"),
        temp(TempRate::Percent(120.0), 30)
    );
    // A 3.0 development build wrote the percentage as `rate` (30): not
    // 30 U/h, a 30 % temp basal.
    assert_eq!(
        at(&r, "2026-03-10T21:10:00Z"),
        temp(TempRate::Percent(30.0), 30)
    );
}

#[test]
fn an_absolute_temp_basal_lasts_its_milliseconds_not_the_minutes_cut_down() {
    // `duration` 7, `durationInMilliseconds` 479000 (7.98 min).
    let r = records();
    assert_eq!(
        at(&r, "2026-03-10T20:40:00Z"),
        temp(TempRate::Absolute(abba_core::UnitsPerHour(1.5)), 8)
    );
}

#[test]
fn androidaps_suspensions_written_as_temp_basals_are_suspensions() {
    let r = records();
    for t in ["2026-03-10T19:00:00Z", "2026-03-10T17:00:00Z"] {
        assert!(
            matches!(at(&r, t), RecordKind::Suspend { duration_min: Some(d) } if d == 60 || d == 45),
            "{t}"
        );
    }
    // A superbolus's zero temp basal stays a temp basal.
    assert_eq!(
        at(&r, "2026-03-10T15:00:00Z"),
        temp(TempRate::Absolute(abba_core::UnitsPerHour(0.0)), 120)
    );
    // A suspension type with a rate is counted, not read.
    let odd = br#"[{"_id":"x","created_at":"2026-03-10T19:00:00.000Z","eventType":"Temp Basal","duration":60,"type":"PUMP_SUSPEND","rate":0.8,"absolute":0.8}]"#;
    let b = read(&[("t.json", odd.to_vec())], &ReadOptions::default()).unwrap();
    assert!(matches!(&b.records[0].kind, RecordKind::Ignored { kind }
        if kind == "Temp Basal of type PUMP_SUSPEND with a rate above zero"));
}

#[test]
fn an_extended_bolus_run_as_a_temp_basal_counts_its_insulin_once() {
    let r = records();
    // The temp basal (scheduled 0.8 + extended 1.5 U/h) and nothing more
    // at 13:00: the nested Combo Bolus is the same insulin.
    assert_eq!(
        at(&r, "2026-03-10T13:00:00Z"),
        temp(TempRate::Absolute(abba_core::UnitsPerHour(2.3)), 20)
    );
    // A real extended bolus, cut short: all of it extended, over its
    // milliseconds (1790000: 29.8 min, `duration` says 29).
    let RecordKind::ExtendedBolus {
        now,
        extended,
        duration_min,
    } = at(&r, "2026-03-10T12:00:00Z")
    else {
        panic!("not an extended bolus")
    };
    assert_eq!((now.0, extended.0, duration_min), (0.0, 2.0, 30));
    let ext = r
        .iter()
        .filter(|(_, k)| matches!(k, RecordKind::ExtendedBolus { .. }))
        .count();
    assert_eq!(ext, 1);
}

#[test]
fn documents_deleted_in_androidaps_are_counted_not_read() {
    let r = records();
    assert_eq!(
        at(&r, "2026-03-10T11:00:00Z"),
        RecordKind::Ignored {
            kind: "Temp Basal marked isValid: false (deleted where it was written)".into()
        }
    );
    assert!(matches!(
        at(&r, "2026-03-10T10:00:00Z"),
        RecordKind::Ignored { .. }
    ));
    // The only bolus read is the SMB that was not deleted.
    let boluses: Vec<f64> = r
        .iter()
        .filter_map(|(_, k)| match k {
            RecordKind::Bolus { units } => Some(units.0),
            _ => None,
        })
        .collect();
    assert_eq!(boluses, vec![0.4]);
    // `isValid` that is not a boolean is an error naming the field.
    let bad = br#"[{"_id":"x","created_at":"2026-03-10T10:00:00.000Z","eventType":"Correction Bolus","insulin":1,"isValid":"no"}]"#;
    let e = read(&[("t.json", bad.to_vec())], &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("isValid"), "{e}");
}

/// `nightscout_treatments_aaps_profile_switch_synthetic.json`: a
/// permanent Profile Switch (LocalProfile0, 100 %), a 150 % one for 60 min
/// that ended within the data, and an 80 % one for 120 min (exercise)
/// started 40 min before the file's last record, so still running at its
/// end; each with AndroidAPS's Effective Profile Switch beside it (a
/// `Note` with `originalProfileName`).
const SWITCHES: &str = "nightscout_treatments_aaps_profile_switch_synthetic.json";

fn zurich() -> ReadOptions {
    common::opts("Europe/Zurich")
}

/// The schedule records: (instant, basal rates to 0.001 U/h, temporary
/// minutes).
fn schedules(b: &abba_io::Batch) -> Vec<(String, Vec<f64>, Option<u32>)> {
    b.records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Schedule { profile } => Some((
                r.at.to_string(),
                profile
                    .basal
                    .segments
                    .iter()
                    .map(|s| (s.1 .0 * 1000.0).round() / 1000.0)
                    .collect(),
                profile.temporary_min,
            )),
            _ => None,
        })
        .collect()
}

#[test]
fn a_temporary_switch_running_at_the_end_is_in_force_in_its_window_only() {
    let b = read(&[("treatments.json", fixture(SWITCHES))], &zurich()).unwrap();
    let base = vec![0.8, 1.0, 0.9, 0.85];
    let s = |at: &str, basal: Vec<f64>, t: Option<u32>| (at.to_string(), basal, t);
    assert_eq!(
        schedules(&b),
        vec![
            s("2026-03-08T07:00:00Z", base.clone(), None),
            s(
                "2026-03-09T10:00:00Z",
                vec![1.2, 1.5, 1.35, 1.275],
                Some(60)
            ),
            // The 150 % switch ended within the file: the permanent back.
            s("2026-03-09T11:00:00Z", base.clone(), None),
            // The 80 % switch is still running at 18:25: no end record, and
            // it says it is temporary.
            s(
                "2026-03-10T17:45:00Z",
                vec![0.64, 0.8, 0.72, 0.68],
                Some(120)
            ),
        ]
    );
    let note = b
        .notes
        .iter()
        .find(|n| n.contains("still running"))
        .expect("a note on the running switch");
    for part in [
        "treatments.json: the Profile Switch of 2026-03-10T17:45:00Z ($[1], profile \"LocalProfile0(80%)\" at 80 %)",
        "120 min, until 2026-03-10T19:45:00Z",
        "2026-03-10T18:25:00Z",
        "not taken as the person's settings",
        "the permanent Profile Switch of 2026-03-08T07:00:00Z ($[11]",
    ] {
        assert!(note.contains(part), "{part}: {note}");
    }
    // The Effective Profile Switches (AndroidAPS writes them as Notes) are
    // counted, not read as profiles.
    assert_eq!(
        b.records
            .iter()
            .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == "Note"))
            .count(),
        4
    );
}

#[test]
fn the_therapy_from_an_export_ending_in_a_temporary_switch_is_the_permanent_profile() {
    let meals = abba_io::meals::MealWindows::default();
    let t = abba_io::therapy::therapy_from_contents(
        &[("treatments.json".into(), fixture(SWITCHES))],
        &zurich(),
        &meals,
        None,
    )
    .unwrap();
    // LocalProfile0 at 100 %, not the 80 % exercise profile.
    assert_eq!(
        t.basal,
        vec![(0, 0.8), (360, 1.0), (720, 0.9), (1080, 0.85)],
        "{t:?}"
    );
    assert_eq!(t.carb_ratio, [10.0, 12.0, 11.0]);
    assert_eq!(t.at.to_string(), "2026-03-09T11:00:00Z");
    assert_eq!(t.temporary_min, None);
    let [note] = &t.notes[..] else {
        panic!("one note: {:?}", t.notes)
    };
    for part in [
        "A temporary profile, treatments.json: $[1] (basal schedule 00:00 0.64, 06:00 0.8, 12:00 0.72, 18:00 0.68 U/h (mean 0.710 U/h), carb ratios 12.5/15/13.75 g/U,",
        "in force from 2026-03-10T17:45:00Z for 120 min, until 2026-03-10T19:45:00Z",
        "was still running at the end of the data (2026-03-10T18:25:00Z)",
        "not taken as the person's settings",
        "which are the permanent profile it returns to: basal schedule 00:00 0.8, 06:00 1, 12:00 0.9, 18:00 0.85 U/h",
        "in force since 2026-03-09T11:00:00Z",
    ] {
        assert!(note.contains(part), "{part}: {note}");
    }
}

#[test]
fn a_temporary_switch_at_the_end_with_no_permanent_profile_before_it_is_refused() {
    let profile = r#"{\"basal\":[{\"time\":\"00:00\",\"value\":1.0}],\"carbratio\":[{\"time\":\"00:00\",\"value\":10}]}"#;
    let t = format!(
        r#"[
 {{"_id":"b","eventType":"Correction Bolus","created_at":"2026-03-05T08:00:00Z","insulin":1}},
 {{"_id":"p","eventType":"Profile Switch","created_at":"2026-03-05T07:30:00Z","profile":"A(50%)","percentage":50,"duration":120,"originalDuration":7200000,"profileJson":"{profile}"}}
]"#
    );
    let meals = abba_io::meals::MealWindows::default();
    let e = abba_io::therapy::therapy_from_contents(
        &[("t.json".into(), t.into_bytes())],
        &zurich(),
        &meals,
        None,
    )
    .unwrap_err()
    .to_string();
    for part in [
        "t.json: $[1]: the latest settings profile is a temporary profile (basal 0.5 U/h, carb ratios 20/20/20 g/U, in force from 2026-03-05T07:30:00Z for 120 min",
        "was still running at the end of the data",
        "no permanent profile before it",
        "--basal and --carb-ratio",
    ] {
        assert!(e.contains(part), "{part}: {e}");
    }
}
