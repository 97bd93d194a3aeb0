//! The daily timeline of spec §2 driven by events, in both modes, with the
//! edge cases of §2.4, and the direction of adaptation on toy people.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::{
    Abba, AbbaConfig, Advisor, Decision, DecisionDetail, Mode, Parameter, SkipReason, TeOutcome,
};
use abba_core::{Event, EventKind, MealSlot, MgDl};
use common::{start, t, Toy, NEUTRAL};

fn abba(mode: Mode, seed: u64) -> Abba {
    Abba::new(AbbaConfig::new(mode, seed), start()).unwrap()
}

fn explanation(d: &Decision) -> &abba_advisor::decision::AbbaExplanation {
    match &d.detail {
        DecisionDetail::Abba(x) => x,
        other => panic!("expected an ABBA update at {}, got {other:?}", d.at),
    }
}

#[test]
fn smbg_timeline_first_updates_and_windows() {
    // Trial days D2..D12 = indices 1..11.
    let mut a = abba(Mode::Smbg, 1);
    let toy = Toy {
        basal_need: 1.3,
        ..NEUTRAL
    };
    toy.run(&mut a, Mode::Smbg, 1, 11, 7);
    let d = a.take_decisions();
    // First decision: BR at 23:00 of D8 (index 7) from the night's two SMBG
    // values (the default window, 22:30 of D7 to 07:30 of D8: D7's bedtime
    // and D8's pre-breakfast readings).
    assert_eq!(d[0].parameter, Parameter::Basal);
    assert_eq!(d[0].at, t(7, 1380), "first BR update at 23:00 D8");
    let x = explanation(&d[0]);
    assert_eq!(x.window.n, 2, "BR window = the night's 2 SMBG values");
    assert_eq!((x.window_start, x.window_end), (t(6, 1350), t(7, 450)));
    // Then D9: CIR1, CIR2, CIR3 at the announcements, BR at 23:00.
    let expect = [
        (Parameter::CarbRatio(MealSlot::Breakfast), t(8, 420)),
        (Parameter::CarbRatio(MealSlot::Lunch), t(8, 720)),
        (Parameter::CarbRatio(MealSlot::Dinner), t(8, 1110)),
        (Parameter::Basal, t(8, 1380)),
    ];
    for (k, (p, at)) in expect.iter().enumerate() {
        assert_eq!(
            (d[k + 1].parameter, d[k + 1].at),
            (*p, *at),
            "decision {}",
            k + 1
        );
    }
    // CIR1 window: D8 breakfast -> D8 lunch, holds the pre-lunch SMBG only.
    let x = explanation(&d[1]);
    assert_eq!(
        (x.window_start, x.window_end, x.window.n),
        (t(7, 420), t(7, 720), 1)
    );
    // CIR3 window: D8 dinner -> D9 breakfast: bedtime + next pre-breakfast SMBG.
    let x = explanation(&d[3]);
    assert_eq!(
        (x.window_start, x.window_end, x.window.n),
        (t(7, 1110), t(8, 420), 2)
    );
    // TE initialisation happened at the first BR update.
    let init = a.init_report().unwrap();
    assert_eq!(init.at, t(7, 1380));
    assert!(matches!(init.te, TeOutcome::Estimated(_)), "{:?}", init.te);
    // 4 decisions a day from D9 (index 8) to D12 (index 11).
    assert_eq!(d.len(), 1 + 4 * 4, "D9..D12 with 4 decisions each");
}

#[test]
fn settings_stay_at_start_during_the_init_week() {
    let mut a = abba(Mode::Cgm, 2);
    let toy = Toy {
        basal_need: 2.0,
        cr_need: [5.0; 3],
        ..NEUTRAL
    };
    let events = toy.run(&mut a, Mode::Cgm, 1, 7, 7);
    assert_eq!(*a.settings(), start());
    assert!(a.decisions().is_empty());
    assert!(!a.is_initialised());
    assert!(events.iter().any(|e| e.kind == EventKind::DayClosed));
}

