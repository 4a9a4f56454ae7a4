"""The Mitsuba reference: white furnace, spp ladder, cache and resume, noise floor."""

from __future__ import annotations


import numpy as np
import pytest

from compare.mitsuba.reference import ReferenceRenderer, ladder_passes
from compare.scene.loader import parse_scene
from tests.helpers import CORNELL, ROOT, furnace_scene, sphere_mask


def test_ladder_passes_double():
    assert ladder_passes(1) == [1]
    assert ladder_passes(8) == [1, 1, 2, 4]
    assert np.cumsum(ladder_passes(100)).tolist() == [1, 2, 4, 8, 16, 32, 64, 100]
    with pytest.raises(ValueError):
        ladder_passes(0)


def test_white_furnace(tmp_path):
    """Albedo 1 in a uniform unit environment: every pixel is 1; noise falls with spp."""
    size = 24
    r = ReferenceRenderer(furnace_scene(1.0, size), materials="diffuse", cache_dir=tmp_path, progress=False)
    mask = sphere_mask(size)
    img = r.render(256).image
    sphere = img[mask]
    assert abs(sphere.mean() - 1.0) < 0.01, sphere.mean()
    assert np.abs(sphere - 1.0).max() < 0.05
    np.testing.assert_allclose(img[0, 0], 1.0, rtol=1e-5)  # background: the environment itself
    # variance falls as spp rises: 16× the samples → a quarter of the standard deviation
    low = np.stack([r.render(16, seed=s).image[mask] for s in range(4)])
    high = np.stack([r.render(256, seed=s).image[mask] for s in range(4)])
    ratio = low.std() / max(high.std(), 1e-12)
    print(f"furnace: mean {sphere.mean():.5f}, max |err| {np.abs(sphere - 1).max():.4f}, std ratio 16/256 spp {ratio:.2f}")
    assert 2.5 < ratio < 6.0


def test_grey_furnace_single_bounce(tmp_path):
    """A convex diffuse sphere sees only the environment: radiance = albedo exactly."""
    r = ReferenceRenderer(furnace_scene(0.5), materials="diffuse", cache_dir=False, progress=False)
    img = r.render(64).image
    assert abs(img[sphere_mask(24)].mean() - 0.5) < 0.005


def test_ladder_and_cache_resume(tmp_path, monkeypatch):
    scene = parse_scene({
        "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "resolution": [16, 12]},
        "materials": {"m": {"base_color": [0.5, 0.5, 0.5]}},
        "meshes": [{"shape": "quad", "size": [4, 4], "rotate": [90, 0, 0], "material": "m"}],
        "lights": [{"center": [0, 0, 2], "size": [1, 1], "normal": [0, 0, -1], "radiance": [5, 5, 5]}],
    }, ROOT / "tests" / "ladder.toml")
    r = ReferenceRenderer(scene, materials="diffuse", cache_dir=tmp_path, progress=False)
    calls = []
    real = r.render_chunk

    def flaky(spp, seed):
        calls.append(spp)
        if len(calls) == 3:
            raise KeyboardInterrupt  # an interruption in the middle of the ladder
        return real(spp, seed)

    monkeypatch.setattr(r, "render_chunk", flaky)
    with pytest.raises(KeyboardInterrupt):
        r.ladder(8)
    cached = sorted(tmp_path.rglob("*.exr"))
    assert len(cached) == 2  # the two finished passes, nothing half-written
    assert not [p for p in tmp_path.rglob("*") if p.is_file() and p.name.startswith(".")]

    monkeypatch.setattr(r, "render_chunk", real)
    rendered = []
    monkeypatch.setattr(r.mi, "render", _counting(r.mi.render, rendered))
    checkpoints = r.ladder(8)
    assert [c.step for c in checkpoints] == [1, 2, 4, 8]
    assert rendered == [2, 4]  # resumed: only the passes that were missing
    assert all(b.seconds > a.seconds for a, b in zip(checkpoints, checkpoints[1:]))

    # A fresh renderer finds everything in the cache and gives identical pixels.
    again = ReferenceRenderer(scene, materials="diffuse", cache_dir=tmp_path, progress=False)
    rendered.clear()  # again.mi is the same module: the counting wrapper is still in place
    np.testing.assert_array_equal(again.render(8).image, checkpoints[-1].image)
    assert rendered == []

    # A corrupt cache entry is rendered again, not trusted.
    victim = sorted(tmp_path.rglob("*.exr"))[0]
    victim.write_bytes(b"not an exr")
    with pytest.warns(UserWarning, match="reference cache: discarded .*not an OpenEXR file"):
        again.render(8)
    # one untimed warm-up sample (JIT kept out of the timings), then the missing pass only
    assert rendered == [1, int(_spp_of(again, victim))]
    assert again.warmup_seconds is not None


