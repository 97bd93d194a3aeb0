//! Tidepool's Excel export (`TidepoolExport.xlsx`, Tidepool Web's
//! "Export" as Excel): its rows turned back into objects of Tidepool's data
//! model, which [`super::tidepool`] reads exactly as it reads Tidepool JSON,
//! so that the JSON and the workbook of the same data give the same records
//! with the same identities (each row's `Id` is the datum's `id`).
//!
//! # The layout (what Tidepool writes)
//!
//! Read from Tidepool's own code, not from a sample: the export service
//! (github.com/tidepool-org/export, commit c94c243 of 2026-02,
//! `lib/handlers/userDataHandler.mjs`) pipes the data of `/data/{user}`
//! through `@tidepool/data-tools` 2.5.0 (npm; its `index.js` and
//! `config.json`; the repository `tidepool-org/data-tools` itself could not
//! be fetched here): `splitPumpSettingsData`, then `tidepoolProcessor`
//! with `bgUnits` (the unit chosen at export, **mmol/L when none is
//! chosen**), then `xlsxStreamWriter` (exceljs 4.4).
//!
//! - **One sheet per data type**, named by `config.json`'s `displayName`
//!   or the type in start case: `CGM` (cbg), `SMBG`, `Bolus`, `Basal`,
//!   `Bolus Calculator` (wizard), `Food`, `Device Event`, `Upload`,
//!   `Blood Ketone`, `Physical Activity`, and the pump settings split into
//!   `Basal Schedules`, `Carb Ratios`, `BG Targets` and `Insulin
//!   Sensitivities`. The first sheet is always `EXPORT ERROR`, hidden
//!   ("veryHidden") when the export finished and left visible when Tidepool
//!   could not retrieve all the data (read here, with a note); an export
//!   with no data has a `NO DATA` sheet. Data types the configuration does
//!   not name are not in the workbook at all: **pen `insulin` doses,
//!   `cgmSettings`, `dosingDecision`, `reportedState`** (send the JSON
//!   for those).
//! - **Row 1 holds the column headers**: a field's `header` in the
//!   configuration or the field in start case (`deliveryType` → `Delivery
//!   Type`, `recommended.carb` → `Recommended Carb`). Every sheet has `Zulu
//!   Time` (`time`), `Local Time`, `Device Time`, `Tidepool Data Type`
//!   (`Tidepool Wizard Type` on the wizard's sheet), `Timezone Offset`,
//!   `Conversion Offset`, `Clock Drift Offset`, `Device Id`, `Id`, `Upload
//!   Id`, `Payload` and `Annotations`; the columns of each sheet are in
//!   [`SHEETS`].
//! - **Times are Excel date serials** (days from 1899-12-30, exceljs's
//!   25569 + ms / 86 400 000): `Zulu Time` is the UTC instant, `Local Time`
//!   the wall time (`time` + `timezoneOffset`), `Device Time` the device's
//!   clock. abba reads `Zulu Time` only, to the millisecond, as the JSON
//!   reader reads `time`; a date typed as text there is read as UTC (the
//!   column says so) when it is ISO 8601.
//! - **Glucose is in the unit chosen at export**: `value` of `cbg`, `smbg`
//!   and `deviceEvent` (calibrations), the wizard's `bgInput`, `bgTarget`
//!   and `insulinSensitivity`, the settings' targets and sensitivities are
//!   multiplied by 18.01559 for mg/dL (Tidepool keeps mmol/L), and the
//!   row's `Units` says which. abba never guesses: a glucose row without a
//!   unit is refused.
//! - **Durations in minutes**: `Duration (mins)` and `Expected Duration
//!   (mins)` of `basal`, `bolus` and `deviceEvent` are the data model's
//!   milliseconds / 1000 / 60 (read back as milliseconds × 60 000).
//! - **Nested fields**: one level is flattened into columns (`suppressed.
//!   rate` → `Suppressed Rate`, `recommended.net`); deeper objects
//!   configured as such are JSON text in one cell (`Nutrition`,
//!   `Annotations`, `Payload`).
//! - **Pump settings are split** (`splitPumpSettingsData`): one row per
//!   segment of every basal schedule (`Schedule Name`, `Basal Schedule
//!   Start` as an Excel time of day, `Basal Schedule Rate`), one per
//!   carb-ratio segment (`Carb Ratio Start`, `Carb Ratio Amount`, `Carb
//!   Units`; `Schedule Name` for the named `carbRatios` of Tandem and
//!   Omnipod 5), likewise targets and sensitivities; every row carries the
//!   settings datum's `Id`, `Zulu Time` and `Active Schedule`. abba joins
//!   the rows of one `Id` back into one `pumpSettings` object.
//!
//! Tidepool Web's *JSON* export goes through the same processor (durations
//! in minutes, `nutrition` as JSON text, settings split): it is not the
//! data model that [`super::tidepool`] reads (the API's form); see that
//! module.

