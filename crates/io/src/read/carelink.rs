//! Medtronic CareLink CSV (MiniMed pumps, Guardian sensors), as CareLink
//! exports it: `;`-separated with decimal commas (or, in the US English
//! export, `,`-separated with decimal points and `MM/DD/YY` dates), CRLF,
//! a preamble (name, patient id, date range, device and serial number),
//! then sections, each opened by a divider
//! `-------;<device>;Pump|Sensor;<serial>;<title>` and its own
//! `Index;Date;Time;...` header, rows newest first. A file that starts
//! with the header (preamble and first divider deleted in a spreadsheet)
//! is read with that first section as the Pump section, and a note says so. `Index` is a
//! row number with decimals (`0,00000`) and never identity: records are
//! identified by their content.
//!
//! Read from the pump section: `BG Reading` (meter), `Basal Rate (U/h)`
//! (the scheduled rate from then on), temporary basals (`Temp Basal
//! Amount`, `Temp Basal Type` absolute or percent, `Temp Basal Duration`),
//! boluses by `Bolus Type` (Normal, Square, Dual normal and square parts)
//! with `Bolus Volume Delivered (U)`, `BWZ Carb Input (grams)` (not of a
//! wizard the person confirmed again before its bolus, see
//! [`confirmed_again`], nor of one whose `BWZ Status` is `Not
//! Delivered`), suspend and
//! resume (`Suspend`), and event markers written as text (`Meal:
//! 60,00grams` is carbohydrate, `Meal: 1.00grams` a meal without its
//! amount, counted; `Insulin: 27,00` is counted, its acting
//! type unknown). From the sensor section: `Sensor Glucose` (CGM). Alarms,
//! primes, rewinds, SmartGuard's auto-basal micro-boluses, the
//! "Aggregated Auto Insulin Data" daily totals (not doses) and every other
//! row are counted as ignored. Glucose units come from the headers.

use abba_core::{Grams, MgDl, Units, UnitsPerHour};

use super::carelink_clock;
use super::table::{number, Table};
use super::{or_skip, Ctx};
use crate::error::{IoError, Location, Place};
use crate::record::{
    content_hash, content_id, BasalSchedule, Censor, Glucose, Profile, Record, RecordKind, Source,
    SourceId, TempRate,
};
use crate::time::{parse_wall, DateOrder, WallClock};
use crate::units::{self, check_range};

/// True for a section header line (`Index;Date;Time...` or
/// `Index,Date,Time...`).
fn is_header(line: &str) -> bool {
    let l = line.trim_start_matches('"');
    l.starts_with("Index;Date;Time") || l.starts_with("Index,Date,Time")
}

/// Whether the start of a file is a CareLink export: an `Index;Date;Time`
/// (or `,`) header after a section divider or the CareLink preamble, or
/// as the first line when its fourth column is CareLink's own `New Device
/// Time` (an export whose preamble and divider were deleted in a
/// spreadsheet and saved again, as a real Paradigm export in the GluGo
/// repository shows).
pub fn looks_like(head: &str) -> bool {
    let header = head.lines().any(is_header);
    let preamble =
        head.starts_with("Last Name;First Name") || head.starts_with("Last Name,First Name");
    header
        && (head.contains("-------;")
            || head.contains("-------,")
            || preamble
            || head.lines().next().is_some_and(bare_header))
}

/// A CareLink section header as a file's first line, without the preamble
/// or divider before it: `Index`, `Date`, `Time`, `New Device Time`.
fn bare_header(line: &str) -> bool {
    let cells: Vec<&str> = line
        .split([',', ';'])
        .map(|c| c.trim().trim_matches('"'))
        .take(4)
        .collect();
    cells == ["Index", "Date", "Time", "New Device Time"]
}

/// A CareLink export whose columns abba does not read: its section
/// divider (`-------;<device>;Pump|Sensor|...;<serial>;-------`, in every
/// language) is there but no English header is: the export of CareLink set
/// to another language. Returns the header line after the divider, for the
/// message.
pub fn other_language_header(head: &str) -> Option<&str> {
    let mut lines = head.lines();
    while let Some(line) = lines.next() {
        let l = line.trim().trim_matches('"');
        let divider = (l.starts_with("-------;") || l.starts_with("-------,"))
            && (l.ends_with(";-------") || l.ends_with(",-------"));
        if divider && !head.lines().any(is_header) {
            return Some(lines.next().unwrap_or("").trim());
        }
    }
    None
}

/// The first line of a CareLink Personal export of 2013-2015 (`... (v1.0.1)`):
/// a preamble (`PATIENT INFO`, `Name`, `Report Range`, `DEVICE INFO`,
/// `Pump:`, `Meter:`, `Sensor:`, `Data Exported on`, `DEVICE DATA (N
/// records)`, `Data Range`; the device lines vary, so the header is on
/// line 10-12), then the `Raw-Type` table.
const PERSONAL_TITLE: &str = "Medtronic Diabetes CareLink Personal Data Export File";

/// How many lines may come before the older layout's header (the v1.0.1
/// preamble has 11).
const PERSONAL_HEADER_LINES: usize = 20;

/// The 1-based line of the older layout's header (`Index,Date,Time,...`
/// with `Raw-Type` and `Raw-Values` columns) among the first lines.
fn personal_header_line(head: &str) -> Option<usize> {
    head.lines()
        .take(PERSONAL_HEADER_LINES)
        .position(|l| {
            let l = l.trim_start_matches('"');
            l.starts_with("Index") && l.contains("Raw-Type") && l.contains("Raw-Values")
        })
        .map(|i| i + 1)
}

/// Whether the start of a file is the older CareLink Personal export
/// (2010-2015, seen in real exports and in the rows Tidepool kept from
/// them): the title line `Medtronic Diabetes CareLink Personal Data Export
/// File (v1.0.1)` and its preamble, or a `Data Range,...` first line, or a
/// header `Index,Date,Time,Timestamp,...` with `Raw-Type` and `Raw-Values`
/// columns among the first lines; no section dividers, the basal schedule
/// only inside `Raw-Values` text. abba does not read it.
pub fn looks_like_personal(head: &str) -> bool {
    let head = head.trim_start_matches('\u{feff}');
    let first = head.trim_start_matches('"');
    first.starts_with("Data Range")
        || first.starts_with(PERSONAL_TITLE)
        || personal_header_line(head).is_some()
}

/// The refusal of the older layout, saying what the file shows of it.
fn personal_refusal(file: &str, head: &str) -> IoError {
    let head = head.trim_start_matches('\u{feff}');
    let first = head.lines().next().unwrap_or("").trim().trim_matches('"');
    let title = if first.starts_with(PERSONAL_TITLE) {
        format!("its first line \"{first}\"")
    } else if first.starts_with("Data Range") {
        "a \"Data Range\" first line".to_string()
    } else {
        "no preamble".to_string()
    };
    let header = personal_header_line(head).map_or(String::new(), |n| {
        format!(", its header on line {n} with Raw-Type and Raw-Values columns")
    });
    IoError::format(
        file,
        format!(
            "this is the older CareLink Personal layout (2010-2015: {title}{header}; one table \
             of every device's rows, no Pump or Sensor sections, the basal schedule only inside \
             Raw-Values text), which abba does not read; abba reads CareLink's current export, \
             whose Pump and Sensor sections each open with a divider (-------,<device>,Pump,...)"
        ),
    )
}

