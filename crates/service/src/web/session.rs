//! Web sessions: the `abba_session` cookie, who it speaks for, the CSRF
//! token and the Origin check of every POST.
//!
//! - The cookie holds 256 random bits (64 hex digits); the store keeps
//!   only their SHA-256 (abba-store's `session` module), with the
//!   session's CSRF token and its expiry (30 days idle, 90 days at most).
//! - `HttpOnly; SameSite=Strict; Path=/`, and `Secure` (the cookie then
//!   named `__Host-abba_session`) when the request came over TLS: abba serves plain HTTP itself, so that is when a
//!   reverse proxy on the same machine (a loopback peer, with
//!   `abba serve --behind-proxy`) says `X-Forwarded-Proto: https` (no
//!   other peer, and no local process without that flag, is trusted to
//!   say so), or
//!   always when the service's `--public-url` is `https://`.
//! - Every POST: the `Origin` (or, without one, the `Referer`) must name
//!   this host (the request's `Host`), then the form's `csrf` must equal
//!   the session's token (compared in constant time). Otherwise 403 and
//!   nothing changes.
//! - A POST that needs a session is refused (403) before its body is read
//!   when it comes from another origin or without a live session
//!   ([`session_before_body`]): an anonymous client cannot hold the
//!   service's request slots by sending a form's body a byte at a time.

use super::form::Form;
use super::page::{forbidden_csrf, forbidden_no_session, forbidden_role, see_other, PageError};
use crate::auth;
use crate::error::ApiError;
use crate::state::AppState;
use abba_store::session::WebSession;
use abba_store::token::Role;
use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use axum::http::{header, HeaderMap, HeaderValue};
use subtle::ConstantTimeEq;

/// The session cookie's name over plain HTTP.
pub const COOKIE: &str = "abba_session";
/// The session cookie's name over TLS: a browser takes a `__Host-` cookie
/// only from this host itself, `Secure`, `Path=/` and without `Domain`
/// (RFC 6265bis, "cookie name prefixes"), so a site on a sibling
/// subdomain cannot plant its own session in a person's browser (cookie
/// tossing) and have them sign in, or stay signed in, as someone else.
pub const HOST_COOKIE: &str = "__Host-abba_session";
/// The sign-in form's double-submit cookie.
pub const SIGNIN_COOKIE: &str = "abba_signin";

/// The request's head as the pages need it.
#[derive(Debug, Clone)]
pub struct Ctx {
    /// The headers.
    pub headers: HeaderMap,
    /// True when the request came over TLS (a trusted proxy said so).
    pub https: bool,
    /// `--public-url`'s host and port, lower case: the origin persons'
    /// browsers name when a proxy in front rewrites `Host`.
    pub public_authority: Option<String>,
}

impl FromRequestParts<AppState> for Ctx {
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(
        parts: &mut Parts,
        state: &AppState,
    ) -> Result<Self, Self::Rejection> {
        // Only a proxy `--behind-proxy` trusts (a loopback peer) may say
        // the request came over TLS (crate::client::ViaProxy).
        let proxied = parts.extensions.get::<crate::client::ViaProxy>().is_some();
        let forwarded = parts
            .headers
            .get("x-forwarded-proto")
            .and_then(|v| v.to_str().ok())
            .is_some_and(|v| v.trim().eq_ignore_ascii_case("https"));
        // `--public-url https://...`: persons reach the service over TLS
        // (a proxy that does not say X-Forwarded-Proto, or one on another
        // machine), so its cookies are never sent in clear.
        let public_https = state
            .public_url()
            .and_then(|u| u.get(..8))
            .is_some_and(|p| p.eq_ignore_ascii_case("https://"));
        Ok(Ctx {
            headers: parts.headers.clone(),
            // Never the request target's scheme: a client on plain HTTP
            // may write `GET https://...` (`crate::head` refuses it).
            https: (proxied && forwarded) || public_https,
            public_authority: state.public_url().and_then(authority_of),
        })
    }
}

impl Ctx {
    /// A cookie's value.
    pub fn cookie(&self, name: &str) -> Option<String> {
        for v in self.headers.get_all(header::COOKIE) {
            let Ok(v) = v.to_str() else { continue };
            for pair in v.split(';') {
                if let Some((k, val)) = pair.trim().split_once('=') {
                    if k == name {
                        return Some(val.to_string());
                    }
                }
            }
        }
        None
    }

