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
    if let Some(r) = a.recent_low {
        out.push(format!(
            "An increase of insulin was cancelled: a finger-stick in the last {} hours was below {}, and four readings a day miss most lows.",
            r.hours,
            glucose(r.below_mg_dl, unit)
        ));
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
        if b.from_outside {
            out.push(format!(
                "The value in force, {:.3} {u}, lies outside your clinician's bounds: the suggestion moves into them, by more than {:.0} % a day if need be.",
                d.old,
                100.0 * cfg.update.max_relative_change
            ));
        }
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
                match &r.segments {
                    // A schedule's segments are on the step, their mean
                    // need not be.
                    Some(_) => format!(
                        "Each segment rounded to your pump's step of {} {u}: {:.3} -> {:.3} {u} (the schedule's mean).",
                        r.step, r.requested, r.new
                    ),
                    None => format!(
                        "Rounded to your pump's step of {} {u}: {:.3} -> {} {u}.",
                        r.step, r.requested, r.new
                    ),
                }
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

/// Said by every human-facing output: what abba is, and is not.
pub const NOTICE: &str = "abba is research software, not a medical device. Changes to insulin therapy belong with your clinician: discuss any suggestion with them before you act on it.";

/// The data one update learned from: `n` readings between two local times.
pub fn data_window(n: u32, from: &str, to: &str) -> String {
    format!("{n} readings from {from} to {to}")
}

/// Why a basal update learned from part of the day (`[from, to)`, minutes
/// after midnight): the hours, and the age group whose defaults chose them
/// (`None`: the advisor's configuration chose them, not an age group's
/// defaults).
pub fn basal_hours(window_min: [i64; 2], group: Option<crate::AgeGroup>) -> String {
    let hours = format!(
        "The basal rate learns from the readings from {} to {} only",
        window_clock(window_min[0]),
        window_clock(window_min[1])
    );
    match group {
        Some(g) => format!("{hours}: the advisor's defaults for {}.", g.plural()),
        None => format!("{hours}, as the advisor's configuration sets."),
    }
}

/// A basal window's edge (minutes after the closed day's midnight) as a
/// clock time: `07:30`, or `22:30 the evening before` for a negative one.
pub fn window_clock(minutes: i64) -> String {
    let m = minutes.rem_euclid(24 * 60);
    let clock = format!("{:02}:{:02}", m / 60, m % 60);
    match minutes {
        i64::MIN..=-1 => format!("{clock} the evening before"),
        1440 => "24:00".into(),
        _ => clock,
    }
}

/// A decision that learned from no data window (a skipped decision point).
pub const NO_DATA_WINDOW: &str = "no data window";

/// The delivery of an app-fed person: what the pump app reports.
pub const DELIVERY_AS_APP_REPORTS: &str = "as the app reports it";

/// What the data gathered so far hold, for [`first_week_gaps`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FirstWeekData {
    /// CGM readings.
    pub cgm_readings: usize,
    /// CGM readings against the days spanned × the readings a day of the sensor's period (0-1).
    pub cgm_coverage: f64,
    /// Bolus records.
    pub boluses: usize,
    /// Announced meals (carbohydrate entries).
    pub meals: usize,
    /// Meter readings, when the person is in SMBG mode (none: CGM mode).
    pub meter_readings: Option<usize>,
}

/// What the first week still lacks, one sentence each (empty: nothing).
pub fn first_week_gaps(d: &FirstWeekData) -> Vec<String> {
    let mut missing = Vec::new();
    if d.cgm_readings == 0 {
        missing.push(
            "no CGM readings yet: the first week needs CGM data to set up the advisor".into(),
        );
    } else if d.cgm_coverage < 0.7 {
        missing.push(format!(
            "CGM coverage so far is {:.0} % (aim for 70 % or more)",
            100.0 * d.cgm_coverage
        ));
    }
    if d.boluses == 0 {
        missing.push("no bolus records yet (import your pump's data)".into());
    }
    if d.meals == 0 {
        missing.push("no meals (carbohydrate entries) yet".into());
    }
    if d.meter_readings == Some(0) {
        missing.push("no meter (finger-stick) readings yet".into());
    }
    missing
}

/// The rule a day of the first week must meet (imported records).
pub fn first_week_rule(init_days: u32) -> String {
    format!(
        "the first week needs {init_days} days each with at least 70 % of the expected CGM readings (SMBG mode: 3 meter readings) and pump records"
    )
}

/// Why one day of the first week does not qualify: `why` are its gaps
/// (see [`first_week_day_gaps`]); `today` for the last day of the data,
/// which no later data closed.
pub fn first_week_day(why: &[String], today: bool) -> String {
    if today {
        // The last day of the data: today's, or the day an export ends
        // (years ago, for an old one); either way no later data closed it.
        format!(
            "so far {} (the last day of the data: it counts once later data close it)",
            why.join(", ")
        )
    } else {
        why.join(", ")
    }
}

