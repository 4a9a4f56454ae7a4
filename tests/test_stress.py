"""The stress scenes (scenes/stress/): what must hold at the numerical extremes, in both renderers.

Every scene is also rendered by tests/test_scenes.py (finite, non-negative,
below the brightest source). Here each gets the assertions it exists for:
closed forms, linearity, scale invariance, invariance to degenerate faces,
per-light bookkeeping, error trends and float32 accumulation drift. Two
known failures of the renderers are recorded as strict xfails, so they show
in every run and turn into failures once fixed (then drop the marker).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.util
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from compare.scene.loader import load_scene
from tests.helpers import CORNELL, ROOT, SMALL_IBL

STRESS = ROOT / "scenes" / "stress"


def load(name: str, size=(48, 36)):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = load_scene(STRESS / name if not Path(name).is_absolute() else name)
    return s.with_resolution(*size) if size else s


def reference(scene, spp: int, **kw) -> np.ndarray:
    from compare.mitsuba.reference import ReferenceRenderer

    return ReferenceRenderer(scene, cache_dir=False, progress=False, **kw).render(spp).image


def progressive(scene, ctx, **kw):
    from compare.progressive.rasterizer import render_progressive

    opts = {"frames": 64, "shadow_size": 256, "ctx": ctx, **kw}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return render_progressive(scene, **opts)


def floor_points(cam, height: float = 0.0):
    """World points where the pixel-centre rays of ``cam`` meet the plane y = height, and t (ray length)."""
    jj, ii = np.meshgrid(np.arange(cam.height) + 0.5, np.arange(cam.width) + 0.5, indexing="ij")
    d = cam.ray_directions(ii, jj)
    o = np.asarray(cam.position, dtype=np.float64)
    t = (height - o[1]) / d[..., 1]
    return o + t[..., None] * d, t, d


def sphere_hits(origin, direction, centre, radius, tmax=np.inf):
    oc = origin - centre
    b = (oc * direction).sum(-1)
    c = (oc * oc).sum(-1) - radius * radius
    disc = b * b - c
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    return (disc > 0) & (t > 0) & (t < tmax), t


def _generator():
    spec = importlib.util.spec_from_file_location("scenes_generate", ROOT / "scenes" / "generate.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["scenes_generate"] = module
    spec.loader.exec_module(module)
    return module


# ----------------------------------------------------------------------------- roughness sweep


def _sphere_ids(scene):
    """Per pixel, the index of the sweep sphere it sees (shrunk 8 % to stay off silhouettes), or −1."""
    cam = scene.camera
    _, _, d = floor_points(cam)
    o = np.asarray(cam.position)
    ids = np.full(d.shape[:2], -1)
    best = np.full(d.shape[:2], np.inf)
    for k, m in enumerate(scene.meshes[1:]):
        hit, t = sphere_hits(o, d, m.transform[:3, 3], m.params["radius"] * 0.92)
        hit &= t < best
        ids[hit], best[hit] = k, t[hit]
    return ids


@functools.lru_cache(maxsize=None)
def _direct_reference(name: str, size: tuple[int, int], spp: int) -> np.ndarray:
    """The direct-light reference of a stress scene, rendered once for all the area models tested on it."""
    return reference(load(name, size), spp, max_depth=2)


@pytest.mark.parametrize("area_model", ["radiometric", "ltc"])
def test_roughness_sweep_agrees_and_highlights_fall_with_roughness(gl_ctx, area_model):
    """Roughness 0…1 × metallic 0/1 under one light: no sphere brighter than the light; per-sphere
    means of the rasterizer within 6 % (dielectric) and 25 % (metal) of the direct-light reference;
    the metal highlight's peak falls as roughness grows, in both renderers (once the lobe is wider
    than the light's reflection)."""
    s = load("roughness_sweep.toml", (96, 72))
    ids = _sphere_ids(s)
    ref = _direct_reference("roughness_sweep.toml", (96, 72), 128)
    ras = progressive(s, gl_ctx, frames=96, shadow_size=512, area_model=area_model).image
    light = max(s.lights[0].radiance)
    assert ref.max() <= light and ras.max() <= light  # even the roughness-0 mirror reflects at most L
    peaks = {"ref": [], "ras": []}
    for k, mesh in enumerate(s.meshes[1:]):
        sel = ids == k
        assert sel.sum() > 30, mesh.name
        r, p = ref[sel].max(-1), ras[sel].max(-1)
        metal = s.materials[mesh.material].metallic == 1
        assert abs(p.mean() / r.mean() - 1) < (0.25 if metal else 0.06), mesh.name
        if metal:
            peaks["ref"].append(r.max())
            peaks["ras"].append(p.max())
    # A peak cannot pass the light's reflection F·L: a mirror and a lobe still narrower than the light as
    # seen in the sphere (roughness 0 and 0.2 in the reference, which keeps the file's roughness 0) both
    # reach it, within the noise; from there on the peaks fall.
    for name, values in peaks.items():
        assert all(a >= 0.99 * b for a, b in zip(values, values[1:])), f"{name}: metal peaks {values} rise"
        assert all(a > b for a, b in zip(values[1:], values[2:])), f"{name}: metal peaks {values} do not fall"


