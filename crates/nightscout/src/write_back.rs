//! Writing back (opt-in per link): each suggestion a person can act on
//! (open or answered) as one treatment of type Note at its decision's
//! time (`enteredBy: abba`, the suggestion at the pump's step and its
//! reasons in the person's unit), updated when it is answered; the settings to use today
//! as a separate profile named `abba` in the profile store, beside the
//! person's own: never the default profile and never a Profile Switch (a
//! profile in Nightscout does not change the pump; the person decides).
//! What abba wrote is remembered in the store so it is written once and
//! can be removed with the link.

use crate::client::{Client, Method};
use crate::error::NsError;
use abba_store::link::Written;
use abba_store::{Store, NOTICE};
use serde::Serialize;
use serde_json::{json, Map, Value};

/// The name of abba's profile in the site's profile store.
pub const PROFILE_NAME: &str = "abba";
/// `enteredBy` of what abba writes.
pub const ENTERED_BY: &str = "abba";

/// What one write-back did.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct WriteReport {
    /// Notes created.
    pub notes_created: usize,
    /// Notes updated (the suggestion was answered).
    pub notes_updated: usize,
    /// Whether the `abba` profile was written (created or changed).
    pub profile_written: bool,
    /// Why the profile was not written, if it was not.
    pub profile_skipped: Option<String>,
}

/// Whether a treatment is one abba wrote (a Note entered by abba).
pub fn is_ours(doc: &Value) -> bool {
    doc.get("enteredBy").and_then(Value::as_str) == Some(ENTERED_BY)
        && doc.get("eventType").and_then(Value::as_str) == Some("Note")
}

fn protocol(client: &Client, call: &str, problem: impl Into<String>) -> NsError {
    NsError::Protocol {
        site: client.site().to_string(),
        call: call.to_string(),
        problem: problem.into(),
    }
}

/// How many decimals a value of `setting` is shown with: the pump's step
/// (0.05 U/h: 2, 0.1 g/U: 1) when the person has one, else 3 (as the CLI
/// prints them).
/// `steps`: the pump's (basal U/h, carb ratio g/U).
fn decimals(steps: Option<(f64, f64)>, setting: &str) -> usize {
    let Some((basal, ratio)) = steps else {
        return 3;
    };
    let step = if setting == "basal" { basal } else { ratio };
    (0..=4)
        .find(|&d| {
            let x = step * 10f64.powi(d as i32);
            (x - x.round()).abs() < 1e-6
        })
        .unwrap_or(4)
}

/// The note for a suggestion (without `_id` and `created_at`), its values
/// at `dp` decimals.
fn note_text(v: &abba_store::advise::SuggestionView, dp: usize) -> String {
    // A change below 0.05 % is not shown as "+0.0 %".
    let pct = if v.change_percent.abs() < 0.05 {
        format!("{:+.2}", v.change_percent)
    } else {
        format!("{:+.1}", v.change_percent)
    };
    let mut s = format!(
        "abba suggests {} {:.dp$} {} (was {:.dp$}, {pct} %), day {}, decided {}; status: {}.",
        v.setting, v.suggested, v.unit, v.previous, v.day, v.decided_at, v.status
    );
    if !v.reasons.is_empty() {
        s.push_str(" Why: ");
        s.push_str(&v.reasons.join(" "));
    }
    if let Some(sched) = &v.schedule {
        let parts: Vec<String> = sched.iter().map(|(t, r)| format!("{t} {r:.dp$}")).collect();
        s.push_str(&format!(" Schedule (U/h): {}.", parts.join(", ")));
    }
    s.push(' ');
    s.push_str(NOTICE);
    s
}

/// Whether a suggestion is one a person can act on, so worth a Note of
/// its own: open, or answered, and a change at the precision shown. Not a
/// decision without an update, a change below the pump's step, a basal
/// not offered, or one superseded before anybody saw it (a Note already
/// written for a suggestion is updated whatever it became).
fn actionable(v: &abba_store::advise::SuggestionView, dp: usize) -> bool {
    let status = matches!(
        v.status.as_str(),
        "open" | "accepted" | "rejected" | "overridden"
    );
    let changed =
        format!("{:.dp$}", v.suggested) != format!("{:.dp$}", v.previous) || v.schedule.is_some();
    !v.no_update && status && changed
}

/// The instant of a decision from its local time in the person's zone
/// (`YYYY-MM-DD HH:MM`, or an instant when the advisor had no clock).
fn decided_instant(decided_at: &str, tz: &jiff::tz::TimeZone) -> Option<jiff::Timestamp> {
    if let Ok(dt) = jiff::civil::DateTime::strptime("%Y-%m-%d %H:%M", decided_at) {
        return dt.to_zoned(tz.clone()).ok().map(|z| z.timestamp());
    }
    decided_at.parse::<jiff::Timestamp>().ok()
}

