//! Importing device exports: one transaction per import. A record is known
//! when the log holds its identity (same source, same id) or the same
//! record by content (same source, instant, kind and values; for Tidepool
//! data and Nightscout CGM readings within [`abba_io::read::twice_window_ms`],
//! as two uploads carry one datum seconds apart): counted, never added twice. A known id with other content is a
//! newer version of that record (a Nightscout document rewritten): it
//! replaces the stored one, counted. Records dated after the time of
//! import (beyond the clock skew) or before
//! [`abba_io::read::RECORDS_FROM`] (1990-01-01: no sensor or pump logged
//! data then) are refused: each is counted with the first one's place,
//! never stored, and a refused record never sets day 1.
//!
//! Day 1 is set by the first import that brings glucose (the local date of
//! its first reading) and never moves after. Records dated before it (a
//! pump's export that starts before the sensor's, imported after it) are
//! stored like any other, so that nothing the person gave is lost and the
//! log does not depend on the order of the imports; the advisor does not
//! use them ([`crate::day_1`]). The import counts them with the first
//! one's place and says so.

use crate::backend::{args, Conn, Db, Q};
use crate::error::StoreError;
use crate::log::key;
use crate::person::{self, Person};
use abba_io::read::pump_identity::PumpIdentity;
use abba_io::read::{Batch, Refused};
use abba_io::{RecordKind, SourceId};
use serde::Serialize;

/// What one import did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportSummary {
    /// Row id of the import (`None`: nothing new, nothing recorded).
    pub import_id: Option<i64>,
    /// The files.
    pub files: Vec<String>,
    /// Records read from the files (after removing exact duplicates between them).
    pub read: usize,
    /// Records new to the log.
    pub added: usize,
    /// Records the log already held.
    pub known: usize,
    /// Stored records replaced by a newer version (same id, other content).
    pub updated: usize,
    /// Exact duplicates within and between the files themselves.
    pub duplicates_in_files: usize,
    /// Older versions of a record whose id came again in the files.
    pub older_versions_in_files: usize,
    /// Tidepool data carried by two uploads, kept once.
    pub cross_upload_duplicates: usize,
    /// Nightscout doses the log already held from an earlier import or
    /// sync under another document, within
    /// [`abba_io::read::copy_elsewhere_window_ms`] and, when both carry
    /// one, with the same pump identity
    /// ([`abba_io::read::pump_identity`]): not stored again (also counted
    /// in `known`).
    pub copies_of_stored_doses: usize,
    /// Doses and carbs edited in the vendor's app between an earlier
    /// export and this one ([`crate::edited`]): the stored value replaced
    /// (also counted in `updated`).
    pub edited: usize,
    /// CGM and meter readings the log held in another unit or rounding
    /// (the vendor's app switched from mg/dL to mmol/L between two
    /// exports, [`crate::other_unit`]): the stored value kept (also
    /// counted in `known`).
    pub other_unit: usize,
    /// On the days this import touched, records of a kind of data that
    /// the log holds (stored, this import's or an earlier one's) from a
    /// source other than the one that covers that day more fully
    /// ([`crate::one_source`]): stored, not used.
    pub set_aside: Vec<crate::one_source::SetAside>,
    /// Records dated after the time of import: refused.
    pub future: Refused,
    /// Records dated before [`abba_io::read::RECORDS_FROM`] (1990-01-01):
    /// refused (they cannot be true).
    pub too_old: Refused,
    /// Records of the files dated before the person's day 1 (profiles
    /// excepted, which are in force on day 1): stored (new ones counted in
    /// `added`, known ones in `known`), not used by the advisor
    /// ([`crate::day_1`]).
    pub before_day_1: Refused,
    /// Files from which no record was read.
    pub empty_files: Vec<String>,
    /// What the readers reported (stretches placed by a transmitter's
    /// clock, repeats kept once).
    pub notes: Vec<String>,
    /// Day 1 of the person's clock (set by the first import).
    pub first_day: Option<String>,
    /// When the files show a delivery ABBA was not designed for (a closed
    /// loop, injections): what they show, and whether the person is
    /// allowed basal suggestions anyway (research only).
    pub delivery: Option<DeliveryShown>,
}

