//! A Nightscout-compatible server for the tests, on 127.0.0.1, built from
//! Nightscout's documented API (our own code; `lib/server/swagger.yaml`,
//! `lib/api3/doc/*.md`, wiki "API-v1-Security" of nightscout/cgm-remote-monitor):
//!
//! - v1 `entries`, `treatments` (`find[...]` and `sort[...]` as
//!   `mongo.rs` evaluates them, `count` with Nightscout's defaults and a
//!   server-side maximum, newest first unless sorted otherwise),
//!   `profile` (newest `startDate` first), `devicestatus` (by `created_at`
//!   as treatments, `lib/server/devicestatus.js`), `status`; POST/PUT/DELETE of
//!   treatments and PUT of profiles;
//! - authentication: `api-secret` = SHA-1 hex of API_SECRET (admin),
//!   access tokens (`?token=`) of subjects with roles (readable,
//!   careportal, admin, denied), `/api/v2/authorization/request/<token>`
//!   giving a JWT (`Authorization: Bearer`);
//! - v3 `version`, `lastModified` (the newest `srvModified` or, when
//!   later, the newest `created_at` / `date`), `{collection}/history/{ms}`
//!   (JWT only, `limit` at most 1,000, ascending `srvModified`, only what
//!   v3 created, changed or deleted: v1 writes have no `srvModified`,
//!   deleted documents with `isValid: false`);
//! - v1 treatment uploads as `lib/server/treatments.js` stores them
//!   (a replace with upsert keyed by `identifier`, `_id`, or `created_at`
//!   and `eventType`), treatments served with `carbs` and `insulin` as
//!   `Number()` makes them;
//! - injected faults: a status (401, 500, 429 with Retry-After), a
//!   connection cut mid-page, a slow answer, a gzip answer nobody asked for.
//!
//! Filters and sorts act on the stored values as MongoDB's do on a real
//! site (`lib/server/query.js`, `lib/server/treatments.js`,
//! `lib/server/entries.js` of cgm-remote-monitor; see `mongo.rs`): `date`
//! as a number, `created_at` as the stored string (with its bound
//! rewritten to `toISOString()` form, as `enforceDateFilter` does, unless
//! the query names `_id`), a document without the field matching no
//! bound, a 24-hex `_id` an ObjectId and any other a string. Options for a site's other behaviours: a
//! readable default role (`AUTH_DEFAULT_ROLES=readable`, Nightscout's
//! default), no `/api/v2/authorization` (an older site: `?token=`),
//! `DE_NORMALIZE_DATES`, a lower `API3_MAX_LIMIT`, a path prefix.
#![allow(dead_code)]

use super::mongo;
use axum::body::{Body, Bytes};
use axum::extract::{Path, Query, State};
use axum::http::{HeaderMap, Method, StatusCode, Uri};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde_json::{json, Value};
use sha1::{Digest, Sha1};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// What the server holds and how it behaves.
pub struct Site {
    /// API_SECRET.
    pub api_secret: String,
    /// Access token -> roles.
    pub tokens: HashMap<String, Vec<&'static str>>,
    /// The most documents a v1 page holds, whatever `count` asks.
    pub max_count: usize,
    /// Documents by collection (`entries`, `treatments`, `devicestatus`,
    /// `profile`).
    pub docs: HashMap<&'static str, Vec<Doc>>,
    /// Faults still to inject, first match first.
    pub faults: Vec<Fault>,
    /// Every request: method, path and query, auth used.
    pub log: Vec<String>,
    /// JWTs given: jwt -> (token, uses left).
    pub jwts: HashMap<String, (String, Option<usize>)>,
    /// A JWT expires after this many uses (`None`: never).
    pub jwt_uses: Option<usize>,
    /// Whether API v3 is offered.
    pub v3: bool,
    /// A delay before every v1 page.
    pub page_delay: Duration,
    /// Reading needs no credential (Nightscout's default role `readable`);
    /// a wrong credential is refused all the same.
    pub default_readable: bool,
    /// `/api/v2/authorization/request/<token>` is offered.
    pub v2_auth: bool,
    /// Its answer names the token's permissions (`permissionGroups`, one
    /// list per role, as Nightscout 15 does); else only
    /// `/api/v2/authorization/debug/check/<permission>` tells.
    pub grants_in_exchange: bool,
    /// `DE_NORMALIZE_DATES`: v1 serves `created_at` / `dateString` in the
    /// document's `utcOffset` (and drops `utcOffset`).
    pub denormalize: bool,
    /// API v3's largest `limit` (`API3_MAX_LIMIT`).
    pub v3_max_limit: usize,
    /// `sort[...]` is ignored (a server that is not Nightscout's code:
    /// always newest first by the date field).
    pub ignores_sort: bool,
    /// `find[_id][$gt|$gte|$lt|$lte]` are ignored (a server that is not
    /// Nightscout's code and filters `_id` by equality only).
    pub ignores_id_bounds: bool,
    /// `find[<date field>]` is ignored (`date` of entries, `created_at` of
    /// treatments): the newest documents whatever the bound, as a server
    /// that is not Nightscout's code may answer.
    pub ignores_time_filter: bool,
    /// No sort at all, not even by the date field: documents in the order
    /// they were stored (a server that is not Nightscout's code).
    pub unsorted: bool,
    /// Oldest first by the date field whatever `sort[...]` asks (a
    /// server that is not Nightscout's code).
    pub ascending: bool,
    /// A v1 list with no document to serve answers 404 instead of `[]`
    /// (a server that is not Nightscout's code).
    pub empty_is_404: bool,
    /// `/api/v1/profile.json` answers its newest document as an object,
    /// not in an array (as `/api/v1/profile/current` does).
    pub profile_as_object: bool,
    /// `settings.units` in `/api/v1/status.json` (`None`: no `settings`).
    pub status_units: Option<&'static str>,
    /// v1 queries as nightscout/nocturne's `QueryParser` (Nightscout's API
    /// rewritten in C#) reads them: a condition on a field it does not map
    /// (`_id`) or with an operator it does not know (`$type`, `$not`) is
    /// left out, and `sort[...]` is not read (newest first by time). A
    /// query left without a date bound gets Nocturne's last 4 days, here
    /// everything (the fixtures are older than 4 days): either way
    /// documents the query did not ask for.
    pub nocturne_query: bool,
    /// PUT as nightscout/nocturne (Nightscout's API rewritten in C#)
    /// routes it: a treatment only at `/api/v1/treatments/{id}` (405 at
    /// `/api/v1/treatments`, where Nightscout takes it), no profile update
    /// (405). Nightscout answers a PUT to `/api/v1/treatments/{id}` 404.
    pub put_by_id: bool,
    next_id: u64,
    clock: i64,
}

