//! Abbott LibreView CSV (FreeStyle Libre 1/2/3): a metadata line
//! (`Glucose Data,Generated on,...`), the header, then one row per record
//! with its `Record Type`: 0 historic glucose (every 15 min, 5 on Libre 3),
//! 1 scan glucose, 2 strip (meter) glucose, 3 ketone, 4 insulin, 5 food,
//! 6 notes and time changes. Device times carry no offset and come in the
//! account's locale: `12-04-1961 22:30` (day first), `05-01-2024 12:03 AM`
//! (month first with AM/PM), `20-12-2021 11:15 PM` (day first with AM/PM),
//! `2024/05/01 00:03` (year first), `24.02.2021 07:00` (day first with
//! dots); the older FreeStyle Libre software's "Patient report" writes
//! `8/1/18 12:00` (no leading zeros, a two-digit year: 20YY). The order is
//! taken from the file's own evidence (a day above 12, a four-digit year
//! first; AM/PM tells nothing) or `--date-order`, never guessed. The header is written in the
//! account's language and found among the first lines
//! ([`libreview_columns`]); numbers may use a decimal comma (`"5,6"`).
//! Scan (type 1), ketone (3) and note (6) rows are counted, not read.
//! One sensor's history uploaded by two devices is read once
//! ([`libreview_devices`]). A device clock set back in the file (a trip
//! west) is reported and its repeated times not read ([`libreview_clock`]).

use abba_core::{Grams, MgDl, Units};

use super::libreview_clock;
use super::libreview_columns::{self, Role};
use super::libreview_devices;
use super::table::{number, Table};
use super::{or_skip, Ctx};
use crate::error::{IoError, Location, Place};
use crate::record::{row_id, Glucose, Record, RecordKind, Source};
use crate::time::{parse_wall, DateOrder, WallClock};
use crate::units::{self, check_range, GlucoseUnit};

/// Whether one of the first lines is a LibreView header (in any language
/// abba knows, see [`libreview_columns`]).
pub fn looks_like(head: &str) -> bool {
    head.lines()
        .take(HEADER_SEARCH_LINES)
        .any(|l| libreview_columns::is_header(&libreview_columns::cells(l)))
}

/// How many lines may come before the header (metadata: "Glucose Data,
/// Generated on, ...", a patient line).
const HEADER_SEARCH_LINES: usize = 10;

/// The 0-based line of the header, or an error showing the first line.
fn header_line(file: &str, bytes: &[u8]) -> Result<usize, IoError> {
    let mut first = None;
    for (i, line) in bytes
        .split(|&b| b == b'\n')
        .take(HEADER_SEARCH_LINES)
        .enumerate()
    {
        let text = String::from_utf8_lossy(line);
        let cells = libreview_columns::cells(text.trim_end_matches('\r'));
        if libreview_columns::is_header(&cells) {
            return Ok(i);
        }
        if first.is_none() && cells.len() > 3 {
            first = Some((i, text.trim().to_string()));
        }
    }
    Err(IoError::format(
        file,
        format!(
            "no LibreView header in the first {HEADER_SEARCH_LINES} lines: expected a row with \
             the device time, the record type and a glucose column naming its unit (mg/dL or \
             mmol/L), in English, German, French, Spanish, Italian, Dutch or Traditional Chinese{}",
            first.map_or(String::new(), |(i, t)| format!(
                "; line {} is \"{}\"",
                i + 1,
                t.chars().take(200).collect::<String>()
            ))
        ),
    ))
}

/// What one time cell says about the date order, if anything: a
/// four-digit first number (year first), a first number above 12 (day
/// first) or a second number above 12 (month first). AM/PM says nothing:
/// LibreView writes the 12-hour clock with either order (`05-01-2024 12:03
/// AM` in the US, `20-12-2021 11:15 PM` elsewhere).
pub(crate) fn order_evidence(cell: &str) -> Option<DateOrder> {
    let s = cell.trim().trim_matches('"');
    let date = s.split([' ', 'T']).next()?;
    let mut parts = date.split(['-', '/', '.']);
    let (a, b) = (parts.next()?, parts.next()?);
    let digits = |x: &str| !x.is_empty() && x.bytes().all(|c| c.is_ascii_digit());
    if !digits(a) || !digits(b) {
        return None;
    }
    if a.len() == 4 {
        return Some(DateOrder::YearFirst);
    }
    let (a, b): (u32, u32) = (a.parse().ok()?, b.parse().ok()?);
    match (a > 12, b > 12) {
        (true, false) => Some(DateOrder::DayFirst),
        (false, true) => Some(DateOrder::MonthFirst),
        _ => None,
    }
}

