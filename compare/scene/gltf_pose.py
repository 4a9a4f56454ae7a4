"""A glTF mesh in the pose its file gives it without animation, for :mod:`compare.scene.gltf_read`.

Morph targets
    At their default weights (a node's ``weights``, else its mesh's, else zeros): each morphed
    attribute is its base value plus Σᵢ wᵢ · targetᵢ.
Skins
    Posed by their joints' node transforms: each vertex moves by the blend
    Σⱼ wⱼ · (global transform of joint j · its inverse bind matrix), normals by that blend's
    inverse transpose, tangents by its linear part; the skinned mesh's own node transform does not
    apply. The blend equals the unskinned mesh only where the joints' transforms undo the inverse
    bind matrices.

Applying both in the reader gives every renderer the same triangles. The array functions check
through ``err(field, message)``, the reader's error naming the file and the JSON path; the functions
that read the file take the reader itself.
"""

from __future__ import annotations

import math

import numpy as np

from compare.scene import geometry

__all__ = ["MORPHED", "check_joints", "check_weights", "joint_matrices", "morph_deltas", "morph_weights",
           "normalised_weights", "posed_parts", "skin", "skin_matrices", "skinned"]

#: The attributes a morph target displaces that the reader reads, with the components each delta has.
MORPHED = {"POSITION": (3,), "NORMAL": (3,), "TANGENT": (3,), "TEXCOORD_0": (2,), "COLOR_0": (3, 4)}
#: A vertex's skin weights may sum to 1 within this before the reader says it renormalised them (glTF: 1
#: within the quantisation of the weights' component type; 8-bit weights miss by a few 1/255).
WEIGHT_SUM_TOLERANCE = 1e-2


def joint_matrices(worlds: np.ndarray, inverse_binds: np.ndarray) -> np.ndarray:
    """Per joint, its global transform times its inverse bind matrix: (J, 4, 4)."""
    return np.asarray(worlds, dtype=np.float64) @ np.asarray(inverse_binds, dtype=np.float64)


def check_joints(joints: np.ndarray, count: int, where: str, err) -> np.ndarray:
    """A JOINTS_n accessor's (N, 4) values as joint indices, each an integer in [0, ``count``)."""
    if joints.ndim != 2 or joints.shape[1] != 4:
        raise err(where, f"expected VEC4 joint indices, got {joints.shape[1] if joints.ndim == 2 else 1} components")
    bad = ~np.isfinite(joints) | (joints != np.round(joints)) | (joints < 0) | (joints >= count)
    if bad.any():
        v, c = np.argwhere(bad)[0]
        raise err(where, f"{int(bad.any(1).sum())} vertices name a joint that is not an index into the skin's "
                         f"{count} joints (first: vertex {v}, component {c}: {joints[v, c]:g})")
    return joints.astype(np.int64)


def check_weights(weights: np.ndarray, where: str, err) -> np.ndarray:
    """A WEIGHTS_n accessor's (N, 4) values, each finite and at least 0."""
    if weights.ndim != 2 or weights.shape[1] != 4:
        raise err(where, f"expected VEC4 weights, got {weights.shape[1] if weights.ndim == 2 else 1} components")
    bad = ~np.isfinite(weights) | (weights < 0)
    if bad.any():
        v, c = np.argwhere(bad)[0]
        raise err(where, f"{int(bad.any(1).sum())} vertices have a weight that is negative or not finite (first: "
                         f"vertex {v}, component {c}: {weights[v, c]:g})")
    return weights


def normalised_weights(weights: np.ndarray, where: str, err) -> tuple[np.ndarray, float]:
    """The vertices' weights of every set (N, K) divided by their sum, and the largest |sum − 1| before;
    a vertex whose weights sum to 0 belongs to no joint and is one error."""
    total = weights.sum(axis=1)
    zero = ~(total > 0)
    if zero.any():
        raise err(where, f"{int(zero.sum())} vertices have weights summing to 0 (first: vertex "
                         f"{int(np.flatnonzero(zero)[0])}): no joint places them")
    return weights / total[:, None], float(np.abs(total - 1.0).max(initial=0.0))


def _cofactors(a: np.ndarray) -> np.ndarray:
    """The cofactor matrices of (N, 3, 3) matrices: det(A) · A⁻ᵀ, defined for singular ones too."""
    r0, r1, r2 = a[:, 0], a[:, 1], a[:, 2]
    return np.stack([np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)], axis=1)