use std::collections::HashMap;
use std::io::Cursor;

use calamine::{Data, Reader, SheetVisible, Xlsx};
use serde_json::{Map, Number, Value};

use crate::error::{IoError, Location};

/// A Tidepool sheet: its name, its data type, and its columns (data-model
/// field, header) in Tidepool's order.
#[derive(Debug)]
pub struct Layout {
    /// The sheet's name.
    pub name: &'static str,
    /// The data type of its rows (the `Tidepool Data Type` cell).
    pub ty: &'static str,
    /// (field, header) of each column.
    pub columns: &'static [(&'static str, &'static str)],
}

/// The columns every sheet has after its own (the settings sheets have
/// four hidden ones between, not read).
macro_rules! layout {
    ($name:expr, $ty:expr, $type_header:expr, [$(($f:expr, $h:expr)),* $(,)?]) => {
        Layout {
            name: $name,
            ty: $ty,
            columns: &[
                ("time", "Zulu Time"),
                ("localTime", "Local Time"),
                ("deviceTime", "Device Time"),
                ("type", $type_header),
                $(($f, $h),)*
                ("timezoneOffset", "Timezone Offset"),
                ("conversionOffset", "Conversion Offset"),
                ("clockDriftOffset", "Clock Drift Offset"),
                ("deviceId", "Device Id"),
                ("id", "Id"),
                ("uploadId", "Upload Id"),
                ("payload", "Payload"),
                ("annotations", "Annotations"),
            ],
        }
    };
}

const DATA_TYPE: &str = "Tidepool Data Type";

/// Tidepool's sheets (data-tools 2.5.0 `config.json`).
pub const SHEETS: &[Layout] = &[
    layout!(
        "CGM",
        "cbg",
        DATA_TYPE,
        [("value", "Value"), ("units", "Units")]
    ),
    layout!(
        "SMBG",
        "smbg",
        DATA_TYPE,
        [
            ("subType", "Sub Type"),
            ("value", "Value"),
            ("units", "Units")
        ]
    ),
    layout!(
        "Bolus",
        "bolus",
        DATA_TYPE,
        [
            ("subType", "Sub Type"),
            ("duration", "Duration (mins)"),
            ("expectedDuration", "Expected Duration (mins)"),
            ("extended", "Extended"),
            ("expectedExtended", "Expected Extended"),
            ("normal", "Normal"),
            ("expectedNormal", "Expected Normal"),
        ]
    ),
    layout!(
        "Basal",
        "basal",
        DATA_TYPE,
        [
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
        ]
    ),
    layout!(
        "Bolus Calculator",
        "wizard",
        "Tidepool Wizard Type",
        [
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
        ]
    ),
    layout!(
        "Food",
        "food",
        DATA_TYPE,
        [("name", "Name"), ("nutrition", "Nutrition")]
    ),
    layout!(
        "Device Event",
        "deviceEvent",
        DATA_TYPE,
        [
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
        ]
    ),
    layout!(
        "Upload",
        "upload",
        DATA_TYPE,
        [
            ("computerTime", "Computer Time"),
            ("timezone", "Timezone"),
            ("timeProcessing", "Time Processing"),
            ("version", "Version"),
            ("deviceSerialNumber", "Device Serial Number"),
            ("deviceModel", "Device Model"),
            ("deviceManufacturers", "Device Manufacturers"),
            ("deviceTags", "Device Tags"),
            ("byUser", "By User"),
        ]
    ),
    layout!(
        "Blood Ketone",
        "bloodKetone",
        DATA_TYPE,
        [("value", "Value"), ("units", "Units")]
    ),
    layout!(
        "Physical Activity",
        "physicalActivity",
        DATA_TYPE,
        [
            ("name", "Name"),
            ("distance", "Distance"),
            ("duration", "Duration"),
            ("energy", "Energy"),
            ("reportedIntensity", "Reported Intensity"),
        ]
    ),
    layout!(
        "Basal Schedules",
        "pumpSettings.basalSchedules",
        DATA_TYPE,
        [
            ("activeSchedule", "Active Schedule"),
            ("scheduleName", "Schedule Name"),
            ("basalSchedule.start", "Basal Schedule Start"),
            ("basalSchedule.rate", "Basal Schedule Rate"),
        ]
    ),
    layout!(
        "Carb Ratios",
        "pumpSettings.carbRatio",
        DATA_TYPE,
        [
            ("activeSchedule", "Active Schedule"),
            ("scheduleName", "Schedule Name"),
            ("carbRatio.start", "Carb Ratio Start"),
            ("carbRatio.amount", "Carb Ratio Amount"),
            ("units.bg", "BG Units"),
            ("units.carb", "Carb Units"),
        ]
    ),
    layout!(
        "BG Targets",
        "pumpSettings.bgTarget",
        DATA_TYPE,
        [
            ("activeSchedule", "Active Schedule"),
            ("scheduleName", "Schedule Name"),
            ("bgTarget.start", "BG Target Start"),
            ("bgTarget.low", "BG Low Target Setting"),
            ("bgTarget.high", "BG High Target Setting"),
            ("bgTarget.target", "BG Target Setting"),
            ("bgTarget.range", "BG Target Range Setting"),
            ("units.bg", "BG Units"),
            ("units.carb", "Carb Units"),
        ]
    ),
    layout!(
        "Insulin Sensitivities",
        "pumpSettings.insulinSensitivity",
        DATA_TYPE,
        [
            ("activeSchedule", "Active Schedule"),
            ("scheduleName", "Schedule Name"),
            ("insulinSensitivity.start", "Insulin Sensitivity Start"),
            ("insulinSensitivity.amount", "Insulin Sensitivity Amount"),
            ("units.bg", "BG Units"),
            ("units.carb", "Carb Units"),
        ]
    ),
];

