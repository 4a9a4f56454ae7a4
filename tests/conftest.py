"""Shared pytest fixtures."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def gl_ctx():
    """One headless OpenGL context for the whole session; skips when none can be made.

    Users must not rely on GL state left by others: every pass of
    compare.progressive sets the state it needs.
    """
    from compare.util.errors import MissingComponentError
    from compare.progressive.context import create_context

    try:
        ctx = create_context()
    except MissingComponentError as exc:
        pytest.skip(f"no OpenGL 3.3+ context: {exc}")
    yield ctx
    ctx.release()
