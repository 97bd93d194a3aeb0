//! Today's advice: what is in force, the latest suggestion for each setting
//! with its reasons and the data it rests on, the first-week countdown.

use crate::answer::{param_key, Answers};
use crate::in_force::{Extras, TherapyChange};
use crate::person::Person;
use abba_advisor::words;
use abba_advisor::{Abba, Advisor, Decision, DecisionDetail, Parameter};
use abba_core::{Event, EventKind, MealSlot, Timestamp};
use abba_io::automation::Delivery;
use abba_io::clock::AdvisorClock;
use abba_io::events::EventStream;
use serde::Serialize;
use std::collections::BTreeMap;

/// Said with every output meant for people.
pub use abba_advisor::words::NOTICE;

/// The four settings, in display order.
pub const PARAMETERS: [Parameter; 4] = [
    Parameter::Basal,
    Parameter::CarbRatio(MealSlot::Breakfast),
    Parameter::CarbRatio(MealSlot::Lunch),
    Parameter::CarbRatio(MealSlot::Dinner),
];

/// One decision of the advisor as the person sees it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SuggestionView {
    /// The setting (`basal`, `breakfast`, ...).
    pub setting: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// Day of the advisor's clock (1 = the first day), the day it is for.
    pub day: i64,
    /// Local date and time of the decision.
    pub decided_at: String,
    /// Value before.
    pub previous: f64,
    /// Suggested value.
    pub suggested: f64,
    /// Relative change (%).
    pub change_percent: f64,
    /// True when the advisor made no update (then `no_update_reason` says why).
    pub no_update: bool,
    /// Why there was no update.
    pub no_update_reason: Option<String>,
    /// Reasons in plain words.
    pub reasons: Vec<String>,
    /// The data it rests on, in plain words.
    pub data: String,
    /// `open`, `accepted`, `rejected`, `overridden`, `superseded` (not
    /// answered before the next one; taken as followed), `unseen` (made and
    /// followed by the next within one import, as history a first import
    /// brings: never shown, not followed), or `no_update`.
    pub status: String,
    /// The value in force after the answer (or the suggestion if open).
    pub in_force: f64,
    /// A basal schedule: the suggested schedule, every segment on the
    /// pump's step (local start time, U/h).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub schedule: Option<Vec<(String, f64)>>,
    /// An answer given when the suggestion said something else (data
    /// imported after the answer changed it): both, in words; the answer
    /// stands.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub answer_note: Option<String>,
}

/// One setting today.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SettingAdvice {
    /// The setting.
    pub setting: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// Value in force now (before the open suggestion, if there is one).
    pub in_force: f64,
    /// What to use today: the open suggestion if there is one, else the value in force.
    pub use_today: f64,
    /// The latest decision, if any.
    pub latest: Option<SuggestionView>,
    /// An open suggestion's predicted effect and the twin check
    /// ([`crate::effect`]); absent for a setting with nothing open.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect: Option<crate::effect::SettingEffect>,
}

/// Where the person stands.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "phase", rename_all = "snake_case")]
pub enum Phase {
    /// No data yet.
    NoData,
    /// The first week: the standard therapy is kept while data is collected.
    FirstWeek {
        /// Days closed so far.
        days_done: u32,
        /// Days still to go.
        days_left: u32,
        /// What is missing or thin, in plain words.
        missing: Vec<String>,
    },
    /// The advisor adapts every day.
    Adapting,
}

/// What the advice rests on.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DataSummary {
    /// Records in the log.
    pub records: usize,
    /// Advisor events by kind.
    pub events: BTreeMap<String, usize>,
    /// First and last event, local time.
    pub span: Option<(String, String)>,
    /// Records that did not become events (with the first few reasons).
    pub records_not_used: usize,
    /// The first reasons records were not used.
    pub not_used_examples: Vec<String>,
    /// Events the advisor refused.
    pub events_refused: usize,
}

