"""The renderer protocol, the registry and external renderers.

Renderers come from three places beside the built-ins (an object of this
process, an installed package's entry point, a renderer TOML file), and each
is measured by ``compare run`` beside Mitsuba; a misbehaving external renderer
gets one exact message and leaves no result behind.
"""

from __future__ import annotations

import json
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from compare.run import runner as run_mod
from compare.cli.main import main
from compare.image.exr import read_exr, write_exr
from compare.renderers import Checkpoint, Renderer, RendererError, Rendering
from compare.renderers.registry import Registry
from compare.renderers.job import export_gltf, read_checkpoints
from compare.report.results import Results, RunSettings
from compare.scene.loader import load_scene
from tests.helpers import CORNELL, ROOT

SIZE = (16, 12)


# Every test of this module: the job folders the renderers make (tempfile's folder) go to a folder of the
# test's own, so that the tests that look for what a job left find only their own (tests in parallel too).
@pytest.fixture(autouse=True)
def own_tempdir(tmp_path, monkeypatch):
    """Job folders go to a folder of this test's own (tests in parallel must not see each other's)."""
    import tempfile

    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))


class GreyRenderer(Renderer):
    """An in-process renderer: a constant grey image that converges to 0.2 as 1/steps."""

    name = "grey"
    label = "Grey (test)"
    unit = "sample"
    portable = False

    def steps(self, settings) -> int:
        return 4

    def key(self, scene, settings):
        return ["grey", 1]

    def render(self, scene, *, steps, checkpoints, seed, context):
        w, h = scene.camera.resolution
        return Rendering([Checkpoint(s, 0.01 * s, np.full((h, w, 3), 0.2 + 0.1 / s, np.float32))
                          for s in checkpoints], 0.5, {"seed_seen": seed})


def _settings(renderers, **more) -> RunSettings:
    return RunSettings(frames=4, spp=4, sizes=[list(SIZE)], renderers=list(renderers), **more)


# --------------------------------------------------------------------------- an external renderer, for tests

SCRIPT = textwrap.dedent('''
    """A test renderer: writes what MODE says (good output or one kind of bad behaviour)."""
    import json, sys, time
    import numpy as np
    import OpenEXR

    mode, job_path = sys.argv[1], sys.argv[2]
    job = json.load(open(job_path))
    w, h = job["camera"]["width"], job["camera"]["height"]
    out = job["output_dir"]
    if mode == "exit3":
        print("the renderer broke: no GPU found", file=sys.stderr)
        sys.exit(3)
    if mode == "hang":
        print("rendering forever", file=sys.stderr, flush=True)
        time.sleep(60)
    if mode == "orphan":  # leaves a process running behind it, and exits as if all went well
        import os, subprocess
        child = subprocess.Popen(["sleep", "300"])
        open(os.path.join(os.path.dirname(os.path.abspath(sys.argv[0])), "orphan.pid"), "w").write(str(child.pid))
    if mode == "chatty":  # a 20 MB progress bar on one line, then the error
        sys.stderr.write("\\r".join(f"{k:8d}" for k in range(2_000_000)) + "\\nout of memory\\n")
        sys.exit(1)
    seconds = {}
    for k, step in enumerate(job["checkpoints"]):
        if mode == "missing" and k == len(job["checkpoints"]) - 1:
            break
        size = (2, 2) if mode == "tiny" else (h, w)
        img = np.full(size + (3,), 0.25, np.float32)
        if mode == "nan":
            img[1, 1, 0] = np.nan
        chans = {c: np.ascontiguousarray(img[..., i]) for i, c in enumerate("RGB")}
        OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, chans).write(
            f"{out}/step-{step}.exr")
        seconds[str(step)] = 0.001 * (k + 1)
    json.dump({"setup_seconds": 0.01, "seconds": seconds, "metadata": {"mode": mode,
               "lights": len(job["scene"]["lights"])}}, open(f"{out}/timings.json", "w"))
''')


