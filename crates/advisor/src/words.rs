//! The advisor's decisions in plain words for the person: why a decision
//! point gave no update, and the reasons of one update, every number
//! reconciling with the change shown, glucose in the person's unit. The
//! one home of these sentences: the store's advice view carries them to
//! the CLI, the service's API and the app alike.

use crate::bounds::Side;
use crate::decision::AbbaExplanation;
use crate::supervisor::SupervisoryRule;
use crate::{AbbaConfig, Decision, DecisionDetail, Parameter, SkipReason};
use abba_core::units::GlucoseUnit;

/// Why a decision point gave no update, in plain words.
pub fn skip_reason(r: SkipReason, p: Parameter) -> String {
    match r {
        SkipReason::EmptyWindow => "no glucose reading in the window it learns from".into(),
        SkipReason::NoPreviousDayWindow => match p {
            Parameter::CarbRatio(s) => format!("{} was not announced on the previous day, so there is nothing to learn from", s.name()),
            Parameter::Basal => "no previous day to learn from".into(),
        },
        SkipReason::NoDayData => "no glucose reading that day".into(),
        SkipReason::NoFastingGlucose => "no fasting glucose that day".into(),
        SkipReason::NoPostMealGlucose => "no glucose after that meal".into(),
        SkipReason::TooFewReadings { n, required } => format!(
            "too little data: {n} readings where {required} are needed (a sensor gap or missing meter readings); the value stays"
        ),
    }
}

fn rule(r: SupervisoryRule, unit: GlucoseUnit) -> String {
    if r == SupervisoryRule::SmbgBrHyponumber {
        let low = glucose(70.0, unit);
        return format!("a reading below {low} that day: the safety rule lowers the basal rate");
    }
    match r {
        SupervisoryRule::SmbgCirInRange => "no reading outside the target range after this meal, so no safety correction",
        SupervisoryRule::SmbgCirHypo => "a low reading after this meal: the safety rule raises the carb ratio (less insulin)",
        SupervisoryRule::SmbgCirHyper => "only high readings after this meal: the safety rule lowers the carb ratio (more insulin)",
        SupervisoryRule::SmbgBrMostlyHigh => "mostly high readings that day: the safety rule raises the basal rate",
        SupervisoryRule::SmbgBrMostlyLow => "mostly low readings that day: the safety rule lowers the basal rate",
        SupervisoryRule::SmbgBrOther => "no clear pattern that day, so no safety correction",
        SupervisoryRule::CgmNoHypo => "no low glucose, so no safety correction",
        SupervisoryRule::CgmHypoOnly => "low glucose only: the safety rule moves toward less insulin",
        SupervisoryRule::CgmMixed => "both low and high glucose: a smaller safety move toward less insulin",
        SupervisoryRule::SmbgBrHyponumber => "",
    }
    .to_string()
}

fn pct(x: f64) -> String {
    format!("{:+.1} %", 100.0 * x)
}

/// A glucose value in the person's unit.
fn glucose(mg_dl: f64, unit: GlucoseUnit) -> String {
    unit.with_unit(mg_dl)
}

/// The reasons of one update, in plain words, one sentence each (mg/dL).
pub fn reasons(d: &Decision, cfg: &AbbaConfig) -> Vec<String> {
    reasons_in(d, cfg, GlucoseUnit::MgDl)
}

/// The reasons of one update in the person's unit. Every number
/// reconciles with the change shown: the step the agents asked for, the
/// part of it the update applies (the average with the value in force),
/// then each rule that changed it, and the change in all.
pub fn reasons_in(d: &Decision, cfg: &AbbaConfig, unit: GlucoseUnit) -> Vec<String> {
    let x: &AbbaExplanation = match &d.detail {
        DecisionDetail::Abba(x) => x,
        DecisionDetail::Skipped { reason } => {
            return vec![format!("No update: {}.", skip_reason(*reason, d.parameter))]
        }
        DecisionDetail::RunToRun(_) => return vec!["A run-to-run update.".into()],
        DecisionDetail::Autotune(_) => return vec!["A nightly autotune (oref0) update.".into()],
    };
    let f = &cfg.features;
    let w = &x.window;
    let u = d.parameter.unit();
    let mut out = vec![format!(
        "{} of the {} readings of the window (see data) were above {} and {} below {} (high score {:.2}, low score {:.2}).",
        w.n_hyper,
        w.n,
        glucose(f.g_high_mg_dl, unit),
        w.n_hypo,
        glucose(f.g_low_mg_dl, unit),
        x.features.hyper,
        x.features.hypo
    )];
    out.push(format!("Safety rules: {}.", rule(x.supervisory_rule, unit)));
    let a = &x.applied;
    let applied_rel = if a.old != 0.0 {
        a.ap_fusion / a.old - 1.0
    } else {
        0.0
    };
    out.push(format!(
        "The learned policy proposed {}, the safety rule {} (together {}), exploration {}: a step of {}. The update moves {:.0} % of the way (the average with the value in force): {} ({:.3} -> {:.3} {u}).",
        pct(x.action.p_a),
        pct(x.action.p_s),
        pct(x.action.p_d),
        pct(x.action.exploration),
        pct(x.action.p_e),
        100.0 * (1.0 - cfg.update.fusion_m),
        pct(applied_rel),
        a.old,
        a.ap_fusion,
    ));
    if a.switch_fired {
        let moved = x
            .br_change
            .map(|(o, n)| format!(" ({o:.3} -> {n:.3} U/h, {})", pct(n / o - 1.0)))
            .unwrap_or_default();
        out.push(format!("The carb ratio was kept because the basal rate last moved the other way{moved} (bolus and basal insulin must not both move the same way)."));
    }
    if a.clamp_fired {
        out.push(format!(
            "The change was limited to {:.0} % a day.",
            100.0 * cfg.update.max_relative_change
        ));
    }
    if a.hypo_guard_fired {
        out.push("An increase of insulin was cancelled because of a low reading.".into());
    }
    if a.non_finite {
        out.push("The computation gave no usable number; the value stays.".into());
    }
    if let Some(b) = x.bound {
        let side = match b.side {
            Side::Lower => "lower",
            Side::Upper => "upper",
        };
        out.push(format!(
            "Held at your clinician's {side} bound {} {u} (the advisor asked for {:.3}).",
            b.bound, b.requested
        ));
    }
    if let Some(r) = &x.rounded {
        if r.carried != 0.0 {
            out.push(format!(
                "With {} carried from earlier changes smaller than one step of your pump, the advisor asks for {:.3} {u}.",
                pct(r.carried),
                r.requested
            ));
        }
        if (r.new - r.requested).abs() > 1e-12 {
            out.push(if (r.new - d.old).abs() < 1e-12 {
                format!(
                    "{:.3} {u} is less than one step of your pump ({} {u}) from the value in force: no change.",
                    r.requested, r.step
                )
            } else {
                format!(
                    "Rounded to your pump's step of {} {u}: {:.3} -> {} {u}.",
                    r.step, r.requested, r.new
                )
            });
        }
    }
    out.push(format!(
        "In all: {:.3} -> {:.3} {u} ({}).",
        d.old,
        d.new,
        pct(if d.old != 0.0 {
            d.new / d.old - 1.0
        } else {
            0.0
        })
    ));
    out
}
