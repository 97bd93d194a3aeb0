//! The live advisor: events posted over HTTP in batches (flushed at each
//! event that can produce an answer) give exactly the decisions of one
//! advisor fed the same events in process; each answer is tagged with the
//! seq of the event that produced it; the CLI's store view agrees; a late
//! event and an answer rebuild the advisor to what a replay gives.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::{Advisor, Decision, Parameter};
use abba_core::{Event, EventKind, Grams, MealSlot, MgDl, Timestamp, Units};
use axum::http::{Method, StatusCode};
use common::{ev, Svc};
use serde_json::{json, Value};

const DAYS: i64 = 12;

/// A deterministic app stream: CGM every 5 min with meal excursions, three
/// meals with their boluses, the day closed at 00:00 after that minute's
/// reading (from day 2). (seq, event, wire event).
pub(crate) fn stream() -> Vec<(u64, Event, Value)> {
    let mut out = Vec::new();
    let mut seq = 100u64;
    let meals = [
        (7 * 60 + 30, MealSlot::Breakfast, 50.0),
        (12 * 60 + 30, MealSlot::Lunch, 70.0),
        (19 * 60, MealSlot::Dinner, 80.0),
    ];
    let mut push = |e: Event, w: Value, out: &mut Vec<(u64, Event, Value)>| {
        seq += 3; // gaps in the app's numbering are fine
        out.push((seq, e, ev(seq, e.at.0, w)));
    };
    for day in 0..DAYS {
        for m in (0..1440).step_by(5) {
            let t = day * 1440 + m;
            let mut g = 110.0 + 15.0 * ((t as f64) / 300.0).sin();
            for (k, &(at, _, carbs)) in meals.iter().enumerate() {
                let since = (m - at) as f64;
                if since >= 0.0 {
                    // Each day's excursions differ a little.
                    let size = carbs * (1.0 + 0.1 * (((day * 3 + k as i64) % 5) as f64 - 2.0));
                    g += size * (since / 60.0) * (-since / 60.0).exp() * 5.0;
                }
            }
            push(
                Event::new(Timestamp(t), EventKind::Cgm(MgDl(g))),
                json!({"type": "cgm", "mg_dl": g}),
                &mut out,
            );
            if m == 0 && day > 0 {
                push(
                    Event::new(Timestamp(t), EventKind::DayClosed),
                    json!({"type": "day_closed"}),
                    &mut out,
                );
            }
            for &(at, slot, carbs) in &meals {
                if m == at {
                    push(
                        Event::new(
                            Timestamp(t),
                            EventKind::MealAnnounced {
                                carbs: Grams(carbs),
                                slot,
                            },
                        ),
                        json!({"type": "meal", "carbs_g": carbs, "slot": slot.name()}),
                        &mut out,
                    );
                    let units = carbs / 10.0;
                    push(
                        Event::new(Timestamp(t), EventKind::Bolus(Units(units))),
                        json!({"type": "bolus", "units": units}),
                        &mut out,
                    );
                }
            }
        }
    }
    out
}

/// (Values unrounded, as in the paper: the overrides below are 97 % and 99
/// % of a suggestion, off any pump step.)
fn person_body(name: &str) -> Value {
    json!({
        "name": name, "tz": "UTC", "mode": "cgm", "first_day": "2026-01-01",
        "continuous_values": true,
        "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]},
        "min_data": {"cgm_coverage": 0.0, "cgm_period_min": 5, "smbg_per_day": 0, "smbg_per_meal": 0}
    })
}

/// The in-process loop: one advisor, every event, decisions with the seq
/// of the event that made them.
fn in_process(svc: &Svc, id: u64, events: &[(u64, Event, Value)]) -> Vec<(Decision, u64)> {
    let store = abba_store::Store::open(&svc.db).unwrap();
    let mut advisor = store.person_by_id(id as i64).unwrap().advisor().unwrap();
    let mut out = Vec::new();
    for (seq, e, _) in events {
        advisor.observe(e).unwrap();
        for d in advisor.take_decisions() {
            out.push((d, *seq));
        }
    }
    out
}

