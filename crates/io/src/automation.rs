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
pub const LOOP_NAMES: [&str; 11] = [
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
    "smartguard",
];

/// Names of pumps that run in a manual mode (open-loop pump therapy) or
/// in an automated one (lower case): the MiniMed 780G (manual mode or
/// SmartGuard) and the Omnipod 5 (Manual Mode or Automated Mode). Their
/// name tells nothing of the mode: their automated deliveries do
/// (Tidepool's `deliveryType` `automated`, CareLink's `CLOSED_LOOP_*`).
pub const DUAL_MODE_PUMPS: [&str; 2] = ["780g", "omnipod 5"];

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
    /// Pumps named that run in a manual or an automated mode
    /// ([`DUAL_MODE_PUMPS`]), with counts: not loop marks by themselves.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub dual_mode_pumps: BTreeMap<String, usize>,
    /// A loop app's own records of running in open loop (AndroidAPS's
    /// permanent running mode `OPEN_LOOP`, see [`running_mode`]): it
    /// suggests, the person decides.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub open_loop_modes: usize,
    /// The latest dated record of a loop app's mode ([`running_mode`]):
    /// a mode holds until the next one, so the latest tells the mode at
    /// the end of the data, however old it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_mode: Option<ModeMark>,
    /// A record of a loop app's mode without a time abba could read: the
    /// modes cannot be ordered, and a closed one holds.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub undated_modes: bool,
    /// The latest instant (Unix ms) of an automated delivery (an SMB or
    /// automatic bolus, an automated basal) of a file, when every one is
    /// dated: deliveries all before the last [`LOOP_RECENT_DAYS`] of a
    /// person's data are a past loop even when the file goes on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub automated_until_ms: Option<i64>,
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
    /// How many of a CareLink export's auto-mode rows have a date and
    /// time abba could not read ([`Evidence::from_file_with`]): marks
    /// taken as current, said.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub undated_marks: usize,
    /// The lines of the first [`UNDATED_LINES_KEPT`] of them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub undated_mark_lines: Vec<u64>,
    /// Loop marks of files left out because they all end before the last
    /// [`LOOP_RECENT_DAYS`] of the data: the latest (Unix ms), for words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub past_loop_until_ms: Option<i64>,
    /// The device's UTC offsets the files carry ([`crate::clocks`]; the
    /// store keeps a file's when some are not the person's zone's).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub clocks: Vec<crate::clocks::ClockStretch>,
}

/// How many lines of undated auto-mode rows the evidence keeps (and says).
pub const UNDATED_LINES_KEPT: usize = 5;

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

/// What a loop app's record of its mode says (see [`running_mode`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunningMode {
    /// Open loop: the app suggests, the person decides; the record, in
    /// words.
    Open(&'static str),
    /// Closed loop; the record, in words (the key it is counted under in
    /// [`Evidence::systems`]).
    Closed(&'static str),
}

/// A dated record of a loop app's mode (see [`Evidence::last_mode`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModeMark {
    /// When (Unix ms).
    pub at_ms: i64,
    /// Open loop (else closed).
    pub open: bool,
    /// The record, in words.
    pub what: String,
}

/// AndroidAPS's running mode `OPEN_LOOP`.
pub const AAPS_OPEN: &str = "AndroidAPS's running mode OPEN_LOOP (\"OpenAPS Offline\")";
/// Loop's settings with closed loop off.
pub const LOOP_OPEN: &str =
    "Loop's settings with closed loop off (a Nightscout profile with loopSettings.dosingEnabled false)";
/// Loop's settings with closed loop on.
pub const LOOP_CLOSED: &str =
    "Loop's settings with closed loop on (a Nightscout profile with loopSettings.dosingEnabled true)";
/// Pump settings in Tidepool with automated delivery off (Loop's closed
/// loop off).
pub const TIDEPOOL_LOOP_OPEN: &str =
    "pump settings in Tidepool with automated delivery off (pumpSettings with automatedDelivery false, as Loop writes them)";
/// Pump settings in Tidepool with automated delivery on (Loop's closed
/// loop on).
pub const TIDEPOOL_LOOP_CLOSED: &str =
    "pump settings in Tidepool with automated delivery on (pumpSettings with automatedDelivery true, as Loop writes them)";
