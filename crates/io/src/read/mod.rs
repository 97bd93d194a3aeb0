//! Reading exports: format detection, the per-format readers, and merging
//! files into one sorted stream with duplicates removed and counted.

pub mod carelink;
pub mod carelink_clock;
pub mod clarity;
pub mod json;
pub mod libreview;
pub mod libreview_clock;
pub mod libreview_columns;
pub mod libreview_devices;
pub mod nightscout;
pub mod plain;
pub mod pump_identity;
pub mod table;
pub mod tidepool;
pub mod tidepool_xlsx;

use std::collections::BTreeMap;

use jiff::tz::TimeZone;
use serde::Serialize;

use crate::error::IoError;
use crate::record::{Origin, OriginAt, Record, RecordKind, Source, SourceId};
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
    /// Tidepool's Excel export (.xlsx).
    TidepoolXlsx,
    /// Plain CSV with named columns.
    Csv,
    /// Medtronic CareLink CSV.
    CareLink,
}

impl Format {
    /// Reads a format name (`nightscout`, `clarity`, `libreview`,
    /// `tidepool`, `tidepool-xlsx`, `csv`, `carelink`). `tidepool` also
    /// reads Tidepool's workbook when the file is one.
    pub fn parse(name: &str) -> Option<Self> {
        match name.to_ascii_lowercase().as_str() {
            "nightscout" => Some(Self::Nightscout),
            "clarity" | "dexcom" => Some(Self::Clarity),
            "libreview" | "libre" => Some(Self::LibreView),
            "tidepool" => Some(Self::Tidepool),
            "tidepool-xlsx" | "tidepool_xlsx" => Some(Self::TidepoolXlsx),
            "csv" => Some(Self::Csv),
            "carelink" | "medtronic" => Some(Self::CareLink),
            _ => None,
        }
    }
}

impl Format {
    /// The name `--format` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Nightscout => "nightscout",
            Self::Clarity => "clarity",
            Self::LibreView => "libreview",
            Self::Tidepool => "tidepool",
            Self::TidepoolXlsx => "tidepool-xlsx",
            Self::Csv => "csv",
            Self::CareLink => "carelink",
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
    /// CareLink: grams of carbohydrate in one exchange, for a pump whose
    /// wizard counts in exchanges (10 for the Spanish ración; 12 and 15
    /// are used elsewhere). Without it such carbohydrate is not read (the
    /// file's notes say so).
    pub grams_per_exchange: Option<f64>,
}

/// The grams of carbohydrate in one exchange abba accepts (the Spanish
/// ración is 10 g; 12 and 15 g are used elsewhere).
pub const GRAMS_PER_EXCHANGE: std::ops::RangeInclusive<f64> = 5.0..=25.0;

/// Checks a given grams-per-exchange ([`ReadOptions::grams_per_exchange`]);
/// the error says what is expected (the caller names the field).
pub fn check_grams_per_exchange(g: f64) -> Result<f64, String> {
    if GRAMS_PER_EXCHANGE.contains(&g) {
        Ok(g)
    } else {
        Err(format!(
            "expected the grams of carbohydrate in one exchange, {} to {} (10 for the Spanish raci\u{f3}n), got {g}",
            GRAMS_PER_EXCHANGE.start(),
            GRAMS_PER_EXCHANGE.end()
        ))
    }
}

/// What a reader needs: the file's name and index, and the options.
pub struct Ctx<'a> {
    /// The file as the user named it.
    pub file: &'a str,
    /// Its index in the batch.
    pub index: u16,
    /// The options.
    pub opts: &'a ReadOptions,
    /// What the reader reports about the file without refusing it (a
    /// stretch placed by the transmitter's clock, repeats kept once).
    pub notes: std::cell::RefCell<Vec<String>>,
    /// Rows and items that could not be read ([`Ctx::skip`]).
    pub skipped: std::cell::RefCell<Skipped>,
    /// The device's UTC offsets the file carries, with their instants
    /// ([`Ctx::clock`], [`crate::clocks`]).
    pub clocks: std::cell::RefCell<Vec<(jiff::Timestamp, i32)>>,
    /// The Nightscout profile stores of the whole batch (every file's),
    /// in which a Profile Switch that only names its profile is looked up
    /// ([`nightscout::ProfileStore`]); empty on a first read.
    pub stores: &'a [nightscout::ProfileStore],
    /// The profile stores this file holds (read by the Nightscout reader).
    pub found_stores: std::cell::RefCell<Vec<nightscout::ProfileStore>>,
    /// Whether this file holds a Profile Switch that only names its
    /// profile and no store was given to look it up in: [`read_all`]
    /// reads it again with the batch's stores.
    pub wants_stores: std::cell::Cell<bool>,
    /// The pump identities of the file's doses, by JSON item
    /// ([`pump_identity`]; the Nightscout reader's).
    pub pump_identities: std::cell::RefCell<Vec<(u32, pump_identity::PumpIdentity)>>,
}

