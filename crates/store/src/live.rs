//! The service's side of the store: a person's advisor kept live in memory
//! and advanced by each committed batch of app events, answers to single
//! suggestions, clinician bounds by person id, tokens.
//!
//! A [`Live`] is what a replay of the log gives (events, advisor,
//! decisions, answers); feeding it the new events of a batch in the
//! advisor's order gives the same state a replay of the longer log would,
//! because decisions are a pure function of the events and answers. A
//! batch holding an event earlier than the last one fed, an answer or new
//! bounds rebuild it from the store (snapshot + replay) instead. Every
//! decision is stored in the suggestion table as it is made, in the
//! batch's transaction, so `abba advise` on the same file sees it.

use crate::advise;
use crate::answer::{self, param_key, Answer, AnswerKind, Answers};
use crate::app::{self, AppEvent, NewAppEvent};
use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use crate::in_force::{Extras, TherapyChange};
use crate::person::{self, Person};
use crate::replay::prefix_hash;
use crate::store::{refresh, State, Store};
use crate::token::{self, Role, StoredToken};
use abba_advisor::{Abba, Advisor, ClinicianBounds, Decision, DecisionDetail, Parameter};
use abba_core::EventKind;
use abba_io::events::{kind_name, EventStream};
use std::path::Path;
use std::sync::Arc;

/// A person's advisor and log as the service keeps them in memory.
#[derive(Debug, Clone)]
pub struct Live {
    /// The person.
    pub person: Person,
    /// The events fed so far (the whole log, in the advisor's order).
    pub stream: EventStream,
    /// Records (app events or imported records) in the log.
    pub records: usize,
    /// The advisor after every event.
    pub advisor: Abba,
    /// Every decision, oldest first.
    pub decisions: Vec<Decision>,
    /// Every answer.
    pub answers: Answers,
    /// Events the advisor refused.
    pub refused: usize,
    /// What the replay applied besides the events (therapy changes; for an
    /// import-fed person also the first week and the delivery).
    pub extras: Option<Extras>,
    /// The person's revision in the store this state reflects (see
    /// [`Store::person_rev`]): another revision means someone else wrote.
    pub rev: i64,
    /// (minute, seq) of the last app event fed.
    last: Option<(i64, u64)>,
    /// The decisions the last event fed produced (answers to them can go
    /// to the advisor at once: a replay would feed them right there).
    last_produced: Vec<(i64, Parameter)>,
}

/// A decision made while feeding a batch, with the app event that made it.
#[derive(Debug, Clone, PartialEq)]
pub struct Produced {
    /// The decision.
    pub decision: Decision,
    /// The seq of the event that produced it (`None` after a rebuild when
    /// the event is not known).
    pub seq: Option<u64>,
}

/// What a posted batch did.
#[derive(Debug, Clone, PartialEq)]
pub struct Posted {
    /// Events stored now, in the advisor's order.
    pub stored: Vec<AppEvent>,
    /// Sequence numbers already held with the same payload.
    pub repeated: Vec<u64>,
    /// Decisions the new events produced, in the advisor's order.
    pub produced: Vec<Produced>,
    /// True when the batch held an event earlier than the last one fed and
    /// the advisor was rebuilt from the store.
    pub rebuilt: bool,
}

/// One answer to one suggestion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SuggestionAnswer {
    /// The decision's advisor minute.
    pub at_min: i64,
    /// Its setting.
    pub parameter: Parameter,
    /// What the person did.
    pub kind: AnswerKind,
    /// The value put in force (overrides only).
    pub value: Option<f64>,
}

fn last_key(conn: &dyn Db, person: i64) -> Result<Option<(i64, u64)>, StoreError> {
    conn.row(Q::AppEventLastKey, args![person])?
        .map(|r| Ok((r.int(0)?, r.int(1)? as u64)))
        .transpose()
}

/// Stores decisions in the suggestion table (a cache of the log's
/// decisions; inside the caller's transaction).
pub(crate) fn store_decisions(
    conn: &dyn Db,
    person: i64,
    decisions: &[Decision],
) -> Result<(), StoreError> {
    for d in decisions {
        let json = serde_json::to_string(d).map_err(|e| StoreError::corrupt("suggestion", e))?;
        let skipped = matches!(d.detail, DecisionDetail::Skipped { .. });
        conn.execute(
            Q::SuggestionPut,
            args![
                person,
                d.at.0,
                param_key(d.parameter),
                d.old,
                d.new,
                skipped,
                json
            ],
        )?;
    }
    Ok(())
}

