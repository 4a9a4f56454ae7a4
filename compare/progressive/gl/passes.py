"""What the rasterizer asks of every pass, target and table it holds: :class:`RenderPass`.

:class:`~compare.progressive.rasterizer.Rasterizer` keeps the parts a scene needs in one list, in
the order it made them, and walks that list to start a render again (:meth:`RenderPass.reset`),
to describe the render (:meth:`RenderPass.describe`, merged into its metadata) and to free the GL
objects (:meth:`RenderPass.release`, in reverse order). A part that keeps nothing across frames or
has nothing to report inherits the defaults.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["RenderPass"]


@runtime_checkable
class RenderPass(Protocol):
    """A pass, target or table of the rasterizer; subclass it to inherit the defaults."""

    def reset(self) -> None:
        """Forget what the frames so far added, so that the next frame starts the plan again (the
        default: nothing is kept across frames)."""

    def describe(self) -> dict[str, str | int | float]:
        """Metadata entries of this part (str, int and float values; the default: none)."""
        return {}

    def release(self) -> None:
        """Free the GL objects it made."""
        raise NotImplementedError(f"{type(self).__name__} does not say how to free its GL objects")
