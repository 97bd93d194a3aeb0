//! Scenario configuration: every number of protocol.md §4 as a field whose
//! default is the paper's value, and the four named scenarios S1-S4.

use crate::SimError;
use abba_core::{Grams, MealSlot, MINUTES_PER_DAY};
use serde::{Deserialize, Serialize};

/// How a check names a refused field (the scenario's name added by `validate`).
type Bad<'a> = dyn Fn(&str, String) -> Result<(), SimError> + 'a;

/// The paper's four scenario names live in abba-core (results and reports
/// carry them without seeing the simulator); re-exported here, where the
/// scenarios themselves are defined.
pub use abba_core::ScenarioId;

/// One meal of the daily plan, before the day's random draws.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MealTemplate {
    /// Which meal.
    pub slot: MealSlot,
    /// Nominal time, minutes after midnight.
    pub minute_of_day: u32,
    /// Nominal carbohydrate content.
    pub carbs: Grams,
    /// Half-width of the uniform size variation (actual = carbs + U(-w, +w)).
    pub size_jitter: Grams,
    /// Half-width of the uniform time variation, in whole minutes (the offset
    /// is a uniform integer in [-w, +w]).
    pub time_jitter_min: u32,
    /// Whether the person announces (and boluses for) this meal.
    pub announced: bool,
}

/// The meal plan and the carb-counting error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MealConfig {
    /// The meals of every day, in time order (no two with the same slot).
    pub meals: Vec<MealTemplate>,
    /// Lower bound of the carb-counting factor: announced = actual × U(min, max).
    pub announce_factor_min: f64,
    /// Upper bound of the carb-counting factor.
    pub announce_factor_max: f64,
}

impl Default for MealConfig {
    /// Seed paper §III-A-3: breakfast 07:00 50 g, lunch 12:00 60 g, dinner
    /// 18:30 80 g (±10 g), bedtime snack 23:00 15 g (±5 g, not announced),
    /// times ±15 min, announced carbs ±50 %.
    fn default() -> Self {
        let main = |slot, minute_of_day, carbs| MealTemplate {
            slot,
            minute_of_day,
            carbs: Grams(carbs),
            size_jitter: Grams(10.0),
            time_jitter_min: 15,
            announced: true,
        };
        Self {
            meals: vec![
                main(MealSlot::Breakfast, 7 * 60, 50.0),
                main(MealSlot::Lunch, 12 * 60, 60.0),
                main(MealSlot::Dinner, 18 * 60 + 30, 80.0),
                MealTemplate {
                    slot: MealSlot::Snack,
                    minute_of_day: 23 * 60,
                    carbs: Grams(15.0),
                    size_jitter: Grams(5.0),
                    time_jitter_min: 15,
                    announced: false,
                },
            ],
            announce_factor_min: 0.5,
            announce_factor_max: 1.5,
        }
    }
}

/// Randomly skipped main meals (S4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkipConfig {
    /// Main meals skipped in every block (2 in the paper).
    pub per_block: u32,
    /// Block length in days (7 in the paper). Blocks are counted from day 1:
    /// D1-D7, D8-D14, ..., D92-D98.
    pub block_days: u32,
    /// First day (1-based) with skipped meals; must be the first day of a
    /// block. Default 1: the paper's Table I gives S4 a W1 of its own ("-"
    /// under the shared S1-S3 standard-therapy week), so S4 skips meals from
    /// the start, including the standard-therapy week.
    pub from_day: u32,
}

impl Default for SkipConfig {
    fn default() -> Self {
        Self {
            per_block: 2,
            block_days: 7,
            from_day: 1,
        }
    }
}

/// Which insulin actions of the model s(t) scales.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SensitivityTarget {
    /// Utilisation (Vmx) and the liver's insulin action (kp3), as
    /// spec/protocol.md §1 states. Default.
    #[default]
    VmxAndKp3,
    /// Utilisation (Vmx) only: the liver's insulin action stays nominal.
    Vmx,
}

/// The insulin-sensitivity profile s(t) (seed paper §III-A-1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensitivityConfig {
    /// Lower bound of the daily factor, drawn each midnight (0.75).
    pub daily_factor_min: f64,
    /// Upper bound of the daily factor (1.25).
    pub daily_factor_max: f64,
    /// The dawn factor at its lowest (0.5).
    pub dawn_factor: f64,
    /// Start of the descending ramp, minutes after midnight (04:00).
    pub dawn_start_min: u32,
    /// End of the ascending ramp, minutes after midnight (08:00).
    pub dawn_end_min: u32,
    /// Length of each linear ramp in minutes (30).
    pub dawn_ramp_min: u32,
    /// Last day (1-based) with daily variability and dawn phenomenon (90);
    /// from the next day on s(t) = 1.
    pub variable_until_day: u32,
    /// Which insulin actions s(t) scales (the paper does not say; T1DMS's
    /// choice is not documented in any source we found).
    #[serde(default)]
    pub target: SensitivityTarget,
    /// A slow drift of sensitivity on top of the daily factor (`None`, the
    /// paper's protocol; on in S6).
    #[serde(default)]
    pub drift: Option<SensitivityDrift>,
}

