//! The devices of the simulated person: a CGM sensor, an SMBG (finger-stick)
//! meter and an insulin pump (protocol.md §5).
//!
//! * [`cgm`]: simglucose's CGM noise model (Johnson SU transform of a
//!   15-minute latent process, not-a-knot cubic interpolation) on
//!   subcutaneous glucose, 5-minute samples by default.
//! * [`meter`]: ISO 15197:2013-like finger-stick error on plasma glucose.
//! * [`pump`]: 0.05 U bolus steps (rounded down) delivered at up to
//!   1.5 U/min, 0.05 U/h basal steps, 30 U / 30 U/h limits, exact totals and
//!   a device event log.
//!
//! Each random device takes its own `u64` seed (derive it with
//! `abba_core::derive_seed(trial, patient, scenario, Stream::CgmNoise)` or
//! `Stream::MeterNoise`), so the same seed gives the same readings.

pub mod cgm;
pub mod meter;
pub mod pump;
pub mod spline;
mod table;

pub use cgm::{CgmConfig, CgmSensor};
pub use meter::{MeterConfig, SmbgMeter};
pub use pump::{BasalOutcome, BolusOutcome, DeliveryTotals, Pump, PumpConfig};