#[test]
fn cgm_timeline_first_br_update_at_midnight_from_previous_day() {
    let mut a = abba(Mode::Cgm, 3);
    NEUTRAL.run(&mut a, Mode::Cgm, 1, 10, 7);
    let d = a.take_decisions();
    assert_eq!((d[0].parameter, d[0].at), (Parameter::Basal, t(8, 0)));
    let x = explanation(&d[0]);
    assert_eq!(
        x.window.n, 288,
        "all CGM samples of D8 and not the 00:00 D9 one"
    );
    assert_eq!(x.window_start, t(7, 0));
    assert_eq!(d[1].parameter, Parameter::CarbRatio(MealSlot::Breakfast));
    let x = explanation(&d[1]);
    // Breakfast window: 07:00 -> 12:00 of D8 = 60 samples.
    assert_eq!(
        (x.window_start, x.window_end, x.window.n),
        (t(7, 420), t(7, 720), 60)
    );
    assert_eq!(a.init_report().unwrap().at, t(8, 0));
}

#[test]
fn skipped_meal_skips_its_update_and_extends_the_previous_window() {
    let toy = Toy {
        skip_lunch_days: &[9],
        ..NEUTRAL
    };
    let mut a = abba(Mode::Cgm, 4);
    toy.run(&mut a, Mode::Cgm, 1, 11, 7);
    let d = a.take_decisions();
    // Breakfast of day 10 uses day 9's breakfast window, which ran to dinner.
    let b10 = d
        .iter()
        .find(|x| x.at == t(10, 420))
        .expect("breakfast decision on day 10");
    assert_eq!(explanation(b10).window_end, t(9, 1110));
    let l10 = d.iter().find(|x| x.at == t(10, 720)).unwrap();
    assert_eq!(
        l10.detail,
        DecisionDetail::Skipped {
            reason: SkipReason::NoPreviousDayWindow
        }
    );
    assert_eq!(l10.old, l10.new);
    // No lunch decision on day 9 itself (no announcement), and the advisor
    // did not count a decision for the skipped one.
    assert!(!d
        .iter()
        .any(|x| x.at.day_index() == 9 && x.at.minute_of_day() == 720));
}

#[test]
fn empty_smbg_window_leaves_the_ratio_and_the_learner_untouched() {
    let toy = Toy {
        no_prelunch_smbg_days: &[9],
        ..NEUTRAL
    };
    let mut a = abba(Mode::Smbg, 5);
    toy.run(&mut a, Mode::Smbg, 1, 11, 7);
    let d = a.take_decisions();
    let b10 = d.iter().find(|x| x.at == t(10, 420)).unwrap();
    assert_eq!(
        b10.detail,
        DecisionDetail::Skipped {
            reason: SkipReason::EmptyWindow
        }
    );
    assert_eq!(b10.old, b10.new);
    // breakfast agent: decisions on day indices 8, 9 and 11 (10 skipped)
    assert_eq!(
        a.counters(Parameter::CarbRatio(MealSlot::Breakfast))
            .decisions,
        3
    );
}

fn final_settings(
    toy: Toy,
    mode: Mode,
    seed: u64,
    days: i64,
) -> (abba_core::TherapySettings, Vec<Decision>) {
    final_settings_with(AbbaConfig::new(mode, seed), toy, days)
}

fn final_settings_with(
    cfg: AbbaConfig,
    toy: Toy,
    days: i64,
) -> (abba_core::TherapySettings, Vec<Decision>) {
    let mode = cfg.mode;
    let mut a = Abba::new(cfg, start()).unwrap();
    toy.run(&mut a, mode, 1, days, 7);
    (*a.settings(), a.take_decisions())
}

