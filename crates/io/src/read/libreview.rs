//! Abbott LibreView CSV (FreeStyle Libre 1/2/3): a metadata line
//! (`Glucose Data,Generated on,...`), the header, then one row per record
//! with its `Record Type`: 0 historic glucose (every 15 min, 5 on Libre 3),
//! 1 scan glucose, 2 strip (meter) glucose, 3 ketone, 4 insulin, 5 food,
//! 6 notes and time changes. Device times carry no offset and come in the
//! account's locale: `12-04-1961 22:30` (day first), `05-01-2024 12:03 AM`
//! (month first with AM/PM), `2024/05/01 00:03` (year first).

use abba_core::{Grams, MgDl, Units};

use super::table::{number, Table};
use super::Ctx;
use crate::error::{IoError, Location, Place};
use crate::record::{content_hash, Glucose, Record, RecordKind, Source, SourceId};
use crate::time::{parse_wall, DateOrder, WallClock};
use crate::units::{self, check_range};

/// Whether the first two lines are LibreView's.
pub fn looks_like(first: &str, second: &str) -> bool {
    second.contains("Device Timestamp") && second.contains("Record Type")
        || first.contains("Device Timestamp") && first.contains("Record Type")
}

/// What one time cell says about the date order, if anything: year
/// first, AM/PM (month first, as US accounts write), a first field above 12
/// (day first) or a second field above 12 (month first).
fn order_evidence(cell: &str) -> Option<DateOrder> {
    let s = cell.trim().trim_matches('"');
    if s.get(4..5)
        .is_some_and(|c| c == "-" || c == "/" || c == ".")
    {
        return Some(DateOrder::YearFirst);
    }
    let upper = s.to_ascii_uppercase();
    if upper.ends_with("AM") || upper.ends_with("PM") {
        return Some(DateOrder::MonthFirst);
    }
    let mut parts = s.split(['-', '/', '.', ' ']);
    let a: u32 = parts.next()?.parse().ok()?;
    let b: u32 = parts.next()?.parse().ok()?;
    match (a > 12, b > 12) {
        (true, false) => Some(DateOrder::DayFirst),
        (false, true) => Some(DateOrder::MonthFirst),
        _ => None,
    }
}

/// The file's date order: the first time cell that tells, else the one
/// the user gave, else an error (never guessed).
fn date_order(
    file: &str,
    rows: &[u8],
    delimiter: u8,
    column: usize,
    given: Option<DateOrder>,
) -> Result<DateOrder, IoError> {
    for line in rows.split(|&b| b == b'\n') {
        let cell = line.split(|&b| b == delimiter).nth(column).unwrap_or(b"");
        if let Some(o) = order_evidence(&String::from_utf8_lossy(cell)) {
            return Ok(o);
        }
    }
    given.ok_or_else(|| {
        IoError::format(
            file,
            "every date could be day-first or month-first (no day above 12, no AM/PM); give \
             --date-order day-first or month-first",
        )
    })
}

