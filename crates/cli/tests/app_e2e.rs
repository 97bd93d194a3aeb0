//! End to end over HTTP: the real `abba serve` binary, a person created
//! with the admin token as the in-process trial configures its advisor,
//! and the reference client (the CLI's `remote`, abba-client) playing the
//! pump app for one simulated patient for 98 days, flushing its events at
//! each meal announcement and day closing, putting the answers in force and
//! accepting them. The service must make exactly the decisions the
//! in-process trial's ABBA arm makes for the same patient and seed: same
//! minutes, settings, values before and after, in the same order; the
//! person ends on the same settings; the service holds every event once.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::service_common;

// The CLI's reference app (`abba app`), compiled into this test binary (tests/main.rs).
use crate::remote;

use abba_api::{PhaseView, Setting};
use abba_client::{Client, Retry};
use abba_sim::person::SuggestionResponse;
use abba_sim::scenario::ScenarioId;
use abba_trial::closed_loop::{run_patient_with, Trace};
use abba_trial::protocol::{ArmKind, RawTrialConfig};
use abba_trial::runner::build_cohort;
use abba_trial::TrialConfig;
use remote::RemoteApp;
use service_common::{admin_token, Server, TempDir};
use std::time::Instant;

fn setting_of(p: abba_advisor::Parameter) -> Setting {
    remote::setting(p).unwrap_or_else(|| panic!("no setting for {p:?}"))
}

