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
///
/// Read through [`wire`]: a value of the wrong type inside an event is
/// reported with the field's name (serde reads an internally tagged enum
/// whole, so a path would stop at the event).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(
    tag = "type",
    rename_all = "snake_case",
    deny_unknown_fields,
    try_from = "serde_json::Map<String, serde_json::Value>"
)]
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
    /// The notice: abba is research software, not a medical device (the
    /// acknowledgement may carry suggestions).
    pub notice: String,
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

/// Reading an [`EventBody`] kind by kind, so that an error names the field.
mod wire {
    use super::{EventBody, MealSlot, TempRate};
    use serde::de::DeserializeOwned;
    use serde::Deserialize;
    use serde_json::{Map, Value};

    /// The kinds, as `type` names them.
    const KINDS: &[&str] = &[
        "cgm",
        "smbg",
        "meal",
        "bolus",
        "extended_bolus",
        "basal_rate",
        "temp_basal",
        "suspend",
        "resume",
        "day_closed",
    ];

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Glucose {
        mg_dl: f64,
    }
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Meal {
        carbs_g: f64,
        slot: MealSlot,
    }
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Bolus {
        units: f64,
    }
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct ExtendedBolus {
        total_units: f64,
        immediate_units: f64,
        duration_min: u32,
    }
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct BasalRate {
        units_per_hour: f64,
    }
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct TempBasal {
        rate: TempRate,
        duration_min: u32,
    }
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Nothing {}

    /// The fields of one kind, the error prefixed with the field's path.
    fn fields<T: DeserializeOwned>(rest: Map<String, Value>) -> Result<T, String> {
        serde_path_to_error::deserialize(Value::Object(rest)).map_err(|e| {
            let path = e.path().to_string();
            let inner = e.into_inner().to_string();
            if path == "." {
                inner
            } else {
                format!("{path}: {inner}")
            }
        })
    }

    impl TryFrom<Map<String, Value>> for EventBody {
        type Error = String;

        fn try_from(mut m: Map<String, Value>) -> Result<Self, String> {
            let kind = match m.remove("type") {
                Some(Value::String(s)) => s,
                Some(other) => return Err(format!("type: expected a string, got {other}")),
                None => return Err("missing field `type`".into()),
            };
            Ok(match kind.as_str() {
                "cgm" => EventBody::Cgm {
                    mg_dl: fields::<Glucose>(m)?.mg_dl,
                },
                "smbg" => EventBody::Smbg {
                    mg_dl: fields::<Glucose>(m)?.mg_dl,
                },
                "meal" => {
                    let f: Meal = fields(m)?;
                    EventBody::Meal {
                        carbs_g: f.carbs_g,
                        slot: f.slot,
                    }
                }
                "bolus" => EventBody::Bolus {
                    units: fields::<Bolus>(m)?.units,
                },
                "extended_bolus" => {
                    let f: ExtendedBolus = fields(m)?;
                    EventBody::ExtendedBolus {
                        total_units: f.total_units,
                        immediate_units: f.immediate_units,
                        duration_min: f.duration_min,
                    }
                }
                "basal_rate" => EventBody::BasalRate {
                    units_per_hour: fields::<BasalRate>(m)?.units_per_hour,
                },
                "temp_basal" => {
                    let f: TempBasal = fields(m)?;
                    EventBody::TempBasal {
                        rate: f.rate,
                        duration_min: f.duration_min,
                    }
                }
                "suspend" => fields::<Nothing>(m).map(|_| EventBody::Suspend)?,
                "resume" => fields::<Nothing>(m).map(|_| EventBody::Resume)?,
                "day_closed" => fields::<Nothing>(m).map(|_| EventBody::DayClosed)?,
                other => {
                    return Err(format!(
                        "type: unknown kind `{other}`, expected one of {}",
                        KINDS.join(", ")
                    ))
                }
            })
        }
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        /// Every kind written by the derived serialiser reads back the same
        /// (the per-kind structs mirror the enum), and an error inside an
        /// event names its field.
        #[test]
        #[allow(clippy::unwrap_used)]
        fn every_kind_round_trips_and_errors_name_the_field() {
            let all = [
                EventBody::Cgm { mg_dl: 100.0 },
                EventBody::Smbg { mg_dl: 90.0 },
                EventBody::Meal {
                    carbs_g: 50.0,
                    slot: MealSlot::Lunch,
                },
                EventBody::Bolus { units: 3.5 },
                EventBody::ExtendedBolus {
                    total_units: 4.0,
                    immediate_units: 1.0,
                    duration_min: 120,
                },
                EventBody::BasalRate {
                    units_per_hour: 0.85,
                },
                EventBody::TempBasal {
                    rate: TempRate::Percent(50.0),
                    duration_min: 30,
                },
                EventBody::Suspend,
                EventBody::Resume,
                EventBody::DayClosed,
            ];
            assert_eq!(all.len(), KINDS.len());
            for e in all {
                let text = serde_json::to_string(&e).unwrap();
                let back: EventBody = serde_json::from_str(&text).unwrap();
                assert_eq!(back, e, "{text}");
            }
            let err = |s: &str| {
                serde_json::from_str::<EventBody>(s)
                    .unwrap_err()
                    .to_string()
            };
            assert!(err(r#"{"type":"cgm","mg_dl":"x"}"#).starts_with("mg_dl: invalid type"));
            assert!(err(r#"{"type":"meal","carbs_g":5,"slot":"brunch"}"#)
                .starts_with("slot: unknown variant"));
            assert!(
                err(r#"{"type":"temp_basal","rate":{"percent":"x"},"duration_min":5}"#)
                    .starts_with("rate.percent: invalid type")
            );
            assert!(
                err(r#"{"type":"bolus","units":1,"extra":2}"#).contains("unknown field `extra`")
            );
            assert!(err(r#"{"type":"suspend","units":1}"#).contains("unknown field `units`"));
            assert!(err(r#"{"type":"coffee"}"#).contains("unknown kind `coffee`"));
            assert!(err(r#"{"mg_dl":5}"#).contains("missing field `type`"));
            assert!(err(r#"{"type":"cgm"}"#).contains("missing field `mg_dl`"));
        }
    }
}
