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
pub mod convert;
pub mod error;
pub mod openapi;
pub mod routes;
pub mod state;

pub use error::{ApiError, ServiceError};
pub use state::AppState;

use abba_store::Store;
use axum::extract::DefaultBodyLimit;
use axum::routing::{delete, get, post, put};
use axum::Router;
use std::net::SocketAddr;
use std::path::Path;

/// The router over a state.
pub fn router(state: AppState) -> Router {
    use routes::{admin, meta, person};
    Router::new()
        .route("/healthz", get(meta::healthz))
        .route("/v1/openapi.json", get(meta::openapi))
        .route("/v1/persons", post(admin::create_person))
        .route("/v1/persons/{id}/bounds", put(admin::set_bounds))
        .route("/v1/persons/{id}/tokens", post(admin::issue_token))
        .route("/v1/tokens/{token_id}", delete(admin::revoke_token))
        .route("/v1/persons/{id}/events", post(person::post_events))
        .route("/v1/persons/{id}/answers", post(person::post_answers))
        .route("/v1/persons/{id}/sync", get(person::sync))
        .route("/v1/persons/{id}/suggestions", get(person::suggestions))
        .route("/v1/persons/{id}/advice", get(person::advice))
        .route("/v1/persons/{id}/history", get(person::history))
        .fallback(routes::not_found)
        .method_not_allowed_fallback(routes::method_not_allowed)
        .layer(DefaultBodyLimit::max(abba_api::MAX_BODY_BYTES))
        .with_state(state)
}

/// Opens the store for the service (WAL, `synchronous=FULL`).
pub fn open_store(db: &Path) -> Result<Store, ServiceError> {
    Ok(Store::open_durable(db)?)
}

/// Prints a new admin token's secret once; stores only its hash.
pub fn new_admin_token(db: &Path) -> Result<(i64, String), ServiceError> {
    let mut store = open_store(db)?;
    auth::issue(&mut store, abba_store::token::Role::Admin)
}

/// Issues a person's token by name (for the CLI).
pub fn new_person_token(db: &Path, name: &str) -> Result<(i64, String), ServiceError> {
    let mut store = open_store(db)?;
    let p = store.person(name)?;
    auth::issue(&mut store, abba_store::token::Role::Person(p.id))
}

/// Serves `db` on `listen` until SIGTERM or Ctrl-C; `ready` is told the
/// address bound (useful with port 0).
pub fn serve(db: &Path, listen: &str, ready: impl FnOnce(SocketAddr)) -> Result<(), ServiceError> {
    let store = open_store(db)?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|source| ServiceError::Io {
            context: "starting the runtime".into(),
            source,
        })?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(listen)
            .await
            .map_err(|source| ServiceError::Io {
                context: format!("binding {listen}"),
                source,
            })?;
        let addr = listener.local_addr().map_err(|source| ServiceError::Io {
            context: "reading the bound address".into(),
            source,
        })?;
        ready(addr);
        axum::serve(listener, router(AppState::new(store)))
            .with_graceful_shutdown(shutdown())
            .await
            .map_err(|source| ServiceError::Io {
                context: "serving".into(),
                source,
            })
    })
}

/// Resolves on Ctrl-C or SIGTERM.
async fn shutdown() {
    let ctrl_c = async {
        // If the handler cannot be installed, wait for SIGTERM only.
        if tokio::signal::ctrl_c().await.is_err() {
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
}
