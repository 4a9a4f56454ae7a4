"""Distributed sweeps: a local process pool and a dask LocalCluster give the same results as a serial run."""

from __future__ import annotations

import json

import pytest

from compare.run.executor import ExecutorError, parse_executor
from compare.report.results import RunSettings
from compare.run.runner import run
from tests.helpers import CORNELL


def test_parse_executor():
    assert parse_executor("serial") == ("serial", None)
    assert parse_executor("local:3") == ("local", 3)
    assert parse_executor("local")[1] >= 1
    assert parse_executor("dask://10.0.0.1:8786") == ("dask", "tcp://10.0.0.1:8786")
    for bad in ("local:0", "local:x", "dask://", "ray://x"):
        with pytest.raises(ExecutorError):
            parse_executor(bad)


def _strip(results: dict) -> dict:
    """results.json without what legitimately differs between runs: timings, dates, hosts."""
    drop = {"seconds", "first_seconds", "setup_seconds", "load_seconds", "created", "environment", "key",
            "gpu_seconds", "metadata", "first_frame_seconds"}

    def clean(v):
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items() if k not in drop}
        if isinstance(v, list):
            return [clean(x) for x in v]
        return v

    return clean(results)


def _settings():
    return RunSettings(frames=4, spp=8, renderers=["mitsuba", "progressive"], sizes=[[32, 24], [24, 18]])


@pytest.mark.gl
def test_dask_local_cluster_matches_serial(tmp_path):
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed (pip install '.[dask]')")
    cache = tmp_path / "cache"
    serial = run([CORNELL], tmp_path / "serial", _settings(), progress=False, cache_dir=cache, report=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
            distributed.Client(cl) as client:
        dist = run([CORNELL], tmp_path / "dask", _settings(), progress=False, cache_dir=cache, report=False,
                   executor=client)
    a = _strip(json.loads((tmp_path / "serial" / "results.json").read_text()))
    b = _strip(json.loads((tmp_path / "dask" / "results.json").read_text()))
    assert a == b
    assert len(dist.scenes) == 2 and len(serial.scenes) == 2
    # every image the results name was shipped back into the client's folder
    for sc in dist.scenes:
        for r in sc.runs:
            assert (tmp_path / "dask" / "runs" / sc.id).is_dir()


@pytest.mark.gl
def test_local_pool_matches_serial(tmp_path):
    cache = tmp_path / "cache"
    run([CORNELL], tmp_path / "serial", _settings(), progress=False, cache_dir=cache, report=False)
    run([CORNELL], tmp_path / "pool", _settings(), progress=False, cache_dir=cache, report=False, executor="local:2")
    a = _strip(json.loads((tmp_path / "serial" / "results.json").read_text()))
    b = _strip(json.loads((tmp_path / "pool" / "results.json").read_text()))
    assert a == b
