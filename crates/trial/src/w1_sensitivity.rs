//! The W1 sensitivity block: where our standard-therapy week differs from
//! the paper's, and why. The standard arm's W1 (D2-D8) is re-run with each
//! source of variability switched off in turn (dawn phenomenon, day-to-day
//! insulin sensitivity, carb-counting error, both sensitivity sources), and
//! with s(t) scaling Vmx only instead of Vmx and kp3.

use crate::closed_loop::run_patient_group;
use crate::error::TrialError;
use crate::protocol::{ArmKind, PlannedScenario, TrialConfig};
use crate::results::PatientResult;
use abba_sim::cohort::Cohort;
use abba_sim::scenario::{ScenarioConfig, ScenarioId, SensitivityTarget};
use rayon::prelude::*;
use serde::Serialize;

/// One variant of the W1 block.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct W1Row {
    /// What was switched off or changed.
    pub variant: String,
    /// Patients whose W1 was evaluated.
    pub n: usize,
    /// Mean % time in 70-180 mg/dL.
    pub tir: f64,
    /// Mean % time below 70 mg/dL.
    pub below_70: f64,
    /// Mean % time above 180 mg/dL.
    pub above_180: f64,
    /// Mean LBGI.
    pub lbgi: f64,
    /// Mean HBGI.
    pub hbgi: f64,
}

/// How a variant changes the scenario.
pub type Change = fn(&mut ScenarioConfig);

/// The variants: (label, how the scenario is changed).
pub fn variants() -> Vec<(&'static str, Change)> {
    vec![
        ("as configured", |_| {}),
        ("no dawn phenomenon", |s| s.sensitivity.dawn_factor = 1.0),
        ("no day-to-day SI variability", |s| {
            s.sensitivity.daily_factor_min = 1.0;
            s.sensitivity.daily_factor_max = 1.0;
        }),
        ("no SI variability (neither source)", |s| {
            s.sensitivity.dawn_factor = 1.0;
            s.sensitivity.daily_factor_min = 1.0;
            s.sensitivity.daily_factor_max = 1.0;
        }),
        ("no carb-counting error", |s| {
            s.meals.announce_factor_min = 1.0;
            s.meals.announce_factor_max = 1.0;
        }),
        ("s(t) on Vmx only", |s| {
            s.sensitivity.target = SensitivityTarget::Vmx;
        }),
    ]
}

/// Runs the standard arm's W1 of `scenario` for every variant on the
/// trial's `cohort` (only the first 9 days are simulated).
pub fn w1_sensitivity(
    config: &TrialConfig,
    cohort: &Cohort,
    scenario: ScenarioId,
) -> Result<Vec<W1Row>, TrialError> {
    w1_sensitivity_with(config, cohort, scenario, None)
}

/// [`w1_sensitivity`], taking the first variant ("as configured") from
/// `configured`, the trial's own standard-arm results in `scenario` (one
/// per patient of `cohort`, in order), when given: a run's first nine days
/// do not depend on how many days follow (the day plans are drawn day by
/// day, the loop never looks ahead), so its W1 is that variant's.
pub fn w1_sensitivity_with(
    config: &TrialConfig,
    cohort: &Cohort,
    scenario: ScenarioId,
    configured: Option<&[PatientResult]>,
) -> Result<Vec<W1Row>, TrialError> {
    let configured = configured.filter(|c| c.len() == cohort.patients.len());
    let mut planned = Vec::new();
    for (label, change) in variants() {
        let mut s = config.scenario(scenario);
        change(&mut s);
        s.days = 2 + config.init_days;
        s.validate()
            .map_err(|e| TrialError::Config(format!("W1 block, {label}: {e}")))?;
        planned.push(PlannedScenario {
            id: scenario,
            mode: TrialConfig::mode_for(&s),
            config: s,
        });
    }
    // Each patient's variants run together in lock-step: they eat the same
    // (the variants change insulin sensitivity and carb counting, not the
    // meals), so they share the patient model's gut work
    // (`run_patient_group`; the results are those of one run at a time).
    let skip = usize::from(configured.is_some());
    let runs: Vec<_> = planned
        .iter()
        .skip(skip)
        .map(|p| (p, ArmKind::Standard))
        .collect();
    let per_patient: Vec<Vec<_>> = cohort
        .patients
        .par_iter()
        .enumerate()
        .map(|(i, vp)| {
            let mut r = run_patient_group(config, vp, i as u64 + 1, &runs)?;
            if let Some(c) = configured {
                r.insert(0, c[i].clone());
            }
            Ok(r)
        })
        .collect::<Result<_, TrialError>>()?;
    let mut rows = Vec::new();
    for (v, (label, _)) in variants().into_iter().enumerate() {
        let w1: Vec<_> = per_patient
            .iter()
            .filter_map(|r| r[v].week(crate::results::Week::W1))
            .map(|w| w.metrics)
            .collect();
        let n = w1.len();
        let mean = |f: &dyn Fn(&abba_core::metrics::GlucoseMetrics) -> f64| {
            w1.iter().map(f).sum::<f64>() / n.max(1) as f64
        };
        rows.push(W1Row {
            variant: label.to_string(),
            n,
            tir: mean(&|m| m.tir_70_180),
            below_70: mean(&|m| m.below_70),
            above_180: mean(&|m| m.above_180),
            lbgi: mean(&|m| m.lbgi),
            hbgi: mean(&|m| m.hbgi),
        });
    }
    Ok(rows)
}

