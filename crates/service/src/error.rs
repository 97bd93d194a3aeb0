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
}

impl ApiError {
    /// An error without a path.
    pub fn new(status: StatusCode, code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            status,
            code,
            message: message.into(),
            path: None,
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

    /// 500 (a fault of the service, logged).
    pub fn internal(message: impl std::fmt::Display) -> Self {
        eprintln!("abba serve: internal error: {message}");
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
            message: self.message.clone(),
            path: self.path.clone(),
        }
    }
}

impl From<StoreError> for ApiError {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::Invalid { field, problem } => ApiError::invalid(field, problem),
            StoreError::SeqConflict { index, .. } => {
                let msg = e.to_string();
                ApiError::conflict(msg).at(format!("events[{index}].seq"))
            }
            StoreError::PersonExists(_) => ApiError::conflict(e.to_string()).at("name"),
            StoreError::Answer(m) => ApiError::conflict(m),
            StoreError::Feed(m) => ApiError::conflict(m),
            StoreError::NoPerson(_) | StoreError::NoPersonId(_) => ApiError::no_person(),
            StoreError::NoSuggestion(field) => {
                ApiError::not_found("no such suggestion for this person").at(field)
            }
            StoreError::NoToken(_) => ApiError::not_found(e.to_string()),
            StoreError::Advisor(a) => ApiError::invalid("advisor", a.to_string()),
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
    /// Token generation.
    #[error("the operating system's random generator failed: {0}")]
    Random(String),
}
