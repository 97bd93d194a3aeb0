//! abba-client: the reference client of the abba service (`/v1`).
//!
//! Two parts, neither of which knows the simulator:
//!
//! - [`Client`]: a blocking, typed call per endpoint on abba-api's wire
//!   types (ureq over plain HTTP/1.1, connections kept alive), errors as
//!   [`ClientError`] with the service's error body;
//! - [`Outbox`]: what a pump app does to deliver its events exactly once:
//!   its own sequence numbers, events kept until acknowledged, a flush at
//!   each event that can produce an answer, and after a failure a sync
//!   (`GET .../sync`) and a re-send of only what the service does not hold
//!   ([`Retry`] says how long to keep trying).
//!
//! `abba app` drives a simulated patient through a live service with these
//! (the CLI's `remote` module); the crash and load tests use them directly.
//! abba is research software, not a medical device.

// ClientError::Status carries the service's whole error body and its
// Retry-After; boxing it would only move the allocation.
#![allow(clippy::result_large_err)]

pub mod client;
pub mod error;
pub mod outbox;
pub mod retry;

pub use client::Client;
pub use error::ClientError;
pub use outbox::{post_answers, AnswersPosted, Flushed, Outbox, OutboxStats};
pub use retry::Retry;

/// The wire types, re-exported for callers of this crate.
pub use abba_api as api;