/// Where the file's date order was learnt (for messages).
enum OrderFrom {
    /// A row whose date tells (its line and time cell).
    Row(u64, String),
    /// `--date-order`, every date being possible both ways.
    Given,
}

impl OrderFrom {
    /// The order and its source in words, with an example of it.
    fn describe(&self, order: DateOrder) -> String {
        let (what, example) = match order {
            DateOrder::DayFirst => ("day first", "12-04-2024 22:30"),
            DateOrder::MonthFirst => ("month first", "04-12-2024 10:30 PM"),
            DateOrder::YearFirst => ("year first", "2024-04-12 22:30"),
        };
        match self {
            Self::Row(line, text) => format!("like \"{text}\" ({what}, as line {line} shows)"),
            Self::Given => {
                format!("like {example} ({what}, as --date-order says; no date in the file tells)")
            }
        }
    }
}

fn order_name(o: DateOrder) -> &'static str {
    match o {
        DateOrder::DayFirst => "day-first",
        DateOrder::MonthFirst => "month-first",
        DateOrder::YearFirst => "year-first",
    }
}

/// The file's date order: the first time cell that tells (checked against
/// `--date-order` when given: a disagreement is an error), else the order
/// given, else an error naming the first row (never guessed). A year-first
/// file needs no order.
fn date_order(
    t: &mut Table<'_>,
    column: usize,
    given: Option<DateOrder>,
) -> Result<(DateOrder, OrderFrom), IoError> {
    let mut first: Option<(u64, String)> = None;
    while let Some(line) = t.next_row()? {
        let text = t.cell(column);
        if text.is_empty() {
            continue;
        }
        first.get_or_insert_with(|| (line, text.to_string()));
        let Some(o) = order_evidence(text) else {
            continue;
        };
        return match given {
            Some(g) if o != DateOrder::YearFirst && g != o => Err(IoError::invalid(
                Location::line(t.file, line),
                &t.header[column],
                format!(
                    "\"{text}\" can only be {} (a number above 12 where the {} would be), but \
                     --date-order says {}",
                    order_name(o),
                    if o == DateOrder::DayFirst {
                        "month"
                    } else {
                        "day"
                    },
                    order_name(g)
                ),
            )),
            _ => Ok((o, OrderFrom::Row(line, text.to_string()))),
        };
    }
    match (given, first) {
        (Some(g), _) => Ok((g, OrderFrom::Given)),
        (None, Some((line, text))) => Err(IoError::invalid(
            Location::line(t.file, line),
            &t.header[column],
            format!(
                "\"{text}\" and every date after it could be day-first or month-first (no day \
                 above 12; AM/PM does not tell, LibreView writes it with either order); give \
                 --date-order day-first or month-first"
            ),
        )),
        // No row with a time: nothing to read, the order does not matter.
        (None, None) => Ok((DateOrder::YearFirst, OrderFrom::Given)),
    }
}

