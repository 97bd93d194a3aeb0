//! Fetching what is new: API v1 collections paged by time (Nightscout
//! answers newest first, at most `count` documents, and a server may cap
//! `count` lower than asked), the profile store, and API v3 `history` for
//! the documents the site reports deleted (`isValid: false`).
//!
//! Paging: the first page is everything from the lower bound (newest
//! first); each next page asks for what is at or before the oldest time of
//! the last one (`$lte`, so documents sharing that instant are not lost;
//! they come again and are kept once by `_id`). A page that brings nothing
//! new moves the bound one millisecond down; an empty page ends it.

use crate::client::Client;
use crate::error::NsError;
use serde_json::Value;
use std::collections::HashMap;

/// A v1 collection read by time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Collection {
    /// `/api/v1/entries.json` by `date` (ms): sgv, mbg, cal.
    Entries,
    /// `/api/v1/treatments.json` by `created_at` (ISO 8601): boluses,
    /// carbs, temporary basals, Profile Switches, notes...
    Treatments,
}

impl Collection {
    /// The name (also the mark's key and v3's collection).
    pub fn name(self) -> &'static str {
        match self {
            Collection::Entries => "entries",
            Collection::Treatments => "treatments",
        }
    }
    /// The v1 path.
    pub fn path(self) -> &'static str {
        match self {
            Collection::Entries => "/api/v1/entries.json",
            Collection::Treatments => "/api/v1/treatments.json",
        }
    }
    fn field(self) -> &'static str {
        match self {
            Collection::Entries => "date",
            Collection::Treatments => "created_at",
        }
    }
    /// The filter value of `ms` in this collection's field.
    fn bound(self, ms: i64) -> String {
        match self {
            Collection::Entries => ms.to_string(),
            Collection::Treatments => iso_ms(ms),
        }
    }
    /// A document's time (ms) by this collection's field (and the
    /// fall-backs the reader uses), if it has one.
    pub fn time_of(self, doc: &Value) -> Option<i64> {
        let num = |k: &str| doc.get(k).and_then(Value::as_f64).map(|v| v as i64);
        let text = |k: &str| {
            doc.get(k)
                .and_then(Value::as_str)
                .and_then(|s| s.parse::<jiff::Timestamp>().ok())
                .map(|t| t.as_millisecond())
        };
        match self {
            Collection::Entries => num("date").or_else(|| text("dateString")),
            Collection::Treatments => text("created_at")
                .or_else(|| num("date"))
                .or_else(|| num("mills")),
        }
    }
}

/// `2026-01-14T21:54:00.000Z`: Nightscout's `created_at` form.
pub fn iso_ms(ms: i64) -> String {
    match jiff::Timestamp::from_millisecond(ms) {
        Ok(t) => t.strftime("%Y-%m-%dT%H:%M:%S%.3fZ").to_string(),
        Err(_) => ms.to_string(),
    }
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
}

/// The most pages one collection's fetch asks for (a guard against a
/// server that ignores the time filter).
pub const MAX_PAGES: usize = 100_000;

fn doc_key(doc: &Value) -> String {
    match doc.get("_id") {
        Some(Value::String(s)) => s.clone(),
        Some(Value::Object(o)) => o
            .get("$oid")
            .and_then(Value::as_str)
            .map_or_else(|| doc.to_string(), String::from),
        _ => doc.to_string(),
    }
}

