//! Architecture invariant 1: abba-advisor does not depend on abba-sim, not
//! even as a dev-dependency.
#![allow(clippy::unwrap_used, clippy::expect_used)]

#[test]
fn cargo_tree_does_not_contain_abba_sim() {
    let out = std::process::Command::new(env!("CARGO"))
        .args(["tree", "-p", "abba-advisor", "-e", "all", "--offline"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo tree runs");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "cargo tree failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("abba-core"), "expected abba-core in:\n{text}");
    assert!(!text.contains("abba-sim"), "abba-sim found in:\n{text}");
}
