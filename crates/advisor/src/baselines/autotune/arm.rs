//! The `autotune` arm: oref0's autotune run every night over the previous
//! day's CGM and pump data, its result put in force as the trial's
//! therapy (one flat basal, three carb ratios).
//!
//! - The profile autotune tunes is the therapy in force: its flat basal as a
//!   one-entry `basalprofile`, its one carb ratio, and the ISF tuned so far;
//!   the pump profile (the caps' reference) is the standard therapy.
//! - One carb ratio from three: the pump's is the mean of the standard
//!   therapy's three; the tuned ratio scales all three by tuned / pump, so
//!   the standard's meal-to-meal shape stays.
//! - One flat basal from 24 hourly ones: their mean (the same daily basal
//!   insulin).
//! - ISF: the trial's scenarios have no correction boluses, so the ISF only
//!   scales insulin's glucose impact in the categorisation. It starts from
//!   the 1800 rule on the first closed day's total insulin
//!   (`isf_rule_mg_dl` / TDI), within abba_core's ISF limits, and is tuned
//!   as oref0 tunes it.
//! - The day: at each `DayClosed`, the CGM of the 24 hours before it and
//!   insulin and carbs of the 42 hours before it (oref0's day runs 04:00 to
//!   04:00; the trial closes days at midnight). Delivered basal is the rate
//!   in force, so no temporary basals (the profile's rate is delivered).
//! - On the same days as the other arms: the standard therapy for the
//!   first `init_days` closed days; at the close of the last of them
//!   autotune runs over each of those days in turn (as `oref0-autotune
//!   --start-days-ago=7` does), and from then on nightly over the day just
//!   closed. A day with fewer than `min_readings` CGM readings is not tuned
//!   (in SMBG scenarios the CGM stops after the first week, so the
//!   first-week result stays).

use super::{autotune_day, Carbs, DayData, Insulin, Profile, Reading, UtcClock};
use crate::config::{check_limits_and_log, EventLimits, Mode};
use crate::decision::{Decision, DecisionDetail, DecisionLog, SkipReason};
use crate::error::{check_count, check_positive, check_range, config_err, AdvisorError};
use crate::guard::EventGuard;
use crate::parameter::Parameter;
use crate::ArmKind;
use abba_core::limits::ISF_MG_DL_PER_U;
use abba_core::{
    Event, EventKind, GramsPerUnit, MealSlot, TherapySettings, Timestamp, UnitsPerHour,
};
use serde::{Deserialize, Serialize};

/// The autotune arm's knobs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AutotuneConfig {
    /// Which measurements the scenario has (only the day-closing rule depends on it).
    pub mode: Mode,
    /// Closed days of standard therapy before the first run (the trial's 7).
    pub init_days: u32,
    /// The 1800 rule's constant (mg/dL): ISF = it / total daily insulin. 1800.
    pub isf_rule_mg_dl: f64,
    /// Duration of insulin action (h) of the rapid-acting curve. 5 (oref0's
    /// minimum for exponential curves).
    pub dia_h: f64,
    /// `autosens_max`: the caps' upper factor. 1.2 (oref0's default).
    pub autosens_max: f64,
    /// `autosens_min`: the caps' lower factor. 0.7 (oref0's default).
    pub autosens_min: f64,
    /// Fewest CGM readings in the day for a tuning run. 144 (half a day).
    pub min_readings: u32,
    /// Event plausibility limits.
    pub limits: EventLimits,
    /// Most decisions kept before the oldest are dropped. 4096.
    pub decision_log_capacity: usize,
}

