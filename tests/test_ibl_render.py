"""Environment lighting through both renderers: furnaces, a mirror sphere, a concave corner.

Done-when checks of the IBL issue:

* ``test_white_furnace_both_renderers``: a white Lambert sphere in a uniform
  environment of radiance 1 renders as 1 within 1 % in the rasterizer and in
  Mitsuba;
* ``test_mirror_sphere_matches_the_reference``: a roughness-0 metal sphere
  reflects the marked 'axes' map the same way in both (mean LDR-FLIP < 0.03;
  measured 0.015, two reference seeds differ by 0.007, a mirrored image by 0.16);
* ``test_specular_occlusion_darkens_the_corner_like_the_reference``: screen-space
  occlusion darkens a concave corner where Mitsuba does, with d_occ's effect printed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from compare.brdf import directional_albedo
from compare.metrics.images import flip
from compare.progressive.rasterizer import Rasterizer, render_progressive
from compare.mitsuba.reference import ReferenceRenderer
from compare.scene.loader import load_scene, parse_scene
from tests.helpers import CORNELL, ROOT


#: Small preprocessing for tests: 16² or 32² cube faces, few GGX samples.
SMALL = {"ibl_size": 16, "ibl_samples": 64}


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def sphere_scene(material: dict, environment: dict, size=(48, 48), name="sphere", extra_meshes=()):
    return parse_scene({
        "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 35, "resolution": list(size)},
        "materials": {"m": material, "grey": {"base_color": [0.5, 0.5, 0.5], "roughness": 0.8}},
        "meshes": [{"shape": "sphere", "radius": 1.0, "material": "m", "segments": 128, "rings": 64},
                   *extra_meshes],
        "environment": environment,
        "render": {"max_depth": 2},
    }, ROOT / "tests" / f"{name}.toml")


def disc_mask(scene, fraction: float) -> np.ndarray:
    """Pixels whose centre ray hits the unit sphere at the origin with n·v > ``fraction``."""
    cam = scene.camera
    jj, ii = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.ray_directions(ii + 0.5, jj + 0.5)
    o = np.asarray(cam.position, dtype=float)
    b = d @ o
    disc = b * b - (o @ o - 1.0)
    t = -b - np.sqrt(np.maximum(disc, 0))
    n = o + t[..., None] * d
    return (disc > 0) & (np.sum(-d * n, axis=-1) > fraction)


# ----------------------------------------------------------------------------- what runs when


def test_scene_without_environment_does_no_environment_work(gl_ctx, tmp_path, monkeypatch):
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path))
    cornell = load_scene(CORNELL).with_resolution(32, 24)
    with Rasterizer(cornell, frames=4, ctx=gl_ctx, shadow_size=64) as r:
        assert r.environment is None and r.env_occlusion is None and r.env_acc is None
        assert r.accumulate.environment is None
        assert not any(fp.env_samples for fp in r.plan)
        for _ in r.frames():
            pass
        assert r.metadata()["environment"] == "none"
    assert not (tmp_path / "ibl").exists(), "no preprocessing for a scene without an environment"


def test_first_frame_is_environment_only(gl_ctx):
    scene = sphere_scene({"base_color": [0.8, 0.8, 0.8], "roughness": 0.4},
                         {"procedural": "sky", "width": 64, "sun_radiance": 0.0},
                         extra_meshes=[{"shape": "quad", "size": [4, 4], "material": "grey",
                                        "translate": [0, -1, 0]}])
    with Rasterizer(scene, frames=8, ctx=gl_ctx, **SMALL) as r:
        assert r.plan.env_frames == 7 and not r.plan[0].env_samples
        r.render_frame()
        assert r.env_acc.count == 0, "frame 0: no occlusion pass"
        first = r.image()
        for _ in r.frames():
            pass
        assert r.env_acc.counts == list(r.plan.env_counts)
        meta = r.metadata()
    with Rasterizer(scene, frames=8, ctx=gl_ctx, d_occ=0.0, **SMALL) as r0:
        assert r0.env_occlusion is None and r0.plan.env_frames == 0
        r0.render_frame()
        np.testing.assert_array_equal(first, r0.image())  # frame 0 is the unoccluded split sum
    assert meta["environment"] == "split sum" and meta["env_samples"] == 8 and meta["env_frames"] == 7
    # The preprocessing went to the default cache, $COMPARE_CACHE/ibl/, keyed by content.
    import os

    cached = list((Path(os.environ["COMPARE_CACHE"]) / "ibl").rglob("*.npz"))
    assert any(f.stem == r.environment.ibl.key for f in cached)
    assert meta["env_samples_diffuse"] == 4 and meta["d_occ"] > 0
    assert all(isinstance(v, (str, int, float)) for v in meta.values())


def test_bad_environment_options_are_refused(gl_ctx):
    scene = sphere_scene({"base_color": [1, 1, 1]}, {"constant": [1, 1, 1]})
    with pytest.raises(ValueError, match="d_occ"):
        Rasterizer(scene, frames=2, ctx=gl_ctx, d_occ=-1.0)
    with pytest.raises(ValueError, match="env_diffuse"):
        Rasterizer(scene, frames=2, ctx=gl_ctx, env_diffuse="sh4")
    with pytest.raises(ValueError, match="env_format"):
        Rasterizer(scene, frames=2, ctx=gl_ctx, env_format="logluv")


# ----------------------------------------------------------------------------- furnaces


def test_white_furnace_both_renderers(gl_ctx, tmp_path):
    """Radiance-1 environment, white Lambert sphere: 1 within 1 % in both renderers."""
    scene = sphere_scene({"base_color": [1.0, 1.0, 1.0], "roughness": 1.0}, {"constant": [1.0, 1.0, 1.0]})
    inside = disc_mask(scene, 0.15)  # every pixel fully on the sphere
    ours = render_progressive(scene, frames=16, ctx=gl_ctx, materials="diffuse", d_occ=0.0, **SMALL).image
    assert np.abs(ours[inside] - 1.0).max() < 0.01
    np.testing.assert_allclose(ours[0, 0], 1.0, rtol=1e-6)  # the background is the environment
    # With the default occlusion distance, only the silhouette sees (false) screen-space occlusion.
    occ = render_progressive(scene, frames=16, ctx=gl_ctx, materials="diffuse", **SMALL).image
    assert np.abs(occ[disc_mask(scene, 0.5)] - 1.0).max() < 0.01
    r = ReferenceRenderer(scene, materials="diffuse", cache_dir=tmp_path, progress=False)
    stack = r.independent_passes(8, 32).astype(np.float64)[..., 0]
    mean = stack.mean(0)
    # One standard error for all pixels (pooled: the furnace's noise is alike everywhere); a per-pixel
    # estimate from 8 passes has heavy (t, 7 dof) tails.
    se = np.sqrt(np.mean(stack.var(0, ddof=1)[inside]) / len(stack))
    z = (mean[inside] - 1.0) / se
    assert abs(mean[inside].mean() - 1.0) < 0.01
    assert np.abs(z).max() < 5, "every pixel is 1 up to its Monte Carlo noise"
    print(f"furnace: rasterizer max |1 - L| {np.abs(ours[inside] - 1).max():.5f}, "
          f"with occlusion (n.v > 0.5) {np.abs(occ[disc_mask(scene, 0.5)] - 1).max():.5f}; "
          f"Mitsuba mean {mean[inside].mean():.5f}, max |z| {np.abs(z).max():.2f}")


def test_shared_brdf_sphere_in_a_uniform_environment(gl_ctx):
    """Split sum + LUT reproduce the shared BRDF's directional albedo (the split is exact for a constant)."""
    rough, base = 0.4, 0.9
    scene = sphere_scene({"base_color": [base] * 3, "roughness": rough}, {"constant": [1.0, 1.0, 1.0]})
    img = render_progressive(scene, frames=1, ctx=gl_ctx, d_occ=0.0, **SMALL).image[..., 0]
    cam = scene.camera
    o = np.asarray(cam.position, dtype=float)
    errs = []
    for j in range(8, 40, 4):
        for i in range(8, 40, 4):
            d = cam.ray_directions(np.array(i + 0.5), np.array(j + 0.5))
            b = o @ d
            disc = b * b - (o @ o - 1)
            if disc < 0.05:
                continue
            hit = o + (-b - np.sqrt(disc)) * d
            exact = float(directional_albedo(rough, float(-(d @ hit)), [base] * 3, 0.0, 4096)[0])
            errs.append(abs(img[j, i] - exact) / exact)
    print(f"shared-BRDF furnace: {len(errs)} pixels, max relative error {max(errs):.4f}")
    assert len(errs) > 30 and max(errs) < 0.02


