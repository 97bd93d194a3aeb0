//! Insulin pump: quantised basal and bolus delivery with the limits of a
//! real pump (protocol.md §5).
//!
//! * Bolus: in steps of 0.05 U, **rounded down** (a pump never gives more
//!   than asked), at most 30 U per bolus, delivered at up to 1.5 U/min, so a
//!   4 U bolus reaches the patient as 1.5, 1.5 and 1.0 U over three minutes.
//!   A bolus requested while another is still being delivered queues behind
//!   it (the undelivered amounts add up; each request is capped on its own).
//! * Basal: a rate in steps of 0.05 U/h, rounded to the **nearest** step,
//!   ties to the even step (as a person programming the pump would pick the
//!   closest available rate; ties are resolved without bias, as
//!   `numpy.round` does), at most 30 U/h, delivered continuously (rate/60
//!   U each minute; the pulses of a real pump are not modelled). The rate is
//!   0 until set.
//! * Above a maximum the pump delivers the maximum and says so: every
//!   request returns an outcome ([`BolusOutcome`], [`BasalOutcome`]) with
//!   `capped` and `rounded` flags for the caller to log. Negative or
//!   non-finite requests are errors.
//! * Exactness: amounts are kept as whole numbers of increments (`u64`), so
//!   rounding and totals are exact and deterministic; a request is taken to
//!   be *on* a step when it is within 1e-9 (relative) of it, so a decimal
//!   0.15 U typed as the float 0.1499999… is 3 steps, not 2.
//! * The device log: the pump records [`Event`]s as a device history would:
//!   `Bolus(U)` when a bolus is programmed (with the amount it will deliver;
//!   delivery is never interrupted in this model) and `BasalRate(U/h)` each
//!   time a rate is set. Drain them with [`Pump::drain_events`].
//!
//! simglucose's pump (uva-padova-model.md §3) differs on purpose: it rounds
//! per-minute rates in pmol/min, so it has practically no quantisation.
//!
//! `pump_params.csv` (Cozmo, Insulet) can be loaded with
//! [`PumpConfig::from_table`]. Its units are ambiguous (see
//! `data/uva-padova/README.md`): simglucose compares `max_bolus`/`max_basal`
//! with rates in U/min and applies the 0.05 increments to pmol/min. Here the
//! columns are read as the real pump units their names and values suggest:
//! `inc_bolus` in U, `max_bolus` in U per bolus, `inc_basal` and `max_basal`
//! in U/h. `min_bolus`/`min_basal` must be 0 (minimum doses are not
//! modelled) and `sample_time` is not used (the pump works per minute). The
//! table has no delivery speed; the protocol's 1.5 U/min is used.

use crate::devices::table::Table;
use crate::error::SimError;
use abba_core::units::MINUTES_PER_HOUR;
use abba_core::{Event, EventKind, Timestamp, Units, UnitsPerHour};
use serde::{Deserialize, Serialize};

/// The pump parameter table (simglucose's `pump_params.csv`).
const PUMP_TABLE: &str = include_str!("../../../../data/uva-padova/pump_params.csv");
/// Its file name, for error messages.
const PUMP_TABLE_NAME: &str = "data/uva-padova/pump_params.csv";
/// The columns of the pump table.
const PUMP_COLUMNS: &[&str] = &[
    "Name",
    "min_bolus",
    "max_bolus",
    "inc_bolus",
    "min_basal",
    "max_basal",
    "inc_basal",
    "sample_time",
];
/// Relative distance within which a number counts as a whole number of steps.
const SNAP: f64 = 1e-9;

/// The pump's increments, limits and delivery speed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PumpConfig {
    /// A label for messages.
    pub name: String,
    /// Bolus step, U (must be 1/n U for a whole n; default 0.05).
    pub bolus_increment_u: f64,
    /// Basal step, U/h (must be 1/n U/h for a whole n; default 0.05).
    pub basal_increment_u_per_h: f64,
    /// Largest bolus, U (a multiple of the bolus step; default 30).
    pub max_bolus_u: f64,
    /// Largest basal rate, U/h (a multiple of the basal step; default 30).
    pub max_basal_u_per_h: f64,
    /// Bolus delivery speed, U/min (a multiple of the bolus step; default 1.5).
    pub bolus_speed_u_per_min: f64,
}

