"""``--spp auto``: a ground truth that renders passes until its own noise, measured from their spread, is low
enough (compare/image/convergence.py), with a cap."""

from __future__ import annotations

import json

import numpy as np
import pytest

from compare.image.convergence import EPS, PassSpread, StopRule, Stopping
from compare.mitsuba.reference import ReferenceRenderer
from compare.report.results import Results, RunSettings
from compare.run import runner as run_mod
from compare.scene.loader import parse_scene
from tests.helpers import ROOT

SIZE = [32, 24]


def lit_floor(size=SIZE):
    """A grey Lambert floor under a large square light, seen from above: direct light only, few spp suffice."""
    return parse_scene({
        "camera": {"position": [0, 2.0, 1.6], "target": [0, 0, 0], "fov": 40, "resolution": list(size)},
        "materials": {"grey": {"base_color": [0.5, 0.5, 0.5], "roughness": 1.0}},
        "meshes": [{"shape": "quad", "size": [8, 8], "material": "grey"}],
        "lights": [{"center": [0, 2, 0], "size": [1, 1], "normal": [0, -1, 0], "radiance": [10, 10, 10]}],
    }, ROOT / "tests" / "lit-floor.toml")


def glass_caustic(size=SIZE):
    """A glass ball on a floor, lit by a small lamp behind it: its shadow holds a caustic, light that reaches
    the floor only through the glass, which a path tracer finds only when a path from the floor happens to
    refract onto the lamp (no light sampling through glass)."""
    return parse_scene({
        "camera": {"position": [0, 2.2, 2.4], "target": [0, 0.2, 0.6], "fov": 40, "resolution": list(size)},
        "materials": {"floor": {"base_color": [0.8, 0.8, 0.8], "roughness": 1.0},
                      "glass": {"base_color": [1, 1, 1], "roughness": 0.0, "transmission": 1.0, "ior": 1.5,
                                "thickness": 1.0}},
        "meshes": [{"shape": "quad", "size": [6, 6], "material": "floor"},
                   {"shape": "sphere", "radius": 0.5, "translate": [0, 0.5, 0], "material": "glass"}],
        "lights": [{"center": [0, 2, -1.2], "size": [0.3, 0.3], "normal": [0, -0.857, 0.514],
                    "radiance": [250, 250, 250]}],
        "render": {"max_depth": 8},
    }, ROOT / "tests" / "glass-caustic.toml")


def _until(scene, rule):
    """(the last checkpoint, the stopping record) of a reference render under ``rule``."""
    rr = ReferenceRenderer(scene, cache_dir=False, progress=False)
    stopping = Stopping(rule)
    *_, last = rr.iter_checkpoints([rule.cap], 0, until=stopping)
    return rr, last, stopping.record()


def test_the_estimate_is_the_relative_standard_error_of_the_mean():
    """Passes of unequal sizes drawn with a known per-sample spread: the estimate is the standard error of
    their mean over sqrt(mean² + ε), ε relMSE's."""
    from compare.metrics.images import RELMSE_EPS

    assert EPS == RELMSE_EPS
    rng = np.random.default_rng(1)
    mean, sigma, sizes = 0.5, 0.2, [1, 1, 2, 4, 8, 16, 32, 64, 64]
    spread = PassSpread()
    for n in sizes:  # the mean of n samples of luminance y has a standard deviation sigma / sqrt(n)
        y = mean + sigma / np.sqrt(n) * rng.standard_normal((200, 300))
        spread.add(np.repeat(y[..., None], 3, axis=-1), n)
    rel = spread.relative_standard_error()
    want = sigma / np.sqrt(sum(sizes)) / np.sqrt(mean ** 2 + EPS)
    assert rel.shape == (200, 300)
    assert abs(np.median(rel) / want - 1) < 0.05, (np.median(rel), want)
    one = PassSpread()
    one.add(np.ones((2, 2, 3)), 4)
    assert one.estimate(StopRule()) is None  # one pass says nothing about its noise


def test_the_rule_refuses_a_meaningless_target_or_cap():
    for bad in ({"target": 0.0}, {"target": float("nan")}, {"cap": 0}, {"min_spp": True}, {"percentile": 0}):
        with pytest.raises(ValueError):
            StopRule(**bad)


def test_a_diffuse_floor_stops_early_with_its_estimate_under_the_target(mi_llvm):
    rule = StopRule(cap=1024)
    rr, last, record = _until(lit_floor(), rule)
    print("lit floor:", record["history"])
    assert last.step <= 64 and record["spp"] == last.step
    assert record["met"] and record["estimate"] <= rule.target
    assert all(e > rule.target for _, e in record["history"][:-1])  # it stopped at the first sum that met it
    # the same passes as a fixed budget of the spp it reached: the same image, bit for bit
    fixed = list(rr.iter_checkpoints([last.step], 0))[-1]
    np.testing.assert_array_equal(fixed.image, last.image)


def test_a_caustic_is_not_converged_at_1024_spp(mi_llvm):
    rule = StopRule(cap=2048)
    _, last, record = _until(glass_caustic(), rule)
    print("glass caustic:", record["history"])
    assert last.step == 2048 and not record["met"]  # past 1024 spp, to the cap, without meeting the target
    at = dict(record["history"])
    assert at[1024] > 2 * rule.target and record["estimate"] > rule.target


def test_a_run_with_spp_auto_records_the_criterion_and_gives_the_noise_floor_its_spp(tmp_path, mi_llvm):
    settings = RunSettings(spp_auto=True, spp_cap=256, renderers=["mitsuba"])
    res = run_mod.run([lit_floor([16, 12])], tmp_path / "o", settings, progress=False, cache_dir=tmp_path / "cache")
    (scene,) = res.scenes
    c = scene.reference.convergence
    assert c["met"] and c["estimate"] <= settings.spp_target and c["cap"] == 256
    assert scene.reference.spp == c["spp"] == scene.noise_floor.spp == scene.run("mitsuba").steps <= 64
    assert "95th percentile" in c["criterion"]
    again = Results.load(tmp_path / "o" / "results.json")  # the schema holds it
    assert again.scenes[0].reference.convergence == c
    assert json.loads((tmp_path / "o" / "results.json").read_text())["settings"]["spp_auto"] is True
    page = (tmp_path / "o" / "index.html").read_text()
    assert f"the ground truth stopped at {c['spp']} spp" in page and ": met." in page