/// A delivery the imported files show that ABBA was not designed for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct DeliveryShown {
    /// What the files show.
    pub delivery: abba_io::automation::Delivery,
    /// The person was created with `--allow-closed-loop`.
    pub allowed: bool,
}

/// "1 record", "2 records".
fn records(n: usize) -> String {
    format!("{n} record{}", if n == 1 { "" } else { "s" })
}

impl ImportSummary {
    /// What the import did, in sentences for a person or a clinician (the
    /// CLI's `abba import` and `abba sync`, the clinic's page): the counts,
    /// every refused or unused stretch with its first record, the files
    /// with no readings and every reader's note. Nothing is left out.
    pub fn lines(&self, person: &str) -> Vec<String> {
        let mut out = Vec::new();
        if self.added == 0 && self.updated == 0 && self.known == 0 {
            out.push(format!(
                "Nothing was added to {person}'s log: no record of {} could be used (below).",
                self.files.join(", ")
            ));
        } else if self.added == 0 && self.updated == 0 {
            out.push(format!(
                "Nothing new: {} of {} {} already in {person}'s log.",
                records(self.known),
                self.files.join(", "),
                if self.known == 1 { "is" } else { "are" }
            ));
        } else {
            out.push(format!(
                "Imported {} new {} for {person} ({} read, {} already known, {} newer versions of known records).",
                self.added,
                if self.added == 1 { "record" } else { "records" },
                self.read,
                self.known,
                self.updated
            ));
        }
        out.push(format!(
            "Duplicates within and between the files: {} repeats (the same record, or a glucose reading in two files' units), {} older versions of a repeated id, {} carried by two uploads seconds apart (Tidepool's pump and Apple Health, two Nightscout uploaders of one sensor).",
            self.duplicates_in_files, self.older_versions_in_files, self.cross_upload_duplicates
        ));
        if self.copies_of_stored_doses > 0 {
            out.push(format!(
                "{} of the known records are copies of doses already stored from an earlier import or sync: the same bolus or temporary basal under another Nightscout document within {} s (AndroidAPS uploading its pump history again), counted once.",
                records(self.copies_of_stored_doses),
                abba_io::read::nightscout::COPY_WITHIN_S
            ));
        }
        if self.other_unit > 0 {
            out.push(format!(
                "{} of the known records are glucose readings already stored in another unit or rounding (the export's app switched between mg/dL and mmol/L, or writes other decimals): the same instant, kind and reading within 0.1 mmol/L; the stored value was kept, not added to.",
                records(self.other_unit)
            ));
        }
        if self.edited > 0 {
            out.push(format!(
                "{} of the newer versions are doses or carbohydrate edited since an earlier export: the same instant and kind with another value, the earlier value no longer in this export; the stored value was replaced, not added to.",
                records(self.edited)
            ));
        }
        for o in &self.set_aside {
            out.push(crate::one_source::sentence(o));
        }
        let too_old = format!("{} (refused)", abba_io::read::too_old_words());
        let before = format!(
            "dated before day 1 ({}): stored, not used by the advisor",
            self.first_day.as_deref().unwrap_or("?")
        );
        for (what, r) in [
            ("dated after the time of import (refused)", &self.future),
            (too_old.as_str(), &self.too_old),
            (before.as_str(), &self.before_day_1),
        ] {
            if r.count > 0 {
                out.push(format!(
                    "{} {what}; the first: {} ({}).",
                    records(r.count),
                    r.first.as_deref().unwrap_or("?"),
                    r.first_at.as_deref().unwrap_or("?")
                ));
            }
        }
        for f in &self.empty_files {
            out.push(format!("No readings in {f}."));
        }
        for n in &self.notes {
            out.push(format!("Note: {n}"));
        }
        if let Some(d) = &self.delivery {
            let what = if d.allowed {
                format!("{person}'s basal suggestions continue for research only (created with --allow-closed-loop)")
            } else {
                format!("abba suggests no basal rate for {person} (abba advise says why)")
            };
            out.push(format!(
                "These files show {}: ABBA was designed and validated for open-loop pump therapy, so {what}.",
                d.delivery.name()
            ));
        }
        if let Some(d) = &self.first_day {
            out.push(format!("Day 1 of the advisor: {d}."));
        }
        out
    }
}

