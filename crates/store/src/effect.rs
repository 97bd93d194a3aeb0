//! A suggestion's predicted effect, and the twin check.
//!
//! The store defines the interface ([`EffectPredictor`]) and never
//! implements it: the `abba` binary wires in a person's twin (abba-twin),
//! so the store, the service and the pages stay free of the simulator.
//! The question asked of a predictor is plain: this person's log (the
//! events the advice was built from), one setting, its value in force and
//! the suggested value. The answer is the predicted time in 70-180 mg/dL
//! and below 70 mg/dL over the recent days, in force (the recorded days
//! as they were) and with the suggestion (the same days with the change
//! applied), each with its band; or why there is no prediction (no twin
//! yet, a twin not usable, a twin older than the data, a replay that
//! failed).
//!
//! **The twin check** ([`TwinCheck`], on by default): an open suggestion
//! whose predicted time below 70 mg/dL rises by more than
//! [`TWIN_CHECK_MARGIN_PP`] percentage points (the MAP value of the
//! change) is held back: its status becomes `held_back` and what to use
//! today stays the value in force; the figures go with it. Only a
//! prediction can hold a suggestion back: without one (no usable twin on
//! the current data) the advice is what the advisor alone says, and says
//! why there is no prediction.

use crate::advise::Advice;
use abba_advisor::Parameter;
use abba_core::Event;
use serde::Serialize;

/// The twin check's default margin: a suggestion is held back when its
/// predicted time below 70 mg/dL rises by more than this (percentage
/// points of the recent days). One point is about 14 minutes a day, a
/// quarter of the 4 % the international consensus on time in ranges
/// (Battelino et al., Diabetes Care 2019) accepts below 70 mg/dL in all.
pub const TWIN_CHECK_MARGIN_PP: f64 = 1.0;

/// A figure with its 5-95 % band.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Band {
    /// The value (at the twin's most probable parameters).
    pub value: f64,
    /// 5th percentile.
    pub low: f64,
    /// 95th percentile.
    pub high: f64,
}

/// Time in range and below 70 mg/dL (%).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Figures {
    /// % of the time in 70-180 mg/dL.
    pub tir_pct: Band,
    /// % of the time below 70 mg/dL.
    pub below_70_pct: Band,
}

/// A prediction.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Predicted {
    /// Recent days replayed.
    pub days: usize,
    /// The twin's revision.
    pub twin_revision: u32,
    /// The twin's grade (`good` or `fair`).
    pub grade: String,
    /// The recorded days as they were (the settings in force).
    pub in_force: Figures,
    /// The same days with the suggestion.
    pub suggested: Figures,
    /// Suggested minus in force (percentage points), with the band of the
    /// difference.
    pub change: Figures,
}

/// Why there is no prediction.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "why", rename_all = "snake_case")]
pub enum NoPrediction {
    /// Effects are not predicted here (no predictor wired in).
    NotAvailable,
    /// The person has no twin yet.
    NoTwin,
    /// The twin's grade is "not usable".
    NotUsable {
        /// Its grade's reason.
        reason: String,
    },
    /// The log changed since the twin was fitted.
    Outdated {
        /// The twin's revision.
        revision: u32,
    },
    /// The replay failed.
    Failed {
        /// What went wrong.
        reason: String,
    },
}

/// A predictor's answer.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Effect {
    /// The predicted effect.
    Predicted(Predicted),
    /// None, and why.
    None(NoPrediction),
}

/// The question: one setting of one person, in force and suggested.
#[derive(Debug, Clone, Copy)]
pub struct EffectQuery<'a> {
    /// The person's name.
    pub person: &'a str,
    /// The events the advice was built from (the whole log).
    pub events: &'a [Event],
    /// The setting.
    pub parameter: Parameter,
    /// Its value in force.
    pub in_force: f64,
    /// The suggested value.
    pub suggested: f64,
}

/// What predicts a suggestion's effect (the `abba` binary: the person's
/// stored twin). Must be cheap per call (no fitting): the service calls
/// it inside requests.
pub trait EffectPredictor: Send + Sync {
    /// The effect of `q.suggested` against `q.in_force`, or why none.
    fn predict(&self, q: &EffectQuery<'_>) -> Effect;
}

/// What a refit did.
#[derive(Debug, Clone, PartialEq)]
pub enum RefitOutcome {
    /// The person has no twin (none is made).
    NoTwin,
    /// The twin was fitted on exactly this log already: kept.
    Unchanged {
        /// Its revision.
        revision: u32,
    },
    /// A new revision was stored.
    Refitted {
        /// The new revision.
        revision: u32,
        /// Its grade (`good`, `fair`, `not usable`).
        grade: String,
    },
}

/// What refits a person's twin when their log changed (the `abba` binary:
/// abba-twin's refit rule on the twin stored beside the store). A refit
/// takes seconds: the service runs it only on its refit worker.
pub trait TwinRefitter: Send + Sync {
    /// Whether `person` has a stored twin (cheap: no fit, no store read).
    fn has_twin(&self, person: &str) -> bool;

