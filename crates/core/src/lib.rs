//! Shared vocabulary of abba: units, simulated time, the device event log,
//! therapy settings and glucose metrics.
//!
//! Everything that crosses the line between a person (real or simulated) and
//! the advisor is an [`Event`]. The simulator produces them, a real device
//! export produces them, and the advisor consumes them.
//!
//! ```
//! use abba_core::{Event, EventKind, MgDl, Timestamp};
//! let reading = Event::new(Timestamp::from_day_and_minute(1, 7 * 60), EventKind::Cgm(MgDl(142.0)));
//! assert_eq!(reading.at.minute_of_day(), 420);
//! assert_eq!(reading.at.day_number(), 2);
//! ```

pub mod error;
pub mod event;
pub mod limits;
pub mod metrics;
pub mod named;
pub mod scenario;
pub mod seed;
pub mod text;
pub mod therapy;
pub mod time;
pub mod units;

pub use error::CoreError;
pub use event::{Event, EventKind, SettingValue, TempBasalRate};
pub use metrics::Metric;
pub use named::Named;
pub use scenario::ScenarioId;
pub use seed::{derive_seed, Stream};
pub use therapy::{MealSlot, TherapySettings};
pub use time::{Timestamp, MINUTES_PER_DAY};
pub use units::{Grams, GramsPerUnit, MgDl, Units, UnitsPerHour, PMOL_PER_UNIT};
