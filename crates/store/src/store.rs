//! The store: a SQLite file of persons, and the operations the CLI calls.

use crate::advise::{self, Advice, SuggestionView};
use crate::answer::{self, param_key, Answer, AnswerKind, Answers};
use crate::error::StoreError;
use crate::import::{self, ImportSummary};
use crate::log;
use crate::person::{self, NewPerson, Person};
use crate::replay::{self, Snapshot};
use abba_advisor::{Abba, Decision, DecisionDetail, Parameter};
use abba_core::Event;
use abba_io::events::EventStream;
use abba_io::read::{read_files, Batch, Format, ReadOptions};
use abba_io::Record;
use rusqlite::{params, Connection, OptionalExtension};
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

/// A person store (one SQLite file).
pub struct Store {
    pub(crate) conn: Connection,
    /// Events per person, keyed by (record count, last import id, app
    /// events): the logs only grow, so an unchanged key means unchanged
    /// records.
    pub(crate) cache: HashMap<i64, Cached>,
}

/// The most event streams one connection keeps.
const MAX_CACHED_STREAMS: usize = 8;

pub(crate) struct Cached {
    key: (i64, i64, i64),
    records: usize,
    stream: Arc<EventStream>,
}

/// Everything one refresh knows.
pub(crate) struct State {
    pub(crate) stream: Arc<EventStream>,
    pub(crate) records: usize,
    pub(crate) advisor: Abba,
    pub(crate) decisions: Vec<Decision>,
    pub(crate) answers: Answers,
    pub(crate) refused: usize,
}