/// The rows or items of a file that could not be read: left out, the rest
/// of the file read ([`Ctx::skip`], [`or_skip!`]).
#[derive(Debug, Default)]
pub struct Skipped {
    /// How many.
    pub count: usize,
    /// The first few errors, in file order.
    pub first: Vec<IoError>,
}

/// How many of the skipped rows' errors a note quotes.
const SKIPPED_QUOTED: usize = 3;

/// In a reader's loop over rows or items: the value of `$e`, or, when it
/// is an error about that row or item ([`IoError::Invalid`]), the row is
/// left out and reported ([`Ctx::skip`]) and the loop goes on with the
/// next; any other error ends the read.
macro_rules! or_skip {
    ($ctx:expr, $e:expr) => {
        match $e {
            Ok(v) => v,
            Err(e) => {
                $ctx.skip(e)?;
                continue;
            }
        }
    };
}
pub(crate) use or_skip;

impl Ctx<'_> {
    /// Reports something about the file (see [`Ctx::notes`]).
    pub fn note(&self, text: impl Into<String>) {
        self.notes
            .borrow_mut()
            .push(format!("{}: {}", self.file, text.into()));
    }
    /// A datum at `at` written by a device at `offset_s` seconds east of
    /// UTC (see [`crate::clocks`]).
    pub fn clock(&self, at: jiff::Timestamp, offset_s: i32) {
        self.clocks.borrow_mut().push((at, offset_s));
    }
    /// One row or item that could not be read: an error about it alone
    /// ([`IoError::Invalid`]) is kept for the file's report and the row is
    /// left out (one odd row does not cost the rest of the file; a file of
    /// which no row could be read is refused with the first error, see
    /// [`read_bytes_noted`]). Any other error is the file's: returned.
    pub fn skip(&self, e: IoError) -> Result<(), IoError> {
        if !matches!(e, IoError::Invalid { .. }) {
            return Err(e);
        }
        let mut s = self.skipped.borrow_mut();
        s.count += 1;
        if s.first.len() < SKIPPED_QUOTED {
            s.first.push(e);
        }
        Ok(())
    }
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

/// Detects the format from the first bytes of the content (a workbook:
/// from its sheets).
pub fn detect(file: &str, bytes: &[u8]) -> Result<Format, IoError> {
    if tidepool_xlsx::is_zip(bytes) {
        tidepool_xlsx::check(file, bytes)?;
        return Ok(Format::TidepoolXlsx);
    }
    let text = table::strip_bom(bytes);
    let start = text
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(text.len());
    let raw_head = &text[start..text.len().min(start + 4096)];
    if let Some(what) = not_text(raw_head) {
        return Err(IoError::format(
            file,
            format!(
                "{what}, not a data export: abba reads CSV, TSV or JSON exports and Excel \
                 workbooks (.xlsx); export the data again as one of those"
            ),
        ));
    }
    let head = String::from_utf8_lossy(raw_head);
    if head.starts_with('[') || head.starts_with('{') {
        // Tidepool data carry `type` and `time`; Nightscout uses `date`,
        // `created_at`, `eventType`, `sgv`, `store`. The first item's own
        // keys decide when it can be read whole (a Tidepool export may
        // open with a `pumpSettings` whose history runs over many KB before
        // its `type`); else the first 4 KB's text.
        let tidepool = match first_json_item(&text[start..]) {
            Some(item) => {
                let kind = item.get("type").and_then(|t| t.as_str());
                kind.is_some_and(|k| tidepool::TYPES.contains(&k))
                    && item.contains_key("time")
                    && !item.contains_key("eventType")
                    && !item.contains_key("sgv")
            }
            None => {
                tidepool::TYPES.iter().any(|t| {
                    head.contains(&format!("\"type\": \"{t}\""))
                        || head.contains(&format!("\"type\":\"{t}\""))
                }) && head.contains("\"time\"")
                    && !head.contains("\"eventType\"")
                    && !head.contains("\"sgv\"")
            }
        };
        return Ok(if tidepool {
            Format::Tidepool
        } else {
            Format::Nightscout
        });
    }
    let first = head.lines().next().unwrap_or("");
    if carelink::looks_like(&head) || carelink::looks_like_personal(&head) {
        // (the older Personal layout is refused by the CareLink reader,
        // with its name)
        return Ok(Format::CareLink);
    }
    if let Some(header) = carelink::other_language_header(&head) {
        let shown: String = header.chars().take(160).collect();
        return Err(IoError::format(
            file,
            format!(
                "a Medtronic CareLink export whose columns are not in English (its header: \"{shown}\"); \
                 abba reads CareLink's English column names: set CareLink's language to English, \
                 export again and import that file"
            ),
        ));
    }
    if clarity::looks_like(first) {
        return Ok(Format::Clarity);
    }
    if libreview::looks_like(&head) {
        return Ok(Format::LibreView);
    }
    if nightscout::looks_like_csv(first) {
        return Ok(Format::Nightscout);
    }
    if first.contains(',') || first.contains(';') || first.contains('\t') {
        return Ok(Format::Csv);
    }
    Err(IoError::format(file, "cannot tell the format from the content (expected JSON or CSV with a header); give --format"))
}

