//! Paging API v1 by `_id`, where paging by time cannot reach: the
//! documents of one key (or one narrow range of keys) when they are more
//! than the server serves in a page, and the treatments without a
//! `created_at` string, which no bound on `created_at` matches (API v3
//! inserts on a site with `API3_CREATED_AT_FALLBACK_ENABLED=false`, which
//! carry `date` in ms; uploaders writing to MongoDB directly).
//!
//! What this relies on, read in cgm-remote-monitor 7e0e77f and the
//! MongoDB node driver (our reading, not their code):
//!
//! - `lib/server/query.js` `create()`: a query naming `_id` skips
//!   `enforceDateFilter` entirely (no default 4-day filter, and the other
//!   fields' values reach MongoDB as the strings given: a `created_at`
//!   bound is compared verbatim, and `find[created_at][$not][$type]=string`
//!   is a valid filter, "missing or not a string"); every 24-hex leaf under
//!   `_id` becomes an ObjectId (`updateIdQuery`).
//! - `lib/server/treatments.js` `list()` and `lib/server/entries.js`
//!   `list()`: `.sort(opts.sort || ...)` with the query string's `sort`, so
//!   `sort[_id]=1` reaches the driver as `{_id: '1'}`; the driver's
//!   `prepareDirection` (`src/sort.ts` of mongodb/node-mongodb-native, read
//!   at one commit, not at the 5.9 line Nightscout pins) takes `'1'` and
//!   `'-1'` as 1 and -1. `lib/api/entries/index.js` orders each page by
//!   date again (a stable sort), treatments are served in MongoDB's order.
//! - MongoDB compares only within a type: `$gt` an ObjectId never matches
//!   a string `_id` (Loop's UUIDs), and in ascending order every string
//!   comes before every ObjectId. So each set is read in two runs:
//!   `find[_id][$type]=string` then `$gt` the last string, until an empty
//!   page; then `find[_id][$gte]=<ObjectId>` then `$gt` the last, until an
//!   empty page.
//!
//! A page out of `_id` order (the server ignores `sort[_id]`) has the
//! rest of its run read by ranges of `_id` ([`split`]), which need no
//! order. What cannot be proven is put in
//! [`crate::fetch::Pages::unproven`], which fails the sync: a page
//! outside its bound (the server ignores `find[_id]`), a string `_id` of
//! 24 hex digits ending a page or needed as a bound (it would be sent back
//! as an ObjectId: the strings after it are not reached).
//! A 24-hex `_id` stored as a string (Nightscout's own writes make
//! ObjectIds of them) is taken for an ObjectId.
//!
//! The treatments without `created_at` are read from the ObjectId of the
//! sync's lower bound on (an ObjectId's first 4 bytes are the second it
//! was made, by the server inserting it): what was inserted since the
//! window read again, so the cost follows what is new, with no mark of
//! its own. That misses none: the bound is the treatments' mark less the
//! overlap (24 h), the mark is never later than the last sync plus the
//! import's future skew (10 min), so a document inserted after the last
//! sync began is above it, and one inserted before was read by a sync
//! whose bound was no later (marks only grow), unless the clock making
//! its ObjectId was a day off. Those with a string `_id` have no time to
//! start from and are read whole each sync.

use crate::client::Client;
use crate::error::NsError;
use crate::fetch::{doc_id, is_object_id, list, Collection, Collector, Key, MAX_PAGES};
use serde_json::Value;

/// The least ObjectId made at or after `ms` (its seconds, then zeros).
pub fn object_id_at(ms: i64) -> String {
    let s = ms.div_euclid(1000).clamp(0, i64::from(u32::MAX));
    format!("{s:08x}0000000000000000")
}

