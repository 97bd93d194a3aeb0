//! The OpenAPI document, generated from the handlers' annotations and the
//! wire types' schemas (never written by hand).

use crate::routes::{admin, meta, person};
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::{Modify, OpenApi};

/// The document.
#[derive(OpenApi)]
#[openapi(
    info(
        title = "abba service",
        description = "The abba advisor service for pump and phone apps: device events with the app's sequence numbers, acknowledged after commit and answered with the advisor's suggestions; answers; history sync. abba is research software, not a medical device.",
        license(name = "MIT")
    ),
    paths(
        meta::healthz,
        meta::openapi,
        admin::create_person,
        admin::set_bounds,
        admin::issue_token,
        admin::revoke_token,
        person::post_events,
        person::post_answers,
        person::sync,
        person::suggestions,
        person::advice,
        person::history,
    ),
    components(schemas(abba_api::ErrorCode, abba_api::Mode)),
    modifiers(&Bearer),
    tags(
        (name = "meta", description = "Health and this document"),
        (name = "admin", description = "The clinic: persons, bounds, tokens"),
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
