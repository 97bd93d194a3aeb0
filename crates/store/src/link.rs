//! A person's link to their Nightscout site: the URL and credential, the
//! last sync, per collection the high-water mark, and what abba wrote
//! there. The HTTP side lives in abba-nightscout; here is only what must
//! be durable, and the import of what a sync fetched, whose marks advance
//! in the same transaction as its records (a sync killed at any point
//! leaves the store as before it, or as after it).

use crate::backend::{args, Db, Row, Q};
use crate::error::StoreError;
use crate::import::ImportSummary;
use crate::person::{self, Person};
use crate::store::{ProfileResolution, Store};
use abba_io::automation::Evidence;
use abba_io::SourceId;
use serde::Serialize;
use std::collections::BTreeMap;

/// How abba authenticates to the site.
#[derive(Clone, PartialEq, Eq)]
pub enum Credential {
    /// The SHA-1 hex of the site's API_SECRET (what Nightscout's
    /// `api-secret` header carries); the secret itself is never stored.
    ApiSecretSha1(String),
    /// An access token of a subject (`name-0123456789abcdef`), as given: a
    /// bearer credential, which is why the store file is owner-only.
    Token(String),
}

impl Credential {
    /// The kind's name as stored and shown (`api_secret_sha1`, `token`).
    pub fn kind(&self) -> &'static str {
        match self {
            Credential::ApiSecretSha1(_) => "api_secret_sha1",
            Credential::Token(_) => "token",
        }
    }
    /// The value (for the HTTP client only: never print it).
    pub fn secret(&self) -> &str {
        match self {
            Credential::ApiSecretSha1(s) | Credential::Token(s) => s,
        }
    }
}

impl std::fmt::Debug for Credential {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Credential({}, redacted)", self.kind())
    }
}

/// A stored link.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// The person's name.
    pub person: String,
    /// The site's base URL (`https://example.herokuapp.com`).
    pub url: String,
    /// The credential.
    pub credential: Credential,
    /// Whether abba writes its suggestions back.
    pub write_back: bool,
    /// When the link was made (UTC).
    pub created_at: String,
    /// The last sync's end (UTC), whatever its outcome.
    pub last_sync_at: Option<String>,
    /// The last successful sync's end (UTC).
    pub last_success_at: Option<String>,
    /// The last sync's error, if it failed.
    pub last_error: Option<String>,
    /// Failed syncs in a row (the background sync backs off by them).
    pub failures: u32,
    /// What the last successful sync could not look for, in words (it
    /// imported what it read; see abba-nightscout's `SyncReport`).
    pub warnings: Vec<String>,
}

/// A link as shown (no credential).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinkView {
    /// The person's name.
    pub person: String,
    /// The site's base URL.
    pub url: String,
    /// `api_secret_sha1` or `token`.
    pub credential_kind: &'static str,
    /// Whether abba writes its suggestions back.
    pub write_back: bool,
    /// The last sync's end (UTC).
    pub last_sync_at: Option<String>,
    /// The last successful sync's end (UTC).
    pub last_success_at: Option<String>,
    /// The last sync's error.
    pub last_error: Option<String>,
    /// Failed syncs in a row.
    pub failures: u32,
    /// What the last successful sync could not look for, in words.
    pub warnings: Vec<String>,
}

impl Link {
    /// What may be shown of the link.
    pub fn view(&self) -> LinkView {
        LinkView {
            person: self.person.clone(),
            url: self.url.clone(),
            credential_kind: self.credential.kind(),
            write_back: self.write_back,
            last_sync_at: self.last_sync_at.clone(),
            last_success_at: self.last_success_at.clone(),
            last_error: self.last_error.clone(),
            failures: self.failures,
            warnings: self.warnings.clone(),
        }
    }
}

/// Something abba wrote to the site (a Note treatment, the `abba` profile).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// `note` or `profile`.
    pub what: String,
    /// The suggestion's key (`at_min:parameter`) or `abba`.
    pub key: String,
    /// The document's `_id` on the site.
    pub remote_id: String,
    /// What was written (JSON), to tell whether it must be updated.
    pub content: String,
}

