"""glTF's dispersion in the reference (``KHR_materials_dispersion``): a glass sphere over a checker, whose
dispersive image is, channel by channel, the image of the same sphere without dispersion at that channel's
IOR (:func:`compare.scene.model.channel_iors`): the hero-channel estimator is unbiased per channel."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from compare.scene.model import channel_iors
from tests.helpers import sphere_scene

#: A checker card 1 m behind the sphere, filling its view.
CHECKER_BEHIND = """
    [materials.checker]
    base_color_texture = "checker.png"
    texture_filter = "nearest"

    [[meshes]]
    shape = "quad"
    size = [2.0, 2.0]
    rotate = [90.0, 0.0, 0.0]
    translate = [0.0, 0.0, -1.0]
    material = "checker"
    """


def _scene(make_scene, tmp_path, *, ior: float, dispersion: float, roughness: float = 0.0):
    checker = np.kron((np.indices((8, 8)).sum(0) % 2).astype(np.uint8) * 230 + 20, np.ones((4, 4), np.uint8))
    Image.fromarray(np.repeat(checker[..., None], 3, axis=2)).save(tmp_path / "checker.png")
    material = f"base_color = [1, 1, 1]\nroughness = {roughness}\ntransmission = 1.0\nthickness = 1.0\nior = {ior}\n" \
               f"dispersion = {dispersion}"
    return sphere_scene(make_scene, material, sky=1.0, depth=16, extra=CHECKER_BEHIND,
                        file=f"s-{ior}-{dispersion}-{roughness}.toml")


def _render(scene, spp):
    from compare.mitsuba.reference import ReferenceRenderer

    return ReferenceRenderer(scene, cache_dir=False, progress=False).render(spp, seed=3).image


def test_channel_iors_follow_the_extensions_rule():
    assert channel_iors(1.5, 0.0) == (1.5, 1.5, 1.5)
    r, g, b = channel_iors(1.5, 1.0)  # V_d = 20: n_F − n_C = 0.5 / 20, half of it each side of n_d
    assert (g, b - r) == (1.5, pytest.approx(0.025)) and r < g < b
    assert channel_iors(1.01, 100.0)[0] == 1.0  # never below 1


@pytest.mark.parametrize("roughness", [0.0, pytest.param(0.2, marks=pytest.mark.slow)], ids=["smooth", "rough"])
def test_each_channel_is_the_sphere_at_that_channels_ior(make_scene, tmp_path, mi_llvm, roughness):
    """The colour fringes (red minus blue) of the dispersive sphere are those of the three spheres at the
    channels' IORs (correlation measured 0.89 smooth, 0.94 rough at 2048 spp; none without dispersion, where
    red equals blue), and each channel's mean is theirs (unbiased)."""
    ior, dispersion = 1.5, 8.0  # an exaggerated spread (0.2) so that the channels part visibly
    scene = _scene(make_scene, tmp_path, ior=ior, dispersion=dispersion, roughness=roughness)
    assert scene.features().dispersion
    spread = _render(scene, 2048)
    assert np.isfinite(spread).all()
    per_channel = [_render(_scene(make_scene, tmp_path, ior=n, dispersion=0.0, roughness=roughness), 512)[..., k]
                   for k, n in enumerate(channel_iors(ior, dispersion))]
    expected = np.stack(per_channel, axis=-1)
    blocks = lambda a: a.reshape(12, 2, 12, 2, 3).mean(axis=(1, 3))  # noqa: E731
    fringe = lambda a: (blocks(a)[..., 0] - blocks(a)[..., 2]).ravel()  # noqa: E731
    assert np.abs(fringe(expected)).max() > 0.1  # the channels do part
    assert np.corrcoef(fringe(spread), fringe(expected))[0, 1] > 0.8
    np.testing.assert_allclose(spread.mean(axis=(0, 1)), expected.mean(axis=(0, 1)), rtol=0.01)


@pytest.mark.bpy
def test_cycles_parts_the_channels_as_the_reference_does(make_scene, tmp_path, mi_llvm):
    """Cycles draws dispersion as three glasses of the channels' IORs (compare.blender.export.dispersion_inputs):
    its colour fringes correlate with those of the reference's three spheres at the channels' IORs, as the
    reference's own do (measured 0.80 to 0.94 over seeds at 1024 and 2048 samples; the reference 0.89; none
    where it draws one glass, where red equals blue), and its channel means are theirs within 5 %."""
    from compare.blender.render import render_blender

    ior, dispersion = 1.5, 8.0
    cycles = render_blender(_scene(make_scene, tmp_path, ior=ior, dispersion=dispersion), engine="cycles",
                            samples=2048).image
    expected = np.stack([_render(_scene(make_scene, tmp_path, ior=n, dispersion=0.0), 512)[..., k]
                         for k, n in enumerate(channel_iors(ior, dispersion))], axis=-1)
    blocks = lambda a: a.reshape(12, 2, 12, 2, 3).mean(axis=(1, 3))  # noqa: E731
    fringe = lambda a: (blocks(a)[..., 0] - blocks(a)[..., 2]).ravel()  # noqa: E731
    assert np.abs(fringe(cycles)).max() > 0.1
    assert np.corrcoef(fringe(cycles), fringe(expected))[0, 1] > 0.75
    np.testing.assert_allclose(cycles.mean(axis=(0, 1)), expected.mean(axis=(0, 1)), rtol=0.05)


def test_the_rasterizer_parts_the_channels_as_its_own_spheres_at_their_iors(make_scene, tmp_path, gl_ctx):
    """The rasterizer's glass pass refracts one channel's IOR per pixel and frame (its light × 3 in that
    channel): over the frames each channel is the rasterizer's own sphere at that channel's IOR (fringes
    correlate by 0.85 at 96 frames, 0.87 at 256; channel means 1.7 % apart), where the sphere without
    dispersion has no fringe. (Against the reference's fringes the correlation is −0.22, as it is for the
    rasterizer's own three spheres: at 24 × 24 pixels its screen-space refraction blurs this lens's image.)"""
    from compare.progressive.rasterizer import render_progressive

    ior, dispersion = 1.5, 8.0
    spread = render_progressive(_scene(make_scene, tmp_path, ior=ior, dispersion=dispersion), frames=96,
                                ctx=gl_ctx).image
    assert np.isfinite(spread).all()
    scenes = [_scene(make_scene, tmp_path, ior=n, dispersion=0.0) for n in channel_iors(ior, dispersion)]
    own = np.stack([render_progressive(s, frames=16, ctx=gl_ctx).image[..., k] for k, s in enumerate(scenes)], axis=-1)
    plain = render_progressive(scenes[1], frames=16, ctx=gl_ctx).image
    blocks = lambda a: a.reshape(12, 2, 12, 2, 3).mean(axis=(1, 3))  # noqa: E731
    fringe = lambda a: (blocks(a)[..., 0] - blocks(a)[..., 2]).ravel()  # noqa: E731
    assert np.abs(fringe(spread)).max() > 0.1 and np.abs(fringe(plain)).max() < 1e-3
    assert np.corrcoef(fringe(spread), fringe(own))[0, 1] > 0.75
    np.testing.assert_allclose(spread.mean(axis=(0, 1)), own.mean(axis=(0, 1)), rtol=0.03)
