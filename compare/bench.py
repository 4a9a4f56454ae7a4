"""``compare bench``: speed and memory figures, measured side by side in one run.

These machines are noisy, so every figure is a **ratio of medians** of runs that
alternate between the two sides (A, B, A, B, …) so slow drift hits both alike;
absolute times are printed for context only. How to read each figure:

``first-frame``
    median wall time of frame 1 ÷ median of the mean frame time of a whole
    run. Frame 1 is the cheap preview (environment only, or the unshadowed
    direct estimate without an environment), forward-shaded in one pass, at half
    size from 320×240 up (:mod:`compare.progressive.first_frame`). The paper reports 0.98 ms against
    a 6.4 ms average (≈ 0.15). Lower is better. ``first-frame-total`` divides
    by the whole run instead; ``first-frame-full-size`` is the same ratio with
    frame 0 drawn at full size (``first_frame_scale=1``), in the same run.
``depth-floor``
    median frame time ÷ median time of a depth-only pass of the same geometry
    at the same size: how far a frame is above the cost a rasterizer cannot
    avoid. 1 would mean shading is free.
``wrapper-overhead``
    the reference wrapper's render of one pass ÷ a bare ``mi.render`` of the
    same Mitsuba scene dictionary with the same spp; 1.00 means no overhead.
``equal-error``
    the seconds Mitsuba needs to reach the progressive renderer's final FLIP
    (interpolated on the log–log spp ladder, measured against an independent
    high-spp ground truth) ÷ the progressive renderer's seconds for all its
    frames: > 1 means the rasterizer reaches that error faster. Given against
    the full reference and against the direct-light-only reference; ``equal-error-direct-ltc``
    is the same for the ``ltc`` area model (:mod:`compare.progressive.ltc`) against the
    direct-light-only reference, ``equal-error-full-ltc-probes`` for ``ltc`` with the
    irradiance probes against the full reference.
``area-model-ltc``, ``area-model-paper``
    median of the mean frame time with the ``ltc`` (closed-form unshadowed light, shadow ratio) or
    the paper's point-light area model ÷ the same with the radiometric default, runs
    alternating. > 1 means the model costs more per frame.
``frame-budget``
    seconds to reach a target FLIP (1.1 × the fixed plan's final FLIP against
    the direct-light-only reference, which more samples converge to) with a per-frame time budget
    (:mod:`compare.progressive.budget`; 16 ms and 100 ms) ÷ the same with the
    paper's fixed plan of ``--frames`` frames. < 1 means the budget gets there
    sooner. Medians of ``--repeats`` alternating runs.
``peak-rss``
    peak resident memory (MiB) of a separate process doing a 1080p progressive
    run and one doing a 1080p reference pass; their ratio is progressive ÷ reference.
``eevee``
    progressive (all frames) ÷ EEVEE (64 samples) render seconds, when the
    ``blender`` extra is installed (the paper's Table 1 comparison).
"""

from __future__ import annotations

import json
import math
import platform
import statistics
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .fsutil import write_text_atomic

ITEMS = ("first-frame", "depth-floor", "area-models", "wrapper-overhead", "equal-error", "frame-budget", "peak-rss",
         "eevee")
#: Per-frame budgets (ms) of the frame-budget item.
BUDGETS_MS = (16.0, 100.0)


@dataclass
class Figure:
    """One benchmark figure: two medians and their ratio (A ÷ B)."""

    name: str
    a: str
    b: str
    a_median: float
    b_median: float
    unit: str
    repeats: int
    note: str = ""
    a_samples: list[float] = field(default_factory=list)
    b_samples: list[float] = field(default_factory=list)

    @property
    def ratio(self) -> float:
        return self.a_median / self.b_median if self.b_median > 0 else math.inf

    def to_json(self) -> dict:
        d = asdict(self)
        d["ratio"] = self.ratio if math.isfinite(self.ratio) else None
        return d


def _median(xs) -> float:
    return float(statistics.median(xs))