impl AutotuneConfig {
    /// oref0's defaults in `mode`.
    pub fn new(mode: Mode) -> Self {
        Self {
            mode,
            init_days: 7,
            isf_rule_mg_dl: 1800.0,
            dia_h: 5.0,
            autosens_max: 1.2,
            autosens_min: 0.7,
            min_readings: 144,
            limits: EventLimits::default(),
            decision_log_capacity: 4096,
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        check_count("init_days", self.init_days, 1, 60)?;
        check_positive("isf_rule_mg_dl", self.isf_rule_mg_dl)?;
        check_range("dia_h", self.dia_h, 3.0, 12.0)?;
        check_range("autosens_max", self.autosens_max, 1.0, 3.0)?;
        check_range("autosens_min", self.autosens_min, 0.1, 1.0)?;
        if self.min_readings > 288 {
            return Err(config_err(
                "min_readings",
                format!(
                    "must be at most 288 (a day of 5-min readings), got {}",
                    self.min_readings
                ),
            ));
        }
        check_limits_and_log(&self.limits, self.decision_log_capacity)
    }
}

/// What one nightly run found (the decision's explanation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AutotuneExplanation {
    /// 5-min data sorted into basal (after folding UAM data).
    pub basal_data: u32,
    /// ISF data.
    pub isf_data: u32,
    /// Carb-absorption data.
    pub csf_data: u32,
    /// Unannounced-meal data (before folding).
    pub uam_data: u32,
    /// Carb-ratio periods.
    pub cr_periods: u32,
    /// The 24 tuned hourly basals (U/h), whose mean is the new flat basal.
    pub hourly_basal: Vec<f64>,
    /// ISF after the run (mg/dL/U).
    pub isf: f64,
    /// The one carb ratio after the run (g/U).
    pub carb_ratio: f64,
}

/// The autotune advisor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Autotune {
    config: AutotuneConfig,
    standard: TherapySettings,
    settings: TherapySettings,
    /// ISF tuned so far (None before the first closed day).
    isf: Option<f64>,
    /// The first ISF estimate (the pump profile's ISF, the caps' reference).
    isf_start: Option<f64>,
    /// The one carb ratio in force (the three are the standard's × it / pump's).
    carb_ratio: f64,
    guard: EventGuard,
    glucose: Vec<(i64, f64)>,
    boluses: Vec<(i64, f64)>,
    carbs: Vec<(i64, f64)>,
    /// Minutes of the days closed so far while initialising (emptied by
    /// the first run).
    closes: Vec<i64>,
    /// True once the first run has been made.
    initialised: bool,
    log: DecisionLog,
}

fn mean3(c: &[GramsPerUnit; 3]) -> f64 {
    (c[0].0 + c[1].0 + c[2].0) / 3.0
}

const KEEP_MIN: i64 = 42 * 60;

