//! The arm knob for simulated answers: people who reject every suggestion
//! keep their starting therapy (the advisor hears each rejection and starts
//! its next update from the value in force); people who override within
//! ±x % end elsewhere than people who accept; accepting all is the paper.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::person::SuggestionResponse;
use abba_sim::scenario::ScenarioId;
use abba_trial::closed_loop::{run_patient_with, Trace};
use abba_trial::protocol::{ArmKind, RawTrialConfig};
use abba_trial::runner::build_cohort;
use abba_trial::TrialConfig;

fn run(
    scenario: ScenarioId,
    suggestions: SuggestionResponse,
) -> (abba_trial::results::PatientResult, Trace) {
    let config = TrialConfig::try_from(RawTrialConfig {
        patients: 2,
        days: 21,
        scenarios: vec![scenario],
        calibrate_te_ref: false,
        suggestions,
        ..RawTrialConfig::default()
    })
    .unwrap();
    let cohort = build_cohort(&config).unwrap();
    let sc = config.planned_scenario(scenario).unwrap();
    let mut trace = Trace {
        events: Some(Vec::new()),
        decisions: Some(Vec::new()),
        minutes: None,
        init: None,
    };
    let r = run_patient_with(
        &config,
        &cohort.patients[1],
        2,
        sc,
        ArmKind::Abba,
        &mut trace,
    )
    .unwrap();
    (r, trace)
}

fn answers(t: &Trace) -> [usize; 3] {
    let mut n = [0; 3];
    for e in t.events.as_ref().unwrap() {
        match e.kind {
            abba_core::EventKind::SuggestionAccepted(_) => n[0] += 1,
            abba_core::EventKind::SuggestionRejected(_) => n[1] += 1,
            abba_core::EventKind::SuggestionOverridden(_) => n[2] += 1,
            _ => {}
        }
    }
    n
}

#[test]
fn rejecting_everything_keeps_the_starting_therapy() {
    for sc in [ScenarioId::S1, ScenarioId::S2] {
        let (r, t) = run(sc, SuggestionResponse::RejectShare { percent: 100 });
        assert_eq!(r.final_basal_u_per_h, r.start_basal_u_per_h, "{sc:?}");
        let n = answers(&t);
        assert!(n[1] > 10 && n[0] == 0 && n[2] == 0, "{sc:?}: {n:?}");
        // Every update started from the value in force: the start.
        for d in t.decisions.as_ref().unwrap() {
            if d.parameter == abba_advisor::Parameter::Basal {
                assert_eq!(d.old, r.start_basal_u_per_h, "{sc:?} {d}");
            }
        }
    }
}

#[test]
fn accept_all_sends_no_answer_events_and_others_differ() {
    let (accept, t) = run(ScenarioId::S1, SuggestionResponse::AcceptAll);
    assert_eq!(
        answers(&t),
        [0, 0, 0],
        "the paper's person: no answer events"
    );
    let (half, t) = run(
        ScenarioId::S1,
        SuggestionResponse::RejectShare { percent: 50 },
    );
    let n = answers(&t);
    assert!(n[0] > 3 && n[1] > 3, "{n:?}");
    let (own, t) = run(
        ScenarioId::S1,
        SuggestionResponse::OverrideWithin { percent: 3 },
    );
    assert!(answers(&t)[2] > 10);
    assert_ne!(accept.final_basal_u_per_h, half.final_basal_u_per_h);
    assert_ne!(accept.final_basal_u_per_h, own.final_basal_u_per_h);
}

#[test]
fn out_of_range_shares_are_refused() {
    let bad = RawTrialConfig {
        suggestions: SuggestionResponse::OverrideWithin { percent: 80 },
        ..RawTrialConfig::default()
    };
    let e = TrialConfig::try_from(bad).unwrap_err();
    assert!(e.to_string().contains("override_within"), "{e}");
}