/// A section of the export.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Section {
    Pump,
    Sensor,
    /// Daily totals ("Aggregated Auto Insulin Data"), not doses.
    Totals,
    /// A section abba does not know: its rows are counted.
    Other,
}

fn section_of(divider: &str) -> Section {
    let cells: Vec<&str> = divider
        .split([';', ','])
        .map(|c| c.trim().trim_matches('"'))
        .collect();
    if cells.iter().any(|c| c.contains("Aggregated")) {
        return Section::Totals;
    }
    match cells.get(2).copied() {
        Some("Pump") => Section::Pump,
        Some("Sensor") => Section::Sensor,
        _ => Section::Other,
    }
}

/// One section's header line (0-based) and the end of its rows (byte).
struct Span {
    section: Section,
    /// The device its divider names (`MiniMed 780G MMT-1886`), empty for a
    /// header before any divider.
    device: String,
    /// The file starts with its header, no divider before it (the preamble
    /// and first divider deleted): read as the Pump section.
    undivided: bool,
    /// The divider names a Paradigm pump (its `Basal Rate` rows are the
    /// rate in effect, see [`in_effect`]).
    paradigm: bool,
    header_at: usize,
    end: usize,
}

impl Span {
    /// The section in words, for notes.
    fn describe(&self) -> String {
        let what = match self.section {
            Section::Pump => "Pump section",
            Section::Sensor => "Sensor section",
            Section::Totals => "\"Aggregated Auto Insulin Data\" section",
            Section::Other => "section",
        };
        if self.device.is_empty() {
            format!("the {what} with its header on line {}", self.header_at + 1)
        } else {
            format!(
                "the {what} of {} (header on line {})",
                self.device,
                self.header_at + 1
            )
        }
    }
}

fn spans(bytes: &[u8]) -> Vec<Span> {
    let mut out: Vec<Span> = Vec::new();
    let mut section = Section::Other;
    let mut device = String::new();
    let mut paradigm = false;
    // Whether a divider, or any line, came before: a header that opens
    // the file is the Pump section's (its preamble and divider deleted).
    let mut divided = false;
    let mut first_line = true;
    let mut start = 0usize;
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let text = String::from_utf8_lossy(line);
        // (a byte-order mark: Excel's "CSV UTF-8")
        let text = text.trim_start_matches('\u{feff}').trim_start_matches('"');
        if text.starts_with("-------") {
            if let Some(last) = out.last_mut() {
                last.end = last.end.min(start);
            }
            section = section_of(text);
            divided = true;
            device = text
                .split([';', ','])
                .nth(1)
                .map(|c| c.trim().trim_matches('"').to_string())
                .unwrap_or_default();
            paradigm = text.contains("Paradigm");
        } else if is_header(text) {
            if let Some(last) = out.last_mut() {
                last.end = last.end.min(start);
            }
            // CareLink writes the Pump section first: a header opening the
            // file is that section's (had it been the Sensor section, its
            // rows would carry no pump cell to read as such). After a
            // preamble without a divider, the section stays unknown.
            let undivided = !divided && first_line;
            out.push(Span {
                section: if undivided { Section::Pump } else { section },
                device: device.clone(),
                undivided,
                paradigm,
                header_at: i,
                end: bytes.len(),
            });
        }
        first_line &= text.trim().is_empty();
        start += line.len() + 1;
    }
    out
}

/// What a CareLink export says of SmartGuard's auto mode (the MiniMed
/// 780G's closed loop), from its `Bolus Source` cells: boluses the pump
/// gives in auto mode are `CLOSED_LOOP_*` (the person's own,
/// `CLOSED_LOOP_BG_CORRECTION_AND_FOOD_BOLUS`, and the automatic ones,
/// `CLOSED_LOOP_AUTO_BASAL` micro-boluses and `CLOSED_LOOP_AUTO_BOLUS`
/// corrections), and the "Aggregated Auto Insulin Data" section's daily
/// totals are `CLOSED_LOOP_AUTO_INSULIN`. In manual mode the same pump
/// writes `BOLUS_WIZARD` and no auto insulin, so its name alone says
/// nothing of the loop.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AutoMode {
    /// The device the first section divider names (`MiniMed 780G
    /// MMT-1886`).
    pub device: Option<String>,
    /// Delivered boluses the loop gave on its own (`CLOSED_LOOP_AUTO_*`).
    pub automatic_doses: usize,
    /// Other delivered boluses given in auto mode (`CLOSED_LOOP_*`).
    pub auto_mode_boluses: usize,
    /// Daily auto insulin totals (`CLOSED_LOOP_*` rows of the
    /// "Aggregated Auto Insulin Data" section).
    pub auto_insulin_totals: usize,
    /// The lines of all these rows (1-based, as the reader numbers them),
    /// each with whether it is an automatic dose (`CLOSED_LOOP_AUTO_*`
    /// of the Pump section): dated by the reader
    /// ([`SettingsRows::closed_loop`], [`SettingsRows::auto_insulin_days`]).
    pub marks: Vec<(u64, bool)>,
}

/// Reads [`AutoMode`] from a CareLink export (BOM stripped, UTF-8); a
/// file that is not one, or a section that cannot be read, adds nothing
/// (the reader reports what is wrong with it).
pub fn auto_mode(bytes: &[u8]) -> AutoMode {
    let mut out = AutoMode::default();
    let spans = spans(bytes);
    out.device = spans
        .iter()
        .map(|s| s.device.clone())
        .find(|d| !d.is_empty());
    for span in &spans {
        let Ok(mut t) = Table::open("", &bytes[..span.end], span.header_at) else {
            continue;
        };
        let (Some(source), Some(delivered)) = (
            t.column_starting("Bolus Source"),
            t.column_starting("Bolus Volume Delivered"),
        ) else {
            continue;
        };
        while let Ok(Some(line)) = t.next_row() {
            let src = t.cell(source);
            if !src.starts_with("CLOSED_LOOP_") || t.cell(delivered).is_empty() {
                continue;
            }
            let automatic = match span.section {
                Section::Totals => {
                    out.auto_insulin_totals += 1;
                    false
                }
                Section::Pump if src.starts_with("CLOSED_LOOP_AUTO_") => {
                    out.automatic_doses += 1;
                    true
                }
                Section::Pump => {
                    out.auto_mode_boluses += 1;
                    false
                }
                _ => continue,
            };
            out.marks.push((line, automatic));
        }
    }
    out
}

/// A row's cells by name (absent columns read as empty).
struct Cols {
    date: usize,
    time: usize,
    bg: Option<usize>,
    basal: Option<usize>,
    temp_amount: Option<usize>,
    temp_type: Option<usize>,
    temp_duration: Option<usize>,
    bolus_type: Option<usize>,
    bolus_delivered: Option<usize>,
    bolus_duration: Option<usize>,
    bolus_source: Option<usize>,
    carbs: Option<usize>,
    /// `BWZ Status` (the 780G's): `Delivered` or `Not Delivered`.
    bwz_status: Option<usize>,
    carb_ratio: Option<usize>,
    sensor: Option<usize>,
    marker: Option<usize>,
    alarm: Option<usize>,
    suspend: Option<usize>,
    rewind: Option<usize>,
    prime: Option<usize>,
    time_change: Option<usize>,
    /// Every `BWZ ...` column.
    bwz: Vec<usize>,
}

