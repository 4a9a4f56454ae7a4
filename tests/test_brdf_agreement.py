"""The three forms of the shared BRDF agree: numpy (float64) vs Mitsuba plugin vs GLSL.

Inputs are rounded to float32 once and the numpy reference is evaluated on the
rounded values, so the differences measured are those of float32 arithmetic.

Tolerances (per sample, per channel): |got - ref| <= rtol |ref| + floor, with

* ``floor = 1e-6 * scale`` where ``scale = D V + 1/pi`` is the same geometry's
  BRDF with unit Fresnel and a white base. Fresnel and colour factors near 0
  (base colour 0 with metallic 1, where F = (1 - v.h)^5) are differences of
  float32 numbers of order 1, so their error is absolute, ~1e-7 of that
  unit-Fresnel value; the floor allows 10x that and nothing more.
* plugin: ``rtol = 1e-5`` (about 80 float32 ulp). The plugin works in the local
  frame, where |n x h|^2 = h.x^2 + h.y^2 and n.v = v.z are exact, so even the
  GGX peak at alpha = ALPHA_MIN is this accurate.
* GLSL: ``rtol = 1e-5 + 5e-7 / alpha``. The rasterizer evaluates in world space;
  float32 rounding of n, h and dot products (~1.2e-7) moves |n x h| near the GGX
  peak, a relative error of about 5e-7 / alpha in D (2.5e-4 at ALPHA_MIN).
  Directions within 1e-5 of a horizon are left out of the world-space set: the
  sign of a cosine below float32 resolution is not defined by the inputs.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from compare import brdf

N_RANDOM = 4096
PLUGIN_RTOL = 1e-5
GL_RTOL = 1e-5
GL_RTOL_ALPHA = 5e-7
FLOOR = 1e-6

_worst: dict[str, float] = {}


def _f32(x):
    return np.asarray(x, dtype=np.float32).astype(np.float64)


def _unit(x):
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _materials(rng, n):
    """Random materials, with exact extremes mixed in (roughness/metallic 0 and 1, colour 0 and 1)."""
    c = rng.random((n, 3))
    m = rng.random(n)
    r = rng.random(n)
    k = n // 16
    r[:k] = 0.0
    r[k:2 * k] = 1.0
    m[2 * k:3 * k] = 0.0
    m[3 * k:4 * k] = 1.0
    c[4 * k:5 * k] = 0.0
    c[5 * k:6 * k] = 1.0
    c[6 * k:7 * k, 0] = 0.0
    m[6 * k:7 * k] = 1.0
    perm = rng.permutation(n)
    return c[perm], m[perm], r[perm]


def _local_directions(rng, n):
    """Random upper-hemisphere pairs, half uniform, half near the specular peak (VNDF-sampled)."""
    wi = _unit(rng.normal(size=(n, 3)))
    wi[:, 2] = np.abs(wi[:, 2])
    wo = _unit(rng.normal(size=(n, 3)))
    wo[:, 2] = np.abs(wo[:, 2])
    return wi, wo


def _peak_directions(rng, wi, roughness):
    alpha = brdf.alpha_from_roughness(roughness)
    h = brdf.sample_ggx_vndf(wi, alpha, rng.random((len(wi), 2)))
    wo = 2.0 * np.sum(wi * h, -1)[:, None] * h - wi
    wo[:, 2] = np.maximum(wo[:, 2], 1e-3)  # keep it above the horizon
    return _unit(wo)


def _case_set(seed):
    """(wi, wo, c, m, r) in float32-rounded float64: uniform pairs and near-peak pairs."""
    rng = np.random.default_rng(seed)
    c, m, r = _materials(rng, N_RANDOM)
    wi, wo = _local_directions(rng, N_RANDOM)
    half = N_RANDOM // 2
    wo[half:] = _peak_directions(rng, wi[half:], r[half:])
    return tuple(_f32(x) for x in (wi, wo, c, m, r))


def _scale(n, v, l, r, alpha_min=brdf.ALPHA_MIN):  # noqa: E741
    """D V + 1/pi: the BRDF of the same geometry with unit Fresnel and a white base."""
    unit_spec = brdf.eval_brdf(n, v, l, np.ones(3), 1.0, r, alpha_min=alpha_min)[..., 0]
    return unit_spec + 1.0 / np.pi


def _pdf_rtol(r):
    """The pdf's tolerance: 1e-5, or float32's precision near a narrow lobe's peak, about 1e-6 / α
    (compare.brdf's notes), where the reference keeps the file's roughness below the rasterizer's floor."""
    return np.maximum(1e-5, 1e-6 / brdf.alpha_from_roughness(r, brdf.REFERENCE_ALPHA_MIN))


def _check(name, got, ref, rtol, scale):
    """Assert |got - ref| <= rtol |ref| + FLOOR * scale; record the worst relative error among
    values >= 1e-3 * scale (not dominated by the floor) and the worst error / allowed."""
    assert np.all(np.isfinite(got)), f"{name}: non-finite values"
    floor = FLOOR * scale
    err = np.abs(got - ref)
    allowed = rtol * np.abs(ref) + floor
    rel = err / np.maximum(np.abs(ref), 1e-300)
    big = np.abs(ref) >= 1e-3 * scale
    _worst[name] = max(_worst.get(name, 0.0), float(rel[big].max()) if np.any(big) else 0.0)
    _worst[name + " (err/allowed)"] = max(_worst.get(name + " (err/allowed)", 0.0), float((err / allowed).max()))
    bad = err > allowed
    assert not np.any(bad), (
        f"{name}: {int(bad.sum())} values differ beyond tolerance; worst at "
        f"{np.unravel_index(np.argmax(err / allowed), err.shape)}: got {got[bad][0]}, ref {ref[bad][0]}")


@pytest.fixture(scope="module", autouse=True)
def _report():
    yield
    if _worst:
        print("\nLargest disagreements with numpy: relative error of values >= 1e-3 * (D V + 1/pi), "
              "and error / allowed:")
        for k, v in sorted(_worst.items()):
            print(f"  {k:45s} {v:.3e}")


# -- Mitsuba ---------------------------------------------------------------------------

# mi_llvm and mi_scalar (tests/conftest.py): the plugin registered with that variant, made active.


def _compare_plugin(mi, name, wi, wo, c, m, r):
    from compare.mitsuba.bsdf import evaluate

    value, pdf = evaluate(wi, wo, c, m, r, variant=mi.variant())
    got = value / wo[:, 2:]
    n = np.array([0.0, 0.0, 1.0])
    # the reference's plugin keeps what the file says, down to REFERENCE_ALPHA_MIN (no rasterizer floor)
    ref = brdf.eval_brdf(n, wi, wo, c, m, r, alpha_min=brdf.REFERENCE_ALPHA_MIN)
    _check(f"plugin {name} eval", got, ref, PLUGIN_RTOL, _scale(n, wi, wo, r, brdf.REFERENCE_ALPHA_MIN)[:, None])
    # the pdf: the documented lobe mixture (one-sample MIS)
    p = brdf.specular_sampling_probability(wi[:, 2], c, m)
    ref_pdf = (p * brdf.pdf_ggx_vndf_reflection(wi, wo, brdf.alpha_from_roughness(r, brdf.REFERENCE_ALPHA_MIN))
               + (1 - p) * wo[:, 2] / np.pi)
    _check(f"plugin {name} pdf", pdf, ref_pdf, _pdf_rtol(r), np.zeros_like(ref_pdf))


def test_plugin_matches_numpy_llvm(mi_llvm):
    """Vectorised: all rows in one eval_pdf call, per-row materials through bitmap textures."""
    _compare_plugin(mi_llvm, "llvm_ad_rgb", *_case_set(1))


def test_plugin_matches_numpy_scalar(mi_scalar):
    wi, wo, c, m, r = _case_set(2)
    sel = np.r_[0:150, N_RANDOM // 2:N_RANDOM // 2 + 150]  # scalar_rgb loops in Python
    _compare_plugin(mi_scalar, "scalar_rgb", wi[sel], wo[sel], c[sel], m[sel], r[sel])


def test_plugin_zero_below_horizon(mi_llvm):
    from compare.mitsuba.bsdf import evaluate

    rng = np.random.default_rng(3)
    wi, wo = _local_directions(rng, 256)
    wi[:128, 2] *= -1.0  # viewer below: one-sided, black
    wo[128:, 2] *= -1.0  # light below
    value, pdf = evaluate(wi, wo, np.full(3, 0.5), 0.5, 0.5, variant=mi_llvm.variant())
    assert np.all(value == 0.0) and np.all(pdf == 0.0)


def test_plugin_traverse_and_string(mi_llvm):
    mi = mi_llvm
    bsdf = mi.load_dict({"type": "gltf_pbr", "base_color": {"type": "rgb", "value": [0.2, 0.4, 0.6]},
                         "metallic": 0.25, "roughness": 0.5})
    params = mi.traverse(bsdf)
    assert {"base_color.value", "metallic.value", "roughness.value"} <= set(params.keys())
    assert "GltfPbrBSDF" in str(bsdf)
    # an update through traverse changes the evaluation
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(0.0, 0.0, 1.0)
    ctx = mi.BSDFContext()
    before = np.array(bsdf.eval(ctx, si, mi.Vector3f(0.6, 0.0, 0.8))).ravel()
    params["metallic.value"] = 1.0
    params.update()
    after = np.array(bsdf.eval(ctx, si, mi.Vector3f(0.6, 0.0, 0.8))).ravel()
    expect = brdf.eval_brdf([0, 0, 1.0], [0, 0, 1.0], [0.6, 0, 0.8], _f32([0.2, 0.4, 0.6]), 1.0, 0.5) * 0.8
    assert not np.allclose(before, after)
    np.testing.assert_allclose(after, expect, rtol=1e-5)


# -- the plugin's ``cycles`` flavour (Blender's Principled BSDF v2, compare.mitsuba.principled) --

def _compare_cycles_flavour(mi, name, wi, wo, c, m, r, distribution=None):
    from compare.mitsuba import principled
    from compare.mitsuba.bsdf import evaluate

    value, pdf = evaluate(wi, wo, c, m, r, variant=mi.variant(), flavour="cycles", distribution=distribution)
    dist = distribution or principled.DEFAULT_DISTRIBUTION
    n = np.array([0.0, 0.0, 1.0])
    ref = principled.eval_principled(n, wi, wo, c, m, r, dist)
    _check(f"cycles flavour {name} {dist} eval", value / wo[:, 2:], ref, PLUGIN_RTOL,
           _scale(n, wi, wo, r, brdf.REFERENCE_ALPHA_MIN)[:, None])
    p = principled.specular_sampling_probability(wi[:, 2], c, m, r, dist)
    ref_pdf = (p * brdf.pdf_ggx_vndf_reflection(wi, wo, brdf.alpha_from_roughness(r, brdf.REFERENCE_ALPHA_MIN))
               + (1 - p) * wo[:, 2] / np.pi)
    _check(f"cycles flavour {name} {dist} pdf", pdf, ref_pdf, _pdf_rtol(r), np.zeros_like(ref_pdf))


@pytest.mark.parametrize("distribution", [None, "multi_ggx", "ggx"])
def test_cycles_flavour_matches_numpy_llvm(mi_llvm, distribution):
    _compare_cycles_flavour(mi_llvm, "llvm_ad_rgb", *_case_set(4), distribution=distribution)


@pytest.mark.parametrize("distribution", ["multi_ggx", "ggx"])
def test_cycles_flavour_matches_numpy_scalar(mi_scalar, distribution):
    wi, wo, c, m, r = _case_set(5)
    sel = np.r_[0:150, N_RANDOM // 2:N_RANDOM // 2 + 150]
    _compare_cycles_flavour(mi_scalar, "scalar_rgb", wi[sel], wo[sel], c[sel], m[sel], r[sel], distribution)


def test_cycles_flavour_differs_from_gltf_only_where_documented():
    """GGX: same D V; exact dielectric Fresnel (not Schlick); the diffuse weight depends on n.v only."""
    from compare.mitsuba import principled

    rng = np.random.default_rng(6)
    wi, wo = _local_directions(rng, 512)
    n = np.array([0.0, 0.0, 1.0])
    c = np.array([0.7, 0.5, 0.3])
    spec_m, _ = principled.eval_principled_lobes(n, wi, wo, c, 1.0, 0.4, "ggx")
    gltf_m, _ = brdf.eval_brdf_lobes(n, wi, wo, c, 1.0, 0.4)
    np.testing.assert_allclose(spec_m, gltf_m, rtol=1e-12)  # metals: Schlick with F0 = c in both
    h = _unit(wi + wo)
    vh = np.sum(wi * h, -1)
    spec_d, diff_d = principled.eval_principled_lobes(n, wi, wo, c, 0.0, 0.4, "ggx")
    unit, _ = brdf.eval_brdf_lobes(n, wi, wo, np.ones(3), 1.0, 0.4)  # D V
    np.testing.assert_allclose(spec_d, unit * principled.fresnel_dielectric(vh)[:, None], rtol=1e-12)
    w = diff_d[:, 0] * np.pi / c[0]
    np.testing.assert_allclose(w, 1.0 - principled.specular_layer_albedo(0.4, wi[:, 2]), rtol=1e-12)
    assert principled.fresnel_dielectric(1.0) == pytest.approx(brdf.DIELECTRIC_F0)


def test_multiscatter_differs_from_ggx_by_its_compensation():
    """Multiscatter GGX = GGX with each lobe x (1 + F_ms (1 - E)/E) and the layer albedo x (E + F_ms (1 - E))."""
    from compare.brdf import multiscatter as ms
    from compare.mitsuba import principled

    rng = np.random.default_rng(7)
    wi, wo = _local_directions(rng, 512)
    n = np.array([0.0, 0.0, 1.0])
    c = np.array([0.9, 0.6, 0.2])
    mu = wi[:, 2]
    for r in (0.3, 0.7, 1.0):
        e = ms.ggx_e(r, mu)
        e_avg = ms.ggx_eavg(r)
        for m in (0.0, 1.0):
            spec_g, diff_g = principled.eval_principled_lobes(n, wi, wo, c, m, r, "ggx")
            spec_x, diff_x = principled.eval_principled_lobes(n, wi, wo, c, m, r, "multi_ggx")
            fss = c + (1 - c) / 21 if m else np.full(3, (1.5 - 1) / (4.08567 + 1.00071 * 1.5))
            f_ms = fss * e_avg / (1 - fss * (1 - e_avg))
            np.testing.assert_allclose(spec_x, spec_g * (1 + f_ms * ((1 - e) / e)[:, None]), rtol=1e-12)
            if m == 0.0:
                e_s = principled.specular_layer_albedo(r, mu)
                w = np.clip(1 - e_s * (e + f_ms[0] * (1 - e)), 0, 1)
                np.testing.assert_allclose(diff_x, diff_g / (1 - e_s)[:, None] * w[:, None], rtol=1e-12)
                # the multiscatter diffuse is brighter: less energy is taken by the specular layer
                assert np.all(diff_x >= diff_g) and np.mean(diff_x / np.maximum(diff_g, 1e-30)) > 1.0 + 0.02 * r
    with pytest.raises(ValueError, match="distribution"):
        principled.eval_principled(n, wi, wo, c, 0.0, 0.5, "beckmann")


def test_cycles_layer_table_reproduces_cycles():
    """S(r, n.v) looked up as Cycles does, against values read from Cycles' ggx_gen_schlick_ior_s at IOR 1.5."""
    from compare.mitsuba import principled

    cycles = {0.0: (0.0000, 0.0117, 0.0955, 0.5628), 0.25: (0.0001, 0.0126, 0.0927, 0.4092),
              0.5: (0.0006, 0.0138, 0.0639, 0.1705), 1.0: (0.0014, 0.0058, 0.0161, 0.0403)}
    for r, row in cycles.items():
        got = principled.layer_s(r, np.array([1.0, 0.7, 0.4, 0.1]))
        np.testing.assert_allclose(got, row, atol=3e-4, err_msg=f"roughness {r}")


def test_cycles_layer_table_is_what_layer_table_computes():
    from compare.mitsuba import principled

    np.testing.assert_allclose(principled.layer_table(), principled.LAYER_S_TABLE, atol=1e-6)


def test_cycles_flavour_is_checked(mi_llvm):
    with pytest.raises(Exception, match="flavour"):
        mi_llvm.load_dict({"type": "gltf_pbr", "flavour": "disney"})
    bsdf = mi_llvm.load_dict({"type": "gltf_pbr", "flavour": "cycles"})
    assert "cycles" in str(bsdf) and "multi_ggx" in str(bsdf)
    with pytest.raises(Exception, match="distribution must be one of"):
        mi_llvm.load_dict({"type": "gltf_pbr", "flavour": "cycles", "distribution": "beckmann"})
    with pytest.raises(Exception, match="flavour 'cycles' only"):
        mi_llvm.load_dict({"type": "gltf_pbr", "distribution": "ggx"})


def test_register_is_idempotent(mi_llvm):
    from compare.mitsuba.bsdf import register, registered_variants

    register("llvm_ad_rgb")
    register("llvm_ad_rgb")
    assert registered_variants().count("llvm_ad_rgb") == 1


# -- GLSL ------------------------------------------------------------------------------

# gl_ctx: the session-wide headless context of tests/conftest.py (skips without OpenGL).


def _world_frames(rng, n):
    normal = _unit(rng.normal(size=(n, 3)))
    t = _unit(np.cross(normal, rng.normal(size=(n, 3))))
    b = np.cross(normal, t)
    return normal, t, b


def test_glsl_matches_numpy(gl_ctx):
    from compare.brdf.glsl import eval_brdf_gl

    wi, wo, c, m, r = _case_set(4)
    rng = np.random.default_rng(5)
    normal, t, b = _world_frames(rng, len(wi))
    world = lambda d: d[:, :1] * t + d[:, 1:2] * b + d[:, 2:3] * normal  # noqa: E731
    n, v, l = (_f32(x) for x in (normal, world(wi), world(wo)))  # noqa: E741
    nv, nl = np.sum(n * v, -1), np.sum(n * l, -1)
    keep = (np.abs(nv) > 1e-5) & (np.abs(nl) > 1e-5)
    n, v, l, c, m, r = n[keep], v[keep], l[keep], c[keep], m[keep], r[keep]  # noqa: E741
    got = eval_brdf_gl(gl_ctx, n, v, l, c, m, r).astype(np.float64)
    ref = brdf.eval_brdf(n, v, l, c, m, r)
    rtol = (GL_RTOL + GL_RTOL_ALPHA / brdf.alpha_from_roughness(r))[:, None]
    _check("glsl eval (world frames)", got, ref, rtol, _scale(n, v, l, r)[:, None])


def test_glsl_zero_below_horizon(gl_ctx):
    from compare.brdf.glsl import eval_brdf_gl

    rng = np.random.default_rng(6)
    wi, wo = _local_directions(rng, 256)
    wi[:128, 2] *= -1.0
    wo[128:, 2] *= -1.0
    got = eval_brdf_gl(gl_ctx, np.tile([0.0, 0.0, 1.0], (256, 1)), wi, wo, np.full((256, 3), 0.5), 0.5, 0.5)
    assert np.all(got == 0.0)


def test_glsl_vndf_sampler_matches_numpy(gl_ctx):
    from compare.brdf.glsl import sample_ggx_vndf_gl

    rng = np.random.default_rng(7)
    wi = _unit(rng.normal(size=(N_RANDOM, 3)))
    wi[:, 2] = np.abs(wi[:, 2]) + 1e-3
    wi = _f32(_unit(wi))
    alpha = _f32(brdf.alpha_from_roughness(rng.random(N_RANDOM)))
    u = _f32(rng.random((N_RANDOM, 2)))
    got = sample_ggx_vndf_gl(gl_ctx, wi, alpha, u).astype(np.float64)
    ref = brdf.sample_ggx_vndf(wi, alpha, u)
    err = np.abs(got - ref).max()
    _worst["glsl vndf sample (max abs)"] = float(err)
    assert err < 1e-5  # GLSL sin/cos of 2 pi u: a few float32 ulp of 2 pi


def test_glsl_constants_come_from_python(gl_ctx):
    """brdf.glsl and layers.glsl write none of the constants they share with Python: glsl_source() and
    layers_source() write them ahead of the files with compare.brdf's values, a compiled shader reads those
    values (rounded to float32), and either file without them stops, naming each one."""
    from compare.brdf import coat, sheen
    from compare.brdf.glsl import (BRDF_DEFINES, GLSL_PATH, LAYERS_DEFINES, LAYERS_GLSL_PATH, _run_pointwise,
                                   glsl_source, layers_source)

    python = {"BRDF_ALPHA_MIN": brdf.ALPHA_MIN, "BRDF_COS_MIN": brdf.COS_MIN, "BRDF_DIELECTRIC_F0": brdf.DIELECTRIC_F0,
              "BRDF_H_LEN2_MIN": brdf.H_LEN2_MIN, "BRDF_DENOM_MIN": brdf.DENOM_MIN,
              "LAYERS_SHEEN_ALPHA_MIN": sheen.SHEEN_ALPHA_MIN, "LAYERS_SHEEN_TABLE": sheen.TABLE_SIZE,
              "LAYERS_COAT_F0": coat.COAT_F0}
    assert {**BRDF_DEFINES, **LAYERS_DEFINES} == python
    for path in (GLSL_PATH, LAYERS_GLSL_PATH):
        text = path.read_text(encoding="utf-8")
        for name in python:
            assert not re.search(rf"^\s*#define\s+{name}\b", text, flags=re.M), f"{path.name} writes {name}"
    src = "#define LAYERS 1\n" + glsl_source() + layers_source()
    assert not re.search(r"^\s*#version", src, flags=re.M)
    written = dict(re.findall(r"^#define\s+((?:BRDF|LAYERS)_\w+)\s+(\S+)$", src, flags=re.M))
    for name, value in python.items():
        assert float(written[name]) == value, name
    assert written["LAYERS_SHEEN_TABLE"] == "32.0"  # a float: the texture coordinates divide by it
    names = [*python, "BRDF_PI"]
    body = (f"float k[{len(names)}] = float[{len(names)}]({', '.join(f'float({n})' for n in names)}); "
            "out_value = vec4(k[p.x], 0.0, 0.0, 1.0);")
    got = _run_pointwise(gl_ctx, body, [np.zeros((len(names), 4))], include=src)[:, 0]
    np.testing.assert_array_equal(got, np.float32([*python.values(), np.pi]))
    raw = {GLSL_PATH: "#define LAYERS 1\n" + GLSL_PATH.read_text(encoding="utf-8") + layers_source(),
           LAYERS_GLSL_PATH: "#define LAYERS 1\n" + glsl_source() + LAYERS_GLSL_PATH.read_text(encoding="utf-8")}
    for path, include in raw.items():
        with pytest.raises(Exception) as err:
            _run_pointwise(gl_ctx, "out_value = vec4(0.0);", [np.zeros((1, 4))], include=include)
        for name in BRDF_DEFINES if path == GLSL_PATH else LAYERS_DEFINES:
            assert f"{name} comes from compare/brdf/glsl.py" in str(err.value), (path.name, name)