def renderer_toml(tmp_path: Path, mode: str, *, timeout: float = 60, name: str = "mine") -> Path:
    (tmp_path / "tools").mkdir(exist_ok=True)
    (tmp_path / "tools" / "test_renderer.py").write_text(SCRIPT)
    path = tmp_path / "renderers.toml"
    path.write_text(textwrap.dedent(f'''
        [renderer.{name}]
        command = ["{sys.executable}", "tools/test_renderer.py", "{mode}", "{{job}}"]
        label = "My renderer"
        unit = "frames"
        steps = 4
        timeout = {timeout}
    '''))
    return path


# --------------------------------------------------------------------------- three sources, measured beside Mitsuba


def test_in_process_renderer_is_measured_beside_mitsuba(tmp_path):
    res = run_mod.run([CORNELL], tmp_path / "out", _settings(["mitsuba", "grey"]), progress=False, report=False,
                      renderers=[GreyRenderer()])
    scene = res.scenes[0]
    grey = scene.run("grey")
    assert [p.step for p in grey.points] == [1, 2, 4] and grey.unit == "sample" and grey.label == "Grey (test)"
    assert grey.setup_seconds == 0.5 and grey.metadata["seed_seen"] == 0
    assert scene.noise_floor is not None and scene.noise_floor.metrics == scene.run("mitsuba").final.metrics
    assert all(p.metrics["flip"] > 0 for p in grey.points)


def test_toml_renderer_is_measured_beside_mitsuba(tmp_path):
    config = renderer_toml(tmp_path, "good")
    settings = _settings(["mitsuba", "mine"], renderer_config=str(config))
    res = run_mod.run([CORNELL], tmp_path / "out", settings, progress=False)
    mine = res.scenes[0].run("mine")
    assert mine.label == "My renderer" and mine.unit == "frame" and [p.step for p in mine.points] == [1, 2, 4]
    assert mine.metadata["mode"] == "good" and mine.metadata["lights"] == 1 and mine.setup_seconds == 0.01
    assert [p.seconds for p in mine.points] == [0.001, 0.002, 0.003]
    # the report names it; a rerun reuses it (the command and the script it names are the key)
    assert "My renderer" in (tmp_path / "out" / "index.html").read_text()
    again = run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, report=False)
    assert again.scenes[0].run("mine").key == mine.key
    # nothing of the job is left in the temporary folder
    assert not list(Path(tempfile_dir()).glob("compare-job-mine-*"))


def tempfile_dir() -> str:
    import tempfile

    return tempfile.gettempdir()


def test_entry_point_renderer_is_measured_beside_mitsuba(tmp_path, monkeypatch):
    """A package "installed" on sys.path with a compare.renderers entry point (its dist-info)."""
    site = tmp_path / "site"
    pkg = site / "grey_plugin"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text(textwrap.dedent('''
        import numpy as np
        from compare.renderers import Checkpoint, Renderer, Rendering

        class Plugged(Renderer):
            name = "plugged"
            label = "Plugged-in renderer"
            unit = "frame"

            def key(self, scene, settings):
                return ["plugged"]

            def render(self, scene, *, steps, checkpoints, seed, context):
                w, h = scene.camera.resolution
                return Rendering([Checkpoint(s, 0.001 * s, np.full((h, w, 3), 0.3, np.float32))
                                  for s in checkpoints])
    '''))
    info = site / "grey_plugin-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: grey-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[compare.renderers]\nplugged = grey_plugin:Plugged\n")
    monkeypatch.syspath_prepend(str(site))
    reg = Registry()
    assert "plugged" in reg.names() and reg.get("plugged").label == "Plugged-in renderer"
    res = run_mod.run([CORNELL], tmp_path / "out", _settings(["mitsuba", "plugged"]), progress=False,
                      report=False)
    assert [p.step for p in res.scenes[0].run("plugged").points] == [1, 2, 4]
    listing = {r["name"]: r for r in reg.listing()}
    assert listing["plugged"]["available"] and "grey_plugin:Plugged" in listing["plugged"]["source"]