# ----------------------------------------------------------------------------- grazing views


def test_grazing_views_reference_stays_bounded():
    s = load("grazing.toml", (64, 48))
    image = reference(s, 64, max_depth=2)
    assert np.isfinite(image).all() and image.min() >= 0
    assert image.max() <= max(s.lights[0].radiance) * 1.0001  # radiance of what the plane reflects ≤ L


_RADIOMETRIC_GRAZING = pytest.mark.xfail(strict=True, reason=(
    "finding: the representative-point specular still overestimates the glossy plane's tail at N.V ~ 0.1: "
    "measured 2.0x the reference (6.4x with Karis' isotropic normalisation; the foreshortened, albedo-bounded "
    "form in area_light.glsl brought it down); a lobe-coverage factor that reaches 0.95 here breaks the "
    "roughness sweep's metal spheres (0.57x); area_model='ltc' integrates the polygon in closed form instead"))


@pytest.mark.parametrize("area_model, what", [
    ("radiometric", "energy bound"), pytest.param("radiometric", "plane radiance", marks=_RADIOMETRIC_GRAZING),
    # ltc: measured 0.88x. The closed form alone, a fitted LTC cut by the horizon, was 1.89x; the
    # specular shadow ratio, whose denominator is the LTC's own estimate per sample, corrects its shape.
    ("ltc", "energy bound"), ("ltc", "plane radiance")])
