"""The LTC table of the specular lobe (compare.brdf.ltc).

The committed table is checked for its layout (the (a, b, c, d) <-> M^-1
convention the GLSL uses), against brute-force integrals of the shared BRDF's
lobe over rectangles, for the horizon clipping of the polygon integral, and for
being what the module's fitter makes.
"""

from __future__ import annotations

import numpy as np
import pytest

from compare.brdf import ALPHA_MIN, directional_albedo, eval_brdf_lobes, pdf_ggx_vndf_reflection
from compare.brdf import ltc
from tools import fit_ltc
from compare.util.errors import MissingComponentError

NORMAL = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def table():
    return ltc.load_table()


def view(cos_theta: float) -> np.ndarray:
    return np.array([np.sqrt(1.0 - cos_theta * cos_theta), 0.0, cos_theta])


def magnitude(roughness: float, cos_theta: float) -> float:
    """integral D V (n.l) dl: the albedo of a metal with F0 = 1 (the split sum's A + B)."""
    return float(directional_albedo(roughness, cos_theta, (1.0, 1.0, 1.0), 1.0)[0])


def rectangle(direction, half_u: float, half_v: float) -> np.ndarray:
    """Corners (4, 3) of a rectangle facing the origin, centred at the unit ``direction``."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / np.linalg.norm(d)
    e1 = np.cross([0.0, 1.0, 0.0], d) if abs(d[1]) < 0.9 else np.cross([1.0, 0.0, 0.0], d)
    e1 /= np.linalg.norm(e1)
    u, v = half_u * e1, half_v * np.cross(d, e1)
    return np.array([d - u - v, d + u - v, d + u + v, d - u + v])


def lobe_over_rectangle(roughness: float, cos_theta: float, corners: np.ndarray, m: int = 400) -> float:
    """integral of the BRDF's lobe f = D V max(l.z, 0) over a rectangle: m x m midpoints on it.

    The rectangle's solid angle element is ``|n_rect . p| / |p|^3 dA``. The
    midpoint rule is converged: doubling m changes the results by < 1e-5 of the
    lobe's magnitude (the horizon cut included).
    """
    c = corners.mean(axis=0)
    u, v = (corners[1] - corners[0]) / 2, (corners[3] - corners[0]) / 2
    s = (np.arange(m) + 0.5) / m * 2.0 - 1.0
    a, b = np.meshgrid(s, s, indexing="ij")
    p = c + a[..., None] * u + b[..., None] * v
    normal = np.cross(u, v)
    area = 4.0 * np.linalg.norm(normal) / m**2
    dist = np.linalg.norm(p, axis=-1)
    l = p / dist[..., None]  # noqa: E741
    d_omega = np.abs(p @ normal) / np.linalg.norm(normal) / dist**3 * area
    spec, _ = eval_brdf_lobes(NORMAL, view(cos_theta), l, np.ones(3), 1.0, roughness)
    return float(np.sum(spec[..., 0] * np.maximum(l[..., 2], 0.0) * d_omega))


def rectangles(cos_theta: float) -> dict[str, np.ndarray]:
    """Rectangles on the lobe's peak (the mirror direction, at -x), off it, across the horizon."""
    sin_theta = np.sqrt(1.0 - cos_theta**2)
    mirror = np.array([-sin_theta, 0.0, cos_theta])
    c30, s30 = np.cos(np.radians(30)), np.sin(np.radians(30))
    c10, s10 = np.cos(np.radians(10)), np.sin(np.radians(10))
    return {
        "peak, small": rectangle(mirror, 0.1, 0.1),
        "peak, large": rectangle(mirror, 1.0, 0.6),
        "30 deg off peak": rectangle([-sin_theta * c30, s30, cos_theta * c30], 0.3, 0.3),
        "across the horizon": rectangle([-c10, 0.0, s10], 0.5, 0.5),
        "viewer's side": rectangle([1.0, 0.0, 1.0], 0.4, 0.4),
    }


# Tolerance on |magnitude * LTC integral - brute force| / magnitude per (roughness, cos):
# the measured maximum over the five rectangles (in the comment) with a margin. The
# fit is good near normal incidence (<= 1 % of the magnitude) and for roughness 1
# (where D is constant and the lobe is rotationally symmetric); at cos 0.2 a clamped
# cosine cannot follow a lobe cut by the horizon. The polygon is clipped to the
# surface's horizon before the transform (as the GLSL does): without that, rectangles
# across the horizon also picked up the LTC's mass below it (measured then: 0.179 at
# (0.6, 0.2), 0.060 at (0.3, 0.2)). Heitz's own GGX table shows the same errors there.
TOLERANCE = {
    (0.3, 1.0): 0.01,   # measured 0.0049
    (0.3, 0.7): 0.015,  # measured 0.0103 (across the horizon)
    (0.3, 0.2): 0.06,   # measured 0.043 (large rectangle on the peak; 0.030 small)
    (0.6, 1.0): 0.015,  # measured 0.0096
    (0.6, 0.7): 0.03,   # measured 0.020
    (0.6, 0.2): 0.14,   # measured 0.108 (large rectangle on the peak; 0.078 across the horizon)
    (1.0, 1.0): 0.01,   # measured 0.0025
    (1.0, 0.7): 0.01,   # measured 0.0032
    (1.0, 0.2): 0.01,   # measured 0.0063
}


