//! The ABBA advisor: the daily timeline of spec §2 driven by device events.

use crate::agent::{Agent, AgentCounters};
use crate::bounds::ClinicianBounds;
use crate::config::{AbbaConfig, Mode};
use crate::data_rule::MinData;
use crate::decision::{
    AbbaExplanation, Decision, DecisionDetail, DecisionLog, Rounded, SkipReason,
};
use crate::error::AdvisorError;
use crate::features::{local_cost, NightStats, WindowStats};
use crate::fusion::apply_action;
use crate::guard::{closed_day, EventGuard};
use crate::parameter::Parameter;
use crate::recent_low::RecentLows;
use crate::steps::{
    mean_rate, rescale_schedule, round_change, scale_schedule, validate_segments, PumpSteps,
    Segments,
};
use crate::supervisor::{adds_insulin, supervisory, ParamKind};
use crate::te::{te_scale, theta0, transfer_entropy, TeCollector, TeEstimate};
use crate::windows::{DayWindows, MealWindows};
use crate::ArmKind;
use abba_core::{
    Event, EventKind, GramsPerUnit, MealSlot, SettingValue, TherapySettings, Timestamp,
    UnitsPerHour,
};
use serde::{Deserialize, Serialize};

/// The outcome of the TE estimation at the end of the initialisation week.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum TeOutcome {
    /// TE was estimated.
    Estimated(TeEstimate),
    /// TE could not be estimated (too little CGM data); TE_n = 1 (nominal θ0) was used.
    Failed {
        /// Why, with the counts involved.
        reason: String,
    },
}

/// What the initialisation did (spec §7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InitReport {
    /// The `DayClosed` that ended the initialisation week.
    pub at: Timestamp,
    /// The TE estimate or why there is none.
    pub te: TeOutcome,
    /// TE_n, the scale of θ0.
    pub te_n: f64,
    /// θ0 of the basal agent (hyper, hypo).
    pub theta0_basal: [f64; 2],
    /// θ0 of each carb-ratio agent (hyper, hypo).
    pub theta0_carb_ratio: [f64; 2],
}

/// The ABBA advisor (SMBG or CGM mode). See the crate documentation for the
/// event contract. The whole struct is plain data: serialise it (e.g. with
/// [`Abba::save_json`]) after any event and resume with [`Abba::load_json`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Abba {
    config: AbbaConfig,
    start: TherapySettings,
    settings: TherapySettings,
    guard: EventGuard,
    initialised: bool,
    te: Option<TeCollector>,
    init: Option<InitReport>,
    /// 0: basal; 1..=3: carb ratios of breakfast, lunch, dinner.
    agents: [Agent; 4],
    day_windows: DayWindows<WindowStats>,
    /// The readings of the basal agent's hours of each day, when its
    /// features come from part of the day
    /// (`features.cgm_basal_window_min`).
    #[serde(default, skip_serializing_if = "DayWindows::is_empty")]
    basal_windows: DayWindows<WindowStats>,
    /// The same readings split into evening and morning, when an SMBG
    /// night's fall decides the evening reading's part
    /// (`features.smbg_night_fall_mg_dl`).
    #[serde(default, skip_serializing_if = "DayWindows::is_empty")]
    nights: DayWindows<NightStats>,
    meal_windows: MealWindows<WindowStats>,
    last_br_change: Option<(f64, f64)>,
    log: DecisionLog,
    /// Clinician bounds, applied after the clamp (none by default).
    #[serde(default)]
    bounds: ClinicianBounds,
    /// Minimum data per window (none by default).
    #[serde(default)]
    min_data: Option<MinData>,
    /// The pump's steps: suggestions are rounded to them (none by default:
    /// the paper's continuous values, as in the trial).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    steps: Option<PumpSteps>,
    /// The basal schedule in force (its mean is `settings.basal`); none: a
    /// flat rate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    basal_schedule: Option<Segments>,
    /// The schedule before the last basal update (restored when the person
    /// keeps the previous value).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    prev_basal_schedule: Option<Segments>,
    /// The day index whose close ends the first week, when the caller
    /// counts qualifying days ([`Abba::with_first_week_end`]); none: the
    /// close of day `init_days` (the paper's week).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    first_week_end: Option<i64>,
    /// With pump steps: per setting (basal, breakfast, lunch, dinner), the
    /// relative change the advisor asked for and the pump's step did not
    /// yet deliver. Sub-step changes add up in it until they make a step
    /// (ABBA's daily steps are often under 1 %: rounded one by one they
    /// would never move a pump), as a continuous pump would have summed
    /// them; the part that would add insulin is dropped after a window with
    /// a low, and all of it when the value in force changes outside the
    /// advisor (an own value, a kept one, a new therapy).
    #[serde(default, skip_serializing_if = "no_carry")]
    carry: [f64; 4],
    /// SMBG mode: the readings the recent-low rules
    /// (`update.smbg_recent_low_*`) may still need.
    #[serde(default, skip_serializing_if = "RecentLows::is_empty")]
    recent_lows: RecentLows,
}

