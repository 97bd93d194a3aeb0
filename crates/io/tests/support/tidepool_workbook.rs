//! Synthetic Tidepool exports for tests: a person's data in Tidepool's data
//! model (the JSON abba reads), and the same data as Tidepool's Excel
//! export writes it, from a description of that layout (Tidepool's export
//! service with `@tidepool/data-tools` 2.5.0; see abba-io's
//! `read::tidepool_xlsx`): one sheet per type under its display name, row 1
//! the headers below in this order, `Zulu Time` an Excel date serial of
//! the UTC instant, glucose in the unit chosen at export (× 18.01559 for
//! mg/dL), durations of basal, bolus and device events in minutes,
//! `nutrition`, `annotations` and `payload` as JSON text, pump settings
//! split into one row per schedule segment, and the `EXPORT ERROR` sheet
//! first, very hidden when the export finished. Shared by abba-io's and
//! abba-store's tests (included with `#[path]`).
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use rust_xlsxwriter::{Format, Workbook};
use serde_json::{json, Value};

/// Tidepool's factor between mmol/L and mg/dL.
pub const MG_DL_PER_MMOL_L: f64 = 18.01559;

/// Headers of the first columns of every sheet.
const HEAD: [(&str, &str); 3] = [
    ("time", "Zulu Time"),
    ("localTime", "Local Time"),
    ("deviceTime", "Device Time"),
];
/// Headers of the last columns of every sheet.
const TAIL: [(&str, &str); 8] = [
    ("timezoneOffset", "Timezone Offset"),
    ("conversionOffset", "Conversion Offset"),
    ("clockDriftOffset", "Clock Drift Offset"),
    ("deviceId", "Device Id"),
    ("id", "Id"),
    ("uploadId", "Upload Id"),
    ("payload", "Payload"),
    ("annotations", "Annotations"),
];

/// (type, sheet, type column header, the sheet's own columns).
type Sheet = (
    &'static str,
    &'static str,
    &'static str,
    &'static [(&'static str, &'static str)],
);