/// How errors name the fields of pump settings joined from their rows
/// (the place named is the settings' first row).
pub const JOINED_SETTINGS: &[(&str, &str)] = &[
    ("time", "Zulu Time"),
    ("type", "Tidepool Data Type"),
    ("id", "Id"),
    ("activeSchedule", "Active Schedule"),
    (
        "basalSchedules",
        "Basal Schedule Start and Rate (sheet Basal Schedules)",
    ),
    (
        "carbRatio",
        "Carb Ratio Start and Amount (sheet Carb Ratios)",
    ),
    (
        "carbRatios",
        "Carb Ratio Start and Amount (sheet Carb Ratios)",
    ),
    ("units.carb", "Carb Units (sheet Carb Ratios)"),
    ("units.bg", "BG Units"),
];

/// The first sheet of every Tidepool workbook (hidden when the export
/// finished).
pub const ERROR_SHEET: &str = "EXPORT ERROR";
/// The sheet of a Tidepool workbook with no data.
pub const NO_DATA_SHEET: &str = "NO DATA";

/// The name of sheet `i` of [`SHEETS`] (for an [`crate::record::OriginAt::Row`]).
pub fn sheet_name(i: u16) -> &'static str {
    SHEETS.get(usize::from(i)).map_or("?", |l| l.name)
}

/// True when `bytes` are a zip archive (an .xlsx workbook is one).
pub fn is_zip(bytes: &[u8]) -> bool {
    bytes.starts_with(b"PK\x03\x04")
}

/// The most a workbook's parts may hold together once uncompressed
/// (bytes): about 500,000 rows of Tidepool's sheets (years of CGM). A zip
/// archive inflates a part up to about a thousand times, so a workbook of
/// a few megabytes can hold gigabytes of XML (a zip bomb): refused from
/// the sizes its directory declares, before any part is inflated (the
/// `zip` reader stops at a part's declared size).
pub const MAX_INFLATED_BYTES: u64 = 256 * 1024 * 1024;

fn not_a_workbook(file: &str, e: impl std::fmt::Display) -> IoError {
    IoError::format(
        file,
        format!("a zip archive that is not a readable Excel workbook (.xlsx): {e}"),
    )
}

/// Refuses a workbook whose parts declare more than
/// [`MAX_INFLATED_BYTES`] together.
fn check_inflated(file: &str, bytes: &[u8]) -> Result<(), IoError> {
    let mut zip = zip::ZipArchive::new(Cursor::new(bytes)).map_err(|e| not_a_workbook(file, e))?;
    let mut total: u64 = 0;
    for i in 0..zip.len() {
        let part = zip.by_index_raw(i).map_err(|e| not_a_workbook(file, e))?;
        total = total.saturating_add(part.size());
    }
    if total > MAX_INFLATED_BYTES {
        let mib = |b: u64| b / (1024 * 1024);
        return Err(IoError::format(
            file,
            format!(
                "an Excel workbook of {} bytes whose parts hold {} MiB once uncompressed, more than the {} MiB abba reads from one workbook: export a shorter date range (or Tidepool's JSON)",
                bytes.len(),
                mib(total),
                mib(MAX_INFLATED_BYTES)
            ),
        ));
    }
    Ok(())
}

