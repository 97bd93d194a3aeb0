//! A trial run as N shards (through shard files) merges into the same
//! report bytes as a single run; merging refuses incomplete or mixed sets.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::RawTrialConfig;
use abba_trial::runner::{run_trial, Silent, TrialOutput};
use abba_trial::shard::{merge, read_shard, run_shard, write_shard, ShardFile, ShardSpec};
use abba_trial::{ArmKind, TrialConfig};

fn small_raw() -> RawTrialConfig {
    RawTrialConfig {
        patients: 5,
        days: 16,
        scenarios: vec![ScenarioId::S1, ScenarioId::S2],
        arms: vec![ArmKind::Abba, ArmKind::R2r],
        ..RawTrialConfig::default()
    }
}

fn small() -> TrialConfig {
    TrialConfig::try_from(small_raw()).unwrap()
}

fn report(output: &TrialOutput) -> Vec<(&'static str, Vec<u8>)> {
    let tool = abba_trial::report::ToolInfo {
        version: "test",
        git_revision: "test",
    };
    let manifest = abba_trial::report::trial_manifest(output, &tool);
    abba_report::build_report(&output.arms, &manifest, None)
        .unwrap()
        .into_iter()
        .map(|f| (f.name, f.bytes))
        .collect()
}

fn shards(config: &TrialConfig, n: u32) -> Vec<ShardFile> {
    // Written and read back through files; the directory goes with the test.
    let dir = tempfile::Builder::new()
        .prefix(&format!("abba-shard-test-{n}-"))
        .tempdir()
        .unwrap();
    // Run them in reverse order and with different thread counts: neither matters.
    (1..=n)
        .rev()
        .map(|i| {
            let spec = ShardSpec::new(i, n).unwrap();
            let s = run_shard(config, spec, (i % 2) as usize, &Silent).unwrap();
            let path = dir.path().join(format!("{i}.json"));
            write_shard(&path, &s).unwrap();
            read_shard(&path).unwrap()
        })
        .collect()
}

#[test]
fn sharded_trial_merges_into_the_single_run_report() {
    let config = small();
    let single = report(&run_trial(&config, 0, &Silent).unwrap());
    // 20 jobs: 3 shards split 6/7/7 and cut through (scenario, arm) blocks;
    // 7 shards leave some with two jobs; 20 shards are one job each.
    for n in [1, 3, 7, 20] {
        let merged = report(&merge(&shards(&config, n)).unwrap());
        assert_eq!(single.len(), merged.len());
        for ((name, a), (name_b, b)) in single.iter().zip(&merged) {
            assert_eq!(name, name_b);
            assert!(a == b, "{name} differs after merging {n} shards");
        }
    }
}

#[test]
fn merge_refuses_missing_repeated_and_foreign_shards() {
    let config = small();
    let mut set = shards(&config, 3);
    let missing = merge(&set[..2]).unwrap_err().to_string();
    assert!(missing.contains("is missing"), "{missing}");
    let mut twice = set.clone();
    twice.push(set[0].clone());
    let e = merge(&twice).unwrap_err().to_string();
    assert!(e.contains("twice"), "{e}");
    let other = run_shard(
        &TrialConfig::try_from(RawTrialConfig {
            seed: 2,
            ..small_raw()
        })
        .unwrap(),
        ShardSpec::new(1, 3).unwrap(),
        1,
        &Silent,
    )
    .unwrap();
    let first = set.iter().position(|s| s.shard.index == 1).unwrap();
    set[first] = other;
    let e = merge(&set).unwrap_err().to_string();
    assert!(e.contains("different trial configuration"), "{e}");
}