/// A slow sinusoidal drift of insulin sensitivity: from `from_day` on, the
/// day's factor is multiplied by 1 + amplitude · sin(2π (d − from_day) /
/// period_days + φ), with the phase φ drawn once per patient, uniform in
/// [0, 2π), from the patient's sensitivity stream (so one seed gives the
/// same drift). It also acts on the days after `variable_until_day`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensitivityDrift {
    /// Relative amplitude (0.3: ±30 %).
    pub amplitude: f64,
    /// Length of one cycle in days (42: six weeks).
    pub period_days: u32,
    /// First day (1-based) of the drift (9: after the standard-therapy
    /// week, so that W1 is S1's).
    pub from_day: u32,
}

impl Default for SensitivityDrift {
    fn default() -> Self {
        Self {
            amplitude: 0.3,
            period_days: 42,
            from_day: 9,
        }
    }
}

impl Default for SensitivityConfig {
    fn default() -> Self {
        Self {
            daily_factor_min: 0.75,
            daily_factor_max: 1.25,
            dawn_factor: 0.5,
            dawn_start_min: 4 * 60,
            dawn_end_min: 8 * 60,
            dawn_ramp_min: 30,
            variable_until_day: 90,
            target: SensitivityTarget::VmxAndKp3,
            drift: None,
        }
    }
}

/// Hypoglycaemia treatment: the person eats rescue carbohydrate when a
/// reading they see (CGM, or meter) is below a threshold, and treats again
/// when the next reading they see at least `recheck_min` later is still low.
/// Rescue carbohydrate is not announced to the advisor (no bolus).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HypoTreatment {
    /// Treat below this reading (mg/dL). 70.
    pub below_mg_dl: f64,
    /// Carbohydrate per treatment (g). 15 (the "rule of 15").
    pub carbs_g: f64,
    /// Minutes before the person re-checks and may treat again. 15.
    pub recheck_min: u32,
}

impl Default for HypoTreatment {
    fn default() -> Self {
        Self {
            below_mg_dl: 70.0,
            carbs_g: 15.0,
            recheck_min: 15,
        }
    }
}

/// Finger-stick (SMBG) measurement schedule (S2-S4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SmbgConfig {
    /// Minutes before each main meal's actual time (20); the reading is taken
    /// even when the meal is then skipped.
    pub before_meal_min: u32,
    /// Bedtime reading, minutes after midnight (23:00).
    pub bedtime_min: u32,
    /// Half-width of the uniform time uncertainty in whole minutes (0 in S2,
    /// 10 in S3 and S4); the offset is a uniform integer in [-w, +w].
    pub jitter_min: u32,
    /// First day (1-based) with SMBG readings (1: the person measures every
    /// day; the trial decides which readings the advisor uses).
    pub from_day: u32,
}

/// When the CGM is worn. How often it reads is the sensor's own property
/// (`devices::cgm::CgmConfig::sample_time_min`), the one place the CGM
/// period is set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CgmWear {
    /// Last day (1-based) the CGM is worn; `None` means every day (S1). 8 in
    /// S2-S4: the sensor provides the data for the advisor's initialisation.
    pub until_day: Option<u32>,
}

/// A complete scenario: the daily life of every patient in one arm of the trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioConfig {
    /// Name shown in reports ("S1".."S4" for the paper's).
    pub name: String,
    /// Length of the trial in days (98).
    pub days: u32,
    /// The `scenario` argument given to `abba_core::derive_seed` for every
    /// stream of this scenario. The paper's four scenarios all use 1, so they
    /// share meal times, sizes, carb-counting errors, sensitivity, CGM and
    /// meter noise and SMBG time jitter: S2-S4 differ from each other only in
    /// what the protocol changes (jitter on/off, skipped meals), and the
    /// standard-therapy week W1 is the same in S1-S3, as in the paper's
    /// Table I. Give scenarios distinct keys for independent realisations.
    pub random_key: u64,
    /// Meals and carb counting.
    pub meals: MealConfig,
    /// Skipped main meals (`None`: no meal is skipped).
    pub skip: Option<SkipConfig>,
    /// Insulin sensitivity.
    pub sensitivity: SensitivityConfig,
    /// SMBG schedule (`None`: no finger sticks, S1).
    pub smbg: Option<SmbgConfig>,
    /// When the CGM is worn.
    pub cgm: CgmWear,
    /// Hypoglycaemia treatment by the person (`None`, the paper's
    /// protocol: no rescue carbohydrate; on in S5).
    #[serde(default)]
    pub hypo_treatment: Option<HypoTreatment>,
}