/// What a file's first bytes show it is when it is no text at all (a
/// PDF, or binary data: a NUL byte, which no text export holds once a
/// UTF-16 one is decoded), so that its bytes are never shown as column
/// names; `None` for text.
fn not_text(head: &[u8]) -> Option<&'static str> {
    if head.starts_with(b"%PDF-") {
        Some("a PDF document (a printed report)")
    } else if head.contains(&0) {
        Some("binary data (or UTF-16 text without its byte-order mark)")
    } else {
        None
    }
}

/// The first item of a JSON array (or the object itself), when it is an
/// object that ends within its first MiB; `None` otherwise (the caller
/// then reads the text). Only that item is parsed: a scan for where it
/// ends (braces outside strings), then serde_json on those bytes.
fn first_json_item(json: &[u8]) -> Option<serde_json::Map<String, serde_json::Value>> {
    const LIMIT: usize = 1 << 20;
    let skip_ws = |from: usize| {
        json[from..]
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .map(|k| from + k)
    };
    let at = skip_ws(0)?;
    let open = match json[at] {
        b'[' => skip_ws(at + 1)?,
        b'{' => at,
        _ => return None,
    };
    if json[open] != b'{' {
        return None;
    }
    let (mut depth, mut in_string, mut escaped) = (0usize, false, false);
    for (k, &b) in json[open..].iter().enumerate().take(LIMIT) {
        if in_string {
            match b {
                _ if escaped => escaped = false,
                b'\\' => escaped = true,
                b'"' => in_string = false,
                _ => {}
            }
            continue;
        }
        match b {
            b'"' => in_string = true,
            b'{' | b'[' => depth += 1,
            b'}' | b']' => {
                depth = depth.checked_sub(1)?;
                if depth == 0 {
                    return serde_json::from_slice(&json[open..=open + k]).ok();
                }
            }
            _ => {}
        }
    }
    None
}

/// Reads one file's bytes (named `file`, index `index` in the batch).
pub fn read_bytes(
    file: &str,
    index: u16,
    bytes: &[u8],
    opts: &ReadOptions,
) -> Result<(Format, Vec<Record>), IoError> {
    read_bytes_noted(file, index, bytes, opts).map(|f| (f.format, f.records))
}

/// One file as read: its format, records, the reader's notes and the rows
/// or items left out.
pub struct FileRead {
    /// The format.
    pub format: Format,
    /// The records.
    pub records: Vec<Record>,
    /// The reader's notes on the file.
    pub notes: Vec<String>,
    /// Rows or items that could not be read (left out, reported in a note).
    pub unread: Unread,
    /// The device's UTC offsets the file carries ([`crate::clocks`]).
    pub clocks: Vec<crate::clocks::ClockStretch>,
    /// The Nightscout profile stores the file holds.
    pub stores: Vec<nightscout::ProfileStore>,
    /// Whether the file names profiles of a store it was not given
    /// ([`Ctx::wants_stores`]).
    pub wants_stores: bool,
    /// The pump identities of its doses, by JSON item ([`Ctx::pump_identities`]).
    pub pump_identities: Vec<(u32, pump_identity::PumpIdentity)>,
}

/// Rows or items of the files that could not be read and were left out
/// (each reported in its file's note): how many, and the first errors.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Unread {
    /// How many.
    pub count: usize,
    /// The first few errors (naming file, line or JSON path, and field).
    pub first: Vec<String>,
}

/// Like [`read_bytes`], with the reader's notes on the file and the rows
/// left out.
pub fn read_bytes_noted(
    file: &str,
    index: u16,
    bytes: &[u8],
    opts: &ReadOptions,
) -> Result<FileRead, IoError> {
    read_bytes_with_stores(file, index, bytes, opts, &[])
}

