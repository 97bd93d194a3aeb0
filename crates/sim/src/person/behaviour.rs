//! How the simulated person behaves: when their app talks to the advisor,
//! when their day closes, and what they do with the advisor's suggestions.
//!
//! Extension points (each a field here and one hook in
//! [`VirtualPerson`](super::VirtualPerson), so new behaviour needs no
//! restructuring):
//! - answers to suggestions: [`SuggestionResponse`], applied in
//!   `VirtualPerson::suggest` (today: accept everything, as in the paper);
//!   reject / override variants go here;
//! - reactions to readings (for example rescue carbohydrate when a reading
//!   is below a threshold, re-checked later): a new optional field, applied
//!   in the readings hook `VirtualPerson::react_to_readings`, which sees
//!   every reading of the minute and may add carbohydrate to the eating
//!   queue or schedule extra finger sticks.

use serde::{Deserialize, Serialize};

/// When the person's app tells the advisor that a day is over.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DayClosing {
    /// Right after the bedtime finger stick (the advisor adapts from SMBG).
    AfterBedtimeReading,
    /// At 00:00 of the next day (the advisor adapts from CGM).
    AtMidnight,
}

/// What the person does with settings the advisor suggests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum SuggestionResponse {
    /// Takes every suggestion at once: the new basal rate goes to the pump
    /// the same minute, new carb ratios are used from the next bolus on.
    AcceptAll,
}

/// The person's behaviour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Behaviour {
    /// The 1-based day from which the person uses the advisor app: their
    /// devices' events from 00:00 of that day on go to the advisor (the
    /// trial: 2, as D1 is warm-up). Before it they follow their starting
    /// therapy.
    pub app_from_day: u32,
    /// When the app closes a day (from the app's first day on).
    pub day_closing: DayClosing,
    /// What the person does with suggestions.
    pub suggestions: SuggestionResponse,
}

impl Behaviour {
    /// The paper's person: uses the app from D2, accepts every suggestion,
    /// and closes days as the advisor's mode needs.
    pub fn paper(day_closing: DayClosing) -> Self {
        Self {
            app_from_day: 2,
            day_closing,
            suggestions: SuggestionResponse::AcceptAll,
        }
    }
}
