"""EXT_mesh_gpu_instancing: one mesh drawn at many transforms (``gltfpack -mi``, forests, cities).

The reader expands a node's instances into parts that share the mesh's triangles (read once), each with its
own matrix, world = node's world · T · R · S of the instance, as the extension defines it. Every renderer then
draws them as it draws any part. The expansion is bounded: a file whose instances would make more than
:data:`MAX_INSTANCES` parts or :data:`MAX_INSTANCED_TRIANGLES` triangles is refused with one error naming the
node and the counts, before any instance is decoded, so that no file can exhaust memory.
"""

from __future__ import annotations

import numpy as np

__all__ = ["EXTENSION", "MAX_INSTANCED_TRIANGLES", "MAX_INSTANCES", "instance_matrices"]

EXTENSION = "EXT_mesh_gpu_instancing"
#: Parts the instances of one file may make: each is an object of every renderer's scene.
MAX_INSTANCES = 65536
#: Triangles they may make in all (each renderer holds them in world space).
MAX_INSTANCED_TRIANGLES = 1 << 24


def _quaternion_matrices(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations of unit quaternions (x, y, z, w), glTF's order."""
    q = q / np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-30)
    x, y, z, w = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], 1)


def instance_matrices(r, node: dict, where: str, mesh_triangles: int, budget: dict) -> np.ndarray | None:
    """The (n, 4, 4) matrices of ``node``'s instances (None: the node has none), from the extension's
    TRANSLATION, ROTATION and SCALE accessors (absent: identity). ``budget`` counts the parts and triangles
    of the file's instances so far (one error past the limits)."""
    ext = node.get("extensions", {}).get(EXTENSION)
    if ext is None:
        return None
    where = f"{where}.extensions.{EXTENSION}"
    attrs = ext.get("attributes") if isinstance(ext, dict) else None
    if not isinstance(attrs, dict) or not attrs:
        raise r.err(f"{where}.attributes", "expected TRANSLATION, ROTATION and/or SCALE accessors")
    unknown = sorted(set(attrs) - {"TRANSLATION", "ROTATION", "SCALE"})
    if unknown:
        r.notes.append(f"{where}.attributes: {', '.join(unknown)} not read (custom per-instance data)")
    counts = {k: r.item("accessors", attrs[k], f"{where}.attributes.{k}").get("count")
              for k in ("TRANSLATION", "ROTATION", "SCALE") if k in attrs}
    if len(set(counts.values())) != 1 or not all(isinstance(c, int) and c >= 1 for c in counts.values()):
        raise r.err(f"{where}.attributes", f"expected one positive count for every attribute, got {counts}")
    n = next(iter(counts.values()))
    budget["parts"] = budget.get("parts", 0) + n
    budget["triangles"] = budget.get("triangles", 0) + n * mesh_triangles
    if budget["parts"] > MAX_INSTANCES or budget["triangles"] > MAX_INSTANCED_TRIANGLES:
        raise r.err(where, f"{n} instances of {mesh_triangles} triangles: the file's instances would make "
                           f"{budget['parts']} parts and {budget['triangles']} triangles, over the limits of "
                           f"{MAX_INSTANCES} parts and {MAX_INSTANCED_TRIANGLES} triangles that keep every "
                           "renderer's memory bounded")
    m = np.tile(np.eye(4), (n, 1, 1))
    if "ROTATION" in attrs:
        q = r.accessor(attrs["ROTATION"], f"{where}.attributes.ROTATION")
        if q.shape[1] != 4 or not np.isfinite(q).all() or (np.linalg.norm(q, axis=1) < 1e-12).any():
            raise r.err(f"{where}.attributes.ROTATION", "expected finite, non-zero VEC4 quaternions")
        m[:, :3, :3] = _quaternion_matrices(q)
    if "SCALE" in attrs:
        s = r.accessor(attrs["SCALE"], f"{where}.attributes.SCALE")
        if s.shape[1] != 3 or not np.isfinite(s).all():
            raise r.err(f"{where}.attributes.SCALE", "expected finite VEC3 scales")
        m[:, :3, :3] = m[:, :3, :3] * s[:, None, :]
    if "TRANSLATION" in attrs:
        t = r.accessor(attrs["TRANSLATION"], f"{where}.attributes.TRANSLATION")
        if t.shape[1] != 3 or not np.isfinite(t).all():
            raise r.err(f"{where}.attributes.TRANSLATION", "expected finite VEC3 translations")
        m[:, :3, 3] = t
    return m
