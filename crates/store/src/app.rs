//! The app's events: what a pump or phone app posted through the service,
//! each under the app's own sequence number.
//!
//! The table `app_event` is the durable log of an app-fed person: (person,
//! seq) is the key, and the SHA-256 of the payload (computed by the
//! service) tells a repeat (same payload: acknowledged again, nothing
//! stored) from a conflict (another payload: refused). The advisor sees
//! the events in order of (advisor minute, seq). A person is fed by imports
//! or by the app, not both.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use crate::person::Person;
use abba_core::{Event, EventKind, Timestamp};
use abba_io::clock::AdvisorClock;
use abba_io::events::{kind_name, EventStream};
use std::collections::BTreeMap;

/// One event as the app posted it.
#[derive(Debug, Clone, PartialEq)]
pub struct NewAppEvent {
    /// The app's sequence number.
    pub seq: u64,
    /// The instant.
    pub at: jiff::Timestamp,
    /// What happened (an answer event is refused).
    pub kind: EventKind,
    /// SHA-256 of the payload (instant and content).
    pub hash: [u8; 32],
}

/// One stored app event on the advisor's clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AppEvent {
    /// The app's sequence number.
    pub seq: u64,
    /// The event.
    pub event: Event,
}

impl AppEvent {
    /// The order the advisor sees: (minute, seq).
    pub fn key(&self) -> (i64, u64) {
        (self.event.at.0, self.seq)
    }
}

/// What a batch did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Inserted {
    /// Events stored now, in the advisor's order.
    pub new: Vec<AppEvent>,
    /// Sequence numbers already held with the same payload.
    pub repeated: Vec<u64>,
}

fn seq_sql(seq: u64) -> Result<i64, StoreError> {
    i64::try_from(seq).map_err(|_| StoreError::invalid("seq", "expected at most 2^63 - 1"))
}

/// Number of app events of a person.
pub fn count(conn: &dyn Db, person: i64) -> Result<i64, StoreError> {
    conn.one(Q::AppEventCount, args![person])?.int(0)
}

fn record_count(conn: &dyn Db, person: i64) -> Result<i64, StoreError> {
    conn.one(Q::RecordCount, args![person])?.int(0)
}

