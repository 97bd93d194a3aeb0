//! Today: each setting with the value in force, today's suggestion and
//! its reason, and the answers (accept, keep the previous value, my own
//! value) through the same path as `POST /v1/persons/{id}/answers`.

use super::form::{self, Form};
use super::page::{render, see_other, PageResult};
use super::session::{self, Ctx};
use crate::body::RawBody;
use crate::error::ApiError;
use crate::routes::person::answer_batch;
use crate::state::AppState;
use crate::state::EffectSource;
use abba_advisor::Parameter;
use abba_api::{AnswerBody, AnswerItem, AnswerKind};
use abba_core::units::GlucoseUnit;
use abba_store::advise::{Phase, SuggestionView, PARAMETERS};
use abba_store::answer::param_key;
use abba_store::effect::{Band, CheckOutcome, Effect, NoPrediction, SettingEffect};
use abba_store::Live;
use abba_web::pages::{Layout, SuggestionCard};
use abba_web::texts::{fill, EN};
use axum::extract::{RawQuery, State};
use axum::http::StatusCode;
use serde::Serialize;

/// One setting on Today.
#[derive(Debug, Clone, Serialize)]
pub struct SettingCard {
    /// `basal`, `breakfast`, `lunch` or `dinner` (the section is `setting-{key}`).
    pub key: &'static str,
    /// Its name.
    pub title: &'static str,
    /// The value in force with its unit.
    pub in_force: String,
    /// The latest suggestion, when there is one.
    pub suggestion: Option<abba_web::pages::SuggestionCard>,
    /// "No change today", "No suggestion yet" and the like.
    pub note: Option<String>,
    /// The basal schedule in force, segment by segment (a basal card of
    /// a pump running a schedule: `in_force` is its mean), `.schedule`.
    pub schedule: Option<String>,
}

/// Today.
#[derive(Debug, Clone, Serialize)]
pub struct Today {
    /// The first-week countdown (`#first-week`).
    pub first_week: Option<String>,
    /// What abba was not designed for (`#not-designed-for`).
    pub not_designed_for: Option<String>,
    /// An answer refused for a suggestion the page shows no form for (it
    /// was answered in another tab or replaced since the page was shown):
    /// why, above the cards (`#answer-refused`), since there is no field
    /// to show it beside.
    pub answer_refused: Option<String>,
    /// The four settings.
    pub settings: Vec<SettingCard>,
    /// What the advice says about the data and the therapy (a trip's
    /// clock, hypoglycaemia treatments, meals not seen, ...), as `abba
    /// advise` says it (`#advice-notes`).
    pub notes: Vec<String>,
}

/// A value with its unit as the pages show it: a basal rate with two
/// decimals and a carb ratio with one, or with three when the value has
/// them (a pump's 0.025 U/h step: 1.375 U/h is never shown as 1.38, a
/// rate the pump cannot be set to; `abba advise` gives three).
pub fn with_unit(p: Parameter, v: f64) -> String {
    match p {
        Parameter::Basal => format!("{} U/h", decimals(v, 2)),
        Parameter::CarbRatio(_) => format!("{} g/U", decimals(v, 1)),
    }
}

/// A signed change to one decimal: "+1.2", "-0.5", and "+0.0" for a
/// change that rounds to none (never "-0.0", which reads as a cut).
pub fn signed(v: f64) -> String {
    let r = (v * 10.0).round() / 10.0 + 0.0;
    format!("{r:+.1}")
}

/// `v` to three decimals, trailing zeros dropped down to `least`.
pub fn decimals(v: f64, least: usize) -> String {
    let text = format!("{v:.3}");
    let Some((whole, frac)) = text.split_once('.') else {
        return text;
    };
    let mut frac = frac.to_string();
    while frac.len() > least && frac.ends_with('0') {
        frac.pop();
    }
    format!("{whole}.{frac}")
}

/// The setting's name.
pub fn title(p: Parameter) -> &'static str {
    match param_key(p) {
        "basal" => EN.setting_basal,
        "breakfast" => EN.setting_breakfast,
        "lunch" => EN.setting_lunch,
        _ => EN.setting_dinner,
    }
}

/// A refused own value, shown beside its input.
#[derive(Debug, Clone)]
pub struct ValueError {
    /// The suggestion.
    pub sid: u64,
    /// What was typed.
    pub typed: String,
    /// What was wrong.
    pub message: String,
}

