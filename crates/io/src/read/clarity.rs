//! Dexcom Clarity CSV: a header row (the `Index` cell often arrives with a
//! byte-order mark and mangled quotes), preamble rows with no timestamp
//! (FirstName, LastName, Device, Alert settings), then one row per event in
//! device local time (`2019-08-15T00:03:27`, sometimes `2025-05-01 0:01:47`).
//! EGV rows are CGM readings; "Low" and "High" are the sensor's reporting
//! limits (40 and 400 mg/dL, 2.2 and 22.2 mmol/L) and stay censored
//! (never dropped, never read as exact). Calibration rows are meter
//! readings; Insulin (Fast-Acting, Long-Acting; any other subtype is an
//! error) and Carbs rows are read;
//! every other event type (Exercise, Health, Alert, Device, ...) is counted,
//! unless it carries a glucose value: a reading under a name abba does not
//! know (another language's word for EGV) is an error, never ignored.
//! A data row without its time is an error; the preamble's rows, which
//! have none (FirstName, LastName, DateOfBirth, Device, Alert settings),
//! are counted by type in the file's note.
//!
//! Identity: an EGV or Calibration row with its transmitter id and
//! transmitter time is `transmitter id:transmitter time:event type` (the
//! transmitter's own clock, the same in every export); any other row is
//! identified by its content. The `Index` column restarts at 1 in every
//! export and is never identity.
//!
//! A phone clock that moved (set by hand, a trip) shows as a jump of the
//! difference between the written time and the transmitter time within one
//! transmitter: the readings of the smaller stretches are placed by the
//! transmitter's clock relative to the largest stretch, and each stretch
//! is reported. Without transmitter times, readings written at times the
//! series already covered (the clock went back) are a conflicting stretch:
//! reported with its lines, span and count, not read; the rest is read.
//!
//! Clarity lists rows by wall time, so across the autumn clock change the
//! two passes through the repeated hour interleave (seen in a real Android
//! G6 export of 2023-11-05, America/Chicago): the file's order cannot tell
//! them apart, the transmitter's clock can (the two candidates are 3600 s
//! apart). Once readings carry transmitter times, a row in the fold is
//! placed by its transmitter's clock; one it cannot place is reported.
//!
//! Headers in another language (German, French, Spanish, Italian, Dutch)
//! are recognised by the export's structure: the time in column 2 with
//! its `hh:mm:ss` pattern, the glucose column naming its unit in column 8,
//! transmitter time and id last.

use abba_core::{Grams, Units};

use super::table::{required_number, Table};
use super::{or_skip, Ctx};
use crate::error::{IoError, Location, Place};
use crate::record::{row_id, Censor, Glucose, Record, RecordKind, Source, SourceId};
use crate::time::{parse_wall, DateOrder, WallClock};
use crate::units::{self, check_range, GlucoseUnit};

/// Event types that are data and need a time (the preamble's FirstName,
/// LastName, Device and Alert rows have none), in English and as localised
/// exports write them.
const DATA_EVENTS: [&str; 4] = ["EGV", "Calibration", "Insulin", "Carbs"];

/// Localised event type names, mapped to Clarity's English ones (the
/// Spanish export names its sensor readings "Niveles estimados de
/// glucosa", as the HUPA-UCM dataset's Dexcom files show; a real G7
/// export set to Italian keeps `EGV` and writes "Calibrazione"; the
/// other names are not verified against a real export).
const EVENT_NAMES: [(&str, &str); 13] = [
    ("Niveles estimados de glucosa", "EGV"),
    ("Kalibrierung", "Calibration"),
    ("Kohlenhydrate", "Carbs"),
    ("Étalonnage", "Calibration"),
    ("Glucides", "Carbs"),
    ("Calibración", "Calibration"),
    ("Carbohidratos", "Carbs"),
    ("Calibrazione", "Calibration"),
    ("Carboidrati", "Carbs"),
    ("Kalibratie", "Calibration"),
    ("Koolhydraten", "Carbs"),
    ("Insuline", "Insulin"),
    ("Insulina", "Insulin"),
];

