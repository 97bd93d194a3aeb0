//! The checks that turn a [`RawTrialConfig`] into a plan.

use super::{advisor_spec, PlannedScenario, RawTrialConfig, TrialConfig};
use crate::error::TrialError;
use abba_advisor::{ArmKind, Mode};
use abba_sim::scenario::ScenarioId;

/// Every check of the plan; the scenarios resolved.
pub(super) fn check(c: &RawTrialConfig) -> Result<Vec<PlannedScenario>, TrialError> {
    let bad = |m: String| Err(TrialError::Config(m));
    if c.patients == 0 {
        return bad("patients must be at least 1".into());
    }
    if let Err(m) = c.suggestions.validate() {
        return bad(format!("suggestions: {m}"));
    }
    if c.days < 2 + c.init_days {
        return bad(format!(
            "days must be at least {} (warm-up day + {} initialisation days + 1), got {}",
            2 + c.init_days,
            c.init_days,
            c.days
        ));
    }
    if !(c.failure_glucose_mg_dl.is_finite() && c.failure_glucose_mg_dl > 0.0) {
        return bad(format!(
            "failure_glucose_mg_dl must be a finite number > 0, got {}",
            c.failure_glucose_mg_dl
        ));
    }
    if let Some(x) = c.te_ref_bits_smbg {
        if !(x.is_finite() && x > 0.0) {
            return bad(format!(
                "te_ref_bits_smbg must be a finite number > 0, got {x}"
            ));
        }
    }
    if c.scenarios.is_empty() {
        return bad("at least one scenario is needed".into());
    }
    if c.arms.is_empty() {
        return bad("at least one arm is needed".into());
    }
    let mut seen = std::collections::BTreeSet::new();
    for s in &c.scenarios {
        if !seen.insert(*s) {
            return bad(format!("scenario {s} is listed twice"));
        }
    }
    let mut seen = std::collections::BTreeSet::new();
    for a in &c.arms {
        if !seen.insert(*a) {
            return bad(format!("arm {a} is listed twice"));
        }
    }
    let mut overridden = std::collections::BTreeSet::new();
    for (k, o) in c.scenario_overrides.iter().enumerate() {
        let at = format!("scenario_overrides[{k}]");
        let Ok(id) = o.name.parse::<ScenarioId>() else {
            return bad(format!(
                "{at}: name '{}' is not a scenario (expected S1, S2, S3 or S4)",
                o.name
            ));
        };
        if id.name() != o.name {
            return bad(format!("{at}: name '{}' must be written {id}", o.name));
        }
        if !overridden.insert(id) {
            return bad(format!("{at}: a second override of {id}"));
        }
        if !c.scenarios.contains(&id) {
            return bad(format!(
                "{at}: overrides {id}, which is not among the scenarios run ({})",
                c.scenarios
                    .iter()
                    .map(|s| s.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if o.days != c.days {
            return bad(format!(
                "{at}.days is {} but the trial runs {} days (set `days` at the top level)",
                o.days, c.days
            ));
        }
    }
    c.devices
        .validate()
        .map_err(|e| TrialError::Config(format!("devices: {e}")))?;
    c.fixed_limits
        .validate()
        .map_err(|e| TrialError::Config(format!("fixed_limits: {e}")))?;
    let mut planned = Vec::with_capacity(c.scenarios.len());
    for id in &c.scenarios {
        let s = c.scenario(*id);
        s.validate()
            .map_err(|e| TrialError::Config(e.to_string()))?;
        let mode = TrialConfig::mode_for(&s);
        // SMBG mode needs finger sticks: its day closes at the bedtime reading.
        if mode == Mode::Smbg && s.smbg.is_none() {
            return bad(format!(
                "scenario {}: the CGM stops after day {} but there are no SMBG readings, so the advisor would have no glucose and its day would never close",
                s.name,
                s.cgm.until_day.unwrap_or(0)
            ));
        }
        planned.push(PlannedScenario {
            id: *id,
            config: s,
            mode,
        });
    }
    // Every advisor that will run, checked now rather than inside the jobs.
    if let Some(t) = &c.twin_check {
        t.validate()
            .map_err(|e| TrialError::Config(format!("twin_check.{e}")))?;
    }
    for p in &planned {
        for arm in &c.arms {
            // The abba-twin arm runs ABBA's knobs.
            let field = match arm {
                ArmKind::AbbaTwin => ArmKind::Abba.config_section(),
                a => a.config_section(),
            };
            advisor_spec(c, *arm, p.mode)
                .validate()
                .map_err(|e| TrialError::Config(format!("{field}: {e}")))?;
        }
    }
    Ok(planned)
}