def test_another_renderer_can_be_the_ground_truth(tmp_path):
    settings = _settings(["progressive", "grey"], ground_truth="progressive")
    res = run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, renderers=[GreyRenderer()])
    scene = res.scenes[0]
    assert scene.reference.renderer == "progressive" and scene.reference.unit == "frame"
    assert scene.reference.spp == 4 and scene.reference.label.startswith("Progressive rasterizer")
    # the ground-truth renderer's own run is the independent one (seed + 1): its end is the noise floor
    assert scene.noise_floor.metrics == scene.run("progressive").final.metrics
    assert scene.run("progressive").final.metrics["flip"] > 0
    html = (tmp_path / "out" / "index.html").read_text()
    assert "Ground truth (Progressive rasterizer (radiometric))" in html


# --------------------------------------------------------------------------- bad renderer behaviour


@pytest.mark.parametrize("mode, message", [
    ("exit3", r"^renderer 'mine' exited with status 3; the last lines of its stderr:\n"
              r"the renderer broke: no GPU found$"),
    ("hang", r"^renderer 'mine' did not finish within 1 s \(timeout in .*renderers\.toml\) and was stopped; "
             r"the last lines of its stderr:\nrendering forever$"),
    ("missing", r"^renderer 'mine': .*/output/step-4\.exr is missing \(every checkpoint of \[1, 2, 4\] must be "
                r"written\)$"),
    ("tiny", r"^renderer 'mine': step-1\.exr is 2x2, the scene is 16x12$"),
    # 20 MB of stderr on one line: the message quotes its last lines, bounded in bytes
    ("chatty", r"^renderer 'mine' exited with status 1; the last lines of its stderr:\n(.|\n){0,4200}out of memory$"),
    ("nan", r"^renderer 'mine': step-1\.exr: 1 pixel\(s\) are NaN or infinite$"),
])
def test_bad_external_renderer_is_one_clear_error(tmp_path, mode, message):
    # 1 s makes a hang quick to detect; writing 20 MB of stderr may take longer on a loaded machine
    config = renderer_toml(tmp_path, mode, timeout=30 if mode == "chatty" else 1)
    out = tmp_path / "out"
    settings = _settings(["mine"], renderer_config=str(config), ground_truth="grey")
    with pytest.raises(RendererError, match=message):
        run_mod.run([CORNELL], out, settings, progress=False, renderers=[GreyRenderer()], keep_going=False)
    assert not (out / "results.json").exists()
    assert not list(out.rglob("runs/*/mine/*"))  # nothing half-written kept as a result
    assert not list(Path(tempfile_dir()).glob("compare-job-mine-*"))