def test_table_loads(table):
    assert table.shape == (64, 64, 4) and table.dtype == np.float32
    assert np.all(np.isfinite(table))
    with np.load(ltc.TABLE_PATH) as data:
        assert int(data["n"]) == 64
        assert data["fit_error"].shape == (64, 64) and np.all(np.isfinite(data["fit_error"]))
        # A table fitted for another ALPHA_MIN is stale: rerun `python -m tools.fit_ltc`.
        assert float(data["alpha_min"]) == ALPHA_MIN


def test_lobe_is_the_brdf():
    """The fitted lobe and its sampling density are the shared BRDF's (F0 = 1) and its VNDF pdf."""
    rng = np.random.default_rng(1)
    l = rng.normal(size=(2000, 3))  # noqa: E741
    l /= np.linalg.norm(l, axis=1, keepdims=True)
    for roughness, cos_theta in ((0.0, 0.9), (0.4, 0.5), (1.0, 0.05)):
        f, pdf = fit_ltc._Lobe(roughness, cos_theta).eval(l)
        v = view(cos_theta)
        spec, _ = eval_brdf_lobes(NORMAL, v, l, np.ones(3), 1.0, roughness)
        np.testing.assert_allclose(f, spec[:, 0] * np.maximum(l[:, 2], 0.0), rtol=1e-12, atol=0)
        up = l[:, 2] > 0
        ref = pdf_ggx_vndf_reflection(v, l[up], float(max(roughness**2, ALPHA_MIN)))
        np.testing.assert_allclose(pdf[up], ref, rtol=1e-12, atol=0)


def test_stored_magnitude_is_the_albedo():
    with np.load(ltc.TABLE_PATH) as data:
        stored = data["magnitude"]
    for j, i in ((0, 63), (20, 19), (50, 40), (62, 3)):
        roughness, cos_theta = ltc.cell_view(64, j, i)
        assert stored[j, i] == pytest.approx(magnitude(roughness, cos_theta), abs=1e-3)


def test_lookup_is_a_linear_texture_fetch(table):
    def entries(minv):
        return np.array([minv[0, 0], minv[2, 0], minv[0, 2], minv[2, 2]])

    for j, i in ((0, 0), (17, 40), (62, 63)):
        roughness, cos_theta = ltc.cell_view(64, j, i)
        np.testing.assert_allclose(entries(ltc.ltc_matrix(table, roughness, cos_theta)), table[j, i], rtol=1e-12)
    # halfway between two roughness columns, and clamped to the edge outside [0, 1]
    cos_theta = ltc.cell_view(64, 30, 0)[1]
    np.testing.assert_allclose(entries(ltc.ltc_matrix(table, 10.5 / 63, cos_theta)),
                               (table[30, 10].astype(float) + table[30, 11]) / 2, rtol=1e-12)
    np.testing.assert_allclose(entries(ltc.ltc_matrix(table, 1.7, 0.0)), table[63, 63], rtol=1e-12)
    minv = ltc.ltc_matrix(table, 0.5, 0.5)
    assert minv[0, 1] == minv[1, 0] == minv[1, 2] == minv[2, 1] == 0.0 and minv[1, 1] == 1.0


@pytest.mark.parametrize(("roughness", "cos_theta"), sorted(TOLERANCE))
def test_polygon_integral_matches_brute_force(table, roughness, cos_theta):
    mag = magnitude(roughness, cos_theta)
    minv = ltc.ltc_matrix(table, roughness, cos_theta)
    errors = {}
    for name, corners in rectangles(cos_theta).items():
        expected = lobe_over_rectangle(roughness, cos_theta, corners)
        errors[name] = (mag * ltc.polygon_integral(minv, corners) - expected) / mag
    worst = max(errors, key=lambda k: abs(errors[k]))
    assert abs(errors[worst]) <= TOLERANCE[roughness, cos_theta], errors