/// What a sync fetched, ready for the import: the collections as JSON
/// arrays (named for messages), the ids the site reports deleted, the new
/// marks, and per collection the documents new since the previous mark
/// (for the loop evidence, counted once however often a page is fetched).
#[derive(Debug, Clone, Default)]
pub struct Fetched {
    /// (name, JSON array) per collection, read as files of that name.
    pub contents: Vec<(String, Vec<u8>)>,
    /// `_id`s of documents the site reports deleted (API v3 `isValid: false`).
    pub deleted: Vec<String>,
    /// The high-water marks after this sync, by collection.
    pub marks: BTreeMap<String, i64>,
    /// (collection, JSON array of its documents new since the last mark).
    pub fresh: Vec<(String, Vec<u8>)>,
    /// (collection, what its documents new since the last mark tell of the
    /// delivery), counted by the sync as it read them
    /// ([`Evidence::from_file`]): a collection too large to hold whole
    /// (Nightscout's device status) and read for this only.
    pub evidence: Vec<(String, Evidence)>,
    /// The site's glucose unit (`settings.units` of its `status.json`):
    /// a BG Check that does not say its own `units` is in it, as the site
    /// shows it. `None`: the site does not say (such a BG Check is then
    /// reported, not read).
    pub units: Option<abba_io::units::GlucoseUnit>,
    /// The site's profile store as read whole (a JSON array), when it has
    /// one: what it tells of the loop's mode replaces the last sync's.
    pub profile: Option<Vec<u8>>,
}

/// What the import of a sync did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SyncImport {
    /// The import (`None` when nothing was read).
    pub import: Option<ImportSummary>,
    /// Records removed because the site deleted their document.
    pub deleted: usize,
}

fn person_id(conn: &dyn Db, name: &str) -> Result<Person, StoreError> {
    person::load(conn, name)
}

fn row_to_link(r: Row) -> Result<Link, StoreError> {
    let kind = r.text(2)?;
    let secret = r.text(3)?;
    Ok(Link {
        person: r.text(0)?,
        url: r.text(1)?,
        credential: if kind == "token" {
            Credential::Token(secret)
        } else {
            Credential::ApiSecretSha1(secret)
        },
        write_back: r.bool(4)?,
        created_at: r.text(5)?,
        last_sync_at: r.opt_text(6)?,
        last_success_at: r.opt_text(7)?,
        last_error: r.opt_text(8)?,
        failures: r.int(9)?.clamp(0, i64::from(u32::MAX)) as u32,
        warnings: match r.opt_text(10)? {
            Some(j) => {
                serde_json::from_str(&j).map_err(|e| StoreError::corrupt("link warnings", e))?
            }
            None => Vec::new(),
        },
    })
}

/// What a collection's documents tell of the delivery
/// ([`abba_io::automation::Evidence`]); `None` when nothing.
fn evidence_of(person: &Person, collection: &str, bytes: &[u8]) -> Option<Evidence> {
    let mut e = Evidence::from_file(bytes);
    // The device's clock away from the person's zone (abba_io::clocks):
    // only the stretches away are kept, so that the row stays small over
    // many syncs.
    let opts = abba_io::ReadOptions {
        tz: Some(person.tz.clone()),
        format: Some(abba_io::read::Format::Nightscout),
        ..abba_io::ReadOptions::default()
    };
    if let Ok(read) = abba_io::read::read_bytes_noted(collection, 0, bytes, &opts) {
        e.clocks = away(person, &read.clocks);
    }
    (!no_evidence(&e)).then_some(e)
}

/// Whether `e` tells nothing of the delivery nor of the device's clock.
fn no_evidence(e: &Evidence) -> bool {
    e.smb == 0
        && e.automated_basal == 0
        && e.systems.is_empty()
        && e.dual_mode_pumps.is_empty()
        && e.open_loop_modes == 0
        && e.last_mode.is_none()
        && e.clocks.is_empty()
}

fn away(
    person: &Person,
    c: &[abba_io::clocks::ClockStretch],
) -> Vec<abba_io::clocks::ClockStretch> {
    (abba_io::clocks::away(c, &person.tz).into_iter())
        .map(|a| a.stretch)
        .collect()
}

/// The key of a collection's evidence row.
fn evidence_key(collection: &str) -> String {
    format!("nightscout-sync:{collection}")
}

fn put_evidence(
    tx: &dyn Db,
    person: i64,
    collection: &str,
    e: &Evidence,
) -> Result<(), StoreError> {
    let json = serde_json::to_string(e).map_err(|e| StoreError::corrupt("file evidence", e))?;
    tx.execute(
        Q::FileEvidencePut,
        args![person, evidence_key(collection), collection, json],
    )?;
    Ok(())
}

