//! `AbbaConfig`: every constant of the algorithm as a named, documented knob.
//!
//! Tags follow `shared/spec/abba-algorithm.md`: **\[SEED]** values are stated
//! in the paper (kept as knobs for ablations); **\[GUESS]** values are the
//! spec's choices where no source was readable and must be listed in any
//! results write-up. Defaults are the spec's except the deviations listed
//! in crates/trial/README.md "Knobs" (CGM- and SMBG-mode excursion, actor rule, and the
//! guessed scales chosen by `abba calibrate`).

use crate::error::{check_count, check_positive, check_range, config_err, AdvisorError};
use crate::supervisor::ParamKind;
use abba_core::MINUTES_PER_DAY;
use serde::{Deserialize, Serialize};

/// Which measurements drive the advisor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Four finger-stick readings a day (spec §2.2); BR updated at the bedtime reading.
    Smbg,
    /// CGM every 5 min (spec §2.3); BR updated at midnight.
    Cgm,
}

impl Mode {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Smbg => "smbg",
            Mode::Cgm => "cgm",
        }
    }
}

/// A person's age group: it chooses the per-population defaults of ABBA's
/// knobs, the one home of the values the trial calibrated per population
/// (`abba_trial::protocol::RawTrialConfig::for_population` maps its
/// populations here; a person's settings carry one, default adult).
///
/// The basal agent's hours and CGM mode's CIR switch rule and G_max
/// differ, chosen by `abba calibrate` over `cgm_basal_window`,
/// `smbg_basal_window`, `cgm_switch_rule` and `feature_g_max_cgm` on 60
/// generated patients of each population, seeds 101
/// (benches/diagnosis/README.md): adults the whole day in CGM mode and
/// the night's bedtime and fasting readings (22:30 the evening before to
/// 07:30) in SMBG mode, which are [`FeatureConfig::default`]'s;
/// adolescents 00:00-07:00 in CGM mode and children 02:00-07:00, both the
/// fasting reading before breakfast (00:00-07:30) in SMBG mode. The switch
/// rule is off in CGM mode for adults ([`UpdateConfig::default`]'s), the
/// seed's for adolescents and children; CGM mode's
/// G_max is 350 mg/dL for adults ([`FeatureConfig::default`]'s), 400 for
/// the others.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AgeGroup {
    /// Adults (the defaults).
    #[default]
    Adult,
    /// Adolescents.
    Adolescent,
    /// Children.
    Child,
}

impl AgeGroup {
    /// Every age group, adults first.
    pub const ALL: [AgeGroup; 3] = [AgeGroup::Adult, AgeGroup::Adolescent, AgeGroup::Child];

    /// The serialised name: `adult`, `adolescent`, `child`.
    pub fn name(self) -> &'static str {
        match self {
            AgeGroup::Adult => "adult",
            AgeGroup::Adolescent => "adolescent",
            AgeGroup::Child => "child",
        }
    }

    /// The group by its serialised name (exactly; `None` otherwise).
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|g| g.name() == name)
    }

    /// The group in the plural, as people read it: "adults",
    /// "adolescents", "children".
    pub fn plural(self) -> &'static str {
        match self {
            AgeGroup::Adult => "adults",
            AgeGroup::Adolescent => "adolescents",
            AgeGroup::Child => "children",
        }
    }

    /// The basal agent's hours of this group's defaults:
    /// (`features.cgm_basal_window_min`, `features.smbg_basal_window_min`).
    pub fn basal_windows_min(self) -> (Option<[i64; 2]>, Option<[i64; 2]>) {
        match self {
            AgeGroup::Adult => (None, Some([-90, 450])),
            AgeGroup::Adolescent => (Some([0, 420]), Some([0, 450])),
            AgeGroup::Child => (Some([120, 420]), Some([0, 450])),
        }
    }

    /// CGM mode's CIR switch rule of this group's defaults
    /// (`update.cgm_switch_rule`): off for adults, the seed's (as
    /// `update.switch_rule`) for adolescents and children. `abba calibrate`
    /// on each population's training cohort chose off for adults and
    /// adolescents, on for children; for adolescents off stopped more runs
    /// below 10 mg/dL on both evaluation cohorts (1 -> 5 and 0 -> 4,
    /// standard therapy 3 and 4), so they keep the rule
    /// (benches/diagnosis/README.md).
    pub fn cgm_switch_rule(self) -> Option<bool> {
        match self {
            AgeGroup::Adult => Some(false),
            AgeGroup::Adolescent | AgeGroup::Child => None,
        }
    }

    /// SMBG mode's carb-ratio recent-low rule of this group's defaults
    /// (`update.smbg_recent_low_carb_ratios`): below 90 mg/dL for 72 hours
    /// for adults, off for adolescents and children. `abba calibrate` on
    /// each population's training cohort turned it on everywhere
    /// (adolescents 100 mg/dL, 168 h; children 100 mg/dL, 72 h), but on
    /// both evaluation cohorts it gave back more hyperglycaemia than the
    /// lows it saved: children's W14 LBGI + HBGI rose above standard
    /// therapy's, adolescents' to 3-6 % under it (8-15 % without)
    /// (benches/calibration/smbg_recent_low), so they keep the seed's rules.
    pub fn smbg_recent_low_carb_ratios(self) -> Option<RecentLow> {
        match self {
            AgeGroup::Adult => default_smbg_recent_low_carb_ratios(),
            AgeGroup::Adolescent | AgeGroup::Child => None,
        }
    }

    /// CGM mode's hyper normalisation G_max of this group's defaults
    /// (`features.cgm_g_max_mg_dl`): 350 mg/dL for adults, 400 for
    /// adolescents and children (`abba calibrate`, as above).
    pub fn cgm_g_max_mg_dl(self) -> f64 {
        match self {
            AgeGroup::Adult => 350.0,
            AgeGroup::Adolescent | AgeGroup::Child => 400.0,
        }
    }

    /// Sets the knobs this group's defaults choose in `c`: the basal
    /// agent's hours (both modes'), CGM mode's switch rule and G_max, and
    /// SMBG mode's carb-ratio recent-low rule.
    pub fn apply(self, c: &mut AbbaConfig) {
        let f = &mut c.features;
        (f.cgm_basal_window_min, f.smbg_basal_window_min) = self.basal_windows_min();
        f.cgm_g_max_mg_dl = Some(self.cgm_g_max_mg_dl());
        c.update.cgm_switch_rule = self.cgm_switch_rule();
        c.update.smbg_recent_low_carb_ratios = self.smbg_recent_low_carb_ratios();
    }

    /// Whether `f` holds this group's defaults (of the knobs it chooses).
    pub fn holds(self, f: &FeatureConfig) -> bool {
        (f.cgm_basal_window_min, f.smbg_basal_window_min) == self.basal_windows_min()
    }
}

