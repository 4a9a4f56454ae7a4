"""Set-up seconds and peak memory per renderer, and how they grow with triangles and texels.

Two ``compare bench`` items:

``setup-seconds``
    the seconds from the start of a render until its first image can be drawn: loading the scene
    (glTF decoding, maps) plus the renderer's own set-up (:attr:`Rendering.setup_seconds`), median of
    ``--repeats`` warm runs (the decoded-file and image caches filled by a first run).
``setup-rss``
    the peak resident memory (MiB) of the same run: of its own process (``VmHWM``), or of the largest
    process it started and waited for (Blender's) where that is larger. The browser of the web engines is
    not waited for by this process (Playwright's driver starts it), so their figure is the Python side.

Each is measured per available renderer, each run in a process of its own, on the built-in car and on
a generated scene at 1×, 4× and 16× (:func:`scaled_scene`: 62,500 triangles and one 4096² map per ×,
so 16× is a million triangles and sixteen 4096² maps). A figure's ratio is the growth, 4× or 16× over
1×: 4 and 16 are linear, less is a fixed cost that the scene does not grow.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from compare.util.figures import Figure, median

__all__ = ["SCALES", "bench_setup", "probe", "scaled_scene"]

#: The generated scene's sizes, and what one × holds.
SCALES = (1, 4, 16)
TRIANGLES_PER_SCALE = 62_500
MAP_SIZE = 4096


def _map(seed: int, size: int) -> bytes:
    """A size² JPEG base-colour map: a checker over a colour ramp, different per seed."""
    from PIL import Image

    y, x = np.mgrid[0:size, 0:size].astype(np.float32) / size
    check = ((np.floor(x * 32) + np.floor(y * 32)) % 2).astype(np.float32)
    hue = (seed * 0.618) % 1.0
    rgb = np.stack([0.3 + 0.5 * x, 0.3 + 0.4 * ((y + hue) % 1.0), 0.3 + 0.5 * (1 - x)], axis=-1)
    rgb = rgb * (0.6 + 0.4 * check[..., None])
    buf = io.BytesIO()
    Image.fromarray((rgb * 255).astype(np.uint8)).save(buf, format="JPEG", quality=90)
    return buf.getvalue()


def scaled_scene(scale: int, folder: Path, *, triangles: int = TRIANGLES_PER_SCALE, map_size: int = MAP_SIZE) -> Path:
    """The generated scene at ``scale`` × (a GLB and a TOML around it) in ``folder``, written once: ``scale``
    spheres of ``triangles`` triangles, each with its own ``map_size``² base-colour map."""
    from compare.scene import geometry
    from compare.scene.gltf_write import GltfWriter
    from compare.util.files import write_bytes_atomic, write_text_atomic

    stem = f"scaled-{scale}x-{triangles}-{map_size}"
    toml = folder / f"{stem}.toml"
    if toml.is_file():
        return toml
    w = GltfWriter(generator="compare bench setup-seconds")
    # a UV sphere of about `triangles` triangles (2 · segments · rings, segments = 2 · rings)
    rings = max(2, round(np.sqrt(triangles / 4)))
    segments = max(3, round(triangles / (2 * rings)))
    side = int(np.ceil(np.sqrt(scale)))
    for k in range(scale):
        mesh = geometry.sphere(1.0, segments, rings)
        mat = w.material(f"m{k}", (1.0, 1.0, 1.0), 0.0, 0.5)
        w.doc["materials"][mat]["pbrMetallicRoughness"]["baseColorTexture"] = w.texture(_map(k, map_size), "image/jpeg")
        translation = [2.5 * (k % side), 1.0, 2.5 * (k // side)]
        w.node(f"sphere {k}", mesh=w.mesh(f"sphere {k}", [(mesh, mat)], uvs=True), translation=translation)
    write_bytes_atomic(folder / f"{stem}.glb", w.glb())
    write_text_atomic(toml, f"""name = "generated, {scale}x"
[[include]]
file = "{stem}.glb"

[camera]
target = "auto"
orbit = {{ theta = 30, phi = 60 }}