/// One stored document.
#[derive(Clone, Debug)]
pub struct Doc {
    /// As served by v1.
    pub doc: Value,
    /// Server modification time (ms).
    pub srv_modified: i64,
    /// False once deleted through v3 (soft).
    pub valid: bool,
    /// Whether it holds a `srvModified`, which only API v3 writes (a
    /// create, a change, a soft delete): only such a document is in v3's
    /// `history` (a MongoDB filter on `srvModified`), so one uploaded
    /// through v1 (Loop, Trio, xDrip+, Careportal) is not, until v3
    /// changes or deletes it.
    pub v3: bool,
}

/// A fault for the next request whose path contains `path`.
#[derive(Clone, Debug)]
pub struct Fault {
    /// Part of the path.
    pub path: String,
    /// What happens.
    pub kind: FaultKind,
    /// How many times.
    pub times: usize,
}

/// What a fault does.
#[derive(Clone, Debug)]
pub enum FaultKind {
    /// Answer this status.
    Status(u16),
    /// 429 with Retry-After (s).
    TooMany(u64),
    /// 503 with Retry-After (s), as a server restarting or a proxy
    /// before one says.
    Unavailable(u64),
    /// 301 to this Location (a site moved, or http to https).
    Redirect(String),
    /// Lets this many matching requests through, then acts as the
    /// other kind (a site that fails half-way through a long read).
    After(usize, Box<FaultKind>),
    /// Send half of the body, then cut the connection.
    Cut,
    /// Wait this long before answering.
    Slow(Duration),
    /// Answer gzip-compressed (`Content-Encoding: gzip`) whatever the
    /// client asked for, as a misconfigured proxy does.
    Gzip,
    /// Answer with this `Content-Encoding` (the body as it is), as a
    /// proxy compressing in a coding abba does not read would label it.
    Encoded(&'static str),
}

/// The SHA-1 hex Nightscout compares the `api-secret` header with.
pub fn sha1_hex(s: &str) -> String {
    Sha1::digest(s.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

impl Site {
    /// A site with `API_SECRET` and tokens `reader-...` (readable),
    /// `care-...` (careportal + readable), `admin-...` (admin), `denied-...`.
    pub fn new(api_secret: &str) -> Self {
        let mut tokens = HashMap::new();
        tokens.insert("reader-0123456789abcdef".to_string(), vec!["readable"]);
        tokens.insert(
            "care-0123456789abcdef".to_string(),
            vec!["readable", "careportal"],
        );
        tokens.insert("admin-0123456789abcdef".to_string(), vec!["admin"]);
        tokens.insert("denied-0123456789abcdef".to_string(), vec!["denied"]);
        Self {
            api_secret: api_secret.to_string(),
            tokens,
            max_count: 1000,
            docs: HashMap::new(),
            faults: Vec::new(),
            log: Vec::new(),
            jwts: HashMap::new(),
            jwt_uses: None,
            v3: true,
            page_delay: Duration::ZERO,
            default_readable: false,
            v2_auth: true,
            grants_in_exchange: true,
            denormalize: false,
            v3_max_limit: 1000,
            ignores_sort: false,
            ignores_id_bounds: false,
            ignores_time_filter: false,
            unsorted: false,
            ascending: false,
            empty_is_404: false,
            profile_as_object: false,
            status_units: None,
            put_by_id: false,
            nocturne_query: false,
            next_id: 1,
            clock: 1_700_000_000_000,
        }
    }

    /// Sets the server's clock (`srvDate`; the next `srvModified` is
    /// after it).
    pub fn set_clock(&mut self, ms: i64) {
        self.clock = ms;
    }

    /// The next server modification time (strictly increasing).
    fn tick(&mut self) -> i64 {
        self.clock += 1;
        self.clock
    }

    /// Adds documents to a collection as uploaded through API v1 (no
    /// `srvModified`).
    pub fn add(&mut self, col: &'static str, docs: Vec<Value>) {
        for d in docs {
            let m = self.tick();
            self.docs.entry(col).or_default().push(Doc {
                doc: d,
                srv_modified: m,
                valid: true,
                v3: false,
            });
        }
    }

    /// Adds documents as uploaded through API v3 (AndroidAPS): with
    /// `srvModified` and `srvCreated`, in `history`.
    pub fn add_v3(&mut self, col: &'static str, docs: Vec<Value>) {
        for mut d in docs {
            let m = self.tick();
            d["srvModified"] = json!(m);
            d["srvCreated"] = json!(m);
            self.docs.entry(col).or_default().push(Doc {
                doc: d,
                srv_modified: m,
                valid: true,
                v3: true,
            });
        }
    }

    /// Deletes a document softly (as API v3 does; by its `_id` or its
    /// `identifier`): v1 serves it with `isValid: false`, v3 history
    /// reports it.
    pub fn soft_delete(&mut self, col: &'static str, id: &str) {
        let m = self.tick();
        for d in self.docs.entry(col).or_default() {
            if d.doc.get("_id").and_then(Value::as_str) == Some(id)
                || d.doc.get("identifier").and_then(Value::as_str) == Some(id)
            {
                d.valid = false;
                d.srv_modified = m;
                d.v3 = true;
            }
        }
    }

    /// Changes a document as API v3's PATCH does (by its `_id` or its
    /// `identifier`): a new `srvModified`, in the document too.
    pub fn change(&mut self, col: &'static str, id: &str, f: impl Fn(&mut Value)) {
        let m = self.tick();
        for d in self.docs.entry(col).or_default() {
            if d.doc.get("_id").and_then(Value::as_str) == Some(id)
                || d.doc.get("identifier").and_then(Value::as_str) == Some(id)
            {
                f(&mut d.doc);
                d.doc["srvModified"] = json!(m);
                d.srv_modified = m;
                d.v3 = true;
            }
        }
    }

    /// Deletes a document as API v1 does (`DELETE /api/v1/treatments/<id>`,
    /// a MongoDB `deleteMany`): gone, with no trace in v1 or v3.
    pub fn hard_delete(&mut self, col: &'static str, id: &str) {
        self.docs
            .entry(col)
            .or_default()
            .retain(|d| d.doc.get("_id").and_then(Value::as_str) != Some(id));
    }

    /// The valid documents of a collection.
    pub fn valid(&self, col: &str) -> Vec<Value> {
        self.docs
            .get(col)
            .map(|v| {
                v.iter()
                    .filter(|d| d.valid)
                    .map(|d| d.doc.clone())
                    .collect()
            })
            .unwrap_or_default()
    }

    /// A treatment POSTed to v1, as `lib/server/treatments.js` stores it:
    /// `created_at` in `toISOString()` form (now when it has none), then
    /// a replace with upsert keyed by its `identifier`, else its `_id`,
    /// else **its `created_at` and `eventType`** (15.0.2 and before: by
    /// those always), so a second document of one type at one
    /// millisecond replaces the first. The answer is the document as
    /// posted: with the new `_id` when it was inserted, without one when
    /// it replaced a stored document (keeping that one's `_id`).
    pub fn upsert_treatment(&mut self, mut d: Value) -> Value {
        let at = ms_of(&d, "created_at").unwrap_or_else(|| jiff::Timestamp::now().as_millisecond());
        d["created_at"] = Value::String(iso(at));
        let key: (&str, Value) = if let Some(i) = d.get("identifier").filter(|v| !v.is_null()) {
            ("identifier", i.clone())
        } else if let Some(i) = d
            .get("_id")
            .filter(|v| v.as_str().is_some_and(|s| !s.is_empty()))
        {
            ("_id", i.clone())
        } else {
            ("created_at", d["created_at"].clone())
        };
        let event = d.get("eventType").cloned();
        let m = self.tick();
        let docs = self.docs.entry("treatments").or_default();
        let matched = docs.iter_mut().find(|s| {
            s.doc.get(key.0) == Some(&key.1)
                && (key.0 != "created_at" || s.doc.get("eventType") == event.as_ref())
        });
        if let Some(stored) = matched {
            let mut replacement = d.clone();
            replacement["_id"] = stored.doc["_id"].clone();
            stored.v3 = replacement.get("srvModified").is_some();
            stored.doc = replacement;
            stored.srv_modified = m;
            stored.valid = true;
            return d;
        }
        if d.get("_id")
            .and_then(Value::as_str)
            .is_none_or(str::is_empty)
        {
            d["_id"] = Value::String(self.new_id());
        }
        self.add("treatments", vec![d.clone()]);
        d
    }

    fn new_id(&mut self) -> String {
        self.next_id += 1;
        format!("ab{:022x}", self.next_id)
    }
}

/// Who is asking.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Who {
    Nobody,
    Roles(Read, Write),
}
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Read(bool);
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Write {
    /// `api:treatments:create` (careportal, admin).
    treatments: bool,
    /// `api:treatments:update`, `api:treatments:delete`,
    /// `api:profile:update` (admin only: Nightscout's careportal role
    /// grants `api:treatments:create` alone, `lib/authorization/storage.js`).
    profile: bool,
}

fn roles(rs: &[&str]) -> Who {
    let admin = rs.contains(&"admin");
    let read = admin || rs.contains(&"readable") || rs.contains(&"careportal");
    Who::Roles(
        Read(read),
        Write {
            treatments: admin || rs.contains(&"careportal"),
            profile: admin,
        },
    )
}

type Shared = Arc<Mutex<Site>>;

fn who(site: &mut Site, headers: &HeaderMap, query: &[(String, String)], v3: bool) -> Who {
    let attempted = headers.contains_key("authorization")
        || headers.contains_key("api-secret")
        || query.iter().any(|(k, _)| k == "token" || k == "secret");
    if !attempted && !v3 && site.default_readable {
        // `authorization.resolve`: no credential, the default roles.
        return roles(&["readable"]);
    }
    if let Some(b) = headers
        .get("authorization")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
    {
        let Some((token, uses)) = site.jwts.get_mut(b) else {
            return Who::Nobody;
        };
        if let Some(u) = uses {
            if *u == 0 {
                return Who::Nobody;
            }
            *u -= 1;
        }
        let token = token.clone();
        return site.tokens.get(&token).map_or(Who::Nobody, |r| roles(r));
    }
    if v3 {
        // API v3 takes JWTs only.
        return Who::Nobody;
    }
    if let Some(h) = headers.get("api-secret").and_then(|v| v.to_str().ok()) {
        return if h.eq_ignore_ascii_case(&sha1_hex(&site.api_secret)) {
            roles(&["admin"])
        } else {
            Who::Nobody
        };
    }
    if let Some((_, t)) = query.iter().find(|(k, _)| k == "token") {
        return site.tokens.get(t).map_or(Who::Nobody, |r| roles(r));
    }
    Who::Nobody
}

/// A query MongoDB or Nightscout's code refuses: Nightscout answers 500.
fn mongo_error(e: &str) -> Response {
    (
        StatusCode::INTERNAL_SERVER_ERROR,
        axum::Json(json!({"status": 500, "message": "Mongo Error", "description": e})),
    )
        .into_response()
}

fn unauthorized() -> Response {
    (
        StatusCode::UNAUTHORIZED,
        axum::Json(
            json!({"status": 401, "message": "Unauthorized", "description": "Invalid/Missing"}),
        ),
    )
        .into_response()
}

/// The fault for this request, if any (taken from the list).
fn fault(site: &mut Site, path: &str) -> Option<FaultKind> {
    let i = site
        .faults
        .iter()
        .position(|f| path.contains(&f.path) && f.times > 0)?;
    if let FaultKind::After(n, inner) = &mut site.faults[i].kind {
        if *n > 0 {
            *n -= 1;
            return None;
        }
        let k = (**inner).clone();
        site.faults[i].kind = k;
    }
    site.faults[i].times -= 1;
    let k = site.faults[i].kind.clone();
    if site.faults[i].times == 0 {
        site.faults.remove(i);
    }
    Some(k)
}

/// Answers `body` as JSON, or as the fault says.
async fn answer(kind: Option<FaultKind>, status: StatusCode, body: Value) -> Response {
    match kind {
        Some(FaultKind::Status(s)) => {
            let s = StatusCode::from_u16(s).unwrap_or(StatusCode::INTERNAL_SERVER_ERROR);
            (
                s,
                axum::Json(json!({"status": s.as_u16(), "message": "injected"})),
            )
                .into_response()
        }
        Some(FaultKind::TooMany(secs)) => (
            StatusCode::TOO_MANY_REQUESTS,
            [("retry-after", secs.to_string())],
            "Too Many Requests",
        )
            .into_response(),
        Some(FaultKind::Unavailable(secs)) => (
            StatusCode::SERVICE_UNAVAILABLE,
            [("retry-after", secs.to_string())],
            "Service Unavailable",
        )
            .into_response(),
        Some(FaultKind::Redirect(to)) => (
            StatusCode::MOVED_PERMANENTLY,
            [("location", to)],
            "Moved Permanently",
        )
            .into_response(),
        Some(FaultKind::Cut) => {
            let text = body.to_string().into_bytes();
            let half = Bytes::from(text[..text.len() / 2].to_vec());
            let parts: Vec<Result<Bytes, std::io::Error>> = vec![
                Ok(half),
                Err(std::io::Error::new(
                    std::io::ErrorKind::ConnectionReset,
                    "injected cut",
                )),
            ];
            Response::builder()
                .status(status)
                .header("content-type", "application/json")
                .body(Body::from_stream(futures_util::stream::iter(parts)))
                .unwrap_or_default()
        }
        Some(FaultKind::Slow(d)) => {
            tokio::time::sleep(d).await;
            (status, axum::Json(body)).into_response()
        }
        Some(FaultKind::Encoded(coding)) => Response::builder()
            .status(status)
            .header("content-type", "application/json")
            .header("content-encoding", coding)
            .body(Body::from(body.to_string()))
            .unwrap_or_default(),
        Some(FaultKind::Gzip) => Response::builder()
            .status(status)
            .header("content-type", "application/json")
            .header("content-encoding", "gzip")
            .body(Body::from(gzip_stored(body.to_string().as_bytes())))
            .unwrap_or_default(),
        // (Resolved by `fault` before it is met.)
        Some(FaultKind::After(..)) | None => (status, axum::Json(body)).into_response(),
    }
}

/// `data` as a gzip stream of stored (uncompressed) deflate blocks.
fn gzip_stored(data: &[u8]) -> Vec<u8> {
    let mut out = vec![0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 255];
    let chunks: Vec<&[u8]> = if data.is_empty() {
        vec![&[]]
    } else {
        data.chunks(65_535).collect()
    };
    for (i, c) in chunks.iter().enumerate() {
        out.push(u8::from(i + 1 == chunks.len()));
        let len = c.len() as u16;
        out.extend_from_slice(&len.to_le_bytes());
        out.extend_from_slice(&(!len).to_le_bytes());
        out.extend_from_slice(c);
    }
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    out.extend_from_slice(&(!crc).to_le_bytes());
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out
}

fn ms_of(v: &Value, field: &str) -> Option<i64> {
    match v.get(field)? {
        Value::Number(n) => n.as_f64().map(|f| f as i64),
        Value::String(s) => s
            .parse::<jiff::Timestamp>()
            .ok()
            .map(|t| t.as_millisecond()),
        _ => None,
    }
}

/// `2026-01-14T21:54:00.000Z` (JavaScript's `toISOString()`).
pub fn iso(ms: i64) -> String {
    jiff::Timestamp::from_millisecond(ms)
        .unwrap()
        .strftime("%Y-%m-%dT%H:%M:%S%.3fZ")
        .to_string()
}

/// MongoDB's order of two stored values of one field: numbers by value,
/// strings by their bytes, numbers before strings; `None` for others.
fn mongo_cmp(a: &Value, b: &Value) -> Option<std::cmp::Ordering> {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => x.as_f64()?.partial_cmp(&y.as_f64()?),
        (Value::String(x), Value::String(y)) => Some(x.as_bytes().cmp(y.as_bytes())),
        _ => None,
    }
}

/// Whether `doc`'s `field` passes `op value` as MongoDB compares them (a
/// document without the field, or of another type, passes no bound).
fn keep(doc: &Value, field: &str, op: &str, value: &Value) -> bool {
    let Some(x) = doc.get(field) else {
        return false;
    };
    let Some(o) = mongo_cmp(x, value) else {
        return false;
    };
    use std::cmp::Ordering::*;
    match op {
        "$gte" => o != Less,
        "$gt" => o == Greater,
        "$lte" => o != Greater,
        "$lt" => o == Less,
        "$eq" => o == Equal,
        _ => true,
    }
}

/// `DE_NORMALIZE_DATES`: the stored UTC time written in the document's
/// `utcOffset`, as `moment(...).utcOffset(o).toISOString(true)` does.
fn denormalized(mut doc: Value, field: &str) -> Value {
    let (Some(t), Some(off)) = (
        doc.get(field)
            .and_then(Value::as_str)
            .and_then(|s| s.parse::<jiff::Timestamp>().ok()),
        doc.get("utcOffset").and_then(Value::as_i64),
    ) else {
        return doc;
    };
    let offset = jiff::tz::Offset::from_seconds((off * 60) as i32).unwrap();
    let local = t.to_zoned(jiff::tz::TimeZone::fixed(offset));
    let sign = if off < 0 { '-' } else { '+' };
    let text = format!(
        "{}{sign}{:02}:{:02}",
        local.strftime("%Y-%m-%dT%H:%M:%S%.3f"),
        off.abs() / 60,
        off.abs() % 60
    );
    doc[field] = Value::String(text);
    if let Some(o) = doc.as_object_mut() {
        o.remove("utcOffset");
    }
    doc
}

/// A treatment as v1 serves it: `serveTreatments` in
/// `lib/api/treatments/index.js` sets `carbs` and `insulin` of every
/// document to JavaScript's `Number()` of the stored value, so a document
/// without them (a Temp Basal, a Note) is served with `"carbs": null,
/// "insulin": null` (`NaN` in JSON), `""` as `0` and a numeric string as
/// its number. A stored `null` would be served as `0`, but v1 uploads
/// never store one (`prepareData` deletes an empty `carbs` or `insulin`)
/// and the fixtures' `null`s are what v1 served (`NaN`): served as they are.
fn numbers_served(mut doc: Value) -> Value {
    if let Some(o) = doc.as_object_mut() {
        for k in ["carbs", "insulin"] {
            let n = match o.get(k) {
                None | Some(Value::Null) => None,
                Some(Value::Bool(false)) => Some(0.0),
                Some(Value::Bool(true)) => Some(1.0),
                Some(Value::Number(n)) => n.as_f64(),
                Some(Value::String(s)) if s.trim().is_empty() => Some(0.0),
                Some(Value::String(s)) => s.trim().parse::<f64>().ok().filter(|x| x.is_finite()),
                Some(_) => None,
            };
            let v = match n {
                Some(x) if x.fract() == 0.0 && x.abs() < 9e15 => json!(x as i64),
                Some(x) => json!(x),
                None => Value::Null,
            };
            o.insert(k.to_string(), v);
        }
    }
    doc
}

async fn v1_list(
    State(s): State<Shared>,
    method: Method,
    uri: Uri,
    headers: HeaderMap,
    Query(q): Query<Vec<(String, String)>>,
) -> Response {
    let path = uri.path().to_string();
    let col: &'static str = if path.contains("entries") {
        "entries"
    } else if path.contains("treatments") {
        "treatments"
    } else if path.contains("devicestatus") {
        "devicestatus"
    } else {
        "profile"
    };
    let (kind, body, delay) = {
        let mut site = s.lock().unwrap();
        site.log.push(format!(
            "{method} {}{}",
            path,
            uri.query().map(|q| format!("?{q}")).unwrap_or_default()
        ));
        match who(&mut site, &headers, &q, false) {
            Who::Roles(Read(true), _) => {}
            _ => return unauthorized(),
        }
        let kind = fault(&mut site, &path);
        let sort = if col == "profile" {
            "startDate"
        } else if col == "entries" {
            "date"
        } else {
            "created_at"
        };
        let q: Vec<(String, String)> = if site.ignores_time_filter {
            q.into_iter()
                .filter(|(k, _)| !k.starts_with("find[date]") && !k.starts_with("find[created_at]"))
                .collect()
        } else {
            q
        };
        let q: Vec<(String, String)> = if site.ignores_id_bounds {
            let had_id = q.iter().any(|(k, _)| k.starts_with("find[_id]"));
            let mut q: Vec<(String, String)> = q
                .into_iter()
                .filter(|(k, _)| {
                    !["$gt", "$gte", "$lt", "$lte"]
                        .iter()
                        .any(|op| k == &format!("find[_id][{op}]"))
                })
                .collect();
            // Still a query naming `_id` (no date rewriting), matching all.
            if had_id && !q.iter().any(|(k, _)| k.starts_with("find[_id]")) {
                q.push((
                    "find[_id][$ne]".to_string(),
                    "000000000000000000000000".to_string(),
                ));
            }
            q
        } else {
            q
        };
        let nocturne = site.nocturne_query;
        let q: Vec<(String, String)> = if nocturne {
            q.into_iter()
                .filter(|(k, _)| {
                    !(k.starts_with("find[_id]")
                        || k.contains("[$type]")
                        || k.contains("[$not]")
                        || k.starts_with("sort["))
                })
                .collect()
        } else {
            q
        };
        let find = match mongo::Find::parse(col, &q) {
            Ok(f) => f,
            Err(e) => return mongo_error(&e),
        };
        // Nightscout's `enforceDateFilter`: a v1 query of entries or
        // treatments without a bound on its date field and without `_id`
        // gets the last 4 days.
        let bounded =
            find.has_id() || find.names(sort) || (col == "entries" && find.names("dateString"));
        let bound =
            (col != "profile" && !bounded && !site.ignores_time_filter && !nocturne).then(|| {
                let from = jiff::Timestamp::now().as_millisecond() - 4 * 86_400_000;
                if col == "entries" {
                    json!(from)
                } else {
                    Value::String(iso(from))
                }
            });
        // The stored documents the query keeps (a deleted one shows
        // `isValid: false`), cloned only when kept.
        let mut docs: Vec<Value> = Vec::new();
        for d in site.docs.get(col).into_iter().flatten() {
            let doc = if d.valid {
                std::borrow::Cow::Borrowed(&d.doc)
            } else {
                let mut doc = d.doc.clone();
                doc["isValid"] = Value::Bool(false);
                std::borrow::Cow::Owned(doc)
            };
            if bound.as_ref().is_some_and(|b| !keep(&doc, sort, "$gte", b)) {
                continue;
            }
            match find.matches(&doc) {
                Ok(true) => docs.push(doc.into_owned()),
                Ok(false) => {}
                Err(e) => return mongo_error(&e),
            }
        }
        // MongoDB's sort: `sort[...]` as given, else the stored date
        // field, newest first (documents without it last).
        let asked: &[(String, String)] = if site.ignores_sort || site.ascending {
            &[]
        } else {
            &q
        };
        let by = match mongo::sort_of(asked, (sort, if site.ascending { 1 } else { -1 })) {
            Ok(b) => b,
            Err(e) => return mongo_error(&e),
        };
        if !site.unsorted {
            mongo::sort(&mut docs, &by);
        }
        let count = q
            .iter()
            .find(|(k, _)| k == "count")
            .and_then(|(_, v)| v.parse::<usize>().ok())
            .unwrap_or(match col {
                // `lib/api/treatments/index.js`: 1,000 with a `find`.
                "treatments" if q.iter().any(|(k, _)| k.starts_with("find[")) => 1000,
                "treatments" => 100,
                // `lib/api/devicestatus/index.js`: 10, as entries.
                _ => 10,
            })
            .min(site.max_count);
        let mut docs: Vec<Value> = docs.into_iter().take(count).collect();
        if col == "entries" && !site.ascending {
            // `format_entries` orders the page by `mills` or `date`,
            // newest first (a stable sort: ties keep MongoDB's order).
            docs.sort_by_key(|d| {
                std::cmp::Reverse(
                    d.get("mills")
                        .and_then(Value::as_i64)
                        .or_else(|| d.get("date").and_then(Value::as_i64))
                        .unwrap_or(i64::MIN),
                )
            });
        }
        let denorm = site.denormalize;
        let page: Vec<Value> = docs
            .into_iter()
            .map(|d| match (denorm, col) {
                (true, "treatments") => denormalized(numbers_served(d), "created_at"),
                (_, "treatments") => numbers_served(d),
                (true, "entries") => denormalized(d, "dateString"),
                _ => d,
            })
            .collect();
        if page.is_empty() && site.empty_is_404 {
            return (
                StatusCode::NOT_FOUND,
                axum::Json(json!({"status": 404, "message": "no documents found"})),
            )
                .into_response();
        }
        let body = match (col, site.profile_as_object, page.first()) {
            ("profile", true, Some(first)) => first.clone(),
            _ => Value::Array(page),
        };
        (kind, body, site.page_delay)
    };
    if !delay.is_zero() {
        tokio::time::sleep(delay).await;
    }
    answer(kind, StatusCode::OK, body).await
}

