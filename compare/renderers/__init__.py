"""Renderers: one protocol (:mod:`.base`), a registry (:mod:`.registry`) and the built-ins.

Every renderer the suite measures, its own and any a user plugs in, is reached
through :class:`~compare.renderers.registry.Registry` and the protocol of
:class:`~compare.renderers.base.Renderer`; ``docs/renderers.md`` describes both
for renderer authors.
"""

from compare.renderers.base import (Checkpoint, RenderContext, Renderer, RendererError, Rendering, check_layers, check_rendering,
                   doubling_steps)
from compare.renderers.registry import ENTRY_POINT_GROUP, TABLE_1, Registry

__all__ = [
    "ENTRY_POINT_GROUP",
    "TABLE_1",
    "Checkpoint",
    "RenderContext",
    "Renderer",
    "RendererError",
    "Registry",
    "Rendering",
    "check_layers",
    "check_rendering",
    "doubling_steps",
]
