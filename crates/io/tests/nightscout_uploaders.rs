//! Nightscout treatments as two uploaders write them, in their real
//! layouts (fixtures with made-up values, see PROVENANCE.md):
//! 600SeriesAndroidUploader with AndroidAPS's NSClient (a MiniMed 670G,
//! mongoexport's one document a line with `$oid`): the pump's resume as a
//! Temp Basal of duration 0 without a rate, a "Temp Basal: 100%" whose
//! percent Nightscout dropped, and Profile Switches to the pump's auto mode
//! with a placeholder basal of 0.000001 U/h; and treatments with an empty
//! eventType that carry insulin and carbs.

use crate::common;
use abba_core::EventKind;
use abba_io::automation::{Delivery, Evidence, AUTO_MODE_SWITCHES};
use abba_io::events::PersonSettings;
use abba_io::read::nightscout::AUTO_MODE_SWITCH;
use abba_io::record::{RecordKind, TempRate};
use common::{fixture, opts, read};

const MINIMED: &str = "nightscout_treatments_600series_mongoexport_synthetic.json";
const NO_EVENT_TYPE: &str = "nightscout_treatments_no_eventtype_synthetic.json";

/// CGM entries in the 600 series uploader's layout (mongoexport: `$oid`,
/// `date` in ms written as a float, `dateString` in the phone's words),
/// every 5 min from 2026-05-04 00:30 to 2026-05-06 12:00 in Madrid (UTC+2).
fn entries() -> Vec<u8> {
    let start: i64 = 1_777_847_400_000; // 2026-05-03T22:30:00Z
    let mut out = String::new();
    for i in 0..(59 * 12 + 6) {
        let ms = start + i * 300_000;
        let t = jiff::Timestamp::from_millisecond(ms).unwrap();
        let local = t.to_zoned(jiff::tz::TimeZone::get("Europe/Madrid").unwrap());
        out.push_str(&format!(
            "{{\"_id\":{{\"$oid\":\"6a1f3c20b7e4d91a2e{i:06x}\"}},\"date\":{},\"dateString\":\"{}\",\"direction\":\"Flat\",\"key600\":\"CGM9A2B{i:04X}\",\"sgv\":{},\"type\":\"sgv\"}}\n",
            format!("{:.12e}", ms as f64).replace('e', "e+"),
            local.strftime("%a %b %d %H:%M:%S GMT+02:00 %Y"),
            110 + (i % 24) * 2
        ));
    }
    out.into_bytes()
}

fn minimed() -> abba_io::Batch {
    read(
        &[
            ("entries.json", entries()),
            ("treatments.json", fixture(MINIMED)),
        ],
        &opts("Europe/Madrid"),
    )
    .unwrap()
}

/// The records at `t` other than CGM readings.
fn kind_at(b: &abba_io::Batch, t: &str) -> Vec<RecordKind> {
    b.records
        .iter()
        .filter(|r| r.at.to_string() == t && r.kind.name() != "cgm")
        .map(|r| r.kind.clone())
        .collect()
}

fn note<'a>(b: &'a abba_io::Batch, part: &str) -> &'a str {
    b.notes
        .iter()
        .find(|n| n.contains(part))
        .unwrap_or_else(|| panic!("a note with {part}: {:?}", b.notes))
}

#[test]
fn a_temp_basal_of_duration_0_without_a_rate_ends_the_running_one() {
    // 600SeriesAndroidUploader's "Pump resumed insulin delivery": refused
    // as a Temp Basal without a rate, the whole file with it.
    let b = minimed();
    let end = RecordKind::TempBasal {
        rate: TempRate::Percent(100.0),
        duration_min: 0,
    };
    // The suspension (0 U/h for 95 min), then the resume.
    assert_eq!(
        kind_at(&b, "2026-05-04T01:15:20Z"),
        vec![RecordKind::TempBasal {
            rate: TempRate::Absolute(abba_core::UnitsPerHour(0.0)),
            duration_min: 95
        }]
    );
    assert_eq!(kind_at(&b, "2026-05-04T02:50:20Z"), vec![end.clone()]);
    assert_eq!(kind_at(&b, "2026-05-06T02:05:44Z"), vec![end]);
    let n = note(&b, "Temp Basals of duration 0");
    for part in [
        "treatments.json: 2 Temp Basals of duration 0 with no absolute, rate or percent (the first at $[2]",
        "Pump resumed insulin delivery",
        "the end of the temporary basal running then",
    ] {
        assert!(n.contains(part), "{part}: {n}");
    }
    // The advisor gets the end as a temp basal of 0 min (its cancel).
    let s = b
        .to_events(&PersonSettings::new(
            abba_io::time::zone("Europe/Madrid").unwrap(),
        ))
        .unwrap();
    let cancels = s
        .events
        .iter()
        .filter(|e| {
            matches!(
                e.kind,
                EventKind::TempBasal {
                    duration_min: 0,
                    ..
                }
            )
        })
        .count();
    assert_eq!(cancels, 2, "{:?}", s.events);
    // A cancel is not a temporary basal started (loop evidence).
    let e = Evidence::from_records(&b.records, &abba_io::time::zone("Europe/Madrid").unwrap());
    assert_eq!(e.temp_basals, 4, "{e:?}");
}

