//! Records + a person's settings → the advisor's events. Every caller (the
//! CLI, the person store, the service) goes through [`to_events`].
//!
//! Pump records map to the pump kinds of abba-core: a temporary basal to
//! `TempBasal` (absolute or percent, with its duration; 0 cancels), a
//! suspension to `Suspend` (and `Resume` when it ends, by a resume record
//! or its duration), an extended bolus to `ExtendedBolus` (total and
//! immediate part). The scheduled rate is followed through profiles and
//! their time-of-day segments: `BasalRate` is emitted at every new profile
//! and at every change of the scheduled rate (the first rate in force is
//! the person's starting setting and emits nothing).

use std::collections::BTreeMap;

use abba_core::{
    Event, EventKind, Grams, MealSlot, MgDl, TempBasalRate, Timestamp, Units, UnitsPerHour,
};
use jiff::civil::Date;
use jiff::tz::TimeZone;
use serde::Serialize;

use crate::clock::AdvisorClock;
use crate::meals::MealWindows;
use crate::read::Batch;
use crate::record::{BasalSchedule, Censor, OriginAt, Record, RecordKind, TempRate};

/// Longest extended bolus the advisor accepts (its `EventLimits` default).
pub const EXTENDED_BOLUS_MAX_MIN: u32 = 12 * 60;

/// When the advisor's day closes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DayClose {
    /// At every local midnight between the first and the last event (CGM
    /// mode).
    Midnight,
    /// Never (the caller closes days itself).
    Never,
}

/// What the mapping needs to know about the person.
#[derive(Debug, Clone)]
pub struct PersonSettings {
    /// The person's zone.
    pub tz: TimeZone,
    /// Day 1; default: the local date of the earliest record.
    pub first_day: Option<Date>,
    /// Meal windows.
    pub meals: MealWindows,
    /// When days close.
    pub day_close: DayClose,
    /// The unit the person reads glucose in: the notes' words use it.
    pub units: crate::units::GlucoseUnit,
}

impl PersonSettings {
    /// Default windows, days closing at midnight.
    pub fn new(tz: TimeZone) -> Self {
        Self {
            tz,
            first_day: None,
            meals: MealWindows::default(),
            day_close: DayClose::Midnight,
            units: crate::units::GlucoseUnit::MgDl,
        }
    }
}

/// A record that did not become an event, and why.
#[derive(Debug, Clone, Serialize)]
pub struct Rejected {
    /// File and line or JSON item.
    pub origin: String,
    /// The record's kind.
    pub kind: String,
    /// Why.
    pub reason: String,
}

/// The events and an account of every record.
#[derive(Debug, Clone, Serialize)]
pub struct EventStream {
    /// Day 1 of the advisor's clock.
    pub first_day: String,
    /// The person's zone.
    pub tz: String,
    /// The events, in the advisor's order.
    pub events: Vec<Event>,
    /// Events per kind.
    pub counts: BTreeMap<String, usize>,
    /// Ignored records per source kind.
    pub ignored: BTreeMap<String, usize>,
    /// Records kept in the stream but with no advisor event (long-acting
    /// insulin), per kind.
    pub not_mapped: BTreeMap<String, usize>,
    /// CGM/SMBG readings the device reported only as Low or High, passed on
    /// at the device's limit.
    pub censored: usize,
    /// Records rejected, with reasons.
    pub rejected: Vec<Rejected>,
    /// The meal rule applied.
    pub meal_rule: String,
    /// Things the user should know (a profile naming another time zone).
    pub notes: Vec<String>,
}

/// Name of an event kind.
pub fn kind_name(k: &EventKind) -> &'static str {
    match k {
        EventKind::Cgm(_) => "cgm",
        EventKind::Smbg(_) => "smbg",
        EventKind::MealAnnounced { .. } => "meal_announced",
        EventKind::Bolus(_) => "bolus",
        EventKind::BasalRate(_) => "basal_rate",
        EventKind::DayClosed => "day_closed",
        EventKind::TempBasal { .. } => "temp_basal",
        EventKind::Suspend => "suspend",
        EventKind::Resume => "resume",
        EventKind::ExtendedBolus { .. } => "extended_bolus",
        _ => "other",
    }
}

