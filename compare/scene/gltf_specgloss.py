"""``KHR_materials_pbrSpecularGlossiness`` as the scene model's metallic-roughness material.

The reader (:mod:`compare.scene.gltf_read`) converts such a material as glTF-Transform's
``metalRough()`` does, which represents it exactly up to the Fresnel of a finite ior:

* base colour and alpha = ``diffuseFactor``; base-colour map = ``diffuseTexture``;
* metallic 0;
* roughness = 1 − ``glossinessFactor`` (the spec-gloss α = (1 − glossiness)² is the metal-rough
  α = roughness²); with a ``specularGlossinessTexture``, roughness 1 and a roughness map
  1 − ``glossinessFactor`` × the map's alpha (linear), baked into a metallic-roughness EXR
  (:func:`compare.scene.textures.glossiness_roughness_map`);
* ``KHR_materials_specular``: ``specular`` 1, ``specular_color`` = ``specularFactor``, and the map's
  RGB (sRGB) as its ``specularColorTexture``;
* ``KHR_materials_ior``: ior 1000, so that the dielectric F0, ((ior − 1)/(ior + 1))² × specular
  colour, is 0.996 × the file's specular colour.

``pbrMetallicRoughness``, the fallback for readers without the extension, is not read.
"""

from __future__ import annotations

import math

from compare.scene.textures import glossiness_roughness_map, texture_problem

__all__ = ["EXTENSION", "IOR", "factors", "terms"]

EXTENSION = "KHR_materials_pbrSpecularGlossiness"
#: glTF-Transform's ior of a converted material: a Fresnel F0 of 0.996 × the specular colour.
IOR = 1000.0
#: The scene model's fields that the conversion sets (its KHR_materials_specular and KHR_materials_ior).
SETS = ("ior", "specular", "specular_color")


def _unit_numbers(table: dict, key: str, count: int, default, where: str, err) -> list[float]:
    v = table.get(key, default)
    ok = (isinstance(v, list) and len(v) == count
          and all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and 0 <= x <= 1
                  for x in v))
    if not ok:
        raise err(f"{where}.{key}", f"expected {count} numbers in [0, 1], got {v!r}")
    return [float(x) for x in v]


def factors(table, where: str, err) -> tuple[list[float], list[float], float]:
    """The extension's (diffuseFactor RGBA, specularFactor RGB, glossinessFactor), glTF's defaults where
    absent, each checked (one error naming the field through ``err(field, message)``)."""
    if not isinstance(table, dict):
        raise err(where, f"expected an object, got {table!r}")
    diffuse = _unit_numbers(table, "diffuseFactor", 4, [1.0, 1.0, 1.0, 1.0], where, err)
    specular = _unit_numbers(table, "specularFactor", 3, [1.0, 1.0, 1.0], where, err)
    g = table.get("glossinessFactor", 1.0)
    if isinstance(g, bool) or not isinstance(g, (int, float)) or not 0 <= g <= 1:
        raise err(f"{where}.glossinessFactor", f"expected a number in [0, 1], got {g!r}")
    return diffuse, specular, float(g)


def terms(r, sg: dict, where: str, image, specular: list[float], glossiness: float):
    """A spec-gloss material's metallic-roughness terms: (its base-colour and metallic-roughness map indices,
    roughness, the KHR_materials_specular and _ior fields, their map). ``r`` is the reader (its doc, images,
    err), ``sg`` the extension's table at ``where``, ``image(key, table, ext)`` the reader's texture info of
    the material (transform, sampler and source index), the factors :func:`factors`'s."""
    ext = EXTENSION
    maps = dict(base_color_image=image("diffuseTexture", sg, ext), metallic_roughness_image=None)
    layers = {"ior": IOR, "specular": 1.0, "specular_color": tuple(specular)}
    src = image("specularGlossinessTexture", sg, ext)
    count = len(r.doc.get("images", []))
    path = r.images[src] if isinstance(src, int) and not isinstance(src, bool) and 0 <= src < count else None
    if path is None:  # no map (or an unusable one, with its note): the factors
        return maps, 1.0 - glossiness, layers, []
    problem = texture_problem(path)
    if problem:
        raise r.err(f"{where}.specularGlossinessTexture", f"image {src}: {problem}")
    derived = glossiness_roughness_map(path, glossiness)
    if derived not in r.images[count:]:
        r.images.append(derived)
    maps["metallic_roughness_image"] = count + r.images[count:].index(derived)
    # the map's RGB is the specular colour (sRGB, the "rgb" channel of a layer map); its alpha the glossiness
    return maps, 1.0, layers, [("specular_color", "rgb", src)]
