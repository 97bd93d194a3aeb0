//! Errors: the one error type of the service and how each becomes an HTTP
//! response with an [`ErrorBody`].

use abba_api::{ErrorBody, ErrorCode};
use abba_store::StoreError;
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::Json;
use thiserror::Error;

/// An error answered to a request.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{status}: {message}")]
pub struct ApiError {
    /// HTTP status.
    pub status: StatusCode,
    /// Kind.
    pub code: ErrorCode,
    /// What was wrong and what was expected.
    pub message: String,
    /// JSON path or query parameter, when known.
    pub path: Option<String>,
    /// Seconds for a `Retry-After` header (429, 503).
    pub retry_after: Option<u64>,
}

impl ApiError {
    /// An error without a path.
    pub fn new(status: StatusCode, code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            status,
            code,
            message: message.into(),
            path: None,
            retry_after: None,
        }
    }

    /// The same error naming a path.
    pub fn at(mut self, path: impl Into<String>) -> Self {
        self.path = Some(path.into());
        self
    }

    /// 400: the body is not the JSON expected.
    pub fn bad_json(path: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, ErrorCode::BadJson, message).at(path)
    }

    /// 422: a value refused.
    pub fn invalid(path: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(
            StatusCode::UNPROCESSABLE_ENTITY,
            ErrorCode::Invalid,
            message,
        )
        .at(path)
    }

    /// 401.
    pub fn unauthorized(message: impl Into<String>) -> Self {
        Self::new(StatusCode::UNAUTHORIZED, ErrorCode::Unauthorized, message)
    }

    /// 403.
    pub fn forbidden() -> Self {
        Self::new(
            StatusCode::FORBIDDEN,
            ErrorCode::Forbidden,
            "this endpoint needs an admin (clinic) token",
        )
    }

    /// 404 for a person: the same answer whether the person does not exist
    /// or is not the token's.
    pub fn no_person() -> Self {
        Self::new(
            StatusCode::NOT_FOUND,
            ErrorCode::NotFound,
            "no such person for this token",
        )
    }

    /// 404.
    pub fn not_found(message: impl Into<String>) -> Self {
        Self::new(StatusCode::NOT_FOUND, ErrorCode::NotFound, message)
    }

    /// 409.
    pub fn conflict(message: impl Into<String>) -> Self {
        Self::new(StatusCode::CONFLICT, ErrorCode::Conflict, message)
    }

    /// 503: the store stayed busy or the service is at its limit; retry
    /// after `retry_after` seconds.
    pub fn busy(message: impl Into<String>, retry_after: u64) -> Self {
        let mut e = Self::new(StatusCode::SERVICE_UNAVAILABLE, ErrorCode::Busy, message);
        e.retry_after = Some(retry_after);
        e
    }

    /// 429: too many failed authentications; retry after `retry_after` s.
    pub fn too_many(retry_after: u64) -> Self {
        let mut e = Self::new(
            StatusCode::TOO_MANY_REQUESTS,
            ErrorCode::TooManyRequests,
            format!("too many failed authentications from this client; retry in {retry_after} s"),
        );
        e.retry_after = Some(retry_after);
        e
    }

    /// 408: the request came too slowly.
    pub fn timeout(what: &str) -> Self {
        Self::new(
            StatusCode::REQUEST_TIMEOUT,
            ErrorCode::Timeout,
            format!("{what} did not arrive in time"),
        )
    }

    /// 500 (a fault of the service, logged).
    pub fn internal(message: impl std::fmt::Display) -> Self {
        tracing::error!(error = %message, "internal error");
        Self::new(
            StatusCode::INTERNAL_SERVER_ERROR,
            ErrorCode::Internal,
            "internal error of the service (logged)",
        )
    }

    /// The body.
    pub fn body(&self) -> ErrorBody {
        ErrorBody {
            status: self.status.as_u16(),
            code: self.code,
            message: shortened(&self.message, MAX_MESSAGE_CHARS),
            path: self.path.as_deref().map(|p| shortened(p, MAX_PATH_CHARS)),
        }
    }
}

use abba_web::pages::shortened;
pub use abba_web::pages::MAX_MESSAGE_CHARS;

/// The longest JSON path or parameter name an error body carries.
pub const MAX_PATH_CHARS: usize = 200;

