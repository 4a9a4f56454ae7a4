"""``compare bench``: speed and memory figures, measured side by side in one run.

These machines are noisy, so every figure is a **ratio of medians** of runs that
alternate between the two sides (A, B, A, B, …) so slow drift hits both alike;
absolute times are printed for context only. Renderers are reached through the
registry (:mod:`compare.renderers`): the items that compare renderers render through
the protocol; ``first-frame``, ``depth-floor``, ``area-models``, ``textures`` (the rasterizer's),
``wrapper-overhead`` and ``reference-dask`` (Mitsuba's) time a renderer's internals (:mod:`compare.bench.progressive`,
:mod:`compare.bench.reference`). How to read
each figure:

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
``reference-dask``
    wall seconds of a reference of many small chunks (up to 64 spp in chunks of
    at most 4) rendered here ÷ the same render with its chunks on a 2-worker
    dask ``LocalCluster`` (:mod:`compare.mitsuba.cluster`, the pixels the same):
    the speed-up of spreading one reference; > 1 means the workers are faster.
    Skipped without the ``dask`` extra.
``equal-error``
    the seconds Mitsuba needs to reach the progressive renderer's final FLIP
    (interpolated on the log–log spp ladder, measured against an independent
    high-spp ground truth) ÷ the progressive renderer's seconds for all its
    frames: > 1 means the rasterizer reaches that error faster; both times are medians of
    ``--repeats`` alternating runs. Given against
    the full reference and against the direct-light-only reference; ``equal-error-direct-ltc``
    is the same for the ``ltc`` area model (:mod:`compare.progressive.lights.ltc`) against the
    direct-light-only reference, ``equal-error-full-ltc-probes`` for ``ltc`` with the
    irradiance probes against the full reference; ``equal-error-full-envshadows`` and
    ``-direct-envshadows`` for the environment shadow maps (scenes with an environment).
``env-shadows``, ``env-shadows-first``
    median of the mean frame time, and of the first frame's, of ``progressive:envshadows`` ÷
    ``progressive``, runs alternating (scenes with an environment).
``area-model-ltc``, ``area-model-paper``
    median of the mean frame time with the ``ltc`` (closed-form unshadowed light, shadow ratio) or
    the paper's point-light area model ÷ the same with the radiometric default, runs
    alternating. > 1 means the model costs more per frame.
``textures``
    median of the mean frame time of the scene with its maps and alpha masks ÷ the same scene with
    its materials' factors only, runs alternating (the cost of texturing; the rasterizer's item). > 1
    means texturing costs per frame.
``transmission``
    median of the mean frame time of the scene with its glass (the glass pass) ÷ the same scene with every
    transmission 0 (the glass opaque, in the G-buffer), runs alternating (scenes with glass; the rasterizer's).
    > 1 means glass costs per frame.
``frame-budget``
    seconds to reach a target FLIP (1.1 × the fixed plan's final FLIP against
    the direct-light-only reference, which more samples converge to) with a per-frame time budget
    (:mod:`compare.progressive.schedule.budget`; 16 ms and 100 ms) ÷ the same with the
    paper's fixed plan of ``--frames`` frames. < 1 means the budget gets there
    sooner. Medians of ``--repeats`` alternating runs.
``peak-rss``
    peak resident memory (MiB) of a separate process doing a 1080p progressive
    run and one doing a 1080p Mitsuba render of up to 64 spp; their ratio is progressive ÷ Mitsuba.
``eevee``
    progressive (all frames) ÷ EEVEE (64 samples) render seconds, when the
    ``blender`` extra is installed (the paper's Table 1 comparison).
``setup-seconds``, ``setup-rss``
    per available renderer, the seconds before the first image (scene load + the renderer's set-up)
    and the peak resident memory of a two-step render in a process of its own, on the built-in car
    (``--setup-scene``), on a generated interior shaped as a downloaded one (178k triangles) and on a
    generated scene at 1×, 4× and 16× (62,500 triangles and one 4096² map per ×): the ratios are the
    growth over 1× (linear: 4 and 16), the interior's over the car; every variant (each progressive
    option word, its switches together, the declared variants) on the car and the interior. See
    :mod:`compare.bench.setup_cost`.
"""

from __future__ import annotations

import math
import platform
import subprocess
import sys
from pathlib import Path

from compare.util.errors import CompareError, MissingComponentError
from compare.util.figures import Figure, median as _median, time_to_error