def test_bad_renderer_file_names_file_and_field(tmp_path, capsys):
    bad = tmp_path / "r.toml"
    bad.write_text('[renderer.mine]\ncommand = ["x", "{job}"]\nsteps = 0\n')
    assert main(["run", "--renderer-config", str(bad), "--renderers", "mine", "-o", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip() == (f"compare: error: {bad}: renderer.mine.steps: expected a positive "
                                               "integer, got 0")
    bad.write_text('[renderer.mitsuba]\ncommand = ["x", "{job}"]\n')
    assert main(["renderers", "--renderer-config", str(bad)]) == 2
    assert "renderer.mitsuba: the name is taken by a built-in renderer" in capsys.readouterr().err
    bad.write_text('[renderer.gone]\ncommand = ["no-such-renderer-here", "{job}"]\n')
    assert main(["renderers", "--renderer-config", str(bad)]) == 0
    line = next(l for l in capsys.readouterr().out.splitlines() if l.startswith("gone"))
    assert "not available: command 'no-such-renderer-here' is not on PATH" in line
    assert main(["run", "--renderer-config", str(bad), "--renderers", "gone", "-o", str(tmp_path / "o")]) == 2
    assert "renderer not available here: gone (command 'no-such-renderer-here' is not on PATH" \
        in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


# --------------------------------------------------------------------------- compare render, compare measure


def test_compare_render_takes_any_renderer(tmp_path, capsys):
    config = renderer_toml(tmp_path, "good")
    out = tmp_path / "mine.exr"
    assert main(["render", "--scene", str(CORNELL), "--renderer", "mine", "--renderer-config", str(config),
                 "--size", "16x12", "-o", str(out)]) == 0
    image, meta = read_exr(out)
    assert image.shape == (12, 16, 3) and meta["renderer"] == "mine" and meta["frames"] == 4
    assert "My renderer, 4 frames" in capsys.readouterr().out
    assert main(["render", "--scene", str(CORNELL), "--renderer", "nosuch", "-o", str(tmp_path / "x.exr")]) == 2
    assert "unknown renderer 'nosuch'" in capsys.readouterr().err


def test_compare_measure_reads_a_folder_made_anywhere(tmp_path, capsys):
    folder = tmp_path / "my-engine"
    folder.mkdir()
    w, h = SIZE
    for k, step in enumerate((1, 2, 4)):
        write_exr(folder / f"step-{step}.exr", np.full((h, w, 3), 0.3, np.float32))
    (folder / "timings.json").write_text(json.dumps({"setup_seconds": 0.2, "seconds": {"1": 0.1, "2": 0.2,
                                                                                        "4": 0.4}}))
    out = tmp_path / "measured"
    assert main(["measure", str(folder), "--scene", str(CORNELL), "--spp", "4", "--quiet", "-o", str(out)]) == 0
    res = Results.load(out / "results.json")
    run = res.scenes[0].runs[0]
    assert run.renderer == "my-engine" and [p.seconds for p in run.points] == [0.1, 0.2, 0.4]
    assert (res.scenes[0].width, res.scenes[0].height) == SIZE and (out / "index.html").is_file()
    (folder / "step-2.exr").unlink()
    (folder / "timings.json").write_text(json.dumps({"seconds": {"1": 0.1, "4": float("nan")}}))
    assert main(["measure", str(folder), "--scene", str(CORNELL), "--spp", "4", "--quiet", "-o", str(out)]) == 2
    assert 'seconds["4"]: expected cumulative seconds' in capsys.readouterr().err


def test_read_checkpoints_refuses_bad_timings(tmp_path):
    write_exr(tmp_path / "step-1.exr", np.zeros((2, 2, 3), np.float32))
    with pytest.raises(RendererError, match="timings.json is missing"):
        read_checkpoints(tmp_path, who="x", size=(2, 2), checkpoints=None)
    (tmp_path / "timings.json").write_text("{not json")
    with pytest.raises(RendererError, match="not valid JSON"):
        read_checkpoints(tmp_path, who="x", size=(2, 2), checkpoints=None)
    (tmp_path / "timings.json").write_text('{"setup_seconds": -1, "seconds": {"1": 0}}')
    with pytest.raises(RendererError, match="setup_seconds: expected a finite number >= 0, got -1"):
        read_checkpoints(tmp_path, who="x", size=(2, 2), checkpoints=None)


def test_job_gltf_holds_the_scene_in_world_space(tmp_path):
    from compare.scene.gltf_read import load_gltf

    scene = load_scene(CORNELL)
    doc = load_gltf(export_gltf(scene, tmp_path / "scene.gltf"))
    total = sum(len(m.triangles().indices) for m in scene.meshes)
    assert sum(len(p.mesh.indices) for p in doc.primitives) == total
    lo = np.min([p.mesh.positions.min(0) for p in doc.primitives], axis=0)
    assert np.allclose(lo, scene.bounds()[0], atol=1e-5)
    (cam,) = doc.cameras
    assert np.degrees(cam.yfov) == pytest.approx(scene.camera.fov)


def test_example_external_renderer_beside_mitsuba_and_the_rasterizer(tmp_path, gl_ctx):
    """examples/renderers.toml names examples/raycaster.py (no file of compare/ knows it): measured
    beside Mitsuba, it converges, and its direct light agrees with the rasterizer's (an independent
    implementation of the same light: both leave out indirect light)."""
    from compare.metrics.images import compare_images

    settings = RunSettings(frames=16, spp=16, sizes=[[32, 24]], renderers=["mitsuba", "progressive", "numpy-raycaster"],
                           renderer_config=str(ROOT / "examples" / "renderers.toml"))
    res = run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, gl_ctx=gl_ctx)
    ray, prog = res.scenes[0].run("numpy-raycaster"), res.scenes[0].run("progressive")
    assert [p.step for p in ray.points] == [1, 2, 4, 8, 16] and ray.metadata["triangles"] > 0
    assert ray.final.metrics["relmse"] < ray.points[0].metrics["relmse"]
    a, b = (read_exr(tmp_path / "out" / r.image)[0] for r in (prog, ray))
    between = compare_images(a, b)
    assert between["flip"] < 0.2 and abs(b.mean() / a.mean() - 1) < 0.1, between


def test_a_size_beyond_memory_is_refused_before_any_work(tmp_path, monkeypatch):
    from compare.util.errors import SceneError
    from compare.mitsuba import renderer as mitsuba

    monkeypatch.setattr(mitsuba, "_available_memory", lambda: 64 * 2**20)  # a machine with 64 MiB free
    settings = RunSettings(spp=4, sizes=[[1920, 1080]], renderers=["grey"])
    with pytest.raises(SceneError, match=r"cornell\.toml: camera\.resolution: 1920x1080 needs about 0\.2 GiB for "
                                         r"Mitsuba's film and the accumulation of its passes; 0\.1 GiB of memory "
                                         r"is available here$"):
        run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, renderers=[GreyRenderer()])
    assert not list((tmp_path / "out").rglob("*.exr"))


