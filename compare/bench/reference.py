"""The reference's own benchmark (``compare bench`` items about its internals): what its pass wrapper
(:meth:`compare.mitsuba.reference.ReferenceRenderer.render_chunk`) costs over a bare ``mi.render``. Here, not
in the engine, so that the reference's render and pass-cache keys hold no bench code."""

from __future__ import annotations

import time

import numpy as np

from compare.util.figures import Figure, median as _median

__all__ = ["ITEMS", "bench_wrapper_overhead"]


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


def _wrapper_overhead(scene, *, frames: int, spp: int, repeats: int, context) -> list[Figure]:
    return bench_wrapper_overhead(scene, spp=min(spp, 64), repeats=repeats)


#: The reference's bench items, by name (``compare bench --only``).
ITEMS = {"wrapper-overhead": _wrapper_overhead}