impl Default for PumpConfig {
    /// The protocol's pump (protocol.md §5).
    fn default() -> Self {
        Self {
            name: "protocol".into(),
            bolus_increment_u: 0.05,
            basal_increment_u_per_h: 0.05,
            max_bolus_u: 30.0,
            max_basal_u_per_h: 30.0,
            bolus_speed_u_per_min: 1.5,
        }
    }
}

/// The configuration as whole numbers of increments.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Steps {
    /// Bolus steps per unit.
    bolus_per_u: u64,
    /// Basal steps per U/h.
    basal_per_u_per_h: u64,
    /// Largest bolus, in steps.
    max_bolus: u64,
    /// Largest basal rate, in steps.
    max_basal: u64,
    /// Bolus steps delivered per minute at most.
    bolus_per_min: u64,
}

/// `x` as a whole number if it is within [`SNAP`] (relative) of one.
fn whole(x: f64) -> Option<u64> {
    let n = x.round();
    (x.is_finite() && n >= 0.0 && n < u64::MAX as f64 && (x - n).abs() <= SNAP * n.max(1.0))
        .then_some(n as u64)
}

impl PumpConfig {
    /// The pump named `name` in `pump_params.csv` (Cozmo, Insulet), read in
    /// real pump units (see the module docs), with the protocol's delivery
    /// speed.
    pub fn from_table(name: &str) -> Result<Self, SimError> {
        let table = Table::parse(PUMP_TABLE_NAME, PUMP_TABLE, PUMP_COLUMNS)?;
        let row = table.row(name, "pump")?;
        for column in ["min_bolus", "min_basal"] {
            let v = row.number(column)?;
            if v != 0.0 {
                return Err(row.invalid(column, v, "0 (minimum doses are not modelled)"));
            }
        }
        let config = Self {
            name: name.to_owned(),
            bolus_increment_u: row.number("inc_bolus")?,
            basal_increment_u_per_h: row.number("inc_basal")?,
            max_bolus_u: row.number("max_bolus")?,
            max_basal_u_per_h: row.number("max_basal")?,
            bolus_speed_u_per_min: PumpConfig::default().bolus_speed_u_per_min,
        };
        config.steps().map_err(|e| SimError::Table {
            table: row.table_name().to_owned(),
            line: row.line(),
            reason: e.to_string(),
        })?;
        Ok(config)
    }

    /// The names of the pumps in `pump_params.csv`.
    pub fn table_names() -> Result<Vec<String>, SimError> {
        let table = Table::parse(PUMP_TABLE_NAME, PUMP_TABLE, PUMP_COLUMNS)?;
        Ok(table.names().into_iter().map(str::to_owned).collect())
    }

    /// Checks every field; the error names the field and what was expected.
    pub fn validate(&self) -> Result<(), SimError> {
        self.steps().map(|_| ())
    }

