//! The ABBA arm with the twin check (`abba-twin`, issue 27, item 7; opt-in,
//! never in the default trial): a twin is fitted from the simulated
//! person's device events, the same events the advisor sees (never the
//! model's state or parameters), and each suggestion is replayed on it
//! before the person gets it; one whose predicted time below 70 mg/dL rises
//! by more than the margin is answered "rejected" for the person, so the
//! value in force stays, as a person who heeds the check would do.
//!
//! The twin is fitted at the first closed day with [`TwinArmOptions::
//! fit_days`] days of data and refitted every [`TwinArmOptions::
//! refit_every_days`]; a suggestion is replayed on the last
//! [`TwinArmOptions::replay_days`] days of the window the twin was fitted
//! on. Before the first fit, and while the twin's grade is "not usable",
//! suggestions pass unchecked (as for a person without a usable twin).
//! Deterministic: fits and replays are.
//!
//! In a trial the arm is `--arms ...,abba-twin`: the runner builds ABBA
//! (the `abba` section's knobs) wrapped in [`TwinChecked`] with the
//! configuration's `twin_check` section, and each patient's result carries
//! what the check did ([`TwinArmStats`]: summed per arm in `summary.json`'s
//! notes).

use crate::closed_loop::{self, Trace};
use crate::error::TrialError;
use crate::protocol::{PlannedScenario, TrialConfig};
use crate::results::PatientResult;
use abba_advisor::{Advisor, AdvisorError, ArmKind, Decision, Mode, Parameter};
use abba_core::{Event, EventKind, GramsPerUnit, SettingValue, TherapySettings, UnitsPerHour};
use abba_sim::cohort::{Population, VirtualPatient};
use abba_twin::{Grade, Twin, TwinOptions, WhatIf};
use serde::{Deserialize, Serialize};

/// What the twin check did in one run (abba-report's type: each patient's
/// result carries it).
pub use crate::results::TwinCheckCounts as TwinArmStats;

/// How the twin check runs in the trial (the configuration's `twin_check`
/// section; filled with these defaults when the arm runs, absent
/// otherwise).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwinArmOptions {
    /// Days of device data the twin is fitted on (the last ones; 14: the
    /// window `abba twin fit` uses, 12 fitted and 2 held out).
    pub fit_days: usize,
    /// Days between refits (7: a week of new data).
    pub refit_every_days: usize,
    /// Days a suggestion is replayed on (7, as beside a person's advice).
    pub replay_days: usize,
    /// The margin (percentage points of time below 70 mg/dL; 1, the
    /// store's `TWIN_CHECK_MARGIN_PP`).
    pub margin_pp: f64,
}

impl Default for TwinArmOptions {
    fn default() -> Self {
        Self {
            fit_days: 14,
            refit_every_days: 7,
            replay_days: 7,
            margin_pp: 1.0,
        }
    }
}

impl TwinArmOptions {
    /// Checks the knobs (the error names the field).
    pub fn validate(&self) -> Result<(), String> {
        let held_out = TwinOptions::default().held_out_days;
        let least = abba_twin::MIN_FIT_DAYS;
        if self.fit_days < held_out + least {
            return Err(format!(
                "fit_days = {}: must be more than {} (the {held_out} held-out days and at least {least} fitted)",
                self.fit_days,
                held_out + least - 1
            ));
        }
        if self.refit_every_days == 0 {
            return Err("refit_every_days = 0: must be at least 1".into());
        }
        if self.replay_days == 0 || self.replay_days > self.fit_days {
            return Err(format!(
                "replay_days = {}: must be 1 to fit_days ({})",
                self.replay_days, self.fit_days
            ));
        }
        if !(self.margin_pp.is_finite() && self.margin_pp >= 0.0) {
            return Err(format!(
                "margin_pp = {}: must be a finite number of percentage points, 0 or more",
                self.margin_pp
            ));
        }
        Ok(())
    }
}

/// An advisor whose suggestions pass the twin check.
#[derive(Debug)]
pub struct TwinChecked<A> {
    inner: A,
    events: Vec<Event>,
    /// The twin and the events it was fitted on.
    twin: Option<(Twin, Vec<Event>)>,
    closed_days: usize,
    fitted_at_day: Option<usize>,
    name: String,
    population: Population,
    basal_in_force: f64,
    options: TwinArmOptions,
    /// What it did.
    pub stats: TwinArmStats,
}

impl<A: Advisor> TwinChecked<A> {
    /// Wraps `inner` for person `name` of `population` starting on `start`.
    pub fn new(
        inner: A,
        name: &str,
        population: Population,
        start: TherapySettings,
        options: TwinArmOptions,
    ) -> Self {
        Self {
            inner,
            events: Vec::new(),
            twin: None,
            closed_days: 0,
            fitted_at_day: None,
            name: name.to_string(),
            population,
            basal_in_force: start.basal.0,
            options,
            stats: TwinArmStats::default(),
        }
    }

    /// The wrapped advisor.
    pub fn inner(&self) -> &A {
        &self.inner
    }

