"""The path-traced reference: Mitsuba 3 on Dr.Jit, with an spp ladder and a result cache.

A render of N samples per pixel is built from independent passes whose sample
counts double (1, 1, 2, 4, …), so the same passes give the whole ladder of
checkpoints (1, 2, 4, …, N spp) for error-against-time curves, and a longer
render reuses every pass of a shorter one. Passes larger than ``max_pass_spp``
are split into chunks so memory stays bounded at high resolutions.

Every chunk is cached as an EXR keyed by the scene hash and every setting that
changes its pixels (variant, material mode, depth, sampler, spp, seed) and
written atomically, so an interrupted render resumes where it stopped and never
reads a broken file. Each chunk records the seconds it took, so cumulative
times stay meaningful when some chunks come from the cache.

Given ``workers`` (a dask cluster's, :class:`compare.mitsuba.cluster.DaskWorkers`),
the chunks a render needs that are not in the cache are rendered there in
parallel; each comes back with its seconds and is cached here as if rendered
here, and the passes are merged in the same order as without workers, so the
checkpoints are the same bit for bit.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np
from tqdm.auto import tqdm

from compare import __version__
from compare.mitsuba.backend import load_mitsuba
from compare.image.exr import read_exr, write_exr
from compare.renderers.base import Checkpoint
from compare.util.code import code_fingerprint
from compare.util.errors import ImageError
from compare.util.files import sha256_bytes
from compare.util.cache import default_cache_dir
from compare.mitsuba.scene_dict import MATERIAL_MODELS, MATERIAL_MODES, PRINCIPLED_MODES, scene_dict, world_scale
from compare.scene.loader import Scene

#: Largest number of samples per pixel rendered in one Mitsuba call.
MAX_PASS_SPP = 64


def derive_seed(*parts: object) -> int:
    """A 32-bit Mitsuba seed derived from arbitrary parts (independent streams per pass)."""
    return int(sha256_bytes(*(repr(p) for p in parts))[:8], 16)


def ladder_passes(spp: int) -> list[int]:
    """Pass sizes whose running sums are 1, 2, 4, …, spp (the last sum is ``spp`` itself)."""
    if spp < 1:
        raise ValueError(f"spp: expected a positive integer, got {spp}")
    passes, total = [1], 1
    while total < spp:
        step = min(total, spp - total)
        passes.append(step)
        total += step
    return passes


def pass_plan(checkpoints: list[int]) -> list[int]:
    """Running spp sums to render for ``checkpoints``: the checkpoints and the doubling ladder up
    to the last one (:func:`ladder_passes`)."""
    sums = {int(c) for c in checkpoints}
    sums.update(int(t) for t in np.cumsum(ladder_passes(int(max(sums)))))
    return sorted(sums)


@dataclass(frozen=True)
class Chunk:
    """One chunk of a render, the unit of work and of caching: ``spp`` samples with Mitsuba seed ``seed``,
    part of the pass that brings the render to ``total`` samples; ``key`` is its cache key."""

    spp: int
    seed: int
    total: int
    key: str


@dataclass
class RenderResult:
    """A finished reference render: linear radiance (H, W, 3) float32 and how it was made."""

    image: np.ndarray
    spp: int
    seed: int
    seconds: float
    metadata: dict = field(default_factory=dict)


class ReferenceRenderer:
    """Path-traced reference renders of one scene.

    Parameters
    ----------
    scene
        The scene (its resolution is the render resolution).
    materials
        ``"shared"`` (the suite's BRDF plugin), ``"cycles"`` / ``"cycles-ggx"`` (the plugin's Blender Principled v2
        flavour) or ``"diffuse"`` (Lambert); see :mod:`compare.mitsuba.scene_dict`.
    variant
        Mitsuba variant; None picks cuda_ad_rgb > llvm_ad_rgb > scalar_rgb.
    max_depth
        Path depth override (2 = direct light only); None uses the scene's.
    cache_dir
        Where passes are cached; None uses :func:`compare.util.cache.default_cache_dir`; False disables caching.
    progress
        Show a progress bar on renders.
    max_pass_spp
        Largest chunk of a pass (:data:`MAX_PASS_SPP`); smaller chunks are smaller units of work for
        ``workers``. The chunks' seeds follow from it, so renders compare bit for bit only
        with the same value.
    workers
        Where the chunks missing from the cache are rendered, with the same pixels as here:
        :class:`compare.mitsuba.cluster.DaskWorkers` (a dask cluster's workers); None: here. (Passed
        in, not imported here: this module's code is in the cache key, and how chunks travel does
        not change their pixels.)
    """

    def __init__(self, scene: Scene, *, materials: str = "shared", variant: str | None = None,
                 max_depth: int | None = None, sampler: str = "independent",
                 cache_dir: Path | str | None | bool = None, progress: bool = True,
                 max_pass_spp: int = MAX_PASS_SPP, workers=None):
        if materials not in MATERIAL_MODES:
            raise ValueError(f"materials: expected one of {', '.join(MATERIAL_MODES)}, got {materials!r}")
        if isinstance(max_pass_spp, bool) or not isinstance(max_pass_spp, int) or max_pass_spp < 1:
            raise ValueError(f"max_pass_spp: expected a positive integer, got {max_pass_spp!r}")
        if workers is not None and not callable(getattr(workers, "images", None)):
            raise ValueError(f"workers: expected compare.mitsuba.cluster.DaskWorkers, got {type(workers).__name__}")
        self.scene = scene
        self.materials = materials
        self.max_depth = scene.max_depth if max_depth is None else int(max_depth)
        self.sampler = sampler
        self.progress = progress
        self.max_pass_spp = max_pass_spp
        self.workers = workers
        self.mi = load_mitsuba(variant)
        self.variant = self.mi.variant()
        self.cache_dir = None if cache_dir is False else Path(cache_dir or default_cache_dir())
        self.world_scale = world_scale(scene)  # in every cache key: computed once, not per pass
        self._mi_scene = None
        #: (per-pixel variance of the last checkpoint's mean, its degrees of freedom) from the spread of
        #: the independent passes it averages (iter_checkpoints), or None before one with two passes.
        self.variance: tuple[np.ndarray, int] | None = None
        self.load_seconds = 0.0
        self.warmup_seconds: float | None = None

    # -- Mitsuba scene, built once ---------------------------------------------------------

    @property
    def mi_scene(self):
        """The loaded Mitsuba scene (built on first use; the time is in ``load_seconds``)."""
        if self._mi_scene is None:
            t0 = time.perf_counter()
            d = scene_dict(self.scene, spp=1, materials=self.materials, sampler=self.sampler,
                           max_depth=self.max_depth, scale=self.world_scale)
            self._mi_scene = self.mi.load_dict(d)
            self.load_seconds = time.perf_counter() - t0
        return self._mi_scene

    def _warm_up(self) -> None:
        """Render one untimed, uncached sample per pixel before the first timed pass.

        Dr.Jit compiles the render kernel on the first call (about 0.5 s here);
        that one-time cost belongs with set-up (``warmup_seconds``), not in the
        first checkpoint of an error-against-time curve.
        """
        if self.warmup_seconds is None:
            t0 = time.perf_counter()
            np.array(self.mi.render(self.mi_scene, spp=1, seed=0xFFFFFFFF))
            self.warmup_seconds = time.perf_counter() - t0

    def settings(self) -> dict:
        """Every setting that changes the pixels (the cache key, also written as metadata)."""
        cam = self.scene.camera
        settings = {
            "scene_hash": self.scene.hash,
            "variant": self.variant,
            "materials": self.materials,
            "max_depth": self.max_depth,
            "sampler": self.sampler,
            "resolution": [cam.width, cam.height],
            "mitsuba": self.mi.__version__,
            # the code that makes the pixels: a change to it must not reuse cached passes
            "code": code_fingerprint(__name__),
        }
        if self.materials in MATERIAL_MODELS:  # a changed model must not reuse the old model's passes
            settings["material_model"] = MATERIAL_MODELS[self.materials]
        if self.materials in PRINCIPLED_MODES:  # what the report says the ground truth models
            forced = PRINCIPLED_MODES[self.materials]
            settings["distribution"] = "/".join(sorted({forced or m.distribution
                                                        for m in self.scene.materials.values()}))
        if self.world_scale != 1.0:  # tiny scenes are rendered scaled up (keys of all others stay as they were)
            settings["world_scale"] = self.world_scale
        return settings

    # -- one chunk: the unit of work and of caching ---------------------------------------

    def _chunk_key(self, spp: int, seed: int, settings: dict | None = None) -> str:
        """The cache key of a chunk: every setting that changes its pixels, its spp and its seed."""
        return sha256_bytes(json.dumps({**(settings or self.settings()), "spp": spp, "seed": seed}, sort_keys=True))

    def _chunk_path(self, spp: int, seed: int, key: str | None = None) -> Path | None:
        if self.cache_dir is None:
            return None
        key = key or self._chunk_key(spp, seed)
        return self.cache_dir / "reference" / key[:2] / f"{key}.exr"

    def render_chunk(self, spp: int, seed: int) -> tuple[np.ndarray, float]:
        """Render (or load from cache) one pass of ``spp`` samples with Mitsuba seed ``seed``.

        Returns the image and the seconds the render took when it was made.
        """
        path = self._chunk_path(spp, seed)
        if path is not None and path.is_file():
            cached = self._verified_entry(path, spp, seed)
            if cached is not None:
                return cached
        scene = self.mi_scene
        self._warm_up()
        t0 = time.perf_counter()
        image = np.array(self.mi.render(scene, spp=int(spp), seed=int(seed)), dtype=np.float32)
        seconds = time.perf_counter() - t0
        _check_render(image, spp, seed)
        self.store_chunk(spp, seed, image, seconds)
        return image, seconds

    def store_chunk(self, spp: int, seed: int, image: np.ndarray, seconds: float) -> None:
        """Cache a chunk rendered here or on a worker (atomically; nothing without a cache)."""
        path = self._chunk_path(spp, seed)
        if path is not None:
            write_exr(path, image, metadata={"renderer": "mitsuba", **_flat(self.settings()), "spp": int(spp),
                                             "seed": int(seed), "seconds": seconds, "package": __version__,
                                             "pixels_sha256": _pixels_hash(image)})

    def _verified_entry(self, path: Path, spp: int, seed: int) -> tuple[np.ndarray, float] | None:
        """A cache entry's (image, seconds) when it is what its key says; else None, the entry removed
        and a warning given (it is rendered again: never used, never left to fail every rerun)."""
        cam = self.scene.camera
        try:
            image, meta = read_exr(path)
            want = {**_flat(self.settings()), "spp": int(spp), "seed": int(seed)}
            wrong = sorted(k for k, v in want.items() if meta.get(k) != v)
            if wrong:
                why = f"made with other {', '.join(wrong)}"
            elif image.shape != (cam.height, cam.width, 3):
                why = f"{image.shape[1]}x{image.shape[0]} pixels instead of {cam.width}x{cam.height}"
            elif "pixels_sha256" not in meta:
                why = "written by an older version, without a checksum of its pixels"
            elif meta.get("pixels_sha256") != _pixels_hash(image):
                why = "its pixels do not match the checksum it was written with"
            else:
                return image, float(meta["seconds"])
        except (ImageError, KeyError, ValueError) as exc:
            why = f"unreadable ({exc})"
        warnings.warn(f"reference cache: discarded {path} ({why}); rendering that pass again", stacklevel=3)
        path.unlink(missing_ok=True)
        return None

    def _pass_chunks(self, seed: int, index: int, spp: int) -> Iterator[tuple[int, int]]:
        """(chunk spp, chunk seed) for pass ``index`` of ``spp`` samples."""
        done, part = 0, 0
        while done < spp:
            n = min(self.max_pass_spp, spp - done)
            yield n, derive_seed("reference", seed, index, spp, part)
            done += n
            part += 1

    def chunks(self, checkpoints: list[int], seed: int = 0) -> list[Chunk]:
        """Every chunk a render of ``checkpoints`` (:meth:`iter_checkpoints`) needs, in the order its passes
        are merged."""
        settings = self.settings()
        out, done = [], 0
        for index, upto in enumerate(pass_plan(checkpoints)):
            out += [Chunk(n, chunk_seed, upto, self._chunk_key(n, chunk_seed, settings))
                    for n, chunk_seed in self._pass_chunks(seed, index, upto - done)]
            done = upto
        return out

    def _chunk_images(self, chunks: list[Chunk]) -> Iterator[tuple[np.ndarray, float]]:
        """(image, seconds) of each chunk in order: from the cache, else rendered here or on ``workers``."""
        if self.workers is not None and any(self.cached(c) is None for c in chunks):
            return self.workers.images(self, chunks)
        return (self.render_chunk(c.spp, c.seed) for c in chunks)

    def cached(self, chunk: Chunk) -> Path | None:
        """The cache entry of ``chunk`` when there is one (not yet checked: :meth:`render_chunk` checks it)."""
        path = self._chunk_path(chunk.spp, chunk.seed, chunk.key)
        return path if path is not None and path.is_file() else None

    # -- public API ------------------------------------------------------------------------

    def iter_ladder(self, spp: int, seed: int = 0) -> Iterator[Checkpoint]:
        """Yield a :class:`Checkpoint` after each doubling pass (1, 2, 4, …, spp samples)."""
        yield from self.iter_checkpoints(list(np.cumsum(ladder_passes(int(spp)))), seed)

    def iter_checkpoints(self, checkpoints: list[int], seed: int = 0, *, until=None) -> Iterator[Checkpoint]:
        """Yield a :class:`Checkpoint` at each of the ascending spp counts ``checkpoints``.

        Samples are rendered in passes whose running sums are the checkpoints and, between them,
        the doubling ladder up to the last one (:func:`pass_plan`), so every ladder shares its passes
        (and the cache) with the others: a ground truth rendered with one checkpoint is bit for bit
        the end of the doubling ladder of the same seed.

        ``until`` (e.g. :class:`compare.image.convergence.Stopping`) ends the render early: its
        ``add(image, spp)`` sees every independent chunk, and its ``met(spp)`` is asked after each pass;
        the first running sum it accepts is the last checkpoint. The passes are the same as without it,
        so a render that stopped at N spp is bit for bit the render of N spp.

        With ``workers``, the chunks missing from the cache are rendered there, a few ahead of the merge
        (those submitted past an early stop are cancelled); the merge is the same.
        """
        wanted = {int(c) for c in checkpoints}
        plan = self.chunks(checkpoints, seed)
        acc = np.zeros((self.scene.camera.height, self.scene.camera.width, 3), dtype=np.float64)
        acc2 = np.zeros_like(acc)  # sum of n x^2 over chunk means: the spread of the passes
        chunks = 0
        self.variance = None  # of this call's checkpoints only
        total_spp, total_s = 0, 0.0
        # closing: a render that stops early (``until``, an error) cancels the chunks still on workers
        with tqdm(total=int(max(wanted)), unit="spp", desc=f"mitsuba {self.scene.name[:30]}",
                  disable=not self.progress, leave=False) as bar, \
                contextlib.closing(self._chunk_images(plan)) as images:
            for upto, group in itertools.groupby(plan, key=lambda c: c.total):
                for chunk in group:
                    n = chunk.spp
                    image, seconds = next(images)
                    x = image.astype(np.float64)
                    acc += x * n
                    acc2 += x * x * n
                    chunks += 1
                    if until is not None:
                        until.add(image, n)
                    total_s += seconds
                    bar.update(n)
                total_spp = upto
                stop = until is not None and until.met(total_spp)
                if total_spp in wanted or stop:
                    mean = acc / total_spp
                    if chunks >= 2:
                        # Each chunk mean x_i of n_i samples has variance s^2 / n_i, so
                        # sum n_i (x_i - mean)^2 / (C - 1) estimates s^2 (C - 1 degrees of freedom).
                        spread = np.maximum(acc2 - total_spp * mean * mean, 0.0)
                        self.variance = ((spread / ((chunks - 1) * total_spp)).astype(np.float32), chunks - 1)
                    yield Checkpoint(total_spp, total_s, mean.astype(np.float32))
                if stop:
                    return

    def ladder(self, spp: int, seed: int = 0) -> list[Checkpoint]:
        """All checkpoints of :meth:`iter_ladder` as a list."""
        return list(self.iter_ladder(spp, seed))

    def render_layers(self, spp: int, seed: int = 0) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
        """Per-effect ground truths (:mod:`compare.mitsuba.layers`) of ``spp`` samples.

        One render with the layers integrator in place of ``path`` (same scene, materials
        and depth): returns (its image, {layer: image}, seconds). The layers of
        :data:`~compare.metrics.layers.SUM_LAYERS` sum to the image; they are not
        cached (a run keeps them in its folder).
        """
        from compare.mitsuba import layers as reference_layers

        reference_layers.register()
        d = scene_dict(self.scene, spp=1, materials=self.materials, sampler=self.sampler,
                       max_depth=self.max_depth, scale=self.world_scale)
        d["integrator"] = {"type": reference_layers.INTEGRATOR_NAME, "max_depth": int(self.max_depth),
                           "holes": self.scene.features().holes, "background": not self.scene.hides_background}
        scene = self.mi.load_dict(d)
        acc = None
        total, seconds = 0, 0.0
        for n, chunk_seed in self._pass_chunks(derive_seed("layers", seed), 0, int(spp)):
            t0 = time.perf_counter()
            channels = np.array(self.mi.render(scene, spp=int(n), seed=int(chunk_seed)), dtype=np.float64)
            seconds += time.perf_counter() - t0
            if not np.all(np.isfinite(channels)):
                raise ImageError(f"{self.scene.path}: the layers render of {n} spp (seed {chunk_seed}) holds "
                                 f"{int((~np.isfinite(channels)).sum())} non-finite values")
            acc = channels * n if acc is None else acc + channels * n
            total += n
        image, layers = reference_layers.split_layers((acc / total).astype(np.float32))
        return image, layers, seconds

    def render(self, spp: int, seed: int = 0) -> RenderResult:
        """Render ``spp`` samples per pixel (the last checkpoint of the ladder)."""
        last = None
        for last in self.iter_ladder(spp, seed):
            pass
        assert last is not None
        meta = {"renderer": "mitsuba", **_flat(self.settings()), "spp": last.step, "seed": int(seed),
                "seconds": last.seconds, "package": __version__}
        return RenderResult(last.image, last.step, int(seed), last.seconds, meta)

    def independent_passes(self, count: int, spp: int, seed: int = 0) -> np.ndarray:
        """``count`` statistically independent renders of ``spp`` samples each, stacked (count, H, W, 3).

        Their spread gives per-pixel standard errors: ``stack.std(0, ddof=1) / sqrt(count)``
        is the standard error of ``stack.mean(0)``.
        """
        out = []
        for k in tqdm(range(count), desc="independent passes", disable=not self.progress, leave=False):
            acc, total = None, 0
            for n, chunk_seed in self._pass_chunks(derive_seed("independent", seed, k), 0, spp):
                image, _ = self.render_chunk(n, chunk_seed)
                acc = image.astype(np.float64) * n if acc is None else acc + image * n
                total += n
            out.append((acc / total).astype(np.float32))
        return np.stack(out)


def _pixels_hash(image: np.ndarray) -> str:
    """Checksum of a pass's float32 pixels, written into its cache entry and checked on read."""
    return sha256_bytes(np.ascontiguousarray(image, dtype=np.float32).tobytes())


def _flat(d: dict) -> dict:
    return {k: (json.dumps(v) if isinstance(v, (list, dict)) else v) for k, v in d.items()}


def _check_render(image: np.ndarray, spp: int, seed: int) -> None:
    bad = ~np.isfinite(image)
    if bad.any():
        loc = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ImageError(f"Mitsuba produced {int(bad.sum())} non-finite values (first at {loc}) "
                         f"at spp={spp}, seed={seed}; the scene has a numerical problem")
