//! A whole-body deadline for request bodies.
//!
//! tower-http's body timeout restarts with every frame, so a client that
//! sends a byte every few seconds keeps a request (and its slot) open until
//! the request timeout. Every body but a clinic's upload of exports (the
//! forms of the pages, the sign-in form, an app's batch of events: at most
//! [`abba_api::MAX_BODY_BYTES`]) must arrive whole within the body timeout
//! of its head, whatever length it declares; an upload (up to
//! `MAX_UPLOAD_BYTES`, from a clinic's slow line) keeps the per-frame
//! timeout and the request's. (A service probe held every sign-in slot
//! with bodies declared at 1 MB and trickled a byte every 3 s, when only
//! bodies of 64 KiB or less had the deadline.)

use axum::body::{Body, Bytes, HttpBody};
use axum::extract::Request;
use axum::http::header;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll};
use std::time::Duration;

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

/// Wraps the body of `req` (but an upload's, see the module docs) in the
/// deadline `within` from now.
pub fn body_deadline(req: Request, within: Duration) -> Request {
    let length = req
        .headers()
        .get(header::CONTENT_LENGTH)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.trim().parse::<u64>().ok());
    let upload =
        req.method() == axum::http::Method::POST && crate::web::clinic::is_upload(req.uri().path());
    if length == Some(0) || upload {
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
