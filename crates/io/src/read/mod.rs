//! Reading exports: format detection, the per-format readers, and merging
//! files into one sorted stream with duplicates removed and counted.

pub mod clarity;
pub mod json;
pub mod libreview;
pub mod libreview_columns;
pub mod nightscout;
pub mod plain;
pub mod table;
pub mod tidepool;

use std::collections::BTreeMap;

use jiff::tz::TimeZone;
use serde::Serialize;

use crate::error::IoError;
use crate::record::{Origin, OriginAt, Record, RecordKind};
use crate::units::GlucoseUnit;

/// The export formats abba reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// Nightscout API JSON (entries, treatments, profile).
    Nightscout,
    /// Dexcom Clarity CSV.
    Clarity,
    /// LibreView CSV.
    LibreView,
    /// Tidepool JSON.
    Tidepool,
    /// Plain CSV with named columns.
    Csv,
}

impl Format {
    /// Reads a format name (`nightscout`, `clarity`, `libreview`,
    /// `tidepool`, `csv`).
    pub fn parse(name: &str) -> Option<Self> {
        match name.to_ascii_lowercase().as_str() {
            "nightscout" => Some(Self::Nightscout),
            "clarity" | "dexcom" => Some(Self::Clarity),
            "libreview" | "libre" => Some(Self::LibreView),
            "tidepool" => Some(Self::Tidepool),
            "csv" => Some(Self::Csv),
            _ => None,
        }
    }
}

/// How to read: what the user said on the command line.
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// The format, if not detected from content.
    pub format: Option<Format>,
    /// Glucose unit for files that do not say (plain CSV); checked against
    /// files that do.
    pub units: Option<GlucoseUnit>,
    /// The person's zone: how wall times without an offset are read.
    pub tz: Option<TimeZone>,
    /// Plain CSV: the time column.
    pub time_column: Option<String>,
    /// Plain CSV: the glucose column.
    pub glucose_column: Option<String>,
    /// Plain CSV: the subject (`id` column) to keep.
    pub subject: Option<String>,
    /// LibreView: day-first or month-first dates, for a file whose dates
    /// do not tell (used only then).
    pub date_order: Option<crate::time::DateOrder>,
}

/// What a reader needs: the file's name and index, and the options.
pub struct Ctx<'a> {
    /// The file as the user named it.
    pub file: &'a str,
    /// Its index in the batch.
    pub index: u16,
    /// The options.
    pub opts: &'a ReadOptions,
}

impl Ctx<'_> {
    /// The origin of a CSV line.
    pub fn origin_line(&self, line: u64) -> Origin {
        Origin {
            file: self.index,
            at: OriginAt::Line(u32::try_from(line).unwrap_or(u32::MAX)),
        }
    }
    /// The origin of a JSON array item.
    pub fn origin_item(&self, index: usize) -> Origin {
        Origin {
            file: self.index,
            at: OriginAt::Item(u32::try_from(index).unwrap_or(u32::MAX)),
        }
    }
    /// The zone for wall times, or an error saying why it is needed.
    pub fn require_tz(&self, why: &str) -> Result<TimeZone, IoError> {
        self.opts.tz.clone().ok_or_else(|| {
            IoError::format(
                self.file,
                format!("{why}: give the person's zone with --tz (for example --tz Europe/Zurich)"),
            )
        })
    }
}

/// Detects the format from the first bytes of the content.
pub fn detect(file: &str, bytes: &[u8]) -> Result<Format, IoError> {
    let text = table::strip_bom(bytes);
    let start = text
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(text.len());
    let head = String::from_utf8_lossy(&text[start..text.len().min(start + 4096)]);
    if head.starts_with('[') || head.starts_with('{') {
        // Tidepool data carry `type` and `time`; Nightscout uses `date`,
        // `created_at`, `eventType`, `sgv`, `store`.
        let tidepool = tidepool::TYPES.iter().any(|t| {
            head.contains(&format!("\"type\": \"{t}\""))
                || head.contains(&format!("\"type\":\"{t}\""))
        }) && head.contains("\"time\"")
            && !head.contains("\"eventType\"")
            && !head.contains("\"sgv\"");
        return Ok(if tidepool {
            Format::Tidepool
        } else {
            Format::Nightscout
        });
    }
    let first = head.lines().next().unwrap_or("");
    if clarity::looks_like(first) {
        return Ok(Format::Clarity);
    }
    if libreview::looks_like(&head) {
        return Ok(Format::LibreView);
    }
    if first.contains(',') || first.contains(';') || first.contains('\t') {
        return Ok(Format::Csv);
    }
    Err(IoError::format(file, "cannot tell the format from the content (expected JSON or CSV with a header); give --format"))
}

