//! ARCHITECTURE.md is checked against the workspace as cargo sees it
//! (`cargo metadata --no-deps`), so the map cannot drift from the territory:
//!
//! - the crate-graph block lists exactly each crate's direct normal and build
//!   dependencies on other workspace crates;
//! - every rule of the crates table's "never depends on" column holds over
//!   the transitive graph (a crate's own dev-dependencies count, unless the
//!   rule says "but for tests");
//! - every workspace crate has a row in the table;
//! - libraries never print (invariant 5);
//! - each crate has one integration-test binary, which declares every
//!   test file beside it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::process::Command;

/// Direct workspace dependencies of one crate, by kind.
#[derive(Default, Debug)]
struct Deps {
    normal: BTreeSet<String>,
    dev: BTreeSet<String>,
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `cargo metadata` of the workspace (its own packages, no dependencies).
fn metadata() -> Value {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(root())
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON")
}

fn workspace() -> BTreeMap<String, Deps> {
    let meta = metadata();
    let packages = meta["packages"].as_array().expect("packages");
    let names: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().expect("name").to_string())
        .collect();
    let mut graph = BTreeMap::new();
    for p in packages {
        let mut deps = Deps::default();
        for d in p["dependencies"].as_array().expect("dependencies") {
            let name = d["name"].as_str().expect("dependency name").to_string();
            if !names.contains(&name) {
                continue;
            }
            match d["kind"].as_str() {
                None | Some("build") => deps.normal.insert(name),
                Some("dev") => deps.dev.insert(name),
                Some(other) => panic!("unknown dependency kind {other}"),
            };
        }
        graph.insert(p["name"].as_str().expect("name").to_string(), deps);
    }
    graph
}

fn architecture() -> String {
    std::fs::read_to_string(root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md is readable")
}

/// The crate-graph block: `crate -> dep dep ...` per line.
fn documented_graph(doc: &str) -> BTreeMap<String, BTreeSet<String>> {
    let begin = doc
        .find("<!-- crate-graph:begin -->")
        .expect("ARCHITECTURE.md has a crate-graph:begin marker");
    let end = doc
        .find("<!-- crate-graph:end -->")
        .expect("ARCHITECTURE.md has a crate-graph:end marker");
    let mut graph = BTreeMap::new();
    for line in doc[begin..end].lines() {
        if !line.starts_with("abba") {
            continue;
        }
        let Some((name, deps)) = line.split_once("->") else {
            panic!("ARCHITECTURE.md's crate graph line '{line}' has no '->'");
        };
        let deps = deps.split_whitespace().map(str::to_string).collect();
        assert!(
            graph.insert(name.trim().to_string(), deps).is_none(),
            "ARCHITECTURE.md lists {} twice",
            name.trim()
        );
    }
    graph
}

/// Rows of the crates table: crate name and its "never depends on" cell.
fn never_rules(doc: &str) -> BTreeMap<String, String> {
    let mut rules = BTreeMap::new();
    for line in doc.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // | `abba-x` (`crates/x`) | owns | never |
        if cells.len() < 5 || !cells[1].starts_with("`abba") {
            continue;
        }
        let name = cells[1].trim_start_matches('`');
        let name = &name[..name.find('`').expect("closing backtick")];
        rules.insert(name.to_string(), cells[3].to_string());
    }
    rules
}

fn reachable(graph: &BTreeMap<String, Deps>, from: &str, with_dev: bool) -> BTreeSet<String> {
    let start = &graph[from];
    let mut todo: Vec<String> = start.normal.iter().cloned().collect();
    if with_dev {
        todo.extend(start.dev.iter().cloned());
    }
    let mut seen = BTreeSet::new();
    while let Some(n) = todo.pop() {
        if seen.insert(n.clone()) {
            todo.extend(graph[&n].normal.iter().cloned());
        }
    }
    seen
}

#[test]
fn the_documented_crate_graph_is_cargos() {
    let graph = workspace();
    let doc = documented_graph(&architecture());
    let actual: BTreeMap<String, BTreeSet<String>> = graph
        .iter()
        .map(|(k, v)| (k.clone(), v.normal.clone()))
        .collect();
    for (name, deps) in &actual {
        match doc.get(name) {
            None => panic!("ARCHITECTURE.md's crate graph lacks {name} (cargo: {deps:?})"),
            Some(d) => assert_eq!(
                d, deps,
                "ARCHITECTURE.md's crate graph for {name} differs from cargo metadata"
            ),
        }
    }
    for name in doc.keys() {
        assert!(
            actual.contains_key(name),
            "ARCHITECTURE.md's crate graph lists {name}, which is not a workspace crate"
        );
    }
}

