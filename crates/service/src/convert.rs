//! Between the wire (abba-api) and the store: device events checked and
//! hashed, decisions shown as suggestions, the advice, new persons.

use crate::error::ApiError;
use abba_advisor::guard::EventGuard;
use abba_advisor::{
    AbbaConfig, ClinicianBounds, Decision, EventLimits, MinData, Mode as AdvisorMode, Parameter,
};
use abba_api::{
    AdviceResponse, Bounds, DataSummary, DeviceEvent, EventBody, EventsBody, MealSlot as WireSlot,
    Mode, NewPersonBody, PhaseView, Range, Setting, SettingAdvice, Suggestion, TempRate,
    TherapyBody, TherapyChangeBody,
};
use abba_core::limits::{Limit, BASAL_U_PER_H, CARB_RATIO_G_PER_U};
use abba_core::{
    Event, EventKind, Grams, GramsPerUnit, MealSlot, MgDl, TempBasalRate, TherapySettings,
    Timestamp, Units, UnitsPerHour,
};
use abba_io::automation::Delivery;
use abba_store::advise::{self, Advice, Phase, SuggestionView};
use abba_store::app::NewAppEvent;
use abba_store::effect;

use abba_store::{Live, NewPerson, StoreError};
use sha2::{Digest, Sha256};
use std::collections::{BTreeMap, HashSet};

fn slot(s: WireSlot) -> MealSlot {
    match s {
        WireSlot::Breakfast => MealSlot::Breakfast,
        WireSlot::Lunch => MealSlot::Lunch,
        WireSlot::Dinner => MealSlot::Dinner,
        WireSlot::Snack => MealSlot::Snack,
    }
}

/// The advisor's event kind of a wire event.
pub fn event_kind(e: &EventBody) -> EventKind {
    match *e {
        EventBody::Cgm { mg_dl } => EventKind::Cgm(MgDl(mg_dl)),
        EventBody::Smbg { mg_dl } => EventKind::Smbg(MgDl(mg_dl)),
        EventBody::Meal { carbs_g, slot: s } => EventKind::MealAnnounced {
            carbs: Grams(carbs_g),
            slot: slot(s),
        },
        EventBody::Bolus { units } => EventKind::Bolus(Units(units)),
        EventBody::ExtendedBolus {
            total_units,
            immediate_units,
            duration_min,
        } => EventKind::ExtendedBolus {
            total: Units(total_units),
            immediate: Units(immediate_units),
            duration_min,
        },
        EventBody::BasalRate { units_per_hour } => {
            EventKind::BasalRate(UnitsPerHour(units_per_hour))
        }
        EventBody::TempBasal { rate, duration_min } => EventKind::TempBasal {
            rate: match rate {
                TempRate::UnitsPerHour(r) => TempBasalRate::UnitsPerHour(UnitsPerHour(r)),
                TempRate::Percent(p) => TempBasalRate::Percent(p),
            },
            duration_min,
        },
        EventBody::Suspend => EventKind::Suspend,
        EventBody::Resume => EventKind::Resume,
        EventBody::DayClosed => EventKind::DayClosed,
    }
}

/// SHA-256 of an event's payload: its instant (normalised to UTC) and its
/// content (serialised from the parsed value, so spacing, field order and
/// `50` versus `50.0` do not matter).
pub fn payload_hash(at: jiff::Timestamp, e: &DeviceEvent) -> Result<[u8; 32], ApiError> {
    let body = serde_json::to_vec(&e.event).map_err(ApiError::internal)?;
    let mut h = Sha256::new();
    h.update(at.to_string().as_bytes());
    h.update([0x1f]);
    h.update(&body);
    Ok(h.finalize().into())
}

