//! Who is calling, as axum extractors: each checks the token (and the
//! person of the path) from the request's head, so a handler that takes
//! one never runs, and its body is never read, for a caller it does not
//! serve.

use crate::auth::{Caller, Need};
use crate::error::ApiError;
use crate::state::AppState;
use axum::extract::{FromRequestParts, Path};
use axum::http::header;
use axum::http::request::Parts;
use std::net::IpAddr;

/// The `Authorization` header's value ("" when it is not visible ASCII,
/// which the token check calls malformed).
fn authorization(parts: &Parts) -> Option<String> {
    parts
        .headers
        .get(header::AUTHORIZATION)
        .map(|v| v.to_str().map(str::to_string).unwrap_or_default())
}

/// The client, when the request came over a connection (behind a proxy,
/// the client it forwarded: `crate::client`).
fn peer(parts: &Parts) -> Option<IpAddr> {
    crate::client::of_parts(parts)
}

async fn check(parts: &Parts, state: &AppState, need: Need) -> Result<Caller, ApiError> {
    state
        .authorize(authorization(parts), peer(parts), need)
        .await
}

/// The text of the path's one parameter ("" when it could not be decoded:
/// never axum's own plain-text rejection; "" too when it was written with
/// percent-encoding, [`percent_encoded`]).
async fn path_text(parts: &mut Parts, state: &AppState) -> String {
    if percent_encoded(parts) {
        return String::new();
    }
    Path::<String>::from_request_parts(parts, state)
        .await
        .map(|Path(s)| s)
        .unwrap_or_default()
}

/// True when the request's path holds a percent-encoded byte. The routes'
/// fixed segments only match as written, so on a matched route that byte
/// is in a parameter: an id or a secret the service never writes so.
/// axum decodes parameters before a handler sees them, and `%31` reached
/// person 1 (one person under many paths, past a proxy's rule on
/// `/v1/persons/1/`, as `+1` and `01` did).
pub fn percent_encoded(parts: &Parts) -> bool {
    parts.uri.path().contains('%')
}

/// A positive id from a path segment written as the service writes it
/// (decimal digits, no sign, no leading zero); anything else is an id
/// nothing has (-1), so the answer is the same 404 as for an id that does
/// not exist. (`+1` and `01` reached person 1: one person under many
/// paths, past a proxy's rule on `/v1/persons/1/`.)
pub fn parse_id(text: &str) -> i64 {
    let canonical = !text.starts_with('0') && text.bytes().all(|b| b.is_ascii_digit());
    canonical
        .then(|| text.parse::<i64>().ok())
        .flatten()
        .filter(|&v| v > 0)
        .unwrap_or(-1)
}

/// Any valid token.
#[derive(Debug, Clone, Copy)]
pub struct AnyCaller(pub Caller);

impl FromRequestParts<AppState> for AnyCaller {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, ApiError> {
        check(parts, state, Need::Any).await.map(AnyCaller)
    }
}

/// An admin (clinic) token.
#[derive(Debug, Clone, Copy)]
pub struct Admin;

impl FromRequestParts<AppState> for Admin {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, ApiError> {
        check(parts, state, Need::Admin).await.map(|_| Admin)
    }
}

/// An admin token, and the path's one parameter as text (checked after the
/// token: a stranger learns nothing from the path).
#[derive(Debug, Clone)]
pub struct AdminPath(pub String);

impl FromRequestParts<AppState> for AdminPath {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, ApiError> {
        check(parts, state, Need::Admin).await?;
        Ok(AdminPath(path_text(parts, state).await))
    }
}

/// The person of the path `{id}`, for their own token or an admin token:
/// 401 without a valid token, 404 for another person or none.
#[derive(Debug, Clone, Copy)]
pub struct PersonId(pub i64);

impl FromRequestParts<AppState> for PersonId {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, ApiError> {
        let id = parse_id(&path_text(parts, state).await);
        check(parts, state, Need::Person(id)).await?;
        Ok(PersonId(id))
    }
}
