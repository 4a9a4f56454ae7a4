"""The classes of the reference's texture plugins ``compare_product`` and ``compare_front_side``
(:mod:`compare.mitsuba.textures`). Bound to a variant: see :mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import drjit as dr
from mitsuba import ParamFlags

from compare.mitsuba.plugins import bound_variant

__all__ = ["FrontSide", "Product"]

mv = bound_variant(__name__)


class Product(mv.Texture):
    """``a`` × ``b`` at every surface point."""

    def __init__(self, props):
        super().__init__(props)
        self._plugin = props.plugin_name()  # its registered name, for to_string
        self.a = props.get_texture("a")
        self.b = props.get_texture("b")

    def eval(self, si, active=True):
        return self.a.eval(si, active) * self.b.eval(si, active)

    def eval_1(self, si, active=True):
        return self.a.eval_1(si, active) * self.b.eval_1(si, active)

    def eval_3(self, si, active=True):
        return self.a.eval_3(si, active) * self.b.eval_3(si, active)

    def mean(self):
        return self.a.mean() * self.b.mean()  # exact for a constant factor, else an estimate

    def max(self):
        return self.a.max() * self.b.max()

    def is_spatially_varying(self):
        return True

    def traverse(self, callback):
        flags = ParamFlags.NonDifferentiable
        callback.put("a", self.a, flags)
        callback.put("b", self.b, flags)

    def to_string(self):
        return f"{self._plugin}[{self.a} × {self.b}]"


class FrontSide(mv.Texture):
    """1 where the ray comes from the side of the geometric normal, else 0."""

    def __init__(self, props):
        super().__init__(props)
        self._plugin = props.plugin_name()  # its registered name, for to_string

    def _front(self, si):
        return dr.select(dr.dot(si.n, si.to_world(si.wi)) > 0.0, 1.0, 0.0)

    def eval(self, si, active=True):
        return mv.Color3f(self._front(si))

    def eval_1(self, si, active=True):
        return mv.Float(self._front(si))

    def eval_3(self, si, active=True):
        return mv.Color3f(self._front(si))

    def mean(self):
        return 0.5

    def max(self):
        return 1.0

    def is_spatially_varying(self):
        return True

    def to_string(self):
        return self._plugin
