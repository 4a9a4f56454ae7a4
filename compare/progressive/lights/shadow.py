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

Variance shadow maps (``filter="vsm"``)
---------------------------------------
Donnelly & Lauritzen, *Variance Shadow Maps* (I3D 2006); Lauritzen, *Summed-Area
Variance Shadow Maps*, GPU Gems 3, ch. 8. The same five faces store, in an
RG32F colour attachment (``shadow.glsl`` with ``MOMENTS``; a depth buffer still
keeps the nearest surface), the first two moments ``(z, z²)`` of the distance z
from the sample point in world units; texels that see nothing hold
``(far, far²)``. A separable box filter (``vsm_blur.glsl``, two passes through a
scratch atlas) then averages each texel with its neighbours *within its own
face's tile*: taps outside the tile are dropped and the weights renormalised,
so the five faces never bleed into each other. The lookup (``direct.glsl``,
``SHADOW_VSM``, shared maths in ``vsm.glsl``) reads the filtered moments
``(μ, m₂)`` bilinearly (a linear filter, so it commutes with the moments) and
bounds the fraction of the footprint that does *not* occlude a receiver at
distance d by Chebyshev's one-tailed inequality::

    σ² = max(m₂ − μ², σ_min²),   p_max = 1                 if d ≤ μ
                                 p_max = σ² / (σ² + (d − μ)²)  otherwise

    visibility = clamp((p_max − a) / (1 − a), 0, 1)    (light-bleeding reduction)

*Why a box and how wide.* Where the footprint holds one occluder edge at depth
z_o and the receiver's own surface at z_r = d, a fraction α occluded gives
``μ = α z_o + (1−α) d`` and ``σ² = α(1−α)(d − z_o)²``, so ``p_max = 1 − α``
exactly: a box of width W in the map turns the sample's hard edge into a linear
ramp of angular width W, which is exactly the penumbra that a square source of
side w casts (seen from its centre) when ``W = w (1/z_o − 1/z_r)``. Each
sample stands for its share A/n_i of the light (the radiometric model in
``direct.py``), so w is the side of that share, ``w = √(A/n_i)``: the mean of
the n_i ramps then approximates the penumbra of the whole light, whereas a
filter as wide as the whole light would convolve the light's extent twice and
make penumbrae about twice too wide. With fewer samples each share, and so the
blur, grows; with one sample the VSM alone gives the whole light's penumbra.
The filter cannot know z_o and z_r per texel (that would be PCSS's blocker
search), so it uses one *penumbra distance* ``D = 1/(1/z_o − 1/z_r)`` for the
scene, ``D = VSM_PENUMBRA_DISTANCE × (scene diagonal)`` (D is z_r when the
occluder is halfway; the Cornell box's short block over the floor, z_o ≈ 0.40 m,
z_r ≈ 0.63 m, has D ≈ 1.1 m, its diagonal is 0.96 m), and divides by ``1 − a``,
because the bleeding reduction narrows the ramp to (1 − a) of its width:
``W = √(A/n_i) / (D (1 − a))`` tangent units (:func:`vsm_filter_width`).
Penumbrae of occluders near their receivers come out too wide (contact shadows
are not hardened), of occluders near the light too narrow.

A wider filter than that does not pay: it measures worse against the reference,
and no width tried beats the hard test at equal frames
(``docs/performance-notes.md``). Two reasons: light bleeding (below), and
*sloped receivers*: Chebyshev's bound compares the receiver with the footprint's
mean, and on a floor seen obliquely from the light the lit texels beyond a
silhouette lie deeper than the receiver, pull μ past d and light up the edge of
the umbra (the wider the box, the more); the two-depth argument above assumes
the lit part of the footprint lies at the receiver's own depth.

