//! Suggestions, advice, history and health as the service shows them.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use utoipa::ToSchema;

/// A therapy setting the advisor adapts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Setting {
    /// The flat basal rate (U/h).
    Basal,
    /// The breakfast carb ratio (g/U).
    Breakfast,
    /// The lunch carb ratio (g/U).
    Lunch,
    /// The dinner carb ratio (g/U).
    Dinner,
}

impl Setting {
    /// The four settings, in the order of their index in a suggestion id.
    pub const ALL: [Setting; 4] = [
        Setting::Basal,
        Setting::Breakfast,
        Setting::Lunch,
        Setting::Dinner,
    ];

    /// Index in a suggestion id (basal 0, breakfast 1, lunch 2, dinner 3).
    pub fn index(self) -> u64 {
        match self {
            Setting::Basal => 0,
            Setting::Breakfast => 1,
            Setting::Lunch => 2,
            Setting::Dinner => 3,
        }
    }

    /// Unit of the setting's values.
    pub fn unit(self) -> &'static str {
        match self {
            Setting::Basal => "U/h",
            _ => "g/U",
        }
    }

    /// The suggestion id of a decision at advisor minute `minute` (minutes
    /// since 00:00 of day 1) about this setting: `minute * 4 + index`. Ids
    /// are stable (they survive rebuilds) and grow with time.
    pub fn suggestion_id(self, minute: u64) -> u64 {
        minute * 4 + self.index()
    }

    /// The (minute, setting) of a suggestion id.
    pub fn from_suggestion_id(id: u64) -> (u64, Setting) {
        (id / 4, Setting::ALL[(id % 4) as usize])
    }
}

/// One suggestion (a decision of the advisor) as the app sees it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Suggestion {
    /// Stable id: advisor minute × 4 + setting index (see [`Setting`]).
    pub id: u64,
    /// The `seq` of the posted event that produced it (a `meal` or a
    /// `day_closed`); absent when the app's event is not known (a rebuild
    /// after late events or a changed answer).
    pub seq: Option<u64>,
    /// The setting.
    pub parameter: Setting,
    /// The value to use (the suggestion; equal to `previous` when there was
    /// no update).
    pub value: f64,
    /// The value before.
    pub previous: f64,
    /// `U/h` or `g/U`.
    pub unit: String,
    /// True when the advisor made no update (then `reason` says why).
    pub no_update: bool,
    /// Why, in plain words (the reasons joined).
    pub reason: String,
    /// The reasons one by one.
    pub reasons: Vec<String>,
    /// The data it rests on, in plain words.
    pub data: String,
    /// When it was decided: RFC 3339 at the person's offset (their local
    /// time, as `abba advise` shows it).
    #[schema(format = DateTime)]
    pub decided_at: String,
    /// Day of the advisor's clock it is for (1 = day 1).
    pub day: i64,
    /// `open`, `accepted`, `rejected`, `overridden`, `superseded` (not
    /// answered before the next one; taken as followed), `unseen` (made and
    /// followed by the next within one import, as the history a first
    /// import brings: never shown, not followed) or `no_update`;
    /// in the advice also `held_back` (open, but held back by the twin
    /// check: see [`SuggestionEffect`]).
    pub status: String,
    /// The value in force after the answer (the suggestion while open).
    pub in_force: f64,
    /// A basal rate for a basal schedule: the suggested schedule, every
    /// segment on the pump's step (what to program; `value` is its mean).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schedule: Option<Vec<crate::admin::BasalSegment>>,
    /// An answer given when the suggestion said something else (data
    /// imported after the answer changed it): both, in words; the answer
    /// stands.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub answer_note: Option<String>,
}

/// `GET /v1/persons/{id}/suggestions?after=ID`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SuggestionList {
    /// The notice.
    pub notice: String,
    /// Suggestions with an id greater than `after`, oldest first (at most
    /// `limit`).
    pub suggestions: Vec<Suggestion>,
    /// When more follow: the `after` of the next page.
    #[serde(default)]
    pub next_after: Option<u64>,
}

/// `GET /v1/persons/{id}/history`: every suggestion with its answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct HistoryResponse {
    /// The notice.
    pub notice: String,
    /// The person.
    pub person_id: u64,
    /// The suggestions of this page with their answers, oldest first.
    pub suggestions: Vec<Suggestion>,
    /// When more follow: the `after` of the next page.
    #[serde(default)]
    pub next_after: Option<u64>,
}

/// Where the person stands.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "phase", rename_all = "snake_case", deny_unknown_fields)]
pub enum PhaseView {
    /// No data yet.
    NoData,
    /// The first week: the starting therapy is kept while data is collected.
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

/// One setting today.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SettingAdvice {
    /// The setting.
    pub setting: Setting,
    /// Unit.
    pub unit: String,
    /// Value in force now (before the open suggestion, if there is one).
    pub in_force: f64,
    /// What to use today: the open suggestion if there is one, else the
    /// value in force.
    pub use_today: f64,
    /// The latest suggestion, if any.
    pub latest: Option<Suggestion>,
    /// An open suggestion's predicted effect on the person's twin and the
    /// twin check; absent when nothing is open.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effect: Option<SuggestionEffect>,
}

/// A figure with its 5-95 % band over the twin's posterior draws.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct BandedValue {
    /// At the twin's most probable parameters.
    pub value: f64,
    /// 5th percentile.
    pub low: f64,
    /// 95th percentile.
    pub high: f64,
}

/// Time in 70-180 mg/dL and below 70 mg/dL (%, or percentage points for
/// a change).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RangeFigures {
    /// Time in 70-180 mg/dL.
    pub tir_pct: BandedValue,
    /// Time below 70 mg/dL.
    pub below_70_pct: BandedValue,
}