#[test]
fn a_temp_basal_whose_percent_nightscout_dropped_is_the_scheduled_rate() {
    // "Temp Basal: 100%": Nightscout's API v1 drops a percent of 0, the
    // record keeps its duration only.
    let b = minimed();
    assert_eq!(
        kind_at(&b, "2026-05-04T09:20:05Z"),
        vec![RecordKind::TempBasal {
            rate: TempRate::Percent(100.0),
            duration_min: 20
        }]
    );
    let n = note(&b, "Temp Basals with a duration and no");
    for part in [
        "1 Temp Basals with a duration and no absolute, rate or percent (the first at $[11])",
        "drops a percent of 0",
        "100 % of the scheduled rate",
    ] {
        assert!(n.contains(part), "{part}: {n}");
    }
}

#[test]
fn profile_switches_to_the_pumps_auto_mode_are_loop_evidence_not_a_therapy() {
    let b = minimed();
    // Both: the uploader's own (no profileJson) and NSClient's copy with
    // the 0.000001 U/h placeholder.
    for t in ["2026-05-05T02:10:00Z", "2026-05-06T05:20:12Z"] {
        assert_eq!(
            kind_at(&b, t),
            vec![RecordKind::Ignored {
                kind: AUTO_MODE_SWITCH.into()
            }],
            "{t}"
        );
    }
    // The manual profile is read, twice.
    let schedules: Vec<_> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Schedule { profile } => Some((r.at.to_string(), profile.basal.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(schedules.len(), 2, "{schedules:?}");
    assert!(schedules
        .iter()
        .all(|s| s.1.segments.iter().all(|x| x.1 .0 >= 0.7)));
    let n = note(&b, "auto mode");
    for part in [
        "treatments.json: 2 Profile Switches put the pump in its auto mode, from 2026-05-05T02:10:00Z to 2026-05-06T05:20:12Z ($[1], $[7])",
        "a closed loop, not a therapy",
        "no basal rate from them reaches the advisor",
    ] {
        assert!(n.contains(part), "{part}: {n}");
    }
    // No placeholder rate reaches the advisor.
    let s = b
        .to_events(&PersonSettings::new(
            abba_io::time::zone("Europe/Madrid").unwrap(),
        ))
        .unwrap();
    assert!(s.events.iter().all(|e| match e.kind {
        EventKind::BasalRate(r) => r.0 >= 0.7,
        _ => true,
    }));
    assert!(s.counts.get("basal_rate").copied().unwrap_or(0) > 0);
    assert_eq!(s.ignored.get(AUTO_MODE_SWITCH), Some(&2));
    // The file is loop evidence (mongoexport's lines too).
    let e = Evidence::from_file(&fixture(MINIMED));
    assert_eq!(e.systems.get(AUTO_MODE_SWITCHES), Some(&2), "{e:?}");
    assert_eq!(e.delivery(), Delivery::ClosedLoop);
}

#[test]
fn the_therapy_is_the_latest_manual_profile_naming_the_auto_mode_switches_skipped() {
    let meals = abba_io::meals::MealWindows::default();
    let t = abba_io::therapy::therapy_from_contents(
        &[("treatments.json".into(), fixture(MINIMED))],
        &opts("Europe/Madrid"),
        &meals,
        None,
    )
    .unwrap();
    assert_eq!(
        t.basal,
        vec![(0, 0.9), (360, 1.1), (720, 0.7), (1320, 0.85)]
    );
    assert_eq!(t.carb_ratio, [9.0, 12.0, 11.0]);
    assert_eq!(t.at.to_string(), "2026-05-05T09:05:40Z");
    let [n] = &t.notes[..] else {
        panic!("one note: {:?}", t.notes)
    };
    for part in [
        "2 Profile Switches to the pump's auto mode",
        "from 2026-05-05T02:10:00Z to 2026-05-06T05:20:12Z, the latest at treatments.json: $[1]",
        "were skipped",
        "the latest manual profile, of 2026-05-05T09:05:40Z",
    ] {
        assert!(n.contains(part), "{part}: {n}");
    }
    // An export whose only profiles are auto mode has no therapy, and says why.
    let only_auto: Vec<u8> = String::from_utf8(fixture(MINIMED))
        .unwrap()
        .lines()
        .filter(|l| !l.contains("\"Basal 1\""))
        .flat_map(|l| format!("{l}\n").into_bytes())
        .collect();
    let e = abba_io::therapy::therapy_from_contents(
        &[("treatments.json".into(), only_auto)],
        &opts("Europe/Madrid"),
        &meals,
        None,
    )
    .unwrap_err()
    .to_string();
    for part in [
        "no settings profile",
        "the files' only Profile Switches with a profile are 2 Profile Switches to the pump's auto mode",
        "the files hold no manual profile",
        "--basal and --carb-ratio",
    ] {
        assert!(e.contains(part), "{part}: {e}");
    }
}

#[test]
fn a_profile_named_auto_mode_with_real_rates_is_a_profile_and_an_unnamed_placeholder_is_not() {
    let switch = |name: &str, rate: &str| {
        format!(
            r#"{{"_id":"{name}{rate}","eventType":"Profile Switch","created_at":"2026-05-05T09:00:00Z","profile":"{name}","duration":0,"profileJson":"{{\"basal\":[{{\"time\":\"00:00\",\"value\":\"{rate}\"}}],\"carbratio\":[{{\"time\":\"00:00\",\"value\":\"10\"}}]}}"}}"#
        )
    };
    let kinds = |doc: String| {
        read(&[("t.json", doc.into_bytes())], &opts("Europe/Madrid"))
            .unwrap()
            .records
            .into_iter()
            .map(|r| r.kind.name())
            .collect::<Vec<_>>()
    };
    assert_eq!(kinds(switch("Auto Mode", "0.8")), vec!["basal_schedule"]);
    assert_eq!(kinds(switch("Auto Mode", "0.01")), vec!["ignored"]);
    assert_eq!(kinds(switch("Basal 2", "0.0005")), vec!["ignored"]);
    assert_eq!(kinds(switch("Basal 2", "0.8")), vec!["basal_schedule"]);
}

#[test]
fn treatments_without_an_event_type_are_read_for_their_insulin_and_carbs() {
    // Nightscout's IOB and COB count them; abba read them as "" and dropped them.
    let b = read(
        &[("treatments.json", fixture(NO_EVENT_TYPE))],
        &opts("Europe/Moscow"),
    )
    .unwrap();
    let mut at = kind_at(&b, "2026-03-12T16:05:12.318Z");
    at.sort_by_key(|k| k.name());
    assert_eq!(
        at,
        vec![
            RecordKind::Bolus {
                units: abba_core::Units(4.5)
            },
            RecordKind::Carbs {
                grams: abba_core::Grams(48.0)
            },
        ]
    );
    assert_eq!(
        kind_at(&b, "2026-03-10T22:35:44.871Z"),
        vec![RecordKind::Bolus {
            units: abba_core::Units(1.5)
        }]
    );
    let n = note(&b, "without an eventType");
    assert!(
        n.contains("treatments.json: 2 treatments without an eventType"),
        "{n}"
    );
    let s = b
        .to_events(&PersonSettings::new(
            abba_io::time::zone("Europe/Moscow").unwrap(),
        ))
        .unwrap();
    assert!(s.ignored.is_empty(), "{:?}", s.ignored);
    // A document with no eventType at all, and AndroidAPS's "<None>" with
    // nothing in it; a dose is checked as any bolus, naming its place.
    let docs = r#"[
 {"_id":"a","carbs":20,"created_at":"2026-03-12T08:00:00Z"},
 {"_id":"b","eventType":"<None>","insulin":0,"carbs":0,"created_at":"2026-03-12T09:00:00Z"}
]"#;
    let b = read(&[("t.json", docs.into())], &opts("Europe/Moscow")).unwrap();
    let kinds: Vec<_> = b.records.iter().map(|r| r.kind.clone()).collect();
    assert_eq!(
        kinds,
        vec![
            RecordKind::Carbs {
                grams: abba_core::Grams(20.0)
            },
            RecordKind::Ignored {
                kind: "treatment without eventType, insulin or carbs".into()
            }
        ]
    );
    let bad = r#"[{"_id":"c","eventType":"","insulin":400,"created_at":"2026-03-12T08:00:00Z"}]"#;
    let e = read(&[("t.json", bad.into())], &opts("Europe/Moscow"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("t.json") && e.contains("$[0]") && e.contains("insulin"),
        "{e}"
    );
}

const XDRIP: &str = "nightscout_treatments_xdrip_injections_synthetic.json";

#[test]
fn xdrip_and_careportal_treatments_of_event_type_none_are_read_and_pens_basal_is_not_a_bolus() {
    // xDrip+ and Careportal write "<none>" (lowercase) as the event type of
    // plain insulin and carbs: abba ignored them all. xDrip+'s multiple
    // insulins name each injection; its `insulin` is their sum, so a
    // Lantus dose was read as a 22 U bolus.
    let b = read(
        &[("treatments.json", fixture(XDRIP))],
        &opts("Europe/London"),
    )
    .unwrap();
    let u = |x: f64| abba_core::Units(x);
    assert_eq!(
        kind_at(&b, "2026-03-09T21:30:00Z"),
        vec![RecordKind::LongActing { units: u(22.0) }]
    );
    let mut dinner = kind_at(&b, "2026-03-10T18:45:00Z");
    dinner.sort_by_key(|k| k.name());
    assert_eq!(
        dinner,
        vec![
            RecordKind::Bolus { units: u(7.0) },
            RecordKind::Carbs {
                grams: abba_core::Grams(70.0)
            },
            RecordKind::LongActing { units: u(22.0) },
        ]
    );
    let mut lunch = kind_at(&b, "2026-03-10T12:15:00Z");
    lunch.sort_by_key(|k| k.name());
    assert_eq!(
        lunch,
        vec![
            RecordKind::Bolus { units: u(6.5) },
            RecordKind::Carbs {
                grams: abba_core::Grams(60.0)
            },
        ]
    );
    // Careportal's "<none>": its insulin and carbs, as Nightscout counts them.
    let mut snack = kind_at(&b, "2026-03-10T15:30:00Z");
    snack.sort_by_key(|k| k.name());
    assert_eq!(
        snack,
        vec![
            RecordKind::Bolus { units: u(1.5) },
            RecordKind::Carbs {
                grams: abba_core::Grams(15.0)
            },
        ]
    );
    // An insulin whose acting type xDrip+ did not know is counted, not read.
    assert_eq!(
        kind_at(&b, "2026-03-10T22:10:00Z"),
        vec![RecordKind::Ignored {
            kind: "insulin injection of unknown (acting type not known)".into()
        }]
    );
    // Pens' basal insulin and no pump record: injections, not a pump.
    let e = Evidence::from_records(&b.records, &jiff::tz::TimeZone::UTC);
    assert_eq!(e.delivery(), Delivery::Injections, "{e:?}");

    // A total the injections do not add up to, or a list that is not one,
    // is refused naming the field.
    for (doc, field) in [
        (
            r#"{"_id":"a","eventType":"<none>","insulin":9,"insulinInjections":"[{\"insulin\":\"Humalog\",\"units\":4.0}]","created_at":"2026-03-12T08:00:00Z"}"#,
            "insulin",
        ),
        (
            r#"{"_id":"b","eventType":"<none>","insulin":4,"insulinInjections":"Humalog 4","created_at":"2026-03-12T08:00:00Z"}"#,
            "insulinInjections",
        ),
        (
            r#"{"_id":"c","eventType":"<none>","insulin":4,"insulinInjections":[{"insulin":"Humalog"}],"created_at":"2026-03-12T08:00:00Z"}"#,
            "insulinInjections[0].units",
        ),
    ] {
        let e = read(&[("t.json", format!("[{doc}]").into())], &opts("UTC"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.json") && e.contains(field), "{field}: {e}");
    }
    // Careportal's "Temp Basal Start" / "End" as other tools post them.
    let temps = r#"[
 {"_id":"t1","eventType":"Temp Basal Start","absolute":0.4,"duration":60,"created_at":"2026-03-12T08:00:00Z"},
 {"_id":"t2","eventType":"Temp Basal End","created_at":"2026-03-12T08:30:00Z"}
]"#;
    let b = read(&[("t.json", temps.into())], &opts("UTC")).unwrap();
    let kinds: Vec<_> = b.records.iter().map(|r| r.kind.clone()).collect();
    assert_eq!(
        kinds,
        vec![
            RecordKind::TempBasal {
                rate: TempRate::Absolute(abba_core::UnitsPerHour(0.4)),
                duration_min: 60
            },
            RecordKind::TempBasal {
                rate: TempRate::Percent(100.0),
                duration_min: 0
            },
        ]
    );
}