def test_blender_distribution_options_are_variants_with_their_own_key():
    """cycles:ggx / eevee:ggx set GGX everywhere: variants of their engine, keyed apart, matched with
    the reference's cycles-ggx mode for the likeness; bad options are named."""
    from compare.report.results import RunSettings

    reg = Registry()
    plain, ggx = reg.get("cycles"), reg.get("cycles:ggx")
    assert ggx.variant_of == "cycles" and "GGX" in ggx.variant_note and plain.variant_of is None
    scene = load_scene(CORNELL)
    default = RunSettings(materials="cycles")
    assert plain.key(scene, default) != ggx.key(scene, default)
    assert plain.models("cycles") and not ggx.models("cycles")
    assert ggx.models("cycles-ggx") and not plain.models("cycles-ggx")
    assert not plain.models("shared") and not reg.get("eevee").models("cycles")
    assert plain.key(scene, default) == plain.key(scene, RunSettings(materials="cycles", likeness=False))
    assert reg.get("eevee:ggx").variant_of == "eevee"
    for bad in ("cycles:nope", "eevee:ggx+msaa", "cycles:GGX"):
        with pytest.raises(ValueError, match=r"expected one of ggx|one distribution at a time"):
            Registry().get(bad)


def _fake_dist(tmp_path, monkeypatch, name: str, source: str, entry: str) -> None:
    """A package "installed" on sys.path with one compare.renderers entry point (its dist-info)."""
    site = tmp_path / f"site-{name}"
    pkg = site / name
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text(textwrap.dedent(source))
    info = site / f"{name}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name.replace('_', '-')}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[compare.renderers]\n{entry}\n")
    monkeypatch.syspath_prepend(str(site))


