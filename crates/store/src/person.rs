//! Persons: name, zone, mode, meal windows, starting therapy, clinician
//! bounds and the advisor's configuration.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use abba_advisor::{Abba, AbbaConfig, AgeGroup, ClinicianBounds, MinData, Mode, PumpSteps};
use abba_core::units::GlucoseUnit;
use abba_core::TherapySettings;
use abba_io::events::{DayClose, PersonSettings};
use abba_io::meals::MealWindows;
use jiff::civil::Date;
use jiff::tz::TimeZone;
use serde::{Deserialize, Serialize};
use unicode_normalization::UnicodeNormalization;
use unicode_properties::{GeneralCategory, GeneralCategoryGroup, UnicodeGeneralCategory};

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
    /// The person's age group, whose defaults `advisor` holds (set it with
    /// [`PersonSettingsDoc::set_age_group`]); persons stored before it
    /// existed are adults, as they were advised.
    #[serde(default)]
    pub age_group: AgeGroup,
    /// What the reader noted about the export the starting therapy was
    /// read from (`person new --therapy-from`, the clinic's upload: a
    /// temporary profile not taken, a pump's auto-mode days), kept for the
    /// clinic's page.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub therapy_notes: Vec<String>,
}

impl PersonSettingsDoc {
    /// Makes the person one of `group`: records it and applies its
    /// defaults to the advisor's configuration (see [`AgeGroup`]).
    pub fn set_age_group(&mut self, group: AgeGroup) {
        self.age_group = group;
        group.apply(&mut self.advisor);
    }
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
        // The name as it will be stored (see [`check_name`]): trimmed, NFC.
        let name: String = name.trim().nfc().collect();
        let seed = abba_io::record::content_hash([name.as_bytes()]);
        Self {
            name,
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
                age_group: AgeGroup::Adult,
                therapy_notes: Vec::new(),
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
        // The bounds were checked against the value in force when they were
        // set, which may not be the starting therapy.
        let mut a = Abba::new(self.settings.advisor.clone(), self.settings.start)?
            .with_later_bounds(self.settings.bounds)?
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
        s.units = self.settings.units;
        s.day_close = match self.mode() {
            Mode::Cgm => DayClose::Midnight,
            Mode::Smbg => DayClose::Never,
        };
        s
    }
}

/// Longest person name, in characters.
pub const MAX_NAME_CHARS: usize = 200;

/// Why a name may not hold `c`, if it may not.
fn refused(c: char) -> Option<&'static str> {
    use GeneralCategory as G;
    let g = c.general_category();
    Some(if c.is_control() {
        "a name may not hold control characters (newlines, tabs, escape sequences)"
    } else if c != ' '
        && (c.is_whitespace()
            || matches!(
                g,
                G::LineSeparator | G::ParagraphSeparator | G::SpaceSeparator
            ))
    {
        "the only white space a name may hold is the ordinary space (U+0020)"
    } else if g == G::Format || abba_core::text::hidden(c) {
        "a name may not hold characters that show nothing or that reorder or hide text (format characters, variation selectors, tags, fillers, blank signs)"
    } else if g == G::PrivateUse {
        "a name may not hold private-use characters (each screen shows them differently, or not at all)"
    } else if matches!(g, G::Unassigned | G::Surrogate) {
        "a name may not hold characters that Unicode has not assigned (as this abba knows it)"
    } else {
        return None;
    })
}

/// The first character of `text` a name may not hold by its characters
/// alone ([`check_name`]'s control, white space other than the space,
/// format, hidden, private-use and unassigned characters): its place
/// (from 0), the character and why. Also for other names shown on a page
/// (an uploaded file's: a right-to-left override shows `evil\u{202E}gpj.csv`
/// as `evilvsc.jpg`).
pub fn refused_char(text: &str) -> Option<(usize, char, &'static str)> {
    text.chars()
        .enumerate()
        .find_map(|(i, c)| refused(c).map(|why| (i, c, why)))
}

fn invalid_char(i: usize, c: char, why: &str) -> StoreError {
    StoreError::invalid(
        "--name",
        format!("character {} is {}: {why}", i + 1, c.escape_unicode()),
    )
}