fn no_carry(c: &[f64; 4]) -> bool {
    c.iter().all(|x| *x == 0.0)
}

fn agent_index(p: Parameter) -> usize {
    match p {
        Parameter::Basal => 0,
        Parameter::CarbRatio(s) => s.main_index().map_or(0, |i| i + 1),
    }
}

impl Abba {
    /// A new advisor starting from the clinic's `start` therapy.
    pub fn new(config: AbbaConfig, start: TherapySettings) -> Result<Self, AdvisorError> {
        config.validate()?;
        start.validate().map_err(|e| AdvisorError::Config {
            field: "start settings".into(),
            problem: e.to_string(),
        })?;
        let v = config.critic.variant;
        let seed = config.exploration_seed;
        let agents = [
            Agent::new(ParamKind::Basal, v, seed, 0),
            Agent::new(ParamKind::CarbRatio, v, seed, 1),
            Agent::new(ParamKind::CarbRatio, v, seed, 2),
            Agent::new(ParamKind::CarbRatio, v, seed, 3),
        ];
        Ok(Self {
            log: DecisionLog::new(config.decision_log_capacity),
            config,
            start,
            settings: start,
            guard: EventGuard::default(),
            initialised: false,
            te: None,
            init: None,
            agents,
            day_windows: DayWindows::default(),
            basal_windows: DayWindows::default(),
            nights: DayWindows::default(),
            meal_windows: MealWindows::default(),
            last_br_change: None,
            bounds: ClinicianBounds::default(),
            min_data: None,
            steps: None,
            basal_schedule: None,
            prev_basal_schedule: None,
            first_week_end: None,
            carry: [0.0; 4],
            recent_lows: RecentLows::default(),
        })
    }

    /// Sets the clinician bounds. The value in force (at construction, the
    /// starting therapy) must lie inside them.
    pub fn with_bounds(self, bounds: ClinicianBounds) -> Result<Self, AdvisorError> {
        bounds.validate()?;
        bounds.check_in_force(|p| self.value(p))?;
        self.with_later_bounds(bounds)
    }

    /// Sets clinician bounds that were checked against the value in force
    /// when they were set, later than the starting therapy (which may lie
    /// outside them): while the value in force lies outside, each update
    /// moves it into them, past the 5 % a day if need be, and says so.
    pub fn with_later_bounds(mut self, bounds: ClinicianBounds) -> Result<Self, AdvisorError> {
        bounds.validate()?;
        self.bounds = bounds;
        Ok(self)
    }

    /// Asks each window for a minimum of readings; a window with fewer gets
    /// no update ([`SkipReason::TooFewReadings`]).
    pub fn with_min_data(mut self, rule: MinData) -> Self {
        self.min_data = Some(rule);
        self
    }

    /// The clinician bounds.
    pub fn bounds(&self) -> &ClinicianBounds {
        &self.bounds
    }

    /// Rounds every suggestion to the pump's steps ([`crate::steps`]).
    pub fn with_pump_steps(mut self, steps: PumpSteps) -> Result<Self, AdvisorError> {
        steps.validate()?;
        self.steps = Some(steps);
        Ok(self)
    }

