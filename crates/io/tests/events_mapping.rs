//! Records → advisor events: meal slots by windows, basal rate in force
//! through profiles, temporary basals, suspend/resume; day closes.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_core::{EventKind, MealSlot, Timestamp};
use abba_io::events::PersonSettings;
use common::{fixture, opts, read};

fn nightscout_stream() -> abba_io::events::EventStream {
    let b = read(
        &[
            ("entries.json", fixture("nightscout_entries_synthetic.json")),
            (
                "treatments.json",
                fixture("nightscout_treatments_synthetic.json"),
            ),
            ("profile.json", fixture("nightscout_profile_synthetic.json")),
        ],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    b.to_events(&PersonSettings::new(
        abba_io::time::zone("Europe/Zurich").unwrap(),
    ))
    .unwrap()
}

#[test]
fn nightscout_fixtures_map_to_the_expected_events() {
    let s = nightscout_stream();
    // Day 1 is the first day of data (the profile started on 1 January).
    assert_eq!(s.first_day, "2026-01-12");
    assert!(s.rejected.is_empty(), "{:?}", s.rejected);
    assert_eq!(s.counts["cgm"], 859);
    assert_eq!(s.counts["smbg"], 3);
    assert_eq!(s.counts["meal_announced"], 11);
    assert_eq!(s.counts["bolus"], 11);
    assert_eq!(s.counts["day_closed"], 2);
    // Per day: the profile's 04:00 (0.95) and 09:00 (0.8) segments; the
    // temporary basal (0.4 U/h at 02:30 for 60 min) is a pump event of its own.
    assert_eq!(s.counts["basal_rate"], 6);
    assert_eq!(s.counts["temp_basal"], 3);
    let temp = s
        .events
        .iter()
        .find(|e| matches!(e.kind, EventKind::TempBasal { .. }))
        .unwrap();
    assert_eq!(temp.at, Timestamp(150));
    assert_eq!(
        temp.kind,
        EventKind::TempBasal {
            rate: abba_core::TempBasalRate::UnitsPerHour(abba_core::UnitsPerHour(0.4)),
            duration_min: 60
        }
    );
    let basal: Vec<(i64, f64)> = s
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::BasalRate(r) if e.at.day_index() == 0 => Some((e.at.minute_of_day(), r.0)),
            _ => None,
        })
        .collect();
    assert_eq!(basal, vec![(240, 0.95), (540, 0.8)]);
    assert_eq!(s.ignored.get("Sensor Start"), Some(&1));
    assert_eq!(s.ignored.get("Site Change"), Some(&1));
    let slots: Vec<(i64, MealSlot)> = s
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::MealAnnounced { slot, .. } => Some((e.at.day_index(), slot)),
            _ => None,
        })
        .collect();
    use MealSlot::*;
    assert_eq!(
        slots,
        vec![
            (0, Breakfast),
            (0, Lunch),
            (0, Dinner),
            (0, Snack),
            (1, Breakfast),
            (1, Lunch),
            (1, Dinner),
            (1, Snack),
            (2, Breakfast),
            (2, Dinner),
            (2, Snack),
        ]
    );
    // The advisor's order: time, then reading < announcement < bolus < close < basal.
    assert!(s.events.windows(2).all(|w| w[0].at <= w[1].at));
    assert!(s.meal_rule.contains("05:00-10:30"));
}