#[test]
fn hyperglycaemia_means_more_insulin_and_hypoglycaemia_less() {
    let too_little = Toy {
        basal_need: 1.4,
        cr_need: [7.0; 3],
        ..NEUTRAL
    };
    let too_much = Toy {
        basal_need: 0.7,
        cr_need: [14.0; 3],
        ..NEUTRAL
    };
    // The sign conventions of θ0 (§7.3) and of the supervisor (eq26/27/29)
    // through the whole timeline. The actor step is switched off (β = 0):
    // with the spec's β = 0.5 the clipped eq28 step dominates θ within days
    // (see `literal_actor_step_is_clipped_at_almost_every_update`); the
    // default projected natural-gradient step is switched off too, and so
    // is exploration: a single draw σz can outweigh P_d on the first move
    // (with θ0 hyper 0.15 it did, at seed 11), and these are checks of the
    // deterministic sign conventions, not of the noise around them.
    for mode in [Mode::Smbg, Mode::Cgm] {
        let mut cfg = AbbaConfig::new(mode, 11);
        cfg.actor.beta = 0.0;
        cfg.actor.natural_beta = 0.0;
        cfg.actor.c_sigma = 0.0;
        let (s, d) = final_settings_with(cfg.clone(), too_little, 30);
        assert!(
            s.basal.0 > 1.0,
            "{mode:?} hyper: basal expected up, got {}",
            s.basal.0
        );
        // Carb ratios: first move of each is down (more bolus) or frozen by the switch rule.
        for slot in MealSlot::MAIN {
            let first = d
                .iter()
                .find(|x| x.parameter == Parameter::CarbRatio(slot) && x.new != x.old);
            if let Some(x) = first {
                assert!(
                    x.new < x.old,
                    "{mode:?} hyper: first {slot:?} move must be down: {x}"
                );
            }
        }
        assert!(d.iter().all(|x| x.new.is_finite() && x.new > 0.0));
        check_decision_signs(&d);
        let (s, d) = final_settings_with(cfg, too_much, 30);
        assert!(
            s.basal.0 < 1.0,
            "{mode:?} hypo: basal expected down, got {}",
            s.basal.0
        );
        // (The carb ratios of this toy may legitimately move either way once
        // the basal rate has fallen: its post-meal windows become high.)
        check_decision_signs(&d);
    }
}

/// With θ = θ0: a window with only hyper excursions asks for more insulin
/// (P_d > 0 for BR, < 0 for a CIR); one with only hypo excursions for less.
fn check_decision_signs(d: &[Decision]) {
    let mut checked = 0;
    for x in d {
        let DecisionDetail::Abba(e) = &x.detail else {
            continue;
        };
        let more_insulin = match x.parameter {
            Parameter::Basal => e.action.p_d > 0.0,
            Parameter::CarbRatio(_) => e.action.p_d < 0.0,
        };
        let less_insulin = match x.parameter {
            Parameter::Basal => e.action.p_d < 0.0,
            Parameter::CarbRatio(_) => e.action.p_d > 0.0,
        };
        if e.features.hyper > 0.0 && e.features.hypo == 0.0 {
            assert!(
                more_insulin,
                "hyper-only window must ask for more insulin: {x}"
            );
            checked += 1;
        }
        if e.features.hypo > 0.0 && e.features.hyper == 0.0 {
            assert!(
                less_insulin,
                "hypo-only window must ask for less insulin: {x}"
            );
            checked += 1;
        }
    }
    assert!(checked > 10, "only {checked} one-sided windows checked");
}

#[test]
fn every_decision_explains_itself() {
    let toy = Toy {
        basal_need: 1.3,
        ..NEUTRAL
    };
    let (_, d) = final_settings(toy, Mode::Smbg, 6, 12);
    let line = d[0].to_string();
    for needle in [
        "D8 23:00",
        "basal rate",
        "F = (",
        "P_a =",
        "P_s =",
        "exploration =",
        "P_e =",
    ] {
        assert!(line.contains(needle), "missing {needle:?} in {line}");
    }
    // The JSON form carries the whole explanation.
    let json = serde_json::to_string(&d[0]).unwrap();
    for key in [
        "features",
        "p_a",
        "p_s",
        "z",
        "switch_fired",
        "clamp_fired",
        "old",
        "new",
    ] {
        assert!(json.contains(key), "missing {key} in {json}");
    }
}

#[test]
fn readings_of_the_other_kind_do_not_enter_windows() {
    // In SMBG mode a CGM reading after the init week is accepted but not used.
    let mut a = abba(Mode::Smbg, 7);
    NEUTRAL.run(&mut a, Mode::Smbg, 1, 8, 7);
    a.take_decisions();
    a.observe(&Event::new(t(9, 100), EventKind::Cgm(MgDl(300.0))))
        .unwrap();
    a.observe(&Event::new(t(9, 1380), EventKind::Smbg(MgDl(120.0))))
        .unwrap();
    a.observe(&Event::new(t(9, 1381), EventKind::DayClosed))
        .unwrap();
    let d = a.take_decisions();
    assert_eq!(explanation(&d[0]).window.n, 1);
}

