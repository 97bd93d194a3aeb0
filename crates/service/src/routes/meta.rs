//! Health and the OpenAPI document.

use crate::error::ApiError;
use crate::extract::AnyCaller;
use crate::state::AppState;
use abba_api::{ErrorBody, Health};
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

/// The OpenAPI document, generated from the handlers.
#[utoipa::path(get, path = "/v1/openapi.json", tag = "meta", security(("bearer" = [])),
    responses(
        (status = 200, description = "The OpenAPI 3.1 document of this service", body = Object),
        (status = 401, description = "No valid token", body = ErrorBody)))]
pub async fn openapi(_caller: AnyCaller) -> Result<Json<utoipa::openapi::OpenApi>, ApiError> {
    Ok(Json(crate::openapi::document().clone()))
}