fn open<'a>(file: &str, bytes: &'a [u8]) -> Result<Xlsx<Cursor<&'a [u8]>>, IoError> {
    check_inflated(file, bytes)?;
    Xlsx::new(Cursor::new(bytes)).map_err(|e| not_a_workbook(file, e))
}

/// A sheet's row that holds a value: Excel's row number, its cells by column.
type SheetRowCells = (u32, std::collections::BTreeMap<u32, Data>);

/// A sheet's rows that hold a value, in order. Read cell by cell, never as one dense range: a
/// sheet with one cell at A1 and one at XFD1048576 would be a range of
/// 17 billion cells (calamine's `worksheet_range` asked for 512 GiB and
/// aborted the process).
fn sheet_rows(
    book: &mut Xlsx<Cursor<&[u8]>>,
    file: &str,
    name: &str,
) -> Result<Vec<SheetRowCells>, IoError> {
    let bad = |e: calamine::XlsxError| {
        IoError::format(file, format!("sheet \"{name}\" cannot be read: {e}"))
    };
    let mut cells = match book.worksheet_cells_reader(name) {
        Ok(c) => c,
        // Not a worksheet (a chart sheet): no rows, as calamine's range.
        Err(calamine::XlsxError::NotAWorksheet(_)) => return Ok(Vec::new()),
        Err(e) => return Err(bad(e)),
    };
    let mut rows: std::collections::BTreeMap<u32, std::collections::BTreeMap<u32, Data>> =
        std::collections::BTreeMap::new();
    while let Some(cell) = cells.next_cell().map_err(bad)? {
        let value = Data::from(cell.get_value().clone());
        if matches!(value, Data::Empty) {
            continue;
        }
        let (r, c) = cell.get_position();
        rows.entry(r).or_default().insert(c, value);
    }
    Ok(rows.into_iter().map(|(r, cells)| (r + 1, cells)).collect())
}

fn expected() -> String {
    let names: Vec<&str> = SHEETS.iter().map(|l| l.name).collect();
    format!(
        "abba reads Tidepool's Excel export (sheets {}, each with a \"Zulu Time\" column); for Dexcom Clarity, LibreView or CareLink give the CSV their site exports",
        names.join(", ")
    )
}

/// Whether the workbook `bytes` is Tidepool's export (by its sheet
/// names: one of [`SHEETS`], or the `EXPORT ERROR` sheet Tidepool always
/// writes first); an error names the sheets found and what is expected.
pub fn check(file: &str, bytes: &[u8]) -> Result<(), IoError> {
    let book = open(file, bytes)?;
    let names = book.sheet_names();
    let tidepool = names.iter().any(|n| {
        n == ERROR_SHEET || n == NO_DATA_SHEET || SHEETS.iter().any(|l| l.name == n.as_str())
    });
    if tidepool {
        return Ok(());
    }
    let found: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    Err(IoError::format(
        file,
        format!(
            "an Excel workbook with sheets {}, not Tidepool's export: {}",
            if found.is_empty() {
                "(none)".to_string()
            } else {
                found.join(", ")
            },
            expected()
        ),
    ))
}

/// One row of a Tidepool sheet as an object of the data model.
#[derive(Debug)]
pub(crate) struct SheetRow {
    /// The object.
    pub obj: Map<String, Value>,
    /// Its sheet (index in [`SHEETS`]).
    pub sheet: u16,
    /// Excel's row number.
    pub row: u32,
}

/// A workbook's data, in sheet and row order (a pump settings datum at
/// its first row), and what was noted about it.
#[derive(Debug, Default)]
pub(crate) struct Book {
    /// The data.
    pub rows: Vec<SheetRow>,
    /// Notes (an export cut short, sheets not read).
    pub notes: Vec<String>,
}

/// Excel's serial of 1970-01-01 (1900 date system).
const UNIX_EPOCH_SERIAL: f64 = 25_569.0;
const MS_PER_DAY: f64 = 86_400_000.0;
/// Days between the 1900 and the 1904 date systems.
const DAYS_1904: i64 = 1462;

