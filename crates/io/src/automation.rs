//! Which therapy the data show: open-loop pump therapy (what ABBA was
//! designed and validated for), automated insulin delivery (a closed loop)
//! or multiple daily injections, with the evidence counted.
//!
//! A loop is recognised by any of: short temporary basals (≤ 30 min)
//! started in most hours of the pump's days, super micro boluses (SMB,
//! `isSMB`, Loop's automatic boluses), Tidepool `automated` basal, an
//! uploader or device of a JSON export named as a loop system (iAPS, Trio,
//! Loop, AndroidAPS, OpenAPS, FreeAPS, Control-IQ, CamAPS, 780G /
//! SmartGuard auto mode), a Nightscout Profile Switch to the pump's auto
//! mode (a MiniMed 670G's "Auto Mode", see
//! [`crate::read::nightscout::is_auto_mode_switch`]), or in a CareLink
//! export SmartGuard's auto mode:
//! `Bolus Source` `CLOSED_LOOP_*` (the automatic `CLOSED_LOOP_AUTO_*`
//! doses count as automatic boluses) and the "Aggregated Auto Insulin
//! Data" totals. A CareLink export naming a 780G without these is not a
//! loop: the 780G also runs in manual mode, open-loop therapy.
//! Injections: long-acting insulin and no pump basal record, or
//! injections logged in a CGM's app (CareLink's `Insulin: N` markers) and
//! no pump record at all. Data with no
//! pump record and no insulin at all (a CGM-only export) show no delivery:
//! abba says so instead of calling it open-loop pump therapy. For a
//! person the last [`LOOP_RECENT_DAYS`] of the data tell: records before
//! them, and files whose loop marks are all dated before them, are a past
//! loop (named in the words, not counted).

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::read::carelink;
use crate::record::{Record, RecordKind};

/// Names of loop systems as uploaders and devices spell them (lower case).
pub const LOOP_NAMES: [&str; 13] = [
    "iaps",
    "trio",
    "loop",
    "androidaps",
    "openaps",
    "freeaps",
    "aaps",
    "control-iq",
    "controliq",
    "camaps",
    "780g",
    "smartguard",
    "omnipod 5",
];

/// How the loop evidence names Nightscout Profile Switches to a pump's
/// auto mode ([`crate::read::nightscout::is_auto_mode_switch`]).
pub const AUTO_MODE_SWITCHES: &str =
    "SmartGuard auto mode (Nightscout Profile Switches to the pump's \"Auto Mode\")";

/// A temporary basal this short or shorter is a loop's adjustment.
pub const SHORT_TEMP_BASAL_MIN: u32 = 30;

/// Share of the pump's hours with a short temporary basal that marks a loop.
pub const LOOP_HOUR_SHARE: f64 = 0.5;

/// Counts that tell the therapy apart.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Evidence {
    /// Temporary basals.
    pub temp_basals: usize,
    /// Of them, ≤ 30 min.
    pub short_temp_basals: usize,
    /// Of them, at 0 U/h (or 0 %).
    pub zero_temp_basals: usize,
    /// Hours with a short temporary basal starting in them.
    pub hours_with_short_temp: usize,
    /// Hours of the local days that have pump records.
    pub pump_hours: usize,
    /// Super micro boluses and automatic boluses.
    pub smb: usize,
    /// Basal records a loop set on its own: Tidepool's `deliveryType:
    /// automated`, Nightscout Temp Basals marked `automatic` (Loop).
    pub automated_basal: usize,
    /// Loop systems named by uploaders and devices, with counts.
    pub systems: BTreeMap<String, usize>,
    /// A loop app's own records of running in open loop (AndroidAPS's
    /// permanent running mode `OPEN_LOOP`, see [`running_mode`]): it
    /// suggests, the person decides.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub open_loop_modes: usize,
    /// Long-acting insulin records.
    pub long_acting: usize,
    /// Injections logged in a CGM's app without their acting type
    /// (CareLink's `Insulin: N` event markers).
    #[serde(default)]
    pub injection_markers: usize,
    /// Pump basal records (profiles, temporary basals, suspensions).
    pub pump_basal: usize,
    /// The latest instant (Unix ms) of a file item that marks a loop (an
    /// SMB, an automated basal, a loop system named), when every such item
    /// is dated ([`Evidence::from_file`]); marks all older than the last
    /// [`LOOP_RECENT_DAYS`] of a person's data are a past loop.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loop_marks_until_ms: Option<i64>,
    /// A file item marked a loop without a time abba could read (such
    /// marks always count as current).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub undated_loop_marks: bool,
    /// Loop marks of files left out because they all end before the last
    /// [`LOOP_RECENT_DAYS`] of the data: the latest (Unix ms), for words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub past_loop_until_ms: Option<i64>,
    /// The device's UTC offsets the files carry ([`crate::clocks`]; the
    /// store keeps a file's when some are not the person's zone's).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub clocks: Vec<crate::clocks::ClockStretch>,
}