/// The documents of `c` with keys from `from` to `to` (inclusive; `None`:
/// no upper bound), all of them, by `_id`.
pub(crate) fn range(
    client: &Client,
    c: Collection,
    from: &Key,
    to: Option<&Key>,
    page: usize,
    col: &mut Collector,
) -> Result<(), NsError> {
    let field = c.field();
    let mut filter = vec![(format!("find[{field}][$gte]"), from.query())];
    if let Some(t) = to {
        filter.push((format!("find[{field}][$lte]"), t.query()));
    }
    let what = match to {
        Some(t) if t == from => format!("{} at {field} {}", c.name(), from.query()),
        Some(t) => format!(
            "{} with {field} from {} to {}",
            c.name(),
            from.query(),
            t.query()
        ),
        None => format!("{} with {field} from {}", c.name(), from.query()),
    };
    paged(client, c, &filter, &object_id_at(0), true, page, &what, col).map(|_| ())
}

/// The treatments without a `created_at` string: those with an ObjectId
/// made at or after `since_ms`, and every one with a string `_id`.
pub(crate) fn without_created_at(
    client: &Client,
    since_ms: i64,
    page: usize,
    col: &mut Collector,
) -> Result<(), NsError> {
    let filter = vec![(
        "find[created_at][$not][$type]".to_string(),
        "string".to_string(),
    )];
    let found = paged(
        client,
        Collection::Treatments,
        &filter,
        &object_id_at(since_ms),
        true,
        page,
        "treatments without a created_at string",
        col,
    )?;
    col.out.without_created_at += found;
    Ok(())
}

/// The documents of `c` inserted since `since_ms` (an ObjectId made at
/// or after it) but dated before it: uploaded late (an uploader catching
/// up after days offline, a meal entered afterwards in Careportal), so
/// outside the window paging by time reads again. Treatments are asked
/// with `created_at` below the window's start plus the widest offset a
/// string may carry (compared verbatim: the query names `_id`); those
/// already read by time come again and are kept once. Only ObjectIds: a
/// string `_id` (Loop's UUIDs) tells nothing of when it was inserted.
/// Returns how many documents were new to this fetch.
pub(crate) fn inserted_since(
    client: &Client,
    c: Collection,
    since_ms: i64,
    page: usize,
    col: &mut Collector,
) -> Result<usize, NsError> {
    let before = match c {
        Collection::Entries => since_ms.to_string(),
        Collection::Treatments | Collection::DeviceStatus => {
            crate::fetch::iso_ms(since_ms.saturating_add(crate::fetch::OFFSET_SLACK_MS))
        }
    };
    let field = c.field();
    let filter = vec![(format!("find[{field}][$lt]"), before.clone())];
    let what = format!(
        "{} inserted since {} with {field} before {before}",
        c.name(),
        crate::fetch::iso_ms(since_ms)
    );
    paged(
        client,
        c,
        &filter,
        &object_id_at(since_ms),
        false,
        page,
        &what,
        col,
    )
}

/// When `filter` asks for documents without a string in a field
/// (`find[created_at][$not][$type]=string`) and the server served one
/// with it, how to say so: the server leaves that filter out (as
/// nightscout/nocturne, Nightscout's API in C#, leaves out operators it
/// does not know), so no page of it can be the documents asked for.
fn ignored_absence(filter: &[(String, String)], docs: &[Value]) -> Option<String> {
    let field = filter.iter().find_map(|(k, v)| {
        (v == "string")
            .then(|| k.strip_prefix("find[")?.strip_suffix("][$not][$type]"))
            .flatten()
    })?;
    let served = docs
        .iter()
        .find(|d| d.get(field).is_some_and(Value::is_string))?;
    Some(format!(
        "asked for those without a {field} string (find[{field}][$not][$type]=string), the site \
         served {} with {field} {}: it leaves that filter out, and those it holds with a {field} \
         string are read by time",
        doc_id(served).unwrap_or_else(|| "a document".into()),
        served[field]
    ))
}

/// Which run of `_id`s a page belongs to, and the last `_id` read in it.
enum Run {
    Strings(Option<String>),
    ObjectIds(Option<String>),
}