    fn steps(&self) -> Result<Steps, SimError> {
        let bad = |field: &str, value: f64, expected: &str| {
            SimError::Config(format!(
                "pump '{}': {field} = {value}, expected {expected}",
                self.name
            ))
        };
        let per = |field: &str, inc: f64, unit: &str| {
            if !(inc.is_finite() && inc > 0.0) {
                return Err(bad(field, inc, &format!("a positive step in {unit}")));
            }
            whole(1.0 / inc).filter(|&n| n >= 1).ok_or_else(|| {
                bad(
                    field,
                    inc,
                    &format!("1/n {unit} for a whole n (e.g. 0.1, 0.05, 0.025)"),
                )
            })
        };
        let bolus_per_u = per("bolus_increment_u", self.bolus_increment_u, "U")?;
        let basal_per_u_per_h = per(
            "basal_increment_u_per_h",
            self.basal_increment_u_per_h,
            "U/h",
        )?;
        let multiple = |field: &str, value: f64, per: u64, step: f64| {
            whole(value * per as f64)
                .filter(|&n| value > 0.0 && n >= 1)
                .ok_or_else(|| bad(field, value, &format!("a positive multiple of {step}")))
        };
        Ok(Steps {
            bolus_per_u,
            basal_per_u_per_h,
            max_bolus: multiple(
                "max_bolus_u",
                self.max_bolus_u,
                bolus_per_u,
                self.bolus_increment_u,
            )?,
            max_basal: multiple(
                "max_basal_u_per_h",
                self.max_basal_u_per_h,
                basal_per_u_per_h,
                self.basal_increment_u_per_h,
            )?,
            bolus_per_min: multiple(
                "bolus_speed_u_per_min",
                self.bolus_speed_u_per_min,
                bolus_per_u,
                self.bolus_increment_u,
            )?,
        })
    }
}

/// What the pump made of a bolus request.
#[must_use = "a capped or rounded bolus should be logged"]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BolusOutcome {
    /// What was asked for.
    pub requested: Units,
    /// What the pump will deliver (rounded down to the step, capped).
    pub programmed: Units,
    /// The request was above the maximum bolus; the maximum is delivered.
    pub capped: bool,
    /// The request was not a whole number of steps and was rounded down.
    pub rounded: bool,
}

/// What the pump made of a basal-rate request.
#[must_use = "a capped or rounded basal rate should be logged"]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BasalOutcome {
    /// What was asked for.
    pub requested: UnitsPerHour,
    /// The rate now in force (nearest step, capped).
    pub set: UnitsPerHour,
    /// The request was above the maximum rate; the maximum is in force.
    pub capped: bool,
    /// The request was not a whole number of steps and was rounded.
    pub rounded: bool,
}

/// Insulin delivered so far, split by kind.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DeliveryTotals {
    /// Bolus insulin delivered.
    pub bolus: Units,
    /// Basal insulin delivered.
    pub basal: Units,
}

impl DeliveryTotals {
    /// Basal plus bolus.
    pub fn total(&self) -> Units {
        Units(self.bolus.0 + self.basal.0)
    }
}

/// How a request is rounded to the step grid.
#[derive(Debug, Clone, Copy)]
enum Rounding {
    Down,
    NearestTiesEven,
}

/// `requested` (in its unit) as a whole number of steps (`per` steps per
/// unit), capped at `max` steps: (steps, capped, rounded).
fn quantise(requested: f64, per: u64, max: u64, rounding: Rounding) -> (u64, bool, bool) {
    let x = requested * per as f64;
    if let Some(n) = whole(x) {
        return if n > max {
            (max, true, false)
        } else {
            (n, false, false)
        };
    }
    if x > max as f64 {
        return (max, true, true);
    }
    let floor = x.floor();
    let n = match rounding {
        Rounding::Down => floor,
        Rounding::NearestTiesEven => {
            if (x - floor - 0.5).abs() <= SNAP * x.max(1.0) {
                if floor % 2.0 == 0.0 {
                    floor
                } else {
                    floor + 1.0
                }
            } else {
                x.round()
            }
        }
    };
    // n <= max here: x <= max and max is whole.
    (n as u64, false, true)
}