#: The items this module measures itself; those about an engine's internals are in compare.bench.progressive
#: and compare.bench.reference.
SUITE_ITEMS = ("equal-error", "frame-budget", "peak-rss", "eevee", "setup-seconds", "setup-rss")
#: The items measured together by one series of runs (compare.bench.setup_cost).
SETUP_ITEMS = ("setup-seconds", "setup-rss")
#: Per-frame budgets (ms) of the frame-budget item.
BUDGETS_MS = (16.0, 100.0)


def _render(registry, spec: str, scene, *, steps: int, checkpoints=None, seed: int = 0, context):
    """A render through the protocol (checked as ``compare run`` checks it)."""
    from compare.renderers import check_rendering

    r = registry.get(spec)
    cps = list(checkpoints or [steps])
    return check_rendering(r, r.render(r.prepare(scene)[0], steps=steps, checkpoints=cps, seed=seed, context=context),
                           scene=scene, checkpoints=cps)


def _context(context, *, cache: bool = True):
    """``context``'s settings with the reference cache off for ``cache=False`` (a timed render must be
    rendered, not read back with the seconds of whichever run once filled the cache)."""
    from compare.renderers import RenderContext

    return RenderContext(context.settings, cache_dir=context.cache_dir if cache else False)


def _depth(scene, max_depth: int | None):
    """``scene`` with its paths stopped at ``max_depth`` (2: direct light only), or as it is."""
    return scene.with_max_depth(max_depth) if max_depth else scene


def _truth(registry, scene, spp: int, context, max_depth: int | None):
    from compare.mitsuba.reference import derive_seed

    with _context(context) as c:
        return _render(registry, "mitsuba", _depth(scene, max_depth), steps=4 * spp, seed=derive_seed("bench-ground-truth"),
                       context=c).checkpoints[-1].image


def _ladder(registry, scene, spp: int, context, max_depth: int | None):
    """Mitsuba at 1, 2, 4, … ``spp`` samples per pixel (checkpoints of one render, timed: no cache)."""
    from compare.renderers import doubling_steps

    with _context(context, cache=False) as c:
        return _render(registry, "mitsuba", _depth(scene, max_depth), steps=spp, checkpoints=doubling_steps(spp), context=c)


def bench_equal_error(scene, *, frames: int, spp: int, repeats: int = 1, registry, context) -> list[Figure]:
    """Mitsuba's time to reach the rasterizer's final FLIP, ÷ the rasterizer's time; against the
    direct-light reference also for the ``ltc`` area model (one Mitsuba ladder for both).

    Times are medians of ``repeats`` runs, the renderers taking turns; the images (seeded, so the
    same every run) and their FLIP come from the first.
    """
    from compare.metrics.images import flip

    # (figure suffix, renderer, references it is judged against): against the full reference the
    # plain technique misses the indirect light whatever its area model, so the ltc figure there
    # is given with the irradiance probes on.
    runs = [("", "progressive", ("full", "direct"))]
    if scene.lights:
        runs += [("-ltc", "progressive:ltc", ("direct",)), ("-ltc-probes", "progressive:ltc+probes", ("full",))]
    if scene.environment is not None:
        runs += [("-envshadows", "progressive:envshadows", ("full", "direct"))]
    labels = (("full", None), ("direct", 2))
    truths = {label: _truth(registry, scene, spp, context, depth) for label, depth in labels}
    # The first run of each renderer (its images) and every run's checkpoint seconds; later runs'
    # images are dropped at once (a ladder at 1080p holds a gigabyte of them).
    first: dict = {}
    times: dict = {}

    def keep(key, result) -> None:
        first.setdefault(key, result)
        times.setdefault(key, []).append([cp.seconds for cp in result.checkpoints])

    for _ in range(max(1, repeats)):
        for suffix, spec, _ in runs:
            keep(suffix, _render(registry, spec, scene, steps=frames, context=context))
        for label, depth in labels:
            keep(label, _ladder(registry, scene, spp, context, depth))
    out = []
    for label, _ in labels:
        truth, curves = truths[label], times[label]
        errors = [flip(truth, cp.image)[0] for cp in first[label].checkpoints]
        for suffix, spec, refs in runs:
            if label not in refs:
                continue
            final = first[suffix].checkpoints[-1]
            target = flip(truth, final.image)[0]
            reach = [time_to_error(c, errors, target) for c in curves]
            meta = first[suffix].metadata
            what = (meta["area_model"] + (", probes" if meta.get("indirect") == "probes" else "")
                    + (", environment shadow maps" if meta.get("occlusion") == "environment shadow maps" else ""))
            note = (f"vs {label} reference; {spec} FLIP {target:.4f}; Mitsuba FLIP at 1 spp "
                    f"{errors[0]:.4f}, at {spp} spp {errors[-1]:.4f}")
            if any(math.isinf(t) for t in reach):
                note += f"; Mitsuba did not reach it within {spp} spp (ratio is a lower bound)"
                reach = [c[-1] for c in curves]
            own = [c[-1] for c in times[suffix]]
            out.append(Figure(f"equal-error-{label}{suffix}", "Mitsuba to same FLIP",
                              f"progressive ({what}) {frames} frames", _median(reach), _median(own), "s",
                              max(1, repeats), note, reach, own))
    return out


