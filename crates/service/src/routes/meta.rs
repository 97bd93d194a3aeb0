//! Health (the OpenAPI document's endpoint lives with the document, in
//! `crate::openapi`).

use crate::state::AppState;
use abba_api::Health;
use axum::extract::State;
use axum::http::StatusCode;
use axum::Json;

/// The health document (no token needed): `ok` when the store answers and
/// can be written, else 503 with the reason in `status`.
#[utoipa::path(get, path = "/healthz", tag = "meta",
    responses(
        (status = 200, description = "The service is up and its store can be written", body = Health),
        (status = 503, description = "The store is read-only or does not answer (`status` says why)", body = Health)))]
pub async fn healthz(State(s): State<AppState>) -> (StatusCode, Json<Health>) {
    let (code, status) = match s.store_health().await {
        Ok(()) => (StatusCode::OK, "ok".to_string()),
        Err(why) => (StatusCode::SERVICE_UNAVAILABLE, format!("not ok: {why}")),
    };
    (
        code,
        Json(Health {
            status,
            service: "abba".into(),
            version: env!("CARGO_PKG_VERSION").into(),
            notice: abba_api::NOTICE.into(),
        }),
    )
}

#[cfg(test)]
mod tests {
    /// The API says the advisor's notice (abba-api depends on nothing of
    /// abba's, so it keeps its own copy: this keeps the two the same).
    #[test]
    fn the_api_says_the_advisors_notice() {
        assert_eq!(abba_api::NOTICE, abba_advisor::words::NOTICE);
    }
}