#[test]
fn literal_actor_step_is_clipped_at_almost_every_update() {
    // Spec §6.4 asks to report how often the |Δθ| ≤ 0.5 clip fires. With the
    // spec's defaults (β = 0.5, σ = 0.05‖F‖², ψ ∝ 1/σ) a persistently
    // hyperglycaemic toy person makes nearly every actor step hit the clip.
    let toy = Toy {
        basal_need: 1.4,
        cr_need: [7.0; 3],
        ..NEUTRAL
    };
    // The spec-literal clip of 0.5 (our default is 0.01, where the clip
    // fires even more often).
    let mut config = AbbaConfig::new(Mode::Cgm, 11);
    config.actor.rule = abba_advisor::config::ActorRule::Eq28;
    config.actor.theta_step_clip = 0.5;
    // ... and the seed's update rules (the CIR switch rule in CGM mode too).
    config.update = abba_advisor::config::UpdateConfig::spec();
    let mut a = Abba::new(config, start()).unwrap();
    toy.run(&mut a, Mode::Cgm, 1, 30, 7);
    let c = a.counters(Parameter::Basal);
    println!("basal agent counters: {c:?}");
    assert!(c.actor_steps >= 15, "expected >= 15 actor steps, got {c:?}");
    assert!(
        c.actor_clips * 10 >= c.actor_steps * 8,
        "expected the clip on >= 80 % of steps, got {c:?}"
    );
}

#[test]
fn optional_hypo_guard_cancels_insulin_increases_on_hypo_windows() {
    let toy = Toy {
        basal_need: 0.7,
        cr_need: [14.0; 3],
        ..NEUTRAL
    };
    let mut cfg = AbbaConfig::new(Mode::Cgm, 11);
    cfg.update.hypo_guard = true;
    let (_, d) = final_settings_with(cfg, toy, 40);
    let mut checked = 0;
    for x in &d {
        let DecisionDetail::Abba(e) = &x.detail else {
            continue;
        };
        if e.window.hyponumber > 0 {
            checked += 1;
            let more = match x.parameter {
                Parameter::Basal => x.new > x.old,
                Parameter::CarbRatio(_) => x.new < x.old,
            };
            assert!(!more, "insulin added despite a hypo in the window: {x}");
        }
    }
    assert!(checked > 10, "only {checked} hypo windows");
    // Without the guard and with the literal eq28 actor and clip of 0.5, the
    // learned P_a does add insulin on some hypo windows of this toy person:
    // the guard is not vacuous. With the default clip (0.01) it does not.
    let count = |cfg: AbbaConfig| {
        let (_, d) = final_settings_with(cfg, toy, 40);
        d.iter()
            .filter(|x| match &x.detail {
                DecisionDetail::Abba(e) if e.window.hyponumber > 0 => match x.parameter {
                    Parameter::Basal => x.new > x.old,
                    Parameter::CarbRatio(_) => x.new < x.old,
                },
                _ => false,
            })
            .count()
    };
    let mut literal = AbbaConfig::new(Mode::Cgm, 11);
    literal.actor.rule = abba_advisor::config::ActorRule::Eq28;
    literal.actor.theta_step_clip = 0.5;
    let violations = count(literal);
    let default_violations = count(AbbaConfig::new(Mode::Cgm, 11));
    println!(
        "insulin increases on hypo windows: clip 0.5 {violations}, default {default_violations}"
    );
    assert!(
        violations > 0,
        "expected the literal algorithm to add insulin on some hypo window"
    );
    assert_eq!(
        default_violations, 0,
        "the default actor added insulin on a hypo window"
    );
}

