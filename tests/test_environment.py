"""Environment maps (compare.scene.environments): the mapping, Mitsuba's orientation, loaders, scene syntax.

The decisive tests are ``test_sample_equirect_is_mitsubas_envmap`` (the numpy
lookup that feeds the IBL preprocessing equals Mitsuba's ``envmap.eval`` for
random directions and rotations) and ``test_background_orientation_both_renderers``
(a marked map seen along ±X, ±Y, ±Z through both renderers).
"""

from __future__ import annotations

import math
import os
import textwrap
from pathlib import Path

import numpy as np
import pytest

from compare.scene.procedural_env import PROCEDURAL, procedural_map, validate_procedural
from compare.scene.environments import blender_studio_lights, environment_image, environment_path
from compare.scene.equirect import direction_to_uv, rotation_matrix, sample_equirect, uv_to_direction, world_to_env
from compare.image.hdr import read_hdr, write_hdr
from compare.util.errors import ImageError, SceneError
from compare.image.exr import write_exr
from compare.scene.loader import load_scene, parse_scene

AXES = {"+X": (1, 0, 0), "-X": (-1, 0, 0), "+Y": (0, 1, 0), "-Y": (0, -1, 0), "+Z": (0, 0, 1), "-Z": (0, 0, -1)}


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    """Procedural maps and IBL data go to a per-session temporary cache."""
    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path_factory.getbasetemp() / "cache"))


def mitsuba():
    from compare.mitsuba.backend import load_mitsuba

    return load_mitsuba(None)


# ----------------------------------------------------------------------------- the mapping


def test_axes_map_to_the_documented_uv():
    uv = direction_to_uv(np.array([AXES[k] for k in ("-Z", "+X", "+Z", "-X", "+Y", "-Y")], dtype=float))
    np.testing.assert_allclose(uv[:4, 0], [0.0, 0.25, 0.5, 0.75], atol=1e-12)
    np.testing.assert_allclose(uv[:4, 1], 0.5, atol=1e-12)
    np.testing.assert_allclose(uv[4:, 1], [0.0, 1.0], atol=1e-12)


