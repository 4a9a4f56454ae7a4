"""``compare run`` and ``compare report``: results schema, resume, plots, HTML, escaping.

Most tests stand in fast synthetic renderers (:func:`tests.helpers.synthetic_renderers`) so
they check the bookkeeping (keys, resume, schema, report) without Mitsuba or
OpenGL and in well under a second per run; one test runs the real renderers on
a tiny Cornell box (48×36, 16 spp, 8 frames).
"""

from __future__ import annotations

import argparse
import base64
import json
import hashlib
import math
import re
from pathlib import Path

import numpy as np
import pytest

from compare.cli import run as cli_run
from compare.cli.argtypes import parse_sizes
from compare.renderers import doubling_steps
from compare.renderers.registry import Registry
from compare.run import runner as run_mod
from compare.run import scene_job
from compare.progressive import renderer as progressive_adapter
from compare.image.exr import read_exr
from compare.report.results import (
    NoiseFloor,
    Point,
    Reference,
    RendererRun,
    Results,
    ResultsError,
    RunSettings,
    SceneResult,
    check_json_finite,
)
from tests.helpers import (CORNELL, EVIL, ROOT, FakeReference, cornell_named, fake_blender, fake_progressive,
                           synthetic_renderers, synthetic_report, synthetic_truth)

# The synthetic renderers (synthetic_renderers, synthetic_report, FakeReference, fake_*) are tests/helpers.py's.


# --------------------------------------------------------------------------- helpers


def test_doubling_steps():
    assert doubling_steps(1) == [1]
    assert doubling_steps(8) == [1, 2, 4, 8]
    assert doubling_steps(100) == [1, 2, 4, 8, 16, 32, 64, 100]
    with pytest.raises(ValueError):
        doubling_steps(0)


def test_parse_sizes_and_renderers():
    assert parse_sizes("320x240, 1280x720") == [(320, 240), (1280, 720)]
    with pytest.raises(argparse.ArgumentTypeError):
        parse_sizes("320by240")
    assert Registry().parse("mitsuba,progressive:paper") == ["mitsuba", "progressive:paper"]
    for bad in ("cyclesx", "mitsuba:x", "eevee:fast", "progressive:", "", "progressive,progressive"):
        with pytest.raises(ValueError):
            Registry().parse(bad)


def test_scene_id_is_file_name_safe(tmp_path):
    from compare.scene.loader import load_scene

    sid = run_mod.scene_id(load_scene(cornell_named(tmp_path, EVIL)).with_resolution(48, 36))
    assert re.fullmatch(r"[a-z0-9-]+", sid) and sid.endswith("-48x36"), sid


# --------------------------------------------------------------------------- results schema


def _results(flip=0.1) -> Results:
    pts = [Point(1, 0.1, {"flip": 0.4, "ssim": 0.5, "relmse": 0.9, "psnr": None}),
           Point(4, 0.4, {"flip": flip, "ssim": 0.8, "relmse": 0.3, "psnr": 20.0})]
    run = RendererRun("progressive", "Progressive", "frame", 4, "k", 0.4, 0.1, points=pts)
    scene = SceneResult("s-1-8x8", "S", "s.toml", "h", 8, 8, ["area_lights"], {"x": "y"},
                        Reference(16, 0, 1.0, "v"), NoiseFloor("independent-full", 16, [0, 1], {"flip": 0.01}, 1e-4),
                        [run])
    return Results(RunSettings(), run_mod.collect_machine(), [scene], created="now", compare_version="0")


def test_results_round_trip(tmp_path):
    res = _results()
    path = res.save(tmp_path / "results.json")
    back = Results.load(path)
    assert back.to_json() == res.to_json()
    d = json.loads(path.read_text())
    assert d["schema"] == 1 and d["scenes"][0]["runs"][0]["points"][0]["metrics"]["psnr"] is None


def test_results_refuse_nan_and_inf(tmp_path):
    with pytest.raises(ValueError, match=r"scenes\[0\]\.runs\[0\]\.points\[1\]\.metrics\.flip is nan"):
        _results(flip=math.nan).to_json()
    with pytest.raises(ValueError, match="inf"):
        check_json_finite({"a": [1.0, math.inf]})
    assert not (tmp_path / "results.json").exists()
    with pytest.raises(ValueError):
        _results(flip=math.inf).save(tmp_path / "results.json")
    assert not (tmp_path / "results.json").exists()  # nothing half-written
    # A file with a NaN token (as json.dumps writes by default) is refused on reading.
    (tmp_path / "bad.json").write_text(_results().dumps().replace('"flip": 0.1', '"flip": NaN'))
    with pytest.raises(ResultsError, match="NaN"):
        Results.load(tmp_path / "bad.json")


def test_results_refuse_other_schema_and_missing_fields(tmp_path):
    d = _results().to_json()
    (tmp_path / "a.json").write_text(json.dumps({**d, "schema": 2}))
    with pytest.raises(ResultsError, match="schema 2"):
        Results.load(tmp_path / "a.json")
    del d["scenes"][0]["runs"][0]["points"][0]["seconds"]
    (tmp_path / "b.json").write_text(json.dumps(d))
    with pytest.raises(ResultsError, match=r"runs\[0\]\.points\[0\]: missing field 'seconds'"):
        Results.load(tmp_path / "b.json")
    with pytest.raises(ResultsError, match="no such file"):
        Results.load(tmp_path / "missing.json")


