"""The rasterizer's parts behind one protocol (reset, describe, release), and the docs made from tables."""

from __future__ import annotations

import dataclasses

import numpy as np

from compare.progressive import options
from compare.progressive.config import RasterizerOptions
from compare.progressive.gl.passes import RenderPass
from compare.progressive.rasterizer import Rasterizer, render_progressive
from compare.scene.loader import load_scene
from tests.helpers import CORNELL, ROOT


def test_the_rasterizer_resets_describes_and_releases_through_its_list_of_passes(gl_ctx):
    scene = load_scene(ROOT / "scenes" / "stress" / "textures.toml").with_resolution(12, 9)
    r = Rasterizer(scene, frames=4, ctx=gl_ctx, area_model="ltc")
    try:
        assert all(isinstance(obj, RenderPass) for obj in r.passes)
        named = [r.gpu_scene, r.gbuffer, r.environment, r.env_occlusion, r.env_acc, r.accumulate, r.base, r.compose,
                 r.shadow, r.direct, r.ltc, r.first]
        assert all(obj is not None and obj in r.passes for obj in named)
        assert r.ltc_table is r.ltc.table and r.direct.ltc_table is r.ltc.table  # made and freed by the ltc sums
        list(r.frames())
        first, meta = r.image(), r.metadata()
        for obj in r.passes:
            described = obj.describe()
            assert all(meta[k] == v for k, v in described.items()), type(obj).__name__
        assert meta["occlusion"] == "screen-space, progressive" and meta["first_frame"] == "forward"
        assert meta["shadow_filter"] == "hard" and meta["ltc_table"].startswith("64x64")
        r.reset()
        assert r.frame == 0 and r.base.count == 0 and r.env_acc.count == 0 and r.ltc.gbuffer_frames == 0
        list(r.frames())
        np.testing.assert_array_equal(r.image(), first)  # the same plan from the start: the same pixels
    finally:
        r.release()
    assert r.passes == []


def test_metadata_defaults_stand_where_no_pass_replaces_them(gl_ctx):
    scene = load_scene(CORNELL).with_resolution(8, 6)
    meta = render_progressive(scene, frames=2, ctx=gl_ctx, first_frame="gbuffer").metadata
    assert (meta["first_frame"], meta["first_frame_scale"], meta["environment"]) == ("gbuffer", 1.0, "none")
    assert "occlusion" not in meta and meta["shadow_bias"] == "1,1,1"


def test_the_spec_words_have_one_table():
    assert list(options.OPTIONS) == [w.word for w in options.WORDS]
    for w in options.WORDS:
        assert f"``{w.word}``\n    ``{w.keyword}=" in options.__doc__, w.word
        assert w.keyword in {f.name for f in dataclasses.fields(RasterizerOptions)}, w.word
        spec = "progressive:" + w.word.replace("<ms>", "16")
        assert options.renderer_options(spec) == {w.keyword: 16.0 if w.value is None else w.value}
        assert options.describe(spec) == w.label.format(16.0)
        RasterizerOptions(**options.renderer_options(spec))  # a value the options accept


def test_render_progressive_lists_every_option_it_passes_on():
    doc = " ".join(render_progressive.__doc__.split())
    for f in dataclasses.fields(RasterizerOptions):
        if f.name not in ("frames", "seed", "area_model"):
            assert f" {f.name}," in doc or f" {f.name}." in doc, f.name
    assert "{options}" not in doc
