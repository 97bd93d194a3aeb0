//! Today's advice as text for people.

use abba_store::advise::{Advice, Phase, SettingAdvice};
use std::fmt::Write as _;

fn name(setting: &str) -> String {
    match setting {
        "basal" => "Basal rate".into(),
        meal => format!("{}{} carb ratio", meal[..1].to_uppercase(), &meal[1..]),
    }
}

fn setting(s: &mut String, a: &SettingAdvice) {
    let _ = writeln!(
        s,
        "{}: {:.3} {} in force",
        name(a.setting),
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
        let what = if v.status == "open" {
            "suggested, waiting for your answer"
        } else {
            v.status.as_str()
        };
        let _ = writeln!(
            s,
            "  D{} ({}): {:.3} -> {:.3} {} ({:+.1} %), {what}",
            v.day, v.decided_at, v.previous, v.suggested, v.unit, v.change_percent
        );
        if let Some(sch) = &v.schedule {
            let segs: Vec<String> = sch.iter().map(|(t, r)| format!("{t} {r}")).collect();
            let _ = writeln!(s, "    schedule: {} {}", segs.join(", "), v.unit);
        }
        for r in &v.reasons {
            let _ = writeln!(s, "    - {r}");
        }
    }
    let _ = writeln!(s, "    data: {}", v.data);
    if v.status == "open" {
        let _ = writeln!(
            s,
            "  Use today: {:.3} {} if you accept it.",
            a.use_today, a.unit
        );
    }
}

/// The advice as text.
pub fn advice_text(a: &Advice) -> String {
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
        let segs: Vec<String> = sch.iter().map(|(t, r)| format!("{t} {r}")).collect();
        let _ = writeln!(s, "  basal schedule: {} U/h (the basal rate below is its mean; each update scales every segment)", segs.join(", "));
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
        setting(&mut s, x);
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
    if a.settings
        .iter()
        .any(|x| x.latest.as_ref().is_some_and(|v| v.status == "open"))
    {
        let _ = writeln!(
            s,
            "\nAnswer with `abba answer --accept`, `--reject` or `--set basal=...,breakfast=...` once you have talked it over with your clinician."
        );
    }
    s
}
