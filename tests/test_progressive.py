"""The progressive rasterizer (compare.progressive): distributor, accumulation, area lights.

The GL tests render tiny images on the session's headless context (Mesa's
llvmpipe is fine) and skip when there is none. The decisive correctness test is
``test_lambert_plane_matches_polygon_formula``: a Lambert plane under one
rectangular light must converge to the closed-form polygon irradiance.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from compare.util.errors import ImageError, MissingComponentError
from compare.progressive.rasterizer import Rasterizer, render_progressive
from compare.progressive.schedule.distributor import plan
from compare.progressive.schedule.distributor import default_samples_per_light, round_half_up
from compare.progressive.schedule.sampling import light_sample_points, pixel_jitter
from compare.scene.loader import Camera, load_scene
from tests.helpers import CORNELL, ROOT


# ----------------------------------------------------------------------------- helpers


PLANE_SCENE = """
[camera]
position = [0, 0.7, 3.0]
target = [0, 0, 0]
fov = 40
resolution = [64, 48]

[materials.grey]
base_color = [0.5, 0.5, 0.5]
roughness = 1.0

[[meshes]]
name = "plane"
shape = "quad"
size = [40, 40]
material = "grey"

[[lights]]
center = [0.2, 1.5, -0.3]
size = [0.8, 0.5]
normal = [0.25, -1, 0.15]
tangent = [1, 0, 0.3]
radiance = [4, 4, 4]
"""


def pixel_rays(cam: Camera, sub: int) -> np.ndarray:
    """Unit directions through sub × sub points of every pixel, (H, W, sub², 3); row 0 at the top."""
    r, u, f = cam.basis()
    t = math.tan(math.radians(cam.fov) / 2)
    o = (np.arange(sub) + 0.5) / sub
    ii, jj = np.meshgrid(np.arange(cam.width), np.arange(cam.height))
    dirs = []
    for a in o:
        for b in o:
            x = ((ii + a) / cam.width * 2 - 1) * t * cam.aspect
            y = (1 - (jj + b) / cam.height * 2) * t
            d = f + x[..., None] * r + y[..., None] * u
            dirs.append(d / np.linalg.norm(d, axis=-1, keepdims=True))
    return np.stack(dirs, axis=2)


def hit_plane_y0(cam: Camera, sub: int) -> tuple[np.ndarray, np.ndarray]:
    """World points where the pixel rays meet the plane y = 0, and whether they do (t > 0)."""
    d = pixel_rays(cam, sub)
    o = np.asarray(cam.position, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -o[1] / d[..., 1]
    return o + t[..., None] * d, t > 0


def pixel_of(cam: Camera, point) -> tuple[int, int]:
    """(row, column) of the pixel that sees ``point``."""
    r, u, f = cam.basis()
    q = np.asarray(point, dtype=np.float64) - np.asarray(cam.position)
    t = math.tan(math.radians(cam.fov) / 2)
    x = (q @ r) / (q @ f) / (t * cam.aspect)
    y = (q @ u) / (q @ f) / t
    return int((1 - y) / 2 * cam.height), int((x + 1) / 2 * cam.width)


def plane_point(cam: Camera, row: int, col: int, offset=(0.0, 0.0)) -> np.ndarray:
    """Where the ray through pixel (row, col)'s centre + ``offset`` (pixels, x right, y up) meets y = 0."""
    r, u, f = cam.basis()
    t = math.tan(math.radians(cam.fov) / 2)
    x = ((col + 0.5 + offset[0]) / cam.width * 2 - 1) * t * cam.aspect
    y = (1 - (row + 0.5 - offset[1]) / cam.height * 2) * t
    d = f + x * r + y * u
    o = np.asarray(cam.position, dtype=np.float64)
    return o - o[1] / d[1] * d


