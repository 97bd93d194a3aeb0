"""The paper's in-silico trial from Python: the same report the ``abba
trial`` command writes.

Research software, not a medical device.
"""

from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass
from typing import Optional, Union

import pandas as pd

from . import _abba


def default_config(population: Optional[str] = None) -> dict:
    """The paper's protocol with every knob at its default (what ``abba
    trial --print-config`` prints); for a cohort of ``population``
    ("adults", "adolescents" or "children"), ABBA's defaults for it (what
    ``abba trial --population P --print-config`` prints)."""
    if population is None:
        return json.loads(_abba.default_config_json())
    return json.loads(_abba.default_config_json(population))


def _merge(base: dict, changes: dict, path: str = "") -> dict:
    out = dict(base)
    for key, value in changes.items():
        if key not in base:
            raise ValueError(f"trial configuration: unknown knob '{path}{key}'")
        if isinstance(value, dict) and isinstance(base[key], dict):
            out[key] = _merge(base[key], value, f"{path}{key}.")
        else:
            out[key] = value
    return out


def _config_json(config: Optional[Union[dict, str]]) -> str:
    """A whole configuration as JSON: the paper's defaults (its population's,
    when it names one) with ``config``'s knobs changed (nested dicts change only the keys they name; an unknown
    knob is an error), or ``config`` itself when it is a JSON text."""
    if config is None:
        return json.dumps(default_config())
    if isinstance(config, str):
        return config
    return json.dumps(_merge(default_config(config.get("population")), config))


@dataclass
class TrialResult:
    """What a trial produced."""

    #: ``summary.json`` as a dict (per scenario/arm and week: mean, SD,
    #: median, IQR of every metric; Wilcoxon tests; the manifest).
    summary: dict
    #: ``patients.csv``: one row per patient, arm and evaluation week, every metric.
    metrics: pd.DataFrame
    #: Every report file (name to bytes), as ``abba trial`` writes them.
    files: dict

    def write(self, out: Union[str, os.PathLike]) -> None:
        """Writes the report files into directory ``out``."""
        os.makedirs(out, exist_ok=True)
        for name, data in self.files.items():
            with open(os.path.join(out, name), "wb") as f:
                f.write(data)


def _result(files) -> TrialResult:
    files = {name: bytes(data) for name, data in files}
    return TrialResult(
        summary=json.loads(files["summary.json"]),
        metrics=pd.read_csv(io.BytesIO(files["patients.csv"])),
        files=files,
    )


def run(
    config: Optional[Union[dict, str]] = None,
    out: Optional[Union[str, os.PathLike]] = None,
    threads: int = 0,
) -> TrialResult:
    """Runs a trial. ``config`` holds any knobs to change from the paper's
    protocol (e.g. ``{"patients": 10, "days": 21, "scenarios": ["S1"],
    "abba": {"gamma": 0.5}}``; nested dicts change only the keys they name),
    or is a JSON text of a whole configuration. ``threads`` = 0 uses
    every core. With ``out``, the report is also written there.
    Returns the summary (``summary.json``), the per-patient metrics
    (``patients.csv``) and every file."""
    result = _result(_abba.trial_report(_config_json(config), threads))
    if out is not None:
        result.write(out)
    return result


def run_shard(config: Optional[Union[dict, str]], index: int, count: int, threads: int = 0) -> str:
    """Runs shard ``index`` (1-based) of ``count`` of a trial; returns the
    shard file's JSON text (what ``abba trial --shard I/N`` writes)."""
    return _abba.trial_shard(_config_json(config), index, count, threads)


def merge(shards: list[str], out: Optional[Union[str, os.PathLike]] = None) -> TrialResult:
    """Merges the shard texts of one trial into its report (what ``abba
    trial merge`` writes): byte-identical to a single run's."""
    result = _result(_abba.merge_shards(list(shards)))
    if out is not None:
        result.write(out)
    return result
