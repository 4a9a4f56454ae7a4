"""Image-based lighting: environment preprocessing for the rasterizer, cached by content.

:func:`preprocess` turns an equirectangular radiance map into everything the
rasterizer's environment lighting reads (Otto et al. 2020, §3.1; Karis 2013):

* a cube source chain (:mod:`compare.ibl.prefilter`, :mod:`compare.ibl.cubemap`);
* the **prefiltered specular chain**, ``levels`` levels for roughness
  ``i / (levels − 1)``, read at ``lod = roughness · (levels − 1)``;
* **diffuse irradiance** as 9 SH coefficients and as a convolved cube
  (:mod:`compare.ibl.irradiance`);
* optionally the prefiltered chain as **octahedral** maps with 1-texel borders;
* and, separately because it does not depend on the environment, the
  **split-sum LUT** (:func:`split_sum`, :mod:`compare.ibl.lut`).

The GLSL that reads all of it lives here too: ``mapping.glsl`` (the
equirectangular, cube-face and octahedral mappings, mirroring
:mod:`compare.scene.environments`, :mod:`compare.ibl.cubemap` and
:mod:`compare.image.encodings`) and ``ibl.glsl`` (background, prefiltered lookup,
irradiance, split sum; :func:`glsl_source` writes its constants, :data:`GLSL_DEFINES`, ahead of it).
:mod:`compare.ibl.groundtruth` is the brute-force
reference of the same integral and :mod:`compare.bench.ibl_accuracy` the benchmark
(``python -m compare.bench.ibl_accuracy``).

Results are cached as ``.npz`` files under ``<cache>/ibl/`` (cache:
:func:`compare.mitsuba.reference.default_cache_dir`, i.e. ``$COMPARE_CACHE`` or
``~/.cache/compare``), keyed by the SHA-256 of the map's pixels and shape, every
setting, and :data:`IBL_VERSION`; written atomically
(:func:`compare.util.files.atomic_path`). The seconds each stage took are stored
with the result and returned from the cache too (``IBL.timings``,
``IBL.cached``).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from compare.brdf.glsl import with_defines
from compare.util.files import atomic_path, sha256_bytes
from compare.ibl.atlas import ENV_FORMATS, Atlas, build_atlas
from compare.ibl.cubemap import padded_directions
from compare.ibl.irradiance import convolve_irradiance, sh9_project
from compare.ibl.lut import split_sum_lut
from compare.ibl.prefilter import level_roughness, level_sizes, prefilter as _prefilter, source_chain

__all__ = ["DEFAULT_LEVELS", "DEFAULT_SAMPLES", "DEFAULT_SIZE", "ENV_FORMATS", "GLSL_DEFINES", "GLSL_PATH", "IBL",
           "IBL_VERSION", "MAX_LEVELS", "Atlas", "build_atlas", "glsl_source", "preprocess", "split_sum"]

#: Bumped whenever preprocessing changes its output (part of every cache key).
IBL_VERSION = 1
#: Face size of the source cube and of prefiltered level 0.
DEFAULT_SIZE = 128
#: Prefiltered levels (the paper's public code: 9, roughness i/8).
DEFAULT_LEVELS = 9
#: Largest number of prefiltered levels ibl.glsl accepts (the length of its u_env_levels).
MAX_LEVELS = 12
#: GGX samples per prefiltered texel (the paper's public code: 512).
DEFAULT_SAMPLES = 512
#: Face size of the convolved irradiance cube.
DEFAULT_IRRADIANCE_SIZE = 16
#: Split-sum LUT resolution and samples per texel.
DEFAULT_LUT_SIZE = 32
DEFAULT_LUT_SAMPLES = 1024
#: The environment lighting's GLSL, and the constants it takes from Python.
GLSL_PATH = Path(__file__).with_name("ibl.glsl")
GLSL_DEFINES = {"ENV_MAX_LEVELS": MAX_LEVELS}


def glsl_source() -> str:
    """Text of ``ibl.glsl`` with :data:`GLSL_DEFINES` ahead of it (no ``#version`` line)."""
    return with_defines(GLSL_PATH, GLSL_DEFINES)


@dataclass
class IBL:
    """Preprocessed environment (all float32, directions in the map's own frame)."""

    radiance: list[np.ndarray]
    """Padded prefiltered cube levels (6, S_i+2, S_i+2, 3); level i ↔ roughness[i]."""
    roughness: np.ndarray
    """Perceptual roughness of each level, i / (levels − 1)."""
    irradiance: np.ndarray
    """Padded convolved cube (6, s+2, s+2, 3) of the irradiance E (W/m²)."""
    sh9: np.ndarray
    """(9, 3) radiance SH coefficients (multiply band l by Â_l for irradiance)."""
    octahedral: list[np.ndarray] | None
    """Padded octahedral levels (O_i+2, O_i+2, 3), O_i = 2·S_i, or None."""
    settings: dict
    key: str
    timings: dict[str, float] = field(default_factory=dict)
    """Seconds of each stage when it was computed: cube, prefilter, irradiance, sh9, octahedral, total."""
    cached: bool = False

    def atlas(self, env_format: str = "float") -> Atlas:
        """The 2D atlas the rasterizer uploads for ``env_format`` (float, rgbm, octahedral)."""
        return build_atlas(self.radiance, octahedral_levels=self.octahedral, env_format=env_format)


def _cache_root(cache_dir, folder: str = "ibl") -> Path | None:
    if cache_dir is False:
        return None
    if cache_dir is None:
        from compare.util.cache import default_cache_dir

        return default_cache_dir() / folder
    return Path(cache_dir) / folder


def _save(path: Path, arrays: dict[str, np.ndarray], meta: dict) -> None:
    with atomic_path(path, suffix=".npz") as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, _meta=np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8), **arrays)