fn slot_name(p: Parameter) -> &'static str {
    abba_store::answer::param_key(p)
}

/// Posts like an app: flushes after each meal and day close.
async fn post_like_an_app(
    svc: &Svc,
    id: u64,
    token: &str,
    events: &[(u64, Event, Value)],
) -> Vec<Value> {
    let mut answers = Vec::new();
    let mut buf: Vec<Value> = Vec::new();
    for (i, (_, e, w)) in events.iter().enumerate() {
        buf.push(w.clone());
        let answerable = matches!(
            e.kind,
            EventKind::DayClosed | EventKind::MealAnnounced { .. }
        );
        if answerable || i + 1 == events.len() {
            let r = svc
                .call(
                    Method::POST,
                    &format!("/v1/persons/{id}/events"),
                    Some(token),
                    Some(&json!({ "events": std::mem::take(&mut buf) })),
                )
                .await;
            assert_eq!(r.status, StatusCode::OK, "{}", r.text);
            answers.extend(r.json["answers"].as_array().unwrap().iter().cloned());
        }
    }
    answers
}

fn check_same(answers: &[Value], reference: &[(Decision, u64)]) {
    assert_eq!(answers.len(), reference.len());
    for (a, (d, seq)) in answers.iter().zip(reference) {
        let id = a["id"].as_u64().unwrap();
        assert_eq!(id / 4, d.at.0 as u64, "{a}");
        assert_eq!(a["parameter"], slot_name(d.parameter), "{a}");
        assert_eq!(a["value"].as_f64().unwrap(), d.new, "{a}");
        assert_eq!(a["previous"].as_f64().unwrap(), d.old, "{a}");
        assert_eq!(a["seq"].as_u64(), Some(*seq), "{a}");
        assert!(!a["reason"].as_str().unwrap().is_empty());
    }
}

#[tokio::test]
async fn batched_posts_give_the_in_process_decisions() {
    let svc = Svc::new();
    let id = svc.person_with(person_body("ann")).await;
    let (_, t) = svc.token(id).await;
    let events = stream();
    let reference = in_process(&svc, id, &events);
    // The stream is long enough for decisions about every setting, and
    // updates (ABBA's switch rule holds the carb ratios of this stream).
    for p in ["basal", "breakfast", "lunch", "dinner"] {
        assert!(
            reference.iter().any(|(d, _)| slot_name(d.parameter) == p),
            "no decision about {p} in the reference run"
        );
    }
    assert!(reference.iter().filter(|(d, _)| d.new != d.old).count() >= 4);
    let answers = post_like_an_app(&svc, id, &t, &events).await;
    check_same(&answers, &reference);

    // The CLI's view of the same file: the same decisions.
    let mut store = abba_store::Store::open(&svc.db).unwrap();
    let cli: Vec<(i64, Parameter, f64)> = store
        .decisions("ann")
        .unwrap()
        .iter()
        .map(|d| (d.at.0, d.parameter, d.new))
        .collect();
    let mut want: Vec<(i64, Parameter, f64)> = reference
        .iter()
        .map(|(d, _)| (d.at.0, d.parameter, d.new))
        .collect();
    want.sort_by_key(|x| x.0);
    assert_eq!(cli, want);
    let cli_advice = store.advise("ann").unwrap();
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/advice"),
            Some(&t),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    for (s, w) in cli_advice
        .settings
        .iter()
        .zip(r.json["settings"].as_array().unwrap())
    {
        assert_eq!(w["setting"], s.setting);
        assert_eq!(w["use_today"].as_f64().unwrap(), s.use_today);
        assert_eq!(w["in_force"].as_f64().unwrap(), s.in_force);
    }
    assert!(r.json["notice"]
        .as_str()
        .unwrap()
        .contains("not a medical device"));

    // Suggestions the app has not seen: after the id of the tenth answer.
    let after = answers[9]["id"].as_u64().unwrap();
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/suggestions?after={after}"),
            Some(&t),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let listed = r.json["suggestions"].as_array().unwrap();
    assert_eq!(listed.len(), answers.len() - 10);
    for (l, a) in listed.iter().zip(&answers[10..]) {
        assert_eq!(l["id"], a["id"]);
        assert_eq!(l["seq"], a["seq"]);
        assert_eq!(l["value"], a["value"]);
    }
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history"),
            Some(&t),
            None,
        )
        .await;
    assert_eq!(
        r.json["suggestions"].as_array().unwrap().len(),
        answers.len()
    );

    // A service restarted on the file rebuilds the same advisor and goes on
    // with the same decisions as one that never stopped.
    let more: Vec<(u64, Event, Value)> = {
        let last = events.last().unwrap();
        let t0 = last.1.at.0 + 5;
        (0..3)
            .map(|k| {
                let at = Timestamp(t0 + 1440 * k - (t0 % 1440) + 1440);
                let s = last.0 + 1 + k as u64;
                (
                    s,
                    Event::new(at, EventKind::DayClosed),
                    ev(s, at.0, json!({"type": "day_closed"})),
                )
            })
            .collect()
    };
    let mut all = events.clone();
    all.extend(more.iter().cloned());
    let reference_all = in_process(&svc, id, &all);
    let svc2 = Svc {
        router: abba_service::router(
            abba_service::AppState::open(&svc.db, Default::default()).unwrap(),
        ),
        dir: svc.dir,
        db: svc.db,
        admin: svc.admin,
    };
    let answers_more = post_like_an_app(&svc2, id, &t, &more).await;
    check_same(&answers_more, &reference_all[reference.len()..]);
}

