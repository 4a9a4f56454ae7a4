"""Renderers: one contract (:mod:`.base`), one spec grammar (:mod:`.options`), a registry
(:mod:`.registry`), external commands and their job files (:mod:`.external`, :mod:`.job`).

Every renderer the suite measures, its own (one package per engine: ``compare.mitsuba``,
``compare.progressive``, ``compare.blender``, ``compare.web``) and any a user plugs in,
is reached through :class:`~compare.renderers.registry.Registry` and subclasses
:class:`~compare.renderers.base.Renderer`; ``docs/renderers.md`` describes both for
renderer authors. The registry is imported from :mod:`compare.renderers.registry` by those who select
renderers (the run, the CLI, the bench), never from this face: every engine's render key holds the import
closure of its code, package faces included, and the registry and external adapter render no pixel of theirs.
"""

from compare.renderers.base import (Checkpoint, RenderContext, Renderer, RendererError, Rendering, check_layers,
                                    check_renderer, check_rendering, doubling_steps)

__all__ = [
    "Checkpoint",
    "RenderContext",
    "Renderer",
    "RendererError",
    "Rendering",
    "check_layers",
    "check_renderer",
    "check_rendering",
    "doubling_steps",
]
