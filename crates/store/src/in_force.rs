//! What is in force besides the advisor's own suggestions, and what the
//! data say about the person's therapy (all derived from the log, so a
//! replay gives the same every time):
//!
//! - **therapy changes**: the pump's settings profiles (when the person's
//!   therapy follows the profile) and the clinician's changes recorded with
//!   `abba therapy set`, each in force from its time;
//! - **the first week**: day 1 is the first local day with glucose; the
//!   first week ends with the 7th day that has at least 70 % of the
//!   expected CGM readings (SMBG mode: 3 meter readings) and pump data;
//! - **delivery**: open loop, closed loop or injections, with the evidence
//!   ([`abba_io::automation`]); with a loop or injections no basal rate is
//!   suggested unless the person allows it for research
//!   (`--allow-closed-loop`).

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use crate::log;
use crate::person::{Person, TherapySource};
use abba_advisor::Mode;
use abba_core::limits::{BASAL_U_PER_H, CARB_RATIO_G_PER_U, FUTURE_SKEW_MINUTES};
use abba_core::{Event, EventKind, Timestamp};
use abba_io::automation::{Delivery, Evidence};
use abba_io::clock::AdvisorClock;
use abba_io::events::EventStream;
use abba_io::therapy::PumpTherapy;
use abba_io::Record;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Share of the expected CGM readings a qualifying day needs.
pub const CGM_DAY_SHARE: f64 = 0.7;
/// CGM readings expected in a day of a 5-minute sensor (Dexcom, Libre 3,
/// Guardian); see [`cgm_period_min`] for the others.
pub const CGM_PER_DAY: usize = 288;
/// The longest sensor period abba accepts as a CGM's (FreeStyle Libre 1
/// and 2 keep one historic reading every 15 minutes).
pub const CGM_PERIOD_MAX_MIN: i64 = 15;

/// The CGM's own period in minutes: the median interval between
/// consecutive CGM readings of the log (1 to [`CGM_PERIOD_MAX_MIN`]; 5
/// without two readings). A FreeStyle Libre 1 or 2 export (96 historic
/// readings a day) is judged against its 96, not a Dexcom's 288; sensor
/// gaps do not move the median.
pub fn cgm_period_min(events: &[Event]) -> i64 {
    let mut last = None;
    let mut gaps = Vec::new();
    for e in events {
        if let EventKind::Cgm(_) = e.kind {
            if let Some(prev) = last {
                let gap = e.at.0 - prev;
                if gap > 0 {
                    gaps.push(gap);
                }
            }
            last = Some(e.at.0);
        }
    }
    if gaps.is_empty() {
        return 5;
    }
    let mid = gaps.len() / 2;
    let (_, median, _) = gaps.select_nth_unstable(mid);
    (*median).clamp(1, CGM_PERIOD_MAX_MIN)
}
/// Meter readings a qualifying SMBG day needs (70 % of the four a day).
pub const SMBG_PER_DAY: usize = 3;

/// Who made a change of therapy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ChangeSource {
    /// A settings profile of the pump's export (a profile or a switch).
    Profile,
    /// The clinician (`abba therapy set`).
    Clinician,
}

/// A change of therapy in force from `at`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TherapyChange {
    /// From when (advisor time; before day 1: minute 0).
    pub at: Timestamp,
    /// The instant (UTC, RFC 3339).
    pub instant: String,
    /// The basal schedule (one segment: a flat rate); none: unchanged.
    pub basal: Option<Vec<(u32, f64)>>,
    /// Carb ratios of breakfast, lunch, dinner; none: unchanged.
    pub carb_ratio: Option<[f64; 3]>,
    /// Who.
    pub source: ChangeSource,
    /// Where it was read, or who recorded it.
    pub origin: String,
}

/// The first week counted from the data.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct FirstWeek {
    /// Qualifying days (day indices from day 1 = 0), oldest first.
    pub qualifying: Vec<i64>,
    /// Days that did not qualify, with why.
    pub missing: Vec<(i64, String)>,
    /// The day whose close ends the first week (`i64::MAX`: not yet).
    pub end: i64,
    /// The CGM's period the days were judged by ([`cgm_period_min`]; 0
    /// where no CGM data were judged).
    pub cgm_period_min: i64,
}

