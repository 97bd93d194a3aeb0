//! A person's endpoints: events, answers, sync, suggestions, advice,
//! history. The person's own token or an admin token.

use crate::auth::Need;
use crate::body::{self, RawBody};
use crate::convert;
use crate::error::ApiError;
use crate::routes::{person_id, query_u64, PathId};
use crate::state::AppState;
use abba_api::{
    AdviceResponse, AnswerBody, AnswerKind as WireAnswer, Answered, AnswersAck, ErrorBody,
    EventsAck, EventsBody, HistoryResponse, SeqRange, Setting, SuggestionList, SyncResponse,
};
use abba_store::answer::AnswerKind;
use abba_store::SuggestionAnswer;
use axum::extract::{RawQuery, State};
use axum::http::HeaderMap;
use axum::Json;
use std::collections::HashMap;

/// Posts a batch of device events.
#[utoipa::path(post, path = "/v1/persons/{id}/events", tag = "person", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id")),
    request_body = EventsBody,
    responses(
        (status = 200, description = "Committed: every seq of the batch is held; the suggestions the events produced", body = EventsAck),
        (status = 400, description = "Not the JSON expected", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person for this token", body = ErrorBody),
        (status = 409, description = "A seq held with another payload (nothing stored), or a person fed by imports", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 415, description = "Not application/json", body = ErrorBody),
        (status = 422, description = "A value refused (nothing stored)", body = ErrorBody)))]
pub async fn post_events(
    State(s): State<AppState>,
    id: PathId,
    headers: HeaderMap,
    body: RawBody,
) -> Result<Json<EventsAck>, ApiError> {
    let id = person_id(id);
    s.authorize(&headers, Need::Person(id)).await?;
    let b: EventsBody = body::parse(&headers, body)?;
    let mut acked: Vec<u64> = b.events.iter().map(|e| e.seq).collect();
    acked.sort_unstable();
    s.core(move |core| {
        let limits = core.live(id)?.person.settings.advisor.limits.clone();
        let batch = convert::check_events(&b, &limits)?;
        let ack = core.with_live(id, |store, live| {
            let posted = store.post_events(live, &batch)?;
            let seqs: HashMap<(i64, &'static str), Option<u64>> = posted
                .produced
                .iter()
                .map(|p| {
                    (
                        (
                            p.decision.at.0,
                            abba_store::answer::param_key(p.decision.parameter),
                        ),
                        p.seq,
                    )
                })
                .collect();
            let key =
                |d: &abba_advisor::Decision| (d.at.0, abba_store::answer::param_key(d.parameter));
            let answers = if seqs.is_empty() {
                Vec::new()
            } else {
                convert::suggestions(live, |d| seqs.contains_key(&key(d)), &mut |d| {
                    Ok(seqs.get(&key(d)).copied().flatten())
                })?
            };
            Ok(EventsAck {
                acked,
                stored: posted.stored.len() as u64,
                repeated: posted.repeated,
                answers,
            })
        })?;
        Ok(ack)
    })
    .await
    .map(Json)
}

/// Answers suggestions.
#[utoipa::path(post, path = "/v1/persons/{id}/answers", tag = "person", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id")),
    request_body = AnswerBody,
    responses(
        (status = 200, description = "Committed", body = AnswersAck),
        (status = 400, description = "Not the JSON expected", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person or suggestion", body = ErrorBody),
        (status = 409, description = "The suggestion is not open", body = ErrorBody),
        (status = 413, description = "Body too large", body = ErrorBody),
        (status = 415, description = "Not application/json", body = ErrorBody),
        (status = 422, description = "A value refused", body = ErrorBody)))]
pub async fn post_answers(
    State(s): State<AppState>,
    id: PathId,
    headers: HeaderMap,
    body: RawBody,
) -> Result<Json<AnswersAck>, ApiError> {
    let id = person_id(id);
    s.authorize(&headers, Need::Person(id)).await?;
    let b: AnswerBody = body::parse(&headers, body)?;
    if b.answers.is_empty() || b.answers.len() > 4 {
        return Err(ApiError::invalid(
            "answers",
            format!("expected 1 to 4 answers, got {}", b.answers.len()),
        ));
    }
    let items: Vec<SuggestionAnswer> = b
        .answers
        .iter()
        .map(|a| {
            let (minute, setting) = Setting::from_suggestion_id(a.suggestion_id);
            SuggestionAnswer {
                at_min: i64::try_from(minute).unwrap_or(i64::MAX),
                parameter: convert::parameter(setting),
                kind: match a.answer {
                    WireAnswer::Accept => AnswerKind::Accepted,
                    WireAnswer::Reject => AnswerKind::Rejected,
                    WireAnswer::Override => AnswerKind::Overridden,
                },
                value: a.value,
            }
        })
        .collect();
    s.core(move |core| {
        Ok(core.with_live(id, |store, live| {
            let (stored, changed) = store.answer_suggestions(live, &items)?;
            let answered = stored
                .iter()
                .zip(&b.answers)
                .map(|(a, w)| Answered {
                    suggestion_id: w.suggestion_id,
                    parameter: convert::setting(a.parameter),
                    answer: w.answer,
                    in_force: a.in_force,
                })
                .collect();
            let keys: Vec<_> = changed.iter().map(|d| (d.at, d.parameter)).collect();
            let changed =
                convert::suggestions(live, |d| keys.contains(&(d.at, d.parameter)), &mut |d| {
                    store.producer(id, d)
                })?;
            Ok(AnswersAck { answered, changed })
        })?)
    })
    .await
    .map(Json)
}