async fn status(
    State(s): State<Shared>,
    headers: HeaderMap,
    uri: Uri,
    Query(q): Query<Vec<(String, String)>>,
) -> Response {
    let (kind, units) = {
        let mut site = s.lock().unwrap();
        site.log.push(format!("GET {}", uri.path()));
        if !matches!(
            who(&mut site, &headers, &q, false),
            Who::Roles(Read(true), _)
        ) {
            return unauthorized();
        }
        (fault(&mut site, uri.path()), site.status_units)
    };
    let mut body =
        json!({"status": "ok", "name": "nightscout", "version": "15.0.3-test", "apiEnabled": true});
    if let Some(u) = units {
        body["settings"] = json!({"units": u});
    }
    answer(kind, StatusCode::OK, body).await
}

async fn write_treatments(
    State(s): State<Shared>,
    method: Method,
    uri: Uri,
    headers: HeaderMap,
    Query(q): Query<Vec<(String, String)>>,
    axum::Json(body): axum::Json<Value>,
) -> Response {
    let mut site = s.lock().unwrap();
    site.log.push(format!("{method} {}", uri.path()));
    // POST needs `api:treatments:create`, PUT `api:treatments:update`
    // (`lib/api/treatments/index.js`); v1 refuses either with a 401.
    match (who(&mut site, &headers, &q, false), method == Method::POST) {
        (
            Who::Roles(
                _,
                Write {
                    treatments: true, ..
                },
            ),
            true,
        )
        | (Who::Roles(_, Write { profile: true, .. }), false) => {}
        _ => return unauthorized(),
    }
    if method == Method::POST {
        let items = match body {
            Value::Array(a) => a,
            other => vec![other],
        };
        let mut created = Vec::new();
        for d in items {
            created.push(site.upsert_treatment(d));
        }
        return (StatusCode::OK, axum::Json(Value::Array(created))).into_response();
    }
    // PUT: replace by _id.
    if site.put_by_id {
        return StatusCode::METHOD_NOT_ALLOWED.into_response();
    }
    let Some(id) = body.get("_id").and_then(Value::as_str).map(String::from) else {
        return (StatusCode::BAD_REQUEST, "missing _id").into_response();
    };
    replace_treatment(&mut site, &id, body)
}