fn load_snapshot(conn: &Connection, person: i64) -> Result<Option<Snapshot>, StoreError> {
    let row = conn
        .query_row(
            "SELECT events, events_hash, answers, unused, state FROM snapshot WHERE person_id = ?1",
            params![person],
            |r| {
                Ok((
                    r.get::<_, i64>(0)?,
                    r.get::<_, String>(1)?,
                    r.get::<_, String>(2)?,
                    r.get::<_, i64>(3)?,
                    r.get::<_, String>(4)?,
                ))
            },
        )
        .optional()?;
    let Some((events, events_hash, answers, unused, state)) = row else {
        return Ok(None);
    };
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

fn decisions(conn: &Connection, person: i64) -> Result<Vec<Decision>, StoreError> {
    let mut st = conn.prepare(
        "SELECT decision FROM suggestion WHERE person_id = ?1 ORDER BY at_min, parameter",
    )?;
    let rows = st.query_map(params![person], |r| r.get::<_, String>(0))?;
    let mut out: Vec<Decision> = Vec::new();
    for r in rows {
        out.push(serde_json::from_str(&r?).map_err(|e| StoreError::corrupt("suggestion", e))?);
    }
    Ok(out)
}

/// Replays the log (from the snapshot when usable), stores new decisions
/// and the new snapshot. Call inside a transaction.
pub(crate) fn refresh(
    conn: &Connection,
    cache: &mut HashMap<i64, Cached>,
    person: &Person,
    use_snapshot: bool,
) -> Result<State, StoreError> {
    refresh_with(conn, cache, person, use_snapshot, true)
}

/// [`refresh`]; with `write` false nothing is stored (a read transaction:
/// the decisions are the stored ones with the replay's merged in).
pub(crate) fn refresh_with(
    conn: &Connection,
    cache: &mut HashMap<i64, Cached>,
    person: &Person,
    use_snapshot: bool,
    write: bool,
) -> Result<State, StoreError> {
    let (n, last): (i64, i64) = conn.query_row(
        "SELECT count(*), coalesce(max(import_id), 0) FROM record WHERE person_id = ?1",
        params![person.id],
        |r| Ok((r.get(0)?, r.get(1)?)),
    )?;
    let key = (n, last, crate::app::count(conn, person.id)?);
    let (records, stream) = match cache.get(&person.id) {
        Some(c) if c.key == key => (c.records, Arc::clone(&c.stream)),
        _ => {
            let (records, stream) = if key.2 > 0 {
                // An app-fed person: the events as the app posted them.
                let app = crate::app::load(conn, person.id)?;
                (app.len(), crate::app::stream(person, &app))
            } else {
                let recs = log::records(conn, person.id)?;
                (recs.len(), log::events(person, recs)?)
            };
            let stream = Arc::new(stream);
            // Bounded: a connection serving many persons keeps only the
            // streams of a few (each is a person's whole log).
            if cache.len() >= MAX_CACHED_STREAMS {
                cache.clear();
            }
            cache.insert(
                person.id,
                Cached {
                    key,
                    records,
                    stream: Arc::clone(&stream),
                },
            );
            (records, stream)
        }
    };
    let answers = answer::load(conn, person.id)?;
    let snap = if use_snapshot {
        load_snapshot(conn, person.id)?
    } else {
        None
    };
    let r = replay::replay(person, &stream.events, &answers, snap.as_ref())?;
    // Events refused in the whole log: those before the snapshot it started
    // from, and those of this replay. (The new snapshot's count stops at
    // its own checkpoint.)
    let refused = match (&snap, r.rebuilt) {
        (Some(s), false) => s.unused + r.refused.len(),
        _ => r.refused.len(),
    };
    if !write {
        let mut all = if r.rebuilt {
            Vec::new()
        } else {
            decisions(conn, person.id)?
        };
        for d in &r.decisions {
            match all
                .iter_mut()
                .find(|x| x.at == d.at && x.parameter == d.parameter)
            {
                Some(x) => *x = d.clone(),
                None => all.push(d.clone()),
            }
        }
        all.sort_by_key(|d| (d.at, param_key(d.parameter)));
        return Ok(State {
            stream,
            records,
            advisor: r.advisor,
            decisions: all,
            answers,
            refused,
        });
    }
    if r.rebuilt {
        conn.execute(
            "DELETE FROM suggestion WHERE person_id = ?1",
            params![person.id],
        )?;
    }
    {
        let mut st = conn.prepare(
            "INSERT OR REPLACE INTO suggestion (person_id, at_min, parameter, old, new, skipped, decision) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
        )?;
        for d in &r.decisions {
            let json =
                serde_json::to_string(d).map_err(|e| StoreError::corrupt("suggestion", e))?;
            let skipped = matches!(d.detail, DecisionDetail::Skipped { .. });
            st.execute(params![
                person.id,
                d.at.0,
                param_key(d.parameter),
                d.old,
                d.new,
                skipped,
                json
            ])?;
        }
    }
    let s = &r.snapshot;
    let answers_json =
        serde_json::to_string(&s.answers).map_err(|e| StoreError::corrupt("snapshot", e))?;
    conn.execute(
        "INSERT OR REPLACE INTO snapshot (person_id, events, events_hash, answers, unused, state) VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
        params![person.id, s.events as i64, s.events_hash, answers_json, s.unused as i64, s.state],
    )?;
    let mut all = decisions(conn, person.id)?;
    all.sort_by_key(|d| d.at);
    Ok(State {
        stream,
        records,
        advisor: r.advisor,
        decisions: all,
        answers,
        refused,
    })
}

impl Store {
    /// Opens or creates a store file.
    pub fn open(path: &Path) -> Result<Self, StoreError> {
        Ok(Self {
            conn: crate::schema::open(path)?,
            cache: HashMap::new(),
        })
    }

    /// The SQLite connection (for checks and tests).
    pub fn connection(&self) -> &Connection {
        &self.conn
    }

    /// Creates a person.
    pub fn create_person(&mut self, p: &NewPerson) -> Result<Person, StoreError> {
        let tx = self.conn.transaction()?;
        person::create(&tx, p)?;
        tx.commit()?;
        self.person(&p.name)
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
    /// Every file is read and checked before anything is written.
    pub fn import_files(
        &mut self,
        name: &str,
        files: &[PathBuf],
        format: Option<Format>,
    ) -> Result<ImportSummary, StoreError> {
        let p = self.person(name)?;
        let opts = ReadOptions {
            format,
            tz: Some(p.tz.clone()),
            ..ReadOptions::default()
        };
        let batch = read_files(files, &opts)?;
        import::import(&mut self.conn, &p, &batch, jiff::Timestamp::now())
    }

    /// The person's records, in the log's order.
    pub fn records(&self, name: &str) -> Result<Vec<Record>, StoreError> {
        log::records(&self.conn, self.person(name)?.id)
    }

    /// The person's device events (from the records).
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

    /// The advisor after the whole log, from the snapshot when it matches.
    pub fn advisor(&mut self, name: &str) -> Result<Abba, StoreError> {
        Ok(self.state(name, true)?.1.advisor)
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
        Ok(advise::advice(
            &p,
            &s.stream,
            s.records,
            &s.advisor,
            &s.decisions,
            &s.answers,
            s.refused,
        ))
    }

    /// Every decision with the answer and the value in force, oldest first.
    pub fn history(&mut self, name: &str) -> Result<Vec<SuggestionView>, StoreError> {
        let (p, s) = self.state(name, true)?;
        Ok(advise::views(&p, &s.decisions, &s.answers))
    }

    /// Records the person's answer to the open suggestions (one transaction).
    pub fn answer(&mut self, name: &str, req: &AnswerRequest) -> Result<Vec<Answer>, StoreError> {
        let p = self.person(name)?;
        let tx = self.conn.transaction()?;
        let s = refresh(&tx, &mut self.cache, &p, true)?;
        let views = advise::views(&p, &s.decisions, &s.answers);
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

/// A value the person puts in force must be a positive finite number
/// within the clinician's bounds and the advisor's plausibility limits.
pub(crate) fn check_value(p: &Person, param: Parameter, v: f64) -> Result<(), StoreError> {
    let field = format!("--set {}", param_key(param));
    let limit = match param {
        Parameter::Basal => p.settings.advisor.limits.basal_max_u_per_h,
        Parameter::CarbRatio(_) => p.settings.advisor.limits.carbs_max_g,
    };
    if !(v.is_finite() && v > 0.0 && v <= limit) {
        return Err(StoreError::invalid(
            field,
            format!(
                "expected a number in (0, {limit}] {}, got {v}",
                param.unit()
            ),
        ));
    }
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
