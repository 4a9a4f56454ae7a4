"""three.js in headless Chromium: ``threejs`` (rasterized) and ``threejs-pathtracer``
(three-gpu-pathtracer), renderers of the registry like every other, on the page infrastructure of
:mod:`compare.web.host` (``page/engine.js`` builds the job in three.js).

* ``threejs``: ``MeshStandardMaterial`` from the glTF, ``RectAreaLight`` (linearly
  transformed cosines, no shadows) for each area light plus a visible emitter
  face, the environment through PMREM, no tone mapping. Frame 1 is drawn at the
  pixel centres, later frames jittered (Halton 2, 3) and averaged in float, so it
  has an error-against-time curve like the rasterizer's. Steps are frames.
* ``threejs-pathtracer``: the same scene path traced in the page, one sample
  per step (``--frames`` of them), ``bounces = max_depth - 1``.

Timings are the page's: ``performance.now()`` around each step, ending in a
one-pixel readback that waits for the GPU; page and engine start-up (shader
compilation, BVH build) are set-up.
"""

from __future__ import annotations

from compare.scene.model import MAP_FEATURE_NAMES, MATERIAL_FEATURE_NAMES
from compare.web.host import WebRenderer

__all__ = ["THREEJS_OPTIONS", "ThreeJsPathTracer", "ThreeJsRenderer"]

#: Options of ``threejs:<option>[+<option>]`` and what they change.
THREEJS_OPTIONS = {
    "shadows": WebRenderer.SPOT_SHADOWS,
    "msaa": "4x MSAA in each frame's float target",
}


class ThreeJsRenderer(WebRenderer):
    """three.js, rasterized: jittered frames averaged in float."""

    ENGINE = "threejs"
    SCRIPT = "engine.js"
    PACKAGES = ("three",)
    VERSION_KEY = "three"
    OPTIONS = THREEJS_OPTIONS
    VARIANTS = ("threejs:shadows",)
    # GLTFLoader reads every material extension of the job's glTF into MeshPhysicalMaterial, and BLEND as a
    # transparent material; three's PointLight, SpotLight and DirectionalLight too; COLOR_0 as vertexColors.
    renders = (frozenset(MATERIAL_FEATURE_NAMES) | frozenset(MAP_FEATURE_NAMES)
               | {"punctual_lights", "vertex_colors", "single_sided", "hidden_background"})

    def describe(self, opts: list[str]) -> str:
        what = ("shadow-mapped spot lights" if "shadows" in opts else "RectAreaLight") + ", PMREM" \
            + (", 4x MSAA" if "msaa" in opts else "")
        return f"three.js ({what})"


class ThreeJsPathTracer(WebRenderer):
    """three-gpu-pathtracer in the page, one sample per step; its budget is the run's ``--frames``, as a
    real-time path tracer's samples are frames."""

    ENGINE = "threejs-pathtracer"
    SCRIPT = "engine.js"
    PACKAGES = ("three", "three-gpu-pathtracer", "three-mesh-bvh")
    VERSION_KEY = "three"
    unit = "spp"
    renders = ((frozenset(MATERIAL_FEATURE_NAMES) - {"dispersion", "anisotropy", "iridescence"})  # not measured here
               | {"hidden_background"})  # a colour scene.background: its camera rays see it, the others the map

    def describe(self, opts: list[str]) -> str:
        return "three.js path tracer (three-gpu-pathtracer)"
