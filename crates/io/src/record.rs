//! The normalised record stream: what every reader produces.

use abba_core::{Grams, MgDl, Units, UnitsPerHour};
use serde::{Deserialize, Serialize};

/// Which kind of export a record came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Nightscout API JSON (entries, treatments, profile).
    Nightscout,
    /// Dexcom Clarity CSV export.
    Clarity,
    /// Abbott LibreView CSV export.
    LibreView,
    /// Tidepool JSON export.
    Tidepool,
    /// Plain CSV with named columns (abba's own outputs included).
    PlainCsv,
    /// Medtronic CareLink CSV export.
    CareLink,
}

impl Source {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Source::Nightscout => "nightscout",
            Source::Clarity => "clarity",
            Source::LibreView => "libreview",
            Source::Tidepool => "tidepool",
            Source::PlainCsv => "csv",
            Source::CareLink => "carelink",
        }
    }
}

/// A record's identity: what it is, never where it sat in a file.
///
/// Row numbers and indices (Clarity's `Index`, CareLink's decimal `Index`)
/// restart at 1 in every export and are never identity. A record carries
/// the device's own identifier where the format has one (Nightscout `_id`,
/// Tidepool `id`, Clarity transmitter id and transmitter time); any other
/// record is identified by its content ([`content_id`]: source, instant,
/// kind and values), so that two overlapping exports of one person import
/// to exactly their union.
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SourceId {
    /// The device's or service's own id (Nightscout `_id`, Tidepool `id`,
    /// Clarity `transmitter id:transmitter time:event type`).
    Id(Box<str>),
    /// The record's content (FNV-1a 64 of source, instant and kind, see
    /// [`content_id`]), for records with no id of their own.
    Hash(u64),
}

/// The instant of a record in force "since always" (a Nightscout profile
/// dated at the epoch, Nightscout's default record): the epoch itself.
pub const SINCE_ALWAYS: jiff::Timestamp = jiff::Timestamp::UNIX_EPOCH;

/// The content identity of a record with no id of its own: FNV-1a 64 of
/// its source, its instant (ms) and its kind with every value (as JSON).
/// The same reading in two exports has the same content identity whatever
/// row it sat on.
pub fn content_id(source: Source, at: jiff::Timestamp, kind: &RecordKind) -> SourceId {
    let kind = serde_json::to_string(kind).unwrap_or_default();
    SourceId::Hash(content_hash([
        source.name().as_bytes(),
        at.as_millisecond().to_string().as_bytes(),
        kind.as_bytes(),
    ]))
}

/// Two values of one glucose reading in two exports, one in mg/dL and one
/// in mmol/L (or with other decimals), differ by less than this: one step
/// of 0.1 mmol/L (each rounding moves a value by at most half of its step:
/// 0.05 mmol/L = 0.9 mg/dL and 0.5 mg/dL, and vendors' factors, 18.0 to
/// 18.0182, differ by under 0.4 mg/dL at 22.2 mmol/L).
pub const SAME_READING_MG_DL: f64 = 0.1 * abba_core::units::MG_DL_PER_MMOL_L;

/// Whether a source's exports write glucose in the unit its app shows
/// (Clarity, LibreView, CareLink, a plain CSV), which the person may
/// switch. Nightscout's `sgv` is always mg/dL and Tidepool's values always
/// mmol/L: a document of theirs with another value is another version.
pub fn in_display_unit(source: Source) -> bool {
    !matches!(source, Source::Nightscout | Source::Tidepool)
}

/// Whether two records of one source at one instant are one glucose
/// reading written in two units or roundings: both CGM or both meter, the
/// same censoring, values within [`SAME_READING_MG_DL`], from a source
/// [`in_display_unit`].
pub fn same_reading(a: &Record, b: &RecordKind) -> bool {
    fn reading(kind: &RecordKind) -> Option<(bool, Censor, f64)> {
        match kind {
            RecordKind::Cgm { glucose } => Some((true, glucose.censor, glucose.mg_dl.0)),
            RecordKind::Smbg { glucose } => Some((false, glucose.censor, glucose.mg_dl.0)),
            _ => None,
        }
    }
    match (in_display_unit(a.source), reading(&a.kind), reading(b)) {
        (true, Some((c, s, v)), Some((c2, s2, v2))) => {
            c == c2 && s == s2 && (v - v2).abs() < SAME_READING_MG_DL
        }
        _ => false,
    }
}

