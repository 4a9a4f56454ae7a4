"""Where the suite caches what it can make again (reference passes, environment maps, glTF images)."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["default_cache_dir"]


def default_cache_dir() -> Path:
    """``$COMPARE_CACHE``, else ``~/.cache/compare``."""
    return Path(os.environ.get("COMPARE_CACHE") or Path.home() / ".cache" / "compare")