/// Checks a batch against the person's limits (the advisor's own) and
/// makes the store's events; 422 names the event and the field.
///
/// An event more than [`abba_core::limits::FUTURE_SKEW_MINUTES`] after
/// `now` (the server's clock) is refused: a device clock gone wrong would
/// otherwise become the person's latest decision for good.
pub fn check_events(
    body: &EventsBody,
    limits: &EventLimits,
    now: jiff::Timestamp,
) -> Result<Vec<NewAppEvent>, ApiError> {
    let skew = abba_core::limits::FUTURE_SKEW_MINUTES;
    let latest = now
        .checked_add(jiff::SignedDuration::from_mins(skew))
        .map_err(ApiError::internal)?;
    let n = body.events.len();
    if n == 0 || n > abba_api::MAX_EVENTS_PER_BATCH {
        return Err(ApiError::invalid(
            "events",
            format!(
                "expected 1 to {} events, got {n}",
                abba_api::MAX_EVENTS_PER_BATCH
            ),
        ));
    }
    let mut seen = HashSet::with_capacity(n);
    let guard = EventGuard::default();
    let mut out = Vec::with_capacity(n);
    for (i, e) in body.events.iter().enumerate() {
        if e.seq > abba_api::MAX_SEQ {
            return Err(ApiError::invalid(
                format!("events[{i}].seq"),
                format!(
                    "expected 0 to {} (2^53 - 1), got {}",
                    abba_api::MAX_SEQ,
                    e.seq
                ),
            ));
        }
        if !seen.insert(e.seq) {
            return Err(ApiError::invalid(
                format!("events[{i}].seq"),
                format!("sequence number {} appears twice in the batch", e.seq),
            ));
        }
        let at: jiff::Timestamp = rfc3339(&e.at).map_err(|err| {
            ApiError::invalid(
                format!("events[{i}].at"),
                format!(
                    "expected an RFC 3339 instant with an offset (2026-03-02T07:30:00+01:00), got {:?}: {err}",
                    e.at
                ),
            )
        })?;
        if at > latest {
            return Err(ApiError::invalid(
                format!("events[{i}].at"),
                format!(
                    "event seq {} ({}) is dated {at}, more than {skew} minutes after the server's clock ({}); check the device's clock",
                    e.seq,
                    abba_io::events::kind_name(&event_kind(&e.event)),
                    now.round(jiff::Unit::Second).unwrap_or(now)
                ),
            ));
        }
        let kind = event_kind(&e.event);
        guard
            .check(&Event::new(Timestamp(0), kind), limits)
            .map_err(|err| refused(i, e, err))?;
        out.push(NewAppEvent {
            seq: e.seq,
            at,
            kind,
            hash: payload_hash(at, e)?,
        });
    }
    Ok(out)
}

/// The field of a wire event that a refused value came from (the
/// advisor's check names the quantity, the event's kind the field).
fn field_of(e: &EventBody, what: &str) -> &'static str {
    match e {
        EventBody::Cgm { .. } | EventBody::Smbg { .. } => "mg_dl",
        EventBody::Meal { .. } => "carbs_g",
        EventBody::Bolus { .. } => "units",
        EventBody::BasalRate { .. } => "units_per_hour",
        EventBody::TempBasal { rate, .. } => match rate {
            _ if what.contains("duration") => "duration_min",
            TempRate::UnitsPerHour(_) => "rate.units_per_hour",
            TempRate::Percent(_) => "rate.percent",
        },
        EventBody::ExtendedBolus { .. } if what.contains("duration") => "duration_min",
        EventBody::ExtendedBolus { .. } if what.contains("immediate") => "immediate_units",
        EventBody::ExtendedBolus { .. } => "total_units",
        EventBody::Suspend | EventBody::Resume | EventBody::DayClosed => "type",
    }
}

/// 422 for an event the advisor's checks refuse: the path down to the
/// field, the message with the event's seq, kind and its real time (the
/// check itself runs on a placeholder minute, never shown).
fn refused(i: usize, e: &DeviceEvent, err: abba_advisor::AdvisorError) -> ApiError {
    let kind = abba_io::events::kind_name(&event_kind(&e.event));
    let what = format!("event seq {} ({kind}) at {}", e.seq, e.at);
    match err {
        abba_advisor::AdvisorError::InvalidValue {
            what: quantity,
            expected,
            got,
            ..
        } => ApiError::invalid(
            format!("events[{i}].event.{}", field_of(&e.event, quantity)),
            format!("{what}: {quantity} must be {expected}, got {got}"),
        ),
        other => {
            // Not reachable from the wire's kinds today; said without the
            // placeholder time all the same.
            let text = other.to_string();
            let text = text.split_once(": ").map_or(text.as_str(), |x| x.1);
            ApiError::invalid(format!("events[{i}].event"), format!("{what}: {text}"))
        }
    }
}