/// The sheets of the export, in the order Tidepool's configuration names
/// their columns.
pub const SHEETS: &[Sheet] = &[
    (
        "cbg",
        "CGM",
        "Tidepool Data Type",
        &[("value", "Value"), ("units", "Units")],
    ),
    (
        "smbg",
        "SMBG",
        "Tidepool Data Type",
        &[
            ("subType", "Sub Type"),
            ("value", "Value"),
            ("units", "Units"),
        ],
    ),
    (
        "bolus",
        "Bolus",
        "Tidepool Data Type",
        &[
            ("subType", "Sub Type"),
            ("duration", "Duration (mins)"),
            ("expectedDuration", "Expected Duration (mins)"),
            ("extended", "Extended"),
            ("expectedExtended", "Expected Extended"),
            ("normal", "Normal"),
            ("expectedNormal", "Expected Normal"),
        ],
    ),
    (
        "basal",
        "Basal",
        "Tidepool Data Type",
        &[
            ("deliveryType", "Delivery Type"),
            ("duration", "Duration (mins)"),
            ("expectedDuration", "Expected Duration (mins)"),
            ("rate", "Rate"),
            ("percent", "Percent"),
            ("scheduleName", "Schedule Name"),
            ("suppressed.scheduleName", "Suppressed Schedule Name"),
            ("suppressed.deliveryType", "Suppressed Delivery Type"),
            ("suppressed.type", "Suppressed Type"),
            ("suppressed.rate", "Suppressed Rate"),
        ],
    ),
    (
        "wizard",
        "Bolus Calculator",
        "Tidepool Wizard Type",
        &[
            ("bgInput", "Bg Input"),
            ("insulinSensitivity", "Insulin Sensitivity"),
            ("carbInput", "Carb Input"),
            ("insulinCarbRatio", "Insulin Carb Ratio"),
            ("insulinOnBoard", "Insulin On Board"),
            ("bolus", "Bolus"),
            ("units", "Units"),
            ("recommended.carb", "Recommended Carb"),
            ("recommended.correction", "Recommended Correction"),
            ("recommended.net", "Recommended Net"),
            ("bgTarget.target", "BG Target"),
            ("bgTarget.high", "BG Target High"),
            ("bgTarget.low", "BG Target Low"),
            ("bgTarget.range", "BG Target Range Setting"),
        ],
    ),
    (
        "food",
        "Food",
        "Tidepool Data Type",
        &[("name", "Name"), ("nutrition", "Nutrition")],
    ),
    (
        "deviceEvent",
        "Device Event",
        "Tidepool Data Type",
        &[
            ("subType", "Sub Type"),
            ("alarmType", "Alarm Type"),
            ("value", "Value"),
            ("units", "Units"),
            ("duration", "Duration (mins)"),
            ("expectedDuration", "Expected Duration (mins)"),
            ("change.from", "Change From"),
            ("change.to", "Change To"),
            ("change.agent", "Change Agent"),
            ("from", "From"),
            ("to", "To"),
            ("status", "Status"),
            ("primeTarget", "Prime Target"),
            ("volume", "Volume"),
            ("reason.suspended", "Reason Suspended"),
            ("reason.resumed", "Reason Resumed"),
        ],
    ),
    (
        "upload",
        "Upload",
        "Tidepool Data Type",
        &[
            ("computerTime", "Computer Time"),
            ("timezone", "Timezone"),
            ("timeProcessing", "Time Processing"),
            ("version", "Version"),
            ("deviceSerialNumber", "Device Serial Number"),
            ("deviceModel", "Device Model"),
            ("deviceManufacturers", "Device Manufacturers"),
            ("deviceTags", "Device Tags"),
            ("byUser", "By User"),
        ],
    ),
    (
        "pumpSettings.basalSchedules",
        "Basal Schedules",
        "Tidepool Data Type",
        &[
            ("activeSchedule", "Active Schedule"),
            ("scheduleName", "Schedule Name"),
            ("basalSchedule.start", "Basal Schedule Start"),
            ("basalSchedule.rate", "Basal Schedule Rate"),
        ],
    ),
    (
        "pumpSettings.carbRatio",
        "Carb Ratios",
        "Tidepool Data Type",
        &[
            ("activeSchedule", "Active Schedule"),
            ("carbRatio.start", "Carb Ratio Start"),
            ("carbRatio.amount", "Carb Ratio Amount"),
            ("units.bg", "BG Units"),
            ("units.carb", "Carb Units"),
        ],
    ),
    // The named carb ratios of a pump with several profiles (Tandem): the
    // same sheet, with the schedule's name (`config.json`'s
    // `pumpSettings.carbRatios`); a pump has one form or the other.
    (
        "pumpSettings.carbRatios",
        "Carb Ratios",
        "Tidepool Data Type",
        &[
            ("activeSchedule", "Active Schedule"),
            ("scheduleName", "Schedule Name"),
            ("carbRatio.start", "Carb Ratio Start"),
            ("carbRatio.amount", "Carb Ratio Amount"),
            ("units.bg", "BG Units"),
            ("units.carb", "Carb Units"),
        ],
    ),
    (
        "pumpSettings.bgTarget",
        "BG Targets",
        "Tidepool Data Type",
        &[
            ("activeSchedule", "Active Schedule"),
            ("bgTarget.start", "BG Target Start"),
            ("bgTarget.low", "BG Low Target Setting"),
            ("bgTarget.high", "BG High Target Setting"),
            ("bgTarget.target", "BG Target Setting"),
            ("bgTarget.range", "BG Target Range Setting"),
            ("units.bg", "BG Units"),
            ("units.carb", "Carb Units"),
        ],
    ),
];

/// Settings sheets have these hidden columns between their own and the tail.
const SETTINGS_HIDDEN: [(&str, &str); 4] = [
    ("bolus", "Bolus"),
    ("manufacturers", "Manufacturers"),
    ("model", "Model"),
    ("serialNumber", "Serial Number"),
];

/// Fields written as JSON text.
const STRINGIFIED: [&str; 5] = [
    "payload",
    "annotations",
    "nutrition",
    "deviceManufacturers",
    "deviceTags",
];

/// How a workbook is written.
#[derive(Debug, Clone)]
pub struct Options {
    /// The glucose unit chosen at export (`mg/dL` or `mmol/L`).
    pub bg_units: &'static str,
    /// The export ran into Tidepool's size limit: `EXPORT ERROR` stays shown.
    pub cut_short: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            bg_units: "mmol/L",
            cut_short: false,
        }
    }
}