def skin(positions: np.ndarray, normals: np.ndarray | None, tangents: np.ndarray | None, joints: np.ndarray,
         weights: np.ndarray, matrices: np.ndarray):
    """Skinned (positions, normals, tangents, mirrored) of N vertices.

    ``joints`` (N, K) indices into ``matrices`` (J, 4, 4) (:func:`joint_matrices`), ``weights`` (N, K)
    summing to 1. Normals go by the inverse transpose of each vertex's blended matrix (zero where it is
    singular, for the reader to repair), tangents (N, 4) by its linear part with w negated where it
    mirrors; ``mirrored`` (N,) says where its determinant is negative. Normals and tangents come back
    unnormalised.
    """
    m = np.zeros((len(positions), 4, 4))
    for k in range(joints.shape[1]):  # one influence at a time: (N, 4, 4) at most, not (N, K, 4, 4)
        m += weights[:, k, None, None] * matrices[joints[:, k]]
    a = m[:, :3, :3]
    p = np.einsum("vij,vj->vi", a, positions) + m[:, :3, 3]
    det = np.linalg.det(a)
    n = None
    if normals is not None:
        # inverse transpose = cofactors / det: the cofactors times det's sign keep the direction and stay
        # defined (zero) where the blend collapses
        n = np.einsum("vij,vj->vi", _cofactors(a), normals) * np.sign(det)[:, None]
    t = None
    if tangents is not None:
        t = np.concatenate([np.einsum("vij,vj->vi", a, tangents[:, :3]),
                            tangents[:, 3:4] * np.where(det < 0, -1.0, 1.0)[:, None]], axis=1)
    return p, n, t, det < 0


# ----------------------------------------------------------------------------- read from the file
# ``r`` is the reader (compare.scene.gltf_read): its item, accessor, err and notes.


def morph_weights(r, mi: int, mesh: dict, index: int, node: dict) -> tuple[float, ...]:
    """The weights of mesh ``mi``'s morph targets on node ``index``: the node's ``weights``, else the
    mesh's, else zeros (glTF); one per target, finite, and every primitive with as many targets."""
    counts = []
    for k, prim in enumerate(mesh.get("primitives", [])):
        targets = prim.get("targets", [])
        if not isinstance(targets, list):
            raise r.err(f"meshes[{mi}].primitives[{k}].targets", f"expected a list, got {targets!r}")
        counts.append(len(targets))
        if counts[k] != counts[0]:
            raise r.err(f"meshes[{mi}].primitives[{k}].targets",
                        f"{counts[k]} morph targets, but primitives[0] has {counts[0]} (glTF: the same for each)")
    n = counts[0] if counts else 0
    owner, where = (node, f"nodes[{index}].weights") if "weights" in node else (mesh, f"meshes[{mi}].weights")
    v = owner.get("weights", [0.0] * n)
    if (not isinstance(v, list) or len(v) != n
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v)):
        raise r.err(where, f"expected {n} finite numbers, one per morph target of meshes[{mi}], got {v!r}")
    return tuple(float(x) for x in v)


def skin_matrices(r, si: int, where: str, worlds: dict[int, np.ndarray]) -> np.ndarray:
    """Skin ``si``'s joint matrices (J, 4, 4): each joint's world transform (``worlds``, the nodes of the
    default scene) times its inverse bind matrix (identity without ``inverseBindMatrices``)."""
    skin = r.item("skins", si, where)
    w = f"skins[{si}]"
    joints = skin.get("joints")
    if not isinstance(joints, list) or not joints:
        raise r.err(f"{w}.joints", f"expected a non-empty list of node indices, got {joints!r}")
    for j, node in enumerate(joints):
        r.item("nodes", node, f"{w}.joints[{j}]")
        if node not in worlds:
            raise r.err(f"{w}.joints[{j}]", f"node {node} is not in the default scene (a joint poses the mesh "
                                            "by its transform in the scene)")
    if "inverseBindMatrices" in skin:
        where = f"{w}.inverseBindMatrices"
        m = r.accessor(skin["inverseBindMatrices"], where)
        if m.shape[1] != 16:
            raise r.err(where, f"expected MAT4 matrices, got {m.shape[1]} components")
        if len(m) < len(joints):
            raise r.err(where, f"{len(m)} matrices for the skin's {len(joints)} joints")
        if not np.isfinite(m).all():
            raise r.err(where, "NaN or infinite matrix elements")
        inverse_binds = m[:len(joints)].reshape(-1, 4, 4).transpose(0, 2, 1)  # glTF's matrices are column-major
    else:
        inverse_binds = np.broadcast_to(np.eye(4), (len(joints), 4, 4))
    return joint_matrices(np.stack([worlds[j] for j in joints]), inverse_binds)