/// Trio's device status without `enacted`.
pub const TRIO_OPEN: &str =
    "Trio's device status with a suggestion and nothing enacted (Trio uploads enacted only with closed loop on)";
/// Trio's device status with `enacted`.
pub const TRIO_CLOSED: &str = "Trio's device status with an enacted dose (closed loop on)";

/// The mode a loop app's record says it runs in, from what each app
/// writes (read, not copied):
///
/// - AndroidAPS 3.4 and later, an "OpenAPS Offline" treatment (`RM` in
///   `core/data/.../model/RM.kt`, written by
///   `nsclient/extensions/RunningModeExtension.kt` and
///   `nsclientV3/extensions/RunningModeExtension.kt`): `mode` `OPEN_LOOP`,
///   `CLOSED_LOOP` or `CLOSED_LOOP_LGS` with `duration` 0 and
///   `originalDuration` its real length in ms (0: until the next mode). An
///   `OPEN_LOOP` with an `originalDuration` is temporary (AndroidAPS forces
///   it for a while when closing the loop is not allowed) and says nothing
///   of the mode after it; the other modes (suspended, disconnected,
///   disabled, superbolus) say nothing of open or closed.
/// - Loop, a Nightscout profile document with `loopSettings.dosingEnabled`
///   (LoopKit/NightscoutKit at 4ec9fd1, `LoopSettings.swift` and
///   `ProfileSet.swift`; LoopKit/NightscoutService at d839b66,
///   `StoredSettings.swift`): Loop uploads its settings, closed loop on or
///   off among them, each time they change. Its device status cannot
///   tell: with closed loop off Loop still computes and uploads
///   `automaticDoseRecommendation` and the `enacted` it would give
///   (NightscoutService's `StoredDosingDecision.swift`, `loopStatusEnacted`;
///   LoopKit/Loop at 710182e, `LoopDataManager.swift`, `loopInternal`).
/// - Loop (DIY Loop, Tidepool Loop) through its Tidepool service, a
///   Tidepool `pumpSettings` with `automatedDelivery`, Loop's closed loop
///   on or off (`dosingEnabled`; tidepool-org/TidepoolService at 0b9dbdb,
///   `TidepoolServiceKit/Extensions/StoredSettings.swift`), uploaded with
///   the settings each time they change.
/// - Trio, its device status (`device` `Trio`, `openaps`): it uploads
///   `enacted` only when closed loop is on
///   (nightscout/Trio at 29350e3, `NightscoutManager.swift`,
///   `enacted: settingsManager.settings.closedLoop ? ... : nil`).
///
/// `None` for anything else.
pub fn running_mode(item: &Value) -> Option<RunningMode> {
    let s = |k: &str| item.get(k).and_then(Value::as_str).unwrap_or("");
    if let Some(enabled) = item
        .get("loopSettings")
        .and_then(|l| l.get("dosingEnabled"))
        .and_then(Value::as_bool)
    {
        return Some(match enabled {
            false => RunningMode::Open(LOOP_OPEN),
            true => RunningMode::Closed(LOOP_CLOSED),
        });
    }
    if s("type") == "pumpSettings" {
        let automated = item.get("automatedDelivery").and_then(Value::as_bool)?;
        return Some(match automated {
            false => RunningMode::Open(TIDEPOOL_LOOP_OPEN),
            true => RunningMode::Closed(TIDEPOOL_LOOP_CLOSED),
        });
    }
    if names(&s("device").to_ascii_lowercase(), "trio") {
        let status = item.get("openaps").filter(|o| o.is_object())?;
        let has = |k: &str| status.get(k).is_some_and(Value::is_object);
        return match (has("enacted"), has("suggested")) {
            (true, _) => Some(RunningMode::Closed(TRIO_CLOSED)),
            (false, true) => Some(RunningMode::Open(TRIO_OPEN)),
            (false, false) => None,
        };
    }
    if s("eventType") != "OpenAPS Offline" {
        return None;
    }
    let permanent = item
        .get("originalDuration")
        .is_none_or(|d| d.is_null() || d.as_f64() == Some(0.0));
    match s("mode") {
        "OPEN_LOOP" if permanent => Some(RunningMode::Open(AAPS_OPEN)),
        "CLOSED_LOOP" => Some(RunningMode::Closed("AndroidAPS's running mode CLOSED_LOOP")),
        "CLOSED_LOOP_LGS" => Some(RunningMode::Closed(
            "AndroidAPS's running mode CLOSED_LOOP_LGS",
        )),
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
    /// type and automated boluses, in its JSON or its Excel export,
    /// CareLink's SmartGuard auto mode, see [`Evidence::from_carelink`]).
    /// Any other file adds nothing.
    /// A CareLink export's marks are undated here (its times need the
    /// person's zone): see [`Evidence::from_file_with`].
    pub fn from_file(bytes: &[u8]) -> Self {
        Self::from_file_with(bytes, &crate::ReadOptions::default())
    }

    /// Like [`Evidence::from_file`], a CareLink export's auto-mode marks
    /// dated as the reader places its rows with `opts` (the person's zone
    /// `opts.tz`, a date order when the file does not tell), see
    /// [`Evidence::from_carelink_with`].
    pub fn from_file_with(bytes: &[u8], opts: &crate::ReadOptions) -> Self {
        let mut e = Evidence::default();
        // A JSON array, one object, or mongoexport's one document a line;
        // Tidepool's Excel export as the data-model objects of its rows
        // (its `Delivery Type` automated, `Sub Type` automated, `Device
        // Model` ...), as its reader reads them.
        let items = if crate::read::tidepool_xlsx::is_zip(bytes) {
            match crate::read::tidepool_xlsx::read("", bytes) {
                Ok(book) => book
                    .rows
                    .into_iter()
                    .map(|r| Value::Object(r.obj))
                    .collect(),
                Err(_) => return e,
            }
        } else {
            match crate::read::json::parse_array("", bytes) {
                Ok(items) => items,
                Err(_) => return Self::from_carelink_with(bytes, opts),
            }
        };
        // A document deleted where it was written (`isValid: false`, as
        // AndroidAPS and API v3 mark them) is not read, nor is it evidence.
        let deleted = |item: &Value| item.get("isValid") == Some(&Value::Bool(false));
        for item in items.iter().filter(|i| !deleted(i)) {
            let delivered = |e: &Evidence| e.smb + e.automated_basal;
            let marks = |e: &Evidence| delivered(e) + e.systems.values().sum::<usize>();
            let before = (marks(&e), delivered(&e));
            e.count_item(item);
            let at = item_time_ms(item);
            let mode = running_mode(item);
            // A record of open loop names the app, but marks no loop.
            let open = matches!(mode, Some(RunningMode::Open(_)));
            if before.0 != marks(&e) && !open {
                match at {
                    Some(ms) => e.loop_marks_until_ms = e.loop_marks_until_ms.max(Some(ms)),
                    None => e.undated_loop_marks = true,
                }
            }
            if before.1 != delivered(&e) {
                e.automated_until_ms = e.automated_until_ms.max(at);
            }
            if let Some(mode) = mode {
                let (open, what) = match mode {
                    RunningMode::Open(w) => (true, w),
                    RunningMode::Closed(w) => (false, w),
                };
                match at {
                    Some(at_ms) => e.add_mode(ModeMark {
                        at_ms,
                        open,
                        what: what.to_string(),
                    }),
                    None => e.undated_modes = true,
                }
            }
        }
        e
    }

    /// Keeps `m` when it is the latest record of a mode (at the same
    /// instant, a closed one: the safe side).
    fn add_mode(&mut self, m: ModeMark) {
        let later = |held: &ModeMark| (m.at_ms, !m.open) > (held.at_ms, !held.open);
        if self.last_mode.as_ref().is_none_or(later) {
            self.last_mode = Some(m);
        }
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
                || (automatic && !temp_basal && gives_insulin(item))
                || (s("type") == "bolus" && s("subType") == "automated")
            {
                e.smb += 1;
            }
            // Loop writes a suspension as a Temp Basal with `reason`
            // "suspend" and `automatic` true unless the pump said otherwise
            // (NightscoutService's `DoseEntry.swift`, `automatic ?? true`);
            // Loop never suspends on its own, so it is no loop's basal.
            let suspension = s("reason") == "suspend";
            if (s("type") == "basal" && s("deliveryType") == "automated")
                || (automatic && temp_basal && !suspension)
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
                Some(RunningMode::Open(_)) => e.open_loop_modes += 1,
                Some(RunningMode::Closed(what)) => {
                    *e.systems.entry(what.to_string()).or_default() += 1
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
                } else if let Some(name) = DUAL_MODE_PUMPS.iter().find(|n| names(&text, n)) {
                    *e.dual_mode_pumps.entry((*name).to_string()).or_default() += 1;
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
    /// Its marks are undated (taken as current): see
    /// [`Evidence::from_carelink_with`].
    pub fn from_carelink(bytes: &[u8]) -> Self {
        Self::from_carelink_with(bytes, &crate::ReadOptions::default())
    }

    /// Like [`Evidence::from_carelink`], each mark dated by the CareLink
    /// reader with `opts` ([`crate::read::carelink_rows_read`]): a row of
    /// the pump at the instant its record gets (the pump's clock
    /// corrections and daylight-saving days placed as the records' are),
    /// a daily total of auto insulin at the end of its local day (the row
    /// carries a date and no time; auto mode may have run until then).
    /// The latest fills [`Evidence::loop_marks_until_ms`] (and, of the
    /// automatic doses, [`Evidence::automated_until_ms`]), so that marks
    /// all before a person's last [`LOOP_RECENT_DAYS`] are a past loop. A
    /// mark the reader could not date (no zone in `opts`, a date or time
    /// it could not read) leaves the marks undated: current, the safe
    /// side; its line is said ([`Evidence::undated_mark_lines`]).
    pub fn from_carelink_with(raw: &[u8], opts: &crate::ReadOptions) -> Self {
        let mut e = Evidence::default();
        let decoded = crate::read::table::utf16_to_utf8("", raw).ok().flatten();
        let bytes = crate::read::table::strip_bom(decoded.as_deref().unwrap_or(raw));
        let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
        if !carelink::looks_like(&head) {
            return e;
        }
        let a = carelink::auto_mode(bytes);
        e.date_carelink_marks(&a, raw, opts);
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

    /// Dates the marks `a` of the CareLink export `raw` (see
    /// [`Evidence::from_carelink_with`]).
    fn date_carelink_marks(
        &mut self,
        a: &carelink::AutoMode,
        raw: &[u8],
        opts: &crate::ReadOptions,
    ) {
        if a.marks.is_empty() {
            return;
        }
        let Some(tz) = opts.tz.as_ref() else {
            self.undated_loop_marks = true;
            return;
        };
        let rows = crate::read::carelink_rows_read("", raw, opts).unwrap_or_default();
        let mut dated: BTreeMap<u64, i64> = rows
            .closed_loop
            .iter()
            .map(|&(t, line)| (line, t.as_millisecond()))
            .collect();
        for &(day, line) in &rows.auto_insulin_days {
            // The last instant of the local day.
            let end = (day.tomorrow().ok())
                .and_then(|d| d.to_zoned(tz.clone()).ok())
                .map(|z| z.timestamp().as_millisecond() - 1);
            if let Some(ms) = end {
                dated.insert(line, ms);
            }
        }
        for &(line, automatic) in &a.marks {
            match dated.get(&line) {
                Some(&ms) => {
                    self.loop_marks_until_ms = self.loop_marks_until_ms.max(Some(ms));
                    if automatic {
                        self.automated_until_ms = self.automated_until_ms.max(Some(ms));
                    }
                }
                None => {
                    self.undated_loop_marks = true;
                    self.undated_marks += 1;
                    if self.undated_mark_lines.len() < UNDATED_LINES_KEPT {
                        self.undated_mark_lines.push(line);
                    }
                }
            }
        }
    }

    /// Adds a file's counts as a person's last [`LOOP_RECENT_DAYS`] of
    /// data starting at `recent_from_ms` ([`recent_from_ms`]; `None`: all
    /// of them) tell them: a file whose loop marks all end before them
    /// only as the past loop it shows (its clock stretches, its latest
    /// mode and the dual-mode pumps it names kept); a file whose automated deliveries all end before them,
    /// but whose other marks go on (a loop app kept in open loop), without
    /// those deliveries, named as a past loop.
    pub fn add_file_since(&mut self, other: &Evidence, recent_from_ms: Option<i64>) {
        let Some(from) = recent_from_ms else {
            return self.add_file(other);
        };
        if other.loop_marks_before(from) {
            self.past_loop_until_ms = self.past_loop_until_ms.max(other.loop_marks_until_ms);
            self.clocks.extend_from_slice(&other.clocks);
            self.add_modes(other);
            for (k, v) in &other.dual_mode_pumps {
                *self.dual_mode_pumps.entry(k.clone()).or_default() += v;
            }
            return;
        }
        let delivered_before =
            !other.undated_loop_marks && other.automated_until_ms.is_some_and(|u| u < from);
        if delivered_before {
            let mut rest = other.clone();
            rest.smb = 0;
            rest.automated_basal = 0;
            rest.past_loop_until_ms = rest.past_loop_until_ms.max(other.automated_until_ms);
            rest.automated_until_ms = None;
            return self.add_file(&rest);
        }
        self.add_file(other)
    }

    /// Takes `other`'s records of a loop app's mode.
    fn add_modes(&mut self, other: &Evidence) {
        self.undated_modes |= other.undated_modes;
        if let Some(m) = &other.last_mode {
            self.add_mode(m.clone());
        }
    }

    /// Adds another file's counts (records' counts are taken whole).
    pub fn add_file(&mut self, other: &Evidence) {
        self.smb += other.smb;
        self.automated_basal += other.automated_basal;
        self.open_loop_modes += other.open_loop_modes;
        self.add_modes(other);
        self.automated_until_ms = self.automated_until_ms.max(other.automated_until_ms);
        for (k, v) in &other.systems {
            *self.systems.entry(k.clone()).or_default() += v;
        }
        for (k, v) in &other.dual_mode_pumps {
            *self.dual_mode_pumps.entry(k.clone()).or_default() += v;
        }
        self.loop_marks_until_ms = self.loop_marks_until_ms.max(other.loop_marks_until_ms);
        self.undated_loop_marks |= other.undated_loop_marks;
        self.undated_marks += other.undated_marks;
        let room = UNDATED_LINES_KEPT.saturating_sub(self.undated_mark_lines.len());
        (self.undated_mark_lines).extend(other.undated_mark_lines.iter().take(room));
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

    /// True when the latest record of a loop app's mode says open loop
    /// ([`Evidence::last_mode`]; without dated ones, when an open mode and
    /// no closed one was recorded).
    pub fn latest_mode_open(&self) -> bool {
        match (&self.last_mode, self.undated_modes) {
            (Some(m), false) => m.open,
            _ => self.open_loop_modes > 0 && !self.systems.keys().any(|k| closed_mode(k)),
        }
    }

    /// True when the loop marks are only a loop app's name and device
    /// status and its records of closed modes older than its latest mode
    /// (no SMB, automated basal or short temporary basals in most hours)
    /// and that latest mode is open loop ([`Evidence::latest_mode_open`]):
    /// the app suggests, the person decides, open-loop pump therapy.
    pub fn app_in_open_loop(&self) -> bool {
        self.latest_mode_open()
            && self.short_temp_share() < LOOP_HOUR_SHARE
            && self.smb == 0
            && self.automated_basal == 0
            && self.systems.keys().all(|k| app_mark(k) || closed_mode(k))
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
        let apps_only =
            !self.systems.is_empty() && self.systems.keys().all(|k| app_mark(k) || closed_mode(k));
        let latest = self.last_mode.as_ref().filter(|_| !self.undated_modes);
        let latest_words = |m: &ModeMark| format!("{} at {}", m.what, instant(m.at_ms));
        if self.app_in_open_loop() {
            let what = latest.map_or_else(|| AAPS_OPEN.to_string(), latest_words);
            // A past file's records are not counted, its latest mode is.
            let count = match self.open_loop_modes {
                0 => String::new(),
                1 => "1 record of open loop; ".to_string(),
                n => format!("{n} records of open loop; "),
            };
            out.push(format!(
                "a loop app in open loop ({count}the latest record of its mode: {what}) and no automated delivery: it suggests and the person decides, open-loop pump therapy"
            ));
        } else if self.latest_mode_open() {
            let latest = latest.map_or_else(|| AAPS_OPEN.to_string(), latest_words);
            let until = self
                .automated_until_ms
                .map_or_else(String::new, |ms| format!(" (the last at {})", instant(ms)));
            out.push(format!(
                "the loop app's latest mode is open loop ({latest}), but the marks above show the loop closed within the last {LOOP_RECENT_DAYS} days of the data{until}: taken as a closed loop until {LOOP_RECENT_DAYS} days of data pass without automated delivery"
            ));
        } else if let Some(m) = latest.filter(|m| !m.open && apps_only) {
            out.push(format!(
                "the loop app's latest mode is closed loop ({})",
                latest_words(m)
            ));
        } else if self.open_loop_modes > 0 {
            out.push(format!(
                "{} records of a loop app in open loop, but a closed mode was recorded too and they cannot be ordered: taken as a closed loop",
                self.open_loop_modes
            ));
        } else if apps_only
            && self.smb == 0
            && self.automated_basal == 0
            && self.short_temp_share() < LOOP_HOUR_SHARE
        {
            out.push(
                "a loop app (AndroidAPS, OpenAPS, Loop or Trio) is named, with no record of its running mode (AndroidAPS 3.4 and later write it as \"OpenAPS Offline\" with mode OPEN_LOOP or CLOSED_LOOP, Loop as its Nightscout profile's loopSettings.dosingEnabled, Trio in its device status): taken as a closed loop, the safe side".into(),
            );
        }
        if !self.dual_mode_pumps.is_empty() && self.delivery() != Delivery::ClosedLoop {
            let named: Vec<String> = (self.dual_mode_pumps.iter())
                .map(|(k, v)| format!("{k} ({v})"))
                .collect();
            out.push(format!(
                "records naming a pump that runs in a manual or an automated mode: {}; no automated delivery counted: taken as its manual mode",
                named.join(", ")
            ));
        }
        if let Some(lines) = lines_in_words(&self.undated_mark_lines, self.undated_marks) {
            out.push(format!(
                "SmartGuard auto-mode rows of a CareLink export without a date and time abba could read ({lines}): taken as current, a closed loop now (the safe side)"
            ));
        }
        if let Some(ms) = self.past_loop_until_ms {
            out.push(format!(
                "a loop's automated deliveries or marks until {}, before the last {LOOP_RECENT_DAYS} days of the data: a past loop, not counted",
                instant(ms)
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

/// `lines` (the first of `count`) in words, `None` without any.
fn lines_in_words(first: &[u64], count: usize) -> Option<String> {
    let (&one, more) = first.split_first()?;
    let mut text = match more.is_empty() {
        true => format!("line {one}"),
        false => format!(
            "lines {}",
            first
                .iter()
                .map(u64::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    if count > first.len() {
        text.push_str(&format!(" and {} more", count - first.len()));
    }
    Some(text)
}

/// An instant (Unix ms) in words (UTC).
fn instant(ms: i64) -> String {
    jiff::Timestamp::from_millisecond(ms).map_or_else(|_| ms.to_string(), |t| t.to_string())
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
    // Loop writes a profile's `mills` as a string, beside its `startDate`.
    if let Some(ms) = item
        .get("mills")
        .and_then(Value::as_str)
        .and_then(|m| m.parse::<i64>().ok())
        .filter(|ms| *ms > 0)
    {
        return Some(ms);
    }
    [
        "startDate",
        "created_at",
        "dateString",
        "timestamp",
        "time",
        "date",
    ]
    .iter()
    .filter_map(|k| item.get(*k).and_then(Value::as_str))
    .find_map(|t| t.parse::<jiff::Timestamp>().ok())
    .map(jiff::Timestamp::as_millisecond)
}

/// True when a key of [`Evidence::systems`] only names a loop app that
/// records its mode ([`running_mode`]) or counts its device status: what
/// the app writes in open loop too. AndroidAPS (its treatments'
/// `enteredBy` `openaps://AndroidAPS`, its running modes' `openaps://AAPS`,
/// `app` `AAPS`, its device's `openaps://<phone>`, its device status
/// `openaps` with `suggested` and, when the person accepted one,
/// `enacted`); Loop (`enteredBy` and `device` `loop://<phone>`, its profile's
/// `Loop`, its device status `loop`); Trio (`enteredBy` and `device`
/// `Trio`, its device status `openaps`).
fn app_mark(key: &str) -> bool {
    ["androidaps", "aaps", "openaps", "loop", "trio"].contains(&key)
        || key == format!("{DEVICE_STATUS_MARK}openaps")
        || key == format!("{DEVICE_STATUS_MARK}loop")
}

/// True when a key of [`Evidence::systems`] counts a loop app's records
/// of a closed mode ([`running_mode`]).
fn closed_mode(key: &str) -> bool {
    key.starts_with("AndroidAPS's running mode ")
        || [LOOP_CLOSED, TIDEPOOL_LOOP_CLOSED, TRIO_CLOSED].contains(&key)
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

/// Whether a Nightscout treatment carries a dose: `insulin` a number above
/// 0. Nightscout's v1 API serves `insulin` on every treatment, `null` when
/// the uploader wrote none (cgm-remote-monitor's `lib/server/treatments.js`),
/// so the key alone says nothing.
fn gives_insulin(item: &Value) -> bool {
    item.get("insulin")
        .and_then(Value::as_f64)
        .is_some_and(|u| u > 0.0)
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

    /// A Tidepool export of an Omnipod 5 in Automated Mode until
    /// 2026-10-05, then in Manual Mode (its basal `scheduled` and `temp`),
    /// in Tidepool's data model (`type`, `deliveryType`, `time`, `duration`
    /// in ms, the upload record's `deviceModel`).
    fn omnipod5(automated_until: &str) -> Evidence {
        let doc = format!(
            r#"[{{"type":"upload","time":"2026-11-18T20:00:00.000Z","deviceManufacturers":["Insulet"],"deviceModel":"Omnipod 5","deviceTags":["insulin-pump"]}},
                {{"type":"basal","deliveryType":"automated","time":"2026-10-01T10:00:00.000Z","duration":300000,"rate":0.6}},
                {{"type":"basal","deliveryType":"automated","time":"{automated_until}","duration":300000,"rate":0.45}},
                {{"type":"basal","deliveryType":"scheduled","time":"2026-11-10T00:00:00.000Z","duration":86400000,"rate":0.8}},
                {{"type":"basal","deliveryType":"temp","time":"2026-11-12T15:00:00.000Z","duration":3600000,"rate":0.4,"percent":0.5}}]"#
        );
        Evidence::from_file(doc.as_bytes())
    }

    #[test]
    fn a_dual_mode_pump_tells_its_mode_by_its_automated_deliveries_not_its_name() {
        let ms = |t: &str| t.parse::<jiff::Timestamp>().unwrap().as_millisecond();
        // The last 28 days of the data (ending 2026-11-18 20:00).
        let from = Some(ms("2026-11-18T20:00:00Z") - LOOP_RECENT_DAYS * 86_400_000);
        let pump = Evidence {
            pump_hours: 24,
            pump_basal: 2,
            ..Evidence::default()
        };
        // Automated Mode ended 2026-10-05: before them, a past loop.
        let file = omnipod5("2026-10-05T09:55:00.000Z");
        assert_eq!(file.automated_basal, 2);
        assert_eq!(file.dual_mode_pumps.get("omnipod 5"), Some(&1));
        assert!(file.systems.is_empty(), "{file:?}");
        let mut e = pump.clone();
        e.add_file_since(&file, from);
        assert_eq!((e.automated_basal, e.delivery()), (0, Delivery::OpenLoop));
        let words = e.words().join("; ");
        assert!(
            words.contains("automated deliveries or marks until 2026-10-05T09:55:00Z")
                && words.contains("omnipod 5 (1)")
                && words.contains("taken as its manual mode"),
            "{words}"
        );
        // Automated Mode until 2026-11-05: within them, held.
        let mut e = pump.clone();
        e.add_file_since(&omnipod5("2026-11-05T09:55:00.000Z"), from);
        assert_eq!((e.automated_basal, e.delivery()), (2, Delivery::ClosedLoop));
        assert!(!e.words().join("; ").contains("manual mode"));
        // Without the person's data to tell the last days: all counted.
        let mut e = pump;
        e.add_file_since(&omnipod5("2026-10-05T09:55:00.000Z"), None);
        assert_eq!(e.delivery(), Delivery::ClosedLoop);
    }
}