def _counting(fn, log):
    def wrapper(scene, spp, seed):
        log.append(spp)
        return fn(scene, spp=spp, seed=seed)
    return wrapper


@pytest.mark.parametrize("materials", ["cycles", "cycles-ggx"])
def test_cycles_mode_furnace_is_the_principled_albedo(materials):
    """A white rough dielectric sphere in a unit environment (convex: one bounce): the pixels facing
    the camera show the cycles model's directional albedo at n.v = 1, diffuse (1 − E_s L_d) plus
    specular (L_d = 1 with GGX; Multiscatter GGX's layer factor otherwise)."""
    from compare import brdf
    from compare.brdf import multiscatter
    from compare.mitsuba import principled
    from compare.mitsuba.scene_dict import MATERIAL_MODELS, PRINCIPLED_MODES

    size = 24
    dist = PRINCIPLED_MODES[materials] or "multi_ggx"  # the furnace's material keeps Blender's default
    r = ReferenceRenderer(furnace_scene(1.0, size), materials=materials, cache_dir=False, progress=False)
    assert r.settings()["material_model"] == MATERIAL_MODELS[materials]  # not an older model's cache
    assert r.settings()["distribution"] == dist
    assert "material_model" not in ReferenceRenderer(furnace_scene(1.0, size), materials="shared",
                                                     cache_dir=False, progress=False).settings()
    centre = r.render(4096).image[10:14, 10:14].mean((0, 1))  # n.v > 0.98; about 0.1 % noise
    # albedo at n.v = 1: specular by visible-normal sampling, diffuse = 1 − E_s(1, 1) L_d
    g = (np.arange(256) + 0.5) / 256
    u = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    wi = np.broadcast_to([0.0, 0.0, 1.0], (len(u), 3))
    h = brdf.sample_ggx_vndf(wi, np.ones(len(u)), u)
    wo = 2.0 * h[:, 2:] * h - wi
    spec, _ = principled.eval_principled_lobes([0.0, 0.0, 1.0], wi, wo, np.ones(3), 0.0, 1.0, dist)
    pdf = brdf.pdf_ggx_vndf_reflection(wi, wo, 1.0)
    e_spec = np.mean(np.where(pdf > 0, spec[:, 0] * np.maximum(wo[:, 2], 0) / np.where(pdf > 0, pdf, 1), 0))
    l_d = multiscatter.layer_factor(principled.FSS_DIELECTRIC, 1.0, 1.0) if dist == "multi_ggx" else 1.0
    expected = 1.0 - principled.specular_layer_albedo(1.0, 1.0) * l_d + e_spec
    print(f"{materials} furnace: centre {centre}, expected {expected:.4f} (specular {e_spec:.4f})")
    np.testing.assert_allclose(centre, expected, rtol=0.01)
    if dist == "ggx":
        assert expected < 0.99  # E_s darkens the diffuse by more than the rough specular reflects
    else:
        assert expected > 0.99  # Multiscatter GGX gives most of that back


def _spp_of(renderer, victim):
    from compare.image.exr import read_exr

    return read_exr(victim)[1]["spp"]


def test_cornell_renders_finite_and_plausible():
    from compare.scene.loader import load_scene

    scene = load_scene(CORNELL).with_resolution(32, 24)
    img = ReferenceRenderer(scene, materials="shared", cache_dir=False, progress=False).render(16).image
    assert img.shape == (24, 32, 3) and np.isfinite(img).all()
    left, right = img[8:16, 6:8].mean((0, 1)), img[8:16, 24:26].mean((0, 1))
    assert left[0] > 5 * left[1], "red wall on the left"
    assert right[1] > 1.5 * right[0], "green wall on the right"


