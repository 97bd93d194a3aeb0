//! Signing in with a one-time link, and out.
//!
//! `GET /signin/{secret}` shows a button and never uses the link (link
//! previews of messengers fetch it); `POST /signin` uses it once and opens
//! a session. That POST has no session yet: its CSRF token is a
//! double-submit cookie (`abba_signin`, set by the GET, equal to the
//! form's `csrf` field), with the same Origin check as every POST.

use super::form::Form;
use super::page::{forbidden_csrf, message, render, see_other, PageError, PageResult, PathText};
use super::session::{self, Ctx, SIGNIN_COOKIE};
use crate::auth;
use crate::body::RawBody;
use crate::state::AppState;
use abba_store::session::{LinkRefused, ABSOLUTE_MS, LINK_LIFE_MS};
use abba_store::token::Role;
use abba_web::pages::Layout;
use abba_web::texts::EN;
use axum::extract::{RawQuery, State};
use axum::http::{header, StatusCode};
use axum::response::Response;
use serde::Serialize;
use subtle::ConstantTimeEq;

/// The sign-in page of a link.
#[derive(Debug, Clone, Serialize)]
pub struct Signin {
    /// The link's secret (the hidden `link` field).
    pub link: String,
    /// The double-submit token (the hidden `csrf` field, also a cookie).
    pub csrf: String,
}

fn refused_text(r: LinkRefused) -> String {
    let why = match r {
        LinkRefused::Unknown => EN.signin_unknown,
        LinkRefused::Used => EN.signin_used,
        LinkRefused::Expired => EN.signin_expired,
    };
    format!("{why} {}", EN.signin_again)
}

fn refused(r: LinkRefused) -> Response {
    message(
        StatusCode::FORBIDDEN,
        EN.signin_refused_title,
        &refused_text(r),
        None,
    )
}

/// `GET /signin`: how to sign in (or: signed out).
pub async fn help(RawQuery(q): RawQuery) -> Response {
    let text = if q.as_deref() == Some("out=1") {
        format!("{} {}", EN.signed_out, EN.signin_needed)
    } else {
        EN.signin_needed.to_string()
    };
    message(StatusCode::OK, EN.signin_title, &text, None)
}

/// `GET /signin/{secret}`: the sign-in button (the link is not used).
pub async fn page(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(secret): PathText<String>,
) -> PageResult {
    if !session::is_secret(&secret) {
        return Ok(refused(LinkRefused::Unknown));
    }
    let h = auth::hash(&secret);
    let state = s
        .store(move |store| Ok(store.peek_signin_link(&h, session::now_ms())?))
        .await?;
    if let Err(r) = state {
        return Ok(refused(r));
    }
    let csrf = session::secret()?;
    let mut r = render(
        StatusCode::OK,
        "signin.html",
        &Layout::new(EN.signin_title, None),
        &Signin {
            link: secret,
            csrf: csrf.clone(),
        },
    )?;
    r.headers_mut().append(
        header::SET_COOKIE,
        ctx.set_cookie(SIGNIN_COOKIE, &csrf, "/signin", LINK_LIFE_MS / 1000),
    );
    Ok(r)
}

/// `POST /signin`: uses the link once; 303 to `/` (a person) or
/// `/clinic` (the admin) with the session cookie; a session the browser
/// held before is revoked.
pub async fn post(State(s): State<AppState>, ctx: Ctx, body: RawBody) -> PageResult {
    if !ctx.same_origin() {
        return Err(forbidden_csrf());
    }
    let form = Form::parse(&ctx.headers, body)?;
    let sent = form.get("csrf").unwrap_or("");
    let cookie = ctx.cookie(SIGNIN_COOKIE).unwrap_or_default();
    if cookie.is_empty() || !bool::from(sent.as_bytes().ct_eq(cookie.as_bytes())) {
        return Err(forbidden_csrf());
    }
    form.only(&["csrf", "link"])?;
    let link = form.text("link").to_string();
    if !session::is_secret(&link) {
        return Ok(refused(LinkRefused::Unknown));
    }
    // A link that is unknown, used or expired is refused from a read:
    // using one takes the store's write lock, and an anonymous client's
    // made-up links would otherwise each wait for it (holding a pooled
    // connection for the busy timeout while another writer works).
    let lh = auth::hash(&link);
    let state = s
        .store(move |store| Ok(store.peek_signin_link(&lh, session::now_ms())?))
        .await?;
    if let Err(r) = state {
        return Ok(refused(r));
    }
    let value = session::secret()?;
    let csrf = session::secret()?;
    let (lh, sh) = (auth::hash(&link), auth::hash(&value));
    let out = s
        .store(move |store| Ok(store.consume_signin_link(&lh, &sh, &csrf, session::now_ms())?))
        .await?;
    let role = match out {
        Ok((role, _)) => role,
        Err(r) => return Ok(refused(r)),
    };
    // A session this browser held before (another person's, on a shared
    // phone) ends here, not when it would have expired.
    if let Some(old) = session::current(&s, &ctx).await? {
        s.store(move |store| Ok(store.revoke_web_session(old.id, session::now_ms())?))
            .await
            .map_err(PageError::from)?;
    }
    let mut r = see_other(match role {
        Role::Admin => "/clinic",
        Role::Person(_) => "/",
    });
    let h = r.headers_mut();
    h.append(
        header::SET_COOKIE,
        ctx.set_cookie(ctx.session_cookie(), &value, "/", ABSOLUTE_MS / 1000),
    );
    h.append(
        header::SET_COOKIE,
        ctx.set_cookie(SIGNIN_COOKIE, "", "/signin", 0),
    );
    Ok(r)
}

/// `POST /signout`: ends the session (revoked in the store).
pub async fn signout(State(s): State<AppState>, ctx: Ctx, body: RawBody) -> PageResult {
    if !ctx.same_origin() {
        return Err(forbidden_csrf());
    }
    let form = Form::parse(&ctx.headers, body)?;
    let w = session::post_session(&s, &ctx, &form).await?;
    form.only(&["csrf"])?;
    s.store(move |store| Ok(store.revoke_web_session(w.id, session::now_ms())?))
        .await
        .map_err(PageError::from)?;
    let mut r = see_other("/signin?out=1");
    r.headers_mut().append(
        header::SET_COOKIE,
        ctx.set_cookie(ctx.session_cookie(), "", "/", 0),
    );
    Ok(r)
}

/// This module's routes (merged by [`super::routes`]).
pub fn routes() -> axum::Router<crate::state::AppState> {
    use axum::routing::{get, post};
    axum::Router::new()
        .route("/signin", get(help).post(self::post))
        .route("/signin/{secret}", get(page))
        .route("/signout", post(signout))
}