/// Adds `batch` to `person`'s log in one transaction, `now` being the
/// time of import. Everything is read and checked before the transaction
/// starts; the transaction either commits every new record and the import
/// row, or nothing. A batch with no record at all is an error naming the
/// files ("no readings in FILE").
pub fn import(
    conn: &mut Conn,
    person: &Person,
    batch: &Batch,
    now: jiff::Timestamp,
) -> Result<ImportSummary, StoreError> {
    import_with(conn, person, batch, now, &mut |_| Ok(()))
}

/// [`import`], running `also` inside the import's transaction before its
/// records are written (whatever must be written together with the
/// records: the settings a profile brings, a link's high-water marks, the
/// removal of a sync's deleted documents, which must go before the new
/// records are compared with the log: a document deleted and uploaded
/// again under another `_id` with the same content is then added, not
/// taken as known and removed with the old). `also` runs even when
/// nothing is new.
pub fn import_with(
    conn: &mut Conn,
    person: &Person,
    batch: &Batch,
    now: jiff::Timestamp,
    also: &mut dyn FnMut(&dyn Db) -> Result<(), StoreError>,
) -> Result<ImportSummary, StoreError> {
    let empty_files: Vec<String> = batch.empty_files().into_iter().map(String::from).collect();
    // What the reader took out as too old ([`abba_io::read::read_all`]),
    // and what a batch made otherwise still holds (counted below).
    let mut too_old = batch.too_old.clone();
    if batch.records.is_empty() && too_old.count > 0 {
        return Err(all_too_old(batch, &too_old));
    }
    if batch.records.is_empty() {
        let files = if empty_files.is_empty() {
            batch.files.join(", ")
        } else {
            empty_files.join(", ")
        };
        return Err(StoreError::Feed(format!("no readings in {files}")));
    }
    let limit = abba_io::read::future_limit(now);
    let mut future = Refused::default();
    let mut before_day_1 = Refused::default();
    let note = |r: &mut Refused, rec: &abba_io::Record| {
        r.count += 1;
        if r.first.is_none() {
            r.first = Some(batch.origin(rec));
            r.first_at = Some(rec.at.to_string());
        }
    };
    // Day 1: the local date of the first glucose reading not in the future
    // (a profile or a pump record months before the first reading does not
    // start it); an import without glucose leaves day 1 open.
    let first_useful = batch
        .records
        .iter()
        .filter(|r| {
            r.at <= limit
                && !abba_io::read::too_old(r)
                && matches!(r.kind, RecordKind::Cgm { .. } | RecordKind::Smbg { .. })
        })
        .min_by_key(|r| r.at);
    let first_day = match (person.first_day, first_useful) {
        (Some(d), _) => Some(d),
        (None, Some(r)) => Some(person.tz.to_datetime(r.at).date()),
        (None, None) => None,
    };
    let mut rows = Vec::with_capacity(batch.records.len());
    let mut kept = Vec::with_capacity(batch.records.len());
    // The records kept that the advisor uses (on or after day 1): the
    // days on which what was set aside is said.
    let mut from_day_1 = Vec::with_capacity(batch.records.len());
    for r in &batch.records {
        if r.at > limit {
            note(&mut future, r);
            continue;
        }
        if abba_io::read::too_old(r) {
            note(&mut too_old, r);
            continue;
        }
        // Stored, not used (a profile before day 1 is in force on day 1).
        match first_day {
            Some(d) if crate::day_1::is_before(&person.tz, d, r) => note(&mut before_day_1, r),
            _ => from_day_1.push(r),
        }
        kept.push(r);
    }
    // A file that lies wholly in the future (a device clock set wrong, an
    // export read in the wrong zone) is an error, not an import of nothing.
    if kept.is_empty() && future.count > 0 {
        return Err(StoreError::Feed(format!(
            "every record of {} that abba would keep is dated after the time of import ({}): {}, the first {} ({}); check the device's clock and {}'s zone ({}). Nothing was imported",
            batch.files.join(", "),
            now.round(jiff::Unit::Second).unwrap_or(now),
            records(future.count),
            future.first.as_deref().unwrap_or("?"),
            future.first_at.as_deref().unwrap_or("?"),
            person.name,
            person.tz.iana_name().unwrap_or("?"),
        )));
    }
    if kept.is_empty() && too_old.count > 0 && future.count == 0 {
        return Err(all_too_old(batch, &too_old));
    }
    let tx = conn.transaction()?;
    if crate::app::count(&tx, person.id)? > 0 {
        return Err(StoreError::Feed(format!(
            "{} is fed by the app through the service; imports and app events do not mix",
            person.name
        )));
    }
    also(&tx)?;
    // Every record is stored, whatever other source holds its day: which
    // source's records are used is chosen when events are derived
    // ([`crate::one_source`]), and said below.
    for r in &kept {
        let (source, id) = key(r)?;
        let window = match &r.kind {
            RecordKind::Ignored { .. } => None,
            _ => Some(abba_io::read::twice_window_ms(r)),
        };
        let is_id = matches!(r.id, SourceId::Id(_));
        // The record's stored text and origin are made when it is written
        // (a long export's would double what the import holds).
        rows.push((source, id, r.at.as_millisecond(), *r, window, is_id));
    }
    // In key order (stable: rows of one key keep theirs): the records'
    // table is keyed by (source, id), and a long export's ids (content
    // hashes) come in no order, so each look-up and insert would land on
    // another page (a 15-year CSV: 40 -> 24 s).
    rows.sort_by(|a, b| (&a.0, &a.1).cmp(&(&b.0, &b.1)));
    let stamp = now.to_string();
    let files = serde_json::to_string(&batch.files).map_err(|e| StoreError::corrupt("files", e))?;
    let formats =
        serde_json::to_string(&batch.formats).map_err(|e| StoreError::corrupt("formats", e))?;
    let import_id = tx.insert_id(
        Q::ImportPut,
        args![person.id, stamp, files, formats, rows.len() as i64],
    )?;
    let (mut added, mut known, mut updated) = (0usize, 0usize, 0usize);
    let mut copies_of_stored_doses = 0usize;
    let mut edited = 0usize;
    let mut other_unit = 0usize;
    let mut reexported = crate::other_unit::Reexported::of(
        rows.iter()
            .map(|(source, _, at_ms, r, _, _)| (source.as_str(), *at_ms, *r)),
    );
    let exported = crate::edited::Exported::of(
        rows.iter()
            .map(|(source, _, at_ms, r, _, _)| (source.as_str(), *at_ms, *r)),
    )?;
    {
        for (source, id, at_ms, record, window, is_id) in &rows {
            let kind = &serde_json::to_string(&record.kind)
                .map_err(|e| StoreError::corrupt("record", e))?;
            let pump = batch.pump_identity(record);
            let origin = &match pump {
                Some(p) => p.in_origin(&batch.origin(record)),
                None => batch.origin(record),
            };
            let stored = match tx.row(Q::RecordHeld, args![person.id, source, id])? {
                Some(r) => Some((r.int(0)?, r.text(1)?)),
                None => None,
            };
            match stored {
                Some((a, k)) if a == *at_ms && &k == kind => known += 1,
                Some((a, k)) if a == *at_ms && crate::other_unit::same_reading(&k, record)? => {
                    known += 1;
                    other_unit += 1;
                }
                Some(_) if *is_id => {
                    tx.execute(
                        Q::RecordReplace,
                        args![person.id, source, id, at_ms, kind, origin, import_id],
                    )?;
                    updated += 1;
                }
                Some((a, k)) => {
                    return Err(StoreError::corrupt(
                        "record id",
                        format!(
                        "{origin}: its content key {id} is held by another record ({a} ms, {k})"
                    ),
                    ))
                }
                None => {
                    let by_content = match window {
                        Some(w) => tx
                            .row(
                                Q::RecordSameContent,
                                args![person.id, at_ms - w, at_ms + w, source, kind],
                            )?
                            .is_some(),
                        None => false,
                    };
                    let copy_window = abba_io::read::copy_elsewhere_window_ms(record);
                    // A copy: the same dose within the window, unless both
                    // carry the pump's identity and the two differ
                    // (abba_io::read::pump_identity).
                    let copy = !by_content
                        && copy_window > 0
                        && tx
                            .rows(
                                Q::RecordCopyElsewhere,
                                args![
                                    person.id,
                                    at_ms - copy_window,
                                    at_ms + copy_window,
                                    source,
                                    kind,
                                    import_id
                                ],
                            )?
                            .iter()
                            .map(|row| row.text(0))
                            .collect::<Result<Vec<String>, _>>()?
                            .iter()
                            .any(|stored| {
                                PumpIdentity::same_dose(
                                    pump,
                                    PumpIdentity::of_origin(stored).as_ref(),
                                )
                            });
                    let reexpressed = !by_content
                        && !copy
                        && reexported
                            .known_as(&tx, person.id, source, *at_ms, record, import_id)?;
                    let edit_of = match by_content || copy || reexpressed {
                        true => None,
                        false => crate::edited::edit_of(
                            &tx, person.id, source, *at_ms, record, import_id, &exported,
                        )?,
                    };
                    if by_content || copy || reexpressed {
                        known += 1;
                        copies_of_stored_doses += usize::from(copy);
                        other_unit += usize::from(reexpressed);
                    } else if let Some(old) = edit_of {
                        tx.execute(Q::RecordDelete, args![person.id, source, &old])?;
                        tx.execute(
                            Q::RecordPut,
                            args![person.id, source, id, at_ms, kind, origin, import_id],
                        )?;
                        updated += 1;
                        edited += 1;
                    } else {
                        tx.execute(
                            Q::RecordPut,
                            args![person.id, source, id, at_ms, kind, origin, import_id],
                        )?;
                        added += 1;
                    }
                }
            }
        }
    }
    // What the log now sets aside on the days from day 1 this import
    // touched (after its writes, so that both orders of two imports say the
    // same of the second); its days before day 1 are said as such.
    let set_aside = crate::one_source::set_aside_on_days(&tx, person.id, &person.tz, &from_day_1)?;
    let import_id = if added == 0 && updated == 0 {
        // Nothing new: leave no trace beyond saying so.
        tx.execute(Q::ImportDelete, args![import_id])?;
        None
    } else {
        tx.execute(
            Q::ImportCounts,
            args![added as i64, known as i64, import_id],
        )?;
        if let (None, Some(d)) = (person.first_day, first_day) {
            person::set_first_day(&tx, person.id, d)?;
        }
        Some(import_id)
    };
    tx.commit()?;
    Ok(ImportSummary {
        import_id,
        files: batch.files.clone(),
        read: rows.len(),
        added,
        known,
        updated,
        duplicates_in_files: batch.duplicates.values().sum(),
        older_versions_in_files: batch.older_versions,
        cross_upload_duplicates: batch.cross_upload.values().sum(),
        copies_of_stored_doses,
        edited,
        other_unit,
        set_aside,
        future,
        too_old,
        before_day_1,
        empty_files,
        notes: (batch.notes.iter().cloned())
            .chain(batch.files.iter().zip(&batch.clocks).flat_map(|(f, c)| {
                abba_io::clocks::notes(c, &person.tz)
                    .into_iter()
                    .map(move |n| format!("{f}: {n}"))
            }))
            .collect(),
        first_day: first_day.map(|d| d.to_string()),
        delivery: None,
    })
}

