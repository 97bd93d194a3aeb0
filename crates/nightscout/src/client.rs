//! HTTP to one Nightscout site with ureq (rustls): timeouts on every call,
//! no redirects (the credential goes to the linked host only), 429 waited
//! out by its Retry-After and 5xx or a cut connection retried with
//! backoff, the access token exchanged for a JWT
//! (`/api/v2/authorization/request/<token>`) and renewed once on a 401.

use crate::error::NsError;
use crate::site::SiteUrl;
use abba_store::link::Credential;
use serde_json::Value;
use std::sync::Mutex;
use std::time::Duration;

/// Timeouts and retries.
#[derive(Debug, Clone)]
pub struct ClientOptions {
    /// Connecting.
    pub connect_timeout: Duration,
    /// One whole call (request and body).
    pub call_timeout: Duration,
    /// Attempts per call (429, 5xx, a cut connection, a timeout).
    pub attempts: u32,
    /// The first backoff (doubled after each failure).
    pub backoff: Duration,
    /// The longest Retry-After abba waits; a longer one ends the sync.
    pub max_retry_after: Duration,
    /// The largest body read (bytes).
    pub max_body: u64,
}

impl Default for ClientOptions {
    fn default() -> Self {
        Self {
            connect_timeout: Duration::from_secs(10),
            call_timeout: Duration::from_secs(60),
            attempts: 5,
            backoff: Duration::from_millis(500),
            max_retry_after: Duration::from_secs(120),
            max_body: 256 << 20,
        }
    }
}

/// A client of one site.
pub struct Client {
    agent: ureq::Agent,
    site: SiteUrl,
    credential: Credential,
    opts: ClientOptions,
    /// The JWT for an access token (`None`: not asked yet); `Some(None)`:
    /// the site has no `/api/v2/authorization` (the token goes as `?token=`).
    jwt: Mutex<Option<Option<String>>>,
    /// What the token's exchange said it may do (Nightscout's
    /// `permissions`, or `permissionGroups` flattened).
    grants: Mutex<Option<Vec<String>>>,
}

/// An HTTP method abba uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// GET.
    Get,
    /// POST.
    Post,
    /// PUT.
    Put,
    /// DELETE.
    Delete,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Get => "GET",
            Method::Post => "POST",
            Method::Put => "PUT",
            Method::Delete => "DELETE",
        }
    }
}

enum Outcome {
    Done(Value),
    Retry(String, Option<Duration>),
    Renew,
}

impl Client {
    /// A client of `site` with `credential`.
    pub fn new(site: SiteUrl, credential: Credential, opts: ClientOptions) -> Self {
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .max_redirects(0)
            .timeout_connect(Some(opts.connect_timeout))
            .timeout_global(Some(opts.call_timeout))
            .user_agent(concat!("abba/", env!("CARGO_PKG_VERSION")))
            .build()
            .into();
        Self {
            agent,
            site,
            credential,
            opts,
            jwt: Mutex::new(None),
            grants: Mutex::new(None),
        }
    }

    /// The site.
    pub fn site(&self) -> &SiteUrl {
        &self.site
    }

    /// Whether an access token is used (API v3 takes nothing else).
    pub fn has_token(&self) -> bool {
        matches!(self.credential, Credential::Token(_))
    }

    /// Whether calls carry a JWT (API v3 takes nothing else): an access
    /// token exchanged at `/api/v2/authorization/request/<token>`. Known
    /// after the first call.
    pub fn has_jwt(&self) -> bool {
        self.jwt.lock().is_ok_and(|g| matches!(*g, Some(Some(_))))
    }

    /// The Shiro-style permissions the token's exchange granted
    /// (`api:treatments:create`, `*`, ...): `None` when there was no
    /// exchange (an API secret, a site without API v2 authorization) or
    /// it named none. Known after the first call.
    pub fn grants(&self) -> Option<Vec<String>> {
        self.grants.lock().ok().and_then(|g| g.clone())
    }

    /// GET `path` with `query`, as JSON.
    pub fn get(&self, path: &str, query: &[(&str, String)]) -> Result<Value, NsError> {
        self.call(Method::Get, path, query, None)
    }

