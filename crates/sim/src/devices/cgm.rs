//! Continuous glucose monitor: simglucose's CGM noise model, reimplemented.
//!
//! The model (simglucose `sensor/noise_gen.py`, `sensor/cgm.py`; described
//! in our own words in `uva-padova-model.md` §2; the noise model itself is
//! from Breton & Kovatchev, J Diabetes Sci Technol 2008, "Analysis,
//! modeling, and simulation of the accuracy of continuous glucose sensors"):
//!
//! 1. a latent process on a 15-minute grid, e_0 = w_0 and
//!    e_k = PACF·(e_{k−1} + w_k) with w_k i.i.d. N(0, 1) (PACF multiplies the
//!    innovation too; the stationary variance is PACF²/(1 − PACF²));
//! 2. the Johnson SU transform η_k = ξ + λ·sinh((e_k − γ)/δ), in mg/dL;
//! 3. interpolation to the sample grid in batches of 11 knots (the last η of
//!    the previous batch and 10 new ones, at 0, 15, …, 150 min) with the
//!    not-a-knot cubic spline, evaluated at sample_time, 2·sample_time, …,
//!    150 min (the value at 0 is the previous batch's last one and is not
//!    repeated);
//! 4. reading = clip(Gs + ε, min, max), where Gs is the *subcutaneous*
//!    glucose in mg/dL.
//!
//! Choices and differences from simglucose:
//!
//! * The random numbers come from `ChaCha8Rng` seeded with the sensor's own
//!   `u64` seed (normal draws: `rand_distr::StandardNormal`), not numpy's
//!   Mersenne Twister, so the sequences differ from simglucose's while the
//!   model is the same. The same seed gives the same readings.
//! * `sample_time` must divide 150 min (so every batch fills whole samples
//!   and the grid never drifts); simglucose silently shifts the grid
//!   otherwise.
//! * Readings are not rounded (simglucose does not round; the protocol does
//!   not ask for it).
//! * simglucose's environment measures twice at t = 0 (one value goes to the
//!   history, the next is the observation); here each call to
//!   [`CgmSensor::read`] consumes exactly one noise sample.
//! * There is no calibration error, drift or extra lag: Gs already lags
//!   plasma glucose in the patient model.

use crate::devices::spline::{NotAKnotWeights, KNOTS};
use crate::devices::table::Table;
use crate::error::SimError;
use abba_core::{MgDl, Timestamp};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};
use std::sync::{Arc, Mutex, OnceLock};

/// The sensor parameter table (simglucose's `sensor_params.csv`).
const SENSOR_TABLE: &str = include_str!("../../../../data/uva-padova/sensor_params.csv");
/// Its file name, for error messages.
const SENSOR_TABLE_NAME: &str = "data/uva-padova/sensor_params.csv";
/// The columns of the sensor table.
const SENSOR_COLUMNS: &[&str] = &[
    "Name",
    "PACF",
    "gamma",
    "lambda",
    "delta",
    "xi",
    "sample_time",
    "min",
    "max",
];

/// Spacing of the latent noise process, in minutes.
pub const LATENT_STEP_MIN: u32 = 15;
/// Length of one interpolation batch: 10 latent steps, in minutes.
pub const BATCH_MIN: u32 = LATENT_STEP_MIN * (KNOTS as u32 - 1);
/// The protocol's CGM sample time (protocol.md §5), in minutes.
pub const PROTOCOL_SAMPLE_TIME_MIN: u32 = 5;

/// The Johnson SU transform η = ξ + λ·sinh((e − γ)/δ) that turns the
/// latent normal process into the sensor error in mg/dL.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JohnsonSu {
    /// γ, shape (dimensionless); γ < 0 makes the error right-skewed.
    pub gamma: f64,
    /// λ, scale in mg/dL (> 0).
    pub lambda_mg_dl: f64,
    /// δ, shape (dimensionless, > 0).
    pub delta: f64,
    /// ξ, location in mg/dL.
    pub xi_mg_dl: f64,
}

impl JohnsonSu {
    /// The transformed value, in mg/dL, of the latent value `e`.
    #[inline]
    pub fn transform(&self, e: f64) -> f64 {
        self.xi_mg_dl + self.lambda_mg_dl * ((e - self.gamma) / self.delta).sinh()
    }
}

/// Everything that defines a CGM sensor model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CgmConfig {
    /// Model name (a row of `sensor_params.csv`, or a user's label).
    pub name: String,
    /// Coefficient of the latent 15-minute process, in (−1, 1).
    pub pacf: f64,
    /// The Johnson SU transform.
    pub johnson: JohnsonSu,
    /// Minutes between readings; must divide 150.
    pub sample_time_min: u32,
    /// Lowest reading the sensor reports, mg/dL.
    pub min_mg_dl: f64,
    /// Highest reading the sensor reports, mg/dL.
    pub max_mg_dl: f64,
}