# ----------------------------------------------------------------------------- against Mitsuba


@pytest.mark.parametrize("rotation", [0.0, 90.0])
def test_mirror_sphere_matches_the_reference(gl_ctx, tmp_path, rotation):
    scene = sphere_scene({"base_color": [1.0, 1.0, 1.0], "metallic": 1.0, "roughness": 0.0},
                         {"procedural": "axes", "width": 256, "rotation": rotation}, size=(64, 48))
    ref = ReferenceRenderer(scene, cache_dir=tmp_path, progress=False).render(256).image
    ours = render_progressive(scene, frames=32, ctx=gl_ctx, d_occ=0.0, ibl_size=64, ibl_samples=64).image
    f, _, _ = flip(ref, ours)
    wrong, _, _ = flip(ref, ours[:, ::-1])
    print(f"mirror sphere, rotation {rotation:g}: LDR-FLIP {f:.4f} (mirrored image: {wrong:.4f})")
    assert f < 0.03
    assert wrong > 3 * f


def corner_scene(height: float = 0.5):
    """A glossy metal floor meeting a low wall: a concave corner under a sunless sky."""
    return parse_scene({
        "camera": {"position": [0.0, 1.6, 1.4], "target": [0, 0.0, -0.7], "fov": 45, "resolution": [64, 48]},
        "materials": {"m": {"base_color": [0.9, 0.9, 0.9], "roughness": 0.3, "metallic": 1.0}},
        "meshes": [{"shape": "quad", "size": [4, 3], "material": "m", "translate": [0, 0, 0.5]},
                   {"shape": "quad", "size": [4, height], "material": "m", "rotate": [90, 0, 0],
                    "translate": [0, height / 2, -1]}],
        "environment": {"procedural": "sky", "sun_radiance": 0.0, "width": 128},
        "render": {"max_depth": 2},
    }, ROOT / "tests" / "corner.toml")


