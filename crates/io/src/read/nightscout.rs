//! Nightscout API JSON as downloaded (newest first): `entries.json` (`sgv`,
//! `mbg`, `cal`), `treatments.json` (boluses, carbs, temporary basals,
//! suspend/resume, everything else counted by `eventType`; a document
//! marked `isValid: false` counted, see [`is_valid`]; a treatment without
//! an eventType read for its insulin and carbs; a Profile Switch to a
//! pump's auto mode counted as loop evidence, see [`is_auto_mode_switch`];
//! a Profile Switch that only names its profile applied from the batch's
//! profile store, see [`named_switch`]) and `profile.json` (basal schedule
//! in U/h, `timezone`, `units`; every named profile kept for the
//! switches, [`ProfileStore`]). Entries
//! store glucose in mg/dL whatever the display unit; a treatment's
//! `glucose` (BG Check) says its unit in `units`.

use abba_core::{Grams, GramsPerUnit, MgDl, Units, UnitsPerHour};
use serde_json::Value;

use super::json::{object, parse_array, Item};
use super::{or_skip, Ctx};
use crate::error::IoError;
use crate::record::{
    content_id, BasalSchedule, Censor, Glucose, Profile, Record, RecordKind, Source, SourceId,
    TempRate,
};
use crate::time::parse_instant;
use crate::units::{self, check_range, GlucoseUnit};

/// Reads a Nightscout JSON file (entries, treatments or profiles, told
/// apart item by item).
pub fn read(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let text = bytes.trim_ascii_start();
    if !text.starts_with(b"[") && !text.starts_with(b"{") {
        let first = text.split(|b| *b == b'\n').next().unwrap_or_default();
        if looks_like_csv(&String::from_utf8_lossy(first)) {
            return read_csv(ctx, bytes);
        }
    }
    let items = parse_array(ctx.file, bytes)?;
    let mut out = Vec::with_capacity(items.len());
    let mut versions: Vec<Option<f64>> = Vec::with_capacity(items.len());
    let mut pump_keys: Vec<Option<PumpEvent>> = Vec::with_capacity(items.len());
    let mut switches: Vec<Switch> = Vec::new();
    let mut tally = Tally::default();
    for (index, value) in items.iter().enumerate() {
        let item = or_skip!(ctx, object(ctx.file, index, value));
        let at = or_skip!(ctx, instant(&item));
        if let Some(offset) = device_offset(&item) {
            ctx.clock(at, offset);
        }
        let id = or_skip!(ctx, document_id(&item));
        let version = or_skip!(ctx, modified(&item));
        let kinds = or_skip!(ctx, kinds(ctx, &item, at, &mut tally));
        let pump_key = match kinds.first() {
            Some(RecordKind::Ignored { .. }) | None => None,
            Some(_) => or_skip!(ctx, pump_event(&item)),
        };
        if item.get("store").is_some() && matches!(kinds.first(), Some(RecordKind::Schedule { .. }))
        {
            ctx.found_stores.borrow_mut().push(store_of(ctx, &item, at));
        }
        let switch = match item.str("eventType") {
            Ok(Some("Profile Switch"))
                if matches!(kinds.first(), Some(RecordKind::Schedule { .. })) =>
            {
                Some(Switch {
                    record: out.len(),
                    minutes: or_skip!(ctx, switch_minutes(&item)),
                    item: item.index,
                    name: or_skip!(ctx, switch_name(&item)),
                })
            }
            _ => None,
        };
        switches.extend(switch);
        for (n, kind) in kinds.into_iter().enumerate() {
            let id = match (&id, n) {
                (SourceId::Id(s), 0) => SourceId::Id(s.clone()),
                (SourceId::Id(s), n) => SourceId::Id(format!("{s}#{n}").into()),
                (SourceId::Hash(_), _) => content_id(Source::Nightscout, at, &kind),
            };
            versions.push(version);
            pump_keys.push(pump_key.clone());
            out.push(Record {
                at,
                kind,
                source: Source::Nightscout,
                id,
                origin: ctx.origin_item(item.index),
            });
        }
    }
    check_error_codes(ctx, &out)?;
    let item_indices: Vec<u32> = out.iter().map(item_of).collect();
    let copies = pump_copies(ctx, &items, &out, &versions, &pump_keys)?;
    tally.note(ctx, &out);
    temporary_switches(ctx, &mut out, &mut versions, &switches);
    latest_versions(ctx, &mut out, &versions);
    if !copies.is_empty() {
        out.retain(|r| !copies.contains(&item_of(r)));
    }
    // Each dose's pump identity, for the store to tell a copy stored by an
    // earlier import from a second dose ([`super::pump_identity`]).
    let mut kept: Vec<(u32, super::pump_identity::PumpIdentity)> = (pump_keys.iter())
        .zip(item_indices)
        .filter(|(_, item)| !copies.contains(item))
        .filter_map(|(k, item)| k.as_ref().map(|k| (item, k.identity())))
        .collect();
    kept.dedup_by_key(|(item, _)| *item);
    ctx.pump_identities.borrow_mut().extend(kept);
    Ok(out)
}

/// Nightscout's own CSV and TSV of entries (`/api/v1/entries.csv`,
/// `.tsv`, `.txt`; `lib/api/entries/index.js`, `formatWithSeparator`):
/// no header, one entry a line, its `dateString`, `date` (ms since the
/// epoch), `sgv` (mg/dL), `direction` and `device`, each as JSON writes it
/// (strings quoted, a missing value empty), separated by `,` or a tab. The
/// first line decides: a second cell of 12 or 13 digits (milliseconds
/// since 1973 or later) and a third that is a number or empty.
pub fn looks_like_csv(first_line: &str) -> bool {
    let Some(sep) = [',', '\t'].into_iter().find(|c| first_line.contains(*c)) else {
        return false;
    };
    let cells: Vec<&str> = first_line
        .trim_end_matches(['\r', '\n'])
        .split(sep)
        .map(|c| c.trim().trim_matches('"'))
        .collect();
    cells.len() >= 3
        && cells.len() <= 5
        && (12..=13).contains(&cells[1].len())
        && cells[1].bytes().all(|b| b.is_ascii_digit())
        && (cells[2].is_empty() || cells[2].parse::<f64>().is_ok())
}

/// Reads Nightscout's CSV or TSV of entries ([`looks_like_csv`]): each
/// line's `date` and `sgv` as the JSON entries are read (mg/dL, Dexcom's
/// error codes counted); a line without an sgv (a meter reading or a
/// calibration: the CSV carries no `mbg`) is counted, not read. Its time
/// is `date`, which says the instant; `dateString` is the same in words.
pub fn read_csv(ctx: &Ctx<'_>, bytes: &[u8]) -> Result<Vec<Record>, IoError> {
    let first = (bytes.trim_ascii_start().split(|b| *b == b'\n').next()).unwrap_or_default();
    let delimiter = if first.contains(&b'\t') { b'\t' } else { b',' };
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .delimiter(delimiter)
        .flexible(true)
        .from_reader(bytes);
    let mut out = Vec::new();
    let mut record = csv::StringRecord::new();
    let mut no_sgv = 0usize;
    loop {
        let line = reader.position().line();
        match reader.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                return Err(IoError::invalid(
                    crate::error::Location::line(ctx.file, line),
                    "line",
                    format!("not a CSV line of Nightscout entries: {e}"),
                ))
            }
        }
        let cell = |i: usize| record.get(i).map(str::trim).unwrap_or("");
        if record.iter().all(|c| c.trim().is_empty()) {
            continue;
        }
        let mut obj = serde_json::Map::new();
        let date = or_skip!(
            ctx,
            cell(1).parse::<i64>().map_err(|_| IoError::invalid(
                crate::error::Location::line(ctx.file, line),
                "date",
                format!(
                    "expected the entry's time in milliseconds since 1970 (the second cell), got \"{}\"",
                    cell(1)
                ),
            ))
        );
        obj.insert("date".into(), Value::from(date));
        if cell(2).is_empty() {
            no_sgv += 1;
            obj.insert("type".into(), Value::from("no sgv in Nightscout's CSV"));
        } else {
            obj.insert("type".into(), Value::from("sgv"));
            obj.insert("sgv".into(), Value::from(cell(2)));
        }
        let item = Item::json(ctx.file, out.len(), &obj);
        let on_line = |e: IoError| match e {
            IoError::Invalid { field, message, .. } => IoError::Invalid {
                at: crate::error::Location::line(ctx.file, line),
                field: match field.as_str() {
                    "sgv" => "sgv (the third cell)".into(),
                    "date" => "date (the second cell)".into(),
                    _ => field,
                },
                message,
            },
            other => other,
        };
        let at = or_skip!(ctx, instant(&item).map_err(on_line));
        let kind = or_skip!(ctx, entry(&item).map_err(on_line));
        if let Some(offset) = crate::clocks::text_offset_s(cell(0)) {
            ctx.clock(at, offset);
        }
        out.push(Record {
            at,
            id: content_id(Source::Nightscout, at, &kind),
            kind,
            source: Source::Nightscout,
            origin: ctx.origin_line(line),
        });
    }
    if no_sgv > 0 {
        ctx.note(format!(
            "{no_sgv} lines without an sgv (meter readings or calibrations: Nightscout's CSV of \
             entries carries no mbg): counted, not read"
        ));
    }
    check_error_codes(ctx, &out)?;
    Ok(out)
}

/// A document's identity: `_id`, a string from the API or `{"$oid": ...}`
/// from a MongoDB dump; else API v3's `identifier` (a document created
/// through API v1 has its `_id` there, so both name it alike); else none
/// (the first record of some dumps), and its content is its identity.
fn document_id(item: &Item<'_>) -> Result<SourceId, IoError> {
    match item.get("_id") {
        Some(Value::String(id)) => Ok(SourceId::Id(id.as_str().into())),
        Some(Value::Object(o)) => match o.get("$oid") {
            Some(Value::String(id)) => Ok(SourceId::Id(id.as_str().into())),
            _ => Err(item.err("_id", "expected a string or {\"$oid\": string}")),
        },
        None => match item.get("identifier") {
            Some(Value::String(id)) => Ok(SourceId::Id(id.as_str().into())),
            None => Ok(SourceId::Hash(0)),
            Some(other) => Err(item.err("identifier", format!("expected a string, got {other}"))),
        },
        Some(other) => Err(item.err("_id", format!("expected a string, got {other}"))),
    }
}

