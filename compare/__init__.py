"""compare: a validation and comparison suite for physically based real-time rendering.

Scenes (:mod:`compare.scene.loader`) are rendered by a path-traced reference
(:mod:`compare.mitsuba.reference`) and by real-time renderers; images are compared with
:mod:`compare.metrics.images` after one shared tone mapping (:mod:`compare.image.tonemap`).
"""

__version__ = "0.1.0"
