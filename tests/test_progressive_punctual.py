"""Point, spot and directional lights in the progressive rasterizer: exact light from the first frame,
one kept shadow map per light placed by the distributor and the frame budget, and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.progressive.schedule.budget import BudgetScheduler, FrameCosts
from compare.progressive.schedule.distributor import plan, punctual_frames
from compare.progressive.lights.punctual import ShadowMap
from compare.progressive.rasterizer import Rasterizer, render_progressive
from compare.scene.loader import load_scene
from compare.scene.model import PUNCTUAL_KINDS, PunctualLight
from tests.helpers import EFFECTS, effect_scene, ground_points, punctual_closed_form

FRAMES = 32


def _check_closed_form(image, scene, light, samples: int):
    """Within 2 % per pixel of the plane's closed form, beyond the pixel-sampling spread of ``samples``
    jittered frames (4 standard errors) and 1e-3 of the peak; the lit mean within 0.5 %."""
    want, spread = punctual_closed_form(scene, light)
    _, hit = ground_points(scene)
    got, want, spread = image[hit], want[hit], spread[hit]
    peak = want.max()
    bound = 0.02 * want + 4 * spread / math.sqrt(samples) + 1e-3 * peak
    worst = np.abs(got - want) - bound
    assert worst.max() <= 0, (got.ravel()[worst.argmax()], want.ravel()[worst.argmax()])
    lit = want[:, 0] > 0.05 * peak
    assert got[lit].sum() == pytest.approx(want[lit].sum(), rel=5e-3)


@pytest.mark.parametrize("kind", PUNCTUAL_KINDS)
def test_rasterizer_matches_the_closed_form_of_each_punctual_light(gl_ctx, kind):
    scene = effect_scene(kind).with_resolution(48, 36)
    (light,) = scene.punctual
    result = render_progressive(scene, frames=FRAMES, materials="diffuse", ctx=gl_ctx, checkpoints=(1,))
    # The shadow map lands in frame 1 and restarts the mean: FRAMES − 1 jittered frames after it.
    _check_closed_form(result.image, scene, light, FRAMES - 1)
    # exact and unshadowed from the first frame: one sample per pixel, at frame 0's jitter
    _check_closed_form(result.checkpoints[0].image, scene, light, 1)
    assert set(result.layers) == {"emission", "direct_punctual"}
    np.testing.assert_allclose(result.layers["direct_punctual"], result.image, atol=1e-6)
    assert result.metadata["punctual_lights"] == 1


def test_shadows_agree_with_the_reference_and_arrive_with_their_map(gl_ctx):
    """The Cornell box under a point light: the rasterizer's punctual layer is the reference's direct
    punctual light (shadows of both blocks); before its shadow map the light is unshadowed."""
    from compare.mitsuba.reference import ReferenceRenderer

    scene = load_scene(EFFECTS / "cornell_point.toml").with_resolution(80, 60)
    with Rasterizer(scene, frames=24, ctx=gl_ctx) as r:
        r.render_frame()
        before = r.image()
        assert r.shadow_passes == [0]
        for _ in r.frames():
            pass
        after = r.layers()["direct_punctual"]
        assert r.shadow_passes[1] == 1 and sum(r.shadow_passes) == 1  # one map, in frame 1, kept
    _, layers, _ = ReferenceRenderer(scene, cache_dir=False, progress=False).render_layers(256)
    truth = layers["direct_punctual"]
    assert after.mean() == pytest.approx(truth.mean(), rel=0.02)
    # apart from anti-aliased edges and the reference's noise, every pixel agrees
    close = np.abs(after - truth).mean(-1) <= 0.15 * truth.mean(-1) + 0.02 * truth.mean()
    assert close.mean() > 0.95
    shadowed = (truth.mean(-1) < 0.05 * truth.mean()) & (before.mean(-1) > 0.5 * truth.mean())
    assert shadowed.sum() > 50  # the blocks' shadows: lit before the map, dark after
    assert after[shadowed].mean() < 0.05 * truth.mean()


def test_each_punctual_map_is_rendered_once_as_early_as_it_can():
    assert punctual_frames(3, 8) == [[], [0], [1], [2], [], [], [], []]
    assert punctual_frames(5, 3) == [[], [0, 1, 2], [3, 4]]
    assert punctual_frames(2, 1) == [[0, 1]]
    scene = effect_scene("point")
    p = plan(scene, 8)
    assert [fp.punctual for fp in p] == [(), (0,), (), (), (), (), (), ()]
    assert p[1].shadow_passes == 1 and not p[0].preview


def test_the_frame_budget_hands_out_punctual_maps_first():
    scene = effect_scene("spot")
    s = BudgetScheduler(plan(scene, 8), budget=1.0)
    s.costs = FrameCosts(base=0.1, light=0.2, env=0.2, punctual=0.5)
    assert s.punctual == [0] and not s.done
    assert s.next().punctual == ()  # frame 0: the cheap preview
    assert s.next().punctual == (0,)
    assert s.done
    tight = BudgetScheduler(plan(scene, 8), budget=0.01)
    tight.costs = FrameCosts(base=0.1, light=0.2, env=0.2, punctual=0.5)
    tight.next()
    assert tight.next().punctual == (0,)  # every frame gets at least one sample, however tight


def test_shadow_map_layouts():
    bounds = (np.array([-1.0, 0.0, -1.0]), np.array([1.0, 2.0, 1.0]))
    point = ShadowMap(PunctualLight("p", "point", (0, 1, 0), (0, -1, 0), (1, 1, 1)), bounds, np.zeros((0, 3)), 64)
    assert point.faces == 6 and point.shape == (96, 64) and point.texel == (2 / 32, 0.0)
    # each cube face sees its own axis: +x, -x, +y, -y, +z, -z
    for k, axis in enumerate(np.vstack([np.eye(3), -np.eye(3)])[[0, 3, 1, 4, 2, 5]]):
        clip = point.view_proj[k] @ np.append(np.array([0, 1, 0]) + 0.5 * axis, 1.0)
        assert clip[3] > 0 and np.all(np.abs(clip[:2] / clip[3]) < 1e-9)
    narrow = ShadowMap(PunctualLight("s", "spot", (0, 1, 0), (0, -1, 0), (1, 1, 1), 10, 30), bounds,
                       np.zeros((0, 3)), 64)
    assert narrow.faces == 1
    wide = ShadowMap(PunctualLight("s", "spot", (0, 1, 0), (0, -1, 0), (1, 1, 1), 10, 80), bounds,
                     np.zeros((0, 3)), 64)
    assert wide.faces == 6
    # a directional map covers the part of the bounds the camera sees, and every caster towards the light
    seen = np.array([[-0.5, 0.0, -0.5], [0.5, 0.0, -0.5], [-0.5, 0.0, 0.5], [0.5, 0.0, 0.5]])
    sun = ShadowMap(PunctualLight("d", "directional", (0, 0, 0), (0.3, -1.0, 0.2), (1, 1, 1)), bounds, seen, 64)
    full = ShadowMap(PunctualLight("d", "directional", (0, 0, 0), (0.3, -1.0, 0.2), (1, 1, 1)), bounds,
                     np.zeros((0, 3)), 64)
    assert sun.texel[1] < full.texel[1]  # fitted to what is seen: finer texels
    corners = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (0, 2) for z in (-1, 1)])
    for m in (sun, full):
        clip = (m.view_proj[0] @ np.c_[seen, np.ones(4)].T).T
        assert np.all(np.abs(clip[:, :2]) <= 1.0)
        depth = (corners[:, :3] - m.origin) @ m.direction
        assert depth.min() > 0 and depth.max() < m.far


def test_several_punctual_lights_and_area_lights_together(gl_ctx, make_scene):
    """Two punctual lights beside an area light: each kind of light in its own layer, the sum the image,
    and with more lights than frames the maps share frames."""
    text = (EFFECTS / "point_light.toml").read_text()
    spot = "[[lights]]" + (EFFECTS / "spot_light.toml").read_text().split("[[lights]]", 1)[1]
    area = '''
        [[lights]]
        name = "panel"
        center = [0.0, 3.0, 0.0]
        size = [0.5, 0.5]
        normal = [0.0, -1.0, 0.0]
        tangent = [1.0, 0.0, 0.0]
        radiance = [2.0, 2.0, 2.0]
        '''
    scene = load_scene(make_scene(text, spot, area)).with_resolution(40, 30)
    assert len(scene.punctual) == 2 and len(scene.lights) == 1
    result = render_progressive(scene, frames=2, ctx=gl_ctx)
    assert result.plan[1].punctual == (0, 1)
    layers = result.layers
    assert {"direct_area", "direct_punctual"} <= set(layers)
    np.testing.assert_allclose(sum(layers.values()), result.image, rtol=1e-5, atol=1e-6)
    assert layers["direct_punctual"].max() > 0 and layers["direct_area"].max() > 0