/// What one document holds: a profile, a treatment's records, an entry,
/// a device status, or a document deleted where it was written.
fn kinds(
    ctx: &Ctx<'_>,
    item: &Item<'_>,
    at: jiff::Timestamp,
    tally: &mut Tally,
) -> Result<Vec<RecordKind>, IoError> {
    Ok(if !is_valid(item)? {
        vec![RecordKind::Ignored {
            kind: format!(
                "{} marked isValid: false (deleted where it was written)",
                item.str("eventType")?.unwrap_or("record")
            ),
        }]
    } else if item.get("store").is_some() {
        vec![profile(item)?]
    } else if let Some(event) = item.str("eventType")? {
        treatment(ctx, item, at, event, tally)?
    } else if untyped_treatment(item) {
        treatment(ctx, item, at, "", tally)?
    } else if let Some(kind) = device_status(item) {
        vec![kind]
    } else {
        vec![entry(item)?]
    })
}

/// The keys of a Nightscout `devicestatus` document (`/api/v1/devicestatus`):
/// what the uploader, the pump and a loop reported (battery, reservoir,
/// insulin on board, a loop's predictions and what it enacted). Loop
/// writes `loop`, OpenAPS, AndroidAPS, iAPS and Trio `openaps`, the
/// 600-series uploader `pump` with `uploaderBattery`, xDrip+ `xdripjs`.
pub const DEVICE_STATUS_KEYS: [&str; 8] = [
    "loop",
    "openaps",
    "pump",
    "uploader",
    "uploaderBattery",
    "xdripjs",
    "override",
    "radioAdapter",
];

/// A device status document (no `type`, `sgv`, `mbg` or `eventType`, and a
/// key of [`DEVICE_STATUS_KEYS`]): counted, not read. It holds no glucose
/// and no dose; a loop's status marks a closed loop (the
/// [`crate::automation::Evidence`] of the file counts it).
fn device_status(item: &Item<'_>) -> Option<RecordKind> {
    if ["type", "sgv", "mbg", "eventType"]
        .iter()
        .any(|f| item.get(f).is_some())
    {
        return None;
    }
    let of = ["loop", "openaps"]
        .into_iter()
        .find(|k| item.get(k).is_some_and(Value::is_object));
    if of.is_none() && !DEVICE_STATUS_KEYS.iter().any(|k| item.get(k).is_some()) {
        return None;
    }
    Some(RecordKind::Ignored {
        kind: match of {
            Some(k) => format!("devicestatus of a closed loop ({k})"),
            None => "devicestatus".into(),
        },
    })
}

/// A Profile Switch read as a schedule: its record's index, its duration
/// (0: until the next switch), its JSON item and its profile's name and
/// percentage in words (for notes).
struct Switch {
    record: usize,
    minutes: u32,
    item: usize,
    name: String,
}

/// A Profile Switch's profile in words: `profile` (AndroidAPS writes the
/// customised name there, e.g. `Exercise(80%)`), else `originalProfileName`,
/// with its `percentage` when not 100. Words for a note only: a name that
/// is not text is left out, never an error.
fn switch_name(item: &Item<'_>) -> Result<String, IoError> {
    let text = |f: &str| item.str(f).ok().flatten();
    let name = match text("profile").or_else(|| text("originalProfileName")) {
        Some(n) => format!("profile \"{n}\""),
        None => "an unnamed profile".to_string(),
    };
    Ok(match item.num("percentage")? {
        Some(p) if p != 100.0 => format!("{name} at {p} %"),
        _ => name,
    })
}

/// A Profile Switch's duration in minutes, as AndroidAPS reads it back
/// (`PS.fromJson` in `plugins/sync/.../nsclient/extensions/
/// ProfileSwitchExtension.kt`: `originalDuration` in ms, else `duration`
/// in minutes; NSClientV3 writes `durationInMilliseconds`).
fn switch_minutes(item: &Item<'_>) -> Result<u32, IoError> {
    if item.get("durationInMilliseconds").is_none() {
        if let Some(ms) = item.num("originalDuration")? {
            return Ok(check_range(
                &item.at("originalDuration"),
                "originalDuration",
                ms / 60_000.0,
                0.0,
                units::DURATION_MAX_MIN * 365.0,
                "duration (min, from milliseconds)",
            )?
            .round() as u32);
        }
    }
    Ok(match item.num("durationInMilliseconds")? {
        Some(_) => duration(item)?.unwrap_or(0),
        None => match item.num("duration")? {
            None => 0,
            Some(d) => check_range(
                &item.at("duration"),
                "duration",
                d,
                0.0,
                units::DURATION_MAX_MIN * 365.0,
                "duration (min)",
            )?
            .round() as u32,
        },
    })
}

/// A temporary Profile Switch (a duration above 0) is in force from its
/// start until its end or the next switch, whichever is first; then
/// AndroidAPS runs the latest permanent switch again
/// (`getProfileSwitchActiveAt` in `database/impl/.../AppRepository.kt`:
/// the temporary switch active at the time, else the latest permanent
/// one, the later of the two). Every temporary switch's schedule carries
/// its duration ([`crate::record::Profile::temporary_min`]), so that whoever
/// reads the records (the therapy in force, the store's therapy changes)
/// can tell it from the person's settings. At the end of a temporary
/// switch that no other switch cut short, and that ends within the file's
/// records, a schedule record (id `<_id>#end`) brings back the latest
/// permanent switch before it. When the file holds no permanent switch
/// before it, what the pump returned to is not known: the temporary switch
/// is counted, not read (its profile would stay in force for good). A
/// temporary switch still running at the file's last record gets no
/// `#end` record (its end is not in the data, and a later switch may yet
/// cut it short) and a note saying so and what it returns to.
fn temporary_switches(
    ctx: &Ctx<'_>,
    out: &mut Vec<Record>,
    versions: &mut Vec<Option<f64>>,
    switches: &[Switch],
) {
    // Every version of a switch is marked, so that equal versions stay equal.
    for s in switches {
        if let (RecordKind::Schedule { profile }, 1..) = (&mut out[s.record].kind, s.minutes) {
            profile.temporary_min = Some(s.minutes);
        }
    }
    let Some(last) = out.iter().map(|r| r.at).max() else {
        return;
    };
    // One version of each switch: the one `latest_versions` keeps.
    let mut latest: std::collections::HashMap<&SourceId, &Switch> =
        std::collections::HashMap::new();
    for s in switches {
        let e = latest.entry(&out[s.record].id).or_insert(s);
        let newer = match (versions[e.record], versions[s.record]) {
            (Some(a), Some(b)) => b >= a,
            (Some(_), None) => false,
            _ => true,
        };
        if newer {
            *e = s;
        }
    }
    let mut kept: Vec<&Switch> = latest.into_values().collect();
    kept.sort_by_key(|s| (out[s.record].at, s.record));
    let mut ends = Vec::new();
    let mut unknown = Vec::new();
    for (i, s) in kept.iter().enumerate() {
        if s.minutes == 0 {
            continue;
        }
        let start = out[s.record].at;
        let end = start
            .checked_add(jiff::SignedDuration::from_mins(i64::from(s.minutes)))
            .unwrap_or(jiff::Timestamp::MAX);
        let cut_short = kept
            .get(i + 1)
            .is_some_and(|next| out[next.record].at < end);
        if cut_short {
            continue;
        }
        let permanent = kept[..i].iter().rev().find(|p| p.minutes == 0);
        if end > last {
            let returns = match permanent {
                Some(p) => format!(
                    "at its end AndroidAPS returns to the permanent Profile Switch of {} \
                     ($[{}], {}), which stays the person's settings",
                    out[p.record].at, p.item, p.name
                ),
                None => "the file holds no permanent Profile Switch before it, so the profile \
                         it returns to (the person's settings) is not known"
                    .to_string(),
            };
            ctx.note(format!(
                "the Profile Switch of {start} ($[{}], {}) is temporary ({} min, until {end}) \
                 and was still running at the file's last record ({last}): a temporary \
                 profile, in force in its window only and not taken as the person's \
                 settings; {returns}",
                s.item, s.name, s.minutes
            ));
            continue;
        }
        match permanent {
            Some(p) => ends.push((s.record, end, out[p.record].kind.clone())),
            None => unknown.push(s.record),
        }
    }
    for i in unknown {
        out[i].kind = RecordKind::Ignored {
            kind: "Profile Switch, temporary, and the file holds no permanent switch before it \
                   (what the pump returned to is not known)"
                .into(),
        };
    }
    for (i, end, kind) in ends {
        let id = match &out[i].id {
            SourceId::Id(s) => SourceId::Id(format!("{s}#end").into()),
            SourceId::Hash(_) => content_id(Source::Nightscout, end, &kind),
        };
        versions.push(versions[i]);
        out.push(Record {
            at: end,
            kind,
            source: Source::Nightscout,
            id,
            origin: out[i].origin,
        });
    }
}

/// A document's `isValid` (true when absent). AndroidAPS never deletes a
/// document it uploaded: a treatment deleted in AndroidAPS is sent again
/// with `isValid: false` (NSClient: `nsUpdate` of the record's JSON, which
/// carries `isValid`, `plugins/sync/.../nsclient/DataSyncSelectorV1.kt`
/// and `nsclient/extensions/*Extension.kt` `toJson`; NSClientV3: the
/// `isValid` of `core/nssdk/.../mapper/TreatmentMapper.kt`), and
/// Nightscout's API v3 deletes by the same mark; API v1 still lists such
/// documents. They did not happen: counted, not read.
fn is_valid(item: &Item<'_>) -> Result<bool, IoError> {
    match item.get("isValid") {
        None | Some(Value::Bool(true)) => Ok(true),
        Some(Value::Bool(false)) => Ok(false),
        Some(other) => Err(item.err("isValid", format!("expected true or false, got {other}"))),
    }
}

/// A document's version stamp: `srvModified` (Nightscout API v3, ms) or
/// `modifiedAt`, if given.
fn modified(item: &Item<'_>) -> Result<Option<f64>, IoError> {
    match item.num("srvModified")? {
        Some(v) => Ok(Some(v)),
        None => Ok(item
            .str("modifiedAt")?
            .and_then(parse_instant)
            .map(|t| t.as_millisecond() as f64)),
    }
}

