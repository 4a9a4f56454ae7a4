"""HDR encodings (compare.image.encodings): RGBM, RGBM sqrt/range 7, RGBE, octahedral maps with borders."""

from __future__ import annotations

import numpy as np
import pytest

from compare.image.encodings import (decode, encode, octahedral_decode, octahedral_directions, octahedral_encode,
                               octahedral_pad, rgbe_decode, rgbe_encode, rgbm_decode, rgbm_encode, rgbm_max,
                               roundtrip_stats)
from compare.scene.environments import blender_studio_lights, load_equirect
from compare.scene.procedural_env import procedural_map


def log_uniform(n: int, lo: float, hi: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.exp(rng.uniform(np.log(lo), np.log(hi), size=(n, 3)))


def test_rgbm_ranges():
    assert rgbm_max() == 6.0
    assert rgbm_max(7.0, sqrt=True) == 49.0


@pytest.mark.parametrize("name, top", [("rgbm", 6.0), ("rgbm7sqrt", 49.0)])
def test_rgbm_precision_in_range_and_clipping_above(name, top):
    x = log_uniform(20000, 0.05 * top, 0.999 * top)
    enc = encode(name, x)
    assert enc.dtype == np.uint8 and enc.shape == (20000, 4)
    y = decode(name, enc)
    # The largest channel of every pixel: at most about one 8-bit step relative error
    # (1/255 for RGBM; sqrt doubles it: d(x^2)/x^2 = 2 d(x)/x).
    big = np.argmax(x, axis=1)
    rel = np.abs(y - x)[np.arange(len(x)), big] / x[np.arange(len(x)), big]
    limit = (2.0 if name == "rgbm7sqrt" else 1.0) * 1.5 / 255
    assert rel.max() < limit, rel.max()
    # Above the range, the brightest channel is clipped to the maximum.
    over = decode(name, encode(name, np.array([[3.6e4, 1.0, 0.5]])))
    assert over[0, 0] == pytest.approx(top, rel=0.01)


def test_rgbm_decode_accepts_floats_like_a_texture_read():
    x = np.array([[0.3, 2.0, 5.0]])
    enc = rgbm_encode(x, scale=7.0, sqrt=True)
    np.testing.assert_allclose(rgbm_decode(enc.astype(np.float64) / 255, scale=7.0, sqrt=True),
                               rgbm_decode(enc, scale=7.0, sqrt=True))


def test_rgbe_keeps_the_sun_and_has_eight_bits():
    x = log_uniform(20000, 1e-4, 1e5, seed=1)
    y = rgbe_decode(rgbe_encode(x))
    big = np.argmax(x, axis=1)
    idx = np.arange(len(x))
    rel = np.abs(y - x)[idx, big] / x[idx, big]
    assert rel.max() < 1 / 128 and y.max() > 0.99 * x.max()
    # Truncation: the decode (Walter's, Mitsuba's) never exceeds the value; +0.5 (Ward's) is unbiased.
    assert np.all(y <= x * (1 + 1e-12))
    assert abs(np.mean(rgbe_decode(rgbe_encode(x), offset=0.5)[idx, big] / x[idx, big] - 1)) < 5e-4
    assert np.all(rgbe_encode(np.zeros((2, 3))) == 0)


def test_encode_rejects_unknown_names():
    with pytest.raises(ValueError, match="encoding: expected one of"):
        encode("logluv", np.ones((1, 3)))


def test_roundtrip_stats_on_a_sky_with_a_sun():
    sky = procedural_map("sky", {"width": 512, "sun_size": 2.0})
    rgbm = roundtrip_stats("rgbm", sky)
    sqrt7 = roundtrip_stats("rgbm7sqrt", sky)
    rgbe = roundtrip_stats("rgbe", sky)
    # The 3.6e4 sun does not fit RGBM: a visible share of the energy is lost, none with RGBE.
    assert rgbm["clipped"] > 0 and sqrt7["clipped"] > 0 and rgbe["clipped"] == 0
    assert rgbm["energy_lost"] > 0.2 and sqrt7["energy_lost"] > 0.2 and abs(rgbe["energy_lost"]) < 0.01
    # In range, all three keep about 8 bits.
    for s in (rgbm, sqrt7, rgbe):
        assert s["median_rel"] < 0.01 and s["mean_rel"] < 0.01


def test_roundtrip_stats_on_blender_hdris():
    lights = blender_studio_lights()
    if not lights:
        pytest.skip("bpy (the 'blender' extra) is not installed: no Blender HDRIs")
    courtyard = load_equirect(lights["courtyard"])  # peak ~55: almost fits sqrt/range 7, not Karis' range 6
    sqrt7 = roundtrip_stats("rgbm7sqrt", courtyard)
    assert sqrt7["clipped"] < 1e-4 and abs(sqrt7["energy_lost"]) < 1e-3
    assert roundtrip_stats("rgbm", courtyard)["clipped"] > 0.01
    assert roundtrip_stats("rgbm", courtyard)["energy_lost"] > 0.1


# ----------------------------------------------------------------------------- octahedral


def test_octahedral_round_trip_and_layout():
    rng = np.random.default_rng(2)
    d = rng.normal(size=(5000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    uv = octahedral_encode(d)
    assert uv.min() >= 0 and uv.max() <= 1
    np.testing.assert_allclose(octahedral_decode(uv), d, atol=1e-12)
    np.testing.assert_allclose(octahedral_encode(np.array([[0, 1.0, 0]])), [[0.5, 0.5]])
    for corner in ([0, 0], [0, 1], [1, 0], [1, 1]):
        np.testing.assert_allclose(octahedral_decode(np.array([corner], dtype=float)), [[0, -1, 0]], atol=1e-12)


def test_octahedral_border_is_the_sphere_across_the_edge():
    """The padded border holds the function at the texel that is the sphere's neighbour across the fold."""
    size = 16
    d = octahedral_directions(size)
    f = d @ np.array([0.3, -0.5, 0.8])  # a smooth function of the direction
    padded = octahedral_pad(f[..., None])[..., 0]
    # Texel centre just outside the top edge (v = -1/(2S)) decodes — after folding — to the
    # direction of the mirrored texel in row 0.
    for x in range(size):
        u = (x + 0.5) / size
        outside = np.array([u, -0.5 / size])
        # mirror across the edge's midpoint: (u, -e) lies on the sphere next to (1 - u, +e)
        mirrored = octahedral_decode(np.array([1 - u, 0.5 / size]))
        assert padded[0, x + 1] == pytest.approx(float(mirrored @ np.array([0.3, -0.5, 0.8])), abs=1e-12)
        assert outside[1] < 0
    # Bilinear lookups with the border are as accurate at the folds as inside.
    from compare.ibl.atlas import sample_octahedral

    rng = np.random.default_rng(3)
    q = rng.normal(size=(20000, 3))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    exact = q @ np.array([0.3, -0.5, 0.8])
    got = sample_octahedral(padded[..., None], q)[..., 0]
    uv = octahedral_encode(q)
    edge = np.min(np.minimum(uv, 1 - uv), axis=1) < 0.5 / size
    err_edge = np.abs(got - exact)[edge].mean()
    err_inner = np.abs(got - exact)[~edge].mean()
    # The fold's kink makes texels next to it a little worse than inside (measured ~1.9x) ...
    assert err_edge < 3 * err_inner, (err_edge, err_inner)
    # ... but without the mirrored border (clamped edges instead) the folds are worse again (measured ~1.9x).
    clamped = np.pad(f, 1, mode="edge")[..., None]
    err_clamped = np.abs(sample_octahedral(clamped, q)[..., 0] - exact)[edge].mean()
    assert err_clamped > 1.5 * err_edge, (err_clamped, err_edge)