/// An insulin pump with its own clock and device log.
///
/// Per simulated minute: first apply the person's requests
/// ([`set_basal`](Self::set_basal), [`request_bolus`](Self::request_bolus);
/// they are logged at [`now`](Self::now)), then call
/// [`insulin_for_minute`](Self::insulin_for_minute) once for the insulin
/// rate over that minute (a bolus programmed at minute t starts at t).
///
/// ```
/// use abba_core::{Timestamp, Units, UnitsPerHour};
/// use abba_sim::devices::pump::{Pump, PumpConfig};
/// let mut pump = Pump::new(PumpConfig::default(), Timestamp(0))?;
/// let _ = pump.set_basal(UnitsPerHour(0.6))?;
/// let outcome = pump.request_bolus(Units(4.03))?;
/// assert_eq!(outcome.programmed, Units(4.0));
/// let first = pump.insulin_for_minute(); // U/min over minute 0
/// assert!((first - (0.01 + 1.5)).abs() < 1e-12);
/// # Ok::<(), abba_sim::SimError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Pump {
    config: PumpConfig,
    steps: Steps,
    now: Timestamp,
    basal_steps: u64,
    /// `basal_steps` as U/h and as U/min, computed once per change of the
    /// rate (the same divisions `insulin_for_minute` would do each minute).
    basal_u_per_h: f64,
    basal_u_per_min: f64,
    pending_bolus_steps: u64,
    delivered_bolus_steps: u64,
    /// Sum over elapsed minutes of the basal rate in steps (U/h steps × min).
    delivered_basal_step_minutes: u64,
    events: Vec<Event>,
}

impl Pump {
    /// A pump whose clock starts at `start`, with basal 0 and no bolus.
    pub fn new(config: PumpConfig, start: Timestamp) -> Result<Self, SimError> {
        let steps = config.steps()?;
        Ok(Self {
            config,
            steps,
            now: start,
            basal_steps: 0,
            basal_u_per_h: 0.0,
            basal_u_per_min: 0.0,
            pending_bolus_steps: 0,
            delivered_bolus_steps: 0,
            delivered_basal_step_minutes: 0,
            events: Vec::with_capacity(16),
        })
    }

    /// The pump's configuration.
    pub fn config(&self) -> &PumpConfig {
        &self.config
    }

    /// The pump's clock: the minute the next [`insulin_for_minute`](Self::insulin_for_minute) covers.
    pub fn now(&self) -> Timestamp {
        self.now
    }

    fn check(&self, what: &str, value: f64, unit: &str) -> Result<(), SimError> {
        if value.is_finite() && value >= 0.0 {
            Ok(())
        } else {
            Err(SimError::DeviceInput {
                device: format!("pump '{}'", self.config.name),
                reason: format!("{what} of {value} {unit}; expected a finite amount >= 0"),
            })
        }
    }

    /// Sets the basal rate in force from now on (nearest 0.05 U/h step, ties
    /// to even; capped at the maximum) and logs it.
    pub fn set_basal(&mut self, rate: UnitsPerHour) -> Result<BasalOutcome, SimError> {
        self.check("basal rate", rate.0, "U/h")?;
        let (n, capped, rounded) = quantise(
            rate.0,
            self.steps.basal_per_u_per_h,
            self.steps.max_basal,
            Rounding::NearestTiesEven,
        );
        self.basal_steps = n;
        self.basal_u_per_h = n as f64 / self.steps.basal_per_u_per_h as f64;
        self.basal_u_per_min = n as f64 / (self.steps.basal_per_u_per_h as f64 * MINUTES_PER_HOUR);
        let set = self.basal_rate();
        self.events
            .push(Event::new(self.now, EventKind::BasalRate(set)));
        Ok(BasalOutcome {
            requested: rate,
            set,
            capped,
            rounded,
        })
    }

    /// Programs a bolus (rounded down to the 0.05 U step, capped at the
    /// maximum), queued behind any bolus still being delivered, and logs it
    /// if it is not zero.
    pub fn request_bolus(&mut self, amount: Units) -> Result<BolusOutcome, SimError> {
        self.check("bolus", amount.0, "U")?;
        let (n, capped, rounded) = quantise(
            amount.0,
            self.steps.bolus_per_u,
            self.steps.max_bolus,
            Rounding::Down,
        );
        let programmed = Units(n as f64 / self.steps.bolus_per_u as f64);
        if n > 0 {
            self.pending_bolus_steps += n;
            self.events
                .push(Event::new(self.now, EventKind::Bolus(programmed)));
        }
        Ok(BolusOutcome {
            requested: amount,
            programmed,
            capped,
            rounded,
        })
    }

