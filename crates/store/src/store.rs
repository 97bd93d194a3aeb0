//! The store: the persons of one database (an SQLite file by default),
//! and the operations the CLI calls.

use crate::advise::{self, Advice, SuggestionView};
use crate::answer::{self, param_key, Answer, AnswerKind, Answers};
use crate::app::AppEvent;
use crate::backend::{args, Conn, Db, Q};
use crate::error::StoreError;
use crate::import::{self, ImportSummary};
use crate::in_force::{self, Extras, RecordFacts};
use crate::log;
use crate::person::{self, NewPerson, Person};
use crate::replay::{self, Snapshot};
use abba_advisor::{Abba, Decision, Parameter};
use abba_core::units::GlucoseUnit;
use abba_core::Event;
use abba_io::automation::{Delivery, Evidence};
use abba_io::events::EventStream;
use abba_io::read::{read_all, Batch, Format, ReadOptions};
use abba_io::Record;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What the person answers.
#[derive(Debug, Clone, PartialEq)]
pub enum AnswerRequest {
    /// Accept every open suggestion.
    Accept,
    /// Reject every open suggestion (keep the previous values).
    Reject,
    /// Put these values in force instead of the open suggestions for them.
    Set(Vec<(Parameter, f64)>),
}

/// A person store (one database, through [`crate::backend`]).
pub struct Store {
    pub(crate) conn: Conn,
    /// Events per person, keyed by (record count, last import id, app
    /// events): the logs only grow, so an unchanged key means unchanged
    /// records. An app-fed person's stream is brought up to date by
    /// loading only the events after its last one, when those are all the
    /// new ones (another replica or connection stored them).
    pub(crate) cache: StreamCache,
}

/// The event streams one connection keeps ([`Store`]'s `cache`), and how
/// they were loaded.
#[derive(Default)]
pub(crate) struct StreamCache {
    map: HashMap<i64, Cached>,
    loads: StreamLoads,
}

impl StreamCache {
    pub(crate) fn clear(&mut self) {
        self.map.clear();
    }

    pub(crate) fn remove(&mut self, person: &i64) {
        self.map.remove(person);
    }
}

/// How a connection's event streams were brought up to date since it was
/// opened ([`Store::stream_loads`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StreamLoads {
    /// Whole logs read.
    pub whole: u64,
    /// Cached app-fed streams extended by the events after their last one.
    pub tail: u64,
}

/// The most event streams one connection keeps.
const MAX_CACHED_STREAMS: usize = 8;

/// The most events the streams one connection keeps may hold together
/// (about 80 bytes each: some 20 MB, two years of one person's CGM); a
/// person's log larger than this is read whole on each use, not kept (a
/// service probe's 1.5 million readings in one log left each of the pool's
/// connections holding them: 1.2 GB after one import).
const MAX_CACHED_EVENTS: usize = 250_000;

pub(crate) struct Cached {
    key: (i64, i64, i64),
    records: usize,
    stream: Arc<EventStream>,
    /// Import-fed persons: what the records say (profiles, delivery, the
    /// first week); none for app-fed persons.
    facts: Option<Arc<RecordFacts>>,
    /// App-fed persons: the stream's last event with its (minute, seq).
    last_app: Option<AppEvent>,
}

/// Everything one refresh knows.
pub(crate) struct State {
    pub(crate) stream: Arc<EventStream>,
    pub(crate) records: usize,
    pub(crate) advisor: Abba,
    pub(crate) decisions: Vec<Decision>,
    pub(crate) answers: Answers,
    pub(crate) refused: usize,
    /// Changes in force (import-fed persons also the first week and the
    /// delivery); app-fed persons: the clinician's changes, if any.
    pub(crate) extras: Option<Extras>,
}

fn load_snapshot(conn: &dyn Db, person: i64) -> Result<Option<Snapshot>, StoreError> {
    let Some(r) = conn.row(Q::SnapshotGet, args![person])? else {
        return Ok(None);
    };
    let (events, events_hash, answers, unused, state) =
        (r.int(0)?, r.text(1)?, r.text(2)?, r.int(3)?, r.text(4)?);
    // An unreadable snapshot is only a lost shortcut: rebuild.
    let Ok(answers) = serde_json::from_str(&answers) else {
        return Ok(None);
    };
    Ok(Some(Snapshot {
        events: events as usize,
        events_hash,
        answers,
        unused: unused as usize,
        state,
    }))
}

