"""The classes of the reference's texture plugins ``compare_product``, ``compare_front_side`` and
``compare_uv`` (:mod:`compare.mitsuba.textures`). Bound to a variant: see :mod:`compare.mitsuba.plugins`.
"""

from __future__ import annotations

import drjit as dr
from mitsuba import ParamFlags

from compare.mitsuba.plugins import bound_variant

__all__ = ["FrontSide", "Product", "UvMapped"]

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


#: Wrap modes of :class:`UvMapped`'s axes (compare.scene.model.TEXTURE_WRAPS).
_WRAPS = {"repeat": 0, "clamp": 1, "mirror": 2}


def _wrapped(x, mode: int):
    if mode == 0:
        return x - dr.floor(x)
    if mode == 2:
        return 1.0 - dr.abs(x - 2.0 * dr.floor(0.5 * x) - 1.0)
    return dr.clip(x, 0.0, 1.0)


class UvMapped(mv.Texture):
    """``texture`` read at other texture coordinates: the mesh attribute ``attribute`` (glTF's TEXCOORD_1,
    (u, v, 0)) instead of the surface's uv, and, with ``wrap_u``/``wrap_v`` given, transformed by ``to_uv``
    and wrapped per axis before the lookup (glTF's wrapS and wrapT apart; Mitsuba's bitmap has one mode)."""

    def __init__(self, props):
        super().__init__(props)
        self._plugin = props.plugin_name()  # its registered name, for to_string
        self.texture = props.get_texture("texture")
        self.attribute = props.get("attribute", "")
        self.wrap = (_WRAPS[props.get("wrap_u")], _WRAPS[props.get("wrap_v")]) if "wrap_u" in props else None
        identity = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
        self.to_uv = tuple(tuple(float(props.get(f"to_uv_{i}{j}", identity[i][j])) for j in range(3))
                           for i in range(2))

    def _at(self, si):
        out = mv.SurfaceInteraction3f(si)
        if self.attribute:
            uvw = si.shape.eval_attribute_3(self.attribute, si)
            out.uv = mv.Point2f(uvw.x, uvw.y)
        if self.wrap is not None:
            (a, b, c), (d, e, f) = self.to_uv
            u, v = out.uv.x, out.uv.y
            out.uv = mv.Point2f(_wrapped(a * u + b * v + c, self.wrap[0]), _wrapped(d * u + e * v + f, self.wrap[1]))
        return out

    def eval(self, si, active=True):
        return self.texture.eval(self._at(si), active)

    def eval_1(self, si, active=True):
        return self.texture.eval_1(self._at(si), active)

    def eval_3(self, si, active=True):
        return self.texture.eval_3(self._at(si), active)

    def mean(self):
        return self.texture.mean()

    def max(self):
        return self.texture.max()

    def is_spatially_varying(self):
        return True

    def traverse(self, callback):
        callback.put("texture", self.texture, ParamFlags.NonDifferentiable)

    def to_string(self):
        return f"{self._plugin}[{self.attribute or 'uv'}, {self.texture}]"
