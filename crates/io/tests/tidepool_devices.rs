//! Tidepool's data of closed-loop pumps and the pumps' settings, in the
//! data model as Tidepool's API gives it (hand-written fixtures, see
//! `data/PROVENANCE.md`): a t:slim X2 with Control-IQ, DIY Loop on an
//! Omnipod DASH (its data opening with a `dosingDecision`), an Omnipod 5,
//! a MiniMed 670G read in SmartGuard's auto mode. Each is seen as a closed
//! loop, in JSON and in Tidepool's Excel export alike (an Omnipod 5 in
//! Manual Mode is not); the profile taken from the pump settings is the
//! active schedule's, never an override or auto mode's.

use crate::common::{fixture, opts, read};
use crate::tidepool_workbook::{export_json, workbook, Options};
use abba_io::automation::{Delivery, Evidence};
use abba_io::read::{detect, Format};
use abba_io::{Batch, RecordKind};
use serde_json::Value;

const TANDEM: &str = "tidepool_tandem_controliq_synthetic.json";
const LOOP: &str = "tidepool_loop_dash_synthetic.json";
const MINIMED: &str = "tidepool_minimed670g_automode_synthetic.json";
const OMNIPOD5: &str = "tidepool_omnipod5_synthetic.json";

/// The same data as Tidepool's Excel export writes it.
fn as_workbook(name: &str) -> Vec<u8> {
    let data: Vec<Value> = serde_json::from_slice(&fixture(name)).unwrap();
    workbook(&data, &Options::default())
}

/// The profiles (basal segments, carb ratios) read, with their instants.
type Schedules = Vec<(String, Vec<(u32, f64)>, Vec<(u32, f64)>)>;
fn schedules(b: &Batch) -> Schedules {
    b.records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Schedule { profile } if !profile.carb_ratio.is_empty() => Some((
                r.at.to_string(),
                profile
                    .basal
                    .segments
                    .iter()
                    .map(|&(m, u)| (m, u.0))
                    .collect(),
                profile.carb_ratio.iter().map(|&(m, g)| (m, g.0)).collect(),
            )),
            _ => None,
        })
        .collect()
}

/// How many records were counted, not read, as `kind`.
fn ignored(b: &Batch, kind: &str) -> usize {
    b.records
        .iter()
        .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind: k } if k == kind))
        .count()
}

#[test]
fn closed_loops_are_seen_in_tidepools_json_and_in_its_excel_export() {
    for name in [TANDEM, LOOP, MINIMED, OMNIPOD5] {
        let json = Evidence::from_file(&fixture(name));
        assert_eq!(json.delivery(), Delivery::ClosedLoop, "{name}: {json:?}");
        // The workbook has no `dosingDecision` sheet; the automated
        // deliveries are in its Basal and Bolus sheets.
        let xlsx = Evidence::from_file(&as_workbook(name));
        assert_eq!(
            xlsx.delivery(),
            Delivery::ClosedLoop,
            "{name} as .xlsx: {xlsx:?}"
        );
        assert_eq!(
            (xlsx.automated_basal, xlsx.smb),
            (json.automated_basal, json.smb),
            "{name}"
        );
        // Tidepool Web's JSON export (the workbook's rows as JSON).
        let data: Vec<Value> = serde_json::from_slice(&fixture(name)).unwrap();
        let web = Evidence::from_file(&export_json(&data, "mg/dL"));
        assert_eq!(
            (web.delivery(), web.automated_basal, web.smb),
            (Delivery::ClosedLoop, json.automated_basal, json.smb),
            "{name} as Tidepool Web's JSON export"
        );
    }
}

#[test]
fn a_loop_upload_opening_with_a_dosing_decision_is_read_as_tidepool() {
    let bytes = fixture(LOOP);
    assert_eq!(detect(LOOP, &bytes).unwrap(), Format::Tidepool);
    let b = read(&[(LOOP, bytes)], &opts("Europe/Berlin")).unwrap();
    assert_eq!(ignored(&b, "dosingDecision"), 1);
    assert_eq!(ignored(&b, "controllerSettings"), 1);
    let kinds: Vec<String> = b
        .records
        .iter()
        .filter(|r| !matches!(r.kind, RecordKind::Ignored { .. }))
        .map(|r| format!("{} {:?}", r.at, r.kind))
        .collect();
    assert_eq!(kinds.len(), 6, "{kinds:#?}");
    // Loop's settings (its one schedule, "Default") are the profile.
    assert_eq!(
        schedules(&b),
        vec![(
            "2026-11-22T07:30:00Z".into(),
            vec![(0, 0.85), (420, 1.0)],
            vec![(0, 10.0)]
        )]
    );
    assert!(b.records.iter().any(|r| matches!(r.kind,
        RecordKind::Carbs { grams } if grams.0 == 45.0)));
    assert!(b.records.iter().any(|r| matches!(r.kind,
        RecordKind::Cgm { glucose } if glucose.mg_dl.0 == 150.0)));
}