def test_equal_time_and_equal_error_interpolate_on_log_log():
    # error = t^-0.5 exactly: log-log interpolation must reproduce it between checkpoints.
    ts = [0.1, 0.4, 1.6, 6.4]
    run = RendererRun("r", "r", "spp", 4, "", ts[-1], ts[0],
                      points=[Point(i + 1, t, {"flip": t ** -0.5}) for i, t in enumerate(ts)])
    assert run.error_at(0.8, "flip") == pytest.approx(0.8 ** -0.5)
    assert run.seconds_to(0.8 ** -0.5, "flip") == pytest.approx(0.8)
    assert run.error_at(0.05, "flip") is None  # no image yet
    assert run.error_at(10.0, "flip") is None  # not measured: no extrapolation
    assert run.error_at(10.0, "flip", hold=True) == pytest.approx(6.4 ** -0.5)  # finished: final image
    assert run.seconds_to(0.1, "flip") is None  # never reached
    assert run.seconds_to(10.0, "flip") == 0.1  # reached by the first image
    one_minus = RendererRun("r", "r", "spp", 1, "", 1.0, 1.0, points=[Point(1, 1.0, {"ssim": 0.75})])
    assert one_minus.error_at(1.0, "one_minus_ssim") == pytest.approx(0.25)


# --------------------------------------------------------------------------- run, resume, report


def test_run_writes_results_images_and_report(tmp_path):
    out = tmp_path / "out"
    FakeReference.renders.clear()
    res = synthetic_report(out, [CORNELL], renderers=("mitsuba", "progressive", "progressive:paper"))
    back = Results.load(out / "results.json")
    assert back.to_json() == res.to_json()
    (scene,) = back.scenes
    assert (scene.width, scene.height) == (48, 36) and scene.name == "Cornell box"
    assert scene.omitted and "area_lights" in scene.features
    assert [r.renderer for r in scene.runs] == ["mitsuba", "progressive", "progressive:paper"]
    mits, prog, paper = scene.runs
    assert [p.step for p in mits.points] == [1, 2, 4, 8, 16]
    assert [p.step for p in prog.points] == [1, 2, 4, 8]
    assert paper.label.endswith("(paper)") and prog.metadata["gl_renderer"] == "fake GL"
    for run in scene.runs:
        secs = [p.seconds for p in run.points]
        assert secs == sorted(secs) and run.seconds == secs[-1] and run.first_frame_seconds == secs[0]
        assert set(run.maps) == {"flip", "one_minus_ssim", "relmse"}
    # The reference ladder is independent of the ground truth (seed + 1), and the noise floor is its end.
    assert {seed for _, seed in FakeReference.renders} == {0, 1}
    assert scene.noise_floor.metrics == mits.final.metrics and scene.noise_floor.seeds == [0, 1]
    assert mits.final.metrics["mse"] > 0  # not trivially 0 at the last checkpoint
    # progressive errors against the ground truth fall with frames (synthetic noise 1/f)
    assert prog.points[-1].metrics["mse"] < prog.points[0].metrics["mse"]
    # every file named exists; EXRs carry their metadata
    for rel in scene_job._paths_in(back.to_json()):
        assert (out / rel).is_file(), rel
    img, meta = read_exr(out / prog.final.image)
    assert img.shape == (36, 48, 3) and meta["frames"] == 8 and meta["renderer"] == "progressive"
    assert back.machine.facts["gl_renderer"] == "fake GL" and back.machine.facts["mitsuba_variant"] == "fake_rgb"
    assert back.machine.cores >= 1 and back.machine.versions["numpy"]
    for name in ("index.html", "static/report.js", "static/report.css", "static/magma.png",
                 f"data/{scene.id}.js", f"plots/{scene.id}-error.png", f"plots/{scene.id}-equal.png"):
        assert (out / name).stat().st_size > 0, name
    # the paper-model variant is an ablation against the plain renderer: a row with its FLIP change
    html = (out / "index.html").read_text(encoding="utf-8")
    assert "<h3>Ablations</h3>" in html
    from compare.report.html import _ablations

    (row,) = _ablations(scene)
    assert row["label"] == paper.label and row["flip"] == f"{paper.final.metrics['flip']:.4f}"
    sign = "+" if paper.final.metrics["flip"] > prog.final.metrics["flip"] else "-"
    assert row["flip_delta"].startswith(sign)


