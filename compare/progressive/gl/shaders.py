"""Load a render pass's ``.glsl`` program: one file, both stages behind defines.

Each program lives in one file beside the pass that uses it (in its wing of ``compare/progressive/``),
with its stages behind ``#if defined VERTEX_SHADER`` / ``#elif defined FRAGMENT_SHADER``. The loader
prepends ``#version 330 core``, the stage define and the pass's defines (values from Python, as
moderngl-window's ``ShaderSource`` injects them: a constant that Python and GLSL share, an array's
length or a threshold, is a Python constant passed as a define, never written a second time in the
``.glsl``, which stops with ``#error`` without it), and resolves ``#include "name.glsl"`` recursively along
:data:`SEARCH_PATH`: the including file's folder, then every wing of the rasterizer, then the shared GLSL
of ``compare/ibl/`` and ``compare/brdf/``. ``brdf.glsl``, ``layers.glsl`` and ``ibl.glsl`` are the shared
GLSL as :func:`compare.brdf.glsl.glsl_source`, :func:`~compare.brdf.glsl.layers_source` and
:func:`compare.ibl.glsl_source` assemble it, their constants written ahead of them from the Python that owns
them, so the BRDF and its constants have one definition. A file is included
once per program however often it is named (an include guard for every file), and a name that two folders
of the search path both hold is refused: the path must not decide silently which one a program gets.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path
from typing import Mapping

from compare.brdf.glsl import glsl_define

__all__ = ["SEARCH_PATH", "load_program", "set_uniform", "shader_source"]

_INCLUDE = re.compile(r'^[ \t]*#include[ \t]+"([^"]+)"[ \t]*$', re.MULTILINE)
_PROGRESSIVE = Path(__file__).resolve().parent.parent
_PACKAGE = _PROGRESSIVE.parent

#: Where ``#include`` and :func:`load_program` look, after the including file's own folder.
SEARCH_PATH = (_PROGRESSIVE, *sorted(p for p in _PROGRESSIVE.iterdir() if (p / "__init__.py").is_file()),
               _PACKAGE / "ibl", _PACKAGE / "brdf")
#: Includes that are generated, not read: the shared GLSL, with the defines its package writes ahead of it.
_GENERATED = ("brdf.glsl", "layers.glsl", "ibl.glsl")


def _generated(name: str) -> str:
    from compare.brdf.glsl import glsl_source, layers_source
    from compare.ibl import glsl_source as ibl_source

    return {"brdf.glsl": glsl_source, "layers.glsl": layers_source, "ibl.glsl": ibl_source}[name]()


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
            path = _find(name)  # still one name, one file
            return _expand(_generated(name), path.parent, seen, chain + (name,))
        own = folder / name
        path = own if own.is_file() else _find(name)
        return _expand(path.read_text(encoding="utf-8"), path.parent, seen, chain + (name,))

    return _INCLUDE.sub(include, text)


def shader_source(name: str, stage: str, defines: Mapping[str, object] | None = None) -> str:
    """Full source of one stage (``"VERTEX_SHADER"`` or ``"FRAGMENT_SHADER"``) of program ``name``."""
    path = _find(name)
    text = _expand(path.read_text(encoding="utf-8"), path.parent, {name}, (name,))
    head = ["#version 330 core", f"#define {stage}"]
    head += [glsl_define(key, value) for key, value in (defines or {}).items()]
    # '#line 1' keeps compiler messages pointing at the file's own lines (before any include).
    return "\n".join(head) + "\n#line 1\n" + text


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