/// Order of kinds within one minute, as the closed loop feeds them:
/// readings, the announcement, its bolus, other pump records, the day's
/// close, then the basal rate the advisor's answer set. Suspensions and
/// resumes share a rank, so that a minute keeps them in the order they
/// happened (the sort is stable; see [`one_per_minute`]).
fn rank(k: &EventKind) -> u8 {
    match k {
        EventKind::Cgm(_) => 0,
        EventKind::Smbg(_) => 1,
        EventKind::MealAnnounced { .. } => 2,
        EventKind::Bolus(_) => 3,
        EventKind::ExtendedBolus { .. } => 4,
        EventKind::Suspend | EventKind::Resume => 5,
        EventKind::TempBasal { .. } => 7,
        EventKind::DayClosed => 8,
        EventKind::BasalRate(_) => 9,
        _ => 10,
    }
}

/// The basal state followed through the records.
#[derive(Default)]
struct Basal {
    schedule: Option<BasalSchedule>,
    /// A suspension in progress, and when it ends by itself (if it does).
    suspended_until: Option<Option<jiff::Timestamp>>,
    /// The last scheduled rate emitted (or in force before day 1).
    last: Option<f64>,
}

impl Basal {
    /// The scheduled rate at a minute of the local day.
    fn rate(&self, minute_of_day: u32) -> f64 {
        self.schedule
            .as_ref()
            .map_or(0.0, |s| s.rate_at(minute_of_day).0)
    }
    /// The next instant after `after` at which the rate may change.
    fn next_change(&self, after: jiff::Timestamp, clock: &AdvisorClock) -> Option<jiff::Timestamp> {
        let mut next: Option<jiff::Timestamp> = None;
        let mut take = |t: jiff::Timestamp| {
            if t > after && next.is_none_or(|n| t < n) {
                next = Some(t);
            }
        };
        if let Some(Some(end)) = self.suspended_until {
            take(end);
        }
        if let Some(s) = self.schedule.as_ref().filter(|s| s.segments.len() > 1) {
            let now = clock.timestamp(after);
            let m = now.minute_of_day() as u32;
            let next_seg = s.segments.iter().map(|x| x.0).find(|&x| x > m);
            let t = match next_seg {
                Some(x) => Timestamp::from_day_and_minute(now.day_index(), i64::from(x)),
                None => Timestamp::from_day_and_minute(now.day_index() + 1, 0),
            };
            if let Ok(i) = clock.instant(t) {
                take(i);
            }
        }
        next
    }
    /// Ends a suspension whose duration is over at `t`; true if one ended.
    fn expire(&mut self, t: jiff::Timestamp) -> bool {
        let ended = matches!(self.suspended_until, Some(Some(end)) if end <= t);
        if ended {
            self.suspended_until = None;
        }
        ended
    }
}

fn plus_min(t: jiff::Timestamp, m: u32) -> jiff::Timestamp {
    t.checked_add(jiff::SignedDuration::from_mins(i64::from(m)))
        .unwrap_or(t)
}

/// The first glucose reading (CGM or meter) of `records` in time order:
/// day 1 is its local day.
pub fn first_glucose(records: &[Record]) -> Option<&Record> {
    records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Cgm { .. } | RecordKind::Smbg { .. }))
        .min_by_key(|r| r.at)
}

/// How messages name the record they are about.
#[derive(Debug, Clone, Copy)]
pub enum Origins<'a> {
    /// Records read from these files (a record's `origin.file` indexes
    /// them): `file: line N` or `file: $[i]`.
    Files(&'a [String]),
    /// Records with no file (the person store's log): named by their
    /// source and instant, `nightscout record of 2026-03-01T07:00:00Z`.
    Stored,
}

