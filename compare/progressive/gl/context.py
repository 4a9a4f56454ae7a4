"""A headless OpenGL context for the progressive renderer.

The renderer needs OpenGL 3.3 core or newer. Without a display it gets one
through EGL: on a machine without a GPU from Mesa's ``llvmpipe`` (slow but exact
enough for tests), on a GPU machine from the vendor driver, with the same code.
"""

from __future__ import annotations

from compare.util.errors import MissingComponentError

#: The oldest OpenGL version the shaders need (``#version 330``).
MIN_GL_VERSION = 330

_INSTALL_HINT = (
    "install EGL and an OpenGL driver: on Debian/Ubuntu "
    "`sudo apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri` "
    "(Mesa's llvmpipe runs without a GPU); on a GPU machine the vendor's EGL driver works too"
)


def create_context(*, require: int = MIN_GL_VERSION):
    """Create a standalone (headless) moderngl context through EGL.

    Parameters
    ----------
    require : int, keyword-only
        Minimum OpenGL version as moderngl writes it (330 = 3.3).

    Returns
    -------
    moderngl.Context
        A context that the caller owns (``ctx.release()`` when done).

    Raises
    ------
    MissingComponentError
        When moderngl is missing, EGL or an OpenGL driver cannot be loaded, or
        the driver offers less than ``require``; the message names the Debian
        packages to install.
    """
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - moderngl is a dependency
        raise MissingComponentError(f"the Python package moderngl is missing ({exc}); `pip install moderngl`") from exc
    try:
        ctx = moderngl.create_context(standalone=True, backend="egl", require=require)
    except Exception as exc:  # moderngl/glcontext raise plain Exception subclasses
        raise MissingComponentError(
            f"no headless OpenGL {require // 100}.{require % 100 // 10}+ context could be created "
            f"through EGL ({type(exc).__name__}: {exc}); {_INSTALL_HINT}"
        ) from exc
    if ctx.version_code < require:
        version = ctx.version_code
        ctx.release()
        raise MissingComponentError(
            f"the OpenGL driver offers version {version // 100}.{version % 100 // 10}, "
            f"the renderer needs {require // 100}.{require % 100 // 10}; {_INSTALL_HINT}"
        )
    return ctx


def gl_renderer_name(ctx) -> str:
    """Human-readable driver name, e.g. ``llvmpipe (LLVM 15.0.6, 256 bits)``."""
    info = ctx.info
    return f"{info.get('GL_RENDERER', 'unknown')} ({info.get('GL_VERSION', '?')})"


#: About how many bytes of GPU memory the rasterizer's full-size targets take per pixel: the
#: G-buffer, the running means, the partial sums, the composite and the readback, each RGBA32F.
BYTES_PER_PIXEL = 16 * 16


def check_image_size(ctx, size: tuple[int, int], what: str) -> None:
    """Raise SceneError naming ``what`` (the scene file) and the limit when an image of ``size``
    (width, height) cannot be rendered in ``ctx``: a side beyond GL_MAX_TEXTURE_SIZE, or targets
    beyond the machine's memory (a software rasterizer's GPU memory is the system's)."""
    import os

    from compare.util.errors import SceneError

    w, h = size
    limit = int(ctx.info.get("GL_MAX_TEXTURE_SIZE", 0) or 0)
    if limit and max(w, h) > limit:
        raise SceneError(f"{what}: camera.resolution: {w}x{h} is larger than this OpenGL context's largest "
                         f"texture, {limit} pixels a side (GL_MAX_TEXTURE_SIZE of {gl_renderer_name(ctx)})")
    need = w * h * BYTES_PER_PIXEL
    try:
        total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # not on every system
        total = 0
    if total and need > total:
        raise SceneError(f"{what}: camera.resolution: {w}x{h} needs about {need / 2**30:.0f} GiB of render "
                         f"targets, more than this machine's {total / 2**30:.0f} GiB of memory")