/// A day's gaps against the first week's rule: CGM readings below 70 % of
/// `expected` (CGM mode), meter readings below `needed` (SMBG mode, with
/// `smbg`), no pump record.
pub fn first_week_day_gaps(
    cgm: Option<(usize, usize)>,
    smbg: Option<(usize, usize)>,
    pump_records: usize,
) -> Vec<String> {
    let mut why = Vec::new();
    if let Some((n, expected)) = cgm {
        why.push(format!(
            "{n} CGM readings of the {expected} expected ({:.0} %; 70 % needed)",
            100.0 * n as f64 / expected as f64
        ));
    }
    if let Some((n, needed)) = smbg {
        why.push(format!("{n} meter readings ({needed} needed)"));
    }
    if pump_records == 0 {
        why.push("no pump records".into());
    }
    why
}

/// A local date, or "day N" (1-based) where the date cannot be written.
pub fn day_or_date(date: Option<String>, index: i64) -> String {
    date.unwrap_or_else(|| format!("day {}", index + 1))
}

/// A date with what is wrong with it.
pub fn dated(date: &str, why: &str) -> String {
    format!("{date}: {why}")
}

/// How insulin is delivered, when it is not the open-loop pump therapy
/// ABBA was designed for, for [`delivery_note`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NotDesignedFor<'a> {
    /// No pump or insulin record at all: the delivery is not known.
    NoInsulinRecords,
    /// A closed loop or injections (`shown`: what the data show, in
    /// words); `allowed`: the person was created with --allow-closed-loop.
    Delivery {
        /// What the data show, in words.
        shown: &'a str,
        /// Basal suggestions allowed anyway (research only).
        allowed: bool,
    },
}

/// What abba tells a person whose delivery it was not designed for.
pub fn delivery_note(d: NotDesignedFor<'_>) -> String {
    match d {
        NotDesignedFor::NoInsulinRecords => "The data hold no pump or insulin records, so abba cannot tell how insulin is delivered: ABBA was designed and validated for open-loop pump therapy and needs the pump's basal and bolus records. Import them (or an export that has them) before any basal rate is suggested.".to_string(),
        NotDesignedFor::Delivery { shown, allowed: false } => format!(
            "The data show {shown}. ABBA was designed and validated for open-loop pump therapy: abba suggests no basal rate (what the loop or the injections delivered is not a schedule to adapt). Carb ratios are still suggested. For research only, a person created with --allow-closed-loop gets basal suggestions."
        ),
        NotDesignedFor::Delivery { shown, allowed: true } => format!(
            "The data show {shown}, and this person was created with --allow-closed-loop (research only): basal suggestions are made although ABBA was not validated for it."
        ),
    }
}

/// A change of therapy the records show: when, from where, and what it
/// put in force (`basal`: segments as `HH:MM` and U/h).
pub fn therapy_change(
    instant: &str,
    origin: &str,
    basal: Option<&[(String, f64)]>,
    carb_ratios: Option<[f64; 3]>,
) -> String {
    let mut what = Vec::new();
    if let Some(b) = basal {
        what.push(format!("basal {}", schedule(b)));
    }
    if let Some([b, l, d]) = carb_ratios {
        what.push(format!(
            "carb ratios {}/{}/{} g/U",
            rate(b),
            rate(l),
            rate(d)
        ));
    }
    format!("from {instant} ({origin}): {}", what.join(", "))
}

/// A main meal the data never show in its window (`window`: `HH:MM-HH:MM`),
/// while `snacks` carbohydrate entries fell outside the windows or after
/// a window's first: why its carb ratio gets no suggestion.
pub fn meal_not_seen(meal: &str, window: &str, snacks: usize) -> String {
    format!(
        "No {meal} in the data: no carbohydrate entry in the {meal} window ({window}, local time); {}. abba suggests no {meal} carb ratio until a {meal} is logged in its window (meal windows are set when the person is created, --meal-windows).",
        match snacks {
            1 => "1 entry outside the windows or after a window's first was taken as a snack"
                .to_string(),
            n => format!(
                "{n} entries outside the windows or after a window's first were taken as snacks"
            ),
        }
    )
}

/// Segments of the basal schedule in force outside the clinician's basal
/// bounds, which hold the schedule's mean (`outside`: `HH:MM rate`).
pub fn segments_outside_bounds(min: f64, max: f64, outside: &[String]) -> String {
    format!(
        "Your clinician's basal bounds ({}-{} U/h) hold the schedule's mean, not each segment: {} U/h lie outside them, and each update scales every segment by the same factor. The pump's maximum basal rate is not checked by abba.",
        rate(min),
        rate(max),
        outside.join(", ")
    )
}