    /// Runs a basal schedule instead of a flat rate: the basal value the
    /// advisor adapts is the schedule's mean rate, and each update scales
    /// every segment by one factor.
    pub fn with_basal_schedule(mut self, segments: Segments) -> Result<Self, AdvisorError> {
        validate_segments(&segments)?;
        self.settings.basal = UnitsPerHour(mean_rate(&segments));
        self.basal_schedule = Some(segments);
        Ok(self)
    }

    /// Ends the first week at the close of day index `day` (the caller's
    /// 7th day with enough data; `i64::MAX` while there are fewer): the TE
    /// grid covers the `init_days` days up to it.
    pub fn with_first_week_end(mut self, day: i64) -> Self {
        self.first_week_end = Some(day);
        self
    }

    /// The day whose close ends the first week, when set by the caller.
    pub fn first_week_end(&self) -> Option<i64> {
        self.first_week_end
    }

    /// The pump's steps, if suggestions are rounded to them.
    pub fn pump_steps(&self) -> Option<PumpSteps> {
        self.steps
    }

    /// The basal schedule in force, if the person runs one.
    pub fn basal_schedule(&self) -> Option<&Segments> {
        self.basal_schedule.as_ref()
    }

    /// The basal schedule before the last basal update that changed it
    /// (the one in force while that update waits for an answer), if any.
    pub fn previous_basal_schedule(&self) -> Option<&Segments> {
        self.prev_basal_schedule.as_ref()
    }

    /// A change of therapy made outside the advisor (a profile switch on
    /// the pump, the clinician's new settings): in force from now on, the
    /// next update starts from it.
    pub fn set_therapy(
        &mut self,
        basal_schedule: Option<Segments>,
        settings: TherapySettings,
    ) -> Result<(), AdvisorError> {
        settings.validate().map_err(|e| AdvisorError::Config {
            field: "therapy in force".into(),
            problem: e.to_string(),
        })?;
        let basal = match &basal_schedule {
            Some(s) => {
                validate_segments(s)?;
                mean_rate(s)
            }
            None => settings.basal.0,
        };
        self.basal_schedule = basal_schedule;
        self.prev_basal_schedule = None;
        self.put_in_force(SettingValue::Basal {
            rate: UnitsPerHour(basal),
        });
        for (i, slot) in MealSlot::MAIN.into_iter().enumerate() {
            self.put_in_force(SettingValue::CarbRatio {
                slot,
                ratio: settings.carb_ratio[i],
            });
        }
        Ok(())
    }

    /// Puts a person's answer in force: the next update of that setting
    /// starts from `v` (AP_old of eq16 is what the pump used). A basal
    /// answer also becomes BR_final for the carb ratios' switch rule.
    fn put_in_force(&mut self, v: SettingValue) {
        let (p, value) = match v {
            SettingValue::Basal { rate } => (Parameter::Basal, rate.0),
            SettingValue::CarbRatio { slot, ratio } => (Parameter::CarbRatio(slot), ratio.0),
        };
        if (self.value(p) - value).abs() > 1e-9 {
            self.carry[agent_index(p)] = 0.0;
        }
        match v {
            SettingValue::Basal { rate } => {
                let rate = self.schedule_in_force(rate.0);
                self.set_value(Parameter::Basal, rate);
                if let Some((old, _)) = self.last_br_change {
                    self.last_br_change = Some((old, rate));
                }
            }
            SettingValue::CarbRatio { slot, ratio } => {
                self.set_value(Parameter::CarbRatio(slot), ratio.0);
            }
        }
    }

    /// With a schedule: the schedule whose mean is `rate` (the previous one
    /// when the person kept it, the current one scaled when they put their
    /// own value in force), and its mean.
    fn schedule_in_force(&mut self, rate: f64) -> f64 {
        let Some(current) = &self.basal_schedule else {
            return rate;
        };
        if (mean_rate(current) - rate).abs() < 1e-9 {
            return rate;
        }
        let kept = self
            .prev_basal_schedule
            .as_ref()
            .filter(|p| (mean_rate(p) - rate).abs() < 1e-9)
            .cloned();
        let new = kept.unwrap_or_else(|| {
            rescale_schedule(current, rate, self.steps.map(|s| s.basal_u_per_h))
        });
        let m = mean_rate(&new);
        self.basal_schedule = Some(new);
        m
    }