/// Plausibility limits for incoming events; values outside are rejected with an error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EventLimits {
    /// Lowest plausible glucose reading (mg/dL). Default 10: below any device's range.
    pub glucose_min_mg_dl: f64,
    /// Highest plausible glucose reading (mg/dL). Default 1000.
    pub glucose_max_mg_dl: f64,
    /// Largest plausible announced meal (g). Default 500.
    pub carbs_max_g: f64,
    /// Largest plausible single bolus (U). Default 50 (the modelled pump caps at 30).
    pub bolus_max_u: f64,
    /// Largest plausible basal rate (U/h). Default 50 (the modelled pump caps at 30).
    pub basal_max_u_per_h: f64,
    /// Largest accepted timestamp (minutes since 00:00 of day 1). Default 100 years.
    pub max_timestamp_min: i64,
    /// Largest temporary basal given as a percentage of the scheduled rate.
    /// Default 250 (pumps offer up to 200-250 %).
    pub temp_basal_max_percent: f64,
    /// Longest temporary basal (min). Default 4320 (72 h, the longest pumps offer).
    pub temp_basal_max_min: u32,
    /// Longest extended bolus (min). Default 720 (12 h). Its total is
    /// limited by `bolus_max_u`, like a bolus.
    pub extended_bolus_max_min: u32,
}

impl Default for EventLimits {
    fn default() -> Self {
        Self {
            glucose_min_mg_dl: 10.0,
            glucose_max_mg_dl: 1000.0,
            carbs_max_g: 500.0,
            bolus_max_u: 50.0,
            basal_max_u_per_h: 50.0,
            max_timestamp_min: 100 * 365 * 1440,
            temp_basal_max_percent: 250.0,
            temp_basal_max_min: 72 * 60,
            extended_bolus_max_min: 12 * 60,
        }
    }
}

/// Parses a JSON configuration and validates it (each arm's `from_json`).
pub(crate) fn parse_checked<T: serde::de::DeserializeOwned>(
    json: &str,
    validate: fn(&T) -> Result<(), AdvisorError>,
) -> Result<T, AdvisorError> {
    let c: T = serde_json::from_str(json).map_err(|e| config_err("(json)", e.to_string()))?;
    validate(&c)?;
    Ok(c)
}

/// What every adapting arm's configuration check ends with: its event
/// limits, and a decision log that holds at least one decision.
pub(crate) fn check_limits_and_log(
    limits: &EventLimits,
    decision_log_capacity: usize,
) -> Result<(), AdvisorError> {
    limits.validate()?;
    if decision_log_capacity == 0 {
        return Err(config_err(
            "decision_log_capacity",
            "must be at least 1, got 0",
        ));
    }
    Ok(())
}

impl EventLimits {
    /// Checks the limits themselves.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        check_positive("limits.glucose_min_mg_dl", self.glucose_min_mg_dl)?;
        check_range(
            "limits.glucose_max_mg_dl",
            self.glucose_max_mg_dl,
            self.glucose_min_mg_dl,
            1e6,
        )?;
        check_positive("limits.carbs_max_g", self.carbs_max_g)?;
        check_positive("limits.bolus_max_u", self.bolus_max_u)?;
        check_positive("limits.basal_max_u_per_h", self.basal_max_u_per_h)?;
        check_positive("limits.temp_basal_max_percent", self.temp_basal_max_percent)?;
        for (field, v) in [
            ("limits.temp_basal_max_min", self.temp_basal_max_min),
            ("limits.extended_bolus_max_min", self.extended_bolus_max_min),
        ] {
            if v == 0 {
                return Err(config_err(field, "must be at least 1 minute, got 0"));
            }
        }
        check_count(
            "limits.max_timestamp_min",
            self.max_timestamp_min,
            1,
            i64::MAX / 4,
        )?;
        Ok(())
    }
}

/// How eq10-11 average the excursions of a window (spec §3, revision);
/// chosen per mode by `features.cgm_excursion` and `features.smbg_excursion`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Excursion {
    /// Σ excursions / all readings of the window: the time-averaged
    /// excursion, independent of the sampling rate (each of the four SMBG
    /// readings stands for a quarter of the day, so CGM and SMBG estimate
    /// the same daily quantity). \[INFER; DEVIATION from the literal
    /// reading] Default in CGM mode.
    #[default]
    TimeAveraged,
    /// Σ excursions / out-of-range readings only: the literal eq10-11. With
    /// 288 readings a day a 15-minute dip weighs as much as a whole day at
    /// the same level; with four readings one low reading weighs as much as
    /// three high ones together.
    OutOfRangeMean,
}

/// The former name of [`Excursion`] (CGM mode was the first to get the knob).
pub type CgmExcursion = Excursion;