impl Origins<'_> {
    /// Where `r` came from, for messages.
    pub fn of(self, r: &Record) -> String {
        match self {
            Origins::Files(files) => {
                let file = files
                    .get(usize::from(r.origin.file))
                    .map_or("?", String::as_str);
                match r.origin.at {
                    OriginAt::Line(n) => format!("{file}: line {n}"),
                    OriginAt::Item(i) => format!("{file}: $[{i}]"),
                    OriginAt::Row { sheet, row } => format!(
                        "{file}: sheet \"{}\", row {row}",
                        crate::read::tidepool_xlsx::sheet_name(sheet)
                    ),
                }
            }
            Origins::Stored => format!("{} record of {}", r.source.name(), r.at),
        }
    }
}

impl Batch {
    /// The batch's records as the advisor's events ([`to_events`] with the
    /// batch's file names).
    pub fn to_events(&self, person: &PersonSettings) -> Result<EventStream, crate::IoError> {
        to_events(&self.records, Origins::Files(&self.files), person)
    }
}

/// Maps records (in time order, duplicates removed: see
/// [`crate::read::merge_records`]) to the advisor's events; `origins` names
/// a record in messages.
pub fn to_events(
    records: &[Record],
    origins: Origins<'_>,
    person: &PersonSettings,
) -> Result<EventStream, crate::IoError> {
    person.meals.validate()?;
    let first_day = day_one(records, person)?;
    let clock = AdvisorClock::new(person.tz.clone(), first_day);
    let mut out = EventStream {
        first_day: first_day.to_string(),
        tz: person.tz.iana_name().unwrap_or("?").to_string(),
        events: Vec::with_capacity(records.len()),
        counts: BTreeMap::new(),
        ignored: BTreeMap::new(),
        not_mapped: BTreeMap::new(),
        censored: 0,
        rejected: Vec::new(),
        meal_rule: person.meals.rule(),
        notes: Vec::new(),
    };
    let (mut events, rescued) = map_records(records, origins, person, &clock, &mut out);
    events.sort_by_key(|e| (e.at, rank(&e.kind)));
    if person.day_close == DayClose::Midnight {
        close_at_midnights(&mut events);
    }
    let kept = one_per_minute(events, &mut out.rejected);
    for e in &kept {
        *out.counts.entry(kind_name(&e.kind).into()).or_default() += 1;
    }
    rescued.note(person.units, &mut out);
    out.events = kept;
    Ok(out)
}

/// Day 1: the person's, else the local day of the first glucose reading
/// (a profile or a pump record long before the first reading does not
/// make the first day), else of the first record that is data.
fn day_one(records: &[Record], person: &PersonSettings) -> Result<Date, crate::IoError> {
    let first_data = first_glucose(records)
        .or_else(|| {
            records.iter().find(|r| {
                !matches!(
                    r.kind,
                    RecordKind::Schedule { .. } | RecordKind::Ignored { .. }
                )
            })
        })
        .or(records.first());
    match (person.first_day, first_data) {
        (Some(d), _) => Ok(d),
        (None, Some(r)) => Ok(person.tz.to_datetime(r.at).date()),
        (None, None) => Err(crate::IoError::Settings("no records to map".into())),
    }
}

/// Carbohydrate entries that were hypoglycaemia treatments.
#[derive(Default)]
struct Rescued {
    n: usize,
    grams: f64,
}

impl Rescued {
    /// Their count and a note, if there were any.
    fn note(&self, units: crate::units::GlucoseUnit, out: &mut EventStream) {
        if self.n > 0 {
            out.counts.insert(crate::rescue::COUNT_KEY.into(), self.n);
            out.notes.push(format!(
                "{} carbohydrate entries ({:.0} g in all) were hypoglycaemia treatments ({}): counted, not meals, never used to learn a carb ratio",
                self.n,
                self.grams,
                crate::rescue::rule(units)
            ));
        }
    }
}

