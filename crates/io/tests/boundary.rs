//! abba-io never depends on the simulator (nor on the trial that runs it),
//! not even for tests (`.ci/run` checks `cargo tree` too).

#[test]
fn manifest_names_no_simulator_crate() {
    let manifest = include_str!("../Cargo.toml");
    for forbidden in ["abba-sim", "abba-trial"] {
        assert!(
            !manifest.contains(forbidden),
            "crates/io/Cargo.toml mentions {forbidden}"
        );
    }
}
