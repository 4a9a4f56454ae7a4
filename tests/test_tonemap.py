"""Tests of compare.image.tonemap: exposure, operators, transfers, to_ldr, write_png."""

from __future__ import annotations

import functools
import math
import warnings

import numpy as np
import pytest

from compare.image import tonemap as tm
from compare.util.errors import ImageError

# Values every operator must survive without NaN/Inf or a floating-point warning.
EXTREMES = [0.0, -0.0, 1e-40, 1e-30, 1e-8, 0.5, 1.0, 1e4, 1e30, -1e-40, -1.0, -1e30]

OPERATOR_NAMES = sorted(tm.OPERATORS)


def _extreme_rgb(dtype) -> np.ndarray:
    """Every extreme value as a grey pixel and in each channel alone."""
    rows = []
    for v in EXTREMES:
        rows += [[v, v, v], [v, 0.0, 0.0], [0.0, v, 0.0], [0.0, 0.0, v], [v, 1.0, -v]]
    return np.array(rows, dtype=dtype)


@pytest.fixture
def strict_fp():
    """Turn numpy floating-point warnings (overflow, invalid, divide) into errors."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(over="raise", invalid="raise", divide="raise"):
            yield


# --------------------------------------------------------------------------- operators


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("name", OPERATOR_NAMES)
def test_operator_finite_and_non_negative_on_extremes(name, dtype, strict_fp):
    op, _ = tm.OPERATORS[name]
    y = op(_extreme_rgb(dtype))
    assert y.dtype == np.float32
    assert np.all(np.isfinite(y)), y
    assert np.all(y >= 0)
    assert not np.any(np.signbit(y)), "negative zero leaked through"


@pytest.mark.parametrize("func", [tm.srgb_encode, tm.srgb_decode, tm.gamma_encode, tm.reinhard,
                                  tm.hejl_burgess_dawson, tm.hable, tm.aces_narkowicz])
def test_per_channel_functions_on_scalar_extremes(func, strict_fp):
    for v in EXTREMES:
        y = func(np.float32(v))
        assert np.isfinite(y) and y >= 0, (func.__name__, v, y)


@pytest.mark.parametrize("name", OPERATOR_NAMES)
def test_operator_monotone_on_grey_ramp(name):
    op, _ = tm.OPERATORS[name]
    x = np.geomspace(1e-6, 1e4, 3000)
    y = op(np.repeat(x[:, None], 3, axis=1))
    assert np.all(np.diff(y[:, 0].astype(np.float64)) >= 0)
    # Hill's published output matrix has a row summing to 0.99999, hence atol.
    assert np.allclose(y[:, 0], y[:, 1], atol=2e-5) and np.allclose(y[:, 0], y[:, 2], atol=2e-5), "grey must stay grey"


@pytest.mark.parametrize("func", [tm.reinhard, tm.reinhard_extended, tm.hejl_burgess_dawson, tm.hable,
                                  tm.aces_narkowicz, tm.srgb_encode, tm.srgb_decode, tm.gamma_encode])
def test_per_channel_functions_monotone(func):
    x = np.linspace(-1.0, 50.0, 5001)
    assert np.all(np.diff(func(x).astype(np.float64)) >= 0)


@pytest.mark.parametrize("name", OPERATOR_NAMES)
@pytest.mark.parametrize("transfer", sorted(tm.TRANSFERS))
def test_to_ldr_in_unit_interval(name, transfer, strict_fp):
    for exposure in (1e-3, 1.0, 1e3):
        y = tm.to_ldr(_extreme_rgb(np.float32), exposure=exposure, operator=name, transfer=transfer)
        assert y.dtype == np.float32
        assert np.all((y >= 0) & (y <= 1))


def test_known_values():
    assert tm.reinhard(1.0) == pytest.approx(0.5)
    assert tm.reinhard(0.0) == 0.0
    assert tm.reinhard_extended(4.0, white=4.0) == pytest.approx(1.0)
    assert tm.reinhard_extended(2.0, white=math.inf) == pytest.approx(tm.reinhard(2.0))
    # Narkowicz: pre-exposed so that 1 maps to about 0.8.
    assert tm.aces_narkowicz(1.0) == pytest.approx(2.54 / 3.16, rel=1e-6)
    # Hable: the white point maps to exactly 1 (with the exposure bias inside).
    assert tm.hable(tm.HABLE_WHITE / 2.0) == pytest.approx(1.0, rel=1e-6)
    assert tm.hable(tm.HABLE_WHITE, exposure_bias=1.0) == pytest.approx(1.0, rel=1e-6)
    assert tm.hable(0.0) == 0.0
    assert tm.hejl_burgess_dawson(0.004) == 0.0
    assert tm.hejl_burgess_dawson(1e6) == pytest.approx(1.0, abs=1e-5)
    assert np.all(tm.aces(np.zeros(3)) == 0.0)
    assert np.allclose(tm.aces(np.full(3, 1e6)), 1.0)


def test_srgb_known_values_and_inverse():
    # Both pieces meet at the breakpoint: 12.92 * 0.0031308 = 0.0404499...
    assert tm.srgb_encode(0.0031308) == pytest.approx(0.04045, abs=1e-6)
    assert tm.srgb_encode(1.0) == pytest.approx(1.0, abs=1e-7)
    assert tm.srgb_encode(0.0) == 0.0
    assert tm.srgb_encode(0.18) == pytest.approx(0.46135612950044164, rel=1e-6)
    x = np.linspace(0.0, 1.0, 1001)
    assert np.allclose(tm.srgb_decode(tm.srgb_encode(x)), x, atol=1e-6)
    assert tm.gamma_encode(0.5, 2.2) == pytest.approx(0.5 ** (1 / 2.2))


def test_reinhard_luminance_preserves_hue_and_black():
    rgb = np.array([[0.0, 0.0, 0.0], [2.0, 1.0, 0.5], [-1.0, 0.5, 0.25]])
    y = tm.reinhard_luminance(rgb)
    assert np.all(y[0] == 0.0)
    assert y[1] / y[1][0] == pytest.approx(rgb[1] / rgb[1][0], rel=1e-6)
    lum = tm.luminance(rgb[1])
    assert tm.luminance(y[1]) == pytest.approx(lum / (1 + lum), rel=1e-6)
    assert np.all(y[2] >= 0) and y[2][0] == 0.0  # negative clamped first


# --------------------------------------------------------------------------- exposure


def test_exposure_conventions():
    assert tm.ev100_from_camera(1.0, 1.0, 100) == 0.0
    assert tm.ev100_from_camera(16, 1 / 100, 100) == pytest.approx(math.log2(25600))
    assert tm.ev100_from_camera(1.0, 1.0, 200) == pytest.approx(-1.0)
    assert tm.exposure_from_ev(0.0) == pytest.approx(1 / 1.2)
    assert tm.exposure_from_ev(1.0) == pytest.approx(tm.exposure_from_ev(0.0) / 2)
    assert tm.exposure_scale(aperture=1.0, shutter_s=1.0, iso=100) == pytest.approx(1 / 1.2)
    assert tm.exposure_scale(ev100=3.0, compensation_ev=1.0) == pytest.approx(2 * tm.exposure_from_ev(3.0))


@pytest.mark.parametrize(
    "kwargs",
    [{}, {"ev100": 1.0, "iso": 100}, {"aperture": 2.0, "iso": 100}, {"ev100": math.nan}],
)
def test_exposure_scale_rejects_ambiguous_calls(kwargs):
    with pytest.raises(ValueError):
        tm.exposure_scale(**kwargs)


@pytest.mark.parametrize("args", [(0, 1, 100), (1, -1, 100), (1, 1, math.inf)])
def test_ev100_rejects_bad_camera(args):
    with pytest.raises(ValueError):
        tm.ev100_from_camera(*args)


# --------------------------------------------------------------------------- to_ldr


def test_to_ldr_skips_transfer_for_display_encoded_operator():
    x = np.linspace(0, 4, 30).reshape(10, 1, 3)
    assert np.array_equal(
        tm.to_ldr(x, operator="hejl_burgess_dawson"), np.clip(tm.hejl_burgess_dawson(x), 0, 1)
    )
    # A linear-output operator does get the sRGB transfer.
    assert np.allclose(tm.to_ldr(x, operator="reinhard"), np.clip(tm.srgb_encode(tm.reinhard(x)), 0, 1))


def test_to_ldr_exposure_and_callable_operator():
    x = np.full((2, 2, 3), 0.5, dtype=np.float32)
    assert np.allclose(tm.to_ldr(x, exposure=2.0, operator="clamp", transfer="linear"), 1.0)
    op = functools.partial(tm.reinhard_extended, white=1.0)
    assert np.allclose(tm.to_ldr(np.ones((1, 1, 3)), operator=op, transfer="linear"), 1.0)


def test_to_ldr_refuses_nan_and_bad_arguments():
    img = np.zeros((4, 4, 3), dtype=np.float32)
    img[1, 2, 0] = np.nan
    with pytest.raises(ImageError, match=r"1 non-finite.*row 1, col 2, channel 0"):
        tm.to_ldr(img)
    ok = np.zeros((4, 4, 3))
    with pytest.raises(ValueError, match="unknown operator"):
        tm.to_ldr(ok, operator="filmic")
    with pytest.raises(ValueError, match="unknown transfer"):
        tm.to_ldr(ok, transfer="rec2020")
    with pytest.raises(ValueError, match="exposure"):
        tm.to_ldr(ok, exposure=0.0)
    with pytest.raises(ImageError, match="last axis"):
        tm.to_ldr(np.zeros((4, 4)))


# --------------------------------------------------------------------------- write_png


def test_write_png(tmp_path):
    import imageio.v3 as iio

    h, w = 32, 48
    x = np.geomspace(1e-3, 50, w, dtype=np.float32)
    img = np.stack([np.tile(x, (h, 1)), np.tile(x[::-1], (h, 1)), np.full((h, w), 0.2, np.float32)], axis=-1)
    out = tm.write_png(tmp_path / "sub" / "preview.png", img, exposure=0.5, operator="hable")
    assert out == tmp_path / "sub" / "preview.png"
    back = iio.imread(out)
    assert back.shape == (h, w, 3) and back.dtype == np.uint8
    expected = np.round(tm.to_ldr(img, exposure=0.5, operator="hable") * 255).astype(np.uint8)
    assert np.array_equal(back, expected)
    assert sorted(p.name for p in out.parent.iterdir()) == ["preview.png"]  # no temp files


def test_write_png_refuses_nan_and_leaves_nothing(tmp_path):
    img = np.ones((8, 8, 3), dtype=np.float32)
    img[2, 3, 1] = np.inf
    with pytest.raises(ImageError, match=r"row 2, col 3, channel 1"):
        tm.write_png(tmp_path / "bad.png", img)
    assert list(tmp_path.iterdir()) == []
