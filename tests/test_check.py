"""``compare check``: thresholds files, violations, exit codes, and the repository's own gate."""

from __future__ import annotations

import argparse
import tomllib

import numpy as np
import pytest

from compare.report.check import (
    ThresholdsError,
    assert_thresholds,
    check,
    load_thresholds,
)
from compare.cli.check import add_check_parser
from compare.util.errors import CompareError
from compare.report.results import Point, Reference, RendererRun, Results, RunSettings, SceneResult
from compare.run.runner import collect_machine
from tests.helpers import CORNELL, ROOT


def results() -> Results:
    prog = RendererRun("progressive", "Progressive", "frame", 8, "", 0.4, 0.05, points=[
        Point(1, 0.05, {"flip": 0.40, "ssim": 0.50, "relmse": 0.9, "psnr": 15.0, "flip_hdr": None}),
        Point(8, 0.40, {"flip": 0.20, "ssim": 0.80, "relmse": 0.3, "psnr": None, "flip_hdr": 0.5}),
    ])
    mits = RendererRun("mitsuba", "Mitsuba", "spp", 16, "", 2.0, 0.3, points=[
        Point(16, 2.0, {"flip": 0.05, "ssim": 0.95, "relmse": 0.02, "psnr": 30.0, "flip_hdr": 0.1}),
    ])
    scene = SceneResult("c-1-64x48", "Cornell box", "c.toml", "h", 64, 48, [], {}, Reference(16, 0, 2.0, "v"),
                        None, [mits, prog])
    return Results(RunSettings(), collect_machine(), [scene], created="now", compare_version="0")


def rules(*rule_tables: dict) -> dict:
    return {"schema": 1, "rule": list(rule_tables)}


def test_all_bounds_hold():
    violations, checked = check(results(), rules(
        {"scene": "Cornell box", "renderer": "progressive", "max": {"flip": 0.25, "relmse": 0.5},
         "min": {"ssim": 0.75}},
        {"scene": "*", "size": "64x48", "renderer": "mitsuba", "max": {"flip": 0.1, "seconds": 10}},
    ))
    assert violations == [] and checked == 5


def test_every_crossing_is_listed_readably():
    violations, checked = check(results(), rules(
        {"renderer": "progressive", "max": {"flip": 0.1, "relmse": 0.5}, "min": {"ssim": 0.9},
         "note": "regression gate"},
        {"renderer": "progressive", "step": 1, "max": {"flip": 0.3, "first_frame_seconds": 0.01}},
    ))
    text = [str(v) for v in violations]
    assert len(violations) == 4 and checked == 5
    assert text[0] == ("Cornell box 64x48 progressive (frame 8): flip = 0.2 > max 0.1  "
                       "[rule 1 (*, *, progressive, final) — regression gate]")
    assert "ssim = 0.8 < min 0.9" in text[1]
    assert "(frame 1): flip = 0.4 > max 0.3" in text[2]
    assert "first_frame_seconds = 0.05 > max 0.01" in text[3]


def test_missing_values_and_unmatched_rules_fail():
    violations, _ = check(results(), rules(
        {"renderer": "progressive", "max": {"mse_mean": 1.0}},  # only runs with --seeds have it
        {"renderer": "progressive", "min": {"psnr": 10.0}},  # null at the final checkpoint
        {"renderer": "progressive", "step": 3, "max": {"flip": 1.0}},  # no such checkpoint
        {"scene": "Cornell Box", "max": {"flip": 1.0}},  # wrong case: matches nothing
        {"renderer": "blender", "max": {"flip": 1.0}},
    ))
    text = "\n".join(map(str, violations))
    assert len(violations) == 5
    assert "mse_mean is not available" in text and "psnr is not available" in text
    assert "no checkpoint at frame 3" in text
    assert text.count("matched no result") == 2 and "'Cornell box' 64x48 [mitsuba, progressive]" in text


def test_malformed_thresholds_are_errors(tmp_path):
    bad = [
        {"schema": 2, "rule": [{"max": {"flip": 1}}]},
        {"rule": []},
        {"rules": [{"max": {"flip": 1}}]},
        rules({"maximum": {"flip": 1}}),
        rules({"renderer": "progressive"}),
        rules({"max": {"flip": "high"}}),
        rules({"max": {"flip": float("nan")}}),
        rules({"step": 0, "max": {"flip": 1}}),
        rules({"scene": 3, "max": {"flip": 1}}),
    ]
    for data in bad:
        with pytest.raises(ThresholdsError):
            load_thresholds(data)
    with pytest.raises(ThresholdsError, match=r"rule 1\.max\.flp: unknown metric; expected one of flip, "):
        load_thresholds(rules({"max": {"flp": 0.1}}))
    (tmp_path / "t.toml").write_text("[[rule]\nmax = 1")
    with pytest.raises(ThresholdsError, match="t.toml"):
        load_thresholds(tmp_path / "t.toml")
    with pytest.raises(ThresholdsError, match="no such file"):
        load_thresholds(tmp_path / "missing.toml")
    assert issubclass(ThresholdsError, CompareError)  # `compare` turns it into exit status 2


def test_assert_thresholds_helper():
    assert_thresholds(results(), rules({"renderer": "progressive", "max": {"flip": 0.25}}))
    with pytest.raises(AssertionError, match=r"1 threshold violation\(s\) out of 2 bound\(s\):\n  - .*flip = 0.2"):
        assert_thresholds(results(), rules({"renderer": "progressive", "max": {"flip": 0.1}, "min": {"ssim": 0.1}}))