/// The person's revision: bumped by the store's triggers on every write
/// to what a live advisor is built from (0 before any).
pub(crate) fn rev(conn: &dyn Db, person: i64) -> Result<i64, StoreError> {
    Ok(conn
        .row(Q::PersonRev, args![person])?
        .map(|r| r.int(0))
        .transpose()?
        .unwrap_or(0))
}

fn from_state(person: Person, s: State, last: Option<(i64, u64)>, rev: i64) -> Live {
    Live {
        rev,
        person,
        stream: Arc::try_unwrap(s.stream).unwrap_or_else(|a| (*a).clone()),
        records: s.records,
        advisor: s.advisor,
        decisions: s.decisions,
        answers: s.answers,
        refused: s.refused,
        extras: s.extras,
        last,
        last_produced: Vec::new(),
    }
}

/// Saves the live advisor as the store's snapshot (a shortcut for the next
/// rebuild; checked against the log when used). A change put in force
/// after the last event (see [`Extras::applied_after`]) is in the state
/// but not in the hash: a replay from it puts the change in force again
/// before the next event, which changes nothing (the same values).
fn save_snapshot(conn: &dyn Db, live: &Live) -> Result<(), StoreError> {
    let events = &live.stream.events;
    let last = events.last().map_or(i64::MIN, |e| e.at.0);
    let mut answers: Vec<(i64, String)> = live
        .answers
        .keys()
        .filter(|(at, _)| *at <= last)
        .map(|(at, p)| (*at, (*p).to_string()))
        .collect();
    answers.sort();
    let answers =
        serde_json::to_string(&answers).map_err(|e| StoreError::corrupt("snapshot", e))?;
    conn.execute(
        Q::SnapshotPut,
        args![
            live.person.id,
            events.len() as i64,
            prefix_hash(events, events.len(), live.extras.as_ref()),
            answers,
            live.refused as i64,
            live.advisor.save_json()?
        ],
    )?;
    Ok(())
}

/// Feeds `new` (sorted, all after `live.last`) to the live advisor and
/// stores the decisions; saves a snapshot at the start of each minute that
/// closes a day.
fn feed(conn: &dyn Db, live: &mut Live, new: &[AppEvent]) -> Result<Vec<Produced>, StoreError> {
    let mut produced = Vec::new();
    for (i, e) in new.iter().enumerate() {
        let prev = live.stream.events.last().map(|p| p.at);
        let minute_start = prev != Some(e.event.at);
        let closes_day = new[i..]
            .iter()
            .take_while(|x| x.event.at == e.event.at)
            .any(|x| x.event.kind == EventKind::DayClosed);
        if minute_start && closes_day && !live.stream.events.is_empty() {
            save_snapshot(conn, live)?;
        }
        if live.advisor.observe(&e.event).is_err() {
            live.refused += 1;
        }
        live.stream.events.push(e.event);
        *live
            .stream
            .counts
            .entry(kind_name(&e.event.kind).into())
            .or_default() += 1;
        live.records += 1;
        live.last = Some(e.key());
        live.last_produced.clear();
        let decisions = live.advisor.take_decisions();
        store_decisions(conn, live.person.id, &decisions)?;
        for d in decisions {
            live.last_produced.push((d.at.0, d.parameter));
            produced.push(Produced {
                decision: d.clone(),
                seq: Some(e.seq),
            });
            live.decisions.push(d);
        }
    }
    Ok(produced)
}

impl Live {
    /// Every decision with its answer and the value in force (as
    /// [`advise::views_with`] with what the replay applied).
    pub fn views(&self) -> Vec<advise::SuggestionView> {
        advise::views_with(
            &self.person,
            &self.decisions,
            &self.answers,
            self.extras.as_ref(),
        )
    }

