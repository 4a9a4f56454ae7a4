"""The reference's own texture plugins: what glTF asks of a surface that Mitsuba's textures do not give.

* ``compare_product``: one texture times another. glTF's vertex colours multiply the base colour (and the
  alpha) by the mesh's ``COLOR_0`` (read as Mitsuba's ``mesh_attribute`` ``vertex_color`` or
  ``vertex_alpha``); a single-sided surface's opacity is its alpha times its front side.
* ``compare_front_side``: 1 where a ray meets the surface from the side its geometric normal faces, 0 behind
  it: the opacity of glTF's back-face culling (``doubleSided: false``) under Mitsuba's ``mask``.

Mitsuba has neither (a product of two textures, a texture of the side a ray comes from). The classes are
``Product`` and ``FrontSide`` of :mod:`compare.mitsuba.plugins.textures`.
"""

from __future__ import annotations

__all__ = ["ATTRIBUTE_ALPHA", "ATTRIBUTE_RGB", "front_side", "product", "register", "tinted"]

#: The plugins' names in scene dictionaries.
PRODUCT, FRONT_SIDE = "compare_product", "compare_front_side"
#: The mesh attributes the reference's meshes carry for COLOR_0 (Mitsuba's names start with "vertex_").
ATTRIBUTE_RGB, ATTRIBUTE_ALPHA = "vertex_color", "vertex_alpha"


def register(variant: str | None = None):
    """Register both textures with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import load_active_mitsuba  # noqa: PLC0415 - Mitsuba is loaded lazily

    load_active_mitsuba(variant)  # first: the classes subclass the classes of the variant set
    from compare.mitsuba.plugins import register_plugin, textures as classes  # noqa: PLC0415

    register_plugin(PRODUCT, classes, "Product", kind="texture")
    return register_plugin(FRONT_SIDE, classes, "FrontSide", kind="texture")


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
