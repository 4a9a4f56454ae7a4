"""The GLSL form of the shared BRDF, for the rasterizer's shaders.

``brdf.glsl`` (beside this file) holds functions and ``#define``s only, no
``#version`` line, so that a shader can include it by text substitution::

    src = program_text.replace('#include "brdf.glsl"', glsl_source())

Its public functions: ``brdf_eval``, ``brdf_eval_lobes``, ``brdf_geometry``, ``brdf_ggx_d``,
``brdf_smith_v_height_correlated``, ``brdf_fresnel_schlick``,
``brdf_alpha_from_roughness``, ``brdf_sample_ggx_vndf``. Its constants are Python's, never written in the
``.glsl``: :func:`glsl_source` writes :data:`BRDF_DEFINES` (``BRDF_ALPHA_MIN`` … from :mod:`compare.brdf`)
ahead of the file, :func:`layers_source` :data:`LAYERS_DEFINES` ahead of ``layers.glsl``, and each file
stops with ``#error`` without them. :func:`glsl_define` writes a define as GLSL reads it, for every
shader source of the package.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path
from typing import Mapping

import numpy as np

from compare.brdf import ALPHA_MIN, COS_MIN, DENOM_MIN, DIELECTRIC_F0, H_LEN2_MIN
from compare.brdf.coat import COAT_F0
from compare.brdf.sheen import SHEEN_ALPHA_MIN, TABLE_SIZE

__all__ = ["BRDF_DEFINES", "GLSL_PATH", "LAYERS_DEFINES", "LAYERS_GLSL_PATH", "eval_brdf_gl", "eval_layered_gl",
           "glsl_define", "glsl_source", "layers_source", "sample_ggx_vndf_gl", "with_defines"]

#: The include file.
GLSL_PATH = Path(__file__).with_name("brdf.glsl")
#: glTF's material layers over it (clearcoat, sheen, ior and specular), included after it with LAYERS.
LAYERS_GLSL_PATH = Path(__file__).with_name("layers.glsl")


#: The constants brdf.glsl takes from :mod:`compare.brdf` (BRDF_PI is pi, not a setting: the file writes it).
BRDF_DEFINES = {"BRDF_ALPHA_MIN": ALPHA_MIN, "BRDF_COS_MIN": COS_MIN, "BRDF_DIELECTRIC_F0": DIELECTRIC_F0,
                "BRDF_H_LEN2_MIN": H_LEN2_MIN, "BRDF_DENOM_MIN": DENOM_MIN}
#: The constants layers.glsl takes from :mod:`compare.brdf.sheen` and :mod:`compare.brdf.coat`; the table's size
#: as a float, as the texture coordinates use it.
LAYERS_DEFINES = {"LAYERS_SHEEN_ALPHA_MIN": SHEEN_ALPHA_MIN, "LAYERS_SHEEN_TABLE": float(TABLE_SIZE),
                  "LAYERS_COAT_F0": COAT_F0}


def glsl_define(key: str, value) -> str:
    """``#define key value`` as GLSL reads it: a float keeps its point (``16.0``, not ``16``, which GLSL reads
    as an int), False is 0, and None or True define ``key`` without a value."""
    if value is None or value is True:
        return f"#define {key}"
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            raise ValueError(f"#define {key}: {value!r} has no GLSL literal")
        literal = repr(float(value))
    else:
        literal = str(int(value)) if isinstance(value, (bool, np.integer)) else str(value)
    return f"#define {key} {literal}"


def with_defines(path: Path, defines: Mapping[str, object]) -> str:
    """Text of the include ``path`` with ``defines`` ahead of it, ending in a newline."""
    text = path.read_text(encoding="utf-8")
    head = "".join(glsl_define(key, value) + "\n" for key, value in defines.items())
    return head + (text if text.endswith("\n") else text + "\n")


@lru_cache(maxsize=1)
def glsl_source() -> str:
    """Text of ``brdf.glsl`` (GLSL 3.30, no ``#version`` line) with :data:`BRDF_DEFINES` ahead of it, ending
    in a newline."""
    return with_defines(GLSL_PATH, BRDF_DEFINES)


@lru_cache(maxsize=1)
def layers_source() -> str:
    """Text of ``layers.glsl`` with :data:`LAYERS_DEFINES` ahead of it; it goes after :func:`glsl_source`."""
    return with_defines(LAYERS_GLSL_PATH, LAYERS_DEFINES)


# -- evaluating the include on the GPU (tests, debugging) --------------------------------

_VERTEX = """#version 330 core
in vec2 in_pos;
void main() { gl_Position = vec4(in_pos, 0.0, 1.0); }
"""

_FRAGMENT = """#version 330 core
uniform sampler2D in0;
uniform sampler2D in1;
uniform sampler2D in2;
uniform sampler2D in3;
out vec4 out_value;
{include}
void main() {{
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 a = texelFetch(in0, p, 0);
    vec4 b = texelFetch(in1, p, 0);
    vec4 c = texelFetch(in2, p, 0);
    vec4 d = texelFetch(in3, p, 0);
    {body}
}}
"""

_BODIES = {
    # in0 = (n, metallic), in1 = (v, roughness), in2 = (l, -), in3 = (base_color, -)
    "eval": "out_value = vec4(brdf_eval(a.xyz, b.xyz, c.xyz, d.xyz, a.w, b.w), 1.0);",
    # in0 = (wi, alpha), in1 = (u, -, -)
    "vndf": "out_value = vec4(brdf_sample_ggx_vndf(a.xyz, a.w, b.xy), 1.0);",
}


def _run_pointwise(ctx, body: str, inputs: list, *, include: str | None = None,
                   tables: dict | None = None) -> "np.ndarray":
    """Run ``body`` once per input row (one fragment each) and read back (N, 4) float32.

    ``inputs`` are up to four (N, 4) float arrays, bound as RGBA32F textures
    read with ``texelFetch`` (no filtering, exact float32 values). ``include``: the GLSL
    before ``main`` (default: brdf.glsl); ``tables``: sampler name → (h, w) or (h, w, channels) float32
    array, bound as textures with bilinear filtering (as the rasterizer binds its tables).
    """
    import moderngl  # noqa: PLC0415
    import numpy as np  # noqa: PLC0415

    n = len(inputs[0])
    width = min(n, 256)
    height = -(-n // width)
    textures, resources = [], []
    previous_fbo, previous_viewport = ctx.fbo, ctx.viewport
    try:
        for i in range(4):
            data = np.zeros((height * width, 4), dtype=np.float32)
            if i < len(inputs):
                data[:n] = np.asarray(inputs[i], dtype=np.float32)
            tex = ctx.texture((width, height), 4, data.tobytes(), dtype="f4")
            tex.filter = (ctx.NEAREST, ctx.NEAREST)
            textures.append(tex)
        resources += textures
        prog = ctx.program(vertex_shader=_VERTEX,
                           fragment_shader=_FRAGMENT.format(include=include or glsl_source(), body=body))
        resources.append(prog)
        for i in range(4):
            uniform = prog.get(f"in{i}", None)  # unused samplers are optimised away
            if uniform is not None:
                uniform.value = i
        for unit, (name, table) in enumerate((tables or {}).items(), start=4):
            table = np.ascontiguousarray(table, dtype=np.float32)
            channels = table.shape[2] if table.ndim == 3 else 1
            tex = ctx.texture((table.shape[1], table.shape[0]), channels, table.tobytes(), dtype="f4")
            tex.filter = (ctx.LINEAR, ctx.LINEAR)
            tex.repeat_x = tex.repeat_y = False
            resources.append(tex)
            textures.append(tex)
            uniform = prog.get(name, None)
            if uniform is not None:
                uniform.value = unit
        quad = np.array([-1, -1, 1, -1, -1, 1, 1, 1], dtype=np.float32)
        vbo = ctx.buffer(quad.tobytes())
        vao = ctx.vertex_array(prog, [(vbo, "2f", "in_pos")])
        target = ctx.texture((width, height), 4, dtype="f4")
        fbo = ctx.framebuffer(color_attachments=[target])
        resources += [vbo, vao, target, fbo]
        fbo.use()
        ctx.viewport = (0, 0, width, height)
        for i, tex in enumerate(textures):
            tex.use(location=i)  # the inputs at 0 … 3, the tables from 4 on
        vao.render(mode=ctx.TRIANGLE_STRIP)
        ctx.finish()
        out = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32)
        return out.reshape(height * width, 4)[:n].copy()
    finally:
        live = isinstance(previous_fbo, moderngl.Framebuffer) and not isinstance(
            getattr(previous_fbo, "mglo", None), moderngl.InvalidObject)
        if live:  # restore the caller's framebuffer (not when it was None or released)
            previous_fbo.use()
        ctx.viewport = previous_viewport
        for res in reversed(resources):
            res.release()


def eval_brdf_gl(ctx, n, v, l, base_color, metallic, roughness):  # noqa: E741
    """Evaluate ``brdf_eval`` of ``brdf.glsl`` on the GPU, one fragment per input.

    Parameters
    ----------
    ctx : moderngl.Context
        An OpenGL 3.3+ context (e.g. ``moderngl.create_context(standalone=True, backend='egl')``).
    n, v, l, base_color : array_like, shape (N, 3)
    metallic, roughness : array_like, shape (N,)
        Inputs, rounded to float32 on upload.

    Returns
    -------
    ndarray, shape (N, 3), float32
    """
    import numpy as np  # noqa: PLC0415

    n, v, l, c = (np.asarray(x, dtype=np.float64).reshape(-1, 3) for x in (n, v, l, base_color))
    count = len(n)
    m = np.broadcast_to(np.asarray(metallic, dtype=np.float64), (count,))
    r = np.broadcast_to(np.asarray(roughness, dtype=np.float64), (count,))
    zero = np.zeros((count, 1))
    inputs = [np.hstack([n, m[:, None]]), np.hstack([v, r[:, None]]), np.hstack([l, zero]),
              np.hstack([c, zero])]
    return _run_pointwise(ctx, _BODIES["eval"], inputs)[:, :3]


def sample_ggx_vndf_gl(ctx, wi, alpha, u):
    """Evaluate ``brdf_sample_ggx_vndf`` on the GPU; returns (N, 3) float32 half vectors."""
    import numpy as np  # noqa: PLC0415

    wi = np.asarray(wi, dtype=np.float64).reshape(-1, 3)
    count = len(wi)
    a = np.broadcast_to(np.asarray(alpha, dtype=np.float64), (count,))
    u = np.asarray(u, dtype=np.float64).reshape(-1, 2)
    inputs = [np.hstack([wi, a[:, None]]), np.hstack([u, np.zeros((count, 2))])]
    return _run_pointwise(ctx, _BODIES["vndf"], inputs)[:, :3]


def eval_layered_gl(ctx, n, v, l, base_color, metallic, roughness, *, ior=1.5, specular=1.0,  # noqa: E741
                    specular_color=(1.0, 1.0, 1.0), clearcoat=0.0, clearcoat_roughness=0.0,
                    sheen_color=(0.0, 0.0, 0.0), sheen_roughness=0.0):
    """Evaluate ``brdf_eval_layered`` of ``layers.glsl`` on the GPU for one material's layers (glTF's
    factors), one fragment per direction; inputs as :func:`eval_brdf_gl`. Returns (N, 3) float32."""
    import numpy as np  # noqa: PLC0415

    from compare.brdf import dielectric_specular  # noqa: PLC0415
    from compare.brdf.sheen import sheen_tables  # noqa: PLC0415

    n, v, l, c = (np.asarray(x, dtype=np.float64).reshape(-1, 3) for x in (n, v, l, base_color))
    count = len(n)
    m = np.broadcast_to(np.asarray(metallic, dtype=np.float64), (count,))
    r = np.broadcast_to(np.asarray(roughness, dtype=np.float64), (count,))
    zero = np.zeros((count, 1))
    inputs = [np.hstack([n, m[:, None]]), np.hstack([v, r[:, None]]), np.hstack([l, zero]), np.hstack([c, zero])]
    f0, weight = dielectric_specular(ior, specular, specular_color)

    def vec3(x):
        return "vec3({:.9g}, {:.9g}, {:.9g})".format(*np.broadcast_to(np.asarray(x, dtype=np.float64), 3))

    layers = (f"MaterialLayers({vec3(f0)}, {float(weight):.9g}, {float(clearcoat):.9g}, "
              f"{float(clearcoat_roughness):.9g}, {vec3(sheen_color)}, {float(sheen_roughness):.9g})")
    body = (f"vec3 s; vec3 dd; brdf_eval_layered(a.xyz, b.xyz, c.xyz, d.xyz, a.w, b.w, {layers}, s, dd); "
            "out_value = vec4(s + dd, 1.0);")
    include = "#define LAYERS 1\n" + glsl_source() + layers_source()
    return _run_pointwise(ctx, body, inputs, include=include, tables={"u_sheen_albedo": sheen_tables()})[:, :3]
