"""progressive:envshadows: environment light that converges to its shadows (closed form), its sampler of
directions, and the variant in the registry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.progressive.environment.env_shadows import DIRECTIONS_PER_FRAME, luminance_sampler
from compare.progressive.rasterizer import render_progressive
from compare.scene.loader import load_scene
from tests.helpers import ROOT, ground_points

SPHERE_OVER_PLANE = """
    name = "A black sphere over a white plane in a uniform sky"
    [camera]
    position = [0.0, 1.5, 0.0]
    target = [0.0, 0.0, 0.0]
    up = [0.0, 0.0, -1.0]
    fov = 70.0
    resolution = [32, 32]

    [render]
    max_depth = 2

    [materials.white]
    base_color = [0.8, 0.8, 0.8]
    roughness = 1.0

    [materials.black]
    base_color = [0.0, 0.0, 0.0]
    roughness = 1.0

    [[meshes]]
    shape = "quad"
    size = [40.0, 40.0]
    material = "white"

    [[meshes]]
    shape = "sphere"
    radius = 1.0
    segments = 128
    rings = 64
    material = "black"
    translate = [0.0, 3.0, 0.0]

    [environment]
    constant = [1.0, 1.0, 1.0]
    """


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_an_off_screen_sphere_shadows_the_sky_as_the_closed_form_says(gl_ctx, make_scene, seed):
    """The camera between the plane and the sphere: screen-space occlusion cannot see the sphere (the
    plane stays 1/(1 − sin²α cos β) too bright); the environment's shadow maps give the cosine-weighted
    cap it hides, 1 − sin²α cos β, within 3 % per pixel at 128 frames (the paper's count) with the
    default directions, for every seed (each seed shifts the whole point set)."""
    scene = load_scene(make_scene(SPHERE_OVER_PLANE))
    p, hit = ground_points(scene)
    d = np.linalg.norm(p - np.array([0.0, 3.0, 0.0]), axis=-1)
    want = 0.8 * (1.0 - (1.0 / d) ** 2 * (3.0 / d))
    shadows = render_progressive(scene, frames=128, materials="diffuse", env_occlusion="shadows", ctx=gl_ctx,
                                 seed=seed)
    ratio = shadows.image[..., 0][hit] / want[hit]
    lo, hi = np.percentile(ratio, [5, 95])
    assert 0.985 <= lo and hi <= 1.015, (lo, hi)  # measured 0.990–1.013 over seeds 0–5
    assert np.abs(ratio - 1.0).max() < 0.03, (ratio.min(), ratio.max())  # measured 1.6–2.2 % at worst
    assert shadows.metadata["occlusion"] == "environment shadow maps"
    assert shadows.metadata["env_samples"] == DIRECTIONS_PER_FRAME * 127
    np.testing.assert_allclose(shadows.layers["direct_env"], shadows.image, rtol=1e-5, atol=1e-6)
    if seed == 0:
        screen = render_progressive(scene, frames=8, materials="diffuse", ctx=gl_ctx)
        assert (screen.image[..., 0][hit] / want[hit]).min() > 1.08  # what the screen-space samples miss


def test_a_batch_of_directions_adds_what_its_directions_add_one_by_one(gl_ctx, make_scene, monkeypatch):
    """The directions of one pass (tiles of one atlas) give the image that one pass per direction gives,
    up to float rounding; and one seed gives one image."""
    from compare.progressive.environment import env_shadows

    scene = load_scene(make_scene(SPHERE_OVER_PLANE))
    opts = dict(frames=4, env_samples=15, env_occlusion="shadows", ctx=gl_ctx)  # 5 per frame: a partial batch
    batched = render_progressive(scene, **opts).image
    np.testing.assert_array_equal(render_progressive(scene, **opts).image, batched)
    monkeypatch.setattr(env_shadows, "BATCH", 1)
    single = render_progressive(scene, **opts).image
    np.testing.assert_allclose(batched, single, rtol=1e-5, atol=1e-6)
    assert np.abs(render_progressive(scene, seed=1, **opts).image - batched).max() > 1e-3


def test_sobol_points_are_nets_for_every_seed():
    """Any 2^k points of :func:`sobol2` from index 0 put one point into each of the 2^k elementary boxes of
    every shape (here 16 × 16 and 64 × 4 for 256 points), with the seed's digital shift too; points are
    picked by index, so a sample's direction does not depend on which others a render plans."""
    from compare.progressive.schedule.sampling import sobol2

    for seed in (0, 1, 7):
        p = sobol2(range(256), seed)
        assert ((0.0 <= p) & (p < 1.0)).all()
        for nx, ny in ((16, 16), (64, 4), (2, 128)):
            boxes = np.floor(p * [nx, ny]).astype(int)
            assert len({tuple(b) for b in boxes}) == 256, (seed, nx, ny)
        np.testing.assert_array_equal(sobol2([5, 200], seed), p[[5, 200]])
    assert np.abs(sobol2(range(8), 1) - sobol2(range(8), 0)).max() > 0.01


def test_directions_follow_the_maps_luminance():
    """One bright patch holding 3/4 of the map's light (by luminance × solid angle) draws about 3/4 of
    the directions, each inside its cells; a uniform map draws uniformly over the sphere."""
    h, w = 32, 64
    img = np.full((h, w, 3), 0.1, dtype=np.float32)
    patch = (slice(10, 14), slice(20, 28))
    cos_edges = np.cos(np.arange(h + 1) / h * np.pi)
    solid = np.repeat((cos_edges[:-1] - cos_edges[1:])[:, None], w, axis=1)
    others = (solid.sum() - solid[patch].sum()) * 0.1
    img[patch] = 3.0 * others / solid[patch].sum()  # the patch: three times the rest
    u = np.random.default_rng(0).random((20000, 2))
    d = luminance_sampler(img)(u)
    from compare.scene.equirect import direction_to_uv

    uv = direction_to_uv(d)
    inside = ((uv[:, 1] * h >= 10) & (uv[:, 1] * h < 14) & (uv[:, 0] * w >= 20) & (uv[:, 0] * w < 28))
    assert inside.mean() == pytest.approx(0.75, abs=0.01)
    flat = luminance_sampler(np.ones((8, 16, 3), dtype=np.float32))(u)
    assert np.abs(flat.mean(axis=0)).max() < 0.02  # uniform on the sphere: no pole crowding
    assert flat[:, 1].var() == pytest.approx(1.0 / 3.0, rel=0.03)


def test_envshadows_is_a_variant_of_the_registry():
    from compare.renderers.registry import Registry

    r = Registry().get("progressive:envshadows")
    assert r.options == {"env_occlusion": "shadows"} and "environment shadow maps" in r.label


def test_a_sun_sky_casts_its_shadows_as_the_reference_does(gl_ctx):
    """scenes/stress/sun_and_tiny_light.toml (a sun and sky map) at 64×48, 64 frames: the direct environment
    layer's relMSE against the reference's (1024 spp) is about a hundredth of the screen-space occlusion's.

    Measured at 64×48 (seed 0; in brackets seeds 0–3 of each renderer): shadow maps 0.0079 (0.0050–0.0079),
    screen space 0.79 (0.60–1.10), their ratio 0.010 (0.0054–0.010); with four Sobol directions per frame
    (the reference's seed 0, the shadow maps' seeds 0–3) 0.0081 (0.0054–0.0081), a ratio of 0.010
    (0.0068–0.010). The reference has 1024 spp: at 64 its
    own noise (relMSE 0.025 against 1024 spp) is most of what the shadow maps' error then measures
    (0.036–0.17, a ratio of 0.04–0.13)."""
    from compare.metrics.images import relmse
    from compare.mitsuba.reference import ReferenceRenderer

    scene = load_scene(ROOT / "scenes" / "stress" / "sun_and_tiny_light.toml")
    scene = scene.with_resolution(64, 48)
    _, truth, _ = ReferenceRenderer(scene, cache_dir=False, progress=False).render_layers(1024)
    errors = {}
    for name, opts in (("screen", {}), ("shadows", {"env_occlusion": "shadows"})):
        layers = render_progressive(scene, frames=64, ctx=gl_ctx, **opts).layers
        errors[name] = relmse(truth["direct_env"], layers["direct_env"])
    assert errors["shadows"] <= 0.02, errors  # measured 0.0050–0.0081
    assert errors["shadows"] <= 0.025 * errors["screen"], errors  # measured 0.0054–0.010


def test_a_sun_only_map_casts_the_box_shadow_where_and_as_soft_as_the_reference(tmp_path, gl_ctx):
    """A black map with one sun (a disc of 3° radius, 40° above the horizon) over a box on a plane: the
    shadow's area (pixels under half the lit plane's light) and its penumbra (pixels between 10 % and 90 %)
    as in the reference's direct environment layer, within a tenth of the reference's own counts."""
    from compare.image.exr import write_exr
    from compare.mitsuba.reference import ReferenceRenderer
    from compare.scene.equirect import equirect_directions

    h, w = 256, 512
    d = equirect_directions(w, h)
    sun = np.array([0.0, np.sin(np.radians(40.0)), -np.cos(np.radians(40.0))])
    disc = (d @ sun) > np.cos(np.radians(3.0))
    img = np.zeros((h, w, 3), dtype=np.float32)
    img[disc] = 50.0
    write_exr(tmp_path / "sun.exr", img)
    (tmp_path / "box.toml").write_text("""
        [camera]
        position = [0.0, 3.0, 4.0]
        target = [0.0, 0.0, 0.0]
        fov = 45.0
        resolution = [64, 48]

        [render]
        max_depth = 2

        [materials.white]
        base_color = [0.8, 0.8, 0.8]
        roughness = 1.0

        [[meshes]]
        shape = "quad"
        size = [12.0, 12.0]
        material = "white"

        [[meshes]]
        shape = "box"
        size = [1.0, 1.0, 1.0]
        material = "white"
        translate = [0.0, 0.5, 0.0]

        [environment]
        file = "sun.exr"
        """.replace("\n        ", "\n"))
    scene = load_scene(tmp_path / "box.toml")
    _, truth, _ = ReferenceRenderer(scene, cache_dir=False, progress=False).render_layers(256)
    got = render_progressive(scene, frames=64, ctx=gl_ctx, env_occlusion="shadows").layers["direct_env"]
    p, hit = ground_points(scene)
    on_plane = hit & (np.abs(p[..., 0]) < 5.5) & (np.abs(p[..., 2]) < 5.5)

    def counts(img):
        y = img[..., 1][on_plane]
        lit = np.percentile(y, 90)
        return (y < 0.5 * lit).sum(), ((y > 0.1 * lit) & (y < 0.9 * lit)).sum()

    (shadow_t, soft_t), (shadow_g, soft_g) = counts(truth["direct_env"]), counts(got)
    assert shadow_t > 100
    assert abs(shadow_g - shadow_t) <= 0.1 * shadow_t, (shadow_g, shadow_t)
    assert abs(soft_g - soft_t) <= max(0.1 * shadow_t, 5), (soft_g, soft_t)


def test_environment_shadows_only_take_light_away(gl_ctx, make_scene):
    """Energy bounds: with the sphere, the plane's direct environment light is nowhere above the same plane's
    without it (the unshadowed split sum: each ratio is at most 1), never negative, and below it by about the
    cap the sphere hides (the closed form's 1 − sin²α cos β, within 3 % on the mean)."""
    import dataclasses

    scene = load_scene(make_scene(SPHERE_OVER_PLANE))
    bare = dataclasses.replace(scene, meshes=scene.meshes[:1])
    opts = dict(frames=16, env_samples=256, shadow_size=128, env_occlusion="shadows", ctx=gl_ctx)
    shadowed = render_progressive(scene, **opts).layers["direct_env"][..., 0]
    unshadowed = render_progressive(bare, **opts).layers["direct_env"][..., 0]
    p, hit = ground_points(scene)
    assert np.isfinite(shadowed).all() and shadowed.min() >= 0.0
    assert np.all(shadowed[hit] <= unshadowed[hit] * (1.0 + 1e-4) + 1e-6)
    d = np.linalg.norm(p - np.array([0.0, 3.0, 0.0]), axis=-1)
    hidden = (1.0 / d) ** 2 * (3.0 / d)
    assert (shadowed[hit] / unshadowed[hit]).mean() == pytest.approx((1.0 - hidden[hit]).mean(), rel=0.03)


# -- progressive:sun (compare/progressive/environment/sun.py) -------------------------------------------------

def _sky_with_sun(direction, radius_deg: float, radiance, sky: float = 0.5, size=(256, 512)):
    from compare.scene.equirect import uv_to_direction

    h, w = size
    u, v = np.meshgrid((np.arange(w) + 0.5) / w, (np.arange(h) + 0.5) / h)
    dirs = np.asarray(uv_to_direction(u.ravel(), v.ravel())).reshape(h, w, 3)
    disc = dirs @ np.asarray(direction) >= math.cos(math.radians(radius_deg))
    image = np.full((h, w, 3), sky, dtype=np.float32)
    image[disc] = radiance
    return image, disc


def test_the_sun_is_taken_out_of_the_map_with_its_irradiance_and_direction():
    """A uniform sky of 0.5 with a disc of 2° radius and radiance (4000, 3000, 2000): the sun points at the
    disc's centre within 0.3°, its irradiance is (L − 0.5) times the disc's solid angle within 3 % (the
    texels that cover it: exactly theirs), the rest of the map is the sky; a map without a compact bright region has none."""
    from compare.progressive.environment.sun import extract_sun

    d = np.array([0.3, 0.8, -0.52])
    d /= np.linalg.norm(d)
    image, disc = _sky_with_sun(d, 2.0, (4000.0, 3000.0, 2000.0))
    direction, irradiance, rest, share = extract_sun(image)
    assert math.degrees(math.acos(min(1.0, float(direction @ d)))) < 0.3
    h, w = disc.shape
    cos_edges = np.cos(np.arange(h + 1) / h * np.pi)
    texel = np.broadcast_to(((cos_edges[:-1] - cos_edges[1:]) * 2.0 * np.pi / w)[:, None], disc.shape)
    omega = texel[disc].sum()  # the disc as the map holds it: its texels' solid angles
    assert omega == pytest.approx(2.0 * math.pi * (1.0 - math.cos(math.radians(2.0))), rel=0.05)
    np.testing.assert_allclose(irradiance, (np.array([4000.0, 3000.0, 2000.0]) - 0.5) * omega, rtol=1e-5)
    np.testing.assert_allclose(rest, 0.5, rtol=1e-6)
    lum = np.array([0.2126, 0.7152, 0.0722])
    total = float(((image.astype(np.float64) @ lum) * texel).sum())
    assert share == pytest.approx((np.array([4000.0, 3000.0, 2000.0]) - 0.5) @ lum * omega / total, rel=1e-5)
    assert extract_sun(np.full((64, 128, 3), 0.5, dtype=np.float32)) is None
    broad, _ = _sky_with_sun(d, 40.0, (2.0, 2.0, 2.0))  # a bright half of the sky is no sun
    assert extract_sun(broad) is None


def test_progressive_sun_draws_the_suns_shadows(gl_ctx):
    """scenes/stress/sun_and_tiny_light.toml at 64×48, 32 frames: with the sun as a directional light the full
    image's relMSE against the reference (1024 spp) is at most half the default's, its light is reported in
    the direct environment layer (the reference's), and the render says what it took out.

    Measured at 64×48 (seed 0; in brackets seeds 0–3 of each renderer): the sun 0.0122 (0.0042–0.0122), the
    default 0.032 (0.028–0.049), their ratio 0.39 (0.11–0.43). Against a reference of 128 spp (its own noise:
    relMSE 0.015–0.026 between two seeds) the ratio was 0.37 (0.36–0.84)."""
    from compare.metrics.images import relmse
    from compare.mitsuba.reference import ReferenceRenderer

    scene = load_scene(ROOT / "scenes" / "stress" / "sun_and_tiny_light.toml")
    scene = scene.with_resolution(64, 48)
    truth = ReferenceRenderer(scene, cache_dir=False, progress=False).render(1024).image
    default = render_progressive(scene, frames=32, ctx=gl_ctx)
    sun = render_progressive(scene, frames=32, ctx=gl_ctx, sun=True)
    errors = relmse(truth, sun.image), relmse(truth, default.image)
    assert errors[0] <= 0.02, errors  # measured 0.0042–0.0122; the default's 0.028–0.049
    assert errors[0] <= 0.5 * errors[1], errors  # measured 0.11–0.43
    assert "direct_punctual" not in sun.layers and "direct_env" in sun.layers
    np.testing.assert_allclose(sum(sun.layers.values()), sun.image, rtol=1e-4, atol=1e-5)
    assert any("sun: a directional light" in str(v) for v in sun.metadata.values())