*Resolution.* A filtered map needs no more texels than its filter resolves: the
atlas of a VSM has ``S_v = min(S, 2·VSM_FILTER_TEXELS / W)`` (W of the light with
the narrowest filter, rounded up to even), so the narrowest box spans about
VSM_FILTER_TEXELS texels and the blur costs a bounded number of taps
(two per bilinear fetch); ``shadow_size`` becomes an upper bound. Rasterising
fewer texels is what can make a VSM pass cheaper than a hard one at the same S,
but the blur's cost grows with ``S_v² · VSM_FILTER_TEXELS`` and can outweigh
the saving once n_i is large. Supersampling the atlas (exact partial coverage of
silhouettes) does not help (``docs/performance-notes.md``): more texels help by
narrowing the effective kernel (the bilinear lookup adds a texel to the box) and
the texel-sized bias, not by anti-aliasing.

*Bias.* The receiver gets the hard test's normal offset, and its distance the
hard test's constant and slope-scaled bias (all in texels of the VSM atlas)
subtracted before the comparison, so planar receivers, whose filtered mean
lies at (or, distance being convex along a plane, beyond) their own distance,
stay at p_max = 1. ``σ_min = VSM_MIN_SIGMA · d``: float32 moments lose
m₂ − μ² to cancellation at about 1e-7·d², i.e. σ ≈ 3e-4·d, so σ_min = 1e-3·d keeps
the bound out of that noise (below it, receivers a hair behind μ would flicker
between lit and dark) while staying well under a texel's size (2d/S_v).