def morph_deltas(r, prim: dict, w: str, nv: int, weights: tuple) -> dict[str, np.ndarray]:
    """Σᵢ weightᵢ · targetᵢ of each attribute the targets displace (MORPHED), over the targets
    of non-zero weight; every target's accessors are checked to hold one element per vertex."""
    out: dict[str, np.ndarray] = {}
    for i, (target, weight) in enumerate(zip(prim.get("targets", []), weights)):  # counts: morph_weights
        if not isinstance(target, dict):
            raise r.err(f"{w}.targets[{i}]", f"expected an object of attribute accessors, got {target!r}")
        for attr, index in target.items():
            where = f"{w}.targets[{i}].{attr}"
            count = r.item("accessors", index, where).get("count")
            if count != nv:
                raise r.err(where, f"{count!r} elements, but the primitive's POSITION has {nv} (a morph "
                                   "target displaces every vertex)")
            if weight == 0.0 or attr not in MORPHED:
                continue
            d = r.accessor(index, where)
            if d.shape[1] not in MORPHED[attr]:
                raise r.err(where, f"expected {' or '.join(f'VEC{c}' for c in MORPHED[attr])} "
                                   f"displacements, got {d.shape[1]} components")
            if not np.isfinite(d).all():
                raise r.err(where, "NaN or infinite displacements")
            if attr == "COLOR_0" and d.shape[1] == 3:  # an RGB displacement leaves alpha
                d = np.concatenate([d, np.zeros((nv, 1))], axis=1)
            out[attr] = out.get(attr, 0.0) + weight * d
    return out


def skinned(r, attrs: dict, w: str, nv: int, matrices: np.ndarray, p, n, tangents):
    """:func:`skin` of a primitive (``w`` its JSON path) by its JOINTS_n / WEIGHTS_n sets, each checked; a note
    where the weights' sums miss 1 by more than :data:`WEIGHT_SUM_TOLERANCE` (they are renormalised)."""
    if "JOINTS_0" not in attrs or "WEIGHTS_0" not in attrs:
        raise r.err(f"{w}.attributes", "its node has a skin, but the primitive has no JOINTS_0 and WEIGHTS_0 "
                                       "(the joints that move each vertex)")
    sets = sorted({int(key.split("_", 1)[1]) for key in attrs
                   if key.startswith(("JOINTS_", "WEIGHTS_")) and key.split("_", 1)[1].isdigit()})
    joints, weights = [], []
    for s in sets:
        jw, ww = f"{w}.attributes.JOINTS_{s}", f"{w}.attributes.WEIGHTS_{s}"
        if f"JOINTS_{s}" not in attrs or f"WEIGHTS_{s}" not in attrs:
            raise r.err(f"{w}.attributes", f"JOINTS_{s} and WEIGHTS_{s} come in pairs; one is missing")
        j, wt = r.accessor(attrs[f"JOINTS_{s}"], jw), r.accessor(attrs[f"WEIGHTS_{s}"], ww)
        for values, where in ((j, jw), (wt, ww)):
            if len(values) != nv:
                raise r.err(where, f"{len(values)} elements for {nv} vertices")
        joints.append(check_joints(j, len(matrices), jw, r.err))
        weights.append(check_weights(wt, ww, r.err))
    where = f"{w}.attributes.WEIGHTS_0" + (f"…{sets[-1]}" if len(sets) > 1 else "")
    blend, off = normalised_weights(np.concatenate(weights, axis=1), where, r.err)
    if off > WEIGHT_SUM_TOLERANCE:
        r.notes.append(f"{where}: skin weights summing to 1 ± {off:.3g}, renormalised")
    return skin(p, n, tangents, np.concatenate(joints, axis=1), blend, matrices)


def posed_parts(r, parts: list, worlds: dict[int, np.ndarray]) -> list[tuple]:
    """(name, TriangleMesh, matrix, material index) of each primitive of the mesh nodes ``parts`` ((node,
    name, world matrix, mesh) in the scene's order): morphed at the node's weights and, for a node with a
    skin, posed by its joints (``worlds``: every node of the default scene) in the glTF's world space, with
    the identity as its matrix (glTF: a skinned mesh's own node transform does not apply)."""
    out: list[tuple] = []
    made: dict[tuple, list] = {}
    skins: dict[int, np.ndarray] = {}
    for index, name, world, mi in parts:
        node = r.item("nodes", index, "nodes")
        mesh = r.item("meshes", mi, f"nodes[{index}].mesh")
        weights = morph_weights(r, mi, mesh, index, node)
        si = node.get("skin")
        if si is not None and si not in skins:
            skins[si] = skin_matrices(r, si, f"nodes[{index}].skin", worlds)
        key = (mi, weights, si)  # a mesh is read once per pose
        if key not in made:
            made[key] = [(k, r.primitive(mi, k, p, weights, None if si is None else skins[si]), p.get("material"))
                         for k, p in enumerate(mesh.get("primitives", []))]
        matrix = world if si is None else np.eye(4)
        prims = made[key]
        for k, tri, mat in prims:
            if tri is not None:
                problem = geometry.reach_problem(matrix, tri)  # at load: for inspect too
                if problem:
                    raise r.err(f"nodes[{index}] (mesh {mi}, primitive {k})", f"its vertices reach {problem}")
                out.append((name if len(prims) == 1 else f"{name}.{k}", tri, matrix, mat))
    return out