/// Today's advice for a person.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Advice {
    /// The notice.
    pub notice: &'static str,
    /// Person.
    pub person: String,
    /// `cgm` or `smbg`.
    pub mode: &'static str,
    /// Zone.
    pub tz: String,
    /// Day 1 (local date).
    pub first_day: Option<String>,
    /// Phase.
    pub phase: Phase,
    /// Each setting.
    pub settings: Vec<SettingAdvice>,
    /// The data.
    pub data: DataSummary,
    /// The therapy in force: where it comes from, the schedule, the pump's steps, changes.
    pub therapy: TherapyView,
    /// How insulin is delivered, as the data show it.
    pub delivery: DeliveryView,
    /// Import-fed persons in the first week: the days that qualify and those that do not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub first_week: Option<FirstWeekView>,
    /// Things to know about the data (hypoglycaemia treatments, zones) and
    /// the advice (the hours the basal rate learns from, when part of the
    /// day, and whose defaults chose them).
    pub notes: Vec<String>,
}

/// The therapy in force.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TherapyView {
    /// Where it comes from, in words.
    pub source: &'static str,
    /// The basal schedule in force (local start, U/h), when there is one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub basal_schedule: Option<Vec<(String, f64)>>,
    /// That schedule's mean rate (its daily total / 24 h, U/h).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub basal_schedule_mean: Option<f64>,
    /// The pump's steps (none: continuous values).
    pub pump_steps: Option<abba_advisor::PumpSteps>,
    /// Changes of therapy in the data and by the clinician, in words.
    pub changes: Vec<String>,
}

/// Delivery as the data show it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeliveryView {
    /// `open_loop`, `closed_loop` or `injections`.
    pub kind: Delivery,
    /// In words.
    pub words: &'static str,
    /// The evidence (counts).
    pub evidence: Vec<String>,
    /// True when basal rates are suggested.
    pub basal_suggestions: bool,
    /// What the person should know about it.
    pub note: Option<String>,
}

/// The first week counted from the data.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FirstWeekView {
    /// Local dates of the qualifying days.
    pub qualifying: Vec<String>,
    /// Local dates that do not qualify, with why.
    pub missing: Vec<String>,
}

/// A clock for local times, once day 1 is known.
pub fn clock(person: &Person) -> Option<AdvisorClock> {
    person
        .first_day
        .map(|d| AdvisorClock::new(person.tz.clone(), d))
}

/// Local time of an advisor time.
pub fn local(clock: Option<&AdvisorClock>, t: Timestamp) -> String {
    clock
        .and_then(|c| {
            let i = c.instant(t).ok()?;
            Some(
                i.to_zoned(c.tz().clone())
                    .strftime("%Y-%m-%d %H:%M")
                    .to_string(),
            )
        })
        .unwrap_or_else(|| t.to_string())
}

/// The day a decision is for (1-based): a basal update is for the day
/// after the day it closes, a carb ratio for its meal's day.
pub fn day_for(d: &Decision) -> i64 {
    match d.parameter {
        Parameter::Basal => abba_advisor::guard::closed_day(d.at) + 2,
        Parameter::CarbRatio(_) => d.at.day_index() + 1,
    }
}

/// `HH:MM` of a minute of the day.
pub fn hhmm(m: u32) -> String {
    format!("{:02}:{:02}", m / 60, m % 60)
}

/// Every decision as the person sees it, oldest first.
pub fn views(person: &Person, decisions: &[Decision], answers: &Answers) -> Vec<SuggestionView> {
    views_with(person, decisions, answers, None)
}

/// The value a change of therapy puts in force for `p`, if it sets it.
fn change_value(c: &TherapyChange, p: Parameter) -> Option<f64> {
    match p {
        Parameter::Basal => c.basal.as_deref().map(abba_advisor::steps::mean_rate),
        Parameter::CarbRatio(s) => c.carb_ratio.and_then(|cr| s.main_index().map(|i| cr[i])),
    }
}