/// Readings the device reported only as Low or High (beyond its range).
pub fn censored_readings(n: usize) -> String {
    format!(
        "{n} glucose readings were reported by the device only as Low or High (beyond its range): they count at the device's limit, so the mean and the times below and above range are bounds, not exact values."
    )
}

/// Records of the log the advisor did not use, for a page that shows the
/// data (`examples`: a few, in words).
pub fn records_left_out(n: usize, examples: &[String]) -> String {
    format!(
        "{n} records of the log were left out of the advice, for example: {}.",
        examples.join("; ")
    )
}

/// A rate or ratio as people read it: at most four decimals, trailing
/// zeros dropped (a profile scaled by a percentage holds
/// 1.2000000000000002).
pub fn rate(v: f64) -> String {
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// An answer given to a suggestion that data imported after it changed:
/// what was answered, what the suggestion is now, and that the answer
/// stands (the value the person put in force stays).
pub fn answer_on_changed_suggestion(
    setting: &str,
    decided_at: &str,
    answer: &str,
    then: (f64, f64),
    now: (f64, f64),
    in_force: f64,
    unit: &str,
) -> String {
    format!(
        "The {setting} suggestion of {decided_at} was {} {unit} (from {} {unit}) when you answered ({answer}); data imported since change it to {} {unit} (from {} {unit}). Your answer stands: {} {unit} stays in force, and the next update starts from it.",
        rate(then.1),
        rate(then.0),
        rate(now.1),
        rate(now.0),
        rate(in_force)
    )
}

/// A basal schedule's segments in words: `HH:MM rate, ...` (no unit).
pub fn segments(segments: &[(String, f64)]) -> String {
    let segs: Vec<String> = segments
        .iter()
        .map(|(at, r)| format!("{at} {}", rate(*r)))
        .collect();
    segs.join(", ")
}

/// A basal schedule in words: `HH:MM rate` segments and U/h.
pub fn schedule(segments_: &[(String, f64)]) -> String {
    format!("{} U/h", segments(segments_))
}

/// The basal schedule in force, for a page that shows the basal rate as
/// the schedule's mean.
pub fn basal_schedule_in_force(segments: &[(String, f64)]) -> String {
    format!(
        "Basal schedule in force: {}; the basal rates below are its mean (each update scales every segment).",
        schedule(segments)
    )
}

/// A record the advisor did not use, as an example for the person.
pub fn record_not_used(origin: &str, kind: &str, reason: &str) -> String {
    format!("{origin} ({kind}): {reason}")
}

/// A setting's name for a report line (`basal`, or a meal's key).
pub fn setting_name(key: &str) -> String {
    match key {
        "basal" => "basal rate".to_string(),
        meal => format!("carb ratio ({meal})"),
    }
}

/// A suggestion's answer for a report line: its status key, and the value
/// in force with its unit for an override.
pub fn answer_words(status: &str, in_force: f64, unit: &str) -> String {
    match status {
        "open" => "not answered yet".to_string(),
        "overridden" => format!("set to {in_force:.3} {unit}"),
        "superseded" => "not answered before the next suggestion (taken as followed)".to_string(),
        "unseen" => "never shown (past data of one import; not followed)".to_string(),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn schedules_print_rates_without_binary_noise() {
        let s = vec![
            ("00:00".to_string(), 1.1),
            ("19:00".to_string(), 1.2000000000000002),
        ];
        assert_eq!(super::schedule(&s), "00:00 1.1, 19:00 1.2 U/h");
        assert_eq!(super::rate(0.6400000000000001), "0.64");
        assert_eq!(super::rate(0.025), "0.025");
        assert_eq!(super::rate(2.0), "2");
        let c = super::therapy_change(
            "2026-05-13 22:30",
            "x",
            Some(&s),
            Some([9.0, 12.5, 0.30000000000000004 * 10.0]),
        );
        assert_eq!(
            c,
            "from 2026-05-13 22:30 (x): basal 00:00 1.1, 19:00 1.2 U/h, carb ratios 9/12.5/3 g/U"
        );
    }

    use super::{basal_hours, window_clock};
    use crate::AgeGroup;

    #[test]
    fn window_edges_read_as_clock_times() {
        assert_eq!(window_clock(450), "07:30");
        assert_eq!(window_clock(0), "00:00");
        assert_eq!(window_clock(1440), "24:00");
        assert_eq!(window_clock(-90), "22:30 the evening before");
        assert_eq!(
            basal_hours([-90, 450], Some(AgeGroup::Adult)),
            "The basal rate learns from the readings from 22:30 the evening before to 07:30 only: \
             the advisor's defaults for adults."
        );
    }
}