def corner_masks(scene, height: float = 0.5):
    """Floor pixels within 0.25 of the wall (the corner) and farther than 0.9 (open floor)."""
    cam = scene.camera
    jj, ii = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.ray_directions(ii + 0.5, jj + 0.5)
    o = np.asarray(cam.position, dtype=float)
    t_floor = -o[1] / d[..., 1]
    t_wall = (-1 - o[2]) / d[..., 2]
    on_wall = (t_wall > 0) & (t_wall < t_floor) & ((o + t_wall[..., None] * d)[..., 1] < height)
    hit = o + t_floor[..., None] * d
    floor = ~on_wall & (t_floor > 0) & (np.abs(hit[..., 0]) < 1.5)
    gap = hit[..., 2] + 1.0
    return floor & (gap < 0.25), floor & (gap > 0.9)


def test_specular_occlusion_darkens_the_corner_like_the_reference(gl_ctx, tmp_path):
    scene = corner_scene()
    corner, open_floor = corner_masks(scene)
    assert corner.sum() > 300 and open_floor.sum() > 300
    ref = ReferenceRenderer(scene, cache_dir=tmp_path, progress=False).render(256).image.mean(-1)
    # The premise: the reference's floor is much darker near the wall (it reflects the unlit wall).
    assert ref[corner].mean() < 0.3 * ref[open_floor].mean()
    rows = {}
    for d_occ in (0.0, 0.1, 0.25, 0.5, 1.0):
        img = render_progressive(scene, frames=64, ctx=gl_ctx, d_occ=d_occ, ibl_size=32, ibl_samples=64).image
        lum = img.mean(-1)
        rows[d_occ] = (lum[corner].mean(), lum[open_floor].mean(), np.abs(lum - ref)[corner].mean(),
                       np.abs(lum - ref)[open_floor].mean())
    print(f"concave corner, reference: corner {ref[corner].mean():.4f}, open floor {ref[open_floor].mean():.4f}")
    for d_occ, (c, o, ec, eo) in rows.items():
        print(f"  d_occ {d_occ:4.2f}: corner {c:.4f} open {o:.4f} | mean |error| corner {ec:.4f} open {eo:.4f}")
    none = rows[0.0]
    assert none[0] > 1.5 * ref[corner].mean(), "without occlusion the corner is too bright"
    for d_occ in (0.1, 0.25, 0.5):
        c, o, ec, eo = rows[d_occ]
        assert c < 0.9 * none[0], d_occ  # darker in the corner, as in the reference ...
        assert ec < 0.8 * none[2], d_occ  # ... and closer to it there
        assert abs(o - none[1]) < 0.05 * none[1], d_occ  # while the open floor keeps its light
    assert rows[0.5][2] < 0.5 * none[2]


