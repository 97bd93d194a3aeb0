//! The advisor as a function of the log: events (from records) with the
//! person's answers placed right after the decisions they answer, fed to a
//! fresh advisor. A snapshot (the advisor's state after the first `n`
//! events) is only a shortcut: it is used when those `n` events and the
//! answers placed among them are exactly what it was made from, and tests
//! check that resuming from it gives the state a rebuild gives.

use crate::answer::{param_key, Answers};
use crate::error::StoreError;
use crate::in_force::{Extras, TherapyChange};
use crate::person::Person;
use abba_advisor::{Abba, Advisor, Decision, DecisionDetail, Parameter};
use abba_core::{Event, EventKind, GramsPerUnit, SettingValue, UnitsPerHour};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, VecDeque};

/// A saved advisor state and what it was made from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Events consumed.
    pub events: usize,
    /// Hash of those events (hex).
    pub events_hash: String,
    /// Answers placed among them: (decision minute, setting).
    pub answers: Vec<(i64, String)>,
    /// Events the advisor refused among them.
    pub unused: usize,
    /// The advisor's state (JSON).
    pub state: String,
}

/// The outcome of a replay.
#[derive(Debug, Clone)]
pub struct Replay {
    /// The advisor after every event.
    pub advisor: Abba,
    /// Decisions made during this replay, oldest first.
    pub decisions: Vec<Decision>,
    /// True when the replay started from scratch (then `decisions` holds
    /// every decision of the log).
    pub rebuilt: bool,
    /// Events the advisor refused in this replay, with its reason.
    pub refused: Vec<(Event, String)>,
    /// A snapshot of the end state.
    pub snapshot: Snapshot,
}

/// How many checkpoints a replay keeps.
const CHECKPOINTS: usize = 12;

struct Checkpoint {
    index: usize,
    advisor: Abba,
    applied: Vec<(i64, String)>,
    unused: usize,
}

/// True when the minute starting at `events[i]` holds a decision point
/// (a day's close or a main meal's announcement).
fn decision_minute(events: &[Event], i: usize) -> bool {
    events[i..]
        .iter()
        .take_while(|e| e.at == events[i].at)
        .any(|e| match e.kind {
            EventKind::DayClosed => true,
            EventKind::MealAnnounced { slot, .. } => slot.main_index().is_some(),
            _ => false,
        })
}

/// Hash of a list of events (FNV-1a over each event's minute and its
/// serialised kind; a kind's JSON is only built for the rare non-reading
/// events).
pub fn events_hash(events: &[Event]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for e in events {
        eat(&e.at.0.to_le_bytes());
        match e.kind {
            EventKind::Cgm(g) => {
                eat(&[1]);
                eat(&g.0.to_bits().to_le_bytes());
            }
            EventKind::Smbg(g) => {
                eat(&[2]);
                eat(&g.0.to_bits().to_le_bytes());
            }
            other => eat(&serde_json::to_vec(&other).unwrap_or_default()),
        }
    }
    format!("{h:016x}")
}

/// The hash a snapshot of the first `n` events carries: the events', and
/// (for an import-fed person) what else the replay applied up to them.
pub(crate) fn prefix_hash(events: &[Event], n: usize, extras: Option<&Extras>) -> String {
    let h = events_hash(&events[..n]);
    match extras {
        None => h,
        Some(x) => format!(
            "{h}/{}",
            x.hash_until(n.checked_sub(1).map(|i| events[i].at))
        ),
    }
}

fn usable(snap: &Snapshot, events: &[Event], answers: &Answers, extras: Option<&Extras>) -> bool {
    if snap.events == 0 || snap.events > events.len() {
        return false;
    }
    if prefix_hash(events, snap.events, extras) != snap.events_hash {
        return false;
    }
    let last = events[snap.events - 1].at.0;
    let before: Vec<(i64, String)> = answers
        .keys()
        .filter(|(at, _)| *at <= last)
        .map(|(at, p)| (*at, (*p).to_string()))
        .collect();
    let mut saved = snap.answers.clone();
    saved.sort();
    before == saved
}

/// Puts a change of therapy in force (values it leaves out stay).
fn apply_change(advisor: &mut Abba, c: &TherapyChange) -> Result<(), StoreError> {
    let mut settings = *advisor.settings();
    if let Some(cr) = c.carb_ratio {
        settings.carb_ratio = cr.map(GramsPerUnit);
    }
    let schedule = match &c.basal {
        Some(b) if b.len() > 1 || advisor.basal_schedule().is_some() => Some(b.clone()),
        Some(b) => {
            settings.basal = UnitsPerHour(b[0].1);
            None
        }
        None => advisor.basal_schedule().cloned(),
    };
    advisor.set_therapy(schedule, settings)?;
    Ok(())
}