/// The wire name of a parameter.
pub fn setting(p: Parameter) -> Setting {
    match p {
        Parameter::Basal => Setting::Basal,
        Parameter::CarbRatio(MealSlot::Breakfast) => Setting::Breakfast,
        Parameter::CarbRatio(MealSlot::Lunch) => Setting::Lunch,
        // The advisor decides only for main meals.
        Parameter::CarbRatio(_) => Setting::Dinner,
    }
}

/// The parameter of a wire setting.
pub fn parameter(s: Setting) -> Parameter {
    match s {
        Setting::Basal => Parameter::Basal,
        Setting::Breakfast => Parameter::CarbRatio(MealSlot::Breakfast),
        Setting::Lunch => Parameter::CarbRatio(MealSlot::Lunch),
        Setting::Dinner => Parameter::CarbRatio(MealSlot::Dinner),
    }
}

/// A suggestion's id.
pub fn suggestion_id(d: &Decision) -> u64 {
    setting(d.parameter).suggestion_id(d.at.0.max(0) as u64)
}

fn suggestion(live: &Live, d: &Decision, v: &SuggestionView, seq: Option<u64>) -> Suggestion {
    // An RFC 3339 instant at the person's offset: the local time the
    // advice shows, never a bare UTC instant.
    let instant = advise::clock(&live.person)
        .and_then(|c| c.instant(d.at).ok())
        .map_or_else(
            || d.at.to_string(),
            |i| {
                i.to_zoned(live.person.tz.clone())
                    .strftime("%Y-%m-%dT%H:%M:%S%:z")
                    .to_string()
            },
        );
    let reason = match &v.no_update_reason {
        Some(r) => r.clone(),
        None => v.reasons.join(" "),
    };
    Suggestion {
        id: suggestion_id(d),
        seq,
        parameter: setting(d.parameter),
        value: d.new,
        previous: d.old,
        unit: v.unit.to_string(),
        no_update: v.no_update,
        reason,
        reasons: v.reasons.clone(),
        data: v.data.clone(),
        decided_at: instant,
        day: v.day,
        status: v.status.clone(),
        in_force: v.in_force,
        schedule: v.schedule.as_deref().map(segments),
        answer_note: v.answer_note.clone(),
    }
}

/// A schedule as the store's views show it (local `HH:MM`, U/h) on the
/// wire (minute of the day, U/h).
fn segments(s: &[(String, f64)]) -> Vec<abba_api::BasalSegment> {
    s.iter()
        .map(|(t, r)| abba_api::BasalSegment {
            start_minute: t
                .split_once(':')
                .and_then(|(h, m)| Some(h.parse::<u32>().ok()? * 60 + m.parse::<u32>().ok()?))
                .unwrap_or(0),
            units_per_hour: *r,
        })
        .collect()
}

/// Finds the app event (its seq) that made a decision; a store error is
/// passed on, never taken for "no producer".
pub type SeqOf<'a> = dyn FnMut(&Decision) -> Result<Option<u64>, StoreError> + 'a;

/// The person's decisions for which `keep` holds, as suggestions, oldest
/// first; `seq_of` finds the app event that made each.
pub fn suggestions(
    live: &Live,
    keep: impl Fn(&Decision) -> bool,
    seq_of: &mut SeqOf<'_>,
) -> Result<Vec<Suggestion>, StoreError> {
    let views = live.views();
    live.decisions
        .iter()
        .zip(&views)
        .filter(|(d, _)| keep(d))
        .map(|(d, v)| Ok(suggestion(live, d, v, seq_of(d)?)))
        .collect()
}

