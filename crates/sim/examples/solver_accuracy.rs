//! Prints the largest plasma-glucose error of RK4 with 1, 2, 4 and 8 sub-steps
//! per minute and of the default gut-adaptive solver against RK4 with 64 sub-steps, for every public patient on
//! every built-in hard day. Used for the accuracy table in BENCHMARKS.md:
//! `cargo run --release -p abba-sim --example solver_accuracy`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::inputs::hard_days;
use abba_sim::patient::{Patient, PatientParams, QuestRow, Solver};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let patients = PatientParams::all_public()?;
    println!(
        "{:<20} {:>10} {:>10} {:>10} {:>10} {:>10}  worst case (h=1 min)",
        "day", "h=1", "h=1/2", "h=1/4", "default", "h=1/8"
    );
    let solvers = [
        Solver::fixed(1),
        Solver::fixed(2),
        Solver::fixed(4),
        Solver::DEFAULT,
        Solver::fixed(8),
    ];
    for day_name in hard_days::NAMES {
        let mut worst = [0.0f64; 5];
        let mut worst_who = String::new();
        for p in &patients {
            let cr = QuestRow::for_patient(&p.name)?.cr;
            let day = hard_days::build(day_name, p, cr).ok_or("unknown day")?;
            let reference = day.simulate(
                &mut Patient::with_solver(p.clone(), Solver::REFERENCE)?,
                1.0,
            )?;
            for (k, solver) in solvers.iter().enumerate() {
                let bg = day.simulate(&mut Patient::with_solver(p.clone(), *solver)?, 1.0)?;
                let err = bg
                    .iter()
                    .zip(&reference)
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                if err > worst[k] {
                    worst[k] = err;
                    if k == 0 {
                        worst_who = p.name.clone();
                    }
                }
            }
        }
        println!(
            "{:<20} {:>10.2e} {:>10.2e} {:>10.2e} {:>10.2e} {:>10.2e}  {}",
            day_name, worst[0], worst[1], worst[2], worst[3], worst[4], worst_who
        );
    }
    Ok(())
}