/// An app-fed person's cached stream `c` brought up to `key` by appending
/// the events after its last one, when they are all the new events: the
/// last event is still held as cached, and the cached count plus the
/// events after it make the count now (events are only ever added while a
/// store is served; a late event, dated before the last one, and any
/// other change give `None`, and the caller loads the whole log).
fn app_tail(
    conn: &dyn Db,
    person: i64,
    mut c: Cached,
    key: (i64, i64, i64),
) -> Result<Option<Cached>, StoreError> {
    let Some(last) = c.last_app else {
        return Ok(None);
    };
    let app_fed = c.facts.is_none() && (c.key.0, c.key.1) == (0, 0) && (key.0, key.1) == (0, 0);
    if !app_fed || key.2 <= c.key.2 || crate::app::one(conn, person, last.seq)? != Some(last) {
        return Ok(None);
    }
    let tail = crate::app::load_after(conn, person, last.key())?;
    if c.key.2 + tail.len() as i64 != key.2 {
        return Ok(None);
    }
    crate::app::extend_stream(Arc::make_mut(&mut c.stream), &tail);
    c.records += tail.len();
    c.key = key;
    c.last_app = tail.last().copied().or(c.last_app);
    Ok(Some(c))
}

fn decisions(conn: &dyn Db, person: i64) -> Result<Vec<Decision>, StoreError> {
    let mut out: Vec<Decision> = Vec::new();
    for r in conn.rows(Q::SuggestionDecisions, args![person])? {
        out.push(
            serde_json::from_str(&r.text(0)?).map_err(|e| StoreError::corrupt("suggestion", e))?,
        );
    }
    Ok(out)
}

/// Replays the log (from the snapshot when usable), stores new decisions
/// and the new snapshot. Call inside a transaction.
pub(crate) fn refresh(
    conn: &dyn Db,
    cache: &mut StreamCache,
    person: &Person,
    use_snapshot: bool,
) -> Result<State, StoreError> {
    refresh_with(conn, cache, person, use_snapshot, true)
}

/// [`refresh`]; with `write` false nothing is stored (a read transaction:
/// the decisions are the stored ones with the replay's merged in).
pub(crate) fn refresh_with(
    conn: &dyn Db,
    cache: &mut StreamCache,
    person: &Person,
    use_snapshot: bool,
    write: bool,
) -> Result<State, StoreError> {
    let replayed = replay_log(conn, cache, person, use_snapshot)?;
    if write {
        store_replayed(conn, person, replayed)
    } else {
        Ok(merged_unstored(conn, person, replayed)?)
    }
}

/// A replay of a person's log, not stored yet ([`refresh_with`]): made in
/// a read transaction, then stored in a short write transaction while the
/// person's revision is the one it read ([`Store::live`]).
pub(crate) struct Replayed {
    stream: Arc<EventStream>,
    records: usize,
    r: replay::Replay,
    answers: Answers,
    refused: usize,
    extras: Option<Extras>,
}

/// Replays the person's log (from the snapshot when usable); stores
/// nothing.
pub(crate) fn replay_log(
    conn: &dyn Db,
    cache: &mut StreamCache,
    person: &Person,
    use_snapshot: bool,
) -> Result<Replayed, StoreError> {
    let r = conn.one(Q::RecordCountAndLastImport, args![person.id])?;
    let (n, last) = (r.int(0)?, r.int(1)?);
    let key = (n, last, crate::app::count(conn, person.id)?);
    let cached = cache.map.remove(&person.id);
    let current = match cached {
        Some(c) if c.key == key => Some(c),
        Some(c) => {
            let grown = app_tail(conn, person.id, c, key)?;
            cache.loads.tail += u64::from(grown.is_some());
            grown
        }
        None => None,
    };
    let (records, stream, facts, last_app) = match current {
        Some(c) => (c.records, c.stream, c.facts, c.last_app),
        None => {
            cache.loads.whole += 1;
            let (records, stream, facts, last_app) = if key.2 > 0 || key.0 == 0 {
                // An app-fed person: the events as the app posted them.
                // (A person with no data yet has no record facts either:
                // a first week "never ended" would keep the live advisor
                // that the app's first events advance from ever
                // initialising.)
                let app = crate::app::load(conn, person.id)?;
                let last_app = app.last().copied();
                (app.len(), crate::app::stream(person, &app), None, last_app)
            } else {
                let (recs, imports) = log::records_and_imports(conn, person.id)?;
                let n = recs.len();
                let (stream, facts) = in_force::record_facts(person, recs, &imports)?;
                (n, stream, Some(Arc::new(facts)), None)
            };
            (records, Arc::new(stream), facts, last_app)
        }
    };
    // Bounded: a connection serving many persons keeps only the streams of
    // a few (each is a person's whole log), and only so many events.
    let events = stream.events.len();
    let held: usize = cache.map.values().map(|c| c.stream.events.len()).sum();
    if cache.map.len() >= MAX_CACHED_STREAMS || held + events > MAX_CACHED_EVENTS {
        cache.map.clear();
    }
    if events <= MAX_CACHED_EVENTS {
        cache.map.insert(
            person.id,
            Cached {
                key,
                records,
                stream: Arc::clone(&stream),
                facts: facts.clone(),
                last_app,
            },
        );
    }
    let extras = match &facts {
        Some(f) => Some(in_force::extras(conn, person, f)?),
        None => in_force::app_extras(conn, person)?,
    };
    let answers = answer::load(conn, person.id)?;
    let snap = if use_snapshot {
        load_snapshot(conn, person.id)?
    } else {
        None
    };
    let r = replay::replay(
        person,
        &stream.events,
        &answers,
        snap.as_ref(),
        extras.as_ref(),
    )?;
    // Events refused in the whole log: those before the snapshot it started
    // from, and those of this replay. (The new snapshot's count stops at
    // its own checkpoint.)
    let refused = match (&snap, r.rebuilt) {
        (Some(s), false) => s.unused + r.refused.len(),
        _ => r.refused.len(),
    };
    Ok(Replayed {
        stream,
        records,
        r,
        answers,
        refused,
        extras,
    })
}

