//! Behaviour of the closed loop with a scripted advisor: the order of
//! events, when answers take effect, what the advisor is and is not told.
//! Each test fails if the behaviour it names breaks.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_advisor::decision::Decision;
use abba_advisor::{Advisor, AdvisorError, ArmKind, Mode};
use abba_core::{Event, EventKind, GramsPerUnit, TherapySettings, Timestamp, UnitsPerHour};
use abba_sim::cohort::{Cohort, CohortConfig, Population, VirtualPatient};
use abba_sim::devices::DeviceSet;
use abba_sim::person::VirtualPerson;
use abba_sim::scenario::{ScenarioConfig, ScenarioId};
use abba_trial::closed_loop::{simulate, Trace};
use abba_trial::TrialConfig;

/// An advisor that answers every main-meal announcement with a new carb
/// ratio (alternating between two values far from the start) and every
/// day closing with a new basal rate, and records what it was told.
struct Scripted {
    settings: TherapySettings,
    seen: Vec<Event>,
    /// (announcement, carb ratio answered).
    answered_ratios: Vec<(Event, f64)>,
    /// (day closing, basal answered).
    answered_basals: Vec<(Event, f64)>,
}

impl Scripted {
    fn new(start: TherapySettings) -> Self {
        Self {
            settings: start,
            seen: Vec::new(),
            answered_ratios: Vec::new(),
            answered_basals: Vec::new(),
        }
    }
}

impl Advisor for Scripted {
    fn observe(&mut self, e: &Event) -> Result<Option<TherapySettings>, AdvisorError> {
        self.seen.push(*e);
        match e.kind {
            EventKind::MealAnnounced { slot, .. } => {
                let i = slot.main_index().unwrap();
                let n = self.answered_ratios.len();
                let ratio = if n.is_multiple_of(2) { 6.0 } else { 19.0 };
                self.settings.carb_ratio[i] = GramsPerUnit(ratio);
                self.answered_ratios.push((*e, ratio));
                Ok(Some(self.settings))
            }
            EventKind::DayClosed => {
                let n = self.answered_basals.len() as f64;
                self.settings.basal = UnitsPerHour(0.5 + 0.1 * (n % 5.0));
                self.answered_basals.push((*e, self.settings.basal.0));
                Ok(Some(self.settings))
            }
            _ => Ok(None),
        }
    }
    fn settings(&self) -> &TherapySettings {
        &self.settings
    }
    fn decisions(&self) -> &[Decision] {
        &[]
    }
    fn take_decisions(&mut self) -> Vec<Decision> {
        Vec::new()
    }
    fn arm(&self) -> ArmKind {
        ArmKind::Abba
    }
    fn mode(&self) -> Option<Mode> {
        None
    }
}

fn patient() -> VirtualPatient {
    Cohort::generate(&CohortConfig::new(Population::Adults, 1, 1))
        .unwrap()
        .patients
        .remove(0)
}

/// Runs `days` days of scenario `id` with the scripted advisor.
fn run(id: ScenarioId, days: u32) -> (Scripted, Trace) {
    let vp = patient();
    let mut scenario = ScenarioConfig::paper(id);
    scenario.days = days;
    let mode = TrialConfig::mode_for(&scenario);
    let mut person = VirtualPerson::new(
        &vp,
        1,
        &scenario,
        7,
        &DeviceSet::default(),
        TrialConfig::behaviour(mode),
    )
    .unwrap();
    let mut advisor = Scripted::new(vp.therapy);
    let mut trace = Trace {
        events: Some(Vec::new()),
        minutes: Some(Vec::new()),
        ..Trace::default()
    };
    let run = simulate(&mut person, &mut advisor, days, 1.0, &mut trace, "test").unwrap();
    assert!(run.failure.is_none());
    (advisor, trace)
}

/// The pump's bolus for `carbs` at `ratio`: rounded down to 0.05 U.
fn pump_bolus(carbs: f64, ratio: f64) -> f64 {
    (carbs / ratio * 20.0 + 1e-9).floor() / 20.0
}

#[test]
fn a_meal_bolus_uses_the_carb_ratio_answered_at_its_announcement() {
    let (advisor, _) = run(ScenarioId::S1, 4);
    assert!(advisor.answered_ratios.len() >= 6);
    for (announce, ratio) in &advisor.answered_ratios {
        let EventKind::MealAnnounced { carbs, .. } = announce.kind else {
            unreachable!()
        };
        let i = advisor.seen.iter().position(|e| e == announce).unwrap();
        let bolus = advisor.seen[i + 1..]
            .iter()
            .find(|e| matches!(e.kind, EventKind::Bolus(_)))
            .unwrap();
        assert_eq!(
            bolus.at, announce.at,
            "the bolus follows in the same minute"
        );
        let EventKind::Bolus(u) = bolus.kind else {
            unreachable!()
        };
        let expected = pump_bolus(carbs.0, *ratio);
        assert!(
            (u.0 - expected).abs() < 1e-9,
            "at {}: bolus {} U, expected {expected} U ({} g at {ratio} g/U)",
            announce.at,
            u.0,
            carbs.0
        );
        // The ratio before the answer would have given another dose.
        let other = if *ratio == 6.0 { 19.0 } else { 6.0 };
        assert_ne!(pump_bolus(carbs.0, other), expected);
    }
}

