//! Tidepool JSON (its data model): `cbg` and `smbg` (`value` with `units`,
//! mmol/L converted with Tidepool's own 18.01559, a value within the
//! rounding of Tidepool's 5 decimals of a whole mg/dL read as that whole
//! number: [`units::tidepool_mg_dl`]), `bolus` (`normal`,
//! `extended` over `duration` ms), `basal` (`deliveryType` scheduled,
//! automated, temp or suspend, `rate` U/h, `duration` ms), `food`
//! (`nutrition.carbohydrate.net` g), `wizard` (`carbInput` in grams, or
//! in exchanges where `carbUnits` says so, read only with the grams per
//! exchange given; its bolus is a record of its own), `insulin` (pen
//! doses: `dose.total`, rapid/short or intermediate/long by
//! `formulation.simple.actingType`), `pumpSettings`
//! (the active basal schedule and the carb ratios, a therapy profile from
//! its `time`: see [`pump_settings_profile`]); every other type is counted
//! by type.
//!
//! This is Tidepool's data model as its API gives it (`/data/{user}`,
//! durations in ms, objects nested). Tidepool Web's "Export" runs the data
//! through `@tidepool/data-tools` first, for JSON as for Excel (see
//! [`super::tidepool_xlsx`]): its JSON has durations of basal, bolus and
//! device events in **minutes**, `nutrition` and `annotations` as JSON
//! text, glucose in the unit chosen at export (with `units` saying which),
//! pump settings split into `pumpSettings.basalSchedules` ... rows, and no
//! `dose` on pen `insulin` (counted, not read). That form is known by its
//! marks and turned back into the data model first (see `export_form`);
//! read from Tidepool's own code, not from a real file.

use abba_core::{Grams, MgDl, Units, UnitsPerHour};
use serde_json::Value;

use super::json::{objects, parse_array, Item, SheetPlace};
use super::tidepool_xlsx;
use super::{or_skip, Ctx};
use crate::error::IoError;
use crate::record::{
    content_id, BasalSchedule, Censor, Glucose, Origin, OriginAt, Profile, Record, RecordKind,
    Source, SourceId, TempRate,
};
use crate::time::parse_instant;
use crate::units::{self, GLUCOSE_MAX_MG_DL, GLUCOSE_MIN_MG_DL, TIDEPOOL_MG_DL_PER_MMOL_L};

/// Tidepool's data types (for format detection): those of its device
/// data, the loop's own (`dosingDecision`, `controllerSettings`,
/// `controllerStatus`, `pumpStatus`, `reportedState`, `alert`, as
/// Tidepool Loop and DIY Loop upload them: a file of a loop's data may
/// open with one) and `water`, as Tidepool's API documentation lists them
/// (tidepool-org/TidepoolApi, `docs/device-data/data-types`). Those abba
/// does not read are counted by type.
pub const TYPES: [&str; 20] = [
    "insulin",
    "cbg",
    "smbg",
    "bolus",
    "basal",
    "food",
    "wizard",
    "upload",
    "pumpSettings",
    "cgmSettings",
    "deviceEvent",
    "physicalActivity",
    "bloodKetone",
    "dosingDecision",
    "controllerSettings",
    "controllerStatus",
    "pumpStatus",
    "reportedState",
    "alert",
    "water",
];

/// Reads a Tidepool export (JSON).
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let values = parse_array(ctx.file, bytes)?;
    let items = objects(ctx, &values)?;
    match export_form(ctx, &items)? {
        None => read_items(ctx, &items, |item| ctx.origin_item(item.index)),
        Some((rows, notes)) => {
            ctx.notes.borrow_mut().extend(notes);
            let items: Vec<Item<'_>> = rows
                .iter()
                .map(|(obj, index)| Item::json(ctx.file, *index, obj))
                .collect();
            read_items(ctx, &items, |item| ctx.origin_item(item.index))
        }
    }
}

/// How a pen dose of Tidepool Web's export (which leaves out `dose`) is
/// counted.
const PEN_WITHOUT_DOSE: &str = "insulin without its dose (Tidepool Web export)";

