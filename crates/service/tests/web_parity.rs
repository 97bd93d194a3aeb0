//! One day's advice read three ways: the person's Today, the clinic's page
//! of that person and `abba advise` (the store's advice the CLI prints)
//! say the same values, reasons, notes, therapy and delivery, in the same
//! units; and what Today acknowledges after an answer is what the store
//! holds.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::advice_parity::{export, person_from};
use crate::common::Svc;
use crate::pages::{signed_in, Page};
use abba_store::token::Role;
use axum::http::StatusCode;
use serde_json::Value;

/// The visible text of an HTML fragment: tags out, entities back, blanks
/// as one space.
fn text(html: &str) -> String {
    let mut out = String::new();
    let mut in_tag = false;
    for c in html.chars() {
        match c {
            '<' => {
                in_tag = true;
                out.push(' ');
            }
            '>' => in_tag = false,
            c if !in_tag => out.push(c),
            _ => {}
        }
    }
    let out = out
        .replace("&#x27;", "'")
        .replace("&#x2f;", "/")
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// `html` without its forms (Today's answer forms; the clinic shows none).
fn without_forms(html: &str) -> String {
    let mut out = String::new();
    let mut rest = html;
    while let Some(i) = rest.find("<form") {
        out.push_str(&rest[..i]);
        let j = rest[i..].find("</form>").expect("a closed form") + "</form>".len();
        rest = &rest[i + j..];
    }
    out.push_str(rest);
    out
}

/// The element of `page` that starts with `start` (up to its `</tag>`),
/// or `None`.
fn part<'a>(page: &'a Page, start: &str, tag: &str) -> Option<&'a str> {
    page.html.contains(start).then(|| page.section(start, tag))
}

/// The advice's words as the person's pages say them (abba-service's
/// `web::advice_words`): the CLI's flags named as the clinic's doing.
fn for_person(s: &str) -> String {
    abba_service::web::advice_words::for_person(s)
}

/// Nightscout files of [`export`] without the breakfast boluses: the
/// advice notes that no breakfast was seen (a note naming a CLI flag).
fn export_without_breakfast(dir: &std::path::Path, days: i64) -> Vec<std::path::PathBuf> {
    let files = export(dir, days);
    let treatments = files
        .iter()
        .find(|p| p.ends_with("treatments.json"))
        .unwrap();
    let all: Vec<Value> = serde_json::from_slice(&std::fs::read(treatments).unwrap()).unwrap();
    let kept: Vec<Value> = all
        .into_iter()
        .filter(|t| t["carbs"].as_f64() != Some(45.0))
        .collect();
    std::fs::write(treatments, serde_json::to_vec(&kept).unwrap()).unwrap();
    files
}

