//! Temporary basal, suspend/resume and extended bolus reach the advisor's
//! insulin accounting as the insulin they deliver.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_advisor::{Abba, AbbaConfig, Advisor, AdvisorSpec, Mode, R2rConfig};
use abba_core::{
    Event, EventKind, GramsPerUnit, MgDl, TempBasalRate, TherapySettings, Timestamp, Units,
    UnitsPerHour,
};

fn start() -> TherapySettings {
    TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap()
}

fn t(day: i64, minute: i64) -> Timestamp {
    Timestamp::from_day_and_minute(day, minute)
}

/// A week of CGM (days 1-7, closed at each midnight) with `insulin(day)`
/// events inserted in time order.
fn week(insulin: impl Fn(i64) -> Vec<Event>) -> Vec<Event> {
    let mut events = Vec::new();
    for day in 1..=7 {
        let mut day_events: Vec<Event> = (0..288)
            .map(|k| {
                let m = k * 5;
                let g = 140.0 + 40.0 * ((m as f64) / 90.0).sin() + 10.0 * (day as f64).cos();
                Event::new(t(day, m), EventKind::Cgm(MgDl(g)))
            })
            .collect();
        day_events.extend(insulin(day));
        day_events.sort_by_key(|e| e.at);
        if day > 1 {
            events.push(Event::new(t(day, 0), EventKind::DayClosed));
        }
        events.extend(day_events);
    }
    events.push(Event::new(t(8, 0), EventKind::DayClosed));
    events
}

fn init_of(events: &[Event]) -> abba_advisor::InitReport {
    let mut a = Abba::new(AbbaConfig::new(Mode::Cgm, 3), start()).unwrap();
    for e in events {
        a.observe(e).unwrap();
    }
    a.init_report().cloned().unwrap()
}

#[test]
fn a_suspension_and_a_temporary_basal_count_as_the_rates_they_deliver() {
    // 02:00-04:00 suspended, 13:00-14:30 at 40 % of the scheduled 1 U/h.
    let pump_kinds = week(|day| {
        vec![
            Event::new(t(day, 120), EventKind::Suspend),
            Event::new(t(day, 240), EventKind::Resume),
            Event::new(
                t(day, 780),
                EventKind::TempBasal {
                    rate: TempBasalRate::Percent(40.0),
                    duration_min: 90,
                },
            ),
            Event::new(t(day, 420), EventKind::Bolus(Units(4.0))),
        ]
    });
    let plain_rates = week(|day| {
        vec![
            Event::new(t(day, 120), EventKind::BasalRate(UnitsPerHour(0.0))),
            Event::new(t(day, 240), EventKind::BasalRate(UnitsPerHour(1.0))),
            Event::new(t(day, 780), EventKind::BasalRate(UnitsPerHour(0.4))),
            Event::new(t(day, 870), EventKind::BasalRate(UnitsPerHour(1.0))),
            Event::new(t(day, 420), EventKind::Bolus(Units(4.0))),
        ]
    });
    let ignoring_them = week(|day| vec![Event::new(t(day, 420), EventKind::Bolus(Units(4.0)))]);
    let a = init_of(&pump_kinds);
    assert!(
        matches!(a.te, abba_advisor::TeOutcome::Estimated(_)),
        "{:?}",
        a.te
    );
    assert_eq!(a.te, init_of(&plain_rates).te);
    // The pump kinds matter: leaving them out gives another estimate.
    assert_ne!(a.te, init_of(&ignoring_them).te);
}

#[test]
fn every_arm_accepts_the_pump_kinds_and_saves_and_resumes_mid_temp_basal() {
    let events = week(|day| {
        vec![
            Event::new(
                t(day, 300),
                EventKind::TempBasal {
                    rate: TempBasalRate::UnitsPerHour(UnitsPerHour(0.3)),
                    duration_min: 240,
                },
            ),
            Event::new(
                t(day, 720),
                EventKind::ExtendedBolus {
                    total: Units(5.0),
                    immediate: Units(2.0),
                    duration_min: 120,
                },
            ),
        ]
    });
    let cut = events
        .iter()
        .position(|e| e.at == t(4, 400))
        .expect("a CGM reading at 06:40 of day 4, inside the temporary basal");
    for spec in [
        AdvisorSpec::Abba(AbbaConfig::new(Mode::Cgm, 0)),
        AdvisorSpec::RunToRun(R2rConfig::new(Mode::Cgm)),
        AdvisorSpec::Fixed {
            limits: Default::default(),
        },
    ] {
        let mut whole = spec.build(start(), 5).unwrap();
        for e in &events {
            whole.observe(e).unwrap();
        }
        let mut first = spec.build(start(), 5).unwrap();
        for e in &events[..cut] {
            first.observe(e).unwrap();
        }
        let mut resumed = abba_advisor::AnyAdvisor::load_json(&first.save_json().unwrap()).unwrap();
        for e in &events[cut..] {
            resumed.observe(e).unwrap();
        }
        assert_eq!(resumed, whole, "{}", whole.name());
    }
}
