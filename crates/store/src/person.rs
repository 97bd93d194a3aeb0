//! Persons: name, zone, mode, meal windows, starting therapy, clinician
//! bounds and the advisor's configuration.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use abba_advisor::{Abba, AbbaConfig, ClinicianBounds, MinData, Mode, PumpSteps};
use abba_core::units::GlucoseUnit;
use abba_core::TherapySettings;
use abba_io::events::{DayClose, PersonSettings};
use abba_io::meals::MealWindows;
use jiff::civil::Date;
use jiff::tz::TimeZone;
use serde::{Deserialize, Serialize};

/// Everything stored about a person besides the name, zone, mode and day 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PersonSettingsDoc {
    /// The therapy in force when the person started (the clinic's).
    pub start: TherapySettings,
    /// Meal windows (carbohydrate entries become meals by local time).
    pub meal_windows: MealWindows,
    /// Clinician bounds of the basal rate and the carb ratios.
    pub bounds: ClinicianBounds,
    /// SMBG mode: the day closes at the first meter reading at or after this
    /// local minute of the day (the bedtime reading).
    pub bedtime_min: u32,
    /// Minimum data per window for an update.
    pub min_data: MinData,
    /// The advisor's configuration (mode and exploration seed included).
    pub advisor: AbbaConfig,
    /// The starting basal schedule (its mean is `start.basal`); none: the
    /// flat rate `start.basal`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub basal_schedule: Option<Vec<(u32, f64)>>,
    /// The pump's steps (suggestions are rounded to them); none: continuous
    /// values as in the paper and the trial.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pump_steps: Option<PumpSteps>,
    /// Where the therapy in force comes from.
    #[serde(default)]
    pub therapy_source: TherapySource,
    /// Research only: suggest basal rates even when the data show a closed
    /// loop or injections (`--allow-closed-loop`).
    #[serde(default)]
    pub allow_closed_loop: bool,
    /// The glucose unit of every text for this person.
    #[serde(default)]
    pub units: GlucoseUnit,
}

/// Where a person's therapy in force comes from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TherapySource {
    /// Not decided yet: given by hand; an import whose pump profile differs
    /// stops until the person adopts the profile or keeps these values.
    #[default]
    Given,
    /// The pump's profile: profiles and switches in the data are in force
    /// from their time.
    Profile,
    /// The store's values were kept over a differing profile
    /// (`--keep-therapy`): profiles in the data are not read as therapy.
    Kept,
}

impl TherapySource {
    /// In words.
    pub fn words(self) -> &'static str {
        match self {
            TherapySource::Given => "given when the person was created",
            TherapySource::Profile => {
                "the pump's profile (profile switches in force from their time)"
            }
            TherapySource::Kept => {
                "the store's values, kept over the pump's profile (profiles in the data are not read as therapy)"
            }
        }
    }
}

/// A new person.
#[derive(Debug, Clone)]
pub struct NewPerson {
    /// Unique name in the file.
    pub name: String,
    /// IANA zone name (`Europe/Zurich`).
    pub tz: String,
    /// Day 1 of the advisor's clock; `None`: the local date of the first
    /// record imported.
    pub first_day: Option<Date>,
    /// The rest.
    pub settings: PersonSettingsDoc,
}

impl NewPerson {
    /// A person with default meal windows, no bounds, bedtime 22:00, the
    /// default data rule and ABBA's default configuration for `mode` with an
    /// exploration seed derived from the name.
    pub fn new(name: &str, tz: &str, mode: Mode, start: TherapySettings) -> Self {
        // The name as it will be stored (see [`check_name`]).
        let name = name.trim();
        let seed = abba_io::record::content_hash([name.as_bytes()]);
        Self {
            name: name.to_string(),
            tz: tz.to_string(),
            first_day: None,
            settings: PersonSettingsDoc {
                start,
                meal_windows: MealWindows::default(),
                bounds: ClinicianBounds::default(),
                bedtime_min: 22 * 60,
                min_data: MinData::default(),
                advisor: AbbaConfig::new(mode, seed),
                basal_schedule: None,
                pump_steps: None,
                therapy_source: TherapySource::Given,
                allow_closed_loop: false,
                units: GlucoseUnit::MgDl,
            },
        }
    }
}

/// A stored person.
#[derive(Debug, Clone)]
pub struct Person {
    /// Row id.
    pub id: i64,
    /// Name.
    pub name: String,
    /// Zone.
    pub tz: TimeZone,
    /// Day 1, once known.
    pub first_day: Option<Date>,
    /// The rest.
    pub settings: PersonSettingsDoc,
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Cgm => "cgm",
        Mode::Smbg => "smbg",
    }
}

impl Person {
    /// The advisor's mode.
    pub fn mode(&self) -> Mode {
        self.settings.advisor.mode
    }