impl From<StoreError> for ApiError {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::Invalid { field, problem } => ApiError::invalid(field, problem),
            StoreError::ProfileDiffers { origin, difference } => {
                ApiError::invalid(origin, difference)
            }
            StoreError::SeqConflict { index, .. } => {
                let msg = e.to_string();
                ApiError::conflict(msg).at(format!("events[{index}].seq"))
            }
            StoreError::PersonExists(_) | StoreError::PersonLookAlike { .. } => {
                ApiError::conflict(e.to_string()).at("name")
            }
            // "answers[i].field: ...": the field is the path.
            StoreError::Answer(m) => {
                let path = m
                    .split_once(": ")
                    .map(|(head, _)| head)
                    .filter(|h| h.starts_with("answers[") && !h.contains(' '))
                    .map(str::to_string);
                match path {
                    Some(p) => ApiError::conflict(m).at(p),
                    None => ApiError::conflict(m),
                }
            }
            StoreError::Feed(m) => ApiError::conflict(m),
            StoreError::NoPerson(_) | StoreError::NoPersonId(_) => ApiError::no_person(),
            StoreError::NoData(_) => ApiError::conflict(e.to_string()),
            StoreError::NoSuggestion(field) => {
                ApiError::not_found("no such suggestion for this person").at(field)
            }
            StoreError::NoToken(_) => ApiError::not_found(e.to_string()),
            StoreError::LastAdmin(_) => ApiError::conflict(e.to_string()),
            ref busy if busy.is_busy() => {
                tracing::warn!(error = %busy, "the store stayed busy");
                ApiError::busy(
                    "the store is busy (another writer holds it); retry after Retry-After seconds",
                    1,
                )
            }
            ref ro if ro.is_read_only() => {
                tracing::error!(error = %ro, "the store cannot be written");
                ApiError::new(
                    StatusCode::SERVICE_UNAVAILABLE,
                    ErrorCode::Unavailable,
                    "the store cannot be written (read-only)",
                )
            }
            StoreError::Advisor(a) => ApiError::invalid("advisor", a.to_string()),
            other => ApiError::internal(other),
        }
    }
}

/// A service error met while answering a request: the store's as
/// [`StoreError`]'s (contention 503 with `Retry-After`, never 500), an
/// unwritable store 503, the rest 500.
impl From<ServiceError> for ApiError {
    fn from(e: ServiceError) -> Self {
        match e {
            ServiceError::Store(s) => s.into(),
            ServiceError::ReadOnly(_) => {
                tracing::error!(error = %e, "the store cannot be written");
                ApiError::new(
                    StatusCode::SERVICE_UNAVAILABLE,
                    ErrorCode::Unavailable,
                    "the store cannot be written (read-only)",
                )
            }
            other => ApiError::internal(other),
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let mut r = (self.status, Json(self.body())).into_response();
        if self.status == StatusCode::UNAUTHORIZED {
            r.headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
        }
        if let Some(s) = self.retry_after {
            r.headers_mut()
                .insert(header::RETRY_AFTER, HeaderValue::from(s));
        }
        r
    }
}

/// What can stop the server.
#[derive(Debug, Error)]
pub enum ServiceError {
    /// The store.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// Binding or serving.
    #[error("{context}: {source}")]
    Io {
        /// What was being done.
        context: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The store file cannot be written.
    #[error("{}: the store cannot be written (read-only file, folder or medium); the service needs to write every event it acknowledges", .0.display())]
    ReadOnly(std::path::PathBuf),
    /// The connection pool could not be built.
    #[error("opening the store's connections: {0}")]
    Pool(String),
    /// Token generation.
    #[error("the operating system's random generator failed: {0}")]
    Random(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_message_is_cut_and_says_so() {
        let e = ApiError::invalid("at", format!("bad value \"{}\"", "9".repeat(300_000)));
        let b = e.body();
        assert!(
            b.message.chars().count() < MAX_MESSAGE_CHARS + 60,
            "{}",
            b.message.len()
        );
        assert!(
            b.message.ends_with("more characters left out)"),
            "{}",
            &b.message[990..]
        );
        assert_eq!(ApiError::invalid("at", "short").body().message, "short");
    }
}
