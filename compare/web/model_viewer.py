"""model-viewer in headless Chromium (``model-viewer``, ``model-viewer:linear``), on the page infrastructure
of :mod:`compare.web.host` (``page/model-viewer.html`` and ``page/model-viewer.js``).

The job goes to a ``<model-viewer>`` element (npm ``@google/model-viewer``, its module build on the
three.js release it declares as its peer) through its public attributes, as a user sets them: ``src``
the job's glTF, ``environment-image`` and ``skybox-image`` the environment as Radiance HDR (the element
reads ``.hdr``, not EXR; written here, turned and scaled as the scene says, since the element has no
rotation or intensity of its own), ``camera-orbit``, ``camera-target`` and ``field-of-view`` derived from
the suite's look-at camera (the page checks the camera the element made and corrects the field of view
it fits to the model's aspect), ``tone-mapping`` and ``exposure``.

* ``model-viewer``: what the element shows, with its defaults (its neutral tone mapper, exposure 1, its
  MSAA): the canvas read back as 8-bit sRGB, declared display-encoded (``output: display``), so the
  suite measures it with its LDR metrics only. Every step is one more frame of the element.
* ``model-viewer:linear``: ``tone-mapping="none"``, and the element's own three.js scene and camera
  drawn by its own renderer into a float render target, jittered (Halton 2, 3, the first at the pixel
  centres) and averaged in float: linear radiance like the other web engines.

The element has no area lights: the scene's rectangular lights are left out, light and face
(:attr:`MODEL_VIEWER_AREA_LIGHTS`). Its glTF lights (``KHR_lights_punctual``) are three.js lights without
shadows, converted to the suite's units.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from compare.scene.model import MAP_FEATURE_NAMES, MATERIAL_FEATURE_NAMES
from compare.web.host import WebRenderer
from compare.web.panorama import three_panorama

__all__ = ["ModelViewerRenderer", "model_viewer_environment"]

#: The element lights with environments and glTF lights only.
MODEL_VIEWER_AREA_LIGHTS = False
#: The narrowest map handed to the element: three.js sizes the prefiltered environment by the map's own
#: size, and a map a few pixels wide (a constant environment, 16 × 8) lights nothing at all; narrower maps
#: are repeated pixel by pixel, which leaves the radiance of every direction as it was.
MIN_MAP_WIDTH = 256


def model_viewer_environment(image: np.ndarray, rotation_deg: float, intensity: float) -> np.ndarray:
    """The suite's map as the element reads it (:func:`compare.web.panorama.three_panorama`), repeated up to
    :data:`MIN_MAP_WIDTH`: three.js sizes the prefiltered environment by the map's own size."""
    return three_panorama(image, rotation_deg, intensity, MIN_MAP_WIDTH)


class ModelViewerRenderer(WebRenderer):
    """The ``<model-viewer>`` element: as it shows the scene (8-bit sRGB), or tone mapping off, read in float."""

    ENGINE = "model-viewer"
    SCRIPT = "model-viewer.js"
    HTML = "model-viewer.html"
    # three-r183: the three.js its module build imports (npm alias of its peer release); gainmap-js its
    # other import
    PACKAGES = ("@google/model-viewer", "three-r183", "@monogrid/gainmap-js")
    VERSION_KEY = "model_viewer"
    OPTIONS = {"linear": "tone-mapping none, its three.js scene drawn into a float render target and averaged "
                         "over jittered frames (linear radiance), instead of its 8-bit tone-mapped canvas"}
    VARIANTS = ("model-viewer:linear",)
    # its GLTFLoader reads every material extension of the job's glTF into MeshPhysicalMaterial, BLEND as a
    # transparent material, COLOR_0 as vertex colours, KHR_lights_punctual as three's lights
    renders = (frozenset(MATERIAL_FEATURE_NAMES) | frozenset(MAP_FEATURE_NAMES)
               | {"punctual_lights", "vertex_colors", "single_sided", "hidden_background"})
    area_lights = MODEL_VIEWER_AREA_LIGHTS

    def describe(self, opts: list[str]) -> str:
        return "model-viewer (" + ("tone mapping off, float readback" if "linear" in opts
                                   else "its defaults: neutral tone mapping, 8-bit sRGB") + ")"

    def write_files(self, scene, folder: Path, context) -> None:
        """``environment.hdr``: the scene's environment as the element reads it (black where it has none, so
        that the element's own default lighting stays out)."""
        from compare.image.hdr import write_hdr
        from compare.scene.environments import environment_image

        env = scene.environment
        if env is None:
            image = np.zeros((2, 4, 3), dtype=np.float32)
        else:
            image = model_viewer_environment(environment_image(env, context.cache_dir or None), env.rotation,
                                             env.intensity)
        write_hdr(folder / "environment.hdr", image)
