//! The app's side of acknowledged delivery: its own sequence numbers, a
//! buffer of events not yet acknowledged, flushes that survive a service
//! that goes away, and history sync after a reconnect.
//!
//! The rule an app follows (crates/service/README.md):
//!
//! - every event gets the next number of the app's own counter and stays
//!   in the outbox until the service acknowledged it;
//! - the app flushes its outbox up to and including each event that can
//!   produce an answer (a main-meal announcement, a day closing) and
//!   applies the answers before anything later happens;
//! - when a post gets no answer, the app does not know whether the batch
//!   was committed: once the service answers again it asks which of its
//!   numbers are held (`GET .../sync`), drops those from the outbox (they
//!   were committed; only the acknowledgement was lost) and re-sends the
//!   rest; the suggestions that a lost acknowledgement carried are fetched
//!   with `GET .../suggestions?after=ID`.

use crate::client::Client;
use crate::error::ClientError;
use crate::retry::{Backoff, Retry};
use abba_api::{
    AnswerBody, AnswerKind, AnswersAck, DeviceEvent, EventBody, EventsBody, SeqRange, Suggestion,
};
use std::collections::HashSet;

/// Most events in one post (well under [`abba_api::MAX_EVENTS_PER_BATCH`]
/// and the body limit whatever the events).
pub const CHUNK: usize = 2000;

/// Counters of what an outbox did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct OutboxStats {
    /// Events given numbers.
    pub pushed: u64,
    /// `POST .../events` requests sent (successful or not).
    pub posts: u64,
    /// Posts that got no answer (or a 503).
    pub failures: u64,
    /// Sync rounds after a failure.
    pub syncs: u64,
    /// Events acknowledged by a post.
    pub acked: u64,
    /// Of those, stored by that post.
    pub stored: u64,
    /// Of those, already held (acknowledged again).
    pub repeated: u64,
    /// Events found held by sync after a failure (committed, but the
    /// acknowledgement was lost): dropped from the outbox, not re-sent.
    pub held_on_sync: u64,
    /// Suggestions fetched after a failure because the acknowledgement that
    /// carried them was lost.
    pub fetched_suggestions: u64,
}

/// What one flush did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Flushed {
    /// The numbers now known held: acknowledged by a post or found held by
    /// sync, in the order learnt.
    pub held: Vec<u64>,
    /// The suggestions the flushed events produced, in the advisor's order
    /// (by id when some had to be fetched after a failure).
    pub answers: Vec<Suggestion>,
    /// Transient failures met (0: every post answered at once).
    pub failures: u32,
}

/// A person's outbox (see the module docs).
#[derive(Debug, Clone)]
pub struct Outbox {
    person: u64,
    next_seq: u64,
    pending: Vec<DeviceEvent>,
    last_suggestion_id: Option<u64>,
    stats: OutboxStats,
}

impl Outbox {
    /// An empty outbox for `person` whose first event gets number 0.
    pub fn new(person: u64) -> Self {
        Self::starting_at(person, 0, None)
    }

    /// An empty outbox whose next number is `next_seq`, having seen the
    /// suggestions up to `last_suggestion_id`.
    pub fn starting_at(person: u64, next_seq: u64, last_suggestion_id: Option<u64>) -> Self {
        Self {
            person,
            next_seq,
            pending: Vec::new(),
            last_suggestion_id,
            stats: OutboxStats::default(),
        }
    }

    /// An app starting again with an empty outbox: numbers go on after the
    /// highest the service holds, suggestions after the latest it made.
    pub fn resume(client: &Client, person: u64, retry: &Retry) -> Result<Self, ClientError> {
        let (s, _) = retry.run(|| client.sync(person, 0))?;
        Ok(Self::starting_at(
            person,
            s.last_seq.map_or(0, |l| l + 1),
            s.last_suggestion_id,
        ))
    }

    /// The person.
    pub fn person(&self) -> u64 {
        self.person
    }

    /// The number the next event gets.
    pub fn next_seq(&self) -> u64 {
        self.next_seq
    }

