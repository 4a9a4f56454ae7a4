"""Load a render pass's ``.glsl`` program: one file, both stages behind defines.

Each program lives in one file beside the pass that uses it, with its stages
behind ``#if defined VERTEX_SHADER`` / ``#elif defined FRAGMENT_SHADER``. The
loader prepends ``#version 330 core``, the stage define and any pass defines,
and replaces a line ``#include "brdf.glsl"`` by the shared BRDF
(:func:`compare.brdf.glsl.glsl_source`), so the BRDF has one definition;
``#include "mapping.glsl"`` and ``"ibl.glsl"`` are the environment's shared
GLSL in ``compare/ibl/`` (one level of includes; list them in order).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Mapping

_INCLUDE = re.compile(r'^[ \t]*#include[ \t]+"([^"]+)"[ \t]*$', re.MULTILINE)
_HERE = Path(__file__).parent


#: Shared includes that live elsewhere: the environment's mappings and lighting (compare/ibl/).
_IBL = _HERE.parent / "ibl"
_SHARED = {"mapping.glsl": _IBL / "mapping.glsl", "ibl.glsl": _IBL / "ibl.glsl",
           "layers.glsl": _HERE.parent / "brdf" / "layers.glsl"}


def _include(name: str) -> str:
    if name == "brdf.glsl":
        from compare.brdf.glsl import glsl_source

        return glsl_source()
    path = _SHARED.get(name, _HERE / name)
    if not path.is_file():
        raise FileNotFoundError(f'#include "{name}": no such file beside {_HERE} (and not the shared brdf.glsl, '
                                f'{", ".join(_SHARED)})')
    return path.read_text(encoding="utf-8")


def shader_source(name: str, stage: str, defines: Mapping[str, object] | None = None) -> str:
    """Full source of one stage (``"VERTEX_SHADER"`` or ``"FRAGMENT_SHADER"``) of ``name``."""
    text = (_HERE / name).read_text(encoding="utf-8")
    text = _INCLUDE.sub(lambda m: _include(m.group(1)), text)
    head = ["#version 330 core", f"#define {stage}"]
    for key, value in (defines or {}).items():
        head.append(f"#define {key}" if value is None or value is True else f"#define {key} {value}")
    # '#line 1' keeps compiler messages pointing at the file's own lines (before any include).
    return "\n".join(head) + "\n#line 1\n" + text


def load_program(ctx, name: str, defines: Mapping[str, object] | None = None):
    """Compile and link ``name`` (a ``.glsl`` file in this folder) into a moderngl program."""
    try:
        return ctx.program(
            vertex_shader=shader_source(name, "VERTEX_SHADER", defines),
            fragment_shader=shader_source(name, "FRAGMENT_SHADER", defines),
        )
    except Exception as exc:
        raise RuntimeError(f"compare/progressive/{name}: {exc}") from exc


def set_uniform(prog, name: str, value) -> None:
    """Set a uniform if the linker kept it (moderngl drops unused ones)."""
    member = prog.get(name, None)
    if member is None:
        return
    if isinstance(value, (bytes, bytearray)):
        member.write(value)
    else:
        member.value = value
