"""glTF's anisotropy (``KHR_materials_anisotropy``) in the reference's ``gltf_pbr``: its value against an
independent NumPy transcription of the extension's BRDF (anisotropic GGX D and height-correlated V with
α_t = mix(α, 1, s²), α_b = α along the tangent turned by the rotation), its sampling against its pdf (Mitsuba's
chi-square harness), and the file's fields read into the scene model and written back."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers import material_round_trip

BASE = (0.9, 0.6, 0.3)


def _gltf_value(wi, wo, roughness, strength, rotation):
    """f · cos_o of a metal of colour BASE, from the extension's text (directions in the tangent frame)."""
    alpha = roughness * roughness
    at, ab = alpha + (1.0 - alpha) * strength * strength, alpha
    t = np.array([math.cos(rotation), math.sin(rotation), 0.0])
    b = np.array([-math.sin(rotation), math.cos(rotation), 0.0])
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    th, bh, nh = h @ t, h @ b, h[..., 2]
    a2 = at * ab
    v = np.stack([ab * th, at * bh, a2 * nh], axis=-1)  # the extension's D_GGX_anisotropic
    w2 = a2 / np.sum(v * v, axis=-1)
    d = a2 * w2 * w2 / math.pi
    ti, bi, ni = wi @ t, wi @ b, wi[..., 2]
    to, bo, no = wo @ t, wo @ b, wo[..., 2]
    vis = 0.5 / (no * np.sqrt((at * ti) ** 2 + (ab * bi) ** 2 + ni ** 2)
                 + ni * np.sqrt((at * to) ** 2 + (ab * bo) ** 2 + no ** 2))
    vh = np.clip(np.sum(wi * h, axis=-1), 0.0, 1.0)
    f = np.asarray(BASE) + (1.0 - np.asarray(BASE)) * ((1.0 - vh) ** 5)[..., None]
    return f * (d * vis * no)[..., None]


def _bsdf(mi, roughness, strength, rotation):
    return mi.load_dict({"type": "gltf_pbr", "base_color": {"type": "rgb", "value": list(BASE)}, "metallic": 1.0,
                         "roughness": roughness, "anisotropy_strength": strength, "anisotropy_rotation": rotation})


def _directions(n, seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize(("roughness", "strength", "rotation"), [(0.5, 0.8, 0.7), (0.3, 1.0, -2.0), (0.8, 0.4, 0.0)])
def test_the_value_is_the_extensions_brdf(mi_llvm, roughness, strength, rotation):
    mi = mi_llvm
    import drjit as dr

    n = 512
    wi, wo = _directions(n, 1), _directions(n, 2)
    bsdf = _bsdf(mi, roughness, strength, rotation)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    si.wi = mi.Vector3f(*wi.T.astype(np.float32))
    value = np.array(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*wo.T.astype(np.float32)))).T
    expected = _gltf_value(wi, wo, roughness, strength, rotation)
    np.testing.assert_allclose(value, expected, rtol=2e-3, atol=1e-6)
    # able to fail: the isotropic lobe (or another direction) differs by far more than that
    other = _gltf_value(wi, wo, roughness, strength, rotation + math.pi / 2)
    assert np.abs(other - expected).max() > 100 * np.abs(value - expected).max()


@pytest.mark.parametrize(("roughness", "cos_i"), [(1.0, 0.5), (0.6, 0.9)])
def test_sampling_matches_the_pdf(mi_llvm, roughness, cos_i):
    """Mitsuba's chi-square harness on Mitsuba's spherical domain (a lobe this rough is resolved), the view
    off the anisotropy direction's plane."""
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    s = math.sqrt(1.0 - cos_i * cos_i)
    wi = [s * math.cos(0.4), s * math.sin(0.4), cos_i]
    spec = {"type": "gltf_pbr", "base_color": {"type": "rgb", "value": list(BASE)}, "metallic": 0.5,
            "roughness": roughness, "anisotropy_strength": 0.9, "anisotropy_rotation": 1.1}
    sample_func, pdf_func = BSDFAdapter("gltf_pbr", spec, wi=wi)
    test = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func, sample_dim=3,
                         sample_count=1_000_000, res=101, ires=16, seed=0)
    assert test.run(significance_level=0.01, test_count=2, quiet=True), test.messages


