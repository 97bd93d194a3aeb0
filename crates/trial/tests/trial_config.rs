//! The trial configuration is checked in one step at the door: one test per
//! defect the review found (each failed before its fix).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_advisor::any::AdvisorSpec;
use abba_advisor::Mode;
use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::RawTrialConfig;
use abba_trial::{ArmKind, TrialConfig};
use serde_json::{json, Value};

/// The default configuration as JSON, edited by `f`, read back and checked.
fn edited(f: impl FnOnce(&mut Value)) -> Result<TrialConfig, String> {
    let mut v = serde_json::to_value(RawTrialConfig::default()).unwrap();
    f(&mut v);
    TrialConfig::from_json(&v.to_string()).map_err(|e| e.to_string())
}

fn refused(f: impl FnOnce(&mut Value), expect: &[&str]) {
    let e = edited(f).expect_err("the configuration should be refused");
    for x in expect {
        assert!(e.contains(x), "expected '{x}' in: {e}");
    }
}

#[test]
fn the_default_configuration_reads_back() {
    let c = edited(|_| {}).unwrap();
    assert_eq!(c, TrialConfig::paper().unwrap());
}

#[test]
fn unknown_top_level_field_is_refused() {
    refused(|v| v["patinets"] = json!(5), &["unknown field `patinets`"]);
}

#[test]
fn misspelled_smbg_te_reference_is_refused() {
    refused(
        |v| v["te_ref_bits_smgb"] = json!(0.01),
        &["unknown field `te_ref_bits_smgb`"],
    );
}

#[test]
fn unknown_nested_fields_are_refused_at_every_level() {
    refused(
        |v| v["abba"]["critic"]["gama"] = json!(0.9),
        &["abba", "unknown field `gama`"],
    );
    refused(
        |v| v["devices"]["pump"]["max_bolus"] = json!(30.0),
        &["unknown field `max_bolus`"],
    );
    refused(
        |v| {
            let mut s =
                serde_json::to_value(abba_sim::scenario::ScenarioConfig::paper(ScenarioId::S2))
                    .unwrap();
            s["meals"]["meals"][0]["annnounced"] = json!(true);
            v["scenario_overrides"] = json!([s]);
        },
        &["unknown field `annnounced`"],
    );
}

#[test]
fn bad_nested_advisor_values_fail_at_the_door() {
    refused(
        |v| v["abba"]["critic"]["gamma"] = json!(5),
        &["abba", "critic.gamma"],
    );
    refused(
        |v| v["r2r"]["basal_cap"] = json!(0.9),
        &["r2r", "basal_cap"],
    );
    refused(
        |v| v["fixed_limits"]["bolus_max_u"] = json!(-1),
        &["fixed_limits", "bolus_max_u"],
    );
}

#[test]
fn a_byte_order_mark_is_allowed() {
    let text = format!(
        "\u{feff}{}",
        serde_json::to_string(&RawTrialConfig::default()).unwrap()
    );
    assert_eq!(
        TrialConfig::from_json(&text).unwrap(),
        TrialConfig::paper().unwrap()
    );
}

#[test]
fn the_cgm_period_is_set_once_by_the_sensor() {
    // The old fields are gone.
    refused(
        |v| v["devices"]["cgm_sample_time_min"] = json!(3),
        &["unknown field `cgm_sample_time_min`"],
    );
    refused(
        |v| {
            let mut s =
                serde_json::to_value(abba_sim::scenario::ScenarioConfig::paper(ScenarioId::S1))
                    .unwrap();
            s["cgm"]["period_min"] = json!(5);
            v["scenario_overrides"] = json!([s]);
        },
        &["unknown field `period_min`"],
    );
    // A period the sensor model cannot produce is refused.
    refused(
        |v| v["devices"]["cgm"]["sample_time_min"] = json!(7),
        &["devices", "sample_time"],
    );
    // A valid one is used by everything that needs it.
    let c = edited(|v| v["devices"]["cgm"]["sample_time_min"] = json!(3)).unwrap();
    let AdvisorSpec::RunToRun(r2r) = c.advisor_spec(ArmKind::R2r, Mode::Cgm) else {
        panic!("not r2r")
    };
    assert_eq!(r2r.cgm_interval_min, 3.0);
}

#[test]
fn knobs_the_trial_sets_are_not_in_the_configuration() {
    let v = serde_json::to_value(RawTrialConfig::default()).unwrap();
    for (section, key) in [
        ("abba", "mode"),
        ("abba", "init_days"),
        ("abba", "exploration_seed"),
        ("r2r", "mode"),
        ("r2r", "init_days"),
        ("r2r", "cgm_interval_min"),
    ] {
        assert!(v[section].get(key).is_none(), "{section}.{key} is printed");
        refused(
            |v| v[section][key] = json!(7),
            &[&format!("{section}.{key} is set by the trial")],
        );
    }
    // What runs has them, set by the trial.
    let c = TrialConfig::paper().unwrap();
    for mode in [Mode::Cgm, Mode::Smbg] {
        match c.advisor_spec(ArmKind::Abba, mode) {
            AdvisorSpec::Abba(a) => {
                assert_eq!(a.mode, mode);
                assert_eq!(a.init_days, c.init_days);
            }
            _ => panic!("not abba"),
        }
    }
}

