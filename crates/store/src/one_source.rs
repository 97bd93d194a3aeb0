//! One source per local day for each kind of data: what keeps one pump's
//! insulin from being counted twice when it reaches the log by two routes
//! (a CareLink or Tidepool export beside the same days in Nightscout, a
//! Dexcom Clarity export beside the Dexcom readings Nightscout holds).
//!
//! Two routes never carry one datum alike: the same bolus comes seconds or
//! minutes apart (the pump's clock, an uploader's, a share bridge's), a
//! reading comes as mg/dL from one and rounded mmol/L from the other, and
//! neither carries an identifier the other knows. Matching copies across
//! routes would guess; so, for each kind of data ([`DataClass`]: CGM
//! glucose, meter glucose, insulin delivery, carbohydrate), a local day of the person is
//! held by the first source that brought that kind for that day: the log's,
//! else, within one import, the source of the first file (in the order
//! given) that holds it. Records of that kind from another source on that
//! day are not stored: counted by kind and source, the first named, and
//! said with the import's summary. A day the log already holds from two
//! sources (stored before this rule) is left open to both.
//!
//! Other tools do not merge across routes either: Tidepool deduplicates a
//! later upload of one device against that device's earlier upload
//! sessions (tidepool-org/TidepoolApi, `docs/quick-start/uploading-device-data.md`),
//! and Nightscout merges only documents of the same `identifier`, `_id`,
//! or `created_at` and `eventType` (cgm-remote-monitor,
//! `lib/server/treatments.js`); one device's data reaching either by a
//! second route is kept twice.

use crate::backend::{args, Db, Q};
use crate::error::StoreError;
use abba_io::{Record, RecordKind, Source};
use jiff::civil::Date;
use jiff::tz::TimeZone;
use serde::Serialize;
use std::collections::{BTreeMap, HashMap, HashSet};

/// A kind of data held by one source per day.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DataClass {
    /// CGM readings.
    Glucose,
    /// Meter (finger-stick) readings: a linked meter's reading reaches a
    /// pump's export and Nightscout alike.
    Meter,
    /// Insulin delivery: boluses, extended boluses, temporary basals,
    /// suspends and resumes, long-acting injections.
    Insulin,
    /// Carbohydrate.
    Carbs,
}

impl DataClass {
    /// The kind of data in words.
    pub fn words(self) -> &'static str {
        match self {
            DataClass::Glucose => "CGM glucose",
            DataClass::Meter => "meter glucose",
            DataClass::Insulin => "insulin",
            DataClass::Carbs => "carbohydrate",
        }
    }
    /// The class of a record's kind, if it is held by one source per day.
    pub fn of(kind: &RecordKind) -> Option<DataClass> {
        Self::of_name(kind.name())
    }
    /// The class of a kind by its short name ([`RecordKind::name`], which
    /// is also its stored `type`).
    fn of_name(name: &str) -> Option<DataClass> {
        match name {
            "cgm" => Some(DataClass::Glucose),
            "smbg" => Some(DataClass::Meter),
            "bolus" | "extended_bolus" | "temp_basal" | "suspend" | "resume" | "long_acting" => {
                Some(DataClass::Insulin)
            }
            "carbs" => Some(DataClass::Carbs),
            _ => None,
        }
    }
}

/// Records of a kind not stored because another source holds that kind
/// on their day.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OtherSource {
    /// The kind of data.
    pub class: DataClass,
    /// The source of the records not stored.
    pub source: Source,
    /// The source that holds their days.
    pub held_by: Source,
    /// How many.
    pub count: usize,
    /// The days, first and last (local).
    pub days: (String, String),
    /// The first one's place (file and line or item) and instant.
    pub first: String,
    /// Its instant.
    pub first_at: String,
}

/// The stored `type` of a record's kind, from its JSON text.
fn stored_type(prefix: &str) -> Option<&str> {
    let rest = prefix.strip_prefix("{\"type\":\"")?;
    rest.split('"').next()
}

/// Which source holds each (kind of data, local day) the import touches.
pub struct Holders {
    held: HashMap<(DataClass, Date), Option<Source>>,
}

