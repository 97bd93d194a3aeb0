//! The trial's configuration: cohort, scenarios, arms, devices and every
//! knob, with the paper's protocol as the default (`spec/protocol.md` §6).

use crate::error::TrialError;
use abba_advisor::baselines::r2r::R2rConfig;
use abba_advisor::{AbbaConfig, EventLimits, Mode};
use abba_sim::cohort::Population;
use abba_sim::scenario::{ScenarioConfig, ScenarioId};
use serde::{Deserialize, Serialize};

/// The arms live in abba-report (results carry them); re-exported here.
pub use abba_report::ArmKind;

/// Device settings of the trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeviceConfig {
    /// CGM model row of `sensor_params.csv` (the noise parameters).
    pub cgm_model: String,
    /// CGM sample time (min).
    pub cgm_sample_time_min: u32,
    /// Meter error SD below 100 mg/dL (mg/dL).
    pub meter_sd_below_mg_dl: f64,
    /// Meter error SD from 100 mg/dL up (fraction).
    pub meter_sd_fraction_above: f64,
    /// Pump bolus step (U).
    pub pump_bolus_step_u: f64,
    /// Pump bolus delivery speed (U/min).
    pub pump_bolus_speed_u_per_min: f64,
    /// Pump basal step (U/h).
    pub pump_basal_step_u_per_h: f64,
    /// Largest bolus (U).
    pub pump_max_bolus_u: f64,
    /// Largest basal rate (U/h).
    pub pump_max_basal_u_per_h: f64,
}

impl Default for DeviceConfig {
    fn default() -> Self {
        Self {
            cgm_model: "GuardianRT".into(),
            cgm_sample_time_min: 5,
            meter_sd_below_mg_dl: 7.5,
            meter_sd_fraction_above: 0.075,
            pump_bolus_step_u: 0.05,
            pump_bolus_speed_u_per_min: 1.5,
            pump_basal_step_u_per_h: 0.05,
            pump_max_bolus_u: 30.0,
            pump_max_basal_u_per_h: 30.0,
        }
    }
}

/// Everything that defines a trial. Serialised into the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialConfig {
    /// Trial seed (every random stream derives from it).
    pub seed: u64,
    /// Cohort population.
    pub population: Population,
    /// Number of patients (the first 10 are the public ones).
    pub patients: u32,
    /// Cohort seed.
    pub cohort_seed: u64,
    /// Simulated days (98 in the paper).
    pub days: u32,
    /// Days of standard therapy before the advisor acts, after the warm-up day
    /// (7: D2-D8). The advisor is fed events from the start of D2.
    pub init_days: u32,
    /// Scenarios to run.
    pub scenarios: Vec<ScenarioId>,
    /// Arms to run in every scenario.
    pub arms: Vec<ArmKind>,
    /// ABBA's knobs (mode and seed are set per scenario and patient).
    pub abba: AbbaConfig,
    /// Run-to-run knobs (mode set per scenario).
    pub r2r: R2rConfig,
    /// Plausibility limits of the fixed-therapy arm's event checks.
    pub fixed_limits: EventLimits,
    /// Devices.
    pub devices: DeviceConfig,
    /// Set ABBA's TE reference `abba.te.te_ref_bits` to the median
    /// first-week transfer entropy of the cohort (spec §7.3: "TE_ref = median
    /// TE over the training cohort's D2-D8"), computed from the
    /// standard-therapy week before the arms run. When false, the configured
    /// value is used as is.
    pub calibrate_te_ref: bool,
    /// TE reference of ABBA in SMBG mode (bits); `None` uses
    /// `abba.te.te_ref_bits`. SMBG-mode ABBA initialises at the bedtime
    /// reading of the last initialisation day, so its TE grid ends about an
    /// hour earlier than in CGM mode; calibration sets this from SMBG-mode
    /// runs.
    pub te_ref_bits_smbg: Option<f64>,
    /// A run stops when plasma glucose falls below this (mg/dL); the report
    /// counts such runs per arm (10, simglucose's end-of-episode threshold).
    pub failure_glucose_mg_dl: f64,
    /// Scenario overrides: when set, replaces the paper's configuration of
    /// the scenario with that name.
    pub scenario_overrides: Vec<ScenarioConfig>,
}