#[test]
fn a_basal_change_reaches_the_pump_the_same_minute() {
    let (advisor, trace) = run(ScenarioId::S2, 5);
    let minutes = trace.minutes.unwrap();
    assert!(advisor.answered_basals.len() >= 3);
    for (close, basal) in &advisor.answered_basals {
        let i = advisor.seen.iter().position(|e| e == close).unwrap();
        let next = advisor.seen[i + 1];
        assert_eq!(next.at, close.at);
        assert_eq!(next.kind, EventKind::BasalRate(UnitsPerHour(*basal)));
        let m = minutes.iter().find(|r| r.minute == close.at.0).unwrap();
        assert!((m.basal_u_per_h - basal).abs() < 1e-9);
        // That minute's insulin is the new basal (no bolus at bedtime).
        assert!((m.insulin_u_per_min - basal / 60.0).abs() < 1e-9);
    }
}

#[test]
fn the_advisor_hears_nothing_of_the_warm_up_day() {
    for id in [ScenarioId::S1, ScenarioId::S2] {
        let (advisor, _) = run(id, 3);
        let first = advisor.seen.first().unwrap();
        assert_eq!(first.at, Timestamp::from_day_and_minute(1, 0), "{id}");
        // The warm-up day's meals were still bolused (with the start ratio).
        assert!(advisor.seen.windows(2).all(|w| w[0].at <= w[1].at));
    }
}

#[test]
fn days_close_at_bedtime_in_smbg_mode_and_at_midnight_in_cgm_mode() {
    let (smbg, _) = run(ScenarioId::S2, 4);
    for (close, _) in &smbg.answered_basals {
        let i = smbg.seen.iter().position(|e| e == close).unwrap();
        assert!(
            matches!(smbg.seen[i - 1].kind, EventKind::Smbg(_)) && smbg.seen[i - 1].at == close.at,
            "SMBG mode: the day closes right after the bedtime reading"
        );
    }
    let days: Vec<i64> = smbg
        .answered_basals
        .iter()
        .map(|(e, _)| e.at.day_index())
        .collect();
    assert_eq!(days, vec![1, 2, 3]);
    let (cgm, _) = run(ScenarioId::S1, 4);
    let closes: Vec<Timestamp> = cgm.answered_basals.iter().map(|(e, _)| e.at).collect();
    // D3 00:00 closes D2, the first day the advisor saw; D4 00:00 closes D3.
    assert_eq!(
        closes,
        vec![
            Timestamp::from_day_and_minute(2, 0),
            Timestamp::from_day_and_minute(3, 0)
        ]
    );
}

#[test]
fn within_a_minute_readings_come_before_announcements_and_boluses_before_closing() {
    let (advisor, _) = run(ScenarioId::S2, 4);
    let rank = |k: &EventKind| match k {
        EventKind::Cgm(_) | EventKind::Smbg(_) => 0,
        EventKind::MealAnnounced { .. } => 1,
        EventKind::Bolus(_) => 2,
        EventKind::DayClosed => 3,
        EventKind::BasalRate(_) => 4,
        _ => 5,
    };
    for w in advisor.seen.windows(2) {
        if w[0].at == w[1].at {
            assert!(rank(&w[0].kind) <= rank(&w[1].kind), "{w:?}");
        }
    }
}

#[test]
fn skipped_meals_are_neither_announced_nor_eaten() {
    let mut scenario = ScenarioConfig::paper(ScenarioId::S4);
    scenario.days = 14;
    let gen = abba_sim::scenario::ScenarioGenerator::new(scenario.clone(), 7, 1).unwrap();
    let skipped: Vec<Timestamp> = gen
        .all_days()
        .iter()
        .skip(1)
        .flat_map(|d| {
            d.meals
                .iter()
                .filter(|m| m.skipped)
                .map(|m| m.at)
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(!skipped.is_empty());
    let (advisor, trace) = run(ScenarioId::S4, 14);
    let minutes = trace.minutes.unwrap();
    for at in skipped {
        assert!(
            !advisor
                .seen
                .iter()
                .any(|e| e.at == at && matches!(e.kind, EventKind::MealAnnounced { .. })),
            "announced a skipped meal at {at}"
        );
        let m = minutes.iter().find(|r| r.minute == at.0).unwrap();
        assert_eq!(m.cho_g_per_min, 0.0, "ate at a skipped meal's time {at}");
    }
}
