//! What `POST /v1/persons` and `PUT .../bounds` accept: names without
//! control characters, escape sequences or hidden characters, trimmed,
//! composed (NFC), unique ignoring case and not looking like another
//! person's; the starting therapy and the bounds within the
//! plausibility limits of `abba_core::limits` (the CLI's), each refusal
//! naming the field and the range.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use axum::http::{Method, StatusCode};
use common::Svc;
use serde_json::{json, Value};

fn body(name: &str) -> Value {
    json!({
        "name": name, "tz": "UTC", "mode": "cgm",
        "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
    })
}

async fn create(svc: &Svc, b: &Value) -> common::Resp {
    svc.call(Method::POST, "/v1/persons", Some(&svc.admin), Some(b))
        .await
}

#[tokio::test]
async fn names_with_control_or_hidden_characters_are_refused() {
    let svc = Svc::new();
    for bad in [
        "ana\nbob",
        "ana\rbob",
        "tab\there",
        "\u{1b}[31mred\u{1b}[0m",
        "\u{1b}]0;title\u{7}",
        "del\u{7f}",
        "c1\u{9b}31m",
        "nul\u{0}",
        "rtl\u{202e}gnp.exe",
        "zero\u{200b}width",
        // Format characters, tags, variation selectors, fillers, blanks,
        // separators (the security probe's).
        "bob\u{e0020}",
        "ana\u{ad}",
        "ana\u{34f}",
        "x\u{61c}ALM",
        "\u{3164}",
        "\u{ad}",
        "\u{2800}",
        "\u{115f}\u{1160}",
        "x\u{2028}y",
        "x\u{fff9}y",
        "x\u{180e}y",
        "x\u{fe0f}y",
        "\u{301}ana",
    ] {
        let r = create(&svc, &body(bad)).await;
        assert_eq!(
            r.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{bad:?}: {}",
            r.text
        );
        assert_eq!(r.json["path"], "name", "{bad:?}: {}", r.text);
        let m = r.json["message"].as_str().unwrap();
        assert!(
            m.contains("character") && m.contains("\\u{"),
            "{bad:?}: {m}"
        );
        // The answer never carries the raw character back.
        assert!(
            !r.text.contains('\u{1b}') && !r.text.contains('\n'),
            "{}",
            r.text
        );
    }
    for empty in ["", "   ", "\u{3000}"] {
        let r = create(&svc, &body(empty)).await;
        assert_eq!(
            r.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{empty:?}: {}",
            r.text
        );
        assert_eq!(r.json["path"], "name");
    }
    let long = "x".repeat(201);
    let r = create(&svc, &body(&long)).await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    // 200 characters of more than one byte each are fine.
    let r = create(&svc, &body(&"é".repeat(200))).await;
    assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
}

#[tokio::test]
async fn names_are_trimmed_and_unique_ignoring_case() {
    let svc = Svc::new();
    let r = create(&svc, &body("  Ana María \t")).await;
    assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
    assert_eq!(r.json["name"], "Ana María");
    for same in ["ana maría", "ANA MARÍA", " Ana María"] {
        let r = create(&svc, &body(same)).await;
        assert_eq!(r.status, StatusCode::CONFLICT, "{same:?}: {}", r.text);
        assert_eq!(r.json["path"], "name");
        let m = r.json["message"].as_str().unwrap();
        assert!(
            m.contains("\"Ana María\"") && m.contains("ignoring case"),
            "{m}"
        );
    }
    // The stored name is the trimmed one (the CLI finds it by it).
    let store = abba_store::Store::open(&svc.db).unwrap();
    assert_eq!(store.persons().unwrap(), vec!["Ana María".to_string()]);
    let r = create(&svc, &body("Ana Maria")).await;
    assert_eq!(r.status, StatusCode::CREATED, "another name: {}", r.text);
    // Folding that crosses into ASCII: the Kelvin sign is a K.
    let r = create(&svc, &body("kim")).await;
    assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
    let r = create(&svc, &body("\u{212a}IM")).await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
    let r = create(&svc, &body("\u{212a}elvin")).await;
    assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
    let r = create(&svc, &body("KELVIN")).await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
}

#[tokio::test]
async fn names_are_stored_composed_and_look_alikes_are_refused() {
    let svc = Svc::new();
    for name in ["ana", "Ana\u{301}l"] {
        let r = create(&svc, &body(name)).await;
        assert_eq!(r.status, StatusCode::CREATED, "{name:?}: {}", r.text);
    }
    // Stored composed (NFC): "a" and a combining acute became "á".
    let store = abba_store::Store::open(&svc.db).unwrap();
    assert!(store.persons().unwrap().contains(&"An\u{e1}l".to_string()));
    let r = create(&svc, &body("an\u{e1}l")).await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
    // Cyrillic "а", fullwidth "ａ": they look like "ana".
    for look_alike in ["\u{430}na", "\u{ff41}na"] {
        let r = create(&svc, &body(look_alike)).await;
        assert_eq!(r.status, StatusCode::CONFLICT, "{look_alike:?}: {}", r.text);
        assert_eq!(r.json["path"], "name");
        let m = r.json["message"].as_str().unwrap();
        assert!(m.contains("looks like") && m.contains("\"ana\""), "{m}");
    }
}