/// Adds what the new documents of a collection tell to what the earlier
/// syncs' told (one row per collection; each document is new once, so
/// documents fetched again are not counted twice).
fn add_evidence(
    tx: &dyn Db,
    person: &Person,
    collection: &str,
    bytes: &[u8],
) -> Result<(), StoreError> {
    match evidence_of(person, collection, bytes) {
        Some(e) => add_counted(tx, person, collection, &e),
        None => Ok(()),
    }
}

/// Adds evidence the sync counted to what the earlier syncs' told (see
/// [`add_evidence`]).
fn add_counted(
    tx: &dyn Db,
    person: &Person,
    collection: &str,
    e: &Evidence,
) -> Result<(), StoreError> {
    if no_evidence(e) {
        return Ok(());
    }
    let held = tx
        .row(
            Q::FileEvidenceOne,
            args![person.id, evidence_key(collection)],
        )?
        .map(|r| r.text(0))
        .transpose()?;
    let mut sum = match held {
        Some(j) => serde_json::from_str::<Evidence>(&j)
            .map_err(|e| StoreError::corrupt("file evidence", e))?,
        None => Evidence::default(),
    };
    sum.add_file(e);
    sum.clocks = away(person, &sum.clocks);
    put_evidence(tx, person.id, collection, &sum)
}

/// What the site's profile store tells (Loop's `loopSettings`: closed
/// loop on or off), read whole at every sync: it replaces what the last
/// sync's told.
fn replace_profile_evidence(tx: &dyn Db, person: &Person, bytes: &[u8]) -> Result<(), StoreError> {
    let e = evidence_of(person, "profile", bytes).unwrap_or_default();
    put_evidence(tx, person.id, "profile", &e)
}

/// Removes the records of the documents `ids` (and the further records
/// one document gave, `ID#n`); returns how many.
fn delete_records(tx: &dyn Db, person: i64, ids: &[String]) -> Result<usize, StoreError> {
    let mut n = 0;
    for id in ids {
        let key = serde_json::to_string(&SourceId::Id(id.as_str().into()))
            .map_err(|e| StoreError::corrupt("record id", e))?;
        n += tx.execute(Q::NightscoutRecordDelete, args![person, &key])?;
        // `{"id":"ID#` : the further records of the same document.
        let prefix = format!("{}#", key.trim_end_matches("\"}"));
        let len = prefix.chars().count() as i64;
        n += tx.execute(Q::NightscoutRecordPartsDelete, args![person, prefix, len])?;
    }
    Ok(n)
}

fn write_marks(tx: &dyn Db, person: i64, marks: &BTreeMap<String, i64>) -> Result<(), StoreError> {
    for (c, m) in marks {
        tx.execute(Q::NightscoutMarkPut, args![person, c, m])?;
    }
    Ok(())
}

impl Store {
    /// Links `name` to a Nightscout site (replacing a link it had; a link
    /// to another URL starts again from no marks).
    pub fn set_link(
        &mut self,
        name: &str,
        url: &str,
        credential: &Credential,
        write_back: bool,
    ) -> Result<Link, StoreError> {
        let p = person_id(&self.conn, name)?;
        let tx = self.conn.transaction()?;
        let old = tx
            .row(Q::NightscoutLinkUrl, args![p.id])?
            .map(|r| r.text(0))
            .transpose()?;
        if old.as_deref().is_some_and(|u| u != url) {
            tx.execute(Q::NightscoutMarksDelete, args![p.id])?;
            tx.execute(Q::NightscoutStagedDelete, args![p.id])?;
            tx.execute(Q::NightscoutWrittenDeleteAll, args![p.id])?;
        }
        tx.execute(
            Q::NightscoutLinkPut,
            args![
                p.id,
                url,
                credential.kind(),
                credential.secret(),
                write_back,
                jiff::Timestamp::now().to_string()
            ],
        )?;
        tx.commit()?;
        self.link(name)?
            .ok_or_else(|| StoreError::corrupt("link", "not stored"))
    }

    /// The person's link, if any.
    pub fn link(&self, name: &str) -> Result<Option<Link>, StoreError> {
        let p = person_id(&self.conn, name)?;
        self.conn
            .row(Q::NightscoutLinkOf, args![p.id])?
            .map(row_to_link)
            .transpose()
    }

    /// Every link, by person name.
    pub fn links(&self) -> Result<Vec<Link>, StoreError> {
        self.conn
            .rows(Q::NightscoutLinks, args![])?
            .into_iter()
            .map(row_to_link)
            .collect()
    }

