"""EXT_mesh_gpu_instancing: a node's instances are parts of their own (world = node · T · R · S), sharing the
mesh's triangles; a file whose instances would exhaust memory is refused before any is decoded."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.scene.gltf_read import GltfError, load_gltf
from compare.scene.gltf_instancing import MAX_INSTANCES


def _instanced(folder, translation, rotation=None, scale=None, *, node_translation=(0.0, 0.0, 0.0), count=None):
    """A one-triangle mesh on a node with EXT_mesh_gpu_instancing (``count`` overrides the accessors' counts,
    as a file that claims more instances than it holds)."""
    from compare.scene.gltf_write import GltfWriter

    w = GltfWriter()
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    attrs = {"POSITION": w.accessor(pos, bounds=True),
             "NORMAL": w.accessor(np.tile([[0, 0, 1]], (3, 1)).astype(np.float32))}
    w._add("meshes", {"name": "tri", "primitives": [{"attributes": attrs}]})  # noqa: SLF001
    inst = {"TRANSLATION": w.accessor(np.asarray(translation, np.float32))}
    if rotation is not None:
        inst["ROTATION"] = w.accessor(np.asarray(rotation, np.float32))
    if scale is not None:
        inst["SCALE"] = w.accessor(np.asarray(scale, np.float32))
    if count is not None:
        for a in inst.values():
            w.doc["accessors"][a]["count"] = count
    node = w.node("forest", mesh=0)
    w.doc["nodes"][node]["translation"] = list(node_translation)
    w.doc["nodes"][node]["extensions"] = {"EXT_mesh_gpu_instancing": {"attributes": inst}}
    w._use("EXT_mesh_gpu_instancing")  # noqa: SLF001
    w.doc.setdefault("extensionsRequired", []).append("EXT_mesh_gpu_instancing")
    return w.write(folder / "forest.gltf")


def test_each_instance_is_a_part_at_its_transform(tmp_path):
    half = math.sqrt(0.5)
    doc = load_gltf(_instanced(tmp_path, [[0, 0, 0], [5, 0, 0], [0, 0, -3]],
                               rotation=[[0, 0, 0, 1], [0, 0, half, half], [0, 0, 0, 1]],
                               scale=[[1, 1, 1], [1, 1, 1], [2, 2, 2]], node_translation=(10.0, 0.0, 0.0)))
    assert len(doc.primitives) == 3
    assert doc.primitives[0].mesh is doc.primitives[1].mesh  # the triangles are read once
    world = [(p.matrix[:3, :3] @ p.mesh.positions.T).T + p.matrix[:3, 3] for p in doc.primitives]
    np.testing.assert_allclose(world[0], [[10, 0, 0], [11, 0, 0], [10, 1, 0]], atol=1e-6)
    np.testing.assert_allclose(world[1], [[15, 0, 0], [15, 1, 0], [14, 0, 0]], atol=1e-6)  # 90° about +z
    np.testing.assert_allclose(world[2], [[10, 0, -3], [12, 0, -3], [10, 2, -3]], atol=1e-6)
    assert doc.extension_fates()["EXT_mesh_gpu_instancing"] == "read"


def test_a_million_instances_are_refused_before_any_is_decoded(tmp_path):
    """The file claims 10^6 instances (its accessors' counts): one error naming the node and the counts."""
    path = _instanced(tmp_path, [[0, 0, 0]], count=1_000_000)
    with pytest.raises(GltfError, match=r"nodes\[0\]\.extensions\.EXT_mesh_gpu_instancing: 1000000 instances of 1 "
                                        rf"triangles: .* over the limits of {MAX_INSTANCES} parts"):
        load_gltf(path)


@pytest.mark.parametrize("rotation, message", [([[0, 0, 0, 0]], "non-zero VEC4 quaternions"),
                                               ([[0, 0, 0, float("nan")]], "finite, non-zero VEC4")])
def test_bad_instances_are_one_error_naming_the_field(tmp_path, rotation, message):
    with pytest.raises(GltfError, match=rf"EXT_mesh_gpu_instancing\.attributes\.ROTATION: .*{message}"):
        load_gltf(_instanced(tmp_path, [[0, 0, 0]], rotation=rotation))
