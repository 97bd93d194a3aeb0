//! The advice with each open suggestion's predicted effect, through the
//! service's interface (a stand-in predictor here; the real one, the
//! person's twin, is wired in by the `abba` binary and tested in
//! crates/cli/tests/twin_effect_cli.rs): the JSON conforms to the OpenAPI
//! document, and the twin check holds back a suggestion predicted to raise
//! time below 70 by more than the margin and passes one that does not.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_service::EffectSource;
use abba_store::effect::{
    Band, Effect, EffectPredictor, EffectQuery, Figures, Predicted, TwinCheck,
};
use axum::http::{Method, StatusCode};
use common::{cgm, ev, Svc};
use serde_json::{json, Value};
use std::sync::Arc;

/// Predicts a rise of time below 70 of `rise` points for every suggestion
/// that adds insulin (a higher basal, a lower carb ratio), none otherwise.
struct Fixed {
    rise: f64,
}

fn band(v: f64) -> Band {
    Band {
        value: v,
        low: v - 0.5,
        high: v + 0.5,
    }
}

impl EffectPredictor for Fixed {
    fn predict(&self, q: &EffectQuery<'_>) -> Effect {
        let more_insulin = match q.parameter {
            abba_advisor::Parameter::Basal => q.suggested > q.in_force,
            abba_advisor::Parameter::CarbRatio(_) => q.suggested < q.in_force,
        };
        let rise = if more_insulin { self.rise } else { 0.0 };
        let f = |tir: f64, below: f64| Figures {
            tir_pct: band(tir),
            below_70_pct: band(below),
        };
        Effect::Predicted(Predicted {
            days: 7,
            twin_revision: 3,
            grade: "fair".into(),
            in_force: f(70.0, 1.0),
            suggested: f(71.0, 1.0 + rise),
            change: f(1.0, rise),
        })
    }
}

async fn advice(svc: &Svc) -> Value {
    let id = svc.person("ann").await;
    let (_, t) = svc.token(id).await;
    let mut events = Vec::new();
    let mut seq = 0;
    for day in 0..9i64 {
        for m in (0..1440).step_by(5) {
            seq += 1;
            let g = 150.0 + 60.0 * ((m as f64) / 200.0).sin();
            events.push(cgm(seq, day * 1440 + m, g));
            if m == 0 && day > 0 {
                seq += 1;
                events.push(ev(seq, day * 1440, json!({"type": "day_closed"})));
            }
            if m == 750 {
                seq += 1;
                events.push(ev(
                    seq,
                    day * 1440 + m,
                    json!({"type": "meal", "carbs_g": 60, "slot": "lunch"}),
                ));
            }
        }
    }
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/events"),
            Some(&t),
            Some(&json!({ "events": events })),
        )
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
    let doc = svc
        .call(Method::GET, "/v1/openapi.json", Some(&svc.admin), None)
        .await
        .json;
    let schema = &doc["paths"]["/v1/persons/{id}/advice"]["get"]["responses"]["200"]["content"]
        ["application/json"]["schema"];
    let root = json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "components": doc["components"],
        "allOf": [schema],
    });
    let v = jsonschema::validator_for(&root).unwrap();
    let errors: Vec<String> = v.iter_errors(&r.json).map(|e| e.to_string()).collect();
    assert!(errors.is_empty(), "{errors:?}\n{}", r.text);
    r.json
}

fn with_effect(a: &Value) -> Vec<Value> {
    a["settings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["effect"].is_object())
        .cloned()
        .collect()
}

#[tokio::test]
async fn the_advice_holds_back_what_its_predictor_says_raises_lows() {
    let svc = Svc::with_effects(Some(EffectSource {
        predictor: Arc::new(Fixed { rise: 1.5 }),
        check: TwinCheck::default(),
    }));
    let a = advice(&svc).await;
    let open = with_effect(&a);
    assert!(!open.is_empty(), "an open suggestion: {a:#}");
    for s in &open {
        let e = &s["effect"];
        let rise = e["predicted"]["change"]["below_70_pct"]["value"]
            .as_f64()
            .unwrap();
        assert_eq!(e["predicted"]["twin_revision"], 3);
        assert_eq!(e["margin_pp"], 1.0);
        if rise > 1.0 {
            assert_eq!(e["twin_check"], "held_back", "{s:#}");
            assert_eq!(s["latest"]["status"], "held_back");
            assert_eq!(s["use_today"], s["in_force"], "{s:#}");
        } else {
            assert_eq!(e["twin_check"], "passed", "{s:#}");
            assert_eq!(s["latest"]["status"], "open");
            assert_eq!(s["use_today"], s["latest"]["value"], "{s:#}");
        }
    }
    assert!(
        open.iter().any(|s| s["latest"]["status"] == "held_back"),
        "high glucose: a suggestion adds insulin and is held back: {a:#}"
    );
    // The same with the check off: nothing held back, the figures stay.
    let svc = Svc::with_effects(Some(EffectSource {
        predictor: Arc::new(Fixed { rise: 1.5 }),
        check: TwinCheck {
            on: false,
            ..TwinCheck::default()
        },
    }));
    for s in with_effect(&advice(&svc).await) {
        assert_eq!(s["effect"]["twin_check"], "off");
        assert_eq!(s["latest"]["status"], "open");
    }
    // A rise within the margin passes.
    let svc = Svc::with_effects(Some(EffectSource {
        predictor: Arc::new(Fixed { rise: 1.0 }),
        check: TwinCheck::default(),
    }));
    for s in with_effect(&advice(&svc).await) {
        assert_eq!(s["effect"]["twin_check"], "passed");
    }
    // Without a predictor: no prediction, and why.
    let svc = Svc::new();
    for s in with_effect(&advice(&svc).await) {
        assert_eq!(s["effect"]["no_prediction"], "not_available");
        assert_eq!(s["effect"]["twin_check"], "no_prediction");
        assert!(s["effect"]["predicted"].is_null());
    }
}