/// The days at the end of a person's data whose records and loop marks
/// tell the delivery: a loop run only before them (a person who stopped
/// looping) does not hold the basal advice for good.
pub const LOOP_RECENT_DAYS: i64 = 28;

/// The start (Unix ms) of the last [`LOOP_RECENT_DAYS`] of `records`
/// (before their latest instant); `None` without records.
pub fn recent_from_ms(records: &[Record]) -> Option<i64> {
    records
        .iter()
        .map(|r| r.at.as_millisecond())
        .max()
        .map(|end| end - LOOP_RECENT_DAYS * 86_400_000)
}

/// What the data show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Delivery {
    /// Open-loop pump therapy (or nothing says otherwise).
    OpenLoop,
    /// Automated insulin delivery.
    ClosedLoop,
    /// Multiple daily injections.
    Injections,
    /// No pump record and no insulin in the data (CGM or meter only): the
    /// delivery is not known.
    NoInsulinRecords,
}

impl Delivery {
    /// In words.
    pub fn name(self) -> &'static str {
        match self {
            Delivery::OpenLoop => "open-loop pump therapy",
            Delivery::ClosedLoop => "automated insulin delivery (a closed loop)",
            Delivery::Injections => "multiple daily injections",
            Delivery::NoInsulinRecords => "no pump or insulin records (the delivery is not known)",
        }
    }
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// The start of the keys under which [`Evidence::systems`] counts device
/// status documents of a loop (`devicestatus.loop`, `devicestatus.openaps`).
const DEVICE_STATUS_MARK: &str = "devicestatus.";

/// What a loop app's running-mode record says (see [`running_mode`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunningMode {
    /// Permanent open loop: the app suggests, the person decides.
    Open,
    /// Closed loop (`CLOSED_LOOP`, or `CLOSED_LOOP_LGS`: low-glucose
    /// suspend only), permanent or not; the mode's name.
    Closed(&'static str),
}

/// The running mode an AndroidAPS "OpenAPS Offline" treatment records
/// (AndroidAPS 3.4 and later, `RM` in `core/data/.../model/RM.kt`, written
/// by `nsclient/extensions/RunningModeExtension.kt` and
/// `nsclientV3/extensions/RunningModeExtension.kt`): `mode` `OPEN_LOOP`,
/// `CLOSED_LOOP` or `CLOSED_LOOP_LGS` with `duration` 0 and
/// `originalDuration` its real length in ms (0: until the next mode). An
/// `OPEN_LOOP` with an `originalDuration` is temporary (AndroidAPS forces it
/// for a while when closing the loop is not allowed) and says nothing of
/// the mode after it; the other modes (suspended, disconnected, disabled,
/// superbolus) say nothing of open or closed. `None` for anything else.
pub fn running_mode(item: &Value) -> Option<RunningMode> {
    if item.get("eventType").and_then(Value::as_str) != Some("OpenAPS Offline") {
        return None;
    }
    let permanent = item
        .get("originalDuration")
        .is_none_or(|d| d.is_null() || d.as_f64() == Some(0.0));
    match item.get("mode").and_then(Value::as_str)? {
        "OPEN_LOOP" if permanent => Some(RunningMode::Open),
        "CLOSED_LOOP" => Some(RunningMode::Closed("CLOSED_LOOP")),
        "CLOSED_LOOP_LGS" => Some(RunningMode::Closed("CLOSED_LOOP_LGS")),
        _ => None,
    }
}

impl Evidence {
    /// Counts from normalised records (zone `tz` for the hours).
    pub fn from_records(records: &[Record], tz: &jiff::tz::TimeZone) -> Self {
        Self::from_records_since(records, tz, i64::MIN)
    }

