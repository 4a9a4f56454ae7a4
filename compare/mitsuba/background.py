"""A hidden background for the reference: the environment lights the scene but is not seen where a camera
ray hits nothing (``[environment] background = false``).

Mitsuba's own switch, the integrators' ``hide_emitters``, hides every emitter a camera ray meets first: the
area lights and emissive meshes seen directly go black with the environment. :class:`HiddenBackground`
wraps Mitsuba's ``path`` or ``volpath`` instead: a camera ray that hits no surface at all returns 0, and
every other ray is the wrapped integrator's own sample, unchanged (the test below reads no random number,
so the wrapped integrator sees the sampler as it would alone). A camera ray that escapes only after a
surface (a reflection, a refraction) still sees the environment. Registered as ``compare_hidden_background``
with the wrapped integrator as its one nested object.

A scene with alpha masks is rendered by :mod:`compare.mitsuba.layers` (``background = false``), which also
hides what a camera ray sees through the masks' holes; ``volpath`` (a scene with absorbing solids) counts a
hole as a surface, so there the environment stays seen through holes.
"""

from __future__ import annotations

__all__ = ["INTEGRATOR_NAME", "integrator_dict", "register"]

#: Name under which :class:`HiddenBackground` is registered.
INTEGRATOR_NAME = "compare_hidden_background"


def register():
    """Register ``compare_hidden_background`` for the active Mitsuba variant (idempotent); returns ``mitsuba``."""
    from compare.mitsuba.backend import register_integrator_once

    return register_integrator_once(INTEGRATOR_NAME, _make_class)


def _make_class(mi):
    import drjit as dr

    class HiddenBackground(mi.SamplingIntegrator):
        """The nested integrator, with 0 for camera rays that hit nothing (see the module notes)."""

        def __init__(self, props):
            mi.SamplingIntegrator.__init__(self, props)
            inner = [props.get(name) for name in props.keys() if isinstance(props.get(name), mi.Integrator)]
            if len(inner) != 1:
                raise ValueError(f"{INTEGRATOR_NAME}: expected one nested integrator, got {len(inner)}")
            self.inner = inner[0]

        def aov_names(self):
            return self.inner.aov_names()

        def sample(self, scene, sampler, ray, medium=None, active=True):
            # the same intersection routine the wrapped integrator's first step runs
            hit = scene.ray_intersect_preliminary(ray, coherent=True, active=active).is_valid()
            L, valid, aovs = self.inner.sample(scene, sampler, ray, medium, active)
            return dr.select(hit, L, 0.0), valid & hit, aovs

        def to_string(self):
            return f"HiddenBackground[{self.inner}]"

    return HiddenBackground


def integrator_dict(inner: dict) -> dict:
    """The Mitsuba dictionary of ``inner`` (an integrator's) with a hidden background; registers the plugin."""
    register()
    return {"type": INTEGRATOR_NAME, "inner": inner}