def polygon_irradiance(x: np.ndarray, n, corners: np.ndarray, radiance: float) -> np.ndarray:
    """Irradiance at points x (N, 3) with normal n from a Lambertian polygon of uniform radiance.

    E = L/2 Σ_k β_k n·(r_k × r_{k+1}) / |r_k × r_{k+1}| (Lambert's formula, Arvo 1995),
    r_k unit vectors to the corners, β_k the angle between r_k and r_{k+1}. The polygon
    must lie above the points' horizon (no clipping here).
    """
    r = corners[None] - x[:, None]
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    total = np.zeros(len(x))
    for k in range(len(corners)):
        a, b = r[:, k], r[:, (k + 1) % len(corners)]
        c = np.cross(a, b)
        beta = np.arccos(np.clip(np.sum(a * b, -1), -1.0, 1.0))
        total += beta * (c @ np.asarray(n, dtype=np.float64)) / np.linalg.norm(c, axis=-1)
    return radiance / 2 * np.abs(total)


def lambert_plane_expected(scene, sub: int = 8):
    """Box-filtered Lambert radiance of the plane y = 0 per pixel, and where it is well defined."""
    cam, light = scene.camera, scene.lights[0]
    albedo = scene.materials["grey"].base_color[0]
    hit, ok = hit_plane_y0(cam, sub)
    ok &= (np.abs(hit[..., 0]) < 19.5) & (np.abs(hit[..., 2]) < 19.5)
    front = ((hit - np.asarray(light.center)) @ np.asarray(light.normal)) > 0
    valid = ok.all(-1) & front.all(-1)
    e = polygon_irradiance(hit[valid].reshape(-1, 3), (0, 1, 0), light.corners(), light.radiance[0])
    e = e.reshape(-1, sub * sub)
    radiance = np.full(valid.shape, np.nan)
    radiance[valid] = albedo / math.pi * e.mean(1)
    # Pixels whose radiance varies strongly inside them need far more jittered frames than
    # the test renders to reach their box-filtered mean; compare where it is nearly flat.
    spread = np.full(valid.shape, np.inf)
    spread[valid] = (e.max(1) - e.min(1)) / e.mean(1)
    return radiance, valid & (spread < 0.05)


def rel_mse(img: np.ndarray, ref: np.ndarray) -> float:
    img, ref = img.astype(np.float64), ref.astype(np.float64)
    return float(np.mean((img - ref) ** 2 / (ref**2 + 1e-2)))


# ----------------------------------------------------------------------------- distributor (no GL)


@pytest.fixture(scope="module")
def cornell():
    return load_scene(CORNELL).with_resolution(64, 48)


@pytest.fixture(scope="module")
def two_lights(tmp_path_factory):
    path = tmp_path_factory.mktemp("two") / "scene.toml"
    path.write_text(PLANE_SCENE + """
[[lights]]
center = [-1.0, 1.2, 0.0]
size = [0.3, 0.3]
normal = [0, -1, 0]
radiance = [2, 2, 2]
""")
    return load_scene(path)


@pytest.mark.parametrize("frames", [1, 2, 3, 8, 128, 300])
def test_plan_evaluates_every_light_sample_exactly_once(cornell, two_lights, frames):
    for scene, counts in ((cornell, None), (two_lights, (8, 3)), (two_lights, (40, 1))):
        p = plan(scene, frames, samples_per_light=counts)
        assert len(p) == frames
        for i, n in enumerate(p.samples_per_light):
            got = sorted(s.index for _, s in p.samples_of(i))
            assert got == list(range(n)), f"light {i}: every sample once"


@pytest.mark.parametrize("frames", [2, 8, 128, 301])
def test_plan_light_samples_only_from_direct_fraction(two_lights, frames):
    p = plan(two_lights, frames, direct_fraction=0.3, samples_per_light=(8, 5))
    start = min(max(round_half_up(0.3 * frames), 1), frames - 1)
    assert p.direct_start == start
    for fp in p:
        if fp.frame < start:
            assert fp.light_samples == ()
    assert p[0].shadow_passes == 0, "frame 1 is cheap: no shadow passes"
    assert p[0].preview


def test_plan_weights_sum_to_one_per_light(two_lights):
    for frames, counts in ((128, (8, 3)), (16, (40, 7)), (2, (1, 1))):
        p = plan(two_lights, frames, samples_per_light=counts)
        carrying = [fp for fp in p if fp.light_samples]
        assert p.light_frames == len(carrying)
        for i, n in enumerate(counts):
            w = [s.weight for _, s in p.samples_of(i)]
            # Direct mean over F light frames: (1/F) Σ_k w_k est_k must equal (1/n_i) Σ_k est_k.
            assert np.allclose(np.array(w) / p.light_frames, 1.0 / n)
        assert p.paper_weights == tuple(frames / n for n in counts)