/// The card of one setting: the value in force and its latest decision.
/// `fallback`: the value in force when the setting has no decision yet.
pub fn card(
    live: &Live,
    p: Parameter,
    err: Option<&ValueError>,
    fallback: f64,
    effect: Option<&SettingEffect>,
) -> SettingCard {
    let views = live.views();
    let latest = live
        .decisions
        .iter()
        .zip(&views)
        .rev()
        .find(|(d, _)| d.parameter == p);
    let in_force_now = |v: &SuggestionView| {
        if v.status == "open" {
            v.previous
        } else {
            v.in_force
        }
    };
    let Some((d, v)) = latest else {
        return SettingCard {
            key: param_key(p),
            title: title(p),
            in_force: with_unit(p, fallback),
            suggestion: None,
            note: Some(EN.no_decision.to_string()),
            schedule: None,
        };
    };
    let words = super::advice_words::for_person;
    let reason = words(&if v.reasons.is_empty() {
        v.no_update_reason.clone().unwrap_or_default()
    } else {
        v.reasons.join(" ")
    });
    // Only an open suggestion is shown as one; a change under one pump
    // step and a basal rate not offered are notes.
    if v.no_update || v.status == "no_change" || v.status == "not_offered" {
        let note = if v.status == "not_offered" {
            EN.not_offered.to_string()
        } else {
            format!("{} {reason}", EN.no_change).trim().to_string()
        };
        return SettingCard {
            key: param_key(p),
            title: title(p),
            in_force: with_unit(p, in_force_now(v)),
            suggestion: None,
            note: Some(note),
            schedule: None,
        };
    }
    let setting = crate::convert::setting(p);
    let sid = setting.suggestion_id(d.at.0.max(0) as u64);
    let answered = match v.status.as_str() {
        "accepted" => Some(EN.answered_accepted),
        "rejected" => Some(EN.answered_rejected),
        "overridden" => Some(EN.answered_overridden),
        "replaced" => Some(EN.answered_replaced),
        "superseded" => Some(EN.answered_superseded),
        "unseen" => Some(EN.answered_unseen),
        _ => None,
    }
    .map(|t| fill(t, &[("value", &with_unit(p, v.in_force))]));
    let err = err.filter(|e| e.sid == sid);
    let open = v.status == "open";
    let (effect_words, check_words, held_back) = match effect.filter(|_| open) {
        Some(e) => effect_words(p, e, v.previous, live.person.settings.units),
        None => (None, None, false),
    };
    SettingCard {
        key: param_key(p),
        title: title(p),
        in_force: with_unit(p, in_force_now(v)),
        suggestion: Some(SuggestionCard {
            sid,
            label: if open {
                EN.suggested
            } else {
                EN.last_suggestion
            },
            value: with_unit(p, v.suggested),
            change: format!("{} %", signed(v.change_percent)),
            made: fill(
                EN.suggestion_made,
                &[("at", &v.decided_at), ("data", &v.data)],
            ),
            reason: v
                .reasons
                .first()
                .map_or_else(|| reason.clone(), |r| words(r)),
            details: v.reasons.iter().skip(1).map(|r| words(r)).collect(),
            open,
            answered,
            value_error: err.map(|e| e.message.clone()),
            own_value: err.map(|e| e.typed.clone()).unwrap_or_default(),
            unit: p.unit().to_string(),
            effect: effect_words,
            twin_check: check_words,
            held_back,
            schedule: v.schedule.as_ref().map(|sch| {
                fill(
                    EN.schedule_suggested,
                    &[("segments", &abba_advisor::words::schedule(sch))],
                )
            }),
        }),
        note: None,
        schedule: None,
    }
}

fn pct(b: &Band) -> String {
    format!("{:.1} % ({:.1} to {:.1})", b.value, b.low, b.high)
}

fn points(b: &Band) -> String {
    format!(
        "{} points, {} to {}",
        signed(b.value),
        signed(b.low),
        signed(b.high)
    )
}

