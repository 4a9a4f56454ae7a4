"""Tests of compare.metrics.images: identities, ranking of graded errors, input guards."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from compare.image.maps import save_maps
from compare.metrics import images as M
from compare.metrics.model_viewer import MV_DB_FLOOR
from compare.util.errors import ImageError

H, W = 48, 64


@pytest.fixture(scope="module")
def reference() -> np.ndarray:
    """A small HDR scene: a checkerboard of dark and bright squares over a ramp, with texture."""
    rng = np.random.default_rng(3)
    y, x = np.mgrid[0:H, 0:W]
    checker = np.where(((y // 8) + (x // 8)) % 2 == 0, 0.05, 2.0)
    ramp = np.linspace(0.0, 4.0, W)[None, :]
    base = checker + ramp
    tint = np.array([1.0, 0.8, 0.6])
    texture = rng.lognormal(0.0, 0.25, size=(H, W, 3))
    return (base[..., None] * tint * texture).astype(np.float32)


def _noisy(ref: np.ndarray, sigma: float) -> np.ndarray:
    # Relative noise, as Monte Carlo noise scales with radiance; fixed seed so
    # every sigma perturbs the same pixels in the same direction.
    rng = np.random.default_rng(11)
    return np.maximum(ref * (1.0 + sigma * rng.standard_normal(ref.shape)), 0.0).astype(np.float32)


def _blurred(ref: np.ndarray, sigma: float) -> np.ndarray:
    return gaussian_filter(ref, sigma=(sigma, sigma, 0)).astype(np.float32)


# --------------------------------------------------------------------------- identities


def test_identical_images(reference):
    assert M.mse(reference, reference) == 0.0
    assert M.relmse(reference, reference) == 0.0
    assert M.ssim(reference, reference) == pytest.approx(1.0, abs=1e-12)
    assert M.psnr(reference, reference) == math.inf  # documented: inf, no warning
    mean, fmap, params = M.flip(reference, reference)
    assert mean == 0.0 and np.all(fmap == 0.0)
    assert M.flip(reference, reference, mode="HDR")[0] == 0.0

    res = M.compare_images(reference, reference)
    ldr_range = res.pop("ldr_range")
    assert res == {"mse": 0.0, "relmse": 0.0, "psnr": None, "ssim": pytest.approx(1.0),
                   "flip": 0.0, "flip_median": 0.0, "flip_p95": 0.0, "flip_hdr": 0.0,
                   "mv_rms_db": MV_DB_FLOOR}  # identical 8-bit images: model-viewer's number at its floor
    assert ldr_range > 0.5  # the checkerboard spans most of the LDR range
    json.dumps(res, allow_nan=False)  # strict JSON, psnr inf reported as null


@pytest.mark.parametrize("case", ["black", "exposure 1e39", "exposure 1e-30", "flat grey"])
def test_a_reference_that_tone_maps_to_a_constant_has_no_ldr_metrics(reference, case):
    """Nothing to compare: PSNR, SSIM and FLIP are None (never a perfect 1 or 0), HDR metrics stay."""
    ref, test, exposure = reference, reference * 1.5, 1.0
    if case == "black":
        ref, test = np.zeros_like(reference), np.zeros_like(reference)
    elif case == "flat grey":
        ref, test = np.full_like(reference, 0.18), np.full_like(reference, 0.18)
    else:
        exposure = float(case.split()[1])
    res = M.compare_images(ref, test, exposure=exposure)
    assert res["psnr"] is None and res["ssim"] is None and res["flip"] is None
    assert res["ldr_range"] < M.LDR_DEGENERATE_RANGE
    assert math.isfinite(res["mse"]) and math.isfinite(res["relmse"])
    json.dumps(res, allow_nan=False)
    # The same images at a sensible exposure are measured as usual.
    if case.startswith("exposure"):
        normal = M.compare_images(ref, test)
        assert normal["ssim"] < 1 and normal["flip"] > 0


def test_psnr_finite_for_different_images(reference):
    p = M.psnr(reference, _noisy(reference, 0.1))
    assert math.isfinite(p) and 10 < p < 60


# --------------------------------------------------------------------------- graded errors rank in order

# Metric name -> +1 if it grows with error, -1 if it shrinks.
DIRECTION = {"mse": 1, "relmse": 1, "psnr": -1, "ssim": -1, "flip": 1, "flip_hdr": 1}


@pytest.mark.parametrize(
    "perturb, levels",
    [(_noisy, [0.02, 0.05, 0.15, 0.4]), (_blurred, [0.5, 1.0, 2.0, 4.0])],
    ids=["noise", "blur"],
)
def test_graded_perturbations_rank_in_order(reference, perturb, levels):
    results = [M.compare_images(reference, perturb(reference, s)) for s in levels]
    for name, sign in DIRECTION.items():
        values = [r[name] for r in results]
        assert all(isinstance(v, float) and math.isfinite(v) for v in values), (name, values)
        steps = np.diff(values) * sign
        assert np.all(steps > 0), f"{name} does not rank {perturb.__name__} levels {levels}: {values}"
    # compare_images agrees with the single-metric functions.
    t = perturb(reference, levels[1])
    r1 = results[1]
    assert r1["mse"] == pytest.approx(M.mse(reference, t))
    assert r1["relmse"] == pytest.approx(M.relmse(reference, t))
    assert r1["psnr"] == pytest.approx(M.psnr(reference, t))
    assert r1["ssim"] == pytest.approx(M.ssim(reference, t))
    assert r1["flip"] == pytest.approx(M.flip(reference, t)[0])
    assert r1["flip_hdr"] == pytest.approx(M.flip(reference, t, mode="HDR")[0])


def test_relmse_definition_and_eps():
    ref = np.full((12, 12, 3), 0.1, np.float32)
    test = np.full((12, 12, 3), 0.2, np.float32)
    assert M.relmse(ref, test) == pytest.approx(0.01 / (0.01 + 1e-2), rel=1e-6)
    assert M.relmse(ref, test, eps=1e-3) == pytest.approx(0.01 / (0.01 + 1e-3), rel=1e-6)
    assert M.mse(ref, test) == pytest.approx(0.01, rel=1e-6)
    with pytest.raises(ValueError, match="eps"):
        M.relmse(ref, test, eps=0.0)


def test_ldr_metrics_depend_on_tonemapping(reference):
    t = _noisy(reference, 0.1)
    assert M.psnr(reference, t, exposure=0.25) != M.psnr(reference, t, exposure=4.0)
    assert M.ssim(reference, t, operator="reinhard") != M.ssim(reference, t, operator="aces")


# --------------------------------------------------------------------------- FLIP specifics


def test_flip_returns_map_and_parameters(reference):
    t = _noisy(reference, 0.1)
    mean, fmap, params = M.flip(reference, t, exposure=0.5, operator="hable")
    assert fmap.shape == (H, W) and fmap.dtype == np.float32
    assert 0.0 < mean < 1.0 and mean == pytest.approx(float(fmap.mean(dtype=np.float64)))
    assert params["mode"] == "LDR" and params["exposure"] == 0.5 and params["operator"] == "hable"
    assert params["ppd"] == pytest.approx(67.02, abs=0.01)

    mean_h, _, params_h = M.flip(reference, t, mode="hdr", parameters={"ppd": 40})
    assert params_h["mode"] == "HDR" and params_h["ppd"] == 40.0
    assert params_h["startExposure"] <= params_h["stopExposure"] and params_h["numExposures"] >= 2
    json.dumps(params_h, allow_nan=False)


def test_flip_hdr_black_reference_raises_instead_of_exiting():
    black = np.zeros((16, 16, 3), np.float32)
    lit = np.full((16, 16, 3), 0.5, np.float32)
    # flip_evaluator itself would call std::exit(-1) here and kill pytest.
    with pytest.raises(ImageError, match="reference is black"):
        M.flip(black, lit, mode="HDR")
    mean, _, params = M.flip(black, lit, mode="HDR", parameters={"startExposure": -1.0, "stopExposure": 1.0})
    assert mean > 0 and params["numExposures"] == 2
    assert M.compare_images(black, lit)["flip_hdr"] is None


@pytest.mark.parametrize(
    "mode, parameters, match",
    [
        ("LDR", {"ppd": 0}, "ppd"),
        ("LDR", {"ppd": 60, "vc": [0.7, 3840, 0.7]}, "mutually exclusive"),
        ("LDR", {"vc": [0.7, -1, 0.7]}, "vc"),
        ("LDR", {"gamma": 2.2}, "unknown parameters"),
        ("LDR", {"startExposure": 0, "stopExposure": 1}, "only apply to mode='HDR'"),
        ("HDR", {"tonemapper": "filmic"}, "tonemapper"),
        ("HDR", {"startExposure": 2, "stopExposure": 1}, "startExposure <= stopExposure"),
        ("HDR", {"startExposure": 0}, "both"),
        ("HDR", {"numExposures": 1}, "numExposures"),
        ("XDR", {}, "mode"),
    ],
)
def test_flip_bad_parameters_raise_value_error(reference, mode, parameters, match):
    # flip_evaluator prints and calls sys.exit() for these; we raise instead.
    with pytest.raises(ValueError, match=match):
        M.flip(reference, reference, mode=mode, parameters=parameters)


# --------------------------------------------------------------------------- input guards


def _all_metric_calls():
    return {
        "mse": M.mse,
        "relmse": M.relmse,
        "psnr": M.psnr,
        "ssim": M.ssim,
        "flip": M.flip,
        "compare_images": M.compare_images,
        "error_maps": M.error_maps,
    }


@pytest.mark.parametrize("name", sorted(_all_metric_calls()))
def test_nan_guard_names_count_and_location(reference, name):
    bad = reference.copy()
    bad[4, 9, 1] = np.nan
    bad[20, 3, 0] = np.nan
    bad[30, 30, 2] = -np.inf
    func = _all_metric_calls()[name]
    with pytest.raises(ImageError) as err:
        func(reference, bad)
    msg = str(err.value)
    assert msg.startswith("test:")
    assert "3 non-finite value(s) (2 NaN, 1 Inf)" in msg
    assert "first at (row 4, col 9, channel 1)" in msg
    with pytest.raises(ImageError, match=r"^reference: 3 non-finite"):
        func(bad, reference)


@pytest.mark.parametrize("name", sorted(_all_metric_calls()))
def test_shape_mismatch_names_both_shapes(reference, name):
    func = _all_metric_calls()[name]
    with pytest.raises(ImageError, match=r"\(48, 64, 3\).*\(48, 32, 3\)"):
        func(reference, reference[:, :32])


def test_wrong_layout_refused(reference):
    with pytest.raises(ImageError, match=r"\(H, W, 3\)"):
        M.mse(reference[..., 0], reference[..., 0])
    with pytest.raises(ImageError, match="at least 11x11"):
        M.ssim(reference[:8, :8], reference[:8, :8])


def test_check_functions_directly():
    M.check_finite(np.zeros((2, 2, 3)), "x")
    M.check_finite(np.zeros((2, 2, 3), np.uint8), "x")
    with pytest.raises(ImageError, match=r"^img: 1 non-finite value\(s\) \(0 NaN, 1 Inf\).*row 1, col 0, channel 2"):
        a = np.zeros((2, 2, 3))
        a[1, 0, 2] = np.inf
        M.check_finite(a, "img")
    with pytest.raises(ImageError, match="real-valued"):
        M.check_finite(np.array(["a"]), "s")
    M.check_pair(np.zeros((3, 4, 3)), np.ones((3, 4, 3)))
    with pytest.raises(ImageError, match=r"reference has shape \(3, 4, 3\) but test has shape \(4, 3, 3\)"):
        M.check_pair(np.zeros((3, 4, 3)), np.zeros((4, 3, 3)))


# --------------------------------------------------------------------------- maps


def test_error_maps_and_png_output(reference, tmp_path):
    import imageio.v3 as iio

    t = _noisy(reference, 0.2)
    maps = M.error_maps(reference, t)
    assert set(maps) == {"flip", "one_minus_ssim", "relmse"}
    for name, m in maps.items():
        assert m.shape == (H, W), name
        assert np.all(np.isfinite(m)) and np.all(m >= -1e-12), name
    assert np.allclose(maps["one_minus_ssim"], 1.0 - M.ssim(reference, t, full=True)[1])
    assert maps["relmse"].mean() == pytest.approx(M.relmse(reference, t))
    assert np.array_equal(maps["flip"], M.flip(reference, t)[1])

    out = tmp_path / "maps"
    written = save_maps(out, maps, ranges=M.ERROR_MAP_RANGES, prefix="noisy_")
    assert sorted(p.name for p in out.iterdir()) == ["noisy_flip.png", "noisy_one_minus_ssim.png", "noisy_relmse.png"]
    for name, path in written.items():
        img = iio.imread(path)
        assert img.shape == (H, W, 3) and img.dtype == np.uint8, name
    # Zero error maps to magma's darkest colour, full error to its brightest.
    written = save_maps(out, {"ramp": np.linspace(0, 1, 64).reshape(8, 8)})
    ramp = iio.imread(written["ramp"]).astype(int)
    assert ramp[0, 0].sum() < 20 and ramp[-1, -1].sum() > 600


def test_save_error_maps_refuses_bad_maps(tmp_path):
    with pytest.raises(ImageError, match="non-finite"):
        save_maps(tmp_path, {"flip": np.array([[0.0, np.nan]])})
    with pytest.raises(ImageError, match=r"\(H, W\)"):
        save_maps(tmp_path, {"flip": np.zeros((2, 2, 3))})
    with pytest.raises(ValueError, match="file name"):
        save_maps(tmp_path, {"../escape": np.zeros((2, 2))})
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- FLIP pooling and HDR range


def test_flip_statistics_closed_forms():
    # 91 pixels of error 0.1 and 9 of 0.9: the total is 9.1 + 8.1, more than half of it at 0.1
    fmap = np.array([0.1] * 91 + [0.9] * 9).reshape(10, 10)
    st = M.flip_statistics(fmap)
    assert st["flip_median"] == pytest.approx(0.1)
    assert st["flip_p95"] == pytest.approx(0.9)
    # 50 pixels of 0.1, 50 of 0.3: three quarters of the error is in the 0.3 pixels
    st = M.flip_statistics(np.array([0.1] * 50 + [0.3] * 50))
    assert st["flip_median"] == pytest.approx(0.3) and st["flip_p95"] == pytest.approx(0.3)
    assert M.flip_statistics(np.zeros((4, 4))) == {"flip_median": 0.0, "flip_p95": 0.0}
    with pytest.raises(ImageError):
        M.flip_statistics(np.array([0.1, np.nan]))


def test_hdr_flip_range_is_the_references_and_fixed(reference):
    start, stop = M.hdr_exposure_range(reference)
    assert start < stop
    # what FLIP chooses from the reference is what hdr_exposure_range returns ...
    _, _, used = M.flip(reference, reference * 1.3, mode="HDR")
    assert (used["startExposure"], used["stopExposure"]) == pytest.approx((start, stop))
    # ... and with the range given, a test image on a black background does not move it
    test = np.zeros_like(reference)
    test[: reference.shape[0] // 2] = reference[: reference.shape[0] // 2]
    fixed = M.compare_images(reference, test, hdr_range=(start, stop))["flip_hdr"]
    assert fixed == pytest.approx(M.flip(reference, test, mode="HDR",
                                         parameters={"startExposure": start, "stopExposure": stop})[0])
    assert M.hdr_exposure_range(np.zeros_like(reference)) is None