/// One page of the person's suggestions with an id greater than `after`
/// (all without), at most `limit`, in id order; and the `after` of the
/// next page when more follow. Only the page is put in words.
pub fn page(
    live: &Live,
    after: Option<u64>,
    limit: usize,
    seq_of: &mut SeqOf<'_>,
) -> Result<(Vec<Suggestion>, Option<u64>), StoreError> {
    let mut picked: Vec<(u64, usize)> = live
        .decisions
        .iter()
        .enumerate()
        .map(|(i, d)| (suggestion_id(d), i))
        .filter(|(id, _)| after.is_none_or(|a| *id > a))
        .collect();
    picked.sort_unstable();
    let more = picked.len() > limit;
    picked.truncate(limit);
    let next = if more {
        picked.last().map(|x| x.0)
    } else {
        None
    };
    // The latest decision of each setting is the only one that can be
    // open (or replaced): known from the whole list, not the page.
    let indices: Vec<usize> = picked.iter().map(|&(_, i)| i).collect();
    let decisions: Vec<Decision> = indices.iter().map(|&i| live.decisions[i].clone()).collect();
    let views = advise::views_at(
        &live.person,
        &live.decisions,
        &indices,
        &live.answers,
        live.extras.as_ref(),
    );
    let list = decisions
        .iter()
        .zip(&views)
        .map(|(d, v)| Ok(suggestion(live, d, v, seq_of(d)?)))
        .collect::<Result<Vec<_>, StoreError>>()?;
    Ok((list, next))
}

/// The advice as JSON.
pub fn advice(
    live: &Live,
    a: Advice,
    seq_of: &mut SeqOf<'_>,
) -> Result<AdviceResponse, StoreError> {
    let views = live.views();
    let settings = a
        .settings
        .iter()
        .map(|s| {
            // The latest decision of the setting (what `latest` shows).
            let latest = match live
                .decisions
                .iter()
                .zip(&views)
                .rev()
                .find(|(d, _)| advise_key(d) == s.setting)
            {
                Some((d, v)) => Some(suggestion(live, d, v, seq_of(d)?)),
                None => None,
            };
            Ok(SettingAdvice {
                setting: Setting::ALL
                    .into_iter()
                    .find(|x| setting_key(*x) == s.setting)
                    .unwrap_or(Setting::Basal),
                unit: s.unit.to_string(),
                in_force: s.in_force,
                use_today: s.use_today,
                latest: latest.map(|mut l| {
                    // The advice's own status (held back by the twin check).
                    if let Some(v) = &s.latest {
                        l.status.clone_from(&v.status);
                    }
                    l
                }),
                effect: s.effect.as_ref().map(effect),
            })
        })
        .collect::<Result<Vec<_>, StoreError>>()?;
    let phase = match a.phase {
        Phase::NoData => PhaseView::NoData,
        Phase::FirstWeek {
            days_done,
            days_left,
            missing,
        } => PhaseView::FirstWeek {
            days_done,
            days_left,
            missing,
        },
        Phase::Adapting => PhaseView::Adapting,
    };
    Ok(AdviceResponse {
        nightscout: None,
        notice: a.notice.to_string(),
        person_id: live.person.id as u64,
        person: a.person,
        mode: a.mode.to_string(),
        tz: a.tz,
        first_day: a.first_day,
        phase,
        settings,
        data: DataSummary {
            records: a.data.records as u64,
            events: a
                .data
                .events
                .into_iter()
                .map(|(k, v)| (k, v as u64))
                .collect::<BTreeMap<_, _>>(),
            span: a.data.span.map(|(x, y)| vec![x, y]),
            records_not_used: a.data.records_not_used as u64,
            not_used_examples: a.data.not_used_examples,
            events_refused: a.data.events_refused as u64,
        },
        therapy: abba_api::TherapyInForce {
            source: a.therapy.source.to_string(),
            basal_schedule: a.therapy.basal_schedule.as_deref().map(segments),
            basal_schedule_mean: a.therapy.basal_schedule_mean,
            pump_steps: a.therapy.pump_steps.map(|p| abba_api::PumpStepsBody {
                basal_units_per_hour: p.basal_u_per_h,
                carb_ratio_g_per_unit: p.carb_ratio_g_per_u,
            }),
            changes: a.therapy.changes,
        },
        delivery: abba_api::DeliveryView {
            kind: match a.delivery.kind {
                Delivery::OpenLoop => "open_loop",
                Delivery::ClosedLoop => "closed_loop",
                Delivery::Injections => "injections",
                Delivery::NoInsulinRecords => "no_insulin_records",
            }
            .to_string(),
            words: a.delivery.words.to_string(),
            evidence: a.delivery.evidence,
            basal_suggestions: a.delivery.basal_suggestions,
            note: a.delivery.note,
        },
        first_week: a.first_week.map(|f| abba_api::FirstWeekDays {
            qualifying: f.qualifying,
            missing: f.missing,
        }),
        notes: a.notes,
    })
}