def test_plan_spreads_samples_evenly_and_lights_take_turns(two_lights):
    p = plan(two_lights, 128, samples_per_light=(24, 8))
    frames = [fp.frame for fp in p if fp.light_samples]
    assert all(len(fp.light_samples) <= 1 for fp in p), "32 samples in 90 frames: at most one per frame"
    gaps = np.diff(frames)
    assert gaps.min() >= 2 and gaps.max() <= 3
    # Every prefix has done about the same fraction of each light's samples.
    done = np.zeros(2)
    for fp in p:
        for s in fp.light_samples:
            done[s.light] += 1
            frac = done / np.array([24, 8])
            assert abs(frac[0] - frac[1]) <= 1 / 8 + 1e-9


def test_plan_samples_start_at_centre_and_move_outwards(two_lights):
    light = two_lights.lights[0]
    pts, uv = light_sample_points(light, 32, seed=0)
    assert np.allclose(pts[0], light.center)
    local = pts - np.asarray(light.center)
    dist = np.linalg.norm(local, axis=1)
    assert np.all(np.diff(dist) >= -1e-12)
    assert np.allclose(local @ np.asarray(light.normal), 0, atol=1e-12), "on the light's plane"
    assert np.all(np.abs(local @ np.asarray(light.tangent)) <= light.size[0] / 2 + 1e-12)
    assert np.all(np.abs(local @ light.bitangent) <= light.size[1] / 2 + 1e-12)
    p = plan(two_lights, 128, seed=3)
    first = [s for _, s in p.samples_of(0)]
    assert first[0].index == 0 and np.allclose(first[0].point, light.center), "sample 0 is the centre for any seed"


def test_plan_defaults_follow_the_paper(cornell, two_lights):
    assert plan(cornell, 128).samples_per_light == (32,)
    assert plan(two_lights, 128).samples_per_light == (16, 16)
    assert default_samples_per_light(4, 3) == 1
    p = plan(cornell, 1)
    assert p[0].light_samples and p.notes, "a single frame must evaluate the light itself"


def test_jitter_is_uniform_over_the_pixel():
    j = pixel_jitter(256, seed=0)
    assert np.all(j >= -0.5) and np.all(j < 0.5)
    assert np.allclose(j[0], 0.0), "seed 0 starts at the pixel centre"
    assert np.allclose(j.mean(0), 0.0, atol=0.01)
    hist, _, _ = np.histogram2d(j[:, 0], j[:, 1], bins=4, range=[[-0.5, 0.5], [-0.5, 0.5]])
    assert hist.min() >= 12 and hist.max() <= 20, "R2 fills the pixel evenly"
    assert not np.allclose(pixel_jitter(16, seed=1), pixel_jitter(16, seed=0))


def test_plan_rejects_bad_arguments(cornell):
    with pytest.raises(ValueError, match="frames"):
        plan(cornell, 0)
    with pytest.raises(ValueError, match="direct_fraction"):
        plan(cornell, 8, direct_fraction=1.0)
    with pytest.raises(ValueError, match="samples_per_light"):
        plan(cornell, 8, samples_per_light=(1, 2))
    with pytest.raises(ValueError, match="samples_per_light"):
        plan(cornell, 8, samples_per_light=0)


def test_create_context_names_packages_when_egl_is_missing(monkeypatch):
    import moderngl

    from compare.progressive.gl import context

    def broken(**kwargs):
        raise Exception("libEGL.so.1: cannot open shared object file")

    monkeypatch.setattr(moderngl, "create_context", broken)
    with pytest.raises(MissingComponentError) as info:
        context.create_context()
    msg = str(info.value)
    for pkg in ("libegl1", "libegl-mesa0", "libgl1-mesa-dri", "apt-get install"):
        assert pkg in msg


# ----------------------------------------------------------------------------- GL