/// An open suggestion's predicted effect and the twin check in words, and
/// whether it is held back; the target range and the low mark (70-180
/// and 70 mg/dL) in the person's unit.
pub fn effect_words(
    p: Parameter,
    e: &SettingEffect,
    in_force: f64,
    units: GlucoseUnit,
) -> (Option<String>, Option<String>, bool) {
    let margin = format!("{:.1}", e.margin_pp);
    let range = units.range(70.0, 180.0);
    let low = units.with_unit(70.0);
    match &e.effect {
        Effect::Predicted(x) => {
            let effect = fill(
                EN.effect_predicted,
                &[
                    ("revision", &x.twin_revision.to_string()),
                    ("grade", &x.grade),
                    ("days", &x.days.to_string()),
                    ("tir_new", &pct(&x.suggested.tir_pct)),
                    ("tir_now", &pct(&x.in_force.tir_pct)),
                    ("tir_change", &points(&x.change.tir_pct)),
                    ("low_new", &pct(&x.suggested.below_70_pct)),
                    ("low_now", &pct(&x.in_force.below_70_pct)),
                    ("low_change", &points(&x.change.below_70_pct)),
                    ("range", &range),
                    ("low", &low),
                ],
            );
            let check = match e.check {
                CheckOutcome::HeldBack => Some(fill(
                    EN.twin_check_held_back,
                    &[
                        ("rise", &format!("{:.1}", x.change.below_70_pct.value)),
                        ("margin", &margin),
                        ("value", &with_unit(p, in_force)),
                        ("low", &low),
                    ],
                )),
                CheckOutcome::Passed => Some(fill(
                    EN.twin_check_passed,
                    &[("margin", &margin), ("low", &low)],
                )),
                CheckOutcome::Off => Some(EN.twin_check_off.to_string()),
                CheckOutcome::NoPrediction => None,
            };
            (Some(effect), check, e.check == CheckOutcome::HeldBack)
        }
        Effect::None(why) => {
            let words = match why {
                NoPrediction::NotAvailable => EN.no_prediction_not_available.to_string(),
                NoPrediction::NoTwin => EN.no_prediction_no_twin.to_string(),
                NoPrediction::NotUsable { reason } => {
                    fill(EN.no_prediction_not_usable, &[("reason", reason)])
                }
                NoPrediction::Outdated { revision } => fill(
                    EN.no_prediction_outdated,
                    &[("revision", &revision.to_string())],
                ),
                NoPrediction::Failed { reason } => {
                    fill(EN.no_prediction_failed, &[("reason", reason)])
                }
            };
            (Some(words), None, false)
        }
    }
}

/// Today's model.
pub fn model(live: &Live, err: Option<&ValueError>, fx: Option<&EffectSource>) -> Today {
    // The advice's sentences in the person's words (no CLI flag).
    let words = super::advice_words::for_person;
    let a = live.advice_with(fx.map(EffectSource::effects));
    let total = live.person.settings.advisor.init_days;
    let first_week = match a.phase {
        Phase::NoData => Some((0, total)),
        Phase::FirstWeek {
            days_done,
            days_left,
            ..
        } => Some((days_done, days_left)),
        Phase::Adapting => None,
    }
    .map(|(done, left)| {
        fill(
            EN.first_week,
            &[
                ("done", &done.to_string()),
                ("left", &left.to_string()),
                ("total", &(done + left).to_string()),
            ],
        )
    });
    let not_designed_for = if a.delivery.basal_suggestions {
        None
    } else {
        Some(
            a.delivery
                .note
                .as_deref()
                .map_or_else(|| a.delivery.words.to_string(), words),
        )
    };
    let in_force_schedule = a.therapy.basal_schedule.as_ref().map(|sch| {
        fill(
            EN.schedule_in_force,
            &[
                ("segments", &abba_advisor::words::schedule(sch)),
                (
                    "mean",
                    &with_unit(
                        Parameter::Basal,
                        a.therapy.basal_schedule_mean.unwrap_or(f64::NAN),
                    ),
                ),
            ],
        )
    });
    let mut settings: Vec<SettingCard> = PARAMETERS
        .iter()
        .zip(&a.settings)
        .map(|(&p, sa)| card(live, p, err, sa.in_force, sa.effect.as_ref()))
        .collect();
    for c in settings.iter_mut().filter(|c| c.key == "basal") {
        c.schedule.clone_from(&in_force_schedule);
    }
    Today {
        first_week,
        not_designed_for,
        answer_refused: None,
        settings,
        notes: a.notes.iter().map(|n| words(n)).collect(),
    }
}

/// The status after an answer (`?answered=SID`, where the answer form
/// sends the person): what the store holds for that suggestion, the
/// setting and the value in force, when it holds an answer of the person
/// to it; nothing otherwise (a link made up or kept from another day says
/// nothing was saved that was not).
fn answered_status(live: &Live, q: Option<&str>) -> Option<String> {
    let sid = q?.strip_prefix("answered=")?.parse::<u64>().ok()?;
    let views = live.views();
    let (d, v) = live.decisions.iter().zip(&views).find(|(d, _)| {
        crate::convert::setting(d.parameter).suggestion_id(d.at.0.max(0) as u64) == sid
    })?;
    let text = match v.status.as_str() {
        "accepted" => EN.status_accepted,
        "rejected" => EN.status_rejected,
        "overridden" => EN.status_overridden,
        _ => return None,
    };
    Some(fill(
        text,
        &[
            ("setting", &title(d.parameter).to_lowercase()),
            ("value", &with_unit(d.parameter, v.in_force)),
        ],
    ))
}