fn band(b: &effect::Band) -> abba_api::BandedValue {
    abba_api::BandedValue {
        value: b.value,
        low: b.low,
        high: b.high,
    }
}

fn figures(f: &effect::Figures) -> abba_api::RangeFigures {
    abba_api::RangeFigures {
        tir_pct: band(&f.tir_pct),
        below_70_pct: band(&f.below_70_pct),
    }
}

/// A suggestion's predicted effect as JSON.
pub fn effect(e: &effect::SettingEffect) -> abba_api::SuggestionEffect {
    use abba_api::{NoPredictionKind as K, TwinCheckOutcome as O};
    let (predicted, none, detail) = match &e.effect {
        effect::Effect::Predicted(p) => (
            Some(abba_api::PredictedEffect {
                days: p.days as u64,
                twin_revision: p.twin_revision,
                grade: p.grade.clone(),
                in_force: figures(&p.in_force),
                suggested: figures(&p.suggested),
                change: figures(&p.change),
            }),
            None,
            None,
        ),
        effect::Effect::None(why) => {
            let (k, d) = match why {
                effect::NoPrediction::NotAvailable => (K::NotAvailable, None),
                effect::NoPrediction::NoTwin => (K::NoTwin, None),
                effect::NoPrediction::NotUsable { reason } => (K::NotUsable, Some(reason.clone())),
                effect::NoPrediction::Outdated { revision } => (
                    K::Outdated,
                    Some(format!("twin revision {revision} was fitted on older data")),
                ),
                effect::NoPrediction::Failed { reason } => (K::Failed, Some(reason.clone())),
            };
            (None, Some(k), d)
        }
    };
    abba_api::SuggestionEffect {
        predicted,
        no_prediction: none,
        no_prediction_detail: detail,
        twin_check: match e.check {
            effect::CheckOutcome::Passed => O::Passed,
            effect::CheckOutcome::HeldBack => O::HeldBack,
            effect::CheckOutcome::Off => O::Off,
            effect::CheckOutcome::NoPrediction => O::NoPrediction,
        },
        margin_pp: e.margin_pp,
    }
}

fn advise_key(d: &Decision) -> &'static str {
    abba_store::answer::param_key(d.parameter)
}

fn setting_key(s: Setting) -> &'static str {
    abba_store::answer::param_key(parameter(s))
}

/// A clinician's range checked against the plausibility limit of its
/// quantity ([`abba_core::limits`], the CLI's too); 422 names the end.
fn range(
    r: Option<Range>,
    limit: &Limit,
    path: &str,
) -> Result<Option<abba_advisor::bounds::Range>, ApiError> {
    let Some(r) = r else { return Ok(None) };
    limit
        .check(r.min)
        .map_err(|e| ApiError::invalid(format!("{path}.min"), e.to_string()))?;
    limit
        .check(r.max)
        .map_err(|e| ApiError::invalid(format!("{path}.max"), e.to_string()))?;
    if r.min > r.max {
        return Err(ApiError::invalid(
            path,
            format!("expected min <= max, got min {} max {}", r.min, r.max),
        ));
    }
    Ok(Some(abba_advisor::bounds::Range {
        min: r.min,
        max: r.max,
    }))
}

