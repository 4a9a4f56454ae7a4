"""Shadow maps from a point on an area light: five faces of a half cube in one atlas.

Projection
----------
A one-sided emitter lights the whole open half-space in front of it, and a
single perspective frustum cannot cover 180°. A paraboloid map would, with one
texture, but its projection is not linear: a large triangle (a Cornell-box wall
is two) is rasterized along straight edges where the true image has curves, so
shadows of large occluders would be wrong unless the geometry were finely
tessellated. Five faces of a cube map are exact perspective projections and
cover the half-space completely: the front face looks along the light's normal
(90° × 90°), and the four side faces look along ±tangent and ±bitangent with an
off-centre frustum holding only the half in front of the light (90° × 45°, so
their tiles are S × S/2). Together they store 3·S² texels (a full cube would be
6·S²), packed in one depth texture of 3S × S:

    x ∈ [0, S):   front (+n), S × S
    x ∈ [S, 2S):  +t (y ∈ [0, S/2)), −t (y ∈ [S/2, S))
    x ∈ [2S, 3S): +b (y ∈ [0, S/2)), −b (y ∈ [S/2, S))

A receiver picks its face by the largest of (|t|, |b|, n) of its offset from the
sample point (the cube-map rule), so points at grazing angles, down to the
light's own plane, land in a side face's bottom rows.

Depth and bias
--------------
The depth written is the distance to the sample point divided by the far
distance (``gl_FragDepth``), so every face shares one metric and the 24-bit
depth has an absolute precision of far / 2²⁴. The lookup (``direct.glsl``)
scales its bias by the world size of a texel at the receiver's distance d,
``texel = 2d/S``: the receiver moves ``normal_offset`` texels along its normal
(towards the light), and is lit when its distance is at most the stored one plus
``constant + slope·tan θ`` texels (θ between normal and light direction, tan θ
capped at 10; the slope-scaled term is applied at the receiver rather than by
``glPolygonOffset``, so it is in world units for all five faces). Defaults
(1, 1, 1) keep flat surfaces free of acne down to grazing angles of about 84°
and move shadow edges by at most a few texels.
"""

from __future__ import annotations

import numpy as np

from .gpu_scene import frustum, look_at, mat_bytes
from .shaders import load_program, set_uniform

#: Face order, as in direct.glsl.
FACES = ("+n", "+t", "-t", "+b", "-b")
#: Default bias in texels: (normal offset, constant, slope-scaled).
DEFAULT_BIAS = (1.0, 1.0, 1.0)
#: Default face resolution S.
DEFAULT_SHADOW_SIZE = 1024


class ShadowAtlas:
    """The depth atlas of one light sample, its face matrices and the pass that fills it."""

    def __init__(self, ctx, gpu_scene, *, size: int = DEFAULT_SHADOW_SIZE, extent: float = 1.0):
        if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 2:
            raise ValueError(f"shadow_size: expected an integer of at least 2, got {size!r}")
        size = int(size) + int(size) % 2  # side tiles are S × S/2
        self.ctx = ctx
        self.scene = gpu_scene
        self.size = size
        self.near = 1e-5 * extent
        self.far = 4.0 * extent
        s, h = size, size // 2
        self.rects = np.array([(0, 0, s, s), (s, 0, s, h), (s, h, s, h), (2 * s, 0, s, h), (2 * s, h, s, h)],
                              dtype=np.float32)
        self.depth = ctx.depth_texture((3 * s, s))
        self.depth.compare_func = ""  # sample the stored value, no hardware comparison
        self.depth.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer(depth_attachment=self.depth)
        self.program = load_program(ctx, "shadow.glsl")
        self.face_view_proj = np.zeros((5, 4, 4))

    @property
    def texel(self) -> float:
        """Size of one texel in tangent units (2 / S)."""
        return 2.0 / self.size

    def face_matrices(self, light, point) -> np.ndarray:
        """Projection × view of the five faces for a sample ``point`` on ``light``, shape (5, 4, 4)."""
        n = np.asarray(light.normal, dtype=np.float64)
        t = np.asarray(light.tangent, dtype=np.float64)
        b = np.asarray(light.bitangent, dtype=np.float64)
        z0, z1 = self.near, self.far
        full = frustum(-z0, z0, -z0, z0, z0, z1)
        half = frustum(-z0, z0, 0.0, z0, z0, z1)  # only the half in front of the light (up = n)
        views = [look_at(point, n, b), look_at(point, t, n), look_at(point, -t, n), look_at(point, b, n),
                 look_at(point, -b, n)]
        return np.array([(full if k == 0 else half) @ v for k, v in enumerate(views)])

    def render(self, light, light_index: int, point) -> None:
        """Fill the atlas for sample ``point`` of ``light`` (its own quad is not an occluder)."""
        ctx = self.ctx
        self.face_view_proj = self.face_matrices(light, point)
        self.fbo.use()
        ctx.enable_only(ctx.DEPTH_TEST)
        ctx.depth_func = "<"
        self.fbo.clear(depth=1.0)
        set_uniform(self.program, "u_sample", tuple(float(x) for x in point))
        set_uniform(self.program, "u_inv_far", 1.0 / self.far)
        for k in range(5):
            x, y, w, h = (int(v) for v in self.rects[k])
            ctx.viewport = (x, y, w, h)
            set_uniform(self.program, "u_view_proj", mat_bytes(self.face_view_proj[k]))
            self.scene.draw_occluders(self.program, skip_light=light_index)

    def bind(self, program, location: int, bias) -> None:
        """Bind the atlas and set the lookup's uniforms on ``program`` (direct.glsl)."""
        self.depth.use(location=location)
        set_uniform(program, "u_shadow", location)
        set_uniform(program, "u_shadow_far", self.far)
        set_uniform(program, "u_face_view_proj",
                    np.ascontiguousarray(self.face_view_proj.transpose(0, 2, 1), dtype=np.float32).tobytes())
        set_uniform(program, "u_face_rect", self.rects.tobytes())
        set_uniform(program, "u_shadow_texel", self.texel)
        set_uniform(program, "u_bias", tuple(float(b) for b in bias))

    def release(self) -> None:
        self.fbo.release()
        self.depth.release()
        self.program.release()