/// What the twin predicts over the recent days.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PredictedEffect {
    /// Recent days replayed.
    pub days: u64,
    /// The twin's revision.
    pub twin_revision: u32,
    /// The twin's grade: `good` or `fair`.
    pub grade: String,
    /// The recorded days as they were (the settings in force).
    pub in_force: RangeFigures,
    /// The same days with the suggestion.
    pub suggested: RangeFigures,
    /// Suggested minus in force (percentage points).
    pub change: RangeFigures,
}

/// What the twin check made of a suggestion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum TwinCheckOutcome {
    /// The predicted time below 70 does not rise by more than the margin.
    Passed,
    /// It does: the suggestion is held back (use the value in force).
    HeldBack,
    /// The check is off.
    Off,
    /// No prediction, nothing checked.
    NoPrediction,
}

/// Why there is no prediction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum NoPredictionKind {
    /// This service predicts no effects.
    NotAvailable,
    /// The person has no twin yet.
    NoTwin,
    /// The twin's grade is "not usable".
    NotUsable,
    /// The twin is older than the data.
    Outdated,
    /// The twin's replay failed.
    Failed,
}

/// A suggestion's predicted effect and the twin check.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SuggestionEffect {
    /// The prediction, when there is a usable twin fitted on the current data.
    #[serde(default)]
    pub predicted: Option<PredictedEffect>,
    /// Otherwise why not.
    #[serde(default)]
    pub no_prediction: Option<NoPredictionKind>,
    /// The details of why not, in plain words.
    #[serde(default)]
    pub no_prediction_detail: Option<String>,
    /// The twin check.
    pub twin_check: TwinCheckOutcome,
    /// The check's margin (percentage points of time below 70 mg/dL).
    pub margin_pp: f64,
}

/// What the advice rests on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct DataSummary {
    /// Records (imported and posted) in the log.
    pub records: u64,
    /// Advisor events by kind.
    pub events: BTreeMap<String, u64>,
    /// First and last event, local time.
    pub span: Option<Vec<String>>,
    /// Records that did not become events.
    pub records_not_used: u64,
    /// The first reasons records were not used.
    pub not_used_examples: Vec<String>,
    /// Events the advisor refused.
    pub events_refused: u64,
}

/// The therapy in force.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TherapyInForce {
    /// Where it comes from, in words.
    pub source: String,
    /// The basal schedule in force, when the pump runs one.
    #[serde(default)]
    pub basal_schedule: Option<Vec<crate::admin::BasalSegment>>,
    /// That schedule's mean rate (its daily total / 24 h, U/h).
    #[serde(default)]
    pub basal_schedule_mean: Option<f64>,
    /// The pump's steps (none: continuous values).
    #[serde(default)]
    pub pump_steps: Option<crate::admin::PumpStepsBody>,
    /// Changes of therapy in the data and by the clinician, in words.
    pub changes: Vec<String>,
}

/// How insulin is delivered, as the data show it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct DeliveryView {
    /// `open_loop`, `closed_loop`, `injections` or `no_insulin_records`.
    pub kind: String,
    /// In words.
    pub words: String,
    /// The evidence, in words.
    pub evidence: Vec<String>,
    /// True when basal rates are suggested.
    pub basal_suggestions: bool,
    /// What the person should know about it.
    #[serde(default)]
    pub note: Option<String>,
}

/// The first week counted from imported data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FirstWeekDays {
    /// Local dates of the qualifying days.
    pub qualifying: Vec<String>,
    /// Local dates that do not qualify, with why.
    pub missing: Vec<String>,
}

/// `GET /v1/persons/{id}/advice`: what `abba advise` shows, as JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AdviceResponse {
    /// The notice.
    pub notice: String,
    /// The person.
    pub person_id: u64,
    /// The person's name.
    pub person: String,
    /// `cgm` or `smbg`.
    pub mode: String,
    /// IANA zone.
    pub tz: String,
    /// Day 1 (local date), once known.
    pub first_day: Option<String>,
    /// Phase.
    pub phase: PhaseView,
    /// Each setting.
    pub settings: Vec<SettingAdvice>,
    /// The data.
    pub data: DataSummary,
    /// The therapy in force: where it comes from, the basal schedule, the
    /// pump's steps, the changes of therapy (what `abba advise` shows).
    pub therapy: TherapyInForce,
    /// How insulin is delivered, as the data show it.
    pub delivery: DeliveryView,
    /// Import-fed persons in the first week: the days that qualify and
    /// those that do not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_week: Option<FirstWeekDays>,
    /// Things to know about the data and the advice, in plain words (a
    /// trip's clock, hypoglycaemia treatments, meals not seen, ...).
    #[serde(default)]
    pub notes: Vec<String>,
    /// The person's Nightscout link, if any: the last sync's time and error.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nightscout: Option<NightscoutLink>,
}

/// A person's Nightscout link as the service shows it (never the credential).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NightscoutLink {
    /// The site.
    pub url: String,
    /// The last sync's end (UTC), whatever its outcome.
    pub last_sync_at: Option<String>,
    /// The last successful sync's end (UTC).
    pub last_success_at: Option<String>,
    /// The last sync's error, if it failed.
    pub last_error: Option<String>,
    /// Failed syncs in a row.
    pub failures: u32,
    /// What the last successful sync could not look for, in words (late
    /// uploads on a site that cannot be read by `_id`, ...): what it read
    /// is imported; these were not checked.
    #[serde(default)]
    pub warnings: Vec<String>,
}

/// `GET /healthz` (no token).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Health {
    /// `ok`.
    pub status: String,
    /// `abba`.
    pub service: String,
    /// The service's version.
    pub version: String,
    /// The notice.
    pub notice: String,
}
