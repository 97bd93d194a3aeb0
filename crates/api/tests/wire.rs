//! The wire form of the bodies: what an app writes parses, unknown fields
//! are refused, and a body survives a round trip.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_api::{EventBody, EventsBody, MealSlot, Setting, TempRate};

#[test]
fn an_app_batch_parses() {
    let json = r#"{"events": [
        {"seq": 1, "at": "2026-03-02T07:00:00+01:00", "event": {"type": "cgm", "mg_dl": 123.5}},
        {"seq": 2, "at": "2026-03-02T07:30:00+01:00", "event": {"type": "meal", "carbs_g": 50, "slot": "breakfast"}},
        {"seq": 3, "at": "2026-03-02T07:30:00+01:00", "event": {"type": "bolus", "units": 4.2}},
        {"seq": 4, "at": "2026-03-02T08:00:00Z", "event": {"type": "temp_basal", "rate": {"percent": 50}, "duration_min": 30}},
        {"seq": 5, "at": "2026-03-03T00:00:00+01:00", "event": {"type": "day_closed"}}
    ]}"#;
    let b: EventsBody = serde_json::from_str(json).unwrap();
    assert_eq!(b.events.len(), 5);
    assert_eq!(
        b.events[1].event,
        EventBody::Meal {
            carbs_g: 50.0,
            slot: MealSlot::Breakfast
        }
    );
    assert_eq!(
        b.events[3].event,
        EventBody::TempBasal {
            rate: TempRate::Percent(50.0),
            duration_min: 30
        }
    );
    assert_eq!(b.events[4].event, EventBody::DayClosed);
    let again: EventsBody = serde_json::from_str(&serde_json::to_string(&b).unwrap()).unwrap();
    assert_eq!(again, b);
}

#[test]
fn unknown_fields_and_kinds_are_refused() {
    for bad in [
        r#"{"events": [{"seq": 1, "at": "2026-03-02T07:00:00Z", "event": {"type": "cgm", "mg_dl": 1, "x": 2}}]}"#,
        r#"{"events": [{"seq": 1, "at": "2026-03-02T07:00:00Z", "event": {"type": "ketones", "mmol": 1}}]}"#,
        r#"{"events": [], "extra": true}"#,
    ] {
        assert!(serde_json::from_str::<EventsBody>(bad).is_err(), "{bad}");
    }
}

#[test]
fn suggestion_ids_encode_minute_and_setting() {
    for s in Setting::ALL {
        let id = s.suggestion_id(2880);
        assert_eq!(Setting::from_suggestion_id(id), (2880, s));
    }
    assert!(Setting::Basal.suggestion_id(2881) > Setting::Dinner.suggestion_id(2880));
}