/// Feature thresholds and normalisation (spec §3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeatureConfig {
    /// G_L, lower border of the tight range (mg/dL). \[SEED eq11] 90.
    pub g_low_mg_dl: f64,
    /// G_H, upper border of the tight range (mg/dL). \[SEED eq10] 150.
    pub g_high_mg_dl: f64,
    /// G_max in SMBG mode (and in CGM mode unless `cgm_g_max_mg_dl` is
    /// set): F_hyper = raw / (G_max − G_H). \[GUESS §3: 400, the CGM
    /// reporting ceiling; calibrated] 250 (`abba calibrate` on adults,
    /// BENCHMARKS.md "ABBA's defaults").
    pub g_max_mg_dl: f64,
    /// G_min: F_hypo = raw / (G_L − G_min). \[GUESS §3] 40 (CGM reporting floor).
    pub g_min_mg_dl: f64,
    /// "Hyponumber" counts readings below this (mg/dL). \[SEED eq27] 70.
    pub hyponumber_below_mg_dl: f64,
    /// N1 counts readings below this (mg/dL). \[SEED eq27] 80.
    pub n1_below_mg_dl: f64,
    /// N2 counts readings above this (mg/dL). \[SEED eq27] 130.
    pub n2_above_mg_dl: f64,
    /// The CGM-mode reading of eq10-11. \[DEVIATION] time-averaged.
    #[serde(default)]
    pub cgm_excursion: Excursion,
    /// The SMBG-mode reading of eq10-11. \[DEVIATION, calibrated]
    /// time-averaged: each of the four readings stands for a quarter of the
    /// day, so one reading below G_L no longer weighs as much as three
    /// readings above G_H together (the literal out-of-range mean drove
    /// SMBG-mode basal cuts that harmed adolescents and children).
    #[serde(default = "default_smbg_excursion")]
    pub smbg_excursion: Excursion,
    /// G_min in CGM mode (F_hypo = raw/(G_L − G_min)); `None` uses
    /// `g_min_mg_dl`. Time-averaging shrinks the brief hypoglycaemic
    /// excursions far more than the long hyperglycaemic ones, so CGM mode
    /// may need its own hypo normalisation. \[GUESS, calibrated]
    #[serde(default)]
    pub cgm_g_min_mg_dl: Option<f64>,
    /// G_max in CGM mode (F_hyper = raw/(G_max − G_H)); `None` uses
    /// `g_max_mg_dl`. \[GUESS §3, calibrated] 350 (adults, with CGM mode's
    /// switch rule off; 400 before it, and for adolescents and children:
    /// [`AgeGroup`]).
    #[serde(default)]
    pub cgm_g_max_mg_dl: Option<f64>,
    /// CGM mode: the minutes of the calendar day `[from, to)` after
    /// midnight whose readings the basal agent's features come from (a
    /// negative `from` starts the evening before: `[-120, 420]` is 22:00 to
    /// 07:00); `None`: the whole day (the seed). \[DEVIATION when set] A flat
    /// basal judged on the whole day answers the post-meal
    /// hyperglycaemia that is the carb ratios' (benches/diagnosis,
    /// children in CGM mode); clinicians and the run-to-run baseline judge
    /// it on the fasting hours. The day's readings still decide the data
    /// rule and the hypo guard (a low at any hour blocks more insulin).
    #[serde(default)]
    pub cgm_basal_window_min: Option<[i64; 2]>,
    /// SMBG mode: the same for the finger-stick readings (`None`: the
    /// whole day, the seed). \[DEVIATION] With four readings a day
    /// `[0, 450]` holds the fasting one before breakfast (20 min before
    /// it, ±15 min, ±10 more in S3 and S4); `[-90, 450]`, the default
    /// (`abba calibrate` on adults; benches/diagnosis/README.md), adds the
    /// bedtime reading of the evening before: the night's two readings.
    #[serde(default)]
    pub smbg_basal_window_min: Option<[i64; 2]>,
    /// SMBG mode, with a basal window that starts the evening before
    /// (`smbg_basal_window_min`): an evening reading above G_H counts for
    /// the basal agent as in range (no hyper excursion, not in eq27's N2)
    /// when the night fell, i.e. the window's first reading of the morning
    /// is at least this many mg/dL below the evening's last. Glucose that
    /// falls through the night says the basal is not short; the high
    /// bedtime reading is the dinner's (the dinner ratio's agent judges
    /// it). Its hypo parts always count. `None`: the evening reading counts
    /// as it is. \[DEVIATION when set]
    #[serde(default)]
    pub smbg_night_fall_mg_dl: Option<f64>,
}

impl FeatureConfig {
    /// The spec's literal feature settings (§3): the out-of-range mean in
    /// both modes and G_max = 400, G_min = 40 in both modes. The defaults
    /// differ (time-averaged excursions, SMBG-mode G_max 250; see
    /// crates/trial/README.md "Knobs").
    pub fn spec() -> Self {
        Self {
            g_max_mg_dl: 400.0,
            cgm_excursion: Excursion::OutOfRangeMean,
            smbg_excursion: Excursion::OutOfRangeMean,
            cgm_g_min_mg_dl: None,
            cgm_g_max_mg_dl: None,
            smbg_basal_window_min: None,
            smbg_night_fall_mg_dl: None,
            ..Self::default()
        }
    }
}

fn default_smbg_excursion() -> Excursion {
    Excursion::TimeAveraged
}

impl FeatureConfig {
    /// The reading of eq10-11 for an advisor in `mode`.
    pub fn excursion_for(&self, mode: Mode) -> Excursion {
        match mode {
            Mode::Cgm => self.cgm_excursion,
            Mode::Smbg => self.smbg_excursion,
        }
    }

    /// For a reading at `minute_of_day` of an advisor in `mode`, the
    /// calendar day whose basal window it belongs to, relative to its own:
    /// 0 for its own day, 1 for the next (a window that starts the evening
    /// before, `from` < 0), `None` for none (see `cgm_basal_window_min`).
    /// Without a window every reading is its own day's.
    pub fn basal_window_day(&self, mode: Mode, minute_of_day: i64) -> Option<i64> {
        match self.basal_window_for(mode) {
            None => Some(0),
            Some([from, to]) if (from..to).contains(&minute_of_day) => Some(0),
            Some([from, _]) if from < 0 && minute_of_day >= MINUTES_PER_DAY + from => Some(1),
            Some(_) => None,
        }
    }

    /// True when the basal agent's features come from part of the day.
    pub fn basal_window_is_part(&self, mode: Mode) -> bool {
        self.basal_window_for(mode).is_some()
    }

    /// The basal agent's hours `[from, to)` (minutes after midnight) in
    /// `mode`, `None` for the whole day.
    pub fn basal_window_for(&self, mode: Mode) -> Option<[i64; 2]> {
        match mode {
            Mode::Cgm => self.cgm_basal_window_min,
            Mode::Smbg => self.smbg_basal_window_min,
        }
    }

    /// G_min for an advisor in `mode`.
    pub fn g_min_for(&self, mode: Mode) -> f64 {
        match (mode, self.cgm_g_min_mg_dl) {
            (Mode::Cgm, Some(g)) => g,
            _ => self.g_min_mg_dl,
        }
    }

    /// G_max for an advisor in `mode`.
    pub fn g_max_for(&self, mode: Mode) -> f64 {
        match (mode, self.cgm_g_max_mg_dl) {
            (Mode::Cgm, Some(g)) => g,
            _ => self.g_max_mg_dl,
        }
    }
}

impl Default for FeatureConfig {
    fn default() -> Self {
        Self {
            g_low_mg_dl: 90.0,
            g_high_mg_dl: 150.0,
            g_max_mg_dl: 250.0,
            g_min_mg_dl: 40.0,
            hyponumber_below_mg_dl: 70.0,
            n1_below_mg_dl: 80.0,
            n2_above_mg_dl: 130.0,
            cgm_excursion: Excursion::TimeAveraged,
            smbg_excursion: default_smbg_excursion(),
            cgm_g_min_mg_dl: None,
            cgm_g_max_mg_dl: Some(350.0),
            cgm_basal_window_min: None,
            smbg_basal_window_min: Some([-90, 450]),
            smbg_night_fall_mg_dl: None,
        }
    }
}