*Light bleeding.* Chebyshev's inequality is an upper bound; it is tight only
for two depths. Where two occluders at different distances overlap in the
footprint (the top of a block and its base, a block over another's shadow), m₂
is large, σ² overestimates the spread seen by the receiver, and p_max is too
high: light bleeds into the umbra, most where the receiver is close to the
farther occluder (d − μ small against σ). The reduction
``linstep(a, 1, p_max)`` with ``a = VSM_LIGHT_BLEEDING`` cuts off bounds below
a; Lauritzen suggests 0.2–0.3. It narrows each ramp to (1 − a)·W and moves its
middle a·W/2 towards the lit side (the lit end stays), so W is widened by
1/(1 − a), which leaves the ramp W wide but a·W/(2(1 − a)) towards the lit side.
A larger a darkens and shifts penumbrae by more than the bleeding it removes,
hence 0.2, the low end of Lauritzen's range (``docs/performance-notes.md``);
what bleeding is left shows at the far tip of the short block's floor shadow
with few samples. Other known artefacts: the filter stops at face seams (a seam's
penumbra is one-sided for W/2), and texels that see nothing hold ``far``, whose
large variance against a near occluder makes shadows fade where the map looks
past an edge into the void.
"""

from __future__ import annotations

import numpy as np

from compare.progressive.frame.gpu_scene import frustum, look_at, mat_bytes
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import Units, bind, units_of

#: Default bias in texels: (normal offset, constant, slope-scaled).
DEFAULT_BIAS = (1.0, 1.0, 1.0)
#: Default face resolution S.
DEFAULT_SHADOW_SIZE = 1024
#: Visibility tests: a hard depth test per sample, or variance shadow maps.
SHADOW_FILTERS = ("hard", "vsm")
#: VSM light-bleeding reduction a: p_max below a is cut to 0 (Lauritzen: 0.2–0.3).
VSM_LIGHT_BLEEDING = 0.2
#: VSM minimum standard deviation, as a fraction of the receiver's distance.
VSM_MIN_SIGMA = 1e-3
#: VSM: penumbra distance D = 1/(1/z_o − 1/z_r) as a fraction of the scene's diagonal (filter ∝ 1/D).
VSM_PENUMBRA_DISTANCE = 1.0
#: VSM: texels spanned by the narrowest filter; sets the atlas resolution (at most ``size``).
#: 4 keeps a VSM pass about as costly as a hard one at the default size; a wider span buys
#: little accuracy for its time (docs/performance-notes.md).
VSM_FILTER_TEXELS = 4.0


def vsm_filter_width(area: float, samples: int, extent: float, bleeding: float = VSM_LIGHT_BLEEDING) -> float:
    """Box width W (tangent units) of the VSM filter for one light: ``√(area/samples) / (D·(1 − bleeding))``.

    D = :data:`VSM_PENUMBRA_DISTANCE` × ``extent`` (the scene's diagonal); see the
    module notes for why this matches a sample's penumbra.
    """
    return float(np.sqrt(area / samples) / (VSM_PENUMBRA_DISTANCE * extent * (1.0 - bleeding)))


def vsm_face_size(size: int, width: float) -> int:
    """Even face resolution S_v ≤ ``size`` at which a filter of ``width`` spans :data:`VSM_FILTER_TEXELS` texels."""
    wanted = int(np.ceil(2.0 * VSM_FILTER_TEXELS / max(width, 1e-12)))
    return int(min(size, max(16, wanted + wanted % 2)))


def chebyshev_visibility(mean, mean_sq, d, *, min_sigma: float = VSM_MIN_SIGMA,
                         bleeding: float = VSM_LIGHT_BLEEDING) -> np.ndarray:
    """numpy mirror of ``vsm_visibility`` (``vsm.glsl``): Chebyshev bound, then bleeding reduction.

    ``mean``, ``mean_sq``: filtered moments E[z], E[z²]; ``d``: receiver distance
    (after the bias); σ_min = ``min_sigma``·d. Broadcasts; returns float64.
    """
    mean, mean_sq, d = (np.asarray(a, dtype=np.float64) for a in (mean, mean_sq, d))
    variance = np.maximum(mean_sq - mean * mean, (min_sigma * d) ** 2)
    behind = d > mean  # only then is the denominator positive
    p_max = np.where(behind, variance / np.where(behind, variance + (d - mean) ** 2, 1.0), 1.0)
    return np.clip((p_max - bleeding) / (1.0 - bleeding), 0.0, 1.0)


class ShadowAtlas(RenderPass):
    """The depth atlas of one light sample, its face matrices and the pass that fills it.

    ``filter="vsm"`` stores filtered moments instead (module notes); it needs the
    scene's ``lights`` and the plan's ``samples_per_light`` to size each light's
    filter (:attr:`filter_widths`, tangent units) and the atlas (:attr:`size`).
    """

    def __init__(self, ctx, gpu_scene, *, size: int = DEFAULT_SHADOW_SIZE, extent: float = 1.0,
                 filter: str = "hard", lights=(), samples_per_light=()):
        if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 2:
            raise ValueError(f"shadow_size: expected an integer of at least 2, got {size!r}")
        if filter not in SHADOW_FILTERS:
            raise ValueError(f"shadow_filter: expected one of {', '.join(map(repr, SHADOW_FILTERS))}, got {filter!r}")
        self.filter = filter
        self.filter_widths: tuple[float, ...] = ()
        if filter == "vsm":
            if len(lights) == 0 or len(lights) != len(samples_per_light):
                raise ValueError(f"filter='vsm' needs the lights and one sample count per light, got "
                                 f"{len(lights)} lights and samples_per_light={tuple(samples_per_light)!r}")
            self.vsm_params = (VSM_MIN_SIGMA, VSM_LIGHT_BLEEDING)  # (σ_min / d, a), read once
            self.filter_widths = tuple(vsm_filter_width(light.area, n, extent, bleeding=VSM_LIGHT_BLEEDING)
                                       for light, n in zip(lights, samples_per_light))
            size = vsm_face_size(int(size), min(self.filter_widths))
        size = int(size) + int(size) % 2  # side tiles are S × S/2
        self.ctx = ctx
        self.scene = gpu_scene
        self.size = size
        self.near = 1e-5 * extent
        self.far = 4.0 * extent
        s, h = size, size // 2
        self.rects = np.array([(0, 0, s, s), (s, 0, s, h), (s, h, s, h), (2 * s, 0, s, h), (2 * s, h, s, h)],
                              dtype=np.float32)
        self.face_view_proj = np.zeros((5, 4, 4))
        if filter == "vsm":
            self._init_vsm()
            return
        self.depth = ctx.depth_texture((3 * s, s))
        self.depth.compare_func = ""  # sample the stored value, no hardware comparison
        self.depth.filter = (ctx.NEAREST, ctx.NEAREST)
        self.fbo = ctx.framebuffer(depth_attachment=self.depth)
        self.programs = gpu_scene.occluder_programs(ctx, "shadow.glsl")

    def _init_vsm(self) -> None:
        ctx, shape = self.ctx, (3 * self.size, self.size)
        self.depth = ctx.depth_renderbuffer(shape)  # only orders the fragments
        self.moments = ctx.texture(shape, 2, dtype="f4")
        self.moments.filter = (ctx.LINEAR, ctx.LINEAR)  # moments filter linearly: the lookup is bilinear
        self.moments.repeat_x = self.moments.repeat_y = False
        self.scratch = ctx.texture(shape, 2, dtype="f4")  # the horizontal pass's output
        self.scratch.filter = (ctx.LINEAR, ctx.LINEAR)  # the blur reads two texels per fetch
        self.fbo = ctx.framebuffer([self.moments], self.depth)
        self.scratch_fbo = ctx.framebuffer([self.scratch])
        self.programs = self.scene.occluder_programs(ctx, "shadow.glsl", {"MOMENTS": 1})
        self.blur = load_program(ctx, "vsm_blur.glsl")
        self.blur_vao = ctx.vertex_array(self.blur, [])

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
        if self.filter == "vsm":
            self.fbo.clear(self.far, self.far * self.far, 0.0, 0.0, depth=1.0)  # nothing seen: (far, far²)
        else:
            self.fbo.clear(depth=1.0)
        for program in self.programs.values():
            set_uniform(program, "u_sample", tuple(float(x) for x in point))
            set_uniform(program, "u_inv_far", 1.0 / self.far)
        for k in range(5):
            x, y, w, h = (int(v) for v in self.rects[k])
            ctx.viewport = (x, y, w, h)
            for program in self.programs.values():
                set_uniform(program, "u_view_proj", mat_bytes(self.face_view_proj[k]))
            self.scene.draw_occluders(self.programs, skip_light=light_index)
        if self.filter == "vsm":
            self._blur(self.filter_widths[light_index] * self.size / 2)

    def _blur(self, width: float) -> None:
        """Box-filter the moments, ``width`` texels wide, within each face's tile (x, then y)."""
        ctx = self.ctx
        ctx.enable_only(ctx.NOTHING)
        set_uniform(self.blur, "u_width", float(width))
        set_uniform(self.blur, "u_size", self.size)
        for source, fbo, axis in ((self.moments, self.scratch_fbo, (1, 0)), (self.scratch, self.fbo, (0, 1))):
            fbo.use()
            ctx.viewport = (0, 0, 3 * self.size, self.size)
            bind(self.blur, "u_source", source, units_of("vsm_blur.glsl")["source"])
            set_uniform(self.blur, "u_axis", axis)
            self.blur_vao.render(vertices=3)

    def bind(self, program, units: Units, bias) -> None:
        """Bind the atlas to ``units`` (its program's ``shadow`` row) and set the lookup's uniforms on
        ``program`` (shadow_test.glsl)."""
        if self.filter == "vsm":
            bind(program, "u_shadow", self.moments, units)
            set_uniform(program, "u_vsm", self.vsm_params)
        else:
            bind(program, "u_shadow", self.depth, units)
        set_uniform(program, "u_shadow_far", self.far)
        set_uniform(program, "u_face_view_proj",
                    np.ascontiguousarray(self.face_view_proj.transpose(0, 2, 1), dtype=np.float32).tobytes())
        set_uniform(program, "u_face_rect", self.rects.tobytes())
        set_uniform(program, "u_shadow_texel", self.texel)
        set_uniform(program, "u_bias", tuple(float(b) for b in bias))

    def describe(self) -> dict:
        """The atlas's projection, face size and filter."""
        return {"shadow_projection": "half-cube (5 faces)", "shadow_size": int(self.size),
                "shadow_filter": self.filter}

    def release(self) -> None:
        if self.filter == "vsm":
            for obj in (self.blur_vao, self.blur, self.scratch_fbo, self.scratch, self.moments):
                obj.release()
        self.fbo.release()
        self.depth.release()
        self.scene.release_programs(self.programs)
        self.programs = {}
