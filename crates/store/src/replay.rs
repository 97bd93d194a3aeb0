//! The advisor as a function of the log: events (from records) with the
//! person's answers placed right after the decisions they answer, fed to a
//! fresh advisor. A snapshot (the advisor's state after the first `n`
//! events) is only a shortcut: it is used when those `n` events and the
//! answers placed among them are exactly what it was made from, and tests
//! check that resuming from it gives the state a rebuild gives.

use crate::answer::{param_key, Answers};
use crate::error::StoreError;
use crate::person::Person;
use abba_advisor::{Abba, Advisor, Decision};
use abba_core::Event;
use serde::{Deserialize, Serialize};

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

/// Hash of a list of events.
pub fn events_hash(events: &[Event]) -> String {
    let parts: Vec<Vec<u8>> = events
        .iter()
        .map(|e| serde_json::to_vec(e).unwrap_or_default())
        .collect();
    format!(
        "{:016x}",
        abba_io::record::content_hash(parts.iter().map(Vec::as_slice))
    )
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
    for e in &events[start..] {
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
    applied.sort();
    let snapshot = Snapshot {
        events: events.len(),
        events_hash: events_hash(events),
        answers: applied,
        unused,
        state: advisor.save_json()?,
    };
    Ok(Replay {
        advisor,
        decisions,
        rebuilt,
        refused,
        snapshot,
    })
}
