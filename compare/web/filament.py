"""Filament's web build in headless Chromium (``filament``), on the page infrastructure of
:mod:`compare.web.host` (``page/filament.js``).

The job's glTF goes through Filament's own glTF loader (gltfio in npm ``filament``'s WebAssembly build: its
ubershader materials, ``KHR_lights_punctual`` as Filament's point, spot and directional lights, their
intensities set from the job). Filament's image-based light normally comes from ``cmgen``, a native tool of
its release archives that is not on npm; the suite makes the same inputs of ``IndirectLight.Builder``
itself (:mod:`compare.web.filament_ibl`: a GGX-prefiltered reflections cube with its mips and nine
irradiance SH coefficients, written beside the job as ``ibl.json`` and ``ibl.bin``), so nothing is
downloaded at run time. Exposure 1, IBL and sky intensity 1, post-processing off (no tone mapping, no output
transfer): the view renders linear radiance into a float render target, jittered (Halton 2, 3, the first at
the pixel centres) and averaged in float.

Filament has no rectangular area lights: they are left out, light and face
(:attr:`FilamentRenderer.area_lights`); its punctual lights are drawn without shadows (gltfio's default).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from compare.scene.model import MAP_FEATURE_NAMES, MATERIAL_FEATURE_NAMES
from compare.web.host import WebRenderer
from compare.web.panorama import three_panorama

__all__ = ["FilamentRenderer", "IBL_SAMPLES", "IBL_SIZE", "write_ibl"]

#: Face size of the reflections cube (its level 0) and GGX samples a texel of the prefiltered levels.
IBL_SIZE = 128
IBL_SAMPLES = 256


def write_ibl(image: np.ndarray | None, folder: Path, *, sky: bool = True) -> None:
    """``ibl.json`` (cube size, per level the byte offset and float count in ``ibl.bin``, the 27 SH floats, whether
    a sky is shown) and ``ibl.bin`` (every level's six faces, RGB float32) of a world-frame map in the
    suite's mapping; ``None``: a black light and no sky (a scene without an environment); ``sky`` False: the
    map lights but no skybox is drawn (a hidden background: the clear colour, black, behind the scene)."""
    from compare.web.filament_ibl import filament_ibl

    if image is None:
        levels = [np.zeros((6, 8 >> i, 8 >> i, 3), np.float32) for i in range(4)]
        sh = np.zeros((9, 3), np.float32)
    else:
        levels, sh = filament_ibl(image, size=IBL_SIZE, samples=IBL_SAMPLES)
    offsets, pos = [], 0
    for lv in levels:
        offsets.append([pos, int(lv.size)])
        pos += int(lv.nbytes)
    (folder / "ibl.bin").write_bytes(b"".join(np.ascontiguousarray(lv, np.float32).tobytes() for lv in levels))
    doc = {"size": int(levels[0].shape[1]), "levels": offsets, "sh": [float(x) for x in sh.reshape(-1)],
           "sky": image is not None and sky}
    (folder / "ibl.json").write_text(json.dumps(doc))


class FilamentRenderer(WebRenderer):
    """Filament (WebAssembly), rasterized: the suite's IndirectLight, jittered frames averaged in float."""

    ENGINE = "filament"
    SCRIPT = "filament.js"
    PACKAGES = ("filament",)
    VERSION_KEY = "filament"
    # gltfio's ubershaders read the core material and clearcoat, sheen, ior, specular, BLEND, COLOR_0,
    # doubleSided, KHR_texture_transform and TEXCOORD_1; not anisotropy, iridescence or dispersion (its loader
    # parses them, its ubershaders have no input for them). Transmission and volume: its refraction is a
    # screen-space pass of the post-processing this page turns off; measured, TransmissionTest's glass
    # spheres come out black.
    renders = ((frozenset(MATERIAL_FEATURE_NAMES) - {"anisotropy", "iridescence", "dispersion", "transmission",
                                                     "volume"})
               | frozenset(MAP_FEATURE_NAMES)
               | {"punctual_lights", "vertex_colors", "single_sided", "hidden_background"})
    area_lights = False

    def describe(self, opts: list[str]) -> str:
        return "Filament (gltfio, the suite's IndirectLight, post-processing off, float readback)"

    def write_files(self, scene, folder: Path, context) -> None:
        """``ibl.json`` and ``ibl.bin`` (:func:`write_ibl`) of the scene's environment, turned and scaled into
        world directions."""
        from compare.scene.environments import environment_image

        env = scene.environment
        image = None
        if env is not None:
            # three_panorama(…, rotation + 90°) is the map in the suite's own lookup with the rotation baked in
            image = three_panorama(environment_image(env, context.cache_dir or None), env.rotation + 90.0,
                                   env.intensity)
        write_ibl(image, folder, sky=env is None or env.background)