impl Cols {
    fn of(t: &Table<'_>) -> Result<Self, IoError> {
        let col = |p: &str| t.column_starting(p);
        Ok(Self {
            date: t.need_column_starting("CareLink", "Date")?,
            time: t.need_column_starting("CareLink", "Time")?,
            bg: col("BG Reading"),
            basal: col("Basal Rate"),
            temp_amount: col("Temp Basal Amount"),
            temp_type: col("Temp Basal Type"),
            temp_duration: col("Temp Basal Duration"),
            bolus_type: col("Bolus Type"),
            bolus_delivered: col("Bolus Volume Delivered"),
            bolus_duration: col("Programmed Bolus Duration").or_else(|| col("Bolus Duration")),
            bolus_source: col("Bolus Source"),
            carbs: col("BWZ Carb Input"),
            bwz_status: col("BWZ Status"),
            carb_ratio: col("BWZ Carb Ratio"),
            sensor: col("Sensor Glucose"),
            marker: col("Event Marker"),
            alarm: col("Alarm").or_else(|| col("Alert")),
            suspend: col("Suspend"),
            rewind: col("Rewind"),
            prime: col("Prime Type"),
            time_change: col("New Device Time"),
            bwz: (0..t.header.len())
                .filter(|&i| t.header[i].starts_with("BWZ"))
                .collect(),
        })
    }
}

/// A row read but not yet placed in time (rows come newest first; the
/// autumn fold is resolved oldest first).
struct Row {
    line: u64,
    wall: jiff::civil::DateTime,
    kinds: Vec<RecordKind>,
    /// The row's cells but its `Index` (an ignored row's identity).
    cells: u64,
    /// The bolus wizard's carb ratio (g/U) on a wizard row of the pump.
    carb_ratio: Option<f64>,
    /// A wizard row of the pump (its `BWZ Carb Input` filled, 0 for a
    /// correction; a Veo writes some of a wizard's cells on a second row
    /// without it): its `BWZ` cells' hash, and whether its `BWZ Status`
    /// says what became of it.
    wizard: Option<(u64, bool)>,
    /// A bolus row of the pump (a `Bolus Type`; a dual bolus's square part
    /// is the same bolus as its normal part and not counted).
    bolus: bool,
    /// A row of SmartGuard's auto mode (see [`SettingsRows::closed_loop`]).
    closed_loop: bool,
    /// The time the pump's clock was set to (`New Device Time`), on a
    /// pump row that says so.
    set_to: Option<jiff::civil::DateTime>,
}

/// What a CareLink export says about the pump's settings: the rows that
/// set the scheduled basal rate and the bolus wizard's carb ratios, each
/// with its instant and line, oldest first.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SettingsRows {
    /// `Basal Rate (U/h)` rows: the scheduled rate from then on.
    pub basal: Vec<(jiff::Timestamp, f64, u64)>,
    /// Wizard rows' `BWZ Carb Ratio (g/U)` (0, a correction without
    /// carbohydrate, is left out).
    pub carb_ratio: Vec<(jiff::Timestamp, f64, u64)>,
    /// The latest instant of any pump or sensor row.
    pub end: Option<jiff::Timestamp>,
    /// A wizard carb-ratio column not in g/U (its name): not read.
    pub ratio_not_grams: Option<String>,
    /// Pump rows SmartGuard's auto mode wrote (`Bolus Source`
    /// `CLOSED_LOOP_*` with a delivered volume, as [`auto_mode`] counts
    /// them): instant and line, oldest first.
    pub closed_loop: Vec<(jiff::Timestamp, u64)>,
    /// The local dates of the "Aggregated Auto Insulin Data" daily totals
    /// (`CLOSED_LOOP_*` with a volume: auto mode delivered insulin that
    /// day), with their lines.
    pub auto_insulin_days: Vec<(jiff::civil::Date, u64)>,
}

/// Reads a CareLink export.
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    read_with_settings(ctx, bytes).map(|(r, _)| r)
}