impl FeatureConfig {
    /// Checks ordering G_min < G_L < G_H < G_max and positivity.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        check_positive("features.g_min_mg_dl", self.g_min_mg_dl)?;
        check_range(
            "features.g_low_mg_dl",
            self.g_low_mg_dl,
            self.g_min_mg_dl + 1e-9,
            1e4,
        )?;
        check_range(
            "features.g_high_mg_dl",
            self.g_high_mg_dl,
            self.g_low_mg_dl,
            1e4,
        )?;
        check_range(
            "features.g_max_mg_dl",
            self.g_max_mg_dl,
            self.g_high_mg_dl + 1e-9,
            1e4,
        )?;
        if let Some(g) = self.cgm_g_max_mg_dl {
            check_range("features.cgm_g_max_mg_dl", g, self.g_high_mg_dl + 1e-9, 1e4)?;
        }
        if let Some(g) = self.cgm_g_min_mg_dl {
            check_range("features.cgm_g_min_mg_dl", g, 1e-9, self.g_low_mg_dl - 1e-9)?;
        }
        for (field, window) in [
            ("features.cgm_basal_window_min", self.cgm_basal_window_min),
            ("features.smbg_basal_window_min", self.smbg_basal_window_min),
        ] {
            if let Some([from, to]) = window {
                if !(-MINUTES_PER_DAY < from
                    && from < to
                    && to <= MINUTES_PER_DAY
                    && to - from <= MINUTES_PER_DAY)
                {
                    return Err(AdvisorError::Config {
                        field: field.into(),
                        problem: format!(
                            "[{from}, {to}]: expected minutes after the closed day's midnight with -1440 < from < to <= 1440 (from < 0: the evening before) and at most a day long"
                        ),
                    });
                }
            }
        }
        if let Some(fall) = self.smbg_night_fall_mg_dl {
            check_range("features.smbg_night_fall_mg_dl", fall, 0.0, 1e4)?;
        }
        check_positive(
            "features.hyponumber_below_mg_dl",
            self.hyponumber_below_mg_dl,
        )?;
        check_positive("features.n1_below_mg_dl", self.n1_below_mg_dl)?;
        check_positive("features.n2_above_mg_dl", self.n2_above_mg_dl)?;
        Ok(())
    }
}

/// Which critic to run (spec §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CriticVariant {
    /// Variant A: discounted linear V-critic with TD(λ), actor driven by the TD error (seed eq4-7, 28). Default.
    ValueTd,
    /// Variant B: Konda-Tsitsiklis average-cost Q-critic with compatible features (ablation).
    KondaTsitsiklis,
}

/// Critic basis g(x) (spec §5.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CriticBasis {
    /// g = (1, F_hyper, F_hypo). \[GUESS] default.
    WithBias,
    /// g = (F_hyper, F_hypo) (the spec's fallback); stored as (0, F_hyper, F_hypo).
    FeaturesOnly,
}

/// Which cost enters the TD error of decision k (spec §5.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CostTiming {
    /// d_k = c(F_{k+1}) + γV(F_{k+1}) − V(F_k): the cost of the decision's outcome. \[GUESS] default.
    Outcome,
    /// d_k = c(F_k) + γV(F_{k+1}) − V(F_k): the literal reading of eq5.
    Literal,
}

/// Critic knobs (spec §5).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CriticConfig {
    /// Variant A (default) or B.
    pub variant: CriticVariant,
    /// Basis of the V-critic (Variant A; also the state part of φ in Variant B). \[GUESS]
    pub basis: CriticBasis,
    /// Cost timing in the TD error. \[GUESS] Outcome.
    pub cost_timing: CostTiming,
    /// Discount γ (Variant A). \[GUESS] 0.9.
    pub gamma: f64,
    /// Trace decay λ. \[GUESS] 0.5.
    pub lambda: f64,
    /// a_0 in a_k = a_0/(1 + k/κ). \[GUESS] 0.1.
    pub a0: f64,
    /// κ (in updates, i.e. days) in a_k = a_0/(1 + k/κ). \[GUESS] 30.
    pub kappa: f64,
}

impl Default for CriticConfig {
    fn default() -> Self {
        Self {
            variant: CriticVariant::ValueTd,
            basis: CriticBasis::WithBias,
            cost_timing: CostTiming::Outcome,
            gamma: 0.9,
            lambda: 0.5,
            a0: 0.1,
            kappa: 30.0,
        }
    }
}

/// Which action enters the policy gradient (spec §6.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GradientAction {
    /// The sampled P_e, even if the switch rule or the clamp changed what was applied. \[GUESS] default.
    Sampled,
    /// The effective P_e,eff = (AP_final/AP_old − 1)/(1 − m) (ablation).
    Effective,
}

/// Which policy update the actor takes (spec §6.4).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ActorRule {
    /// The natural-gradient step Δθ = −β_k·d·(P_e − P_d)·F/(h·‖F‖²) (the
    /// eq28 direction preconditioned by the inverse Fisher information of
    /// the Gaussian policy, so it has no 1/σ blow-up), with a decaying
    /// step β_k = `natural_beta`/(1 + k/κ)² that makes the actor slower than
    /// the critic (a_k = a_0/(1 + k/κ)), and a projection that keeps θ in its
    /// clinical sign pattern after every step: for the basal rate
    /// θ_hyper ≥ 0 and θ_hypo ≤ 0, for a carb ratio θ_hyper ≤ 0 and
    /// θ_hypo ≥ 0 (more hyperglycaemia never removes insulin, more
    /// hypoglycaemia never adds it). \[DEVIATION] Default.
    #[default]
    ProjectedNatural,
    /// The literal eq28 Δθ = −β·d·(P_e − P_d)/σ²·h·F with the clip of
    /// `theta_step_clip` and no projection.
    Eq28,
}

/// Actor, exploration and supervisor-weight knobs (spec §6.1, §6.4).
///
/// Note on the defaults: the literal eq28 step is of order β·d·z/σ with
/// σ = c_σ‖F‖² ≈ 0.001-0.01, so with β = 0.5 the ±`theta_step_clip` clip
/// fires on most updates and θ moves by ± the clip per update in the
/// direction opposite to the exploration draw while the critic's baseline
/// is still near 0 (d ≈ c > 0): a random walk. With the spec's clip of 0.5,
/// θ leaves its sign pattern within days and the learned action adds
/// insulin on hypoglycaemic days; in our trial that stopped 17 of 30 S1
/// runs below 10 mg/dL. The clip therefore defaults to 0.01 (a deviation
/// from spec §6.4, measured in BENCHMARKS.md "ABBA's defaults"): after 90
/// updates the walk has moved θ by about 0.1, the size of θ0 itself.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActorConfig {
    /// h in P_d = h·P_a + (1−h)·P_s. \[SEED eq23-24] 0.5.
    pub h: f64,
    /// c_σ in σ = c_σ·‖F‖². \[SEED eq22] 0.05.
    pub c_sigma: f64,
    /// Actor step β. \[SEED eq28] 0.5.
    pub beta: f64,
    /// Skip the actor step when the stored σ_k is below this. \[GUESS §6.4] 1e-4.
    pub sigma_min: f64,
    /// Clip each |Δθ_j| per update to this. \[GUESS §6.4; DEVIATION] 0.01
    /// (the spec's 0.5 lets θ random-walk into unsafe signs; see above).
    pub theta_step_clip: f64,
    /// Which P_e enters eq28. \[GUESS] Sampled.
    pub gradient_action: GradientAction,
    /// The policy update. \[DEVIATION] projected natural gradient.
    #[serde(default)]
    pub rule: ActorRule,
    /// β_0 of the projected natural-gradient step (β_k = β_0/(1 + k/κ)²,
    /// κ = `critic.kappa`, k = actor steps taken). \[DEVIATION] 0: the
    /// actor is frozen at the TE-scaled θ0, the simplest advisor with the
    /// same results (learning with β_0 = 0.05, the earlier default, moved
    /// LBGI + HBGI by at most 0.012 in S1 and in S6's slow sensitivity drift
    /// on three held-out cohorts, against 0.6 between cohorts: BENCHMARKS.md,
    /// "ABBA's defaults"). The paper's learning actor: `rule` = `eq28`, or
    /// `natural_beta` > 0 ([`PAPER_LEARNING_NATURAL_BETA`]).
    #[serde(default = "default_natural_beta")]
    pub natural_beta: f64,
}