/// Reads a LibreView export.
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let file = ctx.file;
    let first = bytes.split(|&b| b == b'\n').next().unwrap_or(b"");
    let header_at = usize::from(!String::from_utf8_lossy(first).contains("Record Type"));
    let mut t = Table::open(file, bytes, header_at)?;
    let time_at = t.need_column_starting("LibreView", "Device Timestamp")?;
    let type_at = t.need_column_starting("LibreView", "Record Type")?;
    let historic_at = t.need_column_starting("LibreView", "Historic Glucose")?;
    let scan_at = t.column_starting("Scan Glucose");
    let strip_at = t.column_starting("Strip Glucose");
    let rapid_at = t.column_starting("Rapid-Acting Insulin (units)");
    let long_at = t
        .column_starting("Long-Acting Insulin Value (units)")
        .or_else(|| t.column_starting("Long-Acting Insulin (units)"));
    let meal_at = t.column_starting("Meal Insulin (units)");
    let corr_at = t.column_starting("Correction Insulin (units)");
    let carbs_at = t.column_starting("Carbohydrates (grams)");
    let servings_at = t.column_starting("Carbohydrates (servings)");
    let unit = t.unit_of_column(historic_at, ctx.opts.units)?;
    let historic_name = t.header[historic_at].clone();
    let tz = ctx.require_tz("LibreView writes device times without an offset")?;
    let mut wall = WallClock::new(tz);
    let time_name = t.header[time_at].clone();
    let delim = t.delimiter;
    let rows_start = bytes
        .iter()
        .enumerate()
        .filter(|&(_, &b)| b == b'\n')
        .nth(header_at)
        .map_or(bytes.len(), |(i, _)| i + 1);
    let order = date_order(
        file,
        &bytes[rows_start..],
        delim,
        time_at,
        ctx.opts.date_order,
    )?;
    let mut out = Vec::with_capacity(t.lines_left());
    // One location reused for every row (no allocation per row).
    let mut at = Location::line(file, 0);
    while let Some(line) = t.next_row()? {
        at.place = Place::Line(line);
        let text = t.cell(time_at);
        let dt = parse_wall(text, order).ok_or_else(|| {
            IoError::invalid(
                at.clone(),
                &time_name,
                format!(
                    "expected a device time like {} , got \"{text}\"",
                    match order {
                        DateOrder::DayFirst =>
                            "12-04-2024 22:30 (day first, as the file's first row)",
                        DateOrder::MonthFirst =>
                            "04-12-2024 10:30 PM (month first, as the file's first row)",
                        DateOrder::YearFirst =>
                            "2024-04-12 22:30 (year first, as the file's first row)",
                    }
                ),
            )
        })?;
        let instant = wall.resolve(dt, &at, &time_name)?;
        let value = |t: &Table<'_>, i: Option<usize>| -> Result<Option<(String, f64)>, IoError> {
            let Some(i) = i else { return Ok(None) };
            let text = t.cell(i);
            if text.is_empty() {
                return Ok(None);
            }
            let name = t.header[i].clone();
            let v = number(text, delim).ok_or_else(|| {
                IoError::invalid(
                    at.clone(),
                    &name,
                    format!("expected a number, got \"{text}\""),
                )
            })?;
            Ok(Some((name, v)))
        };
        let glucose = |t: &Table<'_>, i: Option<usize>| -> Result<Option<Glucose>, IoError> {
            match value(t, i)? {
                None => Ok(None),
                Some((name, v)) => Ok(Some(Glucose {
                    mg_dl: MgDl(units::glucose_mg_dl(&at, &name, v, unit)?),
                    censor: crate::record::Censor::Exact,
                })),
            }
        };
        let missing = |what: &str| {
            IoError::invalid(
                at.clone(),
                what,
                "the record type needs this value; the cell is empty",
            )
        };
        let rtype = t.cell(type_at).to_string();
        let mut kinds = Vec::new();
        match rtype.as_str() {
            "0" => kinds.push(RecordKind::Cgm {
                glucose: glucose(&t, Some(historic_at))?.ok_or_else(|| missing(&historic_name))?,
            }),
            "1" => kinds.push(RecordKind::Ignored {
                kind: "scan glucose".into(),
            }),
            "2" => kinds.push(RecordKind::Smbg {
                glucose: glucose(&t, strip_at)?.ok_or_else(|| missing("Strip Glucose"))?,
            }),
            "3" => kinds.push(RecordKind::Ignored {
                kind: "ketone".into(),
            }),
            "4" => {
                let bolus = match value(&t, rapid_at)? {
                    Some(v) => Some(v),
                    None => match (value(&t, meal_at)?, value(&t, corr_at)?) {
                        (None, None) => None,
                        (a, b) => Some((
                            "Meal + Correction Insulin (units)".to_string(),
                            a.map_or(0.0, |a| a.1) + b.map_or(0.0, |b| b.1),
                        )),
                    },
                };
                if let Some((name, u)) = bolus {
                    kinds.push(RecordKind::Bolus {
                        units: Units(check_range(
                            &at,
                            &name,
                            u,
                            0.0,
                            units::BOLUS_MAX_U,
                            "insulin (U)",
                        )?),
                    });
                }
                if let Some((name, u)) = value(&t, long_at)? {
                    kinds.push(RecordKind::LongActing {
                        units: Units(check_range(
                            &at,
                            &name,
                            u,
                            0.0,
                            units::BOLUS_MAX_U,
                            "insulin (U)",
                        )?),
                    });
                }
                if kinds.is_empty() {
                    kinds.push(RecordKind::Ignored {
                        kind: "insulin without a number".into(),
                    });
                }
            }
            "5" => match value(&t, carbs_at)? {
                Some((name, g)) => kinds.push(RecordKind::Carbs {
                    grams: Grams(check_range(
                        &at,
                        &name,
                        g,
                        0.0,
                        units::CARBS_MAX_G,
                        "carbohydrate (g)",
                    )?),
                }),
                None if value(&t, servings_at)?.is_some() => kinds.push(RecordKind::Ignored {
                    kind: "food in servings (grams per serving unknown)".into(),
                }),
                None => kinds.push(RecordKind::Ignored {
                    kind: "food without carbohydrate".into(),
                }),
            },
            "6" => kinds.push(RecordKind::Ignored {
                kind: "note or time change".into(),
            }),
            other => kinds.push(RecordKind::Ignored {
                kind: format!("record type {other}"),
            }),
        }
        let _ = scan_at;
        let hash = content_hash(t.raw());
        for (n, kind) in kinds.into_iter().enumerate() {
            out.push(Record {
                at: instant,
                kind,
                source: Source::LibreView,
                id: SourceId::Hash(hash.wrapping_add(n as u64)),
                origin: ctx.origin_line(line),
            });
        }
    }
    Ok(out)
}
