//! `RunToRun`: integral (run-to-run) adaptation of the basal rate and the
//! three carb ratios (spec §10.2). Gains and references are tuned stand-ins
//! (\[GUESS]), not the published controllers of Palerm, Zisser, Owens or
//! Herrero, whose full texts were not available.
//!
//! Each update is u_{k+1} = u_k·(1 + K·e_k/G_ref), capped, with a hypo
//! override, once per day per parameter, at the same decision points and
//! with the same initialisation week as ABBA.

use crate::config::{check_limits_and_log, parse_checked, EventLimits, Mode};
use crate::decision::{Decision, DecisionDetail, DecisionLog, R2rExplanation, SkipReason};
use crate::error::{check_count, check_positive, check_range, config_err, AdvisorError};
use crate::guard::{closed_day, EventGuard};
use crate::parameter::Parameter;
use crate::windows::{DayWindows, MealWindows};
use crate::ArmKind;
use abba_core::{
    Event, EventKind, GramsPerUnit, MealSlot, TherapySettings, Timestamp, UnitsPerHour,
};
use serde::{Deserialize, Serialize};

/// Run-to-run knobs; defaults are spec §10.2's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct R2rConfig {
    /// SMBG or CGM measurements.
    pub mode: Mode,
    /// Days under the starting therapy before adapting (as ABBA). 7.
    pub init_days: u32,
    /// Basal gain K_B. \[GUESS; calibrated] 0.1: chosen by `abba calibrate`
    /// (coordinate search over {0.1, 0.2, 0.3, 0.5} on 60 generated adults of
    /// cohort seed 101, S1 and S2; BENCHMARKS.md "ABBA's defaults:
    /// calibration"). Earlier tuned to 0.2 by `benches/r2r_gains.py`; the
    /// spec's starting value was 0.3.
    pub basal_gain: f64,
    /// Basal reference G_ref (mg/dL). \[GUESS] 110.
    pub basal_ref_mg_dl: f64,
    /// Cap of the basal relative change per update. \[GUESS] 0.10.
    pub basal_cap: f64,
    /// Basal factor when glucose < `hypo_mg_dl` in the night window. \[GUESS] 0.9.
    pub basal_hypo_factor: f64,
    /// Night window for the basal hypo override, minutes after 00:00: [start, end). \[GUESS] 0-420.
    pub night_window_min: [i64; 2],
    /// CGM mode: fasting window for the basal error, minutes after 00:00. \[GUESS] 180-390 (03:00-06:30).
    pub cgm_fasting_window_min: [i64; 2],
    /// SMBG mode: the fasting reading is the last SMBG in this window before the day's first
    /// main-meal announcement. \[GUESS] 240-600 (04:00-10:00).
    pub smbg_fasting_window_min: [i64; 2],
    /// Carb-ratio gain K_C (on I:C = 1/CIR). \[GUESS; calibrated] 0.05 (see
    /// `basal_gain`; grid {0.05, 0.1, 0.2, 0.25}; the spec's starting value
    /// was 0.25).
    pub cir_gain: f64,
    /// Post-meal reference G_ref (mg/dL). \[GUESS] 120.
    pub cir_ref_mg_dl: f64,
    /// Cap of the I:C relative change per update. \[GUESS] 0.10.
    pub cir_cap: f64,
    /// Carb-ratio factor on a hypo in the window. \[GUESS] 1.1.
    pub cir_hypo_factor: f64,
    /// CGM mode: post-meal window after the announcement (min), inclusive. \[GUESS] 90-180.
    pub cgm_post_meal_window_min: [i64; 2],
    /// CGM mode: override when time below `hypo_mg_dl` in the window exceeds this (min). \[GUESS] 15.
    pub cgm_hypo_minutes: f64,
    /// CGM sampling interval used to turn counts into time (min). 5.
    pub cgm_interval_min: f64,
    /// Hypoglycaemia threshold of the overrides (mg/dL). 70.
    pub hypo_mg_dl: f64,
    /// Event plausibility limits.
    pub limits: EventLimits,
    /// Most decisions kept before the oldest are dropped. 4096.
    pub decision_log_capacity: usize,
}