#[test]
fn the_profile_is_the_active_schedules_not_another_nor_an_override() {
    let b = read(&[(TANDEM, fixture(TANDEM))], &opts("America/Chicago")).unwrap();
    let weekday = vec![(0, 0.8), (360, 1.1), (1320, 0.9)];
    let weekday_cr = vec![(0, 12.0), (660, 9.0)];
    assert_eq!(
        schedules(&b),
        vec![(
            "2026-11-21T02:00:00Z".into(),
            weekday.clone(),
            weekday_cr.clone()
        )]
    );
    // The sleep override is counted, not a profile.
    assert_eq!(ignored(&b, "deviceEvent pumpSettingsOverride"), 1);
    // The same from the workbook (its `Carb Ratios` rows by schedule
    // name), and as --therapy-from takes it from either.
    let x = as_workbook(TANDEM);
    let xb = read(
        &[("TidepoolExport.xlsx", x.clone())],
        &opts("America/Chicago"),
    )
    .unwrap();
    assert_eq!(schedules(&xb), schedules(&b), "{:?}", xb.notes);
    let meals = Default::default();
    let data: Vec<Value> = serde_json::from_slice(&fixture(TANDEM)).unwrap();
    let web = export_json(&data, "mg/dL");
    for (name, bytes) in [
        (TANDEM, fixture(TANDEM)),
        ("TidepoolExport.xlsx", x),
        ("TidepoolExport.json", web),
    ] {
        let t = abba_io::therapy::tidepool_pump_settings(name, &bytes, &meals).unwrap();
        assert_eq!(t.len(), 1, "{name}");
        assert_eq!(
            (&t[0].basal, &t[0].carb_ratio_schedule),
            (&weekday, &weekday_cr),
            "{name}"
        );
    }
    // The Control-IQ correction is insulin delivered; the dual wave keeps
    // its two parts.
    assert!(b
        .records
        .iter()
        .any(|r| r.at.to_string() == "2026-11-20T14:05:00Z"
            && matches!(r.kind, RecordKind::Bolus { units } if units.0 == 0.65)));
    assert!(b.records.iter().any(|r| matches!(r.kind,
        RecordKind::ExtendedBolus { now, extended, duration_min: 60 }
            if now.0 == 3.6 && extended.0 == 2.0)));
}

#[test]
fn a_minimed_read_in_auto_mode_has_no_schedule_in_force_and_says_why() {
    let b = read(&[(MINIMED, fixture(MINIMED))], &opts("Europe/Paris")).unwrap();
    // The settings before auto mode are read; those in auto mode are not.
    assert_eq!(
        schedules(&b),
        vec![(
            "2026-11-10T07:00:00Z".into(),
            vec![(0, 0.75), (240, 0.95), (600, 0.8)],
            vec![(0, 10.0), (720, 12.0)]
        )]
    );
    let note = b
        .notes
        .iter()
        .find(|n| n.contains("$[2]"))
        .unwrap_or_else(|| panic!("{:?}", b.notes));
    assert!(
        note.contains("activeSchedule") && note.contains("Auto Mode") && note.contains("auto mode"),
        "{note}"
    );
    let err =
        abba_io::therapy::tidepool_pump_settings(MINIMED, &fixture(MINIMED), &Default::default())
            .unwrap_err()
            .to_string();
    assert!(
        err.contains("$[2]") && err.contains("Auto Mode") && err.contains("closed loop"),
        "{err}"
    );
    // The pump's own suspension before a low is a suspension.
    assert!(b
        .records
        .iter()
        .any(|r| r.at.to_string() == "2026-11-24T03:10:00Z"
            && matches!(
                r.kind,
                RecordKind::Suspend {
                    duration_min: Some(45)
                }
            )));
}

#[test]
fn loops_settings_in_tidepool_tell_closed_loop_on_or_off() {
    // Loop's data before its first automated delivery: its settings say
    // whether closed loop is on.
    let data: Vec<Value> = serde_json::from_slice(&fixture(LOOP)).unwrap();
    let with = |on: bool| -> Vec<u8> {
        let kept: Vec<Value> = data
            .iter()
            .filter(|d| d["deliveryType"] != "automated" && d["subType"] != "automated")
            .cloned()
            .map(|mut d| {
                if d["type"] == "pumpSettings" {
                    d["automatedDelivery"] = Value::Bool(on);
                }
                d
            })
            .collect();
        serde_json::to_vec(&kept).unwrap()
    };
    let on = Evidence::from_file(&with(true));
    assert_eq!((on.automated_basal, on.smb), (0, 0));
    assert_eq!(on.delivery(), Delivery::ClosedLoop, "{on:?}");
    assert!(
        on.words()
            .iter()
            .any(|w| w.contains("automatedDelivery true")),
        "{:?}",
        on.words()
    );
    let off = Evidence::from_file(&with(false));
    assert!(off.latest_mode_open(), "{off:?}");
    assert_ne!(off.delivery(), Delivery::ClosedLoop, "{off:?}");
}

#[test]
fn an_omnipod_5_is_a_closed_loop_by_its_automated_basal_not_its_name() {
    let data: Vec<Value> = serde_json::from_slice(&fixture(OMNIPOD5)).unwrap();
    let manual: Vec<Value> = data
        .iter()
        .filter(|d| d["deliveryType"] != "automated")
        .cloned()
        .collect();
    let tz = jiff::tz::TimeZone::get("Europe/London").unwrap();
    for (what, data, expected) in [
        ("Automated Mode", data.clone(), Delivery::ClosedLoop),
        ("Manual Mode", manual, Delivery::OpenLoop),
    ] {
        let json = serde_json::to_vec(&data).unwrap();
        let xlsx = workbook(&data, &Options::default());
        for (name, bytes) in [("op5.json", json), ("op5.xlsx", xlsx)] {
            let b = read(&[(name, bytes.clone())], &opts("Europe/London")).unwrap();
            let mut e = Evidence::from_records(&b.records, &tz);
            e.add_file(&Evidence::from_file(&bytes));
            assert_eq!(e.delivery(), expected, "{what}, {name}: {e:?}");
            assert_eq!(e.dual_mode_pumps.get("omnipod 5"), Some(&1), "{name}");
            // The active program's rates and the one carb-ratio schedule.
            assert_eq!(
                schedules(&b),
                vec![(
                    "2026-11-26T21:00:00Z".into(),
                    vec![(0, 0.7), (300, 0.9)],
                    vec![(0, 11.0), (600, 13.0)]
                )],
                "{name}"
            );
        }
    }
}
