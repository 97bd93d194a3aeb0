//! Self-monitoring blood glucose (finger-stick) meter.
//!
//! Error model (protocol.md §5), shaped after the accuracy criterion of
//! ISO 15197:2013 (95 % of results within ±15 mg/dL of the reference below
//! 100 mg/dL and within ±15 % from 100 mg/dL up): the error is normal with
//! mean 0 and SD 7.5 mg/dL below 100 mg/dL and SD 7.5 % of the true value
//! from 100 mg/dL up, so ±15 mg/dL / ±15 % is ±2 SD (95.4 % before rounding).
//! The reading is rounded to a whole mg/dL (half away from zero) and then
//! clipped to the meter's range [20, 600] mg/dL (a real meter shows "LO" /
//! "HI" outside it; here the limit value is returned).
//!
//! What is measured: **plasma glucose** (the model's Gp/Vg). A finger stick
//! samples capillary blood, which tracks plasma glucose without the
//! interstitial lag of a CGM, and meters report plasma-equivalent values;
//! the model has no separate capillary compartment, so plasma glucose is
//! the closest quantity. The SD is chosen from the true value (the
//! reference of the ISO criterion), not from the noisy reading.

use crate::error::SimError;
use abba_core::MgDl;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// The meter's error model and range.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeterConfig {
    /// Error SD below the threshold, mg/dL (default 7.5).
    pub sd_below_threshold_mg_dl: f64,
    /// Error SD from the threshold up, as a fraction of the true value
    /// (default 0.075, i.e. 7.5 %).
    pub sd_fraction_from_threshold: f64,
    /// Where the error model switches, mg/dL (default 100).
    pub threshold_mg_dl: f64,
    /// Lowest reading, mg/dL (default 20).
    pub min_mg_dl: f64,
    /// Highest reading, mg/dL (default 600).
    pub max_mg_dl: f64,
}

impl Default for MeterConfig {
    /// The protocol's meter (protocol.md §5).
    fn default() -> Self {
        Self {
            sd_below_threshold_mg_dl: 7.5,
            sd_fraction_from_threshold: 0.075,
            threshold_mg_dl: 100.0,
            min_mg_dl: 20.0,
            max_mg_dl: 600.0,
        }
    }
}

impl MeterConfig {
    /// Checks every field; the error names the field and what was expected.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |field: &str, value: f64, expected: &str| {
            Err(SimError::Config(format!(
                "SMBG meter: {field} = {value}, expected {expected}"
            )))
        };
        if !(self.sd_below_threshold_mg_dl.is_finite() && self.sd_below_threshold_mg_dl >= 0.0) {
            return bad(
                "sd_below_threshold_mg_dl",
                self.sd_below_threshold_mg_dl,
                "a finite number >= 0",
            );
        }
        if !(self.sd_fraction_from_threshold.is_finite() && self.sd_fraction_from_threshold >= 0.0)
        {
            return bad(
                "sd_fraction_from_threshold",
                self.sd_fraction_from_threshold,
                "a finite fraction >= 0 (0.075 means 7.5 %)",
            );
        }
        if !(self.threshold_mg_dl.is_finite() && self.threshold_mg_dl >= 0.0) {
            return bad(
                "threshold_mg_dl",
                self.threshold_mg_dl,
                "a finite number >= 0",
            );
        }
        if !(self.min_mg_dl.is_finite() && self.min_mg_dl >= 0.0) {
            return bad("min_mg_dl", self.min_mg_dl, "a finite number >= 0");
        }
        if !(self.max_mg_dl.is_finite() && self.max_mg_dl > self.min_mg_dl) {
            return bad(
                "max_mg_dl",
                self.max_mg_dl,
                "a finite number above min_mg_dl",
            );
        }
        Ok(())
    }

    /// The error SD (mg/dL) at true glucose `true_mg_dl`.
    pub fn sd_mg_dl(&self, true_mg_dl: f64) -> f64 {
        if true_mg_dl < self.threshold_mg_dl {
            self.sd_below_threshold_mg_dl
        } else {
            self.sd_fraction_from_threshold * true_mg_dl
        }
    }
}

/// A finger-stick meter with its own random stream.
///
/// ```
/// use abba_core::MgDl;
/// use abba_sim::devices::meter::{MeterConfig, SmbgMeter};
/// let mut meter = SmbgMeter::new(MeterConfig::default(), 7)?;
/// let r = meter.measure(MgDl(150.0))?;
/// assert_eq!(r.0, r.0.round());
/// # Ok::<(), abba_sim::SimError>(())
/// ```
#[derive(Debug, Clone)]
pub struct SmbgMeter {
    config: MeterConfig,
    rng: ChaCha8Rng,
}

impl SmbgMeter {
    /// A meter with error model `config`, seeded with `seed`.
    pub fn new(config: MeterConfig, seed: u64) -> Result<Self, SimError> {
        config.validate()?;
        Ok(Self {
            config,
            rng: ChaCha8Rng::seed_from_u64(seed),
        })
    }

    /// The meter's configuration.
    pub fn config(&self) -> &MeterConfig {
        &self.config
    }

    /// A reading of true plasma glucose `plasma`: rounded to 1 mg/dL and
    /// clipped to the meter's range. Negative or non-finite input is an error.
    pub fn measure(&mut self, plasma: MgDl) -> Result<MgDl, SimError> {
        let true_mg_dl = plasma.0;
        if !(true_mg_dl.is_finite() && true_mg_dl >= 0.0) {
            return Err(SimError::DeviceInput {
                device: "SMBG meter".into(),
                reason: format!(
                    "plasma glucose is {true_mg_dl} mg/dL, expected a finite value >= 0"
                ),
            });
        }
        let z: f64 = self.rng.sample(StandardNormal);
        let raw_mg_dl = true_mg_dl + z * self.config.sd_mg_dl(true_mg_dl);
        Ok(MgDl(
            raw_mg_dl
                .round()
                .clamp(self.config.min_mg_dl, self.config.max_mg_dl),
        ))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn sd_switches_at_the_threshold() {
        let c = MeterConfig::default();
        assert_eq!(c.sd_mg_dl(99.9), 7.5);
        assert_eq!(c.sd_mg_dl(100.0), 7.5);
        assert!((c.sd_mg_dl(200.0) - 15.0).abs() < 1e-12);
    }

    #[test]
    fn bad_config_and_input_are_errors() {
        let c = MeterConfig {
            max_mg_dl: 10.0,
            ..MeterConfig::default()
        };
        let e = SmbgMeter::new(c, 1).unwrap_err().to_string();
        assert!(e.contains("max_mg_dl"), "{e}");
        let mut m = SmbgMeter::new(MeterConfig::default(), 1).unwrap();
        assert!(m.measure(MgDl(-1.0)).is_err());
        assert!(m.measure(MgDl(f64::INFINITY)).is_err());
    }
}
