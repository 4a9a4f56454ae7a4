"""One reference's chunks on a dask LocalCluster: the same pixels as a serial render, bit for bit, and every
chunk in the client's cache afterwards."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from compare.mitsuba.cluster import ChunkRecipe, DaskWorkers, render_chunk
from compare.mitsuba.reference import ReferenceRenderer
from compare.renderers.base import RendererError
from compare.scene.loader import load_scene
from compare.util.errors import CompareError
from tests.helpers import CORNELL

#: Checkpoints that are not all on the doubling ladder, so the pass plan holds passes of both kinds.
CHECKPOINTS = [3, 10, 32]
#: Small chunks: the 32 spp above are 12 chunks, several per pass.
PASS_SPP = 4
SEED = 5


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("distributed", reason="the dask extra is not installed (pip install '.[dask]')")
    import logging

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as cluster, distributed.Client(cluster) as c:
        c.wait_for_workers(2)
        yield c


def _scene():
    return load_scene(CORNELL).with_resolution(24, 18)


def _chunks_on_workers(client) -> int:
    """References whose Mitsuba scene the cluster's workers hold: > 0 once a worker rendered a chunk."""
    return sum(client.run(lambda: len(__import__("compare.mitsuba.cluster", fromlist=["_"])._RENDERERS)).values())


def test_chunks_on_workers_are_the_serial_render_bit_for_bit_and_cached_here(client, tmp_path, monkeypatch):
    scene = _scene()
    serial = ReferenceRenderer(scene, cache_dir=False, progress=False, max_pass_spp=PASS_SPP)
    expected = list(serial.iter_checkpoints(CHECKPOINTS, SEED))

    spread = ReferenceRenderer(scene, cache_dir=tmp_path, progress=False, max_pass_spp=PASS_SPP,
                               workers=DaskWorkers(client))
    got = list(spread.iter_checkpoints(CHECKPOINTS, SEED))
    assert _chunks_on_workers(client) > 0  # rendered there, not here
    assert [c.step for c in got] == [c.step for c in expected] == CHECKPOINTS
    for a, b in zip(got, expected):
        assert np.array_equal(a.image, b.image), f"checkpoint {a.step} differs"
    assert np.array_equal(spread.variance[0], serial.variance[0]) and spread.variance[1] == serial.variance[1]
    assert all(b.seconds > a.seconds > 0 for a, b in zip(got, got[1:]))  # each chunk's own render time

    chunks = spread.chunks(CHECKPOINTS, SEED)
    assert len(chunks) == 12 and max(c.spp for c in chunks) == PASS_SPP
    assert all(spread.cached(c) is not None for c in chunks)
    assert len(list(tmp_path.rglob("*.exr"))) == len(chunks)
    assert not [p for p in tmp_path.rglob("*") if p.is_file() and p.name.startswith(".")]  # nothing half-written

    # a serial render of the same cache reads every chunk and renders none
    again = ReferenceRenderer(scene, cache_dir=tmp_path, progress=False, max_pass_spp=PASS_SPP)
    rendered = []
    real = again.mi.render
    monkeypatch.setattr(again.mi, "render", lambda *a, **k: rendered.append(k.get("spp")) or real(*a, **k))
    cached = list(again.iter_checkpoints(CHECKPOINTS, SEED))
    assert rendered == []
    for a, b in zip(cached, expected):
        assert np.array_equal(a.image, b.image)


class _StopAt:
    """An ``until`` that stops at ``spp`` samples (the convergence rule's interface)."""

    def __init__(self, spp: int):
        self.spp, self.seen = spp, 0

    def add(self, image, spp: int) -> None:
        self.seen += spp

    def met(self, spp: int) -> bool:
        return spp >= self.spp


def test_a_render_that_stops_early_is_the_serial_one_and_leaves_no_work_behind(client):
    """``until`` stops after the 8 spp pass (5 of the 64 spp's 33 chunks): the same last checkpoint as a serial
    render that stopped there; only a few chunks were submitted ahead of the merge, and those that had not
    come back were cancelled."""
    from compare.mitsuba import cluster

    class Counting:  # the client, counting what is submitted and cancelled
        def __init__(self, real):
            self.real, self.submitted, self.cancelled = real, [], []

        def __getattr__(self, name):
            return getattr(self.real, name)

        def submit(self, *args, **kwargs):
            self.submitted.append(self.real.submit(*args, **kwargs))
            return self.submitted[-1]

        def cancel(self, futures):
            self.cancelled += futures
            return self.real.cancel(futures)

    scene = _scene()
    serial = ReferenceRenderer(scene, cache_dir=False, progress=False, max_pass_spp=2)
    counting = Counting(client)
    spread = ReferenceRenderer(scene, cache_dir=False, progress=False, max_pass_spp=2, workers=DaskWorkers(counting))
    a = list(serial.iter_checkpoints([64], SEED, until=_StopAt(8)))
    stop = _StopAt(8)
    b = list(spread.iter_checkpoints([64], SEED, until=stop))
    assert [c.step for c in a] == [c.step for c in b] == [8] and stop.seen == 8
    assert np.array_equal(a[0].image, b[0].image)
    assert len(spread.chunks([64], SEED)) == 33
    assert 5 <= len(counting.submitted) <= 5 + cluster.AHEAD_PER_THREAD * 2
    back = [f for f in counting.submitted if f not in counting.cancelled]
    assert len(back) >= 5 and all(f.done() for f in back)  # every chunk not cancelled came back (and was used)