fn as_array(client: &Client, call: &str, v: Value) -> Result<Vec<Value>, NsError> {
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

/// Every document of `c` at or after `since` (ms; `None`: all), `page`
/// documents asked per page.
pub fn fetch_since(
    client: &Client,
    c: Collection,
    since: Option<i64>,
    page: usize,
) -> Result<Pages, NsError> {
    let field = c.field();
    let gte = format!("find[{field}][$gte]");
    let lte = format!("find[{field}][$lte]");
    let mut out = Pages::default();
    let mut index: HashMap<String, usize> = HashMap::new();
    let mut upper: Option<i64> = None;
    loop {
        if out.pages >= MAX_PAGES {
            return Err(NsError::Protocol {
                site: client.site().to_string(),
                call: format!("GET {}", c.path()),
                problem: format!(
                    "more than {MAX_PAGES} pages: the server seems to ignore find[{field}]"
                ),
            });
        }
        let mut q: Vec<(&str, String)> = Vec::new();
        if let Some(s) = since {
            q.push((&gte, c.bound(s)));
        }
        if let Some(u) = upper {
            q.push((&lte, c.bound(u)));
        }
        q.push(("count", page.to_string()));
        let call = format!("GET {}", c.path());
        let docs = as_array(client, &call, client.get(c.path(), &q)?)?;
        out.pages += 1;
        if docs.is_empty() {
            break;
        }
        out.received += docs.len();
        let mut fresh = 0;
        let mut oldest: Option<i64> = None;
        for d in docs {
            let t = c.time_of(&d);
            if let (Some(t), Some(u)) = (t, upper) {
                if t > u {
                    return Err(NsError::Protocol {
                        site: client.site().to_string(),
                        call,
                        problem: format!("asked for documents at or before {}, got one at {}: the server ignores find[{field}][$lte]", c.bound(u), c.bound(t)),
                    });
                }
            }
            if let Some(t) = t {
                oldest = Some(oldest.map_or(t, |o: i64| o.min(t)));
            }
            let key = doc_key(&d);
            if d.get("isValid") == Some(&Value::Bool(false)) {
                if !out.deleted.contains(&key) {
                    out.deleted.push(key.clone());
                }
                if let Some(&i) = index.get(&key) {
                    out.docs[i] = Value::Null;
                }
                continue;
            }
            match index.get(&key) {
                Some(&i) => out.docs[i] = d,
                None => {
                    index.insert(key, out.docs.len());
                    out.docs.push(d);
                    fresh += 1;
                }
            }
        }
        let Some(oldest) = oldest else {
            // No document carries a time: nothing to page by.
            break;
        };
        upper = Some(if fresh == 0 { oldest - 1 } else { oldest });
        if since.is_some_and(|s| upper.is_some_and(|u| u < s)) {
            break;
        }
    }
    out.docs.retain(|d| !d.is_null());
    out.docs
        .sort_by_key(|d| std::cmp::Reverse(c.time_of(d).unwrap_or(i64::MIN)));
    Ok(out)
}

/// The profile store's documents (all of them: a few).
pub fn profiles(client: &Client, count: usize) -> Result<Vec<Value>, NsError> {
    let path = "/api/v1/profile.json";
    let v = client.get(path, &[("count", count.to_string())])?;
    let docs = as_array(client, &format!("GET {path}"), v)?;
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

/// API v3's `lastModified`: per collection, the newest `srvModified` (ms).
pub fn v3_last_modified(client: &Client) -> Result<HashMap<String, i64>, NsError> {
    let v = client.get("/api/v3/lastModified", &[])?;
    let r = v.get("result").unwrap_or(&v);
    let mut out = HashMap::new();
    if let Some(Value::Object(cols)) = r.get("collections") {
        for (k, v) in cols {
            if let Some(ms) = v.as_i64() {
                out.insert(k.clone(), ms);
            }
        }
    }
    Ok(out)
}

/// API v3 `history` of `collection` after `since` (ms of `srvModified`):
/// the identifiers of documents deleted (`isValid: false`) and the newest
/// `srvModified` seen.
pub fn v3_deleted(
    client: &Client,
    collection: &str,
    since: i64,
    limit: usize,
) -> Result<(Vec<String>, i64), NsError> {
    let mut mark = since;
    let mut deleted = Vec::new();
    let path_of = |m: i64| format!("/api/v3/{collection}/history/{m}");
    for _ in 0..MAX_PAGES {
        let path = path_of(mark);
        let v = client.get(&path, &[("limit", limit.to_string())])?;
        let result = match v {
            Value::Object(mut o) => o.remove("result").unwrap_or(Value::Null),
            other => other,
        };
        let docs = as_array(client, &format!("GET {path}"), result)?;
        if docs.is_empty() {
            break;
        }
        let before = mark;
        for d in &docs {
            if let Some(m) = d.get("srvModified").and_then(Value::as_i64) {
                mark = mark.max(m);
            }
            if d.get("isValid") == Some(&Value::Bool(false)) {
                if let Some(id) = d.get("identifier").and_then(Value::as_str) {
                    deleted.push(id.to_string());
                }
            }
        }
        if mark == before {
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
    Ok((deleted, mark))
}
