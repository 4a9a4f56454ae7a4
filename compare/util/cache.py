"""Where the suite caches what it can make again (reference passes, environment maps, glTF images)."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["default_cache_dir"]


def default_cache_dir() -> Path:
    """``$COMPARE_CACHE``, else ``~/.cache/compare``."""
    return Path(os.environ.get("COMPARE_CACHE") or Path.home() / ".cache" / "compare")


def check_cache_dir(path: str | os.PathLike | None = None) -> Path:
    """The cache folder (default :func:`default_cache_dir`), refused before any work with
    :class:`~compare.util.errors.OutputError` when it cannot be created or written."""
    from compare.util.files import check_output_folder

    folder = Path(path) if path else default_cache_dir()
    check_output_folder("$COMPARE_CACHE (the reference cache; set it to a writable folder)", folder)
    return folder