    /// Today's advice (as `abba advise` on the same store).
    pub fn advice(&self) -> advise::Advice {
        advise::advice_with(
            &self.person,
            &self.stream,
            self.records,
            &self.advisor,
            &self.decisions,
            &self.answers,
            self.refused,
            self.extras.as_ref(),
        )
    }

    /// [`Live::advice`] with each open suggestion's predicted effect and
    /// the twin check ([`crate::effect::predict`]).
    pub fn advice_with(&self, effects: Option<crate::effect::Effects<'_>>) -> advise::Advice {
        let mut a = self.advice();
        crate::effect::predict(&mut a, &self.stream.events, effects);
        a
    }
}

fn same(a: &Decision, b: &Decision) -> bool {
    a.at == b.at && a.parameter == b.parameter
}

impl Store {
    /// Opens a store for the service: like [`Store::open`] with
    /// `synchronous=FULL`, so a commit is on disk before it returns.
    pub fn open_durable(path: &Path) -> Result<Self, StoreError> {
        Ok(Self {
            conn: crate::schema::open_with(path, crate::schema::Sync::Full)?,
            cache: Default::default(),
        })
    }

    /// Like [`Store::open_durable`], waiting at most `busy` for another
    /// writer before SQLite answers busy (the service's setting).
    pub fn open_service(path: &Path, busy: std::time::Duration) -> Result<Self, StoreError> {
        Ok(Self {
            conn: crate::schema::open_opts(path, crate::schema::Sync::Full, busy)?,
            cache: Default::default(),
        })
    }

    /// A person by row id.
    pub fn person_by_id(&self, id: i64) -> Result<Person, StoreError> {
        person::load_by_id(&self.conn, id)
    }

    /// The person's live state, rebuilt from the store (snapshot + replay).
    pub fn live(&mut self, id: i64) -> Result<Live, StoreError> {
        // The replay (a year of CGM: ~0.2 s) in a read transaction, then
        // only its decisions and snapshot stored under the write lock while
        // the person's revision is still the one replayed: an app posting
        // late events to a long log held SQLite's one writer for every
        // replay, and other persons' writes waited past the busy timeout.
        let read = self.conn.read_transaction()?;
        let p = person::load_by_id(&read, id)?;
        let replayed = crate::store::replay_log(&read, &mut self.cache, &p, true)?;
        let read_rev = rev(&read, id)?;
        read.commit()?;
        let tx = self.conn.transaction_for(id)?;
        let (p, s) = if rev(&tx, id)? == read_rev {
            let s = crate::store::store_replayed(&tx, &p, replayed)?;
            (p, s)
        } else {
            // Written meanwhile: replayed again, holding the lock.
            let p = person::load_by_id(&tx, id)?;
            let s = refresh(&tx, &mut self.cache, &p, true)?;
            (p, s)
        };
        let last = last_key(&tx, id)?;
        let r = rev(&tx, id)?;
        tx.commit()?;
        Ok(from_state(p, s, last, r))
    }

    /// The person's live state built in a read transaction that writes
    /// nothing (for read-only requests: no write lock taken, nothing
    /// cached by the caller).
    pub fn live_read(&mut self, id: i64) -> Result<Live, StoreError> {
        let p = person::load_by_id(&self.conn, id)?;
        let tx = self.conn.read_transaction()?;
        let s = crate::store::refresh_with(&tx, &mut self.cache, &p, true, false)?;
        let last = last_key(&tx, id)?;
        let r = rev(&tx, id)?;
        tx.commit()?;
        Ok(from_state(p, s, last, r))
    }

    /// The person's revision now (compare with [`Live::rev`]).
    pub fn person_rev(&self, id: i64) -> Result<i64, StoreError> {
        rev(&self.conn, id)
    }

    /// Stores a batch of app events in one transaction and advances `live`
    /// (which must be this person's current state). The batch is committed
    /// before this returns `Ok`. On an error nothing of the batch is stored
    /// and the caller must drop `live` (it may be partly advanced).
    pub fn post_events(
        &mut self,
        live: &mut Live,
        batch: &[NewAppEvent],
    ) -> Result<Posted, StoreError> {
        self.post(live, batch, None)
    }

