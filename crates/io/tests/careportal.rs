//! An open-loop pump user who enters treatments by hand in Nightscout's
//! Careportal, in its real layout (fixtures with made-up values, see
//! PROVENANCE.md): Meal and Snack Boluses with insulin and carbs in one
//! document, a Combo Bolus (`enteredinsulin`, `splitNow`, `splitExt`,
//! `relative`), a Temp Basal entered by hand, a Site Change, and Profile
//! Switches that only name a profile of the profile store (no
//! `profileJson`): applied from `profile.json` when it is imported with
//! them, as Nightscout applies them (`activeProfileToTime` in
//! cgm-remote-monitor's `lib/profilefunctions.js`).

use crate::common::{fixture, opts, read};
use abba_io::meals::MealWindows;
use abba_io::record::{Profile, RecordKind, TempRate};

const TREATMENTS: &str = "nightscout_treatments_careportal_switches_synthetic.json";
const PROFILES: &str = "nightscout_profile_store_named_synthetic.json";

fn both() -> abba_io::Batch {
    read(
        &[
            ("treatments.json", fixture(TREATMENTS)),
            ("profile.json", fixture(PROFILES)),
        ],
        &opts("Europe/Zurich"),
    )
    .unwrap()
}

fn at(t: &str) -> jiff::Timestamp {
    t.parse().unwrap()
}

/// The schedule records at `t`.
fn schedules_at(b: &abba_io::Batch, t: &str) -> Vec<Profile> {
    b.records
        .iter()
        .filter(|r| r.at == at(t))
        .filter_map(|r| match &r.kind {
            RecordKind::Schedule { profile } => Some((**profile).clone()),
            _ => None,
        })
        .collect()
}

fn basal(p: &Profile) -> Vec<(u32, f64)> {
    p.basal.segments.iter().map(|s| (s.0, s.1 .0)).collect()
}

fn ratios(p: &Profile) -> Vec<(u32, f64)> {
    p.carb_ratio.iter().map(|s| (s.0, s.1 .0)).collect()
}

fn note<'a>(b: &'a abba_io::Batch, part: &str) -> &'a str {
    b.notes
        .iter()
        .find(|n| n.contains(part))
        .unwrap_or_else(|| panic!("no note with {part:?}: {:?}", b.notes))
}

/// Each Profile Switch runs the profile it names, from the profile
/// document in force at it: "Weekend" of the store of 2026-11-01 on the
/// 14th, the same name from the store of 2026-11-20 (other rates) on the
/// 21st; "Weekday" is the older store's (its values written as strings,
/// as Nightscout's profile editor saves them).
#[test]
fn a_switch_naming_a_profile_runs_that_profile_of_the_store_in_force() {
    let b = both();
    let weekend = schedules_at(&b, "2026-11-14T08:00:00Z");
    assert_eq!(weekend.len(), 1, "{:?}", b.notes);
    assert_eq!(basal(&weekend[0]), [(0, 0.7), (300, 0.9)]);
    assert_eq!(ratios(&weekend[0]), [(0, 11.0), (660, 13.0), (1020, 12.0)]);
    assert_eq!(weekend[0].temporary_min, None);
    let weekday = schedules_at(&b, "2026-11-16T06:00:00Z");
    assert_eq!(basal(&weekday[0]), [(0, 0.8), (240, 1.0), (600, 0.85)]);
    let later = schedules_at(&b, "2026-11-21T08:00:00Z");
    assert_eq!(basal(&later[0]), [(0, 0.75), (300, 0.95)]);
    assert_eq!(ratios(&later[0]), [(0, 11.0), (660, 14.0), (1020, 12.0)]);
    // The profile documents themselves: each one's default from its start.
    assert_eq!(
        basal(&schedules_at(&b, "2026-11-20T00:00:00Z")[0]),
        [(0, 0.85), (240, 1.05), (600, 0.9)]
    );
    let n = note(
        &b,
        "Profile Switches name a profile of the Nightscout profile store",
    );
    assert!(
        n.starts_with("treatments.json: 4 Profile Switches")
            && n.contains("\"Sick\", \"Weekday\", \"Weekend\"")
            && n.contains("profile.json $[1]"),
        "{n}"
    );
}