/// Emits the scheduled rate in force at `at` if it changed (or always,
/// with `force`); basal state before day 1 is followed but emits nothing.
fn emit_rate(
    basal: &mut Basal,
    clock: &AdvisorClock,
    at: jiff::Timestamp,
    force: bool,
    events: &mut Vec<Event>,
) {
    let ts = clock.timestamp(at);
    let rate = basal.rate(ts.minute_of_day() as u32);
    match basal.last {
        _ if ts.day_index() < 0 => basal.last = Some(rate),
        None => basal.last = Some(rate),
        Some(last) if force || last != rate => {
            basal.last = Some(rate);
            events.push(Event::new(ts, EventKind::BasalRate(UnitsPerHour(rate))));
        }
        Some(_) => {}
    }
}

/// The per-record mapping: each record's events (unsorted), the basal
/// rate's changes between records, and into `out` every record rejected,
/// ignored, not mapped or censored and the profiles' zone notes.
fn map_records(
    records: &[Record],
    origins: Origins<'_>,
    person: &PersonSettings,
    clock: &AdvisorClock,
    out: &mut EventStream,
) -> (Vec<Event>, Rescued) {
    let first_day = clock.first_day();
    let mut basal = Basal::default();
    let rescue = crate::rescue::Rescue::new(records);
    let mut rescued = Rescued::default();
    let mut meals_taken: BTreeMap<(i64, MealSlot), ()> = BTreeMap::new();
    let mut events: Vec<Event> = Vec::with_capacity(records.len());
    let mut now = records
        .first()
        .map_or(jiff::Timestamp::UNIX_EPOCH, |r| r.at);
    for r in records {
        // Changes of the basal rate in force before this record.
        while let Some(t) = basal.next_change(now, clock).filter(|&t| t <= r.at) {
            if basal.expire(t) && clock.timestamp(t).day_index() >= 0 {
                events.push(Event::new(clock.timestamp(t), EventKind::Resume));
            }
            emit_rate(&mut basal, clock, t, false, &mut events);
            now = t;
        }
        now = r.at;
        let ts = clock.timestamp(r.at);
        let reject = |out: &mut EventStream, r: &Record, reason: String| {
            out.rejected.push(Rejected {
                origin: origins.of(r),
                kind: r.kind.name().into(),
                reason,
            })
        };
        // A profile before day 1 sets the scheduled rate; nothing else
        // before day 1 reaches the advisor.
        if ts.day_index() < 0 && !matches!(r.kind, RecordKind::Schedule { .. }) {
            reject(out, r, format!("before the first day {first_day}"));
            continue;
        }
        match &r.kind {
            RecordKind::Cgm { glucose } | RecordKind::Smbg { glucose } => {
                if glucose.censor != Censor::Exact {
                    out.censored += 1;
                }
                let g = MgDl(glucose.mg_dl.0);
                let kind = if matches!(r.kind, RecordKind::Cgm { .. }) {
                    EventKind::Cgm(g)
                } else {
                    EventKind::Smbg(g)
                };
                events.push(Event::new(ts, kind));
            }
            RecordKind::Carbs { grams } if rescue.is_rescue(r.at) => {
                // A hypoglycaemia treatment: counted, never a meal.
                rescued.n += 1;
                rescued.grams += grams.0;
            }
            RecordKind::Carbs { grams } => {
                let mut slot = person
                    .meals
                    .window_of(ts.minute_of_day() as u32)
                    .unwrap_or(MealSlot::Snack);
                if slot != MealSlot::Snack
                    && meals_taken.insert((ts.day_index(), slot), ()).is_some()
                {
                    slot = MealSlot::Snack;
                }
                events.push(Event::new(
                    ts,
                    EventKind::MealAnnounced {
                        carbs: Grams(grams.0),
                        slot,
                    },
                ));
            }
            RecordKind::Bolus { units } => {
                events.push(Event::new(ts, EventKind::Bolus(Units(units.0))))
            }
            RecordKind::ExtendedBolus {
                now: u_now,
                extended,
                duration_min,
            } => {
                let total = Units(u_now.0 + extended.0);
                if *duration_min == 0 || extended.0 == 0.0 {
                    events.push(Event::new(ts, EventKind::Bolus(total)));
                } else if *duration_min > EXTENDED_BOLUS_MAX_MIN {
                    reject(
                        out,
                        r,
                        format!("an extended bolus over {duration_min} min is longer than the advisor accepts ({EXTENDED_BOLUS_MAX_MIN} min)"),
                    );
                } else {
                    events.push(Event::new(
                        ts,
                        EventKind::ExtendedBolus {
                            total,
                            immediate: *u_now,
                            duration_min: *duration_min,
                        },
                    ));
                }
            }
            RecordKind::Schedule { profile } => {
                // A zone named otherwise but keeping the person's clock at
                // the profile's time (Loop writes "ETC/GMT+7" for Phoenix)
                // needs no note.
                let other_clock = |z: &str| match jiff::tz::TimeZone::get(z) {
                    Ok(tz) => tz.to_offset(r.at) != person.tz.to_offset(r.at),
                    Err(_) => true,
                };
                if let Some(zone) = profile
                    .timezone
                    .as_deref()
                    .filter(|z| Some(*z) != person.tz.iana_name() && other_clock(z))
                {
                    out.notes.push(format!(
                        "{}: the profile names time zone {zone}, the person's is {}; times are read in the person's",
                        origins.of(r),
                        person.tz.iana_name().unwrap_or("?")
                    ));
                }
                basal.schedule = Some(profile.basal.clone());
                emit_rate(&mut basal, clock, r.at, true, &mut events);
            }
            RecordKind::TempBasal { rate, duration_min } => {
                let rate = match *rate {
                    TempRate::Absolute(r) => TempBasalRate::UnitsPerHour(r),
                    TempRate::Percent(p) => TempBasalRate::Percent(p),
                };
                events.push(Event::new(
                    ts,
                    EventKind::TempBasal {
                        rate,
                        duration_min: *duration_min,
                    },
                ));
            }
            RecordKind::Suspend { duration_min } => {
                if basal.suspended_until.is_none() {
                    events.push(Event::new(ts, EventKind::Suspend));
                }
                basal.suspended_until = Some(duration_min.map(|d| plus_min(r.at, d)));
            }
            RecordKind::Resume => {
                if basal.suspended_until.take().is_some() {
                    events.push(Event::new(ts, EventKind::Resume));
                } else {
                    reject(out, r, "a resume with no suspension before it".into());
                }
            }
            RecordKind::LongActing { .. } => {
                *out.not_mapped
                    .entry("long-acting insulin (the advisor follows a pump's basal rate)".into())
                    .or_default() += 1;
            }
            RecordKind::Ignored { kind } => *out.ignored.entry(kind.clone()).or_default() += 1,
        }
    }
    (events, rescued)
}