def test_rerun_reuses_finished_units_and_redoes_changed_ones(tmp_path, monkeypatch):
    out = tmp_path / "out"
    first = synthetic_report(out, [CORNELL], report=False)
    FakeReference.renders.clear()
    calls = []

    def counting(*a, **k):
        calls.append(k["frames"])
        return fake_progressive(*a, **k)

    with synthetic_renderers(progressive=counting):
        again = run_mod.run([CORNELL], out, RunSettings(frames=8, spp=16, sizes=[[48, 36]]), progress=False,
                            report=False)
        assert FakeReference.renders == [] and calls == []  # nothing rendered twice
        assert [s.to_json() for s in again.scenes] == [s.to_json() for s in first.scenes]
        # More frames: only the progressive unit is redone; the reference is reused.
        from compare.util.errors import OutputError

        with pytest.raises(OutputError, match=r"holds the results of other settings \(frames 8 → 16\); use "
                                              r"--fresh to redo it with these, --update to keep what still "
                                              r"matches, or another folder$"):
            run_mod.run([CORNELL], out, RunSettings(frames=16, spp=16, sizes=[[48, 36]]), progress=False,
                        report=False)
        more = run_mod.run([CORNELL], out, RunSettings(frames=16, spp=16, sizes=[[48, 36]]), progress=False,
                           report=False, update=True)
        assert FakeReference.renders == [] and calls == [16]
        assert [p.step for p in more.scenes[0].run("progressive").points] == [1, 2, 4, 8, 16]
        # Another spp changes the ground truth: everything is measured again against it; the
        # rasterizer's finished render (its pixels do not depend on the ground truth) is reused.
        again = run_mod.run([CORNELL], out, RunSettings(frames=16, spp=32, sizes=[[48, 36]]), progress=False,
                            report=False, update=True)
        assert {seed for _, seed in FakeReference.renders} == {0, 1} and calls == [16]
        assert again.scenes[0].run("progressive").key != more.scenes[0].run("progressive").key
        # A change to the rasterizer's code: its unit is redone, the reference reused.
        FakeReference.renders.clear()
        monkeypatch.setattr(progressive_adapter.ProgressiveRenderer, "code_key", lambda self: "edited")
        run_mod.run([CORNELL], out, RunSettings(frames=16, spp=32, sizes=[[48, 36]]), progress=False, report=False)
        assert FakeReference.renders == [] and calls == [16, 16]


def test_interrupted_run_resumes_without_redoing_finished_work(tmp_path):
    out = tmp_path / "out"

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    FakeReference.renders.clear()
    with synthetic_renderers(progressive=interrupted):
        with pytest.raises(KeyboardInterrupt):
            run_mod.run([CORNELL], out, RunSettings(frames=8, spp=16, sizes=[[48, 36]]), progress=False,
                        report=False)
    assert not (out / "results.json").exists()
    rendered = sorted(p.parent.name for p in out.rglob("render.json"))
    assert rendered == ["mitsuba", "reference"]  # finished renders were stored
    assert not [p for p in out.rglob(".*") if p.is_file() and p.name != ".compare.lock"]  # no temporary files
    done = len(FakeReference.renders)
    res = synthetic_report(out, [CORNELL], report=False)
    assert len(FakeReference.renders) == done  # the reference was not rendered again
    assert res.scenes[0].run("progressive").points


def test_broken_partial_is_redone(tmp_path):
    out = tmp_path / "out"
    synthetic_report(out, [CORNELL], report=False)
    partial = next(out.rglob("progressive/partial.json"))
    partial.write_text("{ not json")
    (out / "results.json").unlink()
    res = synthetic_report(out, [CORNELL], report=False)
    assert res.scenes[0].run("progressive").points and json.loads(partial.read_text())["key"]


def test_nan_from_a_renderer_is_an_error_not_a_number(tmp_path):
    from compare.renderers import RendererError

    def nan_progressive(scene, **k):
        cps, setup, meta, layers = fake_progressive(scene, **k)
        cps[-1][2][3, 4, 1] = np.nan
        return cps, setup, meta, layers

    message = "renderer 'progressive' at step 4: 1 pixel(s) are NaN or infinite (first at x=4, y=3)"
    with synthetic_renderers(progressive=nan_progressive):
        with pytest.raises(RendererError, match="^" + re.escape(message) + "$"):
            run_mod.run([CORNELL], tmp_path, RunSettings(frames=4, spp=4, sizes=[[48, 36]]), progress=False,
                        report=False, keep_going=False)
        assert not (tmp_path / "results.json").exists()
        # kept going (the default for more than one unit): the failure is recorded, not a number
        res = run_mod.run([CORNELL], tmp_path, RunSettings(frames=4, spp=4, sizes=[[48, 36]]), progress=False,
                          report=False)
    assert [f["message"] for f in res.failures if f["renderer"] == "progressive"] == [message]
    assert all(r.renderer != "progressive" for r in res.scenes[0].runs)


def test_report_escapes_scene_strings(tmp_path):
    out = tmp_path / "out"
    res = synthetic_report(out, [cornell_named(tmp_path, EVIL)])
    html = (out / "index.html").read_text(encoding="utf-8")
    assert "<script>alert" not in html
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    # Only external scripts from the folder itself; no inline script at all.
    for tag in re.findall(r"<script[^>]*>", html):
        assert re.fullmatch(r'<script src="(data|static)/[a-z0-9.-]+\.js"( defer)?>', tag), tag
    assert re.search(r"<script[^>]*>[^<]+</script>", html) is None
    assert "Content-Security-Policy" in html
    data = (out / "data" / f"{res.scenes[0].id}.js").read_text()
    assert "<" not in data.split("*/", 1)[1] and ">" not in data.split("*/", 1)[1]


def test_hdr_payload_round_trips_as_float16():
    from compare.report.html import hdr_payload

    img = synthetic_truth(16, 12)
    img[0, 0] = [1e6, -1.0, 0.5]
    text = hdr_payload("x", [("reference", "a <b> & c", img)], exposure=2.0)
    body = json.loads(re.search(r"\] = (\{.*\});\s*$", text, re.S).group(1))
    assert (body["width"], body["height"], body["exposure"], body["encoding"]) == (16, 12, 2.0, "float16le-base64")
    assert body["images"][0]["label"] == "a <b> & c"  # escaped as \u003c in the text, intact after parsing
    assert "<b>" not in text
    back = np.frombuffer(base64.b64decode(body["images"][0]["data"]), dtype="<f2").reshape(12, 16, 3)
    np.testing.assert_allclose(back[1:], img[1:], rtol=1e-3)
    assert back[0, 0].tolist() == [65504.0, 0.0, 0.5]  # clamped into half's range, negatives to 0


