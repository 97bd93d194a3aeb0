//! Dexcom Clarity CSV: a header row (the `Index` cell often arrives with a
//! byte-order mark and mangled quotes), preamble rows with no timestamp
//! (FirstName, LastName, Device, Alert settings), then one row per event in
//! device local time (`2019-08-15T00:03:27`, sometimes `2025-05-01 0:01:47`).
//! EGV rows are CGM readings; "Low" and "High" are the sensor's reporting
//! limits (40 and 400 mg/dL, 2.2 and 22.2 mmol/L) and stay censored
//! (never dropped, never read as exact). Calibration rows are meter
//! readings; Insulin (Fast-Acting, Long-Acting; any other subtype is an
//! error) and Carbs rows are read;
//! every other event type (Exercise, Health, Alert, Device, ...) is counted.
//! A data row without its time is an error.

use abba_core::{Grams, Units};

use super::table::{required_number, Table};
use super::Ctx;
use crate::error::{IoError, Location, Place};
use crate::record::{Censor, Glucose, Record, RecordKind, Source, SourceId};
use crate::time::{parse_wall, DateOrder, WallClock};
use crate::units::{self, check_range, GlucoseUnit};

/// Event types that are data and need a time (the preamble's FirstName,
/// LastName, Device and Alert rows have none).
const DATA_EVENTS: [&str; 4] = ["EGV", "Calibration", "Insulin", "Carbs"];

/// Whether a header row (first line) is Clarity's.
pub fn looks_like(header_line: &str) -> bool {
    header_line.contains("Event Type") && header_line.contains("Glucose Value")
}

/// Reads a Clarity export.
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let file = ctx.file;
    let mut t = Table::open(file, bytes, 0)?;
    let time_at = t.need_column_starting("Clarity", "Timestamp")?;
    let type_at = t.need_column_starting("Clarity", "Event Type")?;
    let subtype_at = t.column_starting("Event Subtype");
    let glucose_at = t.need_column_starting("Clarity", "Glucose Value")?;
    let insulin_at = t.column_starting("Insulin Value");
    let carbs_at = t.column_starting("Carb Value");
    let duration_at = t.column_starting("Duration");
    let unit = t.unit_of_column(glucose_at, ctx.opts.units)?;
    let glucose_name = t.header[glucose_at].clone();
    let (low, high) = match unit {
        GlucoseUnit::MgDl => (40.0, 400.0),
        GlucoseUnit::MmolL => (2.2, 22.2),
    };
    let tz = ctx.require_tz("Clarity writes device local times without an offset")?;
    let mut wall = WallClock::new(tz);
    let time_name = t.header[time_at].clone();
    let delim = t.delimiter;
    let mut out = Vec::with_capacity(t.lines_left());
    // One location reused for every row (no allocation per row).
    let mut at = Location::line(file, 0);
    while let Some(line) = t.next_row()? {
        at.place = Place::Line(line);
        let time_text = t.cell(time_at);
        let kind_text = t.cell(type_at);
        if time_text.is_empty() {
            if DATA_EVENTS.contains(&kind_text) {
                return Err(IoError::invalid(
                    at.clone(),
                    &t.header[time_at],
                    format!("a {kind_text} row needs its time; the cell is empty"),
                ));
            }
            continue; // preamble: patient, device and alert settings
        }
        let dt = parse_wall(time_text, DateOrder::YearFirst).ok_or_else(|| {
            IoError::invalid(
                at.clone(),
                &time_name,
                format!("expected a time like 2019-08-15T00:03:27, got \"{time_text}\""),
            )
        })?;
        let instant = wall.resolve(dt, &at, &time_name)?;
        let subtype = subtype_at.map_or("", |i| t.cell(i));
        let glucose = |t: &Table<'_>| -> Result<Glucose, IoError> {
            let text = t.cell(glucose_at);
            let (value, censor) = match text.to_ascii_lowercase().as_str() {
                "low" => (low, Censor::Below),
                "high" => (high, Censor::Above),
                _ => (
                    required_number(
                        file,
                        line,
                        &glucose_name,
                        text,
                        delim,
                        "a glucose number, Low or High",
                    )?,
                    Censor::Exact,
                ),
            };
            let mg = units::glucose_mg_dl(&at, &glucose_name, value, unit)?;
            Ok(Glucose {
                mg_dl: abba_core::MgDl(mg),
                censor,
            })
        };
        let number =
            |t: &Table<'_>, i: Option<usize>, what: &str| -> Result<(String, f64), IoError> {
                let i = i.ok_or_else(|| {
                    IoError::format(file, format!("{kind_text} rows need a {what} column"))
                })?;
                let name = t.header[i].clone();
                let v = required_number(file, line, &name, t.cell(i), delim, what)?;
                Ok((name, v))
            };
        let kind = match kind_text {
            "EGV" => RecordKind::Cgm {
                glucose: glucose(&t)?,
            },
            // A meter reading entered to calibrate the sensor.
            "Calibration" => RecordKind::Smbg {
                glucose: glucose(&t)?,
            },
            "Insulin" => {
                let (name, v) = number(&t, insulin_at, "insulin (U)")?;
                let u = Units(check_range(
                    &at,
                    &name,
                    v,
                    0.0,
                    units::BOLUS_MAX_U,
                    "insulin (U)",
                )?);
                match subtype.to_ascii_lowercase().as_str() {
                    "long-acting" => RecordKind::LongActing { units: u },
                    "fast-acting" | "rapid-acting" => RecordKind::Bolus { units: u },
                    other => {
                        return Err(IoError::invalid(
                            at.clone(),
                            &subtype_at
                                .map_or("Event Subtype".to_string(), |i| t.header[i].clone()),
                            format!(
                                "an Insulin row needs its subtype Fast-Acting or Long-Acting \
                                 (abba does not guess which), got \"{other}\""
                            ),
                        ))
                    }
                }
            }
            "Carbs" => {
                let (name, v) = number(&t, carbs_at, "carbohydrate (g)")?;
                RecordKind::Carbs {
                    grams: Grams(check_range(
                        &at,
                        &name,
                        v,
                        0.0,
                        units::CARBS_MAX_G,
                        "carbohydrate (g)",
                    )?),
                }
            }
            other => {
                let _ = duration_at;
                RecordKind::Ignored {
                    kind: if subtype.is_empty() {
                        other.to_string()
                    } else {
                        format!("{other} {subtype}")
                    },
                }
            }
        };
        let id = t
            .cell(0)
            .parse::<u64>()
            .map(SourceId::Index)
            .unwrap_or_else(|_| SourceId::Hash(crate::record::content_hash(t.raw())));
        out.push(Record {
            at: instant,
            kind,
            source: Source::Clarity,
            id,
            origin: ctx.origin_line(line),
        });
    }
    Ok(out)
}