/// Reads a CareLink export: its records and what its rows say about the
/// pump's settings.
pub fn read_with_settings(
    ctx: &Ctx<'_>,
    bytes: &[u8],
) -> Result<(Vec<Record>, SettingsRows), IoError> {
    let file = ctx.file;
    let mut settings = SettingsRows::default();
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
    if looks_like_personal(&head) {
        return Err(personal_refusal(file, &head));
    }
    let spans = spans(bytes);
    if spans.is_empty() {
        return Err(IoError::format(
            file,
            "a CareLink export needs a section header \"Index;Date;Time;...\"; none found",
        ));
    }
    if spans.iter().all(|s| s.section == Section::Other) {
        return Err(IoError::format(
            file,
            "no Pump or Sensor section found (each opens with a divider like \
             -------;<device>;Pump;<serial>;-------): nothing in the file would be read",
        ));
    }
    let tz = ctx.require_tz("CareLink writes pump times without an offset")?;
    if let Some(g) = ctx
        .opts
        .grams_per_exchange
        .filter(|g| !(g.is_finite() && *g > 0.0))
    {
        return Err(IoError::Settings(format!(
            "grams per exchange {g}: expected a positive number of grams (10 for the Spanish raci\u{f3}n)"
        )));
    }
    let mut out = Vec::new();
    // The pump's clock set by a daylight-saving shift, by device.
    let mut clock_shifts: Vec<(String, carelink_clock::Shift)> = Vec::new();
    let mut unread_exchanges = 0usize;
    let mut unread_exchanges_column: Option<String> = None;
    let mut meals_without_amount = 0usize;
    let (has_rows, order) = survey(file, bytes, &spans, ctx.opts.date_order)?;
    for (span, has_rows) in spans.iter().zip(has_rows) {
        if !has_rows {
            // A Paradigm without a sensor writes the Sensor section's
            // divider and header and no row; a second pump, its own.
            ctx.note(format!("{} has no rows: skipped", span.describe()));
            continue;
        }
        if span.undivided {
            ctx.note(format!(
                "{}: no section divider (-------,<device>,Pump,<serial>,-------) before it (the \
                 export's first lines deleted, in a spreadsheet for instance): read as the \
                 Pump section, the one CareLink writes first",
                span.describe()
            ));
        }
        let order = order.ok_or_else(|| {
            IoError::format(
                file,
                "every date could be day-first or month-first (no day above 12); give \
                 --date-order day-first or month-first",
            )
        })?;
        let mut t = Table::open(file, &bytes[..span.end], span.header_at)?;
        let cols = Cols::of(&t)?;
        if let Some(i) = cols.carb_ratio {
            let unit = ratio_unit(&t.header[i]);
            let read = unit == Some(RatioUnit::GramsPerUnit)
                || (unit.is_some() && ctx.opts.grams_per_exchange.is_some());
            if !read {
                settings.ratio_not_grams = Some(t.header[i].clone());
            }
        }
        let exchanges_unread = cols
            .carbs
            .filter(|&i| in_exchanges(&t.header[i]) && ctx.opts.grams_per_exchange.is_none());
        if let Some(i) = exchanges_unread {
            unread_exchanges_column = Some(t.header[i].clone());
        }
        let mut rows: Vec<Row> = Vec::new();
        let mut at = Location::line(file, 0);
        while let Some(line) = t.next_row()? {
            at.place = Place::Line(line);
            let (date, time) = (t.cell(cols.date), t.cell(cols.time));
            if date.is_empty() && time.is_empty() {
                continue; // a blank row inside a section
            }
            let wall = or_skip!(
                ctx,
                wall_time(date, time, order).ok_or_else(|| {
                    IoError::invalid(
                        at.clone(),
                        &t.header[cols.date],
                        format!(
                            "expected a date and time like 2025/10/30 17:36:29, got \"{date}\" \"{time}\""
                        ),
                    )
                })
            );
            let kinds = match span.section {
                Section::Totals => vec![RecordKind::Ignored {
                    kind: "daily auto insulin total (not a dose)".into(),
                }],
                Section::Other => vec![RecordKind::Ignored {
                    kind: "row of an unknown CareLink section".into(),
                }],
                Section::Pump | Section::Sensor => {
                    or_skip!(ctx, row_kinds(&t, &cols, &at, ctx.opts.grams_per_exchange))
                }
            };
            let carb_ratio = match span.section {
                Section::Pump => or_skip!(
                    ctx,
                    wizard_carb_ratio(&t, &cols, &at, ctx.opts.grams_per_exchange)
                ),
                _ => None,
            };
            let cells = content_hash(t.raw().skip(1));
            let pump = span.section == Section::Pump;
            let wizard = (pump && cols.carbs.is_some_and(|i| !t.cell(i).is_empty())).then(|| {
                let status = cols
                    .bwz
                    .iter()
                    .any(|&i| t.header[i].starts_with("BWZ Status") && !t.cell(i).is_empty());
                (
                    content_hash(cols.bwz.iter().map(|&i| t.cell(i).as_bytes())),
                    status,
                )
            });
            let bolus_type = cols.bolus_type.map_or("", |i| t.cell(i));
            let bolus = pump
                && !bolus_type.is_empty()
                && !bolus_type.to_ascii_lowercase().contains("square part");
            let closed_loop = matches!(span.section, Section::Pump | Section::Totals)
                && cols
                    .bolus_source
                    .is_some_and(|i| t.cell(i).starts_with("CLOSED_LOOP_"))
                && cols.bolus_delivered.is_some_and(|i| !t.cell(i).is_empty());
            let set_to = cols
                .time_change
                .filter(|_| pump)
                .map(|i| t.cell(i))
                .and_then(|c| c.split_once(' '))
                .and_then(|(d, h)| wall_time(d, h.trim(), order));
            rows.push(Row {
                line,
                wall,
                kinds,
                cells,
                carb_ratio,
                wizard,
                bolus,
                closed_loop,
                set_to,
            });
        }
        // Oldest first, so that a wall time in the autumn fold is placed
        // by the device's order.
        let mut clock = WallClock::new(tz.clone());
        let mut suspended = false;
        let mut temp: Option<(TempRate, jiff::Timestamp)> = None;
        let time_name = t.header[cols.time].clone();
        let mut rows: Vec<Row> = rows.into_iter().rev().collect();
        if span.paradigm {
            same_second_order(&mut rows);
        }
        confirmed_again(&mut rows);
        if span.section == Section::Pump {
            let found =
                carelink_clock::shifts(&tz, &clock_settings(&rows), rows.first().map(|r| r.wall));
            clock_shifts.extend(found.into_iter().map(|s| (span.device.clone(), s)));
        }
        let own: Vec<carelink_clock::Shift> = clock_shifts
            .iter()
            .filter(|(d, _)| *d == span.device && span.section != Section::Totals)
            .map(|(_, s)| s.clone())
            .collect();
        let mut pump_clock = carelink_clock::Placer::new(&own);
        for row in rows {
            at.place = Place::Line(row.line);
            let instant = match pump_clock.place(row.wall, row.line) {
                Some(t) => {
                    clock.place(t);
                    t
                }
                None => or_skip!(ctx, clock.resolve(row.wall, &at, &time_name)),
            };
            if matches!(span.section, Section::Pump | Section::Sensor) {
                settings.end = settings.end.max(Some(instant));
            }
            if let Some(r) = row.carb_ratio {
                settings.carb_ratio.push((instant, r, row.line));
            }
            if row.closed_loop {
                if span.section == Section::Totals {
                    settings.auto_insulin_days.push((row.wall.date(), row.line));
                } else {
                    settings.closed_loop.push((instant, row.line));
                }
            }
            for mut kind in row.kinds {
                match &kind {
                    RecordKind::Suspend { .. } => suspended = true,
                    RecordKind::TempBasal { rate, duration_min } => {
                        temp = (*duration_min > 0).then(|| {
                            let end = instant
                                .checked_add(jiff::SignedDuration::from_mins(i64::from(
                                    *duration_min,
                                )))
                                .unwrap_or(instant);
                            (*rate, end)
                        })
                    }
                    RecordKind::Resume if !suspended => {
                        kind = RecordKind::Ignored {
                            kind: "resume row while pumping (a second resume row)".into(),
                        }
                    }
                    RecordKind::Resume => suspended = false,
                    RecordKind::Ignored { kind: k }
                        if k.starts_with("BWZ carb input in exch")
                            || k.starts_with("event marker meal in exch") =>
                    {
                        unread_exchanges += 1
                    }
                    RecordKind::Ignored { kind: k } if k == MEAL_WITHOUT_AMOUNT => {
                        meals_without_amount += 1
                    }
                    _ => {}
                }
                // The Veo writes a `Basal Rate` row for the rate in effect:
                // 0 at a suspension, the adjusted rate at a temporary basal;
                // only the rows outside both say the scheduled rate.
                let in_temp = temp.filter(|t| instant < t.1).map(|t| t.0);
                let in_temp_now = in_temp.is_some();
                if span.paradigm {
                    kind = in_effect(kind, suspended, in_temp);
                }
                if let RecordKind::Schedule { profile } = &kind {
                    if let Some(s) = profile
                        .basal
                        .segments
                        .first()
                        .filter(|_| !suspended && !in_temp_now)
                    {
                        settings.basal.push((instant, s.1 .0, row.line));
                    }
                }
                out.push(Record {
                    at: instant,
                    id: match content_id(Source::CareLink, instant, &kind) {
                        SourceId::Hash(h) if matches!(kind, RecordKind::Ignored { .. }) => {
                            SourceId::Hash(content_hash([
                                h.to_string().as_bytes(),
                                row.cells.to_string().as_bytes(),
                            ]))
                        }
                        id => id,
                    },
                    kind,
                    source: Source::CareLink,
                    origin: ctx.origin_line(row.line),
                });
            }
        }
        for note in pump_clock.notes(&tz, &span.describe()) {
            ctx.note(note);
        }
    }
    if unread_exchanges > 0 {
        let column = unread_exchanges_column.unwrap_or_else(|| "Event Marker".into());
        ctx.note(format!(
            "carbohydrate not read: \"{column}\" counts in exchanges and an exchange is not one fixed mass ({unread_exchanges} rows); give the grams per exchange (--grams-per-exchange G, or the clinic page's grams-per-exchange field; 10 for the Spanish raci\u{f3}n) to read it as grams"
        ));
    }
    if meals_without_amount > 0 {
        ctx.note(format!(
            "{meals_without_amount} \"Meal:\" event markers of {MEAL_MARKER_NO_AMOUNT_G} g or less \
             were counted, not read as carbohydrate: a meal without its amount (a Guardian \
             system's app marks meals so), and abba learns from a meal's carbohydrate"
        ));
    }
    settings.basal.sort_by_key(|b| b.0);
    settings.closed_loop.sort_by_key(|c| c.0);
    settings.auto_insulin_days.sort();
    settings.carb_ratio.sort_by_key(|c| c.0);
    Ok((out, settings))
}