    /// Counts from the records at or after `from_ms` (Unix ms; see
    /// [`recent_from_ms`]).
    pub fn from_records_since(records: &[Record], tz: &jiff::tz::TimeZone, from_ms: i64) -> Self {
        let mut e = Evidence::default();
        let mut short_hours = BTreeSet::new();
        let mut pump_days = BTreeSet::new();
        for r in records.iter().filter(|r| r.at.as_millisecond() >= from_ms) {
            let local = tz.to_datetime(r.at);
            match &r.kind {
                // The end of a temporary basal (0 min): none was started.
                RecordKind::TempBasal {
                    duration_min: 0, ..
                } => {
                    e.pump_basal += 1;
                    pump_days.insert(local.date());
                }
                RecordKind::TempBasal { rate, duration_min } => {
                    e.temp_basals += 1;
                    e.pump_basal += 1;
                    if *duration_min <= SHORT_TEMP_BASAL_MIN {
                        e.short_temp_basals += 1;
                        short_hours.insert((local.date(), local.hour()));
                    }
                    let zero = match rate {
                        crate::record::TempRate::Absolute(u) => u.0 == 0.0,
                        crate::record::TempRate::Percent(p) => *p == 0.0,
                    };
                    if zero {
                        e.zero_temp_basals += 1;
                    }
                    pump_days.insert(local.date());
                }
                RecordKind::Schedule { .. } | RecordKind::Suspend { .. } | RecordKind::Resume => {
                    e.pump_basal += 1;
                    pump_days.insert(local.date());
                }
                RecordKind::Bolus { .. } | RecordKind::ExtendedBolus { .. } => {
                    pump_days.insert(local.date());
                }
                RecordKind::LongActing { .. } => e.long_acting += 1,
                RecordKind::Ignored { kind } if kind == carelink::INSULIN_MARKER => {
                    e.injection_markers += 1
                }
                _ => {}
            }
        }
        e.hours_with_short_temp = short_hours.len();
        e.pump_hours = pump_days.len() * 24;
        e
    }

    /// Counts from an export file as it is (what normalised records do not
    /// keep: SMB marks, uploader and device names, Tidepool's delivery
    /// type, CareLink's SmartGuard auto mode, see [`Evidence::from_carelink`]).
    /// Any other file adds nothing.
    pub fn from_file(bytes: &[u8]) -> Self {
        let mut e = Evidence::default();
        // A JSON array, one object, or mongoexport's one document a line.
        let Ok(items) = crate::read::json::parse_array("", bytes) else {
            return Self::from_carelink(bytes);
        };
        // A document deleted where it was written (`isValid: false`, as
        // AndroidAPS and API v3 mark them) is not read, nor is it evidence.
        let deleted = |item: &Value| item.get("isValid") == Some(&Value::Bool(false));
        for item in items.iter().filter(|i| !deleted(i)) {
            let before = (e.smb, e.automated_basal, e.systems.values().sum::<usize>());
            e.count_item(item);
            if before != (e.smb, e.automated_basal, e.systems.values().sum::<usize>()) {
                match item_time_ms(item) {
                    Some(ms) => {
                        e.loop_marks_until_ms =
                            Some(e.loop_marks_until_ms.map_or(ms, |u| u.max(ms)))
                    }
                    None => e.undated_loop_marks = true,
                }
            }
        }
        e
    }

