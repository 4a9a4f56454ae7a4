"""Variance shadow maps (``shadow_filter="vsm"``; compare.progressive.lights.shadow).

The GL tests render the Cornell box at 96×72 (32 frames, a 256² shadow atlas)
on the session's headless context. Ground truth for "lit" and "umbra" comes
from ray casting the scene's triangles in numpy: a surface point is in the
umbra when no point of a 6 × 6 grid on the light sees it, fully lit when every
point does.
"""

from __future__ import annotations


import numpy as np
import pytest

from compare.progressive.rasterizer import Rasterizer, render_progressive
from compare.progressive.lights.shadow import (SHADOW_FILTERS, VSM_FILTER_TEXELS, ShadowAtlas, chebyshev_visibility,
                                        vsm_face_size, vsm_filter_width)
from compare.scene.loader import load_scene
from tests.helpers import CORNELL, ROOT

VSM_GLSL = ROOT / "compare" / "progressive" / "lights" / "vsm.glsl"
SHADOW_SIZE = 256


@pytest.fixture(scope="module")
def cornell():
    return load_scene(CORNELL).with_resolution(64, 48)


# ----------------------------------------------------------------------------- ray casting


def scene_triangles(scene) -> np.ndarray:
    """Every mesh triangle, shape (T, 3, 3) (the light quad is not an occluder of its own light)."""
    tris = []
    for mesh in scene.meshes:
        t = mesh.triangles()
        tris.append(np.asarray(t.positions, dtype=np.float64)[np.asarray(t.indices)])
    return np.concatenate(tris)


def ray_hits(origins, directions, tris) -> np.ndarray:
    """Möller–Trumbore: distance t along each ray to its nearest triangle (inf where none), shape (P,)."""
    o = np.asarray(origins, dtype=np.float64)[:, None, :]
    d = np.asarray(directions, dtype=np.float64)[:, None, :]
    v0, e1, e2 = tris[None, :, 0], tris[None, :, 1] - tris[None, :, 0], tris[None, :, 2] - tris[None, :, 0]
    p = np.cross(d, e2)
    det = np.sum(e1 * p, axis=-1)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = o - v0
    u = np.sum(s * p, axis=-1) * inv
    q = np.cross(s, e1)
    v = np.sum(d * q, axis=-1) * inv
    t = np.sum(e2 * q, axis=-1) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-7)
    return np.where(hit, t, np.inf).min(axis=1)


def surface_visibility(scene, grid: int = 6):
    """Per pixel centre: whether it sees a surface, whether that is the floor (y = 0), and the
    fraction of a grid × grid set of points on the light that the surface point sees."""
    cam = scene.camera
    tris = scene_triangles(scene)
    j, i = np.mgrid[0:cam.height, 0:cam.width] + 0.5
    d = cam.ray_directions(i, j).reshape(-1, 3)
    origin = np.asarray(cam.position, dtype=np.float64)
    t = ray_hits(np.broadcast_to(origin, d.shape), d, tris)
    x = origin + t[:, None] * d
    hit = np.isfinite(t)
    light = scene.lights[0]
    o = (np.arange(grid) + 0.5) / grid - 0.5
    seen = np.zeros(len(x))
    for a in o:
        for b in o:
            y = (np.asarray(light.center) + a * light.size[0] * np.asarray(light.tangent)
                 + b * light.size[1] * np.asarray(light.bitangent))
            to_y = y - x[hit]
            dist = np.linalg.norm(to_y, axis=1)
            blocked = ray_hits(x[hit] + 1e-6 * to_y / dist[:, None], to_y / dist[:, None], tris) < dist - 1e-6
            seen[hit] += ~blocked
    shape = (cam.height, cam.width)
    floor = hit & (np.abs(x[:, 1]) < 1e-6)
    return hit.reshape(shape), floor.reshape(shape), (seen / grid**2).reshape(shape)