impl Replayed {
    /// The state, with `decisions` as the log's.
    fn into_state(self, decisions: Vec<Decision>) -> State {
        State {
            stream: self.stream,
            records: self.records,
            advisor: self.r.advisor,
            decisions,
            answers: self.answers,
            refused: self.refused,
            extras: self.extras,
        }
    }
}

/// The state of a replay without storing it: the decisions are the stored
/// ones with the replay's merged in.
fn merged_unstored(
    conn: &dyn Db,
    person: &Person,
    replayed: Replayed,
) -> Result<State, StoreError> {
    let mut all = if replayed.r.rebuilt {
        Vec::new()
    } else {
        decisions(conn, person.id)?
    };
    for d in &replayed.r.decisions {
        match all
            .iter_mut()
            .find(|x| x.at == d.at && x.parameter == d.parameter)
        {
            Some(x) => *x = d.clone(),
            None => all.push(d.clone()),
        }
    }
    all.sort_by_key(|d| (d.at, param_key(d.parameter)));
    Ok(replayed.into_state(all))
}

/// Stores a replay's decisions and its snapshot (inside a write
/// transaction); the state with every stored decision.
pub(crate) fn store_replayed(
    conn: &dyn Db,
    person: &Person,
    replayed: Replayed,
) -> Result<State, StoreError> {
    let r = &replayed.r;
    if r.rebuilt {
        conn.execute(Q::SuggestionDeleteAll, args![person.id])?;
    }
    crate::live::store_decisions(conn, person.id, &r.decisions)?;
    let s = &r.snapshot;
    let answers_json =
        serde_json::to_string(&s.answers).map_err(|e| StoreError::corrupt("snapshot", e))?;
    conn.execute(
        Q::SnapshotPut,
        args![
            person.id,
            s.events as i64,
            &s.events_hash,
            answers_json,
            s.unused as i64,
            &s.state
        ],
    )?;
    let mut all = decisions(conn, person.id)?;
    all.sort_by_key(|d| d.at);
    Ok(replayed.into_state(all))
}

impl Store {
    /// Opens or creates a store file.
    pub fn open(path: &Path) -> Result<Self, StoreError> {
        Ok(Self {
            conn: crate::schema::open(path)?,
            cache: StreamCache::default(),
        })
    }

    /// Checks that the store answers a query (a pooled connection's and
    /// `/healthz`'s check).
    pub fn ping(&self) -> Result<(), StoreError> {
        self.conn.one(Q::Ping, args![])?;
        Ok(())
    }

    /// True when the database was opened read-only (SQLite: the file, its
    /// folder or the medium).
    pub fn is_read_only(&self) -> Result<bool, StoreError> {
        self.conn.is_read_only()
    }

    /// SQLite's `synchronous` level in force (1 NORMAL, 2 FULL); a
    /// database server whose commits are durable when they return says 2.
    pub fn synchronous(&self) -> Result<i64, StoreError> {
        self.conn.synchronous()
    }

