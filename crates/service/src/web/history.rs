//! History: every suggestion, the answer and the value in force, by day
//! (newest first), and the person's report one tap away (`/report`, the
//! AGP-style report of `abba report --person`, printable).
//!
//! The clinic opens the same report at `/clinic/persons/{id}/report`.

use super::page::{html, message, render, PageError, PageResult, PathText};
use super::session::{self, Ctx};
use crate::error::ApiError;
use crate::state::{AppState, EffectSource};
use abba_report::html::person::{person_report_html, BackLink};
use abba_store::advise::SuggestionView;
use abba_store::Live;
use abba_web::pages::Layout;
use abba_web::texts::{fill, EN};
use axum::extract::State;
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::Response;
use serde::Serialize;
use sha2::{Digest, Sha256};

/// One row of the History table.
#[derive(Debug, Clone, Serialize)]
pub struct HistoryRow {
    /// The local date of the day it is for.
    pub day: String,
    /// The setting's name.
    pub setting: String,
    /// Local date and time of the decision.
    pub decided: String,
    /// The value before, with its unit.
    pub from: String,
    /// The suggestion with its change (or "no change").
    pub suggested: String,
    /// The answer in words.
    pub answer: String,
    /// The value in force after it, with its unit.
    pub in_force: String,
    /// The reason in plain words.
    pub reason: String,
    /// An answer given when the suggestion said something else (data
    /// imported after it changed the suggestion), in words.
    pub answer_note: Option<String>,
}

/// The History page.
#[derive(Debug, Clone, Serialize)]
pub struct History {
    /// Every decision, newest first.
    pub rows: Vec<HistoryRow>,
}

/// Days of the report (as `abba report`'s default).
pub const REPORT_DAYS: u32 = 14;

fn setting_name(key: &str) -> &'static str {
    match key {
        "basal" => EN.setting_basal,
        "breakfast" => EN.setting_breakfast,
        "lunch" => EN.setting_lunch,
        _ => EN.setting_dinner,
    }
}

/// A setting's value as Today shows it (`today::with_unit`): every decimal
/// it has up to three (1.375 U/h, a pump's 0.025 U/h step, is never 1.38,
/// a rate the pump cannot be set to), at least two for a basal rate and
/// one for a carb ratio.
fn value(v: f64, unit: &str) -> String {
    let least = if unit == "U/h" { 2 } else { 1 };
    format!("{} {unit}", super::today::decimals(v, least))
}

fn answer(v: &SuggestionView) -> &'static str {
    match v.status.as_str() {
        "open" => EN.status_open,
        "accepted" => EN.status_accepted_word,
        "rejected" => EN.status_rejected_word,
        "overridden" => EN.status_overridden_word,
        "superseded" => EN.status_superseded_word,
        "unseen" => EN.status_unseen_word,
        _ => EN.status_no_update_word,
    }
}

/// The History's model: every decision, newest first.
pub fn model(live: &Live) -> History {
    let views = live.views();
    let first_day = live.person.first_day;
    let rows = views
        .iter()
        .rev()
        .map(|v| {
            let day = first_day
                .and_then(|d| d.checked_add(jiff::Span::new().days(v.day - 1)).ok())
                .map_or_else(|| format!("day {}", v.day), |d| d.to_string());
            let reason = super::advice_words::for_person(&if v.reasons.is_empty() {
                v.no_update_reason.clone().unwrap_or_default()
            } else {
                v.reasons.join(" ")
            });
            HistoryRow {
                day,
                setting: setting_name(v.setting).to_string(),
                decided: v.decided_at.clone(),
                from: value(v.previous, v.unit),
                suggested: if v.no_update {
                    EN.status_no_update_word.to_string()
                } else {
                    format!(
                        "{} ({} %)",
                        value(v.suggested, v.unit),
                        super::today::signed(v.change_percent)
                    )
                },
                answer: answer(v).to_string(),
                in_force: value(v.in_force, v.unit),
                reason,
                answer_note: v.answer_note.clone(),
            }
        })
        .collect();
    History { rows }
}

/// `GET /history`.
pub async fn page(State(s): State<AppState>, ctx: Ctx) -> PageResult {
    let (id, w) = session::person_page(&s, &ctx).await?;
    let (h, name) = s
        .person(id, false, |_, live| {
            Ok((model(live), live.person.name.clone()))
        })
        .await?;
    let layout = Layout::person(EN.history_title, &w.csrf, "/history").signed_in_as(&name);
    render(StatusCode::OK, "history.html", &layout, &h)
}

/// Each open suggestion's predicted effect and the twin check, as notes
/// of the report (the pages' words).
fn effect_notes(live: &Live, fx: Option<&EffectSource>, notes: &mut Vec<String>) {
    let a = live.advice_with(fx.map(EffectSource::effects));
    for (&p, sa) in abba_store::advise::PARAMETERS.iter().zip(&a.settings) {
        let (Some(e), Some(v)) = (&sa.effect, &sa.latest) else {
            continue;
        };
        let (effect, check, _) =
            super::today::effect_words(p, e, sa.in_force, live.person.settings.units);
        let head = fill(
            EN.report_open_suggestion,
            &[
                ("setting", super::today::title(p)),
                ("from", &super::today::with_unit(p, v.previous)),
                ("to", &super::today::with_unit(p, v.suggested)),
            ],
        );
        let words: Vec<String> = [Some(head), effect, check].into_iter().flatten().collect();
        notes.push(words.join(" "));
    }
}