[environment]
constant = [1.0, 1.0, 1.0]
""")
    return toml


_PROBE = r"""
import json, resource, sys, time, warnings
warnings.simplefilter("ignore")
start = time.perf_counter()
from compare.renderers import RenderContext
from compare.renderers.registry import Registry
from compare.report.results import RunSettings
from compare.scene.loader import load_scene
spec, path, width, height = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
imported = time.perf_counter()
scene = load_scene(path).with_resolution(width, height)
loaded = time.perf_counter()
renderer = Registry().get(spec)
with RenderContext(RunSettings(frames=1, spp=1), cache_dir=False) as context:
    rendering = renderer.render(renderer.prepare(scene)[0], steps=1, checkpoints=[1], seed=0, context=context)
# VmHWM, not ru_maxrss: Linux carries ru_maxrss over exec, so a child of a large parent would report the
# parent's size; the high-water mark of this process's own memory starts afresh at exec
own = next((int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM:")),
           resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
print(json.dumps({"import": imported - start, "load": loaded - imported, "setup": rendering.setup_seconds,
                  "rss_mib": max(own, children) / 1024.0, "own_mib": own / 1024.0, "children_mib": children / 1024.0}))
"""


def probe(spec: str, scene: Path, size: tuple[int, int]) -> dict:
    """One render of one step of ``scene`` by ``spec`` in a fresh process: its import, scene-load and
    set-up seconds and its peak RSS (MiB)."""
    out = subprocess.run([sys.executable, "-c", _PROBE, spec, str(scene), str(size[0]), str(size[1])],
                         capture_output=True, text=True, timeout=3600)
    if out.returncode != 0:
        tail = (out.stderr or out.stdout).strip().splitlines()[-1:] or ["no output"]
        raise RuntimeError(f"{spec} on {scene.name}: {tail[0][-300:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def bench_setup(car: Path, folder: Path, *, size: tuple[int, int], repeats: int, renderers: list[str],
                progress=None, **scene_size) -> list[Figure]:
    """The ``setup-seconds`` and ``setup-rss`` figures of every renderer in ``renderers``; ``scene_size``:
    :func:`scaled_scene`'s ``triangles`` and ``map_size`` per ×."""
    scenes = {"car": car, **{f"{s}x": scaled_scene(s, folder, **scene_size) for s in SCALES}}
    figures = []
    failed = []
    for spec in renderers:
        runs: dict[str, list[dict]] = {}
        try:
            for label, path in scenes.items():
                probe(spec, path, size)  # warm-up: fills the decoded-file and image caches
                runs[label] = [probe(spec, path, size) for _ in range(max(repeats, 1))]
                if progress:
                    progress(f"{spec} {label}")
        except RuntimeError as exc:  # one renderer's failure leaves the others' figures
            failed.append(str(exc))
            continue
        seconds = {k: [r["load"] + r["setup"] for r in v] for k, v in runs.items()}
        rss = {k: [r["rss_mib"] for r in v] for k, v in runs.items()}
        note = lambda k: (f"scene load {median([r['load'] for r in runs[k]]):.2f} s + set-up "  # noqa: E731
                          f"{median([r['setup'] for r in runs[k]]):.2f} s; import {median([r['import'] for r in runs[k]]):.2f} s")
        figures.append(Figure("setup-seconds", f"{spec} car", f"{spec} 1x", median(seconds["car"]),
                              median(seconds["1x"]), "s", repeats, note("car"), seconds["car"], seconds["1x"]))
        figures.append(Figure("setup-rss", f"{spec} car", f"{spec} 1x", median(rss["car"]), median(rss["1x"]),
                              "MiB", repeats, "", rss["car"], rss["1x"]))
        for s in SCALES[1:]:
            k = f"{s}x"
            figures.append(Figure("setup-seconds", f"{spec} {k}", f"{spec} 1x", median(seconds[k]),
                                  median(seconds["1x"]), "s", repeats, f"growth (linear: {s}); {note(k)}",
                                  seconds[k], seconds["1x"]))
            figures.append(Figure("setup-rss", f"{spec} {k}", f"{spec} 1x", median(rss[k]), median(rss["1x"]),
                                  "MiB", repeats, f"growth (linear: {s})", rss[k], rss["1x"]))
    if failed and not figures:
        raise RuntimeError("; ".join(failed))
    for why in failed:
        import warnings

        warnings.warn(f"setup-seconds: {why}", stacklevel=2)
    return figures