/// Clinician bounds from the wire (`path` prefixes the field names).
pub fn bounds(b: &Bounds, path: &str) -> Result<ClinicianBounds, ApiError> {
    Ok(ClinicianBounds {
        basal: range(b.basal, &BASAL_U_PER_H, &format!("{path}.basal"))?,
        carb_ratio: [
            range(
                b.breakfast,
                &CARB_RATIO_G_PER_U,
                &format!("{path}.breakfast"),
            )?,
            range(b.lunch, &CARB_RATIO_G_PER_U, &format!("{path}.lunch"))?,
            range(b.dinner, &CARB_RATIO_G_PER_U, &format!("{path}.dinner"))?,
        ],
    })
}

/// The starting therapy from the wire, each value checked against the
/// plausibility limits ([`abba_core::limits`]); 422 names the field.
pub fn start(t: &TherapyBody) -> Result<TherapySettings, ApiError> {
    BASAL_U_PER_H
        .check(t.basal_units_per_hour)
        .map_err(|e| ApiError::invalid("start.basal_units_per_hour", e.to_string()))?;
    for (i, &cr) in t.carb_ratio_g_per_unit.iter().enumerate() {
        CARB_RATIO_G_PER_U.check(cr).map_err(|e| {
            ApiError::invalid(format!("start.carb_ratio_g_per_unit[{i}]"), e.to_string())
        })?;
    }
    Ok(TherapySettings {
        basal: UnitsPerHour(t.basal_units_per_hour),
        carb_ratio: t.carb_ratio_g_per_unit.map(GramsPerUnit),
    })
}

/// A new person from the wire.
pub fn new_person(b: &NewPersonBody) -> Result<NewPerson, ApiError> {
    let mode = match b.mode {
        Mode::Cgm => AdvisorMode::Cgm,
        Mode::Smbg => AdvisorMode::Smbg,
    };
    let name = abba_store::person::check_name(&b.name).map_err(|e| match e {
        StoreError::Invalid { problem, .. } => ApiError::invalid("name", problem),
        other => other.into(),
    })?;
    let start = start(&b.start)?;
    let mut p = NewPerson::new(&name, &b.tz, mode, start);
    if let Some(day) = &b.first_day {
        let d: jiff::civil::Date = day.parse().map_err(|e| {
            ApiError::invalid(
                "first_day",
                format!("expected a date YYYY-MM-DD, got {day:?}: {e}"),
            )
        })?;
        // The store's rule (`abba person new --first-day` too), named here
        // by the body's field; an unknown zone is the store's 422 on `tz`.
        if let Ok(tz) = jiff::tz::TimeZone::get(&b.tz) {
            abba_store::person::check_first_day(d, &tz, jiff::Timestamp::now())
                .map_err(|m| ApiError::invalid("first_day", m))?;
        }
        p.first_day = Some(d);
    }
    // The pump's steps: `abba person new`'s defaults unless given; none
    // only when asked (research).
    p.settings.pump_steps = match (b.pump_steps, b.continuous_values) {
        (Some(_), true) => {
            return Err(ApiError::invalid(
                "continuous_values",
                "give pump_steps or continuous_values, not both",
            ))
        }
        (None, true) => None,
        (None, false) => Some(abba_advisor::PumpSteps::default()),
        (Some(st), false) => {
            let steps = abba_advisor::PumpSteps {
                basal_u_per_h: st.basal_units_per_hour,
                carb_ratio_g_per_u: st.carb_ratio_g_per_unit,
            };
            steps.validate().map_err(|e| {
                let (field, problem) = match e {
                    abba_advisor::AdvisorError::Config { field, problem } => (field, problem),
                    other => (String::new(), other.to_string()),
                };
                let path = if field.contains("carb") {
                    "pump_steps.carb_ratio_g_per_unit"
                } else {
                    "pump_steps.basal_units_per_hour"
                };
                ApiError::invalid(path, problem)
            })?;
            Some(steps)
        }
    };
    if let Some(bd) = &b.bounds {
        p.settings.bounds = bounds(bd, "bounds")?;
    }
    if let Some(m) = b.min_data {
        if !(0.0..=1.0).contains(&m.cgm_coverage) {
            return Err(ApiError::invalid(
                "min_data.cgm_coverage",
                format!("expected a share from 0 to 1, got {}", m.cgm_coverage),
            ));
        }
        if m.cgm_period_min == 0 {
            return Err(ApiError::invalid(
                "min_data.cgm_period_min",
                "expected at least 1 minute between the sensor's readings, got 0",
            ));
        }
        p.settings.min_data = MinData {
            cgm_coverage: m.cgm_coverage,
            cgm_period_min: m.cgm_period_min,
            smbg_per_day: m.smbg_per_day,
            smbg_per_meal: m.smbg_per_meal,
        };
    }
    if let Some(cfg) = &b.advisor {
        let c: AbbaConfig = serde_path_to_error::deserialize(cfg).map_err(|e| {
            ApiError::invalid(
                format!("advisor.{}", e.path()),
                format!("not an abba advisor configuration: {}", e.inner()),
            )
        })?;
        if c.mode != mode {
            return Err(ApiError::invalid(
                "advisor.mode",
                "the advisor's mode must equal the person's mode",
            ));
        }
        if b.age_group.is_some() {
            return Err(ApiError::invalid(
                "age_group",
                "give an age group or a full advisor configuration, not both: the configuration sets the basal agent's hours itself (features.cgm_basal_window_min, features.smbg_basal_window_min)",
            ));
        }
        p.settings.advisor = c;
    }
    if let Some(g) = b.age_group {
        p.settings.set_age_group(match g {
            abba_api::AgeGroup::Adult => abba_advisor::AgeGroup::Adult,
            abba_api::AgeGroup::Adolescent => abba_advisor::AgeGroup::Adolescent,
            abba_api::AgeGroup::Child => abba_advisor::AgeGroup::Child,
        });
    }
    Ok(p)
}

