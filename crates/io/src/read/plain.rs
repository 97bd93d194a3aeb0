//! Plain CSV with named columns: a time column (`time`, `timestamp`,
//! `datetime`, `date`, or `minute` for abba's own outputs), a glucose
//! column (`glucose`, `gl`, `sgv`, `cgm`, or named with `--glucose-column`),
//! and optionally `carbs`, `bolus`, `basal`. The glucose unit comes from the
//! column name (`..._mg_dl`, `... (mmol/L)`) or from `--units`.

use abba_core::{Grams, Units, UnitsPerHour};

use super::table::{required_number, unit_in_name, Table};
use super::{or_skip, Ctx};
use crate::error::{IoError, Location, Place};
use crate::record::{content_id, BasalSchedule, Glucose, Profile, Record, RecordKind, Source};
use crate::time::{has_offset, parse_instant, parse_wall, DateOrder, WallClock};
use crate::units::{self, check_range, GlucoseUnit};

const TIME_NAMES: [&str; 6] = [
    "time",
    "timestamp",
    "datetime",
    "date_time",
    "date",
    "minute",
];
const GLUCOSE_NAMES: [&str; 7] = [
    "glucose",
    "gl",
    "sgv",
    "cgm",
    "cgm_mg_dl",
    "glucose_mg_dl",
    "glucose_mmol_l",
];

/// The date order of the time column (or of `date` beside `time`): year
/// first, or what the dates show (a day above 12), or `--date-order`;
/// dates that contradict one another are an error naming both lines.
fn date_order(
    ctx: &Ctx<'_>,
    bytes: &[u8],
    (date_at, clock_at): (usize, Option<usize>),
) -> Result<DateOrder, IoError> {
    let mut t = Table::open(ctx.file, bytes, 0)?;
    let mut seen: Option<(DateOrder, u64)> = None;
    let mut undecided = false;
    while let Some(line) = t.next_row()? {
        let date = t.cell(date_at);
        if date.is_empty() || has_offset(date) {
            continue;
        }
        let text = match clock_at {
            Some(c) => format!("{date} {}", t.cell(c)),
            None => date.to_string(),
        };
        match super::libreview::order_evidence(&text) {
            None => undecided = true,
            Some(o) => match seen {
                None => seen = Some((o, line)),
                Some((first, first_line)) if first != o => {
                    return Err(IoError::invalid(
                        Location::line(ctx.file, line),
                        &t.header[date_at],
                        format!(
                            "date \"{date}\" is {o:?} but line {first_line} is {first:?}: the \
                             file mixes date orders"
                        ),
                    ))
                }
                Some(_) => {}
            },
        }
    }
    match (seen, ctx.opts.date_order) {
        (Some((DateOrder::YearFirst, _)), _) => Ok(DateOrder::YearFirst),
        (Some((o, _)), Some(given)) if given != o => Err(IoError::format(
            ctx.file,
            format!("the dates are {o:?} but --date-order says {given:?}"),
        )),
        (Some((o, _)), _) => Ok(o),
        (None, Some(given)) => Ok(given),
        (None, None) if undecided => Err(IoError::format(
            ctx.file,
            "every date could be day-first or month-first (no day above 12); give --date-order \
             day-first or month-first",
        )),
        (None, None) => Ok(DateOrder::YearFirst),
    }
}

fn find(table: &Table<'_>, wanted: &str) -> Option<usize> {
    table.column(|h| h.eq_ignore_ascii_case(wanted))
}

/// The columns of a plain CSV and how its times and glucose are read.
struct Columns {
    time_at: usize,
    /// A research dataset's separate `date` and `time` columns.
    split: Option<(usize, usize)>,
    time_name: String,
    /// abba's own `minute` column: minutes since 00:00 of day 1.
    minute_clock: bool,
    order: DateOrder,
    type_at: Option<usize>,
    glucose_at: Option<usize>,
    glucose_name: String,
    /// The glucose unit, and whether the file's column name says it.
    unit: Option<GlucoseUnit>,
    declared_in_file: bool,
    carbs_at: Option<usize>,
    bolus_at: Option<usize>,
    basal_at: Option<usize>,
    id_at: Option<usize>,
}