    /// The latest suggestion id seen.
    pub fn last_suggestion_id(&self) -> Option<u64> {
        self.last_suggestion_id
    }

    /// Events not acknowledged yet, in the order pushed.
    pub fn pending(&self) -> &[DeviceEvent] {
        &self.pending
    }

    /// The counters.
    pub fn stats(&self) -> OutboxStats {
        self.stats
    }

    /// Gives `event` at instant `at` (RFC 3339 with an offset) the next
    /// number and keeps it until acknowledged. Returns its number.
    pub fn push(&mut self, at: String, event: EventBody) -> u64 {
        let seq = self.next_seq;
        self.next_seq += 1;
        self.stats.pushed += 1;
        self.pending.push(DeviceEvent { seq, at, event });
        seq
    }

    /// Posts every pending event (in chunks of at most [`CHUNK`]) until the
    /// service holds them all; after a transient failure, syncs and
    /// re-sends only what is missing, and fetches the suggestions whose
    /// acknowledgement was lost. A refusal (4xx) or giving up returns the
    /// error with the events still pending.
    pub fn flush(&mut self, client: &Client, retry: &Retry) -> Result<Flushed, ClientError> {
        let mut out = Flushed::default();
        let mut backoff = Backoff::new(*retry);
        let mut need_sync = false;
        while need_sync || !self.pending.is_empty() {
            if need_sync {
                self.stats.syncs += 1;
                match self.drop_held(client) {
                    Ok(held) => {
                        self.stats.held_on_sync += held.len() as u64;
                        out.held.extend(held);
                        need_sync = false;
                    }
                    Err(e) => backoff.failed(e)?,
                }
                continue;
            }
            let n = self.pending.len().min(CHUNK);
            let body = EventsBody {
                events: self.pending[..n].to_vec(),
            };
            self.stats.posts += 1;
            match client.post_events(self.person, &body) {
                Ok(ack) => {
                    let mut sent: Vec<u64> = body.events.iter().map(|e| e.seq).collect();
                    sent.sort_unstable();
                    if ack.acked != sent {
                        return Err(ClientError::Protocol(format!(
                            "the acknowledgement lists {} numbers for a batch of {} ({:?}..)",
                            ack.acked.len(),
                            sent.len(),
                            ack.acked.first()
                        )));
                    }
                    self.pending.drain(..n);
                    self.stats.acked += n as u64;
                    self.stats.stored += ack.stored;
                    self.stats.repeated += ack.repeated.len() as u64;
                    out.held.extend(ack.acked);
                    out.answers.extend(ack.answers);
                }
                Err(e) => {
                    let transient = e.is_transient();
                    backoff.failed(e)?;
                    if transient {
                        self.stats.failures += 1;
                        need_sync = true;
                    }
                }
            }
        }
        out.failures = backoff.failures;
        if out.failures > 0 {
            let after = self.last_suggestion_id;
            let (list, _) = retry.run(|| client.suggestions(self.person, after))?;
            let known: HashSet<u64> = out.answers.iter().map(|s| s.id).collect();
            for s in list.suggestions {
                if !known.contains(&s.id) {
                    self.stats.fetched_suggestions += 1;
                    out.answers.push(s);
                }
            }
            out.answers.sort_by_key(|s| s.id);
        }
        if let Some(m) = out.answers.iter().map(|s| s.id).max() {
            self.last_suggestion_id = Some(self.last_suggestion_id.map_or(m, |l| l.max(m)));
        }
        Ok(out)
    }

    /// Asks which pending numbers the service holds and drops them from
    /// the outbox; returns them.
    fn drop_held(&mut self, client: &Client) -> Result<Vec<u64>, ClientError> {
        let Some(from) = self.pending.iter().map(|e| e.seq).min() else {
            return Ok(Vec::new());
        };
        let ranges = held_ranges(client, self.person, from)?;
        let mut held = Vec::new();
        self.pending.retain(|e| {
            let is_held = contains(&ranges, e.seq);
            if is_held {
                held.push(e.seq);
            }
            !is_held
        });
        Ok(held)
    }
}