#[test]
fn first_week_te_matches_the_advisors_own_estimate() {
    let mut a = abba(Mode::Cgm, 1);
    let toy = Toy {
        basal_need: 1.2,
        ..NEUTRAL
    };
    let events = toy.run(&mut a, Mode::Cgm, 1, 9, 7);
    let week: Vec<_> = events.iter().copied().filter(|e| e.at < t(8, 0)).collect();
    let te = abba_advisor::te::first_week_te(&week, start().basal, 7, &a.config().te).unwrap();
    match &a.init_report().unwrap().te {
        TeOutcome::Estimated(own) => assert_eq!(*own, te),
        other => panic!("expected an estimate, got {other:?}"),
    }
}

#[test]
fn projected_actor_keeps_theta_in_its_sign_pattern_where_eq28_leaves_it() {
    use abba_advisor::agent::in_sign_pattern;
    use abba_advisor::config::ActorRule;
    use abba_advisor::supervisor::ParamKind;
    let toy = Toy {
        basal_need: 0.7,
        cr_need: [14.0; 3],
        ..NEUTRAL
    };
    let agents = [
        (Parameter::Basal, ParamKind::Basal),
        (
            Parameter::CarbRatio(MealSlot::Breakfast),
            ParamKind::CarbRatio,
        ),
        (Parameter::CarbRatio(MealSlot::Lunch), ParamKind::CarbRatio),
        (Parameter::CarbRatio(MealSlot::Dinner), ParamKind::CarbRatio),
    ];
    let run = |rule: ActorRule| {
        let mut cfg = AbbaConfig::new(Mode::Cgm, 11);
        cfg.actor.rule = rule;
        cfg.actor.natural_beta = 100.0;
        cfg.actor.beta = 0.5;
        cfg.actor.theta_step_clip = 0.5;
        let mut a = Abba::new(cfg, start()).unwrap();
        toy.run(&mut a, Mode::Cgm, 1, 60, 7);
        let out: Vec<bool> = agents
            .iter()
            .map(|(p, k)| in_sign_pattern(*k, a.theta(*p)))
            .collect();
        let clips: u32 = agents.iter().map(|(p, _)| a.counters(*p).actor_clips).sum();
        (out, clips)
    };
    let (projected, clips) = run(ActorRule::ProjectedNatural);
    assert!(projected.iter().all(|x| *x), "{projected:?}");
    assert!(clips > 0, "the projection never fired: the test is vacuous");
    let (literal, _) = run(ActorRule::Eq28);
    assert!(
        literal.iter().any(|x| !*x),
        "expected eq28 to leave the sign pattern somewhere: {literal:?}"
    );
}

/// Every basal decision of `d` (at least 15) names `[from, to)` of its
/// closed day as its window, with `n` readings in it.
fn assert_basal_windows(d: &[Decision], [from, to]: [i64; 2], n: u32) {
    let basal: Vec<_> = d
        .iter()
        .filter(|x| x.parameter == Parameter::Basal)
        .collect();
    assert!(basal.len() >= 15);
    for x in basal {
        let e = explanation(x);
        let day = (e.window_end.0 - to).div_euclid(1440);
        assert_eq!(
            (e.window_start, e.window_end, e.window.n),
            (t(day, from), t(day, to), n),
            "{x}"
        );
    }
}

