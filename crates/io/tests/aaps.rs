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