def test_cli_exit_codes(tmp_path, capsys):
    path = results().save(tmp_path / "results.json")
    good, bad = tmp_path / "good.toml", tmp_path / "bad.toml"
    good.write_text('[[rule]]\nrenderer = "progressive"\nmax = { flip = 0.25 }\n')
    bad.write_text('[[rule]]\nrenderer = "progressive"\nmax = { flip = 0.1 }\nmin = { ssim = 0.9 }\n')
    parser = argparse.ArgumentParser(prog="compare")
    add_check_parser(parser.add_subparsers(dest="command", required=True))

    args = parser.parse_args(["check", str(path), "--thresholds", str(good)])
    assert args.func(args) == 0
    assert "all 1 bound(s) of 1 rule(s)" in capsys.readouterr().out

    args = parser.parse_args(["check", str(path), "--thresholds", str(bad)])
    assert args.func(args) == 1
    out = capsys.readouterr().out
    assert "2 threshold violation(s)" in out and "flip = 0.2 > max 0.1" in out and "ssim = 0.8 < min 0.9" in out


def test_repository_thresholds_file_is_valid():
    data = tomllib.loads((ROOT / "thresholds.toml").read_text(encoding="utf-8"))
    found = load_thresholds(ROOT / "thresholds.toml")
    assert found and all(r.scene == "Cornell box" for r in found)
    assert data["rule"][0]["size"] == CORNELL_TEST_SIZE


#: The resolution and budgets the repository's thresholds.toml was measured at.
CORNELL_TEST_SIZE = "64x48"
CORNELL_TEST_SETTINGS = dict(frames=32, spp=256, sizes=[[64, 48]], renderers=["mitsuba", "progressive"])


def test_cornell_box_meets_repository_thresholds(tmp_path, gl_ctx):
    """The CI gate: the built-in Cornell box at test resolution, real renderers, thresholds.toml."""
    from compare.run.runner import run

    res = run([CORNELL], tmp_path / "out", RunSettings(**CORNELL_TEST_SETTINGS),
              progress=False, cache_dir=tmp_path / "cache", gl_ctx=gl_ctx, report=False)
    assert_thresholds(res, ROOT / "thresholds.toml")


def test_a_degenerate_ground_truth_fails_the_gate_with_the_reason():
    """A ground truth that tone-maps to a constant has no LDR metrics (compare.metrics.images): a bound on
    them fails, saying why, instead of passing on SSIM 1 and FLIP 0; HDR metrics are still gated."""
    from compare.metrics.images import compare_images

    black = compare_images(np.zeros((16, 16, 3)), np.zeros((16, 16, 3)), flip_hdr=True)
    res = results()
    res.scenes[0].runs[1].points[-1] = Point(8, 0.40, black)
    violations, checked = check(res, rules({"renderer": "progressive", "max": {"flip": 0.25, "relmse": 0.5},
                                            "min": {"ssim": 0.75}}))
    assert checked == 3
    assert [str(v).split("  [")[0] for v in violations] == [
        "Cornell box 64x48 progressive (frame 8): flip is undefined: the ground truth tone-maps to a constant "
        "(LDR range 0 < 1/255: black, saturated or flat) at this exposure, so there is nothing to compare",
        "Cornell box 64x48 progressive (frame 8): ssim is undefined: the ground truth tone-maps to a constant "
        "(LDR range 0 < 1/255: black, saturated or flat) at this exposure, so there is nothing to compare"]


def test_gate_on_flip_pooling_and_fixed_hdr_flip(tmp_path, gl_ctx):
    """compare check bounds FLIP's weighted median and 95th percentile like any metric; compare run
    records the ground truth's HDR-FLIP exposure range and computes every HDR-FLIP with it."""
    from compare.run import runner as run_mod
    from compare.image.exr import read_exr
    from compare.metrics.images import flip, hdr_exposure_range

    res = run_mod.run([CORNELL], tmp_path / "r",
                      RunSettings(frames=4, spp=8, sizes=[[32, 24]]), progress=False,
                      cache_dir=tmp_path / "cache", gl_ctx=gl_ctx, report=False)
    (scene,) = res.scenes
    final = scene.run("progressive").final.metrics
    assert 0 < final["flip_median"] <= 1 and final["flip"] <= final["flip_p95"] <= 1
    violations, checked = check(res, rules({"renderer": "progressive", "max": {"flip_p95": final["flip_p95"] / 2,
                                                                             "flip_median": 1.0}}))
    assert checked == 2 and len(violations) == 1 and "flip_p95" in str(violations[0])
    gt = read_exr(tmp_path / "r" / scene.reference.image)[0]
    start, stop = scene.reference.flip_hdr_exposure
    assert (start, stop) == pytest.approx(hdr_exposure_range(gt))
    img = read_exr(tmp_path / "r" / scene.run("progressive").image)[0]
    fixed = flip(gt, img, mode="HDR", parameters={"startExposure": start, "stopExposure": stop})[0]
    assert final["flip_hdr"] == pytest.approx(fixed, rel=1e-6)
    assert Results.load(tmp_path / "r" / "results.json").scenes[0].reference.flip_hdr_exposure == [start, stop]
