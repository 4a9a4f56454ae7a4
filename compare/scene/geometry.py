"""Triangle meshes: primitives (quad, box, sphere, cylinder), PLY/OBJ files, transforms.

Every renderer consumes the same world-space triangle lists from here, so the
reference and the rasterizer see identical geometry. Normals are per vertex;
primitives have the exact analytic ones, files keep theirs or get
area-weighted vertex normals (faceted where a file gives none).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class TriangleMesh:
    """World-space triangles: positions (N,3), normals (N,3), uvs (N,2) float32; indices (M,3) uint32;
    colors (N,4) float32 or None: glTF's COLOR_0, linear RGBA multiplying the base colour and alpha;
    tangents (N,4) float32 or None: glTF's TANGENT (xyz along +u, w = ±1 the bitangent's sign), the file's
    or MikkTSpace's (:func:`compare.scene.tangents.with_tangents`); uvs1 (N,2) float32 or None: glTF's
    TEXCOORD_1, the second set a map may read (:attr:`compare.scene.model.MapSampling.texcoord`)."""

    positions: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray
    indices: np.ndarray
    colors: np.ndarray | None = None
    tangents: np.ndarray | None = None
    uvs1: np.ndarray | None = None

    @property
    def triangle_count(self) -> int:
        return int(self.indices.shape[0])

    def transformed(self, matrix: np.ndarray) -> "TriangleMesh":
        """Apply a 4×4 affine transform (normals by the inverse transpose, renormalised)."""
        m = np.asarray(matrix, dtype=np.float64)
        p = self.positions.astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        reach = float(np.max(np.abs(p))) if p.size else 0.0
        problem = world_range_problem(reach)
        if problem:
            raise MeshRangeError(f"its vertices reach {problem}")
        nm = np.linalg.inv(m[:3, :3]).T
        n = self.normals.astype(np.float64) @ nm.T
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        indices = self.indices
        mirrored = np.linalg.det(m[:3, :3]) < 0
        if mirrored:  # mirroring flips winding; keep faces front-facing
            indices = indices[:, ::-1].copy()
        tangents = None
        if self.tangents is not None:  # glTF: xyz by the node's linear part; a mirror flips the handedness
            t = self.tangents[:, :3].astype(np.float64) @ m[:3, :3].T
            t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-30)
            w = self.tangents[:, 3:4] * (-1.0 if mirrored else 1.0)
            tangents = np.concatenate([t, w], axis=1).astype(np.float32)
        return TriangleMesh(p.astype(np.float32), n.astype(np.float32), self.uvs, indices, self.colors, tangents,
                            self.uvs1)

    def uv_set(self, texcoord: int) -> np.ndarray:
        """Texture coordinate set ``texcoord`` (0: TEXCOORD_0, 1: TEXCOORD_1; zeros where the mesh has none)."""
        if texcoord == 0:
            return self.uvs
        return self.uvs1 if self.uvs1 is not None else np.zeros_like(self.uvs)

    def surface_area(self) -> float:
        p = self.positions.astype(np.float64)
        a, b, c = p[self.indices[:, 0]], p[self.indices[:, 1]], p[self.indices[:, 2]]
        return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def _mesh(p, n, uv, idx, colors=None, tangents=None, uv1=None) -> TriangleMesh:
    return TriangleMesh(
        np.ascontiguousarray(p, dtype=np.float32),
        np.ascontiguousarray(n, dtype=np.float32),
        np.ascontiguousarray(uv, dtype=np.float32),
        np.ascontiguousarray(idx, dtype=np.uint32).reshape(-1, 3),
        None if colors is None else np.ascontiguousarray(colors, dtype=np.float32),
        None if tangents is None else np.ascontiguousarray(tangents, dtype=np.float32),
        None if uv1 is None else np.ascontiguousarray(uv1, dtype=np.float32),
    )


def quad_from_corners(corners: np.ndarray) -> TriangleMesh:
    """A planar quad from four corners in counter-clockwise order seen from its front.

    The normal follows the right-hand rule on the corner order.
    """
    c = np.asarray(corners, dtype=np.float64).reshape(4, 3)
    n = np.cross(c[1] - c[0], c[2] - c[0])
    n /= np.linalg.norm(n)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64)
    return _mesh(c, np.tile(n, (4, 1)), uv, [[0, 1, 2], [0, 2, 3]])


def quad(size: tuple[float, float]) -> TriangleMesh:
    """A w×h quad in the XZ plane centred at the origin, normal +Y."""
    w, h = size[0] / 2, size[1] / 2
    return quad_from_corners(np.array([[-w, 0, h], [w, 0, h], [w, 0, -h], [-w, 0, -h]]))


def box(size: tuple[float, float, float]) -> TriangleMesh:
    """An axis-aligned box centred at the origin with outward faces (24 vertices, flat normals)."""
    sx, sy, sz = (s / 2 for s in size)
    faces = []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            u = np.zeros(3)
            u[(axis + 1) % 3] = 1.0
            v = np.cross(n, u)
            half = np.array([sx, sy, sz])
            centre = n * half
            du, dv = u * half, v * half
            faces.append(np.array([centre - du - dv, centre + du - dv, centre + du + dv, centre - du + dv]))
    ps, ns, uvs, idx = [], [], [], []
    for k, corners in enumerate(faces):
        q = quad_from_corners(corners)
        ps.append(q.positions)
        ns.append(q.normals)
        uvs.append(q.uvs)
        idx.append(q.indices + 4 * k)
    return _mesh(np.concatenate(ps), np.concatenate(ns), np.concatenate(uvs), np.concatenate(idx))


def sphere(radius: float, segments: int = 64, rings: int = 32) -> TriangleMesh:
    """A UV sphere centred at the origin with analytic normals."""
    theta = np.linspace(0.0, math.pi, rings + 1)
    phi = np.linspace(0.0, 2 * math.pi, segments + 1)
    t, f = np.meshgrid(theta, phi, indexing="ij")
    n = np.stack([np.sin(t) * np.cos(f), np.cos(t), -np.sin(t) * np.sin(f)], axis=-1).reshape(-1, 3)
    uv = np.stack([f / (2 * math.pi), 1 - t / math.pi], axis=-1).reshape(-1, 2)
    idx = []
    for i in range(rings):
        for j in range(segments):
            a = i * (segments + 1) + j
            b = a + segments + 1
            if i != 0:
                idx.append([a, b, a + 1])
            if i != rings - 1:
                idx.append([a + 1, b, b + 1])
    return _mesh(n * radius, n, uv, idx)


def cylinder(radius: float, height: float, segments: int = 64) -> TriangleMesh:
    """A capped cylinder along +Y centred at the origin (smooth side, flat caps)."""
    phi = np.linspace(0.0, 2 * math.pi, segments + 1)
    x, z = np.cos(phi), -np.sin(phi)
    h = height / 2
    side_p = np.concatenate([np.stack([x * radius, np.full_like(x, -h), z * radius], 1),
                             np.stack([x * radius, np.full_like(x, h), z * radius], 1)])
    side_n = np.concatenate([np.stack([x, 0 * x, z], 1)] * 2)
    side_uv = np.concatenate([np.stack([phi / (2 * math.pi), 0 * x], 1), np.stack([phi / (2 * math.pi), 0 * x + 1], 1)])
    m = segments + 1
    side_idx = [[j, j + 1, m + j + 1] for j in range(segments)] + [[j, m + j + 1, m + j] for j in range(segments)]
    parts = [(side_p, side_n, side_uv, np.array(side_idx))]
    for sign in (1.0, -1.0):
        ring = np.stack([x[:-1] * radius, np.full(segments, sign * h), z[:-1] * radius], 1)
        p = np.concatenate([[[0, sign * h, 0]], ring])
        n = np.tile([0, sign, 0], (segments + 1, 1))
        uv = np.concatenate([[[0.5, 0.5]], 0.5 + 0.5 * np.stack([x[:-1], z[:-1]], 1)])
        tris = [[0, 1 + j, 1 + (j + 1) % segments] for j in range(segments)]
        tris = np.array(tris) if sign > 0 else np.array(tris)[:, ::-1]
        parts.append((p, n, uv, tris))
    ps, ns, uvs, idx, off = [], [], [], [], 0
    for p, n, uv, tri in parts:
        ps.append(p)
        ns.append(n)
        uvs.append(uv)
        idx.append(tri + off)
        off += len(p)
    return _mesh(np.concatenate(ps), np.concatenate(ns), np.concatenate(uvs), np.concatenate(idx))


def vertex_normals(positions: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals; vertices touching only degenerate faces get +Y."""
    p = positions.astype(np.float64)
    a, b, c = p[indices[:, 0]], p[indices[:, 1]], p[indices[:, 2]]
    fn = np.cross(b - a, c - a)  # length = 2·area: area weighting for free
    n = np.zeros_like(p)
    for k in range(3):
        np.add.at(n, indices[:, k], fn)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    out = np.where(length > 1e-30, n / np.maximum(length, 1e-30), np.array([0.0, 1.0, 0.0]))
    return out.astype(np.float32)