/// Like [`views`], with what the replay derived from imported records:
/// basal updates not offered (a loop or injections: `not_offered`), a
/// suggestion replaced by a later change of therapy (`replaced`).
pub fn views_with(
    person: &Person,
    decisions: &[Decision],
    answers: &Answers,
    extras: Option<&Extras>,
) -> Vec<SuggestionView> {
    let all: Vec<usize> = (0..decisions.len()).collect();
    views_at(person, decisions, &all, answers, extras)
}

/// Like [`views_with`] for the decisions at `picked` (indices into
/// `decisions`, a page of them): each says what it says in the whole list
/// (only the latest of a setting can be open or replaced).
pub fn views_at(
    person: &Person,
    decisions: &[Decision],
    picked: &[usize],
    answers: &Answers,
    extras: Option<&Extras>,
) -> Vec<SuggestionView> {
    let hold_basal = extras.is_some_and(|x| x.hold_basal);
    let changes: &[TherapyChange] = extras.map_or(&[], |x| &x.changes);
    let c = clock(person);
    let mut latest: BTreeMap<&'static str, usize> = BTreeMap::new();
    for (i, d) in decisions.iter().enumerate() {
        latest.insert(param_key(d.parameter), i);
    }
    picked
        .iter()
        .filter_map(|&i| Some((i, decisions.get(i)?)))
        .map(|(i, d)| {
            let key = param_key(d.parameter);
            let skipped = match &d.detail {
                DecisionDetail::Skipped { reason } => {
                    Some(words::skip_reason(*reason, d.parameter))
                }
                _ => None,
            };
            let answer = answers.get(&(d.at.0, key));
            let rounded = match &d.detail {
                DecisionDetail::Abba(x) => x.rounded.as_ref(),
                _ => None,
            };
            let replaced = changes
                .iter()
                .filter(|c| c.at > d.at)
                .find_map(|c| change_value(c, d.parameter));
            let (status, in_force) = match (answer, &skipped) {
                (Some(a), _) => (a.kind.name().to_string(), a.in_force),
                (None, Some(_)) => ("no_update".to_string(), d.new),
                (None, None) if replaced.is_some() && latest.get(key) == Some(&i) => {
                    ("replaced".to_string(), replaced.unwrap_or(d.old))
                }
                (None, None) if hold_basal && d.parameter == Parameter::Basal => {
                    ("not_offered".to_string(), d.old)
                }
                (None, None) if rounded.is_some() && d.new == d.old => {
                    ("no_change".to_string(), d.old)
                }
                (None, None) if latest.get(key) == Some(&i) => ("open".to_string(), d.new),
                // Made and followed by the next within one import: never
                // shown, so not taken as followed (see `Extras::shown`).
                (None, None) if extras.is_some_and(|x| !x.shown(d.at)) => {
                    ("unseen".to_string(), d.old)
                }
                (None, None) => ("superseded".to_string(), d.new),
            };
            let answer_note = answer
                .filter(|a| (a.suggested - d.new).abs() > 1e-9 || (a.previous - d.old).abs() > 1e-9)
                .map(|a| {
                    words::answer_on_changed_suggestion(
                        &d.parameter.to_string(),
                        &local(c.as_ref(), d.at),
                        a.kind.name(),
                        (a.previous, a.suggested),
                        (d.old, d.new),
                        a.in_force,
                        d.parameter.unit(),
                    )
                });
            let data = match &d.detail {
                DecisionDetail::Abba(x) => words::data_window(
                    x.window.n,
                    &local(c.as_ref(), x.window_start),
                    &local(c.as_ref(), x.window_end),
                ),
                _ => words::NO_DATA_WINDOW.to_string(),
            };
            SuggestionView {
                setting: key,
                unit: d.parameter.unit(),
                day: day_for(d),
                decided_at: local(c.as_ref(), d.at),
                previous: d.old,
                suggested: d.new,
                change_percent: 100.0 * (d.new / d.old - 1.0),
                no_update: skipped.is_some(),
                no_update_reason: skipped,
                reasons: reasons(person, d),
                data,
                status,
                in_force,
                schedule: rounded
                    .and_then(|r| r.segments.as_ref())
                    .map(|seg| seg.iter().map(|&(m, r)| (hhmm(m), r)).collect()),
                answer_note,
            }
        })
        .collect()
}

