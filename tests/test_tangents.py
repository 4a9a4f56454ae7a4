"""Tangent frames of normal maps: the file's TANGENT when it has one, else MikkTSpace's (npm mikktspace, one
definition for every renderer), written into the job's glTF."""

from __future__ import annotations

import json

import numpy as np
import pytest

from compare.scene import geometry
from compare.scene.tangents import with_tangents
from compare.util.errors import MissingComponentError, SceneError
from tests.helpers import facing_scene


def uv_tangents(positions, normals, uvs, indices) -> np.ndarray:
    """Per-vertex tangents (N, 4) for normal maps, glTF's convention: xyz along increasing u, and w = ±1
    such that ``cross(normal, xyz) * w`` points up the image (towards decreasing v: glTF's v runs down
    the image, and its normal maps have +Y up).

    Each triangle's dp/du and dp/dv (from its UVs) are summed at its vertices, area-weighted by the
    unnormalised derivatives, then made orthogonal to the vertex normal (Gram–Schmidt). For the planar,
    affinely mapped charts of the built-in meshes this is what MikkTSpace (the tangents glTF assumes when
    a file has none) gives; on curved charts it can differ from MikkTSpace by its weighting. A vertex
    without usable UV derivatives gets any tangent orthogonal to its normal.
    """
    p = np.asarray(positions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    uv = np.asarray(uvs, dtype=np.float64)
    tri = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
    e1, e2 = p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]
    d1, d2 = uv[tri[:, 1]] - uv[tri[:, 0]], uv[tri[:, 2]] - uv[tri[:, 0]]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    ok = np.abs(det) > 1e-20
    r = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    dpdu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r
    dpdv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r
    t = np.zeros_like(p)
    b = np.zeros_like(p)
    for k in range(3):
        np.add.at(t, tri[:, k], dpdu)
        np.add.at(b, tri[:, k], dpdv)
    t = t - n * np.sum(n * t, axis=1, keepdims=True)
    length = np.linalg.norm(t, axis=1)
    # no UV derivatives: any direction orthogonal to the normal
    fallback = np.cross(n, np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]]))
    t = np.where((length > 1e-20)[:, None], t / np.maximum(length, 1e-300)[:, None], fallback)
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    w = np.where(np.sum(np.cross(n, t) * -b, axis=1) < 0.0, -1.0, 1.0)
    return np.concatenate([t, w[:, None]], axis=1).astype(np.float32)


def _same_vertex_tangents(mesh, welded):
    """Each welded vertex's tangent against the closed form of the planar, affinely mapped built-in charts:
    dp/du along the surface, and w from the v direction (uv_tangents states the convention)."""
    expect = uv_tangents(mesh.positions, mesh.normals, mesh.uvs, mesh.indices)
    # a welded vertex copies a source vertex with the same position, normal and uv
    src = [int(np.flatnonzero((np.abs(mesh.positions - p).max(1) < 1e-7) & (np.abs(mesh.normals - n).max(1) < 1e-7)
                              & (np.abs(mesh.uvs - uv).max(1) < 1e-7))[0])
           for p, n, uv in zip(welded.positions, welded.normals, welded.uvs)]
    return np.abs(welded.tangents - expect[src]).max()


@pytest.mark.npm("mikktspace")
@pytest.mark.parametrize("make", [lambda: geometry.quad((2.0, 1.0)), lambda: geometry.box((1.0, 2.0, 3.0))])
def test_mikktspace_matches_the_closed_form_on_planar_charts(make):
    mesh = make()
    welded = with_tangents(mesh)
    assert welded.triangle_count == mesh.triangle_count
    assert np.isin(welded.tangents[:, 3], (-1.0, 1.0)).all()
    assert _same_vertex_tangents(mesh, welded) < 1e-5
    # every triangle keeps its corners' positions
    assert np.allclose(welded.positions[welded.indices], mesh.positions[mesh.indices])


@pytest.mark.npm("mikktspace")
def test_a_mirrored_chart_splits_and_flips_the_sign():
    """Two quads sharing an edge, the second's u mirrored: the shared vertices split, and the w differ."""
    p = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], dtype=np.float32)
    n = np.tile([[0, 0, 1]], (6, 1)).astype(np.float32)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0], [0, 1], [0, 0]], dtype=np.float32)  # u runs back on the right
    idx = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]], dtype=np.uint32)
    welded = with_tangents(geometry._mesh(p, n, uv, idx))
    assert len(welded.positions) == 8  # vertices 1 and 2 split
    left = welded.tangents[welded.indices[0]]
    right = welded.tangents[welded.indices[2]]
    assert np.allclose(left[:, :3], [1, 0, 0], atol=1e-6) and np.allclose(right[:, :3], [-1, 0, 0], atol=1e-6)
    assert (left[:, 3] == 1.0).all() and (right[:, 3] == -1.0).all()  # glTF: +v down the image, +y up


