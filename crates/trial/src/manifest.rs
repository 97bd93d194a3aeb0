//! The trial's manifest (`manifest.json`, and the copy inside
//! `summary.json`): tool, version, revision, seed, cohort, protocol, TE
//! calibration and every knob. Built from a finished trial alone, so a
//! single run, merged shards and the Python package write the same one.

use crate::protocol::{ArmKind, TrialConfig};
use crate::runner::TrialOutput;
use serde_json::{json, Value};

/// The manifest of `output`, as written by `abba trial` without its `run`
/// section (wall time, threads), which differs between runs and is added by
/// the caller to `manifest.json` only. `version` and `git_revision` name the
/// build that ran it.
pub fn manifest(output: &TrialOutput, version: &str, git_revision: &str) -> Value {
    let used = &output.config;
    json!({
        "tool": "abba",
        "version": version,
        "git_revision": git_revision,
        "seed": used.seed,
        "cohort": {
            "population": used.population,
            "patients": output.cohort.patients.len(),
            "seed": used.cohort_seed,
            "rejected_candidates": output.cohort.rejections,
        },
        "protocol": {
            "days": used.days,
            "warm_up_days": 1,
            "init_days": used.init_days,
            "scenarios": used.scenarios,
            "arms": used.arms,
            "modes": used.planned().iter().map(|s| (s.id.name(), s.mode.name())).collect::<std::collections::BTreeMap<_, _>>(),
            "advisors_run": advisors_run(used),
            "evaluation": "plasma glucose G = Gp/Vg every 5 min; W1 = D2-D8, W13 = D84-D90, W14 = D92-D98; weekly Wk = D(7k-5)..D(7k+1)",
        },
        "te_calibration": {
            "calibrated": used.calibrate_te_ref && used.arms.contains(&ArmKind::Abba),
            "te_ref_bits_cgm": used.abba.te.te_ref_bits,
            "te_ref_bits_smbg": used.te_ref_bits_smbg.unwrap_or(used.abba.te.te_ref_bits),
            "how": "median over the cohort of ABBA's own first-week TE estimate in each mode (spec §7.3)",
            "first_week_te_bits": output.first_week_te_bits,
        },
        "knobs": used,
    })
}

/// What each arm ran in each mode, with the knobs the trial set (ABBA's
/// exploration seed is derived per patient).
fn advisors_run(used: &TrialConfig) -> Value {
    let mut out = serde_json::Map::new();
    for p in used.planned() {
        let mode = p.mode.name().to_string();
        if out.contains_key(&mode) {
            continue;
        }
        let arms: serde_json::Map<_, _> = used
            .arms
            .iter()
            .map(|a| (a.name().to_string(), json!(used.advisor_spec(*a, p.mode))))
            .collect();
        out.insert(mode, Value::Object(arms));
    }
    out.insert(
        "exploration_seed".into(),
        json!("derive_seed(seed, patient number, scenario random_key, exploration), per patient"),
    );
    Value::Object(out)
}