    /// Like [`Store::post_events`] for events entered on the web pages,
    /// which have no app counter: the batch's `seq`s are replaced by the
    /// person's next free numbers (one above the highest held), read in
    /// the insert's own transaction, so two entries never share a number.
    ///
    /// With `once` (a web form's submission key, [`crate::submission`]) the
    /// batch is stored only if that submission was not made before, and
    /// the key is kept with the seqs in the same transaction: the same
    /// form sent again stores nothing and gets the first seqs back (as
    /// `repeated`).
    ///
    /// The numbers never pass [`app::MAX_SEQ`], the API's limit (2^53 − 1,
    /// exact in every JSON implementation): numbering web entries after the
    /// highest seq held keeps them from colliding with any number already
    /// given, and once an app has used the top of the range no number above
    /// it is left, so the entry is refused (nothing stored) rather than
    /// numbered where an app could never sync it.
    pub fn post_events_next_seq(
        &mut self,
        live: &mut Live,
        batch: &[NewAppEvent],
        once: Option<&crate::submission::SubmissionKey>,
    ) -> Result<Posted, StoreError> {
        self.post(live, batch, Some(once))
    }

    /// `next_seq`: `None` for the app's own numbers, `Some(once)` for the
    /// next free ones (with a web form's submission key).
    fn post(
        &mut self,
        live: &mut Live,
        batch: &[NewAppEvent],
        next_seq: Option<Option<&crate::submission::SubmissionKey>>,
    ) -> Result<Posted, StoreError> {
        let id = live.person.id;
        let mut tx = self.conn.transaction_for(id)?;
        // Someone else wrote for this person since `live` was built (the
        // CLI, another process): rebuild it first, holding the write lock
        // so nothing else comes in between.
        if rev(&tx, id)? != live.rev {
            drop(tx);
            *live = self.live(id)?;
            tx = self.conn.transaction_for(id)?;
            if rev(&tx, id)? != live.rev {
                return Err(StoreError::corrupt(
                    "person revision",
                    "changed while the write lock was held",
                ));
            }
        }
        let numbered: Vec<NewAppEvent>;
        let once = next_seq.flatten();
        if let Some(key) = once {
            if let Some(outcome) = crate::submission::get(&tx, id, key)? {
                return Ok(Posted {
                    stored: Vec::new(),
                    repeated: crate::submission::outcome_seqs(&outcome)?,
                    produced: Vec::new(),
                    rebuilt: false,
                });
            }
        }
        let batch = if next_seq.is_some() {
            let base = app::last_seq(&tx, id)?.map_or(0, |s| s + 1);
            let last = base.saturating_add(batch.len() as u64).saturating_sub(1);
            if !batch.is_empty() && last > app::MAX_SEQ {
                return Err(StoreError::Feed(format!(
                    "no event number is left for this entry: an app numbered an event {}, the largest number the API allows (2^53 - 1), and entries made here are numbered after the highest one held; nothing was stored",
                    base - 1
                )));
            }
            numbered = batch
                .iter()
                .zip(base..)
                .map(|(e, seq)| NewAppEvent { seq, ..e.clone() })
                .collect();
            &numbered[..]
        } else {
            batch
        };
        let mut person = live.person.clone();
        let ins = app::insert(&tx, &mut person, batch)?;
        if let Some(key) = once {
            let seqs: Vec<u64> = ins.new.iter().map(|e| e.seq).collect();
            crate::submission::put(
                &tx,
                id,
                key,
                &crate::submission::seqs_outcome(&seqs),
                jiff::Timestamp::now().as_millisecond(),
            )?;
        }
        // A clinician's change already put in force after the last event
        // fed: an event before it must see the old therapy (a rebuild).
        let pending = live
            .extras
            .as_ref()
            .and_then(|x| x.applied_after(live.stream.events.last().map(|e| e.at)));
        let in_order = match (ins.new.first(), live.last) {
            (Some(first), Some(last)) => {
                first.key() > last && pending.is_none_or(|p| first.event.at >= p)
            }
            (Some(first), None) => pending.is_none_or(|p| first.event.at >= p),
            _ => true,
        };
        live.person = person;
        if in_order {
            let produced = feed(&tx, live, &ins.new)?;
            live.rev = rev(&tx, id)?;
            tx.commit()?;
            return Ok(Posted {
                stored: ins.new,
                repeated: ins.repeated,
                produced,
                rebuilt: false,
            });
        }
        tx.commit()?;
        let before = std::mem::take(&mut live.decisions);
        *live = self.live(live.person.id)?;
        let mut produced = Vec::new();
        for d in &live.decisions {
            if before.iter().any(|b| same(b, d) && b.new == d.new) {
                continue;
            }
            let slot = match d.parameter {
                Parameter::Basal => None,
                Parameter::CarbRatio(s) => Some(s),
            };
            let seq = app::producer(&self.conn, live.person.id, d.at.0, slot)?;
            produced.push(Produced {
                decision: d.clone(),
                seq,
            });
        }
        Ok(Posted {
            stored: ins.new,
            repeated: ins.repeated,
            produced,
            rebuilt: true,
        })
    }

