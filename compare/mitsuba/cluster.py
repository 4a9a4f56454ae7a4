"""One reference render's chunks on the workers of a dask cluster, merged here as if rendered here.

A reference (:class:`compare.mitsuba.reference.ReferenceRenderer`) is a list of
independent chunks, each ``spp`` samples with its own Mitsuba seed
(:meth:`~compare.mitsuba.reference.ReferenceRenderer.chunks`). Given a
``distributed.Client``, :func:`render_on_workers` submits the chunks missing from the
cache to the workers (:func:`render_chunk`, run there), stores each one in this
process's cache as it arrives (atomically, with the seconds the worker took, as
a chunk rendered here is stored), and hands them to the merge in the order of the
plan, so the checkpoints are the serial render's bit for bit. Workers only render
and send back: they write no chunk, so they need no shared cache. A reference gets
them as ``ReferenceRenderer(scene, workers=DaskWorkers(client))``.

What a worker needs: the same package version and Mitsuba (its settings, the
cache key, are checked against the client's and a difference is refused with
what differs), the Mitsuba variant the client renders with, and the scene's files
(meshes, maps, environments) at the paths the client read them from, with the
same content (checked). Identical pixels across machines also assume the same
kind of CPU: Dr.Jit compiles for the CPU it runs on.

A worker process renders one chunk at a time with all its cores (as a render
here does), keeping the Mitsuba scene of the last few references it rendered, so
only its first chunk of a reference pays the scene load and the JIT warm-up
(untimed, as here).
"""

from __future__ import annotations

import contextlib
import json
import pickle
import platform
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from compare.mitsuba.reference import Chunk, ReferenceRenderer
from compare.renderers.base import RendererError
from compare.scene.model import Scene
from compare.util.errors import CompareError
from compare.util.files import sha256_bytes

__all__ = ["ChunkRecipe", "DaskWorkers", "render_chunk", "render_on_workers"]

#: Chunks a client keeps submitted ahead of the merge, per worker thread: enough to keep every worker
#: busy, few enough that a render that stops early (``until``) wastes little.
AHEAD_PER_THREAD = 2
#: References whose Mitsuba scene a worker process keeps loaded.
KEEP_RENDERERS = 2


@dataclass(frozen=True)
class ChunkRecipe:
    """What a worker needs to render a reference's chunks with the client's pixels (plain data: pickled)."""

    scene: Scene
    materials: str
    variant: str
    max_depth: int
    sampler: str
    settings: dict
    """The client's :meth:`~compare.mitsuba.reference.ReferenceRenderer.settings` (its cache key)."""
    files: dict[str, str]
    """The scene's files as the client read them: path → SHA-256 of the content."""
    key: str
    """What a worker keeps its renderer under: the settings and the scene object itself (a scene changed in
    code, e.g. without its maps, keeps its file's hash)."""

    @classmethod
    def of(cls, reference: ReferenceRenderer) -> "ChunkRecipe":
        """The recipe of ``reference``'s chunks."""
        settings = reference.settings()
        key = sha256_bytes(json.dumps(settings, sort_keys=True), pickle.dumps(reference.scene))
        return cls(reference.scene, reference.materials, reference.variant, reference.max_depth,
                   reference.sampler, settings, _file_hashes(reference.scene.referenced_files), key)


def _file_hashes(paths) -> dict[str, str]:
    """path → SHA-256 of each file's content, read here (a file gone since the scene was loaded is an error)."""
    out = {}
    for p in paths:
        try:
            out[str(p)] = sha256_bytes(Path(p).read_bytes())
        except OSError as exc:
            raise CompareError(f"cannot read the scene's file {p} ({exc.strerror or exc})") from None
    return out


# ----------------------------------------------------------------------------- on a worker

_RENDERERS: OrderedDict[str, ReferenceRenderer] = OrderedDict()
# One render at a time per process: Dr.Jit already spreads a render over every core, and a
# second one beside it would slow both (their seconds are the results' timings).
_LOCK = threading.Lock()


def render_chunk(recipe: ChunkRecipe, spp: int, seed: int) -> tuple[np.ndarray, float]:
    """Render one chunk of ``spp`` samples with Mitsuba seed ``seed`` (run on a dask worker).

    Returns the float32 image and the seconds the render took, as
    :meth:`~compare.mitsuba.reference.ReferenceRenderer.render_chunk` does in the client.

    Raises
    ------
    CompareError
        This worker would render other pixels than the client (another Mitsuba, package version or
        variant; a scene file missing or different), or the render failed; the message names the worker.
    """
    host = platform.node()
    try:
        with _LOCK:
            return _renderer(recipe).render_chunk(int(spp), int(seed))
    except CompareError as exc:
        raise type(exc)(f"dask worker {host}: {exc}") from None