def test_render_result_shape_finite_and_metadata(gl_ctx, cornell):
    r = render_progressive(cornell, frames=8, seed=0, ctx=gl_ctx, shadow_size=128, checkpoints=(1, 2, 8))
    assert r.image.shape == (48, 64, 3) and r.image.dtype == np.float32
    assert np.isfinite(r.image).all() and r.image.min() >= 0
    assert len(r.frame_seconds) == 8 and r.seconds == pytest.approx(sum(r.frame_seconds))
    assert [c.step for c in r.checkpoints] == [1, 2, 8]
    assert [c.seconds for c in r.checkpoints] == sorted(c.seconds for c in r.checkpoints)
    assert np.array_equal(r.checkpoints[-1].image, r.image)
    meta = r.metadata
    assert meta["renderer"] == "progressive" and meta["frames"] == 8 and meta["seed"] == 0
    assert meta["area_model"] == "radiometric" and meta["gl_renderer"]
    assert all(isinstance(v, (str, int, float)) for v in meta.values())


def test_deterministic_for_a_fixed_seed(gl_ctx, cornell):
    a = render_progressive(cornell, frames=6, seed=7, ctx=gl_ctx, shadow_size=128).image
    b = render_progressive(cornell, frames=6, seed=7, ctx=gl_ctx, shadow_size=128).image
    c = render_progressive(cornell, frames=6, seed=8, ctx=gl_ctx, shadow_size=128).image
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_first_frame_is_cheap_and_shows_a_preview(gl_ctx, cornell):
    with Rasterizer(cornell, frames=32, ctx=gl_ctx, shadow_size=128) as r:
        frames = r.frames()
        next(frames)
        first = r.image()
        for _ in frames:
            pass
        final = r.image()
        assert r.shadow_passes[0] == 0
        assert sum(r.shadow_passes) == 8
        assert r.direct_acc.count == r.plan.light_frames
    # The preview (unshadowed, from the light's centre) is already close to the final image's brightness.
    assert first.mean() == pytest.approx(final.mean(), rel=0.35)
    assert first.mean() > 0.5 * final.mean()


def test_error_falls_as_frames_rise(gl_ctx, cornell):
    ref = render_progressive(cornell, frames=256, seed=1, ctx=gl_ctx, shadow_size=256).image
    errors = [rel_mse(render_progressive(cornell, frames=m, seed=0, ctx=gl_ctx, shadow_size=256).image, ref)
              for m in (2, 8, 32, 128)]
    assert all(a > b for a, b in zip(errors, errors[1:])), errors
    assert errors[-1] < 0.2 * errors[0], errors


@pytest.mark.parametrize("view", ["near", "grazing"])
def test_lambert_plane_matches_polygon_formula(gl_ctx, make_scene, view):
    """Radiometric diffuse: the converged image equals (ρ/π)·E with E from the exact polygon formula.

    "grazing" looks at plane points about 10.7 m from the light, 82° from the plane's
    normal and 86° from the light's: they land in a side face of the shadow atlas
    near its bottom edge, where acne or missing coverage would darken them.
    """
    scene = load_scene(make_scene(PLANE_SCENE))
    if view == "grazing":
        cam = dataclasses.replace(scene.camera, position=(3.0, 4.0, -10.0), target=(3.0, 0.0, -10.5))
        scene = dataclasses.replace(scene, camera=cam)
    r = render_progressive(scene, frames=64, ctx=gl_ctx, materials="diffuse", samples_per_light=256,
                           shadow_size=512)
    expected, valid = lambert_plane_expected(scene)
    assert valid.sum() > 300
    got = r.image[..., 0].astype(np.float64)
    rel = got[valid] / expected[valid] - 1
    assert np.max(np.abs(rel)) < 0.01, f"max relative error {np.max(np.abs(rel)):.4f}"
    # All three channels carry the same grey.
    assert np.allclose(r.image[..., 1], r.image[..., 0]) and np.allclose(r.image[..., 2], r.image[..., 0])


SHADOW_SCENE = """
[camera]
position = [0.0, 12.0, 0.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov = 100
resolution = [160, 160]

[materials.grey]
base_color = [0.5, 0.5, 0.5]
roughness = 1.0

[[meshes]]
name = "plane"
shape = "quad"
size = [30, 30]
material = "grey"

[[lights]]
center = [0.0, 1.0, 0.0]
size = [0.02, 0.02]
normal = [0, -1, 0]
radiance = [5000, 5000, 5000]
"""