def test_report_command_rebuilds_into_another_folder(tmp_path, capsys):
    from compare.cli.check import add_check_parser
    from compare.cli.report import add_report_parser

    out = tmp_path / "out"
    synthetic_report(out, [CORNELL])
    parser = argparse.ArgumentParser(prog="compare")
    sub = parser.add_subparsers(dest="command", required=True)
    cli_run.add_run_parser(sub)
    add_report_parser(sub)
    add_check_parser(sub)
    copy = tmp_path / "copy"
    args = parser.parse_args(["report", str(out / "results.json"), "-o", str(copy), "--plot-format", "svg"])
    assert args.func(args) == 0
    res = Results.load(copy / "results.json")
    for rel in scene_job._paths_in(res.to_json()):
        assert (copy / rel).is_file(), rel
    assert (copy / "index.html").is_file() and (copy / "data" / f"{res.scenes[0].id}.js").is_file()
    assert f'src="plots/{res.scenes[0].id}-error.svg"' in (copy / "index.html").read_text()
    # A missing image is a clear error (exit status 2 through compare's CompareError handling).
    from compare.util.errors import CompareError

    (out / res.scenes[0].runs[0].preview).unlink()
    args = parser.parse_args(["report", str(out / "results.json")])
    with pytest.raises(CompareError, match="missing; rerun `compare run`"):
        args.func(args)
    # run's parser: defaults and list options
    args = parser.parse_args(["run", "--size", "320x240,64x48", "--renderers", "progressive:paper"])
    assert args.size == [(320, 240), (64, 48)] and args.renderers == ["progressive:paper"]
    assert args.frames == 128 and args.spp == 1024 and callable(args.func)
    # an unknown renderer: one line naming it and what is known, before any work (exit status 2)
    from compare.cli.main import main

    assert main(["run", "--renderers", "blender", "-o", str(tmp_path / "never")]) == 2
    assert "unknown renderer 'blender'" in capsys.readouterr().err
    assert not (tmp_path / "never").exists()


def test_run_command_end_to_end(tmp_path, capsys):
    parser = argparse.ArgumentParser(prog="compare")
    cli_run.add_run_parser(parser.add_subparsers(dest="command", required=True))
    out = tmp_path / "cli"
    args = parser.parse_args(["run", "--scenes", str(CORNELL), "--size", "48x36", "--frames", "4", "--spp", "8",
                              "--quiet", "--no-report", "-o", str(out)])
    with synthetic_renderers():
        assert args.func(args) == 0
    assert "results.json" in capsys.readouterr().out
    assert Results.load(out / "results.json").settings.frames == 4


def test_plots_without_noise_floor_or_runs(tmp_path):
    from compare.report.plots import equal_error, equal_time, make_plots

    res = _results()
    res.scenes[0].noise_floor = None
    made = make_plots(res, tmp_path, fmt="svg")
    assert all(p.stat().st_size > 0 for d in made.values() for p in d.values())
    rows = equal_time(res.scenes[0], "flip")
    assert rows[0].target == 0.4 and rows[0].values["progressive"] == pytest.approx(0.1)
    assert equal_error(res.scenes[0], "flip")[0].values["progressive"] == pytest.approx(0.4)
    res.scenes[0].runs = []
    make_plots(res, tmp_path / "empty")


# --------------------------------------------------------------------------- the real renderers


@pytest.mark.gl
def test_real_renderers_tiny_cornell(tmp_path, gl_ctx):
    """Mitsuba + the progressive rasterizer on a 48×36 Cornell box: the whole pipeline for real."""
    out = tmp_path / "real"
    settings = RunSettings(frames=8, spp=16, sizes=[[48, 36]], renderers=["mitsuba", "progressive"])
    res = run_mod.run([CORNELL], out, settings, progress=False, cache_dir=tmp_path / "cache", gl_ctx=gl_ctx,
                      report=False)
    scene = res.scenes[0]
    mits, prog = scene.runs
    assert [p.step for p in prog.points] == [1, 2, 4, 8] and [p.step for p in mits.points] == [1, 2, 4, 8, 16]
    assert res.machine.facts["gl_renderer"]
    assert res.machine.facts["mitsuba_variant"]
    # The reference's convergence: more samples, less error against the ground truth.
    assert mits.points[-1].metrics["mse"] < mits.points[0].metrics["mse"]
    assert 0 < prog.final.metrics["flip"] < 1 and 0 < prog.final.metrics["ssim"] <= 1
    assert (out / prog.final.preview).is_file() and (out / scene.reference.image).is_file()