    /// The backend holding the store (`sqlite`, `postgres`).
    pub fn backend(&self) -> &'static str {
        self.conn.backend()
    }

    /// Claims the background job named `key` (a person's sync, say) for
    /// as long as this store stays open (on PostgreSQL the claim is
    /// released, and the server has said so, before the store's drop
    /// returns), when no other process holds it:
    /// two service replicas on one PostgreSQL database never do the same
    /// job at once. Always true on SQLite (one file, whose writers take
    /// turns anyway).
    pub fn claim(&self, key: &str) -> Result<bool, StoreError> {
        let k = abba_io::record::content_hash([b"abba job ".as_slice(), key.as_bytes()]);
        self.conn.try_lock(k as i64)
    }

    /// The imports of person `id`, oldest first.
    pub fn imports_of(&self, id: i64) -> Result<Vec<crate::import::ImportRow>, StoreError> {
        crate::import::imports(&self.conn, id)
    }

    /// Person `id`'s app event `seq`, if stored.
    pub fn app_event(&self, id: i64, seq: u64) -> Result<Option<crate::app::AppEvent>, StoreError> {
        crate::app::one(&self.conn, id, seq)
    }

    /// How many app events person `id` has.
    pub fn app_event_count(&self, id: i64) -> Result<i64, StoreError> {
        crate::app::count(&self.conn, id)
    }

    /// Creates a person.
    pub fn create_person(&mut self, p: &NewPerson) -> Result<Person, StoreError> {
        let tx = self.conn.transaction()?;
        let id = person::create(&tx, p)?;
        tx.commit()?;
        person::load_by_id(&self.conn, id)
    }

    /// A person by name.
    pub fn person(&self, name: &str) -> Result<Person, StoreError> {
        person::load(&self.conn, name)
    }

    /// Every person's name.
    pub fn persons(&self) -> Result<Vec<String>, StoreError> {
        person::names(&self.conn)
    }

    /// Imports a batch already read (one transaction).
    pub fn import(&mut self, name: &str, batch: &Batch) -> Result<ImportSummary, StoreError> {
        self.import_at(name, batch, jiff::Timestamp::now())
    }

    /// Imports a batch read at `now` (records dated after it are refused).
    pub fn import_at(
        &mut self,
        name: &str,
        batch: &Batch,
        now: jiff::Timestamp,
    ) -> Result<ImportSummary, StoreError> {
        let p = self.person(name)?;
        import::import(&mut self.conn, &p, batch, now)
    }

    /// Reads `files` (wall times in the person's zone) and imports them.
    /// Every file is read and checked before anything is written. A pump
    /// profile that differs from the therapy the store holds stops the
    /// import (see [`Store::import_files_with`]).
    pub fn import_files(
        &mut self,
        name: &str,
        files: &[PathBuf],
        format: Option<Format>,
    ) -> Result<ImportSummary, StoreError> {
        self.import_files_with(name, files, format, ProfileResolution::Stop, None)
    }

    /// Like [`Store::import_files`], saying what to do when the export's
    /// pump profile differs from the therapy the store holds: stop (with
    /// both values), adopt the profile, or keep the store's values; a
    /// CareLink export counting carbohydrate in exchanges is read with
    /// `grams_per_exchange` (see [`ReadOptions::grams_per_exchange`]).
    pub fn import_files_with(
        &mut self,
        name: &str,
        files: &[PathBuf],
        format: Option<Format>,
        resolve: ProfileResolution,
        grams_per_exchange: Option<f64>,
    ) -> Result<ImportSummary, StoreError> {
        let read = ReadOptions {
            format,
            grams_per_exchange,
            ..ReadOptions::default()
        };
        self.import_files_read(name, files, &read, resolve)
    }

    /// [`Store::import_files_with`] with every reading option the person
    /// gave (`abba import`'s flags: format, unit of values that do not say
    /// theirs, plain CSV's columns, date order, grams per exchange); the
    /// zone is the person's, whatever `read.tz` says.
    pub fn import_files_read(
        &mut self,
        name: &str,
        files: &[PathBuf],
        read: &ReadOptions,
        resolve: ProfileResolution,
    ) -> Result<ImportSummary, StoreError> {
        let mut contents = Vec::with_capacity(files.len());
        for f in files {
            let name = f.display().to_string();
            let bytes = std::fs::read(f).map_err(|source| abba_io::IoError::Open {
                file: name.clone(),
                source,
            })?;
            contents.push((name, bytes));
        }
        self.import_contents_read(
            name,
            &contents,
            read,
            resolve,
            jiff::Timestamp::now(),
            true,
            &mut |_| Ok(()),
        )
    }

    /// Reads files already in memory (name, bytes; wall times in the
    /// person's zone) and imports them read at `now`, in one transaction
    /// with what the pump profile changes in the person's settings (see
    /// [`Store::import_files_with`]), each file's loop evidence when
    /// `file_evidence`, and `also` (which runs just before the commit).
    #[allow(clippy::too_many_arguments)]
    pub fn import_contents_with(
        &mut self,
        name: &str,
        contents: &[(String, Vec<u8>)],
        format: Option<Format>,
        resolve: ProfileResolution,
        now: jiff::Timestamp,
        file_evidence: bool,
        also: &mut dyn FnMut(&dyn Db) -> Result<(), StoreError>,
    ) -> Result<ImportSummary, StoreError> {
        let read = ReadOptions {
            format,
            ..ReadOptions::default()
        };
        self.import_contents_read(name, contents, &read, resolve, now, file_evidence, also)
    }

    /// [`Store::import_contents_with`] with the reading options `read`
    /// (its `tz` is the person's, whatever `read` says; a CareLink export
    /// in exchanges needs its `grams_per_exchange`).
    #[allow(clippy::too_many_arguments)]
    pub fn import_contents_read(
        &mut self,
        name: &str,
        contents: &[(String, Vec<u8>)],
        read: &ReadOptions,
        resolve: ProfileResolution,
        now: jiff::Timestamp,
        file_evidence: bool,
        also: &mut dyn FnMut(&dyn Db) -> Result<(), StoreError>,
    ) -> Result<ImportSummary, StoreError> {
        let p = self.person(name)?;
        let opts = ReadOptions {
            tz: Some(p.tz.clone()),
            ..read.clone()
        };
        let mut batch = read_all(contents, &opts)?;
        // Records that cannot be true (before 1990) are out before the
        // profile is compared: counted, reported by the import.
        batch.refuse_too_old();
        let new_settings = profile_check(&self.conn, &p, &batch, contents, &opts, resolve)?;
        if let Some(doc) = &new_settings {
            // Checked in full before anything is written.
            let mut q = p.clone();
            q.settings = doc.clone();
            q.advisor()?;
            person::check_start(doc)?;
        }
        // What the files say about loops (kept with the log when
        // `file_evidence`), and what they and their records show of the
        // delivery, for the import's words.
        // (A sync keeps its own: its words then come from the records.)
        let evidence: Vec<Evidence> = match file_evidence {
            true => contents
                .iter()
                .enumerate()
                .map(|(i, (_, bytes))| Evidence {
                    clocks: batch.clocks.get(i).cloned().unwrap_or_default(),
                    ..Evidence::from_file_with(bytes, &opts)
                })
                .collect(),
            false => Vec::new(),
        };
        let mut summary = import::import_with(&mut self.conn, &p, &batch, now, &mut |tx| {
            if let Some(doc) = &new_settings {
                person::update_settings(tx, p.id, doc)?;
            }
            if file_evidence {
                for ((name, bytes), e) in contents.iter().zip(&evidence) {
                    in_force::store_file_evidence(tx, p.id, &p.tz, name, bytes, e)?;
                }
            }
            also(tx)
        })?;
        // As the advice tells it: by the files' last days
        // (`in_force::record_facts`), a loop given up before them is past.
        let recent_from = abba_io::automation::recent_from_ms(&batch.records);
        let mut shown =
            Evidence::from_records_since(&batch.records, &p.tz, recent_from.unwrap_or(i64::MAX));
        for e in &evidence {
            shown.add_file_since(e, recent_from);
        }
        summary.delivery = match shown.delivery() {
            d @ (Delivery::ClosedLoop | Delivery::Injections) => Some(import::DeliveryShown {
                delivery: d,
                allowed: p.settings.allow_closed_loop,
            }),
            _ => None,
        };
        self.cache.remove(&p.id);
        Ok(summary)
    }

    /// Records a change of therapy by the clinician, in force from `at`
    /// (default: now) whether or not a suggestion is open, for a person fed
    /// by imports or by the app alike; the advisor's next update starts
    /// from it (a change before the last event rebuilds the advisor from
    /// there; one before the person's day 1 is refused). `basal`: a
    /// schedule (one segment: a flat rate); values not given stay.
    pub fn set_therapy(
        &mut self,
        name: &str,
        basal: Option<Vec<(u32, f64)>>,
        carb_ratio: Option<[f64; 3]>,
        at: Option<jiff::Timestamp>,
    ) -> Result<in_force::TherapyChange, StoreError> {
        let p = self.person(name)?;
        let (at, change) = make_change(&p, basal, carb_ratio, at, "abba therapy set")?;
        let tx = self.conn.transaction()?;
        in_force::insert_change(&tx, p.id, at, &change)?;
        refresh(&tx, &mut self.cache, &p, true)?;
        tx.commit()?;
        Ok(change)
    }

    /// The person's records, in the log's order: every record stored,
    /// those set aside for a fuller source and those before day 1
    /// included (the raw log, as the person gave it). Whatever derives the person's days or events reads
    /// [`Store::used_records`].
    pub fn records(&self, name: &str) -> Result<Vec<Record>, StoreError> {
        log::records(&self.conn, self.person(name)?.id)
    }

    /// The person's records that their days and events are made from, in
    /// the log's order: those on or after day 1, one source for each kind
    /// of data on each local day ([`crate::day_1::used`]), with what was
    /// left out.
    pub fn used_records(&self, name: &str) -> Result<crate::one_source::Chosen, StoreError> {
        log::used(&self.conn, &self.person(name)?)
    }

    /// The person's device events (from the records used, see
    /// [`Store::used_records`]).
    pub fn events(&self, name: &str) -> Result<Vec<Event>, StoreError> {
        let p = self.person(name)?;
        if crate::app::count(&self.conn, p.id)? > 0 {
            let app = crate::app::load(&self.conn, p.id)?;
            return Ok(app.iter().map(|e| e.event).collect());
        }
        Ok(log::events(&p, log::records(&self.conn, p.id)?)?.events)
    }

    fn state(&mut self, name: &str, use_snapshot: bool) -> Result<(Person, State), StoreError> {
        let p = self.person(name)?;
        let tx = self.conn.transaction()?;
        let s = refresh(&tx, &mut self.cache, &p, use_snapshot)?;
        tx.commit()?;
        Ok((p, s))
    }

    /// [`Store::state`] from the snapshot in a read transaction that
    /// writes nothing (no write lock taken).
    fn state_read(&mut self, name: &str) -> Result<(Person, State), StoreError> {
        let p = self.person(name)?;
        let tx = self.conn.read_transaction()?;
        let s = refresh_with(&tx, &mut self.cache, &p, true, false)?;
        tx.commit()?;
        Ok((p, s))
    }

    /// [`Store::advise`] in a read transaction that writes nothing, its
    /// words in `unit` (a report's page may use another unit than the
    /// person's own).
    pub fn advise_read(&mut self, name: &str, unit: GlucoseUnit) -> Result<Advice, StoreError> {
        let (mut p, s) = self.state_read(name)?;
        p.settings.units = unit;
        Ok(Self::advice_of(&p, &s))
    }

    /// The advisor after the whole log, from the snapshot when it matches.
    pub fn advisor(&mut self, name: &str) -> Result<Abba, StoreError> {
        Ok(self.state(name, true)?.1.advisor)
    }

    /// How this connection's event streams were brought up to date.
    pub fn stream_loads(&self) -> StreamLoads {
        self.cache.loads
    }

    /// The advisor rebuilt from scratch (the snapshot ignored and replaced).
    pub fn rebuild(&mut self, name: &str) -> Result<Abba, StoreError> {
        Ok(self.state(name, false)?.1.advisor)
    }

    /// Every decision of the log with its explanation, oldest first.
    pub fn decisions(&mut self, name: &str) -> Result<Vec<Decision>, StoreError> {
        Ok(self.state(name, true)?.1.decisions)
    }

    /// Today's advice.
    pub fn advise(&mut self, name: &str) -> Result<Advice, StoreError> {
        let (p, s) = self.state(name, true)?;
        Ok(Self::advice_of(&p, &s))
    }

    /// [`Store::advise`] with each open suggestion's predicted effect and
    /// the twin check ([`crate::effect::predict`]).
    pub fn advise_with(
        &mut self,
        name: &str,
        effects: Option<crate::effect::Effects<'_>>,
    ) -> Result<Advice, StoreError> {
        let (p, s) = self.state(name, true)?;
        let mut a = Self::advice_of(&p, &s);
        crate::effect::predict(&mut a, &s.stream.events, effects);
        Ok(a)
    }

    fn advice_of(p: &Person, s: &State) -> Advice {
        advise::advice_with(
            p,
            &s.stream,
            s.records,
            &s.advisor,
            &s.decisions,
            &s.answers,
            s.refused,
            s.extras.as_ref(),
        )
    }

    /// Every decision with the answer and the value in force, oldest first.
    pub fn history(&mut self, name: &str) -> Result<Vec<SuggestionView>, StoreError> {
        let (p, s) = self.state(name, true)?;
        Ok(advise::views_with(
            &p,
            &s.decisions,
            &s.answers,
            s.extras.as_ref(),
        ))
    }

    /// [`Store::history`] in a read transaction that writes nothing (no
    /// write lock: a report is read while another writer, an import,
    /// holds the store); the reasons in `unit`.
    pub fn history_read(
        &mut self,
        name: &str,
        unit: GlucoseUnit,
    ) -> Result<Vec<SuggestionView>, StoreError> {
        let (mut p, s) = self.state_read(name)?;
        p.settings.units = unit;
        Ok(advise::views_with(
            &p,
            &s.decisions,
            &s.answers,
            s.extras.as_ref(),
        ))
    }

    /// Records the person's answer to the open suggestions (one transaction).
    pub fn answer(&mut self, name: &str, req: &AnswerRequest) -> Result<Vec<Answer>, StoreError> {
        let p = self.person(name)?;
        let tx = self.conn.transaction()?;
        let s = refresh(&tx, &mut self.cache, &p, true)?;
        let views = advise::views_with(&p, &s.decisions, &s.answers, s.extras.as_ref());
        let open: Vec<&SuggestionView> = views.iter().filter(|v| v.status == "open").collect();
        if open.is_empty() {
            return Err(StoreError::Answer(
                "nothing to answer: there is no open suggestion (run `abba advise` to see what is in force)".into(),
            ));
        }
        let now = jiff::Timestamp::now().to_string();
        let make =
            |v: &SuggestionView, kind: AnswerKind, in_force: f64| -> Result<Answer, StoreError> {
                let parameter = answer::parse_param(v.setting)
                    .ok_or_else(|| StoreError::corrupt("suggestion", v.setting))?;
                let at_min = s
                    .decisions
                    .iter()
                    .rev()
                    .find(|d| param_key(d.parameter) == v.setting)
                    .map(|d| d.at.0)
                    .ok_or_else(|| StoreError::corrupt("suggestion", v.setting))?;
                Ok(Answer {
                    at_min,
                    parameter,
                    kind,
                    suggested: v.suggested,
                    previous: v.previous,
                    in_force,
                    answered_at: now.clone(),
                })
            };
        let mut out = Vec::new();
        match req {
            AnswerRequest::Accept => {
                for v in &open {
                    out.push(make(v, AnswerKind::Accepted, v.suggested)?);
                }
            }
            AnswerRequest::Reject => {
                for v in &open {
                    out.push(make(v, AnswerKind::Rejected, v.previous)?);
                }
            }
            AnswerRequest::Set(values) => {
                for &(param, value) in values {
                    let key = param_key(param);
                    let v = open.iter().find(|v| v.setting == key).ok_or_else(|| {
                        let names: Vec<&str> = open.iter().map(|v| v.setting).collect();
                        StoreError::Answer(format!(
                            "--set {key}: there is no open suggestion for the {param}; open: {}",
                            names.join(", ")
                        ))
                    })?;
                    check_value(&p, param, value)?;
                    out.push(make(v, AnswerKind::Overridden, value)?);
                }
            }
        }
        answer::insert(&tx, p.id, &out)?;
        // The new answers change the advisor from their decision on: rebuild
        // now so the stored snapshot and suggestions include them.
        refresh(&tx, &mut self.cache, &p, true)?;
        tx.commit()?;
        Ok(out)
    }
}

