"""compare: a validation and comparison suite for physically based real-time rendering.

Scenes (:mod:`compare.scene`) are rendered by a path-traced reference
(:mod:`compare.reference`) and by real-time renderers; images are compared with
:mod:`compare.metrics` after one shared tone mapping (:mod:`compare.tonemap`).
"""

__version__ = "0.1.0"
