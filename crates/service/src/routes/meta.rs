//! Health and the OpenAPI document.

use crate::auth::Need;
use crate::error::ApiError;
use crate::state::AppState;
use abba_api::{ErrorBody, Health};
use axum::extract::State;
use axum::http::HeaderMap;
use axum::Json;
use utoipa::OpenApi;

/// The health document (no token needed).
#[utoipa::path(get, path = "/healthz", tag = "meta",
    responses((status = 200, description = "The service is up", body = Health)))]
pub async fn healthz() -> Json<Health> {
    Json(Health {
        status: "ok".into(),
        service: "abba".into(),
        version: env!("CARGO_PKG_VERSION").into(),
        notice: abba_api::NOTICE.into(),
    })
}

/// The OpenAPI document, generated from the handlers.
#[utoipa::path(get, path = "/v1/openapi.json", tag = "meta", security(("bearer" = [])),
    responses(
        (status = 200, description = "The OpenAPI 3.1 document of this service", body = Object),
        (status = 401, description = "No valid token", body = ErrorBody)))]
pub async fn openapi(
    State(s): State<AppState>,
    headers: HeaderMap,
) -> Result<Json<utoipa::openapi::OpenApi>, ApiError> {
    s.authorize(&headers, Need::Any).await?;
    Ok(Json(crate::openapi::ApiDoc::openapi()))
}