#[tokio::test]
async fn the_clinics_page_today_and_abba_advise_say_the_same_day() {
    let svc = Svc::new();
    let files = export_without_breakfast(svc.dir.path(), 12);
    let (id, advice) = person_from(&svc, &files);
    let cli = serde_json::to_value(&advice).unwrap();
    let (mut person, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let today = person.get("/").await;
    assert_eq!(today.status, StatusCode::OK, "{}", today.html);
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let clinic = admin.get(&format!("/clinic/persons/{id}")).await;
    assert_eq!(clinic.status, StatusCode::OK, "{}", clinic.html);
    let shown = clinic.section("<section id=\"persons-today\"", "h2");
    assert!(shown.contains("The person&#x27;s Today"), "{shown}");

    // The clinic's copy of Today is Today, word for word, without the forms.
    let mut compared = 0;
    for key in ["basal", "breakfast", "lunch", "dinner"] {
        let on_today = today.section(&format!("<section id=\"setting-{key}\""), "section");
        let on_clinic = clinic.section(&format!("<section id=\"today-setting-{key}\""), "section");
        assert_eq!(
            text(on_clinic),
            text(&without_forms(on_today)),
            "setting {key}"
        );
        compared += 1;
    }
    for (id, tag) in [
        ("advice-notes", "section"),
        ("first-week", "p"),
        ("not-designed-for", "p"),
    ] {
        let on_today = part(&today, &format!("<{tag} id=\"{id}\""), tag).map(text);
        let on_clinic = part(&clinic, &format!("<{tag} id=\"today-{id}\""), tag).map(text);
        assert_eq!(on_clinic, on_today, "#{id}");
    }
    assert_eq!(compared, 4);

    // Both say what `abba advise` says.
    let notes = text(today.section("<section id=\"advice-notes\"", "section"));
    let cli_notes = cli["notes"].as_array().unwrap();
    assert!(
        cli_notes
            .iter()
            .any(|n| n.as_str().unwrap().contains("--meal-windows")),
        "no breakfast in the data, so a note names the CLI flag: {cli_notes:#?}"
    );
    for n in cli_notes {
        let said = for_person(n.as_str().unwrap());
        assert!(notes.contains(&said), "{said:?} not in {notes:?}");
    }
    assert!(!today.html.contains("--"), "Today names a CLI flag");
    // One snack (day 3's hypo treatment) in the singular.
    assert!(
        notes.contains(
            "; 1 entry outside the windows or after a window's first was taken as a snack."
        ),
        "{notes}"
    );
    let mut suggestions = 0;
    for s in cli["settings"].as_array().unwrap() {
        let key = s["setting"].as_str().unwrap();
        let on_today = text(today.section(&format!("<section id=\"setting-{key}\""), "section"));
        let on_clinic =
            text(clinic.section(&format!("<section id=\"today-setting-{key}\""), "section"));
        let unit = if key == "basal" { "U/h" } else { "g/U" };
        // As `abba advise` gives it (three decimals), without the zeros
        // past the pages' two (basal) or one (carb ratio).
        let with_unit = |v: &Value| {
            let mut t = format!("{:.3}", v.as_f64().unwrap());
            let least = if key == "basal" { 2 } else { 1 };
            while t.ends_with('0') && t.len() - t.find('.').unwrap() - 1 > least {
                t.pop();
            }
            format!("{t} {unit}")
        };
        let in_force = with_unit(&s["in_force"]);
        assert!(
            on_today.contains(&format!("In force: {in_force}")),
            "{key}: {on_today}"
        );
        let Some(latest) = s.get("latest").filter(|l| !l.is_null()) else {
            continue;
        };
        if latest["status"] != "open" {
            continue;
        }
        suggestions += 1;
        let suggested = format!("Suggested: {}", with_unit(&latest["suggested"]));
        // When it was made and on what data: a suggestion read days after
        // its data says so, as `abba advise` does.
        let made = format!(
            "Made on {} (local time). Data: {}.",
            latest["decided_at"].as_str().unwrap(),
            latest["data"].as_str().unwrap()
        );
        for page in [&on_today, &on_clinic] {
            assert!(page.contains(&suggested), "{key}: {suggested:?} in {page}");
            assert!(page.contains(&made), "{key}: {made:?} in {page}");
            for r in latest["reasons"].as_array().unwrap() {
                let r = for_person(r.as_str().unwrap());
                assert!(page.contains(&r), "{key}: reason {r:?} in {page}");
            }
        }
        // The clinic's list of waiting suggestions: the same change, at
        // the local time `abba advise` gives.
        let waiting = format!(
            "{} → {} ({})",
            with_unit(&latest["previous"]),
            with_unit(&latest["suggested"]),
            latest["decided_at"].as_str().unwrap()
        );
        assert!(text(&clinic.html).contains(&waiting), "{waiting:?}");
    }
    assert!(suggestions > 0, "an open suggestion to compare: {cli:#}");
    // The therapy in force: its schedule on both.
    let schedule = advice.therapy.basal_schedule.clone().expect("a schedule");
    let said = abba_advisor::words::schedule(&schedule);
    let basal = text(today.section("<section id=\"setting-basal\"", "section"));
    assert!(basal.contains(&said), "{said:?} in {basal}");
    let table = text(clinic.section("<table id=\"in-force\"", "table"));
    for (start, rate) in &schedule {
        let row = format!("{start} {rate:.2} U/h");
        assert!(table.contains(&row), "{row:?} in {table}");
    }
}

/// A person on pens (xDrip+'s injections) and one on a closed loop
/// (AndroidAPS): Today, the clinic's copy of it and `abba advise` say the
/// same refusal of basal suggestions (the person's words on Today and its
/// copy, the command's on the clinic's own delivery note).
#[tokio::test]
async fn the_refusal_of_basal_suggestions_is_the_same_on_today_the_clinic_and_abba_advise() {
    for (fixture, shown) in [
        (
            "nightscout_treatments_xdrip_injections_synthetic.json",
            "multiple daily injections",
        ),
        ("nightscout_treatments_aaps_synthetic.json", "closed loop"),
    ] {
        let svc = Svc::new();
        let day0: jiff::Timestamp = "2026-03-08T00:00:00Z".parse().unwrap();
        let entries: Vec<Value> = (0..4 * 288)
            .map(|k| {
                let t = day0 + jiff::SignedDuration::from_mins(5 * k);
                serde_json::json!({"_id": format!("e{k}"), "type": "sgv", "sgv": 110 + (k % 40),
                    "date": t.as_millisecond(), "dateString": t.to_string()})
            })
            .collect();
        let file = svc.dir.path().join("entries.json");
        std::fs::write(&file, serde_json::to_vec(&entries).unwrap()).unwrap();
        let treatments = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../io/tests/data")
            .join(fixture);
        let (id, advice) = person_from(&svc, &[file, treatments]);
        assert!(
            !advice.delivery.basal_suggestions,
            "{fixture}: {:?}",
            advice.delivery
        );
        let note = advice.delivery.note.clone().expect("a delivery note");
        assert!(note.contains(shown), "{fixture}: {note}");
        let (mut person, _) = signed_in(&svc, Role::Person(id as i64)).await;
        let today = person.get("/").await;
        let (mut admin, _) = signed_in(&svc, Role::Admin).await;
        let clinic = admin.get(&format!("/clinic/persons/{id}")).await;
        let on_today = text(today.section("<p id=\"not-designed-for\"", "p"));
        let on_copy = text(clinic.section("<p id=\"today-not-designed-for\"", "p"));
        assert_eq!(on_copy, on_today, "{fixture}");
        assert_eq!(on_today, for_person(&note), "{fixture}");
        let own = text(clinic.section("<p id=\"delivery-note\"", "p"));
        assert_eq!(
            own,
            abba_service::web::advice_words::for_clinic(&note),
            "{fixture}"
        );
    }
}