/// Reads a plain CSV: its columns, then each row's time, glucose and
/// amounts.
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let file = ctx.file;
    let mut t = Table::open(file, bytes, 0)?;
    let c = Columns::find(ctx, &t, bytes)?;
    let tz = ctx.opts.tz.clone().unwrap_or(jiff::tz::TimeZone::UTC);
    let mut rows = Rows {
        wall: WallClock::new(tz.clone()),
        tz,
        with_offset: None,
        first_id: None,
        subject_seen: false,
    };
    let mut raw_glucose = Vec::new();
    let mut out = Vec::with_capacity(t.lines_left());
    // One location reused for every row (no allocation per row).
    let mut at = Location::line(file, 0);
    while let Some(line) = t.next_row()? {
        at.place = Place::Line(line);
        // (Several subjects without --subject is the file's error.)
        if !rows.is_wanted_subject(ctx, &t, &c, &at, line)? {
            continue;
        }
        // A row is read whole or not at all.
        let instant = or_skip!(ctx, rows.instant(&t, &c, &at, line));
        let glucose = or_skip!(ctx, glucose_record(&t, &c, &at, line));
        let amounts = or_skip!(ctx, amount_records(&t, &c, &at, line));
        let mut push = |kind: RecordKind| {
            out.push(Record {
                at: instant,
                id: content_id(Source::PlainCsv, instant, &kind),
                kind,
                source: Source::PlainCsv,
                origin: ctx.origin_line(line),
            })
        };
        if let Some((kind, raw)) = glucose {
            raw_glucose.push(raw);
            push(kind);
        }
        for kind in amounts {
            push(kind);
        }
    }
    if let (Some(wanted), false) = (&ctx.opts.subject, rows.subject_seen) {
        return Err(IoError::format(
            file,
            format!("no rows with id \"{wanted}\""),
        ));
    }
    if let (Some(unit), false) = (c.unit, c.declared_in_file) {
        units::check_median(file, &raw_glucose, unit)?;
    }
    Ok(out)
}

