//! The handlers, one module per group of endpoints.

pub mod admin;
pub mod meta;
pub mod person;

use crate::error::ApiError;
use axum::http::StatusCode;

/// The default page of `?limit=` (history, suggestions).
pub const PAGE_DEFAULT: usize = 200;
/// The largest page `?limit=` may ask for.
pub const PAGE_MAX: usize = 1000;

/// `?after=` and `?limit=` of a paginated list: `limit` 1 to
/// [`PAGE_MAX`] (default [`PAGE_DEFAULT`]).
pub fn page(raw: Option<&str>) -> Result<(Option<u64>, usize), ApiError> {
    let q = query_u64(raw, &["after", "limit"])?;
    let after = q.iter().find(|x| x.0 == "after").map(|x| x.1);
    let limit = match q.iter().find(|x| x.0 == "limit") {
        None => PAGE_DEFAULT,
        Some((_, n)) if (1..=PAGE_MAX as u64).contains(n) => *n as usize,
        Some((_, n)) => {
            return Err(ApiError::new(
                StatusCode::BAD_REQUEST,
                abba_api::ErrorCode::BadQuery,
                format!("expected 1 to {PAGE_MAX}, got {n}"),
            )
            .at("limit"))
        }
    };
    Ok((after, limit))
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
        if known.is_empty() {
            return Err(bad(
                k,
                "unknown query parameter; this endpoint takes none (see GET /v1/openapi.json)"
                    .into(),
            ));
        }
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

/// An endpoint that takes no query parameter: any is 400 naming it, never
/// ignored (a probe's `POST .../answers?dry_run=1` stored its answers, and
/// `POST .../tokens?role=admin` issued a person's token, each with 2xx).
/// Taken after the caller's extractor, so a stranger still gets 401.
#[derive(Debug, Clone, Copy)]
pub struct NoQuery;

impl<S: Send + Sync> axum::extract::FromRequestParts<S> for NoQuery {
    type Rejection = ApiError;

    async fn from_request_parts(
        parts: &mut axum::http::request::Parts,
        _: &S,
    ) -> Result<Self, ApiError> {
        query_u64(parts.uri.query(), &[]).map(|_| NoQuery)
    }
}

/// An endpoint that takes no body: a body is 400 naming it, never ignored
/// (a probe's `POST .../tokens` with a JSON body of its own choosing got
/// 201, the body unread). An empty body, white space or the empty JSON
/// object `{}` (what some HTTP clients send for "no fields") is none.
/// Taken last (it reads the body), after the caller's extractor, so a
/// stranger still gets 401 before anything is read.
#[derive(Debug, Clone, Copy)]
pub struct NoBody;

/// The most of a body [`NoBody`] reads to tell none from some.
const NO_BODY_READ: usize = 64;

impl<S: Send + Sync> axum::extract::FromRequest<S> for NoBody {
    type Rejection = ApiError;

    async fn from_request(req: axum::extract::Request, _: &S) -> Result<Self, ApiError> {
        let refused = || {
            ApiError::bad_json(
                "body",
                "this endpoint takes no body (send none, or {}); see GET /v1/openapi.json",
            )
        };
        let bytes = axum::body::to_bytes(req.into_body(), NO_BODY_READ)
            .await
            .map_err(|_| refused())?;
        let text = std::str::from_utf8(&bytes).map_err(|_| refused())?;
        let bare: String = text.chars().filter(|c| !c.is_whitespace()).collect();
        if bare.is_empty() || bare == "{}" {
            Ok(NoBody)
        } else {
            Err(refused())
        }
    }
}

/// 404 for an unknown path: under an API version (`/v1`, `/v2`, ...) and
/// `/healthz` the API's JSON error, elsewhere the pages' 404 page.
pub async fn not_found(uri: axum::http::Uri) -> axum::response::Response {
    use axum::response::IntoResponse;
    if is_api(uri.path()) {
        ApiError::not_found("no such endpoint (see GET /v1/openapi.json)").into_response()
    } else {
        crate::web::page::unknown_page()
    }
}

/// True for a path of the API: under a version (`/v1`, `/v2`, ...) and
/// `/healthz`; every other path is the pages'.
fn is_api(path: &str) -> bool {
    let first = path.trim_start_matches('/').split('/').next().unwrap_or("");
    first == "healthz"
        || first
            .strip_prefix('v')
            .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
}

/// 405 for a known path with another method: the API's JSON error under
/// the API, a page elsewhere.
pub async fn method_not_allowed(uri: axum::http::Uri) -> axum::response::Response {
    use axum::response::IntoResponse;
    if is_api(uri.path()) {
        ApiError::new(
            StatusCode::METHOD_NOT_ALLOWED,
            abba_api::ErrorCode::MethodNotAllowed,
            "this endpoint does not take that method (see GET /v1/openapi.json)",
        )
        .into_response()
    } else {
        crate::web::page::not_allowed_page()
    }
}