fn ms_of(time: &str) -> i64 {
    time.parse::<jiff::Timestamp>().unwrap().as_millisecond()
}

/// Excel's serial of an instant (exceljs: 25569 + ms / 86 400 000).
pub fn serial(ms: i64) -> f64 {
    25569.0 + ms as f64 / 86_400_000.0
}

/// A datum as Tidepool's processor leaves it: glucose in `bg_units`,
/// durations in minutes (basal, bolus, device events).
fn process(d: &Value, bg_units: &str) -> Value {
    let mut d = d.clone();
    let ty = d["type"].as_str().unwrap_or("").to_string();
    let factor = if bg_units == "mg/dL" {
        MG_DL_PER_MMOL_L
    } else {
        1.0
    };
    let scale = |v: &mut Value| {
        if let Some(x) = v.as_f64() {
            *v = json!(x * factor);
        }
    };
    let o = d.as_object_mut().unwrap();
    if o.contains_key("units") && ty != "bloodKetone" {
        if o["units"].is_string() {
            o.insert("units".into(), json!(bg_units));
        } else if let Some(u) = o["units"].as_object_mut() {
            if u.contains_key("bg") {
                u.insert("bg".into(), json!(bg_units));
            }
        }
    }
    match ty.as_str() {
        "cbg" | "smbg" | "deviceEvent" => {
            if let Some(v) = o.get_mut("value") {
                scale(v);
            }
        }
        "wizard" => {
            for f in ["bgInput", "insulinSensitivity"] {
                if let Some(v) = o.get_mut(f) {
                    scale(v);
                }
            }
            if let Some(Value::Object(t)) = o.get_mut("bgTarget") {
                for (k, v) in t.iter_mut() {
                    if ["high", "low", "target", "range"].contains(&k.as_str()) {
                        scale(v);
                    }
                }
            }
        }
        _ => {}
    }
    if ["basal", "bolus", "deviceEvent"].contains(&ty.as_str()) {
        for f in ["duration", "expectedDuration"] {
            if let Some(v) = o.get_mut(f) {
                *v = json!(v.as_f64().unwrap() / 1000.0 / 60.0);
            }
        }
    }
    d
}

/// A pump settings datum split as Tidepool splits it: one row per segment.
fn split(d: &Value) -> Vec<Value> {
    let mut common = d.clone();
    let c = common.as_object_mut().unwrap();
    for f in [
        "basalSchedules",
        "bgTarget",
        "bgTargets",
        "carbRatio",
        "carbRatios",
        "insulinSensitivity",
        "insulinSensitivities",
        "units",
    ] {
        c.remove(f);
    }
    let with = |extra: Value, ty: &str| {
        let mut row = common.clone();
        for (k, v) in extra.as_object().unwrap() {
            row[k] = v.clone();
        }
        row["type"] = json!(ty);
        row
    };
    let mut out = Vec::new();
    if let Some(Value::Object(named)) = d.get("basalSchedules") {
        for (name, segs) in named {
            for s in segs.as_array().unwrap() {
                out.push(with(
                    json!({"scheduleName": name, "basalSchedule": s}),
                    "pumpSettings.basalSchedules",
                ));
            }
        }
    }
    if let Some(Value::Array(t)) = d.get("bgTarget") {
        for s in t {
            out.push(with(
                json!({"bgTarget": s, "units": d["units"]}),
                "pumpSettings.bgTarget",
            ));
        }
    }
    if let Some(Value::Array(t)) = d.get("carbRatio") {
        for s in t {
            out.push(with(
                json!({"carbRatio": s, "units": d["units"]}),
                "pumpSettings.carbRatio",
            ));
        }
    }
    if let Some(Value::Object(named)) = d.get("carbRatios") {
        for (name, segs) in named {
            for s in segs.as_array().unwrap() {
                out.push(with(
                    json!({"carbRatio": s, "scheduleName": name, "units": d["units"]}),
                    "pumpSettings.carbRatios",
                ));
            }
        }
    }
    out
}

/// The value of a (dotted) field of a processed datum.
fn field<'a>(d: &'a Value, f: &str) -> Option<&'a Value> {
    let mut v = d;
    for part in f.split('.') {
        v = v.get(part)?;
    }
    (!v.is_null()).then_some(v)
}

