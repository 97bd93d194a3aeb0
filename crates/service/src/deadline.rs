//! A whole-body deadline for small request bodies.
//!
//! tower-http's body timeout restarts with every frame, so a client that
//! sends a byte every few seconds keeps a request (and its slot) open until
//! the request timeout. A body of at most [`SMALL_BODY_BYTES`] (every form
//! of the pages, the sign-in form, an app's batch of events), or one whose
//! length is not given, must arrive whole within the body timeout of its
//! head; a larger one (a clinic's upload of exports) keeps the per-frame
//! timeout and the request's.

use axum::body::{Body, Bytes, HttpBody};
use axum::extract::Request;
use axum::http::header;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::Duration;

/// Bodies up to this size (bytes) must arrive whole within the deadline.
pub const SMALL_BODY_BYTES: u64 = 64 * 1024;

/// The error of a body past its deadline: the request's answer is 408, as
/// for the per-frame timeout (`body::is_timeout` knows both).
#[derive(Debug)]
pub struct BodyDeadline;

impl std::fmt::Display for BodyDeadline {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the request body did not arrive whole in time")
    }
}

impl std::error::Error for BodyDeadline {}

/// A body that fails with [`BodyDeadline`] once `sleep` is over.
struct DeadlineBody {
    inner: Body,
    sleep: Pin<Box<tokio::time::Sleep>>,
}

impl HttpBody for DeadlineBody {
    type Data = Bytes;
    type Error = axum::BoxError;

    fn poll_frame(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
    ) -> Poll<Option<Result<http_body::Frame<Self::Data>, Self::Error>>> {
        let this = self.get_mut();
        if this.sleep.as_mut().poll(cx).is_ready() {
            return Poll::Ready(Some(Err(Box::new(BodyDeadline))));
        }
        Pin::new(&mut this.inner)
            .poll_frame(cx)
            .map_err(axum::BoxError::from)
    }

    fn is_end_stream(&self) -> bool {
        self.inner.is_end_stream()
    }

    fn size_hint(&self) -> http_body::SizeHint {
        self.inner.size_hint()
    }
}

/// Wraps a small body of `req` (see the module docs) in the deadline
/// `within` from now.
pub fn small_body_deadline(req: Request, within: Duration) -> Request {
    let length = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    if length.is_some_and(|n| n == 0 || n > SMALL_BODY_BYTES) {
        return req;
    }
    let (parts, body) = req.into_parts();
    // No body (a GET, most requests): nothing to time, no timer made.
    if body.is_end_stream() {
        return Request::from_parts(parts, body);
    }
    let body = Body::new(DeadlineBody {
        inner: body,
        sleep: Box::pin(tokio::time::sleep(within)),
    });
    Request::from_parts(parts, body)
}