class MeshFileError(ValueError):
    """A mesh file is unreadable; the scene loader prefixes the scene file and field."""


#: Largest world coordinate a mesh may reach: the renderers compute in float32, where squared
#: distances (and products of them) of larger coordinates overflow (float32's maximum is 3.4e38).
WORLD_LIMIT = 1e15


def world_bounds(matrix: np.ndarray, tri: TriangleMesh) -> tuple[np.ndarray, np.ndarray]:
    """World-space bounds of ``tri`` under ``matrix``: the transformed corners of its local bounds."""
    lo, hi = tri.positions.min(0).astype(np.float64), tri.positions.max(0).astype(np.float64)
    corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is the answer: infinite bounds
        world = corners @ np.asarray(matrix, dtype=np.float64).T
    return world[:, :3].min(0), world[:, :3].max(0)


def reach_problem(matrix: np.ndarray, tri: TriangleMesh) -> str | None:
    """:func:`world_range_problem` of ``tri``'s world coordinates under ``matrix`` (also when not finite)."""
    lo, hi = world_bounds(matrix, tri)
    reach = float(max(np.max(np.abs(lo)), np.max(np.abs(hi))))
    return world_range_problem(reach) if math.isfinite(reach) else "infinity (not finite)"


def world_range_problem(reach: float) -> str | None:
    """Why a coordinate of magnitude ``reach`` is out of :data:`WORLD_LIMIT` (None if it is not, NaN is)."""
    if reach <= WORLD_LIMIT:
        return None
    return (f"{reach:.3g}, beyond ±{WORLD_LIMIT:g}: the renderers compute in float32, where squared distances "
            "of such coordinates overflow")


