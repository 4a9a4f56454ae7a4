"""The class of ``rough_glass``, height-correlated masking and Cycles' energy compensation around a nested
rough dielectric (:mod:`compare.mitsuba.glass`: read its docstring). Bound to a variant: see
:mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import drjit as dr
import numpy as np

from compare.mitsuba import ggx
from compare.mitsuba.glass_energy import TABLES
from compare.mitsuba.plugins import base, bound_variant, for_variant

__all__ = ["RoughGlassBSDF"]

mv = bound_variant(__name__)
PluginBSDF = for_variant(base).PluginBSDF
_TEXTURE = dict(use_accel=False, filter_mode=dr.FilterMode.Linear, wrap_mode=dr.WrapMode.Clamp)
#: E (3D) and E_avg (2D) of compare.mitsuba.glass_energy.TABLES, trilinear and bilinear on Cycles' grid.
_E = {k: mv.Texture3f(mv.TensorXf(TABLES[k].astype("float32")[..., None]), **_TEXTURE)
      for k in ("ggx_glass_E", "ggx_glass_inv_E")}
_E_AVG = {k: mv.Texture2f(mv.TensorXf(TABLES[k].astype("float32")[..., None]), **_TEXTURE)
          for k in ("ggx_glass_Eavg", "ggx_glass_inv_Eavg")}
_N = 16  # points per axis of the tables


def _coord(x):
    return (dr.clip(x, 0.0, 1.0) * (_N - 1) + 0.5) * (1.0 / _N)


class RoughGlassBSDF(PluginBSDF):
    """Height-correlated masking (and Cycles' compensation) around a nested rough dielectric
    (see :mod:`compare.mitsuba.glass`)."""

    def __init__(self, props):
        super().__init__(props)
        self.nested = props["bsdf"]
        self.roughness = props.get_texture("roughness", 0.0)  # a number, or a map's per texel
        self.compensate = bool(props.get("compensate", False))
        self.ior = float(props.get("ior", 1.5))
        if not self.ior > 1.0:
            raise ValueError(f"{props.plugin_name()}: ior must be > 1, got {self.ior}")
        self.tint = props.get_texture("tint", 1.0)
        self.z = float(np.sqrt((self.ior - 1.0) / (self.ior + 1.0)))
        self.m_components = [self.nested.flags(i) for i in range(self.nested.component_count())]
        self.m_flags = self.nested.flags()

    def _masking(self, si, wo, active):
        r = self.roughness.eval_1(si, active)
        return ggx.masking_ratio(dr, si.wi.z, wo.z, dr.maximum(r * r, 1e-4))

    def _scale(self, si, active):
        """Cycles' energy compensation ``1 + F_ms (1 - E) / E`` (1 without ``compensate``)."""
        if not self.compensate:
            return 1.0
        inside = si.wi.z < 0.0
        mu = dr.abs(si.wi.z)
        r = self.roughness.eval_1(si, active)
        p3 = mv.Point3f(_coord(r), _coord(mu), _coord(self.z))
        p2 = mv.Point2f(_coord(r), _coord(self.z))
        e = dr.select(inside, _E["ggx_glass_inv_E"].eval(p3)[0], _E["ggx_glass_E"].eval(p3)[0])
        e_avg = dr.select(inside, _E_AVG["ggx_glass_inv_Eavg"].eval(p2)[0], _E_AVG["ggx_glass_Eavg"].eval(p2)[0])
        fss = self.tint.eval(si, active)
        f_ms = fss * e_avg / (1.0 - fss * (1.0 - e_avg))
        return 1.0 + f_ms * ((1.0 - e) / dr.maximum(e, 1e-6))

    # eval and pdf are the nested ones' (not the parts of eval_pdf): the nested BSDF may do less for each
    def eval(self, ctx, si, wo, active=True):
        return self.nested.eval(ctx, si, wo, active) * (self._masking(si, wo, active) * self._scale(si, active))

    def pdf(self, ctx, si, wo, active=True):
        return self.nested.pdf(ctx, si, wo, active)

    def eval_pdf(self, ctx, si, wo, active=True):
        value, pdf = self.nested.eval_pdf(ctx, si, wo, active)
        return value * (self._masking(si, wo, active) * self._scale(si, active)), pdf

    def sample(self, ctx, si, sample1, sample2, active=True):
        bs, weight = self.nested.sample(ctx, si, sample1, sample2, active)
        return bs, weight * (self._masking(si, bs.wo, active) * self._scale(si, active))

    def _fields(self):
        return [("roughness", self.roughness), ("ior", self.ior), ("compensate", self.compensate)]
