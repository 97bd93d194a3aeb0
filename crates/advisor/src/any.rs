//! Building any arm of a trial from a serialisable description.

use crate::abba::Abba;
use crate::baselines::autotune::{Autotune, AutotuneConfig};
use crate::baselines::fixed::FixedTherapy;
use crate::baselines::r2r::{R2rConfig, RunToRun};
use crate::config::{AbbaConfig, EventLimits};
use crate::decision::Decision;
use crate::error::AdvisorError;
use crate::{Advisor, ArmKind, Mode};
use abba_core::{Event, TherapySettings};
use serde::{Deserialize, Serialize};

/// Which advisor to build, with its configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
// Built once per patient and arm; boxing would only add noise.
#[allow(clippy::large_enum_variant)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum AdvisorSpec {
    /// ABBA. Its `exploration_seed` is replaced by the seed given to [`AdvisorSpec::build`].
    Abba(AbbaConfig),
    /// The standard therapy, unchanged.
    Fixed {
        /// Event plausibility limits.
        limits: EventLimits,
    },
    /// Run-to-run.
    RunToRun(R2rConfig),
    /// oref0's autotune, nightly.
    Autotune(AutotuneConfig),
}

impl AdvisorSpec {
    /// The arm this spec builds.
    pub fn arm(&self) -> ArmKind {
        match self {
            AdvisorSpec::Abba(_) => ArmKind::Abba,
            AdvisorSpec::Fixed { .. } => ArmKind::Standard,
            AdvisorSpec::RunToRun(_) => ArmKind::R2r,
            AdvisorSpec::Autotune(_) => ArmKind::Autotune,
        }
    }

    /// Checks the configuration inside (what [`AdvisorSpec::build`] would
    /// refuse), without a starting therapy.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        match self {
            AdvisorSpec::Abba(c) => c.validate(),
            AdvisorSpec::Fixed { limits } => limits.validate(),
            AdvisorSpec::RunToRun(c) => c.validate(),
            AdvisorSpec::Autotune(c) => c.validate(),
        }
    }

    /// Builds the advisor for one patient from its starting therapy and its
    /// exploration seed (`derive_seed(trial, patient, scenario, Stream::Exploration)`).
    pub fn build(
        &self,
        start: TherapySettings,
        exploration_seed: u64,
    ) -> Result<AnyAdvisor, AdvisorError> {
        Ok(match self {
            AdvisorSpec::Abba(c) => {
                let mut c = c.clone();
                c.exploration_seed = exploration_seed;
                AnyAdvisor::Abba(Box::new(Abba::new(c, start)?))
            }
            AdvisorSpec::Fixed { limits } => {
                AnyAdvisor::Fixed(FixedTherapy::new(start, limits.clone())?)
            }
            AdvisorSpec::RunToRun(c) => AnyAdvisor::RunToRun(RunToRun::new(c.clone(), start)?),
            AdvisorSpec::Autotune(c) => {
                AnyAdvisor::Autotune(Box::new(Autotune::new(c.clone(), start)?))
            }
        })
    }
}

/// Any advisor behind one type (serialisable, so a run can be saved and resumed).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
// One per patient and arm; the size difference is irrelevant.
#[allow(clippy::large_enum_variant)]
#[serde(rename_all = "snake_case", tag = "kind", content = "state")]
pub enum AnyAdvisor {
    /// ABBA.
    Abba(Box<Abba>),
    /// Standard therapy.
    Fixed(FixedTherapy),
    /// Run-to-run.
    RunToRun(RunToRun),
    /// oref0's autotune.
    Autotune(Box<Autotune>),
}

impl AnyAdvisor {
    /// The ABBA advisor inside, if this arm is ABBA (for θ, critic weights, counters).
    pub fn as_abba(&self) -> Option<&Abba> {
        match self {
            AnyAdvisor::Abba(a) => Some(a),
            _ => None,
        }
    }

    /// The TE initialisation report, if this arm is ABBA and has initialised.
    pub fn init_report(&self) -> Option<&crate::abba::InitReport> {
        self.as_abba().and_then(Abba::init_report)
    }

    /// The whole state as JSON, in the versioned envelope of
    /// [`crate::state`] (the same form as the inner advisor's own
    /// `save_json`).
    pub fn save_json(&self) -> Result<String, AdvisorError> {
        match self {
            AnyAdvisor::Abba(a) => a.save_json(),
            AnyAdvisor::Fixed(a) => a.save_json(),
            AnyAdvisor::RunToRun(a) => a.save_json(),
            AnyAdvisor::Autotune(a) => a.save_json(),
        }
    }

    /// Restores any advisor's saved state (the envelope says which).
    pub fn load_json(json: &str) -> Result<Self, AdvisorError> {
        Ok(match crate::state::saved_arm(json)? {
            ArmKind::Abba => AnyAdvisor::Abba(Box::new(Abba::load_json(json)?)),
            ArmKind::Standard => AnyAdvisor::Fixed(FixedTherapy::load_json(json)?),
            ArmKind::R2r => AnyAdvisor::RunToRun(RunToRun::load_json(json)?),
            ArmKind::Autotune => AnyAdvisor::Autotune(Box::new(Autotune::load_json(json)?)),
            ArmKind::AbbaTwin => {
                return Err(AdvisorError::State(
                    "field `advisor` is \"abba-twin\", a trial arm (ABBA with the twin check) \
                     without a saved state of its own: its advisor saves as \"abba\""
                        .into(),
                ))
            }
        })
    }

    fn inner(&self) -> &dyn Advisor {
        match self {
            AnyAdvisor::Abba(a) => a.as_ref(),
            AnyAdvisor::Fixed(a) => a,
            AnyAdvisor::RunToRun(a) => a,
            AnyAdvisor::Autotune(a) => a.as_ref(),
        }
    }

    fn inner_mut(&mut self) -> &mut dyn Advisor {
        match self {
            AnyAdvisor::Abba(a) => a.as_mut(),
            AnyAdvisor::Fixed(a) => a,
            AnyAdvisor::RunToRun(a) => a,
            AnyAdvisor::Autotune(a) => a.as_mut(),
        }
    }
}

impl Advisor for AnyAdvisor {
    fn observe(&mut self, event: &Event) -> Result<Option<TherapySettings>, AdvisorError> {
        self.inner_mut().observe(event)
    }

    fn settings(&self) -> &TherapySettings {
        self.inner().settings()
    }

    fn decisions(&self) -> &[Decision] {
        self.inner().decisions()
    }

    fn take_decisions(&mut self) -> Vec<Decision> {
        self.inner_mut().take_decisions()
    }

    fn arm(&self) -> ArmKind {
        self.inner().arm()
    }

    fn mode(&self) -> Option<Mode> {
        self.inner().mode()
    }
}