def bench_frame_budget(scene, *, frames: int, spp: int, repeats: int, registry, context) -> list[Figure]:
    """Time to a target FLIP with a frame budget ÷ with the fixed plan (checkpoints at every frame)."""
    from compare.metrics.images import flip

    # Against the direct-light-only reference: that is what more samples converge to (the full
    # reference's error is dominated by the missing indirect light at every frame count).
    truth = _truth(registry, scene, spp, context, 2)

    def curve(budget):
        spec = "progressive" if budget is None else f"progressive:budget{budget:g}"
        res = _render(registry, spec, scene, steps=frames, checkpoints=list(range(1, frames + 1)), context=context)
        cps = res.checkpoints
        return [c.seconds for c in cps], [flip(truth, c.image)[0] for c in cps], cps[-1].step

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
from compare.renderers import RenderContext
from compare.renderers.registry import Registry
from compare.report.results import RunSettings
from compare.scene.loader import load_scene
scene = load_scene(sys.argv[2]).with_resolution(1920, 1080)
steps = int(sys.argv[3])
if sys.argv[1] != "imports":
    with RenderContext(RunSettings(), cache_dir=False) as context:
        Registry().get(sys.argv[1]).render(scene, steps=steps, checkpoints=[steps], seed=0, context=context)
else:
    import compare.progressive, compare.mitsuba.reference, mitsuba, moderngl
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


def _peak_rss_mib(kind: str, scene_path: str, count: int) -> float:
    out = subprocess.run([sys.executable, "-c", _RSS_SCRIPT, kind, scene_path, str(count)], check=True,
                         capture_output=True, text=True)
    return int(out.stdout.strip().splitlines()[-1]) / 1024.0  # ru_maxrss is KiB on Linux


def bench_peak_rss(scene_path: str, *, frames: int, spp: int) -> list[Figure]:
    """Peak RSS of a 1080p progressive run and of a 1080p Mitsuba render, each in its own process."""
    base = _peak_rss_mib("imports", scene_path, 0)
    prog = _peak_rss_mib("progressive", scene_path, frames)
    n = min(spp, 64)
    ref = _peak_rss_mib("mitsuba", scene_path, n)
    return [Figure("peak-rss", "progressive 1080p", "mitsuba 1080p render", prog, ref, "MiB", 1,
                   f"imports alone: {base:.0f} MiB; a Mitsuba render of {n} spp (passes of 1, 1, 2, ..., {n // 2} spp)")]


def bench_eevee(scene, *, frames: int, repeats: int, registry, context) -> list[Figure]:
    """Progressive (all frames) against EEVEE at 64 samples, both through the registry; needs the
    ``blender`` extra."""
    ok, why = registry.get("eevee").available()
    if not ok:
        raise RuntimeError(f"eevee is not available: {why}")
    prog, eevee = [], []
    for k in range(repeats):
        prog.append(_render(registry, "progressive", scene, steps=frames, seed=k, context=context)
                    .checkpoints[-1].seconds)
        eevee.append(_render(registry, "eevee", scene, steps=64, seed=k, context=context).checkpoints[-1].seconds)
    return [Figure("eevee", f"progressive {frames} frames", "EEVEE 64 samples", _median(prog), _median(eevee), "s",
                   repeats, "the paper's Table 1 ratio", prog, eevee)]


def machine_info(ctx=None) -> dict:
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


def _engine_items() -> dict:
    """The items about one engine's internals (:mod:`compare.bench.progressive`,
    :mod:`compare.bench.reference`), by name."""
    from compare.bench import progressive, reference

    return {**progressive.ITEMS, **reference.ITEMS}