    /// Counts one item of a JSON export (see [`Evidence::from_file`]).
    fn count_item(&mut self, item: &Value) {
        let e = self;
        {
            // A Nightscout Profile Switch to the pump's auto mode (the
            // MiniMed 670G's SmartGuard, as 600SeriesAndroidUploader writes it).
            if item
                .as_object()
                .is_some_and(crate::read::nightscout::is_auto_mode_switch)
            {
                *e.systems.entry(AUTO_MODE_SWITCHES.to_string()).or_default() += 1;
            }
            let s = |k: &str| item.get(k).and_then(Value::as_str).unwrap_or("");
            let automatic = item.get("automatic").and_then(Value::as_bool) == Some(true);
            // Loop writes its own temporary basals `automatic` too, with
            // the insulin they delivered: basal records, not boluses.
            let temp_basal = s("eventType") == "Temp Basal";
            if s("eventType") == "SMB"
                || item.get("isSMB").and_then(Value::as_bool) == Some(true)
                || (automatic && !temp_basal && item.get("insulin").is_some())
                || (s("type") == "bolus" && s("subType") == "automated")
            {
                e.smb += 1;
            }
            if (s("type") == "basal" && s("deliveryType") == "automated")
                || (automatic && temp_basal)
            {
                e.automated_basal += 1;
            }
            // Nightscout device status of a loop: `loop` (Loop) or `openaps`
            // (OpenAPS, AndroidAPS, iAPS, Trio).
            for key in ["loop", "openaps"] {
                if item.get(key).is_some_and(Value::is_object) {
                    *e.systems
                        .entry(format!("{DEVICE_STATUS_MARK}{key}"))
                        .or_default() += 1;
                }
            }
            match running_mode(item) {
                Some(RunningMode::Open) => e.open_loop_modes += 1,
                Some(RunningMode::Closed(mode)) => {
                    *e.systems
                        .entry(format!("AndroidAPS's running mode {mode}"))
                        .or_default() += 1
                }
                None => {}
            }
            // `app`: the client that wrote a document through Nightscout's
            // API v3 ("AAPS" for AndroidAPS's NSClientV3, which writes no
            // `enteredBy` on its boluses and temporary basals).
            for key in [
                "enteredBy",
                "device",
                "uploader",
                "deviceModel",
                "deviceManufacturers",
                "app",
            ] {
                let text = match item.get(key) {
                    Some(Value::String(t)) => t.to_ascii_lowercase(),
                    Some(Value::Array(a)) => a
                        .iter()
                        .filter_map(Value::as_str)
                        .collect::<Vec<_>>()
                        .join(" ")
                        .to_ascii_lowercase(),
                    _ => continue,
                };
                if let Some(name) = LOOP_NAMES.iter().find(|n| names(&text, n)) {
                    *e.systems.entry((*name).to_string()).or_default() += 1;
                }
            }
        }
    }

    /// True when the file's loop marks are all dated and end before
    /// `recent_from_ms` (the start of the last [`LOOP_RECENT_DAYS`] of a
    /// person's data): a past loop.
    pub fn loop_marks_before(&self, recent_from_ms: i64) -> bool {
        !self.undated_loop_marks && self.loop_marks_until_ms.is_some_and(|u| u < recent_from_ms)
    }

    /// A CareLink export's auto-mode evidence ([`carelink::auto_mode`]):
    /// its automatic doses (`CLOSED_LOOP_AUTO_*`) counted as automatic
    /// boluses, its boluses in auto mode and its daily auto insulin totals
    /// as "SmartGuard auto mode" with the pump's name. The pump's name
    /// alone (a 780G) is not evidence: the 780G also runs in manual mode,
    /// open-loop therapy. Anything but a CareLink export adds nothing.
    pub fn from_carelink(bytes: &[u8]) -> Self {
        let mut e = Evidence::default();
        let decoded = crate::read::table::utf16_to_utf8("", bytes).ok().flatten();
        let bytes = crate::read::table::strip_bom(decoded.as_deref().unwrap_or(bytes));
        let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
        if !carelink::looks_like(&head) {
            return e;
        }
        let a = carelink::auto_mode(bytes);
        let device = a.device.map_or(String::new(), |d| format!(", {d}"));
        e.smb = a.automatic_doses;
        if a.auto_mode_boluses > 0 {
            e.systems.insert(
                format!("SmartGuard auto mode (CareLink boluses with Bolus Source CLOSED_LOOP_*{device})"),
                a.auto_mode_boluses,
            );
        }
        if a.auto_insulin_totals > 0 {
            e.systems.insert(
                format!("SmartGuard auto mode (CareLink daily totals of auto insulin{device})"),
                a.auto_insulin_totals,
            );
        }
        e
    }

    /// Adds another file's counts (records' counts are taken whole).
    pub fn add_file(&mut self, other: &Evidence) {
        self.smb += other.smb;
        self.automated_basal += other.automated_basal;
        self.open_loop_modes += other.open_loop_modes;
        for (k, v) in &other.systems {
            *self.systems.entry(k.clone()).or_default() += v;
        }
        self.loop_marks_until_ms = self.loop_marks_until_ms.max(other.loop_marks_until_ms);
        self.undated_loop_marks |= other.undated_loop_marks;
        self.past_loop_until_ms = self.past_loop_until_ms.max(other.past_loop_until_ms);
        self.clocks.extend_from_slice(&other.clocks);
    }