def eroded(mask: np.ndarray, steps: int) -> np.ndarray:
    """``mask`` shrunk by ``steps`` pixels (8-neighbourhood): pixel jitter blurs edges by one pixel."""
    m = mask.copy()
    for _ in range(steps):
        p = np.pad(m, 1, constant_values=False)
        m = np.logical_and.reduce([p[1 + dy:p.shape[0] - 1 + dy, 1 + dx:p.shape[1] - 1 + dx]
                                   for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
    return m


@pytest.fixture(scope="module")
def cornell_96():
    """A little larger than the other tests': the floor of the 64×48 view holds only a few umbra pixels."""
    return load_scene(CORNELL).with_resolution(96, 72)


@pytest.fixture(scope="module")
def truth(cornell_96):
    return surface_visibility(cornell_96)


@pytest.fixture(scope="module")
def renders(cornell_96, gl_session_ctx):
    """96×72, 32 frames (8 light samples): hard, vsm, and unshadowed (a bias every surface passes)."""
    opts = dict(frames=32, seed=0, ctx=gl_session_ctx, shadow_size=SHADOW_SIZE)
    hard = render_progressive(cornell_96, **opts)
    vsm = render_progressive(cornell_96, shadow_filter="vsm", **opts)
    lit = render_progressive(cornell_96, shadow_bias=(0.0, 1e9, 0.0), **opts)
    return hard, vsm, lit


# ----------------------------------------------------------------------------- the maths


def test_chebyshev_is_exact_for_one_edge_over_its_receiver():
    """A footprint with a fraction α at the occluder's depth and the rest at the receiver's: p_max = 1 − α."""
    alpha = np.linspace(0.0, 1.0, 21)
    z_o, z_r = 0.3, 0.55
    mean = alpha * z_o + (1 - alpha) * z_r
    mean_sq = alpha * z_o**2 + (1 - alpha) * z_r**2
    p = chebyshev_visibility(mean, mean_sq, z_r, min_sigma=0.0, bleeding=0.0)
    np.testing.assert_allclose(p, 1 - alpha, atol=1e-9)
    # The bleeding reduction cuts bounds below a and stretches the rest to [0, 1].
    q = chebyshev_visibility(mean, mean_sq, z_r, min_sigma=0.0, bleeding=0.25)
    np.testing.assert_allclose(q, np.clip((0.75 - alpha) / 0.75, 0, 1), atol=1e-9)
    # A receiver in front of the mean is lit, whatever the variance.
    assert chebyshev_visibility(0.5, 0.5, 0.4) == 1.0


def test_filter_width_follows_the_share_of_the_light(cornell):
    light = cornell.lights[0]
    w1, w4 = (vsm_filter_width(light.area, n, 1.0) for n in (1, 4))
    assert w1 == pytest.approx(2 * w4)  # four times the samples: half the side of each share
    assert vsm_filter_width(light.area, 1, 2.0) == pytest.approx(w1 / 2)
    size = vsm_face_size(1024, w4)
    assert size % 2 == 0 and size <= 1024
    assert w4 * size / 2 == pytest.approx(VSM_FILTER_TEXELS, rel=0.05)
    assert vsm_face_size(64, w4) == 64  # never above the requested size


def test_shadow_filter_is_validated(cornell):
    assert SHADOW_FILTERS == ("hard", "vsm")
    with pytest.raises(ValueError, match="shadow_filter.*'hard', 'vsm'.*'pcf'"):
        Rasterizer(cornell, shadow_filter="pcf")


def test_glsl_chebyshev_matches_numpy(gl_ctx):
    """vsm.glsl's vsm_visibility against chebyshev_visibility on edge cases and random moments."""
    rng = np.random.default_rng(3)
    n = 512
    mean = rng.uniform(0.1, 2.0, n)
    sigma = rng.choice([0.0, 1e-5, 1e-3, 0.05, 0.3], n) * mean
    d = mean + rng.choice([-0.1, 0.0, 1e-4, 0.01, 0.1, 0.5], n) * mean
    mean_sq = mean**2 + sigma**2
    bleeding = 0.2
    data = np.stack([mean, mean_sq, d, np.zeros(n)], axis=1).astype(np.float32)
    source = VSM_GLSL.read_text()
    prog = gl_ctx.program(
        vertex_shader="#version 330 core\nvoid main() { vec2 p = vec2(float((gl_VertexID << 1) & 2), "
                      "float(gl_VertexID & 2)); gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }",
        fragment_shader="#version 330 core\n" + source + """
uniform sampler2D u_in;
uniform vec2 u_params;
out vec4 out_color;
void main() {
    vec4 m = texelFetch(u_in, ivec2(gl_FragCoord.xy), 0);
    float sigma = u_params.x * m.z;
    out_color = vec4(vsm_visibility(m.xy, m.z, sigma * sigma, u_params.y), 0.0, 0.0, 1.0);
}
""")
    tex = gl_ctx.texture((n, 1), 4, data.tobytes(), dtype="f4")
    out = gl_ctx.texture((n, 1), 4, dtype="f4")
    fbo = gl_ctx.framebuffer([out])
    vao = gl_ctx.vertex_array(prog, [])
    try:
        fbo.use()
        gl_ctx.viewport = (0, 0, n, 1)
        gl_ctx.enable_only(gl_ctx.NOTHING)
        tex.use(location=0)
        prog["u_in"].value = 0
        prog["u_params"].value = (1e-3, bleeding)
        vao.render(vertices=3)
        got = np.frombuffer(fbo.read(components=4, dtype="f4"), dtype=np.float32).reshape(n, 4)[:, 0]
    finally:
        for obj in (vao, fbo, out, tex, prog):
            obj.release()
    m = data.astype(np.float64)  # the float32 inputs the shader saw
    want = chebyshev_visibility(m[:, 0], m[:, 1], m[:, 2], min_sigma=1e-3, bleeding=bleeding)
    # float32 cancellation in E[z²] − μ² is the shader's only difference from float64.
    assert np.abs(got - want).max() < 2e-3, np.abs(got - want).max()
    assert set(np.round(want, 6)) >= {0.0, 1.0} and ((want > 0.05) & (want < 0.95)).sum() > 20


def test_blur_stays_within_each_face(gl_ctx, cornell):
    """Each tile filled with its own constant keeps it exactly: nothing bleeds across the five faces."""
    from compare.progressive.frame.gpu_scene import GpuScene

    gpu = GpuScene(gl_ctx, cornell)
    atlas = ShadowAtlas(gl_ctx, gpu, size=64, extent=1.0, filter="vsm", lights=cornell.lights,
                        samples_per_light=(1,))
    try:
        s = atlas.size
        tile = np.zeros((s, 3 * s), dtype=np.float32)
        for k, (x, y, w, h) in enumerate(atlas.rects.astype(int)):
            tile[y:y + h, x:x + w] = k + 1
        data = np.stack([tile, tile**2], axis=-1)
        atlas.moments.write(np.ascontiguousarray(data).tobytes())
        atlas._blur(9.5)
        got = np.frombuffer(atlas.moments.read(), dtype=np.float32).reshape(s, 3 * s, 2)
        np.testing.assert_allclose(got, data, rtol=1e-6)
        # ... and the filter does average inside a tile: a single bright texel spreads.
        spot = np.zeros_like(data)
        spot[s // 2, s // 2] = (1.0, 1.0)
        atlas.moments.write(np.ascontiguousarray(spot).tobytes())
        atlas._blur(5.0)
        got = np.frombuffer(atlas.moments.read(), dtype=np.float32).reshape(s, 3 * s, 2)
        assert got[..., 0].sum() == pytest.approx(1.0, rel=1e-5)
        assert got[s // 2, s // 2, 0] == pytest.approx(1 / 25, rel=1e-5)
        assert (got[..., 0] > 0).sum() == 25
        # A real-valued width: the end taps cover part of their texel (4.5 = 0.75 + 3 + 0.75).
        atlas.moments.write(np.ascontiguousarray(spot).tobytes())
        atlas._blur(4.5)
        got = np.frombuffer(atlas.moments.read(), dtype=np.float32).reshape(s, 3 * s, 2)[..., 0]
        assert got.sum() == pytest.approx(1.0, rel=1e-5)
        c = s // 2
        # Bilinear fetches read two taps at once; their weights are quantised (8 bits on llvmpipe).
        assert got[c, c] == pytest.approx(1 / 4.5**2, rel=1e-2)
        assert got[c + 2, c - 2] == pytest.approx(0.75**2 / 4.5**2, rel=1e-2)
        assert got[c, c + 3] == 0.0
    finally:
        atlas.release()
        gpu.release()


# ----------------------------------------------------------------------------- renders


def test_hard_is_the_default_and_unchanged(cornell_96, gl_ctx, renders):
    hard = render_progressive(cornell_96, frames=32, seed=0, ctx=gl_ctx, shadow_size=SHADOW_SIZE,
                              shadow_filter="hard")
    np.testing.assert_array_equal(hard.image, renders[0].image)
    assert hard.metadata["shadow_filter"] == "hard" and hard.metadata["shadow_size"] == SHADOW_SIZE


def test_vsm_is_finite_non_negative_and_described(renders):
    _, vsm, _ = renders
    assert np.isfinite(vsm.image).all() and vsm.image.min() >= 0
    assert vsm.metadata["shadow_filter"] == "vsm"
    assert 16 <= vsm.metadata["shadow_size"] <= SHADOW_SIZE


def test_fully_lit_surfaces_are_unchanged(renders, truth):
    """Pixels that see the whole light (and whose neighbours do): vsm = hard = unshadowed."""
    hard, vsm, lit = (r.image.astype(np.float64).sum(-1) for r in renders)
    hit, _, seen = truth
    # Two pixels in from every shadowed pixel: one for the jitter, one for the VSM's ramps,
    # which may reach a little past the geometric penumbra (measured one pixel at 2.6 %).
    mask = eroded(hit & (seen == 1.0), 2) & (lit > 0)
    assert mask.sum() > 1500
    assert np.abs(hard[mask] / lit[mask] - 1).max() < 1e-6
    # Measured exactly 0: a receiver in front of the filtered mean gets p_max = 1.
    assert np.abs(vsm[mask] / hard[mask] - 1).max() < 1e-6


def test_occluder_shadow_is_still_there(renders, truth):
    """The floor in the blocks' umbra stays dark; the open floor stays lit."""
    _, vsm, lit = (r.image.astype(np.float64).sum(-1) for r in renders)
    _, floor, seen = truth
    umbra, open_floor = eroded(floor & (seen == 0.0), 1), eroded(floor & (seen == 1.0), 1)
    assert umbra.sum() >= 20 and open_floor.sum() >= 50
    visibility = vsm / np.maximum(lit, 1e-12)
    # Measured (96×72, 32 frames, seed 0): umbra mean 0.0002, max 0.0075 (33 pixels); open floor min 0.986
    # (98 pixels). Seeds 1-3: umbra mean at most 0.0010, max 0.027; open floor min 1.0.
    assert visibility[umbra].mean() < 0.005 and visibility[umbra].max() < 0.05
    assert visibility[open_floor].min() > 0.95
    assert vsm[umbra].mean() < 0.005 * vsm[open_floor].mean()  # measured 0.0002 (seeds 1-3: at most 0.0010)


def test_error_against_direct_reference_is_close_to_hard(cornell_96, renders, tmp_path_factory):
    """Against Mitsuba's direct light (max_depth = 2), VSM's error stays within a measured bound of hard's."""
    from compare.metrics.images import compare_images
    from compare.mitsuba.reference import ReferenceRenderer

    ref = ReferenceRenderer(cornell_96, materials="shared", max_depth=2, cache_dir=tmp_path_factory.mktemp("ref"),
                            progress=False).render(256).image
    hard, vsm, _ = renders
    mh = compare_images(ref, hard.image, flip_hdr=False)
    mv = compare_images(ref, vsm.image, flip_hdr=False)
    print(f"hard: FLIP {mh['flip']:.4f} SSIM {mh['ssim']:.4f} relMSE {mh['relmse']:.5f}; "
          f"vsm: FLIP {mv['flip']:.4f} SSIM {mv['ssim']:.4f} relMSE {mv['relmse']:.5f}")
    # Measured (96×72, 32 frames, 256 spp): hard FLIP 0.0382, SSIM 0.9795, relMSE 0.00353;
    # vsm 0.0400, 0.9790, 0.00390 (ratios 1.05, −0.0005, 1.10).
    assert mv["flip"] <= 1.15 * mh["flip"]
    assert mv["ssim"] >= mh["ssim"] - 0.005
    assert mv["relmse"] <= 1.3 * mh["relmse"]