/// A person's name as stored: trimmed, in Unicode's composed form (NFC:
/// an "á" typed as "a" and a combining accent is stored as the one
/// character "á"), 1 to [`MAX_NAME_CHARS`] characters. Refused: control
/// characters (newlines, tabs, ESC and with it every terminal escape
/// sequence, DEL, C1 controls); white space other than the ordinary
/// space; format characters (general category Cf: bidirectional marks,
/// overrides and isolates, zero-width characters, the soft hyphen, tags
/// ...), line and paragraph separators (Zl, Zp), private-use (Co),
/// unassigned (Cn) and surrogate (Cs) code points; the default-ignorable
/// and blank characters of [`abba_core::text::hidden`]; a combining mark as the first
/// character; a name without a letter or a digit. The error names the
/// field, the character's place and its code point.
pub fn check_name(name: &str) -> Result<String, StoreError> {
    let t = name.trim();
    let stored: String = t.nfc().collect();
    let n = stored.chars().count();
    if n == 0 || n > MAX_NAME_CHARS {
        return Err(StoreError::invalid(
            "--name",
            format!("expected 1 to {MAX_NAME_CHARS} characters (spaces at either end do not count), got {n}"),
        ));
    }
    // (Places are counted in the name as given, trimmed.)
    if let Some((i, c, why)) = refused_char(t) {
        return Err(invalid_char(i, c, why));
    }
    if let Some(c) = t
        .chars()
        .next()
        .filter(|c| c.general_category_group() == GeneralCategoryGroup::Mark)
    {
        return Err(invalid_char(
            0,
            c,
            "a name may not start with a combining mark (it would sit on whatever is shown before the name)",
        ));
    }
    if !t.chars().any(|c| {
        matches!(
            c.general_category_group(),
            GeneralCategoryGroup::Letter | GeneralCategoryGroup::Number
        )
    }) {
        return Err(StoreError::invalid(
            "--name",
            "a name must hold at least one letter or digit",
        ));
    }
    Ok(stored)
}

/// What a name looks like, as two keys: names with an equal key look
/// alike on a screen. Both are confusable skeletons (Unicode Technical
/// Standard #39: look-alike characters of every script mapped to one
/// prototype, default-ignorable characters dropped) of the name's NFKC
/// form (fullwidth and other compatibility forms as the plain letter),
/// with runs of spaces as one (a web page shows them so): `folded` of the
/// case-folded form (Cyrillic "аna", fullwidth "ＡＮＡ" and "ana" are one),
/// `cased` of the form as written (capital "I" and small "l" are one,
/// which case folding would tell apart).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NameLooks {
    /// The skeleton of the case-folded NFKC form.
    pub folded: String,
    /// The skeleton of the NFKC form.
    pub cased: String,
}

