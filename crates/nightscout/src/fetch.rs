//! Fetching what is new: API v1 collections paged by time (Nightscout
//! answers newest first, at most `count` documents, and a server may cap
//! `count` lower than asked), the profile store, and API v3 `history` for
//! the documents the site reports deleted (`isValid: false`).
//!
//! Paging: the first page is everything from the lower bound (newest
//! first); each next page asks for what is at or before the oldest time of
//! the last one (`$lte`, so documents sharing that instant are not lost;
//! they come again and are kept once by `_id`). A page that brings nothing
//! new (a page or more at its keys) has those keys read by `_id`
//! ([`crate::by_id`]), then moves the bound below them; an empty page ends
//! it.

use crate::client::Client;
use crate::error::NsError;
use serde_json::Value;
use std::collections::HashMap;

/// A v1 collection read by time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Collection {
    /// `/api/v1/entries.json` by `date` (ms, a number): sgv, mbg, cal.
    Entries,
    /// `/api/v1/treatments.json` by `created_at` (a string): boluses,
    /// carbs, temporary basals, Profile Switches, notes...
    Treatments,
    /// `/api/v1/devicestatus.json` by `created_at` (a string, filtered,
    /// sorted and bounded as the treatments' are: `storage.queryOpts` of
    /// cgm-remote-monitor's `lib/server/devicestatus.js`): what the
    /// uploader, the pump and a loop reported each cycle. Read only for
    /// the loop's evidence ([`crate::device_status`]), never imported.
    DeviceStatus,
}

/// Where a page ends, in the terms the server compares: `date` as a
/// number; `created_at` as a string (MongoDB compares the stored string
/// with the bound, which Nightscout rewrites to `toISOString()`'s form).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Key {
    Ms(i64),
    Text(String),
}

impl Collection {
    /// The name (also the mark's key and v3's collection).
    pub fn name(self) -> &'static str {
        match self {
            Collection::Entries => "entries",
            Collection::Treatments => "treatments",
            Collection::DeviceStatus => "devicestatus",
        }
    }
    /// The v1 path.
    pub fn path(self) -> &'static str {
        match self {
            Collection::Entries => "/api/v1/entries.json",
            Collection::Treatments => "/api/v1/treatments.json",
            Collection::DeviceStatus => "/api/v1/devicestatus.json",
        }
    }
    pub(crate) fn field(self) -> &'static str {
        match self {
            Collection::Entries => "date",
            Collection::Treatments | Collection::DeviceStatus => "created_at",
        }
    }
    /// Whether the server compares the date field as a string
    /// (`created_at`), not as a number (`date`).
    pub(crate) fn keyed_by_text(self) -> bool {
        self != Collection::Entries
    }
    /// The lower bound for documents at or after `ms`.
    pub(crate) fn lower(self, ms: i64) -> Key {
        match self {
            Collection::Entries => Key::Ms(ms),
            Collection::Treatments | Collection::DeviceStatus => Key::Text(iso_ms(ms)),
        }
    }
    /// A document's time (ms) by this collection's field and the
    /// fall-backs the reader uses, if it has one.
    pub fn time_of(self, doc: &Value) -> Option<i64> {
        let num = |k: &str| doc.get(k).and_then(Value::as_f64).map(|v| v as i64);
        let text = |k: &str| {
            doc.get(k)
                .and_then(Value::as_str)
                .and_then(abba_io::time::parse_instant)
                .map(|t| t.as_millisecond())
        };
        match self {
            Collection::Entries => num("date")
                .or_else(|| text("dateString"))
                .or_else(|| text("sysTime")),
            Collection::Treatments | Collection::DeviceStatus => text("created_at")
                .or_else(|| num("date"))
                .or_else(|| num("mills"))
                .or_else(|| text("timestamp")),
        }
    }
    /// The keys the server may have compared for `doc` (the least and the
    /// greatest): for a treatment its `created_at` as served, and when
    /// that carries an offset without `utcOffset` beside it (a site with
    /// `DE_NORMALIZE_DATES`, which rewrites the stored UTC string on the
    /// way out), also the UTC form it is stored in. A document without
    /// the field is keyed by its time in the server's form.
    pub(crate) fn keys_of(self, doc: &Value) -> Option<(Key, Key)> {
        match self {
            Collection::Entries => {
                let t = self.time_of(doc)?;
                Some((Key::Ms(t), Key::Ms(t)))
            }
            Collection::Treatments | Collection::DeviceStatus => {
                let t = self.time_of(doc);
                let utc = t.map(iso_ms);
                match doc.get("created_at").and_then(Value::as_str) {
                    Some(s) => {
                        let offset =
                            !s.trim_end().ends_with(['Z', 'z']) && abba_io::time::has_offset(s);
                        let stored_utc = offset && doc.get("utcOffset").is_none();
                        match (utc, t) {
                            (Some(u), Some(t)) if stored_utc => {
                                // Stored in UTC: `toISOString()`'s form, or
                                // without milliseconds when they are 0.
                                let mut forms = vec![s.to_string(), u];
                                if t.rem_euclid(1000) == 0 {
                                    forms.push(iso_seconds(t));
                                }
                                forms.sort();
                                let hi = forms.pop().map(Key::Text)?;
                                let lo = forms.into_iter().next().map(Key::Text)?;
                                Some((lo, hi))
                            }
                            _ => Some((Key::Text(s.to_string()), Key::Text(s.to_string()))),
                        }
                    }
                    None => utc.map(|u| (Key::Text(u.clone()), Key::Text(u))),
                }
            }
        }
    }
}