/// A clinician's change from the wire, checked field by field with
/// [`abba_core::limits`] like the create-person body (422 naming the
/// field): the basal schedule, the carb ratios, the instant (not in the
/// future).
pub type TherapyChangeIn = (
    Option<Vec<(u32, f64)>>,
    Option<[f64; 3]>,
    Option<jiff::Timestamp>,
);

/// See [`TherapyChangeIn`].
pub fn therapy_change(b: &TherapyChangeBody) -> Result<TherapyChangeIn, ApiError> {
    let basal = match (&b.basal_units_per_hour, &b.basal_schedule) {
        (Some(_), Some(_)) => {
            return Err(ApiError::invalid(
                "basal_schedule",
                "give basal_units_per_hour or basal_schedule, not both",
            ))
        }
        (Some(r), None) => {
            BASAL_U_PER_H
                .check(*r)
                .map_err(|e| ApiError::invalid("basal_units_per_hour", e.to_string()))?;
            Some(vec![(0, *r)])
        }
        (None, Some(segs)) => {
            if segs.is_empty() {
                return Err(ApiError::invalid(
                    "basal_schedule",
                    "expected at least one segment (the first from start_minute 0)",
                ));
            }
            let mut out: Vec<(u32, f64)> = Vec::with_capacity(segs.len());
            for (i, seg) in segs.iter().enumerate() {
                let first = out.is_empty();
                let after = out.last().map(|l| l.0);
                if (first && seg.start_minute != 0)
                    || seg.start_minute >= 1440
                    || after.is_some_and(|a| seg.start_minute <= a)
                {
                    return Err(ApiError::invalid(
                        format!("basal_schedule[{i}].start_minute"),
                        format!(
                            "expected minutes of the day from 0 to 1439, the first 0 and each after the one before, got {}",
                            seg.start_minute
                        ),
                    ));
                }
                BASAL_U_PER_H.check(seg.units_per_hour).map_err(|e| {
                    ApiError::invalid(format!("basal_schedule[{i}].units_per_hour"), e.to_string())
                })?;
                out.push((seg.start_minute, seg.units_per_hour));
            }
            Some(out)
        }
        (None, None) => None,
    };
    let carb_ratio = match &b.carb_ratios {
        Some(c) => {
            let values = [c.breakfast, c.lunch, c.dinner];
            for (v, name) in values.iter().zip(["breakfast", "lunch", "dinner"]) {
                CARB_RATIO_G_PER_U
                    .check(*v)
                    .map_err(|e| ApiError::invalid(format!("carb_ratios.{name}"), e.to_string()))?;
            }
            Some(values)
        }
        None => None,
    };
    if basal.is_none() && carb_ratio.is_none() {
        return Err(ApiError::invalid(
            "basal_units_per_hour",
            "give basal_units_per_hour, basal_schedule and/or carb_ratios",
        ));
    }
    let at = match &b.at {
        None => None,
        Some(t) => {
            let at: jiff::Timestamp = rfc3339(t).map_err(|err| {
                ApiError::invalid(
                    "at",
                    format!(
                        "expected an RFC 3339 instant with an offset (2026-03-02T07:30:00+01:00), got {t:?}: {err}"
                    ),
                )
            })?;
            let latest = jiff::Timestamp::now()
                .checked_add(jiff::SignedDuration::from_mins(
                    abba_core::limits::FUTURE_SKEW_MINUTES,
                ))
                .unwrap_or(jiff::Timestamp::MAX);
            if at > latest {
                return Err(ApiError::invalid(
                    "at",
                    format!(
                        "{at} is in the future (more than {} min after the server's clock): a change is recorded when it is made",
                        abba_core::limits::FUTURE_SKEW_MINUTES
                    ),
                ));
            }
            Some(at)
        }
    };
    Ok((basal, carb_ratio, at))
}