/// Writes what is new or changed since the last write-back: a Note for
/// each suggestion a person can act on, dated at its decision, and the
/// update of a Note written before when its suggestion changed status.
pub fn write_back(
    store: &mut Store,
    client: &Client,
    person: &str,
) -> Result<WriteReport, NsError> {
    let mut report = WriteReport::default();
    let views = store.history(person)?;
    let written = store.written(person)?;
    let p = store.person(person)?;
    let steps = p
        .settings
        .pump_steps
        .map(|s| (s.basal_u_per_h, s.carb_ratio_g_per_u));
    for v in views.iter().filter(|v| !v.no_update) {
        let key = format!("{}|{}", v.decided_at, v.setting);
        let dp = decimals(steps, v.setting);
        let notes = note_text(v, dp);
        let held = written.iter().find(|w| w.what == "note" && w.key == key);
        if held.is_none() && !actionable(v, dp) {
            continue;
        }
        let Some(at) = decided_instant(&v.decided_at, &p.tz) else {
            return Err(protocol(
                client,
                "POST /api/v1/treatments",
                format!(
                    "the time of the {} suggestion, {}, is not a time abba can write",
                    v.setting, v.decided_at
                ),
            ));
        };
        let at_ms = at.as_millisecond();
        match held {
            Some(w) => {
                let old: Value = serde_json::from_str(&w.content).unwrap_or(Value::Null);
                // The instant the Note was given (its decision's, or a
                // millisecond after where another Note held that one).
                let created_at = old
                    .get("created_at")
                    .and_then(Value::as_str)
                    .filter(|t| {
                        t.parse::<jiff::Timestamp>().is_ok_and(|t| {
                            (0..FREE_INSTANT_TRIES).contains(&(t.as_millisecond() - at_ms))
                        })
                    })
                    .map_or_else(|| crate::fetch::iso_ms(at_ms), String::from);
                if old.get("notes").and_then(Value::as_str) == Some(notes.as_str())
                    && old.get("created_at").and_then(Value::as_str) == Some(created_at.as_str())
                {
                    continue;
                }
                let mut doc = old.as_object().cloned().unwrap_or_default();
                doc.insert("notes".into(), Value::String(notes));
                doc.insert("created_at".into(), Value::String(created_at));
                doc.insert("_id".into(), Value::String(w.remote_id.clone()));
                let doc = Value::Object(doc);
                put_treatment(client, &w.remote_id, &doc)?;
                store.set_written(
                    person,
                    &Written {
                        content: doc.to_string(),
                        ..w.clone()
                    },
                )?;
                report.notes_updated += 1;
            }
            None => {
                let created_at = free_instant(client, at_ms, v.setting)?;
                let doc = json!({
                    "eventType": "Note",
                    "enteredBy": ENTERED_BY,
                    "created_at": created_at,
                    "notes": notes,
                });
                let call = "POST /api/v1/treatments";
                let r =
                    client.call(Method::Post, "/api/v1/treatments", &[], Some(&json!([doc])))?;
                let id = created_id(&r).ok_or_else(|| {
                    protocol(
                        client,
                        call,
                        format!(
                            "expected the created treatment with its _id; an answer without \
                             one is Nightscout's when it replaced a Note it held at {created_at} \
                             (uploaded there since abba looked)"
                        ),
                    )
                })?;
                let mut stored = doc.as_object().cloned().unwrap_or_default();
                stored.insert("_id".into(), Value::String(id.clone()));
                store.set_written(
                    person,
                    &Written {
                        what: "note".into(),
                        key,
                        remote_id: id,
                        content: Value::Object(stored).to_string(),
                    },
                )?;
                report.notes_created += 1;
            }
        }
    }
    match write_profile(store, client, person)? {
        Ok(written) => report.profile_written = written,
        Err(why) => report.profile_skipped = Some(why),
    }
    Ok(report)
}

/// How many milliseconds after its decision a Note may be moved to find
/// an instant no other Note holds.
const FREE_INSTANT_TRIES: i64 = 1000;

