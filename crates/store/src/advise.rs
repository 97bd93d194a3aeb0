//! Today's advice: what is in force, the latest suggestion for each setting
//! with its reasons and the data it rests on, the first-week countdown.

use crate::answer::{param_key, Answers};
use crate::person::Person;
use crate::words;
use abba_advisor::{Abba, Advisor, Decision, DecisionDetail, Parameter};
use abba_core::{Event, EventKind, MealSlot, Timestamp};
use abba_io::clock::AdvisorClock;
use abba_io::events::EventStream;
use serde::Serialize;
use std::collections::BTreeMap;

/// Said with every output meant for people.
pub const NOTICE: &str = "abba is research software, not a medical device. Changes to insulin therapy belong with your clinician: discuss any suggestion with them before you act on it.";

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
    /// answered before the next one; taken as followed) or `no_update`.
    pub status: String,
    /// The value in force after the answer (or the suggestion if open).
    pub in_force: f64,
}

/// One setting today.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SettingAdvice {
    /// The setting.
    pub setting: &'static str,
    /// Unit.
    pub unit: &'static str,
    /// Value in force now (what the advisor's next update starts from).
    pub in_force: f64,
    /// What to use today: the open suggestion if there is one, else the value in force.
    pub use_today: f64,
    /// The latest decision, if any.
    pub latest: Option<SuggestionView>,
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

/// Every decision as the person sees it, oldest first.
pub fn views(person: &Person, decisions: &[Decision], answers: &Answers) -> Vec<SuggestionView> {
    let c = clock(person);
    let cfg = &person.settings.advisor;
    let mut latest: BTreeMap<&'static str, usize> = BTreeMap::new();
    for (i, d) in decisions.iter().enumerate() {
        latest.insert(param_key(d.parameter), i);
    }
    decisions
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let key = param_key(d.parameter);
            let skipped = match &d.detail {
                DecisionDetail::Skipped { reason } => {
                    Some(words::skip_reason(*reason, d.parameter))
                }
                _ => None,
            };
            let answer = answers.get(&(d.at.0, key));
            let (status, in_force) = match (answer, &skipped) {
                (Some(a), _) => (a.kind.name().to_string(), a.in_force),
                (None, Some(_)) => ("no_update".to_string(), d.new),
                (None, None) if latest.get(key) == Some(&i) => ("open".to_string(), d.new),
                (None, None) => ("superseded".to_string(), d.new),
            };
            let data = match &d.detail {
                DecisionDetail::Abba(x) => format!(
                    "{} readings from {} to {}",
                    x.window.n,
                    local(c.as_ref(), x.window_start),
                    local(c.as_ref(), x.window_end)
                ),
                _ => "no data window".to_string(),
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
                reasons: words::reasons(d, cfg),
                data,
                status,
                in_force,
            }
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
    let mut missing = Vec::new();
    let coverage = cgm as f64 / (days as f64 * 288.0);
    if cgm == 0 {
        missing.push(
            "no CGM readings yet: the first week needs CGM data to set up the advisor".into(),
        );
    } else if coverage < 0.7 {
        missing.push(format!(
            "CGM coverage so far is {:.0} % (aim for 70 % or more)",
            100.0 * coverage
        ));
    }
    if count(|k| matches!(k, EventKind::Bolus(_))) == 0 {
        missing.push("no bolus records yet (import your pump's data)".into());
    }
    if count(|k| matches!(k, EventKind::MealAnnounced { .. })) == 0 {
        missing.push("no meals (carbohydrate entries) yet".into());
    }
    if person.mode() == abba_advisor::Mode::Smbg && count(|k| matches!(k, EventKind::Smbg(_))) == 0
    {
        missing.push("no meter (finger-stick) readings yet".into());
    }
    Phase::FirstWeek {
        days_done: closed.min(init),
        days_left: init.saturating_sub(closed),
        missing,
    }
}

/// Builds the advice from the replayed advisor, every decision and the answers.
pub fn advice(
    person: &Person,
    stream: &EventStream,
    records: usize,
    advisor: &Abba,
    decisions: &[Decision],
    answers: &Answers,
    refused: usize,
) -> Advice {
    let c = clock(person);
    let all = views(person, decisions, answers);
    let settings = PARAMETERS
        .iter()
        .map(|&p| {
            let key = param_key(p);
            let latest = all.iter().rev().find(|v| v.setting == key).cloned();
            let in_force = value(advisor, p);
            let use_today = match &latest {
                Some(v) if v.status == "open" => v.suggested,
                _ => in_force,
            };
            SettingAdvice {
                setting: key,
                unit: p.unit(),
                in_force,
                use_today,
                latest,
            }
        })
        .collect();
    let phase = if advisor.is_initialised() {
        Phase::Adapting
    } else {
        first_week(person, &stream.events)
    };
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
                .map(|r| format!("{} ({}): {}", r.origin, r.kind, r.reason))
                .collect(),
            events_refused: refused,
        },
    }
}
