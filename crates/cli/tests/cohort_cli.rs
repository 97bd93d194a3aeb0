//! `abba cohort` run as a user would: the built binary writing real files.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;

use std::path::PathBuf;

use cli_common::{abba, ok};

const PUBLIC_TABLE: &str = include_str!("../../../data/uva-padova/vpatient_params.csv");

fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("abba_cohort_cli_{}_{name}", std::process::id()))
}

#[test]
fn same_seed_gives_byte_identical_tables_and_the_first_ten_adults_are_public() {
    let a = temp_path("a.csv");
    let b = temp_path("b.csv");
    let c = temp_path("c.csv");
    for (path, seed) in [(&a, "7"), (&b, "7"), (&c, "8")] {
        ok(&abba(&[
            "cohort",
            "--population",
            "adults",
            "--size",
            "100",
            "--seed",
            seed,
            "--out",
            path.to_str().unwrap(),
        ]));
    }
    let (ta, tb, tc) = (
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        std::fs::read(&c).unwrap(),
    );
    assert_eq!(ta, tb, "same seed, same bytes");
    assert_ne!(ta, tc, "another seed, other generated patients");

    let text = String::from_utf8(ta).unwrap();
    let mut rdr = csv::Reader::from_reader(text.as_bytes());
    let header = rdr.headers().unwrap().clone();
    let rows: Vec<csv::StringRecord> = rdr.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), 100);

    let mut pub_rdr = csv::Reader::from_reader(PUBLIC_TABLE.as_bytes());
    let pub_header = pub_rdr.headers().unwrap().clone();
    assert_eq!(
        &header.iter().take(62).collect::<Vec<_>>(),
        &pub_header.iter().collect::<Vec<_>>(),
        "the first 62 columns are those of vpatient_params.csv"
    );
    let adults: Vec<csv::StringRecord> = pub_rdr
        .records()
        .map(|r| r.unwrap())
        .filter(|r| r[0].starts_with("adult#"))
        .collect();
    assert_eq!(adults.len(), 10);
    for (k, (got, want)) in rows.iter().zip(&adults).enumerate() {
        for (col, (g, w)) in pub_header.iter().zip(got.iter().zip(want.iter())) {
            if col == "Name" {
                assert_eq!(g, w);
            } else {
                let (g, w): (f64, f64) = (g.parse().unwrap(), w.parse().unwrap());
                assert_eq!(g, w, "row {k} column {col}: expected {w} got {g}");
            }
        }
        let src = header
            .iter()
            .position(|h| h == "carb_ratio_source")
            .unwrap();
        assert_eq!(&got[src], "quest");
    }
    let names: Vec<&str> = rows.iter().map(|r| r.get(0).unwrap()).collect();
    assert_eq!(names[10], "adult#011");
    assert_eq!(names[99], "adult#100");
    for p in [&a, &b, &c] {
        std::fs::remove_file(p).ok();
    }
}

#[test]
fn json_summary_has_statistics_rejections_and_titration() {
    let out = abba(&[
        "cohort",
        "--population",
        "children",
        "--size",
        "30",
        "--seed",
        "3",
        "--json",
    ]);
    ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["population"], "children");
    assert_eq!(v["size"], 30);
    assert_eq!(v["public"], 10);
    assert_eq!(v["generated"], 20);
    let params = v["parameters"].as_array().unwrap();
    let bw = params.iter().find(|p| p["name"] == "BW").unwrap();
    for k in ["mean", "sd", "min", "max"] {
        assert!(bw[k].as_f64().unwrap() > 0.0, "BW {k}");
    }
    assert!(bw["min"].as_f64() <= bw["mean"].as_f64() && bw["mean"].as_f64() <= bw["max"].as_f64());
    assert!(params.iter().any(|p| p["name"] == "carb_ratio_g_per_u"));
    let rej = &v["rejections"];
    let by_reason: u64 = rej["by_reason"]
        .as_object()
        .unwrap()
        .values()
        .map(|x| x.as_u64().unwrap())
        .sum();
    assert_eq!(rej["total"].as_u64().unwrap(), by_reason);
    let t = &v["titration_vs_quest"];
    assert_eq!(t["patients"].as_array().unwrap().len(), 10);
    assert!(t["geometric_mean_ratio"].as_f64().unwrap() > 0.0);
}

#[test]
fn bad_arguments_are_clear_errors() {
    let out = abba(&["cohort", "--population", "elders", "--json"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("elders") && err.contains("adults"), "{err}");

    let out = abba(&["cohort", "--population", "adults"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--out") && err.contains("--json"), "{err}");

    let out = abba(&["cohort", "--size", "0", "--json"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("size"), "{err}");

    let dir = temp_path("no_such_dir");
    let file = dir.join("x.csv");
    let out = abba(&["cohort", "--size", "3", "--out", file.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("x.csv"), "{err}");
}