/// Day closes at local midnights strictly after the first event and not
/// after the last one; `events` sorted, and sorted again after.
fn close_at_midnights(events: &mut Vec<Event>) {
    let (Some(first), Some(last)) = (events.first().map(|e| e.at), events.last().map(|e| e.at))
    else {
        return;
    };
    let mut closes = Vec::new();
    let mut day = first.day_index() + 1;
    while Timestamp::from_day_and_minute(day, 0) <= last {
        closes.push(Event::new(
            Timestamp::from_day_and_minute(day, 0),
            EventKind::DayClosed,
        ));
        day += 1;
    }
    // Exactly: a long log's list would otherwise double.
    events.reserve_exact(closes.len());
    events.extend(closes);
    events.sort_by_key(|e| (e.at, rank(&e.kind)));
}

/// One reading of a kind per minute, one basal rate per minute (the
/// last); boluses of one minute, and snacks of one minute, become one
/// event with their sum (the advisor takes two equal events in a minute
/// for a repeat; two records of the device are two doses). A second
/// reading (or day close) of a minute is rejected, and so is a second
/// resume (the pump runs after it as after the first). Suspensions and
/// resumes alternate in time ([`map_records`] sends a suspend only while
/// the pump runs, a resume only while it is suspended) and keep their order
/// in a minute ([`rank`]): of three in one minute (suspend, resume,
/// suspend), the middle state lasted less than the minute, and the second
/// and third are rejected, so that the minute ends as the records say (the
/// advisor takes a second equal event in a minute for a repeat).
fn one_per_minute(events: Vec<Event>, rejected: &mut Vec<Rejected>) -> Vec<Event> {
    let mut kept: Vec<Event> = Vec::with_capacity(events.len());
    let pump_state = |k: &EventKind| matches!(k, EventKind::Suspend | EventKind::Resume);
    for e in events {
        let n = kept.len();
        if pump_state(&e.kind)
            && n >= 2
            && kept[n - 2..]
                .iter()
                .all(|k| k.at == e.at && pump_state(&k.kind))
            && kept[n - 2].kind != kept[n - 1].kind
        {
            let Some(between) = kept.pop() else { continue };
            let (first, end, short) = match kept[n - 2].kind {
                EventKind::Suspend => ("suspend", "suspended", "the pump ran for"),
                _ => ("resume", "running", "the suspension lasted"),
            };
            let reason = format!(
                "a {} and a {} after a {first} of the same minute ({short} less than the minute): the minute ends {end}, as the records say",
                kind_name(&between.kind),
                kind_name(&e.kind),
            );
            for dropped in [&between, &e] {
                rejected.push(Rejected {
                    origin: format!("advisor time {}", dropped.at),
                    kind: kind_name(&dropped.kind).into(),
                    reason: reason.clone(),
                });
            }
            continue;
        }
        if let Some(prev) = kept.last_mut() {
            if prev.at == e.at
                && std::mem::discriminant(&prev.kind) == std::mem::discriminant(&e.kind)
            {
                match (&mut prev.kind, e.kind) {
                    (EventKind::Bolus(a), EventKind::Bolus(b)) => {
                        a.0 += b.0;
                        continue;
                    }
                    (
                        EventKind::MealAnnounced {
                            carbs: a,
                            slot: MealSlot::Snack,
                        },
                        EventKind::MealAnnounced {
                            carbs: b,
                            slot: MealSlot::Snack,
                        },
                    ) => {
                        a.0 += b.0;
                        continue;
                    }
                    _ => {}
                }
                match e.kind {
                    EventKind::BasalRate(_) | EventKind::TempBasal { .. } => {
                        *prev = e;
                        continue;
                    }
                    // Two resumes of one minute: a suspension that ended
                    // at its time (or by a resume) and one that began and
                    // ended again within the minute (the minute's events
                    // sorted by kind put both resumes after its suspend):
                    // the pump runs after both, as after one.
                    EventKind::Resume => {
                        rejected.push(Rejected {
                            origin: format!("advisor time {}", e.at),
                            kind: kind_name(&e.kind).into(),
                            reason: "a second resume in the same minute (a suspension that began and ended within the minute): the pump runs after it as after the first, which was kept".into(),
                        });
                        continue;
                    }
                    EventKind::Cgm(_) | EventKind::Smbg(_) | EventKind::DayClosed => {
                        rejected.push(Rejected {
                            origin: format!("advisor time {}", e.at),
                            kind: kind_name(&e.kind).into(),
                            reason: "a second reading of this kind in the same minute (the advisor takes one per minute); the first was kept".into(),
                        });
                        continue;
                    }
                    _ => {}
                }
            }
        }
        kept.push(e);
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{Origin, Source, SourceId};

    #[test]
    fn origins_name_a_file_line_or_item_and_a_stored_record_by_source_and_instant() {
        let mut r = Record {
            at: "2026-03-01T07:00:00Z".parse().unwrap(),
            kind: RecordKind::Resume,
            source: Source::Nightscout,
            id: SourceId::Hash(1),
            origin: Origin {
                file: 1,
                at: OriginAt::Item(3),
            },
        };
        let files = ["a.csv".to_string(), "t.json".to_string()];
        assert_eq!(Origins::Files(&files).of(&r), "t.json: $[3]");
        r.origin.at = OriginAt::Line(7);
        assert_eq!(Origins::Files(&files).of(&r), "t.json: line 7");
        r.origin.file = 2;
        assert_eq!(Origins::Files(&files).of(&r), "?: line 7");
        assert_eq!(
            Origins::Stored.of(&r),
            "nightscout record of 2026-03-01T07:00:00Z"
        );
    }
}