/// The instant of a `Zulu Time` cell: an Excel date (UTC, to the
/// millisecond), or ISO 8601 text (without an offset: UTC, as the column
/// says).
fn instant(cell: &Data) -> Result<Option<jiff::Timestamp>, String> {
    let serial = |v: f64| -> Result<jiff::Timestamp, String> {
        let ms = ((v - UNIX_EPOCH_SERIAL) * MS_PER_DAY).round();
        if !ms.is_finite() || !(0.0..=4.0e14).contains(&ms) {
            return Err(format!("expected a date, got the number {v}"));
        }
        jiff::Timestamp::from_millisecond(ms as i64).map_err(|e| e.to_string())
    };
    Ok(Some(match cell {
        Data::Empty => return Ok(None),
        Data::DateTime(d) if d.is_datetime() => {
            let t = serial(d.as_f64())?;
            // A workbook saved in the 1904 date system: calamine's own
            // reading of the cell says so (its date is 1462 days later).
            let (y, m, day, ..) = d.to_ymd_hms_milli();
            let theirs =
                jiff::civil::Date::new(y as i16, m as i8, day as i8).map_err(|e| e.to_string())?;
            let mine = t.to_zoned(jiff::tz::TimeZone::UTC).date();
            let days = (theirs - mine)
                .total((jiff::Unit::Day, theirs))
                .map_err(|e| e.to_string())?
                .round() as i64;
            match days {
                -1..=1 => t,
                d if (DAYS_1904 - 1..=DAYS_1904 + 1).contains(&d) => t
                    .checked_add(jiff::SignedDuration::from_hours(24 * DAYS_1904))
                    .map_err(|e| e.to_string())?,
                _ => {
                    return Err(format!(
                        "the date serial {} is not a date abba can place",
                        d.as_f64()
                    ))
                }
            }
        }
        Data::Float(v) => serial(*v)?,
        Data::Int(v) => serial(*v as f64)?,
        Data::String(s) | Data::DateTimeIso(s) => {
            let t = s.trim();
            let parsed = if crate::time::has_offset(t) {
                crate::time::parse_instant(t)
            } else {
                crate::time::parse_instant(&format!("{t}Z"))
            };
            parsed.ok_or_else(|| {
                format!("expected a date (an Excel date, or ISO 8601 text), got \"{s}\"")
            })?
        }
        other => return Err(format!("expected a date, got {}", describe(other))),
    }))
}

/// The milliseconds from midnight of a settings row's `... Start` cell (an
/// Excel time of day: exceljs writes the start as a date on 1970-01-01).
fn start_ms(cell: &Data) -> Result<Option<f64>, String> {
    let v = match cell {
        Data::Empty => return Ok(None),
        Data::DateTime(d) => d.as_f64(),
        Data::Float(v) => *v,
        Data::Int(v) => *v as f64,
        other => {
            return Err(format!(
                "expected a time of day (an Excel time), got {}",
                describe(other)
            ))
        }
    };
    let day = if v >= 1.0 { v - UNIX_EPOCH_SERIAL } else { v };
    let ms = (day * MS_PER_DAY).round();
    if !(0.0..MS_PER_DAY).contains(&ms) {
        return Err(format!(
            "expected a time of day (an Excel time on 1970-01-01, as Tidepool writes it), got the serial {v}"
        ));
    }
    Ok(Some(ms))
}

fn describe(cell: &Data) -> String {
    match cell {
        Data::Empty => "an empty cell".into(),
        Data::String(s) => format!("the text \"{s}\""),
        Data::Float(v) => format!("the number {v}"),
        Data::Int(v) => format!("the number {v}"),
        Data::Bool(b) => format!("the boolean {b}"),
        Data::DateTime(d) => format!("the date serial {}", d.as_f64()),
        Data::DateTimeIso(s) | Data::DurationIso(s) => format!("\"{s}\""),
        Data::Error(e) => format!("the error {e}"),
    }
}

/// A plain cell as a JSON value (`None`: empty).
fn value(cell: &Data) -> Result<Option<Value>, String> {
    Ok(Some(match cell {
        Data::Empty => return Ok(None),
        Data::String(s) if s.trim().is_empty() => return Ok(None),
        Data::String(s) => Value::String(s.clone()),
        Data::Float(v) => Value::Number(
            Number::from_f64(*v).ok_or_else(|| format!("expected a number, got {v}"))?,
        ),
        Data::Int(v) => Value::Number((*v).into()),
        Data::Bool(b) => Value::Bool(*b),
        Data::DateTime(d) => Value::Number(
            Number::from_f64(d.as_f64()).ok_or_else(|| "expected a number".to_string())?,
        ),
        Data::DateTimeIso(s) | Data::DurationIso(s) => Value::String(s.clone()),
        Data::Error(e) => {
            return Err(format!(
                "the cell holds the spreadsheet error {e}, not a value"
            ))
        }
    }))
}

/// Sets `path` (`a.b`) in `obj`, making the nested object.
fn set(obj: &mut Map<String, Value>, path: &str, v: Value) {
    match path.split_once('.') {
        None => {
            obj.insert(path.to_string(), v);
        }
        Some((head, rest)) => {
            let inner = obj
                .entry(head.to_string())
                .or_insert_with(|| Value::Object(Map::new()));
            if !inner.is_object() {
                *inner = Value::Object(Map::new());
            }
            if let Value::Object(m) = inner {
                set(m, rest, v);
            }
        }
    }
}

