"""Bias against noise (compare.metrics.bias and compare run --seeds)."""

from __future__ import annotations


import numpy as np
import pytest

from compare.run import runner as run_mod
from compare.metrics.bias import bias_variance
from compare.mitsuba.renderer import MitsubaRenderer
from compare.report.results import RunSettings
from tests.helpers import CORNELL


@pytest.mark.parametrize("k", [2, 4, 8])
def test_split_of_synthetic_renders(k):
    rng = np.random.default_rng(k)
    truth = rng.random((36, 48, 3))
    noisy = truth + rng.normal(0.0, 0.1, (k,) + truth.shape)
    none = bias_variance(noisy, truth)
    assert none["variance"] == pytest.approx(0.01, rel=0.1)
    assert abs(none["bias2"]) <= none["bias2_ci"]  # no bias: 0 within the interval
    offset = bias_variance(noisy + 0.05, truth)
    assert offset["bias2"] == pytest.approx(0.05**2, rel=0.2)
    assert offset["bias2"] - offset["bias2_ci"] > 0  # the bias is found
    assert offset["variance"] == pytest.approx(none["variance"])  # an offset is no noise
    # the truth's own variance is taken off
    assert bias_variance(noisy, truth, truth_variance=0.001)["bias2"] == pytest.approx(none["bias2"] - 0.001)
    with pytest.raises(ValueError, match="K >= 2"):
        bias_variance(noisy[:1], truth)


class OffsetMitsuba(MitsubaRenderer):
    """Mitsuba with a deliberate constant offset: a renderer with a known bias."""

    name = "mitsuba+offset"
    OFFSET = 0.1

    @property
    def label(self) -> str:
        return "Mitsuba + 0.1 (test)"

    def render(self, scene, **kw):
        out = super().render(scene, **kw)
        from compare.renderers import Checkpoint

        out.checkpoints = [Checkpoint(c.step, c.seconds, c.image + np.float32(self.OFFSET)) for c in out.checkpoints]
        return out


def test_a_known_bias_is_found_and_mitsuba_against_itself_has_none(tmp_path):
    """compare run --seeds 4: Mitsuba + 0.1 has bias² 0.1² (in MSE units) and is found biased; Mitsuba's
    own bias² is 0 within its interval once the ground truth's variance is taken off."""
    settings = RunSettings(frames=4, spp=128, sizes=[[32, 24]], renderers=["mitsuba", "mitsuba+offset"], seeds=4)
    res = run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, report=False,
                      cache_dir=tmp_path / "cache", renderers=[OffsetMitsuba()])
    (scene,) = res.scenes
    plain, offset = scene.run("mitsuba").final.metrics, scene.run("mitsuba+offset").final.metrics
    assert plain["seeds"] == 4 and plain["truth_variance"] > 0
    for m in (plain, offset):
        assert m["mse_mean"] > 0 and m["variance"] > 0 and m["bias2_ci"] > 0
    assert abs(plain["bias2"]) <= plain["bias2_ci"], plain
    assert abs(plain["rel_bias2"]) <= plain["rel_bias2_ci"], plain
    assert offset["bias2"] == pytest.approx(OffsetMitsuba.OFFSET**2, abs=offset["bias2_ci"]), offset
    assert offset["bias2"] - offset["bias2_ci"] > 0 and offset["rel_bias2"] - offset["rel_bias2_ci"] > 0
    # every checkpoint has the split, and the replicas are kept in their own units
    assert all("bias2" in p.metrics for p in scene.run("mitsuba").points)
    assert (tmp_path / "out" / "runs" / scene.id / "mitsuba-offset-seed3" / "render.json").is_file()


def test_report_shows_the_split_and_warns_within_the_noise_floor(tmp_path):
    """The report draws bias against noise for runs with seeds, states how the ground truth's noise
    compares with the smallest error it judges, and warns about a run whose error is within it."""
    from compare.report.html import _noise_check
    from compare.report.results import NoiseFloor, Point, Reference, RendererRun, SceneResult

    def run(name, relmse, flip):
        return RendererRun(name, name.title(), "frame", 8, "", 1.0, 0.1,
                           points=[Point(8, 1.0, {"relmse": relmse, "flip": flip})])

    nf = NoiseFloor("independent-full", 256, [0, 1], {"relmse": 0.004, "flip": 0.03}, 1e-4)
    scene = SceneResult("c", "Cornell box", "c.toml", "h", 32, 24, [], {}, Reference(256, 0, 1.0, "v"), nf,
                        [run("mitsuba", 0.004, 0.03), run("good", 0.003, 0.05), run("rough", 0.2, 0.2)])
    check = _noise_check(scene)
    assert check["within"] == ["Good"] and not check["ok"] and check["smallest"] == "Good"
    assert check["need_spp"] == int(np.ceil(256 * (0.004 / 0.003) / 0.1))
    scene.runs = scene.runs[::2]  # without the run it cannot judge: the floor is 2 % of the smallest error
    check = _noise_check(scene)
    assert check["ok"] and check["within"] == [] and check["fraction"] == "2.0 %"

    from compare.report.html import build_report

    settings = RunSettings(frames=4, spp=64, sizes=[[32, 24]], renderers=["mitsuba", "mitsuba+offset"], seeds=3)
    res = run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, report=False,
                      cache_dir=tmp_path / "cache", renderers=[OffsetMitsuba()])
    from compare.metrics.table import known

    # every metric a run writes has its row in the one table (names, headings, directions)
    written = {k for sc in res.scenes for r in sc.runs for p in r.points for k in p.metrics}
    assert {"bias2", "rel_bias2_ci", "flip"} <= written and all(known(k) for k in written), sorted(k for k in written if not known(k))
    html = build_report(res, tmp_path / "out").read_text()
    assert "Bias against noise" in html and "biased" in html and (tmp_path / "out" / "plots").is_dir()
    assert any(p.name.endswith("-bias.png") for p in (tmp_path / "out" / "plots").iterdir())