/// Reads a LibreView export: the header line and columns, the date
/// order, then each row's time and records.
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let file = ctx.file;
    let header_at = header_line(file, bytes)?;
    let mut t = Table::open(file, bytes, header_at)?;
    let cols = Columns::of(&t, ctx)?;
    let tz = ctx.require_tz("LibreView writes device times without an offset")?;
    let mut wall = WallClock::new(tz.clone());
    let time_name = t.header[cols.time].clone();
    let (order, from) = date_order(
        &mut Table::open(file, bytes, header_at)?,
        cols.time,
        ctx.opts.date_order,
    )?;
    // Another device's copy of the main device's historic readings.
    let copies = match cols.serial {
        Some(serial) => libreview_devices::find(
            &mut Table::open(file, bytes, header_at)?,
            serial,
            cols.time,
            cols.record_type,
            cols.historic,
            order,
        )?,
        None => libreview_devices::Duplicates::default(),
    };
    for note in &copies.notes {
        ctx.note(note.as_str());
    }
    let mut out = Vec::with_capacity(t.lines_left());
    let (mut historic_rows, mut scan_rows, mut scans_in_historic) = (0usize, 0usize, 0usize);
    // One location reused for every row (no allocation per row).
    let mut at = Location::line(file, 0);
    while let Some(line) = t.next_row()? {
        at.place = Place::Line(line);
        let text = t.cell(cols.time);
        let dt = or_skip!(
            ctx,
            parse_wall(text, order).ok_or_else(|| {
                IoError::invalid(
                    at.clone(),
                    &time_name,
                    format!(
                        "expected a device time {}, got \"{text}\"",
                        from.describe(order)
                    ),
                )
            })
        );
        let instant = or_skip!(ctx, wall.resolve(dt, &at, &time_name));
        let row = Row {
            t: &t,
            cols: &cols,
            at: &at,
        };
        for mut kind in or_skip!(ctx, row.kinds()) {
            if matches!(kind, RecordKind::Cgm { .. }) && copies.lines.contains(&line) {
                kind = RecordKind::Ignored {
                    kind: libreview_devices::SECOND_DEVICE.into(),
                };
            }
            match &kind {
                RecordKind::Cgm { .. } => historic_rows += 1,
                RecordKind::Ignored { kind } if kind == SCAN => {
                    scan_rows += 1;
                    scans_in_historic += usize::from(!t.cell(cols.historic).is_empty());
                }
                _ => {}
            }
            out.push(Record {
                at: instant,
                id: row_id(Source::LibreView, instant, &kind, t.raw(), None),
                kind,
                source: Source::LibreView,
                origin: ctx.origin_line(line),
            });
        }
    }
    if let Some(note) = libreview_clock::mark(&mut out, &tz) {
        ctx.note(note);
    }
    if historic_rows == 0 && scan_rows > 0 {
        // Without a word, `metrics` would only find no CGM reading.
        ctx.note(format!(
            "no historic glucose row (record type 0, the CGM series abba reads): the {scan_rows} \
             rows of record type 1 (scan glucose) are counted, not read as CGM{}",
            if scans_in_historic > 0 {
                format!(
                    "; {scans_in_historic} of them have their value in the column \"{}\", but \
                     their record type says scan",
                    t.header[cols.historic]
                )
            } else {
                String::new()
            }
        ));
    }
    Ok(out)
}

/// The ignored kind of a scan row (record type 1).
const SCAN: &str = "scan glucose";

/// One data row with its columns and place, read by record type.
struct Row<'r, 't> {
    t: &'r Table<'t>,
    cols: &'r Columns,
    at: &'r Location,
}

impl Row<'_, '_> {
    /// A number cell (`None` when the column is absent or the cell empty),
    /// with its column's name.
    fn value(&self, i: Option<usize>) -> Result<Option<(String, f64)>, IoError> {
        let Some(i) = i else { return Ok(None) };
        let text = self.t.cell(i);
        if text.is_empty() {
            return Ok(None);
        }
        let name = self.t.header[i].clone();
        let v = number(text, self.t.delimiter).ok_or_else(|| {
            IoError::invalid(
                self.at.clone(),
                &name,
                format!("expected a number, got \"{text}\""),
            )
        })?;
        Ok(Some((name, v)))
    }

    /// A glucose cell in its column's unit, which the record type needs.
    fn glucose(&self, i: Option<usize>, what: &str) -> Result<Glucose, IoError> {
        let found = match i {
            None => None,
            Some(i) => match self.value(Some(i))? {
                None => None,
                Some((name, v)) => Some(Glucose {
                    mg_dl: MgDl(units::glucose_mg_dl(self.at, &name, v, self.cols.unit(i))?),
                    censor: crate::record::Censor::Exact,
                }),
            },
        };
        found.ok_or_else(|| {
            IoError::invalid(
                self.at.clone(),
                what,
                "the record type needs this value; the cell is empty",
            )
        })
    }