/// Of the records repeating an `_id` (AndroidAPS rewrites a temporary
/// basal it cut short, with another duration or time), keeps the latest
/// version: the greatest `srvModified`, else the last in the file; the
/// others are counted in a note.
fn latest_versions(ctx: &Ctx<'_>, out: &mut Vec<Record>, versions: &[Option<f64>]) {
    let mut best: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for (i, r) in out.iter().enumerate() {
        let SourceId::Id(id) = &r.id else { continue };
        let e = best.entry(id).or_insert(i);
        let newer = match (versions[*e], versions[i]) {
            (Some(a), Some(b)) => b >= a,
            (Some(_), None) => false,
            _ => true,
        };
        if newer {
            *e = i;
        }
    }
    let drop: Vec<bool> = out
        .iter()
        .map(|r| match &r.id {
            SourceId::Id(id) => best.get(&**id).is_some_and(|&w| {
                let w = &out[w];
                w.at != r.at || w.kind != r.kind
            }),
            SourceId::Hash(_) => false,
        })
        .collect();
    let before = out.len();
    let mut i = 0;
    out.retain(|_| {
        i += 1;
        !drop[i - 1]
    });
    if out.len() < before {
        ctx.note(format!(
            "{} records repeat an _id of another record of the file: the latest version \
             (srvModified, else the last in the file) is kept",
            before - out.len()
        ));
    }
}

/// How far apart (seconds) copies of one pump event with the same values
/// may be and still read alike: AndroidAPS dates a dose when it sends the
/// command and again, seconds apart, when it reads the pump's history.
pub const COPY_WITHIN_S: i64 = 60;

/// One event of a pump's history as AndroidAPS names it: its `eventType`
/// and the pump's `pumpType`, `pumpSerial` and `pumpId` (the history
/// record's number; `nsclient/extensions/*Extension.kt` and
/// `core/nssdk/.../mapper/TreatmentMapper.kt` write all three beside each
/// bolus, temporary basal and extended bolus read from the pump).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct PumpEvent {
    event: String,
    pump_type: String,
    serial: String,
    id: i64,
}

impl PumpEvent {
    /// The pump's identity of the event, kept with its record.
    fn identity(&self) -> super::pump_identity::PumpIdentity {
        super::pump_identity::PumpIdentity {
            pump_type: self.pump_type.clone(),
            serial: self.serial.clone(),
            id: self.id,
        }
    }
}

/// The pump event a document carries ([`PumpEvent`]), if it has a
/// `pumpId`; one that is not a whole number is refused.
fn pump_event(item: &Item<'_>) -> Result<Option<PumpEvent>, IoError> {
    let id = match item.get("pumpId") {
        None | Some(Value::Null) => return Ok(None),
        Some(Value::Number(n)) => n
            .as_i64()
            .or_else(|| n.as_f64().filter(|f| f.fract() == 0.0).map(|f| f as i64)),
        Some(_) => None,
    };
    let Some(id) = id else {
        return Err(item.err(
            "pumpId",
            format!(
                "expected the pump history record's number (a whole number), got {}",
                item.get("pumpId").map_or(String::new(), Value::to_string)
            ),
        ));
    };
    Ok(Some(PumpEvent {
        event: item.str("eventType")?.unwrap_or("").to_string(),
        pump_type: item.str("pumpType")?.unwrap_or("").to_string(),
        serial: item.str("pumpSerial")?.unwrap_or("").to_string(),
        id,
    }))
}

/// Documents naming one pump event ([`PumpEvent`]) under other `_id`s are
/// copies of it, not more doses: AndroidAPS uploads its history again after
/// a reinstall or a lost answer, and a switch between its NSClient (API v1)
/// and NSClientV3 can leave a copy of each (Nightscout merges copies only
/// of the same `created_at` and `eventType`, `lib/server/treatments.js`,
/// or `identifier`). The copies are one event. Copies that read alike (the
/// same values, within [`COPY_WITHIN_S`]): one is kept, the latest
/// version (`srvModified`) when every copy has one, else the first. Copies
/// that differ (a bolus cut short, a temporary basal ended early): the
/// latest version when every copy has a `srvModified`; without it all
/// are left out, each reported as unread (abba does not guess which dose
/// was given). Counted in a note.
fn pump_copies(
    ctx: &Ctx<'_>,
    items: &[Value],
    out: &[Record],
    versions: &[Option<f64>],
    keys: &[Option<PumpEvent>],
) -> Result<std::collections::HashSet<u32>, IoError> {
    use std::collections::{HashMap, HashSet};
    // Each pump event's documents (item indices, in file order). A
    // document that comes again under its own `_id` is one document in
    // versions ([`latest_versions`] keeps one): its last item stands for it.
    let mut copies: HashMap<&PumpEvent, Vec<(u32, Option<&str>)>> = HashMap::new();
    for (r, key) in out.iter().zip(keys) {
        let Some(k) = key else { continue };
        let id = match &r.id {
            SourceId::Id(id) => id.split('#').next(),
            SourceId::Hash(_) => None,
        };
        let items = copies.entry(k).or_default();
        let item = item_of(r);
        match items
            .iter_mut()
            .find(|(i, d)| *i == item || (id.is_some() && *d == id))
        {
            Some(same) => same.0 = item,
            None => items.push((item, id)),
        }
    }
    let copies: HashMap<&PumpEvent, Vec<u32>> = copies
        .into_iter()
        .map(|(k, v)| (k, v.into_iter().map(|(i, _)| i).collect()))
        .collect();
    let content = |item: u32| -> Vec<(jiff::Timestamp, &RecordKind)> {
        out.iter()
            .filter(|r| item_of(r) == item)
            .map(|r| (r.at, &r.kind))
            .collect()
    };
    let version = |item: u32| {
        out.iter()
            .position(|r| item_of(r) == item)
            .and_then(|i| versions[i])
    };
    let mut drop: HashSet<u32> = HashSet::new();
    let (mut alike, mut newer) = (0usize, 0usize);
    let mut groups: Vec<(&PumpEvent, &Vec<u32>)> = copies
        .iter()
        .filter(|(_, v)| v.len() > 1)
        .map(|(k, v)| (*k, v))
        .collect();
    groups.sort_by_key(|(_, v)| v[0]);
    for (key, group) in groups {
        let stamps: Option<Vec<f64>> = group.iter().map(|&i| version(i)).collect();
        let latest = stamps.as_ref().map(|s| {
            (0..group.len())
                .max_by(|&a, &b| s[a].total_cmp(&s[b]))
                .unwrap_or(0)
        });
        let first = content(group[0]);
        let like_first = |i: u32| {
            let c = content(i);
            c.len() == first.len()
                && c.iter().zip(&first).all(|((a, k), (b, l))| {
                    k == l
                        && a.duration_since(*b).abs()
                            <= jiff::SignedDuration::from_secs(COPY_WITHIN_S)
                })
        };
        if group[1..].iter().all(|&i| like_first(i)) {
            let kept = latest.unwrap_or(0);
            drop.extend(
                (group.iter().enumerate())
                    .filter(|(n, _)| *n != kept)
                    .map(|(_, i)| *i),
            );
            alike += group.len() - 1;
            continue;
        }
        if let Some(kept) = latest {
            drop.extend(
                (group.iter().enumerate())
                    .filter(|(n, _)| *n != kept)
                    .map(|(_, i)| *i),
            );
            newer += group.len() - 1;
            continue;
        }
        drop.extend(group);
        let named: Vec<String> = group.iter().map(|i| format!("$[{i}]")).collect();
        for &i in group {
            ctx.skip(IoError::invalid(
                crate::error::Location::json(ctx.file, format!("$[{i}]")),
                "pumpId",
                format!(
                    "{} documents ({}) carry one pump event ({}, pump {} {}, pumpId {}) with other \
                     values (this one: {}) and no srvModified to tell the latest version: none is \
                     read, abba does not guess which was given",
                    group.len(),
                    named.join(", "),
                    if key.event.is_empty() { "no eventType" } else { &key.event },
                    if key.pump_type.is_empty() { "?" } else { &key.pump_type },
                    if key.serial.is_empty() { "?" } else { &key.serial },
                    key.id,
                    values_of(items.get(i as usize))
                ),
            ))?;
        }
    }
    if alike + newer > 0 {
        ctx.note(format!(
            "{} documents repeat a pump event of another document under another _id (the same \
             eventType, pumpType, pumpSerial and pumpId, as AndroidAPS writes beside what it read \
             from the pump; uploaded again): one event, read once ({alike} copies with the same \
             values within {COPY_WITHIN_S} s, the latest srvModified or else the first kept; \
             {newer} older versions, the latest srvModified kept)",
            alike + newer
        ));
    }
    Ok(drop)
}

/// The JSON item a record was read from (its index in the file).
fn item_of(r: &Record) -> u32 {
    match r.origin.at {
        crate::record::OriginAt::Item(i) => i,
        _ => u32::MAX,
    }
}

/// A treatment's time and amounts in words (for messages).
fn values_of(item: Option<&Value>) -> String {
    let Some(item) = item else {
        return "?".into();
    };
    let fields = [
        "created_at",
        "date",
        "insulin",
        "carbs",
        "absolute",
        "rate",
        "percent",
        "duration",
    ];
    let shown: Vec<String> = fields
        .iter()
        .filter_map(|f| item.get(*f).map(|v| format!("{f} {v}")))
        .collect();
    shown.join(", ")
}

/// Error codes and glucose below 39 mg/dL are rare: a file where most
/// `sgv` values are below 39 is more likely glucose in mmol/L (which
/// Nightscout entries must not hold) than a sensor failing or reading a
/// severe low all the time, and is refused. Otherwise the codes dropped
/// and the readings kept below 39 are named in the file's notes.
fn check_error_codes(ctx: &Ctx<'_>, records: &[Record]) -> Result<(), IoError> {
    let codes = records
        .iter()
        .filter(|r| {
            matches!(&r.kind, RecordKind::Ignored { kind } if kind.starts_with("sgv sensor error code"))
        })
        .count();
    let below = |r: &Record| matches!(r.kind, RecordKind::Cgm { glucose } if glucose.mg_dl.0 < SGV_ERROR_BELOW);
    let low = records.iter().filter(|r| below(r)).count();
    let readings = records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Cgm { .. }))
        .count();
    if codes + low > 0 && codes + low >= readings - low {
        return Err(IoError::Units {
            file: ctx.file.to_string(),
            message: format!(
                "{} of {} sgv values are below {SGV_ERROR_BELOW} ({codes} of them Dexcom's error \
                 codes 0-{SGV_CODE_MAX}); so many look like glucose in mmol/L, but Nightscout \
                 entries hold mg/dL (check the uploader's settings)",
                codes + low,
                codes + readings
            ),
        });
    }
    if codes > 0 {
        ctx.note(format!(
            "{codes} sgv values are Dexcom's error codes (0-{SGV_CODE_MAX}: sensor not active, \
             not calibrated, bad radio ...), not glucose: counted, not read as readings"
        ));
    }
    if low > 0 {
        ctx.note(format!(
            "{low} sgv values between {} and {} mg/dL are kept as glucose (Nightscout shows values \
             below {SGV_ERROR_BELOW} as errors, but uploaders that read the sensor themselves, \
             such as iAPS and xDrip+, store the bottom of a low there)",
            SGV_CODE_MAX + 1.0,
            SGV_ERROR_BELOW - 1.0
        ));
    }
    Ok(())
}

