"""Renderers: one contract (:mod:`.base`), one spec grammar (:mod:`.options`), a registry
(:mod:`.registry`), external commands and their job files (:mod:`.external`, :mod:`.job`).

Every renderer the suite measures, its own (one package per engine: ``compare.mitsuba``,
``compare.progressive``, ``compare.blender``, ``compare.web``) and any a user plugs in,
is reached through :class:`~compare.renderers.registry.Registry` and subclasses
:class:`~compare.renderers.base.Renderer`; ``docs/renderers.md`` describes both for
renderer authors.
"""

from compare.renderers.base import (Checkpoint, RenderContext, Renderer, RendererError, Rendering, check_layers,
                                    check_renderer, check_rendering, doubling_steps)
from compare.renderers.registry import ENTRY_POINT_GROUP, Registry

__all__ = [
    "ENTRY_POINT_GROUP",
    "Checkpoint",
    "RenderContext",
    "Renderer",
    "RendererError",
    "Registry",
    "Rendering",
    "check_layers",
    "check_renderer",
    "check_rendering",
    "doubling_steps",
]