/// Replays `events` with `answers` for `person`, from `snapshot` when it
/// is usable. `extras`: therapy changes put in force at their time (an
/// app-fed person: the clinician's); import-fed persons also the first
/// week's end and basal updates held.
pub fn replay(
    person: &Person,
    events: &[Event],
    answers: &Answers,
    snapshot: Option<&Snapshot>,
    extras: Option<&Extras>,
) -> Result<Replay, StoreError> {
    let fresh = || -> Result<Abba, StoreError> {
        let a = person.advisor()?;
        Ok(match extras {
            Some(x) if !x.fed_by_app => {
                // A window's readings are counted at the sensor's own
                // period when it is longer than the person's rule says
                // (a FreeStyle Libre's 15 minutes against 5).
                let mut rule = person.settings.min_data;
                let period = u32::try_from(x.first_week.cgm_period_min).unwrap_or(0);
                rule.cgm_period_min = rule.cgm_period_min.max(period);
                a.with_min_data(rule).with_first_week_end(x.first_week.end)
            }
            _ => a,
        })
    };
    let (mut advisor, start, mut applied, mut unused, rebuilt) = match snapshot {
        Some(s) if usable(s, events, answers, extras) => (
            Abba::load_json(&s.state)?,
            s.events,
            s.answers.clone(),
            s.unused,
            false,
        ),
        _ => (fresh()?, 0, Vec::new(), 0, true),
    };
    let no_changes = Vec::new();
    let changes = extras.map_or(&no_changes, |x| &x.changes);
    let hold_basal = extras.is_some_and(|x| x.hold_basal);
    // Changes before the snapshot's last event are in its state.
    let mut next_change = match start {
        0 => 0,
        n => changes.partition_point(|c| c.at <= events[n - 1].at),
    };
    let mut decisions = Vec::new();
    let mut refused = Vec::new();
    // States at the start of the last minutes holding a decision point: the
    // snapshot is taken before the earliest open suggestion, so answering
    // it does not invalidate the snapshot.
    let mut checkpoints: VecDeque<Checkpoint> = VecDeque::new();
    for (i, e) in events.iter().enumerate().skip(start) {
        let minute_start = i == 0 || events[i - 1].at != e.at;
        if minute_start && i > start && decision_minute(events, i) {
            if checkpoints.len() == CHECKPOINTS {
                checkpoints.pop_front();
            }
            checkpoints.push_back(Checkpoint {
                index: i,
                advisor: advisor.clone(),
                applied: applied.clone(),
                unused,
            });
        }
        while let Some(c) = changes.get(next_change).filter(|c| c.at <= e.at) {
            apply_change(&mut advisor, c)?;
            next_change += 1;
        }
        if let Err(err) = advisor.observe(e) {
            unused += 1;
            refused.push((*e, err.to_string()));
            continue;
        }
        for d in advisor.take_decisions() {
            let key = (d.at.0, param_key(d.parameter));
            if let Some(a) = answers.get(&key) {
                let answer = Event::new(d.at, a.event_kind());
                advisor.observe(&answer)?;
                applied.push((key.0, key.1.to_string()));
            } else if hold_basal && d.parameter == Parameter::Basal && d.new != d.old {
                // Not offered (a loop or injections): the basal stays.
                let keep = SettingValue::Basal {
                    rate: UnitsPerHour(d.old),
                };
                advisor.observe(&Event::new(d.at, EventKind::SuggestionRejected(keep)))?;
            } else if d.new != d.old && !extras.is_none_or(|x| x.shown(d.at)) {
                // Never shown (made and followed by the next within one
                // import, the history a first import brings): not taken as
                // followed; the value in force stays what the pump had.
                let keep = match d.parameter {
                    Parameter::Basal => SettingValue::Basal {
                        rate: UnitsPerHour(d.old),
                    },
                    Parameter::CarbRatio(slot) => SettingValue::CarbRatio {
                        slot,
                        ratio: GramsPerUnit(d.old),
                    },
                };
                advisor.observe(&Event::new(d.at, EventKind::SuggestionRejected(keep)))?;
            }
            decisions.push(d);
        }
    }
    let mut latest: BTreeMap<&str, &Decision> = BTreeMap::new();
    for d in &decisions {
        latest.insert(param_key(d.parameter), d);
    }
    let earliest_open = latest
        .values()
        .filter(|d| !matches!(d.detail, DecisionDetail::Skipped { .. }))
        .filter(|d| d.new != d.old)
        .filter(|d| !(hold_basal && d.parameter == Parameter::Basal))
        .filter(|d| !answers.contains_key(&(d.at.0, param_key(d.parameter))))
        .map(|d| d.at)
        .min();
    let cp = earliest_open.and_then(|t| checkpoints.iter().find(|c| events[c.index].at == t));
    let snapshot = match cp {
        Some(c) => {
            let mut applied = c.applied.clone();
            applied.sort();
            Snapshot {
                events: c.index,
                events_hash: prefix_hash(events, c.index, extras),
                answers: applied,
                unused: c.unused,
                state: c.advisor.save_json()?,
            }
        }
        None => {
            applied.sort();
            Snapshot {
                events: events.len(),
                events_hash: prefix_hash(events, events.len(), extras),
                answers: applied,
                unused,
                state: advisor.save_json()?,
            }
        }
    };
    // Changes after the last event are in force now (not in the snapshot).
    for c in &changes[next_change.min(changes.len())..] {
        apply_change(&mut advisor, c)?;
    }
    Ok(Replay {
        advisor,
        decisions,
        rebuilt,
        refused,
        snapshot,
    })
}