    /// Removes the person's link, its marks and the list of what abba
    /// wrote (the records stay). False when there was no link.
    pub fn remove_link(&mut self, name: &str) -> Result<bool, StoreError> {
        let p = person_id(&self.conn, name)?;
        let tx = self.conn.transaction()?;
        tx.execute(Q::NightscoutMarksDelete, args![p.id])?;
        tx.execute(Q::NightscoutStagedDelete, args![p.id])?;
        tx.execute(Q::NightscoutWrittenDeleteAll, args![p.id])?;
        let n = tx.execute(Q::NightscoutLinkDelete, args![p.id])?;
        tx.commit()?;
        Ok(n > 0)
    }

    /// The person's high-water marks (ms), by collection.
    pub fn link_marks(&self, name: &str) -> Result<BTreeMap<String, i64>, StoreError> {
        let p = person_id(&self.conn, name)?;
        self.conn
            .rows(Q::NightscoutMarksOf, args![p.id])?
            .into_iter()
            .map(|r| Ok((r.text(0)?, r.int(1)?)))
            .collect()
    }

    /// Records a sync's outcome at `at`: `None` a success (the failures
    /// count restarts, no warnings), `Some(error)` a failure (the last
    /// success's warnings stay).
    pub fn record_sync(
        &mut self,
        name: &str,
        at: jiff::Timestamp,
        error: Option<&str>,
    ) -> Result<(), StoreError> {
        let Some(e) = error else {
            return self.record_success(name, at, &[]);
        };
        let p = person_id(&self.conn, name)?;
        self.conn
            .execute(Q::NightscoutSyncFailed, args![p.id, at.to_string(), e])?;
        Ok(())
    }

    /// Records a successful sync at `at` with what it could not look for
    /// (`warnings`, in words), shown with the link until the next success.
    pub fn record_success(
        &mut self,
        name: &str,
        at: jiff::Timestamp,
        warnings: &[String],
    ) -> Result<(), StoreError> {
        let p = person_id(&self.conn, name)?;
        let json = match warnings {
            [] => None,
            w => Some(
                serde_json::to_string(w).map_err(|e| StoreError::corrupt("link warnings", e))?,
            ),
        };
        self.conn.execute(
            Q::NightscoutSyncSucceeded,
            args![p.id, at.to_string(), json],
        )?;
        Ok(())
    }

    /// Imports what a sync fetched, read at `now`, exactly as files of the
    /// same content are imported (the same reader, identities and checks;
    /// see [`Store::import_contents`]), and in the same transaction
    /// removes the records of deleted documents and advances the marks.
    pub fn import_synced(
        &mut self,
        name: &str,
        fetched: &Fetched,
        resolve: ProfileResolution,
        now: jiff::Timestamp,
    ) -> Result<SyncImport, StoreError> {
        let p = person_id(&self.conn, name)?;
        let mut deleted = 0;
        let mut also = |tx: &dyn Db| -> Result<(), StoreError> {
            // What an interrupted first sync kept is in this import.
            tx.execute(Q::NightscoutStagedDelete, args![p.id])?;
            deleted = delete_records(tx, p.id, &fetched.deleted)?;
            for (c, bytes) in &fetched.fresh {
                add_evidence(tx, &p, c, bytes)?;
            }
            for (c, e) in &fetched.evidence {
                add_counted(tx, &p, c, e)?;
            }
            if let Some(bytes) = &fetched.profile {
                replace_profile_evidence(tx, &p, bytes)?;
            }
            write_marks(tx, p.id, &fetched.marks)
        };
        let has_records = {
            let opts = abba_io::ReadOptions {
                tz: Some(p.tz.clone()),
                units: fetched.units,
                ..abba_io::ReadOptions::default()
            };
            // (Records the import refuses as too old are records here: it
            // reports them, an error when they are all it would read.)
            !abba_io::read::read_all(&fetched.contents, &opts)?
                .records
                .is_empty()
        };
        if !has_records {
            let tx = self.conn.transaction()?;
            also(&tx)?;
            tx.commit()?;
            self.cache.remove(&p.id);
            return Ok(SyncImport {
                import: None,
                deleted,
            });
        }
        let read = abba_io::ReadOptions {
            format: Some(abba_io::read::Format::Nightscout),
            units: fetched.units,
            ..abba_io::ReadOptions::default()
        };
        let s = self.import_contents_read(
            name,
            &fetched.contents,
            &read,
            resolve,
            now,
            false,
            &mut also,
        )?;
        Ok(SyncImport {
            import: Some(s),
            deleted,
        })
    }

