//! A person's endpoints: events, answers, sync, suggestions, advice,
//! history. The person's own token or an admin token.

use crate::body::{self, RawBody};
use crate::convert;
use crate::error::ApiError;
use crate::extract::PersonId;
use crate::routes::{page, query_u64};
use crate::state::AppState;
use abba_api::{
    AdviceResponse, AnswerBody, AnswerKind as WireAnswer, Answered, AnswersAck, ErrorBody,
    EventsAck, EventsBody, HistoryResponse, SeqRange, Setting, SuggestionList, SyncResponse,
};
use abba_store::answer::AnswerKind;
use abba_store::{Live, Store, SuggestionAnswer};
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
    PersonId(id): PersonId,
    _query: super::NoQuery,
    headers: HeaderMap,
    body: RawBody,
) -> Result<Json<EventsAck>, ApiError> {
    let b: EventsBody = body::parse(&headers, body)?;
    s.person(id, true, move |store, live| {
        post_batch(store, live, &b, Numbering::App)
    })
    .await
    .map(Json)
}

/// Who numbers a batch's events.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Numbering {
    /// The app's own `seq`s (the `/v1` endpoint).
    App,
    /// The person's next free numbers, assigned in the insert's
    /// transaction (the web pages' Log: the `seq`s given are placeholders),
    /// with the form's submission key: a form sent again stores nothing
    /// and is acknowledged with the first submission's seqs.
    Next(Option<abba_store::submission::SubmissionKey>),
}

/// The one path of device events into the store, for the `/v1` endpoint
/// and the pages: checks the batch, stores it in one transaction,
/// advances the live advisor and answers with every suggestion its
/// events produced.
pub fn post_batch(
    store: &mut Store,
    live: &mut Live,
    b: &EventsBody,
    numbering: Numbering,
) -> Result<EventsAck, ApiError> {
    let limits = live.person.settings.advisor.limits.clone();
    let batch = convert::check_events(b, &limits, jiff::Timestamp::now())?;
    let posted = match numbering {
        Numbering::App => store.post_events(live, &batch)?,
        Numbering::Next(once) => store.post_events_next_seq(live, &batch, once.as_ref())?,
    };
    let mut acked: Vec<u64> = match numbering {
        Numbering::App => b.events.iter().map(|e| e.seq).collect(),
        Numbering::Next(_) => posted
            .stored
            .iter()
            .map(|e| e.seq)
            .chain(posted.repeated.iter().copied())
            .collect(),
    };
    acked.sort_unstable();
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
    let key = |d: &abba_advisor::Decision| (d.at.0, abba_store::answer::param_key(d.parameter));
    let answers = if seqs.is_empty() {
        Vec::new()
    } else {
        convert::suggestions(live, |d| seqs.contains_key(&key(d)), &mut |d| {
            Ok(seqs.get(&key(d)).copied().flatten())
        })?
    };
    Ok(EventsAck {
        notice: abba_api::NOTICE.into(),
        acked,
        stored: posted.stored.len() as u64,
        repeated: posted.repeated,
        answers,
    })
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
    PersonId(id): PersonId,
    _query: super::NoQuery,
    headers: HeaderMap,
    body: RawBody,
) -> Result<Json<AnswersAck>, ApiError> {
    let b: AnswerBody = body::parse(&headers, body)?;
    s.person(id, true, move |store, live| answer_batch(store, live, &b))
        .await
        .map(Json)
}