    /// A fresh advisor for this person (the state before any event).
    pub fn advisor(&self) -> Result<Abba, StoreError> {
        let mut a = Abba::new(self.settings.advisor.clone(), self.settings.start)?
            .with_bounds(self.settings.bounds)?
            .with_min_data(self.settings.min_data);
        if let Some(steps) = self.settings.pump_steps {
            a = a.with_pump_steps(steps)?;
        }
        if let Some(s) = &self.settings.basal_schedule {
            a = a.with_basal_schedule(s.clone())?;
        }
        Ok(a)
    }

    /// What the record → event mapping needs.
    pub fn mapping(&self) -> PersonSettings {
        let mut s = PersonSettings::new(self.tz.clone());
        s.first_day = self.first_day;
        s.meals = self.settings.meal_windows;
        s.day_close = match self.mode() {
            Mode::Cgm => DayClose::Midnight,
            Mode::Smbg => DayClose::Never,
        };
        s
    }
}

/// Longest person name, in characters.
pub const MAX_NAME_CHARS: usize = 200;

/// Characters a name may not hold besides control characters: the ones
/// that reorder or hide text on a screen (bidirectional overrides and
/// isolates, zero-width characters, the byte-order mark).
fn hidden(c: char) -> bool {
    matches!(c, '\u{200B}'..='\u{200F}' | '\u{202A}'..='\u{202E}' | '\u{2060}'..='\u{2069}' | '\u{FEFF}')
}

/// A person's name as stored: trimmed, 1 to [`MAX_NAME_CHARS`] characters,
/// no control character (newlines, tabs, ESC and with it every terminal
/// escape sequence, DEL, C1 controls) and none of the characters that
/// reorder or hide text. The error names the field and the character.
pub fn check_name(name: &str) -> Result<&str, StoreError> {
    let t = name.trim();
    let n = t.chars().count();
    if n == 0 || n > MAX_NAME_CHARS {
        return Err(StoreError::invalid(
            "--name",
            format!("expected 1 to {MAX_NAME_CHARS} characters (spaces at either end do not count), got {n}"),
        ));
    }
    if let Some((i, c)) = t
        .chars()
        .enumerate()
        .find(|(_, c)| c.is_control() || hidden(*c))
    {
        return Err(StoreError::invalid(
            "--name",
            format!(
                "character {} is {}: a name may not hold control characters (newlines, tabs, escape sequences) or characters that reorder or hide text",
                i + 1,
                c.escape_unicode()
            ),
        ));
    }
    Ok(t)
}

/// The name another person already has, compared case-insensitively
/// (Unicode lower case: "Ana", "ANA" and "ana" are one name).
pub fn name_taken(conn: &dyn Db, name: &str) -> Result<Option<String>, StoreError> {
    let key = name.to_lowercase();
    let mut candidates: Vec<String> = Vec::new();
    // The ASCII names that fold to the same (by index: for them the
    // database's lower() is Unicode's); then the names with any other
    // character (a partial index), compared here.
    for r in conn.rows(Q::PersonNamesFolded, args![&key])? {
        candidates.push(r.text(0)?);
    }
    for r in conn.rows(Q::PersonNamesNotAscii, args![])? {
        candidates.push(r.text(0)?);
    }
    Ok(candidates
        .into_iter()
        .find(|other| other.to_lowercase() == key))
}

/// Checks and stores a new person; returns its id.
pub fn create(conn: &dyn Db, p: &NewPerson) -> Result<i64, StoreError> {
    let name = check_name(&p.name)?;
    TimeZone::get(&p.tz).map_err(|e| {
        StoreError::invalid(
            "--tz",
            format!("\"{}\" is not a known IANA zone ({e})", p.tz),
        )
    })?;
    let s = &p.settings;
    s.meal_windows.validate()?;
    if s.bedtime_min >= 1440 {
        return Err(StoreError::invalid(
            "bedtime",
            "expected a minute of the day, 0-1439",
        ));
    }
    check_start(s)?;
    // Builds the advisor once: checks the configuration, the steps, the
    // schedule and that the starting therapy lies inside the bounds.
    let mut a = Abba::new(s.advisor.clone(), s.start)?.with_bounds(s.bounds)?;
    if let Some(steps) = s.pump_steps {
        a = a.with_pump_steps(steps)?;
    }
    if let Some(sch) = &s.basal_schedule {
        a.with_basal_schedule(sch.clone())?;
    }
    if let Some(other) = name_taken(conn, name)? {
        return Err(StoreError::PersonExists(other));
    }
    let doc = serde_json::to_string(s).map_err(|e| StoreError::corrupt("person settings", e))?;
    conn.insert_id(
        Q::PersonPut,
        args![
            name,
            &p.tz,
            mode_name(s.advisor.mode),
            p.first_day.map(|d| d.to_string()),
            doc,
            jiff::Timestamp::now().to_string()
        ],
    )
}