# (distance from below the light, azimuth in degrees) of shadow centres on the plane:
# the first falls in the front face, the others in the side faces, down to 83° from the
# light's normal, one on the diagonal where two side faces meet.
SHADOW_TARGETS = [(0.6, 0.0), (3.0, 90.0), (3.0, 180.0), (3.0, 270.0), (6.0, 45.0), (8.0, 0.0), (5.0, 225.0)]


def test_shadow_atlas_covers_the_lit_half_space(gl_ctx, make_scene):
    """Small occluders between the light and the plane in every direction cast their shadows."""
    light_pos = np.array([0.0, 1.0, 0.0])
    boxes, targets, beside = [], [], []
    for rho, az in SHADOW_TARGETS:
        a = math.radians(az)
        s = np.array([rho * math.cos(a), 0.0, rho * math.sin(a)])
        c = light_pos + 0.4 * (s - light_pos)
        boxes.append(f"""
[[meshes]]
shape = "box"
size = [0.4, 0.4, 0.4]
translate = [{c[0]:.6f}, {c[1]:.6f}, {c[2]:.6f}]
material = "grey"
""")
        side = np.array([-math.sin(a), 0.0, math.cos(a)])  # across the shadow
        targets.append(s)
        beside.append((s + 1.6 * side, s - 1.6 * side))
    scene = load_scene(make_scene(SHADOW_SCENE + "".join(boxes)))
    r = render_progressive(scene, frames=2, ctx=gl_ctx, materials="diffuse", samples_per_light=1, shadow_size=512)
    img = r.image[..., 0]
    light = scene.lights[0]
    for (rho, az), s, (p1, p2) in zip(SHADOW_TARGETS, targets, beside):
        assert img[pixel_of(scene.camera, s)] < 1e-6, f"shadow missing at rho={rho}, azimuth={az}"
        for p in (p1, p2):
            # The single light frame (frame 1) shifted the image by its jitter: the pixel saw
            # the scene at its centre minus the jitter.
            row, col = pixel_of(scene.camera, p)
            q = plane_point(scene.camera, row, col, -np.asarray(r.plan[1].jitter))
            want = 0.5 / math.pi * polygon_irradiance(q[None], (0, 1, 0), light.corners(), light.radiance[0])[0]
            assert img[row, col] == pytest.approx(want, rel=0.01), f"acne or leak beside the shadow at {rho}, {az}°"


def test_paper_model_is_a_quarter_below_the_light(gl_ctx, make_scene):
    text = SHADOW_SCENE.replace("position = [0.0, 12.0, 0.0]", "position = [0.0, 5.0, 0.0]").replace(
        "fov = 100", "fov = 30").replace("[160, 160]", "[48, 48]")
    scene = load_scene(make_scene(text))
    kw = dict(frames=2, ctx=gl_ctx, materials="diffuse", samples_per_light=1, shadow_size=128)
    rad = render_progressive(scene, area_model="radiometric", **kw)
    pap = render_progressive(scene, area_model="paper", **kw)
    assert pap.metadata["area_model"] == "paper"
    hit, _ = hit_plane_y0(scene.camera, 1)
    cos_l = 1.0 / np.linalg.norm(hit[..., 0, :] - np.array([0.0, 1.0, 0.0]), axis=-1)
    mask = rad.image[..., 0] > 0
    ratio = pap.image[..., 0][mask] / rad.image[..., 0][mask]
    # Φ/(4πd²)·cosθ_s against L·A·cosθ_l·cosθ_s/d² with Φ = πAL: 1 / (4 cosθ_l).
    assert ratio == pytest.approx(1.0 / (4.0 * cos_l[mask]), rel=0.03)


def test_lights_show_as_one_sided_emitters(gl_ctx, make_scene):
    text = PLANE_SCENE.replace("position = [0, 0.7, 3.0]", "position = [0.2, 0.5, -0.3]").replace(
        "target = [0, 0, 0]", "target = [0.2, 1.5, -0.31]")
    below = load_scene(make_scene(text, name="below.toml"))
    img = render_progressive(below, frames=2, ctx=gl_ctx, shadow_size=64).image
    assert np.allclose(img[24, 32], 4.0, rtol=1e-5), "the front of the light shows its radiance"
    text = PLANE_SCENE.replace("position = [0, 0.7, 3.0]", "position = [0.2, 2.5, -0.3]").replace(
        "target = [0, 0, 0]", "target = [0.2, 1.5, -0.29]")
    above = load_scene(make_scene(text, name="above.toml"))
    img = render_progressive(above, frames=2, ctx=gl_ctx, shadow_size=64).image
    assert np.all(img[24, 32] == 0.0), "the back of the light is black and reflects nothing"