/// Default β_0 of the projected natural-gradient actor: 0, the actor
/// frozen (its learning measurably adds nothing; see `natural_beta`).
pub const DEFAULT_NATURAL_BETA: f64 = 0.0;

/// β_0 of the learning actor as calibrated before it was frozen (the
/// named knob for the paper's learning: `abba.actor.natural_beta` = 0.05).
pub const PAPER_LEARNING_NATURAL_BETA: f64 = 0.05;

fn default_natural_beta() -> f64 {
    DEFAULT_NATURAL_BETA
}

impl Default for ActorConfig {
    fn default() -> Self {
        Self {
            h: 0.5,
            c_sigma: 0.05,
            beta: 0.5,
            sigma_min: 1e-4,
            theta_step_clip: 0.01,
            gradient_action: GradientAction::Sampled,
            rule: ActorRule::ProjectedNatural,
            natural_beta: DEFAULT_NATURAL_BETA,
        }
    }
}

/// Supervisory-action gains (spec §6.2); all \[SEED].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SupervisorConfig {
    /// SMBG CIR gain (eq26): ±0.02·F.
    pub smbg_cir_gain: f64,
    /// SMBG BR: P_s = −F_hypo / this when Hyponumber > 0 (eq27). 8.
    pub smbg_br_hypo_divisor: f64,
    /// SMBG BR: P_s = +F_hyper / this when N1 ≤ 1 and N2 ≥ 2 (eq27). 30.
    pub smbg_br_high_divisor: f64,
    /// SMBG BR: P_s = −F_hypo / this when N1 ≥ 2 and N2 ≤ 1 (eq27). 30.
    pub smbg_br_low_divisor: f64,
    /// CGM gain when only hypo excursions (eq29). 0.10.
    pub cgm_hypo_only_gain: f64,
    /// CGM gain when both hypo and hyper excursions (eq29). 0.05.
    pub cgm_mixed_gain: f64,
}

impl Default for SupervisorConfig {
    fn default() -> Self {
        Self {
            smbg_cir_gain: 0.02,
            smbg_br_hypo_divisor: 8.0,
            smbg_br_high_divisor: 30.0,
            smbg_br_low_divisor: 30.0,
            cgm_hypo_only_gain: 0.10,
            cgm_mixed_gain: 0.05,
        }
    }
}

/// From P_e to the new value (spec §6.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UpdateConfig {
    /// m in AP_fusion = m·AP_old + (1−m)·AP_new. \[SEED eq17] 0.5.
    pub fusion_m: f64,
    /// Largest relative change per update. \[SEED "within 5%"] 0.05.
    pub max_relative_change: f64,
    /// Apply the CIR switch rule l (eq20-21). \[SEED] true.
    pub switch_rule: bool,
    /// CGM mode's own switch rule, `None`: as `switch_rule` (the seed's
    /// one rule for both modes). \[DEVIATION] Off in CGM mode by default
    /// (`abba calibrate`, benches/diagnosis/README.md): with a reading
    /// every 5 minutes the basal agent rises on most days, and the rule
    /// then held the breakfast carb ratio still through the dawn factor's
    /// mornings (60-67 of 90 breakfast decisions); in SMBG mode it keeps
    /// both agents from adding insulin on the same four readings, and
    /// stays.
    #[serde(default)]
    pub cgm_switch_rule: Option<bool>,
    /// Extra safety, **not in the seed or the spec** (a deviation when on):
    /// cancel any update that would add insulin (basal up, carb ratio down)
    /// when its window holds a reading below `features.hyponumber_below_mg_dl`.
    /// Default false (spec-literal). The supervisory action alone never adds
    /// insulin on such windows, but P_a (the learned part) can.
    pub hypo_guard: bool,
    /// SMBG mode: no basal update adds insulin while a reading below
    /// the threshold was taken within the look-back, whatever window it
    /// fell in. \[DEVIATION when set] Four readings a day see a fraction of
    /// the lows: a low reading at one hour says that today's settings leave
    /// unseen lows at others (benches/diagnosis/README.md, "SMBG W14").
    /// `None`: off (the seed).
    #[serde(default)]
    pub smbg_recent_low_basal: Option<RecentLow>,
    /// The same for the three carb ratios (no ratio goes down). Default:
    /// below 90 mg/dL, 72 hours (`abba calibrate` on adults,
    /// benches/calibration/smbg_recent_low); the basal's rule raised
    /// W13 hyperglycaemia there and stays off. A stored configuration
    /// from before the rule (no field) keeps working as it did: off.
    #[serde(default)]
    pub smbg_recent_low_carb_ratios: Option<RecentLow>,
}

/// A reading threshold and a look-back ([`UpdateConfig::smbg_recent_low_basal`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecentLow {
    /// A reading below this (mg/dL) is a recent low.
    pub below_mg_dl: f64,
    /// How long (hours) after it no update adds insulin.
    pub hours: u32,
}

impl RecentLow {
    /// The longest look-back kept (four weeks).
    pub const MAX_HOURS: u32 = 24 * 28;
    /// The highest threshold (mg/dL): above it a reading is not low.
    pub const MAX_BELOW_MG_DL: f64 = 150.0;
}

fn default_smbg_recent_low_carb_ratios() -> Option<RecentLow> {
    Some(RecentLow {
        below_mg_dl: 90.0,
        hours: 72,
    })
}