    /// A call with retries; the answer's JSON (`null` for an empty body).
    pub fn call(
        &self,
        method: Method,
        path: &str,
        query: &[(&str, String)],
        body: Option<&Value>,
    ) -> Result<Value, NsError> {
        let call = describe(method, path, query);
        let mut backoff = self.opts.backoff;
        let mut renewed = false;
        let mut last = String::new();
        let mut attempt = 0;
        while attempt < self.opts.attempts {
            attempt += 1;
            match self.once(method, path, query, body, &call)? {
                Outcome::Done(v) => return Ok(v),
                Outcome::Renew if !renewed => {
                    renewed = true;
                    attempt -= 1;
                    self.set_jwt(None);
                }
                Outcome::Renew => {
                    return Err(self.unauthorized(&call));
                }
                Outcome::Retry(why, wait) => {
                    last = why;
                    if attempt < self.opts.attempts {
                        std::thread::sleep(wait.unwrap_or(backoff));
                        backoff = backoff.saturating_mul(2);
                    }
                }
            }
        }
        Err(NsError::GaveUp {
            site: self.site.to_string(),
            call,
            attempts: self.opts.attempts,
            last,
        })
    }

    fn unauthorized(&self, call: &str) -> NsError {
        NsError::Unauthorized {
            site: self.site.to_string(),
            call: call.to_string(),
            what: match self.credential {
                Credential::ApiSecretSha1(_) => "API secret",
                Credential::Token(_) => "access token",
            },
        }
    }

    fn set_jwt(&self, v: Option<Option<String>>) {
        if let Ok(mut g) = self.jwt.lock() {
            *g = v;
        }
    }

    /// The JWT for the token (asked once, renewed after a 401).
    fn jwt(&self, token: &str) -> Result<Option<String>, NsError> {
        if let Ok(g) = self.jwt.lock() {
            if let Some(j) = g.as_ref() {
                return Ok(j.clone());
            }
        }
        let path = "/api/v2/authorization/request/";
        let call = format!("GET {path}<token>");
        let url = self.site.join(&format!("{path}{}", encode_segment(token)));
        let mut attempt = 0;
        let mut backoff = self.opts.backoff;
        let got = loop {
            attempt += 1;
            let r = self
                .agent
                .get(&url)
                .header("Accept", "application/json")
                .header("Accept-Encoding", "identity")
                .call();
            match r {
                Ok(mut resp) => {
                    let status = resp.status().as_u16();
                    match status {
                        200 => {
                            if let Some(enc) = foreign_encoding(&resp) {
                                return Err(self.protocol(&call, not_identity(&enc)));
                            }
                            let text = resp
                                .body_mut()
                                .with_config()
                                .limit(1 << 20)
                                .read_to_string()
                                .map_err(|e| {
                                    self.protocol(&call, format!("reading the body: {e}"))
                                })?;
                            let v: Value = serde_json::from_str(&text)
                                .map_err(|e| self.protocol(&call, format!("expected JSON: {e}")))?;
                            let jwt = v.get("token").and_then(Value::as_str).ok_or_else(|| {
                                self.protocol(&call, "expected {\"token\": JWT}".into())
                            })?;
                            if let Ok(mut g) = self.grants.lock() {
                                *g = grants_of(&v);
                            }
                            break Some(jwt.to_string());
                        }
                        401 => return Err(self.unauthorized(&call)),
                        // A site without API v2 authorization: `?token=`.
                        404 => break None,
                        s if (s == 429 || s >= 500) && attempt < self.opts.attempts => {
                            let wait = retry_after(&resp);
                            if let Some(w) = wait.filter(|w| *w > self.opts.max_retry_after) {
                                return Err(self.wait_too_long(&call, s, w));
                            }
                            std::thread::sleep(wait.unwrap_or(backoff));
                            backoff = backoff.saturating_mul(2);
                        }
                        s => {
                            return Err(NsError::Status {
                                site: self.site.to_string(),
                                call,
                                status: s,
                                body: String::new(),
                            })
                        }
                    }
                }
                Err(e) if refused_certificate(&e) => {
                    return Err(NsError::Certificate {
                        site: self.site.to_string(),
                        problem: e.to_string(),
                    })
                }
                Err(_) if attempt < self.opts.attempts => {
                    std::thread::sleep(backoff);
                    backoff = backoff.saturating_mul(2);
                }
                Err(e) => {
                    return Err(NsError::GaveUp {
                        site: self.site.to_string(),
                        call,
                        attempts: attempt,
                        last: e.to_string(),
                    })
                }
            }
        };
        self.set_jwt(Some(got.clone()));
        Ok(got)
    }