/// The first instant from `at_ms` on (by milliseconds) at which the site
/// holds no Note, in the `toISOString()` form Nightscout stores.
///
/// Nightscout's v1 POST of a treatment without `identifier` or `_id` is a
/// replace with upsert keyed by its `created_at` and `eventType`
/// (`upsert` / `upsertQueryFor` in `lib/server/treatments.js`; in 15.0.2
/// and before, always by those two): a Note at an instant that already
/// holds one (the person's own, entered at the decision's minute, or
/// abba's for another setting decided at the same time) would replace it.
fn free_instant(client: &Client, at_ms: i64, setting: &str) -> Result<String, NsError> {
    let path = "/api/v1/treatments.json";
    for step in 0..FREE_INSTANT_TRIES {
        let t = crate::fetch::iso_ms(at_ms + step);
        let held = crate::fetch::list(
            client,
            path,
            &[
                ("find[created_at][$gte]", t.clone()),
                ("find[created_at][$lte]", t.clone()),
                ("find[eventType]", "Note".into()),
                ("count", "1".into()),
            ],
        )?;
        // Only a Note at that instant counts (a server that leaves a
        // filter out serves others).
        let taken = held.iter().any(|d| {
            d.get("eventType").and_then(Value::as_str) == Some("Note")
                && crate::fetch::Collection::Treatments.time_of(d) == Some(at_ms + step)
        });
        if !taken {
            return Ok(t);
        }
    }
    Err(protocol(
        client,
        &format!("GET {path}"),
        format!(
            "every millisecond of the {FREE_INSTANT_TRIES} after the {setting} suggestion's decision \
             ({}) holds a Note: abba writes none there, as Nightscout would replace the one it holds",
            crate::fetch::iso_ms(at_ms)
        ),
    ))
}

/// Replaces abba's Note `id` on the site: Nightscout takes the PUT at
/// `/api/v1/treatments` with the `_id` in the body (`lib/api/treatments`;
/// it has no route at `/api/v1/treatments/<id>`, 404), a server that
/// routes it by id only (nightscout/nocturne, `PUT
/// /api/v1/treatments/{id}`) answers that 405 and gets it there.
fn put_treatment(client: &Client, id: &str, doc: &Value) -> Result<Value, NsError> {
    match client.call(Method::Put, "/api/v1/treatments", &[], Some(doc)) {
        Err(NsError::Status {
            status: 404 | 405, ..
        }) => client.call(
            Method::Put,
            &format!("/api/v1/treatments/{}", crate::client::encode_segment(id)),
            &[],
            Some(doc),
        ),
        r => r,
    }
}

fn created_id(v: &Value) -> Option<String> {
    let doc = match v {
        Value::Array(a) => a.first()?,
        other => other,
    };
    doc.get("_id").and_then(Value::as_str).map(String::from)
}

fn hhmm(min: u32) -> (String, u32) {
    (format!("{:02}:{:02}", min / 60, min % 60), min * 60)
}

fn schedule(rows: &[(u32, f64)]) -> Value {
    Value::Array(
        rows.iter()
            .map(|&(m, v)| {
                let (t, s) = hhmm(m);
                json!({"time": t, "timeAsSeconds": s, "value": v})
            })
            .collect(),
    )
}

fn minutes_of(t: &str) -> Option<u32> {
    let (h, m) = t.split_once(':')?;
    Some(h.parse::<u32>().ok()? * 60 + m.parse::<u32>().ok()?)
}

