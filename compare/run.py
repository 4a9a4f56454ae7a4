"""``compare run``: render every scene with every renderer, measure error against time.

For each scene and resolution this module

1. renders the **ground truth**: the Mitsuba reference at the full budget
   (``--spp``, seed ``s``). Its passes come from the reference cache
   (:mod:`compare.reference`), so a rerun costs nothing;
2. renders the **reference's own convergence curve** (renderer ``mitsuba``): a
   second, *independent* spp ladder with seed ``s + 1`` (1, 2, 4, …, spp
   samples), every checkpoint measured against the ground truth.
   Measuring the ground truth's own ladder against its last checkpoint would
   make the curve fall to exactly 0 at the end and bend down before it,
   because early checkpoints share samples with the final image. An
   independent ladder has no such correlation: its error falls as a Monte
   Carlo estimate should until it meets the **noise floor**, the error between
   two independent full-budget renders, which is this ladder's last point
   (so the floor costs no extra render; see :class:`compare.results.NoiseFloor`
   for what the floor means for each metric). The reference's
   ``noise_floor(spp)`` (two half-budget renders) would cost a third full
   render to say the same thing;
3. renders each **progressive** variant (``progressive`` or
   ``progressive:<option>[+<option>]``, :mod:`compare.variants`: the paper's
   area model, irradiance probes, variance shadow maps, a frame budget) with
   checkpoints at frames 1, 2, 4, …,
   ``--frames``, every checkpoint measured against the ground truth;
4. writes ``results.json`` (:mod:`compare.results`) and the HTML report
   (:mod:`compare.report`).

Resuming
--------
Each (scene, size, renderer) unit stores its result as
``runs/<id>/<renderer>/partial.json`` and its images as EXR (plus PNG
previews) beside it, all written atomically; ``partial.json`` is written last
and so marks the unit finished. A rerun reuses a unit when the key stored in
it equals the key of the current settings: a hash of the scene content, the
resolution, the budget, seeds, tone mapping, material mode, Mitsuba variant
and version, the machine's CPU and core count (timings belong to a machine)
and, for the renderers measured against the ground truth, the ground truth's
key. An interrupted reference ladder also resumes pass by pass through the
reference cache.

Timings
-------
``seconds`` are the renderers' own cumulative render times at each checkpoint:
Mitsuba's per-pass times (recorded when a pass was first rendered, so cached
passes keep their cost) and the progressive renderer's frame times. One-time
set-up (Mitsuba scene load, GL resource creation, shader compilation) is
reported separately as ``setup_seconds``. Metric computation and image writing
happen outside the timed regions.
"""

from __future__ import annotations

import argparse
import datetime
import functools
import json
import os
import platform
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

import numpy as np
from tqdm.auto import tqdm

from . import __version__
from .errors import CompareError, ImageError
from .exr import read_exr, write_exr
from .fsutil import check_output_folder, sha256_bytes, write_text_atomic
from .results import (
    Environment,
    NoiseFloor,
    Point,
    Reference,
    RendererRun,
    Results,
    RunSettings,
    SceneResult,
    check_json_finite,
)
from .scene import Scene, load_scene
from .variants import OPTIONS as VARIANT_OPTIONS

__all__ = [
    "add_run_parser",
    "checkpoint_steps",
    "collect_environment",
    "parse_renderers",
    "parse_sizes",
    "run",
    "scene_id",
]

#: Renderer specs accepted by ``--renderers`` (``progressive:<option>`` too, see compare.variants).
RENDERER_NAMES = ("mitsuba", "progressive", "cycles", "eevee")
#: What the rasterizer's images depend on (its units are redone when any of it changes).
RASTERIZER_SOURCES = ("progressive", "brdf", "ibl", "variants.py", "scene.py", "geometry.py", "gltf.py",
                      "procedural_meshes.py", "environments.py", "encodings.py")
#: Blender's engines (the ``blender`` extra): the paper's reference and its rasterizer comparator.
BLENDER_RENDERERS = ("cycles", "eevee")
#: What ``--renderers all`` means: the paper's Table 1 (and the three area models).
ALL_RENDERERS = ("mitsuba", "progressive", "progressive:paper", "progressive:ltc", "cycles", "eevee")
_HALF_MAX = 65504.0


# --------------------------------------------------------------------------- small helpers


def checkpoint_steps(total: int) -> list[int]:
    """1, 2, 4, …, up to ``total``, always ending with ``total`` (e.g. 100 → …, 64, 100)."""
    if total < 1:
        raise ValueError(f"expected a positive budget, got {total}")
    steps, k = [], 1
    while k < total:
        steps.append(k)
        k *= 2
    steps.append(total)
    return steps


