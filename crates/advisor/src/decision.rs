//! Explanations: every decision records why a setting moved (or did not).

use crate::agent::{Action, ActorStep, Learning};
use crate::features::{Features, WindowStats};
use crate::fusion::Applied;
use crate::parameter::Parameter;
use crate::supervisor::SupervisoryRule;
use abba_core::Timestamp;
use serde::{Deserialize, Serialize};

/// Why a decision point left the setting unchanged without computing an action.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SkipReason {
    /// The window held no reading (spec §2.4): no action, no learning step.
    EmptyWindow,
    /// No window for this meal on the previous day (meal skipped or not seen, spec §2.4).
    NoPreviousDayWindow,
    /// No basal data for the closed day.
    NoDayData,
    /// Run-to-run: no fasting (or night) glucose for the basal update.
    NoFastingGlucose,
    /// Run-to-run: no post-meal glucose in the window.
    NoPostMealGlucose,
    /// The window held fewer readings than the minimum set with
    /// [`crate::Abba::with_min_data`] (a sensor gap, missing meter readings).
    TooFewReadings {
        /// Readings in the window.
        n: u32,
        /// Readings required.
        required: u32,
    },
}

/// Everything ABBA computed for one update.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AbbaExplanation {
    /// Start of the window the features come from.
    pub window_start: Timestamp,
    /// End of the window (exclusive).
    pub window_end: Timestamp,
    /// Counts of the window (n, hyper/hypo counts, Hyponumber, N1, N2).
    pub window: WindowStats,
    /// The features F (eq10-12).
    pub features: Features,
    /// Local cost c (eq13).
    pub cost: f64,
    /// The learning step for the previous decision (critic, actor eq28).
    pub learning: Learning,
    /// Which supervisory rule fired.
    pub supervisory_rule: SupervisoryRule,
    /// P_a, P_s, P_d, σ, the exploration draw and P_e (eq22-25).
    pub action: Action,
    /// The most recent basal change (BR_old, BR_final) seen by the switch rule.
    pub br_change: Option<(f64, f64)>,
    /// AP_new, AP_fusion, switch rule, clamp and the final value (eq16-21).
    pub applied: Applied,
    /// The clinician bound that held the value, if one did (applied after
    /// the clamp; `applied.new` is then the bound).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bound: Option<crate::bounds::BoundHeld>,
    /// The rounding to the pump's step, when the person's pump has one
    /// (`applied.new` is then the rounded value).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rounded: Option<Rounded>,
}

/// A suggestion rounded to the pump's step ([`crate::steps`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Rounded {
    /// The value after the clamp and the bounds, before rounding.
    pub requested: f64,
    /// The pump's step.
    pub step: f64,
    /// The rounded value (the value in force when a change is below one step).
    pub new: f64,
    /// A basal schedule: every segment scaled and rounded (its mean is `new`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub segments: Option<Vec<(u32, f64)>>,
    /// The relative change carried from earlier updates that were below one
    /// step, included in `requested` (0: none).
    #[serde(default)]
    pub carried: f64,
}

/// What a run-to-run update computed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct R2rExplanation {
    /// The performance measure y (mg/dL): fasting/night glucose or post-meal
    /// glucose (None when a hypo override fired without one).
    pub measure_mg_dl: Option<f64>,
    /// Reference G_ref (mg/dL).
    pub reference_mg_dl: f64,
    /// Relative change requested K·e/G_ref before the cap (for a carb ratio: of I:C).
    pub raw_relative_change: f64,
    /// The cap fired.
    pub capped: bool,
    /// The hypoglycaemia override fired.
    pub hypo_override: bool,
}

/// The details of a decision.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum DecisionDetail {
    /// An ABBA update.
    Abba(Box<AbbaExplanation>),
    /// A run-to-run update.
    RunToRun(R2rExplanation),
    /// A nightly autotune run.
    Autotune(Box<crate::baselines::autotune::arm::AutotuneExplanation>),
    /// A decision point without an update.
    Skipped {
        /// Why.
        reason: SkipReason,
    },
}

/// One decision: which setting, when, old and new value, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Decision {
    /// The event that triggered it.
    pub at: Timestamp,
    /// The setting.
    pub parameter: Parameter,
    /// Value before (U/h or g/U).
    pub old: f64,
    /// Value from now on (U/h or g/U).
    pub new: f64,
    /// Why.
    pub detail: DecisionDetail,
}