impl Columns {
    /// Finds every column (named by the options or by the usual names),
    /// the date order and the glucose unit; refuses a file whose columns
    /// cannot be read, naming the columns found.
    fn find(ctx: &Ctx<'_>, t: &Table<'_>, bytes: &[u8]) -> Result<Columns, IoError> {
        let file = ctx.file;
        let data: Vec<&String> = t.header.iter().filter(|c| looks_like_data(c)).collect();
        if data.len() >= 2 {
            return Err(IoError::format(
                file,
                format!(
                    "line {} looks like data, not a header ({}): a plain CSV needs a first line \
                     naming its columns (for example time,glucose_mg_dl); add one, or give the \
                     export's own format with --format",
                    t.header_line,
                    data.iter()
                        .map(|c| format!("\"{c}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        let time_at = time_column(ctx, t)?;
        let split = match (
            ctx.opts.time_column.is_none(),
            find(t, "date"),
            find(t, "time"),
        ) {
            (true, Some(d), Some(c)) => Some((d, c)),
            _ => None,
        };
        let time_name = match split {
            Some((d, c)) => format!("{} + {}", t.header[d], t.header[c]),
            None => t.header[time_at].clone(),
        };
        let minute_clock = split.is_none() && time_name.eq_ignore_ascii_case("minute");
        // Every column is found before the dates are read, so that a file
        // missing several things says so column first, not in turns.
        let glucose_at = glucose_column(ctx, t)?;
        let carbs_at = find(t, "carbs").or_else(|| find(t, "carbs_g"));
        let bolus_at = find(t, "bolus").or_else(|| find(t, "bolus_u"));
        let basal_at = find(t, "basal").or_else(|| find(t, "basal_u_per_h"));
        if glucose_at.is_none() && carbs_at.is_none() && bolus_at.is_none() && basal_at.is_none() {
            return Err(IoError::format(
                file,
                format!(
                    "no glucose column \"glucose\" (or \"gl\", \"sgv\", \"cgm\"), nor carbs, bolus or \
                     basal; the columns found are {} (choose one with --glucose-column)",
                    t.columns_found()
                ),
            ));
        }
        let order = if minute_clock {
            DateOrder::YearFirst
        } else {
            date_order(
                ctx,
                bytes,
                split.map_or((time_at, None), |(d, c)| (d, Some(c))),
            )?
        };
        let glucose_name = glucose_at.map(|i| t.header[i].clone()).unwrap_or_default();
        let named = glucose_at.and_then(|i| unit_in_name(&t.header[i]));
        let unit = glucose_unit(ctx, &glucose_name, glucose_at.is_some(), named)?;
        let id_at = find(t, "id");
        if ctx.opts.subject.is_some() && id_at.is_none() {
            return Err(IoError::format(
                file,
                format!(
                    "--subject needs an \"id\" column; the columns found are {}",
                    t.columns_found()
                ),
            ));
        }
        Ok(Columns {
            time_at,
            split,
            time_name,
            minute_clock,
            order,
            type_at: find(t, "type"),
            glucose_at,
            glucose_name,
            unit,
            declared_in_file: named.is_some(),
            carbs_at,
            bolus_at,
            basal_at,
            id_at,
        })
    }
}

/// A header cell that reads as a value (a number, a date or a time: digits
/// with only `.:-/+,` spaces, `T`, `Z`, AM and PM around them), as in a
/// file without a header row.
fn looks_like_data(cell: &str) -> bool {
    let c = cell.trim();
    c.bytes().any(|b| b.is_ascii_digit())
        && c.bytes()
            .all(|b| b.is_ascii_digit() || b" .:-/+,TZAPMapm".contains(&b))
}

/// The time column: `--time-column`, else the first of the usual names.
fn time_column(ctx: &Ctx<'_>, t: &Table<'_>) -> Result<usize, IoError> {
    match &ctx.opts.time_column {
        Some(name) => find(t, name).ok_or_else(|| {
            IoError::format(
                ctx.file,
                format!(
                    "no time column \"{name}\"; the columns found are {}",
                    t.columns_found()
                ),
            )
        }),
        None => TIME_NAMES.iter().find_map(|n| find(t, n)).ok_or_else(|| {
            IoError::format(
                ctx.file,
                format!(
                    "no time column \"time\" (or timestamp, datetime, date, minute); the columns \
                     found are {} (choose one with --time-column)",
                    t.columns_found()
                ),
            )
        }),
    }
}

/// The glucose column: `--glucose-column`, else the first of the usual
/// names; abba's own simulate output (plasma and subcutaneous glucose)
/// must say which.
fn glucose_column(ctx: &Ctx<'_>, t: &Table<'_>) -> Result<Option<usize>, IoError> {
    if let Some(name) = &ctx.opts.glucose_column {
        return find(t, name).map(Some).ok_or_else(|| {
            IoError::format(
                ctx.file,
                format!(
                    "no glucose column \"{name}\"; the columns found are {}",
                    t.columns_found()
                ),
            )
        });
    }
    let hits: Vec<usize> = GLUCOSE_NAMES.iter().filter_map(|n| find(t, n)).collect();
    let sim = ["bg_mg_dl", "gs_mg_dl"]
        .iter()
        .filter_map(|n| find(t, n))
        .count();
    match (hits.first(), sim) {
        (Some(&i), _) => Ok(Some(i)),
        (None, 0) => Ok(None),
        (None, _) => Err(IoError::format(
            ctx.file,
            "abba simulate output has plasma (bg_mg_dl) and subcutaneous (gs_mg_dl) \
             glucose; choose one with --glucose-column",
        )),
    }
}

/// The glucose unit: the column name's, or `--units`; never guessed, and
/// the two must agree.
fn glucose_unit(
    ctx: &Ctx<'_>,
    glucose_name: &str,
    has_glucose: bool,
    named: Option<GlucoseUnit>,
) -> Result<Option<GlucoseUnit>, IoError> {
    let unit = match (named, ctx.opts.units) {
        (Some(named), Some(given)) if named != given => {
            return Err(IoError::Units {
                file: ctx.file.to_string(),
                message: format!(
                    "column \"{glucose_name}\" says {} but --units says {}",
                    named.label(),
                    given.label()
                ),
            })
        }
        (Some(named), _) => Some(named),
        (None, given) => given,
    };
    if has_glucose && unit.is_none() {
        return Err(IoError::Units {
            file: ctx.file.to_string(),
            message: format!(
                "column \"{glucose_name}\" does not say its unit; give --units mg/dL or --units mmol/L"
            ),
        });
    }
    Ok(unit)
}

/// What the rows carry from one to the next: the wall clock (daylight-
/// saving folds), whether times have offsets, the subject.
struct Rows {
    tz: jiff::tz::TimeZone,
    wall: WallClock,
    with_offset: Option<(bool, u64)>,
    first_id: Option<(String, u64)>,
    subject_seen: bool,
}

impl Rows {
    /// Whether this row belongs to the subject read: `--subject`'s, or the
    /// file's only one (a second subject is an error).
    fn is_wanted_subject(
        &mut self,
        ctx: &Ctx<'_>,
        t: &Table<'_>,
        c: &Columns,
        at: &Location,
        line: u64,
    ) -> Result<bool, IoError> {
        let Some(i) = c.id_at else { return Ok(true) };
        let id = t.cell(i);
        match &ctx.opts.subject {
            Some(wanted) if id != wanted => return Ok(false),
            Some(_) => self.subject_seen = true,
            None => match &self.first_id {
                None => self.first_id = Some((id.to_string(), line)),
                Some((first, first_line)) if first != id => {
                    return Err(IoError::invalid(
                        at.clone(),
                        "id",
                        format!(
                            "subject \"{id}\" differs from \"{first}\" on line {first_line}; the \
                             file holds several subjects, choose one with --subject"
                        ),
                    ))
                }
                Some(_) => {}
            },
        }
        Ok(true)
    }

    /// The row's instant: a whole minute of abba's own clock, a time with
    /// a UTC offset, or a wall-clock time in `--tz` (a file must not mix
    /// the last two).
    fn instant(
        &mut self,
        t: &Table<'_>,
        c: &Columns,
        at: &Location,
        line: u64,
    ) -> Result<jiff::Timestamp, IoError> {
        let joined;
        let text = match c.split {
            Some((d, k)) => {
                joined = format!("{} {}", t.cell(d), t.cell(k));
                joined.as_str()
            }
            None => t.cell(c.time_at),
        };
        if c.minute_clock {
            return self.minute(t, c, at, line, text);
        }
        let offset = has_offset(text);
        match self.with_offset {
            None => self.with_offset = Some((offset, line)),
            // The file's, not the row's: which of the two is meant cannot
            // be told, so no row is left out in its favour.
            Some((first, first_line)) if first != offset => {
                return Err(IoError::format(
                    &at.file,
                    format!(
                        "line {line}, field \"{}\": time \"{text}\" {} a UTC offset but the \
                         time on line {first_line} {}; a file must not mix the two",
                        c.time_name,
                        if offset { "has" } else { "has no" },
                        if first { "has one" } else { "has none" }
                    ),
                ))
            }
            Some(_) => {}
        }
        let parsed = if offset {
            parse_instant(text)
        } else {
            match parse_wall(text, c.order) {
                Some(dt) => Some(self.wall.resolve(dt, at, &c.time_name)?),
                None => None,
            }
        };
        parsed.ok_or_else(|| {
            IoError::invalid(
                at.clone(),
                &c.time_name,
                format!(
                    "expected a time like 2015-06-06 16:50:27 or 2015-06-06T16:50:27Z{}, got \"{text}\"",
                    match c.order {
                        DateOrder::YearFirst => "",
                        DateOrder::DayFirst => " (day first, as the file's dates show)",
                        DateOrder::MonthFirst => " (month first, as the file's dates show)",
                    }
                ),
            )
        })
    }

    /// Minutes since 00:00 of day 1, placed at 1970-01-01 00:00 in the
    /// given zone (UTC without --tz): only differences matter.
    fn minute(
        &self,
        t: &Table<'_>,
        c: &Columns,
        at: &Location,
        line: u64,
        text: &str,
    ) -> Result<jiff::Timestamp, IoError> {
        let m = required_number(
            at.file.as_str(),
            line,
            &c.time_name,
            text,
            t.delimiter,
            "a whole minute",
        )?;
        if m.fract() != 0.0 || m.abs() > 1e9 {
            return Err(IoError::invalid(
                at.clone(),
                &c.time_name,
                format!("expected a whole minute, got \"{text}\""),
            ));
        }
        jiff::civil::date(1970, 1, 1)
            .at(0, 0, 0, 0)
            .to_zoned(self.tz.clone())
            .and_then(|z| z.checked_add(jiff::SignedDuration::from_mins(m as i64)))
            .map(|z| z.timestamp())
            .map_err(|e| IoError::invalid(at.clone(), &c.time_name, e.to_string()))
    }
}

/// The row's glucose reading (and its number as written), if it has one:
/// CGM, or a meter reading by the `type` column; an empty glucose cell
/// is allowed on a row that carries an amount.
fn glucose_record(
    t: &Table<'_>,
    c: &Columns,
    at: &Location,
    line: u64,
) -> Result<Option<(RecordKind, f64)>, IoError> {
    let (Some(i), Some(unit)) = (c.glucose_at, c.unit) else {
        return Ok(None);
    };
    let text = t.cell(i);
    if text.is_empty() && (c.carbs_at.is_some() || c.bolus_at.is_some() || c.basal_at.is_some()) {
        return Ok(None);
    }
    let v = required_number(
        at.file.as_str(),
        line,
        &c.glucose_name,
        text,
        t.delimiter,
        "a glucose number",
    )?;
    let mg = units::glucose_mg_dl(at, &c.glucose_name, v, unit)?;
    let glucose = Glucose::exact(mg);
    let kind = match c.type_at.map(|i| t.cell(i).to_ascii_lowercase()) {
        None => RecordKind::Cgm { glucose },
        Some(ty) => match ty.as_str() {
            "" | "cgm" | "sensor" | "cbg" | "historic" | "egv" => RecordKind::Cgm { glucose },
            "manual" | "meter" | "smbg" | "bg" | "fingerstick" | "finger stick" | "capillary" => {
                RecordKind::Smbg { glucose }
            }
            other => RecordKind::Ignored {
                kind: format!("glucose of type \"{other}\" (not cgm or manual)"),
            },
        },
    };
    Ok(Some((kind, v)))
}

/// The row's carbohydrate, bolus and basal rate, each checked against its
/// plausible range.
fn amount_records(
    t: &Table<'_>,
    c: &Columns,
    at: &Location,
    line: u64,
) -> Result<Vec<RecordKind>, IoError> {
    let mut out = Vec::new();
    for (col, what) in [(c.carbs_at, 1), (c.bolus_at, 2), (c.basal_at, 3)] {
        let Some(i) = col else { continue };
        let text = t.cell(i);
        if text.is_empty() {
            continue;
        }
        let name = &t.header[i];
        let v = required_number(at.file.as_str(), line, name, text, t.delimiter, "a number")?;
        out.push(match what {
            1 => RecordKind::Carbs {
                grams: Grams(check_range(
                    at,
                    name,
                    v,
                    0.0,
                    units::CARBS_MAX_G,
                    "carbohydrate (g)",
                )?),
            },
            2 => RecordKind::Bolus {
                units: Units(check_range(
                    at,
                    name,
                    v,
                    0.0,
                    units::BOLUS_MAX_U,
                    "bolus (U)",
                )?),
            },
            _ => RecordKind::Schedule {
                profile: Box::new(Profile::basal_only(BasalSchedule::flat(UnitsPerHour(
                    check_range(
                        at,
                        name,
                        v,
                        0.0,
                        units::BASAL_MAX_U_PER_H,
                        "basal rate (U/h)",
                    )?,
                )))),
            },
        });
    }
    Ok(out)
}