/// [`read_bytes_noted`] with the batch's Nightscout profile stores, in
/// which a Profile Switch that only names its profile is looked up.
pub fn read_bytes_with_stores(
    file: &str,
    index: u16,
    bytes: &[u8],
    opts: &ReadOptions,
    stores: &[nightscout::ProfileStore],
) -> Result<FileRead, IoError> {
    let ctx = Ctx {
        file,
        index,
        opts,
        notes: Default::default(),
        skipped: Default::default(),
        clocks: Default::default(),
        stores,
        found_stores: Default::default(),
        wants_stores: Default::default(),
        pump_identities: Default::default(),
    };
    // A workbook (a zip) is binary: no text decoding.
    if tidepool_xlsx::is_zip(bytes) {
        let format = workbook_format(file, bytes, opts.format)?;
        let records = tidepool::read_xlsx(&ctx, bytes)?;
        let (records, unread) = skipped_rows(&ctx, records)?;
        return Ok(FileRead {
            format,
            records,
            notes: ctx.notes.into_inner(),
            unread,
            clocks: crate::clocks::stretches(ctx.clocks.into_inner()),
            stores: ctx.found_stores.into_inner(),
            wants_stores: ctx.wants_stores.get(),
            pump_identities: ctx.pump_identities.into_inner(),
        });
    }
    let decoded = decode_text(&ctx, bytes)?;
    let bytes = decoded.as_deref().unwrap_or(bytes);
    let format = match opts.format {
        Some(Format::TidepoolXlsx) => {
            return Err(IoError::format(
                file,
                "given as tidepool-xlsx but not an Excel workbook (.xlsx is a zip archive)",
            ))
        }
        Some(f) => f,
        None => detect(file, bytes)?,
    };
    let bytes = table::strip_bom(bytes);
    let bytes = whole_lines(&ctx, format, bytes)?;
    let records = match format {
        Format::Nightscout => nightscout::read(&ctx, bytes)?,
        Format::Clarity => clarity::read(&ctx, bytes)?,
        Format::LibreView => libreview::read(&ctx, bytes)?,
        Format::Tidepool => tidepool::read(&ctx, bytes)?,
        Format::TidepoolXlsx => tidepool::read_xlsx(&ctx, bytes)?,
        Format::Csv => plain::read(&ctx, bytes)?,
        Format::CareLink => carelink::read(&ctx, bytes)?,
    };
    let (records, unread) = skipped_rows(&ctx, records)?;
    Ok(FileRead {
        format,
        records,
        notes: ctx.notes.into_inner(),
        unread,
        clocks: crate::clocks::stretches(ctx.clocks.into_inner()),
        stores: ctx.found_stores.into_inner(),
        wants_stores: ctx.wants_stores.get(),
        pump_identities: ctx.pump_identities.into_inner(),
    })
}

