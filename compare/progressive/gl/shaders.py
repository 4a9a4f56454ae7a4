"""Load a render pass's ``.glsl`` program: one file, both stages behind defines.

Each program lives in one file beside the pass that uses it (in its wing of ``compare/progressive/``),
with its stages behind ``#if defined VERTEX_SHADER`` / ``#elif defined FRAGMENT_SHADER``. The loader
prepends ``#version 330 core``, the stage define and the pass's defines (values from Python, as
moderngl-window's ``ShaderSource`` injects them: a constant that Python and GLSL share, an array's
length or a threshold, is a Python constant passed as a define, never written a second time in the
``.glsl``, which stops with ``#error`` without it), and resolves ``#include "name.glsl"`` recursively along
:data:`SEARCH_PATH`: the including file's folder, then every wing of the rasterizer, then the shared GLSL
of ``compare/ibl/`` and ``compare/brdf/``. ``brdf.glsl`` is the shared BRDF as
:func:`compare.brdf.glsl.glsl_source` assembles it, so the BRDF has one definition. A file is included
once per program however often it is named (an include guard for every file), and a name that two folders
of the search path both hold is refused: the path must not decide silently which one a program gets.
"""

from __future__ import annotations

import functools
import math
import re
from pathlib import Path
from typing import Mapping

import numpy as np

__all__ = ["SEARCH_PATH", "load_program", "set_uniform", "shader_source"]

_INCLUDE = re.compile(r'^[ \t]*#include[ \t]+"([^"]+)"[ \t]*$', re.MULTILINE)
_PROGRESSIVE = Path(__file__).resolve().parent.parent
_PACKAGE = _PROGRESSIVE.parent

#: Where ``#include`` and :func:`load_program` look, after the including file's own folder.
SEARCH_PATH = (_PROGRESSIVE, *sorted(p for p in _PROGRESSIVE.iterdir() if (p / "__init__.py").is_file()),
               _PACKAGE / "ibl", _PACKAGE / "brdf")
#: Includes that are generated, not read: the shared BRDF.
_GENERATED = {"brdf.glsl"}


@functools.lru_cache(maxsize=None)
def _find(name: str) -> Path:
    hits = [d / name for d in SEARCH_PATH if (d / name).is_file()]
    if not hits:
        raise FileNotFoundError(f'"{name}": no such GLSL file in {", ".join(_rel(d) for d in SEARCH_PATH)}')
    if len(hits) > 1:
        raise FileNotFoundError(f'"{name}" is in {" and ".join(_rel(h) for h in hits)}: one name, one file')
    return hits[0]


def _rel(path: Path) -> str:
    return path.relative_to(_PACKAGE.parent).as_posix() if path.is_relative_to(_PACKAGE.parent) else str(path)


def _expand(text: str, folder: Path, seen: set[str], chain: tuple[str, ...]) -> str:
    def include(m: re.Match) -> str:
        name = m.group(1)
        if name in chain:
            raise RuntimeError(f'#include "{name}": an include circle ({" -> ".join(chain + (name,))})')
        if name in seen:
            return f"// {name} (included above)"
        seen.add(name)
        if name in _GENERATED:
            from compare.brdf.glsl import glsl_source

            return _expand(glsl_source(), folder, seen, chain + (name,))
        own = folder / name
        path = own if own.is_file() else _find(name)
        return _expand(path.read_text(encoding="utf-8"), path.parent, seen, chain + (name,))

    return _INCLUDE.sub(include, text)


def shader_source(name: str, stage: str, defines: Mapping[str, object] | None = None) -> str:
    """Full source of one stage (``"VERTEX_SHADER"`` or ``"FRAGMENT_SHADER"``) of program ``name``."""
    path = _find(name)
    text = _expand(path.read_text(encoding="utf-8"), path.parent, {name}, (name,))
    head = ["#version 330 core", f"#define {stage}"]
    for key, value in (defines or {}).items():
        head.append(f"#define {key}" if value is None or value is True else f"#define {key} {_literal(key, value)}")
    # '#line 1' keeps compiler messages pointing at the file's own lines (before any include).
    return "\n".join(head) + "\n#line 1\n" + text


def _literal(key: str, value) -> str:
    """``value`` as GLSL writes it: a float keeps its point (``16.0``, not ``16``, which GLSL reads as an int)."""
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            raise ValueError(f"#define {key}: {value!r} has no GLSL literal")
        return repr(float(value))
    return str(int(value)) if isinstance(value, (bool, np.integer)) else str(value)


def load_program(ctx, name: str, defines: Mapping[str, object] | None = None):
    """Compile and link program ``name`` (a ``.glsl`` file of the search path) into a moderngl program; its
    ``extra`` is ``name``, so that the program says which file (and row of texture units) it is."""
    try:
        program = ctx.program(
            vertex_shader=shader_source(name, "VERTEX_SHADER", defines),
            fragment_shader=shader_source(name, "FRAGMENT_SHADER", defines),
        )
    except Exception as exc:
        where = _rel(_find(name)) if name.endswith(".glsl") else name
        raise RuntimeError(f"{where}: {exc}") from exc
    program.extra = name
    return program


def set_uniform(prog, name: str, value) -> None:
    """Set a uniform if the linker kept it (moderngl drops unused ones)."""
    member = prog.get(name, None)
    if member is None:
        return
    if isinstance(value, (bytes, bytearray)):
        member.write(value)
    else:
        member.value = value
