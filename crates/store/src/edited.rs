//! An event edited between two exports of one vendor: a dose or carbs a
//! person entered in the vendor's app (Dexcom Clarity's Insulin and Carbs
//! events, LibreView's notes of insulin and food, a CSV's rows) carries no
//! id of its own, so its identity is its content; edited (5 U made 6 U),
//! the later export's row is another record. Were it added, the log would
//! hold both (11 U). So a new record of such a kind is the edit of a stored
//! one when the log holds, at the same instant, a record of the same source
//! and kind with another value stored by an earlier import, and the new
//! export does not hold that value at that instant (two doses of one
//! minute come in both exports and stay two). The stored record is
//! replaced, counted and said. An event moved to another time is not
//! recognised (it is another event at another time).

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use abba_io::{Record, RecordKind, SourceId};
use std::collections::{HashMap, HashSet};

/// Whether `r` may be an edit of a stored record: a dose or carbs
/// identified by its content.
pub fn may_be_edited(r: &Record) -> bool {
    matches!(r.id, SourceId::Hash(_))
        && matches!(
            r.kind,
            RecordKind::Bolus { .. }
                | RecordKind::ExtendedBolus { .. }
                | RecordKind::LongActing { .. }
                | RecordKind::Carbs { .. }
        )
}

/// What the new export holds at each instant of such records: (source,
/// instant in ms) -> the kinds' stored text.
#[derive(Default)]
pub struct Exported {
    at: HashMap<(String, i64), HashSet<String>>,
}

impl Exported {
    /// The records of the import that [`may_be_edited`].
    pub fn of<'a>(
        rows: impl Iterator<Item = (&'a str, i64, &'a Record)>,
    ) -> Result<Self, StoreError> {
        let mut at: HashMap<(String, i64), HashSet<String>> = HashMap::new();
        for (source, ms, r) in rows.filter(|(_, _, r)| may_be_edited(r)) {
            let kind =
                serde_json::to_string(&r.kind).map_err(|e| StoreError::corrupt("record", e))?;
            at.entry((source.to_string(), ms)).or_default().insert(kind);
        }
        Ok(Exported { at })
    }
}

/// The stored record (its source id) that the new record `r` (`kind` its
/// stored text) is the edit of, if any (see the module's words).
pub fn edit_of(
    tx: &dyn Db,
    person: i64,
    source: &str,
    at_ms: i64,
    r: &Record,
    import_id: i64,
    exported: &Exported,
) -> Result<Option<String>, StoreError> {
    if !may_be_edited(r) {
        return Ok(None);
    }
    let type_prefix = format!("{{\"type\":\"{}\"", r.kind.name());
    let in_export = exported.at.get(&(source.to_string(), at_ms));
    for row in tx.rows(Q::RecordsAtInstant, args![person, source, at_ms, import_id])? {
        let (id, kind) = (row.text(0)?, row.text(1)?);
        if kind.starts_with(&type_prefix) && !in_export.is_some_and(|k| k.contains(&kind)) {
            return Ok(Some(id));
        }
    }
    Ok(None)
}
