"""The reference against exact answers: Lambert's polygon formula and the BRDF's own albedo."""

from __future__ import annotations


import numpy as np

from compare.metrics.closed_form import polygon_irradiance
from compare.mitsuba.reference import ReferenceRenderer
from compare.scene.loader import parse_scene
from tests.helpers import ROOT

ALBEDO = np.array([0.8, 0.6, 0.4])
RADIANCE = np.array([4.0, 5.0, 6.0])


def plane_scene():
    return parse_scene({
        "camera": {"position": [0.3, 1.6, 2.2], "target": [0, 0, 0], "fov": 45, "resolution": [32, 24]},
        "materials": {"m": {"base_color": ALBEDO.tolist(), "roughness": 1.0}},
        "meshes": [{"shape": "quad", "size": [6, 6], "material": "m"}],
        "lights": [{"center": [0.2, 0.8, -0.1], "size": [0.6, 0.35], "normal": [0.3, -1, 0.1],
                    "tangent": [1, 0, 0], "radiance": RADIANCE.tolist()}],
        "render": {"max_depth": 2},
    }, ROOT / "tests" / "plane.toml")


def pixel_average(scene, fn, i, j, sub=12):
    """Box-filtered pixel value: the mean of fn over a sub×sub grid inside pixel (i, j).

    None where part of the pixel misses the plane or sees the light's back instead.
    """
    o = (np.arange(sub) + 0.5) / sub
    x, y = np.meshgrid(i + o, j + o)
    d = scene.camera.ray_directions(x, y)
    origin = np.asarray(scene.camera.position)
    t = -origin[1] / d[..., 1]  # hit the plane y = 0
    hit = origin + t[..., None] * d
    if np.any(t <= 0) or np.abs(hit[..., [0, 2]]).max() > 2.9:
        return None
    light = scene.lights[0]
    n = np.asarray(light.normal)
    tl = ((np.asarray(light.center) - origin) @ n) / (d @ n)
    local = origin + tl[..., None] * d - np.asarray(light.center)
    inside = ((np.abs(local @ np.asarray(light.tangent)) < light.size[0] / 2 + 1e-3)
              & (np.abs(local @ light.bitangent) < light.size[1] / 2 + 1e-3) & (tl > 0) & (tl < t))
    behind = (hit - np.asarray(light.center)) @ n <= 0  # the one-sided emitter's dark side
    if inside.any() or behind.any():
        return None
    return fn(hit).reshape(-1, 3).mean(0)


def test_lambert_plane_under_rectangle_light(tmp_path):
    """Pixel radiance = albedo/π · E(x), E from Lambert's polygon formula, within 3 standard errors."""
    scene = plane_scene()
    light = scene.lights[0]
    poly = light.corners()

    def radiance(points):
        e = polygon_irradiance(points, np.broadcast_to([0.0, 1.0, 0.0], points.shape), poly, RADIANCE)
        return ALBEDO / np.pi * e

    r = ReferenceRenderer(scene, materials="diffuse", cache_dir=tmp_path, progress=False)
    stack = r.independent_passes(16, 16).astype(np.float64)
    mean, se = stack.mean(0), stack.std(0, ddof=1) / np.sqrt(len(stack))
    pixels = [(i, j) for j in range(1, 24, 3) for i in range(1, 32, 4)]
    zs = []
    for i, j in pixels:
        exact = pixel_average(scene, radiance, i, j)
        if exact is None:
            continue
        z = (mean[j, i] - exact) / se[j, i]
        zs.append(z)
        rel = np.abs(mean[j, i] / exact - 1)
        assert np.all(np.abs(z) < 3), f"pixel {(i, j)}: mean {mean[j, i]}, exact {exact}, z {z}, rel {rel}"
    zs = np.array(zs)
    assert len(zs) >= 20, "too few usable pixels: the test scene is misframed"
    print(f"Lambert plane: {len(zs)} pixels x 3 channels, max |z| {np.abs(zs).max():.2f}, "
          f"mean z {zs.mean():+.3f}, rms z {np.sqrt((zs ** 2).mean()):.2f}")
    # Unbiased: the z-scores average to about zero (their mean has standard error 1/sqrt(n)).
    assert abs(zs.mean()) < 3 / np.sqrt(zs.size)


def test_shared_brdf_sphere_in_uniform_environment(tmp_path):
    """A convex sphere in a unit environment shows its directional albedo (single bounce)."""
    from compare.brdf import directional_albedo

    size, rough, base = 24, 0.4, 0.9
    scene = parse_scene({
        "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 32, "resolution": [size, size]},
        "materials": {"m": {"base_color": [base] * 3, "roughness": rough, "metallic": 0.0}},
        "meshes": [{"shape": "sphere", "radius": 1.0, "material": "m", "segments": 128, "rings": 64}],
        "environment": {"constant": [1.0, 1.0, 1.0]},
        "render": {"max_depth": 2},
    }, ROOT / "tests" / "sphere.toml")
    r = ReferenceRenderer(scene, materials="shared", cache_dir=tmp_path, progress=False)
    stack = r.independent_passes(8, 32).astype(np.float64)[..., 0]
    mean, se = stack.mean(0), stack.std(0, ddof=1) / np.sqrt(len(stack))
    origin = np.array(scene.camera.position)
    zs = []
    for j in range(6, 18, 3):
        for i in range(6, 18, 3):
            d = scene.camera.ray_directions(np.array(i + 0.5), np.array(j + 0.5))
            b = origin @ d
            disc = b * b - (origin @ origin - 1)
            if disc < 0.05:
                continue  # near the silhouette the pixel mixes in background
            hit = origin + (-b - np.sqrt(disc)) * d
            cos_v = float(-(d @ hit))
            exact = float(np.asarray(directional_albedo(rough, cos_v, [base] * 3, 0.0, 4096)).ravel()[0])
            z = (mean[j, i] - exact) / se[j, i]
            zs.append(z)
            # The pixel footprint spans a range of view angles: allow 1% for that on top of the noise.
            assert abs(mean[j, i] - exact) < 3 * se[j, i] + 0.01 * exact, (i, j, mean[j, i], exact)
    print(f"shared-BRDF sphere: {len(zs)} pixels, max |z| {np.abs(zs).max():.2f}")
    assert len(zs) >= 8