#[tokio::test]
async fn the_starting_therapy_and_bounds_are_checked_against_the_limits() {
    let svc = Svc::new();
    let cases = [
        (
            json!({"basal_units_per_hour": 1e300, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}),
            "start.basal_units_per_hour",
            "35",
        ),
        (
            json!({"basal_units_per_hour": 0.001, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}),
            "start.basal_units_per_hour",
            "0.025",
        ),
        (
            json!({"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 1e300, 11.0]}),
            "start.carb_ratio_g_per_unit[1]",
            "150",
        ),
        (
            json!({"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 0.5]}),
            "start.carb_ratio_g_per_unit[2]",
            "between 1 and 150",
        ),
    ];
    for (start, path, range) in cases {
        let mut b = body("p");
        b["start"] = start.clone();
        let r = create(&svc, &b).await;
        assert_eq!(
            r.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{start}: {}",
            r.text
        );
        assert_eq!(r.json["path"], path, "{start}: {}", r.text);
        let m = r.json["message"].as_str().unwrap();
        assert!(m.contains(range), "{start}: {m}");
    }
    let bounds = [
        (
            json!({"basal": {"min": 0.5, "max": 1e300}}),
            "bounds.basal.max",
        ),
        (
            json!({"basal": {"min": 0.0, "max": 2.0}}),
            "bounds.basal.min",
        ),
        (
            json!({"lunch": {"min": 8.0, "max": 400.0}}),
            "bounds.lunch.max",
        ),
        (
            json!({"dinner": {"min": 14.0, "max": 8.0}}),
            "bounds.dinner",
        ),
    ];
    for (bd, path) in &bounds {
        let mut b = body("p");
        b["bounds"] = bd.clone();
        let r = create(&svc, &b).await;
        assert_eq!(
            r.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{bd}: {}",
            r.text
        );
        assert_eq!(r.json["path"], *path, "{bd}: {}", r.text);
    }
    // Nothing was created; the same checks hold for PUT .../bounds.
    let store = abba_store::Store::open(&svc.db).unwrap();
    assert!(store.persons().unwrap().is_empty());
    let id = svc.person("alice").await;
    for (bd, path) in &bounds {
        let r = svc
            .call(
                Method::PUT,
                &format!("/v1/persons/{id}/bounds"),
                Some(&svc.admin),
                Some(&json!({"bounds": bd})),
            )
            .await;
        assert_eq!(
            r.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{bd}: {}",
            r.text
        );
        assert_eq!(r.json["path"], *path, "{bd}: {}", r.text);
    }
}

/// `age_group`: the group's defaults in the stored advisor configuration
/// (default adult); an unknown group, or a group beside a full advisor
/// configuration, refused naming the field.
#[tokio::test]
async fn an_age_group_chooses_the_advisors_defaults_and_an_unknown_one_is_refused() {
    let svc = Svc::new();
    let mut b = body("kid");
    b["age_group"] = json!("child");
    let r = create(&svc, &b).await;
    assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
    let r = create(&svc, &body("grown-up")).await;
    assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
    let store = abba_service::open_store(&svc.db).unwrap();
    let kid = store.person("kid").unwrap();
    assert_eq!(kid.settings.age_group, abba_advisor::AgeGroup::Child);
    assert_eq!(
        kid.settings.advisor.features.cgm_basal_window_min,
        Some([120, 420])
    );
    assert_eq!(
        kid.settings.advisor.features.smbg_basal_window_min,
        Some([0, 450])
    );
    let adult = store.person("grown-up").unwrap();
    assert_eq!(adult.settings.age_group, abba_advisor::AgeGroup::Adult);
    assert_eq!(adult.settings.advisor.features.cgm_basal_window_min, None);
    drop(store);

    let mut b = body("toddler");
    b["age_group"] = json!("toddler");
    let r = create(&svc, &b).await;
    assert_eq!(r.status, StatusCode::BAD_REQUEST, "{}", r.text);
    assert_eq!(r.json["path"], "age_group", "{}", r.text);
    let m = r.json["message"].as_str().unwrap();
    assert!(m.contains("toddler") && m.contains("child"), "{m}");

    let mut b = body("both");
    b["age_group"] = json!("adolescent");
    b["advisor"] =
        serde_json::to_value(abba_advisor::AbbaConfig::new(abba_advisor::Mode::Cgm, 1)).unwrap();
    let r = create(&svc, &b).await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    assert_eq!(r.json["path"], "age_group", "{}", r.text);
    assert!(r.text.contains("not both"), "{}", r.text);
    let store = abba_service::open_store(&svc.db).unwrap();
    assert!(store.person("toddler").is_err() && store.person("both").is_err());
}