#[test]
fn a_basal_window_judges_the_night_and_leaves_the_meals_to_the_carb_ratios() {
    // Under-bolused meals (carb ratios 10 against a need of 7: ~190 mg/dL
    // after each meal), the right basal (fasting 110 mg/dL). Judged on the
    // whole day the basal agent answers the meals' hyperglycaemia with
    // more basal; judged on 00:00-07:00 it sees a night in range.
    let toy = Toy {
        basal_need: 1.0,
        cr_need: [7.0; 3],
        ..NEUTRAL
    };
    let whole = AbbaConfig::new(Mode::Cgm, 5);
    let mut night = AbbaConfig::new(Mode::Cgm, 5);
    night.features.cgm_basal_window_min = Some([0, 420]);
    let (s_whole, _) = final_settings_with(whole, toy, 25);
    let (s_night, d) = final_settings_with(night.clone(), toy, 25);
    println!(
        "basal: whole day {}, night {}",
        s_whole.basal.0, s_night.basal.0
    );
    assert!(s_whole.basal.0 > 1.04, "whole day: {}", s_whole.basal.0);
    assert!(
        (s_night.basal.0 - 1.0).abs() < 0.03,
        "night: {}",
        s_night.basal.0
    );
    // Both still give the meals more insulin.
    assert!(
        s_night.carb_ratio.iter().all(|cr| cr.0 < 9.9),
        "{s_night:?}"
    );
    // Each basal decision names the night as its window: 84 five-minute
    // readings from 00:00 to 07:00 of the closed day.
    assert_basal_windows(&d, [0, 420], 84);
    // SMBG mode reads its four readings a day as before.
    let mut smbg = AbbaConfig::new(Mode::Smbg, 5);
    smbg.features.cgm_basal_window_min = Some([0, 420]);
    smbg.features.smbg_basal_window_min = None;
    let (_, d) = final_settings_with(smbg, toy, 12);
    let x = d.iter().find(|x| x.parameter == Parameter::Basal).unwrap();
    assert_eq!(explanation(x).window.n, 4);
    // SMBG mode's own window holds the fasting reading (06:40): the basal
    // stays where the fasting glucose is right; on the whole day its four
    // readings (three after meals) raise it.
    let mut whole_day = AbbaConfig::new(Mode::Smbg, 5);
    whole_day.features.smbg_basal_window_min = None;
    let (s_whole, _) = final_settings_with(whole_day, toy, 25);
    let mut fasting = AbbaConfig::new(Mode::Smbg, 5);
    fasting.features.smbg_basal_window_min = Some([0, 450]);
    let (s_fasting, d) = final_settings_with(fasting, toy, 25);
    println!(
        "SMBG basal: whole day {}, fasting reading {}",
        s_whole.basal.0, s_fasting.basal.0
    );
    assert!(
        s_whole.basal.0 > 1.04,
        "SMBG whole day: {}",
        s_whole.basal.0
    );
    assert!(
        (s_fasting.basal.0 - 1.0).abs() < 0.03,
        "SMBG fasting: {}",
        s_fasting.basal.0
    );
    assert_basal_windows(&d, [0, 450], 1);
    // A window from the evening before holds the night's two readings:
    // bedtime (23:00) and fasting (06:40).
    let mut evening = AbbaConfig::new(Mode::Smbg, 5);
    evening.features.smbg_basal_window_min = Some([-90, 450]);
    let (_, d) = final_settings_with(evening.clone(), toy, 25);
    assert_basal_windows(&d, [-90, 450], 2);
    // The data rule (a person's store sets it) asks of these few readings
    // what it asks of a meal window, the day's count checked on the day:
    // the basal still moves.
    let mut ruled = Abba::new(evening, start())
        .unwrap()
        .with_min_data(abba_advisor::MinData::default());
    toy.run(&mut ruled, Mode::Smbg, 1, 14, 7);
    let basal: Vec<_> = ruled
        .take_decisions()
        .into_iter()
        .filter(|x| x.parameter == Parameter::Basal)
        .collect();
    assert!(basal.len() >= 5);
    for x in &basal {
        assert!(matches!(x.detail, DecisionDetail::Abba(_)), "{x}");
    }
    // A window that is not part of a day is refused by name.
    for bad in [[420, 0], [-1440, 420], [0, 1441], [300, 300], [-600, 1000]] {
        let mut c = AbbaConfig::new(Mode::Cgm, 5);
        c.features.cgm_basal_window_min = Some(bad);
        let e = Abba::new(c, start()).unwrap_err().to_string();
        assert!(e.contains("features.cgm_basal_window_min"), "{e}");
        let mut c = AbbaConfig::new(Mode::Smbg, 5);
        c.features.smbg_basal_window_min = Some(bad);
        let e = Abba::new(c, start()).unwrap_err().to_string();
        assert!(e.contains("features.smbg_basal_window_min"), "{e}");
    }
    // The data rule holds the night to its coverage: a night with readings
    // only until 03:00 (36 of 84) is too little, though its day has 252
    // of 288 readings (more than 70 %).
    let mut recorder = Abba::new(night.clone(), start()).unwrap();
    let events = toy.run(&mut recorder, Mode::Cgm, 1, 12, 7);
    let gap_day = 10;
    let mut a = Abba::new(night, start())
        .unwrap()
        .with_min_data(abba_advisor::MinData::default());
    for e in events.iter().filter(|e| {
        !(matches!(e.kind, EventKind::Cgm(_))
            && e.at.day_index() == gap_day
            && (180..420).contains(&e.at.minute_of_day()))
    }) {
        a.observe(e).unwrap();
    }
    let d = a.take_decisions();
    let skipped = d
        .iter()
        .find(|x| x.parameter == Parameter::Basal && x.at == t(gap_day + 1, 0))
        .unwrap();
    assert!(
        matches!(
            skipped.detail,
            DecisionDetail::Skipped {
                reason: SkipReason::TooFewReadings {
                    n: 36,
                    required: 58
                }
            }
        ),
        "{skipped}"
    );
}