/// Where the record was read: the file (an index into the batch's file
/// list) and its line (text formats), array index (JSON formats) or sheet
/// and row (workbooks).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub struct Origin {
    /// Index into [`crate::Batch::files`].
    pub file: u16,
    /// Line (CSV) or item index (JSON).
    pub at: OriginAt,
}

/// Line or JSON item of an [`Origin`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OriginAt {
    /// 1-based line.
    Line(u32),
    /// 0-based index in the file's top-level JSON array.
    Item(u32),
    /// A row of a workbook (Tidepool's Excel export): the sheet, as its
    /// index in [`crate::read::tidepool_xlsx::SHEETS`], and Excel's
    /// 1-based row number.
    Row {
        /// Index of the sheet's layout in `tidepool_xlsx::SHEETS`.
        sheet: u16,
        /// Excel's row number.
        row: u32,
    },
}

/// A glucose value as the device reported it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Glucose {
    /// The value in mg/dL (for a censored reading: the device's limit).
    pub mg_dl: MgDl,
    /// Whether the device reported a value or only "beyond my limit".
    pub censor: Censor,
}

/// Censoring of a glucose reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Censor {
    /// A measured value.
    Exact,
    /// The device said "Low": the true value is below `mg_dl`.
    Below,
    /// The device said "High": the true value is above `mg_dl`.
    Above,
}

impl Glucose {
    /// A measured value.
    pub fn exact(mg_dl: f64) -> Self {
        Self {
            mg_dl: MgDl(mg_dl),
            censor: Censor::Exact,
        }
    }
}

/// A temporary basal's rate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TempRate {
    /// An absolute rate.
    Absolute(UnitsPerHour),
    /// A percentage of the scheduled rate (100 = unchanged).
    Percent(f64),
}

/// A basal schedule: rates from given minutes of the local day.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BasalSchedule {
    /// (minute of local day, rate) pairs, strictly increasing minutes, the
    /// first at minute 0.
    pub segments: Vec<(u32, UnitsPerHour)>,
}

impl BasalSchedule {
    /// One rate all day.
    pub fn flat(rate: UnitsPerHour) -> Self {
        Self {
            segments: vec![(0, rate)],
        }
    }
    /// The rate in force at `minute_of_day`.
    pub fn rate_at(&self, minute_of_day: u32) -> UnitsPerHour {
        let mut rate = self.segments.first().map_or(UnitsPerHour(0.0), |s| s.1);
        for &(from, r) in &self.segments {
            if from <= minute_of_day {
                rate = r;
            }
        }
        rate
    }
}

/// A therapy profile as a pump, Nightscout or a CSV gives it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    /// The basal schedule.
    pub basal: BasalSchedule,
    /// Carb ratios from minutes of the local day (empty when the source has none).
    pub carb_ratio: Vec<(u32, abba_core::GramsPerUnit)>,
    /// The time zone the profile names, if any.
    pub timezone: Option<String>,
    /// A temporary profile (AndroidAPS's Profile Switch with a duration):
    /// in force for this many minutes from the record's instant unless
    /// another profile comes first; then the latest permanent profile
    /// before it is in force again. `None`: permanent (until the next
    /// profile).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temporary_min: Option<u32>,
}

impl Profile {
    /// A profile with only a basal schedule.
    pub fn basal_only(basal: BasalSchedule) -> Self {
        Self {
            basal,
            carb_ratio: Vec::new(),
            timezone: None,
            temporary_min: None,
        }
    }
}