    /// Share of the pump's hours with a short temporary basal.
    pub fn short_temp_share(&self) -> f64 {
        if self.pump_hours == 0 {
            0.0
        } else {
            self.hours_with_short_temp as f64 / self.pump_hours as f64
        }
    }

    /// True when the loop marks are only AndroidAPS's name and device
    /// status (no closed running mode, SMB, automated basal or short
    /// temporary basals in most hours) and the app recorded running in open
    /// loop ([`Evidence::open_loop_modes`]): open-loop pump therapy.
    pub fn app_in_open_loop(&self) -> bool {
        self.open_loop_modes > 0
            && self.short_temp_share() < LOOP_HOUR_SHARE
            && self.smb == 0
            && self.automated_basal == 0
            && self.systems.keys().all(|k| app_mark(k))
    }

    /// What the counts show.
    pub fn delivery(&self) -> Delivery {
        if self.app_in_open_loop() {
            Delivery::OpenLoop
        } else if self.short_temp_share() >= LOOP_HOUR_SHARE
            || self.smb > 0
            || self.automated_basal > 0
            || !self.systems.is_empty()
        {
            Delivery::ClosedLoop
        } else if self.long_acting > 0 && self.pump_basal == 0
            || self.injection_markers > 0 && self.pump_basal == 0 && self.pump_hours == 0
        {
            Delivery::Injections
        } else if self.pump_hours == 0 && self.long_acting == 0 {
            Delivery::NoInsulinRecords
        } else {
            Delivery::OpenLoop
        }
    }

    /// The evidence in words (only what is there).
    pub fn words(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.temp_basals > 0 {
            out.push(format!(
                "{} temporary basals ({} of {} min or less, {} at 0 U/h) starting in {} of {} pump hours ({:.0} %)",
                self.temp_basals,
                self.short_temp_basals,
                SHORT_TEMP_BASAL_MIN,
                self.zero_temp_basals,
                self.hours_with_short_temp,
                self.pump_hours,
                100.0 * self.short_temp_share()
            ));
        }
        if self.smb > 0 {
            out.push(format!("{} super micro / automatic boluses", self.smb));
        }
        if self.automated_basal > 0 {
            out.push(format!("{} automated basal records", self.automated_basal));
        }
        for (k, v) in &self.systems {
            out.push(format!(
                "{v} record{} from or naming {k}",
                if *v == 1 { "" } else { "s" }
            ));
        }
        let apps_only = !self.systems.is_empty() && self.systems.keys().all(|k| app_mark(k));
        if self.app_in_open_loop() {
            out.push(format!(
                "{} running-mode record{} of AndroidAPS in open loop (\"OpenAPS Offline\", mode OPEN_LOOP) and no closed mode: it suggests temporary basals and the person decides, open-loop pump therapy",
                self.open_loop_modes,
                if self.open_loop_modes == 1 { "" } else { "s" }
            ));
        } else if self.open_loop_modes > 0 {
            out.push(format!(
                "{} running-mode records of AndroidAPS in open loop (OPEN_LOOP), but the marks above show the loop closed: taken as a closed loop",
                self.open_loop_modes
            ));
        } else if apps_only
            && self.smb == 0
            && self.automated_basal == 0
            && self.short_temp_share() < LOOP_HOUR_SHARE
        {
            out.push(
                "AndroidAPS (or OpenAPS) is named, with no record of its running mode (AndroidAPS 3.4 and later write it as \"OpenAPS Offline\" with mode OPEN_LOOP or CLOSED_LOOP): taken as a closed loop, the safe side".into(),
            );
        }
        if let Some(ms) = self.past_loop_until_ms {
            let until = jiff::Timestamp::from_millisecond(ms)
                .map_or_else(|_| ms.to_string(), |t| t.to_string());
            out.push(format!(
                "loop marks in earlier files until {until}, before the last {LOOP_RECENT_DAYS} days of the data: a past loop, not counted"
            ));
        }
        if self.long_acting > 0 {
            out.push(format!(
                "{} long-acting insulin records, {} pump basal records",
                self.long_acting, self.pump_basal
            ));
        }
        if self.injection_markers > 0 {
            out.push(format!(
                "{} injections logged as event markers (\"Insulin: N\", acting type not given), {} pump records",
                self.injection_markers, self.pump_basal
            ));
        }
        out
    }
}

