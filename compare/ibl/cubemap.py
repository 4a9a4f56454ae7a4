"""Cube maps with a 1-texel border: face frames, texel directions, solid angles, lookups.

Faces and their frames
----------------------
Six faces in the order +X, −X, +Y, −Y, +Z, −Z. Face ``f`` has a major axis
``A_f`` and two in-face axes ``U_f`` (grows with the column) and ``V_f`` (grows
with the row); a face coordinate (s, t) in [−1, 1]² is the direction
``normalize(A + s·U + t·V)``. The frames are OpenGL's cube-map table
(``sc``/``tc`` of the GL spec, section "Cube Map Texture Selection"), so a
face array could be uploaded to a ``GL_TEXTURE_CUBE_MAP`` unchanged, with row
0 at t = −1. (The seeds' remark that cube maps are "left-handed" is this
table: seen from inside, +X's U axis is −Z.) The rasterizer does not use GL cube
textures, though: it reads faces from a 2D atlas (:mod:`compare.ibl.atlas`), so
every level of the prefiltered chain can be uploaded with the GL 3.3 API and
the lookup is the same code in GLSL and numpy.

Border
------
Every face array is stored with a one-texel border: shape (6, S+2, S+2, 3),
interior texel k at index k+1, centred on s = (2k + 1)/S − 1. The border texels
hold the function at their own direction, which lies just beyond the face
edge, on the neighbouring face. Bilinear lookups then never cross a face
boundary and are seamless without GL's seamless-cube-map filtering.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "FACE_AXES",
    "face_coordinates",
    "pad_from_interior",
    "padded_directions",
    "sample_faces",
    "texel_solid_angles",
]

#: (A, U, V) of each face: direction = A + s·U + t·V (OpenGL's cube-map table).
FACE_AXES = np.array([
    [[1, 0, 0], [0, 0, -1], [0, -1, 0]],    # +X
    [[-1, 0, 0], [0, 0, 1], [0, -1, 0]],    # -X
    [[0, 1, 0], [1, 0, 0], [0, 0, 1]],      # +Y
    [[0, -1, 0], [1, 0, 0], [0, 0, -1]],    # -Y
    [[0, 0, 1], [1, 0, 0], [0, -1, 0]],     # +Z
    [[0, 0, -1], [-1, 0, 0], [0, -1, 0]],   # -Z
], dtype=np.float64)


def padded_directions(size: int, *, padded: bool = True, sub: int = 1) -> np.ndarray:
    """Unit directions of the texel centres of a cube with faces ``size``², shape (6, P, P, [sub²,] 3).

    ``padded`` includes the one-texel border (P = size + 2), otherwise P = size.
    ``sub`` > 1 gives sub × sub directions spread evenly over each texel's
    square (for supersampling), as an extra axis before the last.
    """
    k = np.arange(-1, size + 1) if padded else np.arange(size)
    o = (np.arange(sub) + 0.5) / sub - 0.5  # offsets within a texel, in texels
    s = (2.0 * (k[:, None] + 0.5 + o[None, :]) / size - 1.0)  # (P, sub)
    ss = s[None, :, None, :, None]   # column -> U
    tt = s[:, None, None, None, :]   # row    -> V
    ss, tt = np.broadcast_arrays(ss, tt)  # (P, P, 1, sub, sub)
    ss = ss.reshape(len(k), len(k), sub * sub)
    tt = tt.reshape(len(k), len(k), sub * sub)
    a, u, v = FACE_AXES[:, 0], FACE_AXES[:, 1], FACE_AXES[:, 2]
    d = (a[:, None, None, None, :] + ss[None, ..., None] * u[:, None, None, None, :]
         + tt[None, ..., None] * v[:, None, None, None, :])
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d[..., 0, :] if sub == 1 else d


def face_coordinates(d) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Face index and face coordinates (s, t) in [−1, 1] of directions (..., 3)."""
    d = np.asarray(d)
    ad = np.abs(d)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ax, ay, az = ad[..., 0], ad[..., 1], ad[..., 2]
    # Ties: x before y before z, as in the GLSL.
    use_x = (ax >= ay) & (ax >= az)
    use_y = ~use_x & (ay >= az)
    use_z = ~use_x & ~use_y
    face = np.where(use_x, np.where(x >= 0, 0, 1), np.where(use_y, np.where(y >= 0, 2, 3), np.where(z >= 0, 4, 5)))
    ma = np.where(use_x, ax, np.where(use_y, ay, az))
    # s, t from the table FACE_AXES: s = d·U / ma, t = d·V / ma.
    sc = np.where(use_x, np.where(x >= 0, -z, z), np.where(use_y, x, np.where(z >= 0, x, -x)))
    tc = np.where(use_x | use_z, -y, np.where(y >= 0, z, -z))
    return face, sc / ma, tc / ma