/// A batch whose every record is dated before
/// [`abba_io::read::RECORDS_FROM`]: an error, not an import of nothing.
fn all_too_old(batch: &Batch, too_old: &Refused) -> StoreError {
    StoreError::Feed(format!(
        "every record of {} is {}: {}, the first {} ({}). Nothing was imported",
        batch.files.join(", "),
        abba_io::read::too_old_words(),
        records(too_old.count),
        too_old.first.as_deref().unwrap_or("?"),
        too_old.first_at.as_deref().unwrap_or("?"),
    ))
}

/// One past import.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImportRow {
    /// Row id.
    pub id: i64,
    /// When (UTC).
    pub imported_at: String,
    /// Files (JSON list as stored).
    pub files: String,
    /// Records read.
    pub read: i64,
    /// Records added.
    pub added: i64,
}

/// The person's imports, oldest first.
pub fn imports(conn: &dyn Db, person: i64) -> Result<Vec<ImportRow>, StoreError> {
    conn.rows(Q::ImportsOf, args![person])?
        .into_iter()
        .map(|r| {
            Ok(ImportRow {
                id: r.int(0)?,
                imported_at: r.text(1)?,
                files: r.text(2)?,
                read: r.int(3)?,
                added: r.int(4)?,
            })
        })
        .collect()
}