/// The settings of the pump's clock among a section's rows (oldest first):
/// of each run of rows with one `New Device Time`, the first is at the old
/// clock's time (the next, at the new clock's).
fn clock_settings(rows: &[Row]) -> Vec<carelink_clock::Setting> {
    let mut out = Vec::new();
    let mut previous: Option<jiff::civil::DateTime> = None;
    for row in rows {
        if let Some(to) = row.set_to {
            if previous != Some(to) {
                out.push(carelink_clock::Setting {
                    line: row.line,
                    from: row.wall,
                    to,
                });
            }
        }
        previous = row.set_to;
    }
    out
}

/// How soon after a wizard row another one is the same wizard confirmed
/// again (seconds): the Paradigm rows seen are 2 to 37 s apart.
const WIZARD_AGAIN_S: i64 = 60;

/// A wizard row without a `BWZ Status` (the Paradigm and MiniMed pumps
/// before the 780G) whose carbohydrate the person confirmed again before
/// any bolus: the pump writes a wizard row at each confirmation, and the
/// bolus that follows goes with the last one (GluGo's Revel 723 export:
/// the same 35 g at 15:39:17 and 15:39:19 with one 5.8 U bolus at
/// 15:39:19; 29 g at 12:25:15 changed to 25 g at 12:25:28, the 4.5 U bolus
/// the second row's estimate). So a wizard row followed within
/// [`WIZARD_AGAIN_S`] (and at least a second later) by another wizard row,
/// with no bolus from its own second to the other's, is not a meal: its carbohydrate is counted as
/// repeated (the same values) or changed, and the later row is the meal.
fn confirmed_again(rows: &mut [Row]) {
    let mut order: Vec<usize> = (0..rows.len()).collect();
    order.sort_by_key(|&k| rows[k].wall);
    let window = jiff::SignedDuration::from_secs(WIZARD_AGAIN_S);
    let mut first_of_second = 0;
    for p in 0..order.len() {
        let i = order[p];
        let t0 = rows[i].wall;
        if rows[order[first_of_second]].wall < t0 {
            first_of_second = p;
        }
        let Some((values, false)) = rows[i].wizard else {
            continue;
        };
        if !rows[i]
            .kinds
            .iter()
            .any(|k| matches!(k, RecordKind::Carbs { .. }))
        {
            continue;
        }
        let Some(&j) = order[p + 1..]
            .iter()
            .take_while(|&&k| rows[k].wall.duration_since(t0) <= window)
            .find(|&&k| rows[k].wizard.is_some() && rows[k].wall > t0)
        else {
            continue;
        };
        let t1 = rows[j].wall;
        let bolus_between = order[first_of_second..]
            .iter()
            .take_while(|&&k| rows[k].wall < t1)
            .any(|&k| rows[k].bolus);
        if bolus_between {
            continue;
        }
        let same = rows[j].wizard.is_some_and(|(v, _)| v == values);
        for k in &mut rows[i].kinds {
            if matches!(k, RecordKind::Carbs { .. }) {
                *k = RecordKind::Ignored {
                    kind: if same {
                        "bolus wizard row repeated with the same values before its bolus (one meal)"
                            .into()
                    } else {
                        "bolus wizard row changed and confirmed again before any bolus (the later row is the meal)"
                            .into()
                    },
                };
            }
        }
    }
}

/// Orders the rows of one second (oldest first otherwise) as the pump
/// ran them: a Paradigm writes a suspension and its resumption in the same
/// second in either order (HUPA0006P, 17/07/2018 01:27:17: `ALARM_SUSPEND`
/// listed after `NORMAL_PUMPING`, the rate rows after it delivering), so
/// such a pair is read as a suspension of under a second: the suspend row
/// first, then the `0.00` rate rows (in effect while suspended), the
/// resume row, then the rest (the rates it resumed with).
fn same_second_order(rows: &mut [Row]) {
    let rank = |r: &Row| {
        let is = |f: fn(&RecordKind) -> bool| r.kinds.iter().any(f);
        if is(|k| matches!(k, RecordKind::Suspend { .. })) {
            0
        } else if is(|k| {
            matches!(k, RecordKind::Schedule { profile }
                if profile.basal.segments.first().is_some_and(|s| s.1 .0 == 0.0))
        }) {
            1
        } else if is(|k| matches!(k, RecordKind::Resume)) {
            2
        } else {
            3
        }
    };
    let mut start = 0;
    while start < rows.len() {
        let wall = rows[start].wall;
        let end = start + rows[start..].iter().take_while(|r| r.wall == wall).count();
        let group = &mut rows[start..end];
        let both = group.iter().any(|r| rank(r) == 0) && group.iter().any(|r| rank(r) == 2);
        if both {
            group.sort_by_key(|r| rank(r));
        }
        start = end;
    }
}

/// A Paradigm's `Basal Rate (U/h)` row is the rate in effect, not the
/// schedule's (seen in the HUPA-UCM Veo 754 exports: `0.00` at each
/// suspension; `0.46` at the start of a 70 % temporary basal over 0.65,
/// `0.35` under it when the schedule steps to 0.50). Under a percent
/// temporary basal the scheduled rate is the row's rate divided by the
/// percentage, so that the delivered rate is the one the pump wrote; while
/// suspended, or under a 0 % or absolute temporary basal, the row says
/// nothing about the schedule: counted, not read.
fn in_effect(kind: RecordKind, suspended: bool, temp: Option<TempRate>) -> RecordKind {
    let RecordKind::Schedule { profile } = &kind else {
        return kind;
    };
    let Some(&(_, rate)) = profile.basal.segments.first() else {
        return kind;
    };
    match (suspended, temp) {
        (false, None) => kind,
        // (a schedule the row would imply above the plausible basal, as
        // a 1 % temporary basal could, is not guessed either)
        (false, Some(TempRate::Percent(p))) if p > 0.0 => {
            let scheduled = rate.0 * 100.0 / p;
            if scheduled <= units::BASAL_MAX_U_PER_H {
                RecordKind::Schedule {
                    profile: Box::new(Profile::basal_only(BasalSchedule::flat(UnitsPerHour(
                        scheduled,
                    )))),
                }
            } else {
                RecordKind::Ignored {
                    kind: format!(
                        "basal rate in effect under a {p} % temporary basal implies {scheduled:.2} U/h scheduled, above {} U/h (not read as the schedule)",
                        units::BASAL_MAX_U_PER_H
                    ),
                }
            }
        }
        (true, _) => RecordKind::Ignored {
            kind: "basal rate in effect while suspended (not the schedule)".into(),
        },
        (false, Some(_)) => RecordKind::Ignored {
            kind: "basal rate in effect under a 0 % or absolute temporary basal (not the schedule)"
                .into(),
        },
    }
}