#[tokio::test]
async fn one_big_batch_a_late_event_and_an_answer_agree_with_a_replay() {
    let svc = Svc::new();
    let id = svc.person_with(person_body("bo")).await;
    let (_, t) = svc.token(id).await;
    let events = stream();
    let reference = in_process(&svc, id, &events);
    // Everything but one reading of day 10, in batches of 2000.
    let hole = events
        .iter()
        .position(|(_, e, _)| e.at.0 == 9 * 1440 + 600)
        .unwrap();
    let mut sent: Vec<Value> = events.iter().map(|x| x.2.clone()).collect();
    let late = sent.remove(hole);
    let mut got = Vec::new();
    for chunk in sent.chunks(2000) {
        let r = svc
            .call(
                Method::POST,
                &format!("/v1/persons/{id}/events"),
                Some(&t),
                Some(&json!({ "events": chunk })),
            )
            .await;
        assert_eq!(r.status, StatusCode::OK, "{}", r.text);
        got.extend(r.json["answers"].as_array().unwrap().iter().cloned());
    }
    // The late reading: the advisor is rebuilt; the decisions after it are
    // now exactly the reference's (those it changed come back in answers).
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/events"),
            Some(&t),
            Some(&json!({ "events": [late] })),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history"),
            Some(&t),
            None,
        )
        .await;
    let all = r.json["suggestions"].as_array().unwrap().clone();
    check_same(&all, &reference);

    // Override the latest basal suggestion: stored as the store's answer,
    // the CLI sees it, and the advisor goes on from the value put in force.
    let latest = all
        .iter()
        .rev()
        .find(|s| s["parameter"] == "basal" && !s["no_update"].as_bool().unwrap())
        .unwrap()
        .clone();
    assert_eq!(latest["status"], "open");
    let value = latest["value"].as_f64().unwrap() * 0.97;
    let answers = format!("/v1/persons/{id}/answers");
    let post = |body: Value| {
        let (svc, answers, t) = (&svc, &answers, &t);
        async move { svc.call(Method::POST, answers, Some(t), Some(&body)).await }
    };
    let overridden =
        json!({"answers": [{"suggestion_id": latest["id"], "answer": "override", "value": value}]});
    let r = post(overridden.clone()).await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["answered"][0]["in_force"].as_f64().unwrap(), value);
    // The acknowledgement a person's app shows carries the notice.
    assert_eq!(r.json["notice"], abba_api::NOTICE, "{}", r.text);
    // The same answer again (an app retrying after a lost reply): the same
    // acknowledgement, nothing stored twice.
    let stored = abba_store::testing::count_rows(&svc.db, "answer");
    let r = post(overridden).await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["answered"][0]["in_force"].as_f64().unwrap(), value);
    assert_eq!(abba_store::testing::count_rows(&svc.db, "answer"), stored);
    // Another answer to it: it is no longer open.
    let r = post(json!({"answers": [{"suggestion_id": latest["id"], "answer": "accept"}]})).await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
    let mut store = abba_store::Store::open(&svc.db).unwrap();
    let h = store.history("bo").unwrap();
    let row = h
        .iter()
        .find(|v| {
            v.setting == "basal"
                && v.suggested == latest["value"].as_f64().unwrap()
                && v.status != "superseded"
        })
        .unwrap();
    assert_eq!(row.status, "overridden");
    assert_eq!(row.in_force, value);

    // A next day close (at midnight, as a CGM app closes its days): the
    // in-process advisor told the same override.
    let close_at = (DAYS) * 1440;
    let mut advisor = store.person_by_id(id as i64).unwrap().advisor().unwrap();
    let latest_at = latest["id"].as_u64().unwrap() / 4;
    for (_, e, _) in &events {
        advisor.observe(e).unwrap();
        for d in advisor.take_decisions() {
            if d.at.0 as u64 == latest_at && d.parameter == Parameter::Basal {
                advisor
                    .observe(&Event::new(
                        d.at,
                        EventKind::SuggestionOverridden(abba_core::SettingValue::Basal {
                            rate: abba_core::UnitsPerHour(value),
                        }),
                    ))
                    .unwrap();
            }
        }
    }
    let close = Event::new(Timestamp(close_at), EventKind::DayClosed);
    advisor.observe(&close).unwrap();
    let want: Vec<Decision> = advisor.take_decisions();
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/events"),
            Some(&t),
            Some(&json!({"events": [ev(999_999, close_at, json!({"type": "day_closed"}))]})),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let got = r.json["answers"].as_array().unwrap();
    assert_eq!(got.len(), want.len());
    for (g, d) in got.iter().zip(&want) {
        assert_eq!(g["value"].as_f64().unwrap(), d.new);
        assert_eq!(g["previous"].as_f64().unwrap(), d.old);
        assert_eq!(g["seq"], 999_999);
    }
    assert!(want
        .iter()
        .any(|d| d.parameter == Parameter::Basal && d.old == value));
}

