//! Request bodies: read whole (up to [`abba_api::MAX_BODY_BYTES`], else
//! 413; a body that does not arrive in time: 408), checked to be JSON
//! without a key twice in any object, parsed with the JSON path of the
//! first problem (400 naming it and what was expected).

use crate::error::ApiError;
use abba_api::ErrorCode;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::http::{header, HeaderMap, StatusCode};
use serde::de::{self, DeserializeOwned, Deserializer, MapAccess, SeqAccess, Visitor};
use std::collections::HashSet;
use std::fmt;

/// The bytes of a body, or the error for a body that could not be read.
pub type RawBody = Result<Bytes, BytesRejection>;

/// The most a form of the pages may declare (bytes): the sign-in form, a
/// logged reading or meal, an answer, a clinic's settings are a few
/// hundred bytes (a service probe held the sign-in's slots with bodies
/// declared at 1 MB).
pub const FORM_BODY_BYTES: usize = 64 * 1024;

/// The most a request to `path` may declare (bytes): a clinic's upload
/// [`crate::web::clinic::MAX_UPLOAD_BYTES`], the API
/// [`abba_api::MAX_BODY_BYTES`], a form of the pages [`FORM_BODY_BYTES`].
pub fn body_limit(method: &axum::http::Method, path: &str) -> usize {
    if method == axum::http::Method::POST && crate::web::clinic::is_upload(path) {
        crate::web::clinic::MAX_UPLOAD_BYTES
    } else if path.starts_with("/v1/") {
        abba_api::MAX_BODY_BYTES
    } else {
        FORM_BODY_BYTES
    }
}

/// Middleware: a request whose `Content-Length` is over its route's limit
/// ([`body_limit`]) is refused at once with 413 and the connection closed,
/// before a byte of its body is read: no `100 Continue` for a client that
/// asked (`Expect: 100-continue`), no wait for a body that never comes.
/// Reading stops at the limit too, for a body without a length (chunked):
/// a form's at [`FORM_BODY_BYTES`] (413), not at the API's 1 MiB (a
/// probe's 900 KB chunked sign-in form was read whole).
pub async fn refuse_declared_oversize(
    req: axum::extract::Request,
    next: axum::middleware::Next,
) -> axum::response::Response {
    use axum::response::IntoResponse;
    let limit = body_limit(req.method(), req.uri().path());
    let declared = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    let Some(n) = declared.filter(|&n| n > limit as u64) else {
        if limit >= abba_api::MAX_BODY_BYTES {
            // The router's body limit (or an upload route's) applies.
            return next.run(req).await;
        }
        let (parts, body) = req.into_parts();
        let body = axum::body::Body::new(http_body_util::Limited::new(body, limit));
        return next
            .run(axum::extract::Request::from_parts(parts, body))
            .await;
    };
    let e = ApiError::new(
        StatusCode::PAYLOAD_TOO_LARGE,
        ErrorCode::TooLarge,
        format!("the body is declared as {n} bytes, larger than {limit} bytes"),
    );
    let path = req.uri().path();
    let mut r = if path.starts_with("/v1/") || path == "/healthz" {
        e.into_response()
    } else if req.method() == axum::http::Method::POST && crate::web::clinic::is_upload(path) {
        crate::web::clinic::upload_too_large(path, n)
    } else {
        crate::web::page::PageError::from(e).into_response()
    };
    r.headers_mut().insert(
        header::CONNECTION,
        axum::http::HeaderValue::from_static("close"),
    );
    r
}

/// Parses a JSON body.
pub fn parse<T: DeserializeOwned>(headers: &HeaderMap, body: RawBody) -> Result<T, ApiError> {
    let bytes = body.map_err(|e| {
        if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
            ApiError::new(
                StatusCode::PAYLOAD_TOO_LARGE,
                ErrorCode::TooLarge,
                format!("the body is larger than {} bytes", abba_api::MAX_BODY_BYTES),
            )
        } else if is_timeout(&e) {
            ApiError::timeout("the request body")
        } else {
            ApiError::bad_json(".", "the body could not be read whole")
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
    uncompressed(headers, "JSON body")?;
    no_duplicate_keys(&bytes)?;
    let mut de = serde_json::Deserializer::from_slice(&bytes);
    let value: T = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        // The root is ".".
        let (path, message) = locate(&bytes, e.path().to_string(), e.into_inner().to_string());
        ApiError::bad_json(path, message)
    })?;
    de.end()
        .map_err(|e| ApiError::bad_json(".", format!("after the JSON value: {e}")))?;
    Ok(value)
}