    /// Records answers to single open suggestions (one transaction) and
    /// rebuilds `live`. Returns the answers, in the order of `items`, and
    /// the later decisions whose value changed. An answer the store holds
    /// already, the same (an app sending it again after a lost reply), is
    /// acknowledged again as stored, and nothing is written for it.
    pub fn answer_suggestions(
        &mut self,
        live: &mut Live,
        items: &[SuggestionAnswer],
    ) -> Result<(Vec<Answer>, Vec<Decision>), StoreError> {
        let views = live.views();
        let now = jiff::Timestamp::now().to_string();
        let mut out = Vec::new();
        // Every answer in the order asked: the new ones (`out`) and those
        // held already.
        let mut all: Vec<Answer> = Vec::new();
        for (i, item) in items.iter().enumerate() {
            let field = format!("answers[{i}].suggestion_id");
            let Some(k) = live
                .decisions
                .iter()
                .position(|d| d.at.0 == item.at_min && d.parameter == item.parameter)
            else {
                return Err(StoreError::NoSuggestion(field));
            };
            let (d, v) = (&live.decisions[k], &views[k]);
            let held = live
                .answers
                .get(&(item.at_min, param_key(item.parameter)))
                .filter(|a| {
                    a.kind == item.kind
                        && match item.value {
                            Some(x) => (a.in_force - x).abs() < 1e-9,
                            None => item.kind != AnswerKind::Overridden,
                        }
                });
            if let Some(a) = held {
                if all
                    .iter()
                    .any(|b: &Answer| b.at_min == item.at_min && b.parameter == item.parameter)
                {
                    return Err(StoreError::invalid(
                        field,
                        "the suggestion is answered twice",
                    ));
                }
                all.push(a.clone());
                continue;
            }
            if v.status != "open" {
                return Err(StoreError::Answer(format!(
                    "{field}: the suggestion is {} (only the latest suggestion of a setting, with an update and not yet answered, can be answered)",
                    v.status
                )));
            }
            if out
                .iter()
                .any(|a: &Answer| a.at_min == item.at_min && a.parameter == item.parameter)
            {
                return Err(StoreError::invalid(
                    field,
                    "the suggestion is answered twice",
                ));
            }
            let in_force = match (item.kind, item.value) {
                (AnswerKind::Accepted, None) => d.new,
                (AnswerKind::Rejected, None) => d.old,
                (AnswerKind::Overridden, Some(x)) => {
                    crate::store::check_value(&live.person, item.parameter, x)
                        .map_err(|e| relabel(e, &format!("answers[{i}].value")))?;
                    x
                }
                (AnswerKind::Overridden, None) => {
                    return Err(StoreError::invalid(
                        format!("answers[{i}].value"),
                        "an override needs the value put in force",
                    ))
                }
                (_, Some(_)) => {
                    return Err(StoreError::invalid(
                        format!("answers[{i}].value"),
                        "a value goes only with an override",
                    ))
                }
            };
            let a = Answer {
                at_min: item.at_min,
                parameter: item.parameter,
                kind: item.kind,
                suggested: d.new,
                previous: d.old,
                in_force,
                answered_at: now.clone(),
            };
            all.push(a.clone());
            out.push(a);
        }
        if out.is_empty() {
            // Every answer was held already: nothing to write.
            return Ok((all, Vec::new()));
        }
        let id = live.person.id;
        // Answers to what the last event fed decided: a replay would feed
        // them right after it, so the live advisor takes them now (in the
        // order of its decisions) and nothing later changes.
        let at_once = out
            .iter()
            .all(|a| live.last_produced.contains(&(a.at_min, a.parameter)));
        if at_once {
            let tx = self.conn.transaction_for(id)?;
            answer::insert(&tx, id, &out)?;
            let mut ordered: Vec<&Answer> = out.iter().collect();
            ordered.sort_by_key(|a| {
                live.last_produced
                    .iter()
                    .position(|k| *k == (a.at_min, a.parameter))
            });
            for a in ordered {
                let at = abba_core::Timestamp(a.at_min);
                live.advisor
                    .observe(&abba_core::Event::new(at, a.event_kind()))?;
                live.answers
                    .insert((a.at_min, param_key(a.parameter)), a.clone());
            }
            let more = live.advisor.take_decisions();
            store_decisions(&tx, id, &more)?;
            live.decisions.extend(more);
            live.rev = rev(&tx, id)?;
            tx.commit()?;
            return Ok((all, Vec::new()));
        }
        let p = person::load_by_id(&self.conn, id)?;
        let tx = self.conn.transaction_for(id)?;
        answer::insert(&tx, id, &out)?;
        let s = refresh(&tx, &mut self.cache, &p, true)?;
        let last = last_key(&tx, id)?;
        let r = rev(&tx, id)?;
        tx.commit()?;
        let before = std::mem::take(&mut live.decisions);
        *live = from_state(p, s, last, r);
        let changed = live
            .decisions
            .iter()
            .filter(|d| before.iter().any(|b| same(b, d) && b.new != d.new))
            .cloned()
            .collect();
        Ok((all, changed))
    }