#[test]
fn a_night_that_fell_from_a_high_bedtime_reading_does_not_raise_the_basal_when_asked() {
    // The toy's SMBG days with every bedtime reading (23:00) at 200 mg/dL and
    // every fasting one (06:40) at 135: the night fell 65 mg/dL.
    let toy = Toy {
        basal_need: 1.0,
        cr_need: [10.0; 3],
        ..NEUTRAL
    };
    let mut recorder = abba(Mode::Smbg, 5);
    let events: Vec<Event> = toy
        .run(&mut recorder, Mode::Smbg, 1, 14, 7)
        .into_iter()
        .map(|mut e| {
            if let EventKind::Smbg(_) = e.kind {
                let m = e.at.minute_of_day();
                if m >= 22 * 60 {
                    e.kind = EventKind::Smbg(MgDl(200.0));
                } else if m < 450 {
                    e.kind = EventKind::Smbg(MgDl(135.0));
                }
            }
            e
        })
        .collect();
    let basal_features = |fall: Option<f64>| {
        let mut c = AbbaConfig::new(Mode::Smbg, 5);
        assert_eq!(c.features.smbg_basal_window_min, Some([-90, 450]));
        assert_eq!(c.features.smbg_night_fall_mg_dl, None, "off by default");
        c.features.smbg_night_fall_mg_dl = fall;
        let mut a = Abba::new(c, start()).unwrap();
        for e in &events {
            a.observe(e).unwrap();
        }
        let d: Vec<_> = a
            .take_decisions()
            .into_iter()
            .filter(|x| x.parameter == Parameter::Basal)
            .collect();
        assert!(d.len() >= 6, "{}", d.len());
        d.iter()
            .map(|x| (explanation(x).window, explanation(x).features))
            .collect::<Vec<_>>()
    };
    // As the seed reads it: the bedtime reading's 50 mg/dL above G_H over
    // the night's two readings, F_hyper = 25 / (250 − 150).
    for (w, f) in basal_features(None) {
        assert_eq!((w.n, w.n_hyper), (2, 1));
        assert!((f.hyper - 0.25).abs() < 1e-12, "{f:?}");
    }
    // With the night's fall asked for (30 mg/dL), it counts as in range.
    for (w, f) in basal_features(Some(30.0)) {
        assert_eq!((w.n, w.n_hyper, w.n2), (2, 0, 1));
        assert_eq!(f.hyper, 0.0);
    }
    // A fall smaller than asked leaves it as it is.
    for (w, f) in basal_features(Some(80.0)) {
        assert_eq!((w.n, w.n_hyper), (2, 1));
        assert!((f.hyper - 0.25).abs() < 1e-12, "{f:?}");
    }
    // A negative threshold is refused by name.
    let mut c = AbbaConfig::new(Mode::Smbg, 5);
    c.features.smbg_night_fall_mg_dl = Some(-1.0);
    let e = Abba::new(c, start()).unwrap_err().to_string();
    assert!(e.contains("features.smbg_night_fall_mg_dl"), "{e}");
}

/// A toy whose breakfast bolus is too large (the pre-lunch finger-stick is
/// low) and whose lunch bolus too small (the pre-dinner one is high).
const LOW_BEFORE_LUNCH: Toy = Toy {
    basal_need: 1.0,
    cr_need: [20.0, 7.0, 10.0],
    ..NEUTRAL
};

