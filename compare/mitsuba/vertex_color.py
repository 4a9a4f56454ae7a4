"""glTF's vertex colours in the reference: a texture that multiplies a material's base colour (a map or a
factor) by the mesh's ``COLOR_0``, read as Mitsuba's ``mesh_attribute`` ``vertex_color`` (RGB) or
``vertex_alpha`` (one channel). glTF: "the base color ... multiplied by the vertex color" (and the alpha
by its alpha). Mitsuba has no product of two textures; this plugin is that product and nothing else.
"""

from __future__ import annotations

__all__ = ["ATTRIBUTE_ALPHA", "ATTRIBUTE_RGB", "PLUGIN_NAME", "register", "tinted"]

#: The plugin's name in scene dictionaries.
PLUGIN_NAME = "compare_vertex_tinted"
#: The mesh attributes the reference's meshes carry for COLOR_0 (Mitsuba's names start with "vertex_").
ATTRIBUTE_RGB, ATTRIBUTE_ALPHA = "vertex_color", "vertex_alpha"

_CLASSES: dict[str, type] = {}


def register(variant: str | None = None):
    """Register the texture with the active (or given) variant; returns the ``mitsuba`` module."""
    from compare.mitsuba.backend import register_bsdf_plugin  # noqa: PLC0415 - Mitsuba is loaded lazily

    return register_bsdf_plugin(PLUGIN_NAME, _make_class, _CLASSES, variant, kind="texture")


def tinted(texture: dict | float, *, alpha: bool = False) -> dict:
    """``texture`` (a texture dictionary or a constant) times the mesh's vertex colour (or its alpha)."""
    register()
    inner = texture if isinstance(texture, dict) else {"type": "rgb", "value": [float(texture)] * 3}
    return {"type": PLUGIN_NAME, "texture": inner,
            "attribute": {"type": "mesh_attribute", "name": ATTRIBUTE_ALPHA if alpha else ATTRIBUTE_RGB}}


def _make_class(mv, mitsuba):
    class VertexTinted(mv.Texture):
        """``texture`` × ``attribute`` at every surface point."""

        def __init__(self, props):
            mv.Texture.__init__(self, props)
            self.texture = props.get_texture("texture")
            self.attribute = props.get_texture("attribute")

        def eval(self, si, active=True):
            return self.texture.eval(si, active) * self.attribute.eval(si, active)

        def eval_1(self, si, active=True):
            return self.texture.eval_1(si, active) * self.attribute.eval_1(si, active)

        def eval_3(self, si, active=True):
            return self.texture.eval_3(si, active) * self.attribute.eval_3(si, active)

        def mean(self):
            return self.texture.mean()  # an upper bound: the colours are in [0, 1]

        def max(self):
            return self.texture.max()

        def is_spatially_varying(self):
            return True

        def traverse(self, callback):
            callback.put("texture", self.texture, mitsuba.ParamFlags.NonDifferentiable)

        def to_string(self):
            return f"{PLUGIN_NAME}[{self.texture}]"

    return VertexTinted