/// The block as Markdown, beside the paper's W1.
pub fn w1_markdown(scenario: ScenarioId, rows: &[W1Row]) -> String {
    let mut s = format!(
        "## W1 sensitivity ({scenario}, standard therapy, D2-D8)\n\n\
         Each row re-runs the standard-therapy week with one source of variability switched off \
         (or s(t) applied to Vmx only). The paper's W1: TIR 89.9 ± 8.7 %, time below 70 mg/dL \
         4.0 % (hypo 2.5 + severe 1.5), above 180 mg/dL 6.1 %.\n\n\
         | variant | n | TIR % | <70 % | >180 % | LBGI | HBGI |\n|---|---:|---:|---:|---:|---:|---:|\n"
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {:.1} | {:.2} | {:.1} | {:.2} | {:.2} |\n",
            r.variant, r.n, r.tir, r.below_70, r.above_180, r.lbgi, r.hbgi
        );
    }
    s
}

/// The W1 block of a trial's report (`w1_sensitivity.md` and its section
/// of `report.html`), on the first scenario of the trial and its own
/// cohort; `None` when the trial has no scenario.
pub fn w1_block(
    output: &crate::runner::TrialOutput,
) -> Result<Option<abba_report::W1Block>, TrialError> {
    let Some(&first) = output.config.scenarios.first() else {
        return Ok(None);
    };
    let configured = output
        .arms
        .iter()
        .find(|a| a.scenario == first && a.advisor == ArmKind::Standard)
        .map(|a| a.patients.as_slice());
    let rows = w1_sensitivity_with(&output.config, &output.cohort, first, configured)?;
    Ok(Some(abba_report::W1Block {
        markdown: w1_markdown(first, &rows),
        section: w1_html_section(first, &rows),
    }))
}

/// The block as a section of `report.html`.
pub fn w1_html_section(scenario: ScenarioId, rows: &[W1Row]) -> abba_report::html::HtmlSection {
    use abba_report::html::Row;
    abba_report::html::HtmlSection {
        title: format!("W1 sensitivity ({scenario}, standard therapy, D2-D8)"),
        note: "Each row re-runs the standard-therapy week with one source of variability \
               switched off (or s(t) applied to Vmx only). The paper's W1: TIR 89.9 ± 8.7 %, \
               time below 70 mg/dL 4.0 %, above 180 mg/dL 6.1 %."
            .to_string(),
        headers: ["Variant", "n", "TIR %", "<70 %", ">180 %", "LBGI", "HBGI"]
            .map(String::from)
            .to_vec(),
        rows: rows
            .iter()
            .map(|r| {
                Row::of([
                    &r.variant,
                    &r.n.to_string(),
                    &format!("{:.1}", r.tir),
                    &format!("{:.2}", r.below_70),
                    &format!("{:.1}", r.above_180),
                    &format!("{:.2}", r.lbgi),
                    &format!("{:.2}", r.hbgi),
                ])
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_variant_changes_what_it_names() {
        let base = ScenarioConfig::paper(ScenarioId::S1);
        for (label, change) in variants().into_iter().skip(1) {
            let mut s = base.clone();
            change(&mut s);
            assert_ne!(s, base, "{label} changed nothing");
            s.validate().unwrap();
        }
    }

    #[test]
    fn switching_off_variability_changes_w1_of_the_standard_arm() {
        let config = TrialConfig::try_from(crate::protocol::RawTrialConfig {
            patients: 3,
            ..Default::default()
        })
        .unwrap();
        let cohort = crate::runner::build_cohort(&config).unwrap();
        let rows = w1_sensitivity(&config, &cohort, ScenarioId::S1).unwrap();
        assert_eq!(rows.len(), variants().len());
        assert!(rows.iter().all(|r| r.n == 3));
        // Each change alters the simulated week of the same patients.
        for r in &rows[1..] {
            assert!(
                (r.tir - rows[0].tir).abs() > 1e-9 || (r.hbgi - rows[0].hbgi).abs() > 1e-9,
                "{} gave the same W1 as the configured scenario",
                r.variant
            );
        }
        assert!(w1_markdown(ScenarioId::S1, &rows).contains("s(t) on Vmx only"));
    }

    /// The trial's own standard-arm runs stand in for the first variant:
    /// the block of a trial equals the one simulated from scratch.
    #[test]
    fn the_trials_standard_arm_is_the_configured_variant() {
        let config = TrialConfig::try_from(crate::protocol::RawTrialConfig {
            patients: 3,
            days: 12,
            scenarios: vec![ScenarioId::S1],
            arms: vec![ArmKind::Standard],
            ..Default::default()
        })
        .unwrap();
        let output = crate::runner::run_trial(&config, 1, &crate::runner::Silent).unwrap();
        let scratch = w1_sensitivity(&config, &output.cohort, ScenarioId::S1).unwrap();
        let block = w1_block(&output).unwrap().unwrap();
        assert_eq!(block.markdown, w1_markdown(ScenarioId::S1, &scratch));
        assert!(scratch.iter().all(|r| r.n == 3));
    }
}
