//! The person's log: device records (append-only, each with its source and
//! its identity there) and the advisor's events derived from them.
//!
//! Events are a pure function of the records and the person's settings
//! (abba-io's [`abba_io::events::to_events`] plus, in SMBG mode, the day
//! closes below), so importing the same data twice, or overlapping exports,
//! cannot change them: a record already known (same source, same id) is not
//! added again. The log keeps every source's records; events are made from
//! one source per kind of data and local day ([`crate::one_source`]), and
//! every reader that derives the person's events or days from the log goes
//! through [`events`] or [`used`].

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use crate::one_source::Chosen;
use crate::person::Person;
use abba_advisor::Mode;
use abba_core::{Event, EventKind, Timestamp};
use abba_io::events::{to_events, EventStream, Origins};
use abba_io::read::merge_records;
use abba_io::record::{Origin, OriginAt};
use abba_io::{Record, RecordKind, Source, SourceId};

/// A stored record's source, by the name serde gives it (`libre_view`,
/// `care_link`, ...): the reader's enum is the one list of sources.
pub(crate) fn parse_source(s: &str) -> Result<Source, StoreError> {
    use serde::de::IntoDeserializer;
    use serde::Deserialize;
    let de: serde::de::value::StrDeserializer<'_, serde::de::value::Error> = s.into_deserializer();
    Source::deserialize(de).map_err(|e| StoreError::corrupt("record source", e))
}

/// The schema step [`crate::schema::Step::Rekey`]: re-keys every record whose id is a row index (`{"index": N}`) to its
/// content identity, inside the migration's transaction. A record whose
/// new key is already held by one with the same instant and kind is the
/// same record exported twice (the second import of an overlapping export
/// under other row numbers) and is removed; a different record under that
/// key would be lost, so the migration fails instead.
pub fn rekey(conn: &dyn Db) -> Result<(), StoreError> {
    let rows = conn.rows(Q::RecordsKeyedByIndex, args![])?;
    for r in rows {
        let (person, source_text, old, at_ms, kind_text) =
            (r.int(0)?, r.text(1)?, r.text(2)?, r.int(3)?, r.text(4)?);
        let source = parse_source(&source_text)?;
        let kind: RecordKind =
            serde_json::from_str(&kind_text).map_err(|e| StoreError::corrupt("record", e))?;
        let at = jiff::Timestamp::from_millisecond(at_ms)
            .map_err(|e| StoreError::corrupt("record instant", e))?;
        let new = serde_json::to_string(&abba_io::record::content_id(source, at, &kind))
            .map_err(|e| StoreError::corrupt("record id", e))?;
        let held = match conn.row(Q::RecordHeld, args![person, &source_text, &new])? {
            Some(r) => Some((r.int(0)?, r.text(1)?)),
            None => None,
        };
        match held {
            None => {
                conn.execute(Q::RecordRekey, args![&new, person, &source_text, &old])?;
            }
            Some((a, k)) if a == at_ms && k == kind_text => {
                conn.execute(Q::RecordDelete, args![person, &source_text, &old])?;
            }
            Some(_) => {
                return Err(StoreError::corrupt(
                    "record id",
                    format!(
                    "re-keying {old} of person {person}: its new key {new} holds another record"
                ),
                ))
            }
        }
    }
    Ok(())
}

/// A source as stored (the name serde gives it, see [`parse_source`]).
pub(crate) fn source_text(source: Source) -> Result<String, StoreError> {
    match serde_json::to_value(source) {
        Ok(serde_json::Value::String(s)) => Ok(s),
        _ => Err(StoreError::corrupt("record source", "not a string")),
    }
}

/// A record's key columns: (source, source id) as stored.
pub fn key(r: &Record) -> Result<(String, String), StoreError> {
    let source = source_text(r.source)?;
    let mut id = serde_json::to_string(&r.id).map_err(|e| StoreError::corrupt("record id", e))?;
    // serde_json's buffer starts at 128 bytes; an import holds one id a row.
    id.shrink_to_fit();
    Ok((source, id))
}

/// Every record of a person, in a fixed order (instant, source, id): the
/// same set of records always gives the same list, whatever the order in
/// which they were imported. Every source's, those that
/// [`crate::one_source`] sets aside and those before day 1 included: the raw log, for listing or
/// exporting what the person gave us; events and days come from [`used`].
pub fn records(conn: &dyn Db, person: i64) -> Result<Vec<Record>, StoreError> {
    records_and_imports(conn, person).map(|(r, _)| r)
}

/// For each import (in the order made, by id), the latest instant among
/// the records it brought that are still stored as it brought them (ms
/// since the epoch).
pub type ImportEnds = Vec<(i64, i64)>;