    /// Delivers one minute and advances the clock: returns the insulin rate
    /// (U/min) to infuse over this minute, basal/60 plus the part of the
    /// queued bolus given this minute (at most the delivery speed).
    #[inline]
    pub fn insulin_for_minute(&mut self) -> f64 {
        let bolus_steps = self.pending_bolus_steps.min(self.steps.bolus_per_min);
        self.pending_bolus_steps -= bolus_steps;
        self.delivered_bolus_steps += bolus_steps;
        self.delivered_basal_step_minutes += self.basal_steps;
        self.now = self.now.plus(1);
        if bolus_steps == 0 {
            // basal + 0/n: adding +0.0 to a rate >= 0 changes no bit.
            return self.basal_u_per_min;
        }
        self.basal_u_per_min + bolus_steps as f64 / self.steps.bolus_per_u as f64
    }

    /// The basal rate in force.
    pub fn basal_rate(&self) -> UnitsPerHour {
        UnitsPerHour(self.basal_u_per_h)
    }

    /// Bolus insulin programmed but not yet delivered.
    pub fn pending_bolus(&self) -> Units {
        Units(self.pending_bolus_steps as f64 / self.steps.bolus_per_u as f64)
    }

    /// Whether a bolus is still being delivered.
    pub fn bolus_in_progress(&self) -> bool {
        self.pending_bolus_steps > 0
    }

    /// Insulin delivered since the pump was created (exact: each total is
    /// one division of whole numbers). Difference two snapshots for a
    /// day's total daily insulin.
    pub fn totals(&self) -> DeliveryTotals {
        DeliveryTotals {
            bolus: Units(self.delivered_bolus_steps as f64 / self.steps.bolus_per_u as f64),
            basal: Units(
                self.delivered_basal_step_minutes as f64
                    / (self.steps.basal_per_u_per_h as f64 * MINUTES_PER_HOUR),
            ),
        }
    }

    /// The logged events not yet drained, oldest first.
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// Takes the logged events out, oldest first (the log keeps its capacity).
    pub fn drain_events(&mut self) -> std::vec::Drain<'_, Event> {
        self.events.drain(..)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn whole_snaps_only_near_integers() {
        assert_eq!(whole(3.0000000000000004), Some(3));
        assert_eq!(whole(2.9999999999999996), Some(3));
        assert_eq!(whole(2.5), None);
        assert_eq!(whole(-1.0), None);
        assert_eq!(whole(f64::NAN), None);
    }

    #[test]
    fn quantise_rounds_as_documented() {
        use Rounding::*;
        assert_eq!(quantise(0.15, 20, 600, Down), (3, false, false));
        assert_eq!(quantise(0.19, 20, 600, Down), (3, false, true));
        assert_eq!(quantise(0.19, 20, 600, NearestTiesEven), (4, false, true));
        // 0.125 U/h = 2.5 steps -> 2 (even); 0.175 = 3.5 steps -> 4.
        assert_eq!(quantise(0.125, 20, 600, NearestTiesEven), (2, false, true));
        assert_eq!(quantise(0.175, 20, 600, NearestTiesEven), (4, false, true));
        assert_eq!(quantise(30.03, 20, 600, Down), (600, true, true));
        assert_eq!(quantise(31.0, 20, 600, Down), (600, true, false));
        assert_eq!(quantise(1e300, 20, 600, Down), (600, true, true));
    }

    #[test]
    fn table_pumps_load_in_pump_units() {
        assert_eq!(PumpConfig::table_names().unwrap(), vec!["Cozmo", "Insulet"]);
        let c = PumpConfig::from_table("Cozmo").unwrap();
        assert_eq!((c.max_bolus_u, c.max_basal_u_per_h), (75.0, 35.0));
        let i = PumpConfig::from_table("Insulet").unwrap();
        assert_eq!(
            (i.max_bolus_u, i.max_basal_u_per_h, i.bolus_increment_u),
            (30.0, 30.0, 0.05)
        );
        let e = PumpConfig::from_table("Tandem").unwrap_err().to_string();
        assert!(e.contains("Tandem") && e.contains("Cozmo, Insulet"), "{e}");
    }
}