    fn refit_if_due(&mut self) {
        let due = self.closed_days >= self.options.fit_days
            && self
                .fitted_at_day
                .is_none_or(|d| self.closed_days >= d + self.options.refit_every_days);
        if !due {
            return;
        }
        self.fitted_at_day = Some(self.closed_days);
        self.stats.fits += 1;
        let fitted = Twin::fit(
            &self.name,
            &self.events,
            &TwinOptions {
                days: self.options.fit_days,
                population: self.population,
                basal_in_force_u_per_h: self.basal_in_force,
                ..TwinOptions::default()
            },
        );
        match fitted {
            Ok(t) => {
                if t.grade != Grade::NotUsable {
                    self.stats.usable_fits += 1;
                }
                self.twin = Some((t, self.events.clone()));
            }
            Err(_) => {
                self.stats.failed_fits += 1;
                self.twin = None;
            }
        }
    }

    /// True when the twin predicts `d` to raise time below 70 by more than
    /// the margin.
    fn holds_back(&mut self, d: &Decision) -> bool {
        let Some((twin, events)) = self
            .twin
            .as_ref()
            .filter(|(t, _)| t.grade != Grade::NotUsable)
        else {
            self.stats.unchecked += 1;
            return false;
        };
        let meal = match d.parameter {
            Parameter::Basal => None,
            Parameter::CarbRatio(slot) => Some(slot),
        };
        let w = WhatIf::one_setting(meal, d.new / d.old);
        let days = self.options.replay_days.min(twin.data.days);
        match twin.replay(events, &w, days) {
            Ok(r) => {
                self.stats.checked += 1;
                let held = r.change.value.below_70_pct > self.options.margin_pp;
                self.stats.held_back += u32::from(held);
                held
            }
            Err(_) => {
                self.stats.unchecked += 1;
                false
            }
        }
    }
}

impl<A: Advisor> Advisor for TwinChecked<A> {
    fn observe(&mut self, event: &Event) -> Result<Option<TherapySettings>, AdvisorError> {
        let answer = self.inner.observe(event)?;
        self.events.push(*event);
        if event.kind == EventKind::DayClosed {
            self.closed_days += 1;
            self.refit_if_due();
        }
        if answer.is_none() {
            return Ok(None);
        }
        // This event's decisions (the log's last ones, at its minute).
        let mut new: Vec<Decision> = self
            .inner
            .decisions()
            .iter()
            .rev()
            .take_while(|d| d.at == event.at)
            .filter(|d| d.new != d.old)
            .cloned()
            .collect();
        new.reverse();
        let mut rejected = false;
        for d in &new {
            if !self.holds_back(d) {
                continue;
            }
            let value = match d.parameter {
                Parameter::Basal => SettingValue::Basal {
                    rate: UnitsPerHour(d.old),
                },
                Parameter::CarbRatio(slot) => SettingValue::CarbRatio {
                    slot,
                    ratio: GramsPerUnit(d.old),
                },
            };
            let reject = Event::new(event.at, EventKind::SuggestionRejected(value));
            self.inner.observe(&reject)?;
            self.events.push(reject);
            rejected = true;
        }
        Ok(if rejected {
            Some(*self.inner.settings())
        } else {
            answer
        })
    }

    fn settings(&self) -> &TherapySettings {
        self.inner.settings()
    }

    fn decisions(&self) -> &[Decision] {
        self.inner.decisions()
    }

    fn take_decisions(&mut self) -> Vec<Decision> {
        self.inner.take_decisions()
    }

    fn arm(&self) -> ArmKind {
        match self.inner.arm() {
            ArmKind::Abba => ArmKind::AbbaTwin,
            other => other,
        }
    }

    fn mode(&self) -> Option<Mode> {
        self.inner.mode()
    }
}

/// Runs `vp` through `scenario` in the ABBA arm with the twin check, with
/// `options` (instead of the configuration's `twin_check` section); the
/// result is the trial's [`PatientResult`] (comparable with the plain ABBA
/// arm's, paired: same person, same days) and what the check did.
pub fn run_patient(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
    options: TwinArmOptions,
) -> Result<(PatientResult, TwinArmStats), TrialError> {
    let (mut person, advisor, context) =
        closed_loop::start(config, vp, patient_no, scenario, ArmKind::Abba)?;
    let closed_loop::ArmAdvisor::Plain(advisor) = advisor else {
        return Err(TrialError::Config(format!(
            "{context}: the ABBA arm built a twin-checked advisor"
        )));
    };
    let mut checked = TwinChecked::new(
        advisor,
        &vp.params.name,
        config.population,
        vp.therapy,
        options,
    );
    let run = closed_loop::simulate(
        &mut person,
        &mut checked,
        scenario.config.days,
        config.failure_glucose_mg_dl,
        &mut Trace::default(),
        &context,
    )?;
    let stats = checked.stats;
    let advisor = closed_loop::ArmAdvisor::TwinChecked(Box::new(checked));
    let r = closed_loop::result(vp, &person, &advisor, &run, &context)?;
    Ok((r, stats))
}