impl std::fmt::Display for Decision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {}: {:.4} -> {:.4} {} ({:+.2} %)",
            self.at,
            self.parameter,
            self.old,
            self.new,
            self.parameter.unit(),
            100.0 * (self.new / self.old - 1.0)
        )?;
        match &self.detail {
            DecisionDetail::Skipped { reason } => write!(f, "; skipped: {reason:?}"),
            DecisionDetail::Autotune(x) => write!(
                f,
                "; autotune: {} basal, {} ISF, {} carb-absorption, {} UAM data, {} carb-ratio \
                 periods; ISF {:.1} mg/dL/U, carb ratio {:.2} g/U",
                x.basal_data, x.isf_data, x.csf_data, x.uam_data, x.cr_periods, x.isf, x.carb_ratio
            ),
            DecisionDetail::RunToRun(r) => write!(
                f,
                "; run-to-run: y = {} mg/dL vs {:.0}, requested {:+.2} %{}{}",
                r.measure_mg_dl
                    .map_or("none".to_string(), |y| format!("{y:.1}")),
                r.reference_mg_dl,
                100.0 * r.raw_relative_change,
                if r.capped { ", capped" } else { "" },
                if r.hypo_override {
                    ", hypo override"
                } else {
                    ""
                }
            ),
            DecisionDetail::Abba(x) => {
                write!(
                    f,
                    "; n = {}, F = ({:.4}, {:.4}), c = {:.4}, P_a = {:+.5}, P_s = {:+.5} ({:?}), \
                     P_d = {:+.5}, sigma = {:.5}, exploration = {:+.5}, P_e = {:+.5}",
                    x.window.n,
                    x.features.hyper,
                    x.features.hypo,
                    x.cost,
                    x.action.p_a,
                    x.action.p_s,
                    x.supervisory_rule,
                    x.action.p_d,
                    x.action.sigma,
                    x.action.exploration,
                    x.action.p_e
                )?;
                if let Some(d) = x.learning.td_error {
                    write!(f, ", TD error = {d:+.5}")?;
                }
                if let ActorStep::Applied { delta, clipped } = x.learning.actor {
                    write!(
                        f,
                        ", dtheta = ({:+.4}, {:+.4}){}",
                        delta[0],
                        delta[1],
                        if clipped { " clipped" } else { "" }
                    )?;
                }
                if x.applied.switch_fired {
                    write!(f, ", switch rule fired (basal moved the other way)")?;
                }
                if x.applied.clamp_fired {
                    write!(f, ", 5 % clamp fired")?;
                }
                if let Some(b) = x.bound {
                    write!(
                        f,
                        ", held at the clinician's {:?} bound {} (requested {:.4})",
                        b.side, b.bound, b.requested
                    )?;
                }
                if x.applied.hypo_guard_fired {
                    write!(f, ", hypo guard cancelled an insulin increase")?;
                }
                if let Some(r) = x.applied.recent_low {
                    write!(
                        f,
                        ", a reading below {} mg/dL in the last {} h cancelled an insulin increase",
                        r.below_mg_dl, r.hours
                    )?;
                }
                if x.applied.non_finite {
                    write!(f, ", non-finite action ignored")?;
                }
                Ok(())
            }
        }
    }
}

/// A bounded log of decisions. When it is full, the oldest half is dropped
/// (amortised O(1)) and counted; drain it regularly with `take`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DecisionLog {
    items: Vec<Decision>,
    capacity: usize,
    dropped: u64,
}

impl DecisionLog {
    /// An empty log holding at most `capacity` decisions.
    pub fn new(capacity: usize) -> Self {
        Self {
            items: Vec::new(),
            capacity: capacity.max(1),
            dropped: 0,
        }
    }

    /// Appends a decision.
    pub fn push(&mut self, d: Decision) {
        if self.items.len() >= self.capacity {
            let n = (self.capacity / 2).max(1).min(self.items.len());
            self.items.drain(..n);
            self.dropped += n as u64;
        }
        self.items.push(d);
    }

    /// The retained decisions, oldest first.
    pub fn as_slice(&self) -> &[Decision] {
        &self.items
    }

    /// Removes and returns the retained decisions.
    pub fn take(&mut self) -> Vec<Decision> {
        std::mem::take(&mut self.items)
    }

    /// Decisions dropped because the log was full.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}