/// Checks the starting therapy and the clinician's bounds against the
/// plausibility limits of [`abba_core::limits`] (the limit is named).
pub fn check_start(s: &PersonSettingsDoc) -> Result<(), StoreError> {
    use abba_core::limits::{BASAL_U_PER_H, CARB_RATIO_G_PER_U};
    BASAL_U_PER_H
        .check(s.start.basal.0)
        .map_err(|e| StoreError::invalid("--basal", e.to_string()))?;
    for (i, cr) in s.start.carb_ratio.iter().enumerate() {
        let slot = ["breakfast", "lunch", "dinner"][i];
        CARB_RATIO_G_PER_U
            .check(cr.0)
            .map_err(|e| StoreError::invalid(format!("--carb-ratio ({slot})"), e.to_string()))?;
    }
    if let Some(sch) = &s.basal_schedule {
        for &(m, r) in sch {
            BASAL_U_PER_H.check(r).map_err(|e| {
                StoreError::invalid(
                    format!("basal schedule (from {:02}:{:02})", m / 60, m % 60),
                    e.to_string(),
                )
            })?;
        }
        let mean = abba_advisor::steps::mean_rate(sch);
        if (mean - s.start.basal.0).abs() > 1e-9 {
            return Err(StoreError::invalid(
                "basal schedule",
                format!(
                    "its mean {mean} U/h differs from the starting basal {} U/h",
                    s.start.basal.0
                ),
            ));
        }
    }
    if let Some(r) = s.bounds.basal {
        BASAL_U_PER_H
            .check_range(r.min, r.max)
            .map_err(|e| StoreError::invalid("--basal-range", e.to_string()))?;
    }
    for r in s.bounds.carb_ratio.iter().flatten() {
        CARB_RATIO_G_PER_U
            .check_range(r.min, r.max)
            .map_err(|e| StoreError::invalid("--carb-ratio-range", e.to_string()))?;
    }
    Ok(())
}

/// Replaces a person's settings document (checked as at creation).
pub fn update_settings(conn: &dyn Db, id: i64, s: &PersonSettingsDoc) -> Result<(), StoreError> {
    check_start(s)?;
    let doc = serde_json::to_string(s).map_err(|e| StoreError::corrupt("person settings", e))?;
    conn.execute(Q::PersonSettingsPut, args![doc, id])?;
    Ok(())
}

/// Looks a person up by name.
pub fn load(conn: &dyn Db, name: &str) -> Result<Person, StoreError> {
    let r = conn
        .row(Q::PersonByName, args![name])?
        .ok_or_else(|| StoreError::NoPerson(name.to_string()))?;
    let (id, tz, first_day, doc) = (r.int(0)?, r.text(1)?, r.opt_text(2)?, r.text(3)?);
    parse(id, name.to_string(), tz, first_day, doc)
}

/// Looks a person up by row id.
pub fn load_by_id(conn: &dyn Db, id: i64) -> Result<Person, StoreError> {
    let r = conn
        .row(Q::PersonById, args![id])?
        .ok_or(StoreError::NoPersonId(id))?;
    let (name, tz, first_day, doc) = (r.text(0)?, r.text(1)?, r.opt_text(2)?, r.text(3)?);
    parse(id, name, tz, first_day, doc)
}

/// Replaces a person's clinician bounds (the starting therapy must lie
/// inside them).
pub fn set_bounds(
    conn: &dyn Db,
    id: i64,
    bounds: abba_advisor::ClinicianBounds,
) -> Result<Person, StoreError> {
    let mut p = load_by_id(conn, id)?;
    p.settings.bounds = bounds;
    Abba::new(p.settings.advisor.clone(), p.settings.start)?.with_bounds(bounds)?;
    let doc = serde_json::to_string(&p.settings)
        .map_err(|e| StoreError::corrupt("person settings", e))?;
    conn.execute(Q::PersonSettingsPut, args![doc, id])?;
    Ok(p)
}

fn parse(
    id: i64,
    name: String,
    tz: String,
    first_day: Option<String>,
    doc: String,
) -> Result<Person, StoreError> {
    let tz = TimeZone::get(&tz).map_err(|e| StoreError::corrupt("person zone", e))?;
    let first_day = first_day
        .map(|d| d.parse::<Date>())
        .transpose()
        .map_err(|e| StoreError::corrupt("person first day", e))?;
    let settings =
        serde_json::from_str(&doc).map_err(|e| StoreError::corrupt("person settings", e))?;
    Ok(Person {
        id,
        name,
        tz,
        first_day,
        settings,
    })
}

/// Sets day 1 (done once, at the first import).
pub fn set_first_day(conn: &dyn Db, id: i64, day: Date) -> Result<(), StoreError> {
    conn.execute(Q::PersonFirstDayPut, args![day.to_string(), id])?;
    Ok(())
}

/// Names of every person in the file.
pub fn names(conn: &dyn Db) -> Result<Vec<String>, StoreError> {
    conn.rows(Q::PersonNames, args![])?
        .into_iter()
        .map(|r| r.text(0))
        .collect()
}