/// When the basal agent learns from part of the day: which hours, and
/// whose defaults chose them (the person's age group's, or the advisor's
/// configuration).
fn basal_hours(person: &Person) -> Option<String> {
    let s = &person.settings;
    let f = &s.advisor.features;
    let w = f.basal_window_for(s.advisor.mode)?;
    let group = s.age_group.holds(f).then_some(s.age_group);
    Some(words::basal_hours(w, group))
}

/// The reasons of one decision; a basal update that learned from part
/// of the day says which hours and whose defaults chose them.
fn reasons(person: &Person, d: &Decision) -> Vec<String> {
    let s = &person.settings;
    let mut out = words::reasons_in(d, &s.advisor, s.units);
    if let (Parameter::Basal, DecisionDetail::Abba(_), Some(h)) =
        (d.parameter, &d.detail, basal_hours(person))
    {
        out.insert(1, h);
    }
    out
}

/// The schedule in force's segments outside the clinician's basal bounds
/// (which hold its mean), said once.
fn segments_outside(person: &Person, therapy: &TherapyView) -> Option<String> {
    let r = person.settings.bounds.basal?;
    let outside: Vec<String> = therapy
        .basal_schedule
        .as_ref()?
        .iter()
        .filter(|(_, v)| *v < r.min - 1e-9 || *v > r.max + 1e-9)
        .map(|(t, v)| format!("{t} {}", words::rate(*v)))
        .collect();
    (!outside.is_empty()).then(|| words::segments_outside_bounds(r.min, r.max, &outside))
}

/// Main meals imported data never show in their window, once a day has
/// closed and some carbohydrate was logged: their carb ratios get no
/// suggestion, and the person is told why (someone who skips breakfast, a
/// night-shift worker eating outside the windows).
fn meals_not_seen(person: &Person, events: &[Event]) -> Vec<String> {
    if !events.iter().any(|e| e.kind == EventKind::DayClosed) {
        return Vec::new();
    }
    let mut seen = [0usize; 3];
    let mut snacks = 0;
    for e in events {
        if let EventKind::MealAnnounced { slot, .. } = e.kind {
            match slot.main_index() {
                Some(i) => seen[i] += 1,
                None => snacks += 1,
            }
        }
    }
    if snacks + seen.iter().sum::<usize>() == 0 {
        return Vec::new();
    }
    let w = person.settings.meal_windows;
    let windows = [w.breakfast, w.lunch, w.dinner];
    MealSlot::MAIN
        .iter()
        .zip(windows)
        .zip(seen)
        .filter(|(_, n)| *n == 0)
        .map(|((slot, (from, to)), _)| {
            words::meal_not_seen(slot.name(), &format!("{}-{}", hhmm(from), hhmm(to)), snacks)
        })
        .collect()
}

fn value(a: &Abba, p: Parameter) -> f64 {
    let s = a.settings();
    match p {
        Parameter::Basal => s.basal.0,
        Parameter::CarbRatio(slot) => slot.main_index().map_or(f64::NAN, |i| s.carb_ratio[i].0),
    }
}

fn first_week(person: &Person, events: &[Event]) -> Phase {
    let Some(first) = events.first() else {
        return Phase::NoData;
    };
    let init = person.settings.advisor.init_days;
    let closed = events
        .iter()
        .filter(|e| e.kind == EventKind::DayClosed)
        .count() as u32;
    let count = |f: fn(&EventKind) -> bool| events.iter().filter(|e| f(&e.kind)).count();
    let cgm = count(|k| matches!(k, EventKind::Cgm(_)));
    let days =
        (events.last().map_or(first.at, |e| e.at).day_index() - first.at.day_index() + 1).max(1);
    let missing = words::first_week_gaps(&words::FirstWeekData {
        cgm_readings: cgm,
        cgm_coverage: cgm as f64
            / (days as f64
                * (abba_core::MINUTES_PER_DAY / crate::in_force::cgm_period_min(events)) as f64),
        boluses: count(|k| matches!(k, EventKind::Bolus(_))),
        meals: count(|k| matches!(k, EventKind::MealAnnounced { .. })),
        meter_readings: (person.mode() == abba_advisor::Mode::Smbg)
            .then(|| count(|k| matches!(k, EventKind::Smbg(_)))),
    });
    Phase::FirstWeek {
        days_done: closed.min(init),
        days_left: init.saturating_sub(closed),
        missing,
    }
}

