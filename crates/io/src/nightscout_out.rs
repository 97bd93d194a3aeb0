//! Writing the other way: an advisor event stream (a simulated person's
//! device data) as Nightscout `entries.json`, `treatments.json` and
//! `profile.json`, newest first as the API serves them. Read back with the
//! same clock and meal windows, they give the same events (DayClosed is
//! not written: the reader derives it at local midnights).

use abba_core::Event;
use abba_core::{EventKind, TempBasalRate, TherapySettings, Timestamp};
use serde_json::{json, Value};

use crate::clock::AdvisorClock;
use crate::error::IoError;
use crate::record::content_hash;

/// The three files' contents.
#[derive(Debug, Clone)]
pub struct NightscoutFiles {
    /// `entries.json`.
    pub entries: String,
    /// `treatments.json`.
    pub treatments: String,
    /// `profile.json`.
    pub profile: String,
}

fn id(parts: &[&[u8]]) -> String {
    format!(
        "{:016x}{:08x}",
        content_hash(parts.iter().copied()),
        parts.len()
    )
}

fn profile_doc(
    clock: &AdvisorClock,
    at: jiff::Timestamp,
    basal: f64,
    start: &TherapySettings,
) -> Value {
    let tz = clock.tz().iana_name().unwrap_or("UTC");
    let ratios: Vec<Value> = [(0, 0), (630, 1), (930, 2)]
        .iter()
        .map(|&(m, i)| json!({"time": format!("{:02}:{:02}", m / 60, m % 60), "timeAsSeconds": m * 60, "value": start.carb_ratio[i].0}))
        .collect();
    json!({
        "_id": id(&[b"profile", &at.as_millisecond().to_le_bytes(), &basal.to_le_bytes()]),
        "defaultProfile": "abba",
        "startDate": at.to_string(),
        "mills": at.as_millisecond(),
        "units": "mg/dl",
        "enteredBy": "abba (simulated person; research software, not a medical device)",
        "store": {"abba": {
            "timezone": tz,
            "units": "mg/dl",
            "dia": 5,
            "basal": [{"time": "00:00", "timeAsSeconds": 0, "value": basal}],
            "carbratio": ratios,
        }},
    })
}

/// Writes `events` (with the starting settings, in force from 00:00 of day
/// 1) as Nightscout JSON on `clock`.
pub fn write(
    events: &[Event],
    start: &TherapySettings,
    clock: &AdvisorClock,
) -> Result<NightscoutFiles, IoError> {
    let mut entries = Vec::new();
    let mut treatments = Vec::new();
    let mut profiles = vec![profile_doc(
        clock,
        clock.instant(Timestamp(0))?,
        start.basal.0,
        start,
    )];
    let mut i = 0;
    while i < events.len() {
        let e = events[i];
        let at = clock.instant(e.at)?;
        let ms = at.as_millisecond();
        let iso = at.to_string();
        match e.kind {
            EventKind::Cgm(g) | EventKind::Smbg(g) => {
                let ty = if matches!(e.kind, EventKind::Cgm(_)) {
                    "sgv"
                } else {
                    "mbg"
                };
                let mut v = json!({
                    "_id": id(&[ty.as_bytes(), &ms.to_le_bytes(), &g.0.to_le_bytes()]),
                    "device": "abba-sim",
                    "date": ms,
                    "dateString": iso,
                    "type": ty,
                });
                v[ty] = json!(g.0);
                entries.push(v);
            }
            EventKind::MealAnnounced { carbs, .. } => {
                let bolus = events.get(i + 1).and_then(|n| match n.kind {
                    EventKind::Bolus(u) if n.at == e.at => Some(u),
                    _ => None,
                });
                let mut v = json!({
                    "_id": id(&[b"meal", &ms.to_le_bytes(), &carbs.0.to_le_bytes()]),
                    "eventType": if bolus.is_some() { "Meal Bolus" } else { "Carb Correction" },
                    "created_at": iso,
                    "carbs": carbs.0,
                    "enteredBy": "abba-sim",
                });
                if let Some(u) = bolus {
                    v["insulin"] = json!(u.0);
                    i += 1;
                }
                treatments.push(v);
            }
            EventKind::Bolus(u) => treatments.push(json!({
                "_id": id(&[b"bolus", &ms.to_le_bytes(), &u.0.to_le_bytes()]),
                "eventType": "Correction Bolus",
                "created_at": iso,
                "insulin": u.0,
                "enteredBy": "abba-sim",
            })),
            EventKind::BasalRate(r) => profiles.push(profile_doc(clock, at, r.0, start)),
            EventKind::TempBasal { rate, duration_min } => {
                let mut v = json!({
                    "_id": id(&[b"temp", &ms.to_le_bytes()]),
                    "eventType": "Temp Basal",
                    "created_at": iso,
                    "duration": duration_min,
                    "enteredBy": "abba-sim",
                });
                match rate {
                    TempBasalRate::UnitsPerHour(r) => v["absolute"] = json!(r.0),
                    // Nightscout's percent is a change: -30 is 70 % of the schedule.
                    TempBasalRate::Percent(p) => v["percent"] = json!(p - 100.0),
                }
                treatments.push(v);
            }
            EventKind::Suspend | EventKind::Resume => {
                let (kind, tag): (&str, &[u8]) = if e.kind == EventKind::Suspend {
                    ("Suspend Pump", b"suspend")
                } else {
                    ("Resume Pump", b"resume")
                };
                treatments.push(json!({
                    "_id": id(&[tag, &ms.to_le_bytes()]),
                    "eventType": kind,
                    "created_at": iso,
                    "enteredBy": "abba-sim",
                }));
            }
            EventKind::ExtendedBolus {
                total,
                immediate,
                duration_min,
            } => treatments.push(json!({
                "_id": id(&[b"combo", &ms.to_le_bytes(), &total.0.to_le_bytes()]),
                "eventType": "Combo Bolus",
                "created_at": iso,
                "insulin": immediate.0,
                "enteredinsulin": total.0,
                "duration": duration_min,
                "enteredBy": "abba-sim",
            })),
            _ => {} // DayClosed: derived by the reader
        }
        i += 1;
    }
    let newest_first = |mut v: Vec<Value>| -> String {
        v.reverse();
        serde_json::to_string_pretty(&Value::Array(v)).unwrap_or_default()
    };
    Ok(NightscoutFiles {
        entries: newest_first(entries),
        treatments: newest_first(treatments),
        profile: newest_first(profiles),
    })
}

/// Writes the three files into `dir`.
pub fn write_dir(files: &NightscoutFiles, dir: &std::path::Path) -> Result<(), IoError> {
    std::fs::create_dir_all(dir).map_err(|source| IoError::Write {
        file: dir.display().to_string(),
        source,
    })?;
    for (name, text) in [
        ("entries.json", &files.entries),
        ("treatments.json", &files.treatments),
        ("profile.json", &files.profile),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|source| IoError::Write {
            file: path.display().to_string(),
            source,
        })?;
    }
    Ok(())
}