/// The `abba` profile: the person's default profile with the basal and
/// carb ratios to use today. `Ok(Err(why))` when it cannot be written.
fn write_profile(
    store: &mut Store,
    client: &Client,
    person: &str,
) -> Result<Result<bool, String>, NsError> {
    let advice = store.advise(person)?;
    let p = store.person(person)?;
    let get = |name: &str| advice.settings.iter().find(|s| s.setting == name);
    let Some(basal) = get("basal") else {
        return Ok(Err("no basal in the advice yet".into()));
    };
    let basal_rows: Vec<(u32, f64)> = match basal.latest.as_ref().and_then(|l| l.schedule.clone()) {
        Some(s) => s
            .iter()
            .filter_map(|(t, v)| minutes_of(t).map(|m| (m, *v)))
            .collect(),
        None => match &advice.therapy.basal_schedule {
            Some(s) if basal.latest.is_none() => s
                .iter()
                .filter_map(|(t, v)| minutes_of(t).map(|m| (m, *v)))
                .collect(),
            _ => vec![(0, basal.use_today)],
        },
    };
    let w = &p.settings.meal_windows;
    let mut cr_rows = Vec::new();
    for (name, start) in [
        ("breakfast", 0),
        ("lunch", w.lunch.0),
        ("dinner", w.dinner.0),
    ] {
        match get(name) {
            Some(s) => cr_rows.push((start, s.use_today)),
            None => return Ok(Err(format!("no {name} carb ratio in the advice yet"))),
        }
    }
    let path = "/api/v1/profile.json";
    let docs = client.get(path, &[("count", "1".into())])?;
    let Some(doc) = docs.as_array().and_then(|a| a.first()).cloned() else {
        return Ok(Err("the site holds no profile to add abba's beside".into()));
    };
    let Some(default) = doc
        .get("defaultProfile")
        .and_then(Value::as_str)
        .map(String::from)
    else {
        return Ok(Err("the newest profile document names no defaultProfile; abba does not add a profile that could be taken for the default".into()));
    };
    if default == PROFILE_NAME {
        return Ok(Err(
            "the person's default profile is named abba; abba does not write over it".into(),
        ));
    }
    let Some(id) = doc.get("_id").and_then(Value::as_str).map(String::from) else {
        return Ok(Err("the newest profile document has no _id".into()));
    };
    let stores = doc
        .get("store")
        .and_then(Value::as_object)
        .cloned()
        .unwrap_or_default();
    let Some(base) = stores.get(&default).and_then(Value::as_object).cloned() else {
        return Ok(Err(format!(
            "the store does not hold the default profile {default}"
        )));
    };
    let mut ours: Map<String, Value> = base;
    ours.insert("basal".into(), schedule(&basal_rows));
    ours.insert("carbratio".into(), schedule(&cr_rows));
    ours.insert(
        "notes".into(),
        Value::String(format!("Written by abba from today's advice; not in force until the person chooses it. {NOTICE}")),
    );
    let ours = Value::Object(ours);
    let written = store.written(person)?;
    let held = written.iter().find(|w| w.what == "profile");
    let ours_text = ours.to_string();
    if held.is_some_and(|w| w.remote_id == id && w.content == ours_text)
        && stores.get(PROFILE_NAME) == Some(&ours)
    {
        return Ok(Ok(false));
    }
    let mut new_doc = doc.as_object().cloned().unwrap_or_default();
    let mut new_store = stores;
    new_store.insert(PROFILE_NAME.into(), ours.clone());
    new_doc.insert("store".into(), Value::Object(new_store));
    match client.call(
        Method::Put,
        "/api/v1/profile",
        &[],
        Some(&Value::Object(new_doc)),
    ) {
        Ok(_) => {}
        // A server that takes no profile update (nightscout/nocturne has
        // no `PUT /api/v1/profile`): the Notes are written, the profile
        // is said to be not, and the sync does not fail on it.
        Err(NsError::Status {
            status: s @ (404 | 405),
            ..
        }) => {
            return Ok(Err(format!(
                "the site takes no profile update (PUT /api/v1/profile answered {s}): the {PROFILE_NAME} profile is not written there"
            )))
        }
        Err(e) => return Err(e),
    }
    store.set_written(
        person,
        &Written {
            what: "profile".into(),
            key: PROFILE_NAME.into(),
            remote_id: id,
            content: ours.to_string(),
        },
    )?;
    Ok(Ok(true))
}

/// Removes from the site what abba wrote (its Notes, its profile) and
/// forgets it; returns how many documents were changed.
pub fn delete_written(store: &mut Store, client: &Client, person: &str) -> Result<usize, NsError> {
    let mut n = 0;
    for w in store.written(person)? {
        match w.what.as_str() {
            "note" => {
                let path = format!("/api/v1/treatments/{}", w.remote_id);
                match client.call(Method::Delete, &path, &[], None) {
                    Ok(_) | Err(NsError::Status { status: 404, .. }) => {}
                    Err(e) => return Err(e),
                }
            }
            _ => {
                let docs = client.get("/api/v1/profile.json", &[("count", "1000".into())])?;
                let doc = docs
                    .as_array()
                    .and_then(|a| {
                        a.iter()
                            .find(|d| d.get("_id").and_then(Value::as_str) == Some(&w.remote_id))
                    })
                    .cloned();
                if let Some(Value::Object(mut d)) = doc {
                    if let Some(Value::Object(s)) = d.get_mut("store") {
                        s.remove(PROFILE_NAME);
                    }
                    client.call(Method::Put, "/api/v1/profile", &[], Some(&Value::Object(d)))?;
                }
            }
        }
        store.forget_written(person, &w.what, &w.key)?;
        n += 1;
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_shown_at_the_pumps_step() {
        assert_eq!(decimals(None, "basal"), 3);
        assert_eq!(decimals(Some((0.05, 0.1)), "basal"), 2);
        assert_eq!(decimals(Some((0.025, 1.0)), "basal"), 3);
        assert_eq!(decimals(Some((0.05, 0.1)), "lunch"), 1);
        assert_eq!(decimals(Some((0.05, 1.0)), "dinner"), 0);
    }
}
