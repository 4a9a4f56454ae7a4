"""The class of ``dispersive``, one dielectric per colour channel's IOR (:mod:`compare.mitsuba.dispersion`:
read its docstring). Bound to a variant: see :mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import drjit as dr

from compare.mitsuba.plugins import base, bound_variant, for_variant

__all__ = ["DispersiveBSDF"]

mv = bound_variant(__name__)
PluginBSDF = for_variant(base).PluginBSDF


def _channels(a, b, c):
    """The colour whose channels are the red of ``a``, the green of ``b`` and the blue of ``c``."""
    return mv.Color3f(a[0], b[1], c[2])


class DispersiveBSDF(PluginBSDF):
    """A dielectric whose IOR differs per colour channel: three nested ones, a hero channel per sample."""

    def __init__(self, props):
        super().__init__(props)
        self.lobes = [props[f"bsdf_{k}"] for k in range(3)]
        self.rough = bool(props.get("rough", False))
        first = self.lobes[0]
        self.m_components = [first.flags(i) for i in range(first.component_count())]
        self.m_flags = first.flags()

    def eval_pdf(self, ctx, si, wo, active=True):
        pairs = [lobe.eval_pdf(ctx, si, wo, active) for lobe in self.lobes]
        value = _channels(*(v for v, _ in pairs))
        return value, (pairs[0][1] + pairs[1][1] + pairs[2][1]) * (1.0 / 3.0)

    def sample(self, ctx, si, sample1, sample2, active=True):
        x = sample1 * 3.0
        hero = dr.minimum(mv.UInt32(dr.floor(x)), 2)
        again = x - mv.Float(hero)  # the pick's sample, stretched back to [0, 1)
        samples = [lobe.sample(ctx, si, again, sample2, active) for lobe in self.lobes]
        bs, weight = samples[0]
        mask = [hero == k for k in range(3)]
        for k in (1, 2):
            other, w = samples[k]
            bs.wo = dr.select(mask[k], other.wo, bs.wo)
            bs.pdf = dr.select(mask[k], other.pdf, bs.pdf)
            bs.eta = dr.select(mask[k], other.eta, bs.eta)
            bs.sampled_type = dr.select(mask[k], other.sampled_type, bs.sampled_type)
            bs.sampled_component = dr.select(mask[k], other.sampled_component, bs.sampled_component)
            weight = dr.select(mask[k], w, weight)
        if self.rough:  # the mixture's value over its pdf at the direction drawn
            value, pdf = self.eval_pdf(ctx, si, bs.wo, active)
            bs.pdf = pdf
            return bs, dr.select(pdf > 0.0, value / dr.maximum(pdf, 1e-20), 0.0)
        hero_only = mv.Color3f(dr.select(mask[0], 3.0, 0.0), dr.select(mask[1], 3.0, 0.0), dr.select(mask[2], 3.0, 0.0))
        return bs, weight * hero_only

    def _fields(self):
        return [("rough", self.rough)]