def test_scene_without_lights_skips_light_work(gl_ctx, make_scene):
    text = PLANE_SCENE.split("[[lights]]")[0] + """
[materials.glow]
base_color = [0.0, 0.0, 0.0]
emission = [1.5, 0.5, 0.25]

[[meshes]]
shape = "box"
size = [0.5, 0.5, 0.5]
translate = [0, 0.3, 0]
material = "glow"
"""
    scene = load_scene(make_scene(text))
    with pytest.warns(UserWarning, match="do not light other surfaces"):
        r = Rasterizer(scene, frames=4, ctx=gl_ctx)
    with r:
        assert r.shadow is None and r.direct is None, "no shadow or direct-light programs without area lights"
        for _ in r.frames():
            pass
        img = r.image()
    assert sum(r.shadow_passes) == 0
    assert np.allclose(img[pixel_of(scene.camera, (0, 0.3, 0.25))], (1.5, 0.5, 0.25), rtol=1e-5)


def test_environment_lights_the_scene_with_the_area_light(gl_ctx, tmp_path, make_scene, monkeypatch):
    """Area light and environment together (the environment's own tests are tests/test_ibl*.py)."""
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    scene = load_scene(make_scene(PLANE_SCENE + "\n[environment]\nconstant = [0.1, 0.2, 0.3]\n"))
    r = render_progressive(scene, frames=2, ctx=gl_ctx, shadow_size=64, ibl_size=8, ibl_samples=16)
    assert r.metadata["environment"] == "split sum"
    assert np.allclose(r.image[0, 0], (0.1, 0.2, 0.3)), "the constant environment is the background"
    lit = render_progressive(load_scene(make_scene(PLANE_SCENE, name="lit.toml")), frames=2, ctx=gl_ctx,
                             shadow_size=64).image
    # The grey plane adds its directional albedo times the constant radiance (nothing occludes it).
    from compare.brdf import directional_albedo

    d = scene.camera.ray_directions(np.array(32.5), np.array(40.5))
    albedo = directional_albedo(1.0, float(-d[1]), [0.5] * 3, 0.0, 4096)
    np.testing.assert_allclose(r.image[40, 32] - lit[40, 32], albedo * np.array([0.1, 0.2, 0.3]), rtol=0.01)


def test_readback_rejects_non_finite_pixels(gl_ctx):
    from compare.progressive.gl.readback import read_rgb

    tex = gl_ctx.texture((4, 2), 4, dtype="f4")
    fbo = gl_ctx.framebuffer([tex])
    try:
        data = np.zeros((2, 4, 4), np.float32)
        data[0, 1, 0] = np.nan
        tex.write(data.tobytes())
        with pytest.raises(ImageError, match="NaN"):
            read_rgb(gl_ctx, fbo)
        data[0, 1, 0] = 2.0
        tex.write(data.tobytes())
        img = read_rgb(gl_ctx, fbo)
        assert img.shape == (2, 4, 3) and img[1, 1, 0] == 2.0, "rows flipped once: GL row 0 is the bottom"
    finally:
        fbo.release()
        tex.release()


# ----------------------------------------------------------------------------- the cheap first frame