def _renderer(recipe: ChunkRecipe) -> ReferenceRenderer:
    """This process's renderer of ``recipe`` (made and checked on first use, kept for the next chunks)."""
    if recipe.key in _RENDERERS:
        _RENDERERS.move_to_end(recipe.key)
        return _RENDERERS[recipe.key]
    for path, digest in recipe.files.items():
        try:
            same = sha256_bytes(Path(path).read_bytes()) == digest
        except OSError as exc:
            raise CompareError(f"cannot read the scene's file {path} ({exc.strerror or exc}): a worker reads the "
                               "scene's files at the client's paths (run it from a checkout at the same path, or "
                               "share the folder)") from None
        if not same:
            raise CompareError(f"the scene's file {path} differs from the client's; run the worker from the same "
                               "checkout")
    r = ReferenceRenderer(recipe.scene, materials=recipe.materials, variant=recipe.variant,
                          max_depth=recipe.max_depth, sampler=recipe.sampler, cache_dir=False, progress=False)
    mine = r.settings()
    wrong = sorted(k for k in set(mine) | set(recipe.settings) if mine.get(k) != recipe.settings.get(k))
    if wrong:
        what = "; ".join(f"{k} {mine.get(k)!r} here, {recipe.settings.get(k)!r} on the client" for k in wrong)
        raise CompareError(f"would render other pixels than the client ({what}); install the same version "
                           "on every worker")
    _RENDERERS[recipe.key] = r
    while len(_RENDERERS) > KEEP_RENDERERS:
        _RENDERERS.popitem(last=False)
    return r


# ----------------------------------------------------------------------------- on the client


class DaskWorkers:
    """A dask cluster's workers as the place a reference renders its chunks (``ReferenceRenderer(workers=…)``).

    Parameters
    ----------
    client : distributed.Client
        Connected to the cluster (e.g. to a ``distributed.LocalCluster``); not closed here.
    """

    def __init__(self, client):
        if not callable(getattr(client, "submit", None)) or not callable(getattr(client, "scatter", None)):
            raise ValueError(f"client: expected a distributed.Client, got {type(client).__name__}")
        self.client = client

    def images(self, reference: ReferenceRenderer, chunks: list[Chunk]) -> Iterator[tuple[np.ndarray, float]]:
        """(image, seconds) of each of ``chunks`` in order (:func:`render_on_workers`)."""
        return render_on_workers(reference, chunks, self.client)


def render_on_workers(reference: ReferenceRenderer, chunks: list[Chunk], client
                      ) -> Iterator[tuple[np.ndarray, float]]:
    """(image, seconds) of each of ``chunks`` in order, those not in ``reference``'s cache rendered by
    ``client``'s workers.

    Up to :data:`AHEAD_PER_THREAD` chunks per worker thread are submitted ahead of the one the merge
    waits for; each is cached as it arrives (so an interrupted render keeps every chunk that came
    back). Closing the iterator cancels the chunks still submitted. Called inside a dask task (a
    job of ``compare run``), it gives its worker thread back while it waits (dask's
    ``secede``/``rejoin``), so that worker renders chunks too.

    Raises
    ------
    CompareError
        A worker refused or failed a chunk (:func:`render_chunk`); any other failure of the cluster
        (a worker that died) as :class:`~compare.renderers.base.RendererError`.
    """
    from distributed import as_completed

    ahead = AHEAD_PER_THREAD * max(1, sum(client.nthreads().values()))
    missing = [reference.cached(c) is None for c in chunks]
    recipe = client.scatter(ChunkRecipe.of(reference), hash=False)  # sent once, not with every chunk
    pending: dict[int, object] = {}  # plan index → future
    arrived: dict[int, tuple[np.ndarray, float]] = {}
    index: dict[str, int] = {}
    finished = as_completed()
    submitted = 0
    try:
        with _seceded():
            for i, chunk in enumerate(chunks):
                while submitted < min(len(chunks), i + ahead):
                    c = chunks[submitted]
                    if missing[submitted]:
                        future = client.submit(render_chunk, recipe, c.spp, c.seed, pure=False)
                        pending[submitted], index[future.key] = future, submitted
                        finished.add(future)
                    submitted += 1
                while i in pending:
                    j = index.pop(next(finished).key)
                    image, seconds = _result(pending.pop(j), chunks[j])
                    reference.store_chunk(chunks[j].spp, chunks[j].seed, image, seconds)
                    arrived[j] = image, seconds
                # a chunk that was in the cache is read (and checked) as a serial render reads it
                yield arrived.pop(i) if i in arrived else reference.render_chunk(chunk.spp, chunk.seed)
    finally:
        if pending:
            client.cancel(list(pending.values()))


def _result(future, chunk: Chunk) -> tuple[np.ndarray, float]:
    try:
        image, seconds = future.result()
    except CompareError:
        raise
    except Exception as exc:  # noqa: BLE001 - the cluster's own failures (a killed worker) as one error
        raise RendererError(f"a reference pass of {chunk.spp} spp (seed {chunk.seed}) failed on the dask "
                            f"cluster: {type(exc).__name__}: {exc}") from exc
    return np.asarray(image, dtype=np.float32), float(seconds)


@contextlib.contextmanager
def _seceded():
    """Inside a dask task, leave the worker's thread pool while waiting (dask's ``secede``), so the
    worker runs the chunks this task waits for; rejoin at the end."""
    from distributed import get_worker, rejoin, secede

    try:
        get_worker()
    except ValueError:  # not in a task: nothing to give back
        yield
        return
    secede()
    try:
        yield
    finally:
        rejoin()
