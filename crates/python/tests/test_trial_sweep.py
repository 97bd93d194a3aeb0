"""abba.trial.run returns the summary the CLI writes; a trial run as shards
on a Dask LocalCluster merges into byte-identical report files."""

import json
import os
import subprocess

import pytest

import abba

SMALL = {"patients": 4, "days": 16, "scenarios": ["S1", "S2"], "arms": ["abba", "standard"]}


@pytest.fixture(scope="module")
def single():
    return abba.trial.run(SMALL)


def test_trial_run_returns_summary_and_metrics(single):
    s = single.summary
    assert set(s["arms"]) == {"S1/abba", "S1/standard", "S2/abba", "S2/standard"}
    assert s["manifest"]["cohort"]["patients"] == 4
    m = single.metrics
    assert set(m["patient"]) == {f"adult#00{i}" for i in range(1, 5)}
    assert {"tir_70_180", "lbgi", "hbgi"} <= set(m.columns)
    # The summary's W1 mean TIR is the mean over the patients' W1 rows.
    w1 = m[(m["scenario"] == "S1") & (m["advisor"] == "standard") & (m["week"] == "W1")]
    mean = s["arms"]["S1/standard"]["weeks"]["W1"]["tir_70_180"]["mean"]
    assert mean == pytest.approx(w1["tir_70_180"].mean(), rel=1e-12)


def test_trial_run_writes_what_the_cli_writes(single, tmp_path):
    cli = os.environ.get("ABBA_CLI")
    if not cli:
        pytest.skip("set ABBA_CLI to the abba binary (target/release/abba) to compare")
    args = [cli, "trial", "--quiet", "--patients", "4", "--days", "16", "--scenarios", "S1,S2",
            "--arms", "abba,standard", "--out", str(tmp_path)]
    subprocess.run(args, check=True)
    def without_build(doc, name):
        # The build's git revision may differ (e.g. "-dirty" in a work tree
        # edited between the two builds); everything else must be equal.
        manifest = doc["manifest"] if name == "summary.json" else doc
        manifest.pop("git_revision")
        manifest.pop("run", None)
        return doc

    # report.html names the build too: each side's revision, as its
    # manifest says, becomes one placeholder.
    rev_cli = json.loads((tmp_path / "manifest.json").read_text())["git_revision"].encode()
    rev_py = json.loads(single.files["manifest.json"])["git_revision"].encode()

    def unnamed(data, rev):
        return data.replace(rev, b"<revision>") if rev else data

    for name, data in single.files.items():
        if name in ("manifest.json", "summary.json"):
            on_disk = json.loads((tmp_path / name).read_text())
            assert without_build(on_disk, name) == without_build(json.loads(data), name), name
        else:
            # (a bool, not the bytes: pytest's diff of two large files
            # runs for many minutes)
            same = unnamed((tmp_path / name).read_bytes(), rev_cli) == unnamed(data, rev_py)
            assert same, f"{name} differs from the CLI's"


def test_shards_on_a_dask_local_cluster_merge_byte_identical(single, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            merged = abba.sweep.run_trial(client, SMALL, shards=5, out=tmp_path / "merged")
            sweep = abba.sweep.run_trials(client, [SMALL, dict(SMALL, seed=2)], shards_per_trial=3)
    assert merged.files.keys() == single.files.keys()
    for name, data in single.files.items():
        same = merged.files[name] == data and (tmp_path / "merged" / name).read_bytes() == data
        assert same, f"{name} differs from the single run's"
    same = sweep[0].files == single.files
    assert same, "the sweep's first trial differs from the single run"
    assert sweep[1].files["summary.json"] != single.files["summary.json"]


def test_shards_merge_and_refuse_incomplete_sets(single):
    texts = [abba.trial.run_shard(SMALL, i, 3, threads=1) for i in (3, 1, 2)]
    assert abba.trial.merge(texts).files == single.files
    with pytest.raises(ValueError, match="shard 2/3 is missing"):
        abba.trial.merge(texts[:2])


def test_a_population_brings_its_own_abba_defaults():
    adults = abba.trial.default_config()["abba"]["features"]
    assert adults["cgm_basal_window_min"] is None
    assert adults["smbg_basal_window_min"] == [-90, 450]
    kids = abba.trial.default_config("children")
    assert kids["population"] == "children"
    assert kids["abba"]["features"]["cgm_basal_window_min"] == [120, 420]
    assert kids["abba"]["features"]["smbg_basal_window_min"] == [0, 450]
    merged = json.loads(abba.trial._config_json({"population": "adolescents", "patients": 3}))
    assert merged["abba"]["features"]["cgm_basal_window_min"] == [0, 420]
    assert merged["abba"]["features"]["smbg_basal_window_min"] == [0, 450]
    with pytest.raises(ValueError, match="toddlers"):
        abba.trial.default_config("toddlers")


def test_config_changes_are_checked_knob_by_knob():
    c = abba.trial.default_config()
    merged = json.loads(abba.trial._config_json({"abba": {"te": {"te_ref_bits": 0.5}}}))
    assert merged["abba"]["te"]["te_ref_bits"] == 0.5
    assert merged["abba"]["actor"] == c["abba"]["actor"]
    with pytest.raises(ValueError, match="unknown knob 'patinets'"):
        abba.trial.run({"patinets": 5})
    with pytest.raises(ValueError, match="days must be at least"):
        abba.trial.run({"days": 3})