/// The types whose durations Tidepool's export writes in minutes.
const DURATION_IN_MINUTES: [&str; 3] = ["basal", "bolus", "deviceEvent"];
/// Fields Tidepool writes as JSON text that the data mapping reads.
const JSON_TEXT: [&str; 2] = ["nutrition", "annotations"];
/// Time columns besides `Zulu Time`: not read (the instant is `time`).
const OTHER_TIMES: [&str; 3] = ["localTime", "deviceTime", "computerTime"];

/// A datum as Tidepool's export processor leaves it (`a.b` keys, JSON
/// text, durations of basal, bolus and device events in minutes, the
/// settings' `start` a date on 1970-01-01) as Tidepool's data model; an
/// error names the field.
pub(crate) fn to_model(
    ty: &str,
    flat: Map<String, Value>,
) -> Result<Map<String, Value>, (String, String)> {
    let mut obj = Map::new();
    for (k, mut v) in flat {
        if k == "localTime" {
            continue; // synthesised by the export from time and offset
        }
        if JSON_TEXT.contains(&k.as_str()) {
            if let Value::String(s) = &v {
                v = serde_json::from_str(s).map_err(|e| {
                    (
                        k.clone(),
                        format!("expected JSON text (as Tidepool writes it), {e}"),
                    )
                })?;
            }
        }
        if DURATION_IN_MINUTES.contains(&ty) && (k == "duration" || k == "expectedDuration") {
            let min = v
                .as_f64()
                .ok_or_else(|| (k.clone(), format!("expected minutes as a number, got {v}")))?;
            v = Value::Number(
                Number::from_f64(min * 60_000.0)
                    .ok_or_else(|| (k.clone(), format!("expected minutes, got {min}")))?,
            );
        }
        if k.ends_with(".start") {
            if let Value::String(s) = &v {
                let ms = crate::time::parse_instant(s)
                    .map(|t| t.as_millisecond())
                    .filter(|ms| (0..86_400_000).contains(ms))
                    .ok_or_else(|| {
                        (
                            k.clone(),
                            format!("expected a time of day (a date on 1970-01-01), got \"{s}\""),
                        )
                    })?;
                v = Value::Number(ms.into());
            }
        }
        set(&mut obj, &k, v);
    }
    Ok(obj)
}