impl R2rConfig {
    /// The spec's defaults in `mode`.
    pub fn new(mode: Mode) -> Self {
        Self {
            mode,
            init_days: 7,
            basal_gain: 0.1,
            basal_ref_mg_dl: 110.0,
            basal_cap: 0.10,
            basal_hypo_factor: 0.9,
            night_window_min: [0, 420],
            cgm_fasting_window_min: [180, 390],
            smbg_fasting_window_min: [240, 600],
            cir_gain: 0.05,
            cir_ref_mg_dl: 120.0,
            cir_cap: 0.10,
            cir_hypo_factor: 1.1,
            cgm_post_meal_window_min: [90, 180],
            cgm_hypo_minutes: 15.0,
            cgm_interval_min: 5.0,
            hypo_mg_dl: 70.0,
            limits: EventLimits::default(),
            decision_log_capacity: 4096,
        }
    }

    /// Parses a JSON configuration and validates it.
    pub fn from_json(json: &str) -> Result<Self, AdvisorError> {
        parse_checked(json, Self::validate)
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        check_count("init_days", self.init_days, 1, 60)?;
        check_range("basal_gain", self.basal_gain, 0.0, 10.0)?;
        check_positive("basal_ref_mg_dl", self.basal_ref_mg_dl)?;
        check_range("basal_cap", self.basal_cap, 0.0, 0.5)?;
        check_range("basal_hypo_factor", self.basal_hypo_factor, 0.5, 1.0)?;
        check_range("cir_gain", self.cir_gain, 0.0, 10.0)?;
        check_positive("cir_ref_mg_dl", self.cir_ref_mg_dl)?;
        check_range("cir_cap", self.cir_cap, 0.0, 0.5)?;
        check_range("cir_hypo_factor", self.cir_hypo_factor, 1.0, 2.0)?;
        check_range("cgm_hypo_minutes", self.cgm_hypo_minutes, 0.0, 1440.0)?;
        check_positive("cgm_interval_min", self.cgm_interval_min)?;
        check_positive("hypo_mg_dl", self.hypo_mg_dl)?;
        for (name, w, max) in [
            ("night_window_min", self.night_window_min, 1440),
            ("cgm_fasting_window_min", self.cgm_fasting_window_min, 1440),
            (
                "smbg_fasting_window_min",
                self.smbg_fasting_window_min,
                1440,
            ),
            (
                "cgm_post_meal_window_min",
                self.cgm_post_meal_window_min,
                2880,
            ),
        ] {
            if !(0 <= w[0] && w[0] < w[1] && w[1] <= max) {
                return Err(config_err(
                    name,
                    format!("must be [start, end] with 0 <= start < end <= {max}, got {w:?}"),
                ));
            }
        }
        check_limits_and_log(&self.limits, self.decision_log_capacity)
    }
}

/// Per-day accumulator of the basal law.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
struct DayAcc {
    fasting_smbg: Option<f64>,
    main_meal_seen: bool,
    fasting_cgm_sum: f64,
    fasting_cgm_n: u32,
    night_min: Option<f64>,
}

/// Per-meal-window accumulator of the carb-ratio law.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
struct MealAcc {
    first_reading: Option<f64>,
    post_sum: f64,
    post_n: u32,
    below: u32,
}

/// The run-to-run advisor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunToRun {
    config: R2rConfig,
    settings: TherapySettings,
    guard: EventGuard,
    initialised: bool,
    days: DayWindows<DayAcc>,
    meals: MealWindows<MealAcc>,
    log: DecisionLog,
}

fn in_window(minute: i64, w: [i64; 2]) -> bool {
    minute >= w[0] && minute < w[1]
}