/// `PUT /api/v1/treatments/{id}`: Nocturne's route (see `put_by_id`);
/// Nightscout has none (404, "Cannot PUT").
async fn put_treatment_by_id(
    State(s): State<Shared>,
    headers: HeaderMap,
    Path(id): Path<String>,
    Query(q): Query<Vec<(String, String)>>,
    axum::Json(mut body): axum::Json<Value>,
) -> Response {
    let mut site = s.lock().unwrap();
    site.log.push(format!("PUT /api/v1/treatments/{id}"));
    if !site.put_by_id {
        return (StatusCode::NOT_FOUND, "Cannot PUT").into_response();
    }
    match who(&mut site, &headers, &q, false) {
        Who::Roles(_, Write { profile: true, .. }) => {}
        _ => return unauthorized(),
    }
    body["_id"] = Value::String(id.clone());
    replace_treatment(&mut site, &id, body)
}

fn replace_treatment(site: &mut Site, id: &str, body: Value) -> Response {
    let m = site.tick();
    let docs = site.docs.entry("treatments").or_default();
    match docs
        .iter_mut()
        .find(|d| d.doc.get("_id").and_then(Value::as_str) == Some(id))
    {
        Some(d) => {
            // A v1 replace: the `srvModified` the body holds, if any.
            d.v3 = body.get("srvModified").is_some();
            d.srv_modified = body.get("srvModified").and_then(Value::as_i64).unwrap_or(m);
            d.doc = body.clone();
            (StatusCode::OK, axum::Json(body)).into_response()
        }
        None => (StatusCode::NOT_FOUND, "no such treatment").into_response(),
    }
}

