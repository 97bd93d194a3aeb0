//! Admin (clinic) bodies: persons, bounds, tokens.

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// The advisor's measurement mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Adapts from CGM readings; days close at local midnight.
    Cgm,
    /// Adapts from meter readings; days close after the bedtime reading.
    Smbg,
}

/// A person's age group: it chooses the advisor's defaults the in-silico
/// trial calibrated for it (the hours of the day the basal rate learns
/// from: adults the whole day; adolescents 00:00-07:00 and children
/// 02:00-07:00 in CGM mode; both the fasting reading, 00:00-07:30, in SMBG
/// mode).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum AgeGroup {
    /// Adults.
    Adult,
    /// Adolescents.
    Adolescent,
    /// Children.
    Child,
}

/// The therapy in force when the person starts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TherapyBody {
    /// Flat basal rate (U/h).
    pub basal_units_per_hour: f64,
    /// Carb ratios of breakfast, lunch and dinner (g/U).
    pub carb_ratio_g_per_unit: [f64; 3],
}

/// A closed range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Range {
    /// Lowest value allowed.
    pub min: f64,
    /// Highest value allowed.
    pub max: f64,
}

/// Clinician bounds; an absent setting has no bound.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Bounds {
    /// Basal rate (U/h).
    #[serde(default)]
    pub basal: Option<Range>,
    /// Breakfast carb ratio (g/U).
    #[serde(default)]
    pub breakfast: Option<Range>,
    /// Lunch carb ratio (g/U).
    #[serde(default)]
    pub lunch: Option<Range>,
    /// Dinner carb ratio (g/U).
    #[serde(default)]
    pub dinner: Option<Range>,
}

/// The smallest change the person's pump can make to each setting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PumpStepsBody {
    /// Basal-rate step (U/h): 0.05, 0.025 or 0.01.
    pub basal_units_per_hour: f64,
    /// Carb-ratio step (g/U): 0.1 or 1.
    pub carb_ratio_g_per_unit: f64,
}

/// Minimum data per window for an update (all zero: no minimum, as in the
/// in-silico trial).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MinDataBody {
    /// CGM mode: share of the window's expected readings needed, 0-1.
    pub cgm_coverage: f64,
    /// CGM mode: minutes between the sensor's readings.
    pub cgm_period_min: u32,
    /// SMBG mode: meter readings a day needs for a basal update.
    pub smbg_per_day: u32,
    /// SMBG mode: meter readings a meal window needs.
    pub smbg_per_meal: u32,
}

/// `POST /v1/persons` (admin).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct NewPersonBody {
    /// Unique name in the store (1-200 characters).
    pub name: String,
    /// IANA zone (`Europe/Zurich`): days and meal times are local.
    pub tz: String,
    /// Measurement mode.
    pub mode: Mode,
    /// Day 1 of the advisor's clock (`YYYY-MM-DD`, local); default: the
    /// local date of the first event posted.
    #[serde(default)]
    pub first_day: Option<String>,
    /// Starting therapy.
    pub start: TherapyBody,
    /// Clinician bounds (default: none).
    #[serde(default)]
    pub bounds: Option<Bounds>,
    /// The pump's steps: suggestions are rounded to them and an override
    /// must be on them (default: 0.05 U/h and 0.1 g/U, as `abba person
    /// new`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pump_steps: Option<PumpStepsBody>,
    /// Research only: no pump steps, values unrounded as in the paper and
    /// the in-silico trial (the simulated app, `abba app`); not with
    /// `pump_steps` (422).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub continuous_values: bool,
    /// Minimum data per window (default: 70 % CGM coverage, 3 meter
    /// readings a day, 1 per meal window).
    #[serde(default)]
    pub min_data: Option<MinDataBody>,
    /// The advisor's full configuration as abba's `AbbaConfig` JSON (its
    /// mode must equal `mode`); default: ABBA's defaults for the mode and
    /// the age group with an exploration seed derived from the name.
    #[serde(default)]
    #[schema(value_type = Option<Object>)]
    pub advisor: Option<serde_json::Value>,
    /// The person's age group, whose defaults the advisor takes (default:
    /// adult). Not with `advisor`, whose configuration sets those knobs
    /// itself (422).
    #[serde(default)]
    pub age_group: Option<AgeGroup>,
}

/// The created person.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PersonCreated {
    /// The person's id (used in every `/v1/persons/{id}/...` path).
    pub id: u64,
    /// Name.
    pub name: String,
    /// Mode.
    pub mode: Mode,
    /// Zone.
    pub tz: String,
    /// Day 1, when given.
    pub first_day: Option<String>,
}

/// `PUT /v1/persons/{id}/bounds` (admin): the new bounds replace the old.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct BoundsBody {
    /// The bounds.
    pub bounds: Bounds,
}

/// One segment of a basal schedule.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct BasalSegment {
    /// Minute of the local day the segment starts (0-1439; the first is 0).
    pub start_minute: u32,
    /// Basal rate (U/h).
    pub units_per_hour: f64,
}

/// Carb ratios of the three meals (g/U).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct CarbRatios {
    /// Breakfast (g/U).
    pub breakfast: f64,
    /// Lunch (g/U).
    pub lunch: f64,
    /// Dinner (g/U).
    pub dinner: f64,
}

/// `POST /v1/persons/{id}/therapy` (admin): the clinician's change of
/// settings, in force from `at` whether or not a suggestion is open; what
/// it leaves out stays. At most one of `basal_units_per_hour` and
/// `basal_schedule`; at least one basal or `carb_ratios`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TherapyChangeBody {
    /// A flat basal rate (U/h).
    #[serde(default)]
    pub basal_units_per_hour: Option<f64>,
    /// A basal schedule (segments in order, the first from minute 0).
    #[serde(default)]
    pub basal_schedule: Option<Vec<BasalSegment>>,
    /// The carb ratios of the three meals.
    #[serde(default)]
    pub carb_ratios: Option<CarbRatios>,
    /// In force from (RFC 3339 with an offset; default: now; never in the
    /// future).
    #[serde(default)]
    pub at: Option<String>,
}

/// The change recorded, and what is in force after it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TherapyChanged {
    /// The person's id.
    pub person_id: u64,
    /// In force from (RFC 3339, UTC).
    pub at: String,
    /// The basal schedule the change put in force (none: unchanged).
    pub basal_schedule: Option<Vec<BasalSegment>>,
    /// The carb ratios it put in force (none: unchanged).
    pub carb_ratios: Option<CarbRatios>,
    /// The advisor's basal rate in force now (U/h; a schedule's mean).
    pub basal_in_force: f64,
    /// The advisor's carb ratios in force now.
    pub carb_ratios_in_force: CarbRatios,
    /// abba is research software, not a medical device.
    pub notice: String,
}

/// A token, shown once: only its SHA-256 hash is stored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TokenIssued {
    /// The token's id (to revoke it).
    pub token_id: u64,
    /// The bearer token (`abba_` + 64 hex digits: 256 random bits from the
    /// operating system's CSPRNG). Shown once.
    pub token: String,
    /// `admin` or `person`.
    pub role: String,
    /// The person it is for (person tokens).
    pub person_id: Option<u64>,
}

/// `DELETE /v1/tokens/{token_id}` (admin).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TokenRevoked {
    /// The token revoked.
    pub token_id: u64,
    /// Always true (revoking twice is fine).
    pub revoked: bool,
}