/// Everything derived from the log for one replay.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Extras {
    /// Therapy changes, oldest first.
    pub changes: Vec<TherapyChange>,
    /// An app-fed person (see [`app_extras`]): only the clinician's
    /// changes apply; the first week, the delivery and the basal hold are
    /// the app's (as without extras).
    pub fed_by_app: bool,
    /// The first week.
    pub first_week: FirstWeek,
    /// The delivery evidence.
    pub evidence: Evidence,
    /// True when basal updates are not offered (loop or injections, not allowed).
    pub hold_basal: bool,
    /// An import-fed person: the advisor's time at which each import left
    /// the log ([`import_ends`]), oldest first. Empty: every suggestion
    /// counts as shown (an app-fed person sees each as it is made).
    pub shown_until: Vec<Timestamp>,
}

/// How long after its decision a suggestion counts as shown when an
/// import ends there (minutes): the day until the same setting's next
/// daily update.
pub const SHOWN_WITHIN_MIN: i64 = 1440;

impl Extras {
    /// Whether the person could see a suggestion decided at `at` before
    /// the next update of its setting: an import left the log within a day
    /// after it (the advice of that import showed it). A suggestion made
    /// and followed by the next one within one import (the history a
    /// first import or sync brings) was never shown: it is not taken as
    /// followed, and the value in force stays what the pump had.
    pub fn shown(&self, at: Timestamp) -> bool {
        if self.fed_by_app || self.shown_until.is_empty() {
            return true;
        }
        let first = self.shown_until.partition_point(|b| b.0 < at.0);
        self.shown_until
            .get(first)
            .is_some_and(|b| b.0 < at.0 + SHOWN_WITHIN_MIN)
    }

    /// What the data show.
    pub fn delivery(&self) -> Delivery {
        self.evidence.delivery()
    }

    /// A hash of what a snapshot ending at `last` depends on besides its
    /// events: the changes up to `last`, the basal hold, the first week's end.
    pub fn hash_until(&self, last: Option<Timestamp>) -> String {
        let upto: Vec<&TherapyChange> = self
            .changes
            .iter()
            .filter(|c| last.is_some_and(|l| c.at <= l))
            .collect();
        // The import ends that decide whether a suggestion up to `last`
        // was shown.
        let ends: Vec<i64> = self
            .shown_until
            .iter()
            .filter(|b| last.is_some_and(|l| b.0 < l.0 + SHOWN_WITHIN_MIN))
            .map(|b| b.0)
            .collect();
        let json = serde_json::to_vec(&(
            upto,
            self.hold_basal,
            self.first_week.end,
            self.first_week.cgm_period_min,
            ends,
        ))
        .unwrap_or_default();
        format!("{:016x}", abba_io::record::content_hash([json.as_slice()]))
    }
}

fn pump_event(k: &EventKind) -> bool {
    matches!(
        k,
        EventKind::Bolus(_)
            | EventKind::BasalRate(_)
            | EventKind::TempBasal { .. }
            | EventKind::Suspend
            | EventKind::Resume
            | EventKind::ExtendedBolus { .. }
    )
}