/// The data of Tidepool's workbook `bytes` as objects of the data model
/// (see the module documentation).
pub(crate) fn read(file: &str, bytes: &[u8]) -> Result<Book, IoError> {
    let mut book = open(file, bytes)?;
    let sheets: Vec<(String, SheetVisible)> = book
        .sheets_metadata()
        .iter()
        .map(|s| (s.name.clone(), s.visible))
        .collect();
    let mut out = Book::default();
    let mut known = false;
    for (name, visible) in &sheets {
        if name == ERROR_SHEET {
            known = true;
            if *visible == SheetVisible::Visible {
                out.notes.push(format!(
                    "{file}: Tidepool's \"{ERROR_SHEET}\" sheet is shown: Tidepool could not retrieve all the data of this export (its words: \"try the export again using a smaller date range\"); the rows the workbook holds are read, the rest is missing"
                ));
            }
            continue;
        }
        if name == NO_DATA_SHEET {
            known = true;
            out.notes.push(format!(
                "{file}: Tidepool's \"{NO_DATA_SHEET}\" sheet: the export holds no data for its date range"
            ));
            continue;
        }
        let Some(li) = SHEETS.iter().position(|l| l.name == name.as_str()) else {
            out.notes.push(format!(
                "{file}: sheet \"{name}\" is not one of Tidepool's export: not read"
            ));
            continue;
        };
        known = true;
        let layout = &SHEETS[li];
        let mut rows = sheet_rows(&mut book, file, name)?.into_iter();
        let Some((header_row, header)) = rows.next() else {
            continue; // an empty sheet
        };
        // Column -> field, by the header's text.
        let mut fields: HashMap<u32, &'static str> = HashMap::new();
        for (c, cell) in &header {
            let text = match cell {
                Data::String(s) => s.trim(),
                _ => "",
            };
            if let Some((f, _)) = layout
                .columns
                .iter()
                .find(|(_, h)| h.eq_ignore_ascii_case(text))
            {
                fields.insert(*c, f);
            }
        }
        if !fields.values().any(|f| *f == "time") {
            let found: Vec<String> = header.values().map(|c| format!("\"{c}\"")).collect();
            return Err(IoError::format(
                file,
                format!(
                    "sheet \"{name}\" has no \"Zulu Time\" column in its row {header_row} (found {}): not Tidepool's layout; {}",
                    found.join(", "),
                    expected()
                ),
            ));
        }
        let column = |f: &str| {
            layout
                .columns
                .iter()
                .find(|c| c.0 == f)
                .map_or_else(|| f.to_string(), |c| c.1.to_string())
        };
        for (row, cells) in rows {
            let err = |field: &str, message: String| {
                IoError::invalid(Location::sheet(file, name, row), &column(field), message)
            };
            let mut obj = Map::new();
            for (c, cell) in &cells {
                let Some(field) = fields.get(c).copied() else {
                    continue;
                };
                if OTHER_TIMES.contains(&field) {
                    continue;
                }
                let v = if field == "time" {
                    instant(cell)
                        .map_err(|m| err(field, m))?
                        .map(|t| Value::String(t.to_string()))
                } else if field.ends_with(".start") {
                    start_ms(cell)
                        .map_err(|m| err(field, m))?
                        .and_then(Number::from_f64)
                        .map(Value::Number)
                } else {
                    value(cell).map_err(|m| err(field, m))?
                };
                let Some(v) = v else { continue };
                obj.insert(field.to_string(), v);
            }
            let ty = match obj.get("type") {
                Some(Value::String(t)) => t.clone(),
                Some(other) => {
                    return Err(err(
                        "type",
                        format!("expected a Tidepool data type, got {other}"),
                    ))
                }
                None => layout.ty.to_string(),
            };
            let same_sheet = |t: &str| match layout.ty.split_once('.') {
                Some((_, split)) => t.strip_prefix("pumpSettings.").is_some_and(|x| {
                    x.trim_end_matches('s') == split.trim_end_matches('s')
                        || (split == "insulinSensitivity" && x == "insulinSensitivities")
                }),
                None => t == layout.ty,
            };
            if !same_sheet(&ty) {
                return Err(err(
                    "type",
                    format!("expected {} on sheet \"{name}\", got \"{ty}\"", layout.ty),
                ));
            }
            obj.insert("type".into(), Value::String(ty.clone()));
            let obj = to_model(&ty, obj).map_err(|(f, m)| err(&f, m))?;
            out.rows.push(SheetRow {
                obj,
                sheet: li as u16,
                row,
            });
        }
    }
    if !known {
        let names: Vec<String> = sheets.iter().map(|(n, _)| format!("\"{n}\"")).collect();
        return Err(IoError::format(
            file,
            format!(
                "an Excel workbook with sheets {}, not Tidepool's export: {}",
                names.join(", "),
                expected()
            ),
        ));
    }
    let mut rows = join_settings(
        out.rows
            .into_iter()
            .map(|r| (r.obj, (r.sheet, r.row)))
            .collect(),
    );
    wizard_carb_units(&mut rows);
    out.rows = rows
        .into_iter()
        .map(|(obj, (sheet, row))| SheetRow { obj, sheet, row })
        .collect();
    Ok(out)
}