/// The lower bound of a range of `_id`s within one run.
#[derive(Debug, Clone)]
enum Lower {
    /// The strings run from its start (`$type` string only).
    Start,
    /// `$gte` this `_id`.
    From(String),
    /// `$gt` this `_id`.
    After(String),
}

impl Lower {
    fn of(run: &Run, from_oid: &str) -> Lower {
        match run {
            Run::Strings(None) => Lower::Start,
            Run::ObjectIds(None) => Lower::From(from_oid.to_string()),
            Run::Strings(Some(l)) | Run::ObjectIds(Some(l)) => Lower::After(l.clone()),
        }
    }
    /// Whether `id` (as [`norm`] gives it) is at or above this bound.
    fn admits(&self, id: &str) -> bool {
        match self {
            Lower::Start => true,
            Lower::From(l) => id >= l.as_str(),
            Lower::After(l) => id > l.as_str(),
        }
    }
}

/// Pages `filter` by `_id` ascending: the string `_id`s (when `strings`),
/// then the ObjectIds from `from_oid`. Returns how many documents were new.
/// A server that serves a run's pages out of `_id` order (it ignores
/// `sort[_id]`) has the rest of the run read by ranges of `_id`
/// ([`split`]), which need no order.
#[allow(clippy::too_many_arguments)]
fn paged(
    client: &Client,
    c: Collection,
    filter: &[(String, String)],
    from_oid: &str,
    strings: bool,
    page: usize,
    what: &str,
    col: &mut Collector,
) -> Result<usize, NsError> {
    let mut run = if strings {
        Run::Strings(None)
    } else {
        Run::ObjectIds(None)
    };
    let mut pages = 0;
    let mut fresh = 0;
    let mut largest = 0;
    let call = format!("GET {}", c.path());
    loop {
        if pages >= MAX_PAGES {
            return Err(NsError::Protocol {
                site: client.site().to_string(),
                call,
                problem: format!("more than {MAX_PAGES} pages of {what} by _id"),
            });
        }
        let mut q: Vec<(&str, String)> = filter
            .iter()
            .map(|(k, v)| (k.as_str(), v.clone()))
            .collect();
        match &run {
            Run::Strings(None) => q.push(("find[_id][$type]", "string".into())),
            Run::Strings(Some(l)) | Run::ObjectIds(Some(l)) => {
                q.push(("find[_id][$gt]", l.clone()))
            }
            Run::ObjectIds(None) => q.push(("find[_id][$gte]", from_oid.to_string())),
        }
        q.push(("sort[_id]", "1".into()));
        q.push(("count", page.to_string()));
        let docs = list(client, c.path(), &q)?;
        pages += 1;
        col.out.pages += 1;
        if let Some(ignored) = ignored_absence(filter, &docs) {
            // Nothing it serves is what was asked, and nothing it could
            // serve would be: said, not a failed sync (what it holds with
            // the field is read by time).
            col.out
                .warnings
                .push(format!("{what} cannot be looked for: {ignored}"));
            return Ok(fresh);
        }
        if docs.is_empty() {
            match run {
                Run::Strings(_) => {
                    run = Run::ObjectIds(None);
                    continue;
                }
                Run::ObjectIds(_) => break,
            }
        }
        col.out.received += docs.len();
        largest = largest.max(docs.len());
        let strings = matches!(run, Run::Strings(_));
        // Entries come ordered by date again (Nightscout's
        // `format_entries`), so their order cannot show a server that
        // ignores `sort[_id]`: a full page of them may be any of the
        // run's documents, not its first, and its last `_id` bounds
        // nothing. Such a page's range is read by ranges of `_id`.
        let full = docs.len() > 1 && docs.len() >= col.largest;
        col.largest = col.largest.max(docs.len());
        let problem = match check(c, &docs, &run, from_oid) {
            None if c == Collection::Entries && full => Some(Problem::Unordered),
            p => p,
        };
        let last = docs
            .iter()
            .filter_map(|d| doc_id(d).map(|id| norm(id, strings)))
            .max();
        for d in docs {
            if col.take(d) {
                fresh += 1;
            }
        }
        match problem {
            Some(Problem::Unordered) => {
                // The range this page was asked for, read without order.
                let lower = Lower::of(&run, from_oid);
                fresh += split(client, c, filter, strings, lower, page, largest, what, col)?;
                if strings {
                    run = Run::ObjectIds(None);
                    continue;
                }
                break;
            }
            Some(Problem::Unbounded(p)) => {
                col.out
                    .unproven
                    .push(format!("{what}: {p}; more may be on the site"));
                if strings {
                    run = Run::ObjectIds(None);
                    continue;
                }
                break;
            }
            None => {}
        }
        let Some(last) = last else { break };
        run = match run {
            Run::Strings(_) if is_object_id(&last) => {
                col.out.unproven.push(format!(
                    "{what}: a page of string _ids ends at {last}, which reads as an ObjectId \
                     and cannot bound the next page; string _ids after it may be on the site"
                ));
                Run::ObjectIds(None)
            }
            Run::Strings(_) => Run::Strings(Some(last)),
            Run::ObjectIds(_) => Run::ObjectIds(Some(last)),
        };
    }
    Ok(fresh)
}

