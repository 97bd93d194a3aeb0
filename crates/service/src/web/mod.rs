//! The web pages (issue 24): the person's app (`/`, `/log`, ...) and the
//! clinic's page (`/clinic`), server-rendered by abba-web, on the same
//! state, pool, live advisors and store paths as `/v1` (an event entered
//! on the Log goes through [`crate::routes::person::post_batch`], an
//! answer through [`crate::routes::person::answer_batch`]).
//!
//! Sessions are cookies (`abba_session`), never accepted on `/v1`; every
//! POST needs the session's CSRF token and a same-origin `Origin` (or
//! `Referer`). See crates/service/README.md, "The pages".

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
use axum::extract::DefaultBodyLimit;
use axum::http::{header, HeaderName, HeaderValue};
use axum::routing::{get, post};
use axum::Router;
use tower_http::set_header::SetResponseHeaderLayer;

/// The pages' routes with their headers (merged into the service's router
/// before its layers).
pub fn routes() -> Router<AppState> {
    let set = |name: HeaderName, value: &'static str| {
        SetResponseHeaderLayer::overriding(name, HeaderValue::from_static(value))
    };
    // The report sets its own CSP (its inline stylesheet by hash).
    let csp = SetResponseHeaderLayer::if_not_present(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(abba_web::CSP),
    );
    Router::new()
        .route(abba_web::STYLE_PATH, get(page::style))
        .route("/favicon.ico", get(page::icon))
        .route("/signin", get(signin::help).post(signin::post))
        .route("/signin/{secret}", get(signin::page))
        .route("/signout", post(signin::signout))
        .route("/", get(today::page))
        .route("/answer", post(today::answer))
        .route("/log", get(log::page))
        .route("/log/reading", post(log::reading))
        .route("/log/meal", post(log::meal))
        .route("/glucose", get(glucose::page))
        .route("/history", get(history::page))
        .route("/report", get(history::person_report))
        .route("/clinic", get(clinic::list))
        .route(
            "/clinic/persons",
            post(clinic::create).layer(DefaultBodyLimit::max(clinic::MAX_UPLOAD_BYTES)),
        )
        .route("/clinic/persons/{id}", get(clinic::person))
        .route("/clinic/persons/{id}/report", get(history::clinic_report))
        .route("/clinic/persons/{id}/bounds", post(clinic::bounds))
        .route("/clinic/persons/{id}/steps", post(clinic::steps))
        .route("/clinic/persons/{id}/therapy", post(clinic::therapy))
        .route(
            "/clinic/persons/{id}/import",
            post(clinic::import).layer(DefaultBodyLimit::max(clinic::MAX_UPLOAD_BYTES)),
        )
        .route("/clinic/persons/{id}/signin", post(clinic::issue_signin))
        .route("/clinic/persons/{id}/tokens", post(clinic::issue_token))
        .route(
            "/clinic/persons/{id}/tokens/{token}/revoke",
            post(clinic::revoke_token),
        )
        .route(
            "/clinic/persons/{id}/sessions/{session}/revoke",
            post(clinic::revoke_session),
        )
        .layer(csp)
        .layer(set(header::X_FRAME_OPTIONS, "DENY"))
        .layer(set(header::REFERRER_POLICY, page::REFERRER_POLICY))
        .layer(set(header::CACHE_CONTROL, "no-store"))
        .layer(set(header::X_CONTENT_TYPE_OPTIONS, "nosniff"))
}
