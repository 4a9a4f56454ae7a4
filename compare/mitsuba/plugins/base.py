"""What the suite's BSDF plugins share: :class:`PluginBSDF`, and :class:`LayeredBSDF` for a lobe layered over
a nested BSDF (the coat and the sheen). Bound to a variant: see :mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import drjit as dr
from mitsuba import BSDFFlags

from compare.mitsuba.plugins import bound_variant

__all__ = ["LayeredBSDF", "PluginBSDF"]

mv = bound_variant(__name__)


class PluginBSDF(mv.BSDF):
    """A BSDF plugin of the suite: ``eval`` and ``pdf`` are the parts of ``eval_pdf``; nothing for
    ``mi.traverse`` unless a subclass says so (nested BSDFs and textures are not exposed); ``to_string``
    names the class and :meth:`_fields`."""

    def eval(self, ctx, si, wo, active=True):
        return self.eval_pdf(ctx, si, wo, active)[0]

    def pdf(self, ctx, si, wo, active=True):
        return self.eval_pdf(ctx, si, wo, active)[1]

    def traverse(self, callback):
        pass

    def parameters_changed(self, keys=()):
        pass  # nothing is precomputed from the parameters

    def _fields(self) -> list[tuple[str, object]]:
        """(name, value) of what :meth:`to_string` shows."""
        return []

    def to_string(self):
        fields = ", ".join(f"{key} = {value}" for key, value in self._fields())
        return f"{type(self).__name__}[{fields}]"


class LayeredBSDF(PluginBSDF):
    """A glossy lobe over the nested BSDF ``base``: ``value = base · keep + lobe``, sampled by the lobe with
    probability ``p`` and by the base otherwise; the pdf is the mixture (one-sample MIS).

    A subclass gives, at a surface point: :meth:`_point` (the lobe's parameters there), :meth:`_lobe` (what
    the base keeps, the lobe's value times cos_o as a Color3f, its pdf), :meth:`_probability` (``p`` of the
    pdf) and, for sampling, :meth:`_choice` (``p`` and where the lobe may be drawn) and :meth:`_sample_lobe`.
    The lobe is component ``base.component_count()``, after the base's own.
    """

    def __init__(self, props):
        super().__init__(props)
        self.base = props["base"]
        n = self.base.component_count()
        lobe = BSDFFlags.GlossyReflection | BSDFFlags.FrontSide
        self.m_components = [self.base.flags(i) for i in range(n)] + [lobe]
        self.m_flags = self.base.flags() | lobe

    def _point(self, si, active):
        raise NotImplementedError

    def _lobe(self, point, si, wo):
        raise NotImplementedError

    def _probability(self, point, si):
        raise NotImplementedError

    def _choice(self, point, si):
        raise NotImplementedError

    def _sample_lobe(self, point, si, sample2):
        raise NotImplementedError

    def eval_pdf(self, ctx, si, wo, active=True):
        base_value, base_pdf = self.base.eval_pdf(ctx, si, wo, active)
        point = self._point(si, active)
        keep, lobe, lobe_pdf = self._lobe(point, si, wo)
        p = self._probability(point, si)
        value = base_value * keep + lobe
        pdf = p * lobe_pdf + (1.0 - p) * base_pdf
        return dr.select(active, value, mv.Color3f(0.0)), dr.select(active, pdf, 0.0)

    def sample(self, ctx, si, sample1, sample2, active=True):
        point = self._point(si, active)
        p, possible = self._choice(point, si)
        pick = (sample1 < p) & possible
        bs, base_weight = self.base.sample(ctx, si, dr.clip((sample1 - p) / dr.maximum(1.0 - p, 1e-6), 0.0,
                                                            0.999999), sample2, active & ~pick)
        wo = dr.select(pick, self._sample_lobe(point, si, sample2), bs.wo)
        # A delta lobe of the base (a smooth dielectric under the coat) has no pdf to mix: its sample keeps
        # the base's weight, less what the lobe takes, over the probability of the base.
        delta = (~pick) & ((bs.sampled_type & mv.UInt32(+BSDFFlags.Delta)) != 0)
        keep = self._lobe(point, si, bs.wo)[0]
        value, pdf = self.eval_pdf(ctx, si, wo, active)
        ok = active & (pdf > 0.0) & ~delta
        out = dr.zeros(mv.BSDFSample3f)
        out.wo = wo
        out.pdf = dr.select(delta, bs.pdf * (1.0 - p), dr.select(ok, pdf, 0.0))
        out.eta = dr.select(pick, 1.0, bs.eta)
        out.sampled_component = dr.select(pick, mv.UInt32(self.base.component_count()), bs.sampled_component)
        out.sampled_type = dr.select(pick, mv.UInt32(+BSDFFlags.GlossyReflection), bs.sampled_type)
        weight = dr.select(ok, value / dr.select(ok, pdf, 1.0), mv.Color3f(0.0))
        weight = dr.select(delta & active, base_weight * keep / dr.maximum(1.0 - p, 1e-6), weight)
        return out, weight