/// Fields Tidepool Web's export writes as JSON text where the data model
/// has an object or an array.
const EXPORT_TEXT: [&str; 5] = [
    "nutrition",
    "annotations",
    "payload",
    "deviceManufacturers",
    "deviceTags",
];

/// Tidepool Web's JSON export (the data run through its export processor,
/// see [`super::tidepool_xlsx`]) as the data model, or `None` for a file
/// in the data model's own form. The export's form is known by any of: a
/// flattened key (`suppressed.rate`, `recommended.net`), a split settings
/// row (`pumpSettings.basalSchedules`), the `localTime` the export adds,
/// JSON text in `nutrition`, `annotations`, `payload`,
/// `deviceManufacturers` or `deviceTags`, or the `exportError` item of an
/// export cut short (noted). A file with none of these is read as the data
/// model: the two forms differ only in durations then (ms or minutes), and
/// the export writes every upload's `deviceTags` as text.
#[allow(clippy::type_complexity)]
fn export_form(
    ctx: &Ctx<'_>,
    items: &[Item<'_>],
) -> Result<Option<(Vec<(serde_json::Map<String, Value>, usize)>, Vec<String>)>, IoError> {
    let file = ctx.file;
    let marked = items.iter().any(|i| {
        i.obj
            .keys()
            .any(|k| k.contains('.') || k == "localTime" || k == "exportError")
            || i.obj
                .get("type")
                .and_then(Value::as_str)
                .is_some_and(|t| t.starts_with("pumpSettings."))
            || EXPORT_TEXT
                .iter()
                .any(|f| matches!(i.obj.get(*f), Some(Value::String(_))))
    });
    if !marked {
        return Ok(None);
    }
    let mut notes = Vec::new();
    let mut rows = Vec::with_capacity(items.len());
    let mut pens = 0usize;
    for item in items {
        if item.get("type").is_none() {
            if let Some(e) = item.get("exportError") {
                notes.push(format!(
                    "{file}: $[{}]: Tidepool's export was cut short ({e}); the data before it are read, the rest is missing",
                    item.index
                ));
                continue;
            }
        }
        let ty = or_skip!(
            ctx,
            item.str("type")?
                .ok_or_else(|| item.err("type", "missing: every Tidepool datum has a type"))
        );
        let mut model = or_skip!(
            ctx,
            tidepool_xlsx::to_model(ty, item.obj.clone()).map_err(|(f, m)| item.err(&f, m))
        );
        if ty == "insulin" && !model.contains_key("dose") {
            // The export keeps only the fields of its configuration: a pen
            // dose arrives without its dose.
            pens += 1;
            model.insert("type".into(), Value::String(PEN_WITHOUT_DOSE.into()));
        }
        rows.push((model, item.index));
    }
    if pens > 0 {
        notes.push(format!(
            "{file}: {pens} pen insulin doses (`insulin`) without their dose, as Tidepool Web's export writes them: counted, not read"
        ));
    }
    let mut rows = tidepool_xlsx::join_settings(rows);
    tidepool_xlsx::wizard_carb_units(&mut rows);
    Ok(Some((rows, notes)))
}

/// Reads Tidepool's Excel export (see [`super::tidepool_xlsx`]): each row
/// becomes the data-model object it was written from and is read as the
/// JSON reader reads it.
pub fn read_xlsx(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let book = tidepool_xlsx::read(ctx.file, bytes)?;
    ctx.notes.borrow_mut().extend(book.notes.iter().cloned());
    let items = sheet_items(ctx.file, &book);
    read_items(ctx, &items, |item| {
        let r = &book.rows[item.index];
        Origin {
            file: ctx.index,
            at: OriginAt::Row {
                sheet: r.sheet,
                row: r.row,
            },
        }
    })
}

/// Tidepool data (each an object of Tidepool's data model, from a JSON
/// array or a workbook's rows) as records; `origin` says where each was
/// read.
pub(crate) fn read_items(
    ctx: &Ctx<'_>,
    items: &[Item<'_>],
    origin: impl Fn(&Item<'_>) -> Origin,
) -> Result<Vec<Record>, IoError> {
    let mut out = Vec::with_capacity(items.len());
    let mut exchanges = 0usize;
    let mut unstated = 0usize;
    for item in items {
        let ty = or_skip!(
            ctx,
            item.str("type")?
                .ok_or_else(|| item.err("type", "missing: every Tidepool datum has a type"))
        );
        let kind = match ty {
            "pumpSettings" => settings(ctx, item),
            _ => or_skip!(ctx, datum(item, ty, ctx.opts.grams_per_exchange)),
        };
        let Some(time) = or_skip!(ctx, item.str("time")) else {
            if matches!(kind, RecordKind::Ignored { .. }) || ty == "pumpSettings" {
                continue; // settings and uploads without a time: not data
            }
            or_skip!(
                ctx,
                Err::<(), _>(item.err("time", "missing: expected an ISO 8601 time"))
            );
            continue;
        };
        let at = or_skip!(
            ctx,
            parse_instant(time).ok_or_else(|| {
                item.err(
                    "time",
                    format!("expected an ISO 8601 time with Z or offset, got \"{time}\""),
                )
            })
        );
        let id = match or_skip!(ctx, item.str("id")) {
            Some(id) => SourceId::Id(id.into()),
            None => content_id(Source::Tidepool, at, &kind),
        };
        // The device's zone offset (minutes east; `conversionOffset` is
        // the device clock's error, not a zone): noted, never applied.
        if let Some(s) =
            (item.num("timezoneOffset").ok().flatten()).and_then(crate::clocks::minutes_offset_s)
        {
            ctx.clock(at, s);
        }
        if matches!(&kind, RecordKind::Ignored { kind } if kind == WIZARD_EXCHANGES) {
            exchanges += 1;
        }
        if matches!(&kind, RecordKind::Ignored { kind } if kind == WIZARD_UNSTATED) {
            unstated += 1;
        }
        out.push(Record {
            at,
            kind,
            source: Source::Tidepool,
            id,
            origin: origin(item),
        });
    }
    if exchanges > 0 {
        ctx.note(format!(
            "carbohydrate not read: {exchanges} bolus wizard record{} (`wizard`) in exchanges \
             (`carbUnits`), and an exchange is not one fixed mass; give the grams per exchange \
             (--grams-per-exchange G, or the clinic page's grams-per-exchange field; 10 for the \
             Spanish raci\u{f3}n) to read it as grams",
            if exchanges == 1 { "" } else { "s" }
        ));
    }
    if unstated > 0 {
        ctx.note(format!(
            "carbohydrate not read: {unstated} bolus wizard record{} (`wizard`) of a Medtronic \
             pump whose unit Tidepool's export does not write (its `Carb Input` without \
             `carbUnits`) and no pump settings in the export state (`Carb Units`): the pump may \
             count exchanges, so grams are not assumed; export the data with its pump settings, \
             or read Tidepool's data from its API (JSON), whose wizards carry `carbUnits`",
            if unstated == 1 { "" } else { "s" }
        ));
    }
    Ok(out)
}

fn glucose(item: &Item<'_>) -> Result<Glucose, IoError> {
    let v = item.need_num("value", "a glucose value")?;
    let units_text = item
        .str("units")?
        .ok_or_else(|| item.err("units", "missing: expected mmol/L or mg/dL"))?;
    let mg = match units::GlucoseUnit::parse(units_text) {
        Some(units::GlucoseUnit::MmolL) => units::tidepool_mg_dl(v * TIDEPOOL_MG_DL_PER_MMOL_L),
        Some(units::GlucoseUnit::MgDl) => units::tidepool_mg_dl(v),
        None => {
            return Err(item.err(
                "units",
                format!("expected mmol/L or mg/dL, got \"{units_text}\""),
            ))
        }
    };
    if !(GLUCOSE_MIN_MG_DL..=GLUCOSE_MAX_MG_DL).contains(&mg) {
        return Err(item.err("value", format!("glucose {v} {units_text} is outside the plausible range {GLUCOSE_MIN_MG_DL}..{GLUCOSE_MAX_MG_DL} mg/dL")));
    }
    let censor = match item.get("annotations") {
        Some(Value::Array(a))
            if a.iter().any(|x| {
                x.get("code")
                    .and_then(Value::as_str)
                    .is_some_and(|c| c.ends_with("out-of-range"))
            }) =>
        {
            let threshold = a
                .iter()
                .find_map(|x| x.get("value").and_then(Value::as_str));
            match threshold {
                Some("low") => Censor::Below,
                Some("high") => Censor::Above,
                _ => Censor::Exact,
            }
        }
        _ => Censor::Exact,
    };
    Ok(Glucose {
        mg_dl: MgDl(mg),
        censor,
    })
}

fn ms_to_min(item: &Item<'_>, field: &str) -> Result<Option<u32>, IoError> {
    match item.num(field)? {
        None => Ok(None),
        Some(ms) => Ok(Some(
            (item.range(
                field,
                ms / 60_000.0,
                0.0,
                units::DURATION_MAX_MIN,
                "duration (min)",
            )?)
            .round() as u32,
        )),
    }
}

fn datum(
    item: &Item<'_>,
    ty: &str,
    grams_per_exchange: Option<f64>,
) -> Result<RecordKind, IoError> {
    Ok(match ty {
        "cbg" => RecordKind::Cgm {
            glucose: glucose(item)?,
        },
        "smbg" => RecordKind::Smbg {
            glucose: glucose(item)?,
        },
        "bolus" => bolus(item)?,
        "basal" => basal(item)?,
        "insulin" => insulin_event(item)?,
        "food" => food(item)?,
        "wizard" => wizard(item, grams_per_exchange)?,
        "deviceEvent" => device_event(item)?,
        other => RecordKind::Ignored {
            kind: other.to_string(),
        },
    })
}

/// The kind a wizard's carbohydrate is counted as when Tidepool's export
/// left out its unit and nothing in the export states it (a Medtronic
/// pump's, which may count exchanges; see
/// [`tidepool_xlsx::wizard_carb_units`]).
const WIZARD_UNSTATED: &str = "wizard carbohydrate of unstated unit (Tidepool export)";

/// The kind a wizard's carbohydrate in exchanges is counted as without
/// the grams of one exchange.
const WIZARD_EXCHANGES: &str = "wizard carbohydrate in exchanges (no --grams-per-exchange)";

/// A `wizard` (bolus calculator): its `carbInput` as carbohydrate, in
/// grams, or in exchanges where `carbUnits` says `exchanges` (a Medtronic
/// pump whose wizard counts exchanges; Tidepool's viewer shows them as
/// such) converted with `grams_per_exchange`, and without it counted, not
/// read (the file's note says so). Any other `carbUnits` is refused. Its
/// bolus is a record of its own.
fn wizard(item: &Item<'_>, grams_per_exchange: Option<f64>) -> Result<RecordKind, IoError> {
    let per = match item.str("carbUnits")? {
        None => Some(1.0),
        Some(u) if u.eq_ignore_ascii_case("grams") => Some(1.0),
        Some(u) if u.eq_ignore_ascii_case("exchanges") => grams_per_exchange,
        Some(tidepool_xlsx::CARB_UNITS_UNSTATED) => {
            return Ok(match item.num("carbInput")? {
                Some(v) if v > 0.0 => RecordKind::Ignored {
                    kind: WIZARD_UNSTATED.into(),
                },
                _ => RecordKind::Ignored {
                    kind: "wizard without carbohydrate".into(),
                },
            })
        }
        Some(other) => {
            return Err(item.err(
                "carbUnits",
                format!("expected grams or exchanges, got \"{other}\""),
            ))
        }
    };
    Ok(match (item.num("carbInput")?, per) {
        (Some(v), Some(g)) if v > 0.0 => RecordKind::Carbs {
            grams: Grams(in_range(
                item,
                "carbInput",
                v * g,
                units::CARBS_MAX_G,
                "carbohydrate (g)",
            )?),
        },
        (Some(v), None) if v > 0.0 => RecordKind::Ignored {
            kind: WIZARD_EXCHANGES.into(),
        },
        _ => RecordKind::Ignored {
            kind: "wizard without carbohydrate".into(),
        },
    })
}

/// `field`'s value `v` checked against `0..=max`, naming the field.
fn in_range(item: &Item<'_>, field: &str, v: f64, max: f64, what: &str) -> Result<f64, IoError> {
    item.range(field, v, 0.0, max, what)
}

/// A `bolus`: `normal` now, and `extended` over `duration` (ms).
fn bolus(item: &Item<'_>) -> Result<RecordKind, IoError> {
    let insulin = |field: &str| -> Result<Option<Units>, IoError> {
        match item.num(field)? {
            None => Ok(None),
            Some(u) => Ok(Some(Units(in_range(
                item,
                field,
                u,
                units::BOLUS_MAX_U,
                "insulin (U)",
            )?))),
        }
    };
    let normal = insulin("normal")?;
    Ok(match insulin("extended")? {
        Some(ext) => RecordKind::ExtendedBolus {
            now: normal.unwrap_or(Units(0.0)),
            extended: ext,
            duration_min: ms_to_min(item, "duration")?.ok_or_else(|| {
                item.err("duration", "missing: an extended bolus needs its duration")
            })?,
        },
        None => RecordKind::Bolus {
            units: normal.ok_or_else(|| {
                item.err("normal", "missing: a bolus needs normal or extended (U)")
            })?,
        },
    })
}

/// A `basal` by its `deliveryType`: scheduled or automated (the rate in
/// force), temp (a rate, or for percentage temps the fraction of the
/// schedule: 0.5 = half), suspend.
fn basal(item: &Item<'_>) -> Result<RecordKind, IoError> {
    let delivery = item.str("deliveryType")?.unwrap_or("");
    let duration = ms_to_min(item, "duration")?;
    let rate = || -> Result<UnitsPerHour, IoError> {
        let r = item.need_num("rate", "a basal rate in U/h")?;
        Ok(UnitsPerHour(in_range(
            item,
            "rate",
            r,
            units::BASAL_MAX_U_PER_H,
            "basal rate (U/h)",
        )?))
    };
    Ok(match delivery {
        "scheduled" | "automated" => RecordKind::Schedule {
            profile: Box::new(Profile::basal_only(BasalSchedule::flat(rate()?))),
        },
        "temp" => RecordKind::TempBasal {
            rate: match (item.num("rate")?, item.num("percent")?) {
                (Some(_), _) => TempRate::Absolute(rate()?),
                (None, Some(p)) => TempRate::Percent(in_range(
                    item,
                    "percent",
                    100.0 * p,
                    units::PERCENT_MAX,
                    "percentage of the scheduled rate",
                )?),
                (None, None) => {
                    return Err(item.err("rate", "missing: a temp basal needs rate or percent"))
                }
            },
            duration_min: duration
                .ok_or_else(|| item.err("duration", "missing: a temp basal needs its duration"))?,
        },
        "suspend" => RecordKind::Suspend {
            duration_min: duration,
        },
        other => {
            return Err(item.err(
                "deliveryType",
                format!("expected scheduled, automated, temp or suspend, got \"{other}\""),
            ))
        }
    })
}

/// A `food`: `nutrition.carbohydrate` in grams, `net` (less fibre) when
/// given, else `total`; other units are refused, no carbohydrate counted.
fn food(item: &Item<'_>) -> Result<RecordKind, IoError> {
    let carb = item.get("nutrition").and_then(|n| n.get("carbohydrate"));
    if let Some(u) = carb.and_then(|c| c.get("units")).and_then(Value::as_str) {
        if !u.eq_ignore_ascii_case("grams") {
            return Err(item.err(
                "nutrition.carbohydrate.units",
                format!("expected grams, got \"{u}\""),
            ));
        }
    }
    let (field, g) = match (
        carb.and_then(|c| c.get("net")),
        carb.and_then(|c| c.get("total")),
    ) {
        (Some(v), _) => ("nutrition.carbohydrate.net", v),
        (None, Some(v)) => ("nutrition.carbohydrate.total", v),
        (None, None) => ("", &Value::Null),
    };
    Ok(match g.as_f64() {
        None if !g.is_null() => {
            return Err(item.err(field, format!("expected grams as a number, got {g}")))
        }
        Some(g) => RecordKind::Carbs {
            grams: Grams(in_range(
                item,
                field,
                g,
                units::CARBS_MAX_G,
                "carbohydrate (g)",
            )?),
        },
        None => RecordKind::Ignored {
            kind: "food without carbohydrate".into(),
        },
    })
}

/// A `deviceEvent`: a pump's suspension and resumption; the rest counted.
fn device_event(item: &Item<'_>) -> Result<RecordKind, IoError> {
    Ok(match item.str("subType")? {
        Some("status") => match item.str("status")? {
            Some("suspended") => RecordKind::Suspend {
                duration_min: ms_to_min(item, "duration")?,
            },
            Some("resumed") => RecordKind::Resume,
            other => RecordKind::Ignored {
                kind: format!("deviceEvent status {}", other.unwrap_or("?")),
            },
        },
        other => RecordKind::Ignored {
            kind: format!("deviceEvent {}", other.unwrap_or("?")),
        },
    })
}

/// An `insulin` datum (a pen or syringe dose logged on a meter, receiver
/// or app): `dose.total` in `Units`; `formulation.simple.actingType`
/// rapid or short is a bolus, intermediate or long is long-acting; with no
/// acting type it is counted, not guessed.
fn insulin_event(item: &Item<'_>) -> Result<RecordKind, IoError> {
    let dose = item.get("dose");
    if let Some(u) = dose.and_then(|d| d.get("units")) {
        if u.as_str() != Some("Units") {
            return Err(item.err("dose.units", format!("expected \"Units\", got {u}")));
        }
    }
    let total = match dose.and_then(|d| d.get("total")) {
        Some(v) => v
            .as_f64()
            .ok_or_else(|| item.err("dose.total", format!("expected a number, got {v}")))?,
        None => return Err(item.err("dose.total", "missing: an insulin datum needs its dose (U)")),
    };
    let units = Units(item.range("dose.total", total, 0.0, units::BOLUS_MAX_U, "insulin (U)")?);
    let acting = item
        .get("formulation")
        .and_then(|f| f.get("simple"))
        .and_then(|s| s.get("actingType"))
        .and_then(Value::as_str);
    Ok(match acting {
        Some("rapid" | "short") => RecordKind::Bolus { units },
        Some("intermediate" | "long") => RecordKind::LongActing { units },
        Some(other) => {
            return Err(item.err(
                "formulation.simple.actingType",
                format!("expected rapid, short, intermediate or long, got \"{other}\""),
            ))
        }
        None => RecordKind::Ignored {
            kind: "insulin without an acting type".into(),
        },
    })
}

/// A `pumpSettings` datum: a therapy profile in force from its `time`
/// ([`RecordKind::Schedule`] with the active basal schedule and the carb
/// ratios), which the store puts in force where it differs from the one
/// before it (as a Nightscout profile or Profile Switch). `time` is the
/// only instant Tidepool gives: for Medtronic pumps when the settings took
/// effect, for the others when the pump was read (the upload); the change
/// is placed there, no earlier than the data show it, so advice before
/// it is judged against the settings known before. Settings that cannot
/// be read as a profile (carb ratios in exchanges, no active schedule
/// among several, a value beyond the plausible) are counted with a note
/// saying why, not read, and the rest of the file is kept.
fn settings(ctx: &Ctx<'_>, item: &Item<'_>) -> RecordKind {
    match pump_settings_profile(item).and_then(|p| within_limits(item, p)) {
        Ok(profile) => RecordKind::Schedule {
            profile: Box::new(profile),
        },
        Err(e) => {
            ctx.notes.borrow_mut().push(format!(
                "{e}; these pump settings are counted, not read as a change of therapy"
            ));
            RecordKind::Ignored {
                kind: "pumpSettings".into(),
            }
        }
    }
}

/// `profile` when every rate and ratio is within abba's limits.
fn within_limits(item: &Item<'_>, profile: Profile) -> Result<Profile, IoError> {
    use abba_core::limits::{BASAL_U_PER_H, CARB_RATIO_G_PER_U};
    let hhmm = |m: u32| format!("{:02}:{:02}", m / 60, m % 60);
    for &(m, r) in &profile.basal.segments {
        BASAL_U_PER_H
            .check(r.0)
            .map_err(|e| item.err("basalSchedules", format!("the rate from {}: {e}", hhmm(m))))?;
    }
    for &(m, r) in &profile.carb_ratio {
        CARB_RATIO_G_PER_U
            .check(r.0)
            .map_err(|e| item.err("carbRatio", format!("the ratio from {}: {e}", hhmm(m))))?;
    }
    Ok(profile)
}

/// The active schedule Tidepool's uploader gives the settings of a MiniMed
/// 600 series (630G to 780G) read in SmartGuard's auto mode, with an empty
/// basal schedule of that name (tidepool-org/uploader,
/// `lib/drivers/medtronic600/NGPHistoryParser.js`, `buildSettingsRecords`).
const AUTO_MODE: &str = "Auto Mode";

/// The settings profile of a `pumpSettings` datum, as Tidepool's data
/// model has it: the `activeSchedule` of the named `basalSchedules` (the
/// only one when there is one), the carb ratios of `carbRatio` (one
/// schedule, most pumps) or of `carbRatios` (named like the basal
/// schedules: Tandem, Omnipod 5), `start` in ms from midnight, `units.carb`
/// grams (exchanges are refused). BG targets and sensitivities are not
/// read. A MiniMed's settings in auto mode ([`AUTO_MODE`]) have no
/// schedule in force: refused, saying so. Values are checked by
/// [`crate::therapy::PumpTherapy::from_profile`].
pub fn pump_settings_profile(item: &Item<'_>) -> Result<Profile, IoError> {
    // Carb ratios in g/U: a pump counting exchanges is not read.
    let carb_unit = item
        .get("units")
        .and_then(|u| u.get("carb").or_else(|| u.get("carbs")))
        .and_then(Value::as_str);
    if let Some(u) = carb_unit.filter(|u| !u.eq_ignore_ascii_case("grams")) {
        return Err(item.err(
            "units.carb",
            format!("expected grams (carb ratios in g/U), got \"{u}\""),
        ));
    }
    let active = item.get("activeSchedule").and_then(Value::as_str);
    if active == Some(AUTO_MODE) {
        return Err(item.err(
            "activeSchedule",
            format!(
                "\"{AUTO_MODE}\": the pump was in SmartGuard's auto mode, which sets the basal \
                 itself (no basal schedule in force), a closed loop abba is not designed for"
            ),
        ));
    }
    let pick = |field: &str| -> Option<&Value> {
        let v = item.get(field)?;
        match v {
            Value::Object(named) => active
                .and_then(|a| named.get(a))
                .or_else(|| (named.len() == 1).then(|| named.values().next()).flatten()),
            other => Some(other),
        }
    };
    let segments = |field: &str, value: &str| -> Result<Vec<(u32, f64)>, IoError> {
        let Some(Value::Array(rows)) = pick(field) else {
            let schedule = match active {
                Some(a) => format!("of the active schedule \"{a}\""),
                None => "no activeSchedule named".to_string(),
            };
            return Err(item.err(
                field,
                format!("missing: expected an array of {{start, {value}}} ({schedule})"),
            ));
        };
        let mut s: Vec<(u32, f64)> = Vec::new();
        for (j, row) in rows.iter().enumerate() {
            let f = format!("{field}[{j}]");
            let start = row
                .get("start")
                .and_then(Value::as_f64)
                .ok_or_else(|| item.err(&f, "missing start (ms from midnight)"))?;
            let x = row
                .get(value)
                .and_then(Value::as_f64)
                .ok_or_else(|| item.err(&f, format!("missing {value}")))?;
            let m = start / 60_000.0;
            if !(0.0..1440.0).contains(&m) || m.fract() != 0.0 {
                return Err(item.err(
                    &f,
                    format!("start {start} ms is not a whole minute of the day"),
                ));
            }
            let m = m as u32;
            if s.last().is_some_and(|l| m <= l.0) || (s.is_empty() && m != 0) {
                return Err(item.err(&f, "starts must begin at 0 and increase"));
            }
            s.push((m, x));
        }
        if s.is_empty() {
            return Err(item.err(field, "the schedule is empty"));
        }
        Ok(s)
    };
    let basal = segments("basalSchedules", "rate")?;
    let cr_field = if item.get("carbRatios").is_some() {
        "carbRatios"
    } else {
        "carbRatio"
    };
    let cr = segments(cr_field, "amount")?;
    Ok(Profile {
        basal: BasalSchedule {
            segments: basal
                .into_iter()
                .map(|(m, r)| (m, UnitsPerHour(r)))
                .collect(),
        },
        carb_ratio: cr
            .into_iter()
            .map(|(m, r)| (m, abba_core::GramsPerUnit(r)))
            .collect(),
        timezone: None,
        temporary_min: None,
    })
}

/// Every `pumpSettings` datum of a Tidepool export (JSON or workbook) with
/// its instant, where it was read, and its profile or why it has none.
#[allow(clippy::type_complexity)]
pub(crate) fn pump_settings(
    file: &str,
    bytes: &[u8],
) -> Result<
    Vec<(
        Result<jiff::Timestamp, IoError>,
        String,
        Result<Profile, IoError>,
    )>,
    IoError,
> {
    let each = |items: &[Item<'_>]| {
        items
            .iter()
            .filter(|i| i.str("type").ok().flatten() == Some("pumpSettings"))
            .map(|item| {
                let at = item.str("time").and_then(|t| {
                    let t =
                        t.ok_or_else(|| item.err("time", "missing: expected an ISO 8601 time"))?;
                    parse_instant(t).ok_or_else(|| {
                        item.err(
                            "time",
                            format!("expected an ISO 8601 time with Z or offset, got \"{t}\""),
                        )
                    })
                });
                let place = match &item.sheet {
                    Some(s) => format!("{file}: sheet \"{}\", row {}", s.sheet, s.row),
                    None => format!("{file}: $[{}]", item.index),
                };
                (at, place, pump_settings_profile(item))
            })
            .collect()
    };
    if tidepool_xlsx::is_zip(bytes) {
        let book = tidepool_xlsx::read(file, bytes)?;
        let items = sheet_items(file, &book);
        Ok(each(&items))
    } else {
        let values = parse_array(file, bytes)?;
        let items: Vec<Item<'_>> = values
            .iter()
            .enumerate()
            .filter_map(|(index, v)| v.as_object().map(|obj| Item::json(file, index, obj)))
            .collect();
        // Only the settings are wanted here: a datum the export form
        // cannot read is the data's reader's to report.
        let opts = super::ReadOptions::default();
        let ctx = Ctx {
            file,
            index: 0,
            opts: &opts,
            notes: Default::default(),
            skipped: Default::default(),
            clocks: Default::default(),
            stores: &[],
            found_stores: Default::default(),
            wants_stores: Default::default(),
            pump_identities: Default::default(),
        };
        match export_form(&ctx, &items)? {
            None => Ok(each(&items)),
            Some((rows, _)) => {
                let items: Vec<Item<'_>> = rows
                    .iter()
                    .map(|(obj, index)| Item::json(file, *index, obj))
                    .collect();
                Ok(each(&items))
            }
        }
    }
}

/// A workbook's objects as items naming their sheet, row and columns.
fn sheet_items<'a>(file: &'a str, book: &'a tidepool_xlsx::Book) -> Vec<Item<'a>> {
    book.rows
        .iter()
        .enumerate()
        .map(|(index, r)| {
            let layout = &tidepool_xlsx::SHEETS[usize::from(r.sheet)];
            let joined = r.obj.get("type").and_then(Value::as_str) == Some("pumpSettings");
            Item {
                file,
                index,
                obj: &r.obj,
                sheet: Some(SheetPlace {
                    sheet: layout.name,
                    row: r.row,
                    columns: if joined {
                        tidepool_xlsx::JOINED_SETTINGS
                    } else {
                        layout.columns
                    },
                }),
            }
        })
        .collect()
}
