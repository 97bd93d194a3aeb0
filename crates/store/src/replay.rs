//! The advisor as a function of the log: events (from records) with the
//! person's answers placed right after the decisions they answer, fed to a
//! fresh advisor. A snapshot (the advisor's state after the first `n`
//! events) is only a shortcut: it is used when those `n` events and the
//! answers placed among them are exactly what it was made from, and tests
//! check that resuming from it gives the state a rebuild gives.

use crate::answer::{param_key, Answers};
use crate::error::StoreError;
use crate::person::Person;
use abba_advisor::{Abba, Advisor, Decision, DecisionDetail};
use abba_core::{Event, EventKind};
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

fn usable(snap: &Snapshot, events: &[Event], answers: &Answers) -> bool {
    if snap.events == 0 || snap.events > events.len() {
        return false;
    }
    if events_hash(&events[..snap.events]) != snap.events_hash {
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

/// Replays `events` with `answers` for `person`, from `snapshot` when it
/// is usable.
pub fn replay(
    person: &Person,
    events: &[Event],
    answers: &Answers,
    snapshot: Option<&Snapshot>,
) -> Result<Replay, StoreError> {
    let (mut advisor, start, mut applied, mut unused, rebuilt) = match snapshot {
        Some(s) if usable(s, events, answers) => (
            Abba::load_json(&s.state)?,
            s.events,
            s.answers.clone(),
            s.unused,
            false,
        ),
        _ => (person.advisor()?, 0, Vec::new(), 0, true),
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
                events_hash: events_hash(&events[..c.index]),
                answers: applied,
                unused: c.unused,
                state: c.advisor.save_json()?,
            }
        }
        None => {
            applied.sort();
            Snapshot {
                events: events.len(),
                events_hash: events_hash(events),
                answers: applied,
                unused,
                state: advisor.save_json()?,
            }
        }
    };
    Ok(Replay {
        advisor,
        decisions,
        rebuilt,
        refused,
        snapshot,
    })
}