class MeshRangeError(ValueError):
    """A mesh's vertices leave the range the renderers can compute in (:data:`WORLD_LIMIT`)."""


def load_obj(path: Path) -> TriangleMesh:
    """Read a Wavefront OBJ file (:func:`_load_obj`); anything malformed is one :class:`MeshFileError` naming it."""
    try:
        return _load_obj(path)
    except MeshFileError:
        raise
    except (ValueError, IndexError, KeyError, TypeError, OverflowError, struct.error) as exc:
        # the parser names the line or element it knows to go wrong; any other malformation ends here
        raise MeshFileError(f"{path}: malformed OBJ file ({type(exc).__name__}: {exc})") from None


#: A face's corner in each of OBJ's four forms (positive indices), for the whole-file reader.
_OBJ_CORNER = {0: rb"\d+", 1: rb"\d+/\d+", 2: rb"\d+/\d+/\d+", 3: rb"\d+//\d+"}


def _obj_at_once(data: bytes) -> TriangleMesh | None:
    """An OBJ file read with whole-file regular expressions and numpy, no Python loop per face: for files
    whose faces all use one corner form with positive indices in range, single-spaced (what exporters
    write). None for any other file: :func:`_load_obj` then reads it line by line and names a bad line."""
    import re

    data = data.replace(b"\r\n", b"\n")
    num = rb"(\S+)"
    v = re.findall(rb"^v[ \t]+" + num + rb"[ \t]+" + num + rb"[ \t]+" + num, data, re.M)
    vt = re.findall(rb"^vt[ \t]+" + num + rb"[ \t]+" + num, data, re.M)
    vn = re.findall(rb"^vn[ \t]+" + num + rb"[ \t]+" + num + rb"[ \t]+" + num, data, re.M)
    counts = [len(re.findall(rb"^" + k + rb"[ \t]", data, re.M)) for k in (b"v", b"vt", b"vn")]
    faces = re.findall(rb"^f[ \t]+([^\n#]*?)[ \t]*$", data, re.M)
    if [len(v), len(vt), len(vn)] != counts or not faces or not v:
        return None
    joined = b" ".join(faces)
    first = joined.split(b" ", 1)[0]
    form = 3 if b"//" in first else first.count(b"/")
    if form not in _OBJ_CORNER or not re.fullmatch(rb"(?:" + _OBJ_CORNER[form] + rb" )*" + _OBJ_CORNER[form], joined):
        return None
    fields = {0: 1, 1: 2, 2: 3, 3: 2}[form]
    corners = np.array(joined.replace(b"//", b" ").replace(b"/", b" ").split(), dtype=np.int64).reshape(-1, fields) - 1
    sizes = np.char.count(np.array(faces), b" ") + 1
    if sizes.min() < 3 or sizes.sum() != len(corners):
        return None
    pos = np.array(v, dtype=np.float64)
    tex = np.array(vt, dtype=np.float64) if vt else np.zeros((0, 2))
    nor = np.array(vn, dtype=np.float64) if vn else np.zeros((0, 3))
    vi = corners[:, 0]
    ti = corners[:, 1] if form in (1, 2) else None
    ni = corners[:, 2] if form == 2 else corners[:, 1] if form == 3 else None
    for index, table in ((vi, pos), (ti, tex), (ni, nor)):
        if index is not None and (index.min() < 0 or index.max() >= len(table)):
            return None
    # one output vertex per distinct (position, texture, normal) corner, as the line reader welds them
    key = np.stack([vi, ti if ti is not None else np.zeros_like(vi), ni if ni is not None else np.zeros_like(vi)], 1)
    unique, inverse = np.unique(key, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    # fan each face (k corners: k - 2 triangles) about its first corner, faces of one size at a time
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    tris = []
    for k in np.unique(sizes):  # a handful of polygon sizes, not one pass per face
        s = starts[sizes == k]
        fan = np.arange(1, k - 1)
        tris.append(np.stack([np.repeat(s[:, None], len(fan), 1), s[:, None] + fan, s[:, None] + fan + 1], -1))
    order = np.concatenate([t.reshape(-1, 3) for t in tris])
    # triangles in file order, as the line reader makes them
    order = order[np.argsort(order[:, 0], kind="stable")]
    idx = inverse[order]
    p = pos[unique[:, 0]]
    if not np.all(np.isfinite(p)):
        return None
    uv = tex[unique[:, 1]] if ti is not None else np.zeros((len(unique), 2))
    n = nor[unique[:, 2]] if ni is not None else vertex_normals(p, idx)
    return _mesh(p, n, uv, idx)


def _load_obj(path: Path) -> TriangleMesh:
    """Read a Wavefront OBJ (v, vt, vn, f with any of v, v/t, v//n, v/t/n; polygons fanned)."""
    try:
        fast = _obj_at_once(path.read_bytes())
    except (OSError, ValueError):
        fast = None  # the line reader below says what is wrong
    if fast is not None:
        return fast
    pos, tex, nor = [], [], []
    out_p, out_t, out_n, idx = [], [], [], []
    cache: dict[tuple, int] = {}
    has_n = True
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise MeshFileError(f"cannot read OBJ file {path}: {exc}") from exc
    for lineno, line in enumerate(text.splitlines(), 1):
        parts = line.split()
        if not parts or parts[0].startswith("#"):
            continue
        try:
            if parts[0] == "v":
                pos.append([float(x) for x in parts[1:4]])
            elif parts[0] == "vt":
                tex.append([float(x) for x in parts[1:3]])
            elif parts[0] == "vn":
                nor.append([float(x) for x in parts[1:4]])
            elif parts[0] == "f":
                corners = []
                for tok in parts[1:]:
                    fields = (tok.split("/") + ["", ""])[:3]
                    vi = _obj_index(fields[0], len(pos))
                    ti = _obj_index(fields[1], len(tex)) if fields[1] else None
                    ni = _obj_index(fields[2], len(nor)) if fields[2] else None
                    has_n = has_n and ni is not None
                    key = (vi, ti, ni)
                    if key not in cache:
                        cache[key] = len(out_p)
                        out_p.append(pos[vi])
                        out_t.append(tex[ti] if ti is not None else [0.0, 0.0])
                        out_n.append(nor[ni] if ni is not None else [0.0, 0.0, 0.0])
                    corners.append(cache[key])
                if len(corners) < 3:
                    raise ValueError("a face needs at least three vertices")
                idx.extend([corners[0], corners[k], corners[k + 1]] for k in range(1, len(corners) - 1))
        except (ValueError, IndexError) as exc:
            raise MeshFileError(f"{path}:{lineno}: malformed OBJ line {line.strip()!r}: {exc}") from exc
    if not idx:
        raise MeshFileError(f"{path}: OBJ file has no faces")
    p = np.array(out_p, dtype=np.float64)
    i = np.array(idx, dtype=np.int64)
    n = np.array(out_n, dtype=np.float64) if has_n else vertex_normals(p, i)
    if not np.all(np.isfinite(p)):
        raise MeshFileError(f"{path}: OBJ file has non-finite vertex positions")
    return _mesh(p, n, np.array(out_t), i)


def _obj_index(token: str, count: int) -> int:
    k = int(token)
    k = k - 1 if k > 0 else count + k  # OBJ is 1-based; negatives count from the end
    if not 0 <= k < count:
        raise ValueError(f"index {token} out of range (1..{count})")
    return k


def load_ply(path: Path) -> TriangleMesh:
    """Read a PLY file (:func:`_load_ply`); anything malformed is one :class:`MeshFileError` naming it."""
    try:
        return _load_ply(path)
    except MeshFileError:
        raise
    except (ValueError, IndexError, KeyError, TypeError, OverflowError, struct.error) as exc:
        # the parser names the line or element it knows to go wrong; any other malformation ends here
        raise MeshFileError(f"{path}: malformed PLY file ({type(exc).__name__}: {exc})") from None


def _load_ply(path: Path) -> TriangleMesh:
    """Read a PLY file (ascii or binary little/big endian): x y z, optional nx ny nz, u v / s t, faces."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MeshFileError(f"cannot read PLY file {path}: {exc}") from exc
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise MeshFileError(f"{path}: not a PLY file (no 'ply' magic or no 'end_header')")
    header = data[:end].decode("ascii", errors="replace").splitlines()
    body = data[data.index(b"\n", end) + 1:]
    fmt, elements = None, []
    for line in header:
        w = line.split()
        if not w:
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            elements.append([w[1], int(w[2]), []])
        elif w[0] == "property" and elements:
            elements[-1][2].append(w[1:])
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise MeshFileError(f"{path}: unsupported PLY format {fmt!r}")
    types = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
             "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
             "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
    endian = ">" if fmt == "binary_big_endian" else "<"
    verts, faces = None, None
    try:
        if fmt == "ascii":
            tokens = body.split()
            pos = 0
            for name, count, props in elements:
                if props and props[0][0] == "list":
                    k = int(tokens[pos]) if count else 0
                    try:
                        block = np.array(tokens[pos:pos + (1 + k) * count], dtype=np.int64) if count else None
                    except ValueError:  # not all integers: lists of other lengths, read one by one below
                        block = None
                    if block is not None and len(block) == (1 + k) * count and \
                            np.all(block.reshape(count, 1 + k)[:, 0] == k):
                        rows = block.reshape(count, 1 + k)[:, 1:]  # every list as long: all at once
                        pos += (1 + k) * count
                    else:  # lists of different lengths: each one's length says where the next starts
                        rows = []
                        for _ in range(count):
                            k = int(tokens[pos])
                            rows.append([int(t) for t in tokens[pos + 1:pos + 1 + k]])
                            pos += 1 + k
                    if name == "face":
                        faces = rows
                else:
                    n = len(props)
                    arr = np.array(tokens[pos:pos + n * count], dtype=np.float64).reshape(count, n)
                    pos += n * count
                    if name == "vertex":
                        verts = {p[-1]: arr[:, j] for j, p in enumerate(props)}
        else:
            off = 0
            for name, count, props in elements:
                if props and props[0][0] == "list":
                    ct, it = endian + types[props[0][1]], endian + types[props[0][2]]
                    k = int(np.frombuffer(body, ct, 1, off)[0]) if count else 0
                    uniform = np.dtype([("n", ct), ("v", it, (k,))]) if count else None
                    block = (np.frombuffer(body, uniform, count, off)
                             if count and off + uniform.itemsize * count <= len(body) else None)
                    if block is not None and np.all(block["n"] == k):
                        rows = block["v"].astype(np.int64)  # every list as long (triangles): all at once
                        off += uniform.itemsize * count
                    else:  # lists of different lengths: each one's length says where the next starts
                        rows = []
                        for _ in range(count):
                            k = int(np.frombuffer(body, ct, 1, off)[0])
                            off += np.dtype(ct).itemsize
                            rows.append(np.frombuffer(body, it, k, off).astype(np.int64).tolist())
                            off += k * np.dtype(it).itemsize
                    if name == "face":
                        faces = rows
                else:
                    dt = np.dtype([(p[-1], endian + types[p[0]]) for p in props])
                    arr = np.frombuffer(body, dt, count, off)
                    off += dt.itemsize * count
                    if name == "vertex":
                        verts = {k: arr[k].astype(np.float64) for k in dt.names}
    except (ValueError, KeyError, IndexError) as exc:
        raise MeshFileError(f"{path}: truncated or malformed PLY body: {exc}") from exc
    if verts is None or faces is None or not all(k in verts for k in "xyz"):
        raise MeshFileError(f"{path}: PLY file needs a vertex element with x, y, z and a face element")
    p = np.stack([verts["x"], verts["y"], verts["z"]], 1)
    if isinstance(faces, np.ndarray):  # all faces of k corners: a fan of k - 2 triangles each, at once
        if faces.shape[1] < 3 or (faces.size and (faces.max() >= len(p) or faces.min() < 0)):
            bad = faces[(faces.max(1) >= len(p)) | (faces.min(1) < 0)][0] if faces.size and faces.shape[1] >= 3 \
                else faces[0] if len(faces) else []
            raise MeshFileError(f"{path}: PLY face {list(map(int, bad))} is invalid for {len(p)} vertices")
        fan = np.arange(1, faces.shape[1] - 1)
        i = np.stack([np.repeat(faces[:, :1], len(fan), 1), faces[:, fan], faces[:, fan + 1]], -1).reshape(-1, 3)
    else:
        idx = []
        for f in faces:
            if len(f) < 3 or max(f) >= len(p) or min(f) < 0:
                raise MeshFileError(f"{path}: PLY face {f} is invalid for {len(p)} vertices")
            idx.extend([f[0], f[k], f[k + 1]] for k in range(1, len(f) - 1))
        i = np.array(idx, dtype=np.int64)
    if all(k in verts for k in ("nx", "ny", "nz")):
        n = np.stack([verts["nx"], verts["ny"], verts["nz"]], 1)
    else:
        n = vertex_normals(p, i)
    uk = ("u", "v") if "u" in verts else ("s", "t") if "s" in verts else None
    uv = np.stack([verts[uk[0]], verts[uk[1]]], 1) if uk else np.zeros((len(p), 2))
    if not np.all(np.isfinite(p)):
        raise MeshFileError(f"{path}: PLY file has non-finite vertex positions")
    return _mesh(p, n, uv, i)


def transform_matrix(translate=(0.0, 0.0, 0.0), rotate=(0.0, 0.0, 0.0), scale=(1.0, 1.0, 1.0)) -> np.ndarray:
    """4×4 matrix T·Rz·Ry·Rx·S (rotations in degrees, applied X first, then Y, then Z)."""
    rx, ry, rz = (math.radians(a) for a in rotate)
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    m = np.eye(4)
    m[:3, :3] = Rz @ Ry @ Rx @ np.diag(scale)
    m[:3, 3] = translate
    return m


def ray_cast(origins: np.ndarray, directions: np.ndarray, tris: np.ndarray, *, chunk: int = 256,
             t_max: np.ndarray | float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """Closest hit (Möller–Trumbore) of rays (R, 3) against triangles (T, 3, 3).

    Returns the distance (inf for a miss) and the triangle index (−1) per ray.
    Hits farther than ``t_max`` count as misses.
    """
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    best_t = np.full(len(o), np.inf)
    best_i = np.full(len(o), -1)
    t_max = np.broadcast_to(np.asarray(t_max, dtype=np.float64), (len(o),))
    for start in range(0, len(tris), chunk):
        v0, v1, v2 = (tris[start:start + chunk, i][None] for i in range(3))
        e1, e2 = v1 - v0, v2 - v0
        p = np.cross(d[:, None], e2)
        det = np.sum(e1 * p, axis=-1)
        ok = np.abs(det) > 1e-14
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o[:, None] - v0
        u = np.sum(s * p, axis=-1) * inv
        q = np.cross(s, e1)
        v = np.sum(d[:, None] * q, axis=-1) * inv
        t = np.sum(e2 * q, axis=-1) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 1e-7) & (t < t_max[:, None])
        t = np.where(hit, t, np.inf)
        j = np.argmin(t, axis=1)
        tj = t[np.arange(len(o)), j]
        closer = tj < best_t
        best_t = np.where(closer, tj, best_t)
        best_i = np.where(closer, start + j, best_i)
    return best_t, best_i
