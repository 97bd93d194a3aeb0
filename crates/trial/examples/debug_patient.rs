//! One patient in one scenario and arm: every decision with its
//! explanation, then the settings every week.
//! `cargo run --release -p abba-trial --example debug_patient -- [patient index] [days] [arm] [scenario]`

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::scenario::ScenarioId;
use abba_trial::closed_loop::run_patient;
use abba_trial::runner::build_cohort;
use abba_trial::{ArmKind, TrialConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let who: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    let days: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(35);
    let arm: ArmKind = args
        .get(3)
        .map(|s| s.parse().unwrap())
        .unwrap_or(ArmKind::Abba);
    let config = TrialConfig {
        patients: (who + 1) as u32,
        days,
        ..TrialConfig::default()
    };
    let cohort = build_cohort(&config)?;
    let vp = &cohort.patients[who];
    println!("{} start {:?}", vp.params.name, vp.therapy);
    {
        let sid: ScenarioId = args
            .get(4)
            .map(|s| s.parse().unwrap())
            .unwrap_or(ScenarioId::S1);
        let sc = config.scenario(sid);
        let mut trace = abba_trial::closed_loop::Trace {
            events: None,
            decisions: Some(Vec::new()),
        };
        let r = abba_trial::closed_loop::run_patient_with(
            &config,
            vp,
            who as u64 + 1,
            &sc,
            arm,
            &mut trace,
        );
        for d in trace.decisions.unwrap_or_default() {
            let extra = match &d.detail {
                abba_advisor::decision::DecisionDetail::Abba(x) => format!(
                    "F=({:.3},{:.3}) Pa={:.4} Ps={:.4} Pe={:.4} theta={:?} d={:?}",
                    x.features.hyper,
                    x.features.hypo,
                    x.action.p_a,
                    x.action.p_s,
                    x.action.p_e,
                    x.learning.theta_after,
                    x.learning.td_error
                ),
                other => format!("{other:?}"),
            };
            println!("{d} {extra}");
        }
        println!("{:?}", r.map(|r| r.min_glucose_mg_dl));
    }
    for d in (9..=days).step_by(7) {
        let mut c = config.clone();
        c.days = d;
        let sc = c.scenario(
            args.get(4)
                .map(|s| s.parse().unwrap())
                .unwrap_or(ScenarioId::S1),
        );
        match run_patient(&c, vp, who as u64 + 1, &sc, arm) {
            Ok(r) => println!(
                "day {d}: basal {:.3} CR {:.2} {:.2} {:.2} min G {:.1}",
                r.final_basal_u_per_h,
                r.final_carb_ratio_g_per_u[0],
                r.final_carb_ratio_g_per_u[1],
                r.final_carb_ratio_g_per_u[2],
                r.min_glucose_mg_dl
            ),
            Err(e) => println!("day {d}: {e}"),
        }
    }
    Ok(())
}
