//! The ABBA adaptive basal-bolus advisor and its baselines.
//!
//! ABBA (Sun et al., IEEE JBHI 2019; `shared/spec/abba-algorithm.md`) adapts
//! one flat basal rate (U/h) and three carb ratios (g/U) once a day with four
//! actor-critic agents plus supervisory safety rules, initialised by transfer
//! entropy from one week of CGM and pump data. The advisor sees only device
//! [`Event`]s, so the same code runs on simulated and on real data; it does not
//! depend on the simulator.
//!
//! ```
//! use abba_advisor::{Abba, AbbaConfig, Advisor, Mode};
//! use abba_core::{Event, EventKind, GramsPerUnit, MgDl, Timestamp, TherapySettings, UnitsPerHour};
//! let start = TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(12.0)).unwrap();
//! let mut abba = Abba::new(AbbaConfig::new(Mode::Cgm, 42), start).unwrap();
//! let reading = Event::new(Timestamp::from_day_and_minute(1, 0), EventKind::Cgm(MgDl(140.0)));
//! assert_eq!(abba.observe(&reading).unwrap(), None); // not a decision point
//! // Bad input is rejected, never used:
//! let bad = Event::new(Timestamp::from_day_and_minute(0, 5), EventKind::Cgm(MgDl(140.0)));
//! assert!(abba.observe(&bad).is_err());
//! ```
//!
//! # Contract with the caller (the trial runner or a device bridge)
//!
//! - Feed events in chronological order through [`Advisor::observe`]. An event
//!   earlier than one already accepted, a duplicate (an identical event at the
//!   same minute, a second reading of one kind at the same minute, a main meal
//!   announced twice or out of order in a day, a day closed twice), a
//!   non-finite or implausible value ([`EventLimits`]) or a timestamp outside
//!   `0..=limits.max_timestamp_min` returns an [`AdvisorError`] and leaves the
//!   advisor exactly as it was.
//! - Send `BasalRate` when the rate in force changes (an identical event at
//!   the same minute is a duplicate and is rejected; a different rate at the
//!   same minute replaces the previous one). `Bolus` is the insulin actually
//!   delivered; two identical boluses in one minute are rejected as a
//!   duplicate.
//! - Pump records beyond a plain basal and bolus (`TempBasal`, `Suspend`,
//!   `Resume`, `ExtendedBolus`; abba-core's `event` module says what each
//!   delivers) are checked against [`EventLimits`] and counted as delivered
//!   insulin in the transfer-entropy grid; `BasalRate` is the scheduled
//!   rate. An event kind this advisor does not know is rejected
//!   ([`AdvisorError::UnsupportedEvent`]), never silently ignored.
//! - Events at one minute: readings, then `MealAnnounced`, then `Bolus`,
//!   `BasalRate`, `DayClosed`. The carb-ratio update of meal i happens inside
//!   `observe(MealAnnounced)`, so read [`Advisor::settings`] *after* it returns
//!   to compute that meal's bolus.
//! - The first event's calendar day starts the initialisation week
//!   (`init_days` = 7 days; D2-D8 in the trial, which does not feed D1).
//!   Settings stay at the starting therapy; CGM readings, `Bolus` and
//!   `BasalRate` events fill the transfer-entropy grid (insulin per 5-min bin;
//!   the starting basal is assumed until the first `BasalRate` event). In SMBG
//!   mode send CGM readings during the initialisation week (and SMBG readings
//!   from its first day, so D8's windows exist).
//! - `DayClosed` closes the calendar day containing the minute before it: SMBG
//!   mode sends it right after the bedtime reading (23:00 of day k closes k),
//!   CGM mode at 00:00 of the next day (00:00 of k+1 closes k; the CGM reading
//!   at 00:00 of k+1 belongs to k+1). When the last initialisation day
//!   closes, TE is estimated from the grid collected so far (in SMBG mode the
//!   week therefore ends at D8's bedtime reading), θ0 is set, and the first
//!   basal update follows at once from that day's readings. [`InitReport`]
//!   (via [`Abba::init_report`] or [`AnyAdvisor::init_report`]) records TE,
//!   TE_n and θ0; if TE cannot be estimated (too little CGM), TE_n = 1 is used
//!   and the report says why. Then every `DayClosed` updates the basal
//!   rate and every main-meal announcement updates that meal's carb ratio from
//!   the previous day's window (announcement to the next main-meal
//!   announcement). A meal skipped yesterday means no update today (its
//!   window never existed; the previous window simply ran longer).
//! - `observe` returns `Some(settings)` at every decision point after the
//!   initialisation (even if the value did not move), `None` otherwise.
//! - Every decision point leaves a [`Decision`] explaining it (features, P_a,
//!   P_s, exploration draw, switch rule, clamp, old and new value; or why it
//!   was skipped). Drain them with [`Advisor::take_decisions`]; the log is
//!   bounded by `decision_log_capacity`.
//! - Determinism: decisions are a pure function of the events, the start
//!   therapy and the configuration (including `exploration_seed`). The state
//!   serialises with serde inside a versioned envelope ([`state`]:
//!   `save_json` / `load_json` on [`Abba`], [`FixedTherapy`], [`RunToRun`]
//!   and [`AnyAdvisor`]); a resumed advisor makes the same decisions, and a
//!   state of another format version is refused with a clear error.
//! - The TE reference `te.te_ref_bits` defaults to
//!   [`config::DEFAULT_TE_REF_BITS`] (uncalibrated); compute a cohort's
//!   first-week TE with [`te::first_week_te`] and set its median.
//! - Cost: `observe` on a reading does O(1) work with no allocation (windows
//!   are running accumulators); TE runs once per advisor.
//!
//! Types not in abba-core that the advisor defines: [`Parameter`] (which
//! setting a decision is about) and [`Mode`].

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod abba;
mod adapting;
pub mod agent;
pub mod any;
pub mod arm;
pub mod baselines;
pub mod bounds;
pub mod config;
pub mod data_rule;
pub mod decision;
pub mod error;
pub mod features;
pub mod fusion;
pub mod guard;
pub mod parameter;
pub mod recent_low;
mod rng;
pub mod state;
pub mod steps;
pub mod supervisor;
pub mod te;
pub mod windows;
pub mod words;