impl Default for UpdateConfig {
    fn default() -> Self {
        Self {
            fusion_m: 0.5,
            max_relative_change: 0.05,
            switch_rule: true,
            cgm_switch_rule: Some(false),
            hypo_guard: false,
            smbg_recent_low_basal: None,
            smbg_recent_low_carb_ratios: default_smbg_recent_low_carb_ratios(),
        }
    }
}

impl UpdateConfig {
    /// The seed's literal update rules (the switch rule in both modes).
    pub fn spec() -> Self {
        Self {
            cgm_switch_rule: None,
            smbg_recent_low_carb_ratios: None,
            ..Self::default()
        }
    }

    /// The recent-low rule for an update of `kind` by an advisor in
    /// `mode` (SMBG mode only).
    pub fn recent_low_for(&self, mode: Mode, kind: ParamKind) -> Option<RecentLow> {
        match (mode, kind) {
            (Mode::Cgm, _) => None,
            (Mode::Smbg, ParamKind::Basal) => self.smbg_recent_low_basal,
            (Mode::Smbg, ParamKind::CarbRatio) => self.smbg_recent_low_carb_ratios,
        }
    }

    /// Whether the CIR switch rule applies to an advisor in `mode`.
    pub fn switch_rule_for(&self, mode: Mode) -> bool {
        match mode {
            Mode::Cgm => self.cgm_switch_rule.unwrap_or(self.switch_rule),
            Mode::Smbg => self.switch_rule,
        }
    }
}

/// How the (bias-corrected) TE becomes the policy scale TE_n (spec §7.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum TeMapping {
    /// TE_n = TE / TE_ref. \[GUESS] default.
    Proportional,
    /// TE_n = TE_ref / TE (the other direction; spec says the direction is unverified).
    Inverse,
    /// TE_n = 1: nominal θ for everyone (no personalisation; ablation).
    Constant,
    /// TE_n = intercept + slope·TE (the spec's fitted regression of s* on TE).
    Linear {
        /// Intercept (dimensionless).
        intercept: f64,
        /// Slope per bit.
        slope_per_bit: f64,
    },
}

/// Default TE_ref (bits). \[GUESS, uncalibrated]: the spec defines TE_ref as
/// the median bias-corrected TE of a training cohort's first week; no cohort
/// was available when this default was set. Calibrate it with
/// [`crate::te::first_week_te`] over a cohort and set `te.te_ref_bits`.
pub const DEFAULT_TE_REF_BITS: f64 = 0.02;

/// Transfer-entropy initialisation knobs (spec §7).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeConfig {
    /// Grid step of the signals (min). \[GUESS] 5.
    pub bin_minutes: i64,
    /// Peak of the insulin-activity kernel (min). \[GUESS §7.2] 75.
    pub kernel_peak_min: f64,
    /// Duration of the insulin-activity kernel (min). \[GUESS §7.2] 360.
    pub kernel_duration_min: f64,
    /// Number of equiprobable (quantile) bins per signal. \[GUESS] 4.
    pub bins: usize,
    /// Largest source lag, in grid steps (24 = 120 min). \[GUESS] 24.
    pub max_lag_steps: usize,
    /// Number of circularly shifted surrogates for bias correction. \[GUESS] 20.
    pub surrogates: usize,
    /// Smallest circular shift of a surrogate, in grid steps (288 = 1 day). \[GUESS]
    pub min_surrogate_shift_steps: usize,
    /// Fewest usable (g_t, g_t+1, ĩ) triples to accept an estimate. \[GUESS] 500.
    pub min_pairs: usize,
    /// TE_ref (bits), see [`DEFAULT_TE_REF_BITS`]. \[GUESS]
    pub te_ref_bits: f64,
    /// TE → TE_n mapping. \[GUESS] proportional.
    pub mapping: TeMapping,
    /// Lower clamp of TE_n. \[GUESS] 0.25.
    pub te_n_min: f64,
    /// Upper clamp of TE_n. \[GUESS] 4.
    pub te_n_max: f64,
    /// θ0 for BR per unit TE_n: (hyper, hypo). \[GUESS, calibrated]
    /// (+0.45, −0.60) (spec: (+0.10, −0.20); `abba calibrate` on its
    /// training cohort, gain 0.45 and hypo ratio 4/3; BENCHMARKS.md).
    pub theta0_br: [f64; 2],
    /// θ0 for each CIR per unit TE_n: (hyper, hypo). \[GUESS, calibrated]
    /// (−0.20, +0.60) (spec: (−0.10, +0.20); gain 0.2, hypo ratio 3).
    pub theta0_cir: [f64; 2],
}

impl Default for TeConfig {
    fn default() -> Self {
        Self {
            bin_minutes: 5,
            kernel_peak_min: 75.0,
            kernel_duration_min: 360.0,
            bins: 4,
            max_lag_steps: 24,
            surrogates: 20,
            min_surrogate_shift_steps: 288,
            min_pairs: 500,
            te_ref_bits: DEFAULT_TE_REF_BITS,
            mapping: TeMapping::Proportional,
            te_n_min: 0.25,
            te_n_max: 4.0,
            theta0_br: [0.45, -0.60],
            theta0_cir: [-0.20, 0.60],
        }
    }
}

impl TeConfig {
    /// Checks every TE knob.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        check_count("te.bin_minutes", self.bin_minutes, 1, 60)?;
        check_positive("te.kernel_peak_min", self.kernel_peak_min)?;
        // The exponential activity model needs t_peak < t_duration / 2.
        check_range(
            "te.kernel_duration_min",
            self.kernel_duration_min,
            2.0 * self.kernel_peak_min + 1e-6,
            24.0 * 60.0,
        )?;
        check_count("te.bins", self.bins, 2, 16)?;
        if self.max_lag_steps > 288 {
            return Err(config_err(
                "te.max_lag_steps",
                format!("must be at most 288, got {}", self.max_lag_steps),
            ));
        }
        if self.surrogates > 1000 {
            return Err(config_err(
                "te.surrogates",
                format!("must be at most 1000, got {}", self.surrogates),
            ));
        }
        if self.min_pairs < 16 {
            return Err(config_err(
                "te.min_pairs",
                format!("must be at least 16, got {}", self.min_pairs),
            ));
        }
        check_positive("te.te_ref_bits", self.te_ref_bits)?;
        check_positive("te.te_n_min", self.te_n_min)?;
        check_range("te.te_n_max", self.te_n_max, self.te_n_min, 1e3)?;
        if let TeMapping::Linear {
            intercept,
            slope_per_bit,
        } = self.mapping
        {
            check_range("te.mapping.intercept", intercept, -1e6, 1e6)?;
            check_range("te.mapping.slope_per_bit", slope_per_bit, -1e6, 1e6)?;
        }
        for (name, v) in [
            ("te.theta0_br", self.theta0_br),
            ("te.theta0_cir", self.theta0_cir),
        ] {
            for x in v {
                check_range(name, x, -10.0, 10.0)?;
            }
        }
        Ok(())
    }
}