async fn delete_treatment(
    State(s): State<Shared>,
    headers: HeaderMap,
    Path(id): Path<String>,
    Query(q): Query<Vec<(String, String)>>,
) -> Response {
    let mut site = s.lock().unwrap();
    site.log.push(format!("DELETE /api/v1/treatments/{id}"));
    // `api:treatments:delete`.
    match who(&mut site, &headers, &q, false) {
        Who::Roles(_, Write { profile: true, .. }) => {}
        _ => return unauthorized(),
    }
    let docs = site.docs.entry("treatments").or_default();
    docs.retain(|d| d.doc.get("_id").and_then(Value::as_str) != Some(&id));
    (StatusCode::OK, axum::Json(json!({}))).into_response()
}

async fn put_profile(
    State(s): State<Shared>,
    headers: HeaderMap,
    Query(q): Query<Vec<(String, String)>>,
    axum::Json(body): axum::Json<Value>,
) -> Response {
    let mut site = s.lock().unwrap();
    site.log.push("PUT /api/v1/profile".into());
    if site.put_by_id {
        return StatusCode::METHOD_NOT_ALLOWED.into_response();
    }
    match who(&mut site, &headers, &q, false) {
        Who::Roles(_, Write { profile: true, .. }) => {}
        _ => return unauthorized(),
    }
    let Some(id) = body.get("_id").and_then(Value::as_str).map(String::from) else {
        return (StatusCode::BAD_REQUEST, "missing _id").into_response();
    };
    let m = site.tick();
    let docs = site.docs.entry("profile").or_default();
    match docs
        .iter_mut()
        .find(|d| d.doc.get("_id").and_then(Value::as_str) == Some(&id))
    {
        Some(d) => {
            // A v1 replace: the `srvModified` the body holds, if any.
            d.v3 = body.get("srvModified").is_some();
            d.srv_modified = body.get("srvModified").and_then(Value::as_i64).unwrap_or(m);
            d.doc = body.clone();
            (StatusCode::OK, axum::Json(body)).into_response()
        }
        None => (StatusCode::NOT_FOUND, "no such profile").into_response(),
    }
}

