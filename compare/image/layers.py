"""The names of the light layers a rendering may split its last image into (by where the light comes from).

A leaf: engines name their layers with these, :mod:`compare.metrics.layers` measures them. Kept apart
from the metrics so that an engine's render key (the import closure of its code) holds no metric code.
"""

from __future__ import annotations

__all__ = ["EXTRA_LAYERS", "LAYERS", "LAYER_TITLES", "SUM_LAYERS"]

#: The layers that sum to the image, in order.
SUM_LAYERS = ("emission", "direct_area", "direct_env", "direct_punctual", "indirect_diffuse", "indirect_specular")
#: Layers beside the sum.
EXTRA_LAYERS = ("direct_area_unshadowed",)
#: Every layer a renderer may give (:attr:`compare.renderers.base.Rendering.layers`).
LAYERS = SUM_LAYERS + EXTRA_LAYERS
#: Each layer's heading in a report.
LAYER_TITLES = {"emission": "emission", "direct_area": "direct, area lights", "direct_env": "direct, environment",
                "direct_punctual": "direct, point, spot and directional lights",
                "indirect_diffuse": "indirect diffuse", "indirect_specular": "indirect specular",
                "direct_area_unshadowed": "direct, area lights, unshadowed"}