impl Default for TrialConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            population: Population::Adults,
            patients: 100,
            cohort_seed: 1,
            days: 98,
            init_days: 7,
            scenarios: ScenarioId::ALL.to_vec(),
            arms: ArmKind::ALL.to_vec(),
            abba: AbbaConfig::new(Mode::Cgm, 0),
            r2r: R2rConfig::new(Mode::Cgm),
            fixed_limits: EventLimits::default(),
            devices: DeviceConfig::default(),
            calibrate_te_ref: true,
            te_ref_bits_smbg: None,
            failure_glucose_mg_dl: 10.0,
            scenario_overrides: Vec::new(),
        }
    }
}

impl TrialConfig {
    /// The advisor mode of a scenario: CGM when the CGM is worn throughout
    /// (S1), SMBG otherwise.
    pub fn mode_for(scenario: &ScenarioConfig) -> Mode {
        if scenario.cgm.until_day.is_none() {
            Mode::Cgm
        } else {
            Mode::Smbg
        }
    }

    /// The scenario configuration used for `id` (override or paper), with
    /// the trial's length.
    pub fn scenario(&self, id: ScenarioId) -> ScenarioConfig {
        let mut s = self
            .scenario_overrides
            .iter()
            .find(|s| s.name == id.name())
            .cloned()
            .unwrap_or_else(|| ScenarioConfig::paper(id));
        s.days = self.days;
        s
    }

    /// Checks the configuration; errors name the field.
    pub fn validate(&self) -> Result<(), TrialError> {
        let bad = |m: String| Err(TrialError::Config(m));
        if self.patients == 0 {
            return bad("patients must be at least 1".into());
        }
        if self.days < 2 + self.init_days {
            return bad(format!(
                "days must be at least {} (warm-up day + {} initialisation days + 1), got {}",
                2 + self.init_days,
                self.init_days,
                self.days
            ));
        }
        if !(self.failure_glucose_mg_dl.is_finite() && self.failure_glucose_mg_dl > 0.0) {
            return bad(format!(
                "failure_glucose_mg_dl must be a finite number > 0, got {}",
                self.failure_glucose_mg_dl
            ));
        }
        if let Some(x) = self.te_ref_bits_smbg {
            if !(x.is_finite() && x > 0.0) {
                return bad(format!(
                    "te_ref_bits_smbg must be a finite number > 0, got {x}"
                ));
            }
        }
        if self.scenarios.is_empty() {
            return bad("at least one scenario is needed".into());
        }
        if self.arms.is_empty() {
            return bad("at least one arm is needed".into());
        }
        let mut seen = std::collections::BTreeSet::new();
        for s in &self.scenarios {
            if !seen.insert(*s) {
                return bad(format!("scenario {s} is listed twice"));
            }
        }
        let mut seen = std::collections::BTreeSet::new();
        for a in &self.arms {
            if !seen.insert(*a) {
                return bad(format!("arm {} is listed twice", a.name()));
            }
        }
        for id in &self.scenarios {
            let s = self.scenario(*id);
            s.validate()
                .map_err(|e| TrialError::Config(e.to_string()))?;
            // SMBG mode needs finger sticks: its day closes at the bedtime reading.
            if Self::mode_for(&s) == Mode::Smbg && s.smbg.is_none() {
                return bad(format!(
                    "scenario {}: the CGM stops after day {} but there are no SMBG readings, so the advisor would have no glucose and its day would never close",
                    s.name,
                    s.cgm.until_day.unwrap_or(0)
                ));
            }
        }
        Ok(())
    }
}