impl Default for CgmConfig {
    /// The protocol's CGM, [`CgmConfig::protocol`] (the GuardianRT row of
    /// `sensor_params.csv` at 5 minutes), written out so that it cannot
    /// fail; a test checks that it equals the table's row.
    fn default() -> Self {
        Self {
            name: "GuardianRT".to_owned(),
            pacf: 0.7,
            johnson: JohnsonSu {
                gamma: -0.5444,
                lambda_mg_dl: 15.9574,
                delta: 1.6898,
                xi_mg_dl: -5.47,
            },
            sample_time_min: PROTOCOL_SAMPLE_TIME_MIN,
            min_mg_dl: 39.0,
            max_mg_dl: 600.0,
        }
    }
}

impl CgmConfig {
    /// The sensor named `name` in `sensor_params.csv` (Dexcom, GuardianRT,
    /// Navigator), with its own sample time.
    pub fn from_table(name: &str) -> Result<Self, SimError> {
        let table = Table::parse(SENSOR_TABLE_NAME, SENSOR_TABLE, SENSOR_COLUMNS)?;
        let row = table.row(name, "CGM sensor")?;
        let sample_time = row.number("sample_time")?;
        if !(sample_time >= 1.0 && sample_time.fract() == 0.0 && sample_time <= BATCH_MIN as f64) {
            return Err(row.invalid(
                "sample_time",
                sample_time,
                "a whole number of minutes between 1 and 150",
            ));
        }
        let config = Self {
            name: name.to_owned(),
            pacf: row.number("PACF")?,
            johnson: JohnsonSu {
                gamma: row.number("gamma")?,
                lambda_mg_dl: row.number("lambda")?,
                delta: row.number("delta")?,
                xi_mg_dl: row.number("xi")?,
            },
            sample_time_min: sample_time as u32,
            min_mg_dl: row.number("min")?,
            max_mg_dl: row.number("max")?,
        };
        config.validate().map_err(|e| SimError::Table {
            table: row.table_name().to_owned(),
            line: row.line(),
            reason: e.to_string(),
        })?;
        Ok(config)
    }

    /// The names of the sensors in `sensor_params.csv`.
    pub fn table_names() -> Result<Vec<String>, SimError> {
        let table = Table::parse(SENSOR_TABLE_NAME, SENSOR_TABLE, SENSOR_COLUMNS)?;
        Ok(table.names().into_iter().map(str::to_owned).collect())
    }

    /// The protocol's CGM (protocol.md §5): simglucose's noise parameters,
    /// a 5-minute sample time and readings clipped to [39, 600] mg/dL. This
    /// is the GuardianRT row; all three rows share the noise parameters, so
    /// it is also the Dexcom row at a 5-minute sample time.
    pub fn protocol() -> Result<Self, SimError> {
        Self::from_table("GuardianRT")?.with_sample_time(PROTOCOL_SAMPLE_TIME_MIN)
    }

    /// The same sensor with another sample time (minutes; must divide 150).
    pub fn with_sample_time(mut self, sample_time_min: u32) -> Result<Self, SimError> {
        self.sample_time_min = sample_time_min;
        self.validate()?;
        Ok(self)
    }

    /// Readings per 150-minute interpolation batch.
    pub fn samples_per_batch(&self) -> usize {
        (BATCH_MIN / self.sample_time_min.max(1)) as usize
    }

    /// Checks every field; the error names the field and what was expected.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |field: &str, value: f64, expected: &str| {
            Err(SimError::Config(format!(
                "CGM '{}': {field} = {value}, expected {expected}",
                self.name
            )))
        };
        if !(self.pacf.is_finite() && self.pacf.abs() < 1.0) {
            return bad("PACF", self.pacf, "a number in (-1, 1)");
        }
        let j = &self.johnson;
        if !j.gamma.is_finite() {
            return bad("gamma", j.gamma, "a finite number");
        }
        if !(j.lambda_mg_dl.is_finite() && j.lambda_mg_dl > 0.0) {
            return bad("lambda", j.lambda_mg_dl, "a positive number (mg/dL)");
        }
        if !(j.delta.is_finite() && j.delta > 0.0) {
            return bad("delta", j.delta, "a positive number");
        }
        if !j.xi_mg_dl.is_finite() {
            return bad("xi", j.xi_mg_dl, "a finite number (mg/dL)");
        }
        if self.sample_time_min == 0 || !BATCH_MIN.is_multiple_of(self.sample_time_min) {
            return bad(
                "sample_time",
                f64::from(self.sample_time_min),
                "a whole number of minutes that divides 150 \
                 (1, 2, 3, 5, 6, 10, 15, 25, 30, 50, 75 or 150)",
            );
        }
        if !(self.min_mg_dl.is_finite() && self.min_mg_dl >= 0.0) {
            return bad("min", self.min_mg_dl, "a finite number >= 0 (mg/dL)");
        }
        if !(self.max_mg_dl.is_finite() && self.max_mg_dl > self.min_mg_dl) {
            return bad("max", self.max_mg_dl, "a finite number above min (mg/dL)");
        }
        Ok(())
    }
}

