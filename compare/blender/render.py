"""Run one Blender render in its own process and bring back the image and timings.

bpy (Blender as a Python module) keeps global state, takes a second or two to
import and can take its process down on a driver problem, so each render runs
``worker.py`` in a fresh interpreter: the job goes in through a temporary
folder (JSON + npz), an EXR and a JSON of timings come back.

Which interpreter: ``$COMPARE_BLENDER_PYTHON`` if set (a Python 3.11 with
``bpy`` installed, e.g. a separate virtual environment: bpy 5.0.1 pins
``numpy<2``), else the one the set-up recorded (:mod:`compare.util.installed`:
``.venv-blender``), else this interpreter when it can import bpy.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from compare import __version__
from compare.util.errors import CompareError, MissingComponentError
from compare.image.exr import read_exr
from compare.renderers.base import Checkpoint
from compare.scene.loader import Scene
from compare.blender.export import ENGINES, build_job, cycles_bounces

#: Environment variable naming a Python interpreter that has bpy.
PYTHON_ENV = "COMPARE_BLENDER_PYTHON"
WORKER = Path(__file__).with_name("worker.py")
INSTALL_HINT = ("install the blender extra (`pip install '.[blender]'`, bpy 5.0.1, Python 3.11; about 380 MB "
                "download, 1 GB installed) or point $COMPARE_BLENDER_PYTHON at a Python that has bpy")


class BlenderError(CompareError, RuntimeError):
    """The Blender worker failed; the message carries the end of its log."""


@dataclass
class BlenderResult:
    """A finished Blender render.

    Attributes
    ----------
    image
        Linear radiance, float32 (H, W, 3).
    seconds
        Wall time of the render call alone (no interpreter start, bpy import,
        scene building, warm-up or file writing).
    startup_seconds
        Interpreter start + ``import bpy`` + building the scene.
    metadata
        Flat ``str``/``int``/``float`` values (EXR-ready): renderer, engine,
        samples, seed, settings, versions, every timing (``cpu_seconds``: CPU
        time of the render, all threads; unlike wall time it does not grow when
        other processes share the cores).
    checkpoints
        With ``ladder=``: one :class:`compare.renderers.base.Checkpoint` (step = samples,
        seconds, image) per sample count, the full render last. Each is a
        separate render with the same seed, which for Cycles' and EEVEE's
        deterministic sample sequences is the first n samples of the full
        render; its seconds are that render's own time, or the previous checkpoint's where that is
        more (a render of more samples timed a hair faster than one of fewer).
    """

    image: np.ndarray
    seconds: float
    startup_seconds: float
    metadata: dict[str, str | int | float] = field(default_factory=dict)
    checkpoints: list[Checkpoint] = field(default_factory=list)

    @property
    def engine(self) -> str:
        return str(self.metadata.get("engine", ""))

    @property
    def samples(self) -> int:
        return int(self.metadata.get("samples", 0))


def blender_python() -> tuple[str | None, str]:
    """The interpreter that will run the worker, or None with the reason there is none."""
    env = os.environ.get(PYTHON_ENV)
    if env:
        if not Path(env).is_file():
            return None, f"${PYTHON_ENV}={env} does not exist"
        return env, f"${PYTHON_ENV}"
    from compare.util.installed import RECORD, installed

    recorded = installed("blender_python")
    if recorded:
        return recorded, f"the set-up's environment ({RECORD})"
    if importlib.util.find_spec("bpy") is None:
        return None, f"bpy is not installed in {sys.executable}; {INSTALL_HINT}"
    return sys.executable, "this interpreter"


def blender_available() -> tuple[bool, str]:
    """Whether Blender renders can run here, and why not (cheap: bpy is not imported)."""
    py, why = blender_python()
    return py is not None, why


def render_blender(scene: Scene, *, engine: str = "cycles", samples: int, seed: int = 0,
                   materials: str = "cycles", settings: Mapping[str, Any] | None = None,
                   ladder: Sequence[int] = (), warmup: bool | None = None, threads: int = 0,
                   timeout: float | None = None, keep: str | os.PathLike | None = None,
                   distribution: str | None = None, gltf_import: bool = False) -> BlenderResult:
    """Render ``scene`` with Blender Cycles (CPU) or EEVEE in a separate process.

    Parameters
    ----------
    scene
        The scene; its resolution is the render resolution.
    engine
        ``"cycles"`` or ``"eevee"``.
    samples
        Samples per pixel (Cycles) or temporal samples (EEVEE; the paper used 64).
    seed
        Cycles' sampling seed (taken modulo 2³¹). EEVEE is deterministic and ignores it.
    materials
        ``"cycles"`` (glTF → Principled BSDF, see :mod:`compare.blender.export`)
        or ``"diffuse"`` (Lambert only, for closed-form checks).
    settings
        Overrides of ``scene.cycles`` / ``scene.eevee`` attributes by name, e.g.
        ``{"use_raytracing": True}``; recorded in the metadata.
    ladder
        Sample counts below ``samples`` to render too, as checkpoints for
        error-against-time curves (:attr:`BlenderResult.checkpoints`); each costs
        a render of its own.
    warmup
        Render one sample before the timed renders (shader compilation). Default:
        on for EEVEE, off for Cycles.
    threads
        CPU threads (0 = all).
    timeout
        Seconds before the worker is killed (:class:`BlenderError`); None waits.
    keep
        A folder to keep the job, log and EXRs in (default: a temporary folder, removed).
    distribution
        The Principled BSDF's distribution for every material (``"multi_ggx"``, Blender's
        default, or ``"ggx"``); None keeps each material's own (``Material.distribution``).
        What the worker set is in the metadata (``distribution``, ``distributions``).
    gltf_import
        Read the scene's glTF files with Blender's own glTF importer (its meshes, UVs, tangents and
        materials) instead of the suite's export of them; the camera, lights and environment stay the suite's.

    Raises
    ------
    MissingComponentError
        No interpreter with bpy (see :func:`blender_available`).
    BlenderError
        The worker failed or timed out; the message ends with its log.
    ValueError
        A bad argument (engine, samples, materials, settings, ladder).
    """
    py, why = blender_python()
    if py is None:
        raise MissingComponentError(f"Blender renders need bpy: {why}")
    opts = dict(engine=engine, samples=int(samples), seed=int(seed), materials=materials, settings=settings,
                ladder=tuple(ladder), warmup=(engine == "eevee") if warmup is None else bool(warmup),
                threads=int(threads), distribution=distribution, gltf_import=bool(gltf_import))
    if keep is not None:
        Path(keep).mkdir(parents=True, exist_ok=True)
        return _run(py, scene, opts, timeout, Path(keep))
    with tempfile.TemporaryDirectory(prefix="compare-blender-") as tmp:
        return _run(py, scene, opts, timeout, Path(tmp))


def _run(py: str, scene: Scene, opts: dict, timeout: float | None, folder: Path) -> BlenderResult:
    engine, samples, seed = opts["engine"], opts["samples"], opts["seed"]
    job = build_job(scene, folder=folder, **opts)
    log_path = folder / "worker.log"
    t_spawn = time.time()
    t0 = time.perf_counter()
    with open(log_path, "wb") as log:
        try:
            # (the worker ends with this process: compare.blender.worker._die_with_parent)
            proc = subprocess.run([py, str(WORKER), str(folder), repr(t_spawn)], stdout=log, stderr=subprocess.STDOUT,
                                  cwd=folder, timeout=timeout, check=False,
                                  env={**os.environ, "COMPARE_PARENT_PID": str(os.getpid())})
        except subprocess.TimeoutExpired:
            raise BlenderError(f"Blender {engine} render timed out after {timeout:g} s; "
                               f"log:\n{_tail(log_path)}") from None
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise BlenderError(f"Blender {engine} worker exited with status {proc.returncode} "
                           f"({'signal ' + str(-proc.returncode) if proc.returncode < 0 else 'error'}); "
                           f"log:\n{_tail(log_path)}")
    try:
        info = json.loads((folder / job["result"]).read_text())
        image, _ = read_exr(folder / job["output"])
    except (OSError, ValueError, CompareError) as exc:
        raise BlenderError(f"Blender {engine} worker left no usable result ({exc}); log:\n{_tail(log_path)}") from exc
    if not np.all(np.isfinite(image)):
        raise BlenderError(f"Blender {engine} produced {int((~np.isfinite(image)).sum())} non-finite values")
    startup = info["interpreter_seconds"] + info["import_seconds"] + info["build_seconds"]
    cam = scene.camera
    meta: dict[str, str | int | float] = {
        "renderer": f"blender-{engine}",
        "engine": engine,
        "variant": job["engine"],
        "samples": int(samples),
        "spp": int(samples),
        "seed": int(seed),
        "materials": opts["materials"],
        "seconds": float(info["render_seconds"]),
        "cpu_seconds": float(info["render_cpu_seconds"]),
        "load_average": float(os.getloadavg()[0]),
        "startup_seconds": float(startup),
        "warmup_seconds": float(info.get("warmup_seconds", 0.0)),
        "import_seconds": float(info["import_seconds"]),
        "build_seconds": float(info["build_seconds"]),
        "write_seconds": float(info["write_seconds"]),
        "wall_seconds": float(wall),
        "resolution": json.dumps([cam.width, cam.height]),
        "scene_hash": scene.hash,
        "blender": str(info["blender_version"]),
        "blender_build": str(info["blender_build_hash"]),
        "threads": int(info["threads"]),
        "settings": json.dumps(job["settings"], sort_keys=True),
        "overrides": json.dumps(job["overrides"], sort_keys=True),
        "package": __version__,
    }
    used = sorted(set(info.get("distributions", {}).values()))
    meta["distribution"] = used[0] if len(used) == 1 else "mixed" if used else "none"
    meta["distributions"] = json.dumps(info.get("distributions", {}), sort_keys=True)
    if engine == "cycles":
        meta.update({"device": "CPU", "max_bounces": cycles_bounces(scene.max_depth),
                     "pixel_filter": "box 1.0 px"})
    else:
        meta.update({"gl_driver": str(info["gl_driver"]),
                     "pixel_filter": f"gaussian filter_size {job['eevee_filter_size']:.4f} px",
                     "deterministic": 1})
    checkpoints = []
    # Each checkpoint is a render of its own; where a render's fixed overhead dominates, one of more
    # samples can take a hair less than one of fewer. The first n samples of a render take no longer
    # than the whole render of n' > n, so each checkpoint's seconds are the running maximum.
    latest = 0.0
    for cp in info.get("ladder", []):
        try:
            cp_image, _ = read_exr(folder / cp["file"])
        except (OSError, ValueError, CompareError) as exc:
            raise BlenderError(f"Blender {engine} checkpoint {cp['file']} is unreadable ({exc})") from exc
        latest = max(latest, float(cp["seconds"]))
        checkpoints.append(Checkpoint(int(cp["samples"]), latest, cp_image))
    if checkpoints:
        checkpoints.append(Checkpoint(int(samples), max(latest, float(info["render_seconds"])), image))
        meta["ladder"] = json.dumps([c.step for c in checkpoints])
    return BlenderResult(image=image, seconds=float(info["render_seconds"]), startup_seconds=float(startup),
                         metadata=meta, checkpoints=checkpoints)


def _tail(path: Path, lines: int = 40) -> str:
    from compare.util.files import log_tail

    # EEVEE on Mesa prints harmless EGL_BAD_MATCH lines while it probes for a context.
    return log_tail(path, lines, drop="EGL_BAD_MATCH") or "(no log)"


__all__ = ["ENGINES", "BlenderError", "BlenderResult", "blender_available", "blender_python", "render_blender"]
