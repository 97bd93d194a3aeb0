//! The full sample of the twin's test that matters (BENCHMARKS.md, "The
//! twin"): `--per-group N` members of each population (adults, adolescents,
//! children; members 11.. are generated), each simulated for 15 days in
//! scenario S1 under standard therapy, exported as Nightscout, imported
//! into a store, fitted from the last 14 days (12 fitted, 2 held out), and
//! its what-ifs (basal +10 %, carb ratios +10 %) on the last 7 days compared
//! with the same person living those days under those settings.
//!
//! `cargo run --release -p abba-twin --example twin_recovery -- --per-group 10`
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[path = "../tests/common/mod.rs"]
mod common;

use abba_sim::cohort::Population;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let per_group: u32 = args
        .iter()
        .position(|a| a == "--per-group")
        .and_then(|i| args.get(i + 1))
        .map(|v| v.parse().expect("--per-group N"))
        .unwrap_or(10);
    let first: u32 = args
        .iter()
        .position(|a| a == "--first")
        .and_then(|i| args.get(i + 1))
        .map(|v| v.parse().expect("--first N"))
        .unwrap_or(11);
    println!("member,grade,held_out_rmse,held_out_mard,mean_glucose_rmse,oracle_rmse,fit_rmse,basal_need_fit,basal_need_true,gb_fit,gb_true,found_meals,simulations,fit_s,basal_dtir_pred,basal_dtir_true,basal_dtbr_pred,basal_dtbr_true,cr_dtir_pred,cr_dtir_true,cr_dtbr_pred,cr_dtbr_true");
    let mut all = Vec::new();
    for pop in Population::ALL {
        for n in first..first + per_group {
            let o = common::member(pop, n);
            let w = &o.what_if;
            println!(
                "{},{},{:.1},{:.1},{:.1},{:.1},{:.1},{:.3},{:.3},{:.1},{:.1},{},{},{:.1},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2}",
                o.name, o.grade.name(), o.held_out.0, o.held_out.1, o.held_out.2, o.oracle_rmse, o.fit_rmse,
                o.basal_need.0, o.basal_need.1, o.basal_glucose.0, o.basal_glucose.1, o.found_meals,
                o.simulations, o.fit_seconds,
                w[0].1[0], w[0].2[0], w[0].1[1], w[0].2[1], w[1].1[0], w[1].2[0], w[1].1[1], w[1].2[1]
            );
            all.push(o);
        }
    }
    let n = all.len() as f64;
    let mean = |f: &dyn Fn(&common::Outcome) -> f64| all.iter().map(f).sum::<f64>() / n;
    let mut within = [0usize; 4];
    for o in &all {
        for (c, (_, p, t)) in o.what_if.iter().enumerate() {
            for k in 0..2 {
                within[2 * c + k] += usize::from((p[k] - t[k]).abs() <= 3.0);
            }
        }
    }
    let mut secs: Vec<f64> = all.iter().map(|o| o.fit_seconds).collect();
    secs.sort_by(f64::total_cmp);
    println!("\nmembers {}", all.len());
    println!(
        "held-out RMSE {:.1} mg/dL (oracle {:.1}, own mean {:.1}), MARD {:.1} %",
        mean(&|o| o.held_out.0),
        mean(&|o| o.oracle_rmse),
        mean(&|o| o.held_out.2),
        mean(&|o| o.held_out.1)
    );
    println!(
        "basal need |error| {:.1} %, basal glucose |error| {:.1} %",
        mean(&|o| 100.0 * (o.basal_need.0 / o.basal_need.1 - 1.0).abs()),
        mean(&|o| 100.0 * (o.basal_glucose.0 / o.basal_glucose.1 - 1.0).abs())
    );
    println!(
        "within 3 pp: basal dTIR {}/{}, basal dTBR {}/{}, CR dTIR {}/{}, CR dTBR {}/{}; all {:.0} %",
        within[0], all.len(), within[1], all.len(), within[2], all.len(), within[3], all.len(),
        100.0 * within.iter().sum::<usize>() as f64 / (4.0 * n)
    );
    println!(
        "grades: good {}, fair {}, not usable {}",
        all.iter()
            .filter(|o| o.grade == abba_twin::Grade::Good)
            .count(),
        all.iter()
            .filter(|o| o.grade == abba_twin::Grade::Fair)
            .count(),
        all.iter()
            .filter(|o| o.grade == abba_twin::Grade::NotUsable)
            .count()
    );
    println!(
        "fit seconds: median {:.1}, max {:.1}; simulations per fit {:.0}",
        secs[secs.len() / 2],
        secs[secs.len() - 1],
        mean(&|o| o.simulations as f64)
    );
}