def test_a_plugin_that_does_not_subclass_renderer_is_one_clear_error(tmp_path, monkeypatch, capsys):
    """The attributes alone are not a renderer: the core relies on the base class, so the registry
    refuses anything else by name, in `compare renderers` and in `compare run`, without a traceback."""
    _fake_dist(tmp_path, monkeypatch, "duck_plugin", '''
        class Duck:
            name = "duck"
            label = "Duck"
            unit = "frame"

            def steps(self, settings):
                return 4

            def key(self, scene, settings):
                return []

            def render(self, scene, *, steps, checkpoints, seed, context):
                raise AssertionError("never called")
    ''', "duck = duck_plugin:Duck")
    reg = Registry()
    with pytest.raises(RendererError, match=r"duck_plugin\.Duck is not a renderer: subclass "
                                            r"compare\.renderers\.base\.Renderer"):
        reg.get("duck")
    rows = {r["name"]: r for r in reg.listing()}
    assert not rows["duck"]["available"] and "subclass compare.renderers.base.Renderer" in rows["duck"]["why"]
    assert main(["renderers"]) == 0
    assert "not a renderer" in capsys.readouterr().out
    code = main(["run", "--scenes", str(CORNELL), "--size", "16x12", "--renderers", "mitsuba,duck",
                 "--frames", "2", "--spp", "2", "-o", str(tmp_path / "out"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "subclass compare.renderers.base.Renderer" in err and "Traceback" not in err
    assert not (tmp_path / "out" / "results.json").exists()


def test_a_plugin_may_not_take_a_builtin_name(tmp_path, monkeypatch):
    _fake_dist(tmp_path, monkeypatch, "shadow_plugin", '''
        from compare.renderers import Renderer

        class Fake(Renderer):
            name = "mitsuba"

            def render(self, scene, *, steps, checkpoints, seed, context):
                raise AssertionError("never called")
    ''', "mitsuba = shadow_plugin:Fake")
    assert type(Registry().get("mitsuba")).__module__ == "compare.mitsuba.renderer"


def test_every_builtin_is_an_entry_point_and_its_options_come_from_its_declaration():
    reg = Registry()
    from importlib import metadata

    eps = {ep.name for ep in metadata.entry_points(group="compare.renderers") if ep.dist.name == "compare-pbr"}
    assert set(reg.builtins()) == eps
    for name in reg.builtins():
        cls = type(reg.get(name))
        for word in cls.OPTIONS:
            spec = f"{name}:{word.replace('<ms>', '16')}"
            assert reg.get(spec).name == spec
        with pytest.raises(ValueError, match="expected one of" if cls.OPTIONS else "takes no ':' options"):
            reg.get(f"{name}:nosuchoption")
        assert all(spec.partition(":")[0] == name for spec in cls.VARIANTS)
    for group, specs in reg.groups().items():
        assert reg.parse(group) == specs and all(reg.get(s) for s in specs)


def test_the_docs_table_of_builtins_is_the_registry():
    """docs/renderers.md lists exactly the registered built-ins, each with its declared options."""
    text = (ROOT / "docs" / "renderers.md").read_text(encoding="utf-8")
    start = text.index("<!-- builtins -->")
    end = text.index("<!-- /builtins -->")
    rows = [line for line in text[start:end].splitlines() if line.startswith("| `")]
    reg = Registry()
    documented = {row.split("`")[1]: row for row in rows}
    assert sorted(documented) == sorted(reg.builtins())
    for name, row in documented.items():
        for word in type(reg.get(name)).OPTIONS:
            assert f"`{word}`" in row, f"docs/renderers.md: {name}'s option {word} is missing"


def test_budgets_come_from_the_renderer_unless_the_run_names_one():
    reg = Registry()
    s = RunSettings(frames=7, spp=9)
    assert reg.get("progressive").steps(s) == 7 and reg.get("mitsuba").steps(s) == 9
    assert reg.get("cycles").steps(s) == 1024 and reg.get("eevee").steps(s) == 64
    s = RunSettings(frames=7, spp=9, budgets={"cycles": 5, "progressive:ltc": 3})
    assert reg.get("cycles").steps(s) == 5 and reg.get("cycles:ggx").steps(s) == 5
    assert reg.get("progressive:ltc").steps(s) == 3 and reg.get("progressive").steps(s) == 7
    # results.json written before per-renderer budgets still reads
    old = RunSettings.from_json({"frames": 7, "spp": 9, "cycles_spp": 16, "eevee_samples": 4})
    assert old.budgets == {"cycles": 16, "eevee": 4}


@pytest.mark.parametrize("name, message", [
    ("reference", "taken by a built-in renderer, a group .* or the ground truth's folder"),
    ("web", "taken by a built-in renderer, a group"),
    ("all", "taken by a built-in renderer, a group"),
    ("MINE", "a renderer's name is 1 to 64 lowercase letters"),
    ("a/b", "a renderer's name is 1 to 64 lowercase letters"),
    ("x" * 65, "a renderer's name is 1 to 64 lowercase letters"),
])
def test_renderer_names_that_would_corrupt_results_are_refused(tmp_path, name, message):
    from compare.renderers.registry import Registry
    from compare.renderers.external import ConfigError

    path = tmp_path / "r.toml"
    path.write_text(f'[renderer."{name}"]\ncommand = ["{{python}}", "r.py", "{{job}}"]\n')
    with pytest.raises(ConfigError, match=message):
        Registry(path)


def test_two_renderers_that_would_share_a_folder_are_refused_before_any_work(tmp_path):
    """An external 'progressive-paper' beside the built-in progressive:paper, or 'mine-seed1' beside a second
    seed of 'mine', would write into one folder: the run refuses, naming both."""
    from compare.run.scene_job import check_unit_folders

    check_unit_folders(["mitsuba", "progressive", "progressive:paper"], seeds=2)
    with pytest.raises(ValueError, match=r"renderer 'progressive-paper' and renderer 'progressive:paper' would share "
                                         r"the folder runs/<scene>/progressive-paper/"):
        check_unit_folders(["progressive:paper", "progressive-paper"])
    with pytest.raises(ValueError, match=r"renderer 'mine-seed1' and renderer 'mine' \(its seed 2\) would share"):
        check_unit_folders(["mine", "mine-seed1"], seeds=2)


def test_what_an_external_renderer_leaves_running_is_stopped_with_it(tmp_path):
    """A renderer runs in a process group of its own; when it exits, what it started goes too."""
    import os

    config = renderer_toml(tmp_path, "orphan")
    settings = _settings(["mine"], renderer_config=str(config), ground_truth="grey")
    run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, renderers=[GreyRenderer()])
    pid = int((tmp_path / "tools" / "orphan.pid").read_text())
    for _ in range(50):  # reaped by init: gone once it has been killed
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            break
        with open(f"/proc/{pid}/stat") as f:
            if f.read().split()[2] == "Z":
                break
        time.sleep(0.1)
    else:
        os.kill(pid, 9)
        pytest.fail("the renderer's child was still running after the run")


def test_sigterm_to_compare_stops_the_external_renderer_and_removes_its_job_folder(tmp_path):
    """SIGTERM to `compare` unwinds it as Ctrl-C does: the renderer's process group is killed and its job
    folder removed."""
    import os
    import signal
    import subprocess

    config = renderer_toml(tmp_path, "hang", name="hangs")
    temp = tmp_path / "temp"
    temp.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "compare.cli.main", "render", "--scene", str(CORNELL),
                             "--renderer", "hangs", "--renderer-config", str(config), "--size", "16x12",
                             "-o", str(tmp_path / "x.exr")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env={**os.environ, "TMPDIR": str(temp)})
    for _ in range(400):  # until the renderer has started
        started = list(temp.glob("compare-job-hangs-*"))
        if started and any((f / "stderr.txt").is_file() and (f / "stderr.txt").stat().st_size for f in started):
            break
        time.sleep(0.05)
    else:
        proc.kill()
        pytest.fail(f"the renderer did not start: {proc.communicate()[1].decode()[-500:]}")
    (folder,) = started
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode != 0 and b"Traceback" not in err
    assert not folder.exists()
    alive = [p for p in Path("/proc").iterdir() if p.name.isdigit() and (p / "cmdline").is_file()
             and str(tmp_path).encode() in (p / "cmdline").read_bytes()]
    for p in alive:
        os.kill(int(p.name), signal.SIGKILL)
    assert not alive, "the renderer outlived compare"


def test_a_job_folder_that_a_killed_run_left_is_swept_at_the_next_run(tmp_path, monkeypatch):
    import subprocess
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    dead = subprocess.Popen(["true"])
    dead.wait()
    left = tmp_path / "compare-job-mine-x1"
    left.mkdir()
    (left / "owner.pid").write_text(str(dead.pid))
    mine = tmp_path / "compare-job-mine-x2"  # this process's, in use
    mine.mkdir()
    (mine / "owner.pid").write_text(str(__import__("os").getpid()))
    config = renderer_toml(tmp_path, "good")
    settings = _settings(["mine"], renderer_config=str(config), ground_truth="grey")
    run_mod.run([CORNELL], tmp_path / "out", settings, progress=False, renderers=[GreyRenderer()])
    assert not left.exists() and mine.exists()


def _long_render_started(tmp_path: Path, temp: Path, args: list[str], what: str, marker: bytes = b""):
    """``(proc, children)``: a long `compare render` of the Cornell box (``args``: its renderer, budget and
    size) with the temporary folder ``temp``, once ``what`` runs; ``children()`` lists the processes besides
    compare whose command line names ``temp`` (and holds ``marker``) still alive (their /proc entries)."""
    import os
    import subprocess

    temp.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "compare.cli.main", "render", "--scene", str(CORNELL), *args,
                             "-o", str(tmp_path / "x.exr")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env={**os.environ, "TMPDIR": str(temp)})

    def children():
        return [p for p in Path("/proc").iterdir() if p.name.isdigit() and (p / "cmdline").is_file()
                and marker in (p / "cmdline").read_bytes() and str(temp).encode() in (p / "cmdline").read_bytes()
                and p.name != str(proc.pid)]

    for _ in range(600):  # until it runs
        if children():
            break
        time.sleep(0.05)
    else:
        proc.kill()
        pytest.fail(f"{what} did not start: {proc.communicate()[1].decode()[-500:]}")
    return proc, children


