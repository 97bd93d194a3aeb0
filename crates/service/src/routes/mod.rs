//! The handlers, one module per group of endpoints.

pub mod admin;
pub mod meta;
pub mod person;

use crate::error::ApiError;
use axum::extract::rejection::PathRejection;
use axum::extract::Path;
use axum::http::StatusCode;

/// An id segment of the path, as text (a segment that is not UTF-8 is
/// kept as the error, never answered by axum's own plain-text rejection).
pub type PathId = Result<Path<String>, PathRejection>;

/// The text of a path segment ("" when it could not be decoded).
pub fn path_text(p: PathId) -> String {
    p.map(|Path(s)| s).unwrap_or_default()
}

/// A person id from the path; anything else is an id no person has (so the
/// answer is the same 404 as for a person that does not exist, after the
/// token was checked).
pub fn person_id(raw: PathId) -> i64 {
    path_text(raw)
        .parse::<i64>()
        .ok()
        .filter(|&v| v > 0)
        .unwrap_or(-1)
}

/// The query's `key=value` pairs; a key not in `known` or given twice, or
/// a value that is not an unsigned integer, is 400 naming the key.
pub fn query_u64(raw: Option<&str>, known: &[&str]) -> Result<Vec<(String, u64)>, ApiError> {
    let mut out: Vec<(String, u64)> = Vec::new();
    let bad = |key: &str, msg: String| {
        ApiError::new(StatusCode::BAD_REQUEST, abba_api::ErrorCode::BadQuery, msg).at(key)
    };
    for pair in raw.unwrap_or("").split('&').filter(|p| !p.is_empty()) {
        let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
        if !known.contains(&k) {
            return Err(bad(
                k,
                format!("unknown query parameter; expected {}", known.join(", ")),
            ));
        }
        if out.iter().any(|(x, _)| x == k) {
            return Err(bad(k, "given twice".into()));
        }
        let n = v
            .parse::<u64>()
            .map_err(|_| bad(k, format!("expected an unsigned integer, got {v:?}")))?;
        out.push((k.to_string(), n));
    }
    Ok(out)
}

/// 404 for an unknown path.
pub async fn not_found() -> ApiError {
    ApiError::not_found("no such endpoint (see GET /v1/openapi.json)")
}

/// 405 for a known path with another method.
pub async fn method_not_allowed() -> ApiError {
    ApiError::new(
        StatusCode::METHOD_NOT_ALLOWED,
        abba_api::ErrorCode::MethodNotAllowed,
        "this endpoint does not take that method (see GET /v1/openapi.json)",
    )
}