    /// Records a clinician's change of therapy for the person (as
    /// [`Store::set_therapy`], `by` naming who) and rebuilds `live` with it.
    pub fn set_therapy_by_id(
        &mut self,
        id: i64,
        basal: Option<Vec<(u32, f64)>>,
        carb_ratio: Option<[f64; 3]>,
        at: Option<jiff::Timestamp>,
        by: &str,
    ) -> Result<(TherapyChange, Live), StoreError> {
        let p = person::load_by_id(&self.conn, id)?;
        let (at, change) = crate::store::make_change(&p, basal, carb_ratio, at, by)?;
        let tx = self.conn.transaction_for(id)?;
        crate::in_force::insert_change(&tx, id, at, &change)?;
        let s = refresh(&tx, &mut self.cache, &p, true)?;
        let last = last_key(&tx, id)?;
        let r = rev(&tx, id)?;
        tx.commit()?;
        Ok((change, from_state(p, s, last, r)))
    }

    /// Replaces a person's clinician bounds and rebuilds the advisor from
    /// scratch (the stored snapshot carries the old bounds). Each setting's
    /// value in force now (after the clinician's changes and the answers,
    /// as the advice shows it) must lie inside the bounds.
    pub fn set_bounds_by_id(
        &mut self,
        id: i64,
        bounds: ClinicianBounds,
    ) -> Result<Live, StoreError> {
        let tx = self.conn.transaction_for(id)?;
        let now = person::load_by_id(&tx, id)?;
        let s = refresh(&tx, &mut self.cache, &now, true)?;
        let advice = from_state(now, s, None, 0).advice();
        let in_force = |p: Parameter| {
            let key = param_key(p);
            advice
                .settings
                .iter()
                .find(|x| x.setting == key)
                .map_or(f64::NAN, |x| x.in_force)
        };
        let p = person::set_bounds(&tx, id, bounds, in_force)?;
        let s = refresh(&tx, &mut self.cache, &p, false)?;
        let last = last_key(&tx, id)?;
        let r = rev(&tx, id)?;
        tx.commit()?;
        Ok(from_state(p, s, last, r))
    }

    /// Replaces a person's pump steps (checked: steps pumps use) and
    /// rebuilds the advisor from scratch, as [`Store::set_bounds_by_id`].
    pub fn set_pump_steps_by_id(
        &mut self,
        id: i64,
        steps: abba_advisor::PumpSteps,
    ) -> Result<Live, StoreError> {
        steps.validate()?;
        let bounds = person::load_by_id(&self.conn, id)?.settings.bounds;
        bounds.check_steps(steps)?;
        self.change_settings_by_id(id, |s| s.pump_steps = Some(steps))
    }