fn delivery_view(person: &Person, extras: Option<&Extras>) -> DeliveryView {
    let Some(x) = extras.filter(|x| !x.fed_by_app) else {
        return DeliveryView {
            kind: Delivery::OpenLoop,
            words: words::DELIVERY_AS_APP_REPORTS,
            evidence: Vec::new(),
            basal_suggestions: true,
            note: None,
        };
    };
    let kind = x.delivery();
    let note = match (kind, person.settings.allow_closed_loop) {
        (Delivery::OpenLoop, _) => None,
        (Delivery::NoInsulinRecords, _) => Some(words::delivery_note(
            words::NotDesignedFor::NoInsulinRecords,
        )),
        (_, allowed) => Some(words::delivery_note(words::NotDesignedFor::Delivery {
            shown: kind.name(),
            allowed,
        })),
    };
    DeliveryView {
        kind,
        words: kind.name(),
        evidence: x.evidence.words(),
        basal_suggestions: !x.hold_basal,
        note,
    }
}

/// `basal_open`: a basal suggestion waits for an answer; the replayed
/// advisor already runs its schedule, so the one in force is the schedule
/// before it.
fn therapy_view(
    person: &Person,
    advisor: &Abba,
    extras: Option<&Extras>,
    basal_open: bool,
) -> TherapyView {
    let changes = extras.map_or_else(Vec::new, |x| {
        x.changes
            .iter()
            .map(|c| {
                let basal: Option<Vec<(String, f64)>> = c
                    .basal
                    .as_ref()
                    .map(|b| b.iter().map(|&(m, r)| (hhmm(m), r)).collect());
                // In the person's zone, as every time the advice shows.
                let local = c
                    .instant
                    .parse::<jiff::Timestamp>()
                    .map(|t| {
                        t.to_zoned(person.tz.clone())
                            .strftime("%Y-%m-%d %H:%M")
                            .to_string()
                    })
                    .unwrap_or_else(|_| c.instant.clone());
                words::therapy_change(
                    &local,
                    &c.origin.to_string(),
                    basal.as_deref(),
                    c.carb_ratio,
                )
            })
            .collect()
    });
    let schedule = if basal_open {
        advisor.previous_basal_schedule()
    } else {
        None
    }
    .or_else(|| advisor.basal_schedule())
    .filter(|s| s.len() > 1);
    TherapyView {
        source: person.settings.therapy_source.words(),
        basal_schedule: schedule.map(|s| s.iter().map(|&(m, r)| (hhmm(m), r)).collect()),
        basal_schedule_mean: schedule.map(|s| abba_advisor::steps::mean_rate(s)),
        pump_steps: advisor.pump_steps(),
        changes,
    }
}

fn first_week_view(
    person: &Person,
    extras: Option<&Extras>,
    initialised: bool,
) -> Option<FirstWeekView> {
    let x = extras.filter(|x| !x.fed_by_app)?;
    if initialised {
        return None;
    }
    let c = clock(person)?;
    let date = |d: i64| {
        let date = c.first_day().checked_add(jiff::Span::new().days(d)).ok();
        words::day_or_date(date.map(|x| x.to_string()), d)
    };
    Some(FirstWeekView {
        qualifying: x.first_week.qualifying.iter().map(|&d| date(d)).collect(),
        missing: x
            .first_week
            .missing
            .iter()
            .map(|(d, why)| words::dated(&date(*d), why))
            .collect(),
    })
}

