"""Environment maps: the one direction ↔ equirectangular mapping, loaders, procedural maps, Blender's HDRIs.

Orientation (the convention of Mitsuba 3's ``envmap`` emitter)
---------------------------------------------------------------
A unit direction ``d = (x, y, z)`` in the environment's own frame (world space
when ``rotation = 0``; +Y up, right-handed) maps to equirectangular texture
coordinates ``(u, v)`` in [0, 1)² by::

    u = atan2(x, -z) / (2π)   (wrapped to [0, 1))
    v = acos(y) / π

and back by ``d = (sin 2πu · sin πv, cos πv, −cos 2πu · sin πv)``. So the top
row of the image is straight up (+Y), the bottom row straight down; the left
edge (u = 0) and the right edge look along −Z, the image centre (u = ½, v = ½)
along +Z, u = ¼ along +X and u = ¾ along −X. Seen from inside, the image is
not mirrored: turning from −Z towards +X moves right in the image. This is
``direction_to_uv`` / ``uv_to_direction`` of ``mitsuba3/src/emitters/envmap.cpp``
(``dr::atan2(d.x(), -d.z())``, ``dr::safe_acos(d.y())``), verified by
``tests/test_environment.py`` against Mitsuba renders of a marked map.

Texel positions, as Mitsuba interpolates them (:func:`sample_equirect`):
column ``i`` of a W-wide map sits at ``u = (i + ½)/W`` (columns wrap around),
row ``j`` of an H-high map at ``v = j/(H − 1)``: the first and last rows lie
*on* the poles (not half a texel inside them). Bilinear interpolation between
those positions. The GLSL form (``compare/ibl/mapping.glsl``,
``env_equirect_uv``) reproduces this exactly with a GL_REPEAT × CLAMP_TO_EDGE
linear texture; the IBL preprocessing reads maps with :func:`sample_equirect`.

``rotation`` (degrees about +Y, the scene's ``environment.rotation``) turns the
map with Mitsuba's ``to_world = rotate(axis=[0, 1, 0], angle)``: a world
direction ``d`` looks up the map at ``R⁻¹ d`` (:func:`world_to_env`).

Sources of a map
----------------
* ``file = "x.exr"`` or ``"x.hdr"``: OpenEXR (:func:`compare.image.exr.read_exr`) or
  Radiance RGBE (:func:`read_hdr`), linear radiance.
* ``procedural = "sky" | "studio" | "axes"``: generated here, deterministic, with
  the parameters of :data:`PROCEDURAL` (defaults, ranges, units), written once
  to an EXR in ``<cache>/environments/`` keyed by the parameters and
  :data:`PROCEDURAL_VERSION` (:func:`environment_path`).
* ``blender = "interior"`` etc.: the CC0 studio-light HDRIs that ship inside the
  ``bpy`` wheel (``datafiles/studiolights/world/*.exr``), found without
  importing bpy (:func:`blender_studio_lights`). They are used in *this*
  convention; Blender's own world mapping (Z up) differs, which the Blender
  renderer has to account for.
* ``constant = [r, g, b]``: :func:`environment_image` returns a small uniform map
  so that the rasterizer's IBL code path is the same for every environment.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
from pathlib import Path

import numpy as np

from compare.image.hdr import read_hdr
from compare.scene.procedural_env import PROCEDURAL_VERSION, procedural_key, procedural_map
from compare.util.errors import ImageError, MissingComponentError
from compare.util.files import sha256_bytes

__all__ = [
    "blender_studio_lights",
    "environment_file",
    "environment_image",
    "environment_path",
    "load_equirect",
]

#: Width × height of the uniform map that stands for a ``constant`` environment.
CONSTANT_MAP_SIZE = (16, 8)


# ----------------------------------------------------------------------------- the mapping


# ----------------------------------------------------------------------------- Radiance .hdr


#: Negative values of an environment map down to this fraction of its mean are compression noise
#: and set to zero (Blender's HDRIs: -0.002 against a mean of ~0.5); larger ones are refused.
NEGATIVE_TOLERANCE = 0.01


def load_equirect(path: str | Path) -> np.ndarray:
    """An equirectangular map file (.exr or .hdr) as float32 (H, W, 3), compression noise below zero set to 0.

    Raises ImageError naming the file for a map that is too small, holds NaN or Inf, or holds
    negative radiance beyond :data:`NEGATIVE_TOLERANCE` of its mean (no renderer can emit that,
    and each would treat it differently)."""
    path = Path(path)
    return _checked_equirect(path, _read_equirect(path))


def _read_equirect(path: Path) -> np.ndarray:
    """The map file's pixels as stored."""
    if path.suffix.lower() == ".hdr":
        return read_hdr(path)
    from compare.image.exr import read_exr

    return read_exr(path)[0]


def _checked_equirect(path: Path, img: np.ndarray) -> np.ndarray:
    """:func:`load_equirect`'s checks and clamping of the pixels ``img`` of ``path``."""
    if img.shape[0] < 3 or img.shape[1] < 2:
        raise ImageError(f"{path}: an environment map needs at least 2×3 pixels, got {img.shape[1]}×{img.shape[0]}")
    if not np.all(np.isfinite(img)):
        raise ImageError(f"{path}: an environment map must hold finite radiance (found NaN or Inf)")
    low = float(img.min())
    if low < 0.0:
        mean = float(np.mean(np.maximum(img, 0.0), dtype=np.float64))
        limit = NEGATIVE_TOLERANCE * mean
        if low < -limit:
            count = int(np.count_nonzero(img < -limit))
            raise ImageError(f"{path}: an environment map must hold non-negative radiance: {count} values below "
                             f"-{limit:.3g}, down to {low:.3g} (its mean is {mean:.3g}; only lossy-compression noise "
                             f"within {NEGATIVE_TOLERANCE:.0%} of the mean is set to zero)")
    return np.ascontiguousarray(np.maximum(img, 0.0), dtype=np.float32)


