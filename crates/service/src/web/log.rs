//! The Log: a meter reading (a bedtime one closes the day) and a meal
//! with its carbohydrate, for persons without a connected app. Each goes
//! through [`post_batch`], the path of `POST /v1/persons/{id}/events`,
//! numbered with the person's next free seqs in the insert's transaction.
//! A person fed by imports gets no form (the store refuses mixing).
//!
//! Each form carries a one-time key ([`Form::submission`]): the same form
//! sent twice (a double click, a retry after a timeout) stores nothing
//! the second time and answers with the first result. The bedtime box is
//! for finger sticks (SMBG) only: a CGM person's day closes at the first
//! event after local midnight, by their app.

use super::form::{self, Form};
use super::page::{render, see_other, PageResult};
use super::session::{self, Ctx};
use super::today::{card, with_unit};
use crate::body::RawBody;
use crate::error::ApiError;
use crate::routes::person::{post_batch, Numbering};
use crate::state::{AppState, EffectSource};
use abba_advisor::{Mode, Parameter};
use abba_api::{DeviceEvent, EventBody, EventsBody, MealSlot as WireSlot};
use abba_core::units::GlucoseUnit;
use abba_core::{EventKind, MealSlot};
use abba_store::advise::PARAMETERS;
use abba_store::submission::SubmissionKey;
use abba_store::{Live, Store};
use abba_web::pages::{Choice, Layout};
use abba_web::texts::{fill, EN};
use axum::extract::{RawQuery, State};
use axum::http::StatusCode;
use serde::Serialize;

/// The log.
#[derive(Debug, Clone, Serialize)]
pub struct Log {
    /// An import-fed person: no forms, this says why.
    pub import_fed: Option<String>,
    /// The glucose label with the person's unit.
    pub glucose_label: String,
    /// The glucose field's `step`.
    pub glucose_step: &'static str,
    /// The bedtime box (it closes the day): SMBG mode only.
    pub bedtime: bool,
    /// The meal slots, the default one selected.
    pub slots: Vec<Choice>,
    /// Values typed, kept after an error (glucose, carbs).
    pub glucose: String,
    /// Carbohydrate typed.
    pub carbs: String,
    /// The glucose field's error, beside it.
    pub glucose_error: Option<String>,
    /// The carbohydrate field's error, beside it.
    pub carbs_error: Option<String>,
    /// After a main meal: the ratio, the bolus and the suggestion to answer.
    pub meal_advice: Option<MealAdvice>,
    /// After a bedtime reading: tomorrow's basal.
    pub tomorrow_basal: Option<String>,
    /// The status message (moved into the layout's `#status`).
    pub status: Option<String>,
    /// The person's name (moved into the layout).
    pub name: String,
}

/// The answer to a main meal.
#[derive(Debug, Clone, Serialize)]
pub struct MealAdvice {
    /// The ratio to use, in words.
    pub ratio: String,
    /// The bolus it implies, in words.
    pub bolus: String,
    /// The open suggestion, if any (the same form as on Today).
    pub suggestion: Option<abba_web::pages::SuggestionCard>,
}

/// The bolus step of the pump (U): abba's pump steps have none for
/// boluses, so the common 0.05 U.
pub const BOLUS_STEP: f64 = 0.05;

const SLOTS: [(&str, MealSlot); 4] = [
    ("breakfast", MealSlot::Breakfast),
    ("lunch", MealSlot::Lunch),
    ("dinner", MealSlot::Dinner),
    ("snack", MealSlot::Snack),
];

fn slot_label(s: MealSlot) -> &'static str {
    match s {
        MealSlot::Breakfast => EN.slot_breakfast,
        MealSlot::Lunch => EN.slot_lunch,
        MealSlot::Dinner => EN.slot_dinner,
        _ => EN.slot_snack,
    }
}

/// The meal of the local time now by the person's meal windows (a snack
/// outside them).
fn default_slot(live: &Live) -> MealSlot {
    let local = live.person.tz.to_datetime(jiff::Timestamp::now());
    let m = u32::from(local.hour() as u8) * 60 + u32::from(local.minute() as u8);
    let w = live.person.settings.meal_windows;
    let inside = |(a, b): (u32, u32)| a <= m && m < b;
    if inside(w.breakfast) {
        MealSlot::Breakfast
    } else if inside(w.lunch) {
        MealSlot::Lunch
    } else if inside(w.dinner) {
        MealSlot::Dinner
    } else {
        MealSlot::Snack
    }
}

fn fed_by_imports(store: &Store, id: i64) -> Result<bool, ApiError> {
    Ok(!store.imports_of(id)?.is_empty())
}