def _load(path: Path) -> tuple[dict[str, np.ndarray], dict] | None:
    try:
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, KeyError, EOFError):
        return None  # a damaged entry is recomputed
    meta = json.loads(arrays.pop("_meta").tobytes().decode())
    return arrays, meta


def preprocess(equirect: np.ndarray, *, size: int = DEFAULT_SIZE, levels: int = DEFAULT_LEVELS,
               samples: int = DEFAULT_SAMPLES, irradiance_size: int = DEFAULT_IRRADIANCE_SIZE,
               octahedral: bool = False, cache_dir=None) -> IBL:
    """Preprocess an equirectangular radiance map (H, W, 3) for the rasterizer; cached by content.

    Parameters
    ----------
    equirect : ndarray (H, W, 3)
        Linear radiance in :mod:`compare.scene.environments`' mapping.
    size : int, keyword-only
        Face size of the cube (a power of two); prefiltered level 0 has it.
    levels : int, keyword-only
        Prefiltered levels, roughness i / (levels − 1).
    samples : int, keyword-only
        GGX samples per prefiltered texel (with pdf-based source-level choice).
    irradiance_size : int, keyword-only
        Face size of the convolved irradiance cube.
    octahedral : bool, keyword-only
        Also build the octahedral form of the prefiltered chain.
    cache_dir : path, None or False, keyword-only
        Cache root (``<cache_dir>/ibl/``); None: the default cache; False: no cache.

    Returns
    -------
    IBL
    """
    img = np.ascontiguousarray(equirect, dtype=np.float32)
    if img.ndim != 3 or img.shape[2] != 3 or img.shape[0] < 3 or img.shape[1] < 2:
        raise ValueError(f"equirect: expected an (H, W, 3) map of at least 2×3 pixels, got shape {img.shape}")
    if not np.all(np.isfinite(img)) or img.min() < 0:
        raise ValueError("equirect: the map must hold finite, non-negative radiance")
    if size < 2 or size & (size - 1):
        raise ValueError(f"size: expected a power of two >= 2, got {size}")
    if samples < 1:
        raise ValueError(f"samples: expected a positive number, got {samples}")
    settings = {"size": int(size), "levels": int(levels), "samples": int(samples),
                "irradiance_size": int(irradiance_size), "octahedral": bool(octahedral), "version": IBL_VERSION}
    key = sha256_bytes("ibl", json.dumps(settings, sort_keys=True), repr(img.shape), img.tobytes())
    root = _cache_root(cache_dir)
    path = root / key[:2] / f"{key}.npz" if root is not None else None
    if path is not None and path.is_file():
        loaded = _load(path)
        if loaded is not None:
            arrays, meta = loaded
            return IBL(
                radiance=[arrays[f"radiance_{i}"] for i in range(levels)],
                roughness=arrays["roughness"], irradiance=arrays["irradiance"], sh9=arrays["sh9"],
                octahedral=[arrays[f"octahedral_{i}"] for i in range(levels)] if octahedral else None,
                settings=settings, key=key, timings=meta["timings"], cached=True)

    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    t0 = time.perf_counter()
    chain = source_chain(img, size)
    timings["cube"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    rough = level_roughness(levels)
    sizes = level_sizes(size, levels)
    radiance = [chain[0].astype(np.float32)]
    for i in range(1, levels):
        radiance.append(_prefilter(chain, padded_directions(sizes[i]), rough[i], samples).astype(np.float32))
    timings["prefilter"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    irradiance = convolve_irradiance(chain, irradiance_size).astype(np.float32)
    timings["irradiance"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    sh9 = sh9_project(chain[0]).astype(np.float32)
    timings["sh9"] = time.perf_counter() - t0

    octa = None
    if octahedral:
        from compare.image.encodings import octahedral_directions, octahedral_pad

        t0 = time.perf_counter()
        octa = []
        for i in range(levels):
            d = octahedral_directions(2 * sizes[i])
            if i == 0:
                from compare.ibl.prefilter import sample_chain

                values = sample_chain(chain, d, 0.0)
            else:
                values = _prefilter(chain, d, rough[i], samples)
            octa.append(octahedral_pad(values).astype(np.float32))
        timings["octahedral"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - t_all

    result = IBL(radiance, rough.astype(np.float32), irradiance, sh9, octa, settings, key, timings, False)
    if path is not None:
        arrays = {f"radiance_{i}": r for i, r in enumerate(radiance)}
        arrays.update(roughness=result.roughness, irradiance=irradiance, sh9=sh9)
        if octa is not None:
            arrays.update({f"octahedral_{i}": o for i, o in enumerate(octa)})
        _save(path, arrays, {"timings": timings, "settings": settings})
    return result


def split_sum(size: int = DEFAULT_LUT_SIZE, samples: int = DEFAULT_LUT_SAMPLES, *, cache_dir=None
              ) -> tuple[np.ndarray, float, bool]:
    """The split-sum LUT (size, size, 3) (:func:`compare.ibl.lut.split_sum_lut`), cached.

    The table depends on the BRDF alone, so its cache lives under ``brdf/``: the
    environment light, the direct-light pass (which bounds its specular term with
    it) and the irradiance volume share one copy, and a scene without an
    environment does no environment work.
    Returns (table, seconds it took to compute, whether it came from the cache).
    """
    settings = {"size": int(size), "samples": int(samples), "version": IBL_VERSION}
    key = sha256_bytes("split-sum-lut", json.dumps(settings, sort_keys=True))
    root = _cache_root(cache_dir, "brdf")
    path = root / f"lut-{key[:24]}.npz" if root is not None else None
    if path is not None and path.is_file():
        loaded = _load(path)
        if loaded is not None:
            return loaded[0]["lut"], float(loaded[1]["seconds"]), True
    t0 = time.perf_counter()
    table = split_sum_lut(size, samples)
    seconds = time.perf_counter() - t0
    if path is not None:
        _save(path, {"lut": table}, {"seconds": seconds, "settings": settings})
    return table, seconds, False
