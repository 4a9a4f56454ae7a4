"""glTF's thin-film iridescence (``KHR_materials_iridescence``): the film's Fresnel (compare.brdf.iridescence) in
its limits, the reference's ``gltf_pbr`` against the glTF BRDF with that Fresnel mixed in (NumPy), and the
file's fields read and written."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.brdf.iridescence import NUMPY, iridescence_fresnel
from tests.helpers import material_round_trip


def _schlick(f0, c):
    return f0 + (1.0 - f0) * (1.0 - c) ** 5


def test_a_film_of_the_outsides_index_is_the_base_alone():
    """A film of index 1 in air has no first interface: at normal incidence what is left is the base's own
    reflectance (up to the extension's clamp of R12·R23 at 1e-5, which leaves interference terms of √1e-5 in
    amplitude; off normal incidence its Schlick approximation gives even a matched interface (1 − cos)^5 of
    reflection, and the film interferes with that)."""
    c = np.array([1.0, 0.995])
    for f0 in (0.04, 0.5, 0.9):
        film = np.array(iridescence_fresnel(NUMPY, c, 400.0, 1.0, [f0] * 3))
        np.testing.assert_allclose(film, np.broadcast_to(_schlick(f0, c), film.shape), atol=0.01)


def test_a_film_colours_what_a_bare_dielectric_leaves_white():
    """At normal incidence a 400 nm film of index 1.3 over glass reflects the channels unequally (interference),
    where glass alone reflects 0.04 in each."""
    film = np.array(iridescence_fresnel(NUMPY, np.array([1.0]), 400.0, 1.3, [0.04] * 3))[:, 0]
    assert film.max() - film.min() > 0.01 and np.all(film >= 0.0)


def _gltf_value(wi, wo, base, metallic, roughness, k, film_ior, thickness):
    """f · cos_o of the glTF BRDF with the film's Fresnel mixed in by ``k`` (the module's composition)."""
    alpha = roughness * roughness
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    nh, ni, no = h[:, 2], wi[:, 2], wo[:, 2]
    d = alpha ** 2 / (math.pi * (nh * nh * (alpha ** 2 - 1.0) + 1.0) ** 2)
    a2 = alpha * alpha
    vis = 0.5 / (no * np.sqrt(ni * ni * (1 - a2) + a2) + ni * np.sqrt(no * no * (1 - a2) + a2))
    x = np.clip(np.sum(wi * h, axis=-1), 0.0, 1.0)
    base = np.asarray(base)
    metal = _schlick(base[None], x[:, None])
    metal = metal + (np.array(iridescence_fresnel(NUMPY, x, thickness, film_ior, list(base))).T - metal) * k
    diel = _schlick(0.04, x)[:, None] * np.ones(3)
    diel = diel + (np.array(iridescence_fresnel(NUMPY, x, thickness, film_ior, [0.04] * 3)).T - diel) * k
    spec = metallic * metal + (1.0 - metallic) * diel
    diffuse = (1.0 - metallic) * (1.0 - diel.max(axis=1))[:, None] * base / math.pi
    return (spec * (d * vis)[:, None] + diffuse) * no[:, None]


# (not a film of the dielectric's own index 1.5: there the model's phase at the base flips between 0 and π on the
# last bit of float32 against float64, a tie the extension's text leaves open)
@pytest.mark.parametrize(("metallic", "k", "film_ior", "thickness"), [(0.0, 1.0, 1.3, 400.0), (1.0, 0.7, 1.8, 250.0),
                                                                      (0.4, 0.5, 1.6, 600.0)])
def test_the_reference_mixes_the_films_fresnel_into_each_lobe(mi_llvm, metallic, k, film_ior, thickness):
    mi = mi_llvm
    import drjit as dr

    rng = np.random.default_rng(5)
    n = 256
    wi, wo = (v / np.linalg.norm(v, axis=1, keepdims=True)
              for v in (rng.normal(size=(n, 3)) * [1, 1, 0] + [0, 0, 1.2], rng.normal(size=(n, 3)) * [1, 1, 0] + [0, 0, 1.1]))
    base, roughness = (0.8, 0.5, 0.2), 0.5
    bsdf = mi.load_dict({"type": "gltf_pbr", "base_color": {"type": "rgb", "value": list(base)},
                         "metallic": metallic, "roughness": roughness, "iridescence": k,
                         "iridescence_ior": film_ior, "iridescence_thickness": thickness})
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.wi = mi.Vector3f(*wi.T.astype(np.float32))
    value = np.array(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*wo.T.astype(np.float32)))).T
    expected = _gltf_value(wi, wo, base, metallic, roughness, k, film_ior, thickness)
    np.testing.assert_allclose(value, expected, rtol=5e-3, atol=1e-5)
    plain = _gltf_value(wi, wo, base, metallic, roughness, 0.0, film_ior, thickness)
    assert np.abs(plain - expected).max() > 10 * np.abs(value - expected).max()  # the film does show


def test_the_files_iridescence_is_read_and_written(make_scene):
    scene, again = material_round_trip(make_scene, "soap", base_color=[0.1, 0.1, 0.1], roughness=0.2, iridescence=1.0,
                                       iridescence_ior=1.33, iridescence_thickness_max=550.0)
    assert scene.features().iridescence
    assert again.layers == {"iridescence": 1.0, "iridescence_ior": 1.33, "iridescence_thickness_max": 550.0}


def test_the_films_maps_set_its_factor_and_thickness_per_point(mi_llvm):
    """``iridescenceTexture`` (R) times the factor, and ``iridescenceThicknessTexture`` (G) as
    mix(minimum, maximum, G), per point, as the NumPy BRDF with those values per row; a point of thickness 0
    has no film at all."""
    from compare.mitsuba.bsdf import evaluate

    rng = np.random.default_rng(11)
    n = 128
    wi, wo = (v / np.linalg.norm(v, axis=1, keepdims=True)
              for v in (rng.normal(size=(n, 3)) * [1, 1, 0] + [0, 0, 1.2], rng.normal(size=(n, 3)) * [1, 1, 0] + [0, 0, 1.1]))
    base, metallic, roughness, film_ior, factor, lo, hi = (0.8, 0.5, 0.2), 0.3, 0.5, 1.4, 0.9, 0.0, 800.0
    r, g = rng.uniform(0.0, 1.0, n), rng.uniform(0.0, 1.0, n)
    g[:8] = 0.0  # the minimum, 0 nm
    value, _ = evaluate(wi, wo, base, metallic, roughness,
                        extra={"iridescence": factor * r, "iridescence_ior": film_ior, "iridescence_thickness": hi,
                               "iridescence_thickness_min": lo, "iridescence_thickness_map": g})
    thickness = lo + (hi - lo) * g
    expected = _gltf_value(wi, wo, base, metallic, roughness, (factor * r)[:, None], film_ior, thickness)
    expected[:8] = _gltf_value(wi[:8], wo[:8], base, metallic, roughness, 0.0, film_ior, 400.0)
    np.testing.assert_allclose(value, expected, rtol=5e-3, atol=1e-5)
    # able to fail: the film at its maximum everywhere differs by far more
    flat = _gltf_value(wi, wo, base, metallic, roughness, factor, film_ior, hi)
    assert np.abs(flat - expected).max() > 10 * np.abs(value - expected).max()


def test_the_films_maps_are_read_and_written(tmp_path, make_scene):
    """The file's iridescence maps are read into the material's layer maps, make the feature "layer_maps", and
    go back into the job's glTF under the extension's keys."""
    import dataclasses
    import json

    from compare.renderers.job import export_gltf
    from compare.scene.gltf_read import load_gltf
    from compare.mitsuba.scene_dict import _surface_dict
    from tests.helpers import sphere_scene

    Image = pytest.importorskip("PIL.Image")
    Image.new("RGB", (4, 4), (200, 100, 0)).save(tmp_path / "film.png")
    scene = sphere_scene(make_scene, "roughness = 0.3\niridescence = 1.0\niridescence_thickness_min = 50.0")
    (name, mat), = scene.materials.items()
    mat = dataclasses.replace(mat, layer_maps=(("iridescence", "r", tmp_path / "film.png"),
                                               ("iridescence_thickness_max", "g", tmp_path / "film.png")))
    assert mat.uses() == {"iridescence", "layer_maps"}
    d = _surface_dict(mat, "shared")
    assert d["iridescence"]["type"] == "bitmap" and d["iridescence_thickness_min"] == 50.0
    assert "iridescence_thickness_map" in d
    (tmp_path / "job").mkdir()
    written = export_gltf(dataclasses.replace(scene, materials={name: mat}), tmp_path / "job" / "scene.gltf")
    film = json.loads(written.read_text())["materials"][0]["extensions"]["KHR_materials_iridescence"]
    assert {"iridescenceTexture", "iridescenceThicknessTexture"} <= set(film)
    back = load_gltf(written).materials[0]
    assert sorted((f, c) for f, c, _ in back.layer_images) == [("iridescence", "r"), ("iridescence_thickness_max", "g")]
