"""Sampling of the ``gltf_pbr`` Mitsuba plugin: Pearson chi-square tests and weights.

The chi-square tests use Mitsuba's own harness (``mitsuba.chi2``): a histogram
of ``sample()`` directions against ``pdf()`` integrated over the same cells.

Domain. Mitsuba's ``SphericalDomain`` bins (phi, cos theta) uniformly, 50 x 101
cells. That cannot resolve a GGX lobe with alpha <= 0.09: at roughness 0.05
(alpha 0.0025) the whole lobe lies in a sliver of the top row, the trapezoid
rule over-integrates the pdf (its sum exceeds 1.1, a hard failure), and at
grazing incidence the reflected lobe is also squeezed ~100:1 in azimuth. The
tests therefore bin in a :class:`HalfVectorDomain`, a ``SphericalDomain``
subclass that parameterises the outgoing direction by its half vector: phi_h
uniform, ``cos(theta_h) = 1 - t^k`` with ``t = (y + 1) / 2`` and ``k`` chosen so
that the GGX core spans about a third of the rows; ``wo = reflect(wi, h)``. The
pdf is multiplied by the Jacobian ``d omega_o / d(x, y) = 4 |wi.h| (k/2) t^(k-1)``.
The map covers every above-horizon direction exactly once; samples with zero
weight (below the horizon) are binned at the pole with weight 0. The horizon
is a curve through the cells, where the pdf jumps to 0, so the pdf is
integrated with ``ires = 16`` points per cell side (trapezoid error at a jump
falls as 1/ires). For roughness 1 the plain ``SphericalDomain`` is run too.

Significance: 1% for the whole family of tests (Sidak correction over their
number). With 1e6 samples the harness rejects a pdf whose roughness is off by
10% (0.30 vs 0.33), checked by ``test_chi2_detects_wrong_pdf``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare import brdf

ROUGHNESS = (0.05, 0.3, 1.0)
METALLIC = (0.0, 1.0)
COS_THETA_I = (0.999, 0.5, 0.01)  # "normal incidence" is 0.999 (2.6 degrees), not a degenerate 1
BASE_COLOR = (0.8, 0.5, 0.2)
SAMPLE_COUNT = 1_000_000
RES = 101
IRES = 16
SIGNIFICANCE = 0.01
N_CHI2 = len(ROUGHNESS) * len(METALLIC) * len(COS_THETA_I) + len(METALLIC) * len(COS_THETA_I)
#: (roughness, metallic, cos_i) of the chi-square tests of the ``cycles`` flavour (its own lobe
#: probabilities; the same sampler otherwise): a family of its own, also 1% family-wise.
CYCLES_CHI2 = ((0.3, 0.0, 0.5), (1.0, 0.5, 0.999), (0.05, 0.0, 0.01))

_p_values: dict[tuple, float] = {}


@pytest.fixture
def mi(mi_llvm):
    """llvm_ad_rgb with the plugin registered (the chi2 harness needs a JIT variant)."""
    return mi_llvm


@pytest.fixture(scope="module", autouse=True)
def _print_p_values():
    yield
    if not _p_values:
        return
    print(f"\nchi-square p-values (gltf_pbr, {SAMPLE_COUNT} samples, base colour {BASE_COLOR}; "
          f"reject below {1 - (1 - SIGNIFICANCE) ** (1 / N_CHI2):.2e} each, 1% family-wise):")
    print(f"  {'domain':10s} {'roughness':>9s} {'metallic':>8s} " + " ".join(f"cos={c:<8g}" for c in COS_THETA_I))
    for dom in ("half-vec", "spherical"):
        for r in ROUGHNESS:
            for m in METALLIC:
                row = [_p_values.get((dom, r, m, c)) for c in COS_THETA_I]
                if any(p is not None for p in row):
                    cells = " ".join(f"{p:<12.4f}" if p is not None else f"{'-':<12s}" for p in row)
                    print(f"  {dom:10s} {r:9g} {m:8g} {cells}")


def _half_vector_domain(mi):
    import drjit as dr
    from mitsuba.chi2 import SphericalDomain

    s45 = math.sin(math.pi / 4)

    class HalfVectorDomain(SphericalDomain):
        """(phi_h, y) -> h on the upper hemisphere, cos(theta_h) = 1 - t^k, t = (y+1)/2; wo = reflect(wi, h)."""

        def __init__(self, wi, k):
            self.wi = mi.Vector3f(*wi)
            self.k = float(k)

        def map_forward(self, p):
            t = (p.y + 1.0) * 0.5
            u = s45 * dr.power(t, 0.5 * self.k)  # sin(theta_h / 2), accurate near the pole
            s = 2.0 * u * dr.safe_sqrt(1.0 - u * u)
            sin_phi, cos_phi = dr.sincos(p.x)
            h = mi.Vector3f(cos_phi * s, sin_phi * s, 1.0 - 2.0 * u * u)
            return 2.0 * dr.dot(self.wi, h) * h - self.wi

        def _half(self, wo):
            hu = self.wi + wo
            h = dr.normalize(hu)
            ok = (h.z > 0.0) & (dr.squared_norm(hu) > 1e-12)
            h = dr.select(ok, h, mi.Vector3f(0.0, 0.0, 1.0))
            u = dr.norm(h - mi.Vector3f(0.0, 0.0, 1.0)) * 0.5
            return h, dr.minimum(dr.power(u / s45, 2.0 / self.k), 1.0)

        def map_backward(self, wo):
            h, t = self._half(wo)
            return mi.Vector2f(dr.atan2(h.y, h.x), 2.0 * t - 1.0)

        def jacobian(self, wo):
            h, t = self._half(wo)
            return 4.0 * dr.abs(dr.dot(self.wi, h)) * 0.5 * self.k * dr.power(t, self.k - 1.0)

    return HalfVectorDomain


def _chi2(mi, roughness, metallic, cos_i, domain="half-vec", pdf_roughness=None, seed=0, flavour="gltf",
          test_count=N_CHI2):
    import drjit as dr
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    wi = [math.sqrt(1.0 - cos_i * cos_i), 0.0, cos_i]
    spec = {"type": "gltf_pbr", "base_color": {"type": "rgb", "value": list(BASE_COLOR)},
            "metallic": metallic, "roughness": roughness, "flavour": flavour}
    sample_func, pdf_func = BSDFAdapter("gltf_pbr", spec, wi=wi)
    if pdf_roughness is not None:
        _, pdf_func = BSDFAdapter("gltf_pbr", dict(spec, roughness=pdf_roughness), wi=wi)
    if domain == "spherical":
        dom, sample_fn, pdf_fn = SphericalDomain(), sample_func, pdf_func
    else:
        alpha = float(brdf.alpha_from_roughness(roughness))
        k = max(1.0, 2.0 * math.log(alpha / math.sin(math.pi / 4)) / math.log(0.3))
        dom = _half_vector_domain(mi)(wi, k)

        def sample_fn(u):
            wo, w = sample_func(u)
            hz = dr.normalize(dom.wi + wo).z
            bad = (w == 0.0) | ~(hz > 0.0)
            return dr.select(bad, mi.Vector3f(0.0, 0.0, 1.0), wo), dr.select(bad, 0.0, w)

        def pdf_fn(wo):
            return pdf_func(wo) * dom.jacobian(wo)

    test = ChiSquareTest(domain=dom, sample_func=sample_fn, pdf_func=pdf_fn, sample_dim=3,
                         sample_count=SAMPLE_COUNT, res=RES, ires=IRES, seed=seed)
    ok = test.run(significance_level=SIGNIFICANCE, test_count=test_count, quiet=True)
    return ok, float(test.p_value), test.messages


@pytest.mark.parametrize("cos_i", COS_THETA_I)
@pytest.mark.parametrize("metallic", METALLIC)
@pytest.mark.parametrize("roughness", ROUGHNESS)
def test_chi2_half_vector_domain(mi, roughness, metallic, cos_i):
    ok, p, messages = _chi2(mi, roughness, metallic, cos_i)
    _p_values[("half-vec", roughness, metallic, cos_i)] = p
    print(f"\n[chi2 half-vec r={roughness} m={metallic} cos={cos_i}] p = {p:.4f}")
    assert ok, messages


@pytest.mark.parametrize("cos_i", COS_THETA_I)
@pytest.mark.parametrize("metallic", METALLIC)
def test_chi2_spherical_domain_rough(mi, metallic, cos_i):
    """Mitsuba's plain SphericalDomain, where it can resolve the lobe (roughness 1)."""
    ok, p, messages = _chi2(mi, 1.0, metallic, cos_i, domain="spherical")
    _p_values[("spherical", 1.0, metallic, cos_i)] = p
    print(f"\n[chi2 spherical r=1.0 m={metallic} cos={cos_i}] p = {p:.4f}")
    assert ok, messages