/// The one path of answers into the store, for the `/v1` endpoint and the
/// pages (one transaction; the live advisor follows).
pub fn answer_batch(
    store: &mut Store,
    live: &mut Live,
    b: &AnswerBody,
) -> Result<AnswersAck, ApiError> {
    if b.answers.is_empty() || b.answers.len() > 4 {
        return Err(ApiError::invalid(
            "answers",
            format!("expected 1 to 4 answers, got {}", b.answers.len()),
        ));
    }
    let id = live.person.id;
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
    let changed = convert::suggestions(live, |d| keys.contains(&(d.at, d.parameter)), &mut |d| {
        store.producer(id, d)
    })?;
    Ok(AnswersAck {
        notice: abba_api::NOTICE.into(),
        answered,
        changed,
    })
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
    PersonId(id): PersonId,
    RawQuery(q): RawQuery,
) -> Result<Json<SyncResponse>, ApiError> {
    let from = query_u64(q.as_deref(), &["from"])?
        .first()
        .map_or(0, |x| x.1);
    // The store's tables answer: no live advisor needed, none made.
    s.store(move |store| {
        let (held, truncated) = store.held_ranges(id, from, SyncResponse::MAX_RANGES)?;
        let last_seq = store.last_seq(id)?;
        let last_suggestion_id = store.latest_suggestion_id(id)?;
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
        ("after" = Option<u64>, Query, description = "Only suggestions with a greater id (default: from the first)"),
        ("limit" = Option<u64>, Query, description = "At most this many (1 to 1000, default 200); `next_after` says where the next page starts")),
    responses(
        (status = 200, description = "Suggestions, oldest first", body = SuggestionList),
        (status = 400, description = "Bad query", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person for this token", body = ErrorBody)))]
pub async fn suggestions(
    State(s): State<AppState>,
    PersonId(id): PersonId,
    RawQuery(q): RawQuery,
) -> Result<Json<SuggestionList>, ApiError> {
    let (after, limit) = page(q.as_deref())?;
    s.person(id, false, move |store, live| {
        let (list, next_after) = convert::page(live, after, limit, &mut |d| store.producer(id, d))?;
        Ok(SuggestionList {
            notice: abba_api::NOTICE.into(),
            suggestions: list,
            next_after,
        })
    })
    .await
    .map(Json)
}

/// Today's advice (what `abba advise` shows).
#[utoipa::path(get, path = "/v1/persons/{id}/advice", tag = "person", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id")),
    responses(
        (status = 200, description = "The advice", body = AdviceResponse),
        (status = 400, description = "A query parameter (this endpoint takes none)", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person for this token", body = ErrorBody)))]
pub async fn advice(
    State(s): State<AppState>,
    PersonId(id): PersonId,
    _query: super::NoQuery,
) -> Result<Json<AdviceResponse>, ApiError> {
    let effects = s.effects();
    s.person(id, false, move |store, live| {
        let a = live.advice_with(effects.as_ref().map(|e| e.effects()));
        let mut r = convert::advice(live, a, &mut |d| store.producer(id, d))?;
        // The Nightscout link's last sync (issue 25).
        r.nightscout = store
            .link(&live.person.name)?
            .map(|l| abba_api::NightscoutLink {
                url: l.url,
                last_sync_at: l.last_sync_at,
                last_success_at: l.last_success_at,
                last_error: l.last_error,
                failures: l.failures,
                warnings: l.warnings,
            });
        Ok(r)
    })
    .await
    .map(Json)
}

/// Every suggestion with its answer.
#[utoipa::path(get, path = "/v1/persons/{id}/history", tag = "person", security(("bearer" = [])),
    params(("id" = u64, Path, description = "The person's id"),
        ("after" = Option<u64>, Query, description = "Only suggestions with a greater id (default: from the first)"),
        ("limit" = Option<u64>, Query, description = "At most this many (1 to 1000, default 200); `next_after` says where the next page starts")),
    responses(
        (status = 200, description = "The history", body = HistoryResponse),
        (status = 400, description = "Bad query", body = ErrorBody),
        (status = 401, description = "No valid token", body = ErrorBody),
        (status = 404, description = "No such person for this token", body = ErrorBody)))]
pub async fn history(
    State(s): State<AppState>,
    PersonId(id): PersonId,
    RawQuery(q): RawQuery,
) -> Result<Json<HistoryResponse>, ApiError> {
    let (after, limit) = page(q.as_deref())?;
    s.person(id, false, move |store, live| {
        let (suggestions, next_after) =
            convert::page(live, after, limit, &mut |d| store.producer(id, d))?;
        Ok(HistoryResponse {
            notice: abba_api::NOTICE.into(),
            person_id: id as u64,
            suggestions,
            next_after,
        })
    })
    .await
    .map(Json)
}