/// The item's instant: `date` / `mills` (ms since the epoch), else
/// `dateString` / `created_at` / `startDate` / `timestamp` (ISO 8601); a
/// profile document's is its `startDate` when it has one.
fn instant(item: &Item<'_>) -> Result<jiff::Timestamp, IoError> {
    // A profile (or Profile Switch) dated at the epoch is Nightscout's
    // default record: in force since always.
    let profile = item.get("store").is_some()
        || item.str("eventType").ok().flatten() == Some("Profile Switch");
    if profile {
        let epoch_ms = ["mills", "date"]
            .iter()
            .any(|f| item.num(f).ok().flatten() == Some(0.0));
        let epoch_text = ["startDate", "created_at", "dateString"].iter().any(|f| {
            item.str(f)
                .ok()
                .flatten()
                .and_then(parse_instant)
                .is_some_and(|t| t == jiff::Timestamp::UNIX_EPOCH)
        });
        if epoch_ms || epoch_text {
            return Ok(crate::record::SINCE_ALWAYS);
        }
        // A profile document is in force from its `startDate` (Nightscout
        // derives `mills` from it); `created_at` is when it was uploaded,
        // often months later (openaps' test profile: in force from
        // 2015-08-17, uploaded 2015-11-08).
        if item.get("store").is_some() {
            if let Some(t) = item.str("startDate").ok().flatten().and_then(parse_instant) {
                return Ok(t);
            }
        }
    }
    for field in ["date", "mills", "created_at", "dateString"] {
        // MongoDB extended JSON: {"$date": "2024-05-01T10:00:00Z"},
        // {"$date": 1714557600000} or {"$date": {"$numberLong": "..."}}.
        if let Some(Value::Object(o)) = item.get(field) {
            let Some(d) = o.get("$date") else {
                return Err(item.err(field, "expected a time, got an object without $date"));
            };
            let ms = match d {
                Value::String(s) => match parse_instant(s) {
                    Some(t) => return Ok(t),
                    None => s.parse::<f64>().ok(),
                },
                Value::Number(n) => n.as_f64(),
                Value::Object(l) => l
                    .get("$numberLong")
                    .and_then(Value::as_str)
                    .and_then(|s| s.parse::<f64>().ok()),
                _ => None,
            };
            return match ms {
                Some(ms) if ms.abs() >= MS_SINCE_1973 => {
                    jiff::Timestamp::from_millisecond(ms as i64)
                        .map_err(|e| item.err(field, format!("{ms} is not a time: {e}")))
                }
                _ => Err(item.err(
                    field,
                    format!(
                        "expected {{\"$date\": ISO 8601 time or milliseconds since 1970}}, got {d}"
                    ),
                )),
            };
        }
    }
    for field in ["date", "mills"] {
        if let Some(Value::Number(_)) = item.get(field) {
            let ms = item.need_num(field, "milliseconds since 1970")?;
            if ms.abs() < MS_SINCE_1973 {
                return Err(item.err(
                    field,
                    format!(
                        "{ms} is before 1973 as milliseconds since 1970; it looks like seconds \
                         (Nightscout's {field} is in milliseconds)"
                    ),
                ));
            }
            return jiff::Timestamp::from_millisecond(ms as i64)
                .map_err(|e| item.err(field, format!("{ms} is not a time: {e}")));
        }
    }
    for field in [
        "dateString",
        "created_at",
        "startDate",
        "timestamp",
        "sysTime",
    ] {
        if let Some(text) = item.get(field) {
            if let Value::Number(n) = text {
                let ms = n.as_f64().unwrap_or(f64::NAN);
                if ms.is_nan() || ms.abs() < MS_SINCE_1973 {
                    return Err(item.err(
                        field,
                        format!(
                            "{ms} is before 1973 as milliseconds since 1970; it looks like \
                             seconds (a number in {field} is read as milliseconds, as \
                             Nightscout's date)"
                        ),
                    ));
                }
                return jiff::Timestamp::from_millisecond(ms as i64)
                    .map_err(|e| item.err(field, format!("{ms} is not a time: {e}")));
            }
            let s = item.str(field)?.unwrap_or("");
            return parse_instant(s).ok_or_else(|| {
                item.err(
                    field,
                    format!("expected an ISO 8601 time with offset or Z, got \"{s}\""),
                )
            });
        }
    }
    Err(item.err(
        "date",
        "missing: every record needs date, dateString, created_at or startDate",
    ))
}

/// The offset from UTC the uploader's device was at when it wrote the
/// item (seconds east; [`crate::clocks`]): its `utcOffset` (minutes,
/// xDrip+, AndroidAPS, Loop) when not 0, else the offset of its
/// `dateString` or `created_at` when that is not UTC. A `utcOffset` of 0
/// says nothing of the device's zone: Nightscout's API v1 writes it from
/// the offset the uploader's own time string carries
/// (`moment.parseZone(...).utcOffset()` of an entry's `dateString` in
/// `lib/server/entries.js`, of a treatment's `created_at` in
/// `lib/server/treatments.js` `prepareData`), so every time written in UTC
/// (Careportal's `toISOString()`, Loop's, iAPS's and the Dexcom bridge's
/// `Z` times) is stored with 0, whatever zone the person was in. A
/// profile document says nothing of where the person was (its zone is
/// its `timezone`): none.
fn device_offset(item: &Item<'_>) -> Option<i32> {
    if item.get("store").is_some() {
        return None;
    }
    if let Some(m) = item.num("utcOffset").ok().flatten() {
        if m != 0.0 {
            return crate::clocks::minutes_offset_s(m);
        }
    }
    ["dateString", "created_at"].iter().find_map(|f| {
        item.str(f)
            .ok()
            .flatten()
            .and_then(crate::clocks::text_offset_s)
    })
}

/// 10^11 ms is March 1973, decades before Nightscout: a smaller `date` is
/// seconds, not milliseconds.
const MS_SINCE_1973: f64 = 1e11;

/// Nightscout's `sgv` values below this are shown by Nightscout as "?"
/// (its error display), but only the whole numbers up to
/// [`SGV_CODE_MAX`] are codes: uploaders that read a sensor themselves
/// (iAPS, xDrip+) store real glucose between 13 and 38 mg/dL, the bottom
/// of a severe hypoglycaemia, which must reach the advisor.
pub const SGV_ERROR_BELOW: f64 = 39.0;

/// The largest of Dexcom's special values, which receivers and uploaders
/// write as `sgv` for an error state (1 sensor not active, 2 minimal
/// deviation, 3 no antenna, 5 not calibrated, 6 counts deviation, 9
/// absolute deviation, 10 power deviation, 12 bad RF; Nightscout's
/// error-code table): not glucose.
pub const SGV_CODE_MAX: f64 = 12.0;

fn entry(item: &Item<'_>) -> Result<RecordKind, IoError> {
    let kind = item.str("type")?.unwrap_or(if item.get("sgv").is_some() {
        "sgv"
    } else if item.get("mbg").is_some() {
        "mbg"
    } else {
        ""
    });
    let reading = |field: &str| -> Result<Glucose, IoError> {
        let v = item.need_num(field, "glucose in mg/dL")?;
        let mg = units::glucose_mg_dl(&item.at(field), field, v, GlucoseUnit::MgDl)
            .map_err(|_| item.err(field, format!("glucose {v} mg/dL is outside the plausible range {}..{} mg/dL (Nightscout stores entries in mg/dL)", units::GLUCOSE_MIN_MG_DL, units::GLUCOSE_MAX_MG_DL)))?;
        Ok(Glucose {
            mg_dl: MgDl(mg),
            censor: Censor::Exact,
        })
    };
    Ok(match kind {
        // Dexcom receivers and uploaders write their error states as sgv
        // values 0..=12 (SGV_CODE_MAX): not glucose, counted by code.
        "sgv"
            if item
                .num("sgv")?
                .is_some_and(|v| (0.0..=SGV_CODE_MAX).contains(&v) && v.fract() == 0.0) =>
        {
            RecordKind::Ignored {
                kind: format!(
                    "sgv sensor error code {}",
                    item.num("sgv")?.unwrap_or(f64::NAN)
                ),
            }
        }
        "sgv" => RecordKind::Cgm {
            glucose: reading("sgv")?,
        },
        "mbg" => RecordKind::Smbg {
            glucose: reading("mbg")?,
        },
        "cal" => RecordKind::Ignored {
            kind: "calibration".into(),
        },
        "" => return Err(item.err(
            "type",
            "missing: an entry needs type (sgv, mbg, cal) or is it a treatment without eventType?",
        )),
        other => RecordKind::Ignored {
            kind: format!("entry {other}"),
        },
    })
}

/// A treatment's duration in minutes: `durationInMilliseconds` to the
/// nearest minute when given, else `duration` (minutes). AndroidAPS
/// writes both and its `duration` is the milliseconds cut down to whole
/// minutes (`T.msecs(duration).mins()`, "rounded duration leads to
/// different basal IOB": `plugins/sync/.../nsclient/extensions/
/// TemporaryBasalExtension.kt`); AndroidAPS reads the milliseconds first
/// (`temporaryBasalFromJson`), so does abba.
fn duration(item: &Item<'_>) -> Result<Option<u32>, IoError> {
    match item.num("durationInMilliseconds")? {
        None => minutes(item, "duration"),
        Some(ms) => Ok(Some(
            check_range(
                &item.at("durationInMilliseconds"),
                "durationInMilliseconds",
                ms / 60_000.0,
                0.0,
                units::DURATION_MAX_MIN,
                "duration (min, from milliseconds)",
            )?
            .round() as u32,
        )),
    }
}

fn minutes(item: &Item<'_>, field: &str) -> Result<Option<u32>, IoError> {
    match item.num(field)? {
        None => Ok(None),
        Some(d) => Ok(Some(
            check_range(
                &item.at(field),
                field,
                d,
                0.0,
                units::DURATION_MAX_MIN,
                "duration (min)",
            )?
            .round() as u32,
        )),
    }
}