def test_grazing_views_rasterizer_energy(gl_ctx, area_model, what):
    s = load("grazing.toml", (64, 48))
    image = progressive(s, gl_ctx, frames=64, area_model=area_model).image
    assert np.isfinite(image).all() and image.min() >= 0
    if what == "energy bound":
        assert image.max() <= max(s.lights[0].radiance) * 1.0001
    else:
        ref = _direct_reference("grazing.toml", (64, 48), 64)
        low = slice(s.camera.height * 3 // 4, None)  # the plane's near part: N.V about 0.1
        ratio = image[low].mean() / ref[low].mean()
        print(f"grazing plane, {area_model}: rasterizer / reference = {ratio:.3f}")
        assert 0.67 < ratio < 1.5


# ----------------------------------------------------------------------------- sun and tiny light


def _sun_scene_expectation(s):
    """(floor radiance expected for a white Lambert floor, mask of floor pixels far from the sphere's influence)."""
    from compare.scene.equirect import direction_to_uv, uv_to_direction
    from compare.image.exr import read_exr

    env, _ = read_exr(s.environment.file)
    h, w, _ = env.shape
    # Irradiance of an upward plane from Mitsuba's bilinear interpolation of the map (texel rows at
    # v = j/(h−1)): separable, so each row's weight is its tent's integral of cos θ sin θ dθ over the
    # upper hemisphere, and each column's is 2π/w.
    theta = (np.arange(100_000) + 0.5) / 100_000 * np.pi / 2
    v = theta / np.pi * (h - 1)
    rows = np.array([(np.clip(1 - np.abs(v - j), 0, None) * np.cos(theta) * np.sin(theta)).sum()
                     for j in range(h)]) * (np.pi / 2 / len(theta))
    e_env = (env.astype(np.float64).sum(1) * rows[:, None]).sum(0) * 2 * np.pi / w
    row, col = np.unravel_index(np.argmax(env[..., 0]), env.shape[:2])
    sun = uv_to_direction((col + 0.5) / w, row / (h - 1))  # Mitsuba's texel positions
    assert np.allclose(direction_to_uv(sun), [(col + 0.5) / w, row / (h - 1)])
    x, t, view = floor_points(s.camera)
    light = s.lights[0]
    r = np.asarray(light.center) - x
    dist = np.linalg.norm(r, axis=-1)
    e_tiny = light.radiance[0] * light.area * (r[..., 1] / dist) ** 2 / dist**2
    sphere = s.meshes[1]
    centre, radius = sphere.transform[:3, 3], sphere.params["radius"] * 1.3
    shadowed = (sphere_hits(x, np.broadcast_to(sun, x.shape), centre, radius)[0]
                | sphere_hits(x, r / dist[..., None], centre, radius, dist)[0])
    far = np.linalg.norm((x - centre)[..., [0, 2]], axis=-1) > 1.2  # the sphere hides < 0.3 % of the sky there
    on_floor = (t > 0) & (np.abs(x[..., 0]) < 10) & (np.abs(x[..., 2]) < 10)  # the floor is 30 m wide
    seen = ~sphere_hits(np.asarray(s.camera.position), view, centre, radius)[0]  # not the sphere itself
    mask = on_floor & seen & ~shadowed & far
    albedo = s.materials["white"].base_color[0]
    return albedo / np.pi * (e_env[None, None, :] + e_tiny[..., None]), mask


def test_sun_and_tiny_light_reference_matches_closed_form():
    """A 1e5 sun, a sky of ~1 and a 2 mm light of 1e8: the floor's direct light is known in closed form."""
    s = load("sun_and_tiny_light.toml", (64, 48))
    expected, mask = _sun_scene_expectation(s)
    assert mask.sum() > 0.6 * mask.size
    image = reference(s, 64, materials="diffuse", max_depth=2)
    assert np.isfinite(image).all() and image.min() >= 0
    ratio = image[mask] / expected[mask]
    np.testing.assert_allclose(ratio.mean(0), 1.0, atol=0.01)  # measured 0.9988
    assert abs(np.median(ratio) - 1) < 0.01


def test_sun_and_tiny_light_rasterizer_matches_closed_form(gl_ctx, tmp_path):
    s = load("sun_and_tiny_light.toml", (64, 48))
    expected, mask = _sun_scene_expectation(s)
    # Occlusion off (d_occ = 0): the closed form is for the unoccluded floor, and the screen-space occlusion
    # darkens floor near the sphere on screen by up to 10 % (its samples land on the sphere's depth).
    result = progressive(s, gl_ctx, frames=32, materials="diffuse", cache_dir=tmp_path, d_occ=0.0, **SMALL_IBL)
    image = result.image
    assert np.isfinite(image).all() and image.min() >= 0
    assert result.metadata["environment"] != "none"
    ratio = image[mask] / expected[mask]
    # Measured: 0.996 (per pixel 0.956 … 1.019) with the default 128² cube maps, 0.977 with these 32² ones.
    np.testing.assert_allclose(ratio.mean(0), 1.0, atol=0.04)
    assert ratio.min() > 0.9 and ratio.max() < 1.1


# ----------------------------------------------------------------------------- very dark scene


def test_dark_scene_is_the_bright_one_scaled(gl_ctx):
    """Radiance 1e-6: both renderers are linear, so ×1e6 gives the Cornell box (same seed) to float precision."""
    dark = load("dark.toml")
    bright = load(str(CORNELL))
    for name, render in (("reference", lambda s: reference(s, 16)),
                         ("rasterizer", lambda s: progressive(s, gl_ctx, frames=32).image)):
        d, b = render(dark).astype(np.float64) * 1e6, render(bright).astype(np.float64)
        assert (b > 0).mean() > 0.5, name
        assert np.array_equal(d > 0, b > 0), f"{name}: dark pixels flushed to zero"
        rel = np.abs(d - b) / np.maximum(b, 1e-3 * b.max())
        assert rel.max() < 1e-4, f"{name}: dark ×1e6 differs from bright by {rel.max():.2e}"


def test_error_falls_with_frames(gl_ctx):
    """The dark box's direct light: the rasterizer's error against the reference falls as frames accumulate."""
    s = load("dark.toml")
    ref = reference(s, 1024, max_depth=2)
    result = progressive(s, gl_ctx, frames=256, checkpoints=(96, 128, 192, 256))
    err = [np.abs(c.image - ref).mean() / ref.mean() for c in result.checkpoints]
    assert all(a > b for a, b in zip(err, err[1:])), err
    assert err[-1] < 0.75 * err[0] and err[-1] < 0.04, err


# ----------------------------------------------------------------------------- scale 1e-3 and 1e4


@pytest.fixture(scope="module")
def unit_scale_scene(tmp_path_factory):
    gen = _generator()
    path = tmp_path_factory.mktemp("scale") / "scale_1.toml"
    path.write_text(gen.toml_text("unit scale", {"name": "scale 1", **gen.scaled(gen.SCALE_BASE, 1.0)}))
    return load(str(path))


@pytest.mark.parametrize("name", ["scale_1e-3.toml", "scale_1e4.toml"])
def test_scale_invariance_rasterizer(gl_ctx, unit_scale_scene, name):
    """Lengths ×1e-3 or ×1e4, radiance unchanged: the same image (shadow-map depth and bias are relative)."""
    unit = progressive(unit_scale_scene, gl_ctx).image
    scaled = progressive(load(name), gl_ctx).image
    assert unit.mean() > 0.02
    np.testing.assert_allclose(scaled, unit, rtol=0, atol=1e-4 * unit.max())


@pytest.mark.parametrize("name", ["scale_1e-3.toml", "scale_1e4.toml"])
def test_scale_invariance_reference(unit_scale_scene, name):
    """Lengths ×1e-3 or ×1e4, radiance unchanged: the same image. Mitsuba 3 offsets secondary rays by
    (1 + max|p|)·8.9e-5 scene units, a quarter of the sphere's radius at millimetre scale (contact shadows
    shrank, light leaked: +2.4 % mean, 12 % of pixels off by > 5 %), so the reference renders tiny scenes
    scaled up (compare.mitsuba.scene_dict.world_scale)."""
    unit = reference(unit_scale_scene, 32)
    scaled = reference(load(name), 32)
    assert abs(scaled.mean() / unit.mean() - 1) < 0.005
    diff = np.abs(scaled - unit).max(-1)
    assert (diff > 0.05 * np.maximum(unit.max(-1), 0.05)).mean() < 0.01


def test_world_scale_only_touches_tiny_scenes(unit_scale_scene):
    from compare.mitsuba.scene_dict import world_scale

    assert world_scale(load("scale_1e-3.toml")) == 1000.0
    assert world_scale(load("scale_1e4.toml")) == world_scale(unit_scale_scene) == 1.0
    for name in ("cornell.toml", "kitchen.toml", "car.toml"):  # their cached references stay valid
        assert world_scale(load_scene(ROOT / "scenes" / name)) == 1.0


# ----------------------------------------------------------------------------- degenerate mesh


def _without_zero_area_faces(tmp_path: Path) -> Path:
    """A copy of degenerate.toml whose OBJ has the zero-area faces removed (same vertices, same order)."""
    from compare.scene import geometry

    src = STRESS / "degenerate.obj"
    lines = src.read_text().splitlines()
    verts = np.array([[float(v) for v in ln.split()[1:4]] for ln in lines if ln.startswith("v ")])
    kept = []
    for ln in lines:
        if ln.startswith("f "):
            idx = [int(t) - 1 for t in ln.split()[1:]]
            p = verts[idx]
            area = sum(np.linalg.norm(np.cross(p[k] - p[0], p[k + 1] - p[0])) for k in range(1, len(p) - 1))
            if len(set(idx)) < 3 or area < 1e-12:
                continue
        kept.append(ln)
    (tmp_path / "degenerate.obj").write_text("\n".join(kept) + "\n")
    (tmp_path / "degenerate.toml").write_text((STRESS / "degenerate.toml").read_text())
    assert geometry.load_obj(tmp_path / "degenerate.obj").triangle_count < geometry.load_obj(src).triangle_count
    return tmp_path / "degenerate.toml"


def test_degenerate_mesh_loads_with_unit_normals():
    from compare.scene import geometry

    mesh = geometry.load_obj(STRESS / "degenerate.obj")
    p = mesh.positions.astype(np.float64)
    i = mesh.indices
    area = np.linalg.norm(np.cross(p[i[:, 1]] - p[i[:, 0]], p[i[:, 2]] - p[i[:, 0]]), axis=1)
    assert (area < 1e-12).sum() >= 10  # the file really is degenerate
    assert len(np.unique(p, axis=0)) < len(p)  # duplicate vertices
    assert np.isfinite(mesh.normals).all()
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-6)
    assert (mesh.normals[:, 1] > 0).all()  # the bumpy patch faces up everywhere