def test_without_node_the_error_says_how_to_install(monkeypatch):
    monkeypatch.setattr("compare.scene.tangents.shutil.which", lambda name: None)
    with pytest.raises(MissingComponentError, match=r"^MikkTSpace tangents \(a normal-mapped mesh without TANGENT\) "
                                                     r"need Node.js is not installed"):
        with_tangents(geometry.quad((1.0, 1.0)))


def test_a_mirroring_transform_flips_the_tangent_sign():
    mesh = geometry.quad((1.0, 1.0))
    t = np.tile([[1.0, 0.0, 0.0, 1.0]], (4, 1)).astype(np.float32)
    mesh = geometry._mesh(mesh.positions, mesh.normals, mesh.uvs, mesh.indices, tangents=t)
    moved = mesh.transformed(np.diag([-2.0, 1.0, 1.0, 1.0]))
    assert np.allclose(moved.tangents, [[-1.0, 0.0, 0.0, -1.0]] * 4)
    assert np.allclose(mesh.transformed(np.diag([3.0, 1.0, 1.0, 1.0])).tangents, t)


def _card(folder, tangent=None):
    """A glTF card facing +Z with a normal map, and ``tangent`` (4 × 4) as its TANGENT if given."""
    from compare.scene.gltf_write import GltfWriter
    from compare.image.pillow import Image

    Image.fromarray(np.full((4, 4, 3), (128, 128, 255), np.uint8)).save(folder / "n.png")
    w = GltfWriter()
    mat = w.material("card", (0.8, 0.8, 0.8), 0.0, 1.0)
    w.doc.setdefault("images", []).append({"uri": "n.png"})
    w.doc.setdefault("textures", []).append({"source": 0})
    w.doc["materials"][mat]["normalTexture"] = {"index": 0}
    pos = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=np.float32)
    attrs = {"POSITION": w.accessor(pos, bounds=True), "NORMAL": w.accessor(np.tile([[0, 0, 1]], (4, 1)).astype(np.float32)),
             "TEXCOORD_0": w.accessor(np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=np.float32))}
    if tangent is not None:
        attrs["TANGENT"] = w.accessor(np.asarray(tangent, dtype=np.float32))
    idx = w.accessor(np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32), indices=True)
    w._add("meshes", {"name": "card", "primitives": [{"attributes": attrs, "indices": idx, "material": mat}]})  # noqa: SLF001
    w.node("card", mesh=0)
    return w.write(folder / "card.gltf")


SCENE = facing_scene("card.gltf", distance=3.0, size=(8, 8))

def _scene(tmp_path, tangent=None):
    from compare.scene.loader import load_scene

    _card(tmp_path, tangent)
    (tmp_path / "s.toml").write_text(SCENE, encoding="utf-8")
    return load_scene(tmp_path / "s.toml")


def test_the_files_tangents_are_read_and_kept(tmp_path):
    """A file's TANGENT wins over any derivation: here deliberately rotated 90° from dp/du."""
    given = [[0.0, 1.0, 0.0, -1.0]] * 4
    scene = _scene(tmp_path, given)
    (mesh,) = scene.meshes
    assert np.allclose(mesh.triangles(tangents=True).tangents, given)


@pytest.mark.parametrize("tangent, message", [
    ([[1.0, 0.0, 0.0, 0.5]] * 4, "w must be 1 or -1"),
    ([[0.0, 0.0, 0.0, 1.0]] * 4, "4 zero-length tangents"),
])
def test_bad_tangents_are_one_error_naming_the_field(tmp_path, tangent, message):
    with pytest.raises(SceneError, match=rf"meshes\[0\]\.primitives\[0\]\.attributes\.TANGENT.*{message}"):
        _scene(tmp_path, tangent)


@pytest.mark.npm("mikktspace")
def test_the_jobs_gltf_carries_the_tangents(tmp_path):
    from compare.renderers.job import export_gltf

    scene = _scene(tmp_path)
    doc = json.loads(export_gltf(scene, tmp_path / "job" / "scene.gltf").read_text(encoding="utf-8"))
    (prim,) = doc["meshes"][0]["primitives"]
    assert "TANGENT" in prim["attributes"]
    assert doc["accessors"][prim["attributes"]["TANGENT"]]["type"] == "VEC4"
