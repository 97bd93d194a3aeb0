//! Admin (clinic) endpoints: persons, bounds, tokens.

use crate::auth;
use crate::body::{self, RawBody};
use crate::convert;
use crate::error::ApiError;
use crate::extract::{parse_id, Admin, AdminPath};
use crate::state::AppState;
use abba_advisor::Advisor;
use abba_api::{
    BasalSegment, BoundsBody, CarbRatios, ErrorBody, NewPersonBody, PersonCreated,
    TherapyChangeBody, TherapyChanged, TokenIssued, TokenRevoked,
};
use abba_store::token::Role;
use abba_store::{Live, Store, StoreError};
use axum::extract::State;
use axum::http::{HeaderMap, StatusCode};
use axum::Json;

/// Creates a person.
#[utoipa::path(post, path = "/v1/persons", tag = "admin", security(("bearer" = [])),
    request_body = NewPersonBody,
    responses(
        (status = 201, description = "Created", body = PersonCreated),
        (status = 400, description = "Not the JSON expected", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 403, description = "Not an admin token", body = ErrorBody),
        (status = 409, description = "The name is taken", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 422, description = "A value refused", body = ErrorBody)))]
pub async fn create_person(
    State(s): State<AppState>,
    _admin: Admin,
    _query: super::NoQuery,
    headers: HeaderMap,
    body: RawBody,
) -> Result<(StatusCode, Json<PersonCreated>), ApiError> {
    let b: NewPersonBody = body::parse(&headers, body)?;
    let np = convert::new_person(&b)?;
    let p = s
        .store(move |store| {
            store.create_person(&np).map_err(|e| match e {
                // The store names the CLI's flags.
                StoreError::Invalid { field, problem } => {
                    ApiError::invalid(field.trim_start_matches('-').to_string(), problem)
                }
                StoreError::Advisor(a) => ApiError::invalid("start", a.to_string()),
                other => other.into(),
            })
        })
        .await?;
    Ok((
        StatusCode::CREATED,
        Json(PersonCreated {
            id: p.id as u64,
            name: p.name,
            mode: b.mode,
            tz: b.tz,
            first_day: p.first_day.map(|d| d.to_string()),
        }),
    ))
}

/// Replaces a person's clinician bounds.
#[utoipa::path(put, path = "/v1/persons/{id}/bounds", tag = "admin", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id")),
    request_body = BoundsBody,
    responses(
        (status = 200, description = "The bounds now in force", body = BoundsBody),
        (status = 400, description = "Not the JSON expected", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 403, description = "Not an admin token", body = ErrorBody),
        (status = 404, description = "No such person", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 422, description = "Bounds refused (each setting's value in force must lie inside)", body = ErrorBody)))]
pub async fn set_bounds(
    State(s): State<AppState>,
    AdminPath(id): AdminPath,
    _query: super::NoQuery,
    headers: HeaderMap,
    body: RawBody,
) -> Result<Json<BoundsBody>, ApiError> {
    let id = parse_id(&id);
    let b: BoundsBody = body::parse(&headers, body)?;
    let wire = b;
    s.person(id, true, move |store, live| {
        put_bounds(store, live, id, &wire)
    })
    .await?;
    Ok(Json(b))
}

/// Records the clinician's change of therapy (in force from `at`, default
/// now, whether or not a suggestion is open; for a person fed by the app
/// or by imports); the live advisor is rebuilt with it.
#[utoipa::path(post, path = "/v1/persons/{id}/therapy", tag = "admin", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id")),
    request_body = TherapyChangeBody,
    responses(
        (status = 200, description = "Recorded; what is in force now", body = TherapyChanged),
        (status = 400, description = "Not the JSON expected", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 403, description = "Not an admin token", body = ErrorBody),
        (status = 404, description = "No such person", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 422, description = "A value refused (limits, the clinician's bounds, a time in the future, day 1 not known)", body = ErrorBody)))]
