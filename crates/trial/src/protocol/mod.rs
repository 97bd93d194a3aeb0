//! The trial's configuration: cohort, scenarios, arms, devices and every
//! knob, with the paper's protocol as the default (`spec/protocol.md` §6).
//!
//! Two types: [`RawTrialConfig`] is what a user writes (JSON, every field
//! required, unknown fields refused at every level) and what `abba trial
//! --print-config` prints; [`TrialConfig`] is the checked plan, made from
//! it in one step ([`TryFrom`], or [`TrialConfig::from_json`]) before any
//! simulation starts. Every value is checked there, the advisors' nested
//! knobs included, and every scenario is resolved with its advisor mode, so
//! no job can fail later on configuration.
//!
//! Knobs that the trial sets itself are not in the configuration: each
//! advisor's `mode` (from the scenario), `init_days` (the trial's), ABBA's
//! `exploration_seed` (derived per patient) and run-to-run's
//! `cgm_interval_min` (the CGM's sample time). [`TrialConfig::advisor_spec`]
//! gives what actually runs.

use crate::error::TrialError;
use crate::twin_arm::TwinArmOptions;
use abba_advisor::any::AdvisorSpec;
use abba_advisor::baselines::r2r::R2rConfig;
use abba_advisor::{AbbaConfig, AgeGroup, AutotuneConfig, EventLimits, Mode};
use abba_sim::cohort::Population;
use abba_sim::devices::DeviceSet;
use abba_sim::person::{Behaviour, DayClosing};
use abba_sim::scenario::{ScenarioConfig, ScenarioId};
use serde::{Deserialize, Serialize};

pub use abba_advisor::ArmKind;

mod check;
mod trial_set;

use check::check;

/// Everything that defines a trial, as written by a user (see the module
/// docs); check it with [`TrialConfig::try_from`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawTrialConfig {
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
    /// ABBA's knobs (without `mode`, `init_days` and `exploration_seed`,
    /// which the trial sets; in memory they hold placeholders).
    #[serde(with = "trial_set::abba")]
    pub abba: AbbaConfig,
    /// Run-to-run knobs (without `mode`, `init_days` and `cgm_interval_min`,
    /// which the trial sets).
    #[serde(with = "trial_set::r2r")]
    pub r2r: R2rConfig,
    /// Autotune arm knobs (without `mode` and `init_days`, which the trial
    /// sets).
    /// The one optional field: absent, oref0's defaults; the checked plan
    /// fills them in when the autotune arm runs, and leaves the field out
    /// otherwise, so that a trial without the arm writes the same files as
    /// before the arm existed.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "trial_set::autotune"
    )]
    pub autotune: Option<AutotuneConfig>,
    /// The twin check of the `abba-twin` arm (ABBA with the twin check; it
    /// runs with the `abba` section's knobs). Optional like `autotune`:
    /// absent, the defaults; filled in when the arm runs, left out
    /// otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub twin_check: Option<TwinArmOptions>,
    /// Plausibility limits of the fixed-therapy arm's event checks.
    pub fixed_limits: EventLimits,
    /// Devices, in the simulator's own types.
    pub devices: DeviceSet,
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
    /// Scenario overrides: each replaces the paper's configuration of the
    /// scenario with its name (S1-S4), which must be one of `scenarios`;
    /// its `days` must equal the trial's.
    pub scenario_overrides: Vec<ScenarioConfig>,
    /// What the simulated people do with the advisor's suggestions (the
    /// paper: accept all; `reject_share` or `override_within` measure the
    /// effect of people not following them).
    #[serde(default)]
    pub suggestions: abba_sim::person::SuggestionResponse,
}

fn default_autotune() -> AutotuneConfig {
    AutotuneConfig::new(Mode::Cgm)
}

impl Default for RawTrialConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            population: Population::Adults,
            patients: 100,
            cohort_seed: 1,
            days: 98,
            init_days: 7,
            scenarios: ScenarioId::ALL.to_vec(),
            arms: ArmKind::DEFAULT.to_vec(),
            abba: AbbaConfig::new(Mode::Cgm, 0),
            r2r: R2rConfig::new(Mode::Cgm),
            autotune: None,
            twin_check: None,
            fixed_limits: EventLimits::default(),
            devices: DeviceSet::default(),
            calibrate_te_ref: true,
            te_ref_bits_smbg: None,
            failure_glucose_mg_dl: 10.0,
            scenario_overrides: Vec::new(),
            suggestions: abba_sim::person::SuggestionResponse::AcceptAll,
        }
    }
}

impl RawTrialConfig {
    /// The built-in defaults for a cohort of `population`: the paper's
    /// protocol with ABBA's knobs as `abba calibrate` chose them, where a
    /// population's training cohort chose otherwise than the adults': the
    /// defaults of its [`AgeGroup`] (only the basal agent's hours differ;
    /// the values and where they come from are documented there).
    pub fn for_population(population: Population) -> Self {
        let mut c = Self {
            population,
            ..Self::default()
        };
        age_group(population).apply(&mut c.abba);
        c
    }
}

/// The age group whose defaults a cohort of `population` gets.
pub fn age_group(population: Population) -> AgeGroup {
    match population {
        Population::Adults => AgeGroup::Adult,
        Population::Adolescents => AgeGroup::Adolescent,
        Population::Children => AgeGroup::Child,
    }
}

