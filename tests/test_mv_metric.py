"""model-viewer's fidelity number (compare.metrics.model_viewer): closed forms of pixelmatch's YIQ distance,
the dB figure by hand, the degenerate cases, and the metric in a run's results.json and report."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from compare.image.tonemap import srgb_decode, to_ldr
from compare.metrics import images as M
from compare.metrics.model_viewer import (FIDELITY_TEST_THRESHOLD_DB, MAX_YIQ_DELTA, MV_DB_FLOOR, decibel,
                                          rms_distance_ratio, yiq_delta)
from compare.metrics.table import higher_is_better, known
from compare.util.errors import ImageError

# pixelmatch's Y row sums to 1.00000001; its I and Q rows sum to 0, so a grey offset changes Y only.
Y_SUM = 0.29889531 + 0.58662247 + 0.11448223


def _levels(h=12, w=16, lo=40, hi=200) -> np.ndarray:
    """8-bit grey-and-colour levels that vary over the image (not a constant, so LDR metrics are defined)."""
    k = np.linspace(lo, hi, h * w * 3).round().reshape(h, w, 3)
    return k


def _hdr_of_levels(k: np.ndarray) -> np.ndarray:
    """Linear values that tone-map (operator "clamp", sRGB) back to exactly the 8-bit levels ``k``."""
    return srgb_decode(k / 255.0).astype(np.float32)


# --------------------------------------------------------------------------- pixelmatch's YIQ distance


def test_black_against_white_is_the_luminance_term_only():
    # ΔY = 255 · 1.00000001, ΔI = ΔQ = 0: δ = 0.5053 · 255², not the maximum 35215.
    d = float(yiq_delta([0, 0, 0], [255, 255, 255]))
    assert d == pytest.approx(0.5053 * (255 * Y_SUM) ** 2, rel=1e-12)
    assert d == pytest.approx(32857.133, abs=1e-3)


def test_the_maximum_35215_is_red_against_cyan():
    assert float(yiq_delta([255, 0, 0], [0, 255, 255])) == pytest.approx(35214.749, abs=1e-3)
    assert round(float(yiq_delta([0, 255, 255], [255, 0, 0]))) == MAX_YIQ_DELTA
    # no pair of 8-bit colours goes beyond it: every corner of the RGB cube against every other
    corners = np.array([[r, g, b] for r in (0, 255) for g in (0, 255) for b in (0, 255)], dtype=float)
    all_pairs = yiq_delta(np.broadcast_to(corners[:, None, :], (8, 8, 3)), np.broadcast_to(corners[None], (8, 8, 3)))
    assert all_pairs.max() == pytest.approx(35214.749, abs=1e-3) and all_pairs.max() <= MAX_YIQ_DELTA


@pytest.mark.parametrize("grey, step", [(0, 1), (100, 10), (40, 37), (254, 1)])
def test_a_pure_luminance_difference_is_0_5053_dy_squared(grey, step):
    d = float(yiq_delta([grey] * 3, [grey + step] * 3))
    assert d == pytest.approx(0.5053 * (step * Y_SUM) ** 2, rel=1e-9)
    assert d == pytest.approx(0.5053 * step * step, rel=1e-7)


def test_one_channel_step_by_hand():
    # (10, 0, 0): ΔY = 2.9889531, ΔI = 5.9597799, ΔQ = 2.1147017;
    # 0.5053 · 8.93384 + 0.299 · 35.51898 + 0.1957 · 4.47196 = 16.00961
    assert float(yiq_delta([10, 0, 0], [0, 0, 0])) == pytest.approx(16.00961, abs=1e-5)
    assert float(yiq_delta([0, 0, 0], [10, 0, 0])) == pytest.approx(16.00961, abs=1e-5)  # unsigned


def test_alpha_blends_with_white():
    # transparent black is white; half-transparent black is grey 127.5
    assert float(yiq_delta([0, 0, 0, 0], [255, 255, 255])) == pytest.approx(0.0, abs=1e-9)
    half = float(yiq_delta([0, 0, 0, 127.5], [255, 255, 255, 255]))
    assert half == pytest.approx(0.5053 * (127.5 * Y_SUM) ** 2, rel=1e-9)


def test_identical_pixels_have_no_distance():
    k = _levels()
    assert np.all(yiq_delta(k, k) == 0.0)
    assert rms_distance_ratio(k, k) == 0.0 and decibel(0.0) == MV_DB_FLOOR


# --------------------------------------------------------------------------- the dB figure


def test_a_uniform_offset_by_hand():
    """Every pixel 10 levels brighter: δ = 0.5053 · 10² in every pixel, so sqrt(mean δ²) = δ and
    10 · log10(50.53 / 35215) = −28.432 dB."""
    k = _levels()
    ref, test = _hdr_of_levels(k), _hdr_of_levels(k + 10)
    # the tone mapping gives back exactly these 8-bit levels
    assert np.array_equal(np.round(to_ldr(ref, operator="clamp") * 255.0), k)
    assert np.array_equal(np.round(to_ldr(test, operator="clamp") * 255.0), k + 10)
    expected = 10.0 * math.log10(0.5053 * (10 * Y_SUM) ** 2 / 35215.0)
    assert expected == pytest.approx(-28.4318, abs=1e-4)
    assert M.mv_rms_db(ref, test, operator="clamp") == pytest.approx(expected, abs=1e-9)
    assert M.compare_images(ref, test, operator="clamp", flip_hdr=False)["mv_rms_db"] == pytest.approx(expected,
                                                                                                       abs=1e-9)
    # the RMS of δ: half the pixels at 20 levels (δ four times as large), half unchanged
    half = k.copy()
    half[:6] += 20
    delta20 = 0.5053 * (20 * Y_SUM) ** 2
    assert rms_distance_ratio(half, k) == pytest.approx(math.sqrt(delta20 ** 2 / 2) / 35215.0, rel=1e-12)


def test_it_grows_with_the_error_and_stays_in_its_range():
    k = _levels()
    ref = _hdr_of_levels(k)
    values = [M.mv_rms_db(ref, _hdr_of_levels(np.minimum(k + s, 255)), operator="clamp") for s in (1, 4, 16, 50)]
    assert all(MV_DB_FLOOR < v < 0.0 for v in values) and np.all(np.diff(values) > 0), values
    assert decibel(1.0) == 0.0  # the largest error everywhere


def test_identical_images_get_the_floor_not_minus_infinity():
    ref = _hdr_of_levels(_levels())
    assert M.mv_rms_db(ref, ref) == MV_DB_FLOOR
    res = M.compare_images(ref, ref, flip_hdr=False)
    assert res["mv_rms_db"] == MV_DB_FLOOR
    json.dumps(res, allow_nan=False)
    # one 8-bit step of blue in one pixel is still above the floor
    k = _levels()
    one = k.copy()
    one[3, 4, 2] += 1
    assert decibel(rms_distance_ratio(one, k)) > MV_DB_FLOOR


@pytest.mark.parametrize("case", ["black", "saturated", "flat grey"])
def test_a_degenerate_ground_truth_has_no_score_never_a_perfect_one(case):
    """A black pair is identical in 8 bits, and would get the floor (the best score) if it were measured."""
    shape = (12, 16, 3)
    exposure = 1.0
    if case == "black":
        ref = test = np.zeros(shape, np.float32)
    elif case == "saturated":
        ref, test, exposure = _hdr_of_levels(_levels()), _hdr_of_levels(_levels()) * 2, 1e39
    else:
        ref = test = np.full(shape, 0.18, np.float32)
    assert M.mv_rms_db(ref, test, exposure=exposure) is None
    res = M.compare_images(ref, test, exposure=exposure, flip_hdr=False)
    assert res["mv_rms_db"] is None and res["ldr_range"] < M.LDR_DEGENERATE_RANGE
    assert "mv_rms_db" in M.LDR_METRICS


def test_a_black_test_image_against_a_lit_ground_truth_scores_badly():
    # model-viewer refuses a colorless candidate; here it is a real error, far above its bound
    ref = _hdr_of_levels(_levels())
    v = M.mv_rms_db(ref, np.zeros_like(ref), operator="clamp")
    assert v is not None and FIDELITY_TEST_THRESHOLD_DB < v < 0.0


# --------------------------------------------------------------------------- the model's pixels


def test_the_candidates_alpha_and_a_mask_choose_the_model_pixels():
    k = _levels()
    bright = np.minimum(k + 30, 255)
    test = bright.copy()
    test[:, :8] = k[:, :8]  # left half right, right half 30 levels off
    rgba = np.concatenate([test, np.full(k.shape[:2] + (1,), 255.0)], axis=-1)
    rgba[:, 8:, 3] = 0  # model-viewer skips pixels the candidate leaves transparent
    assert rms_distance_ratio(rgba, k) == 0.0
    mask = np.zeros(k.shape[:2], bool)
    mask[:, 8:] = True
    assert rms_distance_ratio(test, k, mask=mask) == pytest.approx(rms_distance_ratio(bright[:, 8:], k[:, 8:]))
    assert rms_distance_ratio(test, k) == pytest.approx(rms_distance_ratio(bright, k) / math.sqrt(2))
    with pytest.raises(ImageError, match="no model pixels"):
        rms_distance_ratio(test, k, mask=np.zeros(k.shape[:2], bool))
    with pytest.raises(ImageError, match="mask"):
        rms_distance_ratio(test, k, mask=np.ones((3, 3), bool))


# --------------------------------------------------------------------------- inputs refused


def test_nan_is_refused_as_the_other_metrics_refuse_it():
    ref = _hdr_of_levels(_levels())
    bad = ref.copy()
    bad[4, 9, 1] = np.nan
    bad[2, 3, 0] = np.inf
    with pytest.raises(ImageError) as err:
        M.mv_rms_db(ref, bad)
    assert str(err.value).startswith("test:") and "2 non-finite value(s) (1 NaN, 1 Inf)" in str(err.value)
    with pytest.raises(ImageError, match="NaN"):
        yiq_delta([np.nan, 0, 0], [0, 0, 0])
    with pytest.raises(ImageError, match=r"\[0, 255\]"):
        yiq_delta([256, 0, 0], [0, 0, 0])
    with pytest.raises(ImageError, match="shapes differ"):
        yiq_delta(np.zeros((2, 3)), np.zeros((3, 3)))
    for r in (math.nan, math.inf, -0.1):
        with pytest.raises(ValueError):
            decibel(r)


# --------------------------------------------------------------------------- the table, a run, the report


def test_the_metric_has_its_row():
    from compare.report.html import TABLE_METRICS

    assert known("mv_rms_db") and not higher_is_better("mv_rms_db")
    assert ("mv_rms_db", "model-viewer RMS (dB)", 4) in TABLE_METRICS


def test_a_small_run_records_it_at_every_checkpoint_and_the_report_explains_it(tmp_path):
    from compare.report.check import check
    from tests.helpers import CORNELL, synthetic_report

    res = synthetic_report(tmp_path / "out", [CORNELL], size=(16, 12), frames=2, spp=2)
    data = json.loads((tmp_path / "out" / "results.json").read_text(encoding="utf-8"))
    values = []
    for scene in data["scenes"]:
        for run in scene["runs"]:
            for point in run["points"]:
                values.append(point["metrics"]["mv_rms_db"])
    assert values and all(isinstance(v, float) and MV_DB_FLOOR <= v <= 0.0 for v in values), values
    html = (tmp_path / "out" / "index.html").read_text(encoding="utf-8")
    assert "model-viewer RMS (dB)" in html and "pixelmatch" in html and "−22 dB" in html
    # compare check bounds it like any metric
    violations, checked = check(res, {"schema": 1, "rule": [{"renderer": "*", "max": {"mv_rms_db": -1000.0}}]})
    assert checked and len(violations) == checked


def test_a_run_whose_ground_truth_tone_maps_to_black_has_no_score(tmp_path):
    from compare.report.check import check
    from tests.helpers import CORNELL, synthetic_report

    res = synthetic_report(tmp_path / "out", [CORNELL], size=(16, 12), frames=2, spp=2, exposure=1e-30)
    points = [p for r in res.scenes[0].runs for p in r.points]
    assert points and all(p.metrics["mv_rms_db"] is None for p in points)
    violations, _ = check(res, {"schema": 1, "rule": [{"renderer": "*", "max": {"mv_rms_db": 0.0}}]})
    assert violations and all("tone-maps to a constant" in str(v) for v in violations)