    /// The configuration.
    pub fn config(&self) -> &AbbaConfig {
        &self.config
    }

    /// The therapy the advisor started from.
    pub fn start_settings(&self) -> &TherapySettings {
        &self.start
    }

    /// True once the initialisation week is over and θ0 is set.
    pub fn is_initialised(&self) -> bool {
        self.initialised
    }

    /// The TE initialisation report (after the initialisation week).
    pub fn init_report(&self) -> Option<&InitReport> {
        self.init.as_ref()
    }

    /// The policy θ (hyper, hypo) of a parameter's agent.
    pub fn theta(&self, p: Parameter) -> [f64; 2] {
        self.agents[agent_index(p)].theta
    }

    /// The critic weights of a parameter's agent (w for Variant A, r for Variant B).
    pub fn critic_weights(&self, p: Parameter) -> Vec<f64> {
        self.agents[agent_index(p)].critic_weights()
    }

    /// Counters of a parameter's agent (decisions, actor steps, clips, skips).
    pub fn counters(&self, p: Parameter) -> AgentCounters {
        self.agents[agent_index(p)].counters
    }

    /// Decisions dropped from the bounded log because it was not drained.
    pub fn decisions_dropped(&self) -> u64 {
        self.log.dropped()
    }

    /// The whole state as JSON, in the versioned envelope of [`crate::state`].
    pub fn save_json(&self) -> Result<String, AdvisorError> {
        crate::state::save(ArmKind::Abba, self)
    }

    /// Restores a state saved with [`Abba::save_json`], re-validating it.
    pub fn load_json(json: &str) -> Result<Self, AdvisorError> {
        let a: Self = crate::state::load(ArmKind::Abba, json)?;
        a.check_state()?;
        Ok(a)
    }

    /// Re-validates a deserialised state.
    pub(crate) fn check_state(&self) -> Result<(), AdvisorError> {
        self.config.validate()?;
        for (what, s) in [("start", &self.start), ("current", &self.settings)] {
            s.validate()
                .map_err(|e| AdvisorError::State(format!("{what} settings: {e}")))?;
        }
        for ag in &self.agents {
            if !ag.theta.iter().all(|t| t.is_finite()) {
                return Err(AdvisorError::State(format!(
                    "non-finite policy θ {:?}",
                    ag.theta
                )));
            }
        }
        Ok(())
    }

    fn value(&self, p: Parameter) -> f64 {
        match p {
            Parameter::Basal => self.settings.basal.0,
            Parameter::CarbRatio(s) => s
                .main_index()
                .map_or(f64::NAN, |i| self.settings.carb_ratio[i].0),
        }
    }

    fn set_value(&mut self, p: Parameter, v: f64) {
        match p {
            Parameter::Basal => self.settings.basal = UnitsPerHour(v),
            Parameter::CarbRatio(s) => {
                if let Some(i) = s.main_index() {
                    self.settings.carb_ratio[i] = GramsPerUnit(v);
                }
            }
        }
    }

    fn initialise(&mut self, at: Timestamp) {
        let te = match self.te.take() {
            Some(c) => {
                let (g, i) = c.finish(at);
                match transfer_entropy(&g, &i, &self.config.te) {
                    Ok(e) => TeOutcome::Estimated(e),
                    Err(e) => TeOutcome::Failed {
                        reason: e.to_string(),
                    },
                }
            }
            None => TeOutcome::Failed {
                reason: "no data was collected".into(),
            },
        };
        let te_n = match &te {
            TeOutcome::Estimated(e) => te_scale(e.te_bits, &self.config.te),
            TeOutcome::Failed { .. } => 1.0,
        };
        let (br, cir) = theta0(te_n, &self.config.te);
        self.agents[0].theta = br;
        for a in &mut self.agents[1..] {
            a.theta = cir;
        }
        self.init = Some(InitReport {
            at,
            te,
            te_n,
            theta0_basal: br,
            theta0_carb_ratio: cir,
        });
        self.initialised = true;
    }