/// A text file's bytes as UTF-8, when they are not: UTF-16 (with its
/// byte-order mark) decoded, or a file that is not UTF-8 read as
/// Windows-1252 with a note saying so ([`table::windows_1252_to_utf8`]).
fn decode_text(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Option<Vec<u8>>, IoError> {
    if let Some(utf8) = table::utf16_to_utf8(ctx.file, bytes)? {
        return Ok(Some(utf8));
    }
    let decoded = table::windows_1252_to_utf8(bytes);
    if decoded.is_some() {
        ctx.note(
            "not UTF-8 text: read as Windows-1252 (Western European, the encoding Windows \
             programs save CSV in); only letters in names and notes depend on it",
        );
    }
    Ok(decoded)
}

/// A CSV file's bytes without a last line the file ends within (cut
/// short: see [`table::CutLine`]), which is reported as a row not read;
/// JSON is left whole (its parser tells where it ends early).
fn whole_lines<'b>(ctx: &Ctx<'_>, format: Format, bytes: &'b [u8]) -> Result<&'b [u8], IoError> {
    let json = bytes
        .iter()
        .find(|b| !b.is_ascii_whitespace())
        .is_some_and(|&b| b == b'[' || b == b'{');
    if matches!(format, Format::Tidepool | Format::TidepoolXlsx) || json {
        return Ok(bytes);
    }
    match table::cut_last_line(bytes) {
        Some(cut) => {
            ctx.skip(cut.error(ctx.file))?;
            Ok(&bytes[..cut.start])
        }
        None => Ok(bytes),
    }
}

/// The reader's records when some rows or items could not be read
/// ([`Ctx::skip`]): a note names how many and quotes the first errors; a
/// file of which nothing could be read is refused with its first error
/// (the layout, the unit or the format is likely not what abba took it
/// for).
fn skipped_rows(ctx: &Ctx<'_>, records: Vec<Record>) -> Result<(Vec<Record>, Unread), IoError> {
    let mut skipped = ctx.skipped.take();
    if skipped.count == 0 {
        return Ok((records, Unread::default()));
    }
    if records.is_empty() {
        return Err(skipped.first.remove(0));
    }
    let quoted: Vec<String> = skipped.first.iter().map(ToString::to_string).collect();
    let more = if skipped.count > quoted.len() {
        format!("; and {} more", skipped.count - quoted.len())
    } else {
        String::new()
    };
    let (n, what, them) = match skipped.count {
        1 => ("1 row or item".to_string(), "it was", "it"),
        n => (format!("{n} rows or items"), "they were", "them"),
    };
    ctx.note(format!(
        "{n} could not be read: {what} left out and the rest of the file read (fix the file and \
         import it again to add {them}): {}{more}",
        quoted.join("; ")
    ));
    Ok((
        records,
        Unread {
            count: skipped.count,
            first: quoted,
        },
    ))
}

/// The format of a workbook (a zip): Tidepool's Excel export, whether
/// detected or given as `tidepool` or `tidepool-xlsx`; another format
/// given for a workbook is refused by name.
fn workbook_format(file: &str, bytes: &[u8], given: Option<Format>) -> Result<Format, IoError> {
    match given {
        None | Some(Format::Tidepool | Format::TidepoolXlsx) => {
            tidepool_xlsx::check(file, bytes)?;
            Ok(Format::TidepoolXlsx)
        }
        Some(other) => Err(IoError::format(
            file,
            format!(
                "an Excel workbook (.xlsx), given as {}: abba reads no workbook but Tidepool's export; give the CSV or JSON that site exports",
                other.name()
            ),
        )),
    }
}

/// The rows of one CareLink file that say what the pump's settings are
/// (decoded as [`read_bytes`] decodes; `opts.tz` is needed).
pub fn carelink_settings_rows(
    file: &str,
    bytes: &[u8],
    opts: &ReadOptions,
) -> Result<carelink::SettingsRows, IoError> {
    let (settings, skipped) = carelink_rows(file, bytes, opts)?;
    // The therapy is not taken from a file read in part: a row left out
    // may be the setting itself.
    if let Some(e) = skipped.first.into_iter().next() {
        return Err(e);
    }
    Ok(settings)
}

/// The rows of one CareLink file that say what the pump's settings are,
/// its rows that could not be read left out (their lines are those
/// [`carelink::AutoMode::marks`] would not find dated): the instants the
/// reader gives its records, clock corrections and daylight-saving days
/// placed as theirs are.
pub fn carelink_rows_read(
    file: &str,
    bytes: &[u8],
    opts: &ReadOptions,
) -> Result<carelink::SettingsRows, IoError> {
    carelink_rows(file, bytes, opts).map(|(s, _)| s)
}

fn carelink_rows(
    file: &str,
    bytes: &[u8],
    opts: &ReadOptions,
) -> Result<(carelink::SettingsRows, Skipped), IoError> {
    let ctx = Ctx {
        file,
        index: 0,
        opts,
        notes: Default::default(),
        skipped: Default::default(),
        clocks: Default::default(),
        stores: &[],
        found_stores: Default::default(),
        wants_stores: Default::default(),
        pump_identities: Default::default(),
    };
    let decoded = decode_text(&ctx, bytes)?;
    let bytes = table::strip_bom(decoded.as_deref().unwrap_or(bytes));
    let bytes = whole_lines(&ctx, Format::CareLink, bytes)?;
    let (_, settings) = carelink::read_with_settings(&ctx, bytes)?;
    Ok((settings, ctx.skipped.take()))
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
    /// as when two exports overlap or a row is repeated; a glucose reading
    /// of two files of one source within
    /// [`crate::record::SAME_READING_MG_DL`], the files in two units), by
    /// kind.
    pub duplicates: BTreeMap<String, usize>,
    /// Older versions of a record whose id came again with other content
    /// (Nightscout documents AndroidAPS rewrites): the latest version is
    /// kept, these are removed.
    pub older_versions: usize,
    /// Readings and doses carried twice by two uploads seconds apart
    /// (Tidepool's pump and Apple Health uploads; two Nightscout uploaders
    /// of one sensor): one is kept (see [`twice_window_ms`]).
    pub cross_upload: BTreeMap<String, usize>,
    /// Records read from each file (before merging), in file order.
    pub per_file: Vec<usize>,
    /// What the readers reported without refusing (stretches placed by a
    /// transmitter's clock, repeats kept once), each starting with its file.
    pub notes: Vec<String>,
    /// Records dated before [`RECORDS_FROM`] (they cannot be true in a
    /// person's log): taken out of `records` by [`Batch::refuse_too_old`],
    /// which the store's import calls, counted with the first one's place,
    /// never used. (The readers keep them: `abba metrics` and `abba
    /// events` read simulated output, whose minute 0 is the epoch.)
    #[serde(default)]
    pub too_old: Refused,
    /// Rows or items that could not be read and were left out, the rest of
    /// their files read (each file's note says so).
    #[serde(default)]
    pub unread: Unread,
    /// Per file (in file order; empty for a batch made otherwise): the
    /// device's UTC offsets it carries ([`crate::clocks`]), compared with
    /// the person's zone by the store's import.
    #[serde(default)]
    pub clocks: Vec<Vec<crate::clocks::ClockStretch>>,
    /// The pump identities of the batch's Nightscout doses (AndroidAPS's
    /// `pumpType`, `pumpSerial`, `pumpId`), by the record's file and JSON
    /// item ([`pump_identity`], [`Batch::pump_identity`]).
    #[serde(skip)]
    pub pump_identities: BTreeMap<(u16, u32), pump_identity::PumpIdentity>,
}

/// How far apart (seconds) two Tidepool data of the same kind and value
/// may be and still be one datum uploaded twice (a pump upload and Apple
/// Health carry the same bolus or reading with clocks seconds apart).
pub const CROSS_UPLOAD_WINDOW_S: i64 = 60;

/// How far apart (seconds) two Nightscout CGM readings of the same value,
/// from two documents, may be and still be one reading uploaded twice:
/// two uploaders of one sensor (Loop and Nightscout's Dexcom bridge, the
/// Dexcom app on a phone and on a watch through Share, xDrip+ beside
/// Juggluco or AndroidAPS) each write it with their own clock, seconds
/// apart (Dexcom Share's two copies come about 10 s apart). No CGM reads
/// more often than once a minute (the FreeStyle Libre 3), so two readings
/// less than 30 s apart are never two readings.
pub const NIGHTSCOUT_CGM_TWICE_S: i64 = 30;

/// The window (ms) within which a record of the same source, kind and
/// values but another identity is the same datum uploaded twice: Tidepool
/// readings and doses [`CROSS_UPLOAD_WINDOW_S`], Nightscout CGM readings
/// [`NIGHTSCOUT_CGM_TWICE_S`]; 0 for any other record (only the same
/// instant is the same datum) and for what is counted, not read.
pub fn twice_window_ms(r: &Record) -> i64 {
    match (r.source, &r.kind) {
        (_, RecordKind::Ignored { .. }) => 0,
        (Source::Tidepool, _) => CROSS_UPLOAD_WINDOW_S * 1000,
        (Source::Nightscout, RecordKind::Cgm { .. }) => NIGHTSCOUT_CGM_TWICE_S * 1000,
        _ => 0,
    }
}

/// The window (ms) within which a stored Nightscout dose (a bolus, an
/// extended bolus, a temporary basal) of the same kind and values but
/// another document, stored by an earlier import or sync, is the same
/// dose uploaded again: AndroidAPS uploads its pump history again after
/// an NSClient reset, and its NSClient (API v1) and NSClientV3 each write
/// one copy, dated [`nightscout::COPY_WITHIN_S`] apart at most. Within one
/// file the reader tells copies by their pump event (`pumpId`); across
/// imports the store compares the pump identities kept with the doses
/// ([`pump_identity`]) and, where either has none, takes the window
/// alone. 0 for any other record.
pub fn copy_elsewhere_window_ms(r: &Record) -> i64 {
    match (r.source, &r.kind) {
        (
            Source::Nightscout,
            RecordKind::Bolus { .. }
            | RecordKind::ExtendedBolus { .. }
            | RecordKind::TempBasal { .. },
        ) => nightscout::COPY_WITHIN_S * 1000,
        _ => 0,
    }
}

/// The latest instant a record read at `now` may carry:
/// [`abba_core::limits::FUTURE_SKEW_MINUTES`] after it.
pub fn future_limit(now: jiff::Timestamp) -> jiff::Timestamp {
    now.checked_add(jiff::SignedDuration::from_mins(
        abba_core::limits::FUTURE_SKEW_MINUTES,
    ))
    .unwrap_or(now)
}

/// The earliest instant a record may carry: 1990-01-01T00:00:00Z. No
/// glucose sensor, meter or insulin pump logged data abba reads before
/// then (the first meters with a memory and the first pumps with a
/// history came in the 1990s; the first CGM in 1999), so a record dated
/// earlier is a wrong clock or a wrong unit (seconds read as
/// milliseconds, a negative number), never a person's data: the store's
/// import refuses it, record by record (see [`too_old`],
/// [`Batch::refuse_too_old`]). Nightscout's default profile dated at the
/// epoch ([`crate::record::SINCE_ALWAYS`], "in force since always") is
/// the one exception.
pub const RECORDS_FROM: jiff::Timestamp = jiff::Timestamp::constant(631_152_000, 0);

/// [`RECORDS_FROM`] as a date (the earliest day 1 a person may have).
pub const RECORDS_FROM_DATE: jiff::civil::Date = jiff::civil::date(1990, 1, 1);

/// True for a record dated before [`RECORDS_FROM`]: it cannot be true
/// (a therapy profile at [`crate::record::SINCE_ALWAYS`] is in force since
/// always and is kept).
pub fn too_old(r: &Record) -> bool {
    r.at < RECORDS_FROM
        && !(r.at == crate::record::SINCE_ALWAYS && matches!(r.kind, RecordKind::Schedule { .. }))
}

/// What [`too_old`] expects, for messages.
pub fn too_old_words() -> String {
    format!(
        "dated before {} (no glucose sensor, meter or insulin pump logged data then: a wrong clock or a time in the wrong unit; expected a time from {} on)",
        RECORDS_FROM_DATE, RECORDS_FROM
    )
}

/// Records refused (dated after the time of import or before
/// [`RECORDS_FROM`]) or not used (before the person's day 1): how many,
/// and the first.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Refused {
    /// How many.
    pub count: usize,
    /// Where the first (earliest in file order) was read.
    pub first: Option<String>,
    /// The first one's instant.
    pub first_at: Option<String>,
}

