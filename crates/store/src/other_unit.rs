//! A glucose reading exported again in the other unit or with other
//! rounding: the person switched their vendor app from mg/dL to mmol/L (or
//! back) between two exports, or the vendor changed how many decimals it
//! writes. A reading with no id of its own (LibreView, CareLink, a plain
//! CSV) is identified by its content, and 120 mg/dL read again as
//! 6.7 mmol/L is 120.7 mg/dL: another content, another record, and the
//! overlapping days would hold every reading twice.
//!
//! So a new CGM or meter reading identified by its content is the one
//! already stored when the log holds, at the same instant, a reading of the
//! same source and kind (CGM or meter) with the same censoring, stored by
//! an earlier import, whose value differs by less than one step of the
//! coarser unit ([`abba_io::record::SAME_READING_MG_DL`]), and the new export does not hold
//! that stored value at that instant (two meter readings of one minute in
//! both exports stay two); each stored reading stands for one new reading
//! at most. The stored value is kept (nothing the person gave is replaced
//! by a rounder copy); the new one is counted as known, and said. A
//! reading with an id (Clarity's transmitter clock) exported again in the
//! other unit is likewise the stored one, not a newer version of it.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use abba_io::record::in_display_unit;
use abba_io::{Record, RecordKind, SourceId};
use std::collections::{HashMap, HashSet};

/// Whether a stored record (`stored`, its kind's stored text) and a new
/// one (`new`) are one reading in two units or roundings
/// ([`abba_io::record::same_reading`]; a Clarity export in mg/dL, then in
/// mmol/L: each EGV keeps its transmitter's id).
pub fn same_reading(stored: &str, new: &Record) -> Result<bool, StoreError> {
    if !may_be_reading(new) {
        return Ok(false);
    }
    let kind: RecordKind =
        serde_json::from_str(stored).map_err(|e| StoreError::corrupt("record", e))?;
    Ok(abba_io::record::same_reading(new, &kind))
}

/// A CGM or meter reading of a source whose unit the person may switch.
fn may_be_reading(r: &Record) -> bool {
    matches!(r.kind, RecordKind::Cgm { .. } | RecordKind::Smbg { .. }) && in_display_unit(r.source)
}

/// Whether `r` may be a stored reading exported again: a CGM or meter
/// reading identified by its content.
fn may_be_reexpressed(r: &Record) -> bool {
    matches!(r.id, SourceId::Hash(_)) && may_be_reading(r)
}

/// The import's readings that may be stored ones exported again, the
/// stored readings already taken by a new one in this import, and, once a
/// new reading of that kind reaches the store, the [`Index`]: a re-import
/// whose readings are all known by their ids (years of them) builds none.
#[derive(Default)]
pub struct Reexported<'a> {
    rows: Vec<(&'a str, i64, &'a Record)>,
    index: Option<Index<'a>>,
    taken: HashSet<(String, String)>,
}

/// What the new export holds at each instant the log holds a reading of
/// its source ((source, instant in ms) -> its readings there, borrowed from
/// the import's rows: their kinds are written out only where a new reading
/// meets a stored one), and those instants (sorted; one query per source,
/// not one per new reading).
struct Index<'a> {
    at: HashMap<(&'a str, i64), Vec<&'a Record>>,
    held: HashMap<&'a str, Vec<i64>>,
}

impl<'a> Index<'a> {
    /// The index of `rows` against the log of `person`. The instants may
    /// hold this import's own readings: they only narrow the look-up, whose
    /// query leaves this import out.
    fn of(
        tx: &dyn Db,
        person: i64,
        rows: &[(&'a str, i64, &'a Record)],
    ) -> Result<Self, StoreError> {
        let mut span: HashMap<&str, (i64, i64)> = HashMap::new();
        for &(source, ms, _) in rows {
            let s = span.entry(source).or_insert((ms, ms));
            *s = (s.0.min(ms), s.1.max(ms));
        }
        let mut held: HashMap<&str, Vec<i64>> = HashMap::new();
        for (source, (from, to)) in span {
            let mut instants = tx
                .rows(Q::RecordGlucoseInstants, args![person, source, from, to])?
                .iter()
                .map(|r| r.int(0))
                .collect::<Result<Vec<i64>, _>>()?;
            instants.sort_unstable();
            held.insert(source, instants);
        }
        // Only the instants the log holds a reading at can match one.
        let mut at: HashMap<(&str, i64), Vec<&Record>> = HashMap::new();
        for &(source, ms, r) in rows {
            if held[source].binary_search(&ms).is_ok() {
                at.entry((source, ms)).or_default().push(r);
            }
        }
        Ok(Index { at, held })
    }
}

impl<'a> Reexported<'a> {
    /// The readings of the import that may be stored ones exported again.
    pub fn of(rows: impl Iterator<Item = (&'a str, i64, &'a Record)>) -> Self {
        Reexported {
            rows: rows.filter(|(_, _, r)| may_be_reexpressed(r)).collect(),
            index: None,
            taken: HashSet::new(),
        }
    }

    /// Whether the new record `r` (not held under its id) is a reading the
    /// log holds in another unit or rounding (see the module's words); the
    /// stored reading it matched is taken and matches no other.
    pub fn known_as(
        &mut self,
        tx: &dyn Db,
        person: i64,
        source: &str,
        at_ms: i64,
        r: &Record,
        import_id: i64,
    ) -> Result<bool, StoreError> {
        if !may_be_reexpressed(r) {
            return Ok(false);
        }
        let index = match &mut self.index {
            Some(index) => index,
            none => none.insert(Index::of(tx, person, &self.rows)?),
        };
        let held = (index.held.get(source)).is_some_and(|h| h.binary_search(&at_ms).is_ok());
        if !held {
            return Ok(false);
        }
        // The kinds the new export holds at this instant, as stored.
        let mut in_export = HashSet::new();
        for e in index.at.get(&(source, at_ms)).into_iter().flatten() {
            in_export.insert(
                serde_json::to_string(&e.kind).map_err(|e| StoreError::corrupt("record", e))?,
            );
        }
        for row in tx.rows(Q::RecordsAtInstant, args![person, source, at_ms, import_id])? {
            let (id, text) = (row.text(0)?, row.text(1)?);
            if same_reading(&text, r)?
                && !in_export.contains(&text)
                && self.taken.insert((source.to_string(), id))
            {
                return Ok(true);
            }
        }
        Ok(false)
    }
}

#[cfg(test)]
mod tests {
    use abba_core::units::MG_DL_PER_MMOL_L;
    use abba_io::record::SAME_READING_MG_DL;

    #[test]
    fn a_reading_rounded_to_a_tenth_of_a_mmol_is_within_one_step() {
        // Every whole mg/dL from 40 to 400, written as mmol/L with one
        // decimal by either factor vendors use, reads back within the step.
        for mg in 40..=400 {
            for factor in [18.0, MG_DL_PER_MMOL_L, 18.0182] {
                let mmol = (f64::from(mg) / factor * 10.0).round() / 10.0;
                let back = mmol * MG_DL_PER_MMOL_L;
                assert!(
                    (back - f64::from(mg)).abs() < SAME_READING_MG_DL,
                    "{mg} {factor}"
                );
            }
        }
    }
}
