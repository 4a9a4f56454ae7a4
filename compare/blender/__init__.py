"""Blender Cycles and EEVEE, the paper's own comparators, through the ``bpy`` wheel (extra ``blender``).

* :func:`render_blender` renders a scene with Cycles (CPU) or EEVEE in a
  separate process and returns a :class:`BlenderResult` (image, seconds,
  startup_seconds, metadata).
* :mod:`compare.blender.export` holds every convention of the mapping (camera,
  area-light radiometry, Principled BSDF, environment orientation, pixel
  filter, path depth) and is usable without bpy.
* :mod:`compare.run.likeness` measures how "Cycles-like" the Mitsuba
  reference in ``cycles`` material mode is.

Importing this package never imports bpy; :func:`blender_available` says
whether renders can run.
"""

from compare.blender.export import CYCLES_PAPER_SAMPLES, EEVEE_PAPER_SAMPLES, ENGINES
from compare.blender.render import BlenderError, BlenderResult, blender_available, blender_python, render_blender

__all__ = [
    "CYCLES_PAPER_SAMPLES",
    "EEVEE_PAPER_SAMPLES",
    "ENGINES",
    "BlenderError",
    "BlenderResult",
    "blender_available",
    "blender_python",
    "render_blender",
]