def bench_first_frame(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Frame 1 against the mean frame and the total of a whole progressive run; the same with frame 0
    drawn at full size, alternating with the default (half size) run for run."""
    from .progressive import ProgressiveRenderer
    from .progressive.first_frame import auto_scale

    scales = (auto_scale((scene.camera.width, scene.camera.height)), 1.0)  # the default, then full size
    first, mean, total = ([], []), ([], []), []
    renderers = []
    try:
        for k in scales:
            renderers.append(ProgressiveRenderer(scene, frames=frames, ctx=ctx, first_frame_scale=k))
        for _ in range(repeats):
            for i, r in enumerate(renderers):
                r.reset()
                for _ in r.frames():
                    pass
                first[i].append(r.frame_seconds[0])
                mean[i].append(float(np.mean(r.frame_seconds)))
                if i == 0:
                    total.append(r.seconds)
    finally:
        for r in renderers:
            r.release()
    return [
        Figure("first-frame", "frame 1", f"mean frame of {frames}", _median(first[0]), _median(mean[0]), "s",
               repeats, f"frame 0 at {scales[0]:g} of each axis; paper: 0.98 ms / 6.4 ms ≈ 0.15", first[0], mean[0]),
        Figure("first-frame-total", "frame 1", f"all {frames} frames", _median(first[0]), _median(total), "s",
               repeats, "", first[0], total),
        Figure("first-frame-full-size", "frame 1 (full size)", f"mean frame of {frames}", _median(first[1]),
               _median(mean[1]), "s", repeats, "frame 0 at full size, alternating with the runs above",
               first[1], mean[1]),
    ]


def bench_depth_floor(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Mean frame time against a depth-only pass of the same geometry and size."""
    from .progressive import ProgressiveRenderer
    from .progressive.depth_only import DepthOnlyPass

    frame_t, floor_t = [], []
    with ProgressiveRenderer(scene, frames=frames, ctx=ctx) as r:
        depth = DepthOnlyPass(ctx, r.gpu_scene, r.size)
        try:
            vp = r.camera.view_proj((0.0, 0.0))
            depth.render(vp)  # first draw compiles the program: keep it out of the timing
            ctx.finish()
            for _ in range(repeats):
                r.reset()
                for _ in r.frames():
                    pass
                frame_t.append(float(np.mean(r.frame_seconds)))
                times = []
                for _ in range(frames):
                    t0 = time.perf_counter()
                    depth.render(vp)
                    ctx.finish()
                    times.append(time.perf_counter() - t0)
                floor_t.append(float(np.mean(times)))
        finally:
            depth.release()
    return [Figure("depth-floor", "mean frame", "depth-only pass", _median(frame_t), _median(floor_t), "s", repeats,
                   "", frame_t, floor_t)]


def bench_wrapper_overhead(scene, *, spp: int, repeats: int) -> list[Figure]:
    """ReferenceRenderer.render_chunk against a bare mi.render of the same dictionary."""
    from .mitsuba_dict import scene_dict
    from .reference import ReferenceRenderer

    r = ReferenceRenderer(scene, cache_dir=False, progress=False)
    mi = r.mi
    bare_scene = mi.load_dict(scene_dict(scene, spp=1))
    r.render_chunk(spp, 0)  # JIT both once
    np.array(mi.render(bare_scene, spp=spp, seed=0))
    wrapped, bare = [], []
    for k in range(repeats):
        t0 = time.perf_counter()
        r.render_chunk(spp, 1000 + k)
        wrapped.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        np.array(mi.render(bare_scene, spp=spp, seed=2000 + k))
        bare.append(time.perf_counter() - t0)
    return [Figure("wrapper-overhead", "ReferenceRenderer pass", "bare mi.render", _median(wrapped), _median(bare),
                   "s", repeats, f"{spp} spp, cache off", wrapped, bare)]


def time_to_error(seconds: list[float], errors: list[float], target: float) -> float:
    """Seconds at which a log–log interpolated error curve first reaches ``target`` (inf if never).

    Before the first checkpoint nothing is known: if the first checkpoint is
    already below the target, its time is returned (an upper bound).
    """
    for k, (t, e) in enumerate(zip(seconds, errors)):
        if e <= target:
            if k == 0:
                return float(t)
            t0, e0 = seconds[k - 1], errors[k - 1]
            if e0 <= 0 or e <= 0 or e0 == e:
                return float(t)
            f = (math.log(target) - math.log(e0)) / (math.log(e) - math.log(e0))
            return float(math.exp(math.log(t0) + f * (math.log(t) - math.log(t0))))
    return math.inf


def bench_equal_error(scene, *, frames: int, spp: int, ctx) -> list[Figure]:
    """Mitsuba's time to reach the rasterizer's final FLIP, ÷ the rasterizer's time; against the
    direct-light reference also for the ``ltc`` area model (one Mitsuba ladder for both)."""
    from .metrics import flip
    from .progressive import render_progressive
    from .reference import ReferenceRenderer, derive_seed

    # (figure suffix, renderer options, references it is judged against): against the full
    # reference the plain technique misses the indirect light whatever its area model, so the
    # ltc figure there is given with the irradiance probes on.
    runs = [("", {}, ("full", "direct"))]
    if scene.lights:
        runs += [("-ltc", {"area_model": "ltc"}, ("direct",)),
                 ("-ltc-probes", {"area_model": "ltc", "indirect": "probes"}, ("full",))]
    progs = {suffix: (render_progressive(scene, frames=frames, ctx=ctx, **kw), refs) for suffix, kw, refs in runs}
    out = []
    for label, depth in (("full", None), ("direct", 2)):
        r = ReferenceRenderer(scene, max_depth=depth, progress=False)
        truth = r.render(4 * spp, seed=derive_seed("bench-ground-truth")).image
        ladder = r.ladder(spp, seed=0)
        errors = [flip(truth, c.image)[0] for c in ladder]
        for suffix, (prog, refs) in progs.items():
            if label not in refs:
                continue
            target = flip(truth, prog.image)[0]
            t = time_to_error([c.seconds for c in ladder], errors, target)
            what = prog.metadata["area_model"] + (", probes" if prog.metadata.get("indirect") == "probes" else "")
            note = (f"vs {label} reference; progressive ({what}) FLIP {target:.4f}; Mitsuba FLIP at 1 spp "
                    f"{errors[0]:.4f}, at {spp} spp {errors[-1]:.4f}")
            if math.isinf(t):
                note += f"; Mitsuba did not reach it within {spp} spp (ratio is a lower bound)"
                t = ladder[-1].seconds
            out.append(Figure(f"equal-error-{label}{suffix}", "Mitsuba to same FLIP",
                              f"progressive ({what}) {frames} frames", t, prog.seconds, "s", 1, note))
    return out


def bench_area_models(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Mean frame time of the ``ltc`` and the ``paper`` area models ÷ the radiometric default,
    run for run alternating."""
    from .progressive import ProgressiveRenderer

    if not scene.lights:
        raise RuntimeError("the scene has no area lights: the area models do not differ")
    models = ("radiometric", "ltc", "paper")
    mean: dict[str, list[float]] = {m: [] for m in models}
    renderers = []
    try:
        for m in models:
            renderers.append(ProgressiveRenderer(scene, frames=frames, ctx=ctx, area_model=m))
        for _ in range(repeats):
            for m, r in zip(models, renderers):
                r.reset()
                for _ in r.frames():
                    pass
                mean[m].append(float(np.mean(r.frame_seconds)))
    finally:
        for r in renderers:
            r.release()
    base = mean["radiometric"]
    return [Figure(f"area-model-{m}", f"{m} mean frame", "radiometric mean frame", _median(mean[m]),
                   _median(base), "s", repeats, f"{len(scene.lights)} light(s), {frames} frames", mean[m], base)
            for m in models[1:]]


def bench_frame_budget(scene, *, frames: int, spp: int, repeats: int, ctx) -> list[Figure]:
    """Time to a target FLIP with a frame budget ÷ with the fixed plan (checkpoints at every frame)."""
    from .metrics import flip
    from .progressive import render_progressive
    from .reference import ReferenceRenderer, derive_seed

    # Against the direct-light-only reference: that is what more samples converge to (the full
    # reference's error is dominated by the missing indirect light at every frame count).
    truth = ReferenceRenderer(scene, max_depth=2, progress=False).render(
        4 * spp, seed=derive_seed("bench-ground-truth")).image

    def curve(budget):
        res = render_progressive(scene, frames=frames, ctx=ctx, checkpoints="every", frame_budget_ms=budget)
        return ([c.seconds for c in res.checkpoints], [flip(truth, c.image)[0] for c in res.checkpoints],
                len(res.frame_seconds))

    runs: dict = {None: [], **{b: [] for b in BUDGETS_MS}}
    for _ in range(repeats):
        for budget in runs:
            runs[budget].append(curve(budget))
    target = 1.1 * _median([errors[-1] for _, errors, _ in runs[None]])
    fixed = [time_to_error(t, e, target) for t, e, _ in runs[None]]
    out = []
    for budget in BUDGETS_MS:
        times = [time_to_error(t, e, target) for t, e, _ in runs[budget]]
        n = _median([k for _, _, k in runs[budget]])
        final = _median([e[-1] for _, e, _ in runs[budget]])
        out.append(Figure(f"frame-budget-{budget:g}ms", f"budget {budget:g} ms to FLIP {target:.4f}",
                          f"fixed {frames} frames to it", _median(times), _median(fixed), "s", repeats,
                          f"{n:g} frames with the budget, final FLIP {final:.4f}", times, fixed))
    return out


_RSS_SCRIPT = """
import resource, sys
from compare.scene import load_scene
scene = load_scene(sys.argv[2]).with_resolution(1920, 1080)
if sys.argv[1] == "progressive":
    from compare.progressive import render_progressive
    render_progressive(scene, frames=int(sys.argv[3]))
elif sys.argv[1] == "reference":
    from compare.reference import ReferenceRenderer
    ReferenceRenderer(scene, cache_dir=False, progress=False).render_chunk(int(sys.argv[3]), 0)
else:
    import compare.progressive, compare.reference, mitsuba, moderngl
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


def _peak_rss_mib(kind: str, scene_path: str, count: int) -> float:
    out = subprocess.run([sys.executable, "-c", _RSS_SCRIPT, kind, scene_path, str(count)], check=True,
                         capture_output=True, text=True)
    return int(out.stdout.strip().splitlines()[-1]) / 1024.0  # ru_maxrss is KiB on Linux


def bench_peak_rss(scene_path: str, *, frames: int, spp: int) -> list[Figure]:
    """Peak RSS of a 1080p progressive run and of a 1080p reference pass, each in its own process."""
    base = _peak_rss_mib("imports", scene_path, 0)
    prog = _peak_rss_mib("progressive", scene_path, frames)
    ref = _peak_rss_mib("reference", scene_path, min(spp, 64))
    return [Figure("peak-rss", "progressive 1080p", "reference 1080p pass", prog, ref, "MiB", 1,
                   f"imports alone: {base:.0f} MiB; reference pass of {min(spp, 64)} spp (the largest pass)")]


def bench_eevee(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Progressive (all frames) against EEVEE at 64 samples, both through the registry; needs the
    ``blender`` extra."""
    from .renderers import RenderContext, Registry
    from .results import RunSettings

    reg = Registry()
    prog_r, eevee_r = reg.get("progressive"), reg.get("eevee")
    ok, why = eevee_r.available()
    if not ok:
        raise RuntimeError(f"eevee is not available: {why}")
    settings = RunSettings(frames=frames, eevee_samples=64)
    prog, eevee = [], []
    with RenderContext(settings) as context:
        context.provide("gl", ctx)
        for k in range(repeats):
            for r, times in ((prog_r, prog), (eevee_r, eevee)):
                steps = r.steps(settings)
                times.append(r.render(scene, steps=steps, checkpoints=[steps], seed=k,
                                      context=context).checkpoints[-1].seconds)
    return [Figure("eevee", f"progressive {frames} frames", "EEVEE 64 samples", _median(prog), _median(eevee), "s",
                   repeats, "the paper's Table 1 ratio", prog, eevee)]


def environment_info(ctx=None) -> dict:
    """CPU, core count, GL renderer and versions, for the record."""
    import os

    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    info = {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version()}
    if ctx is not None:
        info["gl_renderer"] = ctx.info.get("GL_RENDERER", "")
    for mod in ("mitsuba", "drjit", "moderngl", "numpy"):
        try:
            info[mod] = __import__(mod).__version__
        except Exception:  # noqa: BLE001 - a version string is optional information
            info[mod] = "unavailable"
    return info


def run_bench(scene_path: str | Path, *, size: tuple[int, int], frames: int, spp: int, repeats: int,
              items: tuple[str, ...] = ITEMS, progress: bool = True) -> dict:
    """Run the chosen benchmark items; returns a JSON-ready dict (figures, skipped items, environment)."""
    from tqdm.auto import tqdm

    from .progressive.context import create_context
    from .scene import load_scene

    scene = load_scene(scene_path).with_resolution(*size)
    ctx = create_context()
    figures: list[Figure] = []
    skipped: dict[str, str] = {}
    try:
        for item in tqdm(items, desc="bench", disable=not progress):
            try:
                if item == "first-frame":
                    figures += bench_first_frame(scene, frames=frames, repeats=repeats, ctx=ctx)
                elif item == "depth-floor":
                    figures += bench_depth_floor(scene, frames=frames, repeats=repeats, ctx=ctx)
                elif item == "area-models":
                    figures += bench_area_models(scene, frames=frames, repeats=repeats, ctx=ctx)
                elif item == "wrapper-overhead":
                    figures += bench_wrapper_overhead(scene, spp=min(spp, 64), repeats=repeats)
                elif item == "equal-error":
                    figures += bench_equal_error(scene, frames=frames, spp=spp, ctx=ctx)
                elif item == "frame-budget":
                    figures += bench_frame_budget(scene, frames=frames, spp=spp, repeats=repeats, ctx=ctx)
                elif item == "peak-rss":
                    figures += bench_peak_rss(str(scene_path), frames=frames, spp=spp)
                elif item == "eevee":
                    figures += bench_eevee(scene, frames=frames, repeats=repeats, ctx=ctx)
                else:
                    raise ValueError(f"unknown benchmark item {item!r} (known: {', '.join(ITEMS)})")
            except RuntimeError as exc:
                skipped[item] = str(exc)
        env = environment_info(ctx)
    finally:
        ctx.release()
    return {"schema": 1, "scene": str(scene_path), "size": list(size), "frames": frames, "spp": spp,
            "repeats": repeats, "figures": [f.to_json() for f in figures], "skipped": skipped, "environment": env}


def format_table(result: dict) -> str:
    """The figures as a plain-text table."""
    rows = [("figure", "A", "B", "A median", "B median", "A/B")]
    for f in result["figures"]:
        unit = f["unit"]
        fmt = (lambda v: f"{v * 1e3:.2f} ms") if unit == "s" else (lambda v: f"{v:.1f} {unit}")
        ratio = "inf" if f["ratio"] is None else f"{f['ratio']:.3f}"
        rows.append((f["name"], f["a"], f["b"], fmt(f["a_median"]), fmt(f["b_median"]), ratio))
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    for f in result["figures"]:
        if f["note"]:
            lines.append(f"  {f['name']}: {f['note']}")
    for item, why in result["skipped"].items():
        lines.append(f"  skipped {item}: {why}")
    return "\n".join(lines)


def add_bench_parser(subparsers) -> None:
    """Register ``compare bench``."""
    import argparse

    from .argtypes import parse_size

    p = subparsers.add_parser("bench", help="speed and memory ratios measured side by side (medians)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", type=Path, default=Path("scenes/cornell.toml"), help="scene file")
    p.add_argument("--size", type=parse_size, default=(320, 240), help="WIDTHxHEIGHT")
    p.add_argument("--frames", type=int, default=128, help="progressive frames")
    p.add_argument("--spp", type=int, default=256, help="reference samples per pixel (equal-error ladder)")
    p.add_argument("--repeats", type=int, default=5, help="repeated runs per side (medians)")
    p.add_argument("--only", default=",".join(ITEMS), help=f"comma-separated items of: {', '.join(ITEMS)}")
    p.add_argument("-o", "--output", type=Path, default=Path("reports/bench.json"), help="JSON output")
    p.set_defaults(func=_cmd_bench)


def _cmd_bench(args) -> int:
    items = tuple(x.strip() for x in args.only.split(",") if x.strip())
    bad = [x for x in items if x not in ITEMS]
    if bad:
        print(f"compare bench: error: unknown item(s) {', '.join(bad)}; known: {', '.join(ITEMS)}", file=sys.stderr)
        return 2
    result = run_bench(args.scene, size=args.size, frames=args.frames, spp=args.spp, repeats=args.repeats,
                       items=items)
    write_text_atomic(args.output, json.dumps(result, indent=2))
    print(format_table(result))
    print(f"written {args.output}")
    return 0