/// Whether a header row (first line) is Clarity's: English names, or the
/// structure of a localised export (see the module documentation).
pub fn looks_like(header_line: &str) -> bool {
    (header_line.contains("Event Type") && header_line.contains("Glucose Value"))
        || localised(&super::libreview_columns::cells(header_line))
}

/// A localised Clarity header: at least 13 columns, the time pattern in
/// column 2 and a glucose unit in column 8.
fn localised(cells: &[String]) -> bool {
    cells.len() >= 13
        && cells[1].to_ascii_lowercase().contains("hh:mm:ss")
        && super::table::unit_in_name(&cells[7]).is_some()
}

/// Column `prefix` by its English name, or at `position` in a localised
/// export.
fn column(t: &Table<'_>, prefix: &str, position: usize, localised: bool) -> Option<usize> {
    t.column_starting(prefix)
        .or_else(|| (localised && position < t.header.len()).then_some(position))
}

/// The columns of a Clarity export (English names, or positions in a
/// localised one) and how its glucose is read.
struct Columns {
    time_at: usize,
    time_name: String,
    type_at: usize,
    glucose_at: usize,
    glucose_name: String,
    unit: GlucoseUnit,
    subtype_at: Option<usize>,
    insulin_at: Option<usize>,
    carbs_at: Option<usize>,
    tx_time_at: Option<usize>,
    tx_id_at: Option<usize>,
}

impl Columns {
    fn find(ctx: &Ctx<'_>, t: &Table<'_>) -> Result<Columns, IoError> {
        let loc = t.column_starting("Event Type").is_none() && localised(&t.header);
        let need = |prefix: &str, position: usize| -> Result<usize, IoError> {
            match column(t, prefix, position, loc) {
                Some(i) => Ok(i),
                None => t.need_column_starting("Clarity", prefix),
            }
        };
        let time_at = need("Timestamp", 1)?;
        let type_at = need("Event Type", 2)?;
        let glucose_at = need("Glucose Value", 7)?;
        Ok(Columns {
            time_at,
            time_name: t.header[time_at].clone(),
            type_at,
            glucose_at,
            glucose_name: t.header[glucose_at].clone(),
            unit: t.unit_of_column(glucose_at, ctx.opts.units)?,
            subtype_at: column(t, "Event Subtype", 3, loc),
            insulin_at: column(t, "Insulin Value", 8, loc),
            carbs_at: column(t, "Carb Value", 9, loc),
            tx_time_at: column(t, "Transmitter Time", 12, loc),
            tx_id_at: column(t, "Transmitter ID", 13, loc),
        })
    }
}

