//! Today's advice as text for people.

use abba_core::units::GlucoseUnit;
use abba_store::advise::{Advice, Phase, SettingAdvice};
use abba_store::effect::{Band, CheckOutcome, Effect, NoPrediction, SettingEffect};
use std::fmt::Write as _;

fn band(b: &Band) -> String {
    format!("{:.1} % ({:.1} to {:.1})", b.value, b.low, b.high)
}

fn points(b: &Band) -> String {
    format!("{:+.1} points ({:+.1} to {:+.1})", b.value, b.low, b.high)
}

/// A suggestion's predicted effect and the twin check, in sentences (the
/// CLI's words; `abba advise` and `abba report`).
pub fn effect_lines(
    name: &str,
    unit: &str,
    in_force: f64,
    e: &SettingEffect,
    glucose: GlucoseUnit,
) -> Vec<String> {
    let mut out = Vec::new();
    // The ranges in the person's glucose unit.
    let range = glucose.range(70.0, 180.0);
    let below = glucose.with_unit(70.0);
    match &e.effect {
        Effect::Predicted(p) => {
            out.push(format!(
                "Predicted on your twin (revision {}, {}) over the last {} days: time in range {range} {} with the suggestion, {} in force ({}); time below {below} {} with it, {} in force ({}).",
                p.twin_revision,
                p.grade,
                p.days,
                band(&p.suggested.tir_pct),
                band(&p.in_force.tir_pct),
                points(&p.change.tir_pct),
                band(&p.suggested.below_70_pct),
                band(&p.in_force.below_70_pct),
                points(&p.change.below_70_pct),
            ));
            match e.check {
                CheckOutcome::HeldBack => out.push(format!(
                    "Held back by the twin check: your twin predicts time below {below} rising by {:.1} points, more than the {:.1}-point margin. Keep {in_force:.3} {unit} today and talk it over with your clinician.",
                    p.change.below_70_pct.value, e.margin_pp
                )),
                CheckOutcome::Passed => out.push(format!(
                    "Twin check passed: time below {below} does not rise by more than {:.1} points.",
                    e.margin_pp
                )),
                CheckOutcome::Off => out.push("Twin check off (--twin-check off).".into()),
                CheckOutcome::NoPrediction => {}
            }
        }
        Effect::None(why) => out.push(format!(
            "No predicted effect for the {name}: {}.",
            match why {
                NoPrediction::NotAvailable => "effects are not predicted here".to_string(),
                NoPrediction::NoTwin =>
                    "no twin yet (`abba twin fit` makes one from your data)".to_string(),
                NoPrediction::NotUsable { reason } =>
                    format!("your twin is not usable ({reason})"),
                NoPrediction::Outdated { revision } => format!(
                    "your twin (revision {revision}) is older than your data; `abba twin fit` refits it"
                ),
                NoPrediction::Failed { reason } =>
                    format!("the twin's replay failed ({reason})"),
            }
        )),
    }
    out
}

/// The setting's name in the CLI's words.
pub fn setting_name(setting: &str) -> String {
    match setting {
        "basal" => "Basal rate".into(),
        meal => format!("{}{} carb ratio", meal[..1].to_uppercase(), &meal[1..]),
    }
}

fn setting(s: &mut String, a: &SettingAdvice, glucose: GlucoseUnit) {
    let _ = writeln!(
        s,
        "{}: {:.3} {} in force",
        setting_name(a.setting),
        a.in_force,
        a.unit
    );
    let Some(v) = &a.latest else {
        let _ = writeln!(s, "  no suggestion yet");
        return;
    };
    if v.no_update {
        let _ = writeln!(
            s,
            "  D{} ({}): no update. {}",
            v.day,
            v.decided_at,
            v.no_update_reason.as_deref().unwrap_or("")
        );
    } else if v.status == "no_change" {
        let _ = writeln!(
            s,
            "  D{} ({}): no change: the advisor's change is smaller than one step of your pump; nothing to answer",
            v.day, v.decided_at
        );
    } else if v.status == "not_offered" {
        let _ = writeln!(
            s,
            "  D{} ({}): no basal suggestion (see the delivery note above); the rate stays {:.3} {}",
            v.day, v.decided_at, v.previous, v.unit
        );
        return;
    } else {
        let what = match v.status.as_str() {
            "open" => "suggested, waiting for your answer",
            "held_back" => "held back by the twin check",
            other => other,
        };
        let _ = writeln!(
            s,
            "  D{} ({}): {:.3} -> {:.3} {} ({:+.1} %), {what}",
            v.day, v.decided_at, v.previous, v.suggested, v.unit, v.change_percent
        );
        if let Some(sch) = &v.schedule {
            let _ = writeln!(
                s,
                "    schedule: {} {}",
                abba_advisor::words::segments(sch),
                v.unit
            );
        }
        for r in &v.reasons {
            let _ = writeln!(s, "    - {r}");
        }
    }
    let _ = writeln!(s, "    data: {}", v.data);
    if let Some(e) = &a.effect {
        for line in effect_lines(
            &setting_name(a.setting).to_lowercase(),
            a.unit,
            a.in_force,
            e,
            glucose,
        ) {
            let _ = writeln!(s, "    {line}");
        }
    }
    if v.status == "open" {
        let _ = writeln!(
            s,
            "  Use today: {:.3} {} if you accept it.",
            a.use_today, a.unit
        );
    }
}