def scene_id(scene: Scene) -> str:
    """A file-name-safe, unique id for a scene at its resolution.

    The scene's name is user text (it may hold anything, even markup); only
    ``[a-z0-9-]`` of it survives, followed by 8 hex digits of the scene file's
    content hash (two files with the same name stay apart) and the size.
    """
    slug = re.sub(r"[^a-z0-9]+", "-", scene.name.lower()).strip("-")[:40] or "scene"
    w, h = scene.camera.resolution
    return f"{slug}-{scene.file_hash[:8]}-{w}x{h}"


def parse_sizes(text: str) -> list[tuple[int, int]]:
    """``"320x240,1280x720"`` → ``[(320, 240), (1280, 720)]``."""
    from .cli import parse_size  # local: cli imports this module to wire the command

    return [parse_size(part.strip()) for part in text.split(",") if part.strip()]


def parse_renderers(text: str | Iterable[str]) -> list[str]:
    """Validate a comma-separated renderer list (``mitsuba``, ``progressive[:<option>[+<option>]]``)."""
    from .variants import renderer_options

    items = [s.strip() for s in (text.split(",") if isinstance(text, str) else text) if s.strip()]
    if not items:
        raise ValueError("expected at least one renderer, e.g. mitsuba,progressive")
    if "all" in items:  # the paper's Table 1, plus anything else listed
        items = list(ALL_RENDERERS) + [i for i in items if i != "all" and i not in ALL_RENDERERS]
    for item in items:
        base, _, option = item.partition(":")
        if base not in RENDERER_NAMES or (base != "progressive" and option) or (":" in item and not option):
            raise ValueError(f"unknown renderer {item!r}; expected mitsuba, progressive, "
                             f"progressive:<option> (compare.variants: {', '.join(VARIANT_OPTIONS)}), cycles, "
                             f"eevee or all")
        if base == "progressive":
            renderer_options(item)  # names an unknown option before hours of reference rendering
    if len(set(items)) != len(items):
        raise ValueError(f"renderer listed twice in {items}")
    return items




def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                key, _, value = line.partition(":")
                # x86 says "model name"; some ARM kernels only "Hardware" or "Processor".
                if key.strip() in ("model name", "Hardware", "Processor", "cpu model") and value.strip():
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def _version(dist: str) -> str | None:
    from importlib import metadata

    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def collect_environment(*, gl_renderer: str | None = None, mitsuba_variant: str | None = None) -> Environment:
    """Describe this machine and the software versions (for the report's environment table)."""
    return Environment(
        cpu=_cpu_model(),
        cores=os.cpu_count() or 1,
        platform=platform.platform(),
        gl_renderer=gl_renderer,
        mitsuba_variant=mitsuba_variant,
        versions={
            "python": platform.python_version(),
            "compare": __version__,
            "mitsuba": _version("mitsuba"),
            "drjit": _version("drjit"),
            "moderngl": _version("moderngl"),
            "numpy": _version("numpy"),
            "flip-evaluator": _version("flip-evaluator"),
        },
    )


def _key(*parts: Any) -> str:
    return sha256_bytes(json.dumps(parts, sort_keys=True, default=str))


def _source_files(*names: str) -> list[Path]:
    """The package's sources (``.py``, ``.glsl``, and ``.npz`` for committed tables such as the LTC
    fit) under ``names`` (folders or files of ``compare/``)."""
    root = Path(__file__).resolve().parent
    files: list[Path] = []
    for name in names:
        path = root / name
        files += (sorted(f for f in path.rglob("*") if f.suffix in (".py", ".glsl", ".npz")) if path.is_dir()
                  else [path])
    return files


@functools.lru_cache(maxsize=None)
def _source_fingerprint(*names: str) -> str:
    """Hash of :func:`_source_files` of ``names``: in a unit's key, so that a finished unit is
    redone once its renderer's code changes (the version number moves only at releases)."""
    root = Path(__file__).resolve().parent
    return _key([(f.relative_to(root).as_posix(), sha256_bytes(f.read_bytes())) for f in _source_files(*names)])


def _flat_metadata(meta: dict) -> dict:
    """Keep JSON scalars, stringify the rest (results.json metadata is flat)."""
    out = {}
    for k, v in (meta or {}).items():
        if isinstance(v, np.generic):
            v = v.item()
        if v is None or isinstance(v, (str, bool, int, float)):
            out[str(k)] = v
        else:
            out[str(k)] = json.dumps(v, default=str) if isinstance(v, (list, tuple, dict)) else str(v)
    return out


def _exr_metadata(meta: dict) -> dict:
    """EXR metadata takes str/int/float only (see compare.exr)."""
    out = {}
    for k, v in _flat_metadata(meta).items():
        if isinstance(v, bool):
            out[k] = int(v)
        elif isinstance(v, (str, int, float)):
            out[k] = v
        elif v is not None:
            out[k] = str(v)
    return out