/// The instant of a JSON export's item (Unix ms), from the fields
/// Nightscout and Tidepool date it with: `date` or `mills` (ms), or
/// `created_at`, `dateString`, `timestamp`, `time` with an offset.
fn item_time_ms(item: &Value) -> Option<i64> {
    for key in ["date", "mills"] {
        if let Some(ms) = item.get(key).and_then(Value::as_f64) {
            if ms.is_finite() && ms > 0.0 {
                return Some(ms as i64);
            }
        }
    }
    ["created_at", "dateString", "timestamp", "time", "date"]
        .iter()
        .filter_map(|k| item.get(*k).and_then(Value::as_str))
        .find_map(|t| t.parse::<jiff::Timestamp>().ok())
        .map(jiff::Timestamp::as_millisecond)
}

/// True when a key of [`Evidence::systems`] only names AndroidAPS (its
/// treatments' `enteredBy` `openaps://AndroidAPS`, its running modes'
/// `openaps://AAPS`, its device's `openaps://<phone>`) or counts its device
/// status (`openaps`, with `suggested` and, when the person accepted one,
/// `enacted`): what AndroidAPS writes in open loop too.
fn app_mark(key: &str) -> bool {
    ["androidaps", "aaps", "openaps"].contains(&key)
        || key == format!("{DEVICE_STATUS_MARK}openaps")
}

/// True when `text` names `name` as a word (so "loop" is not found in
/// "sloop" or "loopback").
fn names(text: &str, name: &str) -> bool {
    text.match_indices(name).any(|(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + name.len()..].chars().next();
        !before.is_some_and(char::is_alphanumeric) && !after.is_some_and(char::is_alphanumeric)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loop_names_are_found_as_words() {
        assert!(names("loop://iphone", "loop"));
        assert!(names("openaps://samsung sm-g970f", "openaps"));
        assert!(!names("sloophole", "loop"));
        let e = Evidence::from_file(
            br#"[{"eventType":"SMB","insulin":0.2,"enteredBy":"iAPS"},{"eventType":"Temp Basal","enteredBy":"Trio"}]"#,
        );
        assert_eq!(e.smb, 1);
        assert_eq!(e.systems.get("iaps"), Some(&1));
        assert_eq!(e.systems.get("trio"), Some(&1));
        assert_eq!(e.delivery(), Delivery::ClosedLoop);
        // A document deleted where it was written is no evidence.
        let deleted = Evidence::from_file(
            br#"[{"eventType":"SMB","insulin":0.2,"isSMB":true,"isValid":false,"enteredBy":"openaps://AAPS"}]"#,
        );
        assert_eq!((deleted.smb, deleted.systems.len()), (0, 0), "{deleted:?}");
        let mut none = Evidence::from_file(br#"[{"eventType":"Meal Bolus","enteredBy":"xdrip"}]"#);
        // A day of pump records (counted from the records, not the file).
        none.pump_hours = 24;
        assert_eq!(none.delivery(), Delivery::OpenLoop);
    }

    #[test]
    fn loops_automatic_temp_basals_are_basal_records_not_boluses() {
        // Loop's shapes (Nightscout's captured Loop fixtures): its temporary
        // basals and its automatic boluses both carry `automatic` and the
        // insulin they delivered.
        let e = Evidence::from_file(
            br#"[{"eventType":"Temp Basal","automatic":true,"rate":0.4,"absolute":0.4,"duration":30,"insulin":0.0426},
                 {"eventType":"Temp Basal","automatic":true,"rate":0,"absolute":0,"duration":30,"insulin":0},
                 {"eventType":"Correction Bolus","automatic":true,"insulin":0.35},
                 {"eventType":"Correction Bolus","automatic":false,"insulin":2.0}]"#,
        );
        assert_eq!((e.automated_basal, e.smb), (2, 1));
        assert_eq!(e.delivery(), Delivery::ClosedLoop);
        assert!(e.words().iter().any(|w| w == "2 automated basal records"));
    }

    #[test]
    fn data_without_pump_or_insulin_records_show_no_delivery() {
        // CGM only: nothing says how insulin is delivered.
        assert_eq!(Evidence::default().delivery(), Delivery::NoInsulinRecords);
        let injections = Evidence {
            long_acting: 3,
            ..Evidence::default()
        };
        assert_eq!(injections.delivery(), Delivery::Injections);
        let pump = Evidence {
            pump_hours: 24,
            pump_basal: 1,
            ..Evidence::default()
        };
        assert_eq!(pump.delivery(), Delivery::OpenLoop);
    }
}