impl Autotune {
    /// An autotune advisor whose pump profile is `standard`.
    pub fn new(config: AutotuneConfig, standard: TherapySettings) -> Result<Self, AdvisorError> {
        config.validate()?;
        standard.validate().map_err(|e| AdvisorError::Config {
            field: "start settings".into(),
            problem: e.to_string(),
        })?;
        Ok(Self {
            log: DecisionLog::new(config.decision_log_capacity),
            config,
            standard,
            settings: standard,
            isf: None,
            isf_start: None,
            carb_ratio: mean3(&standard.carb_ratio),
            guard: EventGuard::default(),
            glucose: Vec::new(),
            boluses: Vec::new(),
            carbs: Vec::new(),
            closes: Vec::new(),
            initialised: false,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &AutotuneConfig {
        &self.config
    }

    /// The ISF tuned so far.
    pub fn isf(&self) -> Option<f64> {
        self.isf
    }

    /// The whole state as JSON, in the versioned envelope of [`crate::state`].
    pub fn save_json(&self) -> Result<String, AdvisorError> {
        crate::state::save(ArmKind::Autotune, self)
    }

    /// Restores a state saved with [`Autotune::save_json`], re-validating it.
    pub fn load_json(json: &str) -> Result<Self, AdvisorError> {
        let a: Self = crate::state::load(ArmKind::Autotune, json)?;
        a.config.validate()?;
        a.settings
            .validate()
            .map_err(|e| AdvisorError::State(format!("settings: {e}")))?;
        Ok(a)
    }

    fn profile(&self, basal: f64, isf: f64, cr: f64) -> Result<Profile, AdvisorError> {
        let mut p = Profile::flat(basal, isf, cr, self.config.dia_h)
            .map_err(|e| AdvisorError::State(format!("autotune profile: {e}")))?;
        p.autosens_max = self.config.autosens_max;
        p.autosens_min = self.config.autosens_min;
        Ok(p)
    }

    fn skip(&mut self, at: Timestamp, reason: SkipReason) {
        let old = self.settings.basal.0;
        self.log.push(Decision {
            at,
            parameter: Parameter::Basal,
            old,
            new: old,
            detail: DecisionDetail::Skipped { reason },
        });
    }

    /// The run over the day closed at minute `end`, with the data known
    /// then; its decisions are logged at `at` (now).
    fn night(&mut self, end: i64, at: Timestamp) -> Result<(), AdvisorError> {
        let start = end - 1440;
        let ms = |m: i64| m * 60_000;
        let glucose: Vec<Reading> = self
            .glucose
            .iter()
            .filter(|g| g.0 >= start && g.0 < end)
            .map(|&(m, g)| Reading {
                at_ms: ms(m),
                mg_dl: g,
            })
            .collect();
        let isf = match self.isf {
            Some(i) => i,
            None => {
                let bolus: f64 = self
                    .boluses
                    .iter()
                    .filter(|b| b.0 >= start && b.0 < end)
                    .map(|b| b.1)
                    .sum();
                let tdi = bolus + 24.0 * self.settings.basal.0;
                let isf = (self.config.isf_rule_mg_dl / tdi)
                    .clamp(ISF_MG_DL_PER_U.min, ISF_MG_DL_PER_U.max);
                self.isf = Some(isf);
                self.isf_start = Some(isf);
                isf
            }
        };
        if glucose.len() < self.config.min_readings as usize {
            self.skip(
                at,
                SkipReason::TooFewReadings {
                    n: glucose.len() as u32,
                    required: self.config.min_readings,
                },
            );
            return Ok(());
        }
        let pump_cr = mean3(&self.standard.carb_ratio);
        let pump_isf = self.isf_start.unwrap_or(isf);
        let pump = self.profile(self.standard.basal.0, pump_isf, pump_cr)?;
        let previous = self.profile(self.settings.basal.0, isf, self.carb_ratio)?;
        let day = DayData {
            glucose,
            insulin: self
                .boluses
                .iter()
                .filter(|b| b.0 <= end)
                .map(|&(m, u)| Insulin::Bolus {
                    at_ms: ms(m),
                    units: u,
                })
                .collect(),
            carbs: self
                .carbs
                .iter()
                .filter(|c| c.0 <= end)
                .map(|&(m, g)| Carbs {
                    at_ms: ms(m),
                    grams: g,
                    stamp_ms: None,
                })
                .collect(),
        };
        let (prepped, tuned, _) = autotune_day(&day, &previous, &pump, &UtcClock)
            .map_err(|e| AdvisorError::State(format!("autotune: {e}")))?;
        let hourly: Vec<f64> = tuned.basal.iter().map(|e| e.rate).collect();
        let basal = hourly.iter().sum::<f64>() / 24.0;
        self.isf = Some(tuned.isf);
        self.carb_ratio = tuned.carb_ratio;
        let factor = tuned.carb_ratio / pump_cr;
        let expl = AutotuneExplanation {
            basal_data: prepped.basal.len() as u32,
            isf_data: prepped.isf.len() as u32,
            csf_data: prepped.csf.len() as u32,
            uam_data: prepped.uam.len() as u32,
            cr_periods: prepped.cr.len() as u32,
            hourly_basal: hourly,
            isf: tuned.isf,
            carb_ratio: tuned.carb_ratio,
        };
        let old = self.settings;
        self.settings.basal = UnitsPerHour(basal);
        for i in 0..3 {
            self.settings.carb_ratio[i] = GramsPerUnit(self.standard.carb_ratio[i].0 * factor);
        }
        self.log.push(Decision {
            at,
            parameter: Parameter::Basal,
            old: old.basal.0,
            new: basal,
            detail: DecisionDetail::Autotune(Box::new(expl.clone())),
        });
        for (i, slot) in MealSlot::MAIN.iter().enumerate() {
            self.log.push(Decision {
                at,
                parameter: Parameter::CarbRatio(*slot),
                old: old.carb_ratio[i].0,
                new: self.settings.carb_ratio[i].0,
                detail: DecisionDetail::Autotune(Box::new(expl.clone())),
            });
        }
        Ok(())
    }

    /// One checked event ([`crate::adapting`]): only a night can fail (an
    /// internal error), and it is then undone whole.
    fn step(&mut self, e: &Event) -> Result<Option<TherapySettings>, AdvisorError> {
        let before = matches!(e.kind, EventKind::DayClosed).then(|| self.clone());
        let out = self.process(e);
        if let (Err(_), Some(b)) = (&out, before) {
            *self = b;
        }
        out
    }

    fn process(&mut self, e: &Event) -> Result<Option<TherapySettings>, AdvisorError> {
        let m = e.at.minutes();
        match e.kind {
            EventKind::Cgm(g) => self.glucose.push((m, g.0)),
            EventKind::Bolus(u) => self.boluses.push((m, u.0)),
            EventKind::MealAnnounced { carbs, .. } => self.carbs.push((m, carbs.0)),
            EventKind::DayClosed => {
                if self.initialised {
                    self.night(m, e.at)?;
                } else {
                    self.closes.push(m);
                    if self.closes.len() < self.config.init_days as usize {
                        return Ok(None);
                    }
                    // The first week, day by day, each night in force for the next.
                    for c in std::mem::take(&mut self.closes) {
                        self.night(c, e.at)?;
                    }
                    self.initialised = true;
                }
                let keep = m - KEEP_MIN;
                self.glucose.retain(|g| g.0 >= keep);
                self.boluses.retain(|b| b.0 >= keep);
                self.carbs.retain(|c| c.0 >= keep);
                return Ok(Some(self.settings));
            }
            EventKind::SuggestionAccepted(v)
            | EventKind::SuggestionRejected(v)
            | EventKind::SuggestionOverridden(v) => v.put_in_force(&mut self.settings),
            _ => {}
        }
        Ok(None)
    }
}

crate::adapting::advisor!(Autotune, ArmKind::Autotune);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Advisor;
    use abba_core::{Grams, MgDl, Units};

    fn standard() -> TherapySettings {
        TherapySettings {
            basal: UnitsPerHour(1.0),
            carb_ratio: [GramsPerUnit(10.0), GramsPerUnit(12.0), GramsPerUnit(8.0)],
        }
    }

    /// Day `d` (0-based from D2) of CGM every 5 min, three meals of 60 g
    /// with 5 U each, glucose rising after each and back by 4 h; closed at
    /// midnight.
    fn day(d: i64, cgm: bool) -> Vec<Event> {
        let mut out = Vec::new();
        let base = (d + 1) * 1440;
        let meals = [
            (7 * 60, MealSlot::Breakfast),
            (12 * 60, MealSlot::Lunch),
            (19 * 60, MealSlot::Dinner),
        ];
        for m in (0..1440).step_by(5) {
            let t = base + m;
            for &(at, slot) in &meals {
                if m == at {
                    out.push(Event::new(
                        Timestamp(t),
                        EventKind::MealAnnounced {
                            carbs: Grams(60.0),
                            slot,
                        },
                    ));
                    out.push(Event::new(Timestamp(t), EventKind::Bolus(Units(5.0))));
                }
            }
            if cgm {
                let after = meals
                    .iter()
                    .map(|&(at, _)| m - at)
                    .filter(|x| (0..240).contains(x))
                    .map(|x| 80.0 * (std::f64::consts::PI * x as f64 / 240.0).sin())
                    .sum::<f64>();
                out.push(Event::new(
                    Timestamp(t),
                    EventKind::Cgm(MgDl(110.0 + after)),
                ));
            }
        }
        out.push(Event::new(Timestamp(base + 1440), EventKind::DayClosed));
        out
    }

    fn run(a: &mut Autotune, events: &[Event]) -> Vec<Option<TherapySettings>> {
        events.iter().map(|e| a.observe(e).unwrap()).collect()
    }

    #[test]
    fn the_first_week_is_standard_therapy_then_each_of_its_days_is_tuned() {
        let mut a = Autotune::new(AutotuneConfig::new(Mode::Cgm), standard()).unwrap();
        for d in 0..6 {
            let outs = run(&mut a, &day(d, true));
            assert!(
                outs.iter().all(Option::is_none),
                "day {d} changed something"
            );
            assert_eq!(*a.settings(), standard());
            assert!(a.decisions().is_empty());
        }
        let outs = run(&mut a, &day(6, true));
        let close = day(6, true).last().unwrap().at;
        assert_eq!(outs.last().unwrap().as_ref(), Some(a.settings()));
        // Seven nights of four decisions each, all decided at the 7th close.
        let ds = a.take_decisions();
        assert_eq!(ds.len(), 7 * 4);
        assert!(ds.iter().all(|d| d.at == close));
        // Each night starts from the previous night's values.
        let basal: Vec<&Decision> = ds
            .iter()
            .filter(|d| d.parameter == Parameter::Basal)
            .collect();
        for w in basal.windows(2) {
            assert_eq!(w[1].old, w[0].new);
        }
        // 5 U for 60 g with glucose back where it started 4 h later imply
        // 12 g/U: the one ratio (10, the standard's mean) moves toward it and
        // not past it, the three kept in the standard's proportions.
        let s = *a.settings();
        let one = s.carb_ratio[0].0; // breakfast: the standard 10 × tuned / 10
        assert!(one > 10.0 && one <= 12.0, "{s:?}");
        assert!((s.carb_ratio[1].0 / s.carb_ratio[0].0 - 1.2).abs() < 1e-9);
        assert!((s.carb_ratio[2].0 / s.carb_ratio[0].0 - 0.8).abs() < 1e-9);
        assert!(s.carb_ratio[0].0 >= 10.0 * 0.7 - 1e-9);
        assert!(s.basal.0 <= 1.2 + 1e-9 && s.basal.0 >= 0.7 - 1e-9);
        // Then nightly: one night, four decisions.
        run(&mut a, &day(7, true));
        assert_eq!(a.take_decisions().len(), 4);
    }

    #[test]
    fn a_day_without_cgm_is_not_tuned() {
        let mut cfg = AutotuneConfig::new(Mode::Smbg);
        cfg.init_days = 1;
        let mut a = Autotune::new(cfg, standard()).unwrap();
        run(&mut a, &day(0, false));
        let ds = a.take_decisions();
        assert_eq!(ds.len(), 1);
        assert!(matches!(
            ds[0].detail,
            DecisionDetail::Skipped {
                reason: SkipReason::TooFewReadings {
                    n: 0,
                    required: 144
                }
            }
        ));
        assert_eq!(*a.settings(), standard());
    }

    #[test]
    fn init_days_is_checked() {
        let mut cfg = AutotuneConfig::new(Mode::Cgm);
        cfg.init_days = 0;
        let e = Autotune::new(cfg, standard()).unwrap_err().to_string();
        assert!(e.contains("init_days"), "{e}");
    }
}