    /// Refits `person`'s twin on their whole log in `store`, if they have
    /// one. An error says why nothing was stored (the old twin stays).
    fn refit(&self, store: &crate::Store, person: &str) -> Result<RefitOutcome, String>;
}

/// The twin check, a named knob.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwinCheck {
    /// On (the default).
    pub on: bool,
    /// The margin (percentage points of time below 70 mg/dL).
    pub margin_pp: f64,
}

impl Default for TwinCheck {
    fn default() -> Self {
        Self {
            on: true,
            margin_pp: TWIN_CHECK_MARGIN_PP,
        }
    }
}

/// What the twin check made of a suggestion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CheckOutcome {
    /// The predicted time below 70 does not rise by more than the margin.
    Passed,
    /// It does: the suggestion is held back.
    HeldBack,
    /// The check is off.
    Off,
    /// No prediction, nothing to check.
    NoPrediction,
}

/// The effect of a setting's open suggestion and the check's outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SettingEffect {
    /// The prediction, or why none.
    pub effect: Effect,
    /// The twin check.
    pub check: CheckOutcome,
    /// The margin the check used (percentage points).
    pub margin_pp: f64,
}

/// A predictor and the twin check, as the advice uses them.
#[derive(Clone, Copy)]
pub struct Effects<'a> {
    /// The predictor.
    pub predictor: &'a dyn EffectPredictor,
    /// The check.
    pub check: TwinCheck,
}

impl std::fmt::Debug for Effects<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Effects")
            .field("check", &self.check)
            .finish_non_exhaustive()
    }
}

/// The check's outcome for `effect`.
pub fn check(effect: &Effect, check: TwinCheck) -> CheckOutcome {
    match effect {
        Effect::None(_) => CheckOutcome::NoPrediction,
        Effect::Predicted(_) if !check.on => CheckOutcome::Off,
        Effect::Predicted(p) if p.change.below_70_pct.value > check.margin_pp => {
            CheckOutcome::HeldBack
        }
        Effect::Predicted(_) => CheckOutcome::Passed,
    }
}

/// Puts the predicted effect beside each open suggestion of `advice`
/// (built from `events`) and applies the twin check: a held-back
/// suggestion's status becomes `held_back` and what to use today is the
/// value in force. Without `effects`, every open suggestion says that
/// effects are not predicted here.
pub fn predict(advice: &mut Advice, events: &[Event], effects: Option<Effects<'_>>) {
    for s in &mut advice.settings {
        let Some(v) = s.latest.as_mut() else {
            continue;
        };
        if v.status != "open" {
            continue;
        }
        let Some(&parameter) = crate::advise::PARAMETERS
            .iter()
            .find(|p| crate::answer::param_key(**p) == s.setting)
        else {
            continue;
        };
        let (effect, outcome, margin) = match effects {
            None => (
                Effect::None(NoPrediction::NotAvailable),
                CheckOutcome::NoPrediction,
                TwinCheck::default().margin_pp,
            ),
            Some(e) => {
                let effect = e.predictor.predict(&EffectQuery {
                    person: &advice.person,
                    events,
                    parameter,
                    in_force: v.previous,
                    suggested: v.suggested,
                });
                let outcome = check(&effect, e.check);
                (effect, outcome, e.check.margin_pp)
            }
        };
        if outcome == CheckOutcome::HeldBack {
            v.status = "held_back".into();
            s.use_today = s.in_force;
        }
        s.effect = Some(SettingEffect {
            effect,
            check: outcome,
            margin_pp: margin,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn band(v: f64) -> Band {
        Band {
            value: v,
            low: v - 1.0,
            high: v + 1.0,
        }
    }

    fn predicted(d_below: f64) -> Effect {
        let f = |tir: f64, below: f64| Figures {
            tir_pct: band(tir),
            below_70_pct: band(below),
        };
        Effect::Predicted(Predicted {
            days: 7,
            twin_revision: 1,
            grade: "good".into(),
            in_force: f(70.0, 2.0),
            suggested: f(71.0, 2.0 + d_below),
            change: f(1.0, d_below),
        })
    }

    #[test]
    fn the_check_holds_back_only_a_rise_above_the_margin() {
        let on = TwinCheck::default();
        assert_eq!(check(&predicted(1.5), on), CheckOutcome::HeldBack);
        assert_eq!(check(&predicted(1.0), on), CheckOutcome::Passed);
        assert_eq!(check(&predicted(-3.0), on), CheckOutcome::Passed);
        let off = TwinCheck { on: false, ..on };
        assert_eq!(check(&predicted(5.0), off), CheckOutcome::Off);
        let none = Effect::None(NoPrediction::NoTwin);
        assert_eq!(check(&none, on), CheckOutcome::NoPrediction);
    }
}