impl Holders {
    /// The holders of the days `records` fall on: the log's (a day held
    /// by two sources there: none), then, for days the log does not hold,
    /// the source of the first file of the batch holding them.
    pub fn of(
        db: &dyn Db,
        person: i64,
        tz: &TimeZone,
        records: &[&Record],
    ) -> Result<Holders, StoreError> {
        let mut held: HashMap<(DataClass, Date), Option<Source>> = HashMap::new();
        let classes: Vec<(DataClass, Date, &Record)> = records
            .iter()
            .filter_map(|r| DataClass::of(&r.kind).map(|c| (c, tz.to_datetime(r.at).date(), *r)))
            .collect();
        let (Some(from), Some(to)) = (
            classes.iter().map(|c| c.2.at).min(),
            classes.iter().map(|c| c.2.at).max(),
        ) else {
            return Ok(Holders { held });
        };
        // A day of a zone is at most 26 h; a margin of two days each side
        // takes in every stored record of the days touched.
        let margin = 2 * 86_400_000;
        let rows = db.rows(
            Q::RecordSourcesByQuarter,
            args![
                person,
                from.as_millisecond() - margin,
                to.as_millisecond() + margin
            ],
        )?;
        let wanted: HashSet<(DataClass, Date)> = classes.iter().map(|c| (c.0, c.1)).collect();
        let mut stored: HashMap<(DataClass, Date), HashSet<Source>> = HashMap::new();
        for row in rows {
            let (source, prefix, quarter) = (row.text(0)?, row.text(1)?, row.int(2)?);
            let Some(class) = stored_type(&prefix).and_then(DataClass::of_name) else {
                continue;
            };
            let source = crate::log::parse_source(&source)?;
            let at = jiff::Timestamp::from_millisecond(quarter * QUARTER_MS)
                .map_err(|e| StoreError::corrupt("record instant", e))?;
            // Every zone's offset is a whole number of quarter hours: a
            // quarter lies within one local day.
            let day = tz.to_datetime(at).date();
            if wanted.contains(&(class, day)) {
                stored.entry((class, day)).or_default().insert(source);
            }
        }
        for (key, sources) in stored {
            let one = (sources.len() == 1)
                .then(|| sources.into_iter().next())
                .flatten();
            held.insert(key, one);
        }
        let mut by_file: Vec<&(DataClass, Date, &Record)> = classes.iter().collect();
        by_file.sort_by_key(|c| c.2.origin.file);
        for (class, day, r) in by_file {
            held.entry((*class, *day)).or_insert(Some(r.source));
        }
        Ok(Holders { held })
    }

    /// The source holding `r`'s kind of data on its day, when it is not
    /// `r`'s own (then `r` is not stored).
    pub fn other(&self, tz: &TimeZone, r: &Record) -> Option<Source> {
        let class = DataClass::of(&r.kind)?;
        match self.held.get(&(class, tz.to_datetime(r.at).date())) {
            Some(Some(s)) if *s != r.source => Some(*s),
            _ => None,
        }
    }
}

/// Quarter hours, the unit in which the log's sources per day are read.
pub const QUARTER_MS: i64 = 900_000;

/// Counts of records not stored, by (kind, source, holder).
#[derive(Default)]
pub struct NotStored {
    by: BTreeMap<(DataClass, Source, Source), OtherSource>,
}

impl NotStored {
    /// One record `r` (read at `place`) not stored: `held_by` holds its day.
    pub fn note(
        &mut self,
        tz: &TimeZone,
        r: &Record,
        held_by: Source,
        place: impl FnOnce() -> String,
    ) {
        let Some(class) = DataClass::of(&r.kind) else {
            return;
        };
        let day = tz.to_datetime(r.at).date().to_string();
        let e = self
            .by
            .entry((class, r.source, held_by))
            .or_insert_with(|| OtherSource {
                class,
                source: r.source,
                held_by,
                count: 0,
                days: (day.clone(), day.clone()),
                first: place(),
                first_at: r.at.to_string(),
            });
        e.count += 1;
        if day < e.days.0 {
            e.days.0 = day.clone();
        }
        if day > e.days.1 {
            e.days.1 = day;
        }
    }
    /// What was not stored, by kind, source and holder.
    pub fn into_list(self) -> Vec<OtherSource> {
        self.by.into_values().collect()
    }
}

/// A sentence for one [`OtherSource`].
pub fn sentence(o: &OtherSource) -> String {
    let (days, those) = if o.days.0 == o.days.1 {
        (o.days.0.clone(), "that day's")
    } else {
        (format!("{} to {}", o.days.0, o.days.1), "those days'")
    };
    format!(
        "{} {} record{} from {} ({days}) not stored: {those} {} comes from {} (one source per day \
         for each kind of data, so that one pump's doses or one sensor's readings reaching abba \
         by two routes are not counted twice); the first: {} ({}).",
        o.count,
        o.class.words(),
        if o.count == 1 { "" } else { "s" },
        o.source.name(),
        o.class.words(),
        o.held_by.name(),
        o.first,
        o.first_at
    )
}
