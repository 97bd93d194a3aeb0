//! Every endpoint, registered once for both the router and the OpenAPI
//! document (utoipa-axum's router: the two lists cannot drift); the
//! document is generated from the handlers' annotations and the wire
//! types' schemas (never written by hand).

use crate::routes::{admin, meta, person};
use crate::state::AppState;
use std::sync::OnceLock;
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::{Modify, OpenApi};
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::routes;

/// The endpoints.
pub fn api() -> OpenApiRouter<AppState> {
    OpenApiRouter::with_openapi(ApiDoc::openapi())
        .routes(routes!(meta::healthz))
        .routes(routes!(openapi))
        .routes(routes!(admin::create_person))
        .routes(routes!(admin::set_bounds))
        .routes(routes!(admin::set_therapy))
        .routes(routes!(admin::issue_token))
        .routes(routes!(admin::revoke_token))
        .routes(routes!(person::post_events))
        .routes(routes!(person::post_answers))
        .routes(routes!(person::sync))
        .routes(routes!(person::suggestions))
        .routes(routes!(person::advice))
        .routes(routes!(person::history))
}

/// The OpenAPI document, generated from the handlers.
#[utoipa::path(get, path = "/v1/openapi.json", tag = "meta", security(("bearer" = [])),
    responses(
        (status = 200, description = "The OpenAPI 3.1 document of this service", body = Object),
        (status = 401, description = "No valid token", body = abba_api::ErrorBody)))]
pub async fn openapi(
    _caller: crate::extract::AnyCaller,
) -> Result<axum::Json<utoipa::openapi::OpenApi>, crate::error::ApiError> {
    Ok(axum::Json(document().clone()))
}

/// The document (built once).
pub fn document() -> &'static utoipa::openapi::OpenApi {
    static DOC: OnceLock<utoipa::openapi::OpenApi> = OnceLock::new();
    DOC.get_or_init(|| api().split_for_parts().1)
}

/// The document's frame: title, schemas no handler names, security, tags.
#[derive(OpenApi)]
#[openapi(
    info(
        title = "abba service",
        description = "The abba advisor service for pump and phone apps: device events with the app's sequence numbers, acknowledged after commit and answered with the advisor's suggestions; answers; history sync. abba is research software, not a medical device.",
        license(name = "MIT")
    ),
    components(schemas(abba_api::ErrorCode, abba_api::Mode)),
    modifiers(&Bearer),
    tags(
        (name = "meta", description = "Health and this document"),
        (name = "admin", description = "The clinic: persons, bounds, therapy changes, tokens"),
        (name = "person", description = "A person's app: events, answers, sync, advice")
    )
)]
pub struct ApiDoc;

struct Bearer;

impl Modify for Bearer {
    fn modify(&self, openapi: &mut utoipa::openapi::OpenApi) {
        let c = openapi.components.get_or_insert_with(Default::default);
        c.add_security_scheme(
            "bearer",
            SecurityScheme::Http(
                HttpBuilder::new()
                    .scheme(HttpAuthScheme::Bearer)
                    .description(Some("abba_ followed by 64 hex digits"))
                    .build(),
            ),
        );
    }
}
