"""Every area-light model of the rasterizer against a closed form: a Lambert plane under one rectangle.

Four lights over the plane y = 0: parallel to it ("flat"), tilted by 45° ("tilted"),
parallel at 0.05× its side above it ("near", where a point sample stands for a
patch of the light far larger than its distance to the plane), and upright with a
quarter of it below the plane ("straddling": the surface's horizon clips it). The
exact answer is Lambert's polygon formula (``compare.metrics.closed_form``) over the light's part
above the plane.

* ``ltc`` must match it within 2 % per pixel: the unshadowed light is in closed form
  and an unoccluded light's shadow ratio is exactly 1.
* ``radiometric`` and ``paper`` converge to a point-sample sum over their n light
  samples, not to the exact integral; each must match its own sum (computed here from
  the plan's sample points) within 1 %, and the radiometric sum's distance from the exact
  value (its discretisation error) is printed, so the gap that ``ltc`` closes is on record.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.metrics.closed_form import polygon_irradiance
from compare.progressive.rasterizer import render_progressive
from compare.scene.loader import load_scene
from tests.helpers import CORNELL


ALBEDO = 0.5
RADIANCE = 4.0
SAMPLES = 32  # the paper's default n_i for one light and 128 frames
FRAMES = 64

LIGHTS = {
    "flat": dict(center=[0.1, 1.0, -0.2], size=[1.0, 0.6], normal=[0, -1, 0], tangent=[1, 0, 0.2]),
    "tilted": dict(center=[0.1, 1.0, -0.2], size=[1.0, 0.6], normal=[0, -1, 1], tangent=[1, 0, 0]),
    "near": dict(center=[0.0, 0.05, 0.0], size=[1.0, 1.0], normal=[0, -1, 0], tangent=[1, 0, 0]),
    # Upright, a quarter of it below the plane: the surface's horizon clips it.
    "straddling": dict(center=[0.0, 0.2, -1.0], size=[1.0, 0.8], normal=[0, 0, 1], tangent=[1, 0, 0]),
}
#: Lights of the other tests: one centred over a wall below it (test_shadow_ratio_…).
OTHER_LIGHTS = {"wall": dict(center=[0.0, 1.0, 0.0], size=[1.0, 0.6], normal=[0, -1, 0], tangent=[1, 0, 0])}
CAMERAS = {
    "flat": dict(position=[0.0, 2.6, 3.2], target=[0.0, 0.0, -0.3], fov=50),
    "tilted": dict(position=[0.0, 2.6, 3.2], target=[0.0, 0.0, -0.3], fov=50),
    "near": dict(position=[0.3, 1.1, 1.6], target=[0.0, 0.0, 0.0], fov=55),
    "straddling": dict(position=[0.4, 1.4, 1.8], target=[0.0, 0.0, -0.2], fov=50),
    "wall": dict(position=[1.6, 2.4, 2.4], target=[1.2, 0.0, 0.0], fov=45),
}


def plane_scene(make_scene, case: str, extra: str = "", name: str | None = None):
    """The grey plane y = 0 under light ``case`` seen by camera ``case``, plus the TOML ``extra``."""
    light, cam = {**LIGHTS, **OTHER_LIGHTS}[case], CAMERAS[case]
    text = f"""
    [camera]
    position = {cam['position']}
    target = {cam['target']}
    fov = {cam['fov']}
    resolution = [64, 48]

    [materials.grey]
    base_color = [{ALBEDO}, {ALBEDO}, {ALBEDO}]
    roughness = 1.0

    [[meshes]]
    name = "plane"
    shape = "quad"
    size = [40, 40]
    material = "grey"

    [[lights]]
    center = {light['center']}
    size = {light['size']}
    normal = {light['normal']}
    tangent = {light['tangent']}
    radiance = [{RADIANCE}, {RADIANCE}, {RADIANCE}]
    """
    return load_scene(make_scene(text, extra, name=f"{name or case}.toml"))


def plane_points(scene, jitters):
    """Where each pixel's ray meets y = 0 for each frame's sub-pixel jitter, (H, W, J, 3), and the
    pixels whose rays all see the lit side of the plane (not the light, not past the plane's edge).

    A frame with jitter j sees, at pixel (row, col), the scene at its centre minus j
    (``FramePlan.jitter``: x right, y up, in pixels)."""
    cam, light = scene.camera, scene.lights[0]
    right, up, fwd = cam.basis()
    t = math.tan(math.radians(cam.fov) / 2)
    cols, rows = np.meshgrid(np.arange(cam.width), np.arange(cam.height))
    jit = np.asarray(jitters, dtype=np.float64)
    x = ((cols[..., None] + 0.5 - jit[:, 0]) / cam.width * 2 - 1) * t * cam.aspect
    y = (1 - (rows[..., None] + 0.5 + jit[:, 1]) / cam.height * 2) * t
    d = fwd + x[..., None] * right + y[..., None] * up
    o = np.asarray(cam.position, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        tp = -o[1] / d[..., 1]
    hit = o + tp[..., None] * d
    ok = (tp > 0) & (np.abs(hit[..., 0]) < 19.5) & (np.abs(hit[..., 2]) < 19.5)
    n = np.asarray(light.normal)
    ok &= ((hit - np.asarray(light.center)) @ n) > 0  # the emitting side
    # Rays that meet the light's rectangle before the plane see the light, not the plane.
    with np.errstate(divide="ignore", invalid="ignore"):
        tl = ((np.asarray(light.center) - o) @ n) / (d @ n)
    q = o + tl[..., None] * d - np.asarray(light.center)
    inside = ((np.abs(q @ np.asarray(light.tangent)) <= light.size[0] / 2 + 1e-3)
              & (np.abs(q @ np.asarray(light.bitangent)) <= light.size[1] / 2 + 1e-3) & (tl > 0) & (tl < tp))
    return hit, (ok & ~inside).all(-1)


def ltc_frames(result) -> list[int]:
    """The frames in which ``ltc`` evaluated light 0's unshadowed light: the first G-buffer frame
    (frame 1 after the forward frame 0) and every ``ltc_stride``-th after it (compare.progressive.lights.ltc)."""
    stride = result.metadata["ltc_stride"]
    return [1 + g for g in range(len(result.plan) - 1) if g % stride == 0]


def above_plane(corners: np.ndarray) -> np.ndarray:
    """The part of a convex polygon (K, 3) with y ≥ 0: what points of the plane y = 0 can see."""
    out = []
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        if a[1] >= 0:
            out.append(a)
        if (a[1] >= 0) != (b[1] >= 0):
            out.append(a + (b - a) * (a[1] / (a[1] - b[1])))
    return np.array(out)


def exact_radiance(scene, hit, valid):
    """ρ/π · E at every point (…, 3) of the valid pixels, E from Lambert's polygon formula."""
    out = np.zeros(hit.shape[:-1])
    pts = hit[valid]
    polygon = above_plane(scene.lights[0].corners())
    out[valid] = ALBEDO / math.pi * polygon_irradiance(pts.reshape(-1, 3), (0, 1, 0), polygon,
                                                       RADIANCE).reshape(pts.shape[:-1])
    return out


def point_sample(scene, x, y, model: str):
    """ρ/π · L·Ω·cos θ_s of light sample point y at points x (…, 3): the single-sample estimate."""
    light = scene.lights[0]
    r = np.asarray(y) - x
    d2 = np.sum(r * r, -1)
    l = r / np.sqrt(d2)[..., None]
    cos_s = np.clip(l[..., 1], 0, None)
    cos_l = np.clip(-(l @ np.asarray(light.normal)), 0, None)
    omega = light.area / (4 * d2) if model == "paper" else light.area * cos_l / d2
    return ALBEDO / math.pi * RADIANCE * omega * cos_s * (cos_l > 0)


@pytest.mark.parametrize("case", list(LIGHTS))
@pytest.mark.parametrize("model", ["ltc", "radiometric", "paper"])
def test_plane_under_rectangle(gl_ctx, make_scene, model, case):
    """Each pixel against its exact expectation at the frames' own jitter positions."""
    scene = plane_scene(make_scene, case)
    r = render_progressive(scene, frames=FRAMES, ctx=gl_ctx, materials="diffuse", samples_per_light=SAMPLES,
                           shadow_size=256, area_model=model)
    assert r.metadata["area_model"] == model
    got = r.image[..., 0].astype(np.float64)
    jitters = [fp.jitter for fp in r.plan]
    hit, valid = plane_points(scene, jitters)
    exact = exact_radiance(scene, hit, valid)  # (H, W, frames)
    samples = r.plan.samples_of(0)
    # The sample-point sum each model converges to, each sample at its own frame's jitter.
    sums = {m: np.mean([point_sample(scene, hit[:, :, f], s.point, m) for f, s in samples], axis=0)
            for m in ("radiometric", "paper")}
    want = exact[:, :, ltc_frames(r)].mean(-1) if model == "ltc" else sums[model]
    bound = 0.02 if model == "ltc" else 0.01
    assert valid.sum() > 300, "too few usable pixels: the test scene is misframed"
    rel = got[valid] / want[valid] - 1
    print(f"{case}, {model}: rendered / expected − 1 over {valid.sum()} pixels: {rel.min():+.4f} … {rel.max():+.4f}")
    if model == "radiometric":
        disc = sums[model][valid] / exact[:, :, 1:].mean(-1)[valid] - 1  # its discretisation error
        print(f"{case}: radiometric {SAMPLES}-sample sum / exact − 1: {disc.min():+.3f} … {disc.max():+.3f}")
    assert np.max(np.abs(rel)) < bound, f"{model}, {case}: per-pixel error {rel.min():+.4f} … {rel.max():+.4f}"
    assert np.allclose(r.image[..., 1], r.image[..., 0]) and np.allclose(r.image[..., 2], r.image[..., 0])


WALL_TOP = 0.95  # the wall's top edge; the light hangs at y = 1 above it, centred over the wall
WALL_HALF = 0.001  # half its thickness


def wall_scene(make_scene):
    return plane_scene(make_scene, "wall", name="wall", extra=f"""
    [[meshes]]
    name = "wall"
    shape = "box"
    size = [{2 * WALL_HALF}, {WALL_TOP}, 10.0]
    translate = [0.0, {WALL_TOP / 2}, 0.0]
    material = "grey"
    """)


def visible_part(light, x):
    """Corners (…, 4, 3) of the part of the horizontal light that plane points x (…, 3), x > 0, see past
    the wall: a line from x to the light point at x_l clears the wall's near face (x = WALL_HALF) above
    WALL_TOP iff x_l ≥ WALL_HALF − (x − WALL_HALF)(1/τ − 1), τ = WALL_TOP / light height."""
    c = np.asarray(light.center)
    half_x, half_z = light.size[0] / 2, light.size[1] / 2
    tau = WALL_TOP / c[1]
    lo = np.clip(WALL_HALF - (x[..., 0] - WALL_HALF) * (1 / tau - 1), -half_x, half_x)
    corners = np.zeros(x.shape[:-1] + (4, 3))
    for k, (u, v) in enumerate([(lo, -half_z), (half_x, -half_z), (half_x, half_z), (lo, half_z)]):
        corners[..., k, 0] = c[0] + u
        corners[..., k, 1] = c[1]
        corners[..., k, 2] = c[2] + v
    return corners


def test_shadow_ratio_converges_to_the_exact_shadowed_light(gl_ctx, make_scene):
    """A wall under the middle of the light hides part of it from the plane: the visible part is a
    rectangle again, so Lambert's formula gives the exact shadowed light. The ``ltc`` shadow ratio
    converges to it as samples grow, and with as many samples it is closer than the radiometric sum
    (the largest error over the pixels beside the wall)."""
    scene = wall_scene(make_scene)
    light = scene.lights[0]
    errors = {}
    for model, counts in (("ltc", (8, 128, 512)), ("radiometric", (8, 128))):
        for n in counts:
            r = render_progressive(scene, frames=max(128, n), ctx=gl_ctx, materials="diffuse", samples_per_light=n,
                                   shadow_size=512, area_model=model)
            hit, valid = plane_points(scene, [fp.jitter for fp in r.plan])
            valid &= (hit[..., 0] > 0.05).all(-1) & (np.abs(hit[..., 2]) < 4).all(-1)  # beside the wall
            # The frames whose jitter the unshadowed light (ltc) or the samples (radiometric) met.
            pts = hit[valid][:, ltc_frames(r) if model == "ltc" else slice(1, None)]
            e = polygon_irradiance(pts.reshape(-1, 3), (0, 1, 0), visible_part(light, pts.reshape(-1, 3)),
                                   RADIANCE).reshape(pts.shape[:-1])
            want = ALBEDO / math.pi * e.mean(-1)
            rel = r.image[..., 0][valid].astype(np.float64) / want - 1
            errors[model, n] = float(np.abs(rel).max())
            print(f"wall, {model}, {n} samples: rendered / exact − 1 over {valid.sum()} pixels: "
                  f"{rel.min():+.4f} … {rel.max():+.4f}")
    assert valid.sum() > 300
    # The ratio's error is the visibility's discretisation by the samples (shadow maps of 2048
    # texels give the same figures): measured 0.23–0.25, 0.031–0.032, 0.008–0.010 for 8, 128, 512
    # samples (the range: which frame's jitter each sample meets, f_d 0.3 or 0).
    assert errors["ltc", 512] < 0.015
    assert errors["ltc", 512] < errors["ltc", 128] < errors["ltc", 8]
    # Measured 0.289 and 0.054: the radiometric sum adds the unshadowed part's discretisation.
    assert errors["ltc", 8] < errors["radiometric", 8] and errors["ltc", 128] < errors["radiometric", 128]


def test_ltc_first_frame_is_the_exact_unshadowed_light(gl_ctx):
    """With ``ltc`` frame 0's preview is the closed-form unshadowed light: drawn forward it equals the
    same light drawn from frame 0's G-buffer, and every later frame before a light sample shows it too."""
    from compare.progressive.rasterizer import Rasterizer

    s = load_scene(CORNELL).with_resolution(48, 36)
    firsts = {}
    for mode in ("forward", "gbuffer"):
        with Rasterizer(s, frames=8, ctx=gl_ctx, shadow_size=64, area_model="ltc", first_frame=mode,
                                 direct_fraction=0.5) as r:
            assert r.preview is None and r.direct_acc is None  # no centre-point preview, no running mean
            r.render_frame()
            firsts[mode] = r.image()
            r.render_frame()
            second = r.image()
    f, g = firsts["forward"], firsts["gbuffer"]
    assert np.isfinite(f).all() and f.min() >= 0
    lit = np.maximum(f, g).max(axis=2) < 1.5  # leave out the emitter, whose edges alias differently
    np.testing.assert_allclose(f[lit], g[lit], rtol=2e-3, atol=1e-5)
    # Frame 1 has no light sample yet (f_d = 0.5): its jitter moves the edges and shifts the smooth
    # light by a fraction of a pixel, nothing else (measured: median change 0.4 % of the mean).
    assert np.median(np.abs(second[lit] - g[lit])) < 0.01 * g[lit].mean()


@pytest.mark.parametrize("options", [{"shadow_filter": "vsm"}, {"frame_budget_ms": 30.0}, {"indirect": "probes"}])
def test_ltc_combines_with_the_other_options(gl_ctx, options):
    """Variance shadow maps, a frame budget and probes change ``ltc``'s image as they change the
    radiometric model's: the images' means move by the same factor within 3 %."""
    s = load_scene(CORNELL).with_resolution(48, 36)
    change = {}
    for model in ("ltc", "radiometric"):
        kw = dict(frames=32, ctx=gl_ctx, shadow_size=64, area_model=model)
        plain = render_progressive(s, **kw).image
        other = render_progressive(s, **kw, **options).image
        assert np.isfinite(other).all() and other.min() >= 0
        lit = plain.max(axis=2) < 1.5
        change[model] = other[lit].mean() / plain[lit].mean()
    print(f"{options}: mean / plain mean, ltc {change['ltc']:.3f}, radiometric {change['radiometric']:.3f}")
    assert change["ltc"] == pytest.approx(change["radiometric"], rel=0.03)


@pytest.mark.parametrize("roughness, metallic", [(0.2, 1.0), (0.4, 0.0), (0.6, 1.0)])
@pytest.mark.parametrize("case", ["flat", "tilted"])
def test_ltc_glossy_plane_matches_the_reference(gl_ctx, make_scene, case, roughness, metallic):
    """The shared BRDF's specular lobe through the fitted table, against the direct-light reference,
    in 8×8-pixel blocks where the view is not grazing (N·V ≥ 0.5): their sum within 5 % (measured
    0.98–1.01), each block with at least 5 % of the brightest one's light within 20 % (measured
    0.84–1.07; the table's relative L1 error reaches 0.27 for N·V ≥ 0.5, compare.brdf.ltc). Dimmer
    blocks and grazing views show the LTC's weak spot, the lobe's tails: a rough metal's (roughness
    0.6) back-scattered light is 0.26–0.6 of the reference in blocks with 1–5 % of the peak, and
    0.01–0.66 at N·V ≈ 0.45."""
    from compare.mitsuba.reference import ReferenceRenderer

    text = plane_scene(make_scene, case).path.read_text().replace(
        "roughness = 1.0", f"roughness = {roughness}\nmetallic = {metallic}")
    scene = load_scene(make_scene(text, name="glossy.toml"))
    ref = ReferenceRenderer(scene, max_depth=2, progress=False, cache_dir=False).render(256).image
    img = render_progressive(scene, frames=64, ctx=gl_ctx, shadow_size=128, area_model="ltc").image
    hit, valid = plane_points(scene, [(0.0, 0.0)])
    v = np.asarray(scene.camera.position) - hit[:, :, 0]
    n_dot_v = v[..., 1] / np.linalg.norm(v, axis=-1)

    def blocks(a):
        return a[:48, :64].reshape(6, 8, 8, 8, -1).mean((1, 3))

    b_img, b_ref = blocks(img).mean(-1), blocks(ref).mean(-1)
    seen = blocks((valid & (n_dot_v >= 0.5))[..., None].astype(float))[..., 0] == 1
    total = b_img[seen].sum() / b_ref[seen].sum()
    ok = seen & (b_ref >= 0.05 * b_ref.max())
    ratio = b_img[ok] / b_ref[ok]
    print(f"{case}, roughness {roughness}, metallic {metallic}: ltc / reference {total:.3f} over {seen.sum()} "
          f"blocks, {ratio.min():.3f} … {ratio.max():.3f} per block over the {ok.sum()} brightest")
    assert ok.sum() >= 4
    assert abs(total - 1) < 0.05
    assert np.all(np.abs(ratio - 1) < 0.2)


@pytest.mark.parametrize("case", ["tilted", "straddling"])
def test_ltc_glsl_matches_the_numpy_polygon_integral(gl_ctx, make_scene, case):
    """The shader's LTC (table lookup, frame, both clippings, edge integrals) against the numpy
    form of compare.brdf.ltc per pixel, on a glossy metal plane (specular only) under the tilted
    light and the one the plane's horizon cuts."""
    from compare.brdf.ltc import load_table, ltc_matrix, polygon_integral, polygon_vector_form_factor
    from compare.ibl import split_sum

    text = plane_scene(make_scene, case).path.read_text().replace(
        "roughness = 1.0", "roughness = 0.35\nmetallic = 1.0")
    scene = load_scene(make_scene(text, name="metal.toml"))
    # The closed form itself: the LTC pass's unshadowed specular sum of the one frame (the image scales
    # it by the shadow ratio, which also corrects the fitted lobe's shape through the samples).
    from compare.progressive.rasterizer import Rasterizer
    from compare.progressive.gl.readback import read_texture_rgb

    with Rasterizer(scene, frames=1, ctx=gl_ctx, shadow_size=64, area_model="ltc") as pr:
        for _ in pr.frames():
            pass
        (_, specular), _ = pr.ltc.unshadowed[0]
        image = read_texture_rgb(gl_ctx, specular) / pr.ltc.frames[0]
        jitter = pr.plan[0].jitter
    hit, valid = plane_points(scene, [jitter])
    table, lut, light = load_table(), split_sum()[0].astype(np.float64), scene.lights[0]

    def lut_at(n_dot_v, roughness):  # the GL LINEAR fetch of the split-sum table (x = n.v, y = roughness)
        h, w, _ = lut.shape
        x, y = n_dot_v * w - 0.5, roughness * h - 0.5
        i0, j0 = int(np.floor(x)), int(np.floor(y))
        tx, ty = x - i0, y - j0
        i0, i1 = np.clip([i0, i0 + 1], 0, w - 1)
        j0, j1 = np.clip([j0, j0 + 1], 0, h - 1)
        return ((1 - ty) * ((1 - tx) * lut[j0, i0] + tx * lut[j0, i1])
                + ty * ((1 - tx) * lut[j1, i0] + tx * lut[j1, i1]))

    n = np.array([0.0, 1.0, 0.0])
    rows, cols = np.nonzero(valid)
    checked = 0
    for row, col in list(zip(rows, cols))[::17]:
        x = hit[row, col, 0]
        v = np.asarray(scene.camera.position) - x
        v /= np.linalg.norm(v)
        t1 = v - n * (n @ v)
        t1 /= np.linalg.norm(t1)
        t2 = np.cross(n, t1)
        poly = np.array([[(c - x) @ t1, (c - x) @ t2, (c - x) @ n] for c in light.corners()])
        a, b = lut_at(n @ v, 0.35)[:2]
        minv = ltc_matrix(table, 0.35, n @ v)
        f = polygon_vector_form_factor(minv, poly)
        if not f.any():  # the horizon hides the whole light
            assert image[row, col, 0] == 0.0
            continue
        lit = np.linalg.solve(minv, np.sign(f[2]) * f)  # the lit part's mean direction, mapped back by M
        lit /= np.linalg.norm(lit)
        v_local = np.array([np.sqrt(1 - (n @ v) ** 2), 0.0, n @ v])
        h = (v_local + lit) / np.linalg.norm(v_local + lit)
        fresnel = 0.5 + 0.5 * (1 - v_local @ h) ** 5  # Schlick, F0 = the metal's base colour 0.5
        want = fresnel * (a + b) * abs(f[2]) * RADIANCE
        assert polygon_integral(minv, poly) == pytest.approx(abs(f[2]))
        assert image[row, col, 0] == pytest.approx(want, rel=2e-3, abs=1e-6), (row, col)
        checked += 1
    assert checked > 50
