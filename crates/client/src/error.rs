//! What can go wrong talking to the service.

use abba_api::ErrorBody;

/// An error of a call to the service.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The base URL is not `http://HOST:PORT` (optionally with a path).
    #[error("bad service URL '{url}': {problem}")]
    Url {
        /// The URL given.
        url: String,
        /// What is wrong with it.
        problem: String,
    },
    /// No answer: the connection failed, was reset or timed out. The
    /// request may or may not have been carried out (see
    /// [`ClientError::is_transient`]).
    #[error("{method} {url}: no answer from the service: {message}")]
    Unreachable {
        /// HTTP method.
        method: &'static str,
        /// The URL called.
        url: String,
        /// The transport's message.
        message: String,
    },
    /// The service answered with an error status.
    #[error("{method} {url}: {status} {}", describe(.body.as_ref(), .text))]
    Status {
        /// HTTP method.
        method: &'static str,
        /// The URL called.
        url: String,
        /// The HTTP status.
        status: u16,
        /// The error body, when the service sent one.
        body: Option<ErrorBody>,
        /// The raw body (shortened) when it was not an error body.
        text: String,
        /// The `Retry-After` seconds of a 429 or 503, when sent.
        retry_after: Option<u32>,
    },
    /// The service answered 2xx with a body that is not what `/v1` says.
    #[error("{method} {url}: unexpected response body: {message}")]
    Decode {
        /// HTTP method.
        method: &'static str,
        /// The URL called.
        url: String,
        /// What did not parse, with the JSON path.
        message: String,
    },
    /// The service broke the protocol (an acknowledgement that does not
    /// cover the batch sent, ...).
    #[error("protocol violation: {0}")]
    Protocol(String),
    /// Retries were given up.
    #[error("gave up after {attempts} attempts over {waited_ms} ms: {last}")]
    GaveUp {
        /// Attempts made.
        attempts: u32,
        /// Time spent waiting between them (ms).
        waited_ms: u64,
        /// The last error.
        last: Box<ClientError>,
    },
}

fn describe(body: Option<&ErrorBody>, text: &str) -> String {
    match body {
        Some(b) => match &b.path {
            Some(p) => format!("{:?} at {p}: {}", b.code, b.message),
            None => format!("{:?}: {}", b.code, b.message),
        },
        None => text.to_string(),
    }
}

impl ClientError {
    /// The service's `Retry-After` (seconds), when it sent one.
    pub fn retry_after(&self) -> Option<std::time::Duration> {
        match self {
            ClientError::Status {
                retry_after: Some(s),
                ..
            } => Some(std::time::Duration::from_secs(u64::from(*s))),
            _ => None,
        }
    }

    /// True when trying again later may succeed: no answer, or the service
    /// said it is busy (503) or asked to slow down (429, after failed
    /// authentications). Another 4xx never is, nor a 500.
    pub fn is_transient(&self) -> bool {
        match self {
            ClientError::Unreachable { .. } => true,
            ClientError::Status { status, .. } => *status == 503 || *status == 429,
            _ => false,
        }
    }

    /// The HTTP status, when the service answered with an error.
    pub fn status(&self) -> Option<u16> {
        match self {
            ClientError::Status { status, .. } => Some(*status),
            _ => None,
        }
    }
}