/// One scenario of a checked plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedScenario {
    /// Which scenario.
    pub id: ScenarioId,
    /// Its configuration (override or paper) with the trial's length.
    pub config: ScenarioConfig,
    /// The advisor mode it runs in.
    pub mode: Mode,
}

/// A checked trial plan (see the module docs). Read any knob through
/// `Deref` to [`RawTrialConfig`]; to change one, change the raw form and
/// check it again. Serialises as its raw form.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(try_from = "RawTrialConfig")]
pub struct TrialConfig {
    raw: RawTrialConfig,
    planned: Vec<PlannedScenario>,
}

impl Serialize for TrialConfig {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.raw.serialize(s)
    }
}

impl std::ops::Deref for TrialConfig {
    type Target = RawTrialConfig;
    fn deref(&self) -> &RawTrialConfig {
        &self.raw
    }
}

impl TryFrom<RawTrialConfig> for TrialConfig {
    type Error = TrialError;
    fn try_from(mut raw: RawTrialConfig) -> Result<Self, TrialError> {
        if raw.arms.contains(&ArmKind::Autotune) && raw.autotune.is_none() {
            raw.autotune = Some(default_autotune());
        }
        if raw.arms.contains(&ArmKind::AbbaTwin) && raw.twin_check.is_none() {
            raw.twin_check = Some(TwinArmOptions::default());
        }
        let planned = check(&raw)?;
        Ok(Self { raw, planned })
    }
}

impl TrialConfig {
    /// The paper's protocol with every default.
    pub fn paper() -> Result<Self, TrialError> {
        Self::try_from(RawTrialConfig::default())
    }

    /// Reads and checks a JSON configuration (a UTF-8 byte-order mark is
    /// allowed). Errors give the line, column and field.
    pub fn from_json(text: &str) -> Result<Self, TrialError> {
        Self::try_from(RawTrialConfig::from_json(text)?)
    }

    /// The raw form.
    pub fn raw(&self) -> &RawTrialConfig {
        &self.raw
    }

    /// The raw form, to change and check again.
    pub fn into_raw(self) -> RawTrialConfig {
        self.raw
    }

    /// The scenarios to run, resolved, in configuration order.
    pub fn planned(&self) -> &[PlannedScenario] {
        &self.planned
    }

    /// The planned scenario `id`, if the trial runs it.
    pub fn planned_scenario(&self, id: ScenarioId) -> Option<&PlannedScenario> {
        self.planned.iter().find(|p| p.id == id)
    }

    /// The advisor mode of a scenario: CGM when the CGM is worn throughout
    /// (S1), SMBG otherwise.
    pub fn mode_for(scenario: &ScenarioConfig) -> Mode {
        if scenario.cgm.until_day.is_none() {
            Mode::Cgm
        } else {
            Mode::Smbg
        }
    }

    /// The advisor an arm runs in `mode`, with every knob the trial sets
    /// (ABBA's `exploration_seed` is replaced per patient when it is built).
    pub fn advisor_spec(&self, arm: ArmKind, mode: Mode) -> AdvisorSpec {
        advisor_spec(&self.raw, arm, mode)
    }

    /// The simulated person's behaviour in `mode`: the app from D2 (D1 is
    /// warm-up), days closed at the bedtime reading (SMBG) or midnight (CGM).
    pub fn behaviour(mode: Mode) -> Behaviour {
        Behaviour::paper(match mode {
            Mode::Smbg => DayClosing::AfterBedtimeReading,
            Mode::Cgm => DayClosing::AtMidnight,
        })
    }
}

impl RawTrialConfig {
    /// Whether an arm runs ABBA (`abba`, or `abba-twin`: ABBA with the twin
    /// check), so that its TE reference is calibrated.
    pub fn runs_abba(&self) -> bool {
        self.arms
            .iter()
            .any(|a| matches!(a, ArmKind::Abba | ArmKind::AbbaTwin))
    }

    /// Parses a JSON configuration without checking its values (a UTF-8
    /// byte-order mark is allowed).
    pub fn from_json(text: &str) -> Result<Self, TrialError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        serde_json::from_str(text).map_err(|e| TrialError::Config(e.to_string()))
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
}

fn advisor_spec(raw: &RawTrialConfig, arm: ArmKind, mode: Mode) -> AdvisorSpec {
    match arm {
        // ABBA with the twin check runs ABBA's knobs (the check wraps it).
        ArmKind::Abba | ArmKind::AbbaTwin => {
            let mut c = raw.abba.clone();
            c.mode = mode;
            c.init_days = raw.init_days;
            c.exploration_seed = 0;
            if let (Mode::Smbg, Some(te_ref)) = (mode, raw.te_ref_bits_smbg) {
                c.te.te_ref_bits = te_ref;
            }
            AdvisorSpec::Abba(c)
        }
        ArmKind::Standard => AdvisorSpec::Fixed {
            limits: raw.fixed_limits.clone(),
        },
        ArmKind::R2r => {
            let mut c = raw.r2r.clone();
            c.mode = mode;
            c.init_days = raw.init_days;
            c.cgm_interval_min = f64::from(raw.devices.cgm.sample_time_min);
            AdvisorSpec::RunToRun(c)
        }
        ArmKind::Autotune => {
            let mut c = raw.autotune.clone().unwrap_or_else(default_autotune);
            c.mode = mode;
            c.init_days = raw.init_days;
            AdvisorSpec::Autotune(c)
        }
    }
}