    /// `text` without the access token (a server may echo the request's
    /// URL, `?token=` included, in an answer or a Location).
    fn scrub(&self, text: &str) -> String {
        match &self.credential {
            Credential::Token(t) if !t.is_empty() => text
                .replace(t.as_str(), "***")
                .replace(&encode_segment(t), "***"),
            _ => text.to_string(),
        }
    }

    /// A Retry-After longer than abba waits: the sync ends, to be tried
    /// again later.
    fn wait_too_long(&self, call: &str, status: u16, wait: Duration) -> NsError {
        NsError::GaveUp {
            site: self.site.to_string(),
            call: call.to_string(),
            attempts: 1,
            last: format!(
                "HTTP {status} with Retry-After {} s, longer than abba waits ({} s): sync again later",
                wait.as_secs(),
                self.opts.max_retry_after.as_secs()
            ),
        }
    }

    fn protocol(&self, call: &str, problem: String) -> NsError {
        NsError::Protocol {
            site: self.site.to_string(),
            call: call.to_string(),
            problem,
        }
    }

    fn once(
        &self,
        method: Method,
        path: &str,
        query: &[(&str, String)],
        body: Option<&Value>,
        call: &str,
    ) -> Result<Outcome, NsError> {
        let url = self.site.join(path);
        let mut pairs: Vec<(&str, String)> = query.to_vec();
        let mut bearer = None;
        match &self.credential {
            Credential::ApiSecretSha1(_) => {}
            Credential::Token(t) => match self.jwt(t)? {
                Some(j) => bearer = Some(j),
                None => pairs.push(("token", t.clone())),
            },
        }
        let bearer = bearer.as_deref();
        let sent = match method {
            Method::Get => self.authed(self.agent.get(&url), bearer, &pairs).call(),
            Method::Delete => self.authed(self.agent.delete(&url), bearer, &pairs).call(),
            Method::Post | Method::Put => {
                let rb = if method == Method::Post {
                    self.agent.post(&url)
                } else {
                    self.agent.put(&url)
                };
                let rb = self.authed(rb, bearer, &pairs);
                match body {
                    Some(b) => rb
                        .header("Content-Type", "application/json")
                        .send(b.to_string()),
                    None => rb.send_empty(),
                }
            }
        };
        let mut resp = match sent {
            Ok(r) => r,
            // A certificate abba does not trust is not retried.
            Err(e) if refused_certificate(&e) => {
                return Err(NsError::Certificate {
                    site: self.site.to_string(),
                    problem: e.to_string(),
                })
            }
            // Connection refused or cut, a timeout: retried.
            Err(e) => return Ok(Outcome::Retry(e.to_string(), None)),
        };
        let status = resp.status().as_u16();
        match status {
            200..=299 => {
                if let Some(enc) = foreign_encoding(&resp) {
                    return Err(self.protocol(call, not_identity(&enc)));
                }
                let text = match resp
                    .body_mut()
                    .with_config()
                    .limit(self.opts.max_body)
                    .read_to_string()
                {
                    Ok(t) => t,
                    // Cut mid-body (or timed out): retried.
                    Err(e) => return Ok(Outcome::Retry(format!("reading the body: {e}"), None)),
                };
                if text.trim().is_empty() {
                    return Ok(Outcome::Done(Value::Null));
                }
                match serde_json::from_str(&text) {
                    Ok(v) => Ok(Outcome::Done(v)),
                    // A body cut short by a proxy reads as bad JSON: retried,
                    // then reported.
                    Err(e) => Ok(Outcome::Retry(
                        format!("the body is not JSON ({e})"),
                        None,
                    )),
                }
            }
            300..=399 => {
                // A Location that carries the query back (`?token=...`)
                // is shown without its values.
                let to = resp
                    .headers()
                    .get("location")
                    .and_then(|v| v.to_str().ok())
                    .map(|l| crate::site::redacted(&self.scrub(l)))
                    .unwrap_or_else(|| "?".to_string());
                Err(NsError::Redirect {
                    site: self.site.to_string(),
                    call: call.to_string(),
                    status,
                    to,
                })
            }
            401 if bearer.is_some() => Ok(Outcome::Renew),
            401 => Err(self.unauthorized(call)),
            403 => Err(NsError::Forbidden {
                site: self.site.to_string(),
                call: call.to_string(),
                need: match method {
                    Method::Get => "reading needs a token with the role readable (or an API secret)".into(),
                    _ => "writing back needs a token with the role careportal (treatments) and admin or api:profile:update (the profile)".into(),
                },
            }),
            429 => {
                let wait = retry_after(&resp);
                match wait {
                    Some(w) if w > self.opts.max_retry_after => {
                        Err(self.wait_too_long(call, status, w))
                    }
                    _ => Ok(Outcome::Retry("429 Too Many Requests".into(), wait)),
                }
            }
            // 503 (and any 5xx) with Retry-After: waited for as a 429's.
            500..=599 => match retry_after(&resp) {
                Some(w) if w > self.opts.max_retry_after => Err(self.wait_too_long(call, status, w)),
                wait => Ok(Outcome::Retry(format!("HTTP {status}"), wait)),
            },
            _ => {
                let text = resp
                    .body_mut()
                    .with_config()
                    .limit(4096)
                    .read_to_string()
                    .unwrap_or_default();
                Err(NsError::Status {
                    site: self.site.to_string(),
                    call: call.to_string(),
                    status,
                    body: self.scrub(&text).chars().take(300).collect(),
                })
            }
        }
    }