def test_a_worker_refuses_to_render_other_pixels_than_the_client(tmp_path):
    """A worker with another Mitsuba (any other setting of the cache key) or another scene file refuses,
    saying what differs; a worker's error carries its host name."""
    recipe = ChunkRecipe.of(ReferenceRenderer(_scene(), cache_dir=False, progress=False))
    other = dataclasses.replace(recipe, settings={**recipe.settings, "mitsuba": "0.0.1"}, key="another")
    with pytest.raises(CompareError, match=r"dask worker .*would render other pixels than the client \(mitsuba "
                                           r"'[\d.]+' here, '0.0.1' on the client\)"):
        render_chunk(other, 1, 0)
    missing = dataclasses.replace(recipe, files={"/nonexistent/mesh.glb": "0" * 64}, key="a third")
    with pytest.raises(CompareError, match=r"cannot read the scene's file /nonexistent/mesh.glb"):
        render_chunk(missing, 1, 0)
    (tmp_path / "map.png").write_bytes(b"not the client's map")
    changed = dataclasses.replace(recipe, files={str(tmp_path / "map.png"): "0" * 64}, key="a fourth")
    with pytest.raises(CompareError, match=r"map.png differs from the client's"):
        render_chunk(changed, 1, 0)
    image, seconds = render_chunk(recipe, 2, 7)  # the recipe as it is: the client's pixels
    assert np.array_equal(image, ReferenceRenderer(_scene(), cache_dir=False, progress=False).render_chunk(2, 7)[0])


def test_a_failure_of_the_cluster_is_one_error_naming_the_pass():
    from compare.mitsuba.cluster import _result
    from compare.mitsuba.reference import Chunk

    class Died:
        def result(self):
            raise RuntimeError("worker tcp://10.0.0.2:4000 died")

    with pytest.raises(RendererError, match=r"a reference pass of 4 spp \(seed 9\) failed on the dask cluster: "
                                            r"RuntimeError: worker tcp://10\.0\.0\.2:4000 died"):
        _result(Died(), Chunk(4, 9, 8, "k"))


def test_compare_run_with_fewer_jobs_than_workers_spreads_the_reference(client, tmp_path):
    """One scene at one size on two workers: the job's reference renders its passes on both, and the
    results are those of a serial run (separate caches: both render every pass)."""
    from compare.report.results import RunSettings
    from compare.run.runner import run
    from tests.test_executor import _strip

    client.run(lambda: __import__("compare.mitsuba.cluster", fromlist=["_"])._RENDERERS.clear())
    settings = RunSettings(frames=4, spp=8, renderers=["mitsuba"], sizes=[[24, 18]])
    run([CORNELL], tmp_path / "serial", settings, progress=False, cache_dir=tmp_path / "c1", report=False)
    run([CORNELL], tmp_path / "dask", settings, progress=False, cache_dir=tmp_path / "c2", report=False,
        executor=client)
    assert _chunks_on_workers(client) > 0
    a = _strip(json.loads((tmp_path / "serial" / "results.json").read_text()))
    b = _strip(json.loads((tmp_path / "dask" / "results.json").read_text()))
    assert a == b


def test_the_bench_item_times_both_sides_and_says_what_it_needs(monkeypatch):
    """``compare bench --only reference-dask``: the two sides' medians, derived into the bench's item list;
    without dask the item is skipped with the install command."""
    import sys

    from compare.bench.reference import bench_dask_passes
    from compare.bench.suite import all_items
    from compare.util.errors import MissingComponentError

    pytest.importorskip("distributed", reason="the dask extra is not installed (pip install '.[dask]')")
    assert "reference-dask" in all_items()
    (f,) = bench_dask_passes(_scene(), spp=8, repeats=2)
    assert f.name == "reference-dask" and f.a_median > 0 and f.b_median > 0 and len(f.b_samples) == 2
    assert "8 spp at 24x18 in 4 chunks of at most 4 spp" in f.note
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if not installed
    with pytest.raises(MissingComponentError, match=r"pip install '\.\[dask\]'"):
        bench_dask_passes(_scene(), spp=8, repeats=1)