# ----------------------------------------------------------------------------- options


def test_environment_formats_and_diffuse_options(gl_ctx):
    """Octahedral and SH9 stay close to float/cube on a smooth map; RGBM clips a 3.6e4 sun."""
    smooth = {"procedural": "sky", "width": 128, "sun_radiance": 0.0, "glow": 2.0}
    metal = sphere_scene({"base_color": [0.9, 0.9, 0.9], "metallic": 1.0, "roughness": 0.35}, smooth,
                         name="metal")
    mask = disc_mask(metal, 0.2)
    opts = {"frames": 1, "ctx": gl_ctx, "d_occ": 0.0, "ibl_size": 32, "ibl_samples": 64}
    base = render_progressive(metal, **opts).image
    for env_format, limit in (("octahedral", 0.02), ("rgbm", 0.03)):
        img = render_progressive(metal, env_format=env_format, **opts).image
        err = np.abs(img - base)[mask].mean() / base[mask].mean()
        print(f"{env_format} vs float, smooth sky: {err:.4f}")
        assert 0 < err < limit, env_format
    matte = sphere_scene({"base_color": [0.8, 0.8, 0.8], "roughness": 1.0}, smooth, name="matte")
    cube = render_progressive(matte, **opts).image
    sh9 = render_progressive(matte, env_diffuse="sh9", **opts).image
    err = np.abs(sh9 - cube)[mask].mean() / cube[mask].mean()
    print(f"SH9 vs cube irradiance, smooth sky: {err:.4f}")
    assert 0 < err < 0.03
    # With the sun, RGBM (maximum 49) loses the highlight's energy.
    sunny = sphere_scene({"base_color": [0.9, 0.9, 0.9], "metallic": 1.0, "roughness": 0.1},
                         {"procedural": "sky", "width": 512, "sun_size": 3.0, "sun_elevation": 10.0,
                          "sun_azimuth": 170.0}, name="sunny")
    f = render_progressive(sunny, **opts).image
    rgbm = render_progressive(sunny, env_format="rgbm", **opts).image
    print(f"sun highlight: float peak {f.max():.1f}, RGBM peak {rgbm.max():.1f}")
    assert f.max() > 100 and rgbm.max() < 0.5 * f.max()


def test_intensity_and_rotation_reach_the_rasterizer(gl_ctx):
    env = {"procedural": "axes", "width": 64}
    scene = sphere_scene({"base_color": [0.7, 0.7, 0.7], "roughness": 0.5}, env, name="axes1")
    brighter = sphere_scene({"base_color": [0.7, 0.7, 0.7], "roughness": 0.5}, {**env, "intensity": 2.0},
                            name="axes2")
    turned = sphere_scene({"base_color": [0.7, 0.7, 0.7], "roughness": 0.5}, {**env, "rotation": 180.0},
                          name="axes3")
    opts = {"frames": 2, "ctx": gl_ctx, "d_occ": 0.0, **SMALL}
    a = render_progressive(scene, **opts).image
    np.testing.assert_allclose(render_progressive(brighter, **opts).image, 2 * a, rtol=1e-5, atol=1e-6)
    t = render_progressive(turned, **opts).image
    # Turned by 180°, the camera (on +Z) sees the map's -Z side: yellow (R = G > B) instead of blue.
    assert a[20:28, 20:28, 2].mean() > a[20:28, 20:28, 0].mean()
    assert t[20:28, 20:28, 0].mean() > t[20:28, 20:28, 2].mean()


def test_every_checkpoint_is_non_negative_and_converges(gl_ctx):
    """The visible-light means never go below zero, and later checkpoints approach the final image."""
    scene = corner_scene()
    r = render_progressive(scene, frames=32, ctx=gl_ctx, d_occ=0.5, ibl_size=16, ibl_samples=32,
                           checkpoints=(1, 2, 3, 4, 8, 16, 32))
    for c in r.checkpoints:
        assert c.image.min() >= 0, (c.frame, c.image.min())
    err = [np.abs(c.image - r.image).mean() for c in r.checkpoints[1:-1]]
    assert err[-1] < 0.5 * err[0], err