/// `GET /`: Today.
pub async fn page(State(s): State<AppState>, ctx: Ctx, RawQuery(q): RawQuery) -> PageResult {
    let (id, w) = session::person_page(&s, &ctx).await?;
    let fx = s.effects();
    let (today, name, status) = s
        .person(id, false, move |_, live| {
            Ok((
                model(live, None, fx.as_ref()),
                live.person.name.clone(),
                answered_status(live, q.as_deref()),
            ))
        })
        .await?;
    let layout = Layout::person(EN.today_title, &w.csrf, "/")
        .signed_in_as(&name)
        .with_status(status)
        .with_submission(session::secret()?);
    render(StatusCode::OK, "today.html", &layout, &today)
}

/// What the answer form asks for, or the error beside the own value.
fn answer_item(form: &Form) -> Result<AnswerItem, (u64, String)> {
    let sid = form
        .text("suggestion_id")
        .parse::<u64>()
        .map_err(|_| (0, "suggestion_id: expected a suggestion's id".to_string()))?;
    let typed = form.text("value");
    let (answer, value) = match form.text("action") {
        "accept" | "reject" if !typed.is_empty() => {
            return Err((
                sid,
                format!(
                    "You typed your own value: press “{}” to put it in force, or clear the field.",
                    EN.override_button
                ),
            ))
        }
        "accept" => (AnswerKind::Accept, None),
        "reject" => (AnswerKind::Reject, None),
        "override" if typed.is_empty() => return Err((sid, EN.missing_field.to_string())),
        "override" => match form::number(typed) {
            Some(v) => (AnswerKind::Override, Some(v)),
            None => {
                // An example in the setting's own unit (U/h or g/U).
                let example = match abba_api::Setting::from_suggestion_id(sid).1 {
                    abba_api::Setting::Basal => "0.85",
                    _ => "10.5",
                };
                return Err((sid, fill(EN.expected_number, &[("example", example)])));
            }
        },
        other => {
            return Err((
                sid,
                format!("action: expected accept, reject or override, got {other:?}"),
            ))
        }
    };
    Ok(AnswerItem {
        suggestion_id: sid,
        answer,
        value,
    })
}

/// The page's answer to a refused answer: Today again (422, or the
/// store's status) with the error beside the own value.
fn refused_answer(
    live: &Live,
    sid: u64,
    typed: &str,
    message: String,
    fx: Option<&EffectSource>,
) -> Today {
    let err = ValueError {
        sid,
        typed: typed.to_string(),
        message,
    };
    let mut today = model(live, Some(&err), fx);
    let beside_its_field = today
        .settings
        .iter()
        .filter_map(|c| c.suggestion.as_ref())
        .any(|s| s.sid == sid && s.open);
    if !beside_its_field {
        let reason = err.message.trim_end().trim_end_matches('.');
        today.answer_refused = Some(fill(EN.answer_not_saved, &[("reason", reason)]));
    }
    today
}

