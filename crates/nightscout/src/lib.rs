//! abba-nightscout: a person's live link to their Nightscout site.
//!
//! - [`site`]: the URL (https, plain http only to this machine) and the
//!   credential (an API secret kept only as its SHA-1 hex).
//! - [`client`]: HTTP with ureq and rustls, timeouts on every call, no
//!   redirects, retries of 429 and 5xx.
//! - [`fetch`]: API v1 paging by time (newest first, `count`, duplicates
//!   across pages), profiles, API v3 `history` for deletions.
//! - [`by_id`]: API v1 paging by `_id` where time cannot page: more
//!   documents at one key than a page holds, treatments without a
//!   `created_at` string.
//! - [`by_time`]: API v1 read by ranges of time where the server's pages
//!   are not in time order (oldest first, or as stored).
//! - [`device_status`]: the loop's evidence in the site's device status,
//!   read a day at a time from its mark and counted, never held whole.
//! - [`sync`]: what is new into the person's store, by the same import as
//!   files, the marks advancing in the import's transaction.
//! - [`write_back`]: opt-in; one Note per open or answered suggestion and an `abba` profile
//!   beside the person's own, never the default and never a Profile Switch.
//!
//! abba is research software, not a medical device.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod background;
pub mod by_id;
pub mod by_time;
pub mod client;
pub mod device_status;
pub mod error;
pub mod fetch;
pub mod site;
pub mod sync;
pub mod write_back;

pub use client::{Client, ClientOptions};
pub use error::NsError;
pub use site::SiteUrl;
pub use sync::{check_link, link, sync, SyncOptions, SyncReport};