#[test]
fn scenario_overrides_must_match_what_runs() {
    let s3 =
        serde_json::to_value(abba_sim::scenario::ScenarioConfig::paper(ScenarioId::S3)).unwrap();
    let mut short = s3.clone();
    short["days"] = json!(30);
    refused(
        |v| v["scenario_overrides"] = json!([short]),
        &["scenario_overrides[0].days is 30", "98"],
    );
    let mut unknown = s3.clone();
    unknown["name"] = json!("S9");
    refused(
        |v| v["scenario_overrides"] = json!([unknown]),
        &["'S9' is not a scenario"],
    );
    refused(
        |v| {
            v["scenarios"] = json!(["S1", "S2"]);
            v["scenario_overrides"] = json!([s3]);
        },
        &["overrides S3", "not among the scenarios run"],
    );
}

#[test]
fn the_plan_resolves_every_scenario_with_its_mode() {
    let c = TrialConfig::paper().unwrap();
    let modes: Vec<_> = c.planned().iter().map(|p| (p.id, p.mode)).collect();
    assert_eq!(
        modes,
        vec![
            (ScenarioId::S1, Mode::Cgm),
            (ScenarioId::S2, Mode::Smbg),
            (ScenarioId::S3, Mode::Smbg),
            (ScenarioId::S4, Mode::Smbg)
        ]
    );
    assert!(c.planned().iter().all(|p| p.config.days == c.days));
}

/// The autotune arm is opt-in: the default plan has no autotune section
/// (so a default trial's files are what they were before the arm); with the
/// arm the checked plan fills in oref0's defaults without the knobs the
/// trial sets, and setting one of those is refused naming who sets it.
#[test]
fn the_autotune_arm_is_opt_in_and_its_section_leaves_out_what_the_trial_sets() {
    let paper = TrialConfig::paper().unwrap();
    assert_eq!(paper.arms, ArmKind::DEFAULT.to_vec());
    let v = serde_json::to_value(&paper).unwrap();
    assert!(v.get("autotune").is_none(), "{v}");
    let with = edited(|v| v["arms"] = json!(["abba", "standard", "r2r", "autotune"])).unwrap();
    let v = serde_json::to_value(&with).unwrap();
    let section = v["autotune"].as_object().unwrap();
    assert!(section.contains_key("autosens_max") && section.contains_key("dia_h"));
    assert!(!section.contains_key("mode") && !section.contains_key("init_days"));
    // Every arm runs with the trial's mode and first week.
    let planned = &with.planned()[0];
    let AdvisorSpec::Autotune(c) = with.advisor_spec(ArmKind::Autotune, planned.mode) else {
        panic!("not autotune")
    };
    assert_eq!((c.mode, c.init_days), (planned.mode, with.init_days));
    // It reads back as written.
    let back = TrialConfig::from_json(&v.to_string()).unwrap();
    assert_eq!(back, with);
    refused(
        |v| {
            v["arms"] = json!(["autotune"]);
            v["autotune"] = json!({"init_days": 3});
        },
        &["autotune.init_days", "set by the trial"],
    );
    // Every knob of the section is required and checked.
    let full = Value::Object(section.clone());
    let mut partial = full.clone();
    partial.as_object_mut().unwrap().remove("dia_h");
    refused(
        |v| {
            v["arms"] = json!(["autotune"]);
            v["autotune"] = partial;
        },
        &["autotune", "missing field `dia_h`"],
    );
    let mut wide = full;
    wide["autosens_max"] = json!(9.0);
    refused(
        |v| {
            v["arms"] = json!(["autotune"]);
            v["autotune"] = wide;
        },
        &["autotune", "autosens_max"],
    );
}

/// The abba-twin arm is opt-in like autotune: no `twin_check` section in
/// the default plan, its defaults filled in when the arm runs, and a bad
/// value refused at the door naming the field.
#[test]
fn the_twin_arm_is_opt_in_and_its_section_is_checked() {
    let v = serde_json::to_value(TrialConfig::paper().unwrap()).unwrap();
    assert!(v.get("twin_check").is_none(), "{v}");
    let with = edited(|v| v["arms"] = json!(["abba", "abba-twin"])).unwrap();
    let v = serde_json::to_value(&with).unwrap();
    assert_eq!(v["twin_check"]["fit_days"], json!(14), "{v}");
    assert_eq!(v["twin_check"]["margin_pp"], json!(1.0), "{v}");
    // It runs ABBA's knobs.
    assert_eq!(
        with.advisor_spec(ArmKind::AbbaTwin, Mode::Cgm),
        with.advisor_spec(ArmKind::Abba, Mode::Cgm)
    );
    for (field, value, expect) in [
        ("replay_days", json!(0), "twin_check.replay_days"),
        ("fit_days", json!(3), "twin_check.fit_days"),
        ("margin_pp", json!(-1.0), "twin_check.margin_pp"),
    ] {
        refused(
            |v| {
                v["arms"] = json!(["abba-twin"]);
                v["twin_check"] = json!({
                    "fit_days": 14, "refit_every_days": 7, "replay_days": 7, "margin_pp": 1.0
                });
                v["twin_check"][field] = value;
            },
            &[expect],
        );
    }
    refused(
        |v| {
            v["arms"] = json!(["abba-twin"]);
            v["twin_check"] = json!({"fit_days": 14, "refit_every_days": 7, "replay_days": 7,
                                     "margin_pp": 1.0, "margin": 2});
        },
        &["unknown field `margin`"],
    );
}
