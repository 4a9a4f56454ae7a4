"""The Khronos glTF Sample Viewer in headless Chromium (``gltf-sample-viewer``), on the page infrastructure of
:mod:`compare.web.host` (``page/sample-viewer.js``).

The job goes through the viewer's own API (npm ``@khronosgroup/gltf-viewer``, the glTF Sample Renderer):
its ``ResourceLoader`` reads the job's glTF (every material extension the job writes, ``KHR_lights_punctual``,
``COLOR_0``, ``doubleSided``, ``KHR_texture_transform``, both UV sets) and prefilters the environment itself
in WebGL from an HDR panorama (GGX and Charlie mip chains, a Lambertian cube, the split-sum LUTs); the
panorama is written here (``environment.hdr``) with the scene's rotation and intensity baked in, as the
viewer has neither of the suite's kind. Tone mapping ``NONE`` with the viewer's own ``LINEAR_OUTPUT`` define
(no output transfer), the frame drawn into a float framebuffer of its context (its draws to the default
framebuffer redirected there), the suite's camera as its user camera, jittered (Halton 2, 3, the first at the
pixel centres) and averaged in float.

The viewer has no area lights: the scene's rectangular lights are left out, light and face
(:attr:`SampleViewerRenderer.area_lights`); its punctual lights cast no shadows. Its transmission refracts an
8-bit copy of the opaque scene (the viewer's own RGBA8 target), so refracted radiance above 1 is clipped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from compare.scene.model import MAP_FEATURE_NAMES, MATERIAL_FEATURE_NAMES
from compare.web.host import WebRenderer
from compare.web.panorama import three_panorama

__all__ = ["SampleViewerRenderer", "sheen_lut_image"]


def sheen_lut_image() -> np.ndarray:
    """The sheen albedo table the viewer reads as ``lut_sheen_E.png`` (its repository ships one; its npm
    package does not): E(n·v, roughness) of :func:`compare.brdf.sheen.albedo_table`, 8-bit grey, columns
    n·v and rows roughness from the top (the viewer uploads the image unflipped and reads it at
    (n·v, roughness))."""
    from compare.brdf.sheen import albedo_table

    return np.round(np.clip(albedo_table().T, 0.0, 1.0) * 255.0).astype(np.uint8)


class SampleViewerRenderer(WebRenderer):
    """The Khronos glTF Sample Viewer, rasterized: its own frame in float, jittered frames averaged."""

    ENGINE = "gltf-sample-viewer"
    SCRIPT = "sample-viewer.js"
    PACKAGES = ("@khronosgroup/gltf-viewer",)
    VERSION_KEY = "gltf_sample_viewer"
    OPTIONS = {"coarse": "the viewer's IBL prefiltering at a 64² cube (mips down to 4², the same five roughness "
                         "levels), 256 Lambertian and 128 GGX samples a texel and 128² LUTs instead of its "
                         "256², 2048, 1024 and 1024²: set-up in seconds on a CPU (SwiftShader) instead of minutes"}
    # the reference implementation of glTF's materials: every extension the job writes, BLEND, COLOR_0,
    # single-sided culling, a texCoord, transform and sampler per map, KHR_lights_punctual (no shadows)
    renders = (frozenset(MATERIAL_FEATURE_NAMES) | frozenset(MAP_FEATURE_NAMES)
               | {"punctual_lights", "vertex_colors", "single_sided", "hidden_background"})
    area_lights = False

    def describe(self, opts: list[str]) -> str:
        ibl = "coarse IBL prefiltering" if "coarse" in opts else "its own IBL prefiltering"
        return f"Khronos glTF Sample Viewer ({ibl}, tone mapping off, float readback)"

    def write_files(self, scene, folder: Path, context) -> None:
        """``environment.hdr`` (the scene's environment laid out for the viewer's panorama lookup, turned and
        scaled; black where it has none) and ``lut_sheen_E.png`` (:func:`sheen_lut_image`)."""
        import imageio.v3 as iio

        from compare.image.hdr import write_hdr
        from compare.scene.environments import environment_image

        env = scene.environment
        if env is None:  # the viewer lights every draw with an environment: a black one
            image = np.zeros((2, 4, 3), dtype=np.float32)
        else:
            image = three_panorama(environment_image(env, context.cache_dir or None), env.rotation, env.intensity)
        write_hdr(folder / "environment.hdr", image)
        iio.imwrite(folder / "lut_sheen_E.png", sheen_lut_image())