/// A clinician's change checked (the plausibility limits, the bounds, not
/// in the future, day 1 known) and placed on the advisor's clock; `by`
/// names who recorded it.
pub(crate) fn make_change(
    p: &Person,
    basal: Option<Vec<(u32, f64)>>,
    carb_ratio: Option<[f64; 3]>,
    at: Option<jiff::Timestamp>,
    by: &str,
) -> Result<(jiff::Timestamp, in_force::TherapyChange), StoreError> {
    if basal.is_none() && carb_ratio.is_none() {
        return Err(StoreError::invalid(
            "abba therapy set",
            "give --basal and/or --carb-ratio",
        ));
    }
    in_force::check_change(p, basal.as_deref(), carb_ratio)?;
    let at = at.unwrap_or_else(jiff::Timestamp::now);
    in_force::not_future(at, "--at")?;
    let Some(first) = p.first_day else {
        return Err(StoreError::invalid(
            "abba therapy set",
            format!("{} has no data yet: day 1 is not known (import first, or create the person with these values)", p.name),
        ));
    };
    let clock = abba_io::clock::AdvisorClock::new(p.tz.clone(), first);
    let ts = clock.timestamp(at);
    if ts.day_index() < 0 {
        // Not clamped to day 1: a change before the data is a wrong date.
        return Err(StoreError::invalid(
            "--at",
            format!(
                "{at} is before {}'s day 1: expected an instant on or after {first} 00:00 ({})",
                p.name,
                p.tz.iana_name().unwrap_or("the person's zone")
            ),
        ));
    }
    let change = in_force::TherapyChange {
        at: ts,
        instant: at.to_string(),
        basal,
        carb_ratio,
        source: in_force::ChangeSource::Clinician,
        origin: format!("the clinician ({by})"),
    };
    Ok((at, change))
}