/// Reads the `_id`s of one run from `lower` on without relying on the
/// server's order (one that ignores `sort[_id]`): a range whose page is
/// shorter than the longest the server served holds everything in it; a
/// full one is split at the median `_id` it brought, into the `_id`s below
/// it (`$lt`) and those from it (`$gte`), each holding fewer documents
/// than the range, until every range is read whole. What the server
/// serves outside a range's bounds (it ignores `find[_id]`) proves
/// nothing and is said. Returns how many documents were new.
#[allow(clippy::too_many_arguments)]
fn split(
    client: &Client,
    c: Collection,
    filter: &[(String, String)],
    strings: bool,
    lower: Lower,
    page: usize,
    mut largest: usize,
    what: &str,
    col: &mut Collector,
) -> Result<usize, NsError> {
    let call = format!("GET {}", c.path());
    let mut ranges: Vec<(Lower, Option<String>)> = vec![(lower, None)];
    let mut fresh = 0;
    let mut pages = 0;
    while let Some((lo, hi)) = ranges.pop() {
        if pages >= MAX_PAGES {
            return Err(NsError::Protocol {
                site: client.site().to_string(),
                call,
                problem: format!("more than {MAX_PAGES} pages of {what} by ranges of _id"),
            });
        }
        let mut q: Vec<(&str, String)> = filter
            .iter()
            .map(|(k, v)| (k.as_str(), v.clone()))
            .collect();
        if strings {
            q.push(("find[_id][$type]", "string".into()));
        }
        match &lo {
            Lower::Start => {}
            Lower::From(l) => q.push(("find[_id][$gte]", l.clone())),
            Lower::After(l) => q.push(("find[_id][$gt]", l.clone())),
        }
        if let Some(h) = &hi {
            q.push(("find[_id][$lt]", h.clone()));
        }
        q.push(("sort[_id]", "1".into()));
        q.push(("count", page.to_string()));
        let docs = list(client, c.path(), &q)?;
        pages += 1;
        col.out.pages += 1;
        if let Some(ignored) = ignored_absence(filter, &docs) {
            // Nothing it serves is what was asked, and nothing it could
            // serve would be: said, not a failed sync (what it holds with
            // the field is read by time).
            col.out
                .warnings
                .push(format!("{what} cannot be looked for: {ignored}"));
            return Ok(fresh);
        }
        col.out.received += docs.len();
        let full = !docs.is_empty() && docs.len() >= largest;
        largest = largest.max(docs.len());
        let mut ids = Vec::with_capacity(docs.len());
        let mut outside = None;
        for d in &docs {
            let Some(id) = doc_id(d) else {
                outside = Some("a document without _id".to_string());
                break;
            };
            let oid = is_object_id(&id);
            let id = norm(id, strings);
            // (A 24-hex string among the strings is taken for an
            // ObjectId by the server too: the module's known limit.)
            let inside =
                (strings || oid) && lo.admits(&id) && hi.as_deref().is_none_or(|h| id.as_str() < h);
            if !inside {
                outside = Some(format!(
                    "the server served _id {id} outside the asked range (it ignores find[_id])"
                ));
                break;
            }
            ids.push(id);
        }
        for d in docs {
            if col.take(d) {
                fresh += 1;
            }
        }
        if let Some(p) = outside {
            col.out
                .unproven
                .push(format!("{what}: {p}; more may be on the site"));
            return Ok(fresh);
        }
        if !full {
            continue;
        }
        ids.sort();
        ids.dedup();
        let Some(mid) = ids.get(ids.len() / 2).filter(|_| ids.len() > 1).cloned() else {
            col.out.unproven.push(format!(
                "{what}: a full page of one _id; more may be on the site"
            ));
            return Ok(fresh);
        };
        if strings && is_object_id(&mid) {
            col.out.unproven.push(format!(
                "{what}: _id {mid}, served among the string _ids, reads as an ObjectId \
                 (the server ignores find[_id][$type], or holds a 24-hex string) and cannot \
                 bound a range of strings; string _ids near it may be on the site"
            ));
            return Ok(fresh);
        }
        ranges.push((lo, Some(mid.clone())));
        ranges.push((Lower::From(mid), hi));
    }
    Ok(fresh)
}