impl Batch {
    /// Where a record was read, for messages (`file: line N` or `file: $[i]`).
    pub fn origin(&self, r: &Record) -> String {
        crate::events::Origins::Files(&self.files).of(r)
    }
    /// The pump's identity of a record read from a Nightscout document
    /// that carries one ([`pump_identity`]).
    pub fn pump_identity(&self, r: &Record) -> Option<&pump_identity::PumpIdentity> {
        match r.origin.at {
            crate::record::OriginAt::Item(i) => self.pump_identities.get(&(r.origin.file, i)),
            _ => None,
        }
    }
    /// Removes the records dated more than
    /// [`abba_core::limits::FUTURE_SKEW_MINUTES`] after `now` (the time of
    /// import): they cannot be true yet. Returns their count and the first.
    pub fn refuse_future(&mut self, now: jiff::Timestamp) -> Refused {
        let limit = future_limit(now);
        let mut refused = Refused::default();
        let keep = self.records.partition_point(|r| r.at <= limit);
        let first = self.records[keep..].iter().min_by_key(|r| r.origin);
        if let Some(r) = first {
            refused.first = Some(self.origin(r));
            refused.first_at = Some(r.at.to_string());
        }
        refused.count = self.records.len() - keep;
        self.records.truncate(keep);
        refused
    }
    /// Removes the records dated before [`RECORDS_FROM`] ([`too_old`]):
    /// they cannot be true. Adds them to [`Batch::too_old`] (their count
    /// and the first in file order) and returns it.
    pub fn refuse_too_old(&mut self) -> &Refused {
        let old: Vec<&Record> = self.records.iter().filter(|r| too_old(r)).collect();
        if !old.is_empty() {
            let first = old.iter().min_by_key(|r| r.origin).copied();
            let first_new = first.map(|r| (self.origin(r), r.at.to_string()));
            let first_held = self.too_old.first.is_some();
            self.too_old.count += old.len();
            if let (false, Some((place, at))) = (first_held, first_new) {
                self.too_old.first = Some(place);
                self.too_old.first_at = Some(at);
            }
            self.records.retain(|r| !too_old(r));
        }
        &self.too_old
    }
    /// What [`Batch::refuse_too_old`] refused, in a sentence (`None`: nothing).
    pub fn too_old_line(&self) -> Option<String> {
        (self.too_old.count > 0).then(|| {
            format!(
                "{} records {} were refused; the first: {} ({})",
                self.too_old.count,
                too_old_words(),
                self.too_old.first.as_deref().unwrap_or("?"),
                self.too_old.first_at.as_deref().unwrap_or("?")
            )
        })
    }
    /// The files from which no record was read.
    pub fn empty_files(&self) -> Vec<&str> {
        self.files
            .iter()
            .zip(&self.per_file)
            .filter(|(_, &n)| n == 0)
            .map(|(f, _)| f.as_str())
            .collect()
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
    let mut per_file = Vec::new();
    let mut notes = Vec::new();
    let mut unread = Unread::default();
    let mut clocks = Vec::with_capacity(inputs.len());
    let mut reads = Vec::with_capacity(inputs.len());
    for (i, (name, bytes)) in inputs.iter().enumerate() {
        reads.push(read_bytes_noted(name, i as u16, bytes, opts)?);
    }
    // A Profile Switch that only names its profile (Nightscout's
    // Careportal) is looked up in the profile stores of the whole batch
    // (profile.json beside treatments.json): the files that hold one are
    // read again with them.
    let stores: Vec<nightscout::ProfileStore> = reads
        .iter()
        .flat_map(|r| r.stores.iter().cloned())
        .collect();
    if !stores.is_empty() {
        for (i, (name, bytes)) in inputs.iter().enumerate() {
            if reads[i].wants_stores {
                reads[i] = read_bytes_with_stores(name, i as u16, bytes, opts, &stores)?;
            }
        }
    }
    let mut pump_identities = BTreeMap::new();
    for (
        file,
        FileRead {
            format,
            records: mut r,
            notes: mut n,
            unread: u,
            clocks: c,
            pump_identities: p,
            ..
        },
    ) in reads.into_iter().enumerate()
    {
        pump_identities.extend(p.into_iter().map(|(item, p)| ((file as u16, item), p)));
        clocks.push(c);
        unread.count += u.count;
        unread.first.extend(u.first);
        formats.push(format);
        per_file.push(r.len());
        notes.append(&mut n);
        if records.is_empty() {
            records = r; // one file: no copy
        } else {
            records.append(&mut r);
        }
    }
    let mut batch = merge(
        inputs.iter().map(|(n, _)| n.clone()).collect(),
        formats,
        records,
    );
    batch.per_file = per_file;
    batch.notes = notes;
    batch.unread = unread;
    batch.clocks = clocks;
    batch.pump_identities = pump_identities;
    Ok(batch)
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
/// counting them; of records sharing an id ([`SourceId::Id`]) keeps the
/// last read (the latest version); of data carried by two uploads within
/// [`twice_window_ms`] keeps the first. Works in place: a
/// 10-year CGM file is about a million records.
pub fn merge(files: Vec<String>, formats: Vec<Format>, mut records: Vec<Record>) -> Batch {
    let removed = merge_records(&mut records);
    Batch {
        files,
        formats,
        records,
        duplicates: removed.duplicates,
        older_versions: removed.older_versions,
        cross_upload: removed.cross_upload,
        per_file: Vec::new(),
        notes: Vec::new(),
        too_old: Refused::default(),
        unread: Unread::default(),
        clocks: Vec::new(),
        pump_identities: BTreeMap::new(),
    }
}

/// What [`merge_records`] removed.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Removed {
    /// Exact duplicates, by kind (see [`Batch::duplicates`]).
    pub duplicates: BTreeMap<String, usize>,
    /// Older versions of a record (see [`Batch::older_versions`]).
    pub older_versions: usize,
    /// Data carried by two uploads, by kind (see [`Batch::cross_upload`]).
    pub cross_upload: BTreeMap<String, usize>,
}

/// [`merge`]'s work on records alone (no files): sorts them by instant and
/// removes duplicates, older versions and Tidepool data uploaded twice, in
/// place; returns what it removed.
pub fn merge_records(records: &mut Vec<Record>) -> Removed {
    let older_versions = drop_older_versions(records);
    if !records.is_sorted_by(|a, b| a.at <= b.at) {
        records.sort_by_key(|r| r.at);
    }
    let mut duplicates: BTreeMap<String, usize> = BTreeMap::new();
    let mut cross_upload: BTreeMap<String, usize> = BTreeMap::new();
    let mut write = 0;
    let mut group_start = 0;
    for read in 0..records.len() {
        if write > 0 && records[write - 1].at != records[read].at {
            group_start = write;
        }
        let r = &records[read];
        // Also the same glucose reading in two files of one source, one
        // in mg/dL and one in mmol/L (the app switched between two
        // exports): the first file's is kept.
        let duplicate = records[group_start..write].iter().any(|k| {
            (k.kind == r.kind && (!matches!(r.kind, RecordKind::Ignored { .. }) || k.id == r.id))
                || (k.source == r.source
                    && k.origin.file != r.origin.file
                    && matches!(k.id, SourceId::Hash(_))
                    && crate::record::same_reading(k, &r.kind))
        });
        if duplicate {
            *duplicates.entry(r.kind.name().to_string()).or_default() += 1;
            continue;
        }
        let window = twice_window_ms(r);
        if window > 0 {
            let window = jiff::SignedDuration::from_millis(window);
            let twice = records[..write]
                .iter()
                .rev()
                .take_while(|k| r.at.duration_since(k.at) <= window)
                .any(|k| k.source == r.source && k.kind == r.kind && k.id != r.id);
            if twice {
                *cross_upload.entry(r.kind.name().to_string()).or_default() += 1;
                continue;
            }
        }
        records.swap(write, read);
        write += 1;
    }
    records.truncate(write);
    Removed {
        duplicates,
        older_versions,
        cross_upload,
    }
}

/// Removes every record whose id ([`SourceId::Id`], same source) comes
/// again later in read order (file, then line or item) with other content,
/// keeping the last; returns how many were removed. Repeats with the same
/// content are left for the duplicate count.
fn drop_older_versions(records: &mut Vec<Record>) -> usize {
    let mut last: std::collections::HashMap<(Source, &str), usize> =
        std::collections::HashMap::new();
    for (i, r) in records.iter().enumerate() {
        if let SourceId::Id(id) = &r.id {
            let e = last.entry((r.source, id)).or_insert(i);
            if r.origin >= records[*e].origin {
                *e = i;
            }
        }
    }
    let drop: Vec<bool> = records
        .iter()
        .map(|r| match &r.id {
            SourceId::Id(id) => last.get(&(r.source, &**id)).is_some_and(|&w| {
                let w = &records[w];
                w.at != r.at || w.kind != r.kind
            }),
            SourceId::Hash(_) => false,
        })
        .collect();
    let before = records.len();
    let mut i = 0;
    records.retain(|_| {
        i += 1;
        !drop[i - 1]
    });
    before - records.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pdf_or_binary_file_is_named_not_read_as_columns() {
        let pdf = b"%PDF-1.7\n%\xe2\xe3\xcf\xd3\n1 0 obj <</Type /Catalog>> endobj\n";
        let e = detect("report.pdf", pdf).unwrap_err().to_string();
        assert!(
            e.contains("report.pdf") && e.contains("a PDF document"),
            "{e}"
        );
        let png = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR,x,y\n";
        let e = detect("photo.png", png).unwrap_err().to_string();
        assert!(e.contains("binary data") && !e.contains("IHDR"), "{e}");
        // Text, a UTF-16 export decoded before: still read.
        assert_eq!(
            detect("a.csv", b"time,glucose\n2026-01-01 00:00,100\n").unwrap(),
            Format::Csv
        );
    }
}