    /// Changes a person's settings with `change` and rebuilds the advisor
    /// from scratch, in one transaction: the whole advisor as it will be
    /// built is checked before the write.
    fn change_settings_by_id(
        &mut self,
        id: i64,
        change: impl FnOnce(&mut person::PersonSettingsDoc),
    ) -> Result<Live, StoreError> {
        let tx = self.conn.transaction_for(id)?;
        let mut p = person::load_by_id(&tx, id)?;
        change(&mut p.settings);
        p.advisor()?;
        person::update_settings(&tx, id, &p.settings)?;
        let s = refresh(&tx, &mut self.cache, &p, false)?;
        let last = last_key(&tx, id)?;
        let r = rev(&tx, id)?;
        tx.commit()?;
        Ok(from_state(p, s, last, r))
    }

    /// Makes the person one of `group` (its defaults applied to the
    /// advisor's configuration, see [`abba_advisor::AgeGroup`]) and rebuilds
    /// the advisor from scratch, as [`Store::set_bounds_by_id`]: every
    /// decision is replayed with the group's basal hours.
    pub fn set_age_group_by_id(
        &mut self,
        id: i64,
        group: abba_advisor::AgeGroup,
    ) -> Result<Live, StoreError> {
        self.change_settings_by_id(id, |s| s.set_age_group(group))
    }

    /// The tokens of a role (a person's, or the admin's), newest first.
    pub fn tokens_of(&self, role: Role) -> Result<Vec<token::TokenRow>, StoreError> {
        token::list(&self.conn, role)
    }

    /// Stores a new token's hash (one transaction); returns its id.
    pub fn insert_token(&mut self, hash: &[u8; 32], role: Role) -> Result<i64, StoreError> {
        let tx = self.conn.transaction()?;
        let id = token::insert(&tx, hash, role)?;
        tx.commit()?;
        Ok(id)
    }

    /// Tokens whose hash starts like `hash` (compare the whole hash in
    /// constant time).
    pub fn token_candidates(&self, hash: &[u8; 32]) -> Result<Vec<StoredToken>, StoreError> {
        token::candidates(&self.conn, hash)
    }

    /// Revokes a token (one transaction); the last admin token that is
    /// not revoked cannot be (nobody could administer the store any more).
    pub fn revoke_token(&mut self, id: i64) -> Result<(), StoreError> {
        let tx = self.conn.transaction()?;
        token::revoke(&tx, id)?;
        tx.commit()?;
        Ok(())
    }

    /// The id of the latest suggestion (by advisor minute, then setting
    /// basal, breakfast, lunch, dinner): `minute × 4 + setting`.
    pub fn latest_suggestion_id(&self, person: i64) -> Result<Option<u64>, StoreError> {
        let v = self
            .conn
            .one(Q::SuggestionLatestId, args![person])?
            .opt_int(0)?;
        Ok(v.map(|x| x.max(0) as u64))
    }

    /// Held app sequence numbers ≥ `from` as ranges, and whether more follow.
    pub fn held_ranges(
        &self,
        person: i64,
        from: u64,
        max: usize,
    ) -> Result<(Vec<(u64, u64)>, bool), StoreError> {
        app::held_ranges(&self.conn, person, from, max)
    }

    /// The highest app sequence number held.
    pub fn last_seq(&self, person: i64) -> Result<Option<u64>, StoreError> {
        app::last_seq(&self.conn, person)
    }

    /// The seq of the app event that made the decision `d`, if known.
    pub fn producer(&self, person: i64, d: &Decision) -> Result<Option<u64>, StoreError> {
        let slot = match d.parameter {
            Parameter::Basal => None,
            Parameter::CarbRatio(s) => Some(s),
        };
        app::producer(&self.conn, person, d.at.0, slot)
    }
}

fn relabel(e: StoreError, field: &str) -> StoreError {
    match e {
        StoreError::Invalid { problem, .. } => StoreError::invalid(field, problem),
        other => other,
    }
}