/// The complete configuration of an [`crate::Abba`] advisor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AbbaConfig {
    /// SMBG or CGM mode.
    pub mode: Mode,
    /// Seed of the exploration generator; use
    /// `abba_core::derive_seed(trial, patient, scenario, Stream::Exploration)`.
    pub exploration_seed: u64,
    /// Days of data collected under the starting therapy before adapting. \[SEED] 7.
    pub init_days: u32,
    /// Local-cost weight of F_hyper. \[SEED eq13] 1.
    pub a_hyper: f64,
    /// Local-cost weight of F_hypo. \[SEED eq13] 10.
    pub a_hypo: f64,
    /// Feature thresholds and normalisation.
    pub features: FeatureConfig,
    /// Critic.
    pub critic: CriticConfig,
    /// Actor and exploration.
    pub actor: ActorConfig,
    /// Supervisory gains.
    pub supervisor: SupervisorConfig,
    /// Fusion, switch rule and clamp.
    pub update: UpdateConfig,
    /// TE initialisation.
    pub te: TeConfig,
    /// Event plausibility limits.
    pub limits: EventLimits,
    /// Most decisions kept before the oldest are dropped (drain them with
    /// `take_decisions`); the number dropped is counted. Default 4096.
    pub decision_log_capacity: usize,
}

impl AbbaConfig {
    /// The spec's defaults in the given mode.
    pub fn new(mode: Mode, exploration_seed: u64) -> Self {
        Self {
            mode,
            exploration_seed,
            init_days: 7,
            a_hyper: 1.0,
            a_hypo: 10.0,
            features: FeatureConfig::default(),
            critic: CriticConfig::default(),
            actor: ActorConfig::default(),
            supervisor: SupervisorConfig::default(),
            update: UpdateConfig::default(),
            te: TeConfig::default(),
            limits: EventLimits::default(),
            decision_log_capacity: 4096,
        }
    }

    /// [`AbbaConfig::new`] with the defaults of `group` (see [`AgeGroup`]).
    pub fn for_age_group(mode: Mode, exploration_seed: u64, group: AgeGroup) -> Self {
        let mut c = Self::new(mode, exploration_seed);
        group.apply(&mut c);
        c
    }

    /// Parses a JSON configuration and validates it.
    pub fn from_json(json: &str) -> Result<Self, AdvisorError> {
        parse_checked(json, Self::validate)
    }

    /// Checks every field; the error names the field and the value.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        check_count("init_days", self.init_days, 1, 60)?;
        check_range("a_hyper", self.a_hyper, 0.0, 1e3)?;
        check_range("a_hypo", self.a_hypo, 0.0, 1e3)?;
        self.features.validate()?;
        let c = &self.critic;
        check_range("critic.gamma", c.gamma, 0.0, 0.999_999)?;
        check_range("critic.lambda", c.lambda, 0.0, 1.0)?;
        check_range("critic.a0", c.a0, 1e-12, 10.0)?;
        check_positive("critic.kappa", c.kappa)?;
        let a = &self.actor;
        check_range("actor.h", a.h, 0.0, 1.0)?;
        check_range("actor.c_sigma", a.c_sigma, 0.0, 10.0)?;
        check_range("actor.beta", a.beta, 0.0, 100.0)?;
        check_range("actor.sigma_min", a.sigma_min, 1e-12, 1.0)?;
        check_range("actor.theta_step_clip", a.theta_step_clip, 0.0, 100.0)?;
        check_range("actor.natural_beta", a.natural_beta, 0.0, 100.0)?;
        if a.rule == ActorRule::ProjectedNatural {
            let t = &self.te;
            if t.theta0_br[0] < 0.0 || t.theta0_br[1] > 0.0 {
                return Err(config_err(
                    "te.theta0_br",
                    format!(
                        "must be (>= 0, <= 0) under the projected actor (more hyperglycaemia never removes basal insulin), got {:?}",
                        t.theta0_br
                    ),
                ));
            }
            if t.theta0_cir[0] > 0.0 || t.theta0_cir[1] < 0.0 {
                return Err(config_err(
                    "te.theta0_cir",
                    format!(
                        "must be (<= 0, >= 0) under the projected actor (more hyperglycaemia never raises a carb ratio), got {:?}",
                        t.theta0_cir
                    ),
                ));
            }
        }
        let s = &self.supervisor;
        check_range("supervisor.smbg_cir_gain", s.smbg_cir_gain, 0.0, 10.0)?;
        check_positive("supervisor.smbg_br_hypo_divisor", s.smbg_br_hypo_divisor)?;
        check_positive("supervisor.smbg_br_high_divisor", s.smbg_br_high_divisor)?;
        check_positive("supervisor.smbg_br_low_divisor", s.smbg_br_low_divisor)?;
        check_range(
            "supervisor.cgm_hypo_only_gain",
            s.cgm_hypo_only_gain,
            0.0,
            10.0,
        )?;
        check_range("supervisor.cgm_mixed_gain", s.cgm_mixed_gain, 0.0, 10.0)?;
        check_range("update.fusion_m", self.update.fusion_m, 0.0, 0.999_999)?;
        for (field, r) in [
            (
                "update.smbg_recent_low_basal",
                self.update.smbg_recent_low_basal,
            ),
            (
                "update.smbg_recent_low_carb_ratios",
                self.update.smbg_recent_low_carb_ratios,
            ),
        ] {
            if let Some(r) = r {
                check_range(
                    &format!("{field}.below_mg_dl"),
                    r.below_mg_dl,
                    20.0,
                    RecentLow::MAX_BELOW_MG_DL,
                )?;
                check_count(&format!("{field}.hours"), r.hours, 1, RecentLow::MAX_HOURS)?;
            }
        }
        check_range(
            "update.max_relative_change",
            self.update.max_relative_change,
            0.0,
            0.5,
        )?;
        self.te.validate()?;
        check_limits_and_log(&self.limits, self.decision_log_capacity)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_round_trip_through_json() {
        let c = AbbaConfig::new(Mode::Cgm, 42);
        c.validate().unwrap();
        let s = serde_json::to_string(&c).unwrap();
        let back: AbbaConfig = serde_json::from_str(&s).unwrap();
        assert_eq!(back, c);
    }