/// A store error about a clinician's change, with the wire's field names
/// (the store names the CLI's flags).
pub fn therapy_change_error(e: StoreError) -> ApiError {
    match e {
        StoreError::Invalid { field, problem } => {
            let f = if field.starts_with("--carb-ratio") {
                ["breakfast", "lunch", "dinner"]
                    .into_iter()
                    .find(|s| field.contains(s))
                    .map_or_else(|| "carb_ratios".to_string(), |s| format!("carb_ratios.{s}"))
            } else if field.starts_with("--basal") {
                "basal_schedule".to_string()
            } else if field == "--at" {
                "at".to_string()
            } else if problem.contains("day 1 is not known") {
                // The person's state, not a field of the body: worded for
                // the API (the store's words name the CLI's import).
                return ApiError::new(
                    axum::http::StatusCode::UNPROCESSABLE_ENTITY,
                    abba_api::ErrorCode::Invalid,
                    "the person has no data yet, so day 1 is not known: post their events \
                     (POST /v1/persons/{id}/events) or import an export first, or create \
                     the person with these values as the starting therapy",
                );
            } else {
                // Nothing to change: no setting given.
                return ApiError::new(
                    axum::http::StatusCode::UNPROCESSABLE_ENTITY,
                    abba_api::ErrorCode::Invalid,
                    "expected basal_units_per_hour or basal_schedule, and/or carb_ratios",
                );
            };
            ApiError::invalid(f, problem)
        }
        StoreError::Advisor(a) => ApiError::invalid("basal_schedule", a.to_string()),
        other => other.into(),
    }
}

/// An instant with its offset as the API takes it (RFC 3339): the offset
/// within a real zone's, −12:00 to +14:00 (jiff reads up to ±25:59, which
/// no clock shows).
fn rfc3339(text: &str) -> Result<jiff::Timestamp, String> {
    let at: jiff::Timestamp = text.parse().map_err(|e: jiff::Error| e.to_string())?;
    let t = text.trim();
    if t.ends_with(['Z', 'z']) {
        return Ok(at);
    }
    let Some(sign_at) = t.rfind(['+', '-']) else {
        return Ok(at);
    };
    let digits: String = t[sign_at + 1..]
        .chars()
        .filter(char::is_ascii_digit)
        .collect();
    let hours: i64 = digits.get(..2).and_then(|h| h.parse().ok()).unwrap_or(0);
    let minutes: i64 = digits.get(2..4).and_then(|m| m.parse().ok()).unwrap_or(0);
    let offset = hours * 60 + minutes;
    let east = t.as_bytes()[sign_at] == b'+';
    if minutes >= 60 || (east && offset > 14 * 60) || (!east && offset > 12 * 60) {
        return Err(format!(
            "the offset {} is beyond any zone's (-12:00 to +14:00)",
            &t[sign_at..]
        ));
    }
    Ok(at)
}
