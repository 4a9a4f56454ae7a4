"""glTF's dispersion (``KHR_materials_dispersion``) in the reference: a refracting volume whose IOR differs per
colour channel, as a Mitsuba 3 plugin (``dispersive``) over three nested dielectrics, one per channel's IOR
(:func:`compare.scene.model.channel_iors`, the extension's rule for RGB renderers).

An RGB path tracer has no wavelength to carry along a path, so each interaction picks one channel (the
"hero"), uniformly, and the path continues in the direction that channel's IOR refracts to, with the
channel's throughput times 3 and the others' 0. A path that meets a second dispersive interface picks again:
only the paths whose picks agree carry light, with 3 × 3 the weight, so every channel's estimate stays
unbiased (at the cost of noise; a spectral variant would carry the wavelength instead).

A rough dispersive lobe is sampled the same way but weighted as the mixture it is: ``eval`` gives each
channel its own dielectric's value, ``pdf`` the mean of the three pdfs, and a sample's weight is their
ratio (one-sample MIS over the three lobes), so that emitter sampling and BSDF sampling agree. A smooth one
(a delta lobe) has no value to evaluate: its weight is the picked channel's, times 3.

Properties: ``bsdf_0``, ``bsdf_1``, ``bsdf_2`` (the dielectrics of the red, green and blue IOR) and
``rough`` (bool: the nested lobes are rough).

The class is ``DispersiveBSDF`` of :mod:`compare.mitsuba.plugins.dispersion` (bound to a variant:
:mod:`compare.mitsuba.plugins`).
"""

from __future__ import annotations

__all__ = ["PLUGIN_NAME", "register"]

PLUGIN_NAME = "dispersive"


def register(variant: str | None = None):
    """Register ``dispersive`` with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import load_active_mitsuba  # noqa: PLC0415 - Mitsuba is loaded lazily

    load_active_mitsuba(variant)  # first: the class subclasses the classes of the variant set
    from compare.mitsuba.plugins import dispersion as classes, register_plugin  # noqa: PLC0415

    return register_plugin(PLUGIN_NAME, classes, "DispersiveBSDF")