/// The report of person `id` as a page: the report's own HTML (one
/// self-contained document with its inline stylesheet), served with a CSP
/// that allows exactly that stylesheet (by its hash) and nothing else.
/// Its notes and reasons are the advice's sentences, worded by `words`
/// for its reader (`advice_words`: the person's report names no flag of
/// `abba person new`, the clinic's names the command).
async fn report(
    s: &AppState,
    id: i64,
    csrf: Option<String>,
    back: BackLink,
    words: fn(&str) -> String,
) -> PageResult {
    let fx = s.effects();
    let out = s
        .person(id, false, move |store, live| {
            let name = live.person.name.clone();
            let unit = live.person.settings.units;
            match abba_store::report::person_input(store, &name, REPORT_DAYS, unit) {
                Ok(mut input) => {
                    effect_notes(live, fx.as_ref(), &mut input.notes);
                    for note in &mut input.notes {
                        *note = words(note);
                    }
                    for line in &mut input.suggestions {
                        line.reason = words(&line.reason);
                    }
                    input.back = Some(back);
                    person_report_html(&input)
                        .map(Some)
                        .map_err(ApiError::internal)
                }
                Err(abba_store::StoreError::NoData(_)) => Ok(None),
                Err(e) => Err(e.into()),
            }
        })
        .await?;
    let Some(doc) = out else {
        return Ok(message(
            StatusCode::OK,
            EN.history_title,
            EN.report_no_data,
            csrf,
        ));
    };
    let mut r = html(StatusCode::OK, doc.clone());
    let csp = report_csp(&doc);
    let v = HeaderValue::from_str(&csp).map_err(|e| PageError::from(ApiError::internal(e)))?;
    r.headers_mut().insert(header::CONTENT_SECURITY_POLICY, v);
    Ok(r)
}

/// The report's CSP: its inline `<style>` by hash, images only inline.
pub fn report_csp(doc: &str) -> String {
    use base64::Engine as _;
    let mut styles = String::new();
    let mut rest = doc;
    while let Some(i) = rest.find("<style>") {
        let body = &rest[i + "<style>".len()..];
        let Some(j) = body.find("</style>") else {
            break;
        };
        let digest = Sha256::digest(&body.as_bytes()[..j]);
        styles.push_str(&format!(
            " 'sha256-{}'",
            base64::engine::general_purpose::STANDARD.encode(digest)
        ));
        rest = &body[j..];
    }
    format!("default-src 'none'; style-src{styles}; img-src data:; form-action 'none'; frame-ancestors 'none'; base-uri 'none'")
}

/// `GET /report`: the person's own report.
pub async fn person_report(State(s): State<AppState>, ctx: Ctx) -> Result<Response, PageError> {
    let (id, w) = session::person_page(&s, &ctx).await?;
    let back = BackLink {
        href: "/".into(),
        label: "Back to Today".into(),
    };
    report(&s, id, Some(w.csrf), back, super::advice_words::for_person).await
}

/// `GET /clinic/persons/{id}/report`: a person's report for the clinic.
pub async fn clinic_report(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
) -> Result<Response, PageError> {
    let w = session::admin_page(&s, &ctx).await?;
    let id = crate::extract::parse_id(&id);
    if id < 0 {
        return Err(super::page::not_found());
    }
    let back = BackLink {
        href: format!("/clinic/persons/{id}"),
        label: "Back to the person's page".into(),
    };
    report(&s, id, Some(w.csrf), back, super::advice_words::for_clinic).await
}

/// This module's routes (merged by [`super::routes`]).
pub fn routes() -> axum::Router<crate::state::AppState> {
    use axum::routing::get;
    axum::Router::new()
        .route("/history", get(page))
        .route("/report", get(person_report))
        .route("/clinic/persons/{id}/report", get(clinic_report))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_is_shown_as_today_shows_it() {
        for (v, unit, shown) in [
            (1.375, "U/h", "1.375 U/h"),
            (1.3, "U/h", "1.30 U/h"),
            (10.128, "g/U", "10.128 g/U"),
            (12.0, "g/U", "12.0 g/U"),
        ] {
            assert_eq!(value(v, unit), shown, "{v}");
        }
    }

    #[test]
    fn the_reports_csp_allows_its_own_stylesheet_by_hash_and_nothing_else() {
        let doc = "<html><head><style>\nbody { color: red; }\n</style></head></html>";
        // sha256 of "\nbody { color: red; }\n" in base64 (Python's hashlib).
        assert_eq!(
            report_csp(doc),
            "default-src 'none'; style-src 'sha256-6BtAJHRccEFconKgYZxx3ALoONCc3uWtAQ7oTAu9LLs='; img-src data:; form-action 'none'; frame-ancestors 'none'; base-uri 'none'"
        );
    }
}