    /// One update of parameter `p` from `window` = (start, end, stats).
    /// One update of `p` from `window`; `part` (the basal agent's hours of
    /// the day, `features.cgm_basal_window_min`) is where the features come
    /// from when given, the whole window still deciding the data rule and
    /// the hypo guard.
    fn decide(
        &mut self,
        at: Timestamp,
        p: Parameter,
        window: Result<(Timestamp, Timestamp, WindowStats), SkipReason>,
        part: Option<(Timestamp, Timestamp, WindowStats)>,
    ) {
        let old = self.value(p);
        let skipped = |reason| Decision {
            at,
            parameter: p,
            old,
            new: old,
            detail: DecisionDetail::Skipped { reason },
        };
        let (start, end, stats) = match window {
            Err(reason) => return self.log.push(skipped(reason)),
            Ok(w) if w.2.is_empty() => return self.log.push(skipped(SkipReason::EmptyWindow)),
            Ok(w) => w,
        };
        if let Some(rule) = self.min_data {
            let day = p == Parameter::Basal;
            let required = rule.required(self.config.mode, start, end, day);
            if stats.n < required {
                let reason = SkipReason::TooFewReadings {
                    n: stats.n,
                    required,
                };
                return self.log.push(skipped(reason));
            }
        }
        // The hypo guard looks at the whole window.
        let window_hyponumber = stats.hyponumber;
        let (start, end, stats) = match part {
            None => (start, end, stats),
            Some(w) if w.2.is_empty() => return self.log.push(skipped(SkipReason::EmptyWindow)),
            Some((from, to, part)) => {
                if let Some(rule) = self.min_data {
                    // CGM: the hours' coverage. SMBG: the window holds a
                    // reading or two by design (the fasting one, the
                    // night's two), so it asks what a meal window asks;
                    // the day's own count was checked above.
                    let day = self.config.mode == Mode::Cgm;
                    let required = rule.required(self.config.mode, from, to, day);
                    if part.n < required {
                        let reason = SkipReason::TooFewReadings {
                            n: part.n,
                            required,
                        };
                        return self.log.push(skipped(reason));
                    }
                }
                (from, to, part)
            }
        };
        let cfg = &self.config;
        let kind = match p {
            Parameter::Basal => ParamKind::Basal,
            Parameter::CarbRatio(_) => ParamKind::CarbRatio,
        };
        let f = stats.features(&cfg.features, cfg.mode);
        let cost = local_cost(&f, cfg.a_hyper, cfg.a_hypo);
        let (p_s, rule) = supervisory(cfg.mode, kind, &f, &stats, &cfg.supervisor);
        let br_change = match kind {
            ParamKind::Basal => None,
            ParamKind::CarbRatio => self.last_br_change,
        };
        let (m, switch, max) = (
            cfg.update.fusion_m,
            cfg.update.switch_rule_for(cfg.mode),
            cfg.update.max_relative_change,
        );
        let guard_hypo = cfg.update.hypo_guard && window_hyponumber > 0;
        // SMBG: a low reading of the last hours, in any window.
        let recent_low = cfg
            .update
            .recent_low_for(cfg.mode, kind)
            .filter(|r| self.recent_lows.any_within(at, *r));
        let (learning, action, mut applied) =
            self.agents[agent_index(p)].decide(&f, cost, p_s, cfg, |p_e| {
                let mut a = apply_action(kind, old, p_e, m, br_change, switch, max);
                if (guard_hypo || recent_low.is_some()) && adds_insulin(kind, a.new / old - 1.0) {
                    a.new = old;
                    a.hypo_guard_fired = guard_hypo;
                    a.recent_low = if guard_hypo { None } else { recent_low };
                }
                a
            });
        // The value in force may lie outside bounds set after it: the
        // suggestion then moves into them (the bound comes before the clamp).
        let outside = self.bounds.range(p).is_some_and(|r| !r.contains(old));
        let (held, mut bound) = self.bounds.hold(p, applied.new);
        if let Some(b) = &mut bound {
            b.from_outside = outside;
        }
        applied.new = held;
        let rounded = match self.steps {
            Some(steps) => {
                let i = agent_index(p);
                let asked = applied.new / old - 1.0;
                let mut carried = self.carry[i];
                // After a low, nothing carried may add insulin; nothing
                // carried counts while the value moves into the bounds.
                if outside
                    || ((applied.hypo_guard_fired || window_hyponumber > 0 || recent_low.is_some())
                        && adds_insulin(kind, carried))
                {
                    carried = 0.0;
                }
                let mut r = self.round(p, old, old * (1.0 + asked + carried), max, steps);
                r.carried = carried;
                // What is still owed, at most one step.
                let step = r.step / old;
                self.carry[i] = if outside {
                    0.0
                } else {
                    (asked + carried - (r.new / old - 1.0)).clamp(-step, step)
                };
                Some(r)
            }
            None => None,
        };
        if let Some(r) = &rounded {
            applied.new = r.new;
            if let Some(s) = &r.segments {
                self.prev_basal_schedule = self.basal_schedule.replace(s.clone());
            }
        }
        self.set_value(p, applied.new);
        if kind == ParamKind::Basal {
            self.last_br_change = Some((old, applied.new));
        }
        self.log.push(Decision {
            at,
            parameter: p,
            old,
            new: applied.new,
            detail: DecisionDetail::Abba(Box::new(AbbaExplanation {
                window_start: start,
                window_end: end,
                window: stats,
                features: f,
                cost,
                learning,
                supervisory_rule: rule,
                action,
                br_change,
                applied,
                bound,
                rounded,
            })),
        });
    }

