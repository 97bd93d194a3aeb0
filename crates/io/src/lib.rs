//! abba-io: real device data in and out.
//!
//! Readers for Nightscout (entries, treatments, profile JSON), Dexcom
//! Clarity CSV, LibreView CSV, Tidepool JSON and Excel (.xlsx), Medtronic
//! CareLink CSV and plain CSV turn exports
//! into one normalised [`Record`] stream (source, identity in the source,
//! UTC instant). Units are never guessed, every value is checked against a
//! plausibility limit, and every error names the file, the line, JSON
//! path or sheet and row, and the field. [`events::to_events`] is the one place where
//! records become the advisor's [`abba_core::Event`]s on its clock (days
//! from the person's first day, minutes of local time);
//! [`nightscout_out`] writes the other way.
//!
//! abba-io depends on abba-core only, never on the simulator. abba is
//! research software, not a medical device.

pub mod automation;
pub mod clock;
pub mod clocks;
pub mod coverage;
pub mod error;
pub mod events;
pub mod meals;
pub mod nightscout_out;
pub mod read;
pub mod record;
pub mod rescue;
pub mod therapy;
pub mod time;
pub mod units;

pub use error::{IoError, Location, Place};
pub use read::{read_all, read_files, Batch, Format, ReadOptions};
pub use record::{Glucose, Record, RecordKind, Source, SourceId};
pub use units::GlucoseUnit;