fn end_to_end(scenario: ScenarioId, patient_no: u64, days: u32, response: SuggestionResponse) {
    let config = TrialConfig::try_from(RawTrialConfig {
        patients: patient_no as u32,
        days,
        calibrate_te_ref: false,
        scenarios: vec![scenario],
        arms: vec![ArmKind::Abba],
        suggestions: response,
        ..RawTrialConfig::default()
    })
    .unwrap();
    let cohort = build_cohort(&config).unwrap();
    let vp = &cohort.patients[patient_no as usize - 1];
    let planned = config.planned_scenario(scenario).unwrap().clone();

    // In process: the trial's ABBA arm.
    let mut trace = Trace {
        decisions: Some(Vec::new()),
        ..Default::default()
    };
    let reference =
        run_patient_with(&config, vp, patient_no, &planned, ArmKind::Abba, &mut trace).unwrap();
    let decisions = trace.decisions.unwrap();
    assert!(
        reference.failure.is_none(),
        "{scenario:?}: the run is whole"
    );
    assert!(
        decisions.len() as u32 > 3 * (days - 9),
        "{scenario:?}: {} decisions",
        decisions.len()
    );

    // Through the service, over HTTP.
    let dir = TempDir::new(&format!("app-e2e-{}-{days}", scenario.name()));
    let db = dir.0.join("abba.db");
    let token = admin_token(&db);
    let server = Server::start(&db);
    let admin = Client::new(&server.url(), Some(&token)).unwrap();
    let first_day: jiff::civil::Date = "2026-03-02".parse().unwrap();
    let name = format!("{}-{}", vp.params.name, scenario.name());
    let body = remote::person_body(&config, vp, patient_no, &planned, first_day, &name).unwrap();
    let created = admin.create_person(&body).unwrap();
    let issued = admin.issue_token(created.id).unwrap();
    let app = RemoteApp {
        client: admin.with_token(&issued.token),
        person: created.id,
        first_day,
        retry: Retry::never(),
    };
    let started = Instant::now();
    let run = remote::run_remote(&config, vp, patient_no, &planned, &app).unwrap();
    eprintln!(
        "{scenario:?}: {days} days through the service in {:.1} s ({} posts, {} events, {} answers)",
        started.elapsed().as_secs_f64(),
        run.outbox.posts,
        run.outbox.acked,
        run.answers_posted
    );

    // The same decisions, exactly, in the same order.
    assert_eq!(
        run.suggestions.len(),
        decisions.len(),
        "{scenario:?}: number of suggestions"
    );
    for (k, (d, s)) in decisions.iter().zip(&run.suggestions).enumerate() {
        let (minute, setting) = Setting::from_suggestion_id(s.id);
        assert_eq!(
            (minute as i64, setting, s.previous, s.value),
            (d.at.0, setting_of(d.parameter), d.old, d.new),
            "{scenario:?}: suggestion {k} (in process: {d})"
        );
        assert_eq!(s.parameter, setting, "{scenario:?}: suggestion {k}");
        assert!(
            s.seq.is_some(),
            "{scenario:?}: suggestion {k} names its event"
        );
    }
    // The person followed them: the same settings at the end.
    let fin = run.final_settings;
    assert_eq!(fin.basal.0, reference.final_basal_u_per_h, "{scenario:?}");
    assert_eq!(
        fin.carb_ratio.map(|c| c.0),
        reference.final_carb_ratio_g_per_u,
        "{scenario:?}"
    );

    // Every event posted once, acknowledged at once, held once.
    let o = run.outbox;
    assert_eq!(o.failures, 0, "{scenario:?}");
    assert_eq!(o.acked, o.pushed, "{scenario:?}");
    assert_eq!(o.stored, o.pushed, "{scenario:?}: nothing repeated");
    let sync = app.client.sync(created.id, 0).unwrap();
    assert_eq!(sync.held.len(), 1, "{scenario:?}: {:?}", sync.held);
    assert_eq!(
        (sync.held[0].first, sync.held[0].last),
        (0, o.pushed - 1),
        "{scenario:?}"
    );
    assert_eq!(
        sync.last_suggestion_id,
        run.suggestions.last().map(|s| s.id)
    );

    // The service's own views agree: every update answered as the person
    // did, the advisor adapting, every event a record.
    let history = app.client.history(created.id).unwrap();
    assert_eq!(history.suggestions.len(), decisions.len(), "{scenario:?}");
    // The changes (an update whose value differs from the one in force)
    // are what the person answers.
    let changes: Vec<_> = history
        .suggestions
        .iter()
        .filter(|s| !s.no_update && s.value != s.previous)
        .collect();
    assert!(
        changes.len() as u32 > days / 2,
        "{scenario:?}: {} changes",
        changes.len()
    );
    let statuses: std::collections::BTreeSet<&str> =
        changes.iter().map(|s| s.status.as_str()).collect();
    let expected: &[&str] = match response {
        SuggestionResponse::AcceptAll => &["accepted"],
        SuggestionResponse::RejectShare { .. } => &["accepted", "rejected"],
        _ => &["overridden"],
    };
    assert_eq!(
        statuses,
        expected.iter().copied().collect(),
        "{scenario:?}: statuses"
    );
    assert_eq!(run.answers_posted as usize, changes.len(), "{scenario:?}");
    let advice = app.client.advice(created.id).unwrap();
    assert_eq!(advice.phase, PhaseView::Adapting, "{scenario:?}");
    assert_eq!(advice.data.records, o.pushed, "{scenario:?}");
    let basal = advice
        .settings
        .iter()
        .find(|s| s.setting == Setting::Basal)
        .unwrap();
    assert_eq!(basal.in_force, fin.basal.0, "{scenario:?}");
}

#[test]
fn cgm_mode_through_the_service_equals_the_in_process_trial() {
    end_to_end(ScenarioId::S1, 3, 98, SuggestionResponse::AcceptAll);
}

#[test]
fn smbg_mode_through_the_service_equals_the_in_process_trial() {
    end_to_end(ScenarioId::S2, 3, 98, SuggestionResponse::AcceptAll);
}

/// A person who rejects about a third of the changes: the app posts the
/// rejections, and the service's next decisions start from the kept value
/// as the in-process advisor's do.
#[test]
fn a_person_who_rejects_some_changes_gets_the_same_decisions() {
    end_to_end(
        ScenarioId::S1,
        4,
        30,
        SuggestionResponse::RejectShare { percent: 30 },
    );
}

/// A person who puts their own value in force (within ±4 % of each
/// suggestion): the app posts the overrides with the values.
#[test]
fn a_person_who_overrides_gets_the_same_decisions() {
    end_to_end(
        ScenarioId::S2,
        4,
        30,
        SuggestionResponse::OverrideWithin { percent: 4 },
    );
}
