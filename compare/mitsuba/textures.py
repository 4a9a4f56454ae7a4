"""The reference's own texture plugins: what glTF asks of a surface that Mitsuba's textures do not give.

* ``compare_product``: one texture times another. glTF's vertex colours multiply the base colour (and the
  alpha) by the mesh's ``COLOR_0`` (read as Mitsuba's ``mesh_attribute`` ``vertex_color`` or
  ``vertex_alpha``); a single-sided surface's opacity is its alpha times its front side.
* ``compare_front_side``: 1 where a ray meets the surface from the side its geometric normal faces, 0 behind
  it: the opacity of glTF's back-face culling (``doubleSided: false``) under Mitsuba's ``mask``.

Mitsuba has neither (a product of two textures, a texture of the side a ray comes from).
"""

from __future__ import annotations

__all__ = ["ATTRIBUTE_ALPHA", "ATTRIBUTE_RGB", "front_side", "product", "register", "tinted"]

#: The plugins' names in scene dictionaries.
PRODUCT, FRONT_SIDE = "compare_product", "compare_front_side"
#: The mesh attributes the reference's meshes carry for COLOR_0 (Mitsuba's names start with "vertex_").
ATTRIBUTE_RGB, ATTRIBUTE_ALPHA = "vertex_color", "vertex_alpha"

_PRODUCTS: dict[str, type] = {}
_FRONTS: dict[str, type] = {}


def register(variant: str | None = None):
    """Register both textures with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import register_bsdf_plugin  # noqa: PLC0415 - Mitsuba is loaded lazily

    register_bsdf_plugin(PRODUCT, _make_product, _PRODUCTS, variant, kind="texture")
    return register_bsdf_plugin(FRONT_SIDE, _make_front_side, _FRONTS, variant, kind="texture")


def _texture(value: dict | float) -> dict:
    return value if isinstance(value, dict) else {"type": "rgb", "value": [float(value)] * 3}


def product(a: dict | float, b: dict | float) -> dict:
    """The texture ``a`` × ``b`` (texture dictionaries or constants)."""
    register()
    return {"type": PRODUCT, "a": _texture(a), "b": _texture(b)}


def tinted(texture: dict | float, *, alpha: bool = False) -> dict:
    """``texture`` times the mesh's vertex colour (or its alpha)."""
    return product(texture, {"type": "mesh_attribute", "name": ATTRIBUTE_ALPHA if alpha else ATTRIBUTE_RGB})


def front_side() -> dict:
    """The texture that is 1 on a surface's front side and 0 behind it."""
    register()
    return {"type": FRONT_SIDE}


def _make_product(mv, mitsuba):
    class Product(mv.Texture):
        """``a`` × ``b`` at every surface point."""

        def __init__(self, props):
            mv.Texture.__init__(self, props)
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
            flags = mitsuba.ParamFlags.NonDifferentiable
            callback.put("a", self.a, flags)
            callback.put("b", self.b, flags)

        def to_string(self):
            return f"{PRODUCT}[{self.a} × {self.b}]"

    return Product


def _make_front_side(mv, mitsuba):
    import drjit as dr  # noqa: PLC0415

    class FrontSide(mv.Texture):
        """1 where the ray comes from the side of the geometric normal, else 0."""

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
            return FRONT_SIDE

    return FrontSide
