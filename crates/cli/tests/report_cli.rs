//! `abba report` from a stored person: a simulated patient's days imported
//! through the real path (Nightscout export → abba-io → abba-store),
//! answered day by day (accept, reject, override in turn); the page has
//! the percentiles of the stored readings (computed here again), a panel
//! for every day, every suggestion with its answer; it validates and
//! renders at A4 width in Chromium. CGM in mg/dL, SMBG in mmol/L.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::browser;
use crate::store_common;

use abba_core::{units::MG_DL_PER_MMOL_L, EventKind};
use abba_sim::scenario::ScenarioId;
use abba_store::answer::parse_param;
use abba_store::AnswerRequest;
use store_common::{simulate, TempDir};

fn quantile(values: &[f64], p: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let h = (v.len() as f64 - 1.0) * p;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(v.len() - 1);
    v[lo] + (h - lo as f64) * (v[hi] - v[lo])
}

fn check(scenario: ScenarioId, unit: &str, tag: &str) {
    let sim = simulate(scenario, 2, 24);
    let dir = TempDir::new(tag);
    let mut store = sim.store(&dir.0);
    let name = sim.person.name.clone();
    let first = sim.events[0].at.day_index();
    let mut turn = 0;
    for day in first..=sim.last_day() {
        store
            .import(&name, &sim.export((day - 1).max(first), day))
            .unwrap();
        let advice = store.advise(&name).unwrap();
        let open: Vec<(String, f64)> = advice
            .settings
            .iter()
            .filter_map(|x| x.latest.as_ref().filter(|v| v.status == "open"))
            .map(|v| (v.setting.to_string(), v.previous))
            .collect();
        if open.is_empty() {
            continue;
        }
        turn += 1;
        let req = match turn % 3 {
            0 => AnswerRequest::Accept,
            1 => AnswerRequest::Reject,
            _ => AnswerRequest::Set(
                open.iter()
                    .map(|(s, old)| (parse_param(s).unwrap(), old * 1.01))
                    .collect(),
            ),
        };
        store.answer(&name, &req).unwrap();
    }
    let events = store.events(&name).unwrap();
    let history = store.history(&name).unwrap();
    drop(store);

    let out_dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("html")
        .join(tag);
    let _ = std::fs::remove_dir_all(&out_dir);
    std::fs::create_dir_all(&out_dir).unwrap();
    let page = out_dir.join("report.html");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_abba"))
        .args(["report", "--db"])
        .arg(dir.0.join("abba.db"))
        .args(["--person", &name, "--days", "14", "--units", unit, "--out"])
        .arg(&page)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let html = std::fs::read_to_string(&page).unwrap();
    eprintln!("{tag}: {} bytes", html.len());

    // Every day of the period has its panel.
    let last = events.last().unwrap().at.day_index();
    let period = last - 13..=last;
    let first_day = sim.person.first_day.unwrap();
    for i in period.clone() {
        let date = first_day
            .checked_add(jiff::Span::new().days(i))
            .unwrap()
            .to_string();
        assert!(
            html.contains(&format!("<title>{date}</title>")),
            "{tag}: no panel for {date}"
        );
    }
    let panel = format!(
        r#"viewBox="0 0 {} 150""#,
        abba_report::html::svg::DAY_PANEL_WIDTH
    );
    assert_eq!(html.matches(&panel).count(), 14);

    // Every suggestion of the period, with its answer.
    let shown: Vec<_> = history
        .iter()
        .filter(|v| !v.no_update && period.contains(&(v.day - 1)))
        .collect();
    assert!(shown.len() >= 3, "{tag}: {} suggestions", shown.len());
    let mut answers = std::collections::BTreeSet::new();
    for v in &shown {
        let row = html
            .split("<tr>")
            .find(|r| {
                r.contains(&v.decided_at) && r.contains(&format!("{:.3} {}", v.suggested, v.unit))
            })
            .unwrap_or_else(|| panic!("{tag}: suggestion of {} missing", v.decided_at));
        let want = match v.status.as_str() {
            "overridden" => format!("set to {:.3}", v.in_force),
            "open" => "not answered yet".to_string(),
            s => s.to_string(),
        };
        assert!(
            row.contains(&want),
            "{tag}: answer '{want}' missing in {row}"
        );
        answers.insert(v.status.clone());
    }
    assert!(answers.len() >= 2, "{tag}: answers {answers:?}");

    // The profile table equals the percentiles of the stored readings.
    let readings: Vec<(i64, f64)> = events
        .iter()
        .filter(|e| period.contains(&e.at.day_index()))
        .filter_map(|e| match e.kind {
            EventKind::Cgm(g) if scenario == ScenarioId::S1 => Some((e.at.minute_of_day(), g.0)),
            EventKind::Smbg(g) if scenario != ScenarioId::S1 => Some((e.at.minute_of_day(), g.0)),
            _ => None,
        })
        .collect();
    let fmt = |mg: f64| {
        if unit == "mmol/L" {
            format!("{:.1}", mg / MG_DL_PER_MMOL_L)
        } else {
            format!("{mg:.0}")
        }
    };
    let width = if scenario == ScenarioId::S1 { 15 } else { 60 };
    let mut bins = 0;
    for start in (0..1440).step_by(width as usize) {
        let values: Vec<f64> = readings
            .iter()
            .filter(|(m, _)| m / width * width == start)
            .map(|r| r.1)
            .collect();
        if values.is_empty() {
            continue;
        }
        bins += 1;
        let cells: Vec<String> = [0.05, 0.25, 0.5, 0.75, 0.95]
            .iter()
            .map(|q| format!("<td class=\"num\">{}</td>", fmt(quantile(&values, *q))))
            .collect();
        let row = format!(
            "<tr><th scope=\"row\">{:02}:{:02}</th><td class=\"num\">{}</td>{}</tr>",
            start / 60,
            start % 60,
            values.len(),
            cells.join("")
        );
        assert!(html.contains(&row), "{tag}: profile row {row} missing");
    }
    assert!(bins >= 4);
    assert!(html.contains("research software, not a medical device"));
    browser::validate_with_tidy(&page);
    browser::assert_renders_at_a4(&page);
}