def test_transposed_convention_is_detected(table):
    """Swapping b and c (M^-1 transposed) would fail the comparison above by far (measured: 17 times its tolerance)."""
    roughness, cos_theta = 0.3, 0.7
    minv = ltc.ltc_matrix(table, roughness, cos_theta)
    corners = rectangles(cos_theta)["peak, small"]
    expected = lobe_over_rectangle(roughness, cos_theta, corners)
    mag = magnitude(roughness, cos_theta)
    assert abs(mag * ltc.polygon_integral(minv.T, corners) - expected) > 10 * TOLERANCE[roughness, cos_theta] * mag


def test_polygon_integral_hemisphere_and_horizon(table):
    sky = np.array([[-1e4, -1e4, 1.0], [1e4, -1e4, 1.0], [1e4, 1e4, 1.0], [-1e4, 1e4, 1.0]])
    assert ltc.polygon_integral(np.eye(3), sky) == pytest.approx(1.0, abs=1e-3)
    assert ltc.polygon_integral(np.eye(3), sky[::-1]) == pytest.approx(1.0, abs=1e-3)  # any winding
    assert ltc.polygon_integral(np.eye(3), sky * [1, 1, -1]) == 0.0  # below the horizon
    for roughness in (0.0, 0.3, 0.6, 1.0):  # at normal incidence M^-1 keeps the horizon
        assert ltc.polygon_integral(ltc.ltc_matrix(table, roughness, 1.0), sky) == pytest.approx(1.0, abs=1e-3)
    # At grazing angles part of the LTC lies below the horizon: the sky then gets the
    # rest, which sampling the LTC (l = M w / |M w|, w cosine-distributed) measures.
    m = 512
    u = (np.stack(np.meshgrid(np.arange(m), np.arange(m), indexing="ij"), -1).reshape(-1, 2) + 0.5) / m
    w = np.stack([np.sqrt(1 - u[:, 0]) * np.cos(2 * np.pi * u[:, 1]),
                  np.sqrt(1 - u[:, 0]) * np.sin(2 * np.pi * u[:, 1]), np.sqrt(u[:, 0])], -1)
    for roughness, cos_theta in ((0.3, 0.2), (0.6, 0.2), (0.6, 0.05)):
        minv = ltc.ltc_matrix(table, roughness, cos_theta)
        above = np.mean((w @ np.linalg.inv(minv).T)[:, 2] > 0.0)
        assert above < 0.99
        assert ltc.polygon_integral(minv, sky) == pytest.approx(above, abs=2e-3)


def test_roughness_one_normal_incidence_is_near_a_clamped_cosine(table):
    """GGX with alpha = 1 has D = 1 / pi: the lobe (n.l / (2 pi (1 + n.l))) is almost a cosine.

    Measured M^-1 = diag(1, 1, 1.128): a cosine stretched by 13 % sideways, which
    also fixes the orientation (z stays the normal, no shear).
    """
    a, b, c, d = table[0, 63]
    assert a == pytest.approx(1.0, abs=1e-6) and abs(b) < 1e-6 and abs(c) < 1e-6
    assert d == pytest.approx(1.0, abs=0.2)


def test_refit_reproduces_the_table(table):
    """The first cells of the fit's order (each starts from the previous one) refitted."""
    with np.load(ltc.TABLE_PATH) as data:
        fit_error = data["fit_error"]
    first = fit_ltc.fit_cell(64, 0, 63, fit_ltc.START_PARAMS)
    for (j, i), fit in (((0, 63), first), ((1, 63), fit_ltc.fit_cell(64, 1, 63, first.params)),
                        ((0, 62), fit_ltc.fit_cell(64, 0, 62, first.params))):
        np.testing.assert_allclose(fit.entries, table[j, i], rtol=1e-5, atol=1e-6)
        assert fit.fit_error == pytest.approx(fit_error[j, i], rel=1e-5)


def _write_garbage(path):
    path.write_bytes(b"not an npz file")


def _write_no_minv(path):
    np.savez(path, fit_error=np.zeros((64, 64)))


def _write_wrong_shape(path):
    np.savez(path, minv=np.zeros((32, 32, 4), np.float32))


def _write_nan(path):
    minv = np.zeros((64, 64, 4), np.float32)
    minv[3, 5, 1] = np.nan
    np.savez(path, minv=minv)


@pytest.mark.parametrize("write", [None, _write_garbage, _write_no_minv, _write_wrong_shape, _write_nan])
def test_bad_file_is_one_clear_error(tmp_path, write):
    path = tmp_path / "ltc_table.npz"
    if write is not None:
        write(path)
    with pytest.raises(MissingComponentError) as info:
        ltc.load_table(path)
    assert str(path) in str(info.value) and "python -m tools.fit_ltc" in str(info.value)
