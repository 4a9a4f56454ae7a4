"""Cycles' Multiscatter GGX tables and factors (compare.brdf.multiscatter)."""

import numpy as np
import pytest

from compare.brdf import multiscatter as ms
from tools import fit_multiscatter

# Values read from Cycles' table_ggx_E (Blender 5.0, scene/shader.tables): row mu = j/31, column roughness = i/31.
CYCLES_GGX_E = {
    31: {4: 0.999716, 8: 0.995072, 16: 0.903873, 24: 0.592102, 31: 0.306853},
    24: {4: 0.999618, 8: 0.993224, 16: 0.881288, 24: 0.602968, 31: 0.357977},
    15: {4: 0.999228, 8: 0.985893, 16: 0.843295, 24: 0.646780, 31: 0.457779},
    8: {4: 0.997533, 8: 0.959173, 16: 0.834154, 24: 0.727744, 31: 0.591195},
    3: {4: 0.982075, 8: 0.892271, 16: 0.893246, 24: 0.844436, 31: 0.765057},
    1: {4: 0.911203, 8: 0.917411, 16: 0.952096, 24: 0.927272, 31: 0.888202},
}
# table_ggx_Eavg at roughness i/31.
CYCLES_GGX_EAVG = {4: 0.998729, 8: 0.985805, 16: 0.870874, 24: 0.631068, 31: 0.409137}


def test_tables_reproduce_cycles():
    for j, row in CYCLES_GGX_E.items():
        for i, value in row.items():
            assert ms.GGX_E_TABLE[j, i] == pytest.approx(value, abs=5e-5), (j, i)
    for i, value in CYCLES_GGX_EAVG.items():
        assert ms.GGX_EAVG_TABLE[i] == pytest.approx(value, abs=5e-5), i


def test_stored_tables_are_what_energy_tables_computes():
    e, e_avg = fit_multiscatter.energy_tables(samples=96, avg_nodes=32)
    np.testing.assert_allclose(e, ms.GGX_E_TABLE, atol=3e-4)
    np.testing.assert_allclose(e_avg, ms.GGX_EAVG_TABLE, atol=3e-4)


def test_eavg_is_the_cosine_weighted_mean_of_e():
    mu = np.linspace(0.0, 1.0, 2001)
    for r in (0.2, 0.5, 0.8, 1.0):
        integral = np.trapezoid(2.0 * mu * ms.ggx_e(r, mu), mu)
        assert integral == pytest.approx(float(ms.ggx_eavg(r)), abs=2e-3), r


def test_lookups_interpolate_as_cycles():
    # on the grid the lookups return the table; between grid points they are linear
    assert ms.ggx_e(16 / 31, 8 / 31) == pytest.approx(ms.GGX_E_TABLE[8, 16], abs=1e-12)
    mid = ms.ggx_e(16.5 / 31, 8 / 31)
    assert mid == pytest.approx(0.5 * (ms.GGX_E_TABLE[8, 16] + ms.GGX_E_TABLE[8, 17]), abs=1e-12)
    assert ms.ggx_eavg(2.0) == ms.GGX_EAVG_TABLE[-1] and ms.ggx_eavg(-1.0) == ms.GGX_EAVG_TABLE[0]


def test_compensation_closes_the_white_furnace():
    """With F = 1 (F_ss = 1, F_ms = 1) the compensated lobe's albedo is E (1 + (1 - E)/E) = 1 for every mu."""
    for r in (0.3, 0.6, 1.0):
        mu = np.linspace(0.05, 1.0, 7)
        assert np.allclose(ms.ggx_e(r, mu) * ms.lobe_scale(1.0, r, mu), 1.0)
        assert np.allclose(ms.layer_factor(1.0, r, mu), 1.0)
    # a dark Fresnel gains little: F_ms -> 0 as F_ss -> 0
    assert np.allclose(ms.lobe_scale(0.0, 1.0, 0.5), 1.0)
    assert float(ms.multiscatter_fresnel(0.5, 1.0)) < 0.5


def test_dielectric_fss_is_cycles_fit():
    from compare.mitsuba.principled import FSS_DIELECTRIC

    assert FSS_DIELECTRIC == pytest.approx(0.5 / (4.08567 + 1.00071 * 1.5))
    # the fit is the hemispherical average of the exact Fresnel within a few 1e-3
    from compare.mitsuba.principled import fresnel_dielectric

    mu = np.linspace(0.0, 1.0, 20001)
    exact = np.trapezoid(2.0 * mu * fresnel_dielectric(mu, 1.5), mu)
    assert FSS_DIELECTRIC == pytest.approx(exact, abs=3e-3)