/// What a wizard carb-ratio column counts in, from its name: grams per
/// unit, units per exchange (`(U/Ex)`, the Paradigm set to exchanges) or
/// exchanges per unit; `None` for a name that does not say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RatioUnit {
    GramsPerUnit,
    UnitsPerExchange,
    ExchangesPerUnit,
}

fn ratio_unit(name: &str) -> Option<RatioUnit> {
    let n = name.replace(' ', "").to_ascii_lowercase();
    if n.contains("(g/u)") {
        Some(RatioUnit::GramsPerUnit)
    } else if n.contains("(u/ex)") || n.contains("(u/exch)") || n.contains("(u/exchange)") {
        Some(RatioUnit::UnitsPerExchange)
    } else if n.contains("(ex/u)") || n.contains("(exch/u)") || n.contains("(exchanges/u)") {
        Some(RatioUnit::ExchangesPerUnit)
    } else {
        None
    }
}

/// True for a carbohydrate column in exchanges (`BWZ Carb Input
/// (exchanges)`).
fn in_exchanges(name: &str) -> bool {
    name.to_ascii_lowercase().contains("exch")
}

/// The bolus wizard's carb ratio of a pump row in g/U: `BWZ Carb Ratio
/// (g/U)`, or `(U/Ex)` / `(Ex/U)` converted with `grams_per_exchange` (0,
/// a correction without carbohydrate: none), checked against the
/// plausibility limits. A column in exchanges without
/// `grams_per_exchange`, or whose unit the name does not say: not read.
fn wizard_carb_ratio(
    t: &Table<'_>,
    c: &Cols,
    at: &Location,
    grams_per_exchange: Option<f64>,
) -> Result<Option<f64>, IoError> {
    let Some(i) = c.carb_ratio else {
        return Ok(None);
    };
    let name = &t.header[i];
    let (unit, g) = match (ratio_unit(name), grams_per_exchange) {
        (Some(RatioUnit::GramsPerUnit), _) => (RatioUnit::GramsPerUnit, 1.0),
        (Some(u), Some(g)) => (u, g),
        _ => return Ok(None),
    };
    let text = t.cell(i);
    if text.is_empty() {
        return Ok(None);
    }
    let v = number(text, t.delimiter).ok_or_else(|| {
        IoError::invalid(
            at.clone(),
            name,
            format!("expected a carb ratio (a number), got \"{text}\""),
        )
    })?;
    if v == 0.0 {
        return Ok(None);
    }
    let grams_per_unit = match unit {
        RatioUnit::GramsPerUnit => v,
        RatioUnit::UnitsPerExchange => g / v,
        RatioUnit::ExchangesPerUnit => v * g,
    };
    abba_core::limits::CARB_RATIO_G_PER_U
        .check(grams_per_unit)
        .map_err(|e| {
            IoError::invalid(
                at.clone(),
                name,
                format!("{v} is {grams_per_unit:.1} g/U: {e}"),
            )
        })?;
    Ok(Some(grams_per_unit))
}

/// How a pump reports its state in the `Suspend` column. Suspensions and
/// resumptions as the Paradigm and MiniMed pumps write them (the states
/// Tidepool's uploader maps, tidepool-org/uploader, BSD-2; `LOWSG_SUSPEND`
/// and `NOTSEATED_SUSPEND` also seen in the HUPA-UCM Paradigm Veo 754
/// exports). Any other state is `None`: counted by name, not guessed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PumpState {
    Suspended,
    Resumed,
}

fn pump_state(state: &str) -> Option<PumpState> {
    match state.trim() {
        "USER_SUSPEND"
        | "ALARM_SUSPEND"
        | "NOTSEATED_SUSPEND"
        | "LOWSG_SUSPEND"
        | "LOW_SUSPEND_MODE_1"
        | "LOW_SUSPEND_NO_RESPONSE"
        | "LOW_SUSPEND_USER_SELECTED" => Some(PumpState::Suspended),
        "NORMAL_PUMPING"
        | "USER_RESTART_BASAL"
        | "AUTO_RESUME_COMPLETE"
        | "AUTO_RESUME_REDUCED" => Some(PumpState::Resumed),
        _ => None,
    }
}

/// Whether each section has a row (a date or a time), and the file's
/// date order: year first (`2025/10/30`, CareLink's current form), or
/// what the first date that tells shows (a day above 12), in any section,
/// or `--date-order`; `None` when nothing tells (an error only for a
/// section with rows to read). Never guessed.
fn survey(
    file: &str,
    bytes: &[u8],
    spans: &[Span],
    given: Option<DateOrder>,
) -> Result<(Vec<bool>, Option<DateOrder>), IoError> {
    let mut has_rows = Vec::with_capacity(spans.len());
    let mut order = None;
    for span in spans {
        let mut t = Table::open(file, &bytes[..span.end], span.header_at)?;
        let (date, time) = (
            t.need_column_starting("CareLink", "Date")?,
            t.need_column_starting("CareLink", "Time")?,
        );
        let mut rows = false;
        // (up to the first row and the first date that tells)
        while !(rows && order.is_some()) && t.next_row()?.is_some() {
            let cell = t.cell(date);
            if cell.is_empty() && t.cell(time).is_empty() {
                continue;
            }
            rows = true;
            if order.is_none() && !cell.is_empty() {
                order = super::libreview::order_evidence(&format!("{cell} 00:00"));
            }
        }
        has_rows.push(rows);
    }
    Ok((has_rows, order.or(given)))
}

/// A date and a time cell as one wall time; a two-digit year (older
/// CareLink exports) is 20YY.
fn wall_time(date: &str, time: &str, order: DateOrder) -> Option<jiff::civil::DateTime> {
    let parts: Vec<&str> = date.split(['/', '.', '-']).collect();
    let date = match (order, parts.as_slice()) {
        (DateOrder::DayFirst | DateOrder::MonthFirst, [a, b, y]) if y.len() == 2 => {
            format!("{a}/{b}/20{y}")
        }
        _ => date.to_string(),
    };
    parse_wall(&format!("{date} {time}"), order)
}

/// `h:mm:ss` as whole minutes.
fn hms_minutes(text: &str) -> Option<f64> {
    let mut p = text.split(':');
    let (h, m, s) = (p.next()?, p.next()?, p.next().unwrap_or("0"));
    if p.next().is_some() {
        return None;
    }
    let n = |x: &str| x.trim().parse::<u32>().ok().map(f64::from);
    Some(n(h)? * 60.0 + n(m)? + n(s)? / 60.0)
}

