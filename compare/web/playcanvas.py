"""PlayCanvas in headless Chromium (``playcanvas``), on the page infrastructure of
:mod:`compare.web.host` (``page/playcanvas.js``).

The job's glTF goes through PlayCanvas' own container loader (``StandardMaterial``,
``KHR_lights_punctual`` as PlayCanvas' lights, their intensities set from the job since the loader
clamps them); each area light is a light of rectangular shape (``LIGHTSHAPE_RECT``, linearly
transformed cosines) with a visible emitter face; the environment EXR goes through PlayCanvas' own
prefiltering (``EnvLighting`` into a half-float env atlas). No tone mapping, no gamma; frames are
drawn into an RGBA32F render target, jittered (Halton 2, 3, the first at the pixel centres) and
averaged in float in plain WebGL 2, which also reads them back. ``playcanvas:shadows`` lets each
rectangular light cast a shadow from its spot shadow map.
"""

from __future__ import annotations

from compare.scene.model import MAP_FEATURE_NAMES, MATERIAL_FEATURE_NAMES

from compare.web.host import WebRenderer

__all__ = ["PlayCanvasRenderer"]


class PlayCanvasRenderer(WebRenderer):
    """PlayCanvas, rasterized: jittered frames averaged in float."""

    ENGINE = "playcanvas"
    SCRIPT = "playcanvas.js"
    # three: the LTC tables of the rectangular lights (PlayCanvas' examples load the same fit) and the EXR
    # decoder (PlayCanvas reads no EXR)
    PACKAGES = ("playcanvas", "three")
    VERSION_KEY = "playcanvas"
    OPTIONS = {"shadows": "each rectangular light casts a shadow from a spot shadow map at its centre"}
    VARIANTS = ("playcanvas:shadows",)
    # StandardMaterial from the glTF: clearcoat, sheen, transmission (refraction), ior, specular, volume
    # (thickness, attenuation) and BLEND are read by PlayCanvas' glTF parser; the extensions' maps are not
    # checked here, so they are declared left out
    # (anisotropy: its glTF import leaves KHR_materials_anisotropy out: measured no change at strength 0.9)
    renders = ((frozenset(MATERIAL_FEATURE_NAMES) - {"layer_maps", "anisotropy"})
               | {"punctual_lights", "vertex_colors", "single_sided", "hidden_background", *MAP_FEATURE_NAMES})

    def describe(self, opts: list[str]) -> str:
        return "PlayCanvas (rectangular lights" + (" with spot shadow maps" if "shadows" in opts else "") \
            + ", EnvLighting atlas)"
