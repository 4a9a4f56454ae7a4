"""The reference's own texture plugins: what glTF asks of a surface that Mitsuba's textures do not give.

* ``compare_product``: one texture times another. glTF's vertex colours multiply the base colour (and the
  alpha) by the mesh's ``COLOR_0`` (read as Mitsuba's ``mesh_attribute`` ``vertex_color`` or
  ``vertex_alpha``); a single-sided surface's opacity is its alpha times its front side.
* ``compare_uv``: a texture read at glTF's TEXCOORD_1 (the mesh attribute ``vertex_uv1``) and/or with
  wrapS and wrapT apart (Mitsuba's bitmap reads the surface's one uv set and wraps both axes alike).
* ``compare_front_side``: 1 where a ray meets the surface from the side its geometric normal faces, 0 behind
  it: the opacity of glTF's back-face culling (``doubleSided: false``) under Mitsuba's ``mask``.

Mitsuba has none of them (a product of two textures, a second uv set, a wrap per axis, a texture of the
side a ray comes from). The classes are ``Product``, ``UvMapped`` and ``FrontSide`` of
:mod:`compare.mitsuba.plugins.textures`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["ATTRIBUTE_ALPHA", "ATTRIBUTE_RGB", "ATTRIBUTE_UV1", "front_side", "product", "register", "tinted",
           "uv_mapped"]

#: The plugins' names in scene dictionaries.
PRODUCT, FRONT_SIDE, UV_MAPPED = "compare_product", "compare_front_side", "compare_uv"
#: The mesh attribute of glTF's TEXCOORD_1, (u, v, 0): Mitsuba's mesh attributes have 1 or 3 channels.
ATTRIBUTE_UV1 = "vertex_uv1"
#: The mesh attributes the reference's meshes carry for COLOR_0 (Mitsuba's names start with "vertex_").
ATTRIBUTE_RGB, ATTRIBUTE_ALPHA = "vertex_color", "vertex_alpha"


def register(variant: str | None = None):
    """Register both textures with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import load_active_mitsuba  # noqa: PLC0415 - Mitsuba is loaded lazily

    load_active_mitsuba(variant)  # first: the classes subclass the classes of the variant set
    from compare.mitsuba.plugins import register_plugin, textures as classes  # noqa: PLC0415

    register_plugin(PRODUCT, classes, "Product", kind="texture")
    register_plugin(UV_MAPPED, classes, "UvMapped", kind="texture")
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


def uv_mapped(bitmap: dict, texcoord: int, wrap: tuple[str, str]) -> dict:
    """``bitmap`` (a Mitsuba ``bitmap`` dictionary) read on texture coordinate set ``texcoord`` with wrap
    modes ``wrap`` (s, t); the bitmap itself where Mitsuba's own lookup does that (set 0, one mode)."""
    if texcoord == 0 and wrap[0] == wrap[1]:
        return bitmap
    register()
    out = {"type": UV_MAPPED, "texture": bitmap}
    if texcoord:
        out["attribute"] = ATTRIBUTE_UV1
    if wrap[0] != wrap[1]:
        # the transform and the per-axis wrap here; the bitmap then reads [0, 1]² as it is, clamped at its
        # edges (a repeating axis's seam is not blended across: half a texel at the seam)
        if "to_uv" in bitmap:  # its two rows as numbers (a transform property reads back as a 4 × 4 one)
            rows = np.asarray(bitmap["to_uv"].matrix, dtype=np.float64)[:2]
            out.update({f"to_uv_{i}{j}": float(rows[i, j]) for i in range(2) for j in range(3)})
        plain = {k: v for k, v in bitmap.items() if k != "to_uv"}
        out.update(texture={**plain, "wrap_mode": "clamp"}, wrap_u=wrap[0], wrap_v=wrap[1])
    return out