/// Reads a Clarity export: each data row's time and record, its
/// transmitter clock, then the clock's stretches placed or reported.
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let file = ctx.file;
    let mut t = Table::open(file, bytes, 0)?;
    let c = Columns::find(ctx, &t)?;
    let tz = ctx.require_tz("Clarity writes device local times without an offset")?;
    let mut wall = WallClock::new(tz);
    let mut out = Vec::with_capacity(t.lines_left());
    let mut egv_clock: Vec<TxReading> = Vec::new();
    // Each transmitter's written time less its own clock (s), at its
    // latest reading: what places a reading in the autumn fold.
    let mut offsets: std::collections::BTreeMap<String, i64> = Default::default();
    // Rows in the fold no transmitter clock places (line, event type).
    let mut unplaced: Vec<(u64, String)> = Vec::new();
    // Rows without a time (the preamble), by event type.
    let mut untimed: std::collections::BTreeMap<String, usize> = Default::default();
    // One location reused for every row (no allocation per row).
    let mut at = Location::line(file, 0);
    while let Some(line) = t.next_row()? {
        at.place = Place::Line(line);
        let kind_text = english_event(t.cell(c.type_at));
        let time_text = t.cell(c.time_at);
        if time_text.is_empty() {
            if DATA_EVENTS.contains(&kind_text) {
                or_skip!(
                    ctx,
                    Err::<(), _>(IoError::invalid(
                        at.clone(),
                        &c.time_name,
                        format!("a {kind_text} row needs its time; the cell is empty"),
                    ))
                );
            }
            // The preamble: patient, device and alert settings.
            let kind = if kind_text.is_empty() {
                "(no event type)"
            } else {
                kind_text
            };
            *untimed.entry(kind.to_string()).or_default() += 1;
            continue;
        }
        let dt = or_skip!(
            ctx,
            parse_wall(time_text, DateOrder::YearFirst).ok_or_else(|| {
                IoError::invalid(
                    at.clone(),
                    &c.time_name,
                    format!("expected a time like 2019-08-15T00:03:27, got \"{time_text}\""),
                )
            })
        );
        let kind = or_skip!(ctx, row_kind(&t, &c, &at, line, kind_text));
        let tx = transmitter_clock(&t, &c, &kind);
        let instant = match wall.fold(dt) {
            // Clarity lists rows by wall time, so the two passes through
            // the repeated hour interleave and the file's order cannot
            // tell them apart; once readings carry transmitter times, a
            // reading is placed by its transmitter's clock, and a row it
            // cannot place is reported, not guessed.
            Some((early, late)) if !offsets.is_empty() => {
                let placed = tx.as_ref().and_then(|(id, tx_time)| {
                    by_transmitter(early, late, *offsets.get(id)?, *tx_time)
                });
                match placed {
                    Some(ts) => {
                        wall.place(ts);
                        ts
                    }
                    None => {
                        unplaced.push((line, kind_text.to_string()));
                        continue;
                    }
                }
            }
            _ => or_skip!(ctx, wall.resolve(dt, &at, &c.time_name)),
        };
        if let Some((id, tx_time)) = &tx {
            let offset = instant.as_second().saturating_sub(*tx_time);
            match offsets.get_mut(id) {
                Some(o) => *o = offset,
                None => {
                    offsets.insert(id.clone(), offset);
                }
            }
        }
        let id = match &tx {
            Some((tx_id, tx_time)) => SourceId::Id(format!("{tx_id}:{tx_time}:{kind_text}").into()),
            None => row_id(Source::Clarity, instant, &kind, t.raw(), Some(0)),
        };
        if let (Some((tx_id, tx_time)), RecordKind::Cgm { .. }) = (&tx, &kind) {
            egv_clock.push(TxReading {
                at: out.len(),
                offset: instant.as_second() - *tx_time,
                tx_id: tx_id.clone(),
                tx_time: *tx_time,
                line,
            });
        }
        out.push(Record {
            at: instant,
            kind,
            source: Source::Clarity,
            id,
            origin: ctx.origin_line(line),
        });
    }
    if !untimed.is_empty() {
        let total: usize = untimed.values().sum();
        let kinds: Vec<String> = untimed.iter().map(|(k, n)| format!("{k} {n}")).collect();
        ctx.note(format!(
            "{total} rows without a time (the export's preamble of the person, the device and \
             its alert settings: {}): not read",
            kinds.join(", ")
        ));
    }
    if !unplaced.is_empty() {
        let listed: Vec<String> = unplaced
            .iter()
            .take(10)
            .map(|(line, kind)| format!("line {line} ({kind})"))
            .collect();
        let more = if unplaced.len() > 10 { ", ..." } else { "" };
        ctx.note(format!(
            "{} row(s) written in the hour {} repeats at the autumn change carry no transmitter \
             time that places them ({}{more}); Clarity lists rows by wall time, so which of \
             the two passes each belongs to is not known: not read",
            unplaced.len(),
            wall.zone_name(),
            listed.join(", ")
        ));
    }
    if egv_clock.is_empty() {
        drop_conflicting_stretches(ctx, &mut out);
    } else {
        place_by_transmitter(ctx, &mut out, &egv_clock);
    }
    Ok(out)
}

