//! Request bodies: read whole (up to [`abba_api::MAX_BODY_BYTES`], else
//! 413), checked to be JSON, parsed with the JSON path of the first problem
//! (400 naming it and what was expected).

use crate::error::ApiError;
use abba_api::ErrorCode;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::http::{header, HeaderMap, StatusCode};
use serde::de::DeserializeOwned;

/// The bytes of a body, or the error for a body that could not be read.
pub type RawBody = Result<Bytes, BytesRejection>;

/// Parses a JSON body.
pub fn parse<T: DeserializeOwned>(headers: &HeaderMap, body: RawBody) -> Result<T, ApiError> {
    let bytes = body.map_err(|e| {
        if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
            ApiError::new(
                StatusCode::PAYLOAD_TOO_LARGE,
                ErrorCode::TooLarge,
                format!("the body is larger than {} bytes", abba_api::MAX_BODY_BYTES),
            )
        } else {
            ApiError::bad_json(".", format!("the body could not be read: {e}"))
        }
    })?;
    let json = headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .map(|v| v.split(';').next().unwrap_or("").trim())
        .is_some_and(|m| m.eq_ignore_ascii_case("application/json"));
    if !json {
        return Err(ApiError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ErrorCode::UnsupportedMediaType,
            "expected Content-Type: application/json",
        ));
    }
    let mut de = serde_json::Deserializer::from_slice(&bytes);
    let value: T = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        // The root is ".".
        ApiError::bad_json(e.path().to_string(), e.into_inner().to_string())
    })?;
    de.end()
        .map_err(|e| ApiError::bad_json(".", format!("after the JSON value: {e}")))?;
    Ok(value)
}