/// Which sequence numbers the service holds.
#[utoipa::path(get, path = "/v1/persons/{id}/sync", tag = "person", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id"),
        ("from" = Option<u64>, Query, description = "Lowest seq of interest (default 0)")),
    responses(
        (status = 200, description = "Held ranges", body = SyncResponse),
        (status = 400, description = "Bad query", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person for this token", body = ErrorBody)))]
pub async fn sync(
    State(s): State<AppState>,
    id: PathId,
    RawQuery(q): RawQuery,
    headers: HeaderMap,
) -> Result<Json<SyncResponse>, ApiError> {
    let id = person_id(id);
    s.authorize(&headers, Need::Person(id)).await?;
    let from = query_u64(q.as_deref(), &["from"])?
        .first()
        .map_or(0, |x| x.1);
    s.core(move |core| {
        let (held, truncated) = core.store.held_ranges(id, from, SyncResponse::MAX_RANGES)?;
        let last_seq = core.store.last_seq(id)?;
        let last_suggestion_id = core.live(id)?.decisions.last().map(convert::suggestion_id);
        Ok(SyncResponse {
            from,
            held: held
                .into_iter()
                .map(|(first, last)| SeqRange { first, last })
                .collect(),
            truncated,
            last_seq,
            last_suggestion_id,
        })
    })
    .await
    .map(Json)
}

/// Suggestions the app has not seen.
#[utoipa::path(get, path = "/v1/persons/{id}/suggestions", tag = "person", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id"),
        ("after" = Option<u64>, Query, description = "Only suggestions with a greater id (default: all)")),
    responses(
        (status = 200, description = "Suggestions, oldest first", body = SuggestionList),
        (status = 400, description = "Bad query", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person for this token", body = ErrorBody)))]
pub async fn suggestions(
    State(s): State<AppState>,
    id: PathId,
    RawQuery(q): RawQuery,
    headers: HeaderMap,
) -> Result<Json<SuggestionList>, ApiError> {
    let id = person_id(id);
    s.authorize(&headers, Need::Person(id)).await?;
    let after = query_u64(q.as_deref(), &["after"])?.first().map(|x| x.1);
    s.core(move |core| {
        Ok(core.with_live(id, |store, live| {
            let list = convert::suggestions(
                live,
                |d| after.is_none_or(|a| convert::suggestion_id(d) > a),
                &mut |d| store.producer(id, d),
            )?;
            Ok(SuggestionList {
                notice: abba_api::NOTICE.into(),
                suggestions: list,
            })
        })?)
    })
    .await
    .map(Json)
}

/// Today's advice (what `abba advise` shows).
#[utoipa::path(get, path = "/v1/persons/{id}/advice", tag = "person", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id")),
    responses(
        (status = 200, description = "The advice", body = AdviceResponse),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person for this token", body = ErrorBody)))]
pub async fn advice(
    State(s): State<AppState>,
    id: PathId,
    headers: HeaderMap,
) -> Result<Json<AdviceResponse>, ApiError> {
    let id = person_id(id);
    s.authorize(&headers, Need::Person(id)).await?;
    s.core(move |core| {
        Ok(core.with_live(id, |store, live| {
            let a = abba_store::advise::advice(
                &live.person,
                &live.stream,
                live.records,
                &live.advisor,
                &live.decisions,
                &live.answers,
                live.refused,
            );
            convert::advice(live, a, &mut |d| store.producer(id, d))
        })?)
    })
    .await
    .map(Json)
}

/// Every suggestion with its answer.
#[utoipa::path(get, path = "/v1/persons/{id}/history", tag = "person", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id")),
    responses(
        (status = 200, description = "The history", body = HistoryResponse),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person for this token", body = ErrorBody)))]
pub async fn history(
    State(s): State<AppState>,
    id: PathId,
    headers: HeaderMap,
) -> Result<Json<HistoryResponse>, ApiError> {
    let id = person_id(id);
    s.authorize(&headers, Need::Person(id)).await?;
    s.core(move |core| {
        Ok(core.with_live(id, |store, live| {
            Ok(HistoryResponse {
                notice: abba_api::NOTICE.into(),
                person_id: id as u64,
                suggestions: convert::suggestions(live, |_| true, &mut |d| store.producer(id, d))?,
            })
        })?)
    })
    .await
    .map(Json)
}