/// An event type in Clarity's English (a localised name mapped).
fn english_event(kind_text: &str) -> &str {
    EVENT_NAMES
        .iter()
        .find(|(local, _)| local.eq_ignore_ascii_case(kind_text))
        .map_or(kind_text, |&(_, english)| english)
}

/// What a data row records: a CGM reading (EGV), a meter reading
/// (Calibration), insulin by its subtype, carbohydrate, or an event type
/// counted as ignored.
fn row_kind(
    t: &Table<'_>,
    c: &Columns,
    at: &Location,
    line: u64,
    kind_text: &str,
) -> Result<RecordKind, IoError> {
    let subtype = c.subtype_at.map_or("", |i| t.cell(i));
    let number = |i: Option<usize>, what: &str| -> Result<(String, f64), IoError> {
        let i = i.ok_or_else(|| {
            IoError::format(&at.file, format!("{kind_text} rows need a {what} column"))
        })?;
        let name = t.header[i].clone();
        let v = required_number(&at.file, line, &name, t.cell(i), t.delimiter, what)?;
        Ok((name, v))
    };
    Ok(match kind_text {
        "EGV" => RecordKind::Cgm {
            glucose: glucose(t, c, at, line)?,
        },
        // A meter reading entered to calibrate the sensor.
        "Calibration" => RecordKind::Smbg {
            glucose: glucose(t, c, at, line)?,
        },
        "Insulin" => {
            let (name, v) = number(c.insulin_at, "insulin (U)")?;
            let u = Units(check_range(
                at,
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
                        &c.subtype_at
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
            let (name, v) = number(c.carbs_at, "carbohydrate (g)")?;
            RecordKind::Carbs {
                grams: Grams(check_range(
                    at,
                    &name,
                    v,
                    0.0,
                    units::CARBS_MAX_G,
                    "carbohydrate (g)",
                )?),
            }
        }
        // Another event type with a glucose value: a sensor or meter
        // reading under a name abba does not know (a language's word for
        // EGV), never counted away as ignored.
        other if !t.cell(c.glucose_at).is_empty() => {
            return Err(IoError::invalid(
                at.clone(),
                &t.header[c.type_at],
                format!(
                    "the event type \"{other}\" carries a glucose value (\"{}\" in \"{}\"); \
                     abba reads glucose from EGV (sensor) and Calibration (meter) rows and does \
                     not guess what this one is: export the file with Clarity set to English",
                    t.cell(c.glucose_at),
                    c.glucose_name
                ),
            ))
        }
        other => RecordKind::Ignored {
            kind: if subtype.is_empty() {
                other.to_string()
            } else {
                format!("{other} {subtype}")
            },
        },
    })
}

/// The words Clarity writes in the glucose column for a reading below or
/// above the sensor's range, in the export's language: English "Low" and
/// "High", Spanish "Nivel bajo" and "Nivel alto" (the HUPA-UCM dataset's
/// files), Italian "Basso" and "Alto" (a real G7 export set to Italian:
/// EGV rows with "Basso" in the glucose column; "Alto" is the word its
/// High alert carries, as English exports name the alert and the value
/// alike). Other languages' words are not known: such a row is reported
/// (not a number), never guessed.
const CENSORED: [(&str, Censor); 6] = [
    ("low", Censor::Below),
    ("high", Censor::Above),
    ("nivel bajo", Censor::Below),
    ("nivel alto", Censor::Above),
    ("basso", Censor::Below),
    ("alto", Censor::Above),
];

/// Whether a glucose cell is one of [`CENSORED`]'s words, and which.
fn censored(text: &str) -> Option<Censor> {
    CENSORED
        .iter()
        .find(|(word, _)| word.eq_ignore_ascii_case(text))
        .map(|&(_, censor)| censor)
}

/// A glucose cell: a number, or Low / High at the sensor's reporting
/// limits (40 and 400 mg/dL, 2.2 and 22.2 mmol/L), kept censored.
fn glucose(t: &Table<'_>, c: &Columns, at: &Location, line: u64) -> Result<Glucose, IoError> {
    let (low, high) = match c.unit {
        GlucoseUnit::MgDl => (40.0, 400.0),
        GlucoseUnit::MmolL => (2.2, 22.2),
    };
    let text = t.cell(c.glucose_at);
    let (value, censor) = match censored(text) {
        Some(Censor::Below) => (low, Censor::Below),
        Some(Censor::Above) => (high, Censor::Above),
        Some(Censor::Exact) | None => (
            required_number(
                &at.file,
                line,
                &c.glucose_name,
                text,
                t.delimiter,
                "a glucose number, Low or High",
            )?,
            Censor::Exact,
        ),
    };
    let mg = units::glucose_mg_dl(at, &c.glucose_name, value, c.unit)?;
    Ok(Glucose {
        mg_dl: abba_core::MgDl(mg),
        censor,
    })
}

/// A reading's transmitter id and transmitter time (s), when the row has
/// both.
fn transmitter_clock(t: &Table<'_>, c: &Columns, kind: &RecordKind) -> Option<(String, i64)> {
    let (i, j) = (c.tx_id_at?, c.tx_time_at?);
    if !matches!(kind, RecordKind::Cgm { .. } | RecordKind::Smbg { .. }) {
        return None;
    }
    let (id, time) = (t.cell(i), t.cell(j));
    match time.parse::<i64>() {
        Ok(s) if !id.is_empty() => Some((id.to_string(), s)),
        _ => None,
    }
}

/// The instant of a reading in the autumn fold whose transmitter's
/// written-less-transmitter time was `offset` (s) at its reading before:
/// the one of `early` and `late` (an hour apart) that keeps it within
/// [`CLOCK_JUMP_S`]; `None` if neither or both do (the phone's clock moved).
fn by_transmitter(
    early: jiff::Timestamp,
    late: jiff::Timestamp,
    offset: i64,
    tx_time: i64,
) -> Option<jiff::Timestamp> {
    let fits = |t: jiff::Timestamp| {
        t.as_second()
            .checked_sub(tx_time)
            .and_then(|d| d.checked_sub(offset))
            .is_some_and(|d| (-CLOCK_JUMP_S..=CLOCK_JUMP_S).contains(&d))
    };
    match (fits(early), fits(late)) {
        (true, false) => Some(early),
        (false, true) => Some(late),
        _ => None,
    }
}

/// An EGV row's transmitter clock: its index in the records, the
/// transmitter, its time (s) and the row's line.
struct TxReading {
    at: usize,
    offset: i64,
    tx_id: String,
    tx_time: i64,
    line: u64,
}

/// How far (s) the difference between written time and transmitter time
/// may move between two readings before it is a clock change (transmitter
/// clocks drift by seconds a day; a phone clock change is minutes or
/// hours).
const CLOCK_JUMP_S: i64 = 120;

/// Places EGV readings by their transmitter's clock where the phone's
/// clock moved (see the module documentation).
fn place_by_transmitter(ctx: &Ctx<'_>, out: &mut [Record], readings: &[TxReading]) {
    let mut by_tx: std::collections::BTreeMap<&str, Vec<&TxReading>> = Default::default();
    for r in readings {
        by_tx.entry(r.tx_id.as_str()).or_default().push(r);
    }
    for (tx_id, mut rs) in by_tx {
        rs.sort_by_key(|r| r.tx_time);
        let offset = |r: &TxReading| r.offset;
        // Stretches of readings whose offset moves by less than a jump.
        let mut stretches: Vec<Vec<&TxReading>> = Vec::new();
        for r in rs {
            match stretches.last_mut() {
                Some(s)
                    if s.last()
                        .is_some_and(|p| (offset(p) - offset(r)).abs() <= CLOCK_JUMP_S) =>
                {
                    s.push(r)
                }
                _ => stretches.push(vec![r]),
            }
        }
        let Some(main) = stretches
            .iter()
            .enumerate()
            .max_by_key(|(_, s)| s.len())
            .map(|(i, _)| i)
        else {
            continue;
        };
        let mut main_offsets: Vec<i64> = stretches[main].iter().map(|r| offset(r)).collect();
        main_offsets.sort_unstable();
        let reference = main_offsets[main_offsets.len() / 2];
        for (i, s) in stretches.iter().enumerate() {
            let off = offset(s[0]);
            if i == main || (off - reference).abs() <= CLOCK_JUMP_S {
                continue;
            }
            let (first, last) = (
                s.iter().map(|r| r.line).min().unwrap_or(0),
                s.iter().map(|r| r.line).max().unwrap_or(0),
            );
            let written = (out[s[0].at].at, out[s[s.len() - 1].at].at);
            for r in s {
                if let Ok(t) = jiff::Timestamp::from_second(reference + r.tx_time) {
                    out[r.at].at = t;
                }
            }
            // (written later than the transmitter says: the phone's clock
            // was ahead; a signed duration's own text would say "ago")
            let shift = jiff::SignedDuration::from_secs((off - reference).abs());
            let way = if off > reference {
                "ahead of"
            } else {
                "behind"
            };
            ctx.note(format!(
                "lines {first}-{last}: {} readings of transmitter {tx_id} written {} to {} were \
                 placed by the transmitter's clock (the phone's clock was {shift:#} {way} its \
                 clock in the file's longest stretch)",
                s.len(),
                written.0,
                written.1
            ));
        }
    }
}

/// Without transmitter times: EGV readings written at times the series
/// already covered (the clock went back) cannot be placed; each such
/// stretch is reported and left out, the rest is kept.
fn drop_conflicting_stretches(ctx: &Ctx<'_>, out: &mut Vec<Record>) {
    let mut cgm = out
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Cgm { .. }));
    if let (Some(first), Some(last)) = (cgm.next(), cgm.next_back()) {
        if first.at > last.at {
            return; // newest first: not the order this check reads
        }
    }
    let mut newest: Option<usize> = None;
    let mut drop = vec![false; out.len()];
    let mut stretch: Option<(usize, usize, usize)> = None; // first, last, count
    let report = |s: (usize, usize, usize), out: &[Record]| {
        let line = |i: usize| match out[i].origin.at {
            crate::record::OriginAt::Line(l) => l,
            crate::record::OriginAt::Item(i) | crate::record::OriginAt::Row { row: i, .. } => i,
        };
        ctx.note(format!(
            "lines {}-{}: {} readings written {} to {} fall on times the series already \
             covered (the clock went back?) and carry no transmitter time: not read",
            line(s.0),
            line(s.1),
            s.2,
            out[s.0].at,
            out[s.1].at
        ));
    };
    let slack = jiff::SignedDuration::from_secs(CLOCK_JUMP_S);
    for i in 0..out.len() {
        if !matches!(out[i].kind, RecordKind::Cgm { .. }) {
            continue;
        }
        let at = out[i].at;
        // Before the newest time read, or at it with another value.
        let conflict = newest.is_some_and(|n: usize| {
            at.checked_add(slack).is_ok_and(|a| a < out[n].at)
                || (at <= out[n].at && out[n].kind != out[i].kind)
        });
        if conflict {
            drop[i] = true;
            stretch = Some(match stretch {
                Some((f, _, c)) => (f, i, c + 1),
                None => (i, i, 1),
            });
            continue;
        }
        if let Some(s) = stretch.take() {
            report(s, out);
        }
        if newest.is_none_or(|n| at > out[n].at) {
            newest = Some(i);
        }
    }
    if let Some(s) = stretch.take() {
        report(s, out);
    }
    let mut i = 0;
    out.retain(|_| {
        i += 1;
        !drop[i - 1]
    });
}