#[test]
fn every_never_depends_on_rule_holds() {
    let graph = workspace();
    let rules = never_rules(&architecture());
    for name in graph.keys() {
        assert!(
            rules.contains_key(name),
            "ARCHITECTURE.md's crates table has no row for {name}"
        );
    }
    let all: BTreeSet<String> = graph.keys().cloned().collect();
    let mut checked = 0;
    for (name, rule) in &rules {
        assert!(
            graph.contains_key(name),
            "the crates table names {name}, not a crate"
        );
        for item in rule.split(',').map(str::trim) {
            let (item, with_dev) = match item.strip_suffix("(but for tests)") {
                Some(i) => (i.trim(), false),
                None => (item.trim_end_matches("(not even for tests)").trim(), true),
            };
            let reach = reachable(&graph, name, with_dev);
            let forbidden: BTreeSet<String> = if item == "—" {
                BTreeSet::new()
            } else if item == "any other abba crate" || item == "every other abba crate" {
                all.iter().filter(|n| *n != name).cloned().collect()
            } else if let Some(allowed) = item.strip_prefix("everything but ") {
                let allowed: BTreeSet<String> = allowed
                    .split(" and ")
                    .map(|a| format!("abba-{}", a.trim()))
                    .collect();
                all.iter()
                    .filter(|n| *n != name && !allowed.contains(*n))
                    .cloned()
                    .collect()
            } else {
                let dep = format!("abba-{item}");
                assert!(
                    all.contains(&dep),
                    "rule '{item}' of {name} names no crate (expected a crate's short name)"
                );
                [dep].into()
            };
            for f in &forbidden {
                assert!(
                    !reach.contains(f),
                    "{name} depends on {f}, which ARCHITECTURE.md says it never does"
                );
                checked += 1;
            }
        }
    }
    assert!(
        checked > 20,
        "only {checked} rules checked: the table was not parsed"
    );
    // Invariant 1 by name, whatever the table says.
    for name in [
        "abba-advisor",
        "abba-report",
        "abba-io",
        "abba-store",
        "abba-api",
        "abba-service",
        "abba-client",
        "abba-nightscout",
        "abba-web",
    ] {
        assert!(
            !reachable(&graph, name, true).contains("abba-sim"),
            "{name} depends on abba-sim"
        );
    }
}

/// Invariant 5: libraries never print; what a person or a log sees is the
/// binary's (progress through callbacks, the service's lines through
/// tracing). Every `print!`, `println!`, `eprint!`, `eprintln!` and
/// `dbg!` outside a test module of a library crate fails this test; the
/// `abba` binary, the Python module (its own entry points) and the build
/// scripts' helper (cargo reads its `cargo:` lines) are the exceptions.
#[test]
fn libraries_never_print() {
    let crates = root().join("crates");
    let mut found = Vec::new();
    let mut files = 0;
    for entry in std::fs::read_dir(&crates).unwrap() {
        let dir = entry.unwrap().path();
        let name = dir.file_name().unwrap().to_string_lossy().to_string();
        if matches!(name.as_str(), "cli" | "python" | "build-info") {
            continue;
        }
        let mut stack = vec![dir.join("src")];
        while let Some(d) = stack.pop() {
            let Ok(rd) = std::fs::read_dir(&d) else {
                continue;
            };
            for e in rd {
                let p = e.unwrap().path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    files += 1;
                    let text = std::fs::read_to_string(&p).unwrap();
                    // A file's test module stands at its end.
                    let code = text.split("#[cfg(test)]").next().unwrap_or("");
                    for (i, line) in code.lines().enumerate() {
                        let l = line.split("//").next().unwrap_or("");
                        for m in ["print!(", "println!(", "eprint!(", "eprintln!(", "dbg!("] {
                            let hit = l.match_indices(m).any(|(at, _)| {
                                !l[..at].ends_with(|c: char| c.is_alphanumeric() || c == '_')
                            });
                            if hit {
                                found.push(format!("{}:{}: {}", p.display(), i + 1, line.trim()));
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(files > 100, "only {files} library files read");
    assert!(found.is_empty(), "libraries print:\n{}", found.join("\n"));
}

/// Test files that are binaries of their own, with why.
const ALONE: &[(&str, &str, &str)] = &[(
    "abba",
    "service_crash.rs",
    "asserts a floor on the events its clients post between SIGKILLs: other tests on the same cores push it under",
)];

/// One integration-test binary per crate (each binary is built and linked
/// on its own, so many small ones cost CI minutes): a crate has one `test`
/// target but for the files of [`ALONE`], and where that target is
/// `tests/main.rs` (the crate sets `autotests = false`), every other
/// `tests/*.rs` beside it is one of its modules or a target of its own,
/// so that a new test file cannot be left out of the build unseen.
#[test]
fn each_crate_has_one_test_binary_that_declares_every_test_file() {
    let meta = metadata();
    let mut problems = Vec::new();
    let mut binaries = 0;
    for p in meta["packages"].as_array().expect("packages") {
        let name = p["name"].as_str().expect("name");
        let tests: Vec<PathBuf> = p["targets"]
            .as_array()
            .expect("targets")
            .iter()
            .filter(|t| {
                t["kind"]
                    .as_array()
                    .is_some_and(|k| k.iter().any(|k| k == "test"))
            })
            .map(|t| PathBuf::from(t["src_path"].as_str().expect("src_path")))
            .collect();
        binaries += tests.len();
        let alone = |t: &PathBuf| {
            ALONE.iter().any(|(crate_name, file, _)| {
                *crate_name == name && t.ends_with(format!("tests/{file}"))
            })
        };
        if tests.iter().filter(|t| !alone(t)).count() > 1 {
            problems.push(format!(
                "{name} has {} test binaries ({}): declare them as modules of one tests/main.rs",
                tests.len(),
                tests
                    .iter()
                    .map(|t| t.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        for main in tests.iter().filter(|t| t.ends_with("tests/main.rs")) {
            let text = std::fs::read_to_string(main).unwrap();
            let declared: BTreeSet<String> = text
                .lines()
                .filter_map(|l| l.trim().strip_prefix("mod ")?.strip_suffix(';'))
                .map(str::to_string)
                .collect();
            for e in std::fs::read_dir(main.parent().unwrap()).unwrap() {
                let f = e.unwrap().path();
                let stem = f.file_stem().unwrap().to_string_lossy().to_string();
                if f.extension().is_some_and(|x| x == "rs")
                    && stem != "main"
                    && !declared.contains(&stem)
                    && !tests.contains(&f)
                {
                    problems.push(format!(
                        "{} is not a module of {}: it would never run",
                        f.display(),
                        main.display()
                    ));
                }
            }
        }
    }
    assert!(binaries >= 10, "only {binaries} test binaries found");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