def test_all_renderers_give_the_papers_table_1(tmp_path):
    """``--renderers all``: Mitsuba, the three area models, Cycles and EEVEE, each a Table 1 row with its error."""
    out = tmp_path / "out"
    assert Registry().parse("all") == Registry.groups()["all"]
    assert Registry().parse("all,progressive:probes")[-1] == "progressive:probes"
    with pytest.raises(ValueError, match="unknown renderer|unknown option"):
        Registry().parse("cycles:fast")
    res = synthetic_report(out, [CORNELL], renderers=("all",), budgets={"cycles": 64, "eevee": 16}, materials="cycles")
    (scene,) = res.scenes
    assert [r.renderer for r in scene.runs] == Registry.groups()["all"]
    cycles, eevee = scene.run("cycles"), scene.run("eevee")
    assert [p.step for p in cycles.points] == [1, 4, 16, 64] and cycles.steps == 64
    assert [p.step for p in eevee.points] == [1, 4, 16] and eevee.label == "Blender EEVEE"
    assert cycles.setup_seconds == 1.5 and cycles.metadata["blender"] == "fake 5.0.1"
    assert cycles.final.metrics["mse"] < eevee.final.metrics["mse"]  # EEVEE's fake is biased
    html = (out / "index.html").read_text(encoding="utf-8")
    assert "Blender Cycles (CPU)" in html and "Blender EEVEE" in html
    # the progressive renderer's first image says it is a reduced preview; Blender's do not
    assert html.count("drawn at 0.5× size") == 3  # radiometric, paper and ltc
    # with --materials cycles the run says how Cycles-like the ground truth is
    assert scene.likeness["regions"] == "15/15" and scene.likeness["renderer"] == "cycles"
    assert "Cycles-like" in html and "1.11" in html
    for rel in scene_job._paths_in(Results.load(out / "results.json").to_json()):
        assert (out / rel).is_file(), rel


def test_no_likeness_skips_the_measurement_and_reuses_what_has_it(tmp_path):
    calls = []

    def counting_blender(*a, **k):
        calls.append(k["engine"])
        return fake_blender(*a, **k)

    def run(out, likeness):
        settings = RunSettings(frames=8, spp=16, sizes=[[48, 36]], renderers=["cycles"], budgets={"cycles": 16},
                               materials="cycles", likeness=likeness)
        with synthetic_renderers():
            with pytest.MonkeyPatch.context() as mp:
                mp.setattr("compare.blender.renderer._blender_checkpoints", counting_blender)
                return run_mod.run([CORNELL], out, settings, progress=False, report=False, update=True)

    # Without it: no likeness; asked for later, the finished Cycles unit is reused and the measure stage
    # renders Cycles once more (seed + 1) for it; a run without it again reuses everything.
    res = run(tmp_path / "a", likeness=False)
    assert res.scenes[0].likeness is None and calls == ["cycles"]
    res = run(tmp_path / "a", likeness=True)
    assert res.scenes[0].likeness["regions"] == "15/15" and calls == ["cycles"] * 2
    res = run(tmp_path / "a", likeness=True)  # measured once: kept in the unit
    assert calls == ["cycles"] * 2 and res.scenes[0].likeness is not None
    res = run(tmp_path / "a", likeness=False)
    assert calls == ["cycles"] * 2 and res.scenes[0].likeness is None


def test_blender_renderers_need_bpy_before_any_work(tmp_path, monkeypatch):
    from compare.util.errors import MissingComponentError

    monkeypatch.setattr("compare.blender.blender_available", lambda: (False, "bpy is not installed (test)"))
    settings = RunSettings(frames=2, spp=2, sizes=[[8, 6]], renderers=["mitsuba", "eevee"])
    with pytest.raises(MissingComponentError, match=r"renderer not available here: eevee \(bpy is not installed"):
        run_mod.run([CORNELL], tmp_path / "out", settings, progress=False)
    assert not (tmp_path / "out").exists()


def test_a_ground_truth_that_tone_maps_to_black_gives_no_ldr_scores(tmp_path):
    """At an exposure that maps everything to black the LDR metrics are null (never SSIM 1, FLIP 0),
    the report and its plots are still made, and the HDR metrics are still measured."""
    res = synthetic_report(tmp_path / "out", [CORNELL], exposure=1e-30)
    for run in res.scenes[0].runs:
        for point in run.points:
            assert point.metrics["flip"] is None and point.metrics["ssim"] is None
            assert point.metrics["ldr_range"] == 0.0 and point.metrics["relmse"] >= 0
    html = (tmp_path / "out" / "index.html").read_text(encoding="utf-8")
    assert "FLIP 0 " not in html and "SSIM 1 " not in html


def test_report_copy_refuses_to_replace_another_runs_results(tmp_path, capsys):
    """``compare report A -o B`` where B holds another run's results: one error line, B untouched, unless
    ``--fresh``; copying the same results again is fine (before: B's results were replaced silently)."""
    from compare.cli.main import main

    synthetic_report(tmp_path / "a", [CORNELL], frames=4)
    synthetic_report(tmp_path / "b", [CORNELL], frames=8)
    copy = tmp_path / "copy"
    assert main(["report", str(tmp_path / "a" / "results.json"), "-o", str(copy)]) == 0
    assert main(["report", str(tmp_path / "a" / "results.json"), "-o", str(copy)]) == 0  # the same results
    held = (copy / "results.json").read_bytes()
    capsys.readouterr()
    assert main(["report", str(tmp_path / "b" / "results.json"), "-o", str(copy)]) == 2
    assert capsys.readouterr().err.strip() == (f"compare: error: -o {copy}: holds the results of another run "
                                               f"({copy / 'results.json'}); choose another folder, or --fresh to "
                                               "replace them")
    assert (copy / "results.json").read_bytes() == held
    assert main(["report", str(tmp_path / "b" / "results.json"), "-o", str(copy), "--fresh"]) == 0
    assert Results.load(copy / "results.json").settings.frames == 8


