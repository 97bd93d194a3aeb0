"""Trial sweeps on a Dask cluster: a trial split into shards by (scenario,
arm, patient range), run on any ``dask.distributed`` client (a
``LocalCluster``, Slurm through dask-jobqueue, Kubernetes, ...), merged into
exactly the report a single run writes.

Research software, not a medical device.
"""

from __future__ import annotations

import os
from typing import Optional, Union

from . import trial as _trial


def _run_shard(config_json: str, index: int, count: int, threads: int) -> str:
    from abba import trial

    return trial.run_shard(config_json, index, count, threads)


def run_trial(
    client,
    config: Optional[Union[dict, str]] = None,
    shards: Optional[int] = None,
    threads_per_shard: int = 1,
    out: Optional[Union[str, os.PathLike]] = None,
) -> "_trial.TrialResult":
    """Runs a trial as ``shards`` shards on the Dask ``client`` (default: one
    per worker thread) and merges them. Every worker needs the ``abba``
    package installed. Returns the same ``TrialResult`` as
    ``abba.trial.run``; with ``out`` the report is written there."""
    config_json = _trial._config_json(config)
    if shards is None:
        shards = max(1, sum(client.nthreads().values()))
    futures = [
        client.submit(_run_shard, config_json, i, shards, threads_per_shard, pure=False)
        for i in range(1, shards + 1)
    ]
    texts = client.gather(futures)
    return _trial.merge(texts, out=out)


def run_trials(client, configs: list, shards_per_trial: int = 1, threads_per_shard: int = 1) -> list:
    """A sweep: many trial configurations (seeds, knobs, populations) at
    once on the client, every shard of every trial in one task graph.
    Returns one ``TrialResult`` per configuration, in order."""
    jobs = []
    for c in configs:
        cj = _trial._config_json(c)
        jobs.append(
            [
                client.submit(_run_shard, cj, i, shards_per_trial, threads_per_shard, pure=False)
                for i in range(1, shards_per_trial + 1)
            ]
        )
    return [_trial.merge(client.gather(fs)) for fs in jobs]
