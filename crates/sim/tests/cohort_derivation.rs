//! The steady-state derivation reproduces the derived columns of the public
//! table, and the primary / common / derived split covers every column.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::cohort::derive::{
    derive_steady_state, steady_state_residual, COMMON, DERIVED, PRIMARY,
};
use abba_sim::patient::params::X0_COLUMNS;
use abba_sim::patient::PatientParams;

#[test]
fn derivation_reproduces_all_30_public_rows_to_1e_9_relative() {
    let public = PatientParams::all_public().unwrap();
    assert_eq!(public.len(), 30);
    let mut worst = (0.0f64, String::new());
    for p in &public {
        // Start from the primary and common columns only: wipe every derived one.
        let mut q = p.clone();
        for col in DERIVED {
            *q.scalar_mut(col).unwrap() = f64::NAN;
        }
        q.x0 = [f64::NAN; 13];
        derive_steady_state(&mut q).unwrap();
        let mut check = |col: &str, want: f64, got: f64| {
            let rel = if want == 0.0 {
                got.abs()
            } else {
                ((got - want) / want).abs()
            };
            assert!(
                rel < 1e-9,
                "{} {col}: expected {want} got {got} (relative {rel:e})",
                p.name
            );
            if rel > worst.0 {
                worst = (rel, format!("{} {col}: expected {want} got {got}", p.name));
            }
        };
        for col in DERIVED {
            check(col, p.scalar(col).unwrap(), q.scalar(col).unwrap());
        }
        for (k, col) in X0_COLUMNS.iter().enumerate() {
            check(col, p.x0[k], q.x0[k]);
        }
        // Primary and common columns are untouched.
        for col in PRIMARY.iter().chain(COMMON.iter()) {
            assert_eq!(p.scalar(col), q.scalar(col), "{} {col}", p.name);
        }
    }
    println!("largest relative difference: {:e} ({})", worst.0, worst.1);
}

#[test]
fn public_initial_states_are_exact_steady_states() {
    for p in PatientParams::all_public().unwrap() {
        let r = steady_state_residual(&p);
        let max = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(max < 1e-9, "{}: max |dx/dt| = {max:e}", p.name);
    }
}

#[test]
fn every_column_is_primary_common_or_derived_exactly_once() {
    let mut all: Vec<&str> = PRIMARY
        .iter()
        .chain(&COMMON)
        .chain(&DERIVED)
        .copied()
        .collect();
    let n = all.len();
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), n, "a column is listed twice");
    let mut table: Vec<&str> = PatientParams::SCALAR_COLUMNS.to_vec();
    table.sort_unstable();
    assert_eq!(all, table);
}

#[test]
fn common_columns_are_common_and_primary_ones_vary() {
    let public = PatientParams::all_public().unwrap();
    for col in COMMON {
        let v0 = public[0].scalar(col).unwrap();
        assert!(
            public.iter().all(|p| p.scalar(col) == Some(v0)),
            "{col} differs between public patients"
        );
    }
    for col in PRIMARY {
        let v0 = public[0].scalar(col).unwrap();
        assert!(
            public.iter().any(|p| p.scalar(col) != Some(v0)),
            "{col} is the same for everyone: it should be common"
        );
        assert!(
            public.iter().all(|p| p.scalar(col).unwrap() > 0.0),
            "{col} must be > 0 to mix in log space"
        );
    }
}

#[test]
fn impossible_primaries_are_reported() {
    let mut p = PatientParams::public("adult#001").unwrap();
    p.egpb = 100.0; // more production than the plasma balance can carry
    let e = derive_steady_state(&mut p).unwrap_err().to_string();
    assert!(e.contains("Gtb"), "{e}");
    let mut p = PatientParams::public("adult#001").unwrap();
    p.egpb = 0.5; // less production than the insulin-independent uptake
    let e = derive_steady_state(&mut p).unwrap_err().to_string();
    assert!(e.contains("Vm0"), "{e}");
}

#[test]
fn derivation_handles_renal_excretion_at_basal() {
    // A basal plasma glucose mass above the renal threshold: still an exact steady state.
    let mut p = PatientParams::public("adult#001").unwrap();
    p.gb = 200.0;
    derive_steady_state(&mut p).unwrap();
    assert!(p.gpb > p.ke2, "Gpb {} must exceed ke2 {}", p.gpb, p.ke2);
    let max = steady_state_residual(&p)
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(max < 1e-9, "max |dx/dt| = {max:e}");
}