@pytest.mark.parametrize("tamper", ["another seed", "zeros", "wrong size", "nan", "garbage", "no checksum"])
def test_a_bad_cache_entry_is_discarded_reported_and_rendered_again(tmp_path, tamper):
    """A cache entry that is not what its key says (another seed's pass, zeroed pixels with the right
    header, another size, NaN, not an EXR, an entry without its checksum) is never used: it is removed,
    a warning names it, the pass is rendered again, and the next run reads the good entry silently."""
    import warnings

    from compare.image.exr import read_exr, write_exr
    from compare.scene.loader import load_scene

    scene = load_scene(CORNELL).with_resolution(16, 12)
    r = ReferenceRenderer(scene, cache_dir=tmp_path, progress=False)
    good, _ = r.render_chunk(4, 0)
    path = r._chunk_path(4, 0)
    image, meta = read_exr(path)
    if tamper == "another seed":
        other, _ = r.render_chunk(4, 1)
        write_exr(path, other, metadata=read_exr(r._chunk_path(4, 1))[1])
    elif tamper == "zeros":
        write_exr(path, np.zeros_like(image), metadata=meta)
    elif tamper == "wrong size":
        write_exr(path, image[:6], metadata=meta)
    elif tamper == "nan":
        bad = image.copy()  # write_exr refuses NaN: write the file with OpenEXR itself
        bad[0, 0, 0] = np.nan
        import OpenEXR

        OpenEXR.File({k: v for k, v in meta.items() if isinstance(v, (int, float, str))},
                     {"RGB": bad.astype(np.float32)}).write(str(path))
    elif tamper == "garbage":
        path.write_bytes(b"not an exr")
    else:
        write_exr(path, image, metadata={k: v for k, v in meta.items() if k != "pixels_sha256"})
    fresh = ReferenceRenderer(scene, cache_dir=tmp_path, progress=False)
    with pytest.warns(UserWarning, match=r"reference cache: discarded .*rendering that pass again"):
        again, _ = fresh.render_chunk(4, 0)
    np.testing.assert_array_equal(again, good)  # the right pass, rendered again (Mitsuba is deterministic)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_array_equal(ReferenceRenderer(scene, cache_dir=tmp_path, progress=False)
                                      .render_chunk(4, 0)[0], good)


def _cornell(width: int, height: int):
    from compare.scene.loader import load_scene

    return load_scene(CORNELL).with_resolution(width, height)


def test_a_pass_is_exactly_a_bare_mitsuba_render():
    """render_chunk returns, bit for bit, what a bare ``mi.render`` of the same scene dictionary,
    spp and seed returns: the wrapper adds its checks and its cache, never a change to the pixels
    (``compare bench --only wrapper-overhead`` times the same two calls)."""
    from compare.mitsuba.scene_dict import scene_dict

    scene = _cornell(16, 12)
    r = ReferenceRenderer(scene, cache_dir=False, progress=False)
    bare = r.mi.load_dict(scene_dict(scene, spp=1))
    for spp, seed in ((1, 0), (4, 7)):
        image, seconds = r.render_chunk(spp, seed)
        assert image.dtype == np.float32 and image.shape == (12, 16, 3) and seconds > 0
        np.testing.assert_array_equal(image, np.array(r.mi.render(bare, spp=spp, seed=seed)))


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_a_non_finite_pass_is_refused_and_never_cached(tmp_path, value):
    """One NaN or infinite value in what Mitsuba returns is an error naming how many, where the first
    is, the spp and the seed; nothing is written to the cache."""
    from compare.util.errors import ImageError

    r = ReferenceRenderer(_cornell(16, 12), cache_dir=tmp_path, progress=False)
    real = r.mi

    class OneBadValue:  # Mitsuba, but every render has one non-finite value
        def __getattr__(self, name):
            return getattr(real, name)

        def render(self, *args, **kwargs):
            image = np.array(real.render(*args, **kwargs))
            image[5, 3, 1] = value
            return real.TensorXf(image)

    r.mi = OneBadValue()
    with pytest.raises(ImageError, match=r"produced 1 non-finite values \(first at \(5, 3, 1\)\) at spp=2, seed=3"):
        r.render_chunk(2, 3)
    path = r._chunk_path(2, 3)
    assert path is not None and not path.exists()
