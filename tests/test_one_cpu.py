"""Every renderer on a machine with one CPU, and a SIGTERM that ends the process at any stage."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import ROOT

one_cpu = pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="needs CPU affinity (Linux)")


def _scene(folder: Path) -> Path:
    """A textured sphere on a textured floor under an environment map read from an EXR: what hung the
    reference on one CPU (Mitsuba's loader reads EXRs and textures through Dr.Jit's pool)."""
    from compare.image.exr import write_exr

    shutil.copyfile(ROOT / "scenes" / "stress" / "textures" / "leaves.png", folder / "leaves.png")
    sky = np.ones((16, 32, 3), dtype=np.float32) * np.linspace(0.2, 1.0, 16, dtype=np.float32)[:, None, None]
    write_exr(folder / "sky.exr", sky)
    path = folder / "scene.toml"
    path.write_text(textwrap.dedent("""
        [camera]
        position = [0.0, 1.0, 3.0]
        target = [0.0, 0.3, 0.0]
        resolution = [24, 16]

        [materials.leaves]
        base_color_texture = "leaves.png"
        roughness = 0.6

        [environment]
        file = "sky.exr"

        [[meshes]]
        shape = "sphere"
        translate = [0.0, 0.5, 0.0]
        radius = 0.5
        material = "leaves"

        [[meshes]]
        shape = "quad"
        size = [4.0, 4.0]
        material = "leaves"
        """), encoding="utf-8")
    return path


def _one_cpu() -> None:
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})


def _render_on_one_cpu(tmp_path: Path, renderer: str, *budget: str) -> subprocess.CompletedProcess:
    scene = _scene(tmp_path)
    out = tmp_path / f"{renderer}.exr"
    cmd = [sys.executable, "-m", "compare.cli.main", "render", "--scene", str(scene), "--renderer", renderer,
           *budget, "-o", str(out)]
    try:
        done = subprocess.run(cmd, preexec_fn=_one_cpu, capture_output=True, text=True, timeout=240,
                              start_new_session=True)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"{renderer} did not finish on one CPU in {exc.timeout} s")
    assert done.returncode == 0, done.stderr[-2000:]
    from compare.image.exr import read_exr

    image, _ = read_exr(out)
    assert image.shape == (16, 24, 3) and np.isfinite(image).all() and float(image.mean()) > 0.01
    return done


@one_cpu
@pytest.mark.parametrize("renderer, budget", [("mitsuba", ("--spp", "2")), ("progressive", ("--frames", "2"))])
def test_a_textured_environment_lit_scene_renders_on_one_cpu(tmp_path, renderer, budget):
    _render_on_one_cpu(tmp_path, renderer, *budget)


@one_cpu
@pytest.mark.bpy
def test_cycles_renders_on_one_cpu(tmp_path):
    _render_on_one_cpu(tmp_path, "cycles", "--spp", "2")


@one_cpu
@pytest.mark.web
def test_a_web_engine_renders_on_one_cpu(tmp_path):
    _render_on_one_cpu(tmp_path, "threejs", "--frames", "2")


def test_the_thread_pool_never_drops_below_what_the_loader_needs():
    """Whatever a caller asks (one job per core on two cores gives 1), Dr.Jit keeps the two threads
    Mitsuba's EXR loading needs."""
    from compare.mitsuba.backend import MIN_THREADS, load_mitsuba, set_thread_count

    load_mitsuba()
    import drjit as dr

    before = dr.thread_count()
    try:
        assert set_thread_count(1) == MIN_THREADS and dr.thread_count() == MIN_THREADS
    finally:
        dr.set_thread_count(before)


STUCK = """
import ctypes, signal, sys
from compare.cli import main as cli

cli.TERMINATE_GRACE_S = 0.5
signal.signal(signal.SIGTERM, cli._terminate)
cli._watch_signals()
# the main thread blocks SIGTERM and waits in C on a semaphore nobody posts: a library call that never
# returns to the interpreter, as a deadlocked native loader does
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
libc = ctypes.CDLL(None)
sem = ctypes.create_string_buffer(64)
libc.sem_init(sem, 0, 0)
print("ready", flush=True)
libc.sem_wait(sem)
"""


def test_sigterm_ends_a_process_stuck_in_native_code():
    proc = subprocess.Popen([sys.executable, "-c", STUCK], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT)
    try:
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(0.2)
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=20)
    finally:
        proc.kill()
    assert rc == 128 + signal.SIGTERM
    assert "terminated by signal 15 while inside native code" in proc.stderr.read()


def test_sigterm_still_unwinds_a_process_in_python(tmp_path):
    """The watchdog does not shortcut the clean exit: a process in Python code unwinds (exit 130, the
    interrupted message) well before the grace period."""
    script = tmp_path / "slow.py"
    script.write_text(textwrap.dedent("""
        import argparse, sys, time
        from compare.cli import main as cli
        def slow(args):
            print("ready", flush=True)
            time.sleep(60)
        def build():
            p = argparse.ArgumentParser()
            p.set_defaults(func=slow)
            return p
        cli._build_parser = build
        sys.argv = ["compare"]
        sys.exit(cli.main())
        """))
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT)
    try:
        assert proc.stdout.readline().strip() == "ready"
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=20)
        took = time.monotonic() - t0
    finally:
        proc.kill()
    assert rc == 130 and "interrupted" in proc.stderr.read()
    from compare.cli.main import TERMINATE_GRACE_S

    assert took < TERMINATE_GRACE_S