pub async fn set_therapy(
    State(s): State<AppState>,
    AdminPath(id): AdminPath,
    _query: super::NoQuery,
    headers: HeaderMap,
    body: RawBody,
) -> Result<Json<TherapyChanged>, ApiError> {
    let id = parse_id(&id);
    let b: TherapyChangeBody = body::parse(&headers, body)?;
    let (basal, carb_ratio, at) = convert::therapy_change(&b)?;
    let out = s
        .person(id, true, move |store, live| {
            let (c, rebuilt) = store
                .set_therapy_by_id(id, basal, carb_ratio, at, "POST /v1/persons/{id}/therapy")
                .map_err(convert::therapy_change_error)?;
            *live = rebuilt;
            let settings = live.advisor.settings();
            let ratios = |cr: [f64; 3]| CarbRatios {
                breakfast: cr[0],
                lunch: cr[1],
                dinner: cr[2],
            };
            Ok(TherapyChanged {
                person_id: id as u64,
                at: c.instant.clone(),
                basal_schedule: c.basal.as_ref().map(|b| {
                    b.iter()
                        .map(|&(m, r)| BasalSegment {
                            start_minute: m,
                            units_per_hour: r,
                        })
                        .collect()
                }),
                carb_ratios: c.carb_ratio.map(ratios),
                basal_in_force: settings.basal.0,
                carb_ratios_in_force: ratios(settings.carb_ratio.map(|g| g.0)),
                notice: abba_api::NOTICE.into(),
            })
        })
        .await?;
    Ok(Json(out))
}

/// The one path of clinician bounds into the store (the endpoint and the
/// clinic's page): checked, stored, the live advisor rebuilt.
pub fn put_bounds(
    store: &mut Store,
    live: &mut Live,
    id: i64,
    b: &BoundsBody,
) -> Result<(), ApiError> {
    let bounds = convert::bounds(&b.bounds, "bounds")?;
    *live = store.set_bounds_by_id(id, bounds).map_err(|e| match e {
        StoreError::Advisor(a) => ApiError::invalid(bounds_path(&a), a.to_string()),
        other => other.into(),
    })?;
    Ok(())
}

/// The JSON path of the bounds an advisor's refusal is about (its field
/// names the setting: "clinician bounds (basal rate)", "... (lunch carb
/// ratio)"): `bounds.basal`, `bounds.lunch`, or `bounds` when it names none.
fn bounds_path(a: &abba_advisor::AdvisorError) -> String {
    let field = match a {
        abba_advisor::AdvisorError::Config { field, .. } => field.as_str(),
        _ => "",
    };
    ["basal", "breakfast", "lunch", "dinner"]
        .into_iter()
        .find(|s| field.contains(s))
        .map_or_else(|| "bounds".to_string(), |s| format!("bounds.{s}"))
}

/// Issues a person's token (shown once).
#[utoipa::path(post, path = "/v1/persons/{id}/tokens", tag = "admin", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id")),
    responses(
        (status = 201, description = "The token, shown once", body = TokenIssued),
        (status = 400, description = "A query parameter or a body (this endpoint takes neither)", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 403, description = "Not an admin token", body = ErrorBody),
        (status = 404, description = "No such person", body = ErrorBody)))]
pub async fn issue_token(
    State(s): State<AppState>,
    AdminPath(id): AdminPath,
    _query: super::NoQuery,
    _body: super::NoBody,
) -> Result<(StatusCode, Json<TokenIssued>), ApiError> {
    let id = parse_id(&id);
    let (token_id, token) = s
        .store(move |store| {
            store.person_by_id(id)?;
            Ok(auth::issue(store, Role::Person(id))?)
        })
        .await?;
    Ok((
        StatusCode::CREATED,
        Json(TokenIssued {
            token_id: token_id as u64,
            token,
            role: "person".into(),
            person_id: Some(id as u64),
        }),
    ))
}

/// Revokes a token.
#[utoipa::path(delete, path = "/v1/tokens/{token_id}", tag = "admin", security(("bearer" = [])),
    params(("token_id" = u64, Path, description = "The token's id")),
    responses(
        (status = 200, description = "Revoked", body = TokenRevoked),
        (status = 400, description = "A query parameter or a body (this endpoint takes neither)", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 403, description = "Not an admin token", body = ErrorBody),
        (status = 404, description = "No such token", body = ErrorBody),
        (status = 409, description = "The last admin token (issue another first)", body = ErrorBody)))]
pub async fn revoke_token(
    State(s): State<AppState>,
    AdminPath(token_id): AdminPath,
    _query: super::NoQuery,
    _body: super::NoBody,
) -> Result<Json<TokenRevoked>, ApiError> {
    let id = Some(crate::extract::parse_id(&token_id))
        .filter(|&v| v > 0)
        .ok_or_else(|| ApiError::not_found(format!("no token with id {token_id:?}")))?;
    s.store(move |store| Ok(store.revoke_token(id)?)).await?;
    Ok(Json(TokenRevoked {
        token_id: id as u64,
        revoked: true,
    }))
}