/// Counts the qualifying days of `events` (see the module documentation).
pub fn first_week(mode: Mode, init_days: u32, events: &[Event]) -> FirstWeek {
    let mut per_day: BTreeMap<i64, (usize, usize, usize)> = BTreeMap::new();
    for e in events {
        let d = per_day.entry(e.at.day_index()).or_default();
        match e.kind {
            EventKind::Cgm(_) => d.0 += 1,
            EventKind::Smbg(_) => d.1 += 1,
            ref k if pump_event(k) => d.2 += 1,
            _ => {}
        }
    }
    let (Some(&first), Some(&last)) = (per_day.keys().next(), per_day.keys().next_back()) else {
        return FirstWeek {
            end: i64::MAX,
            ..FirstWeek::default()
        };
    };
    // The last day is still open unless a later event closed it.
    let closed_until = events
        .iter()
        .rev()
        .find(|e| e.kind == EventKind::DayClosed)
        .map_or(first - 1, |e| abba_advisor::guard::closed_day(e.at));
    let mut w = FirstWeek {
        end: i64::MAX,
        ..FirstWeek::default()
    };
    let period = cgm_period_min(events);
    w.cgm_period_min = period;
    let cgm_per_day = (abba_core::MINUTES_PER_DAY / period) as usize;
    let need_cgm = (CGM_DAY_SHARE * cgm_per_day as f64).ceil() as usize;
    for day in first..=last.max(closed_until) {
        if w.qualifying.len() as u32 >= init_days {
            break;
        }
        let (cgm, smbg, pump) = per_day.get(&day).copied().unwrap_or_default();
        let why = abba_advisor::words::first_week_day_gaps(
            (mode == Mode::Cgm && cgm < need_cgm).then_some((cgm, cgm_per_day)),
            (mode == Mode::Smbg && smbg < SMBG_PER_DAY).then_some((smbg, SMBG_PER_DAY)),
            pump,
        );
        if day > closed_until {
            // Today: not over yet.
            if !why.is_empty() {
                w.missing
                    .push((day, abba_advisor::words::first_week_day(&why, true)));
            }
            continue;
        }
        if why.is_empty() {
            w.qualifying.push(day);
            if w.qualifying.len() as u32 == init_days {
                w.end = day;
            }
        } else {
            w.missing
                .push((day, abba_advisor::words::first_week_day(&why, false)));
        }
    }
    w
}

/// The clinician's recorded changes of a person.
pub fn clinician_changes(conn: &dyn Db, person: i64) -> Result<Vec<TherapyChange>, StoreError> {
    let mut out = Vec::new();
    for r in conn.rows(Q::TherapyChangesOf, args![person])? {
        out.push(
            serde_json::from_str(&r.text(0)?)
                .map_err(|e| StoreError::corrupt("therapy change", e))?,
        );
    }
    Ok(out)
}

/// Records a clinician's change (inside the caller's transaction) and
/// bumps the person's revision, so a live advisor kept elsewhere (the
/// service) is rebuilt with it.
pub fn insert_change(
    conn: &dyn Db,
    person: i64,
    at: jiff::Timestamp,
    change: &TherapyChange,
) -> Result<(), StoreError> {
    let json =
        serde_json::to_string(change).map_err(|e| StoreError::corrupt("therapy change", e))?;
    conn.execute(
        Q::TherapyChangePut,
        args![
            person,
            at.as_millisecond(),
            json,
            jiff::Timestamp::now().to_string()
        ],
    )?;
    conn.execute(Q::PersonRevBump, args![person])?;
    Ok(())
}

/// What applies to an app-fed person's replay: the clinician's changes,
/// each in force from its time (none recorded: no extras, the replay is
/// the events as posted).
pub fn app_extras(conn: &dyn Db, person: &Person) -> Result<Option<Extras>, StoreError> {
    let changes = clinician_changes(conn, person.id)?;
    if changes.is_empty() {
        return Ok(None);
    }
    Ok(Some(Extras {
        changes,
        fed_by_app: true,
        first_week: FirstWeek {
            end: i64::MAX,
            ..FirstWeek::default()
        },
        evidence: Evidence::default(),
        hold_basal: false,
        shown_until: Vec::new(),
    }))
}

impl Extras {
    /// The latest change put in force after `last` (the last event fed):
    /// a replay puts it in force at the end, so an event earlier than it
    /// needs a rebuild (the replay would place the change after that event).
    pub fn applied_after(&self, last: Option<Timestamp>) -> Option<Timestamp> {
        self.changes
            .iter()
            .map(|c| c.at)
            .filter(|&at| last.is_none_or(|l| at > l))
            .max()
    }
}

