"""The progressive rasterizer's own benchmarks (``compare bench`` items about its internals): its first
frame against its mean frame, its frame against a depth-only pass, and each area model's frame
against the radiometric one. They time parts of the renderer that :meth:`render` does not expose.
They live here, not in the engine, so that the rasterizer's render key holds no bench code."""

from __future__ import annotations

import time

import numpy as np

from compare.util.figures import Figure, median as _median

__all__ = ["ITEMS", "bench_area_models", "bench_depth_floor", "bench_env_shadows", "bench_first_frame", "bench_punctual",
           "bench_textures", "bench_transmission"]


def bench_first_frame(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Frame 1 against the mean frame and the total of a whole progressive run; the same with frame 0
    drawn at full size, alternating with the default (half size) run for run."""
    from compare.progressive.rasterizer import Rasterizer
    from compare.progressive.first_frame import auto_scale

    scales = (auto_scale((scene.camera.width, scene.camera.height)), 1.0)  # the default, then full size
    first, mean, total = ([], []), ([], []), []
    renderers = []
    try:
        for k in scales:
            renderers.append(Rasterizer(scene, frames=frames, ctx=ctx, first_frame_scale=k))
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
    from compare.progressive.rasterizer import Rasterizer
    from compare.progressive.frame.depth_only import DepthOnlyPass

    frame_t, floor_t = [], []
    with Rasterizer(scene, frames=frames, ctx=ctx) as r:
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


def bench_area_models(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Mean frame time of the ``ltc`` and the ``paper`` area models ÷ the radiometric default,
    run for run alternating."""
    if not scene.lights:
        raise RuntimeError("the scene has no area lights: the area models do not differ")
    models = ("radiometric", "ltc", "paper")
    runs = _alternating_mean_frames([dict(area_model=m) for m in models], scene, frames=frames, repeats=repeats,
                                    ctx=ctx)
    mean = dict(zip(models, runs))
    base = mean["radiometric"]
    return [Figure(f"area-model-{m}", f"{m} mean frame", "radiometric mean frame", _median(mean[m]),
                   _median(base), "s", repeats, f"{len(scene.lights)} light(s), {frames} frames", mean[m], base)
            for m in models[1:]]


def bench_textures(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Mean frame time of the scene with its maps (and alpha masks) ÷ the same scene with its materials'
    factors only (:meth:`~compare.scene.model.Scene.without_maps`), run for run alternating."""
    if not scene.features().textures:
        raise RuntimeError("no material of the scene has a map: there is no texturing to time")
    mean = _alternating_mean_frames([dict(), dict()], scene, frames=frames, repeats=repeats, ctx=ctx,
                                    scenes=[scene, scene.without_maps()])
    used = {scene.materials[m.material].name for m in scene.meshes}
    textured = sum(1 for k in used if scene.materials[k].has_maps)
    return [Figure("textures", "mean frame with maps", "mean frame with factors only", _median(mean[0]),
                   _median(mean[1]), "s", repeats, f"{textured} of {len(used)} materials textured, {frames} frames",
                   mean[0], mean[1])]


def bench_transmission(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Mean frame time of the scene with its glass (the glass pass, :mod:`compare.progressive.glass`) ÷ the same
    scene with every transmission 0 (the glass drawn as opaque surfaces of the G-buffer), runs alternating."""
    import dataclasses

    if not scene.features().transmission:
        raise RuntimeError("no material of the scene transmits: there is no glass to time")
    opaque = dataclasses.replace(scene, materials={k: dataclasses.replace(m, transmission=0.0)
                                                   for k, m in scene.materials.items()})
    mean = _alternating_mean_frames([dict(), dict()], scene, frames=frames, repeats=repeats, ctx=ctx,
                                    scenes=[scene, opaque])
    used = {scene.materials[m.material].name for m in scene.meshes}
    glass = sum(1 for k in used if scene.materials[k].transmission > 0.0)
    return [Figure("transmission", "mean frame with glass", "mean frame with the glass opaque", _median(mean[0]),
                   _median(mean[1]), "s", repeats, f"{glass} of {len(used)} materials transmit, {frames} frames",
                   mean[0], mean[1])]


def bench_punctual(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """The frame cost of one punctual light against one area light: the mean frame of the scene's
    geometry lit by its N punctual lights (or, without any, point lights at its area lights' centres),
    and by N squares in their places (a spot's stand-in: :meth:`~compare.scene.model.PunctualLight.stand_ins`;
    a point light's faces down), each less the mean frame without lights, ÷ N; run for run alternating."""
    import dataclasses

    from compare.scene.model import PunctualLight

    lights = scene.punctual or tuple(
        PunctualLight(a.name, "point", tuple(a.center), (0.0, -1.0, 0.0), tuple(a.radiance)) for a in scene.lights)
    if not lights:
        raise RuntimeError("the scene has no lights to time")
    squares = tuple(dataclasses.replace(p, kind="spot", direction=p.direction if p.kind == "spot" else
                                        (0.0, -1.0, 0.0)).stand_ins()[0] if p.kind != "directional"
                    else None for p in lights)
    if any(s is None for s in squares):
        raise RuntimeError("a directional light has no area light in its place: time a scene of point and spot lights")
    variants = [dataclasses.replace(scene, lights=(), punctual=()),
                dataclasses.replace(scene, lights=(), punctual=tuple(lights)),
                dataclasses.replace(scene, lights=squares, punctual=())]
    none, punctual, area = _alternating_mean_frames([{}, {}, {}], scene, frames=frames, repeats=repeats, ctx=ctx,
                                                    scenes=variants)
    n = len(lights)
    per_punctual = [(p - z) / n for p, z in zip(punctual, none)]
    per_area = [(a - z) / n for a, z in zip(area, none)]
    return [Figure("punctual-light", "frame cost per punctual light", "per area light", _median(per_punctual),
                   _median(per_area), "s", repeats, f"{n} light(s), {frames} frames, less the frame without lights",
                   per_punctual, per_area)]


def bench_env_shadows(scene, *, frames: int, repeats: int, ctx) -> list[Figure]:
    """Mean frame time of ``progressive:envshadows`` ÷ the screen-space occlusion default, runs alternating."""
    from compare.progressive.environment.env_shadows import DIRECTIONS_PER_FRAME

    if scene.environment is None:
        raise RuntimeError("the scene has no environment: there is no environment light to shadow")
    first: list[list[float]] = [[], []]
    shadows, screen = _alternating_mean_frames([dict(env_occlusion="shadows"), dict()], scene, frames=frames,
                                               repeats=repeats, ctx=ctx, first=first)
    return [Figure("env-shadows", "envshadows mean frame", "screen-space occlusion mean frame", _median(shadows),
                   _median(screen), "s", repeats, f"{frames} frames, {DIRECTIONS_PER_FRAME} environment shadow maps a frame",
                   shadows, screen),
            Figure("env-shadows-first", "envshadows first frame", "screen-space occlusion first frame",
                   _median(first[0]), _median(first[1]), "s", repeats,
                   "frame 0 (the environment's samples start at frame 1)", first[0], first[1])]


def _alternating_mean_frames(options: list[dict], scene, *, frames: int, repeats: int, ctx,
                             scenes=None, first: list[list[float]] | None = None) -> list[list[float]]:
    """The mean frame time of one whole run per renderer (``options`` each, on ``scenes`` each or on
    ``scene``), ``repeats`` times, the renderers alternating run for run; ``first``: a list per renderer
    that gets each run's first frame time."""
    from compare.progressive.rasterizer import Rasterizer

    scenes = scenes or [scene] * len(options)
    mean: list[list[float]] = [[] for _ in options]
    renderers = []
    try:
        for s, opts in zip(scenes, options):
            renderers.append(Rasterizer(s, frames=frames, ctx=ctx, **opts))
        for _ in range(repeats):
            for i, r in enumerate(renderers):
                r.reset()
                for _ in r.frames():
                    pass
                mean[i].append(float(np.mean(r.frame_seconds)))
                if first is not None:
                    first[i].append(float(r.frame_seconds[0]))
    finally:
        for r in renderers:
            r.release()
    return mean


def _item(fn):
    """``fn`` as a bench item ``(scene, *, frames, spp, repeats, context)`` on the run's GL context."""
    def item(scene, *, frames: int, spp: int, repeats: int, context) -> list[Figure]:
        from compare.progressive.renderer import gl_context

        return fn(scene, frames=frames, repeats=repeats, ctx=gl_context(context))
    return item


#: The rasterizer's bench items, by name (``compare bench --only``).
ITEMS = {"first-frame": _item(bench_first_frame), "depth-floor": _item(bench_depth_floor),
         "area-models": _item(bench_area_models), "textures": _item(bench_textures),
         "punctual-lights": _item(bench_punctual), "env-shadows": _item(bench_env_shadows),
         "transmission": _item(bench_transmission)}
