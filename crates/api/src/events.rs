//! Device events the app posts, and the acknowledgement.

use crate::views::Suggestion;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// `POST /v1/persons/{id}/events`: a batch of device events.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct EventsBody {
    /// The events (1 to [`crate::MAX_EVENTS_PER_BATCH`]), in any order; the
    /// advisor sees them in order of (instant, seq).
    pub events: Vec<DeviceEvent>,
}

/// One device event with the app's own sequence number.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct DeviceEvent {
    /// The app's sequence number for this event (0 to 2^53 − 1), unique per
    /// person: the service stores each number once.
    pub seq: u64,
    /// When it happened: RFC 3339 with an offset.
    #[schema(format = DateTime, example = "2026-03-02T07:30:00+01:00")]
    pub at: String,
    /// What happened.
    pub event: EventBody,
}

/// A meal slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum MealSlot {
    /// Breakfast.
    Breakfast,
    /// Lunch.
    Lunch,
    /// Dinner.
    Dinner,
    /// A snack (never answered with a carb ratio).
    Snack,
}

/// A temporary basal's rate: absolute or a percentage of the scheduled rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum TempRate {
    /// An absolute rate (U/h).
    UnitsPerHour(f64),
    /// A percentage of the scheduled rate (100 = unchanged).
    Percent(f64),
}

/// What a device event says. `meal` (breakfast, lunch, dinner) and
/// `day_closed` are the only kinds that can produce an answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum EventBody {
    /// A CGM reading.
    Cgm {
        /// mg/dL.
        mg_dl: f64,
    },
    /// A meter (finger-stick) reading.
    Smbg {
        /// mg/dL.
        mg_dl: f64,
    },
    /// A meal announced with the carbohydrate the person estimated. A main
    /// meal is answered with the carb ratio to use for it.
    Meal {
        /// Grams of carbohydrate.
        carbs_g: f64,
        /// Which meal.
        slot: MealSlot,
    },
    /// A bolus delivered at once.
    Bolus {
        /// Insulin (U).
        units: f64,
    },
    /// An extended (square- or dual-wave) bolus.
    ExtendedBolus {
        /// All its insulin, the immediate part included (U).
        total_units: f64,
        /// The part delivered at once (U).
        immediate_units: f64,
        /// Minutes over which the rest is spread.
        duration_min: u32,
    },
    /// The scheduled basal rate in force from now on.
    BasalRate {
        /// U/h.
        units_per_hour: f64,
    },
    /// A temporary basal for a while (duration 0 cancels one).
    TempBasal {
        /// The rate meanwhile.
        rate: TempRate,
        /// Minutes.
        duration_min: u32,
    },
    /// Insulin delivery suspended.
    Suspend,
    /// Insulin delivery resumed.
    Resume,
    /// The day is over: posted right after the day's last meter reading
    /// (SMBG mode) or at the first event after local midnight (CGM mode).
    /// Answered with the basal rate for the new day. The service never
    /// closes a day by itself.
    DayClosed,
}

/// The acknowledgement of a batch, sent only after it was committed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct EventsAck {
    /// Every sequence number of the batch, ascending: each is now held.
    pub acked: Vec<u64>,
    /// How many of them were stored by this request.
    pub stored: u64,
    /// Those already held with the same payload (acknowledged again,
    /// nothing stored), ascending.
    pub repeated: Vec<u64>,
    /// Every suggestion the batch's events produced, in the advisor's
    /// order, each tagged with the `seq` of the event that produced it.
    /// Empty when nothing was decided.
    pub answers: Vec<Suggestion>,
}