/// Checks a new therapy value against the plausibility limits and the
/// clinician's bounds, naming the field.
pub fn check_change(
    person: &Person,
    basal: Option<&[(u32, f64)]>,
    carb_ratio: Option<[f64; 3]>,
) -> Result<(), StoreError> {
    if let Some(b) = basal {
        for &(m, r) in b {
            BASAL_U_PER_H.check(r).map_err(|e| {
                StoreError::invalid(
                    format!("--basal (from {:02}:{:02})", m / 60, m % 60),
                    e.to_string(),
                )
            })?;
        }
        abba_advisor::steps::validate_segments(b)?;
        let mean = abba_advisor::steps::mean_rate(b);
        if let Some(r) = person.settings.bounds.basal.filter(|r| !r.contains(mean)) {
            return Err(StoreError::invalid(
                "--basal",
                format!("{mean:.3} U/h is outside the clinician's bounds {}-{} U/h (change the bounds first)", r.min, r.max),
            ));
        }
    }
    if let Some(cr) = carb_ratio {
        for (i, v) in cr.into_iter().enumerate() {
            let slot = ["breakfast", "lunch", "dinner"][i];
            CARB_RATIO_G_PER_U.check(v).map_err(|e| {
                StoreError::invalid(format!("--carb-ratio ({slot})"), e.to_string())
            })?;
            if let Some(r) = person.settings.bounds.carb_ratio[i].filter(|r| !r.contains(v)) {
                return Err(StoreError::invalid(
                    format!("--carb-ratio ({slot})"),
                    format!(
                        "{v} g/U is outside the clinician's bounds {}-{} g/U",
                        r.min, r.max
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Refuses an instant later than now plus the clock skew.
pub fn not_future(at: jiff::Timestamp, field: &str) -> Result<(), StoreError> {
    let limit = jiff::Timestamp::now()
        .checked_add(jiff::SignedDuration::from_mins(FUTURE_SKEW_MINUTES))
        .unwrap_or(jiff::Timestamp::MAX);
    if at > limit {
        return Err(StoreError::invalid(
            field,
            format!("{at} is in the future (more than {FUTURE_SKEW_MINUTES} min after now); a change is recorded when it is made"),
        ));
    }
    Ok(())
}

/// The settings profiles of the log that become therapy in force (when the
/// person's therapy follows the pump's profile): each one that differs from
/// the one before it. A temporary profile (an AndroidAPS Profile Switch
/// with a duration, [`abba_io::record::Profile::temporary_min`]) is in
/// force from its instant until its end or the next profile, whichever is
/// first; at its end the latest permanent profile before it (else the
/// person's starting settings) is in force again, as AndroidAPS runs it.
/// That end may lie after the data: a temporary profile running at the end
/// of the data is not the person's settings, so the return is in force
/// from then on (the replay puts a change after the last event in force
/// now).
pub fn profile_changes(
    person: &Person,
    records: &[Record],
) -> Result<Vec<TherapyChange>, StoreError> {
    if person.settings.therapy_source != TherapySource::Profile {
        return Ok(Vec::new());
    }
    let Some(clock) = person
        .first_day
        .map(|d| AdvisorClock::new(person.tz.clone(), d))
    else {
        return Ok(Vec::new());
    };
    let meals = &person.settings.meal_windows;
    let mut out: Vec<TherapyChange> = Vec::new();
    let mut prev: (Vec<(u32, f64)>, [f64; 3]) = (
        person
            .settings
            .basal_schedule
            .clone()
            .unwrap_or_else(|| vec![(0, person.settings.start.basal.0)]),
        person.settings.start.carb_ratio.map(|c| c.0),
    );
    // The latest permanent profile (and its instant) and the end of the
    // temporary one in force, if any.
    let mut base: (Vec<(u32, f64)>, [f64; 3], Option<jiff::Timestamp>) =
        (prev.0.clone(), prev.1, None);
    let mut temporary: Option<(jiff::Timestamp, jiff::Timestamp)> = None;
    let push = |out: &mut Vec<TherapyChange>,
                prev: &mut (Vec<(u32, f64)>, [f64; 3]),
                at: jiff::Timestamp,
                basal: &[(u32, f64)],
                carb_ratio: [f64; 3],
                origin: String| {
        let ts = clock.timestamp(at);
        *prev = (basal.to_vec(), carb_ratio);
        out.push(TherapyChange {
            at: if ts.day_index() < 0 { Timestamp(0) } else { ts },
            instant: at.to_string(),
            basal: Some(basal.to_vec()),
            carb_ratio: Some(carb_ratio),
            source: ChangeSource::Profile,
            origin,
        });
    };
    let back =
        |base: &(Vec<(u32, f64)>, [f64; 3], Option<jiff::Timestamp>),
         start: jiff::Timestamp,
         end: jiff::Timestamp| {
            format!(
            "the pump's profile {} again at the end of the temporary profile of {start} ({end})",
            base.2
                .map_or("before it (the starting settings)".to_string(), |t| format!("of {t}"))
        )
        };
    for r in records {
        let abba_io::RecordKind::Schedule { profile } = &r.kind else {
            continue;
        };
        if profile.carb_ratio.is_empty() {
            continue;
        }
        // A temporary profile that ended before this one: the permanent
        // one is back at its end.
        if let Some((start, end)) = temporary.filter(|t| t.1 <= r.at) {
            if !(prev.0 == base.0 && prev.1 == base.1) {
                let (b, c) = (base.0.clone(), base.1);
                push(&mut out, &mut prev, end, &b, c, back(&base, start, end));
            }
        }
        let t =
            PumpTherapy::from_profile(profile, meals, format!("{:?} {:?}", r.source, r.id), r.at)?;
        temporary = profile.temporary_min.map(|m| {
            let end =
                r.at.checked_add(jiff::SignedDuration::from_mins(i64::from(m)))
                    .unwrap_or(jiff::Timestamp::MAX);
            (r.at, end)
        });
        if temporary.is_none() {
            base = (t.basal.clone(), t.carb_ratio, Some(r.at));
        }
        if t.same_settings(&prev.0, prev.1) {
            continue;
        }
        push(
            &mut out,
            &mut prev,
            r.at,
            &t.basal,
            t.carb_ratio,
            // When: the change's own instant, shown beside it.
            "the pump's profile".to_string(),
        );
    }
    if let Some((start, end)) = temporary {
        if !(prev.0 == base.0 && prev.1 == base.1) && end < jiff::Timestamp::MAX {
            let (b, c) = (base.0.clone(), base.1);
            push(&mut out, &mut prev, end, &b, c, back(&base, start, end));
        }
    }
    Ok(out)
}

/// File evidence of loops stored at import: each file's as the last
/// [`abba_io::automation::LOOP_RECENT_DAYS`] of the data, from
/// `recent_from_ms`, tell it ([`Evidence::add_file_since`]: a loop that
/// ended before them is named as past).
pub fn file_evidence(
    conn: &dyn Db,
    person: i64,
    recent_from_ms: Option<i64>,
) -> Result<Evidence, StoreError> {
    let mut e = Evidence::default();
    for r in conn.rows(Q::FileEvidenceOf, args![person])? {
        let x: Evidence = serde_json::from_str(&r.text(0)?)
            .map_err(|e| StoreError::corrupt("file evidence", e))?;
        e.add_file_since(&x, recent_from_ms);
    }
    Ok(e)
}

/// Stores what an import's file says about loops and the device's
/// clock (one row per file content): `e`, its [`Evidence::from_file`]
/// with the reader's [`abba_io::clocks::ClockStretch`]es; a file with
/// neither loop evidence nor a stretch away from the person's zone `tz`
/// stores nothing.
pub fn store_file_evidence(
    conn: &dyn Db,
    person: i64,
    tz: &jiff::tz::TimeZone,
    file: &str,
    bytes: &[u8],
    e: &Evidence,
) -> Result<(), StoreError> {
    let away = !abba_io::clocks::away(&e.clocks, tz).is_empty();
    if e.smb == 0
        && e.automated_basal == 0
        && e.systems.is_empty()
        && e.dual_mode_pumps.is_empty()
        && e.open_loop_modes == 0
        && !away
    {
        return Ok(());
    }
    let hash = format!("{:016x}", abba_io::record::content_hash([bytes]));
    let json = serde_json::to_string(e).map_err(|e| StoreError::corrupt("file evidence", e))?;
    conn.execute(Q::FileEvidencePut, args![person, hash, file, json])?;
    Ok(())
}

/// What the records alone say (cached with the events).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecordFacts {
    /// Profile changes in force.
    pub profile_changes: Vec<TherapyChange>,
    /// Delivery evidence from the records.
    pub evidence: Evidence,
    /// The first week.
    pub first_week: FirstWeek,
    /// Where each import left the log (see [`Extras::shown_until`]).
    pub shown_until: Vec<Timestamp>,
    /// The start (Unix ms) of the last
    /// [`abba_io::automation::LOOP_RECENT_DAYS`] of the records, whose
    /// evidence tells the delivery.
    pub recent_from_ms: Option<i64>,
}

/// The advisor's time at which each import left the person's log: the
/// latest instant any import up to it brought, in import order (`imports`:
/// each import's latest instant, ms, as [`log::records_and_imports`] reads
/// them), on the person's clock. A suggestion is shown to the person
/// only at these times (see [`Extras::shown`]).
pub fn import_ends(person: &Person, imports: &[(i64, i64)]) -> Vec<Timestamp> {
    let Some(day1) = person.first_day else {
        return Vec::new();
    };
    let clock = AdvisorClock::new(person.tz.clone(), day1);
    let mut out: Vec<Timestamp> = Vec::with_capacity(imports.len());
    let mut latest = i64::MIN;
    for &(_, ms) in imports {
        if ms <= latest {
            continue; // an import of older data leaves the log where it was
        }
        let Ok(at) = jiff::Timestamp::from_millisecond(ms) else {
            continue;
        };
        let at = clock.timestamp(at);
        if at.day_index() < 0 {
            // An import of records before day 1 only (stored, not used):
            // it showed no advice, and leaves the log where it was.
            continue;
        }
        latest = ms;
        out.push(at);
    }
    out
}

/// The facts of an import-fed person's records and their events: the
/// records are taken, those before day 1 left out and one source chosen
/// for each kind of data and day ([`crate::day_1::used`]: the profiles, the
/// delivery's evidence and the events all read the records used), made into the events
/// ([`log::events_of`]) and dropped, so that a long log is never held
/// twice. `imports` (where each import left the log) reads every record:
/// it is the history of the imports, not of the person's days.
pub fn record_facts(
    person: &Person,
    records: Vec<Record>,
    imports: &[(i64, i64)],
) -> Result<(EventStream, RecordFacts), StoreError> {
    let chosen = crate::day_1::used(person, records);
    let records = &chosen.records;
    let profile_changes = profile_changes(person, records)?;
    // The delivery is told by the last days of the data: a loop, or
    // injections, given up before them do not hold the advice for good.
    let recent_from_ms = abba_io::automation::recent_from_ms(records);
    let evidence =
        Evidence::from_records_since(records, &person.tz, recent_from_ms.unwrap_or(i64::MAX));
    let stream = log::events_of(person, chosen)?;
    let first_week = first_week(
        person.mode(),
        person.settings.advisor.init_days,
        &stream.events,
    );
    Ok((
        stream,
        RecordFacts {
            profile_changes,
            evidence,
            first_week,
            shown_until: import_ends(person, imports),
            recent_from_ms,
        },
    ))
}

/// Everything [`Extras`] holds for an import-fed person: the records'
/// facts with the clinician's changes and the files' evidence.
pub fn extras(conn: &dyn Db, person: &Person, facts: &RecordFacts) -> Result<Extras, StoreError> {
    let mut changes = facts.profile_changes.clone();
    changes.extend(clinician_changes(conn, person.id)?);
    changes.sort_by_key(|c| c.at);
    let mut evidence = facts.evidence.clone();
    evidence.add_file(&file_evidence(conn, person.id, facts.recent_from_ms)?);
    let hold_basal =
        evidence.delivery() != Delivery::OpenLoop && !person.settings.allow_closed_loop;
    Ok(Extras {
        changes,
        fed_by_app: false,
        first_week: facts.first_week.clone(),
        evidence,
        hold_basal,
        shown_until: facts.shown_until.clone(),
    })
}