/// `data` (Tidepool's data model) as Tidepool Web's JSON export writes it:
/// through the same processor as the workbook (glucose in `bg_units`,
/// durations in minutes, settings split, objects kept one level flat as
/// `a.b` keys, `nutrition`, `annotations`, `payload` and the upload's lists
/// as JSON text, only the configured fields; no `localTime` since 2026),
/// times as the data model's text, a settings segment's `start` a date on
/// 1970-01-01 as JSON writes dates.
pub fn export_json(data: &[Value], bg_units: &str) -> Vec<u8> {
    let rows = export_rows(data);
    let mut out = Vec::new();
    for r in &rows {
        let p = process(r, bg_units);
        let ty = p["type"].as_str().unwrap();
        let own: &[(&str, &str)] = SHEETS.iter().find(|s| s.0 == ty).map_or(&[], |s| s.3);
        let mut flat = serde_json::Map::new();
        let fields = HEAD
            .iter()
            .chain(&[("type", "")])
            .chain(own)
            .chain(&SETTINGS_HIDDEN)
            .chain(&TAIL);
        for (f, _) in fields {
            if *f == "localTime" {
                continue;
            }
            let Some(v) = field(&p, f) else { continue };
            let v = if f.ends_with(".start") {
                let t = jiff::Timestamp::from_millisecond(v.as_i64().unwrap()).unwrap();
                json!(t.strftime("%Y-%m-%dT%H:%M:%S.000Z").to_string())
            } else if STRINGIFIED.contains(f) {
                json!(v.to_string())
            } else {
                v.clone()
            };
            flat.insert(f.to_string(), v);
        }
        out.push(Value::Object(flat));
    }
    serde_json::to_vec(&out).unwrap()
}

/// The rows Tidepool's export writes of `data`: each `pumpSettings` split
/// into its segments, every other datum as it is.
fn export_rows(data: &[Value]) -> Vec<Value> {
    let mut rows = Vec::new();
    for d in data {
        if d["type"] == "pumpSettings" {
            rows.extend(split(d));
        } else {
            rows.push(d.clone());
        }
    }
    rows
}

/// `data` (Tidepool's data model) as Tidepool's Excel export.
pub fn workbook(data: &[Value], o: &Options) -> Vec<u8> {
    let rows = export_rows(data);
    let date = Format::new().set_num_format("yyyy-mm-dd hh:mm:ss");
    let time_of_day = Format::new().set_num_format("[$-x-systime]h:mm am/pm");
    let mut wb = Workbook::new();
    let errors = wb.add_worksheet();
    errors.set_name("EXPORT ERROR").unwrap();
    errors
        .write_string(0, 0, "Due to the size of your export, Tidepool was unable to retrieve all of your data at one time. If your data appears incomplete, try the export again using a smaller date range.")
        .unwrap();
    if !o.cut_short {
        errors.set_very_hidden(true);
    }
    // Sheets in the order their first datum comes, as Tidepool adds them.
    let mut order: Vec<&Sheet> = Vec::new();
    for r in &rows {
        let ty = r["type"].as_str().unwrap();
        let sheet = SHEETS.iter().find(|s| s.0 == ty);
        if let Some(s) = sheet {
            if !order.iter().any(|x| x.0 == s.0) {
                order.push(s);
            }
        }
    }
    if order.is_empty() {
        let ws = wb.add_worksheet();
        ws.set_name("NO DATA").unwrap();
        ws.set_active(true);
        ws.write_string(
            0,
            0,
            "Data is not available within the specified date range.",
        )
        .unwrap();
    }
    for (n, (ty, name, type_header, own)) in order.into_iter().enumerate() {
        let settings = ty.starts_with("pumpSettings.");
        let mut columns: Vec<(&str, &str)> = HEAD.to_vec();
        columns.push(("type", type_header));
        columns.extend_from_slice(own);
        if settings {
            columns.extend_from_slice(&SETTINGS_HIDDEN);
        }
        columns.extend_from_slice(&TAIL);
        let ws = wb.add_worksheet();
        ws.set_name(*name).unwrap();
        if n == 0 && !o.cut_short {
            // The sheet shown first (a writer makes the first sheet active,
            // and an active sheet is never hidden).
            ws.set_active(true);
        }
        for (c, (_, h)) in columns.iter().enumerate() {
            ws.write_string(0, c as u16, *h).unwrap();
        }
        let mut r = 1u32;
        for d in rows.iter().filter(|d| d["type"] == *ty) {
            let p = process(d, o.bg_units);
            for (c, (f, _)) in columns.iter().enumerate() {
                let c = c as u16;
                let Some(v) = field(&p, f) else { continue };
                match *f {
                    "time" => {
                        ws.write_number_with_format(
                            r,
                            c,
                            serial(ms_of(v.as_str().unwrap())),
                            &date,
                        )
                        .unwrap();
                    }
                    "localTime" => {
                        let off = p["timezoneOffset"].as_i64().unwrap_or(0) * 60_000;
                        let t = ms_of(p["time"].as_str().unwrap()) + off;
                        ws.write_number_with_format(r, c, serial(t), &date).unwrap();
                    }
                    "deviceTime" => {
                        let t = ms_of(&format!("{}Z", v.as_str().unwrap()));
                        ws.write_number_with_format(r, c, serial(t), &date).unwrap();
                    }
                    f if f.ends_with(".start") => {
                        ws.write_number_with_format(
                            r,
                            c,
                            serial(v.as_i64().unwrap()),
                            &time_of_day,
                        )
                        .unwrap();
                    }
                    f if STRINGIFIED.contains(&f) => {
                        ws.write_string(r, c, v.to_string()).unwrap();
                    }
                    _ => match v {
                        Value::Number(n) => {
                            ws.write_number(r, c, n.as_f64().unwrap()).unwrap();
                        }
                        Value::String(s) => {
                            ws.write_string(r, c, s).unwrap();
                        }
                        Value::Bool(b) => {
                            ws.write_boolean(r, c, *b).unwrap();
                        }
                        other => {
                            ws.write_string(r, c, other.to_string()).unwrap();
                        }
                    },
                }
            }
            r += 1;
        }
    }
    wb.save_to_buffer().unwrap()
}