def test_report_copy_follows_no_symlink(tmp_path, capsys):
    """An image of the results folder that links outside it is refused, not copied; a link in the
    target folder is replaced, never written through."""
    from compare.cli.main import main

    synthetic_report(tmp_path / "a", [CORNELL], frames=4)
    res = Results.load(tmp_path / "a" / "results.json")
    rel = res.scenes[0].runs[-1].final.image
    secret = tmp_path / "secret.exr"
    secret.write_bytes((tmp_path / "a" / rel).read_bytes())
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    # a link in the target folder where the copy's image will go: replaced, the victim untouched
    copy = tmp_path / "copy"
    (copy / rel).parent.mkdir(parents=True)
    (copy / rel).symlink_to(victim)
    assert main(["report", str(tmp_path / "a" / "results.json"), "-o", str(copy)]) == 0
    assert victim.read_text() == "keep" and not (copy / rel).is_symlink()
    # an image of the source that links outside it
    (tmp_path / "a" / rel).unlink()
    (tmp_path / "a" / rel).symlink_to(secret)
    capsys.readouterr()
    assert main(["report", str(tmp_path / "a" / "results.json"), "-o", str(tmp_path / "other")]) == 2
    assert capsys.readouterr().err.strip() == (
        f"compare: error: {tmp_path / 'a' / rel}: links to {secret}, outside the results folder {tmp_path / 'a'}: "
        "a report copies only what its run wrote")


def test_same_figures_as_the_golden(tmp_path, gl_ctx, update_golden):
    """The Cornell box at 48×36 (16 spp, 8 frames) gives exactly the figures of its golden file
    (tests/data/cornell-48x36-golden.json), timings aside, for the reference and every rasterizer variant
    listed: results.json's metrics, the check verdicts and the report's figures are made from them. A
    restructuring leaves them bit for bit; ``pytest --update-golden`` rewrites the file from the code as it is
    (after a change of figures that is meant; the diff is then the review)."""
    from compare.report.check import check

    golden = ROOT / "tests" / "data" / "cornell-48x36-golden.json"
    host = golden.with_suffix(".truth-sha256")
    settings = RunSettings(frames=8, spp=16, sizes=[[48, 36]],
                           renderers=["mitsuba", "progressive", "progressive:paper", "progressive:ltc"])
    now = run_mod.run([CORNELL], tmp_path / "now", settings, progress=False, cache_dir=tmp_path / "cache",
                      gl_ctx=gl_ctx, report=False)
    # The host's floating point: the ground truth's bits (Dr.Jit compiles for the CPU's vector width) and the
    # vector code NumPy dispatches to (its float32 sums, in the metrics, follow the CPU's vector width too: a
    # host that renders the truth bit for bit can still differ in the metrics' last bits). On the golden's host
    # every figure must be equal bit for bit; elsewhere they may differ in float32 rounding only.
    truth = hashlib.sha256(read_exr(tmp_path / "now" / now.scenes[0].reference.image)[0].tobytes()).hexdigest()
    identity = f"{truth}\n{_numpy_dispatch()}\n"
    if update_golden:
        now.save(golden)
        host.write_text(identity, encoding="utf-8")
        pytest.skip(f"--update-golden: rewrote {golden.name}")
    same_host = host.read_text(encoding="utf-8") == identity
    close = (lambda x, y: x == y) if same_host else _close_figures
    before = Results.load(golden)
    (a,), (b,) = before.scenes, now.scenes
    assert (a.id, a.features, a.omitted) == (b.id, b.features, b.omitted)
    assert (a.reference.spp, a.reference.seed, a.reference.variant) == (b.reference.spp, b.reference.seed,
                                                                        b.reference.variant)
    assert (a.noise_floor.spp, a.noise_floor.seeds) == (b.noise_floor.spp, b.noise_floor.seeds)
    assert close(a.noise_floor.metrics, b.noise_floor.metrics), (a.noise_floor.metrics, b.noise_floor.metrics)
    assert [(r.renderer, r.label, r.unit, r.steps) for r in a.runs] == [(r.renderer, r.label, r.unit, r.steps)
                                                                         for r in b.runs]
    for ra, rb in zip(a.runs, b.runs):
        assert [p.step for p in ra.points] == [p.step for p in rb.points], ra.renderer
        for pa, pb in zip(ra.points, rb.points):
            assert close(pa.metrics, pb.metrics), (ra.renderer, pa.step, pa.metrics, pb.metrics)
    if not same_host:
        return  # the verdicts' messages print the figures, which may differ in their last digits here
    rules = {"schema": 1, "rule": [
        {"renderer": "*", "max": {"flip": 0.3, "relmse": 0.1}, "min": {"ssim": 0.5}},
        {"renderer": "progressive", "step": 1, "max": {"flip": 0.3}, "min": {"ssim": 0.5}}]}
    verdicts = [check(r, rules) for r in (before, now)]
    assert [str(v) for v in verdicts[0][0]] == [str(v) for v in verdicts[1][0]] and verdicts[0][1] == verdicts[1][1]
    assert verdicts[0][0]  # the rules above cross some bounds: the messages compared carry the values