#[tokio::test]
async fn an_answer_given_with_the_cli_while_the_service_runs_is_seen() {
    let svc = Svc::new();
    let id = svc.person_with(person_body("cy")).await;
    let (_, t) = svc.token(id).await;
    post_like_an_app(&svc, id, &t, &stream()).await;
    let uri = format!("/v1/persons/{id}/history");
    let before = svc.call(Method::GET, &uri, Some(&t), None).await.json;
    let open: Vec<Value> = before["suggestions"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["status"] == "open")
        .cloned()
        .collect();
    assert!(!open.is_empty());
    // `abba answer --accept` on the same file, another connection.
    let mut cli = abba_store::Store::open(&svc.db).unwrap();
    cli.answer("cy", &abba_store::AnswerRequest::Accept)
        .unwrap();
    let after = svc.call(Method::GET, &uri, Some(&t), None).await.json;
    for o in &open {
        let s = after["suggestions"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["id"] == o["id"])
            .unwrap();
        assert_eq!(s["status"], "accepted", "{s}");
    }
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/answers"),
            Some(&t),
            Some(&json!({"answers": [{"suggestion_id": open[0]["id"], "answer": "reject"}]})),
        )
        .await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
}

#[tokio::test]
async fn answers_right_after_the_acknowledgement_match_a_person_answering_in_process() {
    let svc = Svc::new();
    let id = svc.person_with(person_body("di")).await;
    let (_, t) = svc.token(id).await;
    let events = stream();
    // In process: the person overrides every basal update at once with 99 %
    // of it and rejects every carb-ratio one (the trial's answer events).
    let store = abba_store::Store::open(&svc.db).unwrap();
    let mut advisor = store.person_by_id(id as i64).unwrap().advisor().unwrap();
    drop(store);
    let mut reference: Vec<Decision> = Vec::new();
    for (_, e, _) in &events {
        advisor.observe(e).unwrap();
        let ds = advisor.take_decisions();
        for d in &ds {
            if d.new == d.old || matches!(d.detail, abba_advisor::DecisionDetail::Skipped { .. }) {
                continue;
            }
            let kind = match d.parameter {
                Parameter::Basal => {
                    EventKind::SuggestionOverridden(abba_core::SettingValue::Basal {
                        rate: abba_core::UnitsPerHour(d.new * 0.99),
                    })
                }
                Parameter::CarbRatio(slot) => {
                    EventKind::SuggestionRejected(abba_core::SettingValue::CarbRatio {
                        slot,
                        ratio: abba_core::GramsPerUnit(d.old),
                    })
                }
            };
            advisor.observe(&Event::new(d.at, kind)).unwrap();
        }
        reference.extend(ds);
    }
    // Over HTTP: the same answers right after each acknowledgement.
    let mut got: Vec<Value> = Vec::new();
    let mut buf: Vec<Value> = Vec::new();
    for (i, (_, e, w)) in events.iter().enumerate() {
        buf.push(w.clone());
        let answerable = matches!(
            e.kind,
            EventKind::DayClosed | EventKind::MealAnnounced { .. }
        );
        if !(answerable || i + 1 == events.len()) {
            continue;
        }
        let r = svc
            .call(
                Method::POST,
                &format!("/v1/persons/{id}/events"),
                Some(&t),
                Some(&json!({ "events": std::mem::take(&mut buf) })),
            )
            .await;
        assert_eq!(r.status, StatusCode::OK, "{}", r.text);
        let answers = r.json["answers"].as_array().unwrap().clone();
        let items: Vec<Value> = answers
            .iter()
            .filter(|a| !a["no_update"].as_bool().unwrap() && a["value"] != a["previous"])
            .map(|a| {
                if a["parameter"] == "basal" {
                    json!({"suggestion_id": a["id"], "answer": "override", "value": a["value"].as_f64().unwrap() * 0.99})
                } else {
                    json!({"suggestion_id": a["id"], "answer": "reject"})
                }
            })
            .collect();
        if !items.is_empty() {
            let r = svc
                .call(
                    Method::POST,
                    &format!("/v1/persons/{id}/answers"),
                    Some(&t),
                    Some(&json!({ "answers": items })),
                )
                .await;
            assert_eq!(r.status, StatusCode::OK, "{}", r.text);
            assert_eq!(r.json["changed"], json!([]));
        }
        got.extend(answers);
    }
    assert!(
        reference
            .iter()
            .filter(|d| d.parameter == Parameter::Basal && d.new != d.old)
            .count()
            >= 3
    );
    assert_eq!(got.len(), reference.len());
    for (g, d) in got.iter().zip(&reference) {
        assert_eq!(g["value"].as_f64().unwrap(), d.new, "{g}");
        assert_eq!(g["previous"].as_f64().unwrap(), d.old, "{g}");
    }
    // The CLI's replay of the file agrees (answers placed after their
    // decisions), and so does a service started afresh.
    let mut cli = abba_store::Store::open(&svc.db).unwrap();
    let replayed: Vec<(i64, f64)> = cli
        .decisions("di")
        .unwrap()
        .iter()
        .map(|d| (d.at.0, d.new))
        .collect();
    let mut want: Vec<(i64, f64)> = reference.iter().map(|d| (d.at.0, d.new)).collect();
    want.sort_by_key(|x| x.0);
    let mut replayed_sorted = replayed.clone();
    replayed_sorted.sort_by(|a, b| a.partial_cmp(b).unwrap());
    want.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(replayed_sorted, want);
    assert_eq!(cli.rebuild("di").unwrap(), advisor);
}