    /// Rounds an update to the pump's step within the clamp and the bounds.
    fn round(&self, p: Parameter, old: f64, requested: f64, max: f64, steps: PumpSteps) -> Rounded {
        let allowed = self.bounds.range(p).map(|r| (r.min, r.max));
        let step = match p {
            Parameter::Basal => steps.basal_u_per_h,
            Parameter::CarbRatio(_) => steps.carb_ratio_g_per_u,
        };
        let schedule = self
            .basal_schedule
            .as_ref()
            .filter(|_| p == Parameter::Basal);
        let (new, segments) = match schedule {
            Some(s) if s.len() > 1 => {
                let n = scale_schedule(s, requested, step, max, allowed);
                (mean_rate(&n), Some(n))
            }
            Some(_) => {
                let v = round_change(old, requested, step, max, allowed);
                (v, Some(vec![(0, v)]))
            }
            None => (round_change(old, requested, step, max, allowed), None),
        };
        Rounded {
            requested,
            step,
            new,
            segments,
            carried: 0.0,
        }
    }

    fn reading(&mut self, at: Timestamp, g_mg_dl: f64) {
        if self.config.mode == Mode::Smbg {
            let u = &self.config.update;
            self.recent_lows.push(
                at,
                g_mg_dl,
                [u.smbg_recent_low_basal, u.smbg_recent_low_carb_ratios],
            );
        }
        let cfg = &self.config.features;
        self.day_windows.day_mut(at.day_index()).push(g_mg_dl, cfg);
        if cfg.basal_window_is_part(self.config.mode) {
            if let Some(ahead) = cfg.basal_window_day(self.config.mode, at.minute_of_day()) {
                let day = at.day_index() + ahead;
                self.basal_windows.day_mut(day).push(g_mg_dl, cfg);
                if self.config.mode == Mode::Smbg && cfg.smbg_night_fall_mg_dl.is_some() {
                    let night = self.nights.day_mut(day);
                    if ahead == 1 {
                        night.push_evening(g_mg_dl, cfg);
                    } else {
                        night.push_morning(g_mg_dl, cfg);
                    }
                }
            }
        }
        if let Some((_, acc)) = self.meal_windows.open_mut() {
            acc.push(g_mg_dl, cfg);
        }
    }