impl ScenarioConfig {
    /// One of the paper's scenarios with every number at the paper's value.
    pub fn paper(id: ScenarioId) -> Self {
        let smbg = |jitter_min| SmbgConfig {
            before_meal_min: 20,
            bedtime_min: 23 * 60,
            jitter_min,
            from_day: 1,
        };
        let (skip, smbg, cgm_until) = match id {
            ScenarioId::S1 => (None, None, None),
            ScenarioId::S2 => (None, Some(smbg(0)), Some(8)),
            ScenarioId::S3 => (None, Some(smbg(10)), Some(8)),
            ScenarioId::S4 => (Some(SkipConfig::default()), Some(smbg(10)), Some(8)),
            ScenarioId::S5 | ScenarioId::S6 => (None, None, None),
        };
        Self {
            name: id.name().to_string(),
            days: 98,
            random_key: 1,
            meals: MealConfig::default(),
            skip,
            sensitivity: SensitivityConfig {
                drift: (id == ScenarioId::S6).then(SensitivityDrift::default),
                ..SensitivityConfig::default()
            },
            smbg,
            cgm: CgmWear {
                until_day: cgm_until,
            },
            hypo_treatment: (id == ScenarioId::S5).then(HypoTreatment::default),
        }
    }

    /// Checks every field; the error names the field and what was expected.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |field: &str, what: String| {
            Err(SimError::Config(format!(
                "scenario '{}': {field}: {what}",
                self.name
            )))
        };
        self.check_drift(&bad)?;
        self.check_hypo_treatment(&bad)?;
        if self.days == 0 {
            return bad("days", "must be at least 1".into());
        }
        self.check_meals(&bad)?;
        self.check_skip(&bad)?;
        self.check_sensitivity(&bad)?;
        self.check_smbg(&bad)?;
        if let Some(0) = self.cgm.until_day {
            return bad(
                "cgm.until_day",
                "days are counted from 1 (null: worn every day)".into(),
            );
        }
        Ok(())
    }

    /// The slow drift of insulin sensitivity (S6).
    fn check_drift(&self, bad: &Bad<'_>) -> Result<(), SimError> {
        if let Some(d) = &self.sensitivity.drift {
            if !(d.amplitude.is_finite() && (0.0..1.0).contains(&d.amplitude)) {
                return bad(
                    "sensitivity.drift.amplitude",
                    format!("must be in [0, 1), got {}", d.amplitude),
                );
            }
            if d.period_days == 0 {
                return bad("sensitivity.drift.period_days", "must be at least 1".into());
            }
            if d.from_day == 0 {
                return bad(
                    "sensitivity.drift.from_day",
                    "must be at least 1 (1-based)".into(),
                );
            }
        }
        Ok(())
    }

    /// The person's treatment of a low (S5).
    fn check_hypo_treatment(&self, bad: &Bad<'_>) -> Result<(), SimError> {
        if let Some(t) = &self.hypo_treatment {
            if !(t.below_mg_dl.is_finite() && t.below_mg_dl > 0.0 && t.below_mg_dl < 200.0) {
                return bad(
                    "hypo_treatment.below_mg_dl",
                    format!("must be in (0, 200) mg/dL, got {}", t.below_mg_dl),
                );
            }
            if !(t.carbs_g.is_finite() && t.carbs_g > 0.0 && t.carbs_g <= 100.0) {
                return bad(
                    "hypo_treatment.carbs_g",
                    format!("must be in (0, 100] g, got {}", t.carbs_g),
                );
            }
            if t.recheck_min == 0 {
                return bad("hypo_treatment.recheck_min", "must be at least 1".into());
            }
        }
        Ok(())
    }

    /// The meal plan: announce factors, each meal's size and time window
    /// (inside the day, in order, not overlapping), one meal per slot, only
    /// main meals announced.
    fn check_meals(&self, bad: &Bad<'_>) -> Result<(), SimError> {
        let day = MINUTES_PER_DAY as u32;
        let m = &self.meals;
        if !(m.announce_factor_min.is_finite()
            && m.announce_factor_max.is_finite()
            && 0.0 < m.announce_factor_min
            && m.announce_factor_min <= m.announce_factor_max)
        {
            return bad(
                "meals.announce_factor_min/max",
                format!(
                    "need 0 < min <= max, got {} and {}",
                    m.announce_factor_min, m.announce_factor_max
                ),
            );
        }
        let mut prev_end: Option<u32> = None;
        for (k, t) in m.meals.iter().enumerate() {
            let f = format!("meals.meals[{k}] ({})", t.slot.name());
            if !(t.carbs.0.is_finite()
                && t.size_jitter.0.is_finite()
                && t.size_jitter.0 >= 0.0
                && t.carbs.0 - t.size_jitter.0 > 0.0)
            {
                return bad(
                    &f,
                    format!(
                        "need carbs - size_jitter > 0 and size_jitter >= 0, got {} ± {}",
                        t.carbs.0, t.size_jitter.0
                    ),
                );
            }
            let lo = t.minute_of_day.checked_sub(t.time_jitter_min);
            let hi = t.minute_of_day + t.time_jitter_min;
            let Some(lo) = lo.filter(|_| hi < day) else {
                return bad(
                    &f,
                    format!(
                        "time {} ± {} min leaves the day [0, {day})",
                        t.minute_of_day, t.time_jitter_min
                    ),
                );
            };
            if let Some(p) = prev_end {
                if lo <= p {
                    return bad(
                        &f,
                        "meals must be in time order and their time windows must not overlap"
                            .into(),
                    );
                }
            }
            prev_end = Some(hi);
            if m.meals[..k].iter().any(|o| o.slot == t.slot) {
                return bad(&f, "slot used twice".into());
            }
            if t.announced && t.slot.main_index().is_none() {
                return bad(
                    &f,
                    "only main meals can be announced (a snack has no carb ratio)".into(),
                );
            }
        }
        Ok(())
    }

    /// Skipped meals: blocks counted from day 1, no more skips than main
    /// meals in a block.
    fn check_skip(&self, bad: &Bad<'_>) -> Result<(), SimError> {
        let m = &self.meals;
        if let Some(s) = &self.skip {
            if s.block_days == 0 {
                return bad("skip.block_days", "must be at least 1".into());
            }
            let mains = m
                .meals
                .iter()
                .filter(|t| t.slot.main_index().is_some())
                .count() as u32;
            if s.per_block > mains * s.block_days {
                return bad(
                    "skip.per_block",
                    format!(
                        "{} exceeds the {} main meals of a block",
                        s.per_block,
                        mains * s.block_days
                    ),
                );
            }
            if s.from_day == 0 || (s.from_day - 1) % s.block_days != 0 {
                return bad(
                    "skip.from_day",
                    format!(
                        "must be the first day of a {}-day block counted from day 1, got {}",
                        s.block_days, s.from_day
                    ),
                );
            }
        }
        Ok(())
    }

    /// Day-to-day sensitivity and the dawn phenomenon's window.
    fn check_sensitivity(&self, bad: &Bad<'_>) -> Result<(), SimError> {
        let day = MINUTES_PER_DAY as u32;
        let s = &self.sensitivity;
        if !(s.daily_factor_min.is_finite()
            && s.daily_factor_max.is_finite()
            && 0.0 < s.daily_factor_min
            && s.daily_factor_min <= s.daily_factor_max)
        {
            return bad(
                "sensitivity.daily_factor_min/max",
                format!(
                    "need 0 < min <= max, got {} and {}",
                    s.daily_factor_min, s.daily_factor_max
                ),
            );
        }
        if !(s.dawn_factor.is_finite() && s.dawn_factor > 0.0) {
            return bad(
                "sensitivity.dawn_factor",
                format!("must be > 0, got {}", s.dawn_factor),
            );
        }
        if !(s.dawn_start_min + 2 * s.dawn_ramp_min <= s.dawn_end_min && s.dawn_end_min <= day) {
            return bad(
                "sensitivity.dawn_start_min/dawn_end_min/dawn_ramp_min",
                format!(
                    "need start + 2·ramp <= end <= {day}, got start {}, end {}, ramp {}",
                    s.dawn_start_min, s.dawn_end_min, s.dawn_ramp_min
                ),
            );
        }
        Ok(())
    }

    /// The meter readings of SMBG mode, inside the day around the meals.
    fn check_smbg(&self, bad: &Bad<'_>) -> Result<(), SimError> {
        let day = MINUTES_PER_DAY as u32;
        let m = &self.meals;
        if let Some(b) = &self.smbg {
            if b.from_day == 0 {
                return bad("smbg.from_day", "days are counted from 1".into());
            }
            for t in m.meals.iter().filter(|t| t.slot.main_index().is_some()) {
                if t.minute_of_day < t.time_jitter_min + b.before_meal_min + b.jitter_min {
                    return bad(
                        "smbg.before_meal_min",
                        format!(
                            "the reading before {} can fall before midnight",
                            t.slot.name()
                        ),
                    );
                }
            }
            if b.bedtime_min < b.jitter_min || b.bedtime_min + b.jitter_min >= day {
                return bad(
                    "smbg.bedtime_min",
                    format!(
                        "{} ± {} min leaves the day [0, {day})",
                        b.bedtime_min, b.jitter_min
                    ),
                );
            }
        }
        Ok(())
    }
}