/// What the page shows after a POST (from the query).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum After {
    Nothing,
    Reading,
    DayClosed,
    Meal(u64),
    Snack,
}

fn after(q: Option<&str>) -> After {
    let Some(q) = q else { return After::Nothing };
    match q.split_once('=') {
        Some(("saved", "reading")) => After::Reading,
        Some(("saved", "snack")) => After::Snack,
        Some(("closed", "1")) => After::DayClosed,
        Some(("meal", n)) => n.parse().map_or(After::Nothing, After::Meal),
        _ => After::Nothing,
    }
}

/// Rounds to the pump's bolus step.
pub fn round_bolus(units: f64) -> f64 {
    (units / BOLUS_STEP).round() * BOLUS_STEP
}

/// The log's model; `typed` and errors after a refused entry.
fn model(
    store: &Store,
    live: &Live,
    show: After,
    typed: Typed,
    fx: Option<&EffectSource>,
) -> Result<Log, ApiError> {
    let id = live.person.id;
    let (glucose_label, glucose_step) = match live.person.settings.units {
        GlucoseUnit::MgDl => (fill(EN.glucose_label, &[("unit", "mg/dL")]), "1"),
        GlucoseUnit::MmolL => (fill(EN.glucose_label, &[("unit", "mmol/L")]), "0.1"),
    };
    let import_fed = fed_by_imports(store, id)?.then(|| EN.log_import_fed.to_string());
    let slot = typed.slot.unwrap_or_else(|| default_slot(live));
    let a = live.advice_with(fx.map(EffectSource::effects));
    let setting = |p: Parameter| {
        PARAMETERS.iter().position(|&q| q == p).map(|i| {
            (
                a.settings[i].use_today,
                a.settings[i].in_force,
                a.settings[i].effect.clone(),
            )
        })
    };
    let mut meal_advice = None;
    let mut tomorrow_basal = None;
    let mut status = None;
    match show {
        After::Meal(seq) => {
            if let Some(EventKind::MealAnnounced { carbs, slot }) =
                store.app_event(id, seq)?.map(|e| e.event.kind)
            {
                let p = Parameter::CarbRatio(slot);
                if let Some((ratio, in_force, effect)) = setting(p) {
                    let bolus = round_bolus(carbs.0 / ratio);
                    let c = card(live, p, None, in_force, effect.as_ref());
                    meal_advice = Some(MealAdvice {
                        ratio: fill(EN.meal_ratio, &[("ratio", &with_unit(p, ratio))]),
                        bolus: fill(
                            EN.meal_bolus,
                            &[
                                // As typed: 45.5 g stays 45.5, not 46.
                                ("carbs", &format!("{}", (carbs.0 * 10.0).round() / 10.0)),
                                ("ratio", &with_unit(p, ratio)),
                                ("bolus", &format!("{bolus:.2}")),
                                ("step", &format!("{BOLUS_STEP}")),
                            ],
                        ),
                        suggestion: c.suggestion.filter(|s| s.open),
                    });
                    status = Some(EN.status_meal.to_string());
                }
            }
        }
        After::DayClosed => {
            if let Some((basal, _, _)) = setting(Parameter::Basal) {
                tomorrow_basal = Some(fill(
                    EN.tomorrow_basal,
                    &[("value", &with_unit(Parameter::Basal, basal))],
                ));
            }
            status = Some(EN.status_day_closed.to_string());
        }
        After::Reading => status = Some(EN.status_reading.to_string()),
        After::Snack => status = Some(EN.status_snack.to_string()),
        After::Nothing => {}
    }
    Ok(Log {
        import_fed,
        bedtime: live.person.mode() == Mode::Smbg,
        glucose_label,
        glucose_step,
        slots: SLOTS
            .iter()
            .map(|&(value, s)| Choice {
                value,
                label: slot_label(s),
                selected: s == slot,
            })
            .collect(),
        glucose: typed.glucose,
        carbs: typed.carbs,
        glucose_error: typed.glucose_error,
        carbs_error: typed.carbs_error,
        meal_advice,
        tomorrow_basal,
        status,
        name: live.person.name.clone(),
    })
}

/// What was typed into a refused form, and the errors.
#[derive(Debug, Clone, Default)]
struct Typed {
    glucose: String,
    carbs: String,
    slot: Option<MealSlot>,
    glucose_error: Option<String>,
    carbs_error: Option<String>,
}

