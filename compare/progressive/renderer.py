"""The progressive rasterizer (:mod:`compare.progressive`) and its variants as renderers of the
registry: ``progressive`` and ``progressive:<option>[+<option>]`` (:mod:`compare.progressive.options`)."""

from __future__ import annotations

import time

import numpy as np

from compare.progressive.frame.gpu_scene import RENDERED_LAYERS
from compare.scene.model import MAP_FEATURE_NAMES
from compare.progressive.options import OPTIONS, describe, renderer_options
from compare.renderers.base import Checkpoint, RenderContext, Renderer, Rendering

__all__ = ["ProgressiveRenderer", "gl_context"]


def _create_gl_context():
    from compare.progressive.gl.context import create_context

    return create_context()


def gl_context(context: RenderContext):
    """The run's one OpenGL context (made on first use, released with ``context``)."""
    return context.resource("gl", _create_gl_context, lambda c: c.release())


def _progressive_checkpoints(scene, *, frames: int, seed: int, options: dict, checkpoints: list[int],
                             ctx) -> tuple[list[tuple[int, float, np.ndarray]], float, dict, dict]:
    """Run the progressive renderer; returns (checkpoints, setup seconds, metadata, final layers).

    ``setup`` is the renderer's own set-up time or else the wall time of the
    call minus its timed frames (context-side set-up, shader compilation,
    uploads, readbacks).
    """
    from compare.progressive.rasterizer import render_progressive

    t0 = time.perf_counter()
    result = render_progressive(scene, frames=frames, seed=seed, checkpoints=tuple(checkpoints), ctx=ctx, **options)
    wall = time.perf_counter() - t0
    cps = [(int(f), float(s), np.asarray(img, dtype=np.float32)) for f, s, img in result.checkpoints]
    done = len(result.frame_seconds) or frames  # a frame budget decides the count itself
    if not cps or cps[-1][0] != done:
        # The final image is the result even if the renderer did not list it as a checkpoint.
        cps.append((done, float(result.seconds), np.asarray(result.image, dtype=np.float32)))
    meta = dict(result.metadata or {})
    setup = meta.get("setup_seconds")
    if not isinstance(setup, (int, float)) or not np.isfinite(setup):
        setup = max(0.0, wall - float(result.seconds))
    return cps, float(setup), meta, dict(result.layers)


class ProgressiveRenderer(Renderer):
    """Otto et al.'s progressive rasterizer (moderngl), with the options of :mod:`compare.progressive.options`."""

    unit = "frame"
    #: Transmission, the volume's absorption and dispersion by the glass pass (compare.progressive.glass, which
    #: says what it leaves out: glass casts an opaque shadow, glass behind glass is not seen but for a thin
    #: wall's own back face). A hidden background: the accumulate and first-frame passes draw no environment
    #: where no surface is.
    renders = (frozenset({"punctual_lights", "alpha_blend", "vertex_colors", "single_sided", "transmission",
                          "volume", "dispersion", "layer_maps", "hidden_background"})
               | RENDERED_LAYERS | frozenset(MAP_FEATURE_NAMES))
    #: A frame budget decides the frame count itself: its last checkpoint is the frames it rendered.
    open_ended = False
    OPTIONS = OPTIONS
    VARIANTS = ("progressive:paper", "progressive:ltc", "progressive:probes", "progressive:vsm")

    def __init__(self, spec: str = "progressive"):
        self.options = renderer_options(spec)  # ValueError naming an unknown option
        self.name = spec
        self.variant_of = "progressive" if spec != "progressive" else None
        self.variant_note = describe(spec)
        words = self.variant_note or self.options.get("area_model", "radiometric")
        self.label = f"Progressive rasterizer ({words})"
        self.open_ended = "frame_budget_ms" in self.options

    def available(self) -> tuple[bool, str]:
        try:
            import moderngl  # noqa: F401
        except ImportError:
            return False, "moderngl is not installed: pip install moderngl (and Mesa's EGL: apt-get install libegl1)"
        return True, ""

    def preflight(self, scene, context: RenderContext) -> None:
        from compare.progressive.gl.context import check_image_size

        ctx = gl_context(context)
        if ctx is not None:
            check_image_size(ctx, scene.camera.resolution, str(scene.path))

    def key(self, scene, settings) -> list:
        return [self.name]  # the code it runs is in every render key (Renderer.code_key)

    def render(self, scene, *, steps: int, checkpoints: list[int], seed: int, context: RenderContext) -> Rendering:
        ctx = gl_context(context)
        cps, setup, meta, layers = _progressive_checkpoints(scene, frames=steps, seed=seed, options=self.options,
                                                            checkpoints=list(checkpoints), ctx=ctx)
        if self.open_ended:  # the budget decided the count: keep what was asked for below it and the end
            done = cps[-1][0]
            cps = [c for c in cps if c[0] in checkpoints and c[0] < done] + [cps[-1]]
        return Rendering([Checkpoint(s, t, img) for s, t, img in cps], setup, meta, layers)

    def notes(self, metadata: dict) -> dict[str, str]:
        scale = metadata.get("first_frame_scale")  # frame 0 is a reduced preview outside the running means
        if isinstance(scale, (int, float)) and 0 < scale < 1:
            return {"first_image": f"drawn at {float(scale):g}× size"}
        return {}

    def facts(self, metadata: dict) -> dict[str, str]:
        g, e = metadata.get("gl_renderer"), metadata.get("gl_srgb_decode_error")
        return {**({"gl_renderer": g} if isinstance(g, str) else {}),
                **({"gl_srgb_decode_error": f"{e:.2g}"} if isinstance(e, float) else {})}


