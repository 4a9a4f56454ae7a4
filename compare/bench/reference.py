"""The reference's own benchmark (``compare bench`` items about its internals): what its pass wrapper
(:meth:`compare.mitsuba.reference.ReferenceRenderer.render_chunk`) costs over a bare ``mi.render``, and what
spreading one render's passes over a dask cluster's workers gains (:mod:`compare.mitsuba.cluster`). Here,
not in the engine, so that the reference's render and pass-cache keys hold no bench code."""

from __future__ import annotations

import time

import numpy as np

from compare.util.errors import MissingComponentError
from compare.util.figures import Figure, median as _median

__all__ = ["ITEMS", "bench_dask_passes", "bench_wrapper_overhead"]

#: Workers of the reference-dask item's LocalCluster, and the largest chunk of its passes (many small
#: units of work: the case where the workers' start-up per chunk matters most).
DASK_WORKERS = 2
DASK_PASS_SPP = 4


def bench_wrapper_overhead(scene, *, spp: int, repeats: int) -> list[Figure]:
    """ReferenceRenderer.render_chunk against a bare mi.render of the same dictionary."""
    from compare.mitsuba.reference import ReferenceRenderer
    from compare.mitsuba.scene_dict import scene_dict

    r = ReferenceRenderer(scene, cache_dir=False, progress=False)
    mi = r.mi
    bare_scene = mi.load_dict(scene_dict(scene, spp=1))
    r.render_chunk(spp, 0)  # JIT both once
    np.array(mi.render(bare_scene, spp=spp, seed=0))
    wrapped, bare = [], []
    for k in range(repeats):
        t0 = time.perf_counter()
        r.render_chunk(spp, 1000 + k)
        wrapped.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        np.array(mi.render(bare_scene, spp=spp, seed=2000 + k))
        bare.append(time.perf_counter() - t0)
    return [Figure("wrapper-overhead", "ReferenceRenderer pass", "bare mi.render", _median(wrapped), _median(bare),
                   "s", repeats, f"{spp} spp, cache off", wrapped, bare)]


def bench_dask_passes(scene, *, spp: int, repeats: int, workers: int = DASK_WORKERS,
                      pass_spp: int = DASK_PASS_SPP) -> list[Figure]:
    """Wall seconds of a reference render here ÷ the same render with its chunks on a ``workers``-worker
    ``distributed.LocalCluster`` (one thread, one process each): the speed-up of spreading one reference.

    Both render the doubling ladder to ``spp`` in chunks of at most ``pass_spp`` samples, with the cache off
    (every chunk rendered, the same pixels on both sides), seeds changing with each repeat, the sides
    alternating. Each side renders once untimed first (the Mitsuba scene's load and the JIT, in this
    process and in every worker).
    """
    try:
        import distributed
    except ImportError:
        raise MissingComponentError("the reference-dask item needs dask.distributed: pip install '.[dask]'") from None
    import logging

    from compare.mitsuba.cluster import DaskWorkers
    from compare.mitsuba.reference import ReferenceRenderer

    with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as cluster, distributed.Client(cluster) as client:
        here = ReferenceRenderer(scene, cache_dir=False, progress=False, max_pass_spp=pass_spp)
        spread = ReferenceRenderer(scene, cache_dir=False, progress=False, max_pass_spp=pass_spp,
                                   workers=DaskWorkers(client))
        client.wait_for_workers(workers)
        n_chunks = len(here.chunks([spp]))
        # untimed: a render as long as a timed one warms every worker (each loads the scene and JITs once)
        for r in (here, spread):
            r.render(spp, seed=0)
        serial, cluster_s = [], []
        for k in range(repeats):
            for r, times in ((here, serial), (spread, cluster_s)):
                t0 = time.perf_counter()
                r.render(spp, seed=1 + k)
                times.append(time.perf_counter() - t0)
    w, h = scene.camera.resolution
    return [Figure("reference-dask", "reference here", f"its chunks on {workers} dask workers", _median(serial),
                   _median(cluster_s), "s", repeats,
                   f"{spp} spp at {w}x{h} in {n_chunks} chunks of at most {pass_spp} spp, cache off; a LocalCluster "
                   f"of {workers} one-thread processes; the ratio is the speed-up", serial, cluster_s)]


def _wrapper_overhead(scene, *, frames: int, spp: int, repeats: int, context) -> list[Figure]:
    return bench_wrapper_overhead(scene, spp=min(spp, 64), repeats=repeats)


def _dask_passes(scene, *, frames: int, spp: int, repeats: int, context) -> list[Figure]:
    return bench_dask_passes(scene, spp=min(spp, 64), repeats=repeats)


#: The reference's bench items, by name (``compare bench --only``).
ITEMS = {"wrapper-overhead": _wrapper_overhead, "reference-dask": _dask_passes}