/// Checks and stores a batch (call inside a transaction): every event is
/// mapped onto the advisor's clock (day 1 is set from the batch's earliest
/// event when the person has none), held numbers are compared by payload.
/// On an error nothing of the batch may be committed.
pub fn insert(
    conn: &dyn Db,
    person: &mut Person,
    batch: &[NewAppEvent],
) -> Result<Inserted, StoreError> {
    if record_count(conn, person.id)? > 0 {
        return Err(StoreError::Feed(format!(
            "person {} is fed by imported records; app events and imports do not mix",
            person.id
        )));
    }
    // An event dated before any sensor or pump logged data cannot be
    // true, and must never become day 1 (imports refuse such records too).
    if let Some((i, e)) = batch
        .iter()
        .enumerate()
        .find(|(_, e)| e.at < abba_io::read::RECORDS_FROM)
    {
        return Err(StoreError::invalid(
            format!("events[{i}].at"),
            format!("{} is {}", e.at, abba_io::read::too_old_words()),
        ));
    }
    if person.first_day.is_none() {
        if let Some(first) = batch.iter().map(|e| e.at).min() {
            let day = person.tz.to_datetime(first).date();
            crate::person::set_first_day(conn, person.id, day)?;
            person.first_day = Some(day);
        }
    }
    let Some(first_day) = person.first_day else {
        return Ok(Inserted::default());
    };
    let clock = AdvisorClock::new(person.tz.clone(), first_day);
    let limit = person.settings.advisor.limits.max_timestamp_min;
    let now = jiff::Timestamp::now().to_string();
    let mut out = Inserted::default();
    for (i, e) in batch.iter().enumerate() {
        let seq = seq_sql(e.seq)?;
        let held: Option<Vec<u8>> = conn
            .row(Q::AppEventHash, args![person.id, seq])?
            .map(|r| r.blob(0))
            .transpose()?;
        match held {
            Some(h) if h == e.hash => {
                out.repeated.push(e.seq);
                continue;
            }
            Some(_) => {
                return Err(StoreError::SeqConflict {
                    index: i,
                    seq: e.seq,
                })
            }
            None => {}
        }
        let at = clock.timestamp(e.at);
        if at.0 < 0 {
            return Err(StoreError::invalid(
                format!("events[{i}].at"),
                format!(
                    "{} is before the person's day 1 ({first_day}, {})",
                    e.at,
                    person.tz.iana_name().unwrap_or("?")
                ),
            ));
        }
        if at.0 > limit {
            return Err(StoreError::invalid(
                format!("events[{i}].at"),
                format!("{} is more than {limit} minutes after day 1", e.at),
            ));
        }
        // CGM mode: the day closes at local midnight (the advisor closes
        // the day that holds the minute before the event); a day_closed at
        // any other time would close the day still running, and a second
        // basal decision would follow for one date.
        if e.kind == EventKind::DayClosed
            && person.mode() == abba_advisor::Mode::Cgm
            && at.minute_of_day() != 0
        {
            let local = person.tz.to_datetime(e.at);
            return Err(StoreError::invalid(
                format!("events[{i}].at"),
                format!(
                    "a CGM-mode person's day closes at local midnight: post day_closed at 00:00 of the next day ({}T00:00 in {}) with the first event after midnight, not at {} ({} local)",
                    local.date().tomorrow().unwrap_or(local.date()),
                    person.tz.iana_name().unwrap_or("the person's zone"),
                    e.at,
                    local.strftime("%H:%M"),
                ),
            ));
        }
        if matches!(
            e.kind,
            EventKind::SuggestionAccepted(_)
                | EventKind::SuggestionRejected(_)
                | EventKind::SuggestionOverridden(_)
        ) {
            return Err(StoreError::invalid(
                format!("events[{i}].event"),
                "answers go to the answers endpoint, not in the event log",
            ));
        }
        let kind =
            serde_json::to_string(&e.kind).map_err(|err| StoreError::corrupt("event", err))?;
        conn.execute(
            Q::AppEventPut,
            args![
                person.id,
                seq,
                e.at.as_millisecond(),
                at.0,
                kind_name(&e.kind),
                kind,
                &e.hash[..],
                &now
            ],
        )?;
        out.new.push(AppEvent {
            seq: e.seq,
            event: Event::new(at, e.kind),
        });
    }
    out.new.sort_by_key(AppEvent::key);
    out.repeated.sort_unstable();
    Ok(out)
}

/// Every app event of a person, in the advisor's order.
pub fn load(conn: &dyn Db, person: i64) -> Result<Vec<AppEvent>, StoreError> {
    // Sized by the count (a hint) and parsed row by row: a long log is
    // never held as rows too.
    let n = count(conn, person)?;
    events_of(conn, Q::AppEventsOf, args![person], n)
}

/// The app events that come after `key` (minute, seq) in the advisor's
/// order, in that order.
pub fn load_after(
    conn: &dyn Db,
    person: i64,
    key: (i64, u64),
) -> Result<Vec<AppEvent>, StoreError> {
    events_of(
        conn,
        Q::AppEventsAfter,
        args![person, key.0, seq_sql(key.1)?],
        0,
    )
}

fn events_of(
    conn: &dyn Db,
    q: Q,
    params: &[crate::backend::Value],
    expected: i64,
) -> Result<Vec<AppEvent>, StoreError> {
    let mut out = Vec::with_capacity(usize::try_from(expected).unwrap_or(0));
    conn.each_row(q, params, &mut |r| {
        let (seq, at) = (r.int(0)?, r.int(1)?);
        let kind: EventKind =
            serde_json::from_str(r.str(2)?).map_err(|e| StoreError::corrupt("app event", e))?;
        out.push(AppEvent {
            seq: seq as u64,
            event: Event::new(Timestamp(at), kind),
        });
        Ok(())
    })?;
    Ok(out)
}

