//! `abba store copy`: every row of one store into another, empty one (an
//! SQLite file into a PostgreSQL database, or back), in one transaction
//! of the destination: the copy is whole or absent.
//!
//! Rows go across as they are stored (the same ids, JSON documents, hashes
//! and instants), table by table in an order that satisfies the foreign
//! keys, so the advice after the copy is the advice before it (a pure
//! function of the log). The person revisions are not copied: the
//! destination's triggers count the copied rows anew (a revision is only
//! compared for change).

use crate::backend::{Db, Q};
use crate::error::StoreError;
use crate::store::Store;

/// Each table with the statements that read and write its rows, parents
/// before children.
const TABLES: &[(&str, Q, Q)] = &[
    ("person", Q::CopyReadPerson, Q::CopyWritePerson),
    ("import", Q::CopyReadImport, Q::CopyWriteImport),
    ("record", Q::CopyReadRecord, Q::CopyWriteRecord),
    ("suggestion", Q::CopyReadSuggestion, Q::CopyWriteSuggestion),
    ("answer", Q::CopyReadAnswer, Q::CopyWriteAnswer),
    ("snapshot", Q::CopyReadSnapshot, Q::CopyWriteSnapshot),
    ("token", Q::CopyReadToken, Q::CopyWriteToken),
    ("app_event", Q::CopyReadAppEvent, Q::CopyWriteAppEvent),
    (
        "therapy_change",
        Q::CopyReadTherapyChange,
        Q::CopyWriteTherapyChange,
    ),
    (
        "file_evidence",
        Q::CopyReadFileEvidence,
        Q::CopyWriteFileEvidence,
    ),
    (
        "nightscout_link",
        Q::CopyReadNightscoutLink,
        Q::CopyWriteNightscoutLink,
    ),
    (
        "nightscout_mark",
        Q::CopyReadNightscoutMark,
        Q::CopyWriteNightscoutMark,
    ),
    (
        "nightscout_staged",
        Q::CopyReadNightscoutStaged,
        Q::CopyWriteNightscoutStaged,
    ),
    (
        "nightscout_written",
        Q::CopyReadNightscoutWritten,
        Q::CopyWriteNightscoutWritten,
    ),
    ("signin_link", Q::CopyReadSigninLink, Q::CopyWriteSigninLink),
    ("web_session", Q::CopyReadWebSession, Q::CopyWriteWebSession),
    (
        "web_submission",
        Q::CopyReadWebSubmission,
        Q::CopyWriteWebSubmission,
    ),
];

/// What a copy moved: rows per table, in copy order.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct CopySummary {
    /// (table, rows).
    pub tables: Vec<(String, usize)>,
}

impl Store {
    /// Copies every row of this store (read in one read transaction: a
    /// consistent state even while others write) into `to`, which must
    /// hold no person yet (one transaction of `to`).
    pub fn copy_into(&mut self, to: &mut Store) -> Result<CopySummary, StoreError> {
        if to.conn.one(Q::Ping, &[])?.int(0)? > 0 {
            return Err(StoreError::invalid(
                "--to",
                "the destination already holds persons: copy into an empty store",
            ));
        }
        let src = self.conn.read_transaction()?;
        let tx = to.conn.transaction()?;
        let mut tables = Vec::with_capacity(TABLES.len());
        for &(name, read, write) in TABLES {
            let rows = src.rows(read, &[])?;
            for r in &rows {
                tx.execute(write, &r.0)?;
            }
            tables.push((name.to_string(), rows.len()));
        }
        tx.one(Q::CopyResetIds, &[])?;
        tx.commit()?;
        src.commit()?;
        to.cache.clear();
        Ok(CopySummary { tables })
    }
}