/// What a record says.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum RecordKind {
    /// A CGM reading.
    Cgm {
        /// The reading.
        glucose: Glucose,
    },
    /// A meter (finger-stick) reading.
    Smbg {
        /// The reading.
        glucose: Glucose,
    },
    /// Carbohydrate eaten (or announced).
    Carbs {
        /// Grams.
        grams: Grams,
    },
    /// A normal bolus, delivered at once.
    Bolus {
        /// Insulin.
        units: Units,
    },
    /// An extended (square or dual-wave) bolus.
    ExtendedBolus {
        /// Part delivered at once.
        now: Units,
        /// Part spread over `duration_min`.
        extended: Units,
        /// Minutes over which the extended part runs.
        duration_min: u32,
    },
    /// Long-acting (basal) insulin injected with a pen.
    LongActing {
        /// Insulin.
        units: Units,
    },
    /// A therapy profile (basal schedule, carb ratios) in force from this
    /// instant on.
    Schedule {
        /// The profile (boxed: records stay small).
        profile: Box<Profile>,
    },
    /// A temporary basal rate for `duration_min` minutes.
    TempBasal {
        /// Rate or percentage.
        rate: TempRate,
        /// Minutes.
        duration_min: u32,
    },
    /// Insulin delivery suspended (for `duration_min`, when the source says).
    Suspend {
        /// Minutes, if known.
        duration_min: Option<u32>,
    },
    /// Insulin delivery resumed.
    Resume,
    /// Anything else, counted by kind (calibrations, alerts, sensor starts,
    /// site changes, notes...).
    Ignored {
        /// The source's name for it.
        kind: String,
    },
}

impl RecordKind {
    /// Short name of the kind (for counts).
    pub fn name(&self) -> &'static str {
        match self {
            RecordKind::Cgm { .. } => "cgm",
            RecordKind::Smbg { .. } => "smbg",
            RecordKind::Carbs { .. } => "carbs",
            RecordKind::Bolus { .. } => "bolus",
            RecordKind::ExtendedBolus { .. } => "extended_bolus",
            RecordKind::LongActing { .. } => "long_acting",
            RecordKind::Schedule { .. } => "basal_schedule",
            RecordKind::TempBasal { .. } => "temp_basal",
            RecordKind::Suspend { .. } => "suspend",
            RecordKind::Resume => "resume",
            RecordKind::Ignored { .. } => "ignored",
        }
    }
}

/// One normalised record.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Record {
    /// The instant (UTC).
    #[serde(serialize_with = "crate::time::serialize_instant")]
    pub at: jiff::Timestamp,
    /// What it says.
    pub kind: RecordKind,
    /// Which export it came from.
    pub source: Source,
    /// Its identity there.
    pub id: SourceId,
    /// Where it was read.
    pub origin: Origin,
}

/// The identity of a CSV row's record with no id of its own: its content
/// ([`content_id`]) and, for an ignored row (a note, an alert), also the
/// row's cells other than its row number (`skip`), so that two notes of
/// one minute stay two while a row repeated in a re-export is one.
pub fn row_id<'a>(
    source: Source,
    at: jiff::Timestamp,
    kind: &RecordKind,
    cells: impl Iterator<Item = &'a [u8]>,
    skip: Option<usize>,
) -> SourceId {
    let SourceId::Hash(h) = content_id(source, at, kind) else {
        return content_id(source, at, kind);
    };
    if !matches!(kind, RecordKind::Ignored { .. }) {
        return SourceId::Hash(h);
    }
    let h = h.to_string();
    SourceId::Hash(content_hash(
        std::iter::once(h.as_bytes()).chain(
            cells
                .enumerate()
                .filter(|(i, _)| Some(*i) != skip)
                .map(|(_, c)| c),
        ),
    ))
}

/// FNV-1a 64-bit hash of some byte strings (with a separator), for sources
/// whose rows carry no id.
pub fn content_hash<'a>(parts: impl IntoIterator<Item = &'a [u8]>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for &b in part.iter().chain(std::iter::once(&0x1f)) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_stays_small() {
        // A 10-year CGM file is a million records (BENCHMARKS.md).
        let size = std::mem::size_of::<Record>();
        println!(
            "Record: {size} bytes, RecordKind: {}",
            std::mem::size_of::<RecordKind>()
        );
        assert!(size <= 96, "{size}");
    }
}
