//! Plain words for the advisor's explanations.

use abba_advisor::bounds::Side;
use abba_advisor::decision::AbbaExplanation;
use abba_advisor::supervisor::SupervisoryRule;
use abba_advisor::{AbbaConfig, Decision, DecisionDetail, Parameter, SkipReason};

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

fn rule(r: SupervisoryRule) -> &'static str {
    match r {
        SupervisoryRule::SmbgCirInRange => "no reading outside the target range after this meal, so no safety correction",
        SupervisoryRule::SmbgCirHypo => "a low reading after this meal: the safety rule raises the carb ratio (less insulin)",
        SupervisoryRule::SmbgCirHyper => "only high readings after this meal: the safety rule lowers the carb ratio (more insulin)",
        SupervisoryRule::SmbgBrHyponumber => "a reading below 70 mg/dL that day: the safety rule lowers the basal rate",
        SupervisoryRule::SmbgBrMostlyHigh => "mostly high readings that day: the safety rule raises the basal rate",
        SupervisoryRule::SmbgBrMostlyLow => "mostly low readings that day: the safety rule lowers the basal rate",
        SupervisoryRule::SmbgBrOther => "no clear pattern that day, so no safety correction",
        SupervisoryRule::CgmNoHypo => "no low glucose, so no safety correction",
        SupervisoryRule::CgmHypoOnly => "low glucose only: the safety rule moves toward less insulin",
        SupervisoryRule::CgmMixed => "both low and high glucose: a smaller safety move toward less insulin",
    }
}

fn pct(x: f64) -> String {
    format!("{:+.1} %", 100.0 * x)
}

/// The reasons of one update, in plain words, one sentence each.
pub fn reasons(d: &Decision, cfg: &AbbaConfig) -> Vec<String> {
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
    let mut out = vec![format!(
        "{} of {} readings were above {:.0} mg/dL and {} below {:.0} mg/dL (high score {:.2}, low score {:.2}).",
        w.n_hyper, w.n, f.g_high_mg_dl, w.n_hypo, f.g_low_mg_dl, x.features.hyper, x.features.hypo
    )];
    out.push(format!("Safety rules: {}.", rule(x.supervisory_rule)));
    out.push(format!(
        "The learned policy proposed {}, the safety rule {}, exploration {}: {} in all.",
        pct(x.action.p_a),
        pct(x.action.p_s),
        pct(x.action.exploration),
        pct(x.action.p_e)
    ));
    if x.applied.switch_fired {
        out.push("The carb ratio was kept because the basal rate moved the other way (bolus and basal insulin must not both move the same way).".into());
    }
    if x.applied.clamp_fired {
        out.push(format!(
            "The change was limited to {:.0} % a day.",
            100.0 * cfg.update.max_relative_change
        ));
    }
    if x.applied.hypo_guard_fired {
        out.push("An increase of insulin was cancelled because of a low reading.".into());
    }
    if x.applied.non_finite {
        out.push("The computation gave no usable number; the value stays.".into());
    }
    if let Some(b) = x.bound {
        let side = match b.side {
            Side::Lower => "lower",
            Side::Upper => "upper",
        };
        out.push(format!(
            "Held at your clinician's {side} bound {} {} (the advisor asked for {:.3}).",
            b.bound,
            d.parameter.unit(),
            b.requested
        ));
    }
    out
}