def _write_image(path: Path, image: np.ndarray, metadata: dict, *, exposure: float, tonemap: str,
                 half: bool = True) -> None:
    """EXR (half floats when the range allows: half the disk, ~3 digits) + tone-mapped PNG preview."""
    from .tonemap import write_png

    use_half = half and float(np.max(np.abs(image), initial=0.0)) < _HALF_MAX
    write_exr(path, image, metadata=_exr_metadata(metadata), half=use_half)
    write_png(path.with_suffix(".png"), image, exposure=exposure, operator=tonemap)


# --------------------------------------------------------------------------- run context


@dataclass
class _Unit:
    """Where one (scene, size, renderer) unit keeps its files."""

    root: Path  # the output folder (results.json lives here)
    dir: Path

    def rel(self, path: Path) -> str:
        return path.relative_to(self.root).as_posix()

    @property
    def partial(self) -> Path:
        return self.dir / "partial.json"

    def load(self, key: str) -> dict | None:
        """The stored result if finished with the same key and every file it names still exists."""
        try:
            d = json.loads(self.partial.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(d, dict) or d.get("key") != key:
            return None
        for rel in _paths_in(d.get("result")):
            if not (self.root / rel).is_file():
                return None
        return d["result"]

    def save(self, key: str, result: dict) -> None:
        check_json_finite(result, f"{self.dir.name} result")
        text = json.dumps({"key": key, "result": result}, indent=1, allow_nan=False)
        write_text_atomic(self.partial, text)


def _paths_in(d: Any) -> Iterable[str]:
    """Every relative file path a stored result points at (image, preview, maps)."""
    if isinstance(d, dict):
        for k, v in d.items():
            if k == "metadata":
                continue  # renderer-reported facts, not files
            if k in ("image", "preview") and isinstance(v, str):
                yield v
            elif k == "maps" and isinstance(v, dict):
                yield from (p for p in v.values() if isinstance(p, str))
            else:
                yield from _paths_in(v)
    elif isinstance(d, list):
        for v in d:
            yield from _paths_in(v)


def _measure(gt: np.ndarray, image: np.ndarray, settings: RunSettings, what: str, *, final: bool) -> dict:
    """Metrics of one checkpoint against the ground truth.

    HDR-FLIP runs several LDR-FLIP passes (one per exposure of its range) and
    costs more than all other metrics together, so it is computed for a
    run's final image only; intermediate checkpoints carry ``flip_hdr: null``.
    """
    from .metrics import compare_images

    try:
        m = compare_images(gt, image, exposure=settings.exposure, operator=settings.tonemap, flip_hdr=final)
    except ImageError as e:
        raise ImageError(f"{what}: {e}") from e
    m.setdefault("flip_hdr", None)
    check_json_finite(m, f"metrics of {what}")
    return m


def _maps(unit: _Unit, gt: np.ndarray, image: np.ndarray, settings: RunSettings) -> dict[str, str]:
    from .metrics import error_maps, save_error_maps

    maps = error_maps(gt, image, exposure=settings.exposure, operator=settings.tonemap)
    written = save_error_maps(unit.dir / "maps", maps)
    return {name: unit.rel(path) for name, path in written.items()}


# --------------------------------------------------------------------------- renderers


def _progressive_checkpoints(scene: Scene, *, frames: int, seed: int, options: dict,
                             checkpoints: list[int], ctx) -> tuple[list[tuple[int, float, np.ndarray]], float, dict]:
    """Run the progressive renderer; returns (checkpoints, setup seconds, metadata).

    A module-level function so that tests can stand in a synthetic renderer.
    ``setup`` is the wall time of the call minus the renderer's own timed
    frames (context-side set-up, shader compilation, uploads, readbacks).
    """
    from .progressive import render_progressive

    kwargs: dict[str, Any] = {"frames": frames, "seed": seed, "checkpoints": tuple(checkpoints), "ctx": ctx,
                              **options}
    t0 = time.perf_counter()
    result = render_progressive(scene, **kwargs)
    wall = time.perf_counter() - t0
    cps = [(int(f), float(s), np.asarray(img, dtype=np.float32)) for f, s, img in result.checkpoints]
    done = len(result.frame_seconds) or frames  # a frame budget decides the count itself
    if not cps or cps[-1][0] != done:
        # The final image is the result even if the renderer did not list it as a checkpoint.
        cps.append((done, float(result.seconds), np.asarray(result.image, dtype=np.float32)))
    meta = dict(result.metadata or {})
    # Prefer the renderer's own set-up time; otherwise everything in the call that was not a timed frame.
    setup = meta.get("setup_seconds")
    if not isinstance(setup, (int, float)) or not np.isfinite(setup):
        setup = max(0.0, wall - float(result.seconds))
    return cps, float(setup), meta


def _blender_checkpoints(scene: Scene, *, engine: str, samples: int, seed: int,
                         ladder: list[int]) -> tuple[list[tuple[int, float, np.ndarray]], float, dict, Any]:
    """Render with Blender (compare.blender); returns (checkpoints, start-up seconds, metadata, result).

    A module-level function so that tests can stand in a synthetic renderer.
    Each checkpoint is a render of its own with the same seed (Blender's
    sample sequences are deterministic, so it is the first n samples).
    """
    from .blender import render_blender

    result = render_blender(scene, engine=engine, samples=samples, seed=seed, ladder=ladder)
    cps = [(int(c.spp), float(c.seconds), np.asarray(c.image, dtype=np.float32)) for c in result.checkpoints]
    if not cps or cps[-1][0] != samples:
        cps.append((samples, float(result.seconds), np.asarray(result.image, dtype=np.float32)))
    return cps, float(result.startup_seconds), dict(result.metadata), result


def _cycles_likeness(scene: Scene, *, samples: int, seed: int, first, cache_dir) -> dict:
    """Is the ground truth Cycles-like (compare.blender.likeness)? The run's Cycles render is seed A;
    one more Cycles render (seed B) and two independent Mitsuba passes of equal spp are made here."""
    from .blender import render_blender
    from .blender.likeness import cycles_likeness

    second = render_blender(scene, engine="cycles", samples=samples, seed=seed + 1)
    res = cycles_likeness(scene, spp=samples, materials="cycles", seeds=(seed, seed + 1), cache_dir=cache_dir,
                          cycles=(first, second))
    agree = sum(1 for r in res.regions if r.agrees)
    return {"likeness_flip_cross": res.flip_cross, "likeness_flip_seed": res.flip_seed,
            "likeness_flip_mitsuba_seed": res.flip_mitsuba_seed, "likeness_ratio": res.ratio,
            "likeness_ratio_noise_matched": res.ratio_noise_matched, "likeness_spp": samples,
            "likeness_regions": f"{agree}/{len(res.regions)}"}


def blender_ladder(samples: int) -> list[int]:
    """Checkpoints of a Blender run below ``samples``: 1, 4, 16, … (each is a render of its own,
    so powers of 4 keep the ladder's cost to about a third of the full render's)."""
    out, k = [], 1
    while k < samples:
        out.append(k)
        k *= 4
    return out


def _create_gl_context():
    from .progressive.context import create_context

    return create_context()


class _Runner:
    """Runs every unit of one ``compare run``, reusing finished ones."""

    def __init__(self, settings: RunSettings, out: Path, *, progress: bool, cache_dir, fresh: bool, gl_ctx=None):
        self.settings = settings
        self.out = out
        self.progress = progress
        self.cache_dir = cache_dir
        self.fresh = fresh
        self.gl_ctx = gl_ctx
        self._own_ctx = gl_ctx is None  # release only a context this runner created
        self.gl_renderer: str | None = None
        self.variant: str | None = None
        self.machine = [_cpu_model(), os.cpu_count()]

    def close(self) -> None:
        if self.gl_ctx is not None and self._own_ctx:
            self.gl_ctx.release()
        self.gl_ctx = None

    def _unit(self, sid: str, name: str) -> _Unit:
        safe = re.sub(r"[^a-z0-9_-]+", "-", name.lower())  # "progressive:paper" -> "progressive-paper"
        return _Unit(self.out, self.out / "runs" / sid / safe)

    def _stored(self, unit: _Unit, key: str) -> dict | None:
        return None if self.fresh else unit.load(key)

    # -- ground truth ----------------------------------------------------------------------

    def reference(self, scene: Scene, sid: str, bar) -> tuple[Reference, Callable[[], np.ndarray], Any]:
        """The ground truth: (its record, a loader of its image, the ReferenceRenderer)."""
        from .reference import ReferenceRenderer

        s = self.settings
        rr = ReferenceRenderer(scene, materials=s.materials, cache_dir=self.cache_dir, progress=self.progress)
        self.variant = rr.variant
        key = _key("reference", rr.settings(), s.spp, s.seed, s.exposure, s.tonemap, __version__)
        unit = self._unit(sid, "reference")
        stored = self._stored(unit, key)
        if stored is not None:
            ref = Reference.from_json(stored)
            path = unit.root / ref.image
            return ref, lambda: read_exr(path)[0], rr

        bar.set_postfix_str(f"{scene.name[:30]} ground truth {s.spp} spp")
        last = None
        for last in rr.iter_ladder(s.spp, s.seed):
            pass
        assert last is not None
        image = last.image
        meta = {"renderer": "mitsuba", "role": "ground truth", **rr.settings(), "spp": last.spp, "seed": s.seed,
                "seconds": last.seconds, "package": __version__}
        path = unit.dir / "final.exr"
        _write_image(path, image, meta, exposure=s.exposure, tonemap=s.tonemap, half=False)
        ref = Reference(spp=int(last.spp), seed=s.seed, seconds=float(last.seconds), variant=rr.variant,
                        load_seconds=rr.load_seconds, key=key, image=unit.rel(path),
                        preview=unit.rel(path.with_suffix(".png")), metadata=_flat_metadata(meta))
        unit.save(key, ref.to_json())
        return ref, lambda: image, rr

    # -- the reference's convergence ---------------------------------------------------------

    def mitsuba(self, scene: Scene, sid: str, ref: Reference, gt: Callable[[], np.ndarray], rr, bar) -> RendererRun:
        s = self.settings
        seed = s.seed + 1  # independent of the ground truth (see the module docstring)
        key = _key("mitsuba-ladder", ref.key, seed, s.exposure, s.tonemap, self.machine, __version__)
        unit = self._unit(sid, "mitsuba")
        stored = self._stored(unit, key)
        if stored is not None:
            return RendererRun.from_json(stored)

        truth = gt()
        points: list[Point] = []
        image = None
        bar.set_postfix_str(f"{scene.name[:30]} mitsuba ladder {s.spp} spp")
        steps = checkpoint_steps(s.spp)
        for cp in rr.iter_ladder(s.spp, seed):
            path = unit.dir / f"step-{cp.spp:05d}.exr"
            meta = {"renderer": "mitsuba", "variant": rr.variant, "spp": cp.spp, "seed": seed,
                    "seconds": cp.seconds, "scene_hash": scene.hash}
            _write_image(path, cp.image, meta, exposure=s.exposure, tonemap=s.tonemap)
            metrics = _measure(truth, cp.image, s, f"{scene.name}: mitsuba at {cp.spp} spp",
                               final=cp.spp >= steps[-1])
            points.append(Point(int(cp.spp), float(cp.seconds), metrics, unit.rel(path),
                                unit.rel(path.with_suffix(".png"))))
            image = cp.image
        assert image is not None
        run = RendererRun(
            renderer="mitsuba", label=f"Mitsuba path tracer ({rr.variant})", unit="spp", steps=s.spp, key=key,
            seconds=points[-1].seconds, first_frame_seconds=points[0].seconds, setup_seconds=float(rr.load_seconds),
            metadata=_flat_metadata({"variant": rr.variant, "seed": seed, **rr.settings()}),
            image=points[-1].image, preview=points[-1].preview,
            maps=_maps(unit, truth, image, s), points=points)
        unit.save(key, run.to_json())
        return run

    # -- progressive ------------------------------------------------------------------------------

    def progressive(self, scene: Scene, sid: str, spec: str, ref: Reference, gt: Callable[[], np.ndarray],
                    bar) -> RendererRun:
        s = self.settings
        from .variants import describe, renderer_options

        options = renderer_options(spec)
        key = _key("progressive", spec, scene.hash, s.frames, s.seed, ref.key, s.exposure, s.tonemap,
                   self.machine, __version__, _source_fingerprint(*RASTERIZER_SOURCES))
        unit = self._unit(sid, spec)
        stored = self._stored(unit, key)
        if stored is not None:
            run = RendererRun.from_json(stored)
            self.gl_renderer = self.gl_renderer or run.metadata.get("gl_renderer")
            return run

        if self.gl_ctx is None:
            self.gl_ctx = _create_gl_context()
        bar.set_postfix_str(f"{scene.name[:30]} {spec} {s.frames} frames")
        cps, setup, meta = _progressive_checkpoints(scene, frames=s.frames, seed=s.seed, options=options,
                                                    checkpoints=checkpoint_steps(s.frames), ctx=self.gl_ctx)
        meta = _flat_metadata(meta)
        if isinstance(meta.get("gl_renderer"), str):
            self.gl_renderer = meta["gl_renderer"]
        words = describe(spec) or meta.get("area_model")
        label = "Progressive rasterizer" + (f" ({words})" if isinstance(words, str) and words else "")
        # steps: the frames rendered (a frame budget decides the count itself)
        return self._finish(scene, unit, key, spec, label, "frame", cps, setup, meta, gt())

    def _finish(self, scene: Scene, unit: _Unit, key: str, spec: str, label: str, step_unit: str,
                cps: list[tuple[int, float, np.ndarray]], setup: float, meta: dict,
                truth: np.ndarray) -> RendererRun:
        """Write and measure every checkpoint (step, seconds, image) against ``truth``; save the unit's run."""
        s = self.settings
        step_key = "frames" if step_unit == "frame" else "spp"
        points: list[Point] = []
        for step, seconds, image in tqdm(cps, desc="metrics", unit="checkpoint", leave=False,
                                         disable=not self.progress):
            path = unit.dir / f"step-{step:05d}.exr"
            _write_image(path, image, {**meta, "renderer": spec, step_key: step, "seed": s.seed, "seconds": seconds,
                                       "scene_hash": scene.hash}, exposure=s.exposure, tonemap=s.tonemap)
            metrics = _measure(truth, image, s, f"{scene.name}: {spec} at {step_unit} {step}",
                               final=step == cps[-1][0])
            points.append(Point(int(step), float(seconds), metrics, unit.rel(path),
                                unit.rel(path.with_suffix(".png"))))
        run = RendererRun(
            renderer=spec, label=label, unit=step_unit, steps=int(cps[-1][0]), key=key,
            seconds=points[-1].seconds, first_frame_seconds=points[0].seconds, setup_seconds=setup,
            metadata=meta, image=points[-1].image, preview=points[-1].preview,
            maps=_maps(unit, truth, cps[-1][2], s), points=points)
        unit.save(key, run.to_json())
        return run

    # -- Blender ----------------------------------------------------------------------------------

    def blender(self, scene: Scene, sid: str, spec: str, ref: Reference, gt: Callable[[], np.ndarray],
                bar) -> RendererRun:
        """Cycles (the paper's reference, CPU) or EEVEE (its rasterizer comparator) against the ground truth."""
        s = self.settings
        samples = s.cycles_spp if spec == "cycles" else s.eevee_samples
        # A Cycles unit run without the likeness measurement gets a key of its own (and keys of
        # units with it stay as they were), so a later run that asks for it does not reuse it.
        parts = ("blender", spec, scene.hash, samples, s.seed, ref.key, s.exposure, s.tonemap, self.machine,
                 __version__)
        skip = ("no-likeness",) if spec == "cycles" and s.materials == "cycles" and not s.likeness else ()
        key = _key(*parts, *skip)
        unit = self._unit(sid, spec)
        stored = self._stored(unit, key)
        if stored is None and skip:  # a finished unit with the likeness has all that is asked for
            stored = self._stored(unit, _key(*parts))
        if stored is not None:
            return RendererRun.from_json(stored)
        bar.set_postfix_str(f"{scene.name[:30]} {spec} {samples} spp")
        cps, startup, meta, result = _blender_checkpoints(scene, engine=spec, samples=samples, seed=s.seed,
                                                          ladder=blender_ladder(samples))
        if spec == "cycles" and s.materials == "cycles" and s.likeness:
            # The ground truth is meant to be Cycles-like: say how much (the report shows it).
            bar.set_postfix_str(f"{scene.name[:30]} Cycles-likeness {samples} spp")
            meta.update(_cycles_likeness(scene, samples=samples, seed=s.seed, first=result,
                                         cache_dir=self.cache_dir))
        meta = _flat_metadata(meta)
        label = "Blender Cycles (CPU)" if spec == "cycles" else "Blender EEVEE"
        return self._finish(scene, unit, key, spec, label, "spp", cps, startup, meta, gt())

    # -- one scene at one size ------------------------------------------------------------------

    def scene(self, scene: Scene, bar) -> SceneResult:
        sid = scene_id(scene)
        ref, gt, rr = self.reference(scene, sid, bar)
        bar.update(1)
        cached_gt: dict[str, np.ndarray] = {}

        def truth() -> np.ndarray:  # read the ground truth at most once per scene
            if "gt" not in cached_gt:
                cached_gt["gt"] = gt()
            return cached_gt["gt"]

        runs: list[RendererRun] = []
        noise_floor = None
        for spec in self.settings.renderers:
            if spec == "mitsuba":
                run = self.mitsuba(scene, sid, ref, truth, rr, bar)
                nf = run.final.metrics
                noise_floor = NoiseFloor(method="independent-full", spp=ref.spp, seeds=[ref.seed, ref.seed + 1],
                                         metrics=dict(nf), mse_reference_estimate=float(nf["mse"]) / 2.0)
            elif spec in BLENDER_RENDERERS:
                run = self.blender(scene, sid, spec, ref, truth, bar)
            else:
                run = self.progressive(scene, sid, spec, ref, truth, bar)
            runs.append(run)
            bar.update(1)
        w, h = scene.camera.resolution
        feats = scene.features()
        return SceneResult(
            id=sid, name=scene.name, path=_display_path(scene.path), hash=scene.hash, width=w, height=h,
            features=feats.names(), omitted=feats.omitted(), reference=ref, noise_floor=noise_floor, runs=runs)


def _display_path(path: Path) -> str:
    try:
        return Path(os.path.relpath(path)).as_posix()
    except ValueError:  # another drive on Windows
        return Path(path).as_posix()


# --------------------------------------------------------------------------- public API


def run(scene_paths: Iterable[str | os.PathLike], out: str | os.PathLike, settings: RunSettings | None = None, *,
        progress: bool = True, cache_dir: str | os.PathLike | None | bool = None, fresh: bool = False,
        report: bool = True, gl_ctx=None, executor: str | object = "serial") -> Results:
    """Render, measure and report every scene at every size with every renderer.

    Parameters
    ----------
    scene_paths : iterable of path
        Scene files (TOML).
    out : path
        Output folder; receives ``results.json``, ``runs/`` (partial results,
        EXR and PNG images) and the report (``index.html`` and its files).
    settings : RunSettings, optional
        Budgets, seeds, renderers, sizes, tone mapping; defaults as ``compare run``.
    progress : bool, optional
        Show tqdm progress bars.
    cache_dir : path or None or False, optional
        The reference cache (None: ``$COMPARE_CACHE`` or ``~/.cache/compare``;
        False: no cache).
    fresh : bool, optional
        Ignore finished units in ``out`` and redo them.
    report : bool, optional
        Also write the HTML report and plots.
    gl_ctx : moderngl.Context, optional
        An OpenGL context for the progressive renderer (not released here);
        default: one is created on first need and released at the end.
        Used by the ``serial`` executor only.
    executor : str or distributed.Client, optional
        ``"serial"`` (this process), ``"local"``, ``"local:N"`` or
        ``"dask://HOST:PORT"``, see :mod:`compare.executor`; or a connected
        ``distributed.Client``.

    Returns
    -------
    Results
        What was written to ``out/results.json``.

    Raises
    ------
    SceneError, ImageError, MissingComponentError
        A bad scene, a renderer that produced NaN/Inf, a missing system component.
    """
    settings = settings or RunSettings()
    settings.renderers = parse_renderers(settings.renderers)
    if settings.frames < 1 or settings.spp < 1:
        raise ValueError(f"frames and spp must be positive, got frames={settings.frames}, spp={settings.spp}")
    if settings.cycles_spp < 1 or settings.eevee_samples < 1:
        raise ValueError(f"Blender samples must be positive, got cycles_spp={settings.cycles_spp}, "
                         f"eevee_samples={settings.eevee_samples}")
    blender = [r for r in settings.renderers if r in BLENDER_RENDERERS]
    if blender:  # before hours of reference rendering
        from .blender import blender_available
        from .errors import MissingComponentError

        ok, why = blender_available()
        if not ok:
            raise MissingComponentError(f"renderers {', '.join(blender)} need Blender's bpy: {why}")
    out = Path(out)
    check_output_folder("-o", out)
    paths = [Path(p) for p in scene_paths]
    if not paths:
        raise ValueError("no scene given")
    scenes = [load_scene(p) for p in paths]  # fail on a bad scene before rendering anything
    jobs: dict[str, Scene] = {}  # by id: a scene or size given twice is done once
    for sc in scenes:
        sizes = [tuple(sz) for sz in settings.sizes] or [sc.camera.resolution]
        for w, h in sizes:
            job = sc.with_resolution(w, h)
            jobs.setdefault(scene_id(job), job)

    gl_renderer = variant = None
    if isinstance(executor, str):
        from .executor import parse_executor

        kind, detail = parse_executor(executor)
        if kind == "serial" or (kind == "local" and (detail == 1 or len(jobs) == 1)):
            executor = "serial"  # one worker: run here, with a progress bar per unit
    if executor == "serial":
        runner = _Runner(settings, out, progress=progress, cache_dir=cache_dir, fresh=fresh, gl_ctx=gl_ctx)
        results: list[SceneResult] = []
        units = len(jobs) * (1 + len(settings.renderers))
        try:
            with tqdm(total=units, desc="compare run", unit="unit", disable=not progress) as bar:
                for sc in jobs.values():
                    results.append(runner.scene(sc, bar))
        finally:
            runner.close()
        gl_renderer, variant = runner.gl_renderer, runner.variant
    else:
        from .executor import Job, execute

        job_list = [Job(scene_path=str(sc.path), size=tuple(sc.camera.resolution), scene_hash=sc.hash,
                        scene_id=sid, settings=settings.to_json(), out=str(out.resolve()),
                        cache_dir=str(cache_dir) if isinstance(cache_dir, os.PathLike) else cache_dir, fresh=fresh)
                    for sid, sc in jobs.items()]
        done: dict[int, SceneResult] = {}
        with tqdm(total=len(job_list), desc="compare run", unit="job", disable=not progress) as bar:
            for i, res_i in execute(job_list, executor):
                done[i] = SceneResult.from_json(res_i.scene)
                gl_renderer = gl_renderer or res_i.gl_renderer
                variant = variant or res_i.variant
                bar.update(1)
        results = [done[i] for i in range(len(job_list))]

    res = Results(
        settings=settings,
        environment=collect_environment(gl_renderer=gl_renderer, mitsuba_variant=variant),
        scenes=results,
        created=datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z"),
        compare_version=__version__,
    )
    res.save(out / "results.json")
    if report:
        from .report import build_report

        build_report(res, out)
    return res


# --------------------------------------------------------------------------- CLI


def _sizes_arg(text: str) -> list[tuple[int, int]]:
    sizes = parse_sizes(text)
    if not sizes:
        raise argparse.ArgumentTypeError(f"expected sizes such as 320x240,1280x720, got {text!r}")
    return sizes


def _renderers_arg(text: str) -> list[str]:
    try:
        return parse_renderers(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _positive(text: str) -> int:
    from .cli import positive_int

    return positive_int(text)


def _positive_float(text: str) -> float:
    from .cli import positive_float

    return positive_float(text)


def add_run_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``compare run`` to an argparse subparsers object; returns the new parser."""
    p = subparsers.add_parser(
        "run", help="render scenes with every renderer, measure error against time, write results.json and a report",
        description="Render each scene at each size with the Mitsuba reference (ground truth, its convergence "
                    "ladder and noise floor) and the progressive rasterizer (checkpoints at frames 1, 2, 4, ...); "
                    "measure every checkpoint against the ground truth; write results.json and an HTML report. "
                    "Finished work in the output folder is reused when the settings match.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    # String defaults: argparse converts them with `type`, and --help prints them plainly.
    p.add_argument("--scenes", nargs="+", type=Path, default="scenes/cornell.toml", metavar="SCENE",
                   help="scene files (TOML)")
    p.add_argument("--size", type=_sizes_arg, default=None, metavar="WxH[,WxH...]",
                   help="resolutions, comma-separated; default: each scene's own")
    p.add_argument("--frames", type=_positive, default=128, help="progressive frames (checkpoints at 1, 2, 4, ...)")
    p.add_argument("--spp", type=_positive, default=1024, help="reference samples per pixel (ground truth)")
    p.add_argument("--renderers", type=_renderers_arg, default="mitsuba,progressive",
                   metavar="LIST", help="comma-separated: mitsuba (reference convergence + noise floor), "
                                        "progressive, progressive:<option>[+<option>] with options " + ", ".join(VARIANT_OPTIONS)
                                        + " (e.g. progressive:paper,progressive:ltc,progressive:budget16), "
                                        "cycles and eevee (Blender, the blender extra), or all (the paper's "
                                        "Table 1: " + ",".join(ALL_RENDERERS) + ")")
    p.add_argument("--cycles-spp", type=_positive, default=1024, help="Cycles samples per pixel (the paper: 1024)")
    p.add_argument("--eevee-samples", type=_positive, default=64, help="EEVEE samples (the paper: 64)")
    p.add_argument("--seed", type=int, default=0, help="seed of the ground truth (its convergence ladder uses seed+1)")
    p.add_argument("--exposure", type=_positive_float, default=1.0,
                   help="linear exposure before ACES tone mapping (LDR metrics and previews)")
    p.add_argument("--materials", choices=["shared", "cycles"], default="shared",
                   help="reference material mode: shared (the rasterizer's BRDF) or cycles (Blender's Principled "
                        "BSDF v2, for comparisons with cycles and eevee)")
    p.add_argument("--no-likeness", dest="likeness", action="store_false",
                   help="with --materials cycles, skip the Cycles-likeness measurement (it renders Cycles once more "
                        "and Mitsuba twice at --cycles-spp: about three times the Cycles unit's cost)")
    p.add_argument("--fresh", action="store_true", help="redo finished units instead of reusing them")
    p.add_argument("--no-report", action="store_true", help="write results.json only")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--executor", default="local", metavar="WHERE",
                   help="local (a process pool sized to the machine), local:N, serial, or dask://HOST:PORT "
                        "(see compare/executor.py for setting up workers)")
    p.add_argument("-o", "--output", type=Path, default=None,
                   help="output folder; default reports/<first scene's file name>")
    p.set_defaults(func=cmd_run)
    return p


def cmd_run(args: argparse.Namespace) -> int:
    """``compare run``; returns the exit status."""
    settings = RunSettings(frames=args.frames, spp=args.spp, seed=args.seed, renderers=list(args.renderers),
                           sizes=[list(s) for s in (args.size or [])], exposure=args.exposure, tonemap="aces",
                           materials=args.materials, cycles_spp=args.cycles_spp, eevee_samples=args.eevee_samples,
                           likeness=args.likeness)
    scenes = args.scenes if isinstance(args.scenes, list) else [args.scenes]  # the default is one Path
    out = args.output or Path("reports") / scenes[0].stem
    try:
        res = run(scenes, out, settings, progress=not args.quiet, fresh=args.fresh, report=not args.no_report,
                  executor=args.executor)
    except ValueError as e:
        if isinstance(e, CompareError):
            raise
        raise _UsageError(str(e)) from e
    n = len(res.scenes)
    where = out / ("index.html" if not args.no_report else "results.json")
    print(f"{out / 'results.json'}: {n} scene/size combination{'s' if n != 1 else ''}; open {where}",
          file=sys.stdout)
    return 0


class _UsageError(CompareError, ValueError):
    """A bad combination of ``compare run`` options."""
