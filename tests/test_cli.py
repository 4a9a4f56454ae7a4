"""The ``compare`` command: render, diff, errors as one line with exit status 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from compare.cli.main import main
from compare.image.exr import read_exr, write_exr
from tests.helpers import CORNELL


def test_render_mitsuba_writes_exr_with_metadata_and_png(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "ref.exr"
    assert main(["render", "--scene", str(CORNELL), "--renderer", "mitsuba", "--spp", "4", "--size", "32x24",
                 "-o", str(out)]) == 0
    image, meta = read_exr(out)
    assert image.shape == (24, 32, 3) and np.isfinite(image).all()
    assert meta["renderer"] == "mitsuba" and meta["spp"] == 4 and meta["seed"] == 0
    for key in ("variant", "seconds", "scene_hash", "package"):
        assert key in meta
    assert (tmp_path / "ref.png").is_file()
    assert "32x24" in capsys.readouterr().out


@pytest.mark.gl
def test_render_progressive_and_diff(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    ref, ours = tmp_path / "ref.exr", tmp_path / "ours.exr"
    assert main(["render", "--scene", str(CORNELL), "--spp", "16", "--size", "32x24", "-o", str(ref)]) == 0
    assert main(["render", "--scene", str(CORNELL), "--renderer", "progressive", "--frames", "8", "--size", "32x24",
                 "-o", str(ours)]) == 0
    assert read_exr(ours)[1]["renderer"] == "progressive"
    capsys.readouterr()
    assert main(["diff", str(ref), str(ours), "--maps", str(tmp_path / "maps")]) == 0
    text = capsys.readouterr().out
    for metric in ("ssim", "flip", "psnr", "relmse"):
        assert metric in text
    assert list((tmp_path / "maps").glob("*.png"))


@pytest.mark.gl
def test_render_progressive_variant(tmp_path, capsys):
    out = tmp_path / "vsm.exr"
    assert main(["render", "--scene", str(CORNELL), "--renderer", "progressive:vsm+budget1000", "--frames", "8",
                 "--size", "32x24", "-o", str(out)]) == 0
    meta = read_exr(out)[1]
    assert meta["shadow_filter"] == "vsm" and meta["distributor"] == "frame budget"
    assert "2 frames" in capsys.readouterr().out  # an ample budget: frame 0, then every sample in frame 1


def test_unknown_variant_is_refused_before_rendering(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["render", "--scene", str(CORNELL), "--renderer", "progressive:ssao", "-o", str(tmp_path / "x.exr")])
    assert exc.value.code == 2
    assert "unknown option 'ssao'" in capsys.readouterr().err


def test_bad_scene_is_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = -3\n')
    out = tmp_path / "x.exr"
    assert main(["render", "--scene", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"compare: error: {bad}: camera.fov: expected a vertical field of view in degrees in (0, 180), got -3"
    assert not out.exists()


def test_diff_refuses_nan_and_shape_mismatch(tmp_path, capsys):
    a = np.ones((16, 16, 3), np.float32)
    write_exr(tmp_path / "a.exr", a)
    write_exr(tmp_path / "b.exr", np.ones((16, 12, 3), np.float32))
    assert main(["diff", str(tmp_path / "a.exr"), str(tmp_path / "b.exr")]) == 2
    assert "shape" in capsys.readouterr().err
    (tmp_path / "c.exr").write_bytes(b"garbage")
    assert main(["diff", str(tmp_path / "a.exr"), str(tmp_path / "c.exr")]) == 2
    assert "c.exr" in capsys.readouterr().err


def test_help_on_every_command():
    for args in ([], ["render"], ["diff"], ["bench"]):
        out = subprocess.run([sys.executable, "-m", "compare.cli.main", *args, "--help"], capture_output=True, text=True)
        assert out.returncode == 0 and "usage: compare" in out.stdout


def test_bad_size_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as info:
        main(["render", "--scene", str(CORNELL), "--size", "big", "-o", "x.exr"])
    assert info.value.code == 2
    assert "expected WIDTHxHEIGHT" in capsys.readouterr().err


def _scene_copy(tmp_path) -> Path:
    """The Cornell box in tmp_path (it references no other file)."""
    scene = tmp_path / "s.toml"
    scene.write_text(CORNELL.read_text())
    return scene


@pytest.mark.parametrize("args, message", [
    (["-o", "{scene}"], "-o {scene}: the output must be a .exr file (ending in .exr)"),
    (["-o", "{tmp}/a.png"], "-o {tmp}/a.png: the output must be a .exr file (ending in .exr)"),
    (["-o", "{tmp}/a.exr", "--png", "{scene}"], "--png {scene}: the output must be a .png file (ending in .png)"),
    (["-o", "{tmp}/a.exr", "--png", "{tmp}/a.exr"], "--png {tmp}/a.exr: the output must be a .png file (ending in .png)"),
    (["-o", "{tmp}/s.EXR", "--png", "{tmp}/keep.png"], None),  # the kind is case-blind: this one renders
    (["-o", "{tmp}/twin.exr", "--png", "{tmp}/link.png"], "--png {tmp}/link.png: is an input of this command ({scene}); "
                                                           "choose another path"),
    (["-o", "{tmp}/ro/a.exr"], "-o {tmp}/ro/a.exr: cannot write in {tmp}/ro (permission denied)"),
    (["-o", "{tmp}/keep.png/a.exr"], "-o {tmp}/keep.png/a.exr: cannot be created, {tmp}/keep.png is a file, "
                                     "not a folder"),
    (["-o", "{tmp}/dir.exr"], "-o {tmp}/dir.exr: is a folder, not a file"),
])
def test_render_refuses_outputs_that_would_overwrite_before_rendering(tmp_path, capsys, monkeypatch, args, message):
    """Every refused output is named with its option, nothing is written or overwritten, no render runs."""
    import os

    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    scene = _scene_copy(tmp_path)
    (tmp_path / "link.png").symlink_to(scene)  # a second name of the scene file
    (tmp_path / "dir.exr").mkdir()
    (tmp_path / "ro").mkdir()
    os.chmod(tmp_path / "ro", 0o500)
    keep = tmp_path / "keep.png"
    keep.write_bytes(b"not to be lost")
    before = {p: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    fill = {"scene": str(scene), "tmp": str(tmp_path)}
    argv = ["render", "--scene", str(scene), "--spp", "2", "--size", "16x12"] + [a.format(**fill) for a in args]
    if message is None:
        assert main(argv) == 0
        assert (tmp_path / "s.EXR").is_file() and keep.read_bytes() != b"not to be lost"
        return
    if os.geteuid() == 0 and "permission" in message:  # root may write anywhere: deny it here as for a user
        real_access = os.access
        monkeypatch.setattr(os, "access", lambda p, mode: Path(p) != tmp_path / "ro" and real_access(p, mode))
    assert main(argv) == 2
    assert capsys.readouterr().err.strip() == f"compare: error: {message.format(**fill)}"
    after = {p: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    assert after == before  # nothing overwritten, nothing new
    assert not (tmp_path / "cache").exists()  # refused before any rendering


def test_render_refuses_to_overwrite_a_file_the_scene_reads(tmp_path, capsys):
    """An environment map the scene lights with is an input too: ``-o`` onto it is refused."""
    env = tmp_path / "sky.exr"
    write_exr(env, np.full((4, 8, 3), 0.5, np.float32))
    scene = tmp_path / "s.toml"
    scene.write_text(CORNELL.read_text() + '\n[environment]\nfile = "sky.exr"\n')
    before = env.read_bytes()
    assert main(["render", "--scene", str(scene), "--spp", "2", "--size", "16x12", "-o", str(env)]) == 2
    assert capsys.readouterr().err.strip() == (f"compare: error: -o {env}: is an input of this command ({env}); "
                                               "choose another path")
    assert env.read_bytes() == before


@pytest.mark.parametrize("command", ["run", "report", "diff"])
@pytest.mark.parametrize("where", ["a file", "below a file"])
def test_output_folders_that_are_files_are_refused_before_any_work(tmp_path, capsys, monkeypatch, command, where):
    """``compare run -o``, ``compare report -o`` and ``compare diff --maps`` onto a file (or below one):
    one error line naming the option and the path, the file untouched (before: a Python traceback)."""
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    blocker = tmp_path / "afile"
    blocker.write_bytes(b"keep")
    out = blocker if where == "a file" else blocker / "sub"
    exr = tmp_path / "a.exr"
    write_exr(exr, np.ones((12, 12, 3), np.float32))
    results = tmp_path / "results.json"
    results.write_text("{}")
    option = "--maps" if command == "diff" else "-o"
    argv = {"run": ["run", "--scenes", str(CORNELL), "--size", "16x12", "--frames", "2", "--spp", "2", "-o", str(out)],
            "report": ["report", str(results), "-o", str(out)],
            "diff": ["diff", str(exr), str(exr), "--maps", str(out)]}[command]
    assert main(argv) == 2
    why = "is a file, not a folder" if where == "a file" else f"cannot be created, {blocker} is a file, not a folder"
    assert capsys.readouterr().err.strip() == f"compare: error: {option} {out}: {why}"
    assert blocker.read_bytes() == b"keep" and not (tmp_path / "cache").exists()


@pytest.mark.parametrize("command", ["render", "diff"])
@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf"])
def test_a_bad_exposure_is_refused_before_any_work(tmp_path, capsys, command, value):
    """Before: ``compare render --exposure 0`` rendered, wrote the EXR, then ended in a traceback."""
    out = tmp_path / "x.exr"
    exr = tmp_path / "a.exr"
    write_exr(exr, np.ones((12, 12, 3), np.float32))
    argv = (["render", "--scene", str(CORNELL), "--size", "16x12", "--spp", "2", "-o", str(out)] if command == "render"
            else ["diff", str(exr), str(exr)])
    with pytest.raises(SystemExit) as exc:
        main(argv + ["--exposure", value])
    assert exc.value.code == 2
    assert capsys.readouterr().err.strip().endswith(
        f"compare {command}: error: argument --exposure: expected a positive finite number, got '{value}'")
    assert not out.exists()


def test_folders_that_cannot_be_written_are_one_error_before_any_work(tmp_path, capsys, monkeypatch):
    """/proc takes no new files, even for root (access() says it would): before, these ended in a
    FileNotFoundError traceback, the bench after all its work."""
    for argv, message in (
        (["run", "--size", "8x6", "--spp", "1", "--frames", "1", "--quiet", "-o", "/proc/compare-x"],
         "compare: error: -o /proc/compare-x: cannot write in /proc ("),
        (["bench", "--only", "first-frame", "-o", "/proc/compare-x.json"],
         "compare: error: -o /proc/compare-x.json: cannot write in /proc ("),
        (["diff", str(tmp_path / "a.exr"), str(tmp_path / "a.exr"), "--maps", "/proc/compare-maps"],
         "compare: error: --maps /proc/compare-maps: cannot write in /proc ("),
    ):
        assert main(argv) == 2
        assert capsys.readouterr().err.startswith(message), argv
    monkeypatch.setenv("COMPARE_CACHE", "/proc/compare-cache")
    assert main(["render", "--scene", str(CORNELL), "--spp", "1", "--size", "8x6", "-o", str(tmp_path / "x.exr")]) == 2
    assert capsys.readouterr().err.startswith("compare: error: $COMPARE_CACHE (the reference cache; set it to a "
                                              "writable folder) /proc/compare-cache: cannot write in /proc (")
    assert not (tmp_path / "x.exr").exists()


def _parsed_defaults(command: str, *required: str) -> dict:
    from compare.cli.main import _build_parser

    return vars(_build_parser().parse_args([command, *required]))


def test_option_defaults_are_the_settings_defaults():
    """Each option a settings dataclass declares takes its default from there: a changed default moves the CLI."""
    import dataclasses

    from compare.report.gate_settings import GateSettings
    from compare.report.results import RunSettings

    run = _parsed_defaults("run")
    run_fields = {f.name: f for f in dataclasses.fields(RunSettings)}
    for name in ("frames", "spp", "seed", "exposure", "materials", "likeness", "seeds", "ground_truth",
                 "baseline", "renderer_config", "spp_target", "spp_cap"):
        assert run[name] == getattr(RunSettings(), name), name
        assert run_fields[name].metadata["help"], name
    assert RunSettings.__doc__.count(" : ") == len(run_fields)  # every field documented once
    check = _parsed_defaults("check", "results.json")
    for f in dataclasses.fields(GateSettings):
        assert check[f.name] == getattr(GateSettings(), f.name), f.name
    render = _parsed_defaults("render", "--scene", "s.toml", "-o", "x.exr")
    measure = _parsed_defaults("measure", "images", "--scene", "s.toml", "-o", "out")
    for name in ("spp", "frames"):
        assert render[name] == getattr(RunSettings(), name)
    assert measure["spp"] == RunSettings().spp and measure["ground_truth"] == RunSettings().ground_truth


def test_material_modes_and_layer_titles_have_one_table():
    """The help texts and the report read the tables; every layer has a title."""
    from compare.brdf import MATERIAL_MODES
    from compare.cli.main import _build_parser
    from compare.image.layers import LAYER_TITLES, LAYERS

    assert set(LAYER_TITLES) == set(LAYERS)
    text = _build_parser()._subparsers._group_actions[0].choices["run"].format_help()
    def flat(t: str) -> str:  # argparse wraps at spaces and hyphens, by the terminal's width
        return "".join(t.split()).replace("-", "")

    for mode in ("shared", "cycles", "cycles-ggx"):
        assert flat(MATERIAL_MODES[mode]) in flat(text), mode