/// Whether a finger-stick below `below` was fed in the `hours` before `at`.
fn low_within(events: &[Event], at: abba_core::Timestamp, below: f64, hours: i64) -> bool {
    events.iter().any(|e| {
        matches!(e.kind, EventKind::Smbg(MgDl(g)) if g < below)
            && e.at <= at
            && at.minutes() - e.at.minutes() < hours * 60
    })
}

#[test]
fn smbg_a_recent_low_in_any_window_keeps_every_carb_ratio_from_going_down() {
    let cfg = AbbaConfig::new(Mode::Smbg, 3);
    let rule = cfg
        .update
        .smbg_recent_low_carb_ratios
        .expect("on by default");
    assert_eq!((rule.below_mg_dl, rule.hours), (90.0, 72));
    let run = |cfg: AbbaConfig| {
        let mut a = Abba::new(cfg.clone(), start()).unwrap();
        let events = LOW_BEFORE_LUNCH.run(&mut a, Mode::Smbg, 1, 40, 7);
        (events, a.take_decisions(), cfg)
    };
    let lunch = Parameter::CarbRatio(MealSlot::Lunch);
    // On: no lunch ratio goes down within 72 h of a reading below 90, and
    // the decision says why.
    let (events, d, cfg) = run(cfg);
    let mut fired = 0;
    for x in d.iter().filter(|x| x.parameter == lunch) {
        let DecisionDetail::Abba(e) = &x.detail else {
            continue;
        };
        if low_within(&events, x.at, 90.0, 72) {
            assert!(x.new >= x.old, "the lunch ratio went down after a low: {x}");
        }
        if e.applied.recent_low.is_some() {
            fired += 1;
            let why = abba_advisor::words::reasons(x, &cfg).join(" ");
            assert!(
                why.contains("below 90 mg/dL") && why.contains("72 hours"),
                "{why}"
            );
            assert!(x.to_string().contains("below 90 mg/dL"), "{x}");
            let mmol =
                abba_advisor::words::reasons_in(x, &cfg, abba_core::units::GlucoseUnit::MmolL);
            assert!(mmol.join(" ").contains("below 5.0 mmol/L"), "{mmol:?}");
        }
    }
    assert!(fired >= 5, "the rule held the lunch ratio {fired} times");
    // The lunch window itself holds no low (its reading is the high
    // pre-dinner one): the window's own hypo guard would not have seen it.
    // Off, the same person's lunch ratio goes down after such lows.
    let mut off = AbbaConfig::new(Mode::Smbg, 3);
    off.update.smbg_recent_low_carb_ratios = None;
    let (events, d, _) = run(off);
    let lowered = d
        .iter()
        .filter(|x| x.parameter == lunch && x.new < x.old && low_within(&events, x.at, 90.0, 72))
        .count();
    assert!(
        lowered >= 5,
        "off, the lunch ratio fell {lowered} times after a low"
    );
}

#[test]
fn the_recent_low_rules_are_smbg_only_off_in_the_seed_and_checked() {
    use abba_advisor::config::{RecentLow, UpdateConfig};
    use abba_advisor::supervisor::ParamKind;
    let rule = RecentLow {
        below_mg_dl: 80.0,
        hours: 48,
    };
    let u = UpdateConfig {
        smbg_recent_low_basal: Some(rule),
        smbg_recent_low_carb_ratios: Some(rule),
        ..UpdateConfig::default()
    };
    for kind in [ParamKind::Basal, ParamKind::CarbRatio] {
        assert_eq!(u.recent_low_for(Mode::Cgm, kind), None);
        assert_eq!(u.recent_low_for(Mode::Smbg, kind), Some(rule));
    }
    assert_eq!(UpdateConfig::spec().smbg_recent_low_carb_ratios, None);
    assert_eq!(UpdateConfig::default().smbg_recent_low_basal, None);
    // Bad values are named.
    let mut cfg = AbbaConfig::new(Mode::Smbg, 1);
    cfg.update.smbg_recent_low_carb_ratios = Some(RecentLow {
        below_mg_dl: 90.0,
        hours: 0,
    });
    let err = cfg.validate().unwrap_err().to_string();
    assert!(
        err.contains("update.smbg_recent_low_carb_ratios.hours"),
        "{err}"
    );
}