    /// Keeps what a first sync read whole before it failed part-way
    /// (per collection, a JSON array of its documents), with the marks of
    /// how far that reaches, in one transaction: not imported (no day is
    /// advised on before the whole history is read), read back by the
    /// next sync ([`Store::staged`]) and removed by the import of all of
    /// it ([`Store::import_synced`]).
    pub fn stage_synced(
        &mut self,
        name: &str,
        staged: &[(String, Vec<u8>)],
        marks: &BTreeMap<String, i64>,
    ) -> Result<(), StoreError> {
        let p = person_id(&self.conn, name)?;
        let tx = self.conn.transaction()?;
        tx.execute(Q::NightscoutStagedDelete, args![p.id])?;
        for (c, bytes) in staged {
            let text = std::str::from_utf8(bytes)
                .map_err(|e| StoreError::corrupt("staged documents", e))?;
            tx.execute(Q::NightscoutStagedPut, args![p.id, c, text])?;
        }
        write_marks(&tx, p.id, marks)?;
        tx.commit()?;
        Ok(())
    }

    /// What a first sync kept for the next ([`Store::stage_synced`]):
    /// (collection, JSON array).
    pub fn staged(&self, name: &str) -> Result<Vec<(String, Vec<u8>)>, StoreError> {
        let p = person_id(&self.conn, name)?;
        self.conn
            .rows(Q::NightscoutStagedOf, args![p.id])?
            .into_iter()
            .map(|r| Ok((r.text(0)?, r.text(1)?.into_bytes())))
            .collect()
    }

    /// The documents whose records a sync brought from `origin` (a site's
    /// collection URL, as the records' origin names it) at or after
    /// `from_ms`: each document's `_id` once (one document may have given
    /// several records, `ID#n`). A sync compares them with what the site
    /// still serves over the same window, to see documents deleted
    /// through API v1, which leaves no trace.
    pub fn synced_documents(
        &self,
        name: &str,
        origin: &str,
        from_ms: i64,
    ) -> Result<Vec<String>, StoreError> {
        let p = person_id(&self.conn, name)?;
        let prefix = format!("{origin}: ");
        let len = prefix.chars().count() as i64;
        let rows = self
            .conn
            .rows(Q::NightscoutDocuments, args![p.id, from_ms, prefix, len])?;
        let mut out: Vec<String> = Vec::new();
        for r in rows {
            let raw = r.text(0)?;
            let id: SourceId =
                serde_json::from_str(&raw).map_err(|e| StoreError::corrupt("record id", e))?;
            let SourceId::Id(id) = id else { continue };
            let id: &str = &id;
            // `ID#n`: the n-th further record of document ID.
            let base = match id.rsplit_once('#') {
                Some((b, n)) if !n.is_empty() && n.bytes().all(|c| c.is_ascii_digit()) => b,
                _ => id,
            };
            out.push(base.to_string());
        }
        out.sort();
        out.dedup();
        Ok(out)
    }

    /// What abba wrote to the person's site.
    pub fn written(&self, name: &str) -> Result<Vec<Written>, StoreError> {
        let p = person_id(&self.conn, name)?;
        self.conn
            .rows(Q::NightscoutWrittenOf, args![p.id])?
            .into_iter()
            .map(|r| {
                Ok(Written {
                    what: r.text(0)?,
                    key: r.text(1)?,
                    remote_id: r.text(2)?,
                    content: r.text(3)?,
                })
            })
            .collect()
    }

    /// Records (or replaces) something abba wrote to the site.
    pub fn set_written(&mut self, name: &str, w: &Written) -> Result<(), StoreError> {
        let p = person_id(&self.conn, name)?;
        self.conn.execute(
            Q::NightscoutWrittenPut,
            args![
                p.id,
                &w.what,
                &w.key,
                &w.remote_id,
                &w.content,
                jiff::Timestamp::now().to_string()
            ],
        )?;
        Ok(())
    }

    /// Forgets something abba wrote (after removing it from the site).
    pub fn forget_written(&mut self, name: &str, what: &str, key: &str) -> Result<(), StoreError> {
        let p = person_id(&self.conn, name)?;
        self.conn
            .execute(Q::NightscoutWrittenDelete, args![p.id, what, key])?;
        Ok(())
    }
}