def _numpy_dispatch() -> str:
    """NumPy's version and the CPU features its vector code is dispatched for on this host."""
    import numpy as np
    from numpy._core import _multiarray_umath as umath

    return f"numpy {np.__version__}: " + " ".join(sorted(k for k, on in umath.__cpu_features__.items() if on))


def _close_figures(a: dict, b: dict) -> bool:
    """Figures equal up to float32 rounding: what another host's vector width changes. A relative 1e-5: the
    FLIP map's 95th percentile moved by 1.4e-6 between two AVX-512 hosts whose ground truths were bit-identical
    (FLIP's library and NumPy's sums vectorise for the CPU; a percentile picks one pixel's value); every other
    figure by less than 1.1e-7."""
    if a.keys() != b.keys():
        return False
    return all((x is None and y is None) or (x is not None and y is not None and math.isclose(x, y, rel_tol=1e-5,
                                                                                            abs_tol=1e-9))
               for x, y in ((a[k], b[k]) for k in a))


def test_output_folder_is_held_while_in_use_and_killed_writes_are_swept(tmp_path):
    """A second command into a folder in use is refused; files a killed run left half-written
    (``.<name>.part-*``) are removed by the next run, with a warning."""
    from compare.util.errors import OutputError
    from compare.util.files import folder_lock

    out = tmp_path / "out"
    synthetic_report(out, [CORNELL], report=False)
    with folder_lock(out, "compare run"):  # as if another run held it
        with pytest.raises(OutputError, match=rf"^{re.escape(str(out))}: in use by compare run \(pid \d+\); wait "
                                              "for it to finish or choose another output folder$"):
            synthetic_report(out, [CORNELL], report=False)
    stale = next(out.rglob("step-00001.exr")).parent / ".step-00001.exr.part-k1ll3d.exr"
    stale.write_bytes(b"half an EXR")
    with pytest.warns(UserWarning, match=r"removed 1 half-written file\(s\) an interrupted run left behind"):
        synthetic_report(out, [CORNELL], report=False)
    assert not stale.exists()


def test_cornell_error_by_kind_of_light(tmp_path, gl_ctx):
    """compare run measures the rasterizer layer by layer against the reference's per-effect ground
    truths: on the Cornell box most of its error is the indirect diffuse light it does not render;
    a renderer without layers (an external command) is measured on the full image only."""
    from compare.report.html import build_report

    settings = RunSettings(frames=16, spp=64, sizes=[[48, 36]],
                           renderers=["mitsuba", "progressive", "numpy-raycaster"],
                           renderer_config=str(ROOT / "examples" / "renderers.toml"))
    res = run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, cache_dir=tmp_path / "cache",
                      gl_ctx=gl_ctx, report=False)
    (scene,) = res.scenes
    layers = scene.run("progressive").layers
    shares = {n: e["share"] for n, e in layers.items() if "share" in e}
    assert sum(shares.values()) == pytest.approx(1.0, abs=1e-9)
    assert max(shares, key=shares.get) == "indirect_diffuse" and shares["indirect_diffuse"] > 0.5, shares
    assert not layers["indirect_diffuse"]["rendered"] and layers["direct_area"]["rendered"]
    assert 0.8 < layers["direct_area"]["mean_ratio"] < 1.2
    assert all((tmp_path / "out" / e["map"]).is_file() for e in layers.values())
    assert scene.run("numpy-raycaster").layers == {} and scene.run("mitsuba").layers == {}
    html = build_report(res, tmp_path / "out").read_text()
    assert "Error by kind of light" in html and "most error: indirect diffuse" in html
    assert "Measured on the full image only (they give no layers): " in html


def test_report_leaves_out_a_kind_of_light_the_scene_does_not_have():
    """No column or map for a layer that is dark in the ground truth and that no run adds light to."""
    from compare.report import html as report_html

    class Run:
        def __init__(self, label, layers):
            self.label, self.layers, self.renderer = label, layers, label

    dark = {"flip": 0.0, "relmse": 0.0, "mean_ratio": None, "share": 0.0, "rendered": True}
    lit = {"flip": 0.1, "relmse": 0.2, "mean_ratio": 0.9, "share": 0.6, "rendered": True}
    extra = {"flip": 0.1, "relmse": 0.2, "mean_ratio": None, "share": 0.4, "rendered": True}  # light the truth lacks

    class Scene:
        runs = [Run("progressive", {"direct_area": lit, "direct_env": dark, "direct_punctual": extra})]
        reference = Run("mitsuba", {})

    table = report_html._layers(Scene())
    assert table["names"] == ["direct, area lights", "direct, point, spot and directional lights"]
    assert len(table["rows"][0]["cells"]) == 2


def test_a_results_file_of_an_unknown_schema_is_never_overwritten_without_fresh(tmp_path):
    """A folder whose results.json this version cannot read (another version's schema, or damaged) is
    refused, the file left as it was; --fresh replaces it."""
    from compare.util.errors import OutputError

    out = tmp_path / "out"
    out.mkdir()
    future = json.dumps({**_results().to_json(), "schema": 99, "settings": {"frames": 3}})
    (out / "results.json").write_text(future)
    settings = RunSettings(frames=2, spp=2, sizes=[[8, 6]], renderers=["mitsuba"])
    with pytest.raises(OutputError, match=r"holds a results.json this version cannot read \(.*schema 99.*\); use "
                                          r"--fresh to replace it"):
        run_mod.run([CORNELL], out, settings, progress=False, report=False)
    assert (out / "results.json").read_text() == future