    fn process(&mut self, e: &Event) -> Option<TherapySettings> {
        if self.guard.first_day().is_none() && self.first_week_end.is_none() {
            let first_day = match e.kind {
                EventKind::DayClosed => closed_day(e.at),
                _ => e.at.day_index(),
            };
            self.te = Some(TeCollector::new(
                first_day,
                self.config.init_days,
                self.config.te.bin_minutes,
                self.start.basal,
            ));
        }
        if let (Some(end), None, false) = (self.first_week_end, &self.te, self.initialised) {
            // The TE grid covers the init_days days that end the first week.
            let te_start = end.saturating_sub(i64::from(self.config.init_days) - 1);
            if e.at.day_index() >= te_start {
                self.te = Some(TeCollector::new(
                    te_start,
                    self.config.init_days,
                    self.config.te.bin_minutes,
                    self.settings.basal,
                ));
            }
        }
        match e.kind {
            EventKind::Cgm(g) => {
                if let Some(te) = &mut self.te {
                    te.cgm(e.at, g.0);
                }
                if self.config.mode == Mode::Cgm {
                    self.reading(e.at, g.0);
                }
                None
            }
            EventKind::Smbg(g) => {
                if self.config.mode == Mode::Smbg {
                    self.reading(e.at, g.0);
                }
                None
            }
            EventKind::MealAnnounced { .. } | EventKind::DayClosed => self.timeline(e),
            EventKind::SuggestionAccepted(v)
            | EventKind::SuggestionRejected(v)
            | EventKind::SuggestionOverridden(v) => {
                self.put_in_force(v);
                None
            }
            // Insulin delivery (bolus, basal, temporary basal, suspension,
            // extended bolus): only the TE grid of the first week uses it.
            _ => {
                if let Some(te) = &mut self.te {
                    te.event(e);
                }
                None
            }
        }
    }

    /// One checked event ([`crate::adapting`]); ABBA's handling cannot fail.
    fn step(&mut self, e: &Event) -> Result<Option<TherapySettings>, AdvisorError> {
        Ok(self.process(e))
    }

    /// The decision points: main-meal announcements and day closings.
    fn timeline(&mut self, e: &Event) -> Option<TherapySettings> {
        match e.kind {
            EventKind::MealAnnounced { slot, .. } => {
                let i = slot.main_index()?;
                let prev = self.meal_windows.announce(i, e.at);
                if !self.initialised {
                    return None;
                }
                let window = prev
                    .map(|w| (w.start, w.end, w.acc))
                    .ok_or(SkipReason::NoPreviousDayWindow);
                self.decide(e.at, Parameter::CarbRatio(MealSlot::MAIN[i]), window, None);
                Some(self.settings)
            }
            EventKind::DayClosed => {
                let day = closed_day(e.at);
                let stats = self.day_windows.close(day);
                let mut part_stats = self.basal_windows.close(day);
                let night = self.nights.close(day);
                if let (Some(fall), Some(n)) = (self.config.features.smbg_night_fall_mg_dl, night) {
                    if self.config.mode == Mode::Smbg {
                        part_stats = Some(n.window(fall));
                    }
                }
                if !self.initialised {
                    let first = self.guard.first_day().unwrap_or(day);
                    let end = self
                        .first_week_end
                        .unwrap_or(first + i64::from(self.config.init_days) - 1);
                    if day < end {
                        return None;
                    }
                    self.initialise(e.at);
                }
                let start = Timestamp::from_day_and_minute(day, 0);
                let window = stats.map(|s| (start, e.at, s)).ok_or(SkipReason::NoDayData);
                let part =
                    self.config
                        .features
                        .basal_window_for(self.config.mode)
                        .map(|[from, to]| {
                            (
                                Timestamp(start.0 + from),
                                Timestamp(start.0 + to),
                                part_stats.unwrap_or_default(),
                            )
                        });
                self.decide(e.at, Parameter::Basal, window, part);
                Some(self.settings)
            }
            _ => None,
        }
    }
}

crate::adapting::advisor!(Abba, ArmKind::Abba);