@pytest.mark.parametrize("scene_file", ["cornell.toml", "car.toml"])
def test_forward_first_frame_matches_the_gbuffer_frame(gl_ctx, scene_file):
    """Frame 0 drawn forward (depth pre-pass + one shading pass) at full size leaves the result unchanged:
    the same every-frame mean, so the same final image; its frame-1 image differs only by the cheaper
    preview. Drawn at half size (the default) it is a preview only: the final image's every-frame mean
    averages frames 1 … N-1, one jitter position fewer, and nothing else changes."""
    import warnings

    def mean_of(acc):  # the every-frame mean's first attachment, row 0 at the top
        w, h = acc.current.size
        return np.frombuffer(acc.current.read(), dtype=np.float32).reshape(h, w, 4)[::-1, :, :3]

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = load_scene(ROOT / "scenes" / scene_file).with_resolution(48, 36)
    frames = 6
    images, means = {}, {}
    for mode, scale in (("forward", 1.0), ("forward", 0.5), ("gbuffer", 1.0)):
        with Rasterizer(s, frames=frames, ctx=gl_ctx, shadow_size=64, ibl_size=16, ibl_samples=16,
                                 first_frame=mode, first_frame_scale=scale) as r:
            meta = r.metadata()
            assert meta["first_frame"] == mode
            assert meta["first_frame_scale"] == scale
            assert (r.first is not None) == (mode == "forward")
            r.render_frame()
            first = r.image()
            assert r.base.count == (0 if scale < 1 else 1), "a reduced frame 0 adds nothing to the means"
            means[mode, scale, 0] = mean_of(r.base).copy() if r.base.count else None
            r.render_frame()
            second = r.image()
            for _ in r.frames():
                pass
            means[mode, scale] = mean_of(r.base).copy()
            images[mode, scale] = first, second, r.image()
    (f1, _, fin), (h1, h2, hin), (g1, g2, gin) = (images["forward", 1.0], images["forward", 0.5],
                                                   images["gbuffer", 1.0])
    for im in (f1, h1, h2):
        assert im.shape == g1.shape and np.isfinite(im).all() and im.min() >= 0
    np.testing.assert_allclose(fin, gin, rtol=1e-4, atol=1e-6)
    # Frame 0 drawn forward against drawn from the G-buffer, mean |difference| / mean, measured at 48x36 (seed 0;
    # seeds 0-3): Cornell 0.14 % (0.14-0.22 %), car 1.1 % (0.85-1.5 %); the means 0.991-0.998 of the G-buffer's.
    bound = {"cornell.toml": 0.005, "car.toml": 0.03}[scene_file]
    assert np.abs(f1 - g1).mean() < bound * g1.mean()
    assert f1.mean() > 0.98 * g1.mean()
    # Half size: the final images differ by exactly frame 0's share of the every-frame mean,
    # (b_0 - mean of b_1 … b_N-1) / N; the direct light and the environment's occlusion means are the same.
    b0, rest = means["gbuffer", 1.0, 0], means["forward", 0.5]
    np.testing.assert_allclose(frames * (gin - hin), b0 - rest, rtol=1e-3, atol=1e-4)
    assert np.abs(gin - hin).max() > 0, "frame 0's jitter position is one of the mean's"
    # The upsampled preview keeps the lit surfaces' brightness, and from frame 2 on the preview is the
    # full-size one. Emitters (radiance far above any lit surface here) alias differently at another
    # size or with one jitter position fewer, so they are left out.
    for a, b, bound in ((h1, g1, 0.2), (h2, g2, 0.1)):  # measured 1.16, 1.06 (Cornell) and 1.03, 1.00 (car) at 48x36
        lit = np.maximum(a, b).max(axis=2) < 1.5
        assert lit.mean() > 0.9
        assert a[lit].mean() == pytest.approx(b[lit].mean(), rel=bound)
    # The upsampled borders show their own side of the image, not the opposite one: measured ≤ 0.04 of the
    # image mean; a wrapping sampler gave 0.13 (Cornell's top row) and 0.22–0.55 (car). The bottom row is
    # left out: the Cornell floor's edge aliases there either way.
    for edge in (np.s_[0], np.s_[:, 0], np.s_[:, -1]):
        assert np.abs(h1[edge] - g1[edge]).mean() < 0.1 * g1.mean()


def test_first_frame_mode_is_validated():
    s = load_scene(CORNELL).with_resolution(8, 6)
    with pytest.raises(ValueError, match="first_frame"):
        Rasterizer(s, frames=2, first_frame="deferred")


def test_first_frame_is_reduced_only_where_the_preview_keeps_its_structure(gl_ctx):
    from compare.progressive.first_frame import auto_scale

    assert auto_scale((320, 240)) == auto_scale((1920, 1080)) == 0.5
    assert auto_scale((319, 240)) == auto_scale((320, 239)) == auto_scale((64, 48)) == 1.0
    s = load_scene(CORNELL).with_resolution(320, 240)
    for frames, scale in ((2, 0.5), (1, 1.0)):  # with one frame the preview would be the result
        with Rasterizer(s, frames=frames, ctx=gl_ctx, shadow_size=64, warm_up=False) as r:
            assert r.metadata()["first_frame_scale"] == scale


