//! Plain CSV with named columns: a time column (`time`, `timestamp`,
//! `datetime`, `date`, or `minute` for abba's own outputs), a glucose
//! column (`glucose`, `gl`, `sgv`, `cgm`, or named with `--glucose-column`),
//! and optionally `carbs`, `bolus`, `basal`. The glucose unit comes from the
//! column name (`..._mg_dl`, `... (mmol/L)`) or from `--units`.

use abba_core::{Grams, Units, UnitsPerHour};

use super::table::{required_number, unit_in_name, Table};
use super::Ctx;
use crate::error::{IoError, Location, Place};
use crate::record::{content_id, BasalSchedule, Glucose, Profile, Record, RecordKind, Source};
use crate::time::{has_offset, parse_instant, parse_wall, DateOrder, WallClock};
use crate::units::{self, check_range};

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

/// Reads a plain CSV.
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let file = ctx.file;
    let mut t = Table::open(file, bytes, 0)?;
    let time_at = match &ctx.opts.time_column {
        Some(name) => find(&t, name).ok_or_else(|| {
            IoError::format(
                file,
                format!(
                    "no time column \"{name}\"; the columns found are {}",
                    t.columns_found()
                ),
            )
        })?,
        None => TIME_NAMES.iter().find_map(|n| find(&t, n)).ok_or_else(|| {
            IoError::format(
                file,
                format!(
                    "no time column \"time\" (or timestamp, datetime, date, minute); the columns \
                     found are {} (choose one with --time-column)",
                    t.columns_found()
                ),
            )
        })?,
    };
    // A research dataset's separate `date` and `time` columns: read as one.
    let split = match (
        ctx.opts.time_column.is_none(),
        find(&t, "date"),
        find(&t, "time"),
    ) {
        (true, Some(d), Some(c)) => Some((d, c)),
        _ => None,
    };
    let time_name = match split {
        Some((d, c)) => format!("{} + {}", t.header[d], t.header[c]),
        None => t.header[time_at].clone(),
    };
    let minute_clock = split.is_none() && time_name.eq_ignore_ascii_case("minute");
    let order = if minute_clock {
        DateOrder::YearFirst
    } else {
        date_order(
            ctx,
            bytes,
            split.map_or((time_at, None), |(d, c)| (d, Some(c))),
        )?
    };
    let type_at = find(&t, "type");
    let glucose_at =
        match &ctx.opts.glucose_column {
            Some(name) => Some(find(&t, name).ok_or_else(|| {
                IoError::format(
                    file,
                    format!(
                        "no glucose column \"{name}\"; the columns found are {}",
                        t.columns_found()
                    ),
                )
            })?),
            None => {
                let hits: Vec<usize> = GLUCOSE_NAMES.iter().filter_map(|n| find(&t, n)).collect();
                let sim: Vec<usize> = ["bg_mg_dl", "gs_mg_dl"]
                    .iter()
                    .filter_map(|n| find(&t, n))
                    .collect();
                match (hits.first(), sim.len()) {
                    (Some(&i), _) => Some(i),
                    (None, 0) => None,
                    (None, _) => return Err(IoError::format(
                        file,
                        "abba simulate output has plasma (bg_mg_dl) and subcutaneous (gs_mg_dl) \
                         glucose; choose one with --glucose-column",
                    )),
                }
            }
        };
    let carbs_at = find(&t, "carbs").or_else(|| find(&t, "carbs_g"));
    let bolus_at = find(&t, "bolus").or_else(|| find(&t, "bolus_u"));
    let basal_at = find(&t, "basal").or_else(|| find(&t, "basal_u_per_h"));
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
    let glucose_name = glucose_at.map(|i| t.header[i].clone()).unwrap_or_default();
    let unit = match (
        glucose_at.and_then(|i| unit_in_name(&t.header[i])),
        ctx.opts.units,
    ) {
        (Some(named), Some(given)) if named != given => {
            return Err(IoError::Units {
                file: file.to_string(),
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
    let declared_in_file = glucose_at
        .and_then(|i| unit_in_name(&t.header[i]))
        .is_some();
    if glucose_at.is_some() && unit.is_none() {
        return Err(IoError::Units {
            file: file.to_string(),
            message: format!(
                "column \"{glucose_name}\" does not say its unit; give --units mg/dL or --units mmol/L"
            ),
        });
    }
    let id_at = find(&t, "id");
    if ctx.opts.subject.is_some() && id_at.is_none() {
        return Err(IoError::format(
            file,
            format!(
                "--subject needs an \"id\" column; the columns found are {}",
                t.columns_found()
            ),
        ));
    }
    let tz = ctx.opts.tz.clone().unwrap_or(jiff::tz::TimeZone::UTC);
    let mut wall = WallClock::new(tz.clone());
    let mut with_offset: Option<(bool, u64)> = None;
    let mut first_id: Option<(String, u64)> = None;
    let mut subject_seen = false;
    let mut raw_glucose = Vec::new();
    let mut out = Vec::with_capacity(t.lines_left());
    let delim = t.delimiter;
    // One location reused for every row (no allocation per row).
    let mut at = Location::line(file, 0);
    while let Some(line) = t.next_row()? {
        at.place = Place::Line(line);
        if let Some(i) = id_at {
            let id = t.cell(i);
            match &ctx.opts.subject {
                Some(wanted) if id != wanted => continue,
                Some(_) => subject_seen = true,
                None => match &first_id {
                    None => first_id = Some((id.to_string(), line)),
                    Some((first, first_line)) if first != id => {
                        return Err(IoError::invalid(
                            at,
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
        }
        let joined;
        let text = match split {
            Some((d, c)) => {
                joined = format!("{} {}", t.cell(d), t.cell(c));
                joined.as_str()
            }
            None => t.cell(time_at),
        };
        let instant = if minute_clock {
            let m = required_number(file, line, &time_name, text, delim, "a whole minute")?;
            if m.fract() != 0.0 || m.abs() > 1e9 {
                return Err(IoError::invalid(
                    at,
                    &time_name,
                    format!("expected a whole minute, got \"{text}\""),
                ));
            }
            // Minutes since 00:00 of day 1, placed at 1970-01-01 00:00 in
            // the given zone (UTC without --tz): only differences matter.
            jiff::civil::date(1970, 1, 1)
                .at(0, 0, 0, 0)
                .to_zoned(tz.clone())
                .and_then(|z| z.checked_add(jiff::SignedDuration::from_mins(m as i64)))
                .map(|z| z.timestamp())
                .map_err(|e| IoError::invalid(at.clone(), &time_name, e.to_string()))?
        } else {
            let offset = has_offset(text);
            match with_offset {
                None => with_offset = Some((offset, line)),
                Some((first, first_line)) if first != offset => {
                    return Err(IoError::invalid(
                        at,
                        &time_name,
                        format!(
                            "time \"{text}\" {} a UTC offset but the time on line {first_line} {}; \
                             a file must not mix the two",
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
                match parse_wall(text, order) {
                    Some(dt) => Some(wall.resolve(dt, &at, &time_name)?),
                    None => None,
                }
            };
            parsed.ok_or_else(|| {
                IoError::invalid(
                    at.clone(),
                    &time_name,
                    format!(
                        "expected a time like 2015-06-06 16:50:27 or 2015-06-06T16:50:27Z{}, got \"{text}\"",
                        match order {
                            DateOrder::YearFirst => "",
                            DateOrder::DayFirst => " (day first, as the file's dates show)",
                            DateOrder::MonthFirst => " (month first, as the file's dates show)",
                        }
                    ),
                )
            })?
        };
        let mut push = |kind: RecordKind, _n: u64| {
            out.push(Record {
                at: instant,
                id: content_id(Source::PlainCsv, instant, &kind),
                kind,
                source: Source::PlainCsv,
                origin: ctx.origin_line(line),
            })
        };
        if let (Some(i), Some(unit)) = (glucose_at, unit) {
            let text = t.cell(i);
            if !(text.is_empty()
                && (carbs_at.is_some() || bolus_at.is_some() || basal_at.is_some()))
            {
                let v =
                    required_number(file, line, &glucose_name, text, delim, "a glucose number")?;
                let mg = units::glucose_mg_dl(&at, &glucose_name, v, unit)?;
                raw_glucose.push(v);
                let glucose = Glucose::exact(mg);
                let kind = match type_at.map(|i| t.cell(i).to_ascii_lowercase()) {
                    None => RecordKind::Cgm { glucose },
                    Some(ty) => match ty.as_str() {
                        "" | "cgm" | "sensor" | "cbg" | "historic" | "egv" => {
                            RecordKind::Cgm { glucose }
                        }
                        "manual" | "meter" | "smbg" | "bg" | "fingerstick" | "finger stick"
                        | "capillary" => RecordKind::Smbg { glucose },
                        other => RecordKind::Ignored {
                            kind: format!("glucose of type \"{other}\" (not cgm or manual)"),
                        },
                    },
                };
                push(kind, 0);
            }
        }
        for (col, n) in [(carbs_at, 1), (bolus_at, 2), (basal_at, 3)] {
            let Some(i) = col else { continue };
            let text = t.cell(i);
            if text.is_empty() {
                continue;
            }
            let name = t.header[i].clone();
            let v = required_number(file, line, &name, text, delim, "a number")?;
            let kind = match n {
                1 => RecordKind::Carbs {
                    grams: Grams(check_range(
                        &at,
                        &name,
                        v,
                        0.0,
                        units::CARBS_MAX_G,
                        "carbohydrate (g)",
                    )?),
                },
                2 => RecordKind::Bolus {
                    units: Units(check_range(
                        &at,
                        &name,
                        v,
                        0.0,
                        units::BOLUS_MAX_U,
                        "bolus (U)",
                    )?),
                },
                _ => RecordKind::Schedule {
                    profile: Box::new(Profile::basal_only(BasalSchedule::flat(UnitsPerHour(
                        check_range(
                            &at,
                            &name,
                            v,
                            0.0,
                            units::BASAL_MAX_U_PER_H,
                            "basal rate (U/h)",
                        )?,
                    )))),
                },
            };
            push(kind, n);
        }
    }
    if let (Some(wanted), false) = (&ctx.opts.subject, subject_seen) {
        return Err(IoError::format(
            file,
            format!("no rows with id \"{wanted}\""),
        ));
    }
    if let (Some(unit), false) = (unit, declared_in_file) {
        units::check_median(file, &raw_glucose, unit)?;
    }
    Ok(out)
}