/// Reads one file's bytes (named `file`, index `index` in the batch).
pub fn read_bytes(
    file: &str,
    index: u16,
    bytes: &[u8],
    opts: &ReadOptions,
) -> Result<(Format, Vec<Record>), IoError> {
    let decoded = table::utf16_to_utf8(file, bytes)?;
    let bytes = decoded.as_deref().unwrap_or(bytes);
    let format = match opts.format {
        Some(f) => f,
        None => detect(file, bytes)?,
    };
    let bytes = table::strip_bom(bytes);
    let ctx = Ctx { file, index, opts };
    let records = match format {
        Format::Nightscout => nightscout::read(&ctx, bytes)?,
        Format::Clarity => clarity::read(&ctx, bytes)?,
        Format::LibreView => libreview::read(&ctx, bytes)?,
        Format::Tidepool => tidepool::read(&ctx, bytes)?,
        Format::Csv => plain::read(&ctx, bytes)?,
    };
    Ok((format, records))
}

/// Records of several files, merged.
#[derive(Debug, Clone, Serialize)]
pub struct Batch {
    /// The files, as named (a record's `origin.file` indexes this).
    pub files: Vec<String>,
    /// Each file's format.
    pub formats: Vec<Format>,
    /// Records in time order (stable: equal instants keep file order).
    pub records: Vec<Record>,
    /// Records removed as duplicates (same instant, same kind and values,
    /// as when two exports overlap), by kind.
    pub duplicates: BTreeMap<String, usize>,
}

impl Batch {
    /// Where a record was read, for messages (`file: line N` or `file: $[i]`).
    pub fn origin(&self, r: &Record) -> String {
        let file = self
            .files
            .get(usize::from(r.origin.file))
            .map_or("?", String::as_str);
        match r.origin.at {
            OriginAt::Line(n) => format!("{file}: line {n}"),
            OriginAt::Item(i) => format!("{file}: $[{i}]"),
        }
    }
    /// Records of a kind name (see [`crate::RecordKind::name`]).
    pub fn count(&self, kind: &str) -> usize {
        self.records
            .iter()
            .filter(|r| r.kind.name() == kind)
            .count()
    }
}

/// Reads files already in memory (name, bytes) and merges them.
pub fn read_all(inputs: &[(String, Vec<u8>)], opts: &ReadOptions) -> Result<Batch, IoError> {
    if inputs.len() > usize::from(u16::MAX) {
        return Err(IoError::Settings(format!(
            "at most {} files at once",
            u16::MAX
        )));
    }
    let mut records = Vec::new();
    let mut formats = Vec::new();
    for (i, (name, bytes)) in inputs.iter().enumerate() {
        let (format, mut r) = read_bytes(name, i as u16, bytes, opts)?;
        formats.push(format);
        if records.is_empty() {
            records = r; // one file: no copy
        } else {
            records.append(&mut r);
        }
    }
    Ok(merge(
        inputs.iter().map(|(n, _)| n.clone()).collect(),
        formats,
        records,
    ))
}

/// Reads files from disk and merges them.
pub fn read_files(paths: &[std::path::PathBuf], opts: &ReadOptions) -> Result<Batch, IoError> {
    let inputs = paths
        .iter()
        .map(|p| {
            let name = p.display().to_string();
            std::fs::read(p)
                .map(|b| (name.clone(), b))
                .map_err(|source| IoError::Open { file: name, source })
        })
        .collect::<Result<Vec<_>, _>>()?;
    read_all(&inputs, opts)
}

/// Sorts records by instant and removes exact duplicates (same instant,
/// same kind and values; for ignored records also the same identity),
/// counting them. Works in place: a 10-year CGM file is about a million
/// records.
pub fn merge(files: Vec<String>, formats: Vec<Format>, mut records: Vec<Record>) -> Batch {
    if !records.is_sorted_by(|a, b| a.at <= b.at) {
        records.sort_by_key(|r| r.at);
    }
    let mut duplicates: BTreeMap<String, usize> = BTreeMap::new();
    let mut write = 0;
    let mut group_start = 0;
    for read in 0..records.len() {
        if write > 0 && records[write - 1].at != records[read].at {
            group_start = write;
        }
        let r = &records[read];
        let duplicate = records[group_start..write].iter().any(|k| {
            k.kind == r.kind && (!matches!(r.kind, RecordKind::Ignored { .. }) || k.id == r.id)
        });
        if duplicate {
            *duplicates.entry(r.kind.name().to_string()).or_default() += 1;
            continue;
        }
        records.swap(write, read);
        write += 1;
    }
    records.truncate(write);
    Batch {
        files,
        formats,
        records,
        duplicates,
    }
}