    /// The session cookie's name for this request: [`HOST_COOKIE`] over
    /// TLS, [`COOKIE`] otherwise. Over TLS a plain `abba_session` is never
    /// read (another site may have set it for the whole domain).
    pub fn session_cookie(&self) -> &'static str {
        if self.https {
            HOST_COOKIE
        } else {
            COOKIE
        }
    }

    /// A `Set-Cookie` value for `name` (`max_age` seconds; 0 removes it).
    pub fn set_cookie(&self, name: &str, value: &str, path: &str, max_age: i64) -> HeaderValue {
        let secure = if self.https { "; Secure" } else { "" };
        let s = format!(
            "{name}={value}; HttpOnly; SameSite=Strict; Path={path}; Max-Age={max_age}{secure}"
        );
        HeaderValue::from_str(&s).unwrap_or_else(|_| HeaderValue::from_static(""))
    }

    /// True when the request's `Origin` (or, without one, its `Referer`)
    /// is this host, or the `--public-url` persons are given (a proxy in
    /// front may rewrite `Host` to the service's own address). Browsers
    /// send `Origin` with every form POST.
    pub fn same_origin(&self) -> bool {
        let host = self
            .headers
            .get(header::HOST)
            .and_then(|v| v.to_str().ok())
            .map(str::to_ascii_lowercase);
        let ours =
            |a: &String| host.as_ref() == Some(a) || self.public_authority.as_ref() == Some(a);
        let named = self
            .headers
            .get(header::ORIGIN)
            .or_else(|| self.headers.get(header::REFERER));
        named
            .and_then(|v| v.to_str().ok())
            .and_then(authority_of)
            .is_some_and(|a| ours(&a))
    }
}

/// The host and port of an `http(s)://` URL, lower case.
fn authority_of(url: &str) -> Option<String> {
    let rest = url
        .strip_prefix("https://")
        .or_else(|| url.strip_prefix("http://"))?;
    Some(rest.split('/').next().unwrap_or("").to_ascii_lowercase())
}

/// 64 lower-case hex digits from the OS CSPRNG (a link's, a session's or
/// a CSRF token's secret).
pub fn secret() -> Result<String, ApiError> {
    let t = auth::new_token()?;
    Ok(t.trim_start_matches(auth::PREFIX).to_string())
}

/// True for 64 lower-case hex digits.
pub fn is_secret(s: &str) -> bool {
    s.len() == 64
        && s.bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

/// Milliseconds since the Unix epoch, now.
pub fn now_ms() -> i64 {
    jiff::Timestamp::now().as_millisecond()
}

/// The request's live session, if any.
pub async fn current(s: &AppState, ctx: &Ctx) -> Result<Option<WebSession>, PageError> {
    let Some(value) = ctx.cookie(ctx.session_cookie()).filter(|v| is_secret(v)) else {
        return Ok(None);
    };
    let h = auth::hash(&value);
    Ok(s.store(move |store| Ok(store.web_session(&h, now_ms())?))
        .await?)
}

/// A person's page: their id and session; without a session 303 to the
/// sign-in page, an admin session goes to the clinic.
pub async fn person_page(s: &AppState, ctx: &Ctx) -> Result<(i64, WebSession), PageError> {
    match current(s, ctx).await? {
        None => Err(PageError::of(see_other("/signin"))),
        Some(w) => match w.role {
            Role::Person(id) => Ok((id, w)),
            Role::Admin => Err(PageError::of(see_other("/clinic"))),
        },
    }
}

/// A clinic page: the admin session; without a session 303 to the sign-in
/// page, a person's session 403.
pub async fn admin_page(s: &AppState, ctx: &Ctx) -> Result<WebSession, PageError> {
    match current(s, ctx).await? {
        None => Err(PageError::of(see_other("/signin"))),
        Some(w) => match w.role {
            Role::Admin => Ok(w),
            Role::Person(_) => Err(forbidden_role()),
        },
    }
}

/// Checks a POST: same origin, a live session, its CSRF token. 403 for
/// each failure (nothing is read or changed before); without a live
/// session the page says so (signed out or ended), not that the form came
/// from elsewhere.
pub async fn post_session(s: &AppState, ctx: &Ctx, form: &Form) -> Result<WebSession, PageError> {
    if !ctx.same_origin() {
        return Err(forbidden_csrf());
    }
    let w = current(s, ctx).await?.ok_or_else(forbidden_no_session)?;
    let sent = form.get("csrf").unwrap_or("");
    if !bool::from(sent.as_bytes().ct_eq(w.csrf.as_bytes())) {
        return Err(forbidden_csrf());
    }
    Ok(w)
}

/// A person's POST: [`post_session`], then a person's session (403 for
/// the admin's).
pub async fn person_post(
    s: &AppState,
    ctx: &Ctx,
    form: &Form,
) -> Result<(i64, WebSession), PageError> {
    let w = post_session(s, ctx, form).await?;
    match w.role {
        Role::Person(id) => Ok((id, w)),
        Role::Admin => Err(forbidden_role()),
    }
}

/// Middleware of the pages: a POST other than the sign-in form's (which
/// brings its one-time link in the body) must come from this origin with a
/// live session, checked from its head before the body is read (403
/// otherwise, as the handler's own check would answer). The handler still
/// checks the session, its role and the form's CSRF token.
pub async fn session_before_body(
    axum::extract::State(s): axum::extract::State<AppState>,
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> axum::response::Response {
    use axum::response::IntoResponse;
    if req.method() != axum::http::Method::POST || req.uri().path() == "/signin" {
        return next.run(req).await;
    }
    let (mut parts, body) = req.into_parts();
    let Ok(ctx) = Ctx::from_request_parts(&mut parts, &s).await;
    if !ctx.same_origin() {
        return forbidden_csrf().into_response();
    }
    match current(&s, &ctx).await {
        Ok(Some(_)) => {
            next.run(axum::extract::Request::from_parts(parts, body))
                .await
        }
        Ok(None) => forbidden_no_session().into_response(),
        Err(e) => e.into_response(),
    }
}