impl Key {
    /// The filter value.
    pub(crate) fn query(&self) -> String {
        match self {
            Key::Ms(ms) => ms.to_string(),
            Key::Text(s) => s.clone(),
        }
    }
    /// The least bound in the server's form at or above this key (so
    /// `$lte` of it keeps every document keyed at or below this one).
    pub(crate) fn at_or_above(&self) -> Option<Key> {
        match self {
            Key::Ms(ms) => Some(Key::Ms(*ms)),
            Key::Text(s) => canonical_at_or_above(s).map(Key::Text),
        }
    }
    /// The greatest bound in the server's form below this key.
    fn below(&self) -> Option<Key> {
        match self {
            Key::Ms(ms) => Some(Key::Ms(ms - 1)),
            Key::Text(s) => canonical_below(s).map(Key::Text),
        }
    }
}

/// `2026-01-14T21:54:00.000Z`: Nightscout's `created_at` form
/// (JavaScript's `toISOString()`, which its query code rewrites every
/// date bound to).
pub fn iso_ms(ms: i64) -> String {
    match jiff::Timestamp::from_millisecond(ms) {
        Ok(t) => t.strftime("%Y-%m-%dT%H:%M:%S%.3fZ").to_string(),
        Err(_) => ms.to_string(),
    }
}

/// `2026-01-14T21:54:00Z`: the UTC form without milliseconds.
fn iso_seconds(ms: i64) -> String {
    match jiff::Timestamp::from_millisecond(ms) {
        Ok(t) => t.strftime("%Y-%m-%dT%H:%M:%SZ").to_string(),
        Err(_) => ms.to_string(),
    }
}

/// The times whose [`iso_ms`] form is 24 characters and ordered as the
/// times are (years 1000 to 9999).
const ISO_FIRST_MS: i64 = -30_610_224_000_000;
const ISO_LAST_MS: i64 = 253_402_300_799_999;

