//! The error body every non-2xx response carries.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// What kind of error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum ErrorCode {
    /// 400: the body is not the JSON expected (`path` says where).
    BadJson,
    /// 400: a query parameter is malformed.
    BadQuery,
    /// 401: no token, a malformed, unknown or revoked token.
    Unauthorized,
    /// 403: a person's token on an admin endpoint.
    Forbidden,
    /// 404: no such person (or not yours), suggestion, token or endpoint.
    NotFound,
    /// 405: the endpoint exists with other methods.
    MethodNotAllowed,
    /// 409: a sequence number already used with another payload, a person
    /// name taken, an answer to a suggestion that is not open.
    Conflict,
    /// 413: the body is larger than [`crate::MAX_BODY_BYTES`].
    TooLarge,
    /// 415: the body is not `application/json`.
    UnsupportedMediaType,
    /// 422: well-formed JSON with a value refused (`path` names the field).
    Invalid,
    /// 500: a fault of the service (never caused by a request's content).
    Internal,
    /// 408: the request (its head or body) came too slowly.
    Timeout,
    /// 429: too many failed authentications from this client; wait for
    /// `Retry-After` seconds.
    TooManyRequests,
    /// 503: the store stayed busy (another writer held it) or the service
    /// is at its limit of requests in flight; retry after `Retry-After`.
    Busy,
    /// 503: the store cannot be written or reached.
    Unavailable,
}

/// The error body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ErrorBody {
    /// The HTTP status.
    pub status: u16,
    /// What kind of error.
    pub code: ErrorCode,
    /// What was wrong and what was expected.
    pub message: String,
    /// Where in the body (`events[3].at`) or query (`from`), when known.
    pub path: Option<String>,
}
