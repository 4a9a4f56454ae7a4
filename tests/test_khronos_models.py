"""The Khronos sample models of scenes/khronos/ show what their READMEs say: they load, and where the model
states a closed form (a colour that no light changes, an instance grid, a morph) the scene holds it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from compare.scene.loader import load_scene

KHRONOS = Path(__file__).resolve().parent.parent / "scenes" / "khronos"
SCENES = sorted(KHRONOS.glob("*.toml"))


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_every_sample_scene_loads(path):
    scene = load_scene(path)
    assert scene.meshes and all(m.triangles().triangle_count > 0 for m in scene.meshes)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_unlit_boxes_show_their_base_colours_in_the_reference_and_the_rasterizer(gl_ctx):
    """UnlitTest: an orange and a blue box whose colour no light changes (KHR_materials_unlit): the reference
    and the rasterizer show exactly the base colours (linear) wherever a box is seen face on."""
    from compare.mitsuba.reference import ReferenceRenderer
    from compare.progressive.rasterizer import render_progressive

    scene = load_scene(KHRONOS / "UnlitTest.toml").with_resolution(32, 32)
    colours = sorted(m.emission for m in scene.materials.values())
    assert len(colours) == 2
    for image in (ReferenceRenderer(scene, cache_dir=False, progress=False).render(16, seed=1).image,
                  render_progressive(scene, frames=4, seed=1, ctx=gl_ctx).image):
        pixels = image.reshape(-1, 3)
        for c in colours:  # a good share of the pixels is exactly that colour (up to float32 and filtering)
            near = np.abs(pixels - np.asarray(c)).max(1) < 2e-3
            assert near.mean() > 0.08, (c, near.mean())


def test_simple_instancing_is_a_grid_of_125_cubes():
    """SimpleInstancing: one cube drawn at 125 instance transforms whose translations form a 5 × 5 × 5 grid."""
    from compare.scene.gltf_read import load_gltf

    doc = load_gltf(KHRONOS / "SimpleInstancing" / "SimpleInstancing.glb")
    assert len(doc.primitives) == 125 and len({id(p.mesh) for p in doc.primitives}) == 1
    origins = np.array([p.matrix[:3, 3] for p in doc.primitives])
    for axis in range(3):  # five distinct positions along each axis, equally spaced
        steps = np.diff(np.unique(np.round(origins[:, axis], 4)))
        assert len(steps) == 4 and np.allclose(steps, steps[0], rtol=1e-4)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_morph_primitives_take_their_default_weights():
    """MorphPrimitivesTest: the morphed mesh differs from its base (the file's default weights are not 0)."""
    from compare.scene.gltf_read import load_gltf

    doc = load_gltf(KHRONOS / "MorphPrimitivesTest" / "MorphPrimitivesTest.glb")
    import json

    from compare.scene.glb import parse_glb

    raw, _ = parse_glb((KHRONOS / "MorphPrimitivesTest" / "MorphPrimitivesTest.glb").read_bytes())
    weights = [w for m in raw["meshes"] for w in m.get("weights", [])]
    assert any(w != 0 for w in weights), json.dumps(raw["meshes"])[:200]
    base = raw["accessors"][raw["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    lo, hi = np.array(base["min"]), np.array(base["max"])
    moved = np.concatenate([p.mesh.positions for p in doc.primitives])
    assert (moved.min(0) < lo - 1e-4).any() or (moved.max(0) > hi + 1e-4).any()