    /// `rb` with the credential (a JWT, the API secret's hash, or the
    /// token in the query when the site gives no JWT) and the query.
    fn authed<B>(
        &self,
        rb: ureq::RequestBuilder<B>,
        bearer: Option<&str>,
        pairs: &[(&str, String)],
    ) -> ureq::RequestBuilder<B> {
        let rb = rb
            .header("Accept", "application/json")
            .header("Accept-Encoding", "identity");
        let rb = match (&self.credential, bearer) {
            (_, Some(j)) => rb.header("Authorization", format!("Bearer {j}")),
            (Credential::ApiSecretSha1(h), None) => rb.header("api-secret", h),
            _ => rb,
        };
        pairs.iter().fold(rb, |rb, (k, v)| rb.query(*k, v))
    }
}

/// The permissions an authorization answer names: `permissions` (a list)
/// or `permissionGroups` (a list per role), `None` when it names none.
fn grants_of(v: &Value) -> Option<Vec<String>> {
    let mut out = Vec::new();
    for key in ["permissions", "permissionGroups"] {
        let Some(Value::Array(a)) = v.get(key) else {
            continue;
        };
        for x in a {
            match x {
                Value::String(p) => out.push(p.clone()),
                Value::Array(group) => {
                    out.extend(group.iter().filter_map(Value::as_str).map(String::from))
                }
                _ => {}
            }
        }
    }
    (!out.is_empty()).then_some(out)
}

/// Whether Shiro-style `grant` (`*`, `api:treatments:*`,
/// `api:treatments,profile:create`; parts it leaves out are `*`) permits
/// `permission` (`api:treatments:create`).
pub fn permits(grant: &str, permission: &str) -> bool {
    let g: Vec<&str> = grant.split(':').collect();
    let p: Vec<&str> = permission.split(':').collect();
    for (i, part) in g.iter().enumerate() {
        let any = part.split(',').any(|o| o.trim() == "*");
        match p.get(i) {
            // A grant longer than the permission: only wildcards after it.
            None if any => {}
            None => return false,
            Some(want) => {
                if !any && !part.split(',').any(|o| o.trim() == *want) {
                    return false;
                }
            }
        }
    }
    true
}

/// The answer's `Content-Encoding` when abba cannot read it: abba asks
/// for `identity`, and reads `gzip` all the same (a proxy in front of a
/// site that compresses every answer; ureq decodes it, the body limit
/// counting the decoded bytes), but no other, nor gzip twice.
fn foreign_encoding(resp: &ureq::http::Response<ureq::Body>) -> Option<String> {
    let codings: Vec<String> = resp
        .headers()
        .get_all("content-encoding")
        .iter()
        .flat_map(|v| {
            String::from_utf8_lossy(v.as_bytes())
                .split(',')
                .map(|c| c.trim().to_string())
                .collect::<Vec<_>>()
        })
        .filter(|c| !c.is_empty() && !c.eq_ignore_ascii_case("identity"))
        .collect();
    match codings.as_slice() {
        [] => None,
        [one] if one == "gzip" => None,
        _ => Some(codings.join(", ")),
    }
}

fn not_identity(enc: &str) -> String {
    format!(
        "the site answered with Content-Encoding: {enc}, which abba did not ask for \
         (it sends Accept-Encoding: identity) and does not read (only gzip); a proxy in \
         front of Nightscout that compresses every answer does this: it should honour \
         Accept-Encoding"
    )
}

