"""Per-effect ground truths (compare.mitsuba.layers) and the per-layer measurement (compare.metrics.layers)."""

from __future__ import annotations


import numpy as np
import pytest

from compare.metrics.layers import layer_metrics
from compare.mitsuba.reference import ReferenceRenderer
from compare.metrics.layers import EXTRA_LAYERS, LAYERS, SUM_LAYERS
from compare.scene.loader import load_scene
from compare.metrics.ztest import pass_statistics, z_test
from tests.helpers import CORNELL, furnace_scene, sphere_mask


@pytest.fixture(scope="module")
def cornell_layers():
    r = ReferenceRenderer(load_scene(CORNELL).with_resolution(48, 36), cache_dir=False, progress=False)
    return r, r.render_layers(256, seed=3)


def test_layers_sum_to_the_image(cornell_layers):
    _, (image, layers, seconds) = cornell_layers
    assert set(layers) == set(LAYERS) and seconds > 0
    total = sum(layers[n].astype(np.float64) for n in SUM_LAYERS)
    np.testing.assert_allclose(total, image, rtol=1e-5, atol=1e-6)
    for name, layer in layers.items():
        assert layer.shape == image.shape and np.isfinite(layer).all() and layer.min() >= 0, name
    # the Cornell box: a visible light, shadowed direct light, both kinds of indirect light, no environment
    assert layers["direct_env"].max() == 0.0
    for name in ("emission", "direct_area", "indirect_diffuse", "indirect_specular"):
        assert layers[name].mean() > 0, name
    # the blocks cast shadows: the unshadowed direct light is more than the shadowed
    assert layers["direct_area_unshadowed"].mean() > 1.05 * layers["direct_area"].mean()


def test_layers_image_converges_to_the_path_tracer():
    """The layers integrator is Mitsuba's path algorithm: its image and `path`'s agree within noise
    (Welch's z-test on 8 independent renders of each), pixel by pixel and in 4x4 tiles."""
    r = ReferenceRenderer(load_scene(CORNELL).with_resolution(32, 24), cache_dir=False, progress=False)
    path = r.independent_passes(8, 128, seed=5)
    layered = np.stack([r.render_layers(128, seed=100 + k)[0] for k in range(8)])
    for block in (1, 4):
        res = z_test(*pass_statistics(path)[:2], *pass_statistics(layered)[:2], block=block,
                     dof_a=7, dof_b=7)
        assert res.passed, str(res)
    assert abs(layered.mean() / path.mean() - 1) < 0.01


def test_furnace_layers_are_closed_forms():
    """A Lambert sphere of albedo 0.5 in a uniform environment of radiance 1: the camera sees the
    environment (emission 1) around it; on it the environment's direct light is the albedo, and a
    convex object has no indirect light and no area lights."""
    size = 24
    r = ReferenceRenderer(furnace_scene(0.5, size, double_sided=False), materials="diffuse", cache_dir=False,
                          progress=False)
    image, layers, _ = r.render_layers(1024, seed=1)
    inside = sphere_mask(size)
    corner = np.zeros((size, size), dtype=bool)
    corner[:3, :3] = True
    np.testing.assert_allclose(layers["emission"][corner], 1.0, rtol=1e-5)
    assert layers["emission"][inside].max() == 0.0
    np.testing.assert_allclose(layers["direct_env"][inside].mean(), 0.5, rtol=0.01)
    for name in ("direct_area", "indirect_diffuse", "indirect_specular", "direct_area_unshadowed"):
        assert np.abs(layers[name]).max() < 1e-6, name


def test_layer_shares_add_up_and_name_the_missing_light(cornell_layers):
    """A renderer with exact emission and direct light but no indirect light: all of its error is in
    the indirect layers; a renderer off by 10 % in direct light only has all of its error there."""
    _, (_, truth, _) = cornell_layers
    no_indirect = {"emission": truth["emission"], "direct_area": truth["direct_area"]}
    m = layer_metrics(truth, no_indirect)
    shares = {n: m[n]["share"] for n in SUM_LAYERS}
    assert sum(shares.values()) == pytest.approx(1.0, abs=1e-9)
    assert shares["emission"] == pytest.approx(0.0, abs=1e-12) and shares["direct_area"] == pytest.approx(0.0, abs=1e-12)
    assert shares["indirect_diffuse"] > 0.5 and not m["indirect_diffuse"]["rendered"]
    assert m["indirect_diffuse"]["mean_ratio"] == 0.0 and m["direct_area"]["mean_ratio"] == pytest.approx(1.0)
    assert m["direct_env"]["mean_ratio"] is None  # no environment: no ratio of nothing
    brighter = dict(truth, direct_area=truth["direct_area"] * 1.1)
    m = layer_metrics(truth, brighter)
    assert m["direct_area"]["share"] == pytest.approx(1.0) and m["direct_area"]["mean_ratio"] == pytest.approx(1.1)
    assert set(m) == set(LAYERS)  # the extra layer is measured when the run has it
    assert "share" not in m[EXTRA_LAYERS[0]]
