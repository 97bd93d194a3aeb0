//! The person path end to end on exports in Nightscout's real layout
//! (entries with `sgv`/`date`/`dateString`, treatments with `eventType`,
//! `created_at`, `enteredBy`, a profile store with time-of-day arrays):
//! therapy from the pump's profile with a 5-segment schedule, a closed
//! loop, a profile long before the first reading, a sensor gap in the first
//! week, a hypoglycaemia treatment, a mismatching profile, the clinician's
//! change at any time.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::steps::on_step;
use abba_advisor::{Mode, PumpSteps};
use abba_io::therapy::therapy_from_files;
use abba_io::ReadOptions;
use abba_store::person::TherapySource;
use abba_store::{NewPerson, ProfileResolution, Store};
use common::TempDir;
use jiff::tz::TimeZone;
use serde_json::{json, Value};
use std::path::PathBuf;

const TZ: &str = "Europe/Zurich";
/// 00:00 of day 1 (2026-05-04) in Zurich (UTC+2), in ms.
const DAY1_MS: i64 = 1_777_845_600_000;

fn iso(ms: i64) -> String {
    jiff::Timestamp::from_millisecond(ms).unwrap().to_string()
}

/// What to put in the export.
#[derive(Clone)]
struct Plan {
    days: i64,
    /// Days (indices) without CGM readings.
    gap: Vec<i64>,
    /// Glucose around which the day moves (mg/dL).
    level: f64,
    /// A closed loop: 5-minute temporary basals and SMBs, entered by iAPS.
    looped: bool,
    /// The loop ran only on the days before this one.
    loop_until_day: Option<i64>,
    /// A low at 10:30 treated with 16 g of "Carb Correction", no bolus.
    rescue: bool,
    /// The profile's start relative to day 1 (days).
    profile_from_day: i64,
    basal: Vec<(&'static str, f64)>,
    carb_ratio: Vec<(&'static str, f64)>,
    /// Meal boluses: (local minute of the day, carbohydrate g).
    meals: Vec<(i64, f64)>,
}

impl Default for Plan {
    fn default() -> Self {
        Plan {
            days: 10,
            gap: Vec::new(),
            level: 150.0,
            looped: false,
            loop_until_day: None,
            rescue: false,
            profile_from_day: -1,
            basal: vec![("00:00", 1.0)],
            carb_ratio: vec![("00:00", 10.0)],
            meals: vec![
                (7 * 60 + 2, 45.0),
                (12 * 60 + 17, 60.0),
                (18 * 60 + 32, 70.0),
            ],
        }
    }
}

fn seconds(t: &str) -> i64 {
    let (h, m) = t.split_once(':').unwrap();
    h.parse::<i64>().unwrap() * 3600 + m.parse::<i64>().unwrap() * 60
}

/// Writes entries.json, treatments.json, profile.json into `dir`.
fn export(dir: &std::path::Path, plan: &Plan) -> Vec<PathBuf> {
    let mut entries = Vec::new();
    let mut treatments = Vec::new();
    let mut n = 0u64;
    let mut id = || {
        n += 1;
        format!("{n:024x}")
    };
    for day in 0..plan.days {
        let base = DAY1_MS + day * 86_400_000;
        for k in 0..288i64 {
            if plan.gap.contains(&day) {
                break;
            }
            let ms = base + k * 300_000;
            let m = (k * 5) as f64;
            let mut g = plan.level + 40.0 * (m / 240.0 + day as f64).sin();
            if plan.rescue && (620..=635).contains(&(k * 5)) {
                g = 62.0;
            }
            entries.push(
                json!({"_id": id(), "type": "sgv", "sgv": g.round(), "date": ms,
                "dateString": iso(ms), "direction": "Flat", "device": "xDrip-DexcomG6"}),
            );
        }
        for &(minute, carbs) in &plan.meals {
            let ms = base + minute * 60_000;
            treatments.push(
                json!({"_id": id(), "eventType": "Meal Bolus", "carbs": carbs,
                "insulin": carbs / 10.0, "created_at": iso(ms), "enteredBy": "pump"}),
            );
        }
        if plan.rescue {
            let ms = base + (10 * 60 + 32) * 60_000;
            treatments.push(
                json!({"_id": id(), "eventType": "Carb Correction", "carbs": 16,
                "created_at": iso(ms), "enteredBy": "pump"}),
            );
        }
        if plan.looped && plan.loop_until_day.is_none_or(|d| day < d) {
            for k in 0..288i64 {
                let ms = base + k * 300_000 + 60_000;
                let rate = if k % 3 == 0 { 0.0 } else { 1.2 };
                treatments.push(
                    json!({"_id": id(), "eventType": "Temp Basal", "duration": 30,
                    "absolute": rate, "rate": rate, "created_at": iso(ms), "enteredBy": "iAPS",
                    "temp": "absolute"}),
                );
                if k % 24 == 0 {
                    treatments.push(json!({"_id": id(), "eventType": "SMB", "insulin": 0.3,
                        "isSMB": true, "created_at": iso(ms + 30_000), "enteredBy": "iAPS"}));
                }
            }
        }
    }
    let arr = |v: &[(&str, f64)]| -> Value {
        v.iter()
            .map(|(t, x)| json!({"time": t, "timeAsSeconds": seconds(t), "value": x}))
            .collect()
    };
    let start = DAY1_MS + plan.profile_from_day * 86_400_000;
    let profile = json!([{"_id": id(), "defaultProfile": "Default", "startDate": iso(start),
        "mills": start, "units": "mg/dl", "store": {"Default": {
            "basal": arr(&plan.basal), "carbratio": arr(&plan.carb_ratio),
            "sens": arr(&[("00:00", 50.0)]), "target_low": arr(&[("00:00", 100.0)]),
            "target_high": arr(&[("00:00", 120.0)]), "timezone": TZ, "units": "mg/dl",
            "dia": 5}}}]);
    let mut paths = Vec::new();
    for (name, v) in [
        ("entries.json", Value::Array(entries)),
        ("treatments.json", Value::Array(treatments)),
        ("profile.json", profile),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
        paths.push(p);
    }
    paths
}

/// A person created from the export's profile (`person new --therapy-from`).
fn person_from(files: &[PathBuf], name: &str) -> NewPerson {
    let opts = ReadOptions {
        tz: Some(TimeZone::get(TZ).unwrap()),
        ..ReadOptions::default()
    };
    let meals = abba_io::meals::MealWindows::default();
    let t = therapy_from_files(files, &opts, &meals).unwrap();
    let mut p = NewPerson::new(name, TZ, Mode::Cgm, t.settings());
    p.settings.basal_schedule = (t.basal.len() > 1).then(|| t.basal.clone());
    p.settings.therapy_source = TherapySource::Profile;
    p.settings.pump_steps = Some(PumpSteps::default());
    p
}

fn setup(tag: &str, plan: &Plan) -> (TempDir, Store, Vec<PathBuf>) {
    let dir = TempDir::new(tag);
    let files = export(&dir.0, plan);
    let mut store = dir.store();
    store.create_person(&person_from(&files, "ana")).unwrap();
    store.import_files("ana", &files, None).unwrap();
    (dir, store, files)
}

#[test]
fn a_five_segment_schedule_is_scaled_by_one_factor_on_the_pumps_step() {
    let plan = Plan {
        level: 80.0,
        basal: vec![
            ("00:00", 0.8),
            ("03:00", 1.1),
            ("07:00", 1.4),
            ("12:00", 1.0),
            ("20:00", 0.9),
        ],
        carb_ratio: vec![("00:00", 9.0), ("11:00", 12.0), ("16:00", 10.0)],
        days: 14,
        ..Plan::default()
    };
    let (_d, mut store, _) = setup("schedule", &plan);
    let a = store.advise("ana").unwrap();
    // In force: the profile's schedule and the carb ratio of each meal window.
    let sched = a
        .therapy
        .basal_schedule
        .clone()
        .expect("a schedule in force");
    assert_eq!(sched.len(), 5);
    let cr: Vec<f64> = a.settings[1..].iter().map(|s| s.in_force).collect();
    let history = store.history("ana").unwrap();
    let first_cr: Vec<f64> = ["breakfast", "lunch", "dinner"]
        .iter()
        .map(|k| history.iter().find(|v| v.setting == *k).unwrap().previous)
        .collect();
    assert_eq!(first_cr, vec![9.0, 12.0, 10.0], "{cr:?}");
    let basal: Vec<_> = history
        .iter()
        .filter(|v| v.setting == "basal" && !v.no_update)
        .collect();
    assert!(!basal.is_empty());
    let mut changed = 0;
    let mut prev: Vec<f64> = plan.basal.iter().map(|b| b.1).collect();
    for v in &basal {
        let s = v
            .schedule
            .as_ref()
            .expect("every basal suggestion is a schedule");
        let new: Vec<f64> = s.iter().map(|x| x.1).collect();
        for (o, n) in prev.iter().zip(&new) {
            assert!(on_step(*n, 0.05), "{n} is not on the 0.05 U/h step");
            assert!(*n >= o * 0.95 - 1e-9 && *n <= o * 1.05 + 1e-9, "{o} -> {n}");
            // One factor: every segment moves the same way.
            assert!((n - o) * (v.suggested - v.previous) >= 0.0, "{o} -> {n}");
        }
        if new != prev {
            changed += 1;
        }
        // The 14 days came in one import: a suggestion followed by the
        // next within it was never shown and left the schedule in force.
        if v.status != "unseen" {
            prev = new;
        }
    }
    assert!(changed > 0, "no basal suggestion moved the schedule");
    assert!(
        basal[..basal.len() - 1]
            .iter()
            .all(|v| v.status == "unseen"),
        "{:?}",
        basal.iter().map(|v| &v.status).collect::<Vec<_>>()
    );
    for v in history
        .iter()
        .filter(|v| v.setting != "basal" && !v.no_update)
    {
        assert!(on_step(v.suggested, 0.1), "{} g/U", v.suggested);
        assert!(v.status != "open" || v.suggested != v.previous);
    }
}

/// The 5-segment schedule of `a_five_segment_schedule_...`, on days low
/// enough that the last basal update lowers it and waits for an answer.
fn open_schedule_plan() -> Plan {
    Plan {
        level: 80.0,
        basal: vec![
            ("00:00", 0.8),
            ("03:00", 1.1),
            ("07:00", 1.4),
            ("12:00", 1.0),
            ("20:00", 0.9),
        ],
        carb_ratio: vec![("00:00", 9.0), ("11:00", 12.0), ("16:00", 10.0)],
        days: 14,
        ..Plan::default()
    }
}

#[test]
fn the_schedule_in_force_is_the_pumps_while_a_basal_suggestion_waits() {
    let plan = open_schedule_plan();
    let (_d, mut store, _) = setup("schedule-open", &plan);
    let a = store.advise("ana").unwrap();
    let basal = &a.settings[0];
    let open = basal.latest.as_ref().expect("a basal suggestion");
    assert_eq!(open.status, "open", "{open:?}");
    let suggested = open.schedule.clone().expect("a suggested schedule");
    let pumps: Vec<(String, f64)> = plan
        .basal
        .iter()
        .map(|&(t, r)| (t.to_string(), r))
        .collect();
    assert_ne!(suggested, pumps, "the suggestion changes the schedule");
    // Not answered: the pump still runs its own schedule.
    assert_eq!(a.therapy.basal_schedule, Some(pumps.clone()));
    assert!((basal.in_force - open.previous).abs() < 1e-12);

    // The report's settings by day: an open suggestion is not in force;
    // the schedule in force is stated, the suggested one beside its line.
    let input =
        abba_store::report::person_input(&mut store, "ana", 3, abba_core::units::GlucoseUnit::MgDl)
            .unwrap();
    let last = input.days.last().unwrap().settings.unwrap();
    assert!(
        (last.basal_u_per_h - open.previous).abs() < 1e-12,
        "the last day shows {} U/h in force, the suggestion {} is open",
        last.basal_u_per_h,
        open.suggested
    );
    let in_force = abba_advisor::words::schedule(&pumps);
    assert!(
        input.notes.iter().any(|n| n.contains(&in_force)),
        "no note names the schedule in force ({in_force}): {:?}",
        input.notes
    );
    let line = input
        .suggestions
        .iter()
        .rev()
        .find(|l| l.setting == "basal rate")
        .unwrap();
    assert!(
        line.to.contains(&abba_advisor::words::schedule(&suggested)),
        "{}",
        line.to
    );

    // An own rate for the schedule: the schedule it puts in force (each
    // segment on the pump's step) is the one to program, with its mean.
    let own = ((open.previous / 0.05).round() + 1.0) * 0.05;
    store
        .answer(
            "ana",
            &abba_store::AnswerRequest::Set(vec![(abba_advisor::Parameter::Basal, own)]),
        )
        .unwrap();
    let after = store.advise("ana").unwrap();
    let schedule = after
        .therapy
        .basal_schedule
        .clone()
        .expect("a schedule in force");
    assert_ne!(schedule, pumps, "the own rate is in force");
    let minutes: Vec<(u32, f64)> = schedule
        .iter()
        .map(|(t, r)| {
            let (h, m) = t.split_once(':').unwrap();
            (
                h.parse::<u32>().unwrap() * 60 + m.parse::<u32>().unwrap(),
                *r,
            )
        })
        .collect();
    let mean = after.therapy.basal_schedule_mean.expect("its mean");
    assert!(
        (mean - abba_advisor::steps::mean_rate(&minutes)).abs() < 1e-12,
        "{mean} is the mean of {schedule:?}"
    );
}

#[test]
fn a_schedules_reasons_print_numbers_for_people() {
    let (_d, mut store, _) = setup("schedule-words", &open_schedule_plan());
    let history = store.history("ana").unwrap();
    let long = regex_lite_long_decimal;
    let mut rounded = 0;
    for v in history.iter().filter(|v| v.setting == "basal") {
        for r in &v.reasons {
            assert!(!long(r), "a raw float in: {r}");
            rounded += usize::from(r.contains("rounded to your pump's step"));
        }
    }
    assert!(rounded > 0, "no basal reason about the pump's step");
}

/// True when `text` holds a number with more than four decimals.
fn regex_lite_long_decimal(text: &str) -> bool {
    let b = text.as_bytes();
    b.windows(7)
        .any(|w| w[0].is_ascii_digit() && w[1] == b'.' && w[2..].iter().all(u8::is_ascii_digit))
}

#[test]
fn meals_outside_the_windows_are_named_as_why_a_carb_ratio_gets_no_suggestion() {
    // A night-shift worker: a meal before the shift (22:40), one in it
    // (03:10) and one after sleep (14:05); breakfast and dinner never fall
    // in their windows.
    let plan = Plan {
        meals: vec![
            (22 * 60 + 40, 60.0),
            (3 * 60 + 10, 45.0),
            (14 * 60 + 5, 70.0),
        ],
        ..Plan::default()
    };
    let (_d, mut store, _) = setup("night-shift", &plan);
    let a = store.advise("ana").unwrap();
    for (i, meal) in ["breakfast", "lunch", "dinner"].iter().enumerate() {
        let named = a
            .notes
            .iter()
            .any(|n| n.starts_with(&format!("No {meal} in the data")));
        let seen = i == 1;
        assert_eq!(named, !seen, "{meal}: {:?}", a.notes);
        if !seen {
            assert!(a.settings[i + 1].latest.is_none());
        }
    }
    let note = a
        .notes
        .iter()
        .find(|n| n.starts_with("No breakfast"))
        .unwrap();
    assert!(note.contains("05:00-10:30"), "{note}");
    // Two of each day's three entries were snacks.
    assert!(
        note.contains(&format!("{} entries", 2 * plan.days)),
        "{note}"
    );
    // A person eating the three meals in their windows gets no such note.
    let (_d2, mut store2, _) = setup("day-meals", &Plan::default());
    let a2 = store2.advise("ana").unwrap();
    assert!(
        a2.notes.iter().all(|n| !n.starts_with("No ")),
        "{:?}",
        a2.notes
    );
}

#[test]
fn a_closed_loop_gets_no_basal_suggestion_and_is_named_with_its_evidence() {
    let plan = Plan {
        looped: true,
        days: 10,
        ..Plan::default()
    };
    let (_d, mut store, _) = setup("loop", &plan);
    let a = store.advise("ana").unwrap();
    assert_eq!(a.delivery.kind, abba_io::automation::Delivery::ClosedLoop);
    assert!(!a.delivery.basal_suggestions);
    let ev = a.delivery.evidence.join("; ");
    assert!(ev.contains("SMB") || ev.contains("micro"), "{ev}");
    assert!(
        ev.contains("iaps") && ev.contains("temporary basals"),
        "{ev}"
    );
    let note = a.delivery.note.clone().unwrap_or_default();
    assert!(
        note.contains("closed loop") && note.contains("no basal rate"),
        "{note}"
    );
    let basal = &a.settings[0];
    assert_ne!(
        basal.latest.as_ref().map(|v| v.status.as_str()),
        Some("open")
    );
    assert_eq!(basal.in_force, 1.0);
    assert!(store
        .history("ana")
        .unwrap()
        .iter()
        .filter(|v| v.setting == "basal")
        .all(|v| v.status != "open" && v.in_force == 1.0));
}

#[test]
fn a_loop_given_up_before_the_last_four_weeks_holds_no_advice_and_is_named_as_past() {
    // iAPS looped on days 1-10 of 45, then the pump ran open loop: the
    // last 28 days tell the delivery.
    let plan = Plan {
        looped: true,
        loop_until_day: Some(10),
        days: 45,
        ..Plan::default()
    };
    let (_d, mut store, files) = setup("past-loop", &plan);
    // The import's words say no loop either.
    let again = store.import_files("ana", &files, None).unwrap();
    assert_eq!(again.delivery, None, "{again:?}");
    let a = store.advise("ana").unwrap();
    assert_eq!(
        a.delivery.kind,
        abba_io::automation::Delivery::OpenLoop,
        "{:?}",
        a.delivery
    );
    assert!(a.delivery.basal_suggestions);
    let ev = a.delivery.evidence.join("; ");
    assert!(
        ev.contains("a loop's automated deliveries or marks until 2026-05-13T")
            && ev.contains("a past loop, not counted"),
        "{ev}"
    );
    // A loop that ran until day 30 of 45 is within the last 28 days: the
    // basal is held.
    let plan = Plan {
        loop_until_day: Some(30),
        ..plan
    };
    let (_d, mut store, files) = setup("recent-loop", &plan);
    let again = store.import_files("ana", &files, None).unwrap();
    assert!(again.delivery.is_some(), "{again:?}");
    let a = store.advise("ana").unwrap();
    assert_eq!(a.delivery.kind, abba_io::automation::Delivery::ClosedLoop);
    assert!(!a.delivery.basal_suggestions);
}

#[test]
fn day_one_is_the_first_reading_not_a_profile_eighty_days_before() {
    let plan = Plan {
        profile_from_day: -80,
        days: 3,
        ..Plan::default()
    };
    let (_d, store, _) = setup("day1", &plan);
    assert_eq!(
        store.person("ana").unwrap().first_day.unwrap().to_string(),
        "2026-05-04"
    );
}

#[test]
fn a_two_day_sensor_gap_extends_the_first_week_until_seven_days_qualify() {
    let plan = Plan {
        gap: vec![2, 3],
        days: 8,
        ..Plan::default()
    };
    let (d, mut store, _) = setup("gap", &plan);
    let a = store.advise("ana").unwrap();
    match a.phase {
        abba_store::advise::Phase::FirstWeek {
            days_done,
            days_left,
            ..
        } => {
            // Days 0, 1, 4, 5, 6 closed and qualifying; day 7 is not over.
            assert_eq!((days_done, days_left), (5, 2));
        }
        p => panic!("{p:?}"),
    }
    let w = a.first_week.clone().unwrap();
    assert!(
        w.missing.iter().any(|m| m.starts_with("2026-05-06")),
        "{w:?}"
    );
    assert!(
        w.missing.iter().any(|m| m.starts_with("2026-05-07")),
        "{w:?}"
    );
    assert!(a.settings.iter().all(|s| s.latest.is_none()));
    // Two more days: the 7th qualifying day is day index 8, the first
    // basal update is made at its close.
    let more = export(&d.0, &Plan { days: 10, ..plan });
    store.import_files("ana", &more, None).unwrap();
    let h = store.history("ana").unwrap();
    let first = h.iter().find(|v| v.setting == "basal").unwrap();
    assert_eq!(first.day, 10, "{first:?}");
}

#[test]
fn a_hypoglycaemia_treatment_does_not_move_a_carb_ratio() {
    let with = Plan {
        rescue: true,
        days: 10,
        ..Plan::default()
    };
    let (_a, mut s1, _) = setup("rescue", &with);
    let a = s1.advise("ana").unwrap();
    assert_eq!(a.data.events.get("rescue_carbs"), Some(&10));
    assert!(
        a.notes.iter().any(|n| n.contains("hypoglycaemia")),
        "{:?}",
        a.notes
    );
    // The same data with the lows and without the treatments: the same lunch decisions.
    let events: Vec<_> = s1.events("ana").unwrap();
    let lunches = |s: &mut Store| -> Vec<(i64, f64)> {
        s.history("ana")
            .unwrap()
            .iter()
            .filter(|v| v.setting == "lunch")
            .map(|v| (v.day, v.suggested))
            .collect()
    };
    let l1 = lunches(&mut s1);
    assert!(!l1.is_empty());
    assert!(!events.iter().any(|e| matches!(e.kind,
        abba_core::EventKind::MealAnnounced { carbs, .. } if carbs.0 == 16.0)));
    let dir = TempDir::new("rescue-none");
    let files = export(&dir.0, &with);
    // Drop the treatments from the file: what remains is the lows.
    let t: Vec<Value> = serde_json::from_slice::<Vec<Value>>(&std::fs::read(&files[1]).unwrap())
        .unwrap()
        .into_iter()
        .filter(|x| x["eventType"] != "Carb Correction")
        .collect();
    std::fs::write(&files[1], serde_json::to_vec(&t).unwrap()).unwrap();
    let mut s2 = dir.store();
    s2.create_person(&person_from(&files, "ana")).unwrap();
    s2.import_files("ana", &files, None).unwrap();
    assert_eq!(lunches(&mut s2), l1);
}

#[test]
fn the_hypoglycaemia_treatment_note_speaks_the_persons_unit() {
    let with = Plan {
        rescue: true,
        days: 4,
        ..Plan::default()
    };
    let dir = TempDir::new("rescue-mmol");
    let files = export(&dir.0, &with);
    let mut store = dir.store();
    let mut p = person_from(&files, "ana");
    p.settings.units = abba_core::units::GlucoseUnit::MmolL;
    store.create_person(&p).unwrap();
    store.import_files("ana", &files, None).unwrap();
    let a = store.advise("ana").unwrap();
    let note = a
        .notes
        .iter()
        .find(|n| n.contains("hypoglycaemia"))
        .unwrap_or_else(|| panic!("no rescue note in {:?}", a.notes));
    assert!(note.contains("below 3.9 mmol/L"), "{note}");
    assert!(!note.contains("mg/dL"), "{note}");
}

/// Sets each entry's and treatment's `utcOffset` (minutes): `away` on
/// days `trip` (indices), UTC+02:00 (Zurich in May) on the others.
fn with_offsets(files: &[PathBuf], trip: std::ops::Range<i64>, away: i64) {
    for f in &files[..2] {
        let items: Vec<Value> = serde_json::from_slice::<Vec<Value>>(&std::fs::read(f).unwrap())
            .unwrap()
            .into_iter()
            .map(|mut x| {
                let ms = x["date"].as_i64().unwrap_or_else(|| {
                    x["created_at"]
                        .as_str()
                        .unwrap()
                        .parse::<jiff::Timestamp>()
                        .unwrap()
                        .as_millisecond()
                });
                let day = (ms - DAY1_MS).div_euclid(86_400_000);
                x["utcOffset"] = json!(if trip.contains(&day) { away } else { 120 });
                x
            })
            .collect();
        std::fs::write(f, serde_json::to_vec(&items).unwrap()).unwrap();
    }
}

#[test]
fn a_trip_across_time_zones_is_named_by_the_import_and_the_advice() {
    let plan = Plan {
        days: 8,
        ..Plan::default()
    };
    let dir = TempDir::new("trip");
    let files = export(&dir.0, &plan);
    // Days 3 to 5 in New York (UTC-04:00 in May).
    with_offsets(&files, 3..6, -240);
    let mut store = dir.store();
    store.create_person(&person_from(&files, "ana")).unwrap();
    let summary = store.import_files("ana", &files, None).unwrap();
    // Times in the person's zone (day 3 is 2026-05-07), never UTC instants.
    let first = "2026-05-07 00:00";
    let named = |notes: &[String]| -> Vec<String> {
        notes
            .iter()
            .filter(|n| n.contains("UTC-04:00"))
            .cloned()
            .collect()
    };
    let in_import = named(&summary.notes);
    // Entries and treatments each name the stretch, from its first instant.
    assert_eq!(in_import.len(), 2, "{:?}", summary.notes);
    assert!(
        in_import
            .iter()
            .any(|n| n.contains(&format!("entries.json: from {first}"))),
        "{in_import:?}"
    );
    for n in &in_import {
        assert!(n.contains("Europe/Zurich's at UTC+02:00"), "{n}");
        assert!(!n.contains(":00Z"), "no UTC instant: {n}");
        assert!(
            n.contains("meal slots and days follow Europe/Zurich"),
            "{n}"
        );
    }
    // The stretch at home is not named.
    assert!(
        !summary
            .notes
            .iter()
            .any(|n| n.contains("clock was at UTC+02:00")),
        "{:?}",
        summary.notes
    );
    let a = store.advise("ana").unwrap();
    let in_advice = named(&a.notes);
    assert_eq!(in_advice.len(), 1, "{:?}", a.notes);
    assert!(
        in_advice[0].contains(&format!("from {first}")),
        "{}",
        in_advice[0]
    );
    // The last instant: the last entry of day 5 (23:55 local, 21:55 UTC).
    let last = "2026-05-09 23:55";
    assert!(
        in_advice[0].contains(&format!("to {last}")),
        "{}",
        in_advice[0]
    );
}

#[test]
fn a_person_at_home_gets_no_note_on_clocks() {
    let dir = TempDir::new("home");
    let files = export(
        &dir.0,
        &Plan {
            days: 4,
            ..Plan::default()
        },
    );
    with_offsets(&files, 0..0, 120);
    let mut store = dir.store();
    store.create_person(&person_from(&files, "ana")).unwrap();
    let summary = store.import_files("ana", &files, None).unwrap();
    assert!(
        !summary.notes.iter().any(|n| n.contains("device's clock")),
        "{:?}",
        summary.notes
    );
    let a = store.advise("ana").unwrap();
    assert!(
        !a.notes.iter().any(|n| n.contains("device's clock")),
        "{:?}",
        a.notes
    );
}

#[test]
fn an_import_whose_profile_differs_stops_with_both_values() {
    let dir = TempDir::new("mismatch");
    let files = export(
        &dir.0,
        &Plan {
            basal: vec![("00:00", 1.35)],
            carb_ratio: vec![("00:00", 8.0)],
            ..Plan::default()
        },
    );
    let mut store = dir.store();
    let mut p = common::person("ana");
    p.first_day = None;
    store.create_person(&p).unwrap();
    let e = store
        .import_files("ana", &files, None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("1.35")
            && e.contains("0.9")
            && e.contains("--adopt-profile")
            && e.contains("--keep-therapy"),
        "{e}"
    );
    assert!(store.records("ana").unwrap().is_empty(), "nothing imported");
    store
        .import_files_with("ana", &files, None, ProfileResolution::Adopt, None)
        .unwrap();
    store.advise("ana").unwrap();
    let start = store.person("ana").unwrap().settings.start;
    assert_eq!(start.basal.0, 1.35);
    assert!(start.carb_ratio.iter().all(|c| c.0 == 8.0), "{start:?}");
}

#[test]
fn the_clinicians_change_is_in_force_at_any_time() {
    let (_d, mut store, _) = setup(
        "therapy-set",
        &Plan {
            days: 9,
            ..Plan::default()
        },
    );
    let at: jiff::Timestamp = iso(DAY1_MS + 8 * 86_400_000 + 9 * 3_600_000)
        .parse()
        .unwrap();
    store
        .set_therapy(
            "ana",
            Some(vec![(0, 1.2)]),
            Some([9.0, 11.0, 10.5]),
            Some(at),
        )
        .unwrap();
    let a = store.advise("ana").unwrap();
    let basal = &a.settings[0];
    assert_eq!(basal.in_force, 1.2, "{basal:?}");
    let lunch = &a.settings[2];
    // The lunch update of that day started from the clinician's value.
    assert_eq!(lunch.latest.as_ref().unwrap().previous, 11.0, "{lunch:?}");
    // Refused: a value outside the limits, a time in the future.
    assert!(store
        .set_therapy("ana", Some(vec![(0, 90.0)]), None, None)
        .is_err());
    let later = jiff::Timestamp::now() + jiff::SignedDuration::from_hours(2);
    assert!(store
        .set_therapy("ana", None, Some([9.0; 3]), Some(later))
        .is_err());
    // Refused, not clamped to day 1: a time before day 1 (a minute before,
    // or 1980), naming --at and what is expected.
    let before: jiff::Timestamp = iso(DAY1_MS - 60_000).parse().unwrap();
    for at in [before, "1980-01-01T00:00:00Z".parse().unwrap()] {
        let e = store
            .set_therapy("ana", Some(vec![(0, 1.0)]), None, Some(at))
            .unwrap_err();
        let text = e.to_string();
        assert!(text.contains("--at"), "{text}");
        assert!(text.contains("before ana's day 1"), "{text}");
        assert!(text.contains("expected an instant on or after"), "{text}");
    }
    assert_eq!(store.advise("ana").unwrap().settings[0].in_force, 1.2);
}

#[test]
fn implausible_starting_therapy_is_refused_with_the_limit_named() {
    let dir = TempDir::new("limits");
    let mut store = dir.store();
    for (basal, cr) in [(90.0, 10.0), (0.0001, 10.0), (1.0, 300.0)] {
        let mut p = common::person("x");
        p.settings.start.basal = abba_core::UnitsPerHour(basal);
        p.settings.start.carb_ratio[2] = abba_core::GramsPerUnit(cr);
        let e = store.create_person(&p).unwrap_err().to_string();
        assert!(e.contains("between"), "{e}");
    }
}

const IO_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../io/tests/data");

#[test]
fn a_carelink_export_gives_the_therapy_and_an_import_that_differs_stops() {
    let dir = TempDir::new("carelink");
    let us = PathBuf::from(format!("{IO_DATA}/carelink_630g_us_synthetic.csv"));
    let chicago = "America/Chicago";
    let opts = ReadOptions {
        tz: Some(TimeZone::get(chicago).unwrap()),
        ..ReadOptions::default()
    };
    let meals = abba_io::meals::MealWindows::default();
    // `person new --therapy-from` on the export: the last full day's
    // schedule and the wizard's ratios, then the import agrees with it.
    let t = therapy_from_files(std::slice::from_ref(&us), &opts, &meals).unwrap();
    let mut p = NewPerson::new("cy", chicago, Mode::Cgm, t.settings());
    p.settings.basal_schedule = Some(t.basal.clone());
    p.settings.therapy_source = TherapySource::Profile;
    let mut store = dir.store();
    store.create_person(&p).unwrap();
    store
        .import_files("cy", std::slice::from_ref(&us), None)
        .unwrap();
    let a = store.advise("cy").unwrap();
    let sched = a.therapy.basal_schedule.expect("the schedule in force");
    let rates: Vec<f64> = sched.iter().map(|s| s.1).collect();
    assert_eq!(rates, vec![0.8, 1.05, 0.85, 0.95, 0.75]);
    let cr: Vec<f64> = a.settings[1..].iter().map(|s| s.in_force).collect();
    assert_eq!(cr, vec![9.0, 11.5, 13.5]);

    // A person whose store holds other values: the import stops with both.
    let mut q = NewPerson::new("dee", chicago, Mode::Cgm, common::start());
    q.settings.pump_steps = Some(PumpSteps::default());
    store.create_person(&q).unwrap();
    let e = store
        .import_files("dee", std::slice::from_ref(&us), None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("1.05")
            && e.contains("9/11.5/13.5")
            && e.contains("0.9")
            && e.contains("--adopt-profile"),
        "{e}"
    );
    assert!(store.records("dee").unwrap().is_empty());
    store
        .import_files_with(
            "dee",
            std::slice::from_ref(&us),
            None,
            ProfileResolution::Adopt,
            None,
        )
        .unwrap();
    let dee = store.person("dee").unwrap();
    assert_eq!(dee.settings.basal_schedule, Some(t.basal.clone()));
    assert_eq!(
        dee.settings.start.carb_ratio.map(|c| c.0),
        [9.0, 11.5, 13.5]
    );

    // The decimal-comma export has no dinner wizard event: the store's
    // dinner ratio stands, and an import whose other values agree goes on.
    let eu = PathBuf::from(format!("{IO_DATA}/carelink_780g_mmol_synthetic.csv"));
    let zurich = TimeZone::get(TZ).unwrap();
    let eu_opts = ReadOptions {
        tz: Some(zurich),
        ..ReadOptions::default()
    };
    let e = therapy_from_files(std::slice::from_ref(&eu), &eu_opts, &meals)
        .unwrap_err()
        .to_string();
    assert!(e.contains("dinner") && e.contains("--carb-ratio"), "{e}");
    let mut r = NewPerson::new(
        "eve",
        TZ,
        Mode::Cgm,
        abba_core::TherapySettings {
            basal: abba_core::UnitsPerHour(0.7),
            carb_ratio: [8.5, 10.0, 12.0].map(abba_core::GramsPerUnit),
        },
    );
    r.settings.basal_schedule = Some(vec![(0, 0.7), (360, 0.95), (720, 0.8), (1260, 0.65)]);
    r.settings.start.basal = abba_core::UnitsPerHour(abba_advisor::steps::mean_rate(
        r.settings.basal_schedule.as_deref().unwrap(),
    ));
    store.create_person(&r).unwrap();
    store
        .import_files("eve", std::slice::from_ref(&eu), None)
        .unwrap();
    assert_eq!(
        store.person("eve").unwrap().settings.therapy_source,
        TherapySource::Profile
    );
}

/// Writes an open-loop pump user's Tidepool export in the layout of
/// Tidepool's data model (the newer export's one JSON array of mixed
/// types; `time` in UTC with the pump's `deviceTime` and `timezoneOffset`
/// in minutes; glucose in mmol/L as Tidepool stores it): `pumpSettings`
/// read at the upload (named `basalSchedules` with `activeSchedule`, one
/// `carbRatio` array, `bgTarget` and `insulinSensitivity` in mmol/L,
/// `units`), `cbg` every 5 minutes for `days` days, `wizard` with its
/// `bolus` (normal; dinner dual/square with `extended` and `duration`),
/// `basal` scheduled segments with `scheduleName`, a percent temp and a
/// suspend, an `upload`, and a `deviceEvent` 20 days before the first
/// reading.
fn tidepool_export(dir: &std::path::Path, days: i64) -> PathBuf {
    tidepool_export_every(dir, days, 5)
}

/// [`tidepool_export`] with a CGM reading every `cgm_min` minutes (15: a
/// FreeStyle Libre 1 or 2's historic series).
fn tidepool_export_every(dir: &std::path::Path, days: i64, cgm_min: i64) -> PathBuf {
    let mut items: Vec<Value> = Vec::new();
    let mut n = 0u64;
    let mut id = || {
        n += 1;
        format!("{n:032x}")
    };
    let offset_min = 120; // Zurich in summer
    let device_time = |ms: i64| {
        let t = jiff::Timestamp::from_millisecond(ms + offset_min * 60_000).unwrap();
        t.strftime("%Y-%m-%dT%H:%M:%S").to_string()
    };
    let base = |ms: i64, ty: &str, id: String| {
        json!({"id": id, "type": ty, "time": iso(ms), "deviceTime": device_time(ms),
            "timezoneOffset": offset_min, "uploadId": "upid_00000000abcd",
            "deviceId": "InsOmn-130-00000000", "conversionOffset": 0, "clockDriftOffset": 0})
    };
    let with = |mut v: Value, extra: Value| {
        if let (Value::Object(a), Value::Object(b)) = (&mut v, extra) {
            a.extend(b);
        }
        v
    };
    let schedule = [(0, 0.75), (240, 0.95), (600, 0.85), (1140, 0.8)];
    items.push(with(
        base(DAY1_MS - 20 * 86_400_000, "deviceEvent", id()),
        json!({"subType": "reservoirChange"}),
    ));
    for day in 0..days {
        let day_ms = DAY1_MS + day * 86_400_000;
        for k in 0..1440 / cgm_min {
            let ms = day_ms + k * cgm_min * 60_000;
            let mg = 165.0 + 35.0 * ((k * cgm_min) as f64 / 240.0 + day as f64).sin();
            items.push(with(
                base(ms, "cbg", id()),
                json!({"units": "mmol/L", "value": (mg / 18.01559 * 10.0).round() / 10.0}),
            ));
        }
        for (i, &(start, rate)) in schedule.iter().enumerate() {
            let end = schedule.get(i + 1).map_or(1440, |s| s.0);
            let ms = day_ms + start * 60_000;
            items.push(with(
                base(ms, "basal", id()),
                json!({"deliveryType": "scheduled", "rate": rate, "scheduleName": "Standard",
                    "duration": (end - start) * 60_000}),
            ));
        }
        if day == 3 {
            items.push(with(
                base(day_ms + 14 * 3_600_000, "basal", id()),
                json!({"deliveryType": "temp", "percent": 0.5, "rate": 0.425,
                    "duration": 3_600_000, "suppressed": {"type": "basal",
                    "deliveryType": "scheduled", "rate": 0.85, "scheduleName": "Standard"}}),
            ));
        }
        if day == 5 {
            items.push(with(
                base(day_ms + 21 * 3_600_000, "basal", id()),
                json!({"deliveryType": "suspend", "duration": 1_800_000}),
            ));
        }
        for (minute, carbs, ratio) in [
            (7 * 60 + 2, 45.0, 10.0),
            (12 * 60 + 17, 60.0, 12.0),
            (18 * 60 + 32, 70.0, 11.0),
        ] {
            let ms = day_ms + minute * 60_000;
            let bolus_id = id();
            let units = ((carbs / ratio) * 20.0_f64).round() / 20.0;
            let bolus = if minute > 18 * 60 {
                json!({"subType": "dual/square", "normal": units * 0.6, "extended": units * 0.4,
                    "duration": 7_200_000})
            } else {
                json!({"subType": "normal", "normal": units})
            };
            items.push(with(base(ms, "bolus", bolus_id.clone()), bolus));
            items.push(with(
                base(ms, "wizard", id()),
                json!({"carbInput": carbs, "insulinCarbRatio": ratio, "units": "mmol/L",
                    "bolus": bolus_id, "recommended": {"carb": units, "correction": 0.0, "net": units}}),
            ));
        }
    }
    let end = DAY1_MS + days * 86_400_000 - 60_000;
    items.push(with(
        base(end, "upload", id()),
        json!({"deviceManufacturers": ["Insulet"], "deviceModel": "Dash", "deviceTags": ["insulin-pump"],
            "client": {"name": "org.tidepool.uploader", "version": "2.60.0"}, "timeProcessing": "utc-bootstrapping"}),
    ));
    let segs = |v: &[(i64, f64)], key: &str| -> Value {
        v.iter()
            .map(|&(m, x)| json!({"start": m * 60_000, key: x}))
            .collect()
    };
    items.push(with(
        base(end, "pumpSettings", id()),
        json!({"activeSchedule": "Standard",
            "basalSchedules": {"Standard": segs(&schedule, "rate"), "Weekend": segs(&[(0, 0.7)], "rate")},
            "carbRatio": segs(&[(0, 10.0), (660, 12.0), (960, 11.0)], "amount"),
            "bgTarget": [{"start": 0, "target": 5.6, "high": 6.1}],
            "insulinSensitivity": segs(&[(0, 2.8)], "amount"),
            "units": {"carb": "grams", "bg": "mmol/L"}}),
    ));
    let p = dir.join("tidepool.json");
    std::fs::write(&p, serde_json::to_vec(&Value::Array(items)).unwrap()).unwrap();
    p
}

#[test]
fn a_libres_fifteen_minute_readings_complete_the_first_week_and_feed_updates() {
    // An OmniPod with a FreeStyle Libre 2 (Tidepool's demo account has
    // one): 96 historic readings a day. Judged against a 5-minute
    // sensor's 288, no day qualified and no window had enough readings.
    let dir = TempDir::new("libre-15");
    let files = vec![tidepool_export_every(&dir.0, 15, 15)];
    let mut store = dir.store();
    store.create_person(&person_from(&files, "lia")).unwrap();
    store.import_files("lia", &files, None).unwrap();
    let a = store.advise("lia").unwrap();
    assert!(
        a.first_week.is_none(),
        "the first week completed: {:?}",
        a.first_week
    );
    let history = store.history("lia").unwrap();
    assert!(
        history.iter().any(|v| v.setting == "basal" && !v.no_update),
        "a basal update from 15-minute readings: {history:?}"
    );
    // Days with a third of their readings do not qualify, and say so
    // against a Libre's 96 readings a day (eight days, two of them gappy:
    // the first week is still open).
    let dir = TempDir::new("libre-15-gaps");
    let file = tidepool_export_every(&dir.0, 8, 15);
    let mut items: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let day = |v: &Value| v["time"].as_str().unwrap_or_default()[..10].to_string();
    let (gappy_1, gappy_2) = ("2026-05-05".to_string(), "2026-05-06".to_string());
    let mut k = 0;
    items.retain(|v| {
        if v["type"] == "cbg" && (day(v) == gappy_1 || day(v) == gappy_2) {
            k += 1;
            k % 3 == 0
        } else {
            true
        }
    });
    std::fs::write(&file, serde_json::to_string(&items).unwrap()).unwrap();
    let mut store = dir.store();
    store
        .create_person(&person_from(std::slice::from_ref(&file), "lia"))
        .unwrap();
    store.import_files("lia", &[file], None).unwrap();
    let week = store
        .advise("lia")
        .unwrap()
        .first_week
        .expect("the first week is open");
    assert!(
        week.missing
            .iter()
            .any(|m| m.contains("of the 96 expected")),
        "a gappy day is judged against a Libre's 96 readings: {week:?}"
    );
    assert!(week.qualifying.len() >= 5, "{week:?}");
}

#[test]
fn an_open_loop_tidepool_export_gives_the_pumps_therapy_a_first_week_and_suggestions_on_step() {
    let dir = TempDir::new("tidepool");
    let file = tidepool_export(&dir.0, 15);
    let files = vec![file];
    let mut store = dir.store();
    store.create_person(&person_from(&files, "ana")).unwrap();
    store.import_files("ana", &files, None).unwrap();
    // Day 1 is the first CGM day, not the device event 20 days before.
    assert_eq!(
        store.person("ana").unwrap().first_day.unwrap().to_string(),
        "2026-05-04"
    );
    let a = store.advise("ana").unwrap();
    assert_eq!(
        a.delivery.kind,
        abba_io::automation::Delivery::OpenLoop,
        "{:?}",
        a.delivery
    );
    assert!(
        a.first_week.is_none(),
        "the first week completed: {:?}",
        a.first_week
    );
    let history = store.history("ana").unwrap();
    // The therapy is the pump's: the active schedule and the ratio in force
    // for the longest part of each meal window.
    let first_cr: Vec<f64> = ["breakfast", "lunch", "dinner"]
        .iter()
        .map(|k| history.iter().find(|v| v.setting == *k).unwrap().previous)
        .collect();
    assert_eq!(first_cr, vec![10.0, 12.0, 11.0]);
    let first_basal = history.iter().find(|v| v.setting == "basal").unwrap();
    let mean = (0.75 * 240.0 + 0.95 * 360.0 + 0.85 * 540.0 + 0.8 * 300.0) / 1440.0;
    assert!(
        (first_basal.previous - mean).abs() < 1e-9,
        "{first_basal:?}"
    );
    let updates: Vec<_> = history.iter().filter(|v| !v.no_update).collect();
    assert!(
        updates.iter().any(|v| v.setting == "basal"),
        "no basal update"
    );
    for v in updates {
        if v.setting == "basal" {
            for (_, r) in v.schedule.as_ref().expect("a schedule") {
                assert!(on_step(*r, 0.05), "{r} U/h is not on the pump's step");
            }
        } else {
            assert!(on_step(v.suggested, 0.1), "{} g/U", v.suggested);
        }
    }
}

/// AndroidAPS's Profile Switch as its NSClient uploads it (`profile`,
/// `percentage`, `timeshift`, `duration` in minutes, `originalDuration` in
/// ms, the profile as chosen in `profileJson`).
fn aaps_switch(id: &str, ms: i64, percentage: u32, minutes: i64, plan: &Plan) -> Value {
    let arr = |v: &[(&str, f64)]| -> Value {
        v.iter()
            .map(|(t, x)| json!({"time": t, "timeAsSeconds": seconds(t), "value": x}))
            .collect()
    };
    let profile = json!({"units": "mg/dl", "dia": 5, "timezone": TZ,
        "basal": arr(&plan.basal), "carbratio": arr(&plan.carb_ratio),
        "sens": arr(&[("00:00", 50.0)]), "target_low": arr(&[("00:00", 100.0)]),
        "target_high": arr(&[("00:00", 110.0)])});
    let name = if percentage == 100 {
        "LocalProfile0".to_string()
    } else {
        format!("LocalProfile0({percentage}%)")
    };
    json!({"_id": id, "timeshift": 0, "percentage": percentage, "duration": minutes,
        "profile": name, "originalProfileName": "LocalProfile0",
        "originalDuration": minutes * 60_000, "created_at": iso(ms),
        "enteredBy": "openaps://AndroidAPS", "isValid": true, "eventType": "Profile Switch",
        "profileJson": profile.to_string(), "pumpType": "DANA_RS", "utcOffset": 120})
}

/// An export whose last AndroidAPS Profile Switch is an 80 % profile for
/// 2 h, set at 22:30 on the last day and still running when the data end
/// (23:55): the person's settings are the permanent profile, the 80 % one
/// is in force in its window, and the permanent one is in force again
/// after it (today's advice starts from it).
#[test]
fn a_temporary_profile_running_at_the_end_of_the_data_is_not_the_therapy_in_force() {
    let plan = Plan {
        basal: vec![("00:00", 1.0), ("12:00", 1.2)],
        ..Plan::default()
    };
    let dir = TempDir::new("aaps-temporary");
    let files = export(&dir.0, &plan);
    let mut treatments: Vec<Value> =
        serde_json::from_slice(&std::fs::read(&files[1]).unwrap()).unwrap();
    let last_day = DAY1_MS + (plan.days - 1) * 86_400_000;
    treatments.push(aaps_switch(
        "66f0b2a1c574da0004a39006",
        DAY1_MS - 86_400_000 + 3_600_000,
        100,
        0,
        &plan,
    ));
    treatments.push(aaps_switch(
        "66f0b2a1c574da0004a39010",
        last_day + (22 * 60 + 30) * 60_000,
        80,
        120,
        &plan,
    ));
    std::fs::write(&files[1], serde_json::to_vec(&treatments).unwrap()).unwrap();
    let opts = ReadOptions {
        tz: Some(TimeZone::get(TZ).unwrap()),
        ..ReadOptions::default()
    };
    let meals = abba_io::meals::MealWindows::default();
    let t = therapy_from_files(&files, &opts, &meals).unwrap();
    assert_eq!(t.basal, vec![(0, 1.0), (720, 1.2)], "{t:?}");
    assert!(
        t.notes.len() == 1 && t.notes[0].contains("was still running at the end of the data"),
        "{:?}",
        t.notes
    );
    let mut store = dir.store();
    store.create_person(&person_from(&files, "ana")).unwrap();
    let s = store.import_files("ana", &files, None).unwrap();
    assert!(
        s.notes.iter().any(|n| n.contains("still running")),
        "{:?}",
        s.notes
    );
    let a = store.advise("ana").unwrap();
    // In force after the data: the permanent profile, not 0.8/0.96.
    assert_eq!(
        a.therapy.basal_schedule,
        Some(vec![("00:00".to_string(), 1.0), ("12:00".to_string(), 1.2)]),
        "{:?}",
        a.therapy
    );
    // The 80 % profile was in force in its window, then the permanent one.
    let [.., temp, back] = &a.therapy.changes[..] else {
        panic!("{:?}", a.therapy.changes)
    };
    assert!(temp.contains("0.8") && temp.contains("0.96"), "{temp}");
    // Dated in the person's zone (22:30 in Zurich, 20:30 UTC), once.
    assert!(
        temp.starts_with("from 2026-05-13 22:30 (the pump's profile):"),
        "{temp}"
    );
    assert!(
        back.contains("at the end of the temporary profile") && back.contains("1.2"),
        "{back}"
    );
}

/// The exported files cut at the end of day `days` (local): entries and
/// treatments up to then, the profile whole (an export made that day).
fn export_until(files: &[PathBuf], dir: &std::path::Path, days: i64) -> Vec<PathBuf> {
    let end = DAY1_MS + days * 86_400_000;
    let at = |v: &Value| {
        v["date"].as_i64().unwrap_or_else(|| {
            v["created_at"]
                .as_str()
                .and_then(|s| s.parse::<jiff::Timestamp>().ok())
                .map_or(i64::MIN, |t| t.as_millisecond())
        })
    };
    files
        .iter()
        .map(|f| {
            let mut v: Value = serde_json::from_slice(&std::fs::read(f).unwrap()).unwrap();
            let name = f.file_name().unwrap().to_str().unwrap();
            if name != "profile.json" {
                let items = v.as_array_mut().unwrap();
                items.retain(|x| at(x) < end);
            }
            let p = dir.join(format!("d{days}-{name}"));
            std::fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
            p
        })
        .collect()
}

/// Two weeks of history in one import (a person's first export, or a
/// first sync): the suggestions made on it and followed by the next within
/// it were never shown, so none is taken as followed and the values in
/// force stay the pump's profile; the same days imported day by day show
/// each suggestion, and one nobody answered is taken as followed.
#[test]
fn suggestions_made_on_the_history_of_one_import_are_not_taken_as_followed() {
    let plan = Plan {
        days: 16,
        level: 190.0,
        ..Plan::default()
    };
    let (dir, mut store, files) = setup("history-once", &plan);
    let a = store.advise("ana").unwrap();
    let history = store.history("ana").unwrap();
    let moved: Vec<_> = history
        .iter()
        .filter(|v| !v.no_update && v.suggested != v.previous)
        .collect();
    assert!(moved.len() > 4, "the high days must ask for more insulin");
    for key in ["basal", "breakfast", "lunch", "dinner"] {
        // The setting's last decision is the one the import showed.
        let last = history.iter().rfind(|v| v.setting == key).unwrap();
        for v in moved
            .iter()
            .filter(|v| v.setting == key && v.decided_at != last.decided_at)
        {
            assert_eq!(v.status, "unseen", "{key} at {}", v.decided_at);
            assert_eq!(v.in_force, v.previous, "{key}");
        }
    }
    // In force: the profile's 1.0 U/h and 10 g/U; each open suggestion
    // one step (at most 5 %) from them.
    for s in &a.settings {
        let profile = if s.setting == "basal" { 1.0 } else { 10.0 };
        assert!(
            (s.in_force - profile).abs() < 1e-9,
            "{}: {}",
            s.setting,
            s.in_force
        );
    }
    // Day by day: every suggestion was the latest after some import.
    let mut daily = dir.store();
    let mut p = person_from(&files, "ben");
    p.first_day = None;
    daily.create_person(&p).unwrap();
    for day in 1..=plan.days {
        let cut = export_until(&files, &dir.0, day);
        daily
            .import_files_with("ben", &cut, None, ProfileResolution::Keep, None)
            .unwrap();
    }
    let h = daily.history("ben").unwrap();
    assert!(
        h.iter().all(|v| v.status != "unseen"),
        "daily imports show every suggestion"
    );
    assert!(h.iter().any(|v| v.status == "superseded"));
    let b = daily.advise("ben").unwrap();
    assert!(
        b.settings
            .iter()
            .any(|s| (s.in_force - if s.setting == "basal" { 1.0 } else { 10.0 }).abs() > 1e-9),
        "unanswered suggestions shown day by day are taken as followed"
    );
}

/// A Dexcom Clarity CSV in its export layout (header, preamble rows without
/// a time, EGV rows every 5 min): three days at `level`, with a night's
/// compression low the sensor reports as `Low`, an afternoon above its
/// range as `High`, and one reading repeated 20 s later with another value.
fn clarity_with_low_and_high(dir: &std::path::Path) -> PathBuf {
    let mut lines = vec![
        "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID".to_string(),
        "1,,FirstName,,Ana,,,,,,,,,".to_string(),
        "2,,Device,,,Dexcom G6 Mobile App,android G6,,,,,,,".to_string(),
    ];
    let mut i = 3;
    let mut tx = 400_000;
    for day in 0..3 {
        for k in 0..288 {
            let m = k * 5;
            let value = match (day, m) {
                (1, 120..=140) => "Low".to_string(),
                (2, 900..=925) => "High".to_string(),
                _ => (140 + (k % 24)).to_string(),
            };
            let at = format!("2026-05-{:02}T{:02}:{:02}:07", 4 + day, m / 60, m % 60);
            lines.push(format!(
                "{i},{at},EGV,,,,android G6,{value},,,,,{tx},ABC123"
            ));
            if (day, m) == (0, 600) {
                i += 1;
                let again = format!("2026-05-04T{:02}:{:02}:27", m / 60, m % 60);
                lines.push(format!(
                    "{i},{again},EGV,,,,android G6,199,,,,,{},ABC123",
                    tx + 20
                ));
            }
            i += 1;
            tx += 300;
        }
    }
    let p = dir.join("Clarity_Export.csv");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    p
}

#[test]
fn readings_beyond_the_sensors_range_and_rows_left_out_are_stated_in_advice_and_report() {
    let dir = TempDir::new("clarity-censored");
    let file = clarity_with_low_and_high(&dir.0);
    let mut store = dir.store();
    let start = abba_core::TherapySettings {
        basal: abba_core::UnitsPerHour(0.9),
        carb_ratio: [abba_core::GramsPerUnit(10.0); 3],
    };
    store
        .create_person(&NewPerson::new("ana", TZ, Mode::Cgm, start))
        .unwrap();
    store.import_files("ana", &[file], None).unwrap();
    // 5 Low (02:00-02:20) and 6 High (15:00-15:25).
    let censored = abba_advisor::words::censored_readings(11);
    let a = store.advise("ana").unwrap();
    assert!(a.notes.contains(&censored), "{:?}", a.notes);
    let left_out = a.data.records_not_used;
    assert!(
        left_out > 0,
        "the repeated reading is left out: {:?}",
        a.data
    );
    let input =
        abba_store::report::person_input(&mut store, "ana", 3, abba_core::units::GlucoseUnit::MgDl)
            .unwrap();
    assert!(input.notes.contains(&censored), "{:?}", input.notes);
    assert!(
        input
            .notes
            .iter()
            .any(|n| n.starts_with(&format!("{left_out} records of the log were left out"))),
        "{:?}",
        input.notes
    );
}

#[test]
fn schedule_segments_outside_the_clinicians_basal_bounds_are_named() {
    // Bounds 0.9-1.2 U/h around the mean (1.04), the 07:00 segment (1.4)
    // and the midnight one (0.8) outside them.
    let plan = open_schedule_plan();
    let dir = TempDir::new("schedule-bounds");
    let files = export(&dir.0, &plan);
    let mut store = dir.store();
    let mut p = person_from(&files, "ana");
    p.settings.bounds.basal = Some(abba_advisor::bounds::Range { min: 0.9, max: 1.2 });
    store.create_person(&p).unwrap();
    store.import_files("ana", &files, None).unwrap();
    let a = store.advise("ana").unwrap();
    let note = a
        .notes
        .iter()
        .find(|n| {
            n.starts_with("Your clinician's basal bounds (0.9-1.2 U/h) hold the schedule's mean")
        })
        .unwrap_or_else(|| panic!("{:?}", a.notes));
    assert!(
        note.contains("00:00 0.8, 07:00 1.4 U/h lie outside"),
        "{note}"
    );
    // Without bounds, nothing to say.
    let (_d, mut store2, _) = setup("schedule-no-bounds", &plan);
    let a2 = store2.advise("ana").unwrap();
    assert!(
        a2.notes.iter().all(|n| !n.contains("basal bounds")),
        "{:?}",
        a2.notes
    );
}

/// The readings of day index `day` from `from_h` to `to_h` o'clock in
/// `files` (written as `tag-NAME` in `dir`): left out (`low` None, a
/// sensor gap a later export fills) or set to `low` mg/dL.
fn readings_changed(
    files: &[PathBuf],
    dir: &std::path::Path,
    tag: &str,
    (day, from_h, to_h): (i64, i64, i64),
    low: Option<f64>,
) -> Vec<PathBuf> {
    let from = DAY1_MS + day * 86_400_000 + from_h * 3_600_000;
    let to = DAY1_MS + day * 86_400_000 + to_h * 3_600_000;
    files
        .iter()
        .map(|f| {
            let mut v: Value = serde_json::from_slice(&std::fs::read(f).unwrap()).unwrap();
            let name = f.file_name().unwrap().to_str().unwrap();
            if name.ends_with("entries.json") {
                let items = v.as_array_mut().unwrap();
                let inside = |x: &Value| (from..to).contains(&x["date"].as_i64().unwrap_or(0));
                match low {
                    None => items.retain(|x| !inside(x)),
                    Some(g) => items
                        .iter_mut()
                        .filter(|x| inside(x))
                        .for_each(|x| x["sgv"] = json!(g)),
                }
            }
            let p = dir.join(format!("{tag}-{name}"));
            std::fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
            p
        })
        .collect()
}

/// An answer given, then an export whose late readings change the
/// suggestion it answered: the answer stays recorded once, the value the
/// person put on the pump stays in force, and the history and the advice
/// say that the suggestion changed after the answer, with both values.
#[test]
fn an_answer_to_a_suggestion_a_later_import_changed_is_kept_and_said() {
    let plan = Plan {
        days: 14,
        level: 230.0,
        ..Plan::default()
    };
    let dir = TempDir::new("answer-changed");
    let files = export(&dir.0, &plan);
    // Day index 9's late morning: a low the sensor uploads late.
    let late = (9, 9, 15);
    let files = readings_changed(&files, &dir.0, "low", late, Some(62.0));
    let mut store = dir.store();
    let mut p = person_from(&files, "ana");
    p.first_day = None;
    store.create_person(&p).unwrap();
    for day in 1..=11 {
        let cut = export_until(&files, &dir.0, day);
        let cut = if day >= 10 {
            readings_changed(&cut, &dir.0, "gap", late, None)
        } else {
            cut
        };
        store
            .import_files_with("ana", &cut, None, ProfileResolution::Keep, None)
            .unwrap();
    }
    let answered = store
        .answer("ana", &abba_store::AnswerRequest::Accept)
        .unwrap();
    let basal = answered
        .iter()
        .find(|a| a.parameter == abba_advisor::Parameter::Basal)
        .expect("a basal suggestion was open");
    assert!(
        basal.suggested > basal.previous,
        "the high days ask for more"
    );
    let history_before = store.history("ana").unwrap();
    // The full export: day index 9's low arrives late, and the basal
    // suggestion the person accepted is now another.
    let full = export_until(&files, &dir.0, 11);
    store
        .import_files_with("ana", &full, None, ProfileResolution::Keep, None)
        .unwrap();
    let history = store.history("ana").unwrap();
    assert_eq!(history.len(), history_before.len(), "the same decisions");
    assert_eq!(
        dir.rows("answer"),
        answered.len() as i64,
        "each answer stored once"
    );
    let row = history.iter().rfind(|v| v.setting == "basal").unwrap();
    assert_ne!(
        row.suggested, basal.suggested,
        "the late low changed it: {row:#?}"
    );
    assert_eq!(row.status, "accepted", "the person's answer stays");
    assert_eq!(
        row.in_force, basal.in_force,
        "what the person programmed stays"
    );
    let note = row.answer_note.as_deref().expect("said in the history");
    for v in [basal.suggested, row.suggested, basal.in_force] {
        assert!(
            note.contains(&abba_advisor::words::rate(v)),
            "{v} in {note}"
        );
    }
    assert!(abba_store::history::to_text("ana", &history).contains(note));
    // Answers whose suggestion did not change say nothing more.
    for v in history.iter().filter(|v| v.setting != "basal") {
        assert!(v.answer_note.is_none(), "{v:#?}");
    }
    let advice = store.advise("ana").unwrap();
    assert!(
        advice.notes.iter().any(|n| n == note),
        "{:#?}",
        advice.notes
    );
    let in_force = &advice.settings[0];
    assert_eq!(in_force.in_force, basal.in_force);
    // The report's suggestion says it with the answer.
    let report = abba_store::report::person_input(
        &mut store,
        "ana",
        14,
        abba_core::units::GlucoseUnit::MgDl,
    )
    .unwrap();
    assert!(
        report.suggestions.iter().any(|l| l.answer.contains(note)),
        "the report's answers: {:#?}",
        report
            .suggestions
            .iter()
            .map(|l| &l.answer)
            .collect::<Vec<_>>()
    );
    // A rebuild from scratch gives the same.
    store.rebuild("ana").unwrap();
    assert_eq!(store.history("ana").unwrap(), history);
}