/// Builds the advice from the replayed advisor, every decision and the
/// answers (an app-fed person: nothing derived from imported records).
pub fn advice(
    person: &Person,
    stream: &EventStream,
    records: usize,
    advisor: &Abba,
    decisions: &[Decision],
    answers: &Answers,
    refused: usize,
) -> Advice {
    advice_with(
        person, stream, records, advisor, decisions, answers, refused, None,
    )
}

/// Like [`advice`], with what the replay derived from imported records.
#[allow(clippy::too_many_arguments)]
pub fn advice_with(
    person: &Person,
    stream: &EventStream,
    records: usize,
    advisor: &Abba,
    decisions: &[Decision],
    answers: &Answers,
    refused: usize,
    extras: Option<&Extras>,
) -> Advice {
    let c = clock(person);
    let all = views_with(person, decisions, answers, extras);
    let settings: Vec<SettingAdvice> = PARAMETERS
        .iter()
        .map(|&p| {
            let key = param_key(p);
            let latest = all.iter().rev().find(|v| v.setting == key).cloned();
            // An open suggestion is not in force until answered.
            let (in_force, use_today) = match &latest {
                Some(v) if v.status == "open" => (v.previous, v.suggested),
                _ => (value(advisor, p), value(advisor, p)),
            };
            SettingAdvice {
                setting: key,
                unit: p.unit(),
                in_force,
                use_today,
                latest,
                effect: None,
            }
        })
        .collect();
    let phase = if advisor.is_initialised() {
        Phase::Adapting
    } else {
        match (
            first_week(person, &stream.events),
            extras.filter(|x| !x.fed_by_app),
        ) {
            (Phase::FirstWeek { mut missing, .. }, Some(x)) => {
                let init = person.settings.advisor.init_days;
                let done = (x.first_week.qualifying.len() as u32).min(init);
                missing.insert(0, words::first_week_rule(init));
                Phase::FirstWeek {
                    days_done: done,
                    days_left: init - done,
                    missing,
                }
            }
            (p, _) => p,
        }
    };
    let basal_open = settings.first().is_some_and(|s| {
        s.setting == "basal" && s.latest.as_ref().is_some_and(|v| v.status == "open")
    });
    let therapy = therapy_view(person, advisor, extras, basal_open);
    // The latest answers that later data changed, said with the advice.
    let answers_changed: Vec<String> = settings
        .iter()
        .filter_map(|s| s.latest.as_ref()?.answer_note.clone())
        .collect();
    let outside = segments_outside(person, &therapy);
    let span = match (stream.events.first(), stream.events.last()) {
        (Some(a), Some(b)) => Some((local(c.as_ref(), a.at), local(c.as_ref(), b.at))),
        _ => None,
    };
    Advice {
        notice: NOTICE,
        person: person.name.clone(),
        mode: match person.mode() {
            abba_advisor::Mode::Cgm => "cgm",
            abba_advisor::Mode::Smbg => "smbg",
        },
        tz: person.tz.iana_name().unwrap_or("?").to_string(),
        first_day: person.first_day.map(|d| d.to_string()),
        phase,
        settings,
        data: DataSummary {
            records,
            events: stream.counts.clone(),
            span,
            records_not_used: stream.rejected.len(),
            not_used_examples: stream
                .rejected
                .iter()
                .take(3)
                .map(|r| {
                    words::record_not_used(&r.origin.to_string(), &r.kind.to_string(), &r.reason)
                })
                .collect(),
            events_refused: refused,
        },
        therapy,
        delivery: delivery_view(person, extras),
        first_week: first_week_view(person, extras, advisor.is_initialised()),
        notes: stream
            .notes
            .iter()
            .cloned()
            .chain((stream.censored > 0).then(|| words::censored_readings(stream.censored)))
            .chain(basal_hours(person))
            .chain(outside)
            .chain(
                extras
                    .map(|x| abba_io::clocks::notes(&x.evidence.clocks, &person.tz))
                    .unwrap_or_default(),
            )
            .chain(
                extras
                    .filter(|x| !x.fed_by_app)
                    .map(|_| meals_not_seen(person, &stream.events))
                    .unwrap_or_default(),
            )
            .chain(answers_changed)
            .collect(),
    }
}
