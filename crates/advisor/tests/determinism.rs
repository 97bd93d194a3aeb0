//! Determinism: the same events and seed give the same decisions; a saved and
//! resumed advisor makes the same decisions as one that never stopped.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::{
    Abba, AbbaConfig, Advisor, AdvisorSpec, AnyAdvisor, CriticVariant, Decision, Mode, R2rConfig,
    STATE_FORMAT_VERSION,
};
use abba_core::{Event, TherapySettings};
use common::{start, Toy};
use proptest::prelude::*;

const TOY: Toy = Toy {
    basal_need: 1.25,
    cr_need: [8.0, 11.0, 9.0],
    skip_lunch_days: &[12, 20],
    no_prelunch_smbg_days: &[15],
};

fn recorded(mode: Mode, variant: CriticVariant, seed: u64) -> (Vec<Event>, Vec<Decision>) {
    let mut c = AbbaConfig::new(mode, seed);
    c.critic.variant = variant;
    let mut a = Abba::new(c, start()).unwrap();
    let events = TOY.run(&mut a, mode, 1, 30, 7);
    (events, a.take_decisions())
}

fn replay(adv: &mut dyn Advisor, events: &[Event]) -> Vec<Option<TherapySettings>> {
    events.iter().map(|e| adv.observe(e).unwrap()).collect()
}

#[test]
fn same_events_and_seed_give_the_same_decisions() {
    for mode in [Mode::Smbg, Mode::Cgm] {
        for variant in [CriticVariant::ValueTd, CriticVariant::KondaTsitsiklis] {
            let (events, decisions) = recorded(mode, variant, 77);
            assert!(decisions.len() > 60, "{} decisions", decisions.len());
            let mut c = AbbaConfig::new(mode, 77);
            c.critic.variant = variant;
            let mut a = Abba::new(c.clone(), start()).unwrap();
            let outs_a = replay(&mut a, &events);
            let mut b = Abba::new(c, start()).unwrap();
            let outs_b = replay(&mut b, &events);
            assert_eq!(outs_a, outs_b);
            // Open-loop replay of the closed-loop stream reproduces it exactly.
            assert!(
                a.take_decisions() == decisions,
                "{mode:?} {variant:?}: decisions differ"
            );
            b.take_decisions();
            assert!(
                a.save_json().unwrap() == b.save_json().unwrap(),
                "{mode:?} {variant:?}: state bytes differ"
            );
        }
    }
}

#[test]
fn a_different_seed_explores_differently() {
    let (events, decisions) = recorded(Mode::Cgm, CriticVariant::ValueTd, 77);
    let mut other = Abba::new(AbbaConfig::new(Mode::Cgm, 78), start()).unwrap();
    replay(&mut other, &events);
    let d2 = other.take_decisions();
    assert_eq!(d2.len(), decisions.len());
    assert!(decisions.iter().zip(&d2).any(|(a, b)| a.new != b.new));
}

fn check_resume(mode: Mode, variant: CriticVariant, events: &[Event], cut: usize) {
    let mut c = AbbaConfig::new(mode, 5);
    c.critic.variant = variant;
    let mut whole = Abba::new(c.clone(), start()).unwrap();
    let outs_whole = replay(&mut whole, events);
    let mut first = Abba::new(c, start()).unwrap();
    let mut outs = replay(&mut first, &events[..cut]);
    let saved = first.save_json().unwrap();
    drop(first);
    let mut resumed = Abba::load_json(&saved).unwrap();
    outs.extend(replay(&mut resumed, &events[cut..]));
    assert!(outs == outs_whole, "cut at {cut}: returned settings differ");
    assert!(
        resumed.take_decisions() == whole.take_decisions(),
        "cut at {cut}: decisions differ"
    );
    if resumed != whole {
        let (a, b) = (resumed.save_json().unwrap(), whole.save_json().unwrap());
        let i = a
            .bytes()
            .zip(b.bytes())
            .position(|(x, y)| x != y)
            .unwrap_or(0);
        panic!(
            "cut at {cut}: state differs at byte {i}: {} vs {}",
            &a[i.saturating_sub(200)..(i + 100).min(a.len())],
            &b[i.saturating_sub(200)..(i + 100).min(b.len())]
        );
    }
}