async fn authorization_request(State(s): State<Shared>, Path(token): Path<String>) -> Response {
    let mut site = s.lock().unwrap();
    site.log
        .push("GET /api/v2/authorization/request/<token>".into());
    if !site.v2_auth {
        return (StatusCode::NOT_FOUND, "Cannot GET").into_response();
    }
    if !site.tokens.contains_key(&token) {
        return unauthorized();
    }
    let n = site.jwts.len();
    let jwt = format!("eyJhbGciOiJIUzI1NiJ9.eyJ0ZXN0Ijo{n}fQ.sig{n}");
    let uses = site.jwt_uses;
    site.jwts.insert(jwt.clone(), (token.clone(), uses));
    let mut answer = json!({"token": jwt, "sub": token, "iat": 1, "exp": 2});
    if site.grants_in_exchange {
        let groups: Vec<Vec<&str>> = site.tokens[&token]
            .iter()
            .map(|r| permissions_of_role(r))
            .collect();
        answer["permissionGroups"] = json!(groups);
    }
    (StatusCode::OK, axum::Json(answer)).into_response()
}

/// Nightscout's default roles as permissions (`lib/authorization/storage.js`).
fn permissions_of_role(role: &str) -> Vec<&'static str> {
    match role {
        "admin" => vec!["*"],
        "readable" => vec!["*:*:read"],
        "careportal" => vec!["api:treatments:create"],
        _ => vec![],
    }
}