/// What an import does when the export's pump profile differs from the
/// therapy the store holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProfileResolution {
    /// Stop with both values and how to resolve it.
    Stop,
    /// Put the profile in force (`--adopt-profile`).
    Adopt,
    /// Keep the store's values (`--keep-therapy`).
    Keep,
}

/// The settings profile in force at the person's first glucose reading (or
/// the earliest one) against the store's therapy. Returns the person's new
/// settings when they change.
fn profile_check(
    conn: &dyn Db,
    p: &Person,
    batch: &Batch,
    contents: &[(String, Vec<u8>)],
    opts: &ReadOptions,
    resolve: ProfileResolution,
) -> Result<Option<person::PersonSettingsDoc>, StoreError> {
    use person::TherapySource;
    if p.settings.therapy_source != TherapySource::Given {
        return Ok(None);
    }
    let meals = &p.settings.meal_windows;
    let mut profiles = abba_io::therapy::settings_profiles(batch, meals)?;
    let store_cr = p.settings.start.carb_ratio.map(|c| c.0);
    for ((name, bytes), format) in contents.iter().zip(&batch.formats) {
        match format {
            // Settings the reader could not read are in the batch's notes
            // ("counted, not read"); the readable ones are compared.
            Format::Tidepool | Format::TidepoolXlsx => profiles.extend(
                abba_io::therapy::tidepool_pump_settings_readable(name, bytes, meals)?,
            ),
            // A CareLink export without Basal Rate rows or a full day says
            // nothing about the settings: nothing to compare.
            Format::CareLink => {
                if let Ok(c) = abba_io::therapy::carelink_settings(name, bytes, opts, meals)? {
                    profiles.push(c.or_held(meals, store_cr)?);
                }
            }
            _ => {}
        }
    }
    // A temporary profile (an AndroidAPS Profile Switch with a duration)
    // is not the person's settings: the permanent ones are compared.
    profiles.retain(|t| t.temporary_min.is_none());
    profiles.sort_by_key(|t| t.at);
    if profiles.is_empty() {
        return Ok(None);
    }
    // The first reading: of the log if it has one from day 1 (readings
    // before day 1 are stored, not used: [`crate::day_1`]), else of this
    // batch.
    let day_1_ms = match p.first_day {
        Some(d) => d
            .to_zoned(p.tz.clone())
            .map_err(|e| StoreError::corrupt("day 1", e))?
            .timestamp()
            .as_millisecond(),
        None => i64::MIN,
    };
    let logged = conn
        .one(Q::RecordFirstGlucose, args![p.id, day_1_ms])?
        .opt_int(0)?;
    let first = logged
        .and_then(|ms| jiff::Timestamp::from_millisecond(ms).ok())
        .or_else(|| abba_io::events::first_glucose(&batch.records).map(|r| r.at));
    let at_start = first
        .and_then(|f| profiles.iter().rev().find(|t| t.at <= f))
        .unwrap_or(&profiles[0]);
    let store_basal = p
        .settings
        .basal_schedule
        .clone()
        .unwrap_or_else(|| vec![(0, p.settings.start.basal.0)]);
    let mut doc = p.settings.clone();
    if at_start.same_settings(&store_basal, store_cr) {
        doc.therapy_source = TherapySource::Profile;
        return Ok(Some(doc));
    }
    match resolve {
        ProfileResolution::Stop => {
            let [b, l, d] = store_cr;
            let held = if store_basal.len() == 1 {
                format!("basal {} U/h", store_basal[0].1)
            } else {
                format!(
                    "basal schedule with mean {:.3} U/h",
                    p.settings.start.basal.0
                )
            };
            Err(StoreError::ProfileDiffers {
                origin: at_start.origin.clone(),
                difference: format!(
                    "the pump's profile ({}) differs from the therapy the store holds for {} ({held}, carb ratios {b}/{l}/{d} g/U). Nothing was imported.",
                    at_start.describe(),
                    p.name
                ),
            })
        }
        ProfileResolution::Adopt => {
            doc.start = at_start.settings();
            doc.basal_schedule = (at_start.basal.len() > 1).then(|| at_start.basal.clone());
            doc.therapy_source = TherapySource::Profile;
            Ok(Some(doc))
        }
        ProfileResolution::Keep => {
            doc.therapy_source = TherapySource::Kept;
            Ok(Some(doc))
        }
    }
}