/// `GET /log`.
pub async fn page(State(s): State<AppState>, ctx: Ctx, RawQuery(q): RawQuery) -> PageResult {
    let (id, w) = session::person_page(&s, &ctx).await?;
    let show = after(q.as_deref());
    let fx = s.effects();
    let log = s
        .person(id, false, move |store, live| {
            model(store, live, show, Typed::default(), fx.as_ref())
        })
        .await?;
    show_log(StatusCode::OK, &w.csrf, log)
}

/// The Log, its forms with a new one-time key.
fn show_log(status: StatusCode, csrf: &str, mut log: Log) -> PageResult {
    let layout = Layout::person(EN.log_title, csrf, "/log")
        .signed_in_as(&log.name)
        .with_status(log.status.take())
        .with_submission(session::secret()?);
    render(status, "log.html", &layout, &log)
}

/// The message of a refused value without the event's placeholder seq
/// (`mg_dl must be ...`).
fn value_message(e: &ApiError) -> String {
    let m = e.message.as_str();
    match m.find(" must be ") {
        Some(i) => {
            let start = m[..i].rfind(": ").map_or(0, |j| j + 2);
            m[start..].to_string()
        }
        None => m.to_string(),
    }
}

/// Posts `events` (placeholder seqs) through the one event path, once for
/// the form's submission key `once` (a second time: the first seqs, nothing
/// stored); a value refused by its checks comes back as the field's error.
async fn enter(
    s: &AppState,
    id: i64,
    events: Vec<EventBody>,
    typed: Typed,
    field: &'static str,
    once: SubmissionKey,
) -> Result<Result<Vec<u64>, Log>, ApiError> {
    let now = jiff::Timestamp::now().to_string();
    let b = EventsBody {
        events: events
            .into_iter()
            .zip(0..)
            .map(|(event, seq)| DeviceEvent {
                seq,
                at: now.clone(),
                event,
            })
            .collect(),
    };
    let fx = s.effects();
    s.person(id, true, move |store, live| {
        match post_batch(store, live, &b, Numbering::Next(Some(once))) {
            Ok(ack) => Ok(Ok(ack.acked)),
            Err(e)
                if e.status == StatusCode::UNPROCESSABLE_ENTITY
                    || e.status == StatusCode::CONFLICT =>
            {
                let mut t = typed;
                let msg = value_message(&e);
                if field == "glucose" {
                    t.glucose_error = Some(msg);
                } else {
                    t.carbs_error = Some(msg);
                }
                Ok(Err(model(store, live, After::Nothing, t, fx.as_ref())?))
            }
            Err(e) => Err(e),
        }
    })
    .await
}

/// The form's submission key; a form without one (from a page of an
/// older version) is refused, nothing stored.
fn once(form: &Form, action: &str) -> Result<SubmissionKey, ApiError> {
    form.submission(action)
        .ok_or_else(|| ApiError::invalid(form::SUBMISSION, EN.submission_missing))
}

/// Refuses a reading outside the plausible range in the person's unit
/// (the store's check would say it in mg/dL): the message beside the field.
fn out_of_range(value: f64, units: GlucoseUnit, limits: (f64, f64)) -> Option<String> {
    let mg_dl = units.to_mg_dl(value);
    if abba_core::limits::within(mg_dl, limits.0, limits.1) {
        return None;
    }
    let mut m = fill(
        EN.glucose_out_of_range,
        &[
            ("min", &units.value(limits.0)),
            ("max", &units.value(limits.1)),
            ("unit", units.label()),
            ("value", &format!("{value}")),
        ],
    );
    if units == GlucoseUnit::MmolL && abba_core::limits::within(value, limits.0, limits.1) {
        m.push(' ');
        m.push_str(&fill(
            EN.glucose_looks_mg_dl,
            &[
                ("value", &format!("{value}")),
                ("mmol", &GlucoseUnit::MmolL.value(value)),
            ],
        ));
    }
    Some(m)
}