/// The split pump-settings rows joined back into one `pumpSettings` object
/// per settings datum (by `id`, else by time), at its first row (`P`:
/// where each row was read).
pub(crate) fn join_settings<P: Copy>(
    rows: Vec<(Map<String, Value>, P)>,
) -> Vec<(Map<String, Value>, P)> {
    let key = |obj: &Map<String, Value>| -> Option<String> {
        let ty = obj.get("type")?.as_str()?;
        ty.starts_with("pumpSettings.")
            .then(|| match obj.get("id").and_then(Value::as_str) {
                Some(id) => format!("id {id}"),
                None => format!(
                    "time {}",
                    obj.get("time").and_then(Value::as_str).unwrap_or("")
                ),
            })
    };
    let mut out: Vec<(Map<String, Value>, P)> = Vec::with_capacity(rows.len());
    let mut at: HashMap<String, usize> = HashMap::new();
    for (obj, place) in rows {
        let Some(k) = key(&obj) else {
            out.push((obj, place));
            continue;
        };
        let ty = obj
            .get("type")
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_string();
        let i = *at.entry(k).or_insert_with(|| {
            let mut common = obj.clone();
            for f in [
                "basalSchedule",
                "carbRatio",
                "bgTarget",
                "insulinSensitivity",
                "scheduleName",
                "units",
                "type",
            ] {
                common.remove(f);
            }
            common.insert("type".into(), Value::String("pumpSettings".into()));
            out.push((common, place));
            out.len() - 1
        });
        let settings = &mut out[i].0;
        // The split field, and where the data model keeps it: a named
        // schedule (`basalSchedules`, `carbRatios` ...) or one array.
        let (part, named, single) = match ty.as_str() {
            "pumpSettings.basalSchedules" => ("basalSchedule", "basalSchedules", None),
            "pumpSettings.carbRatio" => ("carbRatio", "carbRatios", Some("carbRatio")),
            "pumpSettings.carbRatios" => ("carbRatio", "carbRatios", None),
            "pumpSettings.bgTarget" => ("bgTarget", "bgTargets", Some("bgTarget")),
            "pumpSettings.bgTargets" => ("bgTarget", "bgTargets", None),
            "pumpSettings.insulinSensitivity" => (
                "insulinSensitivity",
                "insulinSensitivities",
                Some("insulinSensitivity"),
            ),
            "pumpSettings.insulinSensitivities" => {
                ("insulinSensitivity", "insulinSensitivities", None)
            }
            _ => continue,
        };
        let Some(segment) = obj.get(part).cloned() else {
            continue;
        };
        if let Some(Value::Object(u)) = obj.get("units") {
            let units = settings
                .entry("units")
                .or_insert_with(|| Value::Object(Map::new()));
            if let Value::Object(m) = units {
                for (k, v) in u {
                    m.entry(k.clone()).or_insert_with(|| v.clone());
                }
            }
        }
        let list = match single {
            Some(field) => settings
                .entry(field)
                .or_insert_with(|| Value::Array(Vec::new())),
            None => {
                let name = obj
                    .get("scheduleName")
                    .and_then(Value::as_str)
                    .unwrap_or("")
                    .to_string();
                let map = settings
                    .entry(named)
                    .or_insert_with(|| Value::Object(Map::new()));
                if !map.is_object() {
                    *map = Value::Object(Map::new());
                }
                let Value::Object(m) = map else { continue };
                m.entry(name).or_insert_with(|| Value::Array(Vec::new()))
            }
        };
        if let Value::Array(a) = list {
            a.push(segment);
        }
    }
    out
}

/// What a wizard's `carbUnits` is set to where Tidepool's export does not
/// write it and nothing in the export says it: the data of a Medtronic
/// pump, whose wizard may count exchanges (read as neither unit).
pub(crate) const CARB_UNITS_UNSTATED: &str = "not written by Tidepool's export";

/// The carbohydrate unit of the export's bolus wizards. Tidepool's export
/// (the workbook's `Bolus Calculator` sheet, and its JSON, through the same
/// configuration) writes a wizard's `Carb Input` without its `carbUnits`:
/// 4 exchanges read as 4 g. The unit is taken from the pump settings the
/// export holds (`Carb Units` of `Carb Ratios`: the settings in force at
/// the wizard's time, else the first), which state the unit the pump's
/// wizard counts in; without them, a wizard of an export holding a
/// Medtronic pump's upload (the pumps whose wizards Tidepool marks as
/// counting exchanges) is marked [`CARB_UNITS_UNSTATED`], never guessed.
/// Wizards of other pumps without settings are grams, the data model's
/// unit. A wizard with its own `carbUnits` keeps it.
pub(crate) fn wizard_carb_units<P>(rows: &mut [(Map<String, Value>, P)]) {
    let time = |obj: &Map<String, Value>| {
        obj.get("time")
            .and_then(Value::as_str)
            .and_then(|t| t.parse::<jiff::Timestamp>().ok())
    };
    let mut settings: Vec<(Option<jiff::Timestamp>, String)> = rows
        .iter()
        .filter(|(obj, _)| obj.get("type").and_then(Value::as_str) == Some("pumpSettings"))
        .filter_map(|(obj, _)| {
            let units = obj.get("units")?;
            let unit = units.get("carb").or_else(|| units.get("carbs"))?.as_str()?;
            Some((time(obj), unit.to_string()))
        })
        .collect();
    settings.sort_by_key(|(t, _)| *t);
    let medtronic = rows.iter().any(|(obj, _)| {
        obj.get("type").and_then(Value::as_str) == Some("upload")
            && obj
                .get("deviceManufacturers")
                .is_some_and(|m| m.to_string().to_ascii_lowercase().contains("medtronic"))
    });
    for (obj, _) in rows.iter_mut() {
        if obj.get("type").and_then(Value::as_str) != Some("wizard")
            || obj.contains_key("carbUnits")
        {
            continue;
        }
        let at = time(obj);
        let in_force = settings
            .iter()
            .rev()
            .find(|(t, _)| at.is_some() && *t <= at)
            .or_else(|| settings.first());
        let unit = match in_force {
            Some((_, unit)) => unit.clone(),
            None if medtronic => CARB_UNITS_UNSTATED.to_string(),
            None => continue,
        };
        obj.insert("carbUnits".into(), Value::String(unit));
    }
}