pub use abba::{Abba, InitReport, TeOutcome};
pub use any::{AdvisorSpec, AnyAdvisor};
pub use arm::ArmKind;
pub use baselines::autotune::{Autotune, AutotuneConfig};
pub use baselines::fixed::FixedTherapy;
pub use baselines::r2r::{R2rConfig, RunToRun};
pub use bounds::{BoundHeld, ClinicianBounds};
pub use config::{AbbaConfig, AgeGroup, CriticVariant, EventLimits, Mode};
pub use data_rule::MinData;
pub use decision::{Decision, DecisionDetail, SkipReason};
pub use error::AdvisorError;
pub use parameter::Parameter;
pub use state::STATE_FORMAT_VERSION;
pub use steps::PumpSteps;

use abba_core::{Event, TherapySettings};

/// An insulin-therapy advisor fed with device events.
pub trait Advisor {
    /// Feeds one device event. Returns the settings in force after it when the
    /// event is a decision point, `None` otherwise; a bad event returns an
    /// error and changes nothing.
    fn observe(&mut self, event: &Event) -> Result<Option<TherapySettings>, AdvisorError>;
    /// The settings in force now.
    fn settings(&self) -> &TherapySettings;
    /// Explanations of the decisions since the last [`Advisor::take_decisions`], oldest first.
    fn decisions(&self) -> &[Decision];
    /// Removes and returns the retained decisions.
    fn take_decisions(&mut self) -> Vec<Decision>;
    /// Which advisor this is (the trial arm it runs).
    fn arm(&self) -> ArmKind;
    /// The measurements it adapts from (`None` for an advisor that does not
    /// adapt, the standard therapy).
    fn mode(&self) -> Option<Mode>;
    /// The arm's name (`abba`, `standard`, `r2r`), as in every report; the
    /// mode is separate ([`Advisor::mode`]).
    fn name(&self) -> &'static str {
        self.arm().name()
    }
}