/// The keys of what `name` looks like (see [`NameLooks`]).
pub fn name_looks(name: &str) -> NameLooks {
    fn one_space(s: impl Iterator<Item = char>) -> String {
        let mut out = String::new();
        for c in s {
            if !(c == ' ' && out.ends_with(' ')) {
                out.push(c);
            }
        }
        out.trim().to_string()
    }
    let nfkc: String = name.nfkc().collect();
    let folded: String = caseless::default_case_fold_str(&nfkc).nfkc().collect();
    NameLooks {
        folded: one_space(unicode_security::skeleton(&folded)),
        cased: one_space(unicode_security::skeleton(&nfkc)),
    }
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

/// The name of a person whose name looks like one with keys `looks` (the
/// oldest such person), by the indexes of the keys.
pub fn name_look_alike(conn: &dyn Db, looks: &NameLooks) -> Result<Option<String>, StoreError> {
    conn.row(Q::PersonNameLookAlike, args![&looks.folded, &looks.cased])?
        .map(|r| r.text(0))
        .transpose()
}

/// Schema step 9 ([`crate::schema::Step::NameLooks`]): the keys of what
/// each stored name looks like. Persons whose names already look alike
/// are kept as they are (only new names are refused).
pub fn fill_name_looks(conn: &dyn Db) -> Result<(), StoreError> {
    for r in conn.rows(Q::PersonIdsAndNames, args![])? {
        let (id, name) = (r.int(0)?, r.text(1)?);
        let looks = name_looks(&name);
        conn.execute(Q::PersonNameLooksPut, args![looks.folded, looks.cased, id])?;
    }
    Ok(())
}

/// Checks a given day 1 in the person's zone `tz` at `now`: from
/// [`abba_io::read::RECORDS_FROM_DATE`] (1990-01-01: no sensor or pump
/// logged data before, and imports refuse such records) to tomorrow in the
/// person's zone (a person may be created the evening before they start).
/// A day 1 outside could never receive data. The error says the range
/// (the caller names the field).
pub fn check_first_day(day: Date, tz: &TimeZone, now: jiff::Timestamp) -> Result<(), String> {
    let today = tz.to_datetime(now).date();
    let last = today.tomorrow().unwrap_or(today);
    let first = abba_io::read::RECORDS_FROM_DATE;
    if day < first || day > last {
        return Err(format!(
            "expected a date from {first} (no glucose sensor or insulin pump logged data before) to {last} (tomorrow in {}), got {day}",
            tz.iana_name().unwrap_or("the person's zone")
        ));
    }
    Ok(())
}

/// Checks and stores a new person; returns its id.
pub fn create(conn: &dyn Db, p: &NewPerson) -> Result<i64, StoreError> {
    let name = check_name(&p.name)?;
    let tz = TimeZone::get(&p.tz).map_err(|e| {
        StoreError::invalid(
            "--tz",
            format!("\"{}\" is not a known IANA zone ({e})", p.tz),
        )
    })?;
    // tzdata's "Factory" is the zone of a machine not yet set up (local
    // time unknown), never a person's.
    if p.tz.trim().eq_ignore_ascii_case("factory") {
        return Err(StoreError::invalid(
            "--tz",
            "\"Factory\" is tzdata's zone for a machine whose zone is not set, not a place: give the person's zone, for example Europe/Zurich",
        ));
    }
    // Stored as the database spells it ("europe/zurich" is Europe/Zurich).
    let zone_name = tz.iana_name().unwrap_or(p.tz.as_str()).to_string();
    if let Some(day) = p.first_day {
        check_first_day(day, &tz, jiff::Timestamp::now())
            .map_err(|m| StoreError::invalid("--first-day", m))?;
    }
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
        s.bounds.check_steps(steps)?;
        a = a.with_pump_steps(steps)?;
    }
    if let Some(sch) = &s.basal_schedule {
        a.with_basal_schedule(sch.clone())?;
    }
    // Both checks and the insert are one write transaction of the
    // caller's (the store's write lock held on either backend): two
    // creations never both pass.
    if let Some(other) = name_taken(conn, &name)? {
        return Err(StoreError::PersonExists(other));
    }
    let looks = name_looks(&name);
    if let Some(existing) = name_look_alike(conn, &looks)? {
        return Err(StoreError::PersonLookAlike { name, existing });
    }
    let doc = serde_json::to_string(s).map_err(|e| StoreError::corrupt("person settings", e))?;
    conn.insert_id(
        Q::PersonPut,
        args![
            &name,
            &zone_name,
            mode_name(s.advisor.mode),
            p.first_day.map(|d| d.to_string()),
            doc,
            jiff::Timestamp::now().to_string(),
            looks.folded,
            looks.cased
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

/// Looks a person up by name: as given, else in its composed form (NFC,
/// as names are stored since schema step 9: an "á" typed as "a" and a
/// combining accent finds "á").
pub fn load(conn: &dyn Db, name: &str) -> Result<Person, StoreError> {
    let mut found = conn
        .row(Q::PersonByName, args![name])?
        .map(|r| (name.to_string(), r));
    if found.is_none() {
        let nfc: String = name.nfc().collect();
        if nfc != name {
            found = conn.row(Q::PersonByName, args![&nfc])?.map(|r| (nfc, r));
        }
    }
    let (name, r) = found.ok_or_else(|| StoreError::NoPerson(name.to_string()))?;
    let (id, tz, first_day, doc) = (r.int(0)?, r.text(1)?, r.opt_text(2)?, r.text(3)?);
    parse(id, name, tz, first_day, doc)
}

/// Looks a person up by row id.
pub fn load_by_id(conn: &dyn Db, id: i64) -> Result<Person, StoreError> {
    let r = conn
        .row(Q::PersonById, args![id])?
        .ok_or(StoreError::NoPersonId(id))?;
    let (name, tz, first_day, doc) = (r.text(0)?, r.text(1)?, r.opt_text(2)?, r.text(3)?);
    parse(id, name, tz, first_day, doc)
}

/// Replaces a person's clinician bounds: each setting's value in force now
/// (`in_force`, after the clinician's changes and the answers) must lie
/// inside them.
pub fn set_bounds(
    conn: &dyn Db,
    id: i64,
    bounds: abba_advisor::ClinicianBounds,
    in_force: impl Fn(abba_advisor::Parameter) -> f64,
) -> Result<Person, StoreError> {
    let mut p = load_by_id(conn, id)?;
    p.settings.bounds = bounds;
    bounds.validate()?;
    if let Some(steps) = p.settings.pump_steps {
        bounds.check_steps(steps)?;
    }
    bounds.check_in_force(in_force)?;
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