/// An `_id` as MongoDB orders it within its run: a string by its bytes,
/// an ObjectId by its bytes (its hex in lower case).
fn norm(id: String, strings: bool) -> String {
    if strings {
        id
    } else {
        id.to_ascii_lowercase()
    }
}

/// Why a page read by `_id` cannot be paged on from its last `_id`.
enum Problem {
    /// Out of `_id` order (the server ignores `sort[_id]`): the range is
    /// read by [`split`] instead.
    Unordered,
    /// Outside the page's bound or without `_id`: nothing bounds it.
    Unbounded(String),
}

/// Why a page read by `_id` proves nothing, if it does not: an `_id`
/// outside the page's bound or of the wrong run, or out of order
/// (entries are served ordered by date again: only ties are checked).
fn check(c: Collection, docs: &[Value], run: &Run, from_oid: &str) -> Option<Problem> {
    let strings = matches!(run, Run::Strings(_));
    let mut prev: Option<(String, Option<i64>)> = None;
    let mut unordered = None;
    for d in docs {
        let Some(id) = doc_id(d) else {
            return Some(Problem::Unbounded("a document without _id".into()));
        };
        let oid = is_object_id(&id);
        let id = norm(id, strings);
        let outside = match run {
            Run::Strings(None) => false,
            Run::Strings(Some(l)) => id.as_str() <= l.as_str(),
            Run::ObjectIds(None) => !oid || id.as_str() < from_oid,
            Run::ObjectIds(Some(l)) => !oid || id.as_str() <= l.as_str(),
        };
        if outside {
            return Some(Problem::Unbounded(format!(
                "the server served _id {id} outside the asked bound (it ignores find[_id])"
            )));
        }
        let t = c.time_of(d);
        if let Some((p, pt)) = &prev {
            let compare = c.keyed_by_text() || *pt == t;
            if compare && p.as_str() > id.as_str() && unordered.is_none() {
                unordered = Some(Problem::Unordered);
            }
        }
        prev = Some((id, t));
    }
    unordered
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn object_ids_of_a_time_bound_what_was_made_since() {
        assert_eq!(object_id_at(0), "000000000000000000000000");
        // 2021-02-17T14:06:16Z, the time in 602d22d89e9fc2456f934373.
        assert_eq!(object_id_at(1_613_570_776_999), "602d22d80000000000000000");
        assert!("602d22d89e9fc2456f934373" >= object_id_at(1_613_570_776_000).as_str());
        assert!("602d22d79e9fc2456f934373" < object_id_at(1_613_570_776_000).as_str());
    }
}