#[test]
fn save_and_resume_at_the_hard_points() {
    for mode in [Mode::Smbg, Mode::Cgm] {
        let (events, _) = recorded(mode, CriticVariant::ValueTd, 5);
        // Hard points: the very start, inside the init week, the last
        // init-day close, the first CIR update, and the end.
        let close_idx: Vec<usize> = events
            .iter()
            .enumerate()
            .filter(|(_, e)| e.kind == abba_core::EventKind::DayClosed)
            .map(|(i, _)| i)
            .collect();
        for cut in [
            0,
            1,
            500,
            close_idx[5],
            close_idx[6],
            close_idx[6] + 1,
            close_idx[7] - 3,
            events.len() - 1,
            events.len(),
        ] {
            check_resume(mode, CriticVariant::ValueTd, &events, cut);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]
    #[test]
    fn save_and_resume_anywhere(cut_frac in 0.0f64..1.0, smbg in any::<bool>(), b in any::<bool>()) {
        let mode = if smbg { Mode::Smbg } else { Mode::Cgm };
        let variant = if b { CriticVariant::KondaTsitsiklis } else { CriticVariant::ValueTd };
        let (events, _) = recorded(mode, variant, 5);
        let cut = ((events.len() as f64) * cut_frac) as usize;
        check_resume(mode, variant, &events, cut);
    }
}

#[test]
fn any_advisor_round_trips_for_every_arm() {
    let (events, _) = recorded(Mode::Smbg, CriticVariant::ValueTd, 9);
    let specs = [
        AdvisorSpec::Abba(AbbaConfig::new(Mode::Smbg, 0)),
        AdvisorSpec::RunToRun(R2rConfig::new(Mode::Smbg)),
        AdvisorSpec::Fixed {
            limits: Default::default(),
        },
        AdvisorSpec::Autotune(abba_advisor::AutotuneConfig::new(Mode::Smbg)),
    ];
    for spec in specs {
        // The spec itself is serialisable (the trial's manifest can hold it).
        let spec: AdvisorSpec =
            serde_json::from_str(&serde_json::to_string(&spec).unwrap()).unwrap();
        let mut whole = spec.build(start(), 9).unwrap();
        let outs_whole = replay(&mut whole, &events);
        let mut first = spec.build(start(), 9).unwrap();
        let cut = events.len() / 2;
        let mut outs = replay(&mut first, &events[..cut]);
        let json = first.save_json().unwrap();
        assert!(
            json.starts_with(&format!(
                r#"{{"format":"abba-advisor-state","version":{STATE_FORMAT_VERSION},"advisor":"{}""#,
                first.name()
            )),
            "{}",
            &json[..80]
        );
        let mut resumed = AnyAdvisor::load_json(&json).unwrap();
        outs.extend(replay(&mut resumed, &events[cut..]));
        assert_eq!(outs, outs_whole, "{}", whole.name());
        assert_eq!(
            resumed.take_decisions(),
            whole.take_decisions(),
            "{}",
            whole.name()
        );
        assert_eq!(resumed.settings(), whole.settings());
    }
}

#[test]
fn corrupt_state_is_rejected() {
    let a = Abba::new(AbbaConfig::new(Mode::Cgm, 1), start()).unwrap();
    let json = a.save_json().unwrap();
    let bad = json.replace("\"gamma\":0.9", "\"gamma\":1.9");
    assert_ne!(bad, json);
    let e = Abba::load_json(&bad).unwrap_err().to_string();
    assert!(e.contains("critic.gamma"), "{e}");
    assert!(Abba::load_json("{}").is_err());
}

#[test]
fn states_of_another_version_or_advisor_are_refused_clearly() {
    let a = Abba::new(AbbaConfig::new(Mode::Cgm, 1), start()).unwrap();
    let json = a.save_json().unwrap();
    let v = format!("\"version\":{STATE_FORMAT_VERSION}");
    assert!(json.contains(&v));
    let future = json.replacen(&v, "\"version\":999", 1);
    let e = Abba::load_json(&future).unwrap_err().to_string();
    assert!(e.contains("format version 999"), "{e}");
    assert!(
        e.contains(&format!("only version {STATE_FORMAT_VERSION}")),
        "{e}"
    );
    assert!(AnyAdvisor::load_json(&future).is_err());
    // A bare state without the envelope (as written before versioning).
    let bare = serde_json::to_string(&a).unwrap();
    let e = Abba::load_json(&bare).unwrap_err().to_string();
    assert!(e.contains("no field `format`"), "{e}");
    // The state of one advisor is not loaded as another.
    let fixed = AdvisorSpec::Fixed {
        limits: Default::default(),
    }
    .build(start(), 0)
    .unwrap();
    let e = Abba::load_json(&fixed.save_json().unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("state of a standard advisor"), "{e}");
    // AnyAdvisor reads what the concrete type wrote.
    let any = AnyAdvisor::load_json(&json).unwrap();
    assert_eq!(any.as_abba(), Some(&a));
    assert_eq!(any.name(), "abba");
    assert_eq!(any.mode(), Some(Mode::Cgm));
}