/// A temporary switch ("Sick" for 180 min) is in force for its duration
/// only; at its end the latest permanent switch before it ("Weekday") is
/// in force again.
#[test]
fn a_temporary_switch_naming_a_profile_ends_back_on_the_permanent_one() {
    let b = both();
    let sick = schedules_at(&b, "2026-11-17T12:00:00Z");
    assert_eq!(sick.len(), 1);
    assert_eq!(basal(&sick[0]), [(0, 1.1)]);
    assert_eq!(sick[0].temporary_min, Some(180));
    let back = schedules_at(&b, "2026-11-17T15:00:00Z");
    assert_eq!(back.len(), 1, "the #end record");
    assert_eq!(basal(&back[0]), [(0, 0.8), (240, 1.0), (600, 0.85)]);
}

/// A name the store in force does not hold is not applied, and a note
/// names it, the store and the names it holds.
#[test]
fn a_switch_to_a_profile_the_store_does_not_hold_is_said_not_applied() {
    let b = both();
    assert!(schedules_at(&b, "2026-11-18T09:00:00Z").is_empty());
    let ignored: Vec<&str> = b
        .records
        .iter()
        .filter(|r| r.at == at("2026-11-18T09:00:00Z"))
        .filter_map(|r| match &r.kind {
            RecordKind::Ignored { kind } => Some(kind.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(
        ignored,
        ["Profile Switch to a profile the profile store does not hold (not applied)"]
    );
    let n = note(&b, "\"Holiday\"");
    assert!(
        n.contains("profile.json $[1]")
            && n.contains("\"Sick\", \"Weekday\", \"Weekend\"")
            && n.contains("not applied"),
        "{n}"
    );
}

/// The therapy in force at the end: the last switch's profile ("Weekend"
/// of the newer store), not the newer store's default ("Winter").
#[test]
fn the_therapy_in_force_follows_the_named_switches() {
    let inputs = vec![
        ("treatments.json".to_string(), fixture(TREATMENTS)),
        ("profile.json".to_string(), fixture(PROFILES)),
    ];
    let t = abba_io::therapy::therapy_from_contents(
        &inputs,
        &opts("Europe/Zurich"),
        &MealWindows::default(),
        None,
    )
    .unwrap();
    assert_eq!(t.basal, [(0, 0.75), (300, 0.95)]);
    assert_eq!(t.at, at("2026-11-21T08:00:00Z"));
    assert!(t.origin.starts_with("treatments.json"), "{}", t.origin);
}

/// Without the profile store the switches are counted, not applied, and
/// the note says what to import to apply them.
#[test]
fn without_the_profile_store_the_named_switches_are_said_not_applied() {
    let b = read(
        &[("treatments.json", fixture(TREATMENTS))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(b.count("basal_schedule"), 0);
    let n = note(&b, "without embedding");
    assert!(
        n.contains("5 Profile Switches") && n.contains("not applied") && n.contains("profile.json"),
        "{n}"
    );
}

/// A named switch at a percentage and a timeshift (AndroidAPS's fields;
/// Nightscout applies them to a circadian-percentage profile): the store's
/// basal times 0.8, its ratios divided by 0.8, both two hours later (the
/// value at 02:00 is the profile's at 00:00).
#[test]
fn a_named_switch_at_a_percentage_and_timeshift_scales_and_moves_the_profile() {
    let t =
        br#"[{"_id": "s1", "eventType": "Profile Switch", "created_at": "2026-11-22T08:00:00.000Z",
       "profile": "Weekend", "percentage": 80, "timeshift": 2, "duration": 0}]"#;
    let b = read(
        &[
            ("treatments.json", t.to_vec()),
            ("profile.json", fixture(PROFILES)),
        ],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    let p = &schedules_at(&b, "2026-11-22T08:00:00Z")[0];
    let close = |a: &[(u32, f64)], b: &[(u32, f64)]| {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(x, y)| x.0 == y.0 && (x.1 - y.1).abs() < 1e-9)
    };
    assert!(
        close(&basal(p), &[(0, 0.76), (120, 0.6), (420, 0.76)]),
        "{:?}",
        basal(p)
    );
    assert!(
        close(
            &ratios(p),
            &[(0, 15.0), (120, 13.75), (780, 17.5), (1140, 15.0)]
        ),
        "{:?}",
        ratios(p)
    );
}

/// A named profile the store holds but that cannot be read (a basal rate
/// out of range) leaves the switch out with an error naming the switch,
/// the store and the field; the rest is read.
#[test]
fn a_switch_to_a_named_profile_that_cannot_be_read_is_left_out_naming_why() {
    let profile = br#"[{"_id": "p1", "defaultProfile": "A", "startDate": "2026-11-01T00:00:00.000Z",
      "store": {"A": {"basal": [{"time": "00:00", "value": 0.8}], "carbratio": [{"time": "00:00", "value": 10}]},
                "B": {"basal": [{"time": "00:00", "value": 80}], "carbratio": [{"time": "00:00", "value": 10}]}}}]"#;
    let t = br#"[{"_id": "s1", "eventType": "Profile Switch", "created_at": "2026-11-22T08:00:00.000Z", "profile": "B"},
      {"_id": "b1", "eventType": "Correction Bolus", "created_at": "2026-11-22T09:00:00.000Z", "insulin": 1}]"#;
    let (b, e) = crate::common::read_in_part(
        &[
            ("treatments.json", t.to_vec()),
            ("profile.json", profile.to_vec()),
        ],
        &opts("UTC"),
    );
    assert_eq!(b.count("bolus"), 1);
    assert!(
        e.starts_with("treatments.json: $[0], field \"profile\"")
            && e.contains("\"B\"")
            && e.contains("profile.json $[0]")
            && e.contains("store.B.basal"),
        "{e}"
    );
}