def test_a_huge_scene_name_is_shortened_in_plots_and_kept_whole_in_the_results(tmp_path):
    """A 100 kB scene name (which made matplotlib lay out a 100 kB title for seconds to minutes) is 80
    characters in the plots; results.json keeps the name whole."""
    import dataclasses

    from compare.report import plots

    res = _results()
    name = "kitchen " * 12_500
    res = dataclasses.replace(res, scenes=[dataclasses.replace(res.scenes[0], name=name)])
    assert len(plots._short(name)) == plots.MAX_TEXT and plots._short(name).endswith("…")
    made = plots.make_plots(res, tmp_path / "plots")
    assert made and all(Path(p).is_file() for d in made.values() for p in d.values())
    assert Results.load(res.save(tmp_path / "results.json")).scenes[0].name == name


def test_results_and_report_are_replaced_together_or_not_at_all(tmp_path, monkeypatch):
    """A full disk while the report is written leaves the previous results.json and index.html as they
    were (not the new results beside the old report), and says so."""
    import errno

    from compare.report import html as report_html
    from compare.util.errors import OutputError

    out = tmp_path / "out"
    out.mkdir()
    (out / "results.json").write_text("old results")
    (out / "index.html").write_text("old report")

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(report_html, "build_report", full)
    with pytest.raises(OutputError, match=r"could not write the new results and report \(No space left on device\); "
                                          r"the previous results.json and index.html are as they were"):
        run_mod._save_with_report(_results(), out, True)
    assert (out / "results.json").read_text() == "old results" and (out / "index.html").read_text() == "old report"
    assert sorted(p.name for p in out.iterdir()) == ["index.html", "results.json"]  # no part file left
    monkeypatch.undo()
    run_mod._save_with_report(_results(), out, False)  # without a report: results.json alone, replaced
    assert Results.load(out / "results.json").scenes[0].name == "S"


def test_an_ablation_row_names_the_kind_of_light_it_moved_most():
    """The ablation table's last column: the layer whose relMSE the variant changed most, before → after."""
    from types import SimpleNamespace

    from compare.report.html import _layer_moved

    base = SimpleNamespace(layers={"direct_env": {"relmse": 0.787}, "indirect_diffuse": {"relmse": 0.05},
                                   "direct_area_unshadowed": {"relmse": 9.0}})
    run = SimpleNamespace(layers={"direct_env": {"relmse": 0.071}, "indirect_diffuse": {"relmse": 0.30},
                                  "direct_area_unshadowed": {"relmse": 0.0}})
    assert _layer_moved(run, base) == "direct, environment: 0.787 → 0.071"
    run.layers["indirect_diffuse"]["relmse"] = 0.9
    assert _layer_moved(run, base) == "indirect diffuse: 0.05 → 0.9"
    assert _layer_moved(SimpleNamespace(layers={}), base) == "—"


def test_a_failing_unit_is_recorded_and_the_run_goes_on(tmp_path, gl_ctx):
    """One renderer failing on one scene no longer voids the sweep: its failure is in results.json and the
    report, every other unit is measured; --no-keep-going stops at it."""
    from compare.renderers import Renderer

    class Broken(Renderer):
        name = "broken"
        label = "A broken renderer"
        unit = "frame"
        default_budget = "frames"

        def key(self, scene, settings):
            return ["broken", 1]

        def render(self, scene, *, steps, checkpoints, seed, context):
            raise RuntimeError("the GPU is on fire")

    settings = RunSettings(frames=2, spp=4, sizes=[[16, 12]], renderers=["mitsuba", "broken", "progressive"])
    out = tmp_path / "out"
    res = run_mod.run([CORNELL], out, settings, progress=False, gl_ctx=gl_ctx, renderers=[Broken()],
                      cache_dir=tmp_path / "cache")
    (scene,) = res.scenes
    assert [r.renderer for r in scene.runs] == ["mitsuba", "progressive"]
    assert res.failures == [{"scene": scene.id, "renderer": "broken", "message": "RuntimeError: the GPU is on fire"}]
    assert Results.load(out / "results.json").failures == res.failures
    html = (out / "index.html").read_text()
    assert "Failed units" in html and "the GPU is on fire" in html
    with pytest.raises(RuntimeError, match="on fire"):
        run_mod.run([CORNELL], tmp_path / "strict", settings, progress=False, gl_ctx=gl_ctx, renderers=[Broken()],
                    cache_dir=tmp_path / "cache", keep_going=False)


def test_the_command_line_exits_1_after_a_run_with_failed_units(tmp_path, capsys):
    from compare.cli.main import main

    config = tmp_path / "renderers.toml"
    config.write_text('[renderer.failing]\ncommand = ["{python}", "-c", "import sys; sys.exit(3)", "{job}"]\n'
                      'unit = "frames"\nsteps = 2\n')
    rc = main(["run", "--scenes", str(CORNELL), "--renderer-config", str(config), "--renderers",
               "progressive,failing", "--size", "16x12", "--spp", "4", "--frames", "2", "-o", str(tmp_path / "o"),
               "--quiet"])
    err = capsys.readouterr().err
    assert rc == 1 and "1 unit(s) failed" in err and "failing" in err
    assert (tmp_path / "o" / "results.json").is_file()