def test_zero_area_faces_change_nothing(gl_ctx, tmp_path):
    s = load("degenerate.toml")
    clean = load(str(_without_zero_area_faces(tmp_path)))
    a, b = progressive(s, gl_ctx).image, progressive(clean, gl_ctx).image
    assert np.isfinite(a).all() and a.mean() > 0.01
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-5 * b.max())
    ra, rb = reference(s, 16), reference(clean, 16)
    assert np.isfinite(ra).all()
    assert abs(ra.mean() / rb.mean() - 1) < 0.01


# ----------------------------------------------------------------------------- 64 area lights


def test_64_lights_match_the_closed_form(gl_ctx):
    """An empty floor under the 64 coloured lights: every light's polygon irradiance, summed, per channel."""
    from compare.metrics.closed_form import polygon_irradiance

    s = load("many_lights.toml")
    assert len(s.lights) == 64
    floor = dataclasses.replace(s, meshes=s.meshes[:1])
    x, t, _ = floor_points(floor.camera)
    on = (t > 0) & (np.abs(x[..., 0]) < 2.9) & (np.abs(x[..., 2]) < 2.9)
    assert on.mean() > 0.5
    up = np.array([0.0, 1.0, 0.0])
    irradiance = sum(polygon_irradiance(x, up, light.corners(), np.asarray(light.radiance)) for light in s.lights)
    expected = s.materials["floor"].base_color[0] / np.pi * irradiance
    result = progressive(floor, gl_ctx, frames=256, materials="diffuse")  # n_i = round(256/64/4) = 1
    assert result.plan.samples_per_light == (1,) * 64 and sum(fp.shadow_passes for fp in result.plan) == 64
    ratio = result.image[on] / expected[on]
    assert np.abs(ratio - 1).max() < 0.02  # small lights: the centre sample is within 2 % everywhere
    ref = reference(floor, 32, materials="diffuse", max_depth=2)
    np.testing.assert_allclose((ref[on] / expected[on]).mean(0), 1.0, atol=0.02)