@pytest.mark.parametrize(("roughness", "metallic", "cos_i"), CYCLES_CHI2)
def test_chi2_cycles_flavour(mi, roughness, metallic, cos_i):
    ok, p, messages = _chi2(mi, roughness, metallic, cos_i, flavour="cycles", test_count=len(CYCLES_CHI2))
    _p_values[("cycles half-vec", roughness, metallic, cos_i)] = p
    print(f"\n[chi2 cycles half-vec r={roughness} m={metallic} cos={cos_i}] p = {p:.4f}")
    assert ok, messages


@pytest.mark.parametrize("metallic", METALLIC)
def test_chi2_detects_wrong_pdf(mi, metallic):
    """Power check: sampling roughness 0.30 against the pdf of roughness 0.33 must be rejected."""
    ok, p, _ = _chi2(mi, 0.3, metallic, 0.5, pdf_roughness=0.33)
    assert not ok and p < 1e-6


# -- sample() weights ------------------------------------------------------------------

def _random_batch(mi, n, seed, flavour="gltf"):
    """A bitmap-textured plugin with per-lane materials and random upper-hemisphere wi."""
    import drjit as dr

    rng = np.random.default_rng(seed)
    c = rng.random((n, 3)).astype(np.float32)
    m = rng.random(n).astype(np.float32)
    r = rng.random(n).astype(np.float32)
    r[: n // 8] = 0.0
    m[n // 8: n // 4] = 1.0

    def bitmap(data):
        return {"type": "bitmap", "data": mi.TensorXf(np.ascontiguousarray(data.reshape(1, n, -1))),
                "raw": True, "filter_type": "nearest"}

    bsdf = mi.load_dict({"type": "gltf_pbr", "base_color": bitmap(c), "metallic": bitmap(m),
                         "roughness": bitmap(r), "flavour": flavour})
    wi = rng.normal(size=(n, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wi[:, 2] = np.abs(wi[:, 2])
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(wi.astype(np.float32).T)
    si.uv = mi.Point2f(mi.Float((np.arange(n) + 0.5) / n), mi.Float(np.full(n, 0.5)))
    u1 = mi.Float(rng.random(n))
    u2 = mi.Point2f(rng.random((2, n)))
    return bsdf, si, u1, u2


@pytest.mark.parametrize("flavour", ["gltf", "cycles"])
def test_sample_weight_is_eval_over_pdf(mi, flavour):
    n = 20000
    bsdf, si, u1, u2 = _random_batch(mi, n, seed=11, flavour=flavour)
    ctx = mi.BSDFContext()
    bs, weight = bsdf.sample(ctx, si, u1, u2)
    value = np.array(bsdf.eval(ctx, si, bs.wo)).T
    pdf = np.array(bsdf.pdf(ctx, si, bs.wo))
    weight = np.array(weight).T
    bs_pdf = np.array(bs.pdf)
    valid = np.array(bs.wo.z) > 0
    assert np.all(np.isfinite(weight)) and np.all(np.isfinite(bs_pdf))
    assert valid.mean() > 0.5
    np.testing.assert_allclose(bs_pdf[valid], pdf[valid], rtol=1e-6)
    np.testing.assert_allclose(weight[valid], value[valid] / pdf[valid][:, None], rtol=1e-5, atol=1e-7)
    assert np.all(weight[~valid] == 0.0)
    comp = np.array(bs.sampled_component)
    types = np.array(bs.sampled_type)
    flags = mi.BSDFFlags
    assert set(np.unique(comp)) <= {0, 1}
    assert np.all(types[comp == 1] == int(flags.GlossyReflection))
    assert np.all(types[comp == 0] == int(flags.DiffuseReflection))


@pytest.mark.parametrize(("roughness", "metallic", "cos_i"), [(0.0, 1.0, 0.7), (0.5, 0.0, 0.3), (1.0, 0.5, 0.9)])
def test_sample_weights_average_to_numpy_albedo(mi, roughness, metallic, cos_i):
    """E[weight] of sample() is the directional albedo; compare with the numpy estimator."""
    import drjit as dr

    n = 1_000_000
    rng = np.random.default_rng(12)
    bsdf = mi.load_dict({"type": "gltf_pbr", "base_color": {"type": "rgb", "value": list(BASE_COLOR)},
                         "metallic": metallic, "roughness": roughness})
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(math.sqrt(1 - cos_i * cos_i), 0.0, cos_i)
    _, weight = bsdf.sample(mi.BSDFContext(), si, mi.Float(rng.random(n)), mi.Point2f(rng.random((2, n))))
    w = np.array(weight).T.astype(np.float64)
    est, err = w.mean(axis=0), w.std(axis=0) / math.sqrt(n)
    ref, ref_err = brdf.directional_albedo(roughness, cos_i, np.float32(BASE_COLOR), metallic, 2 ** 16,
                                          return_stderr=True)
    tol = 5.0 * np.sqrt(err ** 2 + ref_err ** 2) + 1e-6
    assert np.all(np.abs(est - ref) <= tol), (est, ref, tol)


def test_context_selects_components(mi):
    """A BSDFContext restricted to one component samples and evaluates only that lobe."""
    import drjit as dr

    n = 4096
    rng = np.random.default_rng(13)
    bsdf = mi.load_dict({"type": "gltf_pbr", "base_color": {"type": "rgb", "value": list(BASE_COLOR)},
                         "metallic": 0.0, "roughness": 0.4})
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(0.6, 0.0, 0.8)
    wo = rng.normal(size=(n, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wo[:, 2] = np.abs(wo[:, 2])
    wo_mi = mi.Vector3f(wo.astype(np.float32).T)
    full = np.array(bsdf.eval(mi.BSDFContext(), si, wo_mi)).T
    parts = []
    for comp in (0, 1):
        ctx = mi.BSDFContext(mi.TransportMode.Radiance, int(mi.BSDFFlags.All), comp)
        parts.append(np.array(bsdf.eval(ctx, si, wo_mi)).T)
        bs, weight = bsdf.sample(ctx, si, mi.Float(rng.random(n)), mi.Point2f(rng.random((2, n))))
        assert np.all(np.array(bs.sampled_component)[np.array(bs.pdf) > 0] == comp)
        assert np.all(np.isfinite(np.array(weight)))
    np.testing.assert_allclose(parts[0] + parts[1], full, rtol=1e-6, atol=1e-9)
    cos_o = wo[:, 2:]
    spec, diff = brdf.eval_brdf_lobes([0, 0, 1.0], [0.6, 0, 0.8], wo.astype(np.float32).astype(float),
                                      np.float32(BASE_COLOR), 0.0, 0.4)
    np.testing.assert_allclose(parts[0], diff * cos_o, rtol=1e-5, atol=1e-8)
    np.testing.assert_allclose(parts[1], spec * cos_o, rtol=1e-5, atol=1e-8)


@pytest.mark.parametrize(("roughness", "metallic"), [(1.0, 1.0), (0.3, 0.0), (0.0, 1.0)])
def test_furnace_render_matches_numpy_albedo(mi, roughness, metallic):
    """The plugin inside Mitsuba's path integrator: a sphere under a constant unit environment.

    The pixels at the centre see the surface at normal incidence, so their value is the
    directional albedo at cos(theta) ~ 1 (>= 0.99 over the 4 x 4 centre pixels).
    """
    mi_ = mi
    scene = mi_.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 30,
                   "to_world": mi_.ScalarTransform4f().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 32, "height": 32, "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": 256}},
        "env": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}},
        "sphere": {"type": "sphere", "bsdf": {"type": "gltf_pbr",
                                              "base_color": {"type": "rgb", "value": list(BASE_COLOR)},
                                              "metallic": metallic, "roughness": roughness}},
    })
    img = np.array(mi_.render(scene, seed=1), dtype=np.float64)
    assert np.all(np.isfinite(img))
    centre = img[14:18, 14:18].reshape(-1, 3).mean(axis=0)
    ref = brdf.directional_albedo(roughness, 1.0, np.float32(BASE_COLOR), metallic, 2 ** 16)
    np.testing.assert_allclose(centre, ref, rtol=0.03)
