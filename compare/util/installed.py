"""What the set-up installed beside this environment, found without environment variables.

``scripts/suite.sh`` records the environments it made that this one cannot import (Blender's ``bpy``
pins numpy < 2, so it lives in ``.venv-blender``) in ``compare-environment.json`` at the root of the
environment running the suite (``sys.prefix``): so ``compare`` finds them whatever folder it is run
from, after ``. .venv/bin/activate`` or by its full path. An environment variable still overrides each
(``$COMPARE_BLENDER_PYTHON``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

__all__ = ["RECORD", "installed"]

#: The set-up's record of this environment.
RECORD = Path(sys.prefix) / "compare-environment.json"


def installed(key: str) -> str | None:
    """What the set-up recorded under ``key`` (e.g. ``"blender_python"``), if it still exists; else None."""
    try:
        value = json.loads(RECORD.read_text(encoding="utf-8")).get(key)
    except (OSError, ValueError, AttributeError):
        return None
    return value if isinstance(value, str) and Path(value).exists() else None