def environment_file(env, cache_dir: str | Path | None = None) -> Path | None:
    """The map file a path tracer should read for ``env``: :func:`environment_path`, or where that file
    holds compression noise below zero, a copy with it set to zero (as :func:`load_equirect` gives the
    rasterizer), written once to ``<cache>/environments/clamped-<content hash>.exr``. The map is
    checked as :func:`load_equirect` checks it."""
    path = environment_path(env, cache_dir)
    if path is None:
        return None
    raw = _read_equirect(path)
    image = _checked_equirect(path, raw)
    if float(np.min(raw)) >= 0.0:
        return path

    clamped = _cache_root(cache_dir) / "environments" / f"clamped-{sha256_bytes(raw.tobytes())[:24]}.exr"
    if not clamped.is_file():
        from compare.image.exr import write_exr

        write_exr(clamped, image, metadata={"renderer": "clamped-environment", "source": str(path)})
    return clamped


# ----------------------------------------------------------------------------- Blender studio lights


def blender_studio_lights() -> dict[str, Path]:
    """Blender's bundled world HDRIs, name → file (``{}`` when the ``bpy`` wheel is not installed).

    Found from the installed package's location without importing bpy (which
    is slow and starts Blender): in this interpreter, else in the environment of
    ``$COMPARE_BLENDER_PYTHON`` or the one the set-up recorded (bpy's own environment,
    :mod:`compare.util.installed`).
    """
    roots: list[str] = []
    try:
        spec = importlib.util.find_spec("bpy")
    except (ImportError, ValueError):
        spec = None
    if spec is not None:
        roots = list(spec.submodule_search_locations or [])
        if not roots and spec.origin:
            roots = [str(Path(spec.origin).parent)]
    from compare.util.installed import installed

    other = os.environ.get("COMPARE_BLENDER_PYTHON") or installed("blender_python")
    if not roots and other:
        # <env>/bin/python → <env>/lib/python3.X/{site,dist}-packages/bpy (not resolved: a venv's python
        # is a link to the base interpreter, whose own packages are elsewhere)
        exe = Path(shutil.which(other) or other)
        roots = [str(p) for p in sorted(exe.parent.parent.glob("lib/python3*/*-packages/bpy"))]
    if not roots:
        return {}
    found: dict[str, Path] = {}
    for root in roots:
        for f in sorted(Path(root).glob("*/datafiles/studiolights/world/*.exr")):
            found.setdefault(f.stem, f)
    return found


def blender_studio_light(name: str) -> Path:
    """The file of Blender's studio light ``name``; raises when bpy is missing or the name is unknown."""
    lights = blender_studio_lights()
    if not lights:
        raise MissingComponentError(
            f"blender = {name!r}: Blender's studio-light HDRIs come with the 'blender' extra "
            "(`pip install compare-pbr[blender]`, the bpy wheel), which is not installed")
    if name not in lights:
        raise ValueError(f"blender: unknown Blender studio light {name!r} (available: {', '.join(sorted(lights))})")
    return lights[name]


# ----------------------------------------------------------------------------- scene environments


def _cache_root(cache_dir: str | Path | None) -> Path:
    if cache_dir is not None:
        return Path(cache_dir)
    from compare.util.cache import default_cache_dir

    return default_cache_dir()


def environment_path(env, cache_dir: str | Path | None = None) -> Path | None:
    """The equirectangular file of a scene environment (None for a constant one).

    A procedural map is generated on first use and written atomically to
    ``<cache>/environments/<kind>-<key>.exr`` (cache: ``cache_dir`` or
    :func:`compare.util.cache.default_cache_dir`).
    """
    if env is None or getattr(env, "constant", None) is not None:
        return None
    if getattr(env, "file", None) is not None:
        return Path(env.file)
    if getattr(env, "blender", None):
        return blender_studio_light(env.blender)
    kind = getattr(env, "procedural", None)
    if kind:
        params = dict(env.parameters)
        key = procedural_key(kind, params)
        path = _cache_root(cache_dir) / "environments" / f"{kind}-{key[:24]}.exr"
        if not path.is_file():
            from compare.image.exr import write_exr

            write_exr(path, procedural_map(kind, params),
                      metadata={"renderer": "procedural-environment", "procedural": kind,
                                "procedural_version": PROCEDURAL_VERSION, "key": key})
        return path
    raise ValueError("environment: has neither constant, file, procedural nor blender")


def environment_image(env, cache_dir: str | Path | None = None) -> np.ndarray:
    """The environment's equirectangular radiance map (float32 H×W×3), *without* ``intensity``.

    A constant environment gives a uniform :data:`CONSTANT_MAP_SIZE` map of its colour.
    """
    if getattr(env, "constant", None) is not None:
        w, h = CONSTANT_MAP_SIZE
        return np.ascontiguousarray(np.broadcast_to(np.asarray(env.constant, dtype=np.float32), (h, w, 3)))
    return load_equirect(environment_path(env, cache_dir))