/// `/api/v2/authorization/debug/check/<permission>`: `{check: true}` when
/// the caller's roles grant it, else 401.
async fn authorization_check(
    State(s): State<Shared>,
    headers: HeaderMap,
    Path(permission): Path<String>,
    Query(q): Query<Vec<(String, String)>>,
) -> Response {
    let mut site = s.lock().unwrap();
    site.log.push(format!(
        "GET /api/v2/authorization/debug/check/{permission}"
    ));
    if !site.v2_auth {
        return (StatusCode::NOT_FOUND, "Cannot GET").into_response();
    }
    let Who::Roles(_, w) = who(&mut site, &headers, &q, false) else {
        return unauthorized();
    };
    let ok = match permission.as_str() {
        p if p.ends_with(":read") => true,
        "api:treatments:create" => w.treatments,
        _ => w.profile,
    };
    if ok {
        axum::Json(json!({"check": true})).into_response()
    } else {
        unauthorized()
    }
}

async fn v3_version(State(s): State<Shared>) -> Response {
    let site = s.lock().unwrap();
    if !site.v3 {
        return (StatusCode::NOT_FOUND, "Cannot GET /api/v3/version").into_response();
    }
    axum::Json(
        json!({"status": 200, "result": {"version": "15.0.3-test", "apiVersion": "3.0.4-alpha"}}),
    )
    .into_response()
}

async fn v3_last_modified(State(s): State<Shared>, headers: HeaderMap) -> Response {
    let mut site = s.lock().unwrap();
    if !site.v3 {
        return StatusCode::NOT_FOUND.into_response();
    }
    if who(&mut site, &headers, &[], true) == Who::Nobody {
        return unauthorized();
    }
    // `lib/api3/specific/lastModified.js`: the newest `srvModified`, or
    // the newest of the collection's fallback date field (`date` of
    // entries, else `created_at`, the greatest string read as a time)
    // when that is later: a document dated ahead (carbs to come, a phone
    // clock wrong) makes it later than the server's own clock.
    let mut cols = serde_json::Map::new();
    for (k, v) in &site.docs {
        let dated = if *k == "entries" {
            v.iter().filter_map(|d| ms_of(&d.doc, "date")).max()
        } else {
            v.iter()
                .filter_map(|d| d.doc.get("created_at").and_then(Value::as_str))
                .max()
                .and_then(|t| t.parse::<jiff::Timestamp>().ok())
                .map(|t| t.as_millisecond())
        };
        let modified = v.iter().filter(|d| d.v3).map(|d| d.srv_modified).max();
        if let Some(m) = modified.max(dated) {
            cols.insert((*k).to_string(), json!(m));
        }
    }
    axum::Json(json!({"status": 200, "result": {"srvDate": site.clock, "collections": cols}}))
        .into_response()
}