@pytest.mark.parametrize("scale", [0.0, -0.5, 1.5, float("nan"), True])
def test_first_frame_scale_is_validated(gl_ctx, scale):
    s = load_scene(CORNELL).with_resolution(8, 6)
    with pytest.raises(ValueError, match="first_frame_scale"):
        Rasterizer(s, frames=2, ctx=gl_ctx, first_frame_scale=scale)


def test_image_sizes_beyond_the_context_are_refused_up_front(gl_ctx, monkeypatch):
    """Before any GL object is made: a side beyond GL_MAX_TEXTURE_SIZE, or targets beyond the machine's
    memory, is one error naming the scene file and the limit (before: a moderngl traceback)."""
    from compare.util.errors import SceneError
    from compare.progressive.gl import context

    limit = int(gl_ctx.info["GL_MAX_TEXTURE_SIZE"])
    scene = load_scene(CORNELL).with_resolution(limit + 1, 8)
    with pytest.raises(SceneError) as exc:
        Rasterizer(scene, frames=2, ctx=gl_ctx)
    assert str(exc.value).startswith(f"{CORNELL}: camera.resolution: {limit + 1}x8 is larger than this OpenGL "
                                     f"context's largest texture, {limit} pixels a side (GL_MAX_TEXTURE_SIZE of ")
    monkeypatch.setattr(context, "BYTES_PER_PIXEL", 2**50)  # as if the targets were vast
    with pytest.raises(SceneError, match=r"camera.resolution: 16x12 needs about \d+ GiB of render targets, more "
                                         r"than this machine's \d+ GiB of memory"):
        Rasterizer(load_scene(CORNELL).with_resolution(16, 12), frames=2, ctx=gl_ctx)


@pytest.mark.parametrize("scene_file, options", [
    ("cornell.toml", {}),
    ("cornell.toml", {"area_model": "ltc"}),
    ("car.toml", {}),  # environment: occluded diffuse and specular means
    ("kitchen.toml", {"indirect": "probes"}),  # irradiance volume
])
def test_layers_sum_to_the_displayed_image(gl_ctx, scene_file, options):
    """The rasterizer's layers (compare.mitsuba.layers names) are its targets, and sum to its image."""
    scene = load_scene(ROOT / "scenes" / scene_file).with_resolution(40, 30)
    res = render_progressive(scene, frames=12, ctx=gl_ctx, **options)
    layers = res.layers
    assert "emission" in layers and "direct_area" in layers
    assert ("direct_env" in layers) == scene.features().environment
    assert ("indirect_diffuse" in layers) == (options.get("indirect") == "probes")
    assert "indirect_specular" not in layers  # it renders none
    np.testing.assert_allclose(sum(layers.values()), res.image, rtol=1e-6, atol=1e-6)


def test_a_half_float_preview_holds_a_bright_sky_finite(gl_ctx, make_scene):
    """The reduced frame 0 is a half-float preview: radiance beyond its range (a sky of 1e6 behind a grey
    sphere) is held at the largest half float, never inf; frame 1 shows the full value again."""
    s = load_scene(make_scene("""
        [camera]
        position = [0.0, 0.0, 3.0]
        target = [0.0, 0.0, 0.0]
        resolution = [320, 240]

        [materials.grey]
        base_color = [0.5, 0.5, 0.5]

        [[meshes]]
        shape = "sphere"
        radius = 0.5
        material = "grey"

        [environment]
        constant = [1e6, 1e6, 1e6]
        """))
    with Rasterizer(s, frames=2, ctx=gl_ctx, ibl_size=16, ibl_samples=16, first_frame_scale=0.5) as r:
        r.render_frame()
        preview = r.image()
        r.render_frame()
        full = r.image()
    assert np.isfinite(preview).all() and preview.min() >= 0.0
    assert preview.max() == pytest.approx(65504.0, rel=1e-3)  # held at the largest half float
    assert np.isfinite(full).all() and full.max() == pytest.approx(1e6, rel=1e-3)