def bilinear_faces(faces: np.ndarray, face: np.ndarray, s: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Bilinear lookup in a padded level (6, S+2, S+2, C) at face coordinates (from :func:`face_coordinates`)."""
    size = faces.shape[1] - 2
    p = size + 2
    flat = faces.reshape(-1, faces.shape[-1])
    # Continuous index in the padded array: interior texel k (index k+1) is centred at s = (2k+1)/S - 1.
    x = np.clip((s + 1) * (0.5 * size) + 0.5, 0, size + 1)
    y = np.clip((t + 1) * (0.5 * size) + 0.5, 0, size + 1)
    xf = np.minimum(np.floor(x), size)
    yf = np.minimum(np.floor(y), size)
    fx = (x - xf)[..., None]  # stays in the dtype of s, t (float32 keeps memory traffic low)
    fy = (y - yf)[..., None]
    i00 = (face * p + yf.astype(np.int32)) * p + xf.astype(np.int32)
    top = np.take(flat, i00, axis=0)
    top += (np.take(flat, i00 + 1, axis=0) - top) * fx
    bottom = np.take(flat, i00 + p, axis=0)
    bottom += (np.take(flat, i00 + p + 1, axis=0) - bottom) * fx
    top += (bottom - top) * fy
    return top


def sample_faces(faces: np.ndarray, d) -> np.ndarray:
    """Bilinear lookup in one padded cube level (6, S+2, S+2, C) towards directions (..., 3)."""
    return bilinear_faces(faces, *face_coordinates(d))


def pad_from_interior(interior: np.ndarray) -> np.ndarray:
    """Padded faces (6, S+2, S+2, C) from interior faces (6, S, S, C).

    Border texels are bilinear lookups of the neighbouring faces' interiors
    (clamped to their edge texels), at the border texels' own directions.
    """
    size = interior.shape[1]
    tmp = np.zeros((6, size + 2, size + 2) + interior.shape[3:], dtype=np.float64)
    tmp[:, 1:-1, 1:-1] = interior
    # Fill the border by clamping first, so that a lookup of the interior never reads zeros.
    tmp[:, 0, 1:-1] = interior[:, 0]
    tmp[:, -1, 1:-1] = interior[:, -1]
    tmp[:, :, 0] = tmp[:, :, 1]
    tmp[:, :, -1] = tmp[:, :, -2]
    d = padded_directions(size)
    border = np.ones((size + 2, size + 2), dtype=bool)
    border[1:-1, 1:-1] = False
    out = tmp.copy()
    for f in range(6):
        dirs = d[f][border]
        face, s, t = face_coordinates(dirs)
        # Clamp to the neighbour's interior texel centres so the lookup uses interior texels only.
        lim = 1.0 - 1.0 / size
        x = (np.clip(s, -lim, lim) + 1.0) * 0.5 * size + 0.5
        y = (np.clip(t, -lim, lim) + 1.0) * 0.5 * size + 0.5
        x0 = np.minimum(np.floor(x).astype(np.int64), size - 1)
        y0 = np.minimum(np.floor(y).astype(np.int64), size - 1)
        fx = (x - x0)[..., None]
        fy = (y - y0)[..., None]
        top = tmp[face, y0, x0] * (1 - fx) + tmp[face, y0, x0 + 1] * fx
        bottom = tmp[face, y0 + 1, x0] * (1 - fx) + tmp[face, y0 + 1, x0 + 1] * fx
        out[f][border] = top * (1 - fy) + bottom * fy
    return out.astype(interior.dtype, copy=False)


def texel_solid_angles(size: int) -> np.ndarray:
    """Exact solid angle of every interior texel of a cube face (size, size); they sum to 4π/6 per face."""
    edges = np.linspace(-1.0, 1.0, size + 1)
    x, y = np.meshgrid(edges, edges)
    area = np.arctan2(x * y, np.sqrt(x * x + y * y + 1.0))
    return area[1:, 1:] - area[:-1, 1:] - area[1:, :-1] + area[:-1, :-1]


def downsample(interior: np.ndarray) -> np.ndarray:
    """Half-size interior faces (6, S/2, S/2, C): solid-angle-weighted 2×2 means."""
    size = interior.shape[1]
    w = texel_solid_angles(size)[None, :, :, None]
    half = size // 2
    wx = (interior * w).reshape(6, half, 2, half, 2, -1).sum(axis=(2, 4))
    ww = w.reshape(1, half, 2, half, 2, 1).sum(axis=(2, 4))
    return wx / ww