def _bench_setup(setup_scene, size, repeats: int, registry) -> list[Figure]:
    from compare.bench.setup_cost import SCALES, bench_setup, setup_specs
    from compare.util.cache import default_cache_dir

    renderers, variants = setup_specs(registry)
    folder = default_cache_dir() / "bench-scenes"
    folder.mkdir(parents=True, exist_ok=True)
    from tqdm.auto import tqdm

    with tqdm(total=len(renderers) * (2 + len(SCALES)) + len(variants) * 2, desc="set-up runs", leave=False) as bar:
        return bench_setup(Path(setup_scene), folder, size=size, repeats=repeats, renderers=renderers,
                           variants=variants, progress=lambda what: (bar.set_postfix_str(what), bar.update()))


def all_items() -> tuple[str, ...]:
    """Every benchmark item: those about one engine's internals, then the suite's own."""
    return tuple(_engine_items()) + SUITE_ITEMS


#: The equal-error item's reference ladder tops out at this many samples per pixel unless told.
LADDER_SPP = 256


def run_bench(scene_path: str | Path, *, size: tuple[int, int], frames: int, spp: int, repeats: int,
              items: tuple[str, ...] | None = None, progress: bool = True,
              setup_scene: str | Path = "scenes/car.toml", on_item=None) -> dict:
    """Run the chosen benchmark items; returns a JSON-ready dict (figures, skipped and failed items, machine).

    Every renderer is reached through the registry: the items that compare renderers render through
    the protocol; the items about one renderer's internals are the ones that renderer declares. An item
    that fails (a renderer's error, a time-out) is recorded in ``failed`` with its message and the others
    stand; ``on_item(result)``, if given, receives the result so far after every item (the command line
    writes it, so a bench stopped half-way keeps what it measured).
    """
    from tqdm.auto import tqdm

    from compare.renderers import RenderContext

    from compare.renderers.registry import Registry
    from compare.report.results import RunSettings
    from compare.scene.loader import load_scene

    scene = load_scene(scene_path).with_resolution(*size)
    registry = Registry()
    own = _engine_items()
    if items is None:
        items = all_items()
    figures: list[Figure] = []
    setup_figures: list[Figure] | None = None
    skipped: dict[str, str] = {}
    failed: dict[str, str] = {}
    info = {"schema": 1, "scene": str(scene_path), "size": list(size), "frames": frames, "spp": spp,
            "repeats": repeats}

    def so_far(machine=None) -> dict:
        return {**info, "figures": [f.to_json() for f in figures], "skipped": dict(skipped), "failed": dict(failed),
                **({"machine": machine} if machine is not None else {})}

    with RenderContext(RunSettings(frames=frames, spp=spp), progress=False) as context:
        for item in tqdm(items, desc="bench", disable=not progress):
            try:
                if item in own:
                    figures += own[item](scene, frames=frames, spp=spp, repeats=repeats, context=context)
                elif item == "equal-error":
                    figures += bench_equal_error(scene, frames=frames, spp=spp, repeats=repeats, registry=registry,
                                                 context=context)
                elif item == "frame-budget":
                    figures += bench_frame_budget(scene, frames=frames, spp=spp, repeats=repeats, registry=registry,
                                                  context=context)
                elif item == "peak-rss":
                    figures += bench_peak_rss(str(scene_path), frames=frames, spp=spp)
                elif item == "eevee":
                    figures += bench_eevee(scene, frames=frames, repeats=repeats, registry=registry, context=context)
                elif item in SETUP_ITEMS:  # one series of runs gives both
                    if setup_figures is None:
                        setup_figures = _bench_setup(setup_scene, size, repeats, registry)
                    figures += [f for f in setup_figures if f.name == item]
                else:
                    raise ValueError(f"unknown benchmark item {item!r} (known: {', '.join(all_items())})")
            except MissingComponentError as exc:  # what this machine lacks: the item does not apply here
                skipped[item] = str(exc)
            except CompareError as exc:  # a renderer's error, a time-out, a bad scene: this item failed
                failed[item] = str(exc)
            except RuntimeError as exc:  # a library's own "not here" (no GL context, no browser)
                skipped[item] = str(exc)
            if on_item is not None:
                on_item(so_far())
        from compare.progressive.renderer import gl_context  # the context the items used

        env = machine_info(gl_context(context))
    return so_far(env)


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