# ----------------------------------------------------------------------------- long accumulation


def _drift(gl_ctx, frames: int) -> float:
    """Largest |float32 running mean − float64 mean of the same frames| after ``frames`` frames, / emission.

    Every frame's value is recovered from consecutive read-backs, C_n = A_{n−1} + n·(A_n − A_{n−1}):
    a pixel sees either the strip (the emission) or black, so even with float32 read-backs amplified by n
    the value is unambiguous, and its float64 mean is exact.
    """
    from compare.progressive.rasterizer import Rasterizer

    s = load("long_accumulation.toml", None)
    emission = np.asarray(s.materials["glow"].emission, dtype=np.float64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # Frame 0 at full size is the mean's first value (a reduced one is a preview outside it).
        r = Rasterizer(s, frames=frames, ctx=gl_ctx, warm_up=False, first_frame_scale=1.0)
    try:
        assert r.shadow is None and r.environment is None  # nothing but jitter and accumulation
        prev = np.zeros((s.camera.height, s.camera.width, 3))
        lit = np.zeros((s.camera.height, s.camera.width))
        worst = 0.0  # largest distance of a recovered frame value from 0 or the emission
        for n, _ in r.frames():
            mean = r.image().astype(np.float64)
            value = prev + n * (mean - prev)
            on = np.abs(value[..., 0] - emission[0]) < np.abs(value[..., 0])
            worst = max(worst, float(np.abs(value - on[..., None] * emission).max()))
            lit += on
            prev = mean
    finally:
        r.release()
    assert worst < 0.1 * emission.min(), f"a frame's value is neither 0 nor the emission (off by {worst:g})"
    fraction = lit / frames
    assert ((fraction > 0.1) & (fraction < 0.9)).sum() >= 8  # columns 1 and 2 really vary from frame to frame
    exact = fraction[..., None] * emission
    return float(np.abs(prev - exact).max() / emission.max())


def test_long_accumulation_float32_drift_1e4_frames(gl_ctx):
    """10⁴ frames of a 4 × 4 image: the RGBA32F running mean stays within 5e-6 of the float64 mean
    (measured, seed 0: 4.7e-7 after 10³ frames, 8.5e-7 after 10⁴; seeds 1 and 2: 7.5e-8 and 9.2e-7 after 10⁴)."""
    assert _drift(gl_ctx, 10_000) < 5e-6


@pytest.mark.slow
def test_long_accumulation_float32_drift_1e5_frames(gl_ctx):
    """10⁵ frames (1–4 minutes on llvmpipe): the drift stays within 3e-5 of the float64 mean."""
    assert _drift(gl_ctx, 100_000) < 3e-5


# ----------------------------------------------------------------------------- early frames


def test_rasterizer_is_never_negative_at_any_checkpoint(gl_ctx, tmp_path):
    """Early images too: the environment-occlusion estimate once went negative after 2–16 frames (car: −0.12)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = load_scene(ROOT / "scenes" / "car.toml").with_resolution(48, 36)
    result = progressive(s, gl_ctx, frames=64, checkpoints=(2, 4, 8, 16, 32, 64), cache_dir=tmp_path, **SMALL_IBL)
    for c in result.checkpoints:
        assert c.image.min() >= 0, f"frame {c.frame}: min {c.image.min():g}"


# ----------------------------------------------------------------------------- texture extremes


def test_texture_extremes_render_in_both_renderers(gl_ctx):
    """High-frequency normal maps at grazing angles, alpha-masked cards, a 1 x 1 and an 8192-wide map:
    both renderers give finite, non-negative images; the foliage cards cover the same pixels (their
    green fraction within 10 %); the 1 x 1 box has its texel's colour."""
    scene = load("textures.toml", size=(96, 72))
    raster = progressive(scene, gl_ctx, frames=32).image
    ref = reference(scene, 128)
    for name, img in (("rasterizer", raster), ("reference", ref)):
        assert np.all(np.isfinite(img)) and img.min() >= 0.0, name
    green = [float(((img[..., 1] > 1.5 * img[..., 0]) & (img[..., 1] > 1.5 * img[..., 2])).mean())
             for img in (raster, ref)]
    assert green[1] > 0.005 and green[0] == pytest.approx(green[1], rel=0.1), green
    # the one-texel box: orange, as its texel (sRGB (0.9, 0.45, 0.1)) is
    box = (ref[..., 0] > 3 * ref[..., 1]) & (ref[..., 1] > 3 * ref[..., 2])
    assert box.sum() > 20
    r = raster[box].mean(0)
    assert r[0] > 3 * r[1] > 9 * r[2]


def test_a_map_larger_than_the_gpu_takes_is_one_clear_error(tmp_path, gl_ctx):
    from PIL import Image

    from compare.util.errors import ImageError

    import shutil

    largest = int(gl_ctx.info["GL_MAX_TEXTURE_SIZE"])
    shutil.copytree(STRESS / "textures", tmp_path / "textures")
    Image.new("RGB", (largest + 1, 1), (200, 100, 50)).save(tmp_path / "textures" / "huge.png")
    (tmp_path / "t.toml").write_text((STRESS / "textures.toml").read_text().replace("one_texel.png", "huge.png"))
    scene = load(str(tmp_path / "t.toml"), size=(16, 12))
    with pytest.raises(ImageError, match=f"huge.png: {largest + 1} x 1 texels, more than this OpenGL's largest"):
        progressive(scene, gl_ctx, frames=1)