/// The in-process loop with changes of therapy (advisor minute, basal,
/// carb ratios) put in force before the first event at or after them.
fn in_process_with(
    svc: &Svc,
    id: u64,
    events: &[(u64, Event, Value)],
    changes: &[(i64, Option<f64>, [f64; 3])],
) -> Vec<(Decision, u64)> {
    let store = abba_store::Store::open(&svc.db).unwrap();
    let mut advisor = store.person_by_id(id as i64).unwrap().advisor().unwrap();
    let mut next = 0;
    let mut out = Vec::new();
    for (seq, e, _) in events {
        while let Some(c) = changes.get(next).filter(|c| c.0 <= e.at.0) {
            let mut s = *advisor.settings();
            if let Some(b) = c.1 {
                s.basal = abba_core::UnitsPerHour(b);
            }
            s.carb_ratio = c.2.map(abba_core::GramsPerUnit);
            advisor.set_therapy(None, s).unwrap();
            next += 1;
        }
        advisor.observe(e).unwrap();
        for d in advisor.take_decisions() {
            out.push((d, *seq));
        }
    }
    out
}

#[tokio::test]
async fn a_clinicians_change_by_the_api_and_the_cli_reaches_an_app_fed_person() {
    let svc = Svc::new();
    let id = svc.person_with(person_body("cat")).await;
    let (_, t) = svc.token(id).await;
    let events = stream();
    // The app has posted up to day 9, 05:00.
    let cut = events
        .iter()
        .position(|(_, e, _)| e.at.0 >= 8 * 1440 + 300)
        .unwrap();
    post_like_an_app(&svc, id, &t, &events[..cut]).await;
    // The clinic records new settings from day 9, 06:00 (admin only).
    let at1 = 8 * 1440 + 360;
    let body = json!({"basal_units_per_hour": 1.1,
        "carb_ratios": {"breakfast": 9.0, "lunch": 13.0, "dinner": 10.5},
        "at": common::at(at1)});
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/therapy"),
            Some(&t),
            Some(&body),
        )
        .await;
    assert_eq!(r.status, StatusCode::FORBIDDEN, "{}", r.text);
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/therapy"),
            Some(&svc.admin),
            Some(&body),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["basal_in_force"].as_f64(), Some(1.1), "{}", r.text);
    assert_eq!(r.json["carb_ratios_in_force"]["lunch"].as_f64(), Some(13.0));
    assert!(r.json["notice"]
        .as_str()
        .unwrap()
        .contains("not a medical device"));
    // The rest of the stream: the lunch update of day 9 starts from 13.
    post_like_an_app(&svc, id, &t, &events[cut..]).await;
    let mut changes = vec![(at1, Some(1.1), [9.0, 13.0, 10.5])];
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history"),
            Some(&t),
            None,
        )
        .await;
    let all = r.json["suggestions"].as_array().unwrap().clone();
    check_same(&all, &in_process_with(&svc, id, &events, &changes));
    let lunch9 = all
        .iter()
        .find(|s| s["parameter"] == "lunch" && s["id"].as_u64().unwrap() / 4 > at1 as u64)
        .expect("a lunch decision after the change");
    assert_eq!(lunch9["previous"].as_f64(), Some(13.0), "{lunch9}");

    // `abba therapy set` on the same file while the service runs, earlier
    // than the last event: the service rebuilds and its history follows.
    let at2 = 10 * 1440 + 600;
    let mut store = abba_store::Store::open(&svc.db).unwrap();
    store
        .set_therapy(
            "cat",
            None,
            Some([9.5, 12.5, 10.0]),
            Some(common::at(at2).parse().unwrap()),
        )
        .unwrap();
    changes.push((at2, None, [9.5, 12.5, 10.0]));
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history"),
            Some(&t),
            None,
        )
        .await;
    let all = r.json["suggestions"].as_array().unwrap().clone();
    check_same(&all, &in_process_with(&svc, id, &events, &changes));
    let lunch = all
        .iter()
        .find(|s| s["parameter"] == "lunch" && s["id"].as_u64().unwrap() / 4 > at2 as u64)
        .expect("a lunch decision after the second change");
    assert_eq!(lunch["previous"].as_f64(), Some(12.5), "{lunch}");

    // Refused with the field named: a value out of the limits, a schedule
    // not starting at 0, both basal forms, a time in the future.
    for (bad, field) in [
        (
            json!({"basal_units_per_hour": 90.0}),
            "basal_units_per_hour",
        ),
        (
            json!({"basal_schedule": [{"start_minute": 60, "units_per_hour": 1.0}]}),
            "basal_schedule[0].start_minute",
        ),
        (
            json!({"basal_units_per_hour": 1.0, "basal_schedule": [{"start_minute": 0, "units_per_hour": 1.0}]}),
            "basal_schedule",
        ),
        (
            json!({"carb_ratios": {"breakfast": 9.0, "lunch": 300.0, "dinner": 10.0}}),
            "carb_ratios.lunch",
        ),
        (
            json!({"carb_ratios": {"breakfast": 9.0, "lunch": 12.0, "dinner": 10.0}, "at": "2999-01-01T00:00:00Z"}),
            "at",
        ),
    ] {
        let r = svc
            .call(
                Method::POST,
                &format!("/v1/persons/{id}/therapy"),
                Some(&svc.admin),
                Some(&bad),
            )
            .await;
        assert_eq!(
            r.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{bad}: {}",
            r.text
        );
        assert_eq!(r.json["path"], field, "{}", r.text);
    }
}

