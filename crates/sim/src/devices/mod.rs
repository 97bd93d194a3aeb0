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

use crate::SimError;
use serde::{Deserialize, Serialize};

/// The devices a simulated person carries, each in the simulator's own
/// configuration type. The CGM's `sample_time_min` is the one place the CGM
/// period is set.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceSet {
    /// The CGM sensor (noise model, sample time, range).
    pub cgm: CgmConfig,
    /// The finger-stick meter.
    pub meter: MeterConfig,
    /// The insulin pump.
    pub pump: PumpConfig,
}

impl DeviceSet {
    /// Checks every device; the error names the device and the field.
    pub fn validate(&self) -> Result<(), SimError> {
        self.cgm.validate()?;
        self.meter.validate()?;
        self.pump.validate()
    }
}