/// `POST /answer`: one answer, then 303 back to Today with a status
/// message; a refused own value: Today again (422) with the error beside
/// the field. The same form sent again (its one-time key,
/// [`Form::submission`]) answers with the first result and stores nothing:
/// the key is kept after the answer's commit (the answer path has its own
/// transactions), under the person's lock; if it could not be kept, a
/// second answer to the same suggestion is still refused by the store
/// (it is no longer open), never stored twice.
pub async fn answer(State(s): State<AppState>, ctx: Ctx, body: RawBody) -> PageResult {
    if !ctx.same_origin() {
        return Err(super::page::forbidden_csrf());
    }
    let form = Form::parse(&ctx.headers, body)?;
    let (id, w) = session::person_post(&s, &ctx, &form).await?;
    form.only(&["csrf", form::SUBMISSION, "suggestion_id", "action", "value"])?;
    let key = form
        .submission("/answer")
        .ok_or_else(|| crate::error::ApiError::invalid(form::SUBMISSION, EN.submission_missing))?;
    let typed = form.text("value").to_string();
    let item = answer_item(&form);
    let fx = s.effects();
    // Today names the setting and the value the store now holds.
    let outcome = match &item {
        Ok(a) => format!("/?answered={}", a.suggestion_id),
        Err(_) => "/".to_string(),
    };
    let out = s
        .person(id, true, move |store, live| {
            if let Some(first) = store.submission(id, &key)? {
                return Ok(Ok(first));
            }
            match item {
                Err((sid, message)) => Ok(Err((
                    StatusCode::UNPROCESSABLE_ENTITY,
                    live.person.name.clone(),
                    refused_answer(live, sid, &typed, message, fx.as_ref()),
                ))),
                Ok(item) => {
                    let sid = item.suggestion_id;
                    let b = AnswerBody {
                        answers: vec![item],
                    };
                    let name = live.person.name.clone();
                    match answer_batch(store, live, &b) {
                        Ok(_) => {
                            let now = jiff::Timestamp::now().as_millisecond();
                            if let Err(e) = store.record_submission(id, &key, &outcome, now) {
                                // The answer is committed: say so all the same.
                                tracing::warn!(error = %e, "an answer's submission key not kept");
                            }
                            Ok(Ok(outcome))
                        }
                        Err(e)
                            if e.status == StatusCode::UNPROCESSABLE_ENTITY
                                || e.status == StatusCode::CONFLICT
                                || e.status == StatusCode::NOT_FOUND =>
                        {
                            let st = e.status;
                            Ok(Err((
                                st,
                                name,
                                refused_answer(live, sid, &typed, plain(&e), fx.as_ref()),
                            )))
                        }
                        Err(e) => Err(e),
                    }
                }
            }
        })
        .await?;
    match out {
        Ok(to) => Ok(see_other(&to)),
        Err((status, name, today)) => render(
            status,
            "today.html",
            &Layout::person(EN.today_title, &w.csrf, "/")
                .signed_in_as(&name)
                .with_submission(session::secret()?),
            &today,
        ),
    }
}

/// An error's message without the API's JSON path (`answers[0].value: `).
pub fn plain(e: &ApiError) -> String {
    let m = e.message.as_str();
    match m.split_once(": ") {
        Some((head, rest)) if head.starts_with("answers[") => rest.to_string(),
        _ => m.to_string(),
    }
}

/// This module's routes (merged by [`super::routes`]).
pub fn routes() -> axum::Router<crate::state::AppState> {
    use axum::routing::{get, post};
    axum::Router::new()
        .route("/", get(page))
        .route("/answer", post(answer))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn effect(check: CheckOutcome) -> SettingEffect {
        abba_store::testing::predicted_effect((70.0, 1.0), (71.0, 2.5), 0.5, check)
    }

    #[test]
    fn a_change_that_rounds_to_none_is_never_minus_zero() {
        for (v, shown) in [
            (-0.04, "+0.0"),
            (-0.0, "+0.0"),
            (0.04, "+0.0"),
            (-0.05, "-0.1"),
            (4.96, "+5.0"),
            (-5.0, "-5.0"),
        ] {
            assert_eq!(signed(v), shown, "{v}");
        }
    }

    #[test]
    fn a_value_is_shown_with_every_decimal_it_has_up_to_three() {
        let cr = Parameter::CarbRatio(abba_core::MealSlot::Lunch);
        for (p, v, shown) in [
            (Parameter::Basal, 1.375, "1.375 U/h"),
            (Parameter::Basal, 0.825, "0.825 U/h"),
            (Parameter::Basal, 1.35, "1.35 U/h"),
            (Parameter::Basal, 1.3, "1.30 U/h"),
            (Parameter::Basal, 1.0437, "1.044 U/h"),
            (cr, 22.0, "22.0 g/U"),
            (cr, 21.9, "21.9 g/U"),
            (cr, 21.949, "21.949 g/U"),
            (Parameter::Basal, f64::NAN, "NaN U/h"),
        ] {
            assert_eq!(with_unit(p, v), shown, "{v}");
        }
    }

    #[test]
    fn the_predicted_effect_names_the_range_in_the_persons_unit() {
        for check in [CheckOutcome::HeldBack, CheckOutcome::Passed] {
            let e = effect(check);
            let (words, check_words, _) =
                effect_words(Parameter::Basal, &e, 0.9, GlucoseUnit::MmolL);
            let all = format!("{} {}", words.unwrap(), check_words.unwrap());
            assert!(all.contains("time in range (3.9-10.0 mmol/L)"), "{all}");
            assert!(all.contains("time below 3.9 mmol/L"), "{all}");
            assert!(!all.contains("mg/dL"), "{all}");
            let (words, check_words, _) =
                effect_words(Parameter::Basal, &e, 0.9, GlucoseUnit::MgDl);
            let all = format!("{} {}", words.unwrap(), check_words.unwrap());
            assert!(all.contains("time in range (70-180 mg/dL)"), "{all}");
            assert!(!all.contains("mmol/L"), "{all}");
        }
    }
}