/// Every held range ≥ `from`, following `truncated` answers.
pub fn held_ranges(client: &Client, person: u64, from: u64) -> Result<Vec<SeqRange>, ClientError> {
    let mut all = Vec::new();
    let mut cursor = from;
    loop {
        let s = client.sync(person, cursor)?;
        let next = s.held.last().map(|r| r.last + 1);
        all.extend(s.held);
        match (s.truncated, next) {
            (true, Some(n)) if n > cursor => cursor = n,
            _ => return Ok(all),
        }
    }
}

/// True when `seq` is in one of the (ascending, disjoint) `ranges`.
pub fn contains(ranges: &[SeqRange], seq: u64) -> bool {
    let i = ranges.partition_point(|r| r.last < seq);
    ranges.get(i).is_some_and(|r| r.first <= seq)
}

/// What became of answers posted with [`post_answers`].
#[derive(Debug, Clone, PartialEq)]
pub enum AnswersPosted {
    /// The service acknowledged them at the first attempt.
    Acked(AnswersAck),
    /// The service acknowledged them after an attempt failed (a lost
    /// reply, a timeout): the service acknowledges the same answers again
    /// as it did the first time and stores them once.
    AckedAfterRetry(AnswersAck),
    /// An attempt whose acknowledgement was lost had stored them (a
    /// service older than the acknowledgement of repeats answered 409):
    /// the suggestions are no longer open and carry the status asked for.
    AlreadyStored,
}

/// Posts answers, retrying transient failures. The service acknowledges
/// answers it holds already, the same, as it did the first time; a 409
/// after a failure (a service that refused repeats) is checked against the
/// suggestions: when each carries the answer asked for, an earlier attempt
/// stored them.
pub fn post_answers(
    client: &Client,
    person: u64,
    body: &AnswerBody,
    retry: &Retry,
) -> Result<AnswersPosted, ClientError> {
    let mut backoff = Backoff::new(*retry);
    loop {
        match client.post_answers(person, body) {
            Ok(ack) if backoff.failures > 0 => return Ok(AnswersPosted::AckedAfterRetry(ack)),
            Ok(ack) => return Ok(AnswersPosted::Acked(ack)),
            Err(e) if e.status() == Some(409) && backoff.failures > 0 => {
                let first = body.answers.iter().map(|a| a.suggestion_id).min();
                let after = first.and_then(|f| f.checked_sub(1));
                let (list, _) = retry.run(|| client.suggestions(person, after))?;
                let stored = body.answers.iter().all(|a| {
                    list.suggestions.iter().any(|s| {
                        s.id == a.suggestion_id
                            && s.status
                                == match a.answer {
                                    AnswerKind::Accept => "accepted",
                                    AnswerKind::Reject => "rejected",
                                    AnswerKind::Override => "overridden",
                                }
                    })
                });
                return if stored {
                    Ok(AnswersPosted::AlreadyStored)
                } else {
                    Err(e)
                };
            }
            Err(e) => backoff.failed(e)?,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn contains_finds_numbers_in_ranges_only() {
        let r = [
            SeqRange { first: 0, last: 4 },
            SeqRange { first: 7, last: 7 },
            SeqRange {
                first: 10,
                last: 20,
            },
        ];
        let held: Vec<u64> = (0..25).filter(|&s| contains(&r, s)).collect();
        let expected: Vec<u64> = (0..=4).chain([7]).chain(10..=20).collect();
        assert_eq!(held, expected);
        assert!(!contains(&[], 0));
    }

    #[test]
    fn push_numbers_events_from_the_counter() {
        let mut o = Outbox::starting_at(3, 41, Some(8));
        let a = o.push("2026-03-02T00:00:00Z".into(), EventBody::Suspend);
        let b = o.push("2026-03-02T00:01:00Z".into(), EventBody::Resume);
        assert_eq!((a, b), (41, 42));
        assert_eq!(o.next_seq(), 43);
        assert_eq!(o.pending().len(), 2);
        assert_eq!(o.stats().pushed, 2);
        assert_eq!(o.last_suggestion_id(), Some(8));
    }
}