    /// The row's records by its record type (0 historic, 1 scan, 2 strip,
    /// 3 ketone, 4 insulin, 5 food, 6 note).
    fn kinds(&self) -> Result<Vec<RecordKind>, IoError> {
        let (t, cols) = (self.t, self.cols);
        let rtype = t.cell(cols.record_type).to_string();
        if rtype.is_empty() || !rtype.bytes().all(|b| b.is_ascii_digit()) {
            return Err(IoError::invalid(
                self.at.clone(),
                &t.header[cols.record_type],
                format!("expected a record type number (0 historic, 1 scan, 2 strip, 3 ketone, 4 insulin, 5 food, 6 note), got \"{rtype}\""),
            ));
        }
        if matches!(rtype.as_str(), "4" | "5") {
            self.refuse_unknown_numbers()?;
        }
        let ignored = |kind: &str| vec![RecordKind::Ignored { kind: kind.into() }];
        Ok(match rtype.trim_start_matches('0') {
            "" => vec![RecordKind::Cgm {
                glucose: self.glucose(Some(cols.historic), &t.header[cols.historic])?,
            }],
            "1" => ignored(SCAN),
            "2" => vec![RecordKind::Smbg {
                glucose: self.glucose(
                    cols.strip,
                    cols.strip
                        .map_or("strip glucose (no such column)", |i| t.header[i].as_str()),
                )?,
            }],
            "3" => ignored("ketone"),
            "4" => self.insulin()?,
            "5" => self.food()?,
            "6" => ignored("note or time change"),
            other => ignored(&format!("record type {other}")),
        })
    }

    /// A number in a column abba cannot name would be insulin or food
    /// lost without a word: refuse instead.
    fn refuse_unknown_numbers(&self) -> Result<(), IoError> {
        let t = self.t;
        match self
            .cols
            .unknown
            .iter()
            .find(|&&i| number(t.cell(i), t.delimiter).is_some())
        {
            Some(&i) => Err(IoError::invalid(
                self.at.clone(),
                &t.header[i],
                format!(
                    "this insulin or food row has the number \"{}\" in a column abba does \
                     not recognise; expected rapid-acting, long-acting, meal or correction \
                     insulin (units) or carbohydrates (grams or servings)",
                    t.cell(i)
                ),
            )),
            None => Ok(()),
        }
    }

    /// An insulin row: rapid-acting (or meal + correction) as a bolus,
    /// long-acting as an injection. A dose the person changed from the
    /// calculator's suggestion (`User Change Insulin`) without the
    /// rapid-acting dose given is refused: whether the change adds to the
    /// meal and correction parts is not written, and abba does not guess.
    fn insulin(&self) -> Result<Vec<RecordKind>, IoError> {
        let cols = self.cols;
        let mut kinds = Vec::new();
        if let Some((name, v)) = self.value(cols.user_change)?.filter(|c| c.1 != 0.0) {
            if self.value(cols.rapid)?.is_none() {
                let rapid = cols
                    .rapid
                    .map_or("a rapid-acting insulin column".to_string(), |i| {
                        format!("\"{}\"", self.t.header[i])
                    });
                return Err(IoError::invalid(
                    self.at.clone(),
                    &name,
                    format!(
                        "the person changed the suggested dose by {v} U and the row gives no \
                         rapid-acting dose in {rapid}; abba does not guess the dose given from \
                         the meal and correction parts and the change"
                    ),
                ));
            }
        }
        let bolus = match self.value(cols.rapid)? {
            Some(v) => Some(v),
            None => match (self.value(cols.meal)?, self.value(cols.correction)?) {
                (None, None) => None,
                (a, b) => Some((
                    "Meal + Correction Insulin (units)".to_string(),
                    a.map_or(0.0, |a| a.1) + b.map_or(0.0, |b| b.1),
                )),
            },
        };
        let dose = |name: &str, u: f64| {
            check_range(self.at, name, u, 0.0, units::BOLUS_MAX_U, "insulin (U)").map(Units)
        };
        if let Some((name, u)) = bolus {
            kinds.push(RecordKind::Bolus {
                units: dose(&name, u)?,
            });
        }
        if let Some((name, u)) = self.value(cols.long)? {
            kinds.push(RecordKind::LongActing {
                units: dose(&name, u)?,
            });
        }
        if kinds.is_empty() {
            kinds.push(RecordKind::Ignored {
                kind: "insulin without a number".into(),
            });
        }
        Ok(kinds)
    }