/// The spline weights made so far, by sample time (minutes).
type WeightTables = Vec<(u32, Arc<NotAKnotWeights>)>;

/// The spline weights of a sensor with `sample_time_min`, computed once per
/// sample time in the process and shared: a vector environment of 256
/// Dexcom sensors kept 256 copies of the same 4.4 KB table, which pushed
/// the patients' state out of the processor's cache (the environment's
/// step ran 1.2× slower). The lock is taken only when a sensor is made.
fn shared_weights(sample_time_min: u32) -> Result<Arc<NotAKnotWeights>, SimError> {
    static TABLES: OnceLock<Mutex<WeightTables>> = OnceLock::new();
    let tables = TABLES.get_or_init(|| Mutex::new(Vec::new()));
    // A poisoned lock only means another thread panicked while pushing a
    // finished table: the list is still whole.
    let mut list = tables
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some((_, w)) = list.iter().find(|(t, _)| *t == sample_time_min) {
        return Ok(Arc::clone(w));
    }
    let n = (BATCH_MIN / sample_time_min.max(1)) as usize;
    let step = f64::from(sample_time_min) / f64::from(LATENT_STEP_MIN);
    let positions: Vec<f64> = (1..=n).map(|j| j as f64 * step).collect();
    let weights = Arc::new(NotAKnotWeights::new(&positions)?);
    list.push((sample_time_min, Arc::clone(&weights)));
    Ok(weights)
}

/// The CGM noise sequence ε (mg/dL), one value per sample time.
///
/// Holds the current batch's 11 knot values and the precomputed spline
/// weights; producing a sample never allocates.
#[derive(Debug, Clone)]
pub struct CgmNoise {
    pacf: f64,
    johnson: JohnsonSu,
    rng: ChaCha8Rng,
    /// The latent value e of the last knot.
    latent: f64,
    /// η at the knots of the current batch (knot 0 = last of the previous one).
    knots: [f64; KNOTS],
    /// Spline weights of the sample positions 1..=n of a batch, shared by
    /// every sensor with the same sample time (see [`shared_weights`]).
    weights: Arc<NotAKnotWeights>,
    /// Index of the next sample in the batch; == n when the batch is used up.
    next: usize,
}

impl CgmNoise {
    /// A noise sequence for `config`, seeded with `seed`.
    pub fn new(config: &CgmConfig, seed: u64) -> Result<Self, SimError> {
        config.validate()?;
        let weights = shared_weights(config.sample_time_min)?;
        let n = weights.len();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        // e_0 = w_0: the first latent value is a plain standard normal.
        let latent: f64 = rng.sample(StandardNormal);
        let mut knots = [0.0; KNOTS];
        knots[KNOTS - 1] = config.johnson.transform(latent);
        Ok(Self {
            pacf: config.pacf,
            johnson: config.johnson,
            rng,
            latent,
            knots,
            weights,
            next: n,
        })
    }

    /// The next noise value, mg/dL.
    #[inline]
    pub fn next_sample(&mut self) -> f64 {
        if self.next == self.weights.len() {
            self.refill();
        }
        let value = self.weights.evaluate(self.next, &self.knots);
        self.next += 1;
        value
    }

    /// Starts a new batch: the last knot becomes the first, 10 new knots follow.
    fn refill(&mut self) {
        self.knots[0] = self.knots[KNOTS - 1];
        for k in 1..KNOTS {
            let w: f64 = self.rng.sample(StandardNormal);
            self.latent = self.pacf * (self.latent + w);
            self.knots[k] = self.johnson.transform(self.latent);
        }
        self.next = 0;
    }
}