/// [`records`], and where each import left them ([`ImportEnds`]).
pub fn records_and_imports(
    conn: &dyn Db,
    person: i64,
) -> Result<(Vec<Record>, ImportEnds), StoreError> {
    // A scan of the primary key (no per-row index look-ups), each row parsed
    // as it comes (a long log is never held as text too), sorted here. The
    // count sizes the list (a hint: a write in between only regrows it).
    let n = conn.one(Q::RecordCount, args![person])?.int(0)?;
    let mut out = Vec::with_capacity(usize::try_from(n).unwrap_or(0));
    let mut imports: std::collections::BTreeMap<i64, i64> = Default::default();
    conn.each_row(Q::RecordsOf, args![person], &mut |r| {
        let at_ms = r.int(2)?;
        let latest = imports.entry(r.int(4)?).or_insert(at_ms);
        *latest = (*latest).max(at_ms);
        let source = parse_source(r.str(0)?)?;
        let id: SourceId =
            serde_json::from_str(r.str(1)?).map_err(|e| StoreError::corrupt("record id", e))?;
        let at = jiff::Timestamp::from_millisecond(at_ms)
            .map_err(|e| StoreError::corrupt("record instant", e))?;
        let kind: RecordKind =
            serde_json::from_str(r.str(3)?).map_err(|e| StoreError::corrupt("record", e))?;
        out.push(Record {
            at,
            kind,
            source,
            id,
            origin: Origin {
                file: 0,
                at: OriginAt::Item(0),
            },
        });
        Ok(())
    })?;
    // The order of the stored columns: instant, then the key's text (made
    // again only for records of one instant, which are few).
    let mut bad = None;
    out.sort_by(|a, b| {
        a.at.cmp(&b.at).then_with(|| match (key(a), key(b)) {
            (Ok(ka), Ok(kb)) => ka.cmp(&kb),
            (Err(e), _) | (_, Err(e)) => {
                bad.get_or_insert(e);
                std::cmp::Ordering::Equal
            }
        })
    });
    if let Some(e) = bad {
        return Err(e);
    }
    for (i, r) in out.iter_mut().enumerate() {
        r.origin.at = OriginAt::Item(u32::try_from(i).unwrap_or(u32::MAX));
    }
    Ok((out, imports.into_iter().collect()))
}

/// The records of a person that events and days are made from: those on
/// or after day 1, one source for each kind of data on each of their local
/// days ([`crate::day_1::used`]), and what was left out.
pub fn used(conn: &dyn Db, person: &Person) -> Result<Chosen, StoreError> {
    Ok(crate::day_1::used(person, records(conn, person.id)?))
}

/// The advisor's events for `records`, every record of the log or a part
/// of it: the records before day 1 are left out and one source is chosen
/// for each kind of data and day first ([`crate::day_1::used`]; what was
/// left out is said in the stream's notes).
pub fn events(person: &Person, records: Vec<Record>) -> Result<EventStream, StoreError> {
    events_of(person, crate::day_1::used(person, records))
}

/// The advisor's events for records already chosen
/// ([`crate::day_1::used`]), what was set aside said first among
/// the stream's notes (see the module documentation).
pub fn events_of(person: &Person, chosen: Chosen) -> Result<EventStream, StoreError> {
    let set_aside = chosen.notes();
    let mut records = chosen.records;
    if records.is_empty() {
        return Ok(EventStream {
            first_day: person.first_day.map(|d| d.to_string()).unwrap_or_default(),
            tz: person.tz.iana_name().unwrap_or("?").to_string(),
            events: Vec::new(),
            counts: Default::default(),
            ignored: Default::default(),
            not_mapped: Default::default(),
            censored: 0,
            rejected: Vec::new(),
            meal_rule: person.settings.meal_windows.rule(),
            notes: set_aside,
        });
    }
    // Two sources carrying one reading or dose count once, as in an import.
    merge_records(&mut records);
    let mut stream = to_events(&records, Origins::Stored, &person.mapping())?;
    stream.notes.splice(0..0, set_aside);
    if person.mode() == Mode::Smbg {
        let minute = i64::from(person.settings.bedtime_min);
        stream.events = with_smbg_day_closes(std::mem::take(&mut stream.events), minute);
        let closes = stream
            .events
            .iter()
            .filter(|e| e.kind == EventKind::DayClosed)
            .count();
        if closes > 0 {
            stream.counts.insert("day_closed".into(), closes);
        }
    }
    Ok(stream)
}

/// SMBG mode: a day closes right after its first meter reading at or after
/// `bedtime_min` (the bedtime reading, as in the trial); a day without one
/// closes at the next midnight once the log holds a later day.
pub fn with_smbg_day_closes(events: Vec<Event>, bedtime_min: i64) -> Vec<Event> {
    let (Some(first), Some(last)) = (events.first().map(|e| e.at), events.last().map(|e| e.at))
    else {
        return events;
    };
    let mut closes: Vec<Timestamp> = Vec::new();
    for day in first.day_index()..=last.day_index() {
        let bedtime = events.iter().find(|e| {
            matches!(e.kind, EventKind::Smbg(_))
                && e.at.day_index() == day
                && e.at.minute_of_day() >= bedtime_min
        });
        match bedtime {
            Some(e) => closes.push(e.at),
            None if day < last.day_index() => {
                closes.push(Timestamp::from_day_and_minute(day + 1, 0))
            }
            None => {}
        }
    }
    let mut out = Vec::with_capacity(events.len() + closes.len());
    let mut next = closes.into_iter().peekable();
    for e in events {
        // The close goes after the minute's readings, meals and boluses,
        // before a basal rate set at that minute.
        while let Some(&c) = next.peek() {
            if c < e.at || (c == e.at && matches!(e.kind, EventKind::BasalRate(_))) {
                out.push(Event::new(c, EventKind::DayClosed));
                next.next();
            } else {
                break;
            }
        }
        out.push(e);
    }
    out.extend(next.map(|c| Event::new(c, EventKind::DayClosed)));
    out
}