#[test]
fn percent_temp_basal_suspend_resume_and_a_second_breakfast() {
    let t = r#"[
 {"_id":"p","startDate":"2024-03-04T00:00:00Z","defaultProfile":"D","store":{"D":{"basal":[{"time":"00:00","value":1.0}]}}},
 {"_id":"a","eventType":"Temp Basal","created_at":"2024-03-04T03:00:00Z","percent":-30,"duration":30},
 {"_id":"b","eventType":"Suspend Pump","created_at":"2024-03-04T05:00:00Z"},
 {"_id":"c","eventType":"Resume Pump","created_at":"2024-03-04T05:20:00Z"},
 {"_id":"d","eventType":"Meal Bolus","created_at":"2024-03-04T07:00:00Z","carbs":50,"insulin":5},
 {"_id":"e","eventType":"Meal Bolus","created_at":"2024-03-04T09:00:00Z","carbs":30,"insulin":3},
 {"_id":"f","eventType":"Temp Basal","created_at":"2024-03-04T10:00:00Z","absolute":2.0,"duration":120},
 {"_id":"g","eventType":"Temp Basal","created_at":"2024-03-04T11:00:00Z","duration":0,"absolute":0},
 {"_id":"h","type":"sgv","sgv":120,"date":1709557200000}
]"#;
    let b = read(&[("t.json", t.into())], &opts("UTC")).unwrap();
    let s = b
        .to_events(&PersonSettings::new(abba_io::time::zone("UTC").unwrap()))
        .unwrap();
    use abba_core::{TempBasalRate, UnitsPerHour};
    let pump: Vec<(i64, EventKind)> = s
        .events
        .iter()
        .filter(|e| {
            matches!(
                e.kind,
                EventKind::BasalRate(_)
                    | EventKind::TempBasal { .. }
                    | EventKind::Suspend
                    | EventKind::Resume
            )
        })
        .map(|e| (e.at.minutes(), e.kind))
        .collect();
    // Nightscout's percent -30 is 70 % of the schedule for 30 min; the
    // suspension 05:00-05:20; 2.0 U/h at 10:00 for 120 min, cancelled
    // (duration 0) at 11:00. The profile's flat rate emits nothing.
    let temp = |rate, duration_min| EventKind::TempBasal { rate, duration_min };
    assert_eq!(
        pump,
        vec![
            (180, temp(TempBasalRate::Percent(70.0), 30)),
            (300, EventKind::Suspend),
            (320, EventKind::Resume),
            (
                600,
                temp(TempBasalRate::UnitsPerHour(UnitsPerHour(2.0)), 120)
            ),
            (660, temp(TempBasalRate::UnitsPerHour(UnitsPerHour(0.0)), 0)),
        ]
    );
    let meals: Vec<_> = s
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::MealAnnounced { slot, carbs } => Some((e.at, slot, carbs.0)),
            _ => None,
        })
        .collect();
    assert_eq!(
        meals,
        vec![
            (Timestamp(420), MealSlot::Breakfast, 50.0),
            (Timestamp(540), MealSlot::Snack, 30.0)
        ]
    );
}

/// A profile naming another zone is noted only when that zone keeps
/// another clock at the profile's time: Loop writes "ETC/GMT+7" for a
/// person in Phoenix (the same clock all year); Denver's summer time is an
/// hour ahead of Phoenix.
#[test]
fn a_profile_zone_is_noted_only_when_its_clock_differs() {
    let notes = |zone: &str| {
        let t = format!(
            r#"[{{"_id":"p","startDate":"2024-07-04T07:00:00Z","defaultProfile":"D","store":{{"D":{{"timezone":"{zone}","basal":[{{"time":"00:00","value":1.0}}]}}}}}},
 {{"_id":"h","type":"sgv","sgv":120,"date":1720080000000}}]"#
        );
        let b = read(&[("t.json", t.into())], &opts("America/Phoenix")).unwrap();
        b.to_events(&PersonSettings::new(
            abba_io::time::zone("America/Phoenix").unwrap(),
        ))
        .unwrap()
        .notes
        .into_iter()
        .filter(|n| n.contains("names time zone"))
        .count()
    };
    assert_eq!(notes("ETC/GMT+7"), 0);
    assert_eq!(notes("America/Phoenix"), 0);
    assert_eq!(notes("America/Denver"), 1);
    assert_eq!(notes("Mars/Olympus"), 1);
}
