//! `FixedTherapy`: the standard therapy, never changed.

use crate::config::EventLimits;
use crate::decision::Decision;
use crate::error::AdvisorError;
use crate::guard::EventGuard;
use crate::{Advisor, ArmKind, Mode};
use abba_core::{Event, TherapySettings};
use serde::{Deserialize, Serialize};

/// The standard therapy for the whole run. It validates events exactly like
/// the other advisors (so every arm rejects the same bad input) and has no
/// decision points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FixedTherapy {
    settings: TherapySettings,
    limits: EventLimits,
    guard: EventGuard,
}

impl FixedTherapy {
    /// Keeps `settings` forever.
    pub fn new(settings: TherapySettings, limits: EventLimits) -> Result<Self, AdvisorError> {
        settings.validate().map_err(|e| AdvisorError::Config {
            field: "start settings".into(),
            problem: e.to_string(),
        })?;
        limits.validate()?;
        Ok(Self {
            settings,
            limits,
            guard: EventGuard::default(),
        })
    }

    /// The whole state as JSON, in the versioned envelope of [`crate::state`].
    pub fn save_json(&self) -> Result<String, AdvisorError> {
        crate::state::save(ArmKind::Standard, self)
    }

    /// Restores a state saved with [`FixedTherapy::save_json`], re-validating it.
    pub fn load_json(json: &str) -> Result<Self, AdvisorError> {
        let a: Self = crate::state::load(ArmKind::Standard, json)?;
        a.check_state()?;
        Ok(a)
    }

    /// Re-validates a deserialised state.
    pub(crate) fn check_state(&self) -> Result<(), AdvisorError> {
        self.limits.validate()?;
        self.settings
            .validate()
            .map_err(|e| AdvisorError::State(format!("settings: {e}")))
    }
}

impl Advisor for FixedTherapy {
    fn observe(&mut self, event: &Event) -> Result<Option<TherapySettings>, AdvisorError> {
        self.guard.check(event, &self.limits)?;
        self.guard.commit(event);
        Ok(None)
    }

    fn settings(&self) -> &TherapySettings {
        &self.settings
    }

    fn decisions(&self) -> &[Decision] {
        &[]
    }

    fn take_decisions(&mut self) -> Vec<Decision> {
        Vec::new()
    }

    fn arm(&self) -> ArmKind {
        ArmKind::Standard
    }

    fn mode(&self) -> Option<Mode> {
        None
    }
}