/// Bounds that hold no value on the pump's step are refused where they
/// are set (a suggestion could not keep to both), naming the setting.
#[tokio::test]
async fn bounds_must_hold_a_value_on_the_pumps_step() {
    let svc = Svc::new();
    let mut body = person_body("cat");
    body.as_object_mut().unwrap().remove("continuous_values");
    let id = svc.person_with(body).await;
    let bounds = format!("/v1/persons/{id}/bounds");
    let off_step = json!({"bounds": {"basal": {"min": 0.91, "max": 0.94}}});
    let r = svc
        .call(Method::PUT, &bounds, Some(&svc.admin), Some(&off_step))
        .await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    assert_eq!(r.json["path"], "bounds.basal", "{}", r.text);
    assert!(r.text.contains("no value on the pump's step"), "{}", r.text);
    let on_step = json!({"bounds": {"basal": {"min": 0.91, "max": 1.04}}});
    let r = svc
        .call(Method::PUT, &bounds, Some(&svc.admin), Some(&on_step))
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
}

#[tokio::test]
async fn bounds_are_checked_against_the_value_in_force_and_the_advice_keeps_to_them() {
    let svc = Svc::new();
    let id = svc.person_with(person_body("bea")).await;
    let (_, t) = svc.token(id).await;
    let events = stream();
    post_like_an_app(&svc, id, &t, &events).await;
    // The clinician puts 1.3 U/h in force from day 9, 06:00 (started at 1).
    let body = json!({"basal_units_per_hour": 1.3, "at": common::at(8 * 1440 + 360)});
    let therapy = format!("/v1/persons/{id}/therapy");
    let r = svc
        .call(Method::POST, &therapy, Some(&svc.admin), Some(&body))
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    // (The days after it moved it a little.)
    let in_force = r.json["basal_in_force"].as_f64().unwrap();
    assert!((1.25..1.35).contains(&in_force), "{}", r.text);
    let bounds = format!("/v1/persons/{id}/bounds");
    // Bounds that leave out the value in force are refused, naming it...
    let tight = json!({"bounds": {"basal": {"min": 0.5, "max": 1.0}}});
    let r = svc
        .call(Method::PUT, &bounds, Some(&svc.admin), Some(&tight))
        .await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    assert!(r.text.contains("value in force 1.3"), "{}", r.text);

    // ... and bounds around it accepted, though the starting 1 U/h is out.
    let around = json!({"bounds": {"basal": {"min": 1.2, "max": 1.4}}});
    let r = svc
        .call(Method::PUT, &bounds, Some(&svc.admin), Some(&around))
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/advice"),
            Some(&t),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let basal = r.json["settings"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s["setting"] == "basal")
        .unwrap()
        .clone();
    for v in [&basal["in_force"], &basal["use_today"]] {
        let v = v.as_f64().unwrap();
        assert!((1.2..=1.4).contains(&v), "{basal}");
    }
    // Every basal suggestion lies inside the bounds; those from the
    // starting 1 U/h, outside them, moved into them and say why.
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history"),
            Some(&t),
            None,
        )
        .await;
    let all = r.json["suggestions"].as_array().unwrap();
    let basal: Vec<&Value> = all
        .iter()
        .filter(|s| s["parameter"] == "basal" && s["no_update"] == false)
        .collect();
    assert!(basal.len() > 2, "{}", r.text);
    let mut from_outside = 0;
    for s in basal {
        let v = s["value"].as_f64().unwrap();
        assert!((1.2..=1.4).contains(&v), "{s}");
        if s["previous"].as_f64().unwrap() < 1.2 {
            from_outside += 1;
            let reasons = s["reasons"].to_string();
            assert!(
                reasons.contains("lies outside your clinician's bounds"),
                "{s}"
            );
        }
    }
    assert!(from_outside > 0, "{}", r.text);
}

