//! Our autotune against oref0 0.7.1's own autotune-prep and autotune-core
//! on the fixture days of tests/data/autotune_oref0 (README.md there says
//! how they were made): every categorised datum, every carb-ratio period,
//! every hourly basal within 0.005 U/h, ISF and carb ratio within 0.5 %.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_advisor::baselines::autotune::{
    autotune_day, Carbs, DayData, Insulin, LocalClock, Profile, Reading,
};
use serde_json::Value;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/autotune_oref0");

/// Europe/Zurich in January: UTC+1 all month (the fixture's days).
struct Cet;
impl LocalClock for Cet {
    fn minute_of_day(&self, at_ms: i64) -> u32 {
        ((at_ms.div_euclid(60_000) + 60).rem_euclid(1440)) as u32
    }
}

fn read(name: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(format!("{DATA}/{name}")).unwrap()).unwrap()
}

fn ms(text: &str) -> i64 {
    // "2026-01-10T05:55:00.000Z" (all fixture times are UTC, whole seconds)
    let d: Vec<i64> = text
        .trim_end_matches('Z')
        .split(['-', 'T', ':', '.'])
        .map(|p| p.parse().unwrap())
        .collect();
    let (y, m, day) = (d[0], d[1], d[2]);
    // days from civil (Howard Hinnant's algorithm)
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    ((days * 24 + d[3]) * 60 + d[4]) * 60_000 + d[5] * 1000
}

fn day_data(entries: &str) -> DayData {
    let e = read(entries);
    let glucose = e
        .as_array()
        .unwrap()
        .iter()
        .map(|x| Reading {
            at_ms: x["date"].as_i64().unwrap(),
            mg_dl: x["sgv"].as_f64().unwrap(),
        })
        .collect();
    let mut insulin = Vec::new();
    let mut carbs = Vec::new();
    for t in read("treatments.json").as_array().unwrap() {
        let at_ms = ms(t["created_at"].as_str().unwrap());
        if let Some(g) = t["carbs"].as_f64() {
            carbs.push(Carbs {
                at_ms,
                grams: g,
                stamp_ms: t["timestamp"].as_str().map(ms),
            });
        }
        if t["eventType"] == "Temp Basal" {
            insulin.push(Insulin::Temp {
                at_ms,
                rate: t["rate"].as_f64().unwrap(),
                duration_min: t["duration"].as_f64().unwrap(),
            });
        } else if let Some(u) = t["insulin"].as_f64() {
            insulin.push(Insulin::Bolus { at_ms, units: u });
        }
    }
    DayData {
        glucose,
        insulin,
        carbs,
    }
}

fn num(v: &Value) -> f64 {
    match v {
        Value::String(s) => s.parse().unwrap(),
        v => v.as_f64().unwrap(),
    }
}

fn check_day(day: u32) {
    let data = day_data(&format!("entries.day{day}.json"));
    let previous =
        Profile::from_json(&read(&format!("profile.day{day}.json")).to_string()).unwrap();
    let pump = Profile::from_json(&read("pumpprofile.json").to_string()).unwrap();
    let (prepped, tuned, json) = autotune_day(&data, &previous, &pump, &Cet).unwrap();

    let expected = read(&format!("prepped.day{day}.json"));
    for (name, ours) in [
        ("CSFGlucoseData", &prepped.csf),
        ("ISFGlucoseData", &prepped.isf),
        ("basalGlucoseData", &prepped.basal),
    ] {
        let theirs = expected[name].as_array().unwrap();
        assert_eq!(ours.len(), theirs.len(), "day {day} {name}: count");
        for (o, t) in ours.iter().zip(theirs) {
            assert_eq!(
                o.at_ms,
                t["date"].as_i64().unwrap(),
                "day {day} {name}: order"
            );
            for (what, a, b) in [
                ("avgDelta", o.avg_delta, num(&t["avgDelta"])),
                ("BGI", o.bgi, num(&t["BGI"])),
                ("deviation", o.deviation, num(&t["deviation"])),
            ] {
                assert_eq!(a, b, "day {day} {name} at {}: {what}", t["dateString"]);
            }
        }
    }
    let cr = expected["CRData"].as_array().unwrap();
    assert_eq!(prepped.cr.len(), cr.len(), "day {day}: carb-ratio periods");
    for (o, t) in prepped.cr.iter().zip(cr) {
        assert_eq!(o.initial_ms, ms(t["CRInitialCarbTime"].as_str().unwrap()));
        assert_eq!(o.end_ms, ms(t["CREndTime"].as_str().unwrap()));
        assert_eq!(o.initial_iob, num(&t["CRInitialIOB"]));
        assert_eq!(o.end_iob, num(&t["CREndIOB"]));
        assert_eq!(o.initial_bg, num(&t["CRInitialBG"]));
        assert_eq!(o.end_bg, num(&t["CREndBG"]));
        assert!((o.carbs - num(&t["CRCarbs"])).abs() < 1e-9);
        assert_eq!(o.insulin, num(&t["CRInsulin"]), "day {day}: CRInsulin");
    }

    let out = read(&format!("autotune.day{day}.json"));
    let basal = out["basalprofile"].as_array().unwrap();
    assert_eq!(tuned.basal.len(), 24);
    for (o, t) in tuned.basal.iter().zip(basal) {
        let (a, b) = (o.rate, num(&t["rate"]));
        assert!(
            (a - b).abs() <= 0.005,
            "day {day} hour {}: {a} vs oref0 {b}",
            o.minutes / 60
        );
        assert_eq!(o.untuned, t["untuned"].as_u64().map(|u| u as u32));
    }
    let rel = |a: f64, b: f64| (a / b - 1.0).abs();
    assert!(
        rel(tuned.isf, num(&out["sens"])) <= 0.005,
        "ISF {} vs {}",
        tuned.isf,
        out["sens"]
    );
    assert!(
        rel(tuned.carb_ratio, num(&out["carb_ratio"])) <= 0.005,
        "CR {} vs {}",
        tuned.carb_ratio,
        out["carb_ratio"]
    );
    assert!(rel(tuned.csf, num(&out["csf"])) <= 0.005);
    // The same numbers exactly, and the same profile document.
    for key in [
        "sens",
        "carb_ratio",
        "csf",
        "dia",
        "insulinPeakTime",
        "autosens_max",
    ] {
        assert_eq!(json[key], out[key], "day {day}: {key}");
    }
    assert_eq!(
        json["isfProfile"], out["isfProfile"],
        "day {day}: isfProfile"
    );
    assert_eq!(
        json["basalprofile"], out["basalprofile"],
        "day {day}: basalprofile"
    );
}

#[test]
fn day1_from_the_pump_profile_matches_oref0() {
    check_day(1);
}

#[test]
fn day2_from_day1s_result_matches_oref0() {
    check_day(2);
}