/// The least time whose [`iso_ms`] string is at or above `s` (compared
/// as strings, as MongoDB compares them).
fn canonical_at_or_above(s: &str) -> Option<String> {
    let (mut lo, mut hi) = (ISO_FIRST_MS, ISO_LAST_MS);
    if iso_ms(hi).as_str() < s {
        return None;
    }
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if iso_ms(mid).as_str() >= s {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    Some(iso_ms(lo))
}

/// The greatest time whose [`iso_ms`] string is below `s`.
fn canonical_below(s: &str) -> Option<String> {
    let (mut lo, mut hi) = (ISO_FIRST_MS, ISO_LAST_MS);
    if iso_ms(lo).as_str() >= s {
        return None;
    }
    while lo < hi {
        let mid = lo + (hi - lo + 1) / 2;
        if iso_ms(mid).as_str() < s {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    Some(iso_ms(lo))
}

/// What one collection's fetch brought.
#[derive(Debug, Clone, Default)]
pub struct Pages {
    /// The documents, each once (by `_id`, the last fetched kept), newest first.
    pub docs: Vec<Value>,
    /// Pages asked for.
    pub pages: usize,
    /// Documents received, repeats across pages included.
    pub received: usize,
    /// `_id`s of documents marked `isValid: false` (deleted through API v3).
    pub deleted: Vec<String>,
    /// Treatments found only by the `_id` probe (no `created_at` string).
    pub without_created_at: usize,
    /// Documents dated before the window read again but inserted since
    /// its start (uploaded late), found by their ObjectId or named by API
    /// v3's history.
    pub late: usize,
    /// What the paging could not prove complete, said in words: the
    /// sync fails with them ([`crate::NsError::Incomplete`]) and imports
    /// nothing.
    pub unproven: Vec<String>,
    /// What could not be looked for beyond the window read by time,
    /// said in words (late uploads on a server that cannot be read by
    /// `_id`): what was read is complete and imported, these are said.
    pub warnings: Vec<String>,
    /// The longest page the server served (a page shorter than it holds
    /// all that its bounds admit).
    pub largest: usize,
}

impl Pages {
    /// Adds documents fetched beside the paging (kept once by `_id`, the
    /// later replacing the earlier); how many were new.
    pub fn add(&mut self, c: Collection, docs: Vec<Value>) -> usize {
        let index = self
            .docs
            .iter()
            .enumerate()
            .map(|(i, d)| (doc_key(d), i))
            .collect();
        let largest = self.largest;
        let mut col = Collector {
            out: std::mem::take(self),
            index,
            largest,
        };
        let fresh = docs.into_iter().filter(|d| col.take(d.clone())).count();
        *self = col.finish(c);
        fresh
    }
}

/// The documents of one fetch, each kept once by `_id` (the last fetched
/// wins; a document served `isValid: false` is taken as deleted).
#[derive(Default)]
pub(crate) struct Collector {
    pub(crate) out: Pages,
    index: HashMap<String, usize>,
    /// The longest page the server served in this fetch (a page as long
    /// may have been cut by its maximum).
    pub(crate) largest: usize,
}

impl Collector {
    /// Keeps `d`; whether it is new to this fetch.
    pub(crate) fn take(&mut self, d: Value) -> bool {
        let key = doc_key(&d);
        if d.get("isValid") == Some(&Value::Bool(false)) {
            if !self.out.deleted.contains(&key) {
                self.out.deleted.push(key.clone());
            }
            if let Some(&i) = self.index.get(&key) {
                self.out.docs[i] = Value::Null;
            }
            return false;
        }
        match self.index.get(&key) {
            Some(&i) => {
                self.out.docs[i] = d;
                false
            }
            None => {
                self.index.insert(key, self.out.docs.len());
                self.out.docs.push(d);
                true
            }
        }
    }

    /// The documents, newest first.
    pub(crate) fn finish(self, c: Collection) -> Pages {
        let mut out = self.out;
        out.largest = out.largest.max(self.largest);
        out.docs.retain(|d| !d.is_null());
        out.docs
            .sort_by_key(|d| std::cmp::Reverse(c.time_of(d).unwrap_or(i64::MIN)));
        out
    }
}

/// The most pages one collection's fetch asks for (a guard against a
/// server that ignores the time filter).
pub const MAX_PAGES: usize = 100_000;

/// A document's `_id` as the reader keys its records (a string from the
/// API, `{"$oid": ...}` from a dump).
pub fn doc_id(doc: &Value) -> Option<String> {
    match doc.get("_id") {
        Some(Value::String(s)) => Some(s.clone()),
        Some(Value::Object(o)) => o.get("$oid").and_then(Value::as_str).map(String::from),
        _ => None,
    }
}

pub(crate) fn doc_key(doc: &Value) -> String {
    doc_id(doc).unwrap_or_else(|| doc.to_string())
}

/// The documents a v1 read of `path` serves: a JSON array, or none when
/// the site answers 404 (a server that is not Nightscout's code may say
/// "nothing found" so; that the site is there at all is known from its
/// `status.json`, which the link and every sync read first).
pub(crate) fn list(
    client: &Client,
    path: &str,
    query: &[(&str, String)],
) -> Result<Vec<Value>, NsError> {
    match client.get(path, query) {
        Ok(v) => as_array(client, &format!("GET {path}"), v),
        Err(NsError::Status { status: 404, .. }) => Ok(Vec::new()),
        Err(e) => Err(e),
    }
}

pub(crate) fn as_array(client: &Client, call: &str, v: Value) -> Result<Vec<Value>, NsError> {
    match v {
        Value::Array(a) => Ok(a),
        other => Err(NsError::Protocol {
            site: client.site().to_string(),
            call: call.to_string(),
            problem: format!(
                "expected a JSON array of documents, got {}",
                kind_of(&other)
            ),
        }),
    }
}

fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// How far a served `created_at` may read from the time it stands for
/// (an offset of up to 14 hours written in the string).
pub const OFFSET_SLACK_MS: i64 = 14 * 3_600_000 + 1000;

/// Every document of `c` at or after `since` (ms; `None`: all), `page`
/// documents asked per page.
///
/// The pages follow the server's own order and comparison: entries by
/// their `date` (a number), treatments by their `created_at` as a string
/// (Nightscout sorts and filters the stored string, which real sites
/// hold in several forms: with or without milliseconds, `Z` or an
/// offset); each next page's `$lte` is the least bound in the server's
/// form at or above the last page's least key, so no document between
/// two pages is skipped whatever its form. A page that brings nothing
/// new and is as long as any the server served holds only documents at
/// its keys, as many as the server serves at once: that range of keys is
/// read by `_id` ([`crate::by_id`]) before the paging steps below it. Treatments without a `created_at` string, which
/// no bound on it matches, are read by `_id` too, those inserted since
/// `since` (their ObjectId's time) and every one whose `_id` is a string.
/// So are the documents inserted since `since` but dated before it
/// (uploaded late), which paging by time from `since` cannot reach.
pub fn fetch_since(
    client: &Client,
    c: Collection,
    since: Option<i64>,
    page: usize,
) -> Result<Pages, NsError> {
    fetch_range(client, c, since, None, Some(since.unwrap_or(0)), page).map_err(|p| p.error)
}

/// What a read that failed part-way had read whole: paging from the
/// newest down, every document keyed above the bound of the page that
/// failed has come (see [`fetch_range`]).
#[derive(Debug)]
pub struct Partial {
    /// The documents read before the failure.
    pub pages: Pages,
    /// Every document of the read dated at or after this (ms) is in
    /// `pages`; `None`: nothing is proven (the first page failed, or the
    /// failure came after the paging by time).
    pub proven_from: Option<i64>,
    /// Why the read stopped.
    pub error: NsError,
}

/// [`fetch_since`] with an upper bound: the documents of `c` keyed at or
/// after `since` (ms; `None`: all) and before `before` (ms; `None`: no
/// bound); treatments without a `created_at` string are read by `_id`
/// when `undated_since` says from which ObjectId time (`None`: not
/// read); late uploads are looked for when the read is open above. A
/// failure part-way says what was read whole ([`Partial`]).
pub fn fetch_range(
    client: &Client,
    c: Collection,
    since: Option<i64>,
    before: Option<i64>,
    undated_since: Option<i64>,
    page: usize,
) -> Result<Pages, Box<Partial>> {
    let lower = since.map(|s| c.lower(s));
    let top = before.map(|b| c.lower(b.saturating_sub(1)));
    let mut col = Collector::default();
    let mut upper = top.clone();
    if let Err(error) = page_down(
        client,
        c,
        lower.as_ref(),
        top.as_ref(),
        page,
        &mut col,
        &mut upper,
    ) {
        let proven_from = upper.as_ref().and_then(|u| match u {
            Key::Ms(ms) => Some(ms.saturating_add(1)),
            Key::Text(s) => abba_io::time::parse_instant(s)
                .map(|t| t.as_millisecond().saturating_add(OFFSET_SLACK_MS)),
        });
        return Err(Box::new(Partial {
            pages: col.finish(c),
            proven_from,
            error,
        }));
    }
    let extras = (|| {
        if let (Collection::Treatments, Some(u)) = (c, undated_since) {
            crate::by_id::without_created_at(client, u, page, &mut col)?;
        }
        if let Some(s) = since.filter(|&s| s > 0 && before.is_none()) {
            let before = col.out.unproven.len();
            let late = crate::by_id::inserted_since(client, c, s, page, &mut col)?;
            col.out.late += late;
            // Late uploads are looked for beyond the window by `_id`; a server
            // that cannot be read so leaves them unseen. The window read by
            // time is complete all the same: said, not a failed sync.
            let cannot: Vec<String> = col.out.unproven.drain(before..).collect();
            col.out.warnings.extend(cannot.into_iter().map(|w| {
                format!(
                    "late uploads (dated before the window read again) cannot be looked for: {w}"
                )
            }));
        }
        Ok::<(), NsError>(())
    })();
    match extras {
        Ok(()) => Ok(col.finish(c)),
        Err(error) => Err(Box::new(Partial {
            pages: col.finish(c),
            proven_from: None,
            error,
        })),
    }
}

/// The treatments without a `created_at` string whose ObjectId was made
/// at or after `since` (ms), and every one whose `_id` is a string (see
/// [`crate::by_id`]).
pub fn undated_treatments(client: &Client, since: i64, page: usize) -> Result<Pages, NsError> {
    let mut col = Collector::default();
    crate::by_id::without_created_at(client, since, page, &mut col)?;
    Ok(col.finish(Collection::Treatments))
}

/// The paging by time from the newest down (see [`fetch_since`]), from
/// `top` (`$lte`; `None`: no bound) to `lower`. `upper` holds the bound of
/// the next page: every document keyed above it has been read.
fn page_down(
    client: &Client,
    c: Collection,
    lower: Option<&Key>,
    top: Option<&Key>,
    page: usize,
    col: &mut Collector,
    upper: &mut Option<Key>,
) -> Result<(), NsError> {
    let field = c.field();
    let gte = format!("find[{field}][$gte]");
    let lte = format!("find[{field}][$lte]");
    let mut largest = col.largest;
    let call = format!("GET {}", c.path());
    let protocol = |problem: String| NsError::Protocol {
        site: client.site().to_string(),
        call: call.clone(),
        problem,
    };
    loop {
        if col.out.pages >= MAX_PAGES {
            return Err(protocol(format!(
                "more than {MAX_PAGES} pages: the server seems to ignore find[{field}]"
            )));
        }
        let mut q: Vec<(&str, String)> = Vec::new();
        if let Some(l) = lower {
            q.push((&gte, l.query()));
        }
        if let Some(u) = upper.as_ref() {
            q.push((&lte, u.query()));
        }
        q.push(("count", page.to_string()));
        let docs = list(client, c.path(), &q)?;
        col.out.pages += 1;
        if docs.is_empty() {
            break;
        }
        col.out.received += docs.len();
        // A page shorter than one the server served before was not cut
        // by its maximum: it holds everything in its bounds.
        let whole = docs.len() < largest;
        largest = largest.max(docs.len());
        col.largest = col.largest.max(largest);
        let mut fresh = 0;
        let mut least: Option<(Key, Key)> = None;
        // Newest first, as the server compares: a document whose least
        // possible key is above the greatest of the one served before it
        // proves the server does not sort by the date field (the pages
        // are then not the newest at or below each bound).
        let mut prev: Option<Key> = None;
        let mut unsorted = false;
        for d in docs {
            if let (Some(t), Some(u)) = (c.time_of(&d), upper.as_ref()) {
                let beyond = match u {
                    Key::Ms(u) => t > *u,
                    Key::Text(u) => abba_io::time::parse_instant(u)
                        .is_some_and(|u| t > u.as_millisecond() + OFFSET_SLACK_MS),
                };
                if beyond {
                    return Err(protocol(format!(
                        "asked for documents at or before {}, got one at {}: the server ignores find[{field}][$lte]",
                        u.query(),
                        iso_ms(t)
                    )));
                }
            }
            if let Some((lo, hi)) = c.keys_of(&d) {
                if prev.as_ref().is_some_and(|p| lo > *p) {
                    unsorted = true;
                }
                prev = Some(hi.clone());
                least = Some(match least {
                    None => (lo, hi),
                    Some((l, h)) => (l.min(lo), h.min(hi)),
                });
            }
            if col.take(d) {
                fresh += 1;
            }
        }
        if unsorted {
            // Paging by time stands on that order; ranges of time need
            // none (nor any order of `_id`): the whole window is read so.
            let from = lower.cloned().unwrap_or_else(|| c.lower(0));
            crate::by_time::window(client, c, &from, top, page, largest, col)?;
            break;
        }
        let Some((least_lo, least_hi)) = least else {
            // No document carries a time: nothing to page by.
            break;
        };
        // Something new: the next page starts at the least key again (the
        // documents sharing it come once more, kept once); nothing new:
        // below the least key, after reading by `_id` the keys from it to
        // the bound when the page was full (they may hold more).
        let next = if fresh > 0 {
            least_hi.at_or_above()
        } else if whole {
            least_lo.below()
        } else {
            let from = match lower {
                Some(l) if *l > least_lo => l.clone(),
                _ => least_lo.clone(),
            };
            crate::by_id::range(client, c, &from, upper.as_ref(), page, col)?;
            least_lo.below()
        };
        let Some(next) = next else { break };
        if lower.is_some_and(|l| next < *l) {
            break;
        }
        *upper = Some(next);
    }
    Ok(())
}

/// Whether the site filters `c` by time as Nightscout does: asked for
/// the documents at or before the epoch's first millisecond, it must
/// serve none dated later (a server that ignores `find[date]` or
/// `find[created_at]` answers its newest documents whatever the bound).
/// abba reads by time and has no way around a server that does not
/// filter by it: the link is refused before anything is stored.
pub fn check_time_filter(client: &Client, c: Collection) -> Result<(), NsError> {
    let field = c.field();
    let (from, to) = (c.lower(0), c.lower(1));
    let q = [
        (format!("find[{field}][$gte]"), from.query()),
        (format!("find[{field}][$lte]"), to.query()),
        ("count".to_string(), "1".to_string()),
    ];
    let q: Vec<(&str, String)> = q.iter().map(|(k, v)| (k.as_str(), v.clone())).collect();
    let call = format!("GET {}", c.path());
    let docs = list(client, c.path(), &q)?;
    let slack = match c {
        Collection::Entries => 1,
        Collection::Treatments | Collection::DeviceStatus => OFFSET_SLACK_MS,
    };
    if let Some(t) = docs
        .iter()
        .filter_map(|d| c.time_of(d))
        .find(|&t| t > slack)
    {
        return Err(NsError::Protocol {
            site: client.site().to_string(),
            call,
            problem: format!(
                "asked for {} at or before {}, the site served one at {}: it ignores \
                 find[{field}], and abba, which reads a site by time, cannot read it \
                 completely. Nightscout (cgm-remote-monitor) filters by it; this server does not",
                c.name(),
                to.query(),
                iso_ms(t)
            ),
        });
    }
    Ok(())
}

/// The profile store's documents (all of them: a few). A site that
/// serves one profile document as an object (not in an array, as
/// `/api/v1/profile/current` does) has that one; a 404 is none.
pub fn profiles(client: &Client, count: usize) -> Result<Vec<Value>, NsError> {
    let path = "/api/v1/profile.json";
    let docs = match client.get(path, &[("count", count.to_string())]) {
        Ok(Value::Object(o)) if o.contains_key("store") => vec![Value::Object(o)],
        Ok(v) => as_array(client, &format!("GET {path}"), v)?,
        Err(NsError::Status { status: 404, .. }) => Vec::new(),
        Err(e) => return Err(e),
    };
    Ok(docs
        .into_iter()
        .filter(|d| d.get("isValid") != Some(&Value::Bool(false)))
        .collect())
}

/// Whether the site offers API v3 (`/api/v3/version` answers).
pub fn has_v3(client: &Client) -> bool {
    client.get("/api/v3/version", &[]).is_ok_and(|v| {
        v.get("status").and_then(Value::as_i64) == Some(200) || v.get("result").is_some()
    })
}

/// API v3's `lastModified`: per collection, where `history` starts from
/// to see what changes from now on (ms), at most the server's clock
/// (`srvDate`).
///
/// Nightscout answers the newest `srvModified` or, when later, the
/// newest `created_at` (`date` of entries) of any document
/// (`lib/api3/specific/lastModified.js`): one dated ahead (carbs to come,
/// an uploader's clock wrong by a year) puts it past every `srvModified`
/// the server will give for a long while, and `history` after it would
/// show none of the deletions made until then.
pub fn v3_last_modified(client: &Client) -> Result<HashMap<String, i64>, NsError> {
    let v = client.get("/api/v3/lastModified", &[])?;
    let r = v.get("result").unwrap_or(&v);
    let now = r.get("srvDate").and_then(Value::as_i64);
    let mut out = HashMap::new();
    if let Some(Value::Object(cols)) = r.get("collections") {
        for (k, v) in cols {
            if let Some(ms) = v.as_i64() {
                out.insert(k.clone(), now.map_or(ms, |n| ms.min(n)));
            }
        }
    }
    Ok(out)
}

/// What API v3 `history` said since a mark.
#[derive(Debug, Clone, Default)]
pub struct History {
    /// Identifiers of documents deleted (`isValid: false`).
    pub deleted: Vec<String>,
    /// Identifiers of valid documents without a `created_at` string
    /// (treatments v1 paging by time cannot see; one changed long after
    /// it was inserted is outside the `_id` probe's window too).
    pub without_created_at: Vec<String>,
    /// The times (ms, by the collection's date field) of the valid
    /// documents changed: a v1 read from the earliest sees them all, those
    /// uploaded or changed late included.
    pub times: Vec<i64>,
    /// The newest `srvModified` seen (the next mark).
    pub mark: i64,
}

/// The least time API v3 reads as one in milliseconds (2000-01-01).
const V3_MIN_TIMESTAMP: i64 = 946_684_800_000;

/// API v3 `history` of `collection` after `since` (ms of `srvModified`).
/// `limit` is halved while the site refuses it (400: a site's
/// `API3_MAX_LIMIT` below Nightscout's default 1,000).
pub fn v3_history(
    client: &Client,
    collection: &str,
    since: i64,
    limit: usize,
) -> Result<History, NsError> {
    let mut out = History {
        mark: since,
        ..History::default()
    };
    let mut limit = limit.max(1);
    // Nightscout takes a number below 2000-01-01 (`MIN_TIMESTAMP`) as
    // seconds, and refuses one that is still below it (`0`: the mark of a
    // collection empty at the first sync) with a 400
    // (`parseToMoment`, `lib/api3/shared/dateTools.js`): from 2000 on.
    let path_of = |m: i64| format!("/api/v3/{collection}/history/{}", m.max(V3_MIN_TIMESTAMP));
    let mut pages = 0;
    while pages < MAX_PAGES {
        let path = path_of(out.mark);
        let v = match client.get(&path, &[("limit", limit.to_string())]) {
            Ok(v) => v,
            Err(NsError::Status { status: 400, .. }) if limit > 1 => {
                limit /= 2;
                continue;
            }
            Err(e) => return Err(e),
        };
        pages += 1;
        let result = match v {
            Value::Object(mut o) => o.remove("result").unwrap_or(Value::Null),
            other => other,
        };
        let docs = as_array(client, &format!("GET {path}"), result)?;
        if docs.is_empty() {
            break;
        }
        let before = out.mark;
        for d in &docs {
            if let Some(m) = d.get("srvModified").and_then(Value::as_i64) {
                out.mark = out.mark.max(m);
            }
            let Some(id) = d.get("identifier").and_then(Value::as_str) else {
                continue;
            };
            if d.get("isValid") == Some(&Value::Bool(false)) {
                out.deleted.push(id.to_string());
                continue;
            }
            if collection == "treatments" && !d.get("created_at").is_some_and(Value::is_string) {
                out.without_created_at.push(id.to_string());
            }
            let c = match collection {
                "entries" => Some(Collection::Entries),
                "treatments" => Some(Collection::Treatments),
                _ => None,
            };
            if let Some(t) = c.and_then(|c| c.time_of(d)) {
                out.times.push(t);
            }
        }
        if out.mark == before {
            return Err(NsError::Protocol {
                site: client.site().to_string(),
                call: format!("GET {path}"),
                problem: "history documents without a newer srvModified: cannot page".into(),
            });
        }
        if docs.len() < limit {
            break;
        }
    }
    Ok(out)
}

/// The v1 documents (with the `_id` the import keys by) of the treatment
/// API v3 calls `identifier`: by `_id` when it is an ObjectId (v3 names a
/// document created through v1 by its `_id`), else by the `identifier`
/// field. Naming `_id` skips Nightscout's default 4-day filter.
pub fn treatments_of_identifier(client: &Client, identifier: &str) -> Result<Vec<Value>, NsError> {
    let path = Collection::Treatments.path();
    let q: Vec<(&str, String)> = if is_object_id(identifier) {
        vec![
            ("find[_id]", identifier.to_string()),
            ("count", "10".into()),
        ]
    } else {
        vec![
            ("find[identifier]", identifier.to_string()),
            ("find[_id][$ne]", crate::by_id::object_id_at(0)),
            ("count", "10".into()),
        ]
    };
    let docs = list(client, path, &q)?;
    Ok(docs
        .into_iter()
        .filter(|d| {
            d.get("identifier").and_then(Value::as_str) == Some(identifier)
                || doc_id(d).as_deref() == Some(identifier)
        })
        .collect())
}

/// Whether `s` is a MongoDB ObjectId in hex (what `_id` holds on a site).
pub fn is_object_id(s: &str) -> bool {
    s.len() == 24 && s.bytes().all(|b| b.is_ascii_hexdigit())
}

/// The `_id`s (the identity the import keys records by) of the document
/// API v3 calls `identifier`. API v3 serves no `_id`: a document created
/// through v1 has its `_id` as identifier, one created through v3
/// (AndroidAPS) or moved there from a UUID `_id` (Loop) an `identifier`
/// field of its own, which v1 serves beside the `_id` and can be asked for
/// (`find[identifier]`; a deleted document stays there with `isValid:
/// false`). The identifier itself is included: an older site may hold it
/// as the `_id`.
pub fn ids_of_identifier(
    client: &Client,
    c: Collection,
    identifier: &str,
) -> Result<Vec<String>, NsError> {
    let mut ids = vec![identifier.to_string()];
    if is_object_id(identifier) {
        return Ok(ids);
    }
    let q = [
        ("find[identifier]", identifier.to_string()),
        // Naming `_id` skips Nightscout's default 4-day filter (a bound on
        // the date field would miss a treatment without `created_at`);
        // `$ne` the zero ObjectId excludes nothing.
        ("find[_id][$ne]", crate::by_id::object_id_at(0)),
        ("count", "10".to_string()),
    ];
    let docs = list(client, c.path(), &q)?;
    for d in &docs {
        if d.get("identifier").and_then(Value::as_str) == Some(identifier) {
            if let Some(id) = doc_id(d) {
                if !ids.contains(&id) {
                    ids.push(id);
                }
            }
        }
    }
    Ok(ids)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn bounds_in_the_servers_form_bracket_every_stored_form() {
        // Stored forms of 21:54:00 UTC and their place among the bounds
        // Nightscout compares them with (`toISOString()` strings).
        for (stored, above) in [
            ("2026-01-14T21:54:00.000Z", "2026-01-14T21:54:00.000Z"),
            ("2026-01-14T21:54:00Z", "2026-01-14T21:54:01.000Z"),
            ("2026-01-14T21:54:00.5Z", "2026-01-14T21:54:00.600Z"),
            ("2026-01-14T21:54:00.1234Z", "2026-01-14T21:54:00.123Z"),
            ("2026-01-14T22:54:00+01:00", "2026-01-14T22:54:00.000Z"),
            ("2026-01-14T16:54:00.000-05:00", "2026-01-14T16:54:00.000Z"),
        ] {
            let a = canonical_at_or_above(stored).unwrap();
            assert_eq!(a, above, "{stored}");
            assert!(a.as_str() >= stored);
            let b = canonical_below(stored).unwrap();
            assert!(b.as_str() < stored, "{stored}: {b}");
            // Nothing in the server's form lies between.
            let next = iso_ms(abba_io::time::parse_instant(&b).unwrap().as_millisecond() + 1);
            assert!(next.as_str() >= stored, "{stored}: {b} then {next}");
        }
    }

    #[test]
    fn treatments_are_keyed_as_the_server_compares_them() {
        let t = Collection::Treatments;
        let k = |d: Value| t.keys_of(&d).unwrap();
        let text = |s: &str| Key::Text(s.to_string());
        // As served: the stored string.
        let s = "2026-01-14T22:54:00+01:00";
        assert_eq!(
            k(json!({"created_at": s, "utcOffset": 60})),
            (text(s), text(s))
        );
        // An offset without utcOffset may be DE_NORMALIZE_DATES's rewrite of
        // the stored UTC string: both.
        let (lo, hi) = k(json!({"created_at": "2026-01-14T22:54:00.000+01:00"}));
        assert_eq!(lo, text("2026-01-14T21:54:00.000Z"));
        assert_eq!(hi, text("2026-01-14T22:54:00.000+01:00"));
        let (lo, hi) = k(json!({"created_at": "2026-01-14T21:54:00.000+00:00"}));
        assert_eq!(lo, text("2026-01-14T21:54:00.000+00:00"));
        assert_eq!(hi, text("2026-01-14T21:54:00Z"));
        // No created_at: the time of `date`, `mills` or `timestamp`.
        for d in [
            json!({"date": 1_768_427_640_000_i64}),
            json!({"mills": 1_768_427_640_000_i64}),
            json!({"timestamp": "2026-01-14T21:54:00Z"}),
        ] {
            assert_eq!(t.time_of(&d), Some(1_768_427_640_000), "{d}");
            assert_eq!(k(d).0, text("2026-01-14T21:54:00.000Z"));
        }
        assert!(t.keys_of(&json!({"eventType": "Note"})).is_none());
        // Entries by `date`, else `dateString` / `sysTime`.
        let e = Collection::Entries;
        assert_eq!(
            e.time_of(&json!({"sysTime": "2026-01-14T22:54:00.000+0100"})),
            Some(1_768_427_640_000)
        );
        assert!(is_object_id("602d22d89e9fc2456f934373"));
        assert!(!is_object_id("7d6bcbb3-9c4d-4e5e-8d7e-1c1f0f1a2b3c"));
    }
}