#[test]
fn cgm_person_report_in_mg_dl() {
    check(ScenarioId::S1, "mg/dL", "report-cgm");
}

#[test]
fn smbg_person_report_in_mmol_l() {
    check(ScenarioId::S2, "mmol/L", "report-smbg");
}

/// A simulated S1 person of `days` days in a store of its own (every
/// record imported), with `unit` as theirs.
fn stored_person(tag: &str, days: u32, unit: abba_core::units::GlucoseUnit) -> (TempDir, String) {
    let mut sim = simulate(ScenarioId::S1, 1, days);
    sim.person.settings.units = unit;
    let dir = TempDir::new(tag);
    let mut store = sim.store(&dir.0);
    store
        .import(&sim.person.name, &sim.export(0, sim.last_day()))
        .unwrap();
    (dir, sim.person.name.clone())
}

/// `abba report` of `name` in `dir`'s store with `extra` flags, into
/// `page`; it must succeed.
fn report_ok(dir: &TempDir, name: &str, extra: &[&str], page: &std::path::Path) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_abba"))
        .args(["report", "--db"])
        .arg(dir.0.join("abba.db"))
        .args(["--person", name])
        .args(extra)
        .arg("--out")
        .arg(page)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn pdf_is_printed_by_chromium_when_asked() {
    if browser::chromium().is_none() {
        return;
    }
    let (dir, name) = stored_person("report-pdf", 10, abba_core::units::GlucoseUnit::MgDl);
    let page = dir.0.join("page.html");
    report_ok(&dir, &name, &["--pdf"], &page);
    let pdf = std::fs::read(dir.0.join("page.pdf")).unwrap();
    assert!(pdf.starts_with(b"%PDF-"), "not a PDF");
    assert!(pdf.len() > 10_000);
}

#[test]
fn the_page_speaks_the_person_s_unit_unless_asked_and_never_two() {
    // A person who reads mmol/L: without --units the page is theirs, the
    // table of suggestions and its reasons included; with --units mg/dL the
    // reasons follow the page (before, the page defaulted to mg/dL while
    // its reasons stayed in mmol/L).
    let (dir, name) = stored_person("report-unit", 12, abba_core::units::GlucoseUnit::MmolL);
    let page = dir.0.join("page.html");
    let report = |extra: &[&str]| -> String {
        report_ok(&dir, &name, extra, &page);
        std::fs::read_to_string(&page).unwrap()
    };
    // The rows of the suggestions' table: their reasons name glucose
    // thresholds ("above ... and ... below ...").
    let rows = |html: &str| -> Vec<String> {
        html.split("<tr>")
            .filter(|r| r.contains("readings of the window"))
            .map(str::to_string)
            .collect()
    };
    let own = report(&[]);
    let own_rows = rows(&own);
    assert!(!own_rows.is_empty(), "no suggestion rows");
    for r in &own_rows {
        assert!(r.contains("mmol/L") && !r.contains("mg/dL"), "{r}");
    }
    assert!(
        own.contains("<strong>Unit:</strong> mmol/L"),
        "the page's unit is not the person's"
    );
    let asked = report(&["--units", "mg/dL"]);
    assert!(asked.contains("<strong>Unit:</strong> mg/dL"));
    for r in &rows(&asked) {
        assert!(r.contains("mg/dL") && !r.contains("mmol/L"), "{r}");
    }
}

#[test]
fn unknown_person_and_bad_unit_are_refused() {
    let dir = TempDir::new("report-bad");
    let sim = simulate(ScenarioId::S1, 1, 9);
    drop(sim.store(&dir.0));
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_abba"))
            .args(["report", "--db"])
            .arg(dir.0.join("abba.db"))
            .args(args)
            .output()
            .unwrap()
    };
    let out = run(&["--person", "nobody", "--out", "/dev/null"]);
    assert!(!out.status.success());
    let out = run(&[
        "--person",
        &sim.person.name,
        "--units",
        "mmol",
        "--out",
        "/dev/null",
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("mg/dL or mmol/L"));
    let out = run(&["--person", &sim.person.name, "--out", "/dev/null"]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("no data yet"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_trial_page_carries_the_w1_sensitivity_block() {
    let dir = TempDir::new("report-w1");
    let out = dir.0.join("trial");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_abba"))
        .args([
            "trial",
            "--patients",
            "2",
            "--days",
            "9",
            "--scenarios",
            "S1",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("<h2>W1 sensitivity (S1, standard therapy, D2-D8)</h2>"));
    for (label, _) in abba_trial::w1_sensitivity::variants() {
        assert!(
            html.contains(&format!("<th scope=\"row\">{label}</th>")),
            "variant {label} missing"
        );
    }
    browser::validate_with_tidy(&out.join("report.html"));
}