/// The advice as text.
/// `glucose`: the person's unit, for the predicted effects' ranges.
pub fn advice_text(a: &Advice, glucose: GlucoseUnit) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "abba advice for {} ({} mode, {})",
        a.person, a.mode, a.tz
    );
    let _ = writeln!(s, "{}\n", a.notice);
    match &a.phase {
        Phase::NoData => {
            let _ = writeln!(
                s,
                "No data yet: import a CGM/pump export with `abba import`."
            );
        }
        Phase::FirstWeek {
            days_done,
            days_left,
            missing,
        } => {
            let _ = writeln!(
                s,
                "First week: {days_done} day(s) collected, {days_left} to go. Keep your usual therapy; abba only collects data now."
            );
            for m in missing {
                let _ = writeln!(s, "  missing: {m}");
            }
        }
        Phase::Adapting => {
            let _ = writeln!(
                s,
                "abba updates the basal rate once a day and each meal's carb ratio at that meal."
            );
        }
    }
    if let Some(w) = &a.first_week {
        let _ = writeln!(
            s,
            "  qualifying days: {}",
            if w.qualifying.is_empty() {
                "none yet".into()
            } else {
                w.qualifying.join(", ")
            }
        );
        for m in &w.missing {
            let _ = writeln!(s, "  not qualifying: {m}");
        }
    }
    let d = &a.delivery;
    let _ = writeln!(s, "\nDelivery: {}.", d.words);
    if !d.evidence.is_empty() {
        let _ = writeln!(s, "  evidence: {}", d.evidence.join("; "));
    }
    if let Some(n) = &d.note {
        let _ = writeln!(s, "  {n}");
    }
    let t = &a.therapy;
    let _ = writeln!(s, "Therapy in force: {}.", t.source);
    if let Some(sch) = &t.basal_schedule {
        let _ = writeln!(s, "  basal schedule: {} U/h (the basal rate below is its mean; each update scales every segment)", abba_advisor::words::segments(sch));
    }
    if let Some(p) = &t.pump_steps {
        let _ = writeln!(
            s,
            "  pump steps: {} U/h, {} g/U (suggestions are rounded to them)",
            p.basal_u_per_h, p.carb_ratio_g_per_u
        );
    }
    for c in t.changes.iter().rev().take(5).rev() {
        let _ = writeln!(s, "  change {c}");
    }
    let _ = writeln!(s);
    for x in &a.settings {
        setting(&mut s, x, glucose);
    }
    let d = &a.data;
    let _ = writeln!(s, "\nData: {} records", d.records);
    if let Some((from, to)) = &d.span {
        let _ = writeln!(s, "  from {from} to {to}");
    }
    let counts: Vec<String> = d.events.iter().map(|(k, v)| format!("{k} {v}")).collect();
    let _ = writeln!(s, "  events: {}", counts.join(", "));
    if d.records_not_used > 0 {
        let _ = writeln!(
            s,
            "  {} record(s) not used, for example:",
            d.records_not_used
        );
        for e in &d.not_used_examples {
            let _ = writeln!(s, "    {e}");
        }
    }
    for n in &a.notes {
        let _ = writeln!(s, "  note: {n}");
    }
    if d.events_refused > 0 {
        let _ = writeln!(s, "  {} event(s) refused by the advisor", d.events_refused);
    }
    if a.settings.iter().any(|x| {
        x.latest
            .as_ref()
            .is_some_and(|v| v.status == "open" || v.status == "held_back")
    }) {
        let _ = writeln!(
            s,
            "\nAnswer with `abba answer --accept`, `--reject` or `--set basal=...,breakfast=...` once you have talked it over with your clinician."
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn effect(rise: f64) -> SettingEffect {
        let check = if rise > 1.0 {
            CheckOutcome::HeldBack
        } else {
            CheckOutcome::Passed
        };
        abba_store::testing::predicted_effect((80.0, 2.0), (82.0, 2.0 + rise), 1.0, check)
    }

    #[test]
    fn predicted_effects_name_the_ranges_in_the_persons_unit() {
        for (rise, check) in [(0.5, "Twin check passed"), (1.5, "Held back")] {
            let mmol = effect_lines("basal rate", "U/h", 0.9, &effect(rise), GlucoseUnit::MmolL);
            assert!(
                mmol[0].contains("time in range 3.9-10.0 mmol/L 82.0 %"),
                "{mmol:?}"
            );
            assert!(mmol[0].contains("time below 3.9 mmol/L"), "{mmol:?}");
            assert!(mmol[1].starts_with(check) && mmol[1].contains("below 3.9 mmol/L"));
            assert!(mmol.iter().all(|l| !l.contains("70")), "{mmol:?}");
            let mg = effect_lines("basal rate", "U/h", 0.9, &effect(rise), GlucoseUnit::MgDl);
            assert!(mg[0].contains("time in range 70-180 mg/dL"), "{mg:?}");
            assert!(mg[1].contains("below 70 mg/dL"), "{mg:?}");
        }
    }
}