/// Whether a failed call is the site's TLS certificate refused (rustls:
/// not valid for the name, expired, or not from an authority abba trusts,
/// such as a self-signed one): retrying cannot help.
fn refused_certificate(e: &ureq::Error) -> bool {
    let mut text = e.to_string();
    let mut source = std::error::Error::source(e);
    while let Some(s) = source {
        text.push_str(&s.to_string());
        source = s.source();
    }
    let text = text.to_ascii_lowercase();
    text.contains("certificate") || text.contains("unknownissuer")
}

/// Retry-After: seconds, or an HTTP date (`Sun, 06 Dec 2026 17:30:00
/// GMT`) counted from now (a date past is no wait).
fn retry_after(resp: &ureq::http::Response<ureq::Body>) -> Option<Duration> {
    let v = resp.headers().get("retry-after")?.to_str().ok()?;
    retry_after_value(v, jiff::Timestamp::now())
}

fn retry_after_value(v: &str, now: jiff::Timestamp) -> Option<Duration> {
    let v = v.trim();
    if let Ok(s) = v.parse::<u64>() {
        return Some(Duration::from_secs(s));
    }
    let at = jiff::fmt::rfc2822::parse(v).ok()?.timestamp();
    let secs = at.as_second().saturating_sub(now.as_second()).max(0);
    Some(Duration::from_secs(secs.unsigned_abs()))
}

/// `METHOD path?query` for messages (never the token).
fn describe(method: Method, path: &str, query: &[(&str, String)]) -> String {
    if query.is_empty() {
        format!("{} {path}", method.name())
    } else {
        let q: Vec<String> = query.iter().map(|(k, v)| format!("{k}={v}")).collect();
        format!("{} {path}?{}", method.name(), q.join("&"))
    }
}

/// A path segment, percent-encoded.
pub(crate) fn encode_segment(s: &str) -> String {
    let mut out = String::new();
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_certificate_is_told_from_a_failure_worth_retrying() {
        // As ureq reports rustls's refusal of a self-signed certificate.
        let e = ureq::Error::Io(std::io::Error::other(
            "invalid peer certificate: Other(OtherError(CaUsedAsEndEntity))",
        ));
        assert!(refused_certificate(&e));
        let e = ureq::Error::Io(std::io::Error::other(
            "invalid peer certificate: UnknownIssuer",
        ));
        assert!(refused_certificate(&e));
        for e in [
            ureq::Error::ConnectionFailed,
            ureq::Error::HostNotFound,
            ureq::Error::Io(std::io::Error::from(std::io::ErrorKind::ConnectionReset)),
        ] {
            assert!(!refused_certificate(&e), "{e}");
        }
    }

    #[test]
    fn retry_after_in_seconds_or_as_an_http_date() {
        let now: jiff::Timestamp = "2026-12-06T17:30:00Z".parse().unwrap();
        let at = |v: &str| retry_after_value(v, now);
        assert_eq!(at("120"), Some(Duration::from_secs(120)));
        assert_eq!(at(" 0 "), Some(Duration::ZERO));
        assert_eq!(
            at("Sun, 06 Dec 2026 17:31:30 GMT"),
            Some(Duration::from_secs(90))
        );
        assert_eq!(at("Sun, 06 Dec 2026 17:00:00 GMT"), Some(Duration::ZERO));
        assert_eq!(at("soon"), None);
        assert_eq!(at("-5"), None);
    }

    #[test]
    fn shiro_grants() {
        for (g, p, ok) in [
            ("*", "api:treatments:create", true),
            ("*:*:read", "api:treatments:create", false),
            ("*:*:read", "api:treatments:read", true),
            ("api:treatments:create", "api:treatments:create", true),
            ("api:treatments:create", "api:treatments:update", false),
            ("api:treatments", "api:treatments:update", true),
            ("api:treatments,profile:*", "api:profile:update", true),
            ("api:entries:*", "api:profile:update", false),
            ("api:treatments:create:*", "api:treatments:create", true),
            ("api:treatments:create:x", "api:treatments:create", false),
        ] {
            assert_eq!(permits(g, p), ok, "{g} {p}");
        }
        let v = serde_json::json!({"token": "j", "permissionGroups": [["*:*:read"], ["api:treatments:create"]]});
        assert_eq!(
            grants_of(&v),
            Some(vec![
                "*:*:read".to_string(),
                "api:treatments:create".to_string()
            ])
        );
        assert_eq!(
            grants_of(&serde_json::json!({"permissionGroups": []})),
            None
        );
        assert_eq!(
            grants_of(&serde_json::json!({"permissions": ["*"]})),
            Some(vec!["*".to_string()])
        );
    }
}
