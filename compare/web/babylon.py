"""Babylon.js in headless Chromium (``babylon``), on the page infrastructure of :mod:`compare.web.host`
(``page/babylon.js``).

The job's glTF goes through Babylon's own glTF loader (``PBRMaterial`` with every material extension
the job carries, ``KHR_lights_punctual`` as Babylon's point, spot and directional lights with shadow
maps); each area light is a ``RectAreaLight`` (linearly transformed cosines, no shadows) with a
visible emitter face; the environment EXR goes through ``EXRCubeTexture`` and Babylon's own
prefiltering. Image processing is off (no tone mapping, no gamma, no clamp); frames are drawn into a
float ``RenderTargetTexture``, jittered (Halton 2, 3, the first at the pixel centres) and averaged in
float. ``babylon:shadows`` puts shadow-mapped spot lights where the area lights are, as
``threejs:shadows`` does.
"""

from __future__ import annotations

from compare.scene.model import MAP_FEATURE_NAMES, MATERIAL_FEATURE_NAMES
from compare.web.host import WebRenderer

__all__ = ["BabylonRenderer"]


class BabylonRenderer(WebRenderer):
    """Babylon.js, rasterized: jittered frames averaged in float."""

    ENGINE = "babylon"
    SCRIPT = "babylon.js"
    # three: the LTC tables of its RectAreaLight (Babylon fetches the same fit from its CDN); fflate: the
    # EXR reader's inflate, which Babylon loads from unpkg
    PACKAGES = ("@babylonjs/core", "@babylonjs/loaders", "fflate", "three")
    VERSION_KEY = "babylon"
    OPTIONS = {"shadows": WebRenderer.SPOT_SHADOWS}
    VARIANTS = ("babylon:shadows",)
    renders = (frozenset(MATERIAL_FEATURE_NAMES) | frozenset(MAP_FEATURE_NAMES)
               | {"punctual_lights", "vertex_colors", "single_sided", "hidden_background"})

    def describe(self, opts: list[str]) -> str:
        return "Babylon.js (" + ("shadow-mapped spot lights" if "shadows" in opts else "RectAreaLight") \
            + ", EXRCubeTexture prefiltered)"
