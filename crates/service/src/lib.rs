//! abba-service: the HTTP/JSON service a pump app, a phone app or a clinic
//! system talks to, over one person store (many persons).
//!
//! The protocol (`/v1`, wire types in abba-api) is described in
//! crates/service/README.md: the app posts device events with its
//! own sequence numbers; each batch is stored in one transaction and
//! acknowledged only after COMMIT, with every suggestion its events
//! produced; a repeated number with the same payload is acknowledged again
//! and stores nothing, with another payload it is refused (409). Tokens are
//! random, stored as SHA-256, compared in constant time and revocable.
//! Each person's advisor is kept live in memory and advanced by new events
//! only. abba-service depends on abba-store, never on the simulator.
//!
//! abba is research software, not a medical device.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod auth;
pub mod body;
pub mod client;
pub mod conns;
pub mod convert;
pub mod deadline;
pub mod error;
pub mod extract;
pub mod head;
pub mod openapi;
pub mod refit;
pub mod routes;
pub mod server;
pub mod settings;
pub mod state;
pub mod web;

pub use error::{ApiError, ServiceError};
pub use refit::RefitQueue;
pub use server::{router, router_with, serve, serve_with, serve_with_twins};
pub use settings::{ServeSettings, StoreSettings};
pub use state::{AppState, EffectSource};

use abba_store::Store;
use std::path::Path;

/// Opens the store for the service (WAL, `synchronous=FULL`, IMMEDIATE
/// transactions).
pub fn open_store(db: &Path) -> Result<Store, ServiceError> {
    Ok(Store::open_durable(db)?)
}

/// Prints a new admin token's secret once; stores only its hash.
pub fn new_admin_token(db: &Path) -> Result<(i64, String), ServiceError> {
    let mut store = open_store(db)?;
    auth::issue(&mut store, abba_store::token::Role::Admin)
}

/// Makes a one-time sign-in link's secret for a person (by name) or, with
/// `None`, the admin; stores only its hash (15 minutes, single use).
pub fn new_signin_link(db: &Path, person: Option<&str>) -> Result<String, ServiceError> {
    let mut store = open_store(db)?;
    let role = match person {
        Some(name) => abba_store::token::Role::Person(store.person(name)?.id),
        None => abba_store::token::Role::Admin,
    };
    auth::issue_signin(&mut store, role)
}

/// Issues a person's token by name (for the CLI).
pub fn new_person_token(db: &Path, name: &str) -> Result<(i64, String), ServiceError> {
    let mut store = open_store(db)?;
    let p = store.person(name)?;
    auth::issue(&mut store, abba_store::token::Role::Person(p.id))
}