/// What one pump or sensor row says (at least one record: a row abba does
/// not read is counted).
fn row_kinds(
    t: &Table<'_>,
    c: &Cols,
    at: &Location,
    grams_per_exchange: Option<f64>,
) -> Result<Vec<RecordKind>, IoError> {
    let delim = t.delimiter;
    let cell = |i: Option<usize>| i.map_or("", |i| t.cell(i));
    let name = |i: Option<usize>| i.map_or(String::new(), |i| t.header[i].clone());
    let num = |i: Option<usize>, what: &str| -> Result<Option<f64>, IoError> {
        let text = cell(i);
        if text.is_empty() {
            return Ok(None);
        }
        number(text, delim).map(Some).ok_or_else(|| {
            IoError::invalid(
                at.clone(),
                &name(i),
                format!("expected {what}, got \"{text}\""),
            )
        })
    };
    let glucose = |i: Option<usize>| -> Result<Option<Glucose>, IoError> {
        let Some(v) = num(i, "a glucose number")? else {
            return Ok(None);
        };
        let n = name(i);
        let unit = super::table::unit_in_name(&n).ok_or_else(|| IoError::Units {
            file: at.file.clone(),
            message: format!("column \"{n}\" names no unit (expected mg/dL or mmol/L)"),
        })?;
        let mg = units::glucose_mg_dl(at, &n, v, unit)?;
        Ok(Some(Glucose {
            mg_dl: MgDl(mg),
            censor: Censor::Exact,
        }))
    };
    let insulin = |v: f64, i: Option<usize>| {
        check_range(at, &name(i), v, 0.0, units::BOLUS_MAX_U, "insulin (U)").map(Units)
    };
    let minutes = |i: Option<usize>| -> Result<Option<u32>, IoError> {
        let text = cell(i);
        if text.is_empty() {
            return Ok(None);
        }
        let m = hms_minutes(text).ok_or_else(|| {
            IoError::invalid(
                at.clone(),
                &name(i),
                format!("expected h:mm:ss, got \"{text}\""),
            )
        })?;
        Ok(Some(
            check_range(
                at,
                &name(i),
                m,
                0.0,
                units::DURATION_MAX_MIN,
                "duration (min)",
            )?
            .round() as u32,
        ))
    };
    let mut kinds = Vec::new();
    if let Some(g) = glucose(c.sensor)? {
        kinds.push(RecordKind::Cgm { glucose: g });
    }
    if let Some(g) = glucose(c.bg)? {
        kinds.push(RecordKind::Smbg { glucose: g });
    }
    if let Some(r) = num(c.basal, "a basal rate (U/h)")? {
        let r = check_range(
            at,
            &name(c.basal),
            r,
            0.0,
            units::BASAL_MAX_U_PER_H,
            "basal rate (U/h)",
        )?;
        kinds.push(RecordKind::Schedule {
            profile: Box::new(Profile::basal_only(BasalSchedule::flat(UnitsPerHour(r)))),
        });
    }
    if let Some(v) = num(c.temp_amount, "a temporary basal amount")? {
        let duration = minutes(c.temp_duration)?.ok_or_else(|| {
            IoError::invalid(
                at.clone(),
                &name(c.temp_duration),
                "missing: a temporary basal needs its duration (h:mm:ss)",
            )
        })?;
        let rate = match cell(c.temp_type).to_ascii_lowercase().as_str() {
            "absolute" => TempRate::Absolute(UnitsPerHour(check_range(
                at,
                &name(c.temp_amount),
                v,
                0.0,
                units::BASAL_MAX_U_PER_H,
                "basal rate (U/h)",
            )?)),
            "percent" => TempRate::Percent(check_range(
                at,
                &name(c.temp_amount),
                v,
                0.0,
                units::PERCENT_MAX,
                "percentage of the scheduled rate",
            )?),
            other => {
                return Err(IoError::invalid(
                    at.clone(),
                    &name(c.temp_type),
                    format!("expected Absolute or Percent, got \"{other}\""),
                ))
            }
        };
        kinds.push(RecordKind::TempBasal {
            rate,
            duration_min: duration,
        });
    }
    let bolus_type = cell(c.bolus_type);
    if !bolus_type.is_empty() {
        let source = cell(c.bolus_source);
        match num(c.bolus_delivered, "insulin delivered (U)")? {
            None => kinds.push(RecordKind::Ignored {
                kind: format!("bolus {bolus_type} without a delivered volume"),
            }),
            Some(_) if source.contains("AUTO_BASAL") => kinds.push(RecordKind::Ignored {
                kind: "SmartGuard auto basal micro-bolus".into(),
            }),
            Some(u) => {
                let units = insulin(u, c.bolus_delivered)?;
                let lower = bolus_type.to_ascii_lowercase();
                if lower.contains("square") {
                    kinds.push(RecordKind::ExtendedBolus {
                        now: Units(0.0),
                        extended: units,
                        duration_min: minutes(c.bolus_duration)?.ok_or_else(|| {
                            IoError::invalid(
                                at.clone(),
                                &name(c.bolus_duration),
                                "missing: a square bolus needs its duration (h:mm:ss)",
                            )
                        })?,
                    });
                } else if lower == "normal" || lower.contains("normal") {
                    kinds.push(RecordKind::Bolus { units });
                } else {
                    return Err(IoError::invalid(
                        at.clone(),
                        &name(c.bolus_type),
                        format!("expected Normal, Square or Dual (normal part / square part), got \"{bolus_type}\""),
                    ));
                }
            }
        }
    }
    if let Some(v) = num(c.carbs, "carbohydrate")? {
        let n = name(c.carbs);
        let grams = match (in_exchanges(&n), grams_per_exchange) {
            (false, _) => Some(v),
            (true, Some(g)) => Some(v * g),
            (true, None) => None,
        };
        let status = cell(c.bwz_status);
        match grams {
            None => kinds.push(RecordKind::Ignored {
                kind: "BWZ carb input in exchanges (no --grams-per-exchange)".into(),
            }),
            // The 780G says what became of the wizard: carbohydrate of one
            // whose bolus was not delivered (declined, a low, confirmed
            // again later) is no meal.
            Some(g) if g > 0.0 && status.eq_ignore_ascii_case("Not Delivered") => {
                kinds.push(RecordKind::Ignored {
                    kind: "bolus wizard carbohydrate not delivered (BWZ Status Not Delivered)"
                        .into(),
                })
            }
            Some(g)
                if g > 0.0 && !status.is_empty() && !status.eq_ignore_ascii_case("Delivered") =>
            {
                kinds.push(RecordKind::Ignored {
                    kind: format!("bolus wizard carbohydrate with BWZ Status {status} (not read)"),
                })
            }
            Some(g) if g > 0.0 => kinds.push(RecordKind::Carbs {
                grams: Grams(check_range(
                    at,
                    &n,
                    g,
                    0.0,
                    units::CARBS_MAX_G,
                    "carbohydrate (g)",
                )?),
            }),
            Some(_) => {}
        }
    }
    let marker = cell(c.marker);
    if !marker.is_empty() {
        kinds.push(event_marker(
            marker,
            delim,
            at,
            &name(c.marker),
            grams_per_exchange,
        )?);
    }
    let state = cell(c.suspend);
    if !state.is_empty() {
        kinds.push(match pump_state(state) {
            Some(PumpState::Suspended) => RecordKind::Suspend { duration_min: None },
            Some(PumpState::Resumed) => RecordKind::Resume,
            None => RecordKind::Ignored {
                kind: format!("unknown suspend state {state}"),
            },
        });
    }
    for (col, what) in [
        (c.alarm, "alarm"),
        (c.rewind, "rewind"),
        (c.prime, "prime"),
        (c.time_change, "pump time change"),
    ] {
        if !cell(col).is_empty() {
            kinds.push(RecordKind::Ignored { kind: what.into() });
        }
    }
    if kinds.is_empty() {
        kinds.push(RecordKind::Ignored {
            kind: "other pump or sensor event".into(),
        });
    }
    Ok(kinds)
}