/// A person's three days in Tidepool's data model (Europe/Zurich, UTC+2 in
/// May): glucose in mmol/L as Tidepool keeps it, a CGM reading carried by
/// two uploads, a reading above the sensor's range, a calibration, a
/// meter reading, scheduled, temporary (absolute and percent) and
/// suspended basal, a wizard with its bolus, a dual-wave bolus, food, a
/// pump suspension and resumption, pump settings, an upload.
pub fn person_data() -> Vec<Value> {
    let mut v = vec![json!({
        "type": "upload", "id": "up1", "uploadId": "upid1",
        "time": "2026-05-06T20:00:00.000Z", "timezoneOffset": 120,
        "deviceTags": ["insulin-pump", "cgm"], "deviceManufacturers": ["Medtronic"],
        "deviceModel": "1780", "deviceSerialNumber": "XXXXXX", "timezone": "Europe/Zurich",
        "version": "2.53.0", "byUser": "u1", "computerTime": "2026-05-06T22:00:00"
    })];
    // CGM every 5 minutes for 3 days from 2026-05-04T00:00 local.
    let start = ms_of("2026-05-03T22:00:00Z");
    for i in 0..(3 * 288) {
        let ms = start + i * 300_000;
        let t = jiff::Timestamp::from_millisecond(ms).unwrap();
        let mmol = ((6.5 + 2.5 * ((i as f64) / 30.0).sin()) * 10.0).round() / 10.0;
        v.push(json!({
            "type": "cbg", "id": format!("cbg{i}"), "uploadId": "upid1",
            "time": t.to_string(), "deviceTime": t.to_zoned(jiff::tz::TimeZone::fixed(jiff::tz::offset(2))).datetime().to_string(),
            "timezoneOffset": 120, "value": mmol, "units": "mmol/L",
            "payload": {"trend": "flat"}
        }));
    }
    // The reading of 2026-05-04T23:30Z carried by a second upload 30 s later.
    let twice = v[1 + 306]["value"].clone();
    v.push(json!({
        "type": "cbg", "id": "cbg-health-306", "uploadId": "upid2",
        "time": "2026-05-04T23:30:30.000Z", "timezoneOffset": 120,
        "value": twice, "units": "mmol/L"
    }));
    v.extend([
        json!({"type": "cbg", "id": "cbg-high", "time": "2026-05-05T12:02:00.000Z", "timezoneOffset": 120,
               "value": 22.2, "units": "mmol/L",
               "annotations": [{"code": "bg/out-of-range", "value": "high", "threshold": 22.2}]}),
        json!({"type": "deviceEvent", "subType": "calibration", "id": "cal1", "time": "2026-05-04T06:10:00.000Z",
               "timezoneOffset": 120, "value": 6.1, "units": "mmol/L"}),
        json!({"type": "smbg", "subType": "manual", "id": "smbg1", "time": "2026-05-04T06:05:00.000Z",
               "timezoneOffset": 120, "value": 6.3, "units": "mmol/L"}),
        json!({"type": "basal", "deliveryType": "scheduled", "id": "b1", "time": "2026-05-04T00:00:00.000Z",
               "timezoneOffset": 120, "duration": 14_400_000, "rate": 0.8, "scheduleName": "Standard"}),
        json!({"type": "basal", "deliveryType": "temp", "id": "b2", "time": "2026-05-04T04:00:00.000Z",
               "timezoneOffset": 120, "duration": 1_800_000, "expectedDuration": 1_800_000, "rate": 0.4,
               "suppressed": {"type": "basal", "deliveryType": "scheduled", "rate": 1.0, "scheduleName": "Standard"}}),
        json!({"type": "basal", "deliveryType": "scheduled", "id": "b3", "time": "2026-05-04T04:30:00.000Z",
               "timezoneOffset": 120, "duration": 27_000_000, "rate": 1.0, "scheduleName": "Standard"}),
        json!({"type": "basal", "deliveryType": "temp", "id": "b4", "time": "2026-05-05T14:00:00.000Z",
               "timezoneOffset": 120, "duration": 3_600_000, "percent": 0.5,
               "suppressed": {"type": "basal", "deliveryType": "scheduled", "rate": 1.0}}),
        json!({"type": "basal", "deliveryType": "suspend", "id": "b5", "time": "2026-05-06T09:00:00.000Z",
               "timezoneOffset": 120, "duration": 900_000,
               "suppressed": {"type": "basal", "deliveryType": "scheduled", "rate": 1.0}}),
        json!({"type": "deviceEvent", "subType": "status", "status": "suspended", "id": "s1",
               "time": "2026-05-06T09:00:00.000Z", "timezoneOffset": 120,
               "reason": {"suspended": "manual"}}),
        json!({"type": "deviceEvent", "subType": "status", "status": "resumed", "id": "s2",
               "time": "2026-05-06T09:15:00.000Z", "timezoneOffset": 120, "reason": {"resumed": "manual"}}),
        json!({"type": "wizard", "id": "w1", "time": "2026-05-04T05:30:00.000Z", "timezoneOffset": 120,
               "bgInput": 7.2, "carbInput": 45, "insulinCarbRatio": 10, "insulinSensitivity": 2.5,
               "insulinOnBoard": 0.3, "bolus": "bo1", "units": "mmol/L",
               "recommended": {"carb": 4.5, "correction": 0.2, "net": 4.4},
               "bgTarget": {"low": 5.0, "high": 7.0}}),
        json!({"type": "bolus", "subType": "normal", "id": "bo1", "time": "2026-05-04T05:30:05.000Z",
               "timezoneOffset": 120, "normal": 4.4}),
        json!({"type": "bolus", "subType": "dual/square", "id": "bo2", "time": "2026-05-04T17:00:00.000Z",
               "timezoneOffset": 120, "normal": 2.0, "extended": 3.0, "duration": 5_400_000,
               "expectedDuration": 5_400_000}),
        json!({"type": "food", "id": "f1", "time": "2026-05-05T13:00:00.000Z", "timezoneOffset": 120,
               "name": "apple", "nutrition": {"carbohydrate": {"net": 20, "units": "grams"}}}),
        json!({"type": "pumpSettings", "id": "ps1", "time": "2026-05-04T00:00:00.000Z", "timezoneOffset": 120,
               "activeSchedule": "Standard",
               "basalSchedules": {
                   "Standard": [{"start": 0, "rate": 0.8}, {"start": 21_600_000, "rate": 1.0}],
                   "Sick": [{"start": 0, "rate": 1.2}]
               },
               "carbRatio": [{"start": 0, "amount": 10}, {"start": 39_600_000, "amount": 12}],
               "bgTarget": [{"start": 0, "low": 5.0, "high": 7.0}],
               "units": {"carb": "grams", "bg": "mmol/L"}}),
    ]);
    v
}