async fn v3_history(
    State(s): State<Shared>,
    headers: HeaderMap,
    Path((col, since)): Path<(String, i64)>,
    Query(q): Query<Vec<(String, String)>>,
) -> Response {
    let mut site = s.lock().unwrap();
    site.log.push(format!("GET /api/v3/{col}/history/{since}"));
    if !site.v3 {
        return StatusCode::NOT_FOUND.into_response();
    }
    if who(&mut site, &headers, &[], true) == Who::Nobody {
        return unauthorized();
    }
    // `parseToMoment` (`lib/api3/shared/dateTools.js`): a number below
    // MIN_TIMESTAMP (2000-01-01) is read as seconds, and refused when
    // that is below it too (`0` among them).
    const MIN_TIMESTAMP: i64 = 946_684_800_000;
    let since = if since >= MIN_TIMESTAMP {
        since
    } else if since.saturating_mul(1000) >= MIN_TIMESTAMP {
        since * 1000
    } else {
        return (
            StatusCode::BAD_REQUEST,
            axum::Json(
                json!({"status": 400, "message": "Bad or missing Last-Modified header/parameter"}),
            ),
        )
            .into_response();
    };
    let limit = match q.iter().find(|(k, _)| k == "limit") {
        None => site.v3_max_limit,
        Some((_, v)) => match v.parse::<usize>() {
            Ok(l) if (1..=site.v3_max_limit).contains(&l) => l,
            _ => {
                return (
                    StatusCode::BAD_REQUEST,
                    axum::Json(
                        json!({"status": 400, "message": "Parameter limit out of tolerance"}),
                    ),
                )
                    .into_response()
            }
        },
    };
    let mut docs: Vec<&Doc> = site
        .docs
        .get(col.as_str())
        .map(|v| {
            v.iter()
                .filter(|d| d.v3 && d.srv_modified > since)
                .collect()
        })
        .unwrap_or_default();
    docs.sort_by_key(|d| d.srv_modified);
    let result: Vec<Value> = docs
        .into_iter()
        .take(limit)
        .map(|d| {
            let mut doc = d.doc.clone();
            if let Some(o) = doc.as_object_mut() {
                // `normalizeDoc`: the document's own identifier, else its
                // `_id`; no `_id`.
                if let Some(id) = o.remove("_id") {
                    o.entry("identifier").or_insert(id);
                }
                o.insert("srvModified".into(), json!(d.srv_modified));
                if !d.valid {
                    o.insert("isValid".into(), Value::Bool(false));
                }
            }
            doc
        })
        .collect();
    axum::Json(json!({"status": 200, "result": result})).into_response()
}

/// A running server: its base URL and its state.
pub struct Server {
    /// `http://127.0.0.1:PORT`.
    pub url: String,
    /// The site.
    pub site: Shared,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// Starts `site` on a free port of 127.0.0.1.
    pub fn start(site: Site) -> Server {
        Self::start_at(site, "")
    }

    /// Starts `site` under a path prefix (`/ns`: a site at
    /// `https://host/ns/`, behind a reverse proxy).
    pub fn start_at(site: Site, prefix: &str) -> Server {
        let shared: Shared = Arc::new(Mutex::new(site));
        let api = Router::new()
            .route("/api/v1/status.json", get(status))
            .route("/api/v1/status", get(status))
            .route("/api/v1/entries.json", get(v1_list))
            .route("/api/v1/entries", get(v1_list))
            .route(
                "/api/v1/treatments.json",
                get(v1_list).post(write_treatments).put(write_treatments),
            )
            .route(
                "/api/v1/treatments",
                get(v1_list).post(write_treatments).put(write_treatments),
            )
            .route(
                "/api/v1/treatments/{id}",
                axum::routing::delete(delete_treatment).put(put_treatment_by_id),
            )
            .route("/api/v1/devicestatus.json", get(v1_list))
            .route("/api/v1/devicestatus", get(v1_list))
            .route("/api/v1/profile.json", get(v1_list).put(put_profile))
            .route("/api/v1/profile", get(v1_list).put(put_profile))
            .route(
                "/api/v2/authorization/request/{token}",
                get(authorization_request),
            )
            .route(
                "/api/v2/authorization/debug/check/{permission}",
                get(authorization_check),
            )
            .route("/api/v3/version", get(v3_version))
            .route("/api/v3/lastModified", get(v3_last_modified))
            .route("/api/v3/{col}/history/{since}", get(v3_history))
            .with_state(Arc::clone(&shared));
        let app = if prefix.is_empty() {
            api
        } else {
            Router::new().nest(prefix, api)
        };
        let prefix = prefix.to_string();
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let (addr_tx, addr_rx) = std::sync::mpsc::channel();
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .unwrap();
            rt.block_on(async move {
                let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
                addr_tx.send(listener.local_addr().unwrap()).unwrap();
                axum::serve(listener, app)
                    .with_graceful_shutdown(async {
                        let _ = rx.await;
                    })
                    .await
                    .unwrap();
            });
        });
        let addr = addr_rx.recv().unwrap();
        Server {
            url: format!("http://{addr}{prefix}"),
            site: shared,
            stop: Some(tx),
            thread: Some(thread),
        }
    }

    /// Runs `f` on the site's state.
    pub fn with<R>(&self, f: impl FnOnce(&mut Site) -> R) -> R {
        f(&mut self.site.lock().unwrap())
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        // Not joined: a client's pooled keep-alive connection would hold
        // the graceful shutdown; the thread ends with the test process.
        drop(self.thread.take());
    }
}