def test_the_files_anisotropy_is_read_and_written(make_scene):
    scene, again = material_round_trip(make_scene, "brushed", base_color=[0.9, 0.9, 0.9], metallic=1.0, roughness=0.4,
                                       anisotropy_strength=0.6, anisotropy_rotation=0.5)
    assert scene.features().anisotropy and scene.materials["brushed"].normal_mapped  # its frame is glTF's
    assert again.layers == {"anisotropy_strength": 0.6, "anisotropy_rotation": 0.5}


def test_the_anisotropy_map_turns_and_scales_the_lobe_per_point(mi_llvm):
    """``anisotropyTexture``: RG the direction in the tangent frame ([0, 1] → [−1, 1], normalised, then turned
    by the rotation), B times the strength, per point, as the extension's BRDF with that direction and strength
    per row; a zero direction is the tangent's (turned by the rotation)."""
    from compare.mitsuba.bsdf import evaluate

    rng = np.random.default_rng(3)
    n = 96
    wi, wo = _directions(n, 4), _directions(n, 5)
    roughness, strength, rotation = 0.5, 0.8, 0.4
    phi, length, b = rng.uniform(-math.pi, math.pi, n), rng.uniform(0.3, 1.0, n), rng.uniform(0.2, 1.0, n)
    encoded = np.stack([(length * np.cos(phi) + 1.0) / 2, (length * np.sin(phi) + 1.0) / 2, b], axis=1)
    encoded[:4, :2], phi[:4] = 0.5, 0.0
    value, _ = evaluate(wi, wo, BASE, 1.0, roughness,
                        extra={"anisotropy_strength": strength, "anisotropy_rotation": rotation,
                               "anisotropy_map": encoded})
    expected = np.concatenate([_gltf_value(wi[i:i + 1], wo[i:i + 1], roughness, strength * b[i], rotation + phi[i])
                               for i in range(n)])
    np.testing.assert_allclose(value, expected, rtol=2e-3, atol=1e-6)
    other = _gltf_value(wi, wo, roughness, strength, rotation)  # the factors alone
    assert np.abs(other - expected).max() > 100 * np.abs(value - expected).max()


def test_the_anisotropy_map_is_read_and_written(tmp_path, make_scene):
    import dataclasses
    import json

    from compare.renderers.job import export_gltf
    from compare.scene.gltf_read import load_gltf
    from tests.helpers import sphere_scene

    Image = pytest.importorskip("PIL.Image")
    Image.new("RGB", (4, 4), (255, 128, 200)).save(tmp_path / "brush.png")
    scene = sphere_scene(make_scene, "metallic = 1.0\nroughness = 0.4\nanisotropy_strength = 0.7")
    (name, mat), = scene.materials.items()
    mat = dataclasses.replace(mat, layer_maps=(("anisotropy_strength", "xyz", tmp_path / "brush.png"),))
    assert mat.uses() == {"anisotropy", "layer_maps"}
    (tmp_path / "job").mkdir()
    written = export_gltf(dataclasses.replace(scene, materials={name: mat}), tmp_path / "job" / "scene.gltf")
    doc = json.loads(written.read_text())
    info = doc["materials"][0]["extensions"]["KHR_materials_anisotropy"]["anisotropyTexture"]
    assert doc["images"][doc["textures"][info["index"]]["source"]]["uri"].endswith(".png")
    back = load_gltf(written).materials[0]
    assert [(f, c) for f, c, _ in back.layer_images] == [("anisotropy_strength", "xyz")]