#: A Cycles render that runs far longer than the tests wait, and the name of its worker's script.
CYCLES_RENDER = (["--renderer", "cycles", "--samples", "100000", "--size", "64x48"], "Blender", b"worker.py")


@pytest.mark.bpy
def test_sigterm_to_compare_stops_a_blender_render_and_removes_its_folder(tmp_path):
    """The same for a Blender render: its worker process ends with `compare`, and its folder goes."""
    import os
    import signal

    temp = tmp_path / "temp"
    proc, workers = _long_render_started(tmp_path, temp, *CYCLES_RENDER)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode != 0 and b"Traceback" not in err
    left = workers()
    for p in left:
        os.kill(int(p.name), signal.SIGKILL)
    assert not left, "Blender's worker outlived compare"
    assert not list(temp.glob("compare-blender-*"))


@pytest.mark.bpy
def test_a_killed_compare_takes_its_blender_worker_with_it(tmp_path):
    """SIGKILL leaves compare no unwinding at all: the worker ends by itself (PR_SET_PDEATHSIG), where it used to
    render on, orphaned (and SIGTERM in the instant between the worker's start and compare holding its handle
    left it so too)."""
    import os
    import signal

    temp = tmp_path / "temp"
    proc, workers = _long_render_started(tmp_path, temp, *CYCLES_RENDER)
    time.sleep(0.5)  # past the worker's own start (its prctl)
    proc.kill()
    proc.communicate(timeout=60)
    for _ in range(40):  # the kernel kills it at once (without it, it rendered on: measured 3.5 s and more)
        left = workers()
        if not left:
            break
        time.sleep(0.05)
    for p in left:
        os.kill(int(p.name), signal.SIGKILL)
    assert not left, "Blender's worker outlived a killed compare"


@pytest.mark.web
def test_sigterm_to_compare_stops_a_web_render_and_its_browser(tmp_path):
    """The same for a web engine: Chromium and Playwright's driver end with `compare`, nothing of theirs
    is left in the temporary folder."""
    import os
    import signal

    temp = tmp_path / "temp"
    args = ["--renderer", "threejs", "--frames", "100000", "--size", "32x24"]
    proc, browsers = _long_render_started(tmp_path, temp, args, "the browser")
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode != 0 and b"Traceback" not in err
    for _ in range(100):  # the browser's processes may take a moment to go
        if not browsers():
            break
        time.sleep(0.05)
    left = browsers()
    for p in left:
        os.kill(int(p.name), signal.SIGKILL)
    assert not left, "the browser outlived compare"
    assert not [p for p in temp.iterdir() if p.name.startswith("compare-")]