/// What the reader read in Nightscout's own way and reports in the file's
/// notes: the JSON item of each (the first is named).
#[derive(Default)]
struct Tally {
    /// Temp Basals of duration 0 with no rate: ends of the running one.
    temp_basal_ends: Vec<usize>,
    /// Temp Basals with a duration and no rate: the scheduled rate.
    temp_basal_scheduled: Vec<usize>,
    /// Treatments without an eventType that carried insulin or carbs.
    untyped: Vec<usize>,
    /// Profile Switches that only name their profile, applied from the
    /// profile store: (item, instant, name, the store's place).
    named: Vec<(usize, jiff::Timestamp, String, String)>,
    /// Profile Switches naming a profile the store in force does not hold.
    unknown_names: Vec<UnknownName>,
}

/// A Profile Switch naming a profile the profile store in force at it
/// does not hold.
struct UnknownName {
    item: usize,
    at: jiff::Timestamp,
    name: String,
    store: String,
    store_at: jiff::Timestamp,
    held: Vec<String>,
}

impl Tally {
    /// The file's notes on what was read so, and on the Profile Switches
    /// to the pump's auto mode among `out` ([`AUTO_MODE_SWITCH`]).
    fn note(&self, ctx: &Ctx<'_>, out: &[Record]) {
        let first = |v: &[usize]| format!("the first at $[{}]", v[0]);
        if !self.temp_basal_ends.is_empty() {
            ctx.note(format!(
                "{} Temp Basals of duration 0 with no absolute, rate or percent ({}; \
                 600SeriesAndroidUploader writes \"Pump resumed insulin delivery\" so): \
                 Nightscout reads a Temp Basal without a duration as the end of the temporary \
                 basal running then; read so (a temporary basal of 0 min, which cancels the \
                 running one)",
                self.temp_basal_ends.len(),
                first(&self.temp_basal_ends)
            ));
        }
        if !self.temp_basal_scheduled.is_empty() {
            ctx.note(format!(
                "{} Temp Basals with a duration and no absolute, rate or percent ({}): \
                 Nightscout's API v1 drops a percent of 0 (100 % of the scheduled rate) when \
                 it stores a treatment, and Nightscout reads a Temp Basal without a rate as \
                 the scheduled rate; read as 100 % of the scheduled rate for their duration",
                self.temp_basal_scheduled.len(),
                first(&self.temp_basal_scheduled)
            ));
        }
        if !self.untyped.is_empty() {
            ctx.note(format!(
                "{} treatments without an eventType (\"\", \"<none>\", \"<None>\" or none at all) carry \
                 insulin or carbs ({}): read as boluses and carbohydrate, as Nightscout counts \
                 any treatment's insulin and carbs in its IOB and COB",
                self.untyped.len(),
                first(&self.untyped)
            ));
        }
        let named: Vec<&Record> = out
            .iter()
            .filter(
                |r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == NOT_EMBEDDED_SWITCH),
            )
            .collect();
        if let Some(f) = named.iter().min_by_key(|r| r.at) {
            let at = match f.origin.at {
                crate::record::OriginAt::Item(i) => format!("$[{i}]"),
                _ => "?".into(),
            };
            if ctx.stores.is_empty() {
                ctx.note(format!(
                    "{} Profile Switches name a profile without embedding it (no profileJson, as \
                     Nightscout's Careportal writes them; the first at {} ({at})): the settings \
                     they switch to are not in the treatment, and the files imported with it hold \
                     no Nightscout profile store (profile.json) to look the name up in, so they \
                     are not applied; the therapy in force follows the profile documents and the \
                     switches that embed their profile. Import profile.json with the treatments \
                     to apply them",
                    named.len(),
                    f.at
                ));
            } else {
                ctx.note(format!(
                    "{} Profile Switches neither embed a profile (no profileJson) nor name one \
                     (no profile; the first at {} ({at})): the settings they switch to are not \
                     known, so they are not applied; the therapy in force stays the one before \
                     them",
                    named.len(),
                    f.at
                ));
            }
        }
        if let Some((item, at, name, store)) = self.named.iter().min_by_key(|n| (n.1, n.0)) {
            let names: std::collections::BTreeSet<&str> =
                self.named.iter().map(|n| n.2.as_str()).collect();
            let names: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
            ctx.note(format!(
                "{} Profile Switches name a profile of the Nightscout profile store without \
                 embedding it (no profileJson, as Careportal writes them; {}; the first at {at} \
                 ($[{item}]), \"{name}\" from {store}): applied as Nightscout applies them, each \
                 the profile of that name in the profile document in force at the switch (its \
                 basal schedule in U/h and carb ratios in g/U, at the switch's percentage and \
                 timeshift when it has them), for its duration or until the next switch",
                self.named.len(),
                names.join(", ")
            ));
        }
        for u in &self.unknown_names {
            ctx.note(format!(
                "the Profile Switch of {} ($[{}]) names the profile \"{}\", which the profile \
                 store in force then ({}, from {}) does not hold (it holds {}): not applied (the \
                 settings it switched to are not known; Nightscout shows the default profile \
                 then); the therapy in force stays the one before it",
                u.at,
                u.item,
                u.name,
                u.store,
                u.store_at,
                if u.held.is_empty() {
                    "no profile".to_string()
                } else {
                    u.held
                        .iter()
                        .map(|n| format!("\"{n}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            ));
        }
        let auto: Vec<&Record> = out
            .iter()
            .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == AUTO_MODE_SWITCH))
            .collect();
        if let (Some(a), Some(b)) = (
            auto.iter().min_by_key(|r| r.at),
            auto.iter().max_by_key(|r| r.at),
        ) {
            let items: Vec<String> = auto
                .iter()
                .take(5)
                .map(|r| match r.origin.at {
                    crate::record::OriginAt::Item(i) => format!("$[{i}]"),
                    _ => "?".into(),
                })
                .collect();
            let more = if auto.len() > 5 { ", ..." } else { "" };
            ctx.note(format!(
                "{} Profile Switches put the pump in its auto mode, from {} to {} ({}{more}): \
                 a profile named \"Auto Mode\" or with a placeholder basal below \
                 {AUTO_MODE_PLACEHOLDER_U_PER_H} U/h, which no pump delivers (the MiniMed \
                 670G's SmartGuard auto mode, as its uploader writes it); in auto mode the pump \
                 delivers a basal of its own, which the file does not hold: a closed loop, not \
                 a therapy, so these are not read as basal schedules (no basal rate from them \
                 reaches the advisor) and abba gives a closed loop no basal advice; the manual \
                 profile before them stays the schedule the records follow",
                auto.len(),
                a.at,
                b.at,
                items.join(", ")
            ));
        }
    }
}

/// The kind a bolus of type PRIMING (AndroidAPS) is counted under.
pub const PRIME: &str = "prime (a bolus of type PRIMING: tubing or cannula filled, not a dose)";

/// The kind a Site Change carrying insulin is counted under.
pub const SITE_CHANGE_PRIME: &str =
    "Site Change with insulin (the prime or cannula fill, not a dose)";

/// The kind a Profile Switch that names its profile without embedding it
/// (no `profileJson`: Nightscout's Careportal, OpenAPS) is counted under.
const NOT_EMBEDDED_SWITCH: &str = "Profile Switch (profile not embedded)";

/// The kind a Profile Switch naming a profile the profile store in force
/// does not hold is counted under ([`named_switch`]).
const NAME_NOT_IN_STORE: &str =
    "Profile Switch to a profile the profile store does not hold (not applied)";

/// The kind a Profile Switch to the pump's auto mode is counted under
/// ([`is_auto_mode_switch`]).
pub const AUTO_MODE_SWITCH: &str =
    "Profile Switch to the pump's auto mode (a closed loop, not a therapy)";

/// A basal rate below this (U/h) in every segment of a profile is a
/// placeholder: pumps deliver 0.01-0.05 U/h at the least (abba's limit is
/// 0.025 U/h).
pub const AUTO_MODE_PLACEHOLDER_U_PER_H: f64 = 0.001;

/// Whether a Nightscout document is a Profile Switch to a pump's automatic
/// mode rather than a therapy: the MiniMed 670G's SmartGuard auto mode,
/// as 600SeriesAndroidUploader writes it (`profile` "Auto Mode", notes
/// "Auto Mode: active") and AndroidAPS's NSClient uploads it again with a
/// `profileJson` whose only basal is 0.000001 U/h. Either mark is enough:
/// a profile named "Auto Mode" with no embedded profile or with every
/// basal rate below abba's smallest (0.025 U/h), or any profile whose
/// every basal rate is above 0 and below [`AUTO_MODE_PLACEHOLDER_U_PER_H`].
/// A profile named "Auto Mode" with real rates is read as a profile.
pub fn is_auto_mode_switch(obj: &serde_json::Map<String, Value>) -> bool {
    if obj.get("eventType").and_then(Value::as_str) != Some("Profile Switch") {
        return false;
    }
    let named = ["profile", "originalProfileName"].iter().any(|f| {
        obj.get(*f)
            .and_then(Value::as_str)
            .is_some_and(|n| n.trim().eq_ignore_ascii_case("auto mode"))
    });
    let rates = obj
        .get("profileJson")
        .and_then(Value::as_str)
        .and_then(|t| serde_json::from_str::<Value>(t).ok())
        .and_then(|p| match p.get("basal") {
            Some(Value::Array(rows)) if !rows.is_empty() => rows
                .iter()
                .map(|r| match r.get("value") {
                    Some(Value::Number(n)) => n.as_f64(),
                    Some(Value::String(s)) => s.trim().parse::<f64>().ok(),
                    _ => None,
                })
                .collect::<Option<Vec<f64>>>(),
            _ => None,
        });
    let below = |max: f64| {
        rates
            .as_ref()
            .is_some_and(|r| r.iter().all(|&v| v > 0.0 && v < max))
    };
    let embedded = obj.get("profileJson").is_some_and(|v| !v.is_null());
    below(AUTO_MODE_PLACEHOLDER_U_PER_H)
        || (named && (!embedded || below(abba_core::limits::BASAL_U_PER_H.min)))
}

/// A document without `eventType` that is a treatment, not an entry: no
/// entry's `type`, `sgv` or `mbg`, and `insulin` or `carbs`.
fn untyped_treatment(item: &Item<'_>) -> bool {
    ["type", "sgv", "mbg"].iter().all(|f| item.get(f).is_none())
        && ["insulin", "carbs"].iter().any(|f| item.get(f).is_some())
}

fn treatment(
    ctx: &Ctx<'_>,
    item: &Item<'_>,
    at: jiff::Timestamp,
    event: &str,
    tally: &mut Tally,
) -> Result<Vec<RecordKind>, IoError> {
    let mut kinds = Vec::new();
    // Careportal's own default event type, and xDrip+'s, is "<none>"
    // (Nightscout's `lib/plugins/careportal.js`; xDrip+'s `Treatments`);
    // AndroidAPS's NSClient writes "<None>".
    let event = if event.eq_ignore_ascii_case("<none>") {
        ""
    } else {
        event
    };
    match event {
        // AndroidAPS's bolus of type PRIMING (`BS.Type`, written as a Meal
        // Bolus by `nsclient/extensions/BolusExtension.kt`): the tubing or
        // cannula filled, no insulin into the body; AndroidAPS leaves it
        // out of insulin on board. Its carbs, if any, are read.
        _ if item
            .str("type")?
            .is_some_and(|t| t.eq_ignore_ascii_case("PRIMING"))
            && item.get("insulin").is_some() =>
        {
            kinds.extend(carbs(item)?);
            kinds.push(RecordKind::Ignored { kind: PRIME.into() });
        }
        // Careportal's Site Change offers an insulin field (the prime or
        // cannula fill, `lib/plugins/careportal.js`): not a dose.
        "Site Change" if item.get("insulin").is_some_and(|v| !v.is_null()) => {
            kinds.push(RecordKind::Ignored {
                kind: SITE_CHANGE_PRIME.into(),
            })
        }
        // Loop writes a bolus delivered over 30 min or more as a Correction
        // Bolus of `type` "square" with its `duration` in minutes
        // (LoopKit's NightscoutService `DoseEntry.swift`, NightscoutKit's
        // `BolusNightscoutTreatment`): the insulin runs over the duration,
        // an extended bolus with nothing given at once.
        "Correction Bolus" if item.str("type")? == Some("square") => {
            match (insulin(item)?, duration(item)?) {
                (Some(RecordKind::Bolus { units }), Some(d)) if d > 0 => {
                    kinds.push(RecordKind::ExtendedBolus {
                        now: Units(0.0),
                        extended: units,
                        duration_min: d,
                    })
                }
                (dose, _) => kinds.extend(dose),
            }
        }
        // Trio and iAPS write insulin given outside the pump (a pen) as
        // "External Insulin" (`PumpEventStored.EventType.isExternal`),
        // counted in their insulin on board like a bolus.
        "Meal Bolus" | "Snack Bolus" | "Bolus Wizard" | "Correction Bolus" | "SMB" | "Bolus"
        | "External Insulin" | "Carb Correction" | "Carbs" => {
            kinds.extend(carbs(item)?);
            kinds.extend(insulin_doses(item)?);
        }
        // No eventType (empty, missing, "<none>" or "<None>"): Nightscout's
        // IOB and COB count any treatment's `insulin` and `carbs`
        // (`lib/plugins/iob.js`, `cob.js`), so abba reads them, checked as
        // any bolus and carbohydrate; a dose of 0 is none.
        "" => {
            kinds.extend(carbs(item)?);
            kinds.extend(
                insulin_doses(item)?
                    .into_iter()
                    .filter(|k| !matches!(k, RecordKind::Bolus { units } if units.0 == 0.0)),
            );
            if kinds.is_empty() {
                kinds.push(RecordKind::Ignored {
                    kind: "treatment without eventType, insulin or carbs".into(),
                });
            } else {
                tally.untyped.push(item.index);
            }
        }
        "Combo Bolus" => {
            kinds.extend(carbs(item)?);
            kinds.push(combo_bolus(item)?);
        }
        // Careportal's menu names "Temp Basal Start" and "Temp Basal End"
        // (its form stores both as "Temp Basal"; other tools post them as
        // named, and Nightscout reads any event type holding "Temp Basal"
        // as one, `lib/data/ddata.js`).
        "Temp Basal" | "Temp Basal Start" | "Temp Basal End" => {
            kinds.push(temp_basal(item, tally)?)
        }
        "Suspend Pump" | "Pump Suspend" => kinds.push(RecordKind::Suspend {
            duration_min: duration(item)?,
        }),
        "Resume Pump" | "Pump Resume" => kinds.push(RecordKind::Resume),
        // Trio writes the pump's suspensions and resumes from its history
        // as Notes whose `notes` is the event's name ("PumpSuspend",
        // "PumpResume": `PumpHistoryStorage.swift`,
        // `getPumpHistoryNotYetUploadedToNightscout`).
        "Note" if item.str("notes")?.map(str::trim) == Some("PumpSuspend") => {
            kinds.push(RecordKind::Suspend { duration_min: None })
        }
        "Note" if item.str("notes")?.map(str::trim) == Some("PumpResume") => {
            kinds.push(RecordKind::Resume)
        }
        "Profile Switch" if is_auto_mode_switch(item.obj) => kinds.push(RecordKind::Ignored {
            kind: AUTO_MODE_SWITCH.into(),
        }),
        "Profile Switch" => kinds.push(profile_switch(ctx, item, at, tally)?),
        "BG Check" if item.get("glucose").is_some() => kinds.push(bg_check(ctx, item)?),
        other => kinds.push(RecordKind::Ignored {
            kind: other.to_string(),
        }),
    }
    if kinds.is_empty() {
        kinds.push(RecordKind::Ignored {
            kind: format!("{event} without insulin or carbs"),
        });
    }
    Ok(kinds)
}

/// `field`'s value `v` checked against `0..=max`, naming the field.
fn in_range(item: &Item<'_>, field: &str, v: f64, max: f64, what: &str) -> Result<f64, IoError> {
    check_range(&item.at(field), field, v, 0.0, max, what)
}

/// A treatment's `insulin` as a bolus, if it has one.
fn insulin(item: &Item<'_>) -> Result<Option<RecordKind>, IoError> {
    Ok(match item.num("insulin")? {
        Some(u) => Some(RecordKind::Bolus {
            units: Units(in_range(
                item,
                "insulin",
                u,
                units::BOLUS_MAX_U,
                "insulin (U)",
            )?),
        }),
        None => None,
    })
}

/// Insulins that act for a day or longer (basal insulin injected with a
/// pen), by name: xDrip+'s profiles whose action lasts over 1000 minutes
/// (its `isBasal`, `res/raw/insulin_profiles.json`: Insulatard, Toujeo,
/// Lantus, Levemir, Basaglar, Tresiba) and their generic and other brand
/// names.
const LONG_ACTING_INSULINS: [&str; 19] = [
    "insulatard",
    "toujeo",
    "lantus",
    "levemir",
    "basaglar",
    "tresiba",
    "abasaglar",
    "semglee",
    "rezvoglar",
    "glargine",
    "detemir",
    "degludec",
    "icodec",
    "awiqli",
    "nph",
    "humulin n",
    "novolin n",
    "protaphane",
    "insuman basal",
];

/// Rapid- and short-acting insulins (bolus insulin), by name: xDrip+'s
/// other profiles (FIASP, Afrezza, Apidra, Novorapid, Humalog, Lispro,
/// Actrapid) and their generic and other brand names.
const RAPID_ACTING_INSULINS: [&str; 16] = [
    "fiasp",
    "afrezza",
    "apidra",
    "novorapid",
    "humalog",
    "lispro",
    "actrapid",
    "novolog",
    "lyumjev",
    "admelog",
    "aspart",
    "glulisine",
    "humulin r",
    "novolin r",
    "insuman rapid",
    "regular",
];

/// A treatment's insulin: its `insulin` as one bolus, or, when xDrip+'s
/// multiple insulins name each injection (`insulinInjections`, a JSON list
/// `[{"insulin": NAME, "units": U}]`, in a string as xDrip+ uploads it),
/// each injection by its insulin: a long-acting one is basal insulin from
/// a pen, not a bolus (xDrip+'s `insulin` is the sum of all). An insulin
/// whose acting type is not known is left out and counted.
fn insulin_doses(item: &Item<'_>) -> Result<Vec<RecordKind>, IoError> {
    const FIELD: &str = "insulinInjections";
    let list = match item.get(FIELD) {
        None | Some(Value::Null) => return Ok(insulin(item)?.into_iter().collect()),
        Some(Value::String(s)) if s.trim().is_empty() => {
            return Ok(insulin(item)?.into_iter().collect())
        }
        Some(Value::String(s)) => serde_json::from_str::<Value>(s)
            .map_err(|e| item.err(FIELD, format!("expected a JSON list of injections: {e}")))?,
        Some(v) => v.clone(),
    };
    let Value::Array(list) = list else {
        return Err(item.err(FIELD, "expected a list of {insulin, units}"));
    };
    if list.is_empty() {
        return Ok(insulin(item)?.into_iter().collect());
    }
    let mut out = Vec::new();
    let mut sum = 0.0;
    for (i, inj) in list.iter().enumerate() {
        let field = format!("{FIELD}[{i}]");
        let name = inj
            .get("insulin")
            .and_then(Value::as_str)
            .ok_or_else(|| item.err(&format!("{field}.insulin"), "expected the insulin's name"))?;
        let u = inj.get("units").and_then(Value::as_f64).ok_or_else(|| {
            item.err(&format!("{field}.units"), "expected the dose (U), a number")
        })?;
        let units = Units(in_range(
            item,
            &format!("{field}.units"),
            u,
            units::BOLUS_MAX_U,
            "insulin (U)",
        )?);
        sum += u;
        let key = name.trim().to_lowercase();
        // The name, a brand followed by more ("Lantus U100"), or one of its
        // words ("Insulin glargine").
        let known = |names: &[&str]| {
            names.iter().any(|n| {
                key == *n
                    || key.starts_with(&format!("{n} "))
                    || (!n.contains(' ')
                        && key.split(|c: char| !c.is_alphanumeric()).any(|w| w == *n))
            })
        };
        out.push(if known(&LONG_ACTING_INSULINS) {
            RecordKind::LongActing { units }
        } else if known(&RAPID_ACTING_INSULINS) {
            RecordKind::Bolus { units }
        } else {
            RecordKind::Ignored {
                kind: format!("insulin injection of {name} (acting type not known)"),
            }
        });
    }
    // xDrip+'s `insulin` is the injections' sum: another total cannot be
    // told apart from an injection missing from the list.
    if let Some(total) = item.num("insulin")? {
        if (total - sum).abs() > 0.01 {
            return Err(item.err(
                "insulin",
                format!(
                    "{total} U, but its insulinInjections sum to {sum} U (which dose was given?)"
                ),
            ));
        }
    }
    Ok(out)
}

/// A treatment's `carbs`, if above zero.
fn carbs(item: &Item<'_>) -> Result<Option<RecordKind>, IoError> {
    Ok(match item.num("carbs")? {
        Some(g) if g > 0.0 => Some(RecordKind::Carbs {
            grams: Grams(in_range(
                item,
                "carbs",
                g,
                units::CARBS_MAX_G,
                "carbohydrate (g)",
            )?),
        }),
        _ => None,
    })
}

/// A Combo Bolus: Careportal's `enteredinsulin` is the total, `insulin`
/// the part given now, `relative` the extended part's rate (U/h).
fn combo_bolus(item: &Item<'_>) -> Result<RecordKind, IoError> {
    let now = item.num("insulin")?.unwrap_or(0.0);
    let duration = duration(item)?.unwrap_or(0);
    let ext = match (item.num("enteredinsulin")?, item.num("relative")?) {
        (Some(total), _) => (total - now).max(0.0),
        (None, Some(rate)) => rate * f64::from(duration) / 60.0,
        (None, None) => 0.0,
    };
    Ok(RecordKind::ExtendedBolus {
        now: Units(in_range(
            item,
            "insulin",
            now,
            units::BOLUS_MAX_U,
            "insulin (U)",
        )?),
        extended: Units(in_range(
            item,
            "enteredinsulin",
            ext,
            units::BOLUS_MAX_U,
            "insulin (U)",
        )?),
        duration_min: duration,
    })
}

/// A Temp Basal, read as Nightscout itself and AndroidAPS read it
/// (`getTempBasal` in cgm-remote-monitor's `lib/profilefunctions.js`,
/// `temporaryBasalFromJson` in AndroidAPS's `plugins/sync/.../nsclient/
/// extensions/TemporaryBasalExtension.kt`): `absolute` (U/h) when given,
/// else `percent`, a change (-50 is half the scheduled rate, -100 none).
///
/// `rate` beside them is never read. AndroidAPS writes it for OpenAPS's
/// sake as its own conversion to U/h (`convertedToAbsolute`: its profile's
/// rate at the start times the percentage, `toNSTemporaryBasal` in
/// `nsclientV3/extensions/TemporaryBasalExtension.kt`), which abba cannot
/// check; and its 3.0 development builds of April-December 2021 wrote the
/// percentage itself there (commits 2463f8fc47 to 682628e845). So a
/// percent temp basal is never read as U/h. `rate` alone (Nightscout's API
/// v1 drops a `percent` of 0, `deleteIfEmpty` in `lib/server/treatments.js`,
/// leaving AndroidAPS's `rate`) is U/h up to any basal rate and counted
/// above it, as a percentage it may be.
///
/// AndroidAPS's `type`: `PUMP_SUSPEND` (suspended on the pump) and
/// `EMULATED_PUMP_SUSPEND` (AndroidAPS's own zero temp basal for a
/// suspension, `LoopPlugin.kt`; `PumpSync.TemporaryBasalType`) are a
/// suspension for the duration; `SUPERBOLUS` and `NORMAL` are temp basals.
/// `FAKE_EXTENDED` with `extendedEmulated` is an extended bolus AndroidAPS
/// ran in place of a high temp basal (`EB.toTemporaryBasal`: `absolute` =
/// the scheduled rate + the extended bolus's rate): read as that temp
/// basal, and the Combo Bolus nested in `extendedEmulated` is the same
/// insulin, not read again (AndroidAPS uploads that extended bolus only
/// this way, `toNSExtendedBolus` in `nsclientV3/extensions/
/// ExtendedBolusExtension.kt`).
///
/// Without `absolute`, `rate` or `percent`, Nightscout reads a Temp Basal
/// as the scheduled rate (`getTempBasal`), and one without a duration as
/// the end of the temporary basal running then (`processDurations` in
/// `lib/data/ddata.js` cuts every temp basal at a treatment whose
/// `duration` is 0 or missing). Such records are real: 600SeriesAndroid
/// Uploader (MiniMed 600 series) writes the pump's resume as a Temp Basal
/// of duration 0 with only notes ("Pump resumed insulin delivery: ..."),
/// and Nightscout's API v1 drops a `percent` of 0 (`deleteIfEmpty` in
/// `lib/server/treatments.js`), so its "Temp Basal: 100%" keeps only its
/// duration. abba reads them as Nightscout does: the end (a temporary
/// basal of 0 min, the advisor's cancel), or 100 % of the scheduled rate
/// for the duration; both counted in the file's notes.
fn temp_basal(item: &Item<'_>, tally: &mut Tally) -> Result<RecordKind, IoError> {
    let duration = duration(item)?.unwrap_or(0);
    let absolute = |field: &str, r: f64| {
        in_range(item, field, r, units::BASAL_MAX_U_PER_H, "basal rate (U/h)")
            .map(|r| TempRate::Absolute(UnitsPerHour(r)))
    };
    let (abs, percent, rate) = (
        item.num("absolute")?,
        item.num("percent")?,
        item.num("rate")?,
    );
    if let Some(t @ ("PUMP_SUSPEND" | "EMULATED_PUMP_SUSPEND")) = item.str("type")? {
        let zero = match (abs, percent, rate) {
            (Some(a), _, _) => a == 0.0,
            (None, Some(p), _) => p == -100.0,
            (None, None, r) => r == Some(0.0),
        };
        return Ok(if zero {
            RecordKind::Suspend {
                duration_min: Some(duration),
            }
        } else {
            RecordKind::Ignored {
                kind: format!("Temp Basal of type {t} with a rate above zero"),
            }
        });
    }
    let rate = match (abs, percent, rate) {
        (Some(r), _, _) => absolute("absolute", r)?,
        (None, Some(p), _) => TempRate::Percent(in_range(
            item,
            "percent",
            100.0 + p,
            units::PERCENT_MAX,
            "percentage of the scheduled rate",
        )?),
        (None, None, Some(r)) if r > units::BASAL_MAX_U_PER_H => {
            return Ok(RecordKind::Ignored {
                kind: "Temp Basal with only a rate above any basal rate (U/h or a percentage?)"
                    .into(),
            })
        }
        (None, None, Some(r)) => absolute("rate", r)?,
        (None, None, None) => {
            if duration == 0 {
                tally.temp_basal_ends.push(item.index);
            } else {
                tally.temp_basal_scheduled.push(item.index);
            }
            TempRate::Percent(100.0)
        }
    };
    Ok(RecordKind::TempBasal {
        rate,
        duration_min: duration,
    })
}

/// A Profile Switch with its profile embedded (`profileJson`), as
/// AndroidAPS runs it: `profileJson` is the profile as chosen, before the
/// switch's `percentage` and `timeshift` (AndroidAPS resets both before
/// writing it: `PS.toJson` in `plugins/sync/.../nsclient/extensions/
/// ProfileSwitchExtension.kt`, `toNSProfileSwitch` in `nsclientV3/
/// extensions/`), so both are applied here as AndroidAPS applies them
/// (`ProfileSealed.kt`, `BlockExtension.kt`): basal rates times p/100,
/// carb ratios (and ISF, which abba does not read) divided by p/100; the
/// value at a local time t is the profile's at t − timeshift. Whether the
/// switch is temporary is settled over the whole file
/// ([`temporary_switches`]).
///
/// A Profile Switch that only names its profile (`profile`, no
/// `profileJson`: Nightscout's Careportal) runs that profile of the
/// Nightscout profile store in force at the switch ([`named_switch`]).
fn profile_switch(
    ctx: &Ctx<'_>,
    item: &Item<'_>,
    at: jiff::Timestamp,
    tally: &mut Tally,
) -> Result<RecordKind, IoError> {
    let Some(text) = item.str("profileJson")? else {
        return named_switch(ctx, item, at, tally);
    };
    let v: Value = serde_json::from_str(text)
        .map_err(|e| item.err("profileJson", format!("not valid JSON: {e}")))?;
    let Value::Object(obj) = v else {
        return Err(item.err("profileJson", "expected an object"));
    };
    let inner = Item::json(item.file, item.index, &obj);
    switch_applied(item, schedule_of(&inner, "profileJson")?)
}

/// A Profile Switch's profile at its `percentage` and moved by its
/// `timeshift` (see [`profile_switch`]).
fn switch_applied(item: &Item<'_>, profile: RecordKind) -> Result<RecordKind, IoError> {
    let percent = check_range(
        &item.at("percentage"),
        "percentage",
        item.num("percentage")?.unwrap_or(100.0),
        1.0,
        units::PERCENT_MAX,
        "profile percentage",
    )?;
    let shift = timeshift_hours(item)?;
    Ok(shifted(scaled(profile, percent), shift))
}

/// One profile document of Nightscout's profile store (`profile.json`,
/// `/api/v1/profile`): in force from its instant (its `startDate`), its
/// `defaultProfile`, and every named profile of its `store` as read (or
/// why it could not be: only a switch to it needs it).
#[derive(Debug, Clone)]
pub struct ProfileStore {
    /// In force from.
    pub at: jiff::Timestamp,
    /// Its `defaultProfile`.
    pub default: String,
    /// Each named profile of `store`, in the document's order.
    pub profiles: Vec<(String, Result<Profile, String>)>,
    /// Where it was read (`file $[i]`).
    pub place: String,
}

/// A profile document's store ([`ProfileStore`]).
fn store_of(ctx: &Ctx<'_>, item: &Item<'_>, at: jiff::Timestamp) -> ProfileStore {
    let mut profiles = Vec::new();
    if let Some(Value::Object(store)) = item.get("store") {
        for (name, p) in store {
            let read = match p {
                Value::Object(p) => {
                    match schedule_of(
                        &Item::json(item.file, item.index, p),
                        &format!("store.{name}"),
                    ) {
                        Ok(RecordKind::Schedule { profile }) => Ok(*profile),
                        Ok(_) => Err("not a profile".to_string()),
                        Err(e) => Err(e.to_string()),
                    }
                }
                other => Err(format!(
                    "{} $[{}].store.{name}: expected an object, got {}",
                    ctx.file,
                    item.index,
                    super::json::kind(other)
                )),
            };
            profiles.push((name.clone(), read));
        }
    }
    ProfileStore {
        at,
        default: item
            .str("defaultProfile")
            .ok()
            .flatten()
            .unwrap_or("")
            .to_string(),
        profiles,
        place: format!("{} $[{}]", ctx.file, item.index),
    }
}

/// A Profile Switch that names its profile without embedding it
/// (Nightscout's Careportal writes `profile` and `duration` only): as
/// Nightscout reads it (`activeProfileToTime` in cgm-remote-monitor's
/// `lib/profilefunctions.js`), the profile of that name in the profile
/// document in force at the switch (the latest `startDate` at or before
/// it; a switch before every document: the earliest). Its basal schedule
/// and carb ratios are applied, at the switch's `percentage` and moved by
/// its `timeshift` when it has them (as for an embedded profile). Without
/// any profile store in the batch the switch is counted, not read, and the
/// reader asks for the batch's stores ([`Ctx::wants_stores`]); a name the
/// store in force does not hold is counted, not read, and named in a note
/// (Nightscout then keeps the default profile; abba keeps the therapy in
/// force); a named profile that cannot be read leaves the switch out with
/// that error.
fn named_switch(
    ctx: &Ctx<'_>,
    item: &Item<'_>,
    at: jiff::Timestamp,
    tally: &mut Tally,
) -> Result<RecordKind, IoError> {
    let not_embedded = || RecordKind::Ignored {
        kind: NOT_EMBEDDED_SWITCH.into(),
    };
    if ctx.stores.is_empty() {
        ctx.wants_stores.set(true);
        return Ok(not_embedded());
    }
    let Some(name) = item.str("profile")? else {
        return Ok(not_embedded());
    };
    let doc = ctx
        .stores
        .iter()
        .filter(|s| s.at <= at)
        .max_by_key(|s| s.at)
        .or_else(|| ctx.stores.iter().min_by_key(|s| s.at));
    let Some(doc) = doc else {
        return Ok(not_embedded());
    };
    match doc.profiles.iter().find(|(n, _)| n == name) {
        None => {
            tally.unknown_names.push(UnknownName {
                item: item.index,
                at,
                name: name.to_string(),
                store: doc.place.clone(),
                store_at: doc.at,
                held: doc.profiles.iter().map(|(n, _)| n.clone()).collect(),
            });
            Ok(RecordKind::Ignored {
                kind: NAME_NOT_IN_STORE.into(),
            })
        }
        Some((_, Err(why))) => Err(item.err(
            "profile",
            format!(
                "names \"{name}\" of the profile store {} (in force from {}), which could not be \
                 read: {why}",
                doc.place, doc.at
            ),
        )),
        Some((_, Ok(p))) => {
            tally
                .named
                .push((item.index, at, name.to_string(), doc.place.clone()));
            switch_applied(
                item,
                RecordKind::Schedule {
                    profile: Box::new(p.clone()),
                },
            )
        }
    }
}

/// A Profile Switch's `timeshift` in whole hours. AndroidAPS 2.x to 3.1
/// wrote hours (`T.msecs(timeshift).hours()`, commit e48d317d55); from 3.2
/// (commit 774ed51e1b) it writes its own value in milliseconds. A shift
/// is a whole number of hours within a day either way, so the two never
/// meet: a value within ±23 is hours, a multiple of 3 600 000 within ±23 h
/// is milliseconds; anything else is refused.
fn timeshift_hours(item: &Item<'_>) -> Result<i64, IoError> {
    let Some(v) = item.num("timeshift")? else {
        return Ok(0);
    };
    const HOUR_MS: f64 = 3_600_000.0;
    if v.fract() == 0.0 && v.abs() <= 23.0 {
        Ok(v as i64)
    } else if (v / HOUR_MS).fract() == 0.0 && (v / HOUR_MS).abs() <= 23.0 {
        Ok((v / HOUR_MS) as i64)
    } else {
        Err(item.err(
            "timeshift",
            format!(
                "expected whole hours within a day (-23..23, or in milliseconds a multiple of \
                 3600000 as AndroidAPS 3.2 writes it), got {v}"
            ),
        ))
    }
}

/// A time-of-day schedule moved `hours` later: the value at minute m is
/// the one the schedule had at m − 60·hours (mod a day).
fn shift_by<T: Copy + PartialEq>(segments: &[(u32, T)], hours: i64) -> Vec<(u32, T)> {
    if hours == 0 || segments.is_empty() {
        return segments.to_vec();
    }
    let by = (hours * 60).rem_euclid(1440) as u32;
    let at = |m: u32| {
        let src = (m + 1440 - by) % 1440;
        segments
            .iter()
            .take_while(|s| s.0 <= src)
            .last()
            .unwrap_or(&segments[0])
            .1
    };
    let mut starts: Vec<u32> = segments.iter().map(|s| (s.0 + by) % 1440).collect();
    starts.push(0);
    starts.sort_unstable();
    starts.dedup();
    let mut out: Vec<(u32, T)> = Vec::with_capacity(starts.len());
    for m in starts {
        let v = at(m);
        if out.last().is_none_or(|l| l.1 != v) {
            out.push((m, v));
        }
    }
    out
}

/// A profile with its schedules shifted `hours` later ([`shift_by`]).
fn shifted(kind: RecordKind, hours: i64) -> RecordKind {
    match kind {
        RecordKind::Schedule { mut profile } if hours != 0 => {
            profile.basal.segments = shift_by(&profile.basal.segments, hours);
            profile.carb_ratio = shift_by(&profile.carb_ratio, hours);
            RecordKind::Schedule { profile }
        }
        other => other,
    }
}

/// A BG Check with its glucose: in the treatment's `units`, or `--units`
/// (never guessed).
fn bg_check(ctx: &Ctx<'_>, item: &Item<'_>) -> Result<RecordKind, IoError> {
    let v = item.need_num("glucose", "glucose")?;
    let unit = match item.str("units")? {
        Some(u) => GlucoseUnit::parse(u)
            .ok_or_else(|| item.err("units", format!("expected mg/dl or mmol, got \"{u}\"")))?,
        None => ctx.opts.units.ok_or_else(|| {
            item.err(
                "units",
                "missing: a BG Check's glucose needs units (or --units)",
            )
        })?,
    };
    Ok(RecordKind::Smbg {
        glucose: Glucose {
            mg_dl: MgDl(units::glucose_mg_dl(
                &item.at("glucose"),
                "glucose",
                v,
                unit,
            )?),
            censor: Censor::Exact,
        },
    })
}

/// A profile at `percent` % (AndroidAPS's Profile Switch percentage:
/// basal rates times it, carb ratios divided by it).
fn scaled(kind: RecordKind, percent: f64) -> RecordKind {
    match kind {
        RecordKind::Schedule { mut profile } if percent != 100.0 => {
            let f = percent / 100.0;
            for seg in &mut profile.basal.segments {
                seg.1 = UnitsPerHour(seg.1 .0 * f);
            }
            for cr in &mut profile.carb_ratio {
                cr.1 = GramsPerUnit(cr.1 .0 / f);
            }
            RecordKind::Schedule { profile }
        }
        other => other,
    }
}

/// A profile document: the default profile's basal schedule.
fn profile(item: &Item<'_>) -> Result<RecordKind, IoError> {
    let store = match item.get("store") {
        Some(Value::Object(s)) => s,
        _ => return Err(item.err("store", "expected an object of named profiles")),
    };
    let name = item
        .str("defaultProfile")?
        .or_else(|| store.keys().next().map(String::as_str))
        .unwrap_or("");
    let Some(Value::Object(p)) = store.get(name) else {
        return Err(item.err(
            "defaultProfile",
            format!("names \"{name}\", which the store does not hold"),
        ));
    };
    let inner = Item::json(item.file, item.index, p);
    schedule_of(&inner, &format!("store.{name}"))
}

/// A time-of-day array (`[{time | timeAsSeconds, value}]`) of a profile,
/// values checked against `[min, max]`: starts at 00:00, strictly
/// increasing.
fn by_time_of_day(
    p: &Item<'_>,
    prefix: &str,
    name: &str,
    (min, max, what): (f64, f64, &str),
) -> Result<Vec<(u32, f64)>, IoError> {
    let field = format!("{prefix}.{name}");
    let Some(Value::Array(rows)) = p.get(name) else {
        return Err(p.err(&field, "missing: expected an array of {time, value}"));
    };
    let mut out: Vec<(u32, f64)> = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        let f = format!("{field}[{i}]");
        let Value::Object(obj) = row else {
            return Err(p.err(&f, "expected {time, value}"));
        };
        let r = Item::json(p.file, p.index, obj);
        let minute = match (r.num("timeAsSeconds")?, r.str("time")?) {
            (Some(s), _) => s / 60.0,
            (None, Some(t)) => {
                let (h, m) = t
                    .split_once(':')
                    .ok_or_else(|| p.err(&f, format!("time \"{t}\" is not HH:MM")))?;
                let (h, m): (f64, f64) =
                    (h.parse().unwrap_or(f64::NAN), m.parse().unwrap_or(f64::NAN));
                h * 60.0 + m
            }
            (None, None) => return Err(p.err(&f, "missing time")),
        };
        let minute = check_range(
            &p.at(&f),
            &format!("{f}.time"),
            minute,
            0.0,
            1439.0,
            "minute of day",
        )? as u32;
        let value = r
            .need_num("value", what)
            .map_err(|_| p.err(&format!("{f}.value"), format!("missing: expected {what}")))?;
        let value = check_range(&p.at(&f), &format!("{f}.value"), value, min, max, what)?;
        if out.last().is_some_and(|&(prev, _)| minute <= prev) || (out.is_empty() && minute != 0) {
            return Err(p.err(&f, "times must start at 00:00 and increase"));
        }
        out.push((minute, value));
    }
    if out.is_empty() {
        return Err(p.err(&field, "the schedule is empty"));
    }
    Ok(out)
}

/// One profile object: its basal schedule, carb ratios (if any) and zone.
fn schedule_of(p: &Item<'_>, prefix: &str) -> Result<RecordKind, IoError> {
    let basal = by_time_of_day(
        p,
        prefix,
        "basal",
        (0.0, units::BASAL_MAX_U_PER_H, "a basal rate in U/h"),
    )?;
    let carb_ratio = match p.get("carbratio") {
        None => Vec::new(),
        Some(_) => by_time_of_day(
            p,
            prefix,
            "carbratio",
            (
                units::CARB_RATIO_MIN_G_PER_U,
                units::CARB_RATIO_MAX_G_PER_U,
                "a carb ratio in g/U",
            ),
        )?,
    };
    Ok(RecordKind::Schedule {
        profile: Box::new(Profile {
            basal: BasalSchedule {
                segments: basal
                    .into_iter()
                    .map(|(m, r)| (m, UnitsPerHour(r)))
                    .collect(),
            },
            carb_ratio: carb_ratio
                .into_iter()
                .map(|(m, r)| (m, GramsPerUnit(r)))
                .collect(),
            timezone: p.str("timezone")?.map(str::to_string),
            temporary_min: None,
        }),
    })
}
