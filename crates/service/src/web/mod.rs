//! The web pages (issue 24): the person's app (`/`, `/log`, ...) and the
//! clinic's page (`/clinic`), server-rendered by abba-web, on the same
//! state, pool, live advisors and store paths as `/v1` (an event entered
//! on the Log goes through [`crate::routes::person::post_batch`], an
//! answer through [`crate::routes::person::answer_batch`]).
//!
//! Sessions are cookies (`abba_session`), never accepted on `/v1`; every
//! POST needs the session's CSRF token and a same-origin `Origin` (or
//! `Referer`). See crates/service/README.md, "The pages".

pub mod advice_words;
pub mod clinic;
pub mod form;
pub mod glucose;
pub mod history;
pub mod log;
pub mod page;
pub mod session;
pub mod signin;
pub mod today;

use crate::state::AppState;
use axum::http::{header, HeaderName, HeaderValue};
use axum::Router;
use tower_http::set_header::SetResponseHeaderLayer;

/// The pages' routes (each page module lists its own) with their headers (merged into the service's router
/// before its layers).
pub fn routes(state: AppState) -> Router<AppState> {
    let set = |name: HeaderName, value: &'static str| {
        SetResponseHeaderLayer::overriding(name, HeaderValue::from_static(value))
    };
    // The report sets its own CSP (its inline stylesheet by hash).
    let csp = SetResponseHeaderLayer::if_not_present(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(abba_web::CSP),
    );
    Router::new()
        .merge(page::routes())
        .merge(signin::routes())
        .merge(today::routes())
        .merge(log::routes())
        .merge(glucose::routes())
        .merge(history::routes())
        .merge(clinic::routes())
        .layer(axum::middleware::from_fn_with_state(
            state,
            session::session_before_body,
        ))
        .layer(csp)
        .layer(set(header::X_FRAME_OPTIONS, "DENY"))
        .layer(set(header::REFERRER_POLICY, page::REFERRER_POLICY))
        .layer(set(header::CACHE_CONTROL, "no-store"))
        .layer(set(header::X_CONTENT_TYPE_OPTIONS, "nosniff"))
}
