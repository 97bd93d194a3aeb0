//! The manifest: what ran (version, revision, seed, cohort, protocol, every
//! knob; built by whoever ran the trial, as JSON) and how the run went
//! ([`RunInfo`]). `summary.json` copies what ran only, so that it is
//! identical across reruns; `manifest.json` has both.

use serde::Serialize;
use serde_json::Value;

/// How one run went: recorded in `manifest.json` under `run`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RunInfo {
    /// Wall time of the simulation (s).
    pub wall_time_s: f64,
    /// Worker threads used.
    pub threads: usize,
    /// Patient-runs simulated (patients × scenarios × arms).
    pub patient_runs: usize,
}

/// `manifest` with `run` added under the key `run` (unchanged without one).
pub fn with_run(manifest: &Value, run: Option<&RunInfo>) -> Value {
    let mut m = manifest.clone();
    if let (Some(run), Some(obj)) = (run, m.as_object_mut()) {
        obj.insert(
            "run".to_string(),
            serde_json::json!({
                "wall_time_s": run.wall_time_s,
                "threads": run.threads,
                "patient_runs": run.patient_runs,
            }),
        );
    }
    m
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn run_facts_go_under_run_only() {
        let m = serde_json::json!({"seed": 1});
        assert_eq!(with_run(&m, None), m);
        let run = RunInfo {
            wall_time_s: 2.5,
            threads: 2,
            patient_runs: 12,
        };
        let with = with_run(&m, Some(&run));
        assert_eq!(with["seed"], 1);
        assert_eq!(with["run"]["wall_time_s"], 2.5);
        assert_eq!(with["run"]["threads"], 2);
        assert_eq!(with["run"]["patient_runs"], 12);
    }
}
