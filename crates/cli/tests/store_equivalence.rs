//! The person store reproduces the validated path: a simulated patient's
//! 98 days exported as Nightscout, imported day by day into a person store
//! (overlapping two-day exports), advised and answered "accept" every day,
//! give exactly the trial ABBA arm's decisions (same values, same days,
//! same explanations), in CGM and SMBG mode. And answers matter: after a
//! rejection or an override the next update starts from the value in force.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::store_common;

use abba_advisor::DecisionDetail;
use abba_sim::scenario::ScenarioId;
use abba_store::answer::{param_key, parse_param};
use abba_store::AnswerRequest;
use std::collections::BTreeMap;
use store_common::{simulate, Sim, TempDir};

/// Imports day by day and answers each day's open suggestions with `answer`.
fn day_by_day(
    sim: &Sim,
    tag: &str,
    answer: impl Fn(&[(String, f64, f64)]) -> Option<AnswerRequest>,
) -> (TempDir, abba_store::Store) {
    let dir = TempDir::new(tag);
    let mut store = sim.store(&dir.0);
    let name = sim.person.name.clone();
    let first = sim.events[0].at.day_index();
    for day in first..=sim.last_day() {
        let batch = sim.export((day - 1).max(first), day);
        let s = store.import(&name, &batch).unwrap();
        assert!(s.added > 0, "day {day}: something new");
        if day > first {
            assert!(s.known > 0, "day {day}: the overlap is recognised");
        }
        let advice = store.advise(&name).unwrap();
        let open: Vec<(String, f64, f64)> = advice
            .settings
            .iter()
            .filter_map(|x| x.latest.as_ref().filter(|v| v.status == "open"))
            .map(|v| (v.setting.to_string(), v.previous, v.suggested))
            .collect();
        if open.is_empty() {
            continue;
        }
        if let Some(req) = answer(&open) {
            store.answer(&name, &req).unwrap();
        }
    }
    (dir, store)
}

fn equivalence(scenario: ScenarioId) {
    let sim = simulate(scenario, 3, 98);
    let (_dir, mut store) = day_by_day(&sim, "equiv", |_| Some(AnswerRequest::Accept));
    let got = store.decisions(&sim.person.name).unwrap();
    let n_updates = sim
        .decisions
        .iter()
        .filter(|d| !matches!(d.detail, DecisionDetail::Skipped { .. }))
        .count();
    assert!(
        n_updates > 300,
        "{scenario:?}: the trial made {n_updates} updates"
    );
    assert_eq!(
        got.len(),
        sim.decisions.len(),
        "{scenario:?}: number of decisions"
    );
    for (k, (a, b)) in got.iter().zip(&sim.decisions).enumerate() {
        assert_eq!(a, b, "{scenario:?}: decision {k} differs");
    }
    // Every update was answered (accepted), the last ones too.
    let history = store.history(&sim.person.name).unwrap();
    assert!(
        history
            .iter()
            .all(|v| v.no_update || v.status == "accepted"),
        "{scenario:?}"
    );
    // The snapshot is only a shortcut: a rebuild gives the same advisor.
    let cached = store.advisor(&sim.person.name).unwrap();
    let rebuilt = store.rebuild(&sim.person.name).unwrap();
    assert_eq!(cached, rebuilt);
}

#[test]
fn cgm_mode_matches_the_trial_abba_arm() {
    equivalence(ScenarioId::S1);
}

#[test]
fn smbg_mode_matches_the_trial_abba_arm() {
    equivalence(ScenarioId::S2);
}

/// Rejects or overrides every day; checks that every update starts from
/// the value put in force by the answer before it.
fn answers_matter(scenario: ScenarioId, override_factor: Option<f64>) {
    let sim = simulate(scenario, 5, 30);
    let (_dir, mut store) = day_by_day(&sim, "answers", |open| {
        Some(match override_factor {
            None => AnswerRequest::Reject,
            Some(f) => AnswerRequest::Set(
                open.iter()
                    .map(|(s, old, _)| (parse_param(s).unwrap(), old * f))
                    .collect(),
            ),
        })
    });
    let name = sim.person.name.clone();
    let decisions = store.decisions(&name).unwrap();
    let history = store.history(&name).unwrap();
    let mut in_force: BTreeMap<&str, f64> = BTreeMap::new();
    let mut checked = 0;
    for (d, v) in decisions.iter().zip(&history) {
        let key = param_key(d.parameter);
        if let Some(&f) = in_force.get(key) {
            assert_eq!(
                d.old, f,
                "{scenario:?} {key} at {}: starts from the value in force",
                d.at
            );
            checked += 1;
        }
        match v.status.as_str() {
            "rejected" => {
                assert_eq!(v.in_force, v.previous);
                in_force.insert(key, v.in_force);
            }
            "overridden" => {
                assert_eq!(v.in_force, v.previous * override_factor.unwrap());
                in_force.insert(key, v.in_force);
            }
            "no_update" => {}
            other => panic!("{scenario:?}: unexpected status {other}"),
        }
    }
    assert!(checked > 40, "{scenario:?}: {checked} updates checked");
    // With every suggestion rejected, nothing ever moves.
    if override_factor.is_none() {
        let a = store.advisor(&name).unwrap();
        assert_eq!(
            abba_advisor::Advisor::settings(&a),
            &sim.person.settings.start
        );
    }
    // Differs from the trial (which followed every suggestion).
    assert_ne!(decisions, sim.decisions[..decisions.len()].to_vec());
}

#[test]
fn reject_keeps_the_previous_value_cgm() {
    answers_matter(ScenarioId::S1, None);
}

#[test]
fn reject_keeps_the_previous_value_smbg() {
    answers_matter(ScenarioId::S2, None);
}

#[test]
fn override_starts_from_the_persons_value_cgm() {
    answers_matter(ScenarioId::S1, Some(0.98));
}

#[test]
fn override_starts_from_the_persons_value_smbg() {
    answers_matter(ScenarioId::S2, Some(1.02));
}