/// The Careportal's boluses and carbs: each document's insulin and carbs
/// read once; the Combo Bolus as its part now and its extended part
/// (`enteredinsulin` − `insulin`) over its duration; the hand-entered Temp
/// Basal as a percentage; the Site Change counted.
#[test]
fn careportal_boluses_carbs_and_a_hand_entered_temp_basal_are_each_read_once() {
    let b = both();
    assert_eq!(b.count("bolus"), 4, "meal x2, snack, correction");
    assert_eq!(b.count("carbs"), 4, "meal x2, snack, combo");
    let combo: Vec<&RecordKind> = b
        .records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::ExtendedBolus { .. }))
        .map(|r| &r.kind)
        .collect();
    let [RecordKind::ExtendedBolus {
        now,
        extended,
        duration_min,
    }] = combo[..]
    else {
        panic!("{combo:?}")
    };
    assert!((now.0 - 3.6).abs() < 1e-9 && (extended.0 - 2.4).abs() < 1e-9);
    assert_eq!(*duration_min, 120);
    let temp: Vec<&RecordKind> = b
        .records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::TempBasal { .. }))
        .map(|r| &r.kind)
        .collect();
    assert_eq!(
        temp,
        [&RecordKind::TempBasal {
            rate: TempRate::Percent(70.0),
            duration_min: 60
        }]
    );
    assert!(b
        .records
        .iter()
        .any(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == "Site Change")));
}

/// Nightscout stores every treatment sent with a `created_at` in UTC (the
/// Careportal's `toISOString()`) with `utcOffset` 0: no device clock at
/// UTC+00:00 is reported for a person in Zurich.
#[test]
fn careportals_utc_offset_of_0_is_no_device_clock() {
    let b = both();
    assert!(
        b.clocks.iter().all(Vec::is_empty),
        "{:?} {:?}",
        b.clocks,
        b.notes
    );
    // A real offset is still one: xDrip+'s +60 at home, -300 away.
    let t = br#"[{"_id": "a", "eventType": "Note", "created_at": "2026-11-22T08:00:00.000Z", "utcOffset": -300}]"#;
    let b = read(&[("t.json", t.to_vec())], &opts("Europe/Zurich")).unwrap();
    assert_eq!(b.clocks[0].len(), 1);
    assert_eq!(b.clocks[0][0].offset_s, -300 * 60);
}

/// A Profile Switch that neither embeds nor names a profile, beside a
/// profile store: not applied, and the note says it names none (not that
/// the store is missing).
#[test]
fn a_switch_naming_no_profile_beside_a_store_is_said_to_name_none() {
    let t = br#"[{"_id": "s1", "eventType": "Profile Switch", "created_at": "2026-11-22T08:00:00.000Z", "duration": 0}]"#;
    let b = read(
        &[
            ("treatments.json", t.to_vec()),
            ("profile.json", fixture(PROFILES)),
        ],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert!(schedules_at(&b, "2026-11-22T08:00:00Z").is_empty());
    let n = note(&b, "neither embed a profile");
    assert!(n.contains("$[0]") && n.contains("not applied"), "{n}");
    assert!(!b
        .notes
        .iter()
        .any(|n| n.contains("hold no Nightscout profile store")));
}
