"""Extremes of the shared BRDF, and energy: finite everywhere, albedo bounded.

* Roughness 0 and 1, metallic 0 and 1, base colour 0 and 1, n.v and n.l from 1
  down to 1e-30, 0 and slightly negative: numpy, the Mitsuba plugin (both
  variants) and the GLSL give finite values, zero below either horizon, and the
  same values as each other (where both cosines are >= 1e-30, a normal float32).
* White furnace: the directional albedo of a white metal (base colour 1,
  metallic 1, so F = 1) never exceeds 1; the energy the single-scattering model
  loses (1 - albedo) is printed. A white dielectric stays at or below 1 for
  cos(theta) >= 0.75; towards grazing the glTF appendix-B weighting of the
  diffuse lobe by (1 - F(v.h)) lets it exceed 1 (printed; see
  ``test_white_dielectric_albedo``).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from compare import brdf

COSINES = (1.0, 0.5, 1e-3, 1e-6, 1e-12, 1e-30, 0.0, -1e-7, -0.5)
ROUGH = (0.0, 1.0)
METAL = (0.0, 1.0)
BASE = (0.0, 1.0)
AZIMUTHS = (0.0, np.pi / 2, np.pi)  # l in the plane of v (both sides) and across

ALBEDO_ROUGHNESS = (0.0, 0.05, 0.1, 0.25, 0.5, 0.75, 1.0)
ALBEDO_COS = (1.0, 0.75, 0.5, 0.25, 0.1, 0.01)
ALBEDO_SAMPLES = 2 ** 16


def _direction(cos_theta, phi):
    s = np.sqrt(max(0.0, 1.0 - cos_theta * cos_theta))
    return np.array([s * np.cos(phi), s * np.sin(phi), cos_theta])


@pytest.fixture(scope="module")
def extremes():
    """Every combination, in float32-rounded float64, local frame (n = z, so n.v = v.z exactly)."""
    rows = []
    for cv, cl, phi, r, m, c in itertools.product(COSINES, COSINES, AZIMUTHS, ROUGH, METAL, BASE):
        rows.append((_direction(cv, 0.0), _direction(cl, np.pi + phi), r, m, c))
    v = np.array([x[0] for x in rows], dtype=np.float32).astype(np.float64)
    l = np.array([x[1] for x in rows], dtype=np.float32).astype(np.float64)  # noqa: E741
    r = np.array([x[2] for x in rows])
    m = np.array([x[3] for x in rows])
    c = np.repeat(np.array([x[4] for x in rows])[:, None], 3, axis=1)
    n = np.tile([0.0, 0.0, 1.0], (len(rows), 1))
    return n, v, l, c, m, r


def _check_extremes(name, got, n, v, l):  # noqa: E741
    assert np.all(np.isfinite(got)), f"{name}: NaN/Inf at {np.argwhere(~np.isfinite(got))[:5].tolist()}"
    below = (v[:, 2] <= 0.0) | (l[:, 2] <= 0.0)
    assert np.all(got[below] == 0.0), f"{name}: non-zero below the horizon"
    assert np.all(got >= 0.0), f"{name}: negative values"


def _comparable(v, l):  # noqa: E741
    return (v[:, 2] >= 1e-30) & (l[:, 2] >= 1e-30)


def _assert_close(name, got, ref, n, v, l, r, rtol, alpha_min=brdf.ALPHA_MIN):  # noqa: E741
    """|got - ref| <= rtol |ref| + 1e-6 (D V + 1/pi): the tolerance of tests/test_brdf_agreement.py."""
    scale = brdf.eval_brdf(n, v, l, np.ones(3), 1.0, r, alpha_min=alpha_min)[:, :1] + 1.0 / np.pi
    err = np.abs(got - ref)
    allowed = rtol * np.abs(ref) + 1e-6 * scale
    assert np.all(err <= allowed), (
        f"{name}: {int((err > allowed).sum())} values beyond tolerance, worst ratio {np.max(err / allowed):.3g}")


def test_numpy_extremes_finite(extremes):
    n, v, l, c, m, r = extremes
    with np.errstate(all="raise"):  # no overflow, division by zero or invalid operation inside
        f = brdf.eval_brdf(n, v, l, c, m, r)
    _check_extremes("numpy", f, n, v, l)
    assert np.any(f > 0.0)


def test_numpy_helpers_extremes():
    with np.errstate(all="raise"):
        for a in (brdf.ALPHA_MIN, 1.0):
            assert np.isfinite(brdf.ggx_d(1.0, a)) and brdf.ggx_d(1.0, a) > 0
            assert np.isfinite(brdf.ggx_d(0.0, a))
            for cv, cl in itertools.product((0.0, 1e-30, 1.0), repeat=2):
                assert np.isfinite(brdf.smith_v_height_correlated(cv, cl, a))
        assert brdf.alpha_from_roughness(0.0) == brdf.ALPHA_MIN
        assert brdf.alpha_from_roughness(1.0) == 1.0
        assert brdf.alpha_from_roughness(-1.0) == brdf.ALPHA_MIN
        np.testing.assert_allclose(brdf.fresnel_schlick(0.04, np.array([0.0, 1.0, 2.0, -1.0])), [1.0, 0.04, 0.04, 1.0])


@pytest.mark.parametrize("variant, fixture", [("llvm_ad_rgb", "mi_llvm"), ("scalar_rgb", "mi_scalar")])
def test_plugin_extremes_finite(extremes, variant, fixture, request):
    from compare.mitsuba.bsdf import evaluate

    mi = request.getfixturevalue(fixture)  # the variant active, the plugin registered (tests/conftest.py)
    n, v, l, c, m, r = extremes
    value, pdf = evaluate(v, l, c, m, r, variant=variant)
    _check_extremes(f"plugin {variant}", value, n, v, l)
    assert np.all(np.isfinite(pdf)) and np.all(pdf >= 0.0)
    ok = _comparable(v, l)
    ref = brdf.eval_brdf(n[ok], v[ok], l[ok], c[ok], m[ok], r[ok], alpha_min=brdf.REFERENCE_ALPHA_MIN)
    _assert_close(f"plugin {variant}", value[ok] / l[ok, 2:], ref, n[ok], v[ok], l[ok], r[ok], 1e-5,
                  alpha_min=brdf.REFERENCE_ALPHA_MIN)
    if variant == "llvm_ad_rgb":
        _check_sampling_extremes(mi)


def _check_sampling_extremes(mi):
    """sample() at grazing incidence and roughness 0/1 returns finite weights and pdfs."""
    import drjit as dr

    rng = np.random.default_rng(21)
    n = 4096
    for cos_i, r, m, c in itertools.product((1.0, 1e-3, 1e-6, 1e-30), ROUGH, METAL, BASE):
        bsdf = mi.load_dict({"type": "gltf_pbr", "base_color": {"type": "rgb", "value": [c, c, c]},
                             "metallic": m, "roughness": r})
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        si.wi = mi.Vector3f(*map(float, np.float32(_direction(cos_i, 0.0))))
        u1 = rng.random(n)
        u1[:2] = [0.0, 1.0 - 2 ** -24]
        u2 = rng.random((2, n))
        u2[:, :4] = [[0.0, 0.0, 1.0 - 2 ** -24, 1.0 - 2 ** -24], [0.0, 1.0 - 2 ** -24, 0.0, 1.0 - 2 ** -24]]
        bs, weight = bsdf.sample(mi.BSDFContext(), si, mi.Float(u1), mi.Point2f(u2))
        w, p = np.array(weight), np.array(bs.pdf)
        assert np.all(np.isfinite(w)) and np.all(np.isfinite(p)), (cos_i, r, m, c)
        assert np.all(np.isfinite(np.array(bs.wo)))


# gl_ctx: the session-wide headless context of tests/conftest.py (skips without OpenGL).


def test_glsl_extremes_finite(extremes, gl_ctx):
    from compare.brdf.glsl import eval_brdf_gl, sample_ggx_vndf_gl

    n, v, l, c, m, r = extremes
    got = eval_brdf_gl(gl_ctx, n, v, l, c, m, r).astype(np.float64)
    _check_extremes("glsl", got, n, v, l)
    ok = _comparable(v, l)
    ref = brdf.eval_brdf(n[ok], v[ok], l[ok], c[ok], m[ok], r[ok])
    rtol = 1e-5 + 5e-7 / brdf.alpha_from_roughness(r[ok])[:, None]
    _assert_close("glsl", got[ok], ref, n[ok], v[ok], l[ok], r[ok], rtol)
    # the sampler at grazing incidence, roughness 0 and 1, with u at its ends
    wi = np.array([_direction(ci, 0.0) for ci in (1.0, 1e-3, 1e-6, 1e-30)])
    wi = np.repeat(wi, 8, axis=0)
    alpha = np.tile(np.repeat([brdf.ALPHA_MIN, 1.0], 4), 4)
    u = np.tile([[0.0, 0.0], [0.0, 1 - 2 ** -24], [1 - 2 ** -24, 0.0], [0.5, 0.5]], (8, 1))
    h = sample_ggx_vndf_gl(gl_ctx, wi, alpha, u)
    assert np.all(np.isfinite(h))


# -- white furnace ---------------------------------------------------------------------

def _table(title, values):
    lines = [title, "  roughness \\ cos(theta_v) " + " ".join(f"{c:>8g}" for c in ALBEDO_COS)]
    for r, row in zip(ALBEDO_ROUGHNESS, values):
        lines.append(f"  {r:>25g} " + " ".join(f"{x:8.5f}" for x in row))
    return "\n".join(lines)


def test_white_metal_albedo_at_most_one():
    """F = 1: the albedo is E[G2 / G1(v)] <= 1; 1 - albedo is the single-scattering energy loss."""
    r, ct = np.meshgrid(ALBEDO_ROUGHNESS, ALBEDO_COS, indexing="ij")
    albedo, err = brdf.directional_albedo(r, ct, (1.0, 1.0, 1.0), 1.0, ALBEDO_SAMPLES, return_stderr=True)
    a = albedo[..., 0]
    print("\n" + _table(f"Energy loss 1 - E(v) of a white metal (base 1, metallic 1), "
                        f"{ALBEDO_SAMPLES} VNDF samples, max std. error {err.max():.1e}:", 1.0 - a))
    assert np.all(np.isfinite(albedo))
    assert np.all(albedo <= 1.0 + 4.0 * err + 1e-12)
    np.testing.assert_allclose(albedo[..., 0], albedo[..., 2])  # grey in, grey out
    # closed form at roughness 1, normal incidence: D = 1/pi, V = 1/(2(1 + n.l)) -> E = 1 - ln 2
    assert abs(a[-1, 0] - (1.0 - np.log(2.0))) < 4.0 * err[-1, 0, 0] + 1e-4


def test_white_dielectric_albedo():
    """Base colour 1, metallic 0: <= 1 near normal incidence; the grazing excess is printed."""
    r, ct = np.meshgrid(ALBEDO_ROUGHNESS, ALBEDO_COS, indexing="ij")
    albedo, err = brdf.directional_albedo(r, ct, (1.0, 1.0, 1.0), 0.0, ALBEDO_SAMPLES, return_stderr=True)
    a = albedo[..., 0]
    print("\n" + _table("Directional albedo E(v) of a white dielectric (base 1, metallic 0); "
                        "values > 1 are the glTF appendix-B form's excess at grazing angles:", a))
    assert np.all(np.isfinite(albedo))
    near_normal = ct >= 0.75
    assert np.all(a[near_normal] <= 1.0 + 4.0 * err[..., 0][near_normal] + 1e-12)
    # Documented behaviour, not a goal: at grazing incidence the diffuse lobe keeps most of
    # its weight (1 - F(v.h) with v.h ~ 0.7 for most l) while the specular lobe tends to F = 1.
    # If this starts failing the model changed: update compare/brdf's docstring and this test.
    assert a[0, -1] > 1.5
    assert np.all(a <= 2.0)