/// A value the person puts in force must lie within the plausibility
/// limits of [`abba_core::limits`] and the clinician's bounds.
/// Checks that a value the person puts in force (an override: `abba
/// answer --set`, `POST .../answers`, the Today page's own value) is one
/// their pump can be set to: a multiple of the pump's step for the
/// setting, when the person has steps. Never rounded: the error names the
/// step and the two nearest values on it (the caller names the field).
pub fn on_pump_step(p: &Person, param: Parameter, v: f64) -> Result<(), String> {
    let Some(steps) = p.settings.pump_steps else {
        return Ok(());
    };
    let (step, what) = match param {
        Parameter::Basal => (steps.basal_u_per_h, "basal"),
        Parameter::CarbRatio(_) => (steps.carb_ratio_g_per_u, "carb-ratio"),
    };
    if !v.is_finite() || abba_advisor::steps::on_step(v, step) {
        return Ok(());
    }
    let k = (v / step).floor() as i64;
    let (below, above) = (
        abba_advisor::steps::multiple(k, step),
        abba_advisor::steps::multiple(k + 1, step),
    );
    let unit = param.unit();
    Err(format!(
        "{v} {unit} is not on the pump's {what} step ({step} {unit}): the nearest values the pump can be set to are {below} and {above} {unit} (abba does not round a value put in force)"
    ))
}

/// Checks a value put in force for `param` against the plausibility
/// limits, the pump's step ([`on_pump_step`]) and the clinician's bounds.
pub(crate) fn check_value(p: &Person, param: Parameter, v: f64) -> Result<(), StoreError> {
    let field = format!("--set {}", param_key(param));
    let limit = match param {
        Parameter::Basal => abba_core::limits::BASAL_U_PER_H,
        Parameter::CarbRatio(_) => abba_core::limits::CARB_RATIO_G_PER_U,
    };
    limit
        .check(v)
        .map_err(|e| StoreError::invalid(field.clone(), e.to_string()))?;
    on_pump_step(p, param, v).map_err(|m| StoreError::invalid(field.clone(), m))?;
    if let Some(r) = p.settings.bounds.range(param) {
        if !r.contains(v) {
            return Err(StoreError::invalid(
                field,
                format!(
                    "{v} {} is outside the clinician's bounds {}-{}",
                    param.unit(),
                    r.min,
                    r.max
                ),
            ));
        }
    }
    Ok(())
}