/// Refuses a body under a content coding (`Content-Encoding: gzip`): 415
/// naming the encoding. Read as it came, a compressed body was refused as
/// bad JSON with a misleading place, and a compressed form as a form from
/// another origin (its CSRF field unreadable) or a field it does not have.
pub fn uncompressed(headers: &HeaderMap, what: &str) -> Result<(), ApiError> {
    match headers
        .get(header::CONTENT_ENCODING)
        .map(|v| v.to_str().unwrap_or("?").trim())
        .filter(|e| !e.is_empty() && !e.eq_ignore_ascii_case("identity"))
    {
        None => Ok(()),
        Some(enc) => Err(ApiError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            ErrorCode::UnsupportedMediaType,
            format!(
                "Content-Encoding \"{}\" is not accepted: send the {what} uncompressed",
                enc.chars().take(100).collect::<String>()
            ),
        )),
    }
}

/// Inside a device event the deserializer's path stops at
/// `events[i].event` (a tagged union read whole) and the message starts
/// with the field's own path: the path is completed with it, and the
/// message says which event (its seq and time as sent) when the batch
/// gives them.
fn locate(bytes: &[u8], path: String, message: String) -> (String, String) {
    let Some(index) = path
        .strip_prefix("events[")
        .and_then(|r| r.split_once(']'))
        .and_then(|(i, _)| i.parse::<usize>().ok())
    else {
        return (path, message);
    };
    let mut path = path;
    if path.ends_with(".event") {
        if let Some((field, _)) = message.split_once(": ") {
            let plain = !field.is_empty()
                && field
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_.[]".contains(c));
            if plain {
                path = format!("{path}.{field}");
            }
        }
    }
    let which = serde_json::from_slice::<serde_json::Value>(bytes)
        .ok()
        .and_then(|v| {
            let e = v.get("events")?.get(index)?;
            let seq = e.get("seq")?.as_u64()?;
            let at: String = e.get("at")?.as_str()?.chars().take(64).collect();
            Some(format!(" (event seq {seq} at {at})"))
        })
        .unwrap_or_default();
    (path, format!("{message}{which}"))
}

/// True when reading the body stopped at the body timeout.
pub(crate) fn is_timeout(e: &BytesRejection) -> bool {
    let mut cur: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(err) = cur {
        if err.is::<tower_http::timeout::TimeoutError>()
            || err.is::<crate::deadline::BodyDeadline>()
        {
            return true;
        }
        cur = err.source();
    }
    false
}

/// True when a body was refused for its size: by axum's limit (413), or
/// by the form's limit ([`refuse_declared_oversize`]) under the body's
/// deadline, whose wrapping hides it from axum.
pub(crate) fn is_too_large(e: &BytesRejection) -> bool {
    let mut cur: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(err) = cur {
        if err.is::<http_body_util::LengthLimitError>() {
            return true;
        }
        cur = err.source();
    }
    e.status() == StatusCode::PAYLOAD_TOO_LARGE
}

/// Refuses a JSON text with a key twice in one object, at any depth (serde
/// would keep the last silently): 400 naming the object's path and the key.
/// Other syntax errors are left to the typed parse, which names them.
pub fn no_duplicate_keys(bytes: &[u8]) -> Result<(), ApiError> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    match serde_path_to_error::deserialize::<_, Unique>(&mut de) {
        Ok(_) => Ok(()),
        Err(e) => {
            let msg = e.inner().to_string();
            if msg.starts_with(DUPLICATE) {
                let path = e.path().to_string();
                let msg = msg.split(" at line ").next().unwrap_or(&msg).to_string();
                Err(ApiError::bad_json(
                    path,
                    format!("{msg} (each key at most once per object)"),
                ))
            } else {
                Ok(())
            }
        }
    }
}

const DUPLICATE: &str = "duplicate key";

/// Any JSON value, checked for repeated keys.
struct Unique;

impl<'de> de::Deserialize<'de> for Unique {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(UniqueVisitor)
    }
}

struct UniqueVisitor;

impl<'de> Visitor<'de> for UniqueVisitor {
    type Value = Unique;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_bool<E>(self, _: bool) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_i64<E>(self, _: i64) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_u64<E>(self, _: u64) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_f64<E>(self, _: f64) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_str<E>(self, _: &str) -> Result<Unique, E> {
        Ok(Unique)
    }
    fn visit_unit<E>(self) -> Result<Unique, E> {
        Ok(Unique)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Unique, A::Error> {
        while seq.next_element::<Unique>()?.is_some() {}
        Ok(Unique)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Unique, A::Error> {
        let mut seen: HashSet<String> = HashSet::new();
        while let Some(k) = map.next_key::<String>()? {
            if seen.contains(&k) {
                return Err(de::Error::custom(format!("{DUPLICATE} {k:?}")));
            }
            map.next_value::<Unique>()?;
            seen.insert(k);
        }
        Ok(Unique)
    }
}
