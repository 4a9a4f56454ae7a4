"""The sRGB decode of this OpenGL's texture sampler, measured: what an 8-bit colour map becomes.

8-bit colour maps are uploaded as sRGB textures (:mod:`compare.progressive.frame.gpu_scene`), so the sampler
decodes them to linear before filtering, as a GPU does. The decode is the driver's: exact to 8 bits on
GPUs, an approximation on Mesa's llvmpipe (up to 2.5 % below code 10, 0.12 % of full scale). The
rasterizer records the measured deviation from the exact sRGB curve as a fact of its runs, and tests
that check its texels against closed forms use the decode this OpenGL really does.
"""

from __future__ import annotations

import numpy as np

from compare.progressive.gl.shaders import load_program
from compare.progressive.gl.units import bind, units_of

__all__ = ["srgb_decode_table", "srgb_decode_error"]

GL_SRGB8 = 0x8C41


def srgb_decode_table(ctx) -> np.ndarray:
    """float64 (256,): the linear value the sampler of ``ctx`` returns for each code of an sRGB8 texture."""
    if ctx.extra is None:  # measured once per context, not per render
        ctx.extra = {}
    cached = ctx.extra.get("srgb_decode_table") if isinstance(ctx.extra, dict) else None
    if cached is not None:
        return cached
    codes = np.repeat(np.arange(256, dtype=np.uint8)[None, :, None], 3, axis=2)
    made = []
    try:
        tex = ctx.texture((256, 1), 3, np.ascontiguousarray(codes), dtype="f1", alignment=1,
                          internal_format=GL_SRGB8)
        made.append(tex)
        target = ctx.texture((256, 1), 4, dtype="f4")
        made.append(target)
        fbo = ctx.framebuffer(color_attachments=[target])
        made.append(fbo)
        prog = load_program(ctx, "srgb_probe.glsl")
        made.append(prog)
        vbo = ctx.buffer(np.array([-1, -1, 3, -1, -1, 3], dtype="f4").tobytes())
        made.append(vbo)
        vao = ctx.vertex_array(prog, [(vbo, "2f", "in_position")])
        made.append(vao)
        fbo.use()
        ctx.viewport = (0, 0, 256, 1)
        bind(prog, "u_codes", tex, units_of("srgb_probe.glsl")["codes"])
        vao.render()
        table = np.frombuffer(target.read(), dtype=np.float32).reshape(256, 4)[:, 0].astype(np.float64)
    finally:
        for obj in reversed(made):
            obj.release()
    if isinstance(ctx.extra, dict):
        ctx.extra["srgb_decode_table"] = table
    return table


def srgb_decode_error(ctx) -> float:
    """The largest absolute deviation of ``ctx``'s sRGB decode from the exact curve (full scale 1)."""
    from compare.image.tonemap import srgb_decode

    exact = srgb_decode(np.arange(256) / 255.0)
    return float(np.abs(srgb_decode_table(ctx) - exact).max())