#[tokio::test]
async fn a_clinicians_change_before_day_1_is_refused_naming_at() {
    let svc = Svc::new();
    let id = svc.person("dee").await;
    let therapy = format!("/v1/persons/{id}/therapy");
    for at in ["1980-01-01T00:00:00Z", "2025-12-31T23:59:00Z"] {
        let body = json!({"basal_units_per_hour": 1.1, "at": at});
        let r = svc
            .call(Method::POST, &therapy, Some(&svc.admin), Some(&body))
            .await;
        assert_eq!(
            r.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{at}: {}",
            r.text
        );
        assert_eq!(r.json["path"], "at", "{}", r.text);
        assert!(
            r.text
                .contains("expected an instant on or after 2026-01-01 00:00 (UTC)"),
            "{}",
            r.text
        );
    }
    // Day 1's first minute is accepted.
    let body = json!({"basal_units_per_hour": 1.1, "at": "2026-01-01T00:00:00Z"});
    let r = svc
        .call(Method::POST, &therapy, Some(&svc.admin), Some(&body))
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
}

/// The history read page by page says of each suggestion what the whole
/// history says: a suggestion followed by the next and then by a change of
/// therapy is superseded, whichever page it is the last of its setting on.
#[tokio::test]
async fn the_history_page_by_page_says_what_the_whole_history_says() {
    let svc = Svc::new();
    let id = svc.person_with(person_body("pia")).await;
    let (_, t) = svc.token(id).await;
    let events = stream();
    let cut = events
        .iter()
        .position(|(_, e, _)| e.at.0 >= 8 * 1440 + 300)
        .unwrap();
    post_like_an_app(&svc, id, &t, &events[..cut]).await;
    let body = json!({"basal_units_per_hour": 1.1,
        "carb_ratios": {"breakfast": 9.0, "lunch": 13.0, "dinner": 10.5},
        "at": common::at(8 * 1440 + 360)});
    let therapy = format!("/v1/persons/{id}/therapy");
    let r = svc
        .call(Method::POST, &therapy, Some(&svc.admin), Some(&body))
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    post_like_an_app(&svc, id, &t, &events[cut..]).await;
    let uri = format!("/v1/persons/{id}/history");
    let whole = svc.call(Method::GET, &uri, Some(&t), None).await;
    let whole = whole.json["suggestions"].as_array().unwrap().clone();
    assert!(whole.iter().any(|s| s["status"] == "superseded"));
    for limit in [1, 3] {
        let mut paged = Vec::new();
        let mut after: Option<u64> = None;
        loop {
            let q = match after {
                Some(a) => format!("{uri}?limit={limit}&after={a}"),
                None => format!("{uri}?limit={limit}"),
            };
            let r = svc.call(Method::GET, &q, Some(&t), None).await;
            assert_eq!(r.status, StatusCode::OK, "{}", r.text);
            paged.extend(r.json["suggestions"].as_array().unwrap().iter().cloned());
            match r.json["next_after"].as_u64() {
                Some(a) => after = Some(a),
                None => break,
            }
        }
        assert_eq!(paged.len(), whole.len());
        for (p, w) in paged.iter().zip(&whole) {
            assert_eq!(p["id"], w["id"]);
            assert_eq!(
                (&p["status"], &p["in_force"]),
                (&w["status"], &w["in_force"]),
                "limit {limit}, suggestion {}",
                w["id"]
            );
        }
    }
}