/// `POST /log/reading`: a meter reading in the person's unit; with
/// `bedtime` (SMBG mode only) the day is closed right after it.
pub async fn reading(State(s): State<AppState>, ctx: Ctx, body: RawBody) -> PageResult {
    if !ctx.same_origin() {
        return Err(super::page::forbidden_csrf());
    }
    let form = Form::parse(&ctx.headers, body)?;
    let (id, w) = session::person_post(&s, &ctx, &form).await?;
    form.only(&["csrf", form::SUBMISSION, "glucose", "bedtime"])?;
    let key = once(&form, "/log/reading")?;
    let typed = Typed {
        glucose: form.text("glucose").to_string(),
        ..Typed::default()
    };
    let bedtime = match form.get("bedtime") {
        None => false,
        Some("on") => true,
        Some(other) => {
            return Err(ApiError::invalid("bedtime", format!("expected on, got {other:?}")).into())
        }
    };
    let (units, mode, limits) = s
        .person(id, false, |_, live| {
            let l = &live.person.settings.advisor.limits;
            Ok((
                live.person.settings.units,
                live.person.mode(),
                (l.glucose_min_mg_dl, l.glucose_max_mg_dl),
            ))
        })
        .await?;
    let number = form::number(&typed.glucose);
    let refused = match number {
        // A CGM day closes by itself (the first event after midnight).
        _ if bedtime && mode != Mode::Smbg => Some(EN.bedtime_cgm.to_string()),
        Some(v) => out_of_range(v, units, limits),
        None if typed.glucose.is_empty() => Some(EN.missing_field.to_string()),
        None => {
            let example = if units == GlucoseUnit::MmolL {
                "5.8"
            } else {
                "105"
            };
            Some(fill(EN.expected_number, &[("example", example)]))
        }
    };
    let value = match (number, refused) {
        (Some(v), None) => v,
        (_, error) => {
            let mut t = typed;
            t.glucose_error = error;
            let fx = s.effects();
            let log = s
                .person(id, false, move |store, live| {
                    model(store, live, After::Nothing, t, fx.as_ref())
                })
                .await?;
            return show_log(StatusCode::UNPROCESSABLE_ENTITY, &w.csrf, log);
        }
    };
    let mg_dl = units.to_mg_dl(value);
    let mut events = vec![EventBody::Smbg { mg_dl }];
    if bedtime {
        events.push(EventBody::DayClosed);
    }
    match enter(&s, id, events, typed, "glucose", key).await? {
        Ok(_) if bedtime => Ok(see_other("/log?closed=1")),
        Ok(_) => Ok(see_other("/log?saved=reading")),
        Err(log) => show_log(StatusCode::UNPROCESSABLE_ENTITY, &w.csrf, log),
    }
}

/// `POST /log/meal`: a meal with its carbohydrate; a main meal is answered
/// with the carb ratio to use and the bolus it implies.
pub async fn meal(State(s): State<AppState>, ctx: Ctx, body: RawBody) -> PageResult {
    if !ctx.same_origin() {
        return Err(super::page::forbidden_csrf());
    }
    let form = Form::parse(&ctx.headers, body)?;
    let (id, w) = session::person_post(&s, &ctx, &form).await?;
    form.only(&["csrf", form::SUBMISSION, "carbs", "slot"])?;
    let key = once(&form, "/log/meal")?;
    let slot = SLOTS
        .iter()
        .find(|(k, _)| *k == form.text("slot"))
        .map(|x| x.1)
        .ok_or_else(|| {
            ApiError::invalid(
                "slot",
                format!(
                    "expected breakfast, lunch, dinner or snack, got {:?}",
                    form.text("slot")
                ),
            )
        })?;
    let typed = Typed {
        carbs: form.text("carbs").to_string(),
        slot: Some(slot),
        ..Typed::default()
    };
    let Some(carbs_g) = form::number(&typed.carbs) else {
        let mut t = typed;
        t.carbs_error = Some(if t.carbs.is_empty() {
            EN.missing_field.to_string()
        } else {
            fill(EN.expected_number, &[("example", "45")])
        });
        let fx = s.effects();
        let log = s
            .person(id, false, move |store, live| {
                model(store, live, After::Nothing, t, fx.as_ref())
            })
            .await?;
        return show_log(StatusCode::UNPROCESSABLE_ENTITY, &w.csrf, log);
    };
    let wire = match slot {
        MealSlot::Breakfast => WireSlot::Breakfast,
        MealSlot::Lunch => WireSlot::Lunch,
        MealSlot::Dinner => WireSlot::Dinner,
        _ => WireSlot::Snack,
    };
    let events = vec![EventBody::Meal {
        carbs_g,
        slot: wire,
    }];
    match enter(&s, id, events, typed, "carbs", key).await? {
        Ok(seqs) if slot.main_index().is_some() => match seqs.first() {
            Some(seq) => Ok(see_other(&format!("/log?meal={seq}"))),
            None => Ok(see_other("/log")),
        },
        Ok(_) => Ok(see_other("/log?saved=snack")),
        Err(log) => show_log(StatusCode::UNPROCESSABLE_ENTITY, &w.csrf, log),
    }
}

/// This module's routes (merged by [`super::routes`]).
pub fn routes() -> axum::Router<crate::state::AppState> {
    use axum::routing::{get, post};
    axum::Router::new()
        .route("/log", get(page))
        .route("/log/reading", post(reading))
        .route("/log/meal", post(meal))
}
