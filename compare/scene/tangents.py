"""MikkTSpace tangents: the tangent frame glTF assumes for a normal map when a file gives no ``TANGENT``.

Normal maps are baked in the frame of the tool that made them, and the glTF specification names MikkTSpace
for files without tangents. Its reference implementation (Morten Mikkelsen's C code) decides where a
vertex splits and how corners are weighted; a re-derivation differs from it on curved charts. So the suite
calls the maintained build of that code, npm ``mikktspace`` (WebAssembly, the one glTF-Transform uses), once
per mesh, through ``web/mikktspace.cjs``, and keeps the result in the cache folder: every renderer (and the
job's glTF) gets these tangents, one definition for all.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np

from compare.util.errors import MissingComponentError
from compare.util.files import sha256_bytes, write_bytes_atomic

__all__ = ["mikktspace", "with_tangents"]

#: The script that runs the npm package, and the package's folder.
SCRIPT = Path(__file__).resolve().parents[2] / "web" / "mikktspace.cjs"
PACKAGE = SCRIPT.parent / "node_modules" / "mikktspace"
#: Part of the cache key: a new build of the package may split or weight differently.
VERSION = "mikktspace-1.1.1"


def _missing() -> str | None:
    if shutil.which("node") is None:
        return "Node.js is not installed (apt-get install nodejs)"
    if not PACKAGE.is_dir() or not SCRIPT.is_file():
        return f"the npm package mikktspace is not in {PACKAGE.parent} (scripts/suite.sh setup, or npm ci --prefix web)"
    return None


def _generate(p: np.ndarray, n: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Tangents (N, 4) of N unwelded corners, by the npm package."""
    why = _missing()
    if why:
        raise MissingComponentError(f"MikkTSpace tangents (a normal-mapped mesh without TANGENT) need {why}")
    count = np.array([len(p)], dtype="<u4").tobytes()
    payload = count + b"".join(np.ascontiguousarray(a, dtype="<f4").tobytes() for a in (p, n, uv))
    done = subprocess.run(["node", str(SCRIPT)], input=payload, capture_output=True, timeout=600, check=False)
    out = np.frombuffer(done.stdout, dtype="<f4")
    if done.returncode != 0 or out.size != 4 * len(p):
        raise MissingComponentError(f"MikkTSpace tangents: {SCRIPT.name} failed: "
                                    f"{done.stderr.decode(errors='replace').strip()[-500:]}")
    return out.reshape(-1, 4).astype(np.float32)


def mikktspace(positions, normals, uvs, indices, *, cache_dir: Path | None = None) -> tuple[np.ndarray, np.ndarray]:
    """MikkTSpace tangents of an indexed triangle mesh in glTF's convention (xyz along +u, ``w`` = ±1 such that
    ``cross(normal, xyz) * w`` is the bitangent, glTF's +v down the image).

    Returns ``(source, tangents)``: the welded mesh's vertex ``k`` copies input vertex ``source[k]`` and has
    tangent ``tangents[k]``; corners of one input vertex whose tangents differ become vertices of their own,
    as MikkTSpace splits them. The new indices are ``inverse`` of the corners: see :func:`with_tangents`.
    """
    corners = np.asarray(indices, dtype=np.int64).reshape(-1)
    p = np.asarray(positions, dtype=np.float32)[corners]
    n = np.asarray(normals, dtype=np.float32)[corners]
    uv = np.asarray(uvs, dtype=np.float32)[corners]
    key = sha256_bytes(VERSION, p.tobytes(), n.tobytes(), uv.tobytes())
    cached = None if cache_dir is None else Path(cache_dir) / "tangents" / f"{key}.npy"
    if cached is not None and cached.is_file():
        t = np.load(cached)
    else:
        t = _generate(p, n, uv)
        # MikkTSpace's bitangent points along +v of its texture space; glTF's v runs down the image.
        t[:, 3] = np.where(t[:, 3] < 0, 1.0, -1.0)
        if cached is not None:
            import io

            buf = io.BytesIO()
            np.save(buf, t)
            write_bytes_atomic(cached, buf.getvalue())
    return corners, t


def with_tangents(mesh, *, cache_dir: Path | None = None, texcoord: int = 0):
    """``mesh`` (a :class:`compare.scene.geometry.TriangleMesh`) with MikkTSpace tangents of its texture
    coordinate set ``texcoord`` (glTF: the normal map's), its vertices split where their corners' tangents
    differ; a mesh that has tangents (the file's ``TANGENT``) is returned as it is."""
    from compare.scene.geometry import TriangleMesh

    if mesh.tangents is not None:
        return mesh
    corners, t = mikktspace(mesh.positions, mesh.normals, mesh.uv_set(texcoord), mesh.indices, cache_dir=cache_dir)
    # weld: corners of one vertex with bit-identical tangents share a vertex again
    rows = np.concatenate([corners[:, None], t.view(np.int32).astype(np.int64)], axis=1)
    _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    src = corners[first]
    return TriangleMesh(mesh.positions[src], mesh.normals[src], mesh.uvs[src],
                        np.ascontiguousarray(inverse.reshape(-1, 3), dtype=np.uint32),
                        None if mesh.colors is None else mesh.colors[src], tangents=np.ascontiguousarray(t[first]),
                        uvs1=None if mesh.uvs1 is None else mesh.uvs1[src])