    #[test]
    fn each_age_group_chooses_its_basal_hours_switch_rule_and_cgm_g_max_and_nothing_else() {
        let hours = |g: AgeGroup, mode: Mode| {
            AbbaConfig::for_age_group(mode, 7, g)
                .features
                .basal_window_for(mode)
        };
        assert_eq!(hours(AgeGroup::Adult, Mode::Cgm), None);
        assert_eq!(hours(AgeGroup::Adult, Mode::Smbg), Some([-90, 450]));
        assert_eq!(hours(AgeGroup::Adolescent, Mode::Cgm), Some([0, 420]));
        assert_eq!(hours(AgeGroup::Adolescent, Mode::Smbg), Some([0, 450]));
        assert_eq!(hours(AgeGroup::Child, Mode::Cgm), Some([120, 420]));
        assert_eq!(hours(AgeGroup::Child, Mode::Smbg), Some([0, 450]));
        let cgm = |g: AgeGroup| {
            let c = AbbaConfig::for_age_group(Mode::Cgm, 7, g);
            (
                c.update.switch_rule_for(Mode::Cgm),
                c.features.g_max_for(Mode::Cgm),
            )
        };
        assert_eq!(cgm(AgeGroup::Adult), (false, 350.0));
        assert_eq!(cgm(AgeGroup::Adolescent), (true, 400.0));
        assert_eq!(cgm(AgeGroup::Child), (true, 400.0));
        assert_eq!(AgeGroup::default(), AgeGroup::Adult);
        for g in AgeGroup::ALL {
            for mode in [Mode::Cgm, Mode::Smbg] {
                let c = AbbaConfig::for_age_group(mode, 7, g);
                c.validate().unwrap();
                assert!(g.holds(&c.features));
                // SMBG mode keeps the seed's switch rule in every group.
                assert!(c.update.switch_rule_for(Mode::Smbg));
                // Everything else is the mode's default.
                let mut plain = AbbaConfig::new(mode, 7);
                g.apply(&mut plain);
                assert_eq!(plain, c);
                let mut back = c.clone();
                AgeGroup::Adult.apply(&mut back);
                assert_eq!(back, AbbaConfig::new(mode, 7));
            }
            assert_eq!(AgeGroup::parse(g.name()), Some(g));
            let json = serde_json::to_string(&g).unwrap();
            assert_eq!(json, format!("\"{}\"", g.name()));
            assert_eq!(serde_json::from_str::<AgeGroup>(&json).unwrap(), g);
        }
        assert!(!AgeGroup::Child.holds(&AbbaConfig::new(Mode::Cgm, 7).features));
        assert_eq!(AgeGroup::parse("Child"), None);
        assert!(serde_json::from_str::<AgeGroup>("\"toddler\"").is_err());
    }

    #[test]
    fn cgm_switch_rule_follows_the_seed_unless_set() {
        // The seed's one rule for both modes, and a stored configuration
        // from before the knob (no field): CGM mode follows switch_rule.
        let spec = UpdateConfig::spec();
        assert_eq!(spec.cgm_switch_rule, None);
        for on in [true, false] {
            let u = UpdateConfig {
                switch_rule: on,
                ..UpdateConfig::spec()
            };
            assert_eq!(
                (u.switch_rule_for(Mode::Cgm), u.switch_rule_for(Mode::Smbg)),
                (on, on)
            );
        }
        let mut json = serde_json::to_value(UpdateConfig::default()).unwrap();
        json.as_object_mut().unwrap().remove("cgm_switch_rule");
        json.as_object_mut()
            .unwrap()
            .remove("smbg_recent_low_carb_ratios");
        let old: UpdateConfig = serde_json::from_value(json).unwrap();
        assert_eq!(old, spec);
        // The default: off in CGM mode only.
        let d = UpdateConfig::default();
        assert!(!d.switch_rule_for(Mode::Cgm));
        assert!(d.switch_rule_for(Mode::Smbg));
        let set_on = UpdateConfig {
            cgm_switch_rule: Some(true),
            switch_rule: false,
            ..d
        };
        assert!(set_on.switch_rule_for(Mode::Cgm));
        assert!(!set_on.switch_rule_for(Mode::Smbg));
    }

    #[test]
    fn every_adapting_arm_checks_its_log_and_json_the_same_way() {
        let want = config_err("decision_log_capacity", "must be at least 1, got 0");
        let mut abba = AbbaConfig::new(Mode::Cgm, 1);
        abba.decision_log_capacity = 0;
        assert_eq!(abba.validate(), Err(want.clone()));
        let mut r2r = crate::R2rConfig::new(Mode::Cgm);
        r2r.decision_log_capacity = 0;
        assert_eq!(r2r.validate(), Err(want.clone()));
        let mut autotune = crate::AutotuneConfig::new(Mode::Cgm);
        autotune.decision_log_capacity = 0;
        assert_eq!(autotune.validate(), Err(want));
        // from_json: parsed, then validated; a parse error names "(json)".
        let json = serde_json::to_string(&r2r).unwrap();
        assert!(crate::R2rConfig::from_json(&json).is_err());
        r2r.decision_log_capacity = 1;
        let json = serde_json::to_string(&r2r).unwrap();
        assert_eq!(crate::R2rConfig::from_json(&json), Ok(r2r));
        let e = AbbaConfig::from_json("{").unwrap_err();
        assert!(
            matches!(e, AdvisorError::Config { ref field, .. } if field == "(json)"),
            "{e}"
        );
    }

    #[test]
    fn bad_fields_are_named_in_the_error() {
        let mut c = AbbaConfig::new(Mode::Smbg, 1);
        c.critic.gamma = 1.5;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("critic.gamma") && e.contains("1.5"), "{e}");
        let mut c = AbbaConfig::new(Mode::Smbg, 1);
        c.features.g_high_mg_dl = 80.0;
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("features.g_high_mg_dl"), "{e}");
        let mut c = AbbaConfig::new(Mode::Smbg, 1);
        c.te.kernel_duration_min = 100.0;
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("te.kernel_duration_min"));
        let mut c = AbbaConfig::new(Mode::Smbg, 1);
        c.update.max_relative_change = f64::NAN;
        assert!(c.validate().is_err());
    }

    #[test]
    fn from_json_parses_and_validates() {
        let mut c = AbbaConfig::new(Mode::Smbg, 3);
        c.actor.h = 0.25;
        let back = AbbaConfig::from_json(&serde_json::to_string(&c).unwrap()).unwrap();
        assert_eq!(back, c);
        c.actor.h = 2.0;
        let e = AbbaConfig::from_json(&serde_json::to_string(&c).unwrap()).unwrap_err();
        assert!(e.to_string().contains("actor.h"), "{e}");
        assert!(AbbaConfig::from_json("{").is_err());
    }

    #[test]
    fn unknown_fields_are_rejected() {
        let mut v = serde_json::to_value(AbbaConfig::new(Mode::Cgm, 1)).unwrap();
        v["gama"] = serde_json::json!(0.9);
        let e = serde_json::from_value::<AbbaConfig>(v)
            .unwrap_err()
            .to_string();
        assert!(e.contains("gama"), "{e}");
    }
}