/// The app event held under `seq`, if any.
pub fn one(conn: &dyn Db, person: i64, seq: u64) -> Result<Option<AppEvent>, StoreError> {
    let row = conn.row(Q::AppEventOne, args![person, seq_sql(seq)?])?;
    row.map(|r| {
        let (at, kind) = (r.int(0)?, r.text(1)?);
        let kind: EventKind =
            serde_json::from_str(&kind).map_err(|e| StoreError::corrupt("app event", e))?;
        Ok(AppEvent {
            seq,
            event: Event::new(Timestamp(at), kind),
        })
    })
    .transpose()
}

/// The event stream of an app-fed person (the events as posted).
pub fn stream(person: &Person, events: &[AppEvent]) -> EventStream {
    let mut s = EventStream {
        first_day: person.first_day.map(|d| d.to_string()).unwrap_or_default(),
        tz: person.tz.iana_name().unwrap_or("?").to_string(),
        events: Vec::with_capacity(events.len()),
        counts: BTreeMap::new(),
        ignored: BTreeMap::new(),
        not_mapped: BTreeMap::new(),
        censored: 0,
        rejected: Vec::new(),
        meal_rule: "meal slots as the app posted them".into(),
        notes: Vec::new(),
    };
    extend_stream(&mut s, events);
    s
}

/// Appends app events that come after every event of `stream` (the
/// advisor's order) to it.
pub fn extend_stream(stream: &mut EventStream, events: &[AppEvent]) {
    for e in events {
        *stream
            .counts
            .entry(kind_name(&e.event.kind).into())
            .or_default() += 1;
        stream.events.push(e.event);
    }
}

/// Held sequence numbers ≥ `from` as maximal ranges (at most `max`), and
/// whether more follow.
pub fn held_ranges(
    conn: &dyn Db,
    person: i64,
    from: u64,
    max: usize,
) -> Result<(Vec<(u64, u64)>, bool), StoreError> {
    let from = i64::try_from(from).unwrap_or(i64::MAX);
    let mut out: Vec<(u64, u64)> = Vec::new();
    for r in conn.rows(Q::AppEventSeqsFrom, args![person, from])? {
        let s = r.int(0)? as u64;
        if let Some(last) = out.last_mut().filter(|l| l.1 + 1 == s) {
            last.1 = s;
        } else if out.len() == max {
            return Ok((out, true));
        } else {
            out.push((s, s));
        }
    }
    Ok((out, false))
}

/// The largest seq (2^53 − 1, exact in every JSON implementation): the
/// API's limit (`abba_api::MAX_SEQ`), which numbers given by the store
/// itself (the web pages' entries) never pass either.
pub const MAX_SEQ: u64 = (1 << 53) - 1;

/// The highest sequence number held.
pub fn last_seq(conn: &dyn Db, person: i64) -> Result<Option<u64>, StoreError> {
    let v = conn.one(Q::AppEventLastSeq, args![person])?.opt_int(0)?;
    Ok(v.map(|s| s as u64))
}

/// The seq of the app event at advisor minute `at` that makes a decision
/// point of this kind: a `DayClosed` (basal) or the main meal of `slot`.
pub fn producer(
    conn: &dyn Db,
    person: i64,
    at: i64,
    slot: Option<abba_core::MealSlot>,
) -> Result<Option<u64>, StoreError> {
    for r in conn.rows(Q::AppEventProducers, args![person, at])? {
        let (seq, kind) = (r.int(0)?, r.text(1)?);
        let kind: EventKind =
            serde_json::from_str(&kind).map_err(|e| StoreError::corrupt("app event", e))?;
        let hit = match (kind, slot) {
            (EventKind::DayClosed, None) => true,
            (EventKind::MealAnnounced { slot: s, .. }, Some(want)) => s == want,
            _ => false,
        };
        if hit {
            return Ok(Some(seq as u64));
        }
    }
    Ok(None)
}