/// A `Meal:` marker of this many grams or fewer is a meal without its
/// amount: a real Guardian 4 export (CGM only, injections logged in the
/// app) marks every meal `Meal: 1.00grams` (23 of 23) beside its 8 to
/// 25 U injection; no meal is 1 g, and read as one it would make a carb
/// ratio of 0.04 g/U. Counted and noted, not read.
const MEAL_MARKER_NO_AMOUNT_G: f64 = 1.0;

/// The kind an `Insulin: N` event marker is counted as: an injection
/// logged in a CGM's app (Guardian Connect, Guardian 4), whose dose
/// CareLink gives but not whether it was rapid- or long-acting. Not read
/// as a bolus or a basal, but evidence of injections
/// ([`crate::automation::Evidence`]) and insulin at a meal for the rescue
/// rule ([`crate::rescue`]).
pub const INSULIN_MARKER: &str = "event marker insulin (acting type not given)";

/// The kind a [`MEAL_MARKER_NO_AMOUNT_G`] marker is counted as.
const MEAL_WITHOUT_AMOUNT: &str =
    "event marker meal without its amount (1 g or less, not read as carbohydrate)";

/// An event marker's text: `Meal: 60,00grams` is carbohydrate (more than
/// [`MEAL_MARKER_NO_AMOUNT_G`]), and so is
/// `Meal: 2.00exchanges` with `grams_per_exchange` (without it: counted,
/// the file's note says so); `Insulin: 27,00` an injection whose acting
/// type CareLink does not say (counted); any other marker is counted by
/// its name.
fn event_marker(
    text: &str,
    delim: u8,
    at: &Location,
    field: &str,
    grams_per_exchange: Option<f64>,
) -> Result<RecordKind, IoError> {
    let (label, value) = text.split_once(':').unwrap_or((text, ""));
    let label = label.trim();
    let value = value.trim();
    Ok(match label.to_ascii_lowercase().as_str() {
        "meal" => {
            let (amount, per) = match value.strip_suffix("exchanges") {
                Some(ex) => (ex, grams_per_exchange),
                None => (value.trim_end_matches("grams"), Some(1.0)),
            };
            let v = number(amount.trim(), delim).ok_or_else(|| {
                IoError::invalid(
                    at.clone(),
                    field,
                    format!("expected \"Meal: <grams>grams\" or \"Meal: <exchanges>exchanges\", got \"{text}\""),
                )
            })?;
            let Some(per) = per else {
                return Ok(RecordKind::Ignored {
                    kind: "event marker meal in exchanges (no --grams-per-exchange)".into(),
                });
            };
            if v * per <= MEAL_MARKER_NO_AMOUNT_G {
                return Ok(RecordKind::Ignored {
                    kind: MEAL_WITHOUT_AMOUNT.into(),
                });
            }
            RecordKind::Carbs {
                grams: Grams(check_range(
                    at,
                    field,
                    v * per,
                    0.0,
                    units::CARBS_MAX_G,
                    "carbohydrate (g)",
                )?),
            }
        }
        "insulin" => {
            number(value, delim).ok_or_else(|| {
                IoError::invalid(
                    at.clone(),
                    field,
                    format!("expected \"Insulin: <units>\", got \"{text}\""),
                )
            })?;
            RecordKind::Ignored {
                kind: INSULIN_MARKER.into(),
            }
        }
        _ => RecordKind::Ignored {
            kind: format!("event marker {label}"),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rate_row(u_per_h: f64) -> RecordKind {
        RecordKind::Schedule {
            profile: Box::new(Profile::basal_only(BasalSchedule::flat(UnitsPerHour(
                u_per_h,
            )))),
        }
    }

    fn scheduled(k: &RecordKind) -> Option<f64> {
        match k {
            RecordKind::Schedule { profile } => profile.basal.segments.first().map(|s| s.1 .0),
            _ => None,
        }
    }

    #[test]
    fn a_paradigm_rate_row_is_the_rate_in_effect_and_says_the_schedule_only_where_it_can() {
        // Pumping normally: the row is the schedule.
        assert_eq!(
            scheduled(&in_effect(rate_row(0.65), false, None)),
            Some(0.65)
        );
        // Under a 70 % temporary basal, 0.46 U/h in effect: 0.657 scheduled.
        let k = in_effect(rate_row(0.46), false, Some(TempRate::Percent(70.0)));
        assert!((scheduled(&k).unwrap() - 0.46 / 0.7).abs() < 1e-12);
        // Suspended, 0 %, absolute: nothing about the schedule (counted).
        for (susp, temp) in [
            (true, None),
            (false, Some(TempRate::Percent(0.0))),
            (false, Some(TempRate::Absolute(UnitsPerHour(0.3)))),
        ] {
            let k = in_effect(rate_row(0.0), susp, temp);
            assert!(
                matches!(k, RecordKind::Ignored { .. }),
                "{susp} {temp:?}: {k:?}"
            );
        }
        // A 1 % temporary basal at 0.6 U/h would imply 60 U/h scheduled:
        // above the plausible basal, so not read.
        let k = in_effect(rate_row(0.6), false, Some(TempRate::Percent(1.0)));
        let RecordKind::Ignored { kind } = &k else {
            panic!("{k:?}")
        };
        assert!(kind.contains("60.00 U/h"), "{kind}");
    }

    #[test]
    fn durations_and_dates_read_as_carelink_writes_them() {
        assert_eq!(hms_minutes("0:30:00"), Some(30.0));
        assert_eq!(hms_minutes("2:00:00"), Some(120.0));
        assert_eq!(hms_minutes("x"), None);
        let w = wall_time("30.10.16", "17:36:29", DateOrder::DayFirst);
        assert_eq!(w.map(|d| d.to_string()), Some("2016-10-30T17:36:29".into()));
        let w = wall_time("2025/10/30", "00:05:00", DateOrder::YearFirst);
        assert_eq!(w.map(|d| d.to_string()), Some("2025-10-30T00:05:00".into()));
    }

    #[test]
    fn sections_are_told_by_their_divider() {
        assert_eq!(
            section_of("-------;MiniMed 780G MMT-1886;Pump;NG4114235H;-------"),
            Section::Pump
        );
        assert_eq!(
            section_of("-------;MiniMed 780G MMT-1886;Sensor;NG4114235H;-------"),
            Section::Sensor
        );
        assert_eq!(
            section_of(
                "-------;MiniMed 780G MMT-1886;Pump;NG4114235H;Aggregated Auto Insulin Data"
            ),
            Section::Totals
        );
    }
}