    /// A food row: carbohydrate in grams; servings (grams per serving
    /// unknown) and food without carbohydrate are counted as ignored.
    fn food(&self) -> Result<Vec<RecordKind>, IoError> {
        Ok(vec![match self.value(self.cols.carbs)? {
            Some((name, g)) => RecordKind::Carbs {
                grams: Grams(check_range(
                    self.at,
                    &name,
                    g,
                    0.0,
                    units::CARBS_MAX_G,
                    "carbohydrate (g)",
                )?),
            },
            None if self.value(self.cols.servings)?.is_some() => RecordKind::Ignored {
                kind: "food in servings (grams per serving unknown)".into(),
            },
            None => RecordKind::Ignored {
                kind: "food without carbohydrate".into(),
            },
        }])
    }
}

/// The columns of a LibreView header, by role.
struct Columns {
    time: usize,
    record_type: usize,
    historic: usize,
    strip: Option<usize>,
    rapid: Option<usize>,
    long: Option<usize>,
    meal: Option<usize>,
    correction: Option<usize>,
    user_change: Option<usize>,
    carbs: Option<usize>,
    servings: Option<usize>,
    serial: Option<usize>,
    /// Columns not recognised (checked on insulin and food rows).
    unknown: Vec<usize>,
    /// Each column's glucose unit, if it names one.
    units: Vec<Option<GlucoseUnit>>,
}

impl Columns {
    fn of(t: &Table<'_>, ctx: &Ctx<'_>) -> Result<Self, IoError> {
        let file = ctx.file;
        let roles: Vec<(Role, Option<GlucoseUnit>)> = t
            .header
            .iter()
            .map(|h| libreview_columns::role(h))
            .collect();
        let first = |r: Role| roles.iter().position(|&(x, _)| x == r);
        let need = |r: Role, what: &str| {
            first(r).ok_or_else(|| {
                IoError::format(
                    file,
                    format!(
                        "a LibreView export needs a {what} column; the columns found are {}",
                        t.columns_found()
                    ),
                )
            })
        };
        let mut unknown = Vec::new();
        for (i, &(role, unit)) in roles.iter().enumerate() {
            if role != Role::Unknown {
                continue;
            }
            if unit.is_some() {
                return Err(IoError::format(
                    file,
                    format!(
                        "column \"{}\" names a glucose unit but abba cannot tell whether it holds \
                         historic, scan or strip glucose; the columns found are {}",
                        t.header[i],
                        t.columns_found()
                    ),
                ));
            }
            unknown.push(i);
        }
        let historic = need(Role::Historic, "historic glucose (with mg/dL or mmol/L)")?;
        if let Some(j) = roles
            .iter()
            .enumerate()
            .skip(historic + 1)
            .find_map(|(j, &(r, _))| (r == Role::Historic).then_some(j))
        {
            return Err(IoError::format(
                file,
                format!(
                    "two historic glucose columns, \"{}\" and \"{}\"; expected one",
                    t.header[historic], t.header[j]
                ),
            ));
        }
        t.unit_of_column(historic, ctx.opts.units)?;
        Ok(Self {
            time: need(Role::Time, "device time")?,
            record_type: need(Role::RecordType, "record type")?,
            historic,
            strip: first(Role::Strip),
            rapid: first(Role::Rapid),
            long: first(Role::Long),
            meal: first(Role::Meal),
            correction: first(Role::Correction),
            user_change: first(Role::UserChange),
            carbs: first(Role::CarbsGrams),
            servings: first(Role::CarbsServings),
            serial: first(Role::Serial),
            unknown,
            units: roles.iter().map(|&(_, u)| u).collect(),
        })
    }

    /// The glucose unit of column `i` (every glucose column names one).
    fn unit(&self, i: usize) -> GlucoseUnit {
        self.units
            .get(i)
            .copied()
            .flatten()
            .unwrap_or(GlucoseUnit::MgDl)
    }
}