impl RunToRun {
    /// A run-to-run advisor starting from `start`.
    pub fn new(config: R2rConfig, start: TherapySettings) -> Result<Self, AdvisorError> {
        config.validate()?;
        start.validate().map_err(|e| AdvisorError::Config {
            field: "start settings".into(),
            problem: e.to_string(),
        })?;
        Ok(Self {
            log: DecisionLog::new(config.decision_log_capacity),
            config,
            settings: start,
            guard: EventGuard::default(),
            initialised: false,
            days: DayWindows::default(),
            meals: MealWindows::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &R2rConfig {
        &self.config
    }

    /// The whole state as JSON, in the versioned envelope of [`crate::state`].
    pub fn save_json(&self) -> Result<String, AdvisorError> {
        crate::state::save(ArmKind::R2r, self)
    }

    /// Restores a state saved with [`RunToRun::save_json`], re-validating it.
    pub fn load_json(json: &str) -> Result<Self, AdvisorError> {
        let a: Self = crate::state::load(ArmKind::R2r, json)?;
        a.check_state()?;
        Ok(a)
    }

    /// Re-validates a deserialised state.
    pub(crate) fn check_state(&self) -> Result<(), AdvisorError> {
        self.config.validate()?;
        self.settings
            .validate()
            .map_err(|e| AdvisorError::State(format!("settings: {e}")))
    }

    fn reading(&mut self, at: Timestamp, g: f64) {
        let c = &self.config;
        let minute = at.minute_of_day();
        let day = self.days.day_mut(at.day_index());
        if in_window(minute, c.night_window_min) {
            day.night_min = Some(day.night_min.map_or(g, |m: f64| m.min(g)));
        }
        match c.mode {
            Mode::Smbg => {
                if in_window(minute, c.smbg_fasting_window_min) && !day.main_meal_seen {
                    day.fasting_smbg = Some(g);
                }
            }
            Mode::Cgm => {
                if in_window(minute, c.cgm_fasting_window_min) {
                    day.fasting_cgm_sum += g;
                    day.fasting_cgm_n += 1;
                }
            }
        }
        if let Some((start, acc)) = self.meals.open_mut() {
            if acc.first_reading.is_none() {
                acc.first_reading = Some(g);
            }
            let since = at.minutes() - start.minutes();
            let w = c.cgm_post_meal_window_min;
            if since >= w[0] && since <= w[1] {
                acc.post_sum += g;
                acc.post_n += 1;
            }
            if g < c.hypo_mg_dl {
                acc.below += 1;
            }
        }
    }

    fn record(&mut self, at: Timestamp, p: Parameter, old: f64, new: f64, detail: DecisionDetail) {
        self.log.push(Decision {
            at,
            parameter: p,
            old,
            new,
            detail,
        });
    }

    fn basal_update(&mut self, at: Timestamp, acc: Option<DayAcc>) {
        let c = &self.config;
        let old = self.settings.basal.0;
        let p = Parameter::Basal;
        let Some(acc) = acc else {
            let d = DecisionDetail::Skipped {
                reason: SkipReason::NoDayData,
            };
            return self.record(at, p, old, old, d);
        };
        let measure = match c.mode {
            Mode::Smbg => acc.fasting_smbg,
            Mode::Cgm => {
                (acc.fasting_cgm_n > 0).then(|| acc.fasting_cgm_sum / f64::from(acc.fasting_cgm_n))
            }
        };
        let hypo = acc.night_min.is_some_and(|m| m < c.hypo_mg_dl);
        let (new, expl) = if hypo {
            (
                old * c.basal_hypo_factor,
                R2rExplanation {
                    measure_mg_dl: measure,
                    reference_mg_dl: c.basal_ref_mg_dl,
                    raw_relative_change: c.basal_hypo_factor - 1.0,
                    capped: false,
                    hypo_override: true,
                },
            )
        } else if let Some(y) = measure {
            let (rel, expl) = integral_step(c.basal_gain, y, c.basal_ref_mg_dl, c.basal_cap);
            (old * (1.0 + rel), expl)
        } else {
            let d = DecisionDetail::Skipped {
                reason: SkipReason::NoFastingGlucose,
            };
            return self.record(at, p, old, old, d);
        };
        self.settings.basal = UnitsPerHour(new);
        self.record(at, p, old, new, DecisionDetail::RunToRun(expl));
    }

    fn cir_update(&mut self, at: Timestamp, i: usize, acc: Option<MealAcc>) {
        let c = &self.config;
        let old = self.settings.carb_ratio[i].0;
        let p = Parameter::CarbRatio(MealSlot::MAIN[i]);
        let Some(acc) = acc else {
            let d = DecisionDetail::Skipped {
                reason: SkipReason::NoPreviousDayWindow,
            };
            return self.record(at, p, old, old, d);
        };
        let measure = match c.mode {
            Mode::Smbg => acc.first_reading,
            Mode::Cgm => (acc.post_n > 0).then(|| acc.post_sum / f64::from(acc.post_n)),
        };
        let hypo = match c.mode {
            Mode::Smbg => acc.below > 0,
            Mode::Cgm => f64::from(acc.below) * c.cgm_interval_min > c.cgm_hypo_minutes,
        };
        let (new, expl) = if hypo {
            (
                old * c.cir_hypo_factor,
                R2rExplanation {
                    measure_mg_dl: measure,
                    reference_mg_dl: c.cir_ref_mg_dl,
                    raw_relative_change: 1.0 / c.cir_hypo_factor - 1.0,
                    capped: false,
                    hypo_override: true,
                },
            )
        } else if let Some(y) = measure {
            // Integral law on I:C = 1/CIR: IC_{k+1} = IC_k·(1 + K_C·e/G_ref).
            let (rel, expl) = integral_step(c.cir_gain, y, c.cir_ref_mg_dl, c.cir_cap);
            (old / (1.0 + rel), expl)
        } else {
            let d = DecisionDetail::Skipped {
                reason: SkipReason::NoPostMealGlucose,
            };
            return self.record(at, p, old, old, d);
        };
        self.settings.carb_ratio[i] = GramsPerUnit(new);
        self.record(at, p, old, new, DecisionDetail::RunToRun(expl));
    }

    /// One checked event ([`crate::adapting`]); run-to-run's handling
    /// cannot fail.
    fn step(&mut self, e: &Event) -> Result<Option<TherapySettings>, AdvisorError> {
        Ok(self.process(e))
    }

    fn process(&mut self, e: &Event) -> Option<TherapySettings> {
        match e.kind {
            EventKind::Cgm(g) if self.config.mode == Mode::Cgm => {
                self.reading(e.at, g.0);
                None
            }
            EventKind::Smbg(g) if self.config.mode == Mode::Smbg => {
                self.reading(e.at, g.0);
                None
            }
            EventKind::MealAnnounced { slot, .. } => {
                let i = slot.main_index()?;
                self.days.day_mut(e.at.day_index()).main_meal_seen = true;
                let prev = self.meals.announce(i, e.at);
                if !self.initialised {
                    return None;
                }
                self.cir_update(e.at, i, prev.map(|w| w.acc));
                Some(self.settings)
            }
            EventKind::DayClosed => {
                let day = closed_day(e.at);
                let acc = self.days.close(day);
                if !self.initialised {
                    let first = self.guard.first_day().unwrap_or(day);
                    if day < first + i64::from(self.config.init_days) - 1 {
                        return None;
                    }
                    self.initialised = true;
                }
                self.basal_update(e.at, acc);
                Some(self.settings)
            }
            // The person's answer: the next update starts from the value in force.
            EventKind::SuggestionAccepted(v)
            | EventKind::SuggestionRejected(v)
            | EventKind::SuggestionOverridden(v) => {
                v.put_in_force(&mut self.settings);
                None
            }
            _ => None,
        }
    }
}

/// The run-to-run integral law shared by basal and carb ratio (spec
/// §10.2): the relative change K·(y − G_ref)/G_ref, capped at ±`cap`, with
/// its explanation.
fn integral_step(gain: f64, y: f64, reference: f64, cap: f64) -> (f64, R2rExplanation) {
    let raw = gain * (y - reference) / reference;
    let rel = raw.clamp(-cap, cap);
    let expl = R2rExplanation {
        measure_mg_dl: Some(y),
        reference_mg_dl: reference,
        raw_relative_change: raw,
        capped: rel != raw,
        hypo_override: false,
    };
    (rel, expl)
}

crate::adapting::advisor!(RunToRun, ArmKind::R2r);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Advisor;
    use abba_core::{Grams, MgDl};

    fn start() -> TherapySettings {
        TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap()
    }

    fn t(day: i64, min: i64) -> Timestamp {
        Timestamp::from_day_and_minute(day, min)
    }

    fn meal(at: Timestamp, slot: MealSlot) -> Event {
        Event::new(
            at,
            EventKind::MealAnnounced {
                carbs: Grams(50.0),
                slot,
            },
        )
    }

    fn close(name: &str, exp: f64, got: f64) {
        assert!(
            (exp - got).abs() < 1e-12,
            "{name}: expected {exp}, got {got}"
        );
    }

    #[test]
    fn config_validation_names_the_field() {
        R2rConfig::new(Mode::Cgm).validate().unwrap();
        let mut c = R2rConfig::new(Mode::Cgm);
        c.basal_cap = 0.9;
        assert!(c.validate().unwrap_err().to_string().contains("basal_cap"));
        let mut c = R2rConfig::new(Mode::Cgm);
        c.night_window_min = [400, 300];
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("night_window_min"));
        let json = serde_json::to_string(&R2rConfig::new(Mode::Smbg)).unwrap();
        assert_eq!(
            R2rConfig::from_json(&json).unwrap(),
            R2rConfig::new(Mode::Smbg)
        );
    }

    #[test]
    fn smbg_basal_and_carb_ratio_laws() {
        let mut cfg = R2rConfig::new(Mode::Smbg);
        cfg.init_days = 1;
        // The spec's starting gains, for hand-computed numbers.
        cfg.basal_gain = 0.3;
        cfg.cir_gain = 0.25;
        let mut r = RunToRun::new(cfg, start()).unwrap();
        // Day 1 (index 1): fasting 160, breakfast, post-breakfast (pre-lunch) 180.
        r.observe(&Event::new(t(1, 400), EventKind::Smbg(MgDl(160.0))))
            .unwrap();
        assert_eq!(
            r.observe(&meal(t(1, 420), MealSlot::Breakfast)).unwrap(),
            None
        );
        r.observe(&Event::new(t(1, 700), EventKind::Smbg(MgDl(180.0))))
            .unwrap();
        r.observe(&meal(t(1, 720), MealSlot::Lunch)).unwrap();
        r.observe(&Event::new(t(1, 1090), EventKind::Smbg(MgDl(100.0))))
            .unwrap();
        r.observe(&meal(t(1, 1110), MealSlot::Dinner)).unwrap();
        r.observe(&Event::new(t(1, 1380), EventKind::Smbg(MgDl(65.0))))
            .unwrap();
        // Day closes: e = 160 − 110 = 50 -> 0.3*50/110 = 0.13636 -> capped at +10 %.
        let s = r
            .observe(&Event::new(t(1, 1381), EventKind::DayClosed))
            .unwrap()
            .unwrap();
        close("basal +10 % cap", 1.1, s.basal.0);
        // Breakfast of day 2: window held 180 -> e = 60 -> IC +0.125 -> capped 0.10 -> CIR = 10/1.1.
        let s = r
            .observe(&meal(t(2, 420), MealSlot::Breakfast))
            .unwrap()
            .unwrap();
        close("CIR1", 10.0 / 1.1, s.carb_ratio[0].0);
        // Lunch: window held 100 -> e = −20 -> IC −0.041667 -> CIR = 10/(1 − 0.041667).
        let s = r
            .observe(&meal(t(2, 720), MealSlot::Lunch))
            .unwrap()
            .unwrap();
        close(
            "CIR2",
            10.0 / (1.0 - 0.25 * 20.0 / 120.0),
            s.carb_ratio[1].0,
        );
        // Dinner: window held 65 < 70 -> hypo override ×1.1 (less insulin).
        let s = r
            .observe(&meal(t(2, 1110), MealSlot::Dinner))
            .unwrap()
            .unwrap();
        close("CIR3 override", 11.0, s.carb_ratio[2].0);
        assert_eq!(r.decisions().len(), 4);
        assert!(r.decisions()[3].to_string().contains("hypo override"));
    }

    #[test]
    fn cgm_carb_ratio_uses_post_meal_mean_and_time_below_70() {
        let mut cfg = R2rConfig::new(Mode::Cgm);
        // The spec's starting gains, for hand-computed numbers.
        cfg.basal_gain = 0.3;
        cfg.cir_gain = 0.25;
        cfg.init_days = 1;
        let mut r = RunToRun::new(cfg, start()).unwrap();
        r.observe(&meal(t(1, 420), MealSlot::Breakfast)).unwrap();
        r.observe(&meal(t(1, 720), MealSlot::Lunch)).unwrap();
        for m in (720..1110).step_by(5) {
            // lunch window: 3 samples below 70 (15 min, not > 15) then high
            let g = if m < 735 {
                65.0
            } else if (810..=900).contains(&m) {
                168.0
            } else {
                140.0
            };
            r.observe(&Event::new(t(1, m), EventKind::Cgm(MgDl(g))))
                .unwrap();
        }
        r.observe(&meal(t(1, 1110), MealSlot::Dinner)).unwrap();
        for m in (1110..1440).step_by(5) {
            // dinner window: 4 samples below 70 = 20 min > 15 -> override
            let g = if m < 1130 { 60.0 } else { 200.0 };
            r.observe(&Event::new(t(1, m), EventKind::Cgm(MgDl(g))))
                .unwrap();
        }
        r.observe(&Event::new(t(2, 0), EventKind::DayClosed))
            .unwrap();
        // Lunch of day 2: post-meal mean over [+90, +180] min = 168 -> e = 48 -> +10 % (capped).
        let s = r
            .observe(&meal(t(2, 720), MealSlot::Lunch))
            .unwrap()
            .unwrap();
        close("CIR2 from post-meal mean", 10.0 / 1.1, s.carb_ratio[1].0);
        let s = r
            .observe(&meal(t(2, 1110), MealSlot::Dinner))
            .unwrap()
            .unwrap();
        close("CIR3 time-below override", 11.0, s.carb_ratio[2].0);
        // Breakfast of day 2 was never announced: no breakfast decision at all;
        // the lunch decision is the first carb-ratio decision.
        assert!(r
            .decisions()
            .iter()
            .all(|d| d.parameter != Parameter::CarbRatio(MealSlot::Breakfast)));
    }

    #[test]
    fn cgm_basal_uses_night_mean_and_hypo_override() {
        let mut cfg = R2rConfig::new(Mode::Cgm);
        // The spec's starting gains, for hand-computed numbers.
        cfg.basal_gain = 0.3;
        cfg.cir_gain = 0.25;
        cfg.init_days = 1;
        let mut r = RunToRun::new(cfg.clone(), start()).unwrap();
        for m in (0..1440).step_by(5) {
            let g = if (180..390).contains(&m) { 99.0 } else { 200.0 };
            r.observe(&Event::new(t(1, m), EventKind::Cgm(MgDl(g))))
                .unwrap();
        }
        // e = 99 − 110 = −11 -> −0.03
        let s = r
            .observe(&Event::new(t(2, 0), EventKind::DayClosed))
            .unwrap()
            .unwrap();
        close("basal", 0.97, s.basal.0);
        let mut r = RunToRun::new(cfg, start()).unwrap();
        for m in (0..1440).step_by(5) {
            let g = if m == 60 { 60.0 } else { 200.0 };
            r.observe(&Event::new(t(1, m), EventKind::Cgm(MgDl(g))))
                .unwrap();
        }
        let s = r
            .observe(&Event::new(t(2, 0), EventKind::DayClosed))
            .unwrap()
            .unwrap();
        close("night hypo override", 0.9, s.basal.0);
    }
}