/// A CGM sensor: reads subcutaneous glucose with simglucose's noise model.
///
/// ```
/// use abba_core::{MgDl, Timestamp};
/// use abba_sim::devices::cgm::{CgmConfig, CgmSensor};
/// let mut cgm = CgmSensor::new(CgmConfig::protocol()?, 42)?;
/// assert!(cgm.measure(Timestamp(3), MgDl(120.0))?.is_none()); // not a sample time
/// let reading = cgm.measure(Timestamp(5), MgDl(120.0))?.unwrap();
/// assert!((39.0..=600.0).contains(&reading.0));
/// # Ok::<(), abba_sim::SimError>(())
/// ```
#[derive(Debug, Clone)]
pub struct CgmSensor {
    config: CgmConfig,
    noise: CgmNoise,
    last: Option<MgDl>,
}

impl CgmSensor {
    /// A sensor of model `config` with its own noise seed.
    pub fn new(config: CgmConfig, seed: u64) -> Result<Self, SimError> {
        let noise = CgmNoise::new(&config, seed)?;
        Ok(Self {
            config,
            noise,
            last: None,
        })
    }

    /// The sensor's configuration.
    pub fn config(&self) -> &CgmConfig {
        &self.config
    }

    /// Whether the sensor takes a reading at `at` (the clock is a multiple
    /// of the sample time).
    pub fn is_sample_time(&self, at: Timestamp) -> bool {
        at.minutes()
            .rem_euclid(i64::from(self.config.sample_time_min))
            == 0
    }

    /// A reading of subcutaneous glucose `gs`: clip(Gs + ε, min, max).
    /// Consumes the next noise sample; call it once per sample time.
    /// A non-finite `gs` is an error.
    #[inline]
    pub fn read(&mut self, gs: MgDl) -> Result<MgDl, SimError> {
        if !gs.0.is_finite() {
            return Err(SimError::DeviceInput {
                device: format!("CGM '{}'", self.config.name),
                reason: format!("subcutaneous glucose is {} mg/dL", gs.0),
            });
        }
        let noise_mg_dl = self.noise.next_sample();
        let reading =
            MgDl((gs.0 + noise_mg_dl).clamp(self.config.min_mg_dl, self.config.max_mg_dl));
        self.last = Some(reading);
        Ok(reading)
    }

    /// The most recent reading (what the receiver shows between samples,
    /// a zero-order hold as in simglucose), or `None` before the first.
    pub fn last_reading(&self) -> Option<MgDl> {
        self.last
    }

    /// A reading at `at` if `at` is a sample time, else `None` (and no noise
    /// sample is used).
    pub fn measure(&mut self, at: Timestamp, gs: MgDl) -> Result<Option<MgDl>, SimError> {
        if self.is_sample_time(at) {
            self.read(gs).map(Some)
        } else {
            Ok(None)
        }
    }

    /// The next noise value (mg/dL) without a glucose value: what
    /// [`read`](Self::read) would add. Consumes it.
    pub fn noise_sample(&mut self) -> f64 {
        self.noise.next_sample()
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn default_is_the_protocol_row() {
        assert_eq!(CgmConfig::default(), CgmConfig::protocol().unwrap());
        CgmConfig::default().validate().unwrap();
    }

    #[test]
    fn table_rows_load() {
        let names = CgmConfig::table_names().unwrap();
        assert_eq!(names, vec!["Dexcom", "GuardianRT", "Navigator"]);
        let d = CgmConfig::from_table("Dexcom").unwrap();
        assert_eq!(d.sample_time_min, 3);
        assert_eq!(d.pacf, 0.7);
        assert_eq!(d.johnson.lambda_mg_dl, 15.9574);
        assert_eq!((d.min_mg_dl, d.max_mg_dl), (39.0, 600.0));
        let n = CgmConfig::from_table("Navigator").unwrap();
        assert_eq!((n.sample_time_min, n.min_mg_dl), (1, 32.0));
        let p = CgmConfig::protocol().unwrap();
        assert_eq!(
            (p.sample_time_min, p.min_mg_dl, p.max_mg_dl),
            (5, 39.0, 600.0)
        );
        assert_eq!(p.samples_per_batch(), 30);
    }

    #[test]
    fn unknown_sensor_and_bad_sample_time_are_clear_errors() {
        let e = CgmConfig::from_table("Libre").unwrap_err().to_string();
        assert!(
            e.contains("Libre") && e.contains("Dexcom, GuardianRT, Navigator"),
            "{e}"
        );
        let e = CgmConfig::protocol()
            .unwrap()
            .with_sample_time(7)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("sample_time = 7") && e.contains("divides 150"),
            "{e}"
        );
        assert!(CgmConfig::protocol().unwrap().with_sample_time(0).is_err());
    }

    #[test]
    fn non_finite_glucose_is_an_error() {
        let mut s = CgmSensor::new(CgmConfig::protocol().unwrap(), 1).unwrap();
        assert!(s.read(MgDl(f64::NAN)).is_err());
        assert!(s.read(MgDl(120.0)).is_ok());
    }
}
