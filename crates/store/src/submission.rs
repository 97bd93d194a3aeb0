//! The web forms' one-time submissions: every form of the pages that
//! writes (a reading, a meal, an answer) carries a random key rendered
//! with it, and the service keeps the SHA-256 of that key with the form's
//! action and fields as the submission's key here, with what the first
//! submission did (its outcome: the seqs of the events it stored, or the
//! page it led to). The same form sent again (a double click, a browser's
//! retry after a timeout) finds its key and stores nothing twice: the
//! person gets the first result again. An acknowledged event is never
//! lost or duplicated.
//!
//! The events' submission is kept in the events' own transaction
//! ([`crate::Store::post_events_next_seq`]), so a crash never leaves events
//! without it; keys are kept [`KEEP_MS`].

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use crate::store::Store;

/// A submission's key: SHA-256 of the form's one-time key, its action and
/// its fields (made by the service).
pub type SubmissionKey = [u8; 32];

/// How long a submission is remembered (ms): a week, far longer than any
/// retry or a page left open.
pub const KEEP_MS: i64 = 7 * 24 * 3600 * 1000;

/// The outcome of a submission already held.
pub fn get(conn: &dyn Db, person: i64, key: &SubmissionKey) -> Result<Option<String>, StoreError> {
    conn.row(Q::WebSubmissionGet, args![person, &key[..]])?
        .map(|r| r.text(0))
        .transpose()
}

/// Keeps a submission and its outcome (a second one of the same key
/// changes nothing) and forgets the person's submissions older than
/// [`KEEP_MS`].
pub fn put(
    conn: &dyn Db,
    person: i64,
    key: &SubmissionKey,
    outcome: &str,
    now_ms: i64,
) -> Result<(), StoreError> {
    conn.execute(Q::WebSubmissionPrune, args![person, now_ms - KEEP_MS])?;
    conn.execute(
        Q::WebSubmissionPut,
        args![person, &key[..], outcome, now_ms],
    )?;
    Ok(())
}

/// The outcome of events stored by a submission: their seqs.
pub fn seqs_outcome(seqs: &[u64]) -> String {
    seqs.iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

/// The seqs of [`seqs_outcome`].
pub fn outcome_seqs(outcome: &str) -> Result<Vec<u64>, StoreError> {
    outcome
        .split(',')
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse()
                .map_err(|_| StoreError::corrupt("web submission outcome", outcome))
        })
        .collect()
}

impl Store {
    /// The outcome of the person's submission `key`, if it was made.
    pub fn submission(
        &self,
        person: i64,
        key: &SubmissionKey,
    ) -> Result<Option<String>, StoreError> {
        get(&self.conn, person, key)
    }

    /// Keeps the person's submission `key` with its outcome (one
    /// transaction; a key already held keeps its first outcome).
    pub fn record_submission(
        &mut self,
        person: i64,
        key: &SubmissionKey,
        outcome: &str,
        now_ms: i64,
    ) -> Result<(), StoreError> {
        let tx = self.conn.transaction_for(person)?;
        put(&tx, person, key, outcome, now_ms)?;
        tx.commit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seqs_round_trip_through_the_outcome() {
        assert_eq!(outcome_seqs(&seqs_outcome(&[3, 4])).unwrap(), vec![3, 4]);
        assert!(outcome_seqs("").unwrap().is_empty());
        assert!(outcome_seqs("x").is_err());
    }
}