def test_uv_direction_round_trip():
    rng = np.random.default_rng(0)
    d = rng.normal(size=(1000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    uv = direction_to_uv(d)
    assert uv.min() >= 0 and uv.max() <= 1
    np.testing.assert_allclose(uv_to_direction(uv[:, 0], uv[:, 1]), d, atol=1e-12)


def test_rotation_is_mitsubas_to_world():
    mi = mitsuba()
    for angle in (0.0, 30.0, -75.0, 180.0):
        m = np.array(mi.ScalarTransform4f().rotate(axis=[0, 1, 0], angle=angle).matrix)[:3, :3]
        np.testing.assert_allclose(rotation_matrix(angle), m, atol=1e-6)
    d = np.array([1.0, 0.0, 0.0])
    # A map rotated by +90 degrees shows at world +X what it holds at map -Z... check R^-1 explicitly.
    np.testing.assert_allclose(world_to_env(d, 90.0), rotation_matrix(90.0).T @ d, atol=1e-12)


def test_sample_equirect_is_mitsubas_envmap():
    """The numpy lookup equals Mitsuba's envmap.eval (bilinear, texel positions, wrap, rotation)."""
    mi = mitsuba()
    img = procedural_map("axes", {"width": 32})
    img[3, 5] = [9.0, 0.0, 2.0]  # a single bright texel makes any half-texel shift visible
    rng = np.random.default_rng(1)
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for rotation in (0.0, 37.0):
        em = mi.load_dict({"type": "envmap", "bitmap": mi.Bitmap(img),
                           "to_world": mi.ScalarTransform4f().rotate(axis=[0, 1, 0], angle=rotation)})
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(-d[:, 0], -d[:, 1], -d[:, 2])  # eval looks along -wi
        theirs = np.array(em.eval(si)).T
        ours = sample_equirect(img, d, rotation)
        assert np.abs(theirs - ours).max() < 1e-4 * img.max(), rotation
        # A mirrored map would not match: the test can fail.
        assert np.abs(sample_equirect(img[:, ::-1], d, rotation) - theirs).max() > 0.5


# ----------------------------------------------------------------------------- files


def test_hdr_round_trip_and_mitsuba_reads_the_same(tmp_path):
    mi = mitsuba()
    img = procedural_map("sky", {"width": 64})
    path = write_hdr(tmp_path / "sky.hdr", img)
    ours = read_hdr(path)
    theirs = np.array(mi.Bitmap(str(path)))
    np.testing.assert_array_equal(ours, theirs)
    big = img > 1e-3 * img.max()
    assert np.max(np.abs(ours - img)[big] / img[big]) < 1.0 / 64  # 8-bit mantissa of the largest channel
    assert ours.max() == pytest.approx(img.max(), rel=1 / 64), "the sun texel keeps its value: RGBE has the range"


def test_hdr_reads_run_length_encoded_scanlines(tmp_path):
    from compare.image.encodings import rgbe_encode

    img = procedural_map("studio", {"width": 32})
    enc = rgbe_encode(img)
    body = bytearray()
    for row in enc:
        body += bytes([2, 2, 0, 32])
        for c in range(4):
            line = row[:, c]
            x = 0
            while x < len(line):  # runs of equal bytes as runs, the rest literal (one byte each)
                run = 1
                while x + run < len(line) and line[x + run] == line[x] and run < 127:
                    run += 1
                if run > 2:
                    body += bytes([128 + run, line[x]])
                    x += run
                else:
                    body += bytes([1, line[x]])
                    x += 1
    path = tmp_path / "rle.hdr"
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16 +X 32\n" + bytes(body))
    np.testing.assert_array_equal(read_hdr(path), np.array(mitsuba().Bitmap(str(path))))


def test_hdr_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.hdr"
    bad.write_bytes(b"P6\n")
    with pytest.raises(ImageError, match="bad.hdr: not a Radiance"):
        read_hdr(bad)
    flipped = tmp_path / "flipped.hdr"
    flipped.write_bytes(b"#?RADIANCE\n\n+Y 2 +X 2\n" + bytes(16))
    with pytest.raises(ImageError, match="flipped.hdr: unsupported resolution line"):
        read_hdr(flipped)
    huge = tmp_path / "huge.hdr"  # a header claiming terabytes: refused before anything is allocated
    huge.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2000000000 +X 2000000000\n" + bytes(64))
    with pytest.raises(ImageError) as exc:
        read_hdr(huge)
    assert str(exc.value) == (f"{huge}: the header claims 2000000000×2000000000 pixels, more than the file's 64 "
                              "bytes of pixel data can hold (corrupt or truncated)")


# ----------------------------------------------------------------------------- procedural maps


def test_procedural_maps_are_deterministic_and_documented():
    for kind, (params, doc) in PROCEDURAL.items():
        assert doc and all(p.doc for p in params.values())
        a = procedural_map(kind, {"width": 64})
        b = procedural_map(kind, {"width": 64})
        assert a.shape == (32, 64, 3) and a.dtype == np.float32
        assert np.array_equal(a, b) and np.isfinite(a).all() and a.min() >= 0


def test_sky_sun_sits_where_asked_with_its_radiance():
    img = procedural_map("sky", {"width": 2048, "sun_azimuth": 90.0, "sun_elevation": 30.0, "sun_size": 2.0})
    j, i = np.unravel_index(np.argmax(img[..., 0]), img.shape[:2])
    d = uv_to_direction((i + 0.5) / 2048, j / 1023)
    sun = np.array([math.cos(math.radians(30)), math.sin(math.radians(30)), 0.0])
    assert math.degrees(math.acos(np.clip(d @ sun, -1, 1))) < 0.3
    assert img[..., 0].max() == pytest.approx(3.6e4, rel=0.01)  # a texel inside the disk (+ the dim sky)


def test_procedural_parameters_are_checked():
    assert validate_procedural("sky", {})["sun_radiance"] == 3.6e4
    with pytest.raises(ValueError, match="^sun_elevation: expected a value in"):
        validate_procedural("sky", {"sun_elevation": 120})
    with pytest.raises(ValueError, match="^zenith: expected three non-negative numbers"):
        validate_procedural("sky", {"zenith": [1, -1, 0]})
    with pytest.raises(ValueError, match="^key: unknown parameter"):
        validate_procedural("sky", {"key": 1})
    with pytest.raises(ValueError, match="^procedural: expected one of"):
        validate_procedural("moon", {})


# ----------------------------------------------------------------------------- scene syntax


def scene_text(env: str) -> str:
    return textwrap.dedent("""
        [camera]
        position = [0, 0, 3]
        target = [0, 0, 0]
        resolution = [32, 24]

        [materials.m]
        base_color = [0.5, 0.5, 0.5]

        [[meshes]]
        shape = "sphere"
        radius = 1.0
        material = "m"

        [environment]
        """) + textwrap.dedent(env)


def test_scene_procedural_environment(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(scene_text('procedural = "sky"\nsun_elevation = 20\nrotation = 45\nintensity = 2\n'))
    scene = load_scene(path)
    env = scene.environment
    assert env.procedural == "sky" and dict(env.parameters)["sun_elevation"] == 20.0
    assert dict(env.parameters)["sun_radiance"] == 3.6e4 and env.rotation == 45 and env.intensity == 2
    file = environment_path(env)
    assert file.suffix == ".exr" and file.is_file() and file in scene.referenced_files
    assert Path(os.environ["COMPARE_CACHE"]) in file.parents
    np.testing.assert_array_equal(environment_image(env), procedural_map("sky", dict(env.parameters)))
    # Another parameter is another map and another scene hash.
    path.write_text(scene_text('procedural = "sky"\nsun_elevation = 21\n'))
    other = load_scene(path)
    assert environment_path(other.environment) != file and other.hash != scene.hash


def test_scene_environment_errors_name_the_field(tmp_path):
    path = tmp_path / "s.toml"
    cases = {
        'procedural = "moon"': "environment.procedural: expected one of 'sky', 'studio', 'axes'",
        'procedural = "sky"\nsun_size = -1': "environment.sun_size: expected a value in",
        'procedural = "sky"\nkey = 3': "environment.key: unknown field",
        'procedural = "sky"\nconstant = 1': "environment: give exactly one of",
        'blender = 3': "environment.blender: expected a studio-light name",
    }
    for text, message in cases.items():
        path.write_text(scene_text(text))
        with pytest.raises(SceneError, match=f"s.toml: {message}"):
            load_scene(path)


def test_scene_blender_studio_light(tmp_path, monkeypatch):
    path = tmp_path / "s.toml"
    lights = blender_studio_lights()
    if not lights:
        path.write_text(scene_text('blender = "interior"'))
        with pytest.raises(SceneError, match="environment.blender: .*'blender' extra"):
            load_scene(path)
        pytest.skip("bpy is not installed: the error says how to get it")
    assert {"interior", "courtyard", "sunset"} <= set(lights)
    path.write_text(scene_text('blender = "interior"'))
    scene = load_scene(path)
    assert environment_path(scene.environment) == lights["interior"]
    assert environment_image(scene.environment).shape[1] == 2 * environment_image(scene.environment).shape[0]
    path.write_text(scene_text('blender = "nowhere"'))
    with pytest.raises(SceneError, match="environment.blender: unknown Blender studio light 'nowhere'"):
        load_scene(path)
    # Without bpy the same scene fails with the install hint.
    monkeypatch.setattr("compare.scene.environments.blender_studio_lights", lambda: {})
    path.write_text(scene_text('blender = "interior"'))
    with pytest.raises(SceneError, match="compare-pbr\\[blender\\]"):
        load_scene(path)


def test_blender_studio_lights_are_found_in_bpys_own_environment(tmp_path, monkeypatch):
    """bpy pins numpy < 2, so it lives in an environment of its own ($COMPARE_BLENDER_PYTHON):
    its HDRIs are found there without importing it."""
    import importlib.util

    env = tmp_path / "venv-blender"
    (env / "bin").mkdir(parents=True)
    (env / "bin" / "python").write_text("")
    world = env / "lib" / "python3.11" / "site-packages" / "bpy" / "5.0" / "datafiles" / "studiolights" / "world"
    world.mkdir(parents=True)
    (world / "forest.exr").write_bytes(b"")
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None)
    monkeypatch.delenv("COMPARE_BLENDER_PYTHON", raising=False)
    monkeypatch.setattr("compare.util.installed.RECORD", tmp_path / "no-record.json")
    assert blender_studio_lights() == {}
    monkeypatch.setenv("COMPARE_BLENDER_PYTHON", str(env / "bin" / "python"))
    assert blender_studio_lights() == {"forest": world / "forest.exr"}


def test_environment_file_is_envmap_in_mitsuba(tmp_path):
    from compare.mitsuba.scene_dict import environment_dict

    write_exr(tmp_path / "map.exr", procedural_map("axes", {"width": 16}))
    path = tmp_path / "s.toml"
    path.write_text(scene_text('file = "map.exr"\nrotation = 30\nintensity = 0.5'))
    d = environment_dict(load_scene(path))
    assert d["type"] == "envmap" and d["filename"] == str(tmp_path / "map.exr") and d["scale"] == 0.5
    path.write_text(scene_text('procedural = "studio"\nwidth = 64'))
    scene = load_scene(path)
    assert environment_dict(scene)["filename"] == str(environment_path(scene.environment))


def test_negative_environment_radiance_is_refused_and_noise_is_clamped_alike(tmp_path, monkeypatch):
    """Real negative radiance is refused with the file named, by the loader both renderers use; the tiny
    negatives of lossy compression are set to zero for the rasterizer and, through a cached copy, for
    Mitsuba too (which would read the file raw)."""
    from compare.scene.environments import NEGATIVE_TOLERANCE, environment_file, load_equirect
    from compare.mitsuba.scene_dict import environment_dict

    monkeypatch.setenv("COMPARE_CACHE", str(tmp_path / "cache"))
    image = np.full((8, 16, 3), 0.5, np.float32)
    bad = image.copy()
    bad[2:4, 3:6] = -0.2
    write_exr(tmp_path / "bad.exr", bad)
    path = tmp_path / "s.toml"
    path.write_text(scene_text('file = "bad.exr"'))
    scene = load_scene(path)
    limit = NEGATIVE_TOLERANCE * float(np.maximum(bad, 0).mean())
    message = (f"{tmp_path / 'bad.exr'}: an environment map must hold non-negative radiance: 18 values below "
               f"-{limit:.3g}, down to -0.2 (its mean is {np.maximum(bad, 0).mean():.3g}; only lossy-compression "
               "noise within 1% of the mean is set to zero)")
    for load in (lambda: load_equirect(tmp_path / "bad.exr"), lambda: environment_dict(scene)):
        with pytest.raises(ImageError) as exc:
            load()
        assert str(exc.value) == message
    noisy = image.copy()
    noisy[0, 0] = -0.002  # within the tolerance: compression noise
    write_exr(tmp_path / "noisy.exr", noisy)
    path.write_text(scene_text('file = "noisy.exr"'))
    scene = load_scene(path)
    given = Path(environment_dict(scene)["filename"])
    assert given != tmp_path / "noisy.exr" and given.parent == tmp_path / "cache" / "environments"
    from compare.image.exr import read_exr

    np.testing.assert_array_equal(read_exr(given)[0], load_equirect(tmp_path / "noisy.exr"))
    assert read_exr(given)[0].min() == 0.0
    assert environment_file(scene.environment) == given  # written once, reused
    write_exr(tmp_path / "clean.exr", image)
    path.write_text(scene_text('file = "clean.exr"'))
    assert environment_dict(load_scene(path))["filename"] == str(tmp_path / "clean.exr")  # no copy when clean


# ----------------------------------------------------------------------------- both renderers


def axis_scene(axis: str, rotation: float = 0.0):
    """A camera at the origin looking along ``axis`` into the 'axes' map (a tiny sphere far behind it)."""
    forward = np.array(AXES[axis], dtype=float)
    up = [0, 0, 1] if axis in ("+Y", "-Y") else [0, 1, 0]
    return parse_scene({
        "camera": {"position": [0, 0, 0], "target": forward.tolist(), "up": up, "fov": 70, "resolution": [32, 24]},
        "materials": {"m": {"base_color": [0.5, 0.5, 0.5]}},
        "meshes": [{"shape": "sphere", "radius": 0.01, "material": "m", "translate": (-50 * forward).tolist()}],
        "environment": {"procedural": "axes", "width": 128, "rotation": rotation},
        "render": {"max_depth": 2},
    }, Path(__file__).with_name(f"axes_{axis}.toml"))


@pytest.mark.parametrize("rotation", [0.0, 90.0])
def test_background_orientation_both_renderers(gl_ctx, tmp_path, rotation):
    """Along ±X, ±Y, ±Z the rasterizer's background equals the numpy lookup and Mitsuba's envmap.

    Frame 0 of the rasterizer samples pixel centres (no jitter): it must equal the
    numpy lookup there up to GL's filtering precision. Mitsuba's box-filtered
    pixels must equal the numpy lookup averaged over 8 × 8 points per pixel up to
    its noise, and the accumulated rasterizer image must equal Mitsuba's.
    """
    from compare.progressive.rasterizer import render_progressive
    from compare.mitsuba.reference import ReferenceRenderer

    for axis in AXES:
        scene = axis_scene(axis, rotation)
        ref = ReferenceRenderer(scene, cache_dir=tmp_path, progress=False).render(256).image
        r = render_progressive(scene, frames=16, ctx=gl_ctx, d_occ=0.0, ibl_size=16, ibl_samples=16,
                               checkpoints=(1,))
        first, ours = r.checkpoints[0].image, r.image
        cam = scene.camera
        jj, ii = np.mgrid[0:cam.height, 0:cam.width]
        image = environment_image(scene.environment)
        centre = sample_equirect(image, cam.ray_directions(ii + 0.5, jj + 0.5), rotation)
        o = (np.arange(8) + 0.5) / 8
        box = np.mean([sample_equirect(image, cam.ray_directions(ii + a, jj + b), rotation)
                       for a in o for b in o], axis=0)
        scale = ref.mean()
        errs = (np.abs(first - centre).mean() / scale, np.abs(ref - box).mean() / scale,
                np.abs(ours - ref).mean() / scale)
        print(f"{axis} rotation {rotation:g}: |frame 1 - numpy| {errs[0]:.4f}, |Mitsuba - numpy| {errs[1]:.4f}, "
              f"|rasterizer - Mitsuba| {errs[2]:.4f} (relative to the mean)")
        assert errs[0] < 0.003, axis
        assert errs[1] < 0.01, axis
        assert errs[2] < 0.04, axis
        # The spot on the axis the camera looks along is in the middle of the image (both renderers).
        if rotation == 0:
            expected = {"+X": 0, "-X": 1, "+Y": 1, "-Y": 0, "+Z": 2, "-Z": 0}[axis]
            assert np.argmax(ref[11:13, 15:17].mean((0, 1))) == expected, axis
            assert np.argmax(ours[11:13, 15:17].mean((0, 1))) == expected, axis
        if axis == "-Z":
            # The white spot (azimuth 30° from -Z towards +X, elevation 20°) appears up and to the right,
            # rotated with the map: rotation 90° moves it out of view (to azimuth 120°).
            white = ours.min(axis=2)
            j, i = np.unravel_index(np.argmax(white), white.shape)
            if rotation == 0:
                assert i > 18 and j < 10 and white[j, i] > 3, (i, j, white.max())
            else:
                assert white.max() < 1.0
