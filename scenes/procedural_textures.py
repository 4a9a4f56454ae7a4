"""Deterministic material maps for the built-in scenes (written by ``scenes/generate.py``).

Every map is a numpy array made from fixed seeds: wood planks, ceramic tiles with
grout, speckled stone, a tyre tread, a car's paint with racing stripes, a round
badge with an alpha mask, and the texture-stress maps. Normal maps follow glTF:
tangent space, +X along increasing u (image right), +Y up the image, encoded
(n + 1) / 2. Maps that tile are periodic (their height fields are built with
periodic noise and differentiated with wrap-around).
"""

from __future__ import annotations

import io

import numpy as np

__all__ = ["badge", "height_to_normal", "leaves", "paint_stripes", "periodic_noise", "png_bytes", "ridges", "speckled_stone",
           "tiles", "tread", "wide_stripes", "wood"]


def png_bytes(image: np.ndarray) -> bytes:
    """An (H, W, 3 or 4) array in [0, 1] as 8-bit PNG bytes (values rounded, not dithered)."""
    from PIL import Image

    a = np.clip(np.rint(np.asarray(image, dtype=np.float64) * 255.0), 0, 255).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(a, "RGBA" if a.shape[2] == 4 else "RGB").save(buf, format="PNG", optimize=False,
                                                                   compress_level=9)
    return buf.getvalue()


def _srgb(linear) -> np.ndarray:
    from compare.image.tonemap import srgb_encode

    return srgb_encode(np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0))


def periodic_noise(h: int, w: int, cells: tuple[int, int], seed: int) -> np.ndarray:
    """Smooth value noise in [0, 1] that tiles: random values on a ``cells`` grid, interpolated with a
    smoothstep, wrapping at the borders."""
    rng = np.random.default_rng(seed)
    grid = rng.random(cells)
    y = (np.arange(h) + 0.5) / h * cells[0]
    x = (np.arange(w) + 0.5) / w * cells[1]
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = y - y0, x - x0
    sy, sx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
    a = grid[y0 % cells[0]][:, x0 % cells[1]]
    b = grid[y0 % cells[0]][:, (x0 + 1) % cells[1]]
    c = grid[(y0 + 1) % cells[0]][:, x0 % cells[1]]
    d = grid[(y0 + 1) % cells[0]][:, (x0 + 1) % cells[1]]
    top = a + (b - a) * sx[None, :]
    bottom = c + (d - c) * sx[None, :]
    return top + (bottom - top) * sy[:, None]


def height_to_normal(height: np.ndarray, strength: float) -> np.ndarray:
    """A glTF normal map (H, W, 3) in [0, 1] of a periodic height field (in texels × ``strength``)."""
    h = np.asarray(height, dtype=np.float64) * strength
    dx = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / 2.0
    d_up = -(np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) / 2.0  # rows run down; +Y is up the image
    n = np.stack([-dx, -d_up, np.ones_like(h)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return (n + 1.0) / 2.0


def wood(size: int = 256, *, seed: int = 1, tint=(0.42, 0.25, 0.13)) -> dict[str, np.ndarray]:
    """Plank wood with its grain along the image's columns (v): sRGB base colour, normal map (the grain's
    shallow grooves) and metallic-roughness map (pores rougher). Tiles in both directions."""
    streaks = periodic_noise(size, size, (4, 48), seed)  # long along v, narrow across u
    rings = 0.5 + 0.5 * np.sin(2 * np.pi * (np.arange(size)[None, :] / size * 9 + 1.6 * streaks))
    fine = periodic_noise(size, size, (64, 256), seed + 1)
    grain = 0.65 * rings + 0.35 * fine
    base = np.asarray(tint, dtype=np.float64)[None, None, :] * (0.7 + 0.6 * grain[..., None])
    normal = height_to_normal(-grain, 1.5)
    rough = 0.38 + 0.2 * fine
    mr = np.stack([np.zeros_like(rough), rough, np.zeros_like(rough)], axis=-1)
    return {"base": _srgb(base), "normal": normal, "mr": mr}


def tiles(size: int = 128, *, grout: float = 0.06, seed: int = 2) -> dict[str, np.ndarray]:
    """One square glazed tile with its grout border (tiles when repeated): sRGB base colour and normal
    map (grout recessed, a rounded bevel at the tile's edge)."""
    t = (np.arange(size) + 0.5) / size
    edge = np.minimum(np.minimum(t, 1 - t)[:, None], np.minimum(t, 1 - t)[None, :])  # distance to the border
    bevel = np.clip((edge - grout / 2) / (grout * 0.75), 0.0, 1.0)
    height = np.sin(bevel * np.pi / 2) * size * 0.02
    glaze = periodic_noise(size, size, (4, 4), seed)
    colour = np.where(bevel[..., None] > 0, np.array([0.82, 0.82, 0.79]) * (0.95 + 0.08 * glaze[..., None]),
                      np.array([0.32, 0.31, 0.29]))
    return {"base": _srgb(colour), "normal": height_to_normal(height, 1.0)}


def speckled_stone(size: int = 256, *, seed: int = 3) -> np.ndarray:
    """Dark polished stone with light speckles, sRGB base colour (tiles)."""
    rng = np.random.default_rng(seed)
    base = np.full((size, size, 3), 0.10) * (0.8 + 0.4 * periodic_noise(size, size, (16, 16), seed)[..., None])
    spots = rng.random((size, size)) > 0.985
    base[spots] = (0.45, 0.44, 0.42)
    return _srgb(base)


def tread(width: int = 64, length: int = 64) -> np.ndarray:
    """A tyre tread's normal map: u across the tread, v around the tyre; three circumferential grooves
    and chevron blocks, one block per map (repeat it along v)."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(length) + 0.5) / length
    uu, vv = np.meshgrid(u, v)  # rows: v
    height = np.ones_like(uu)
    for c in (0.3, 0.5, 0.7):
        height -= np.exp(-((uu - c) / 0.025) ** 2)
    chevron = np.abs(((vv + 0.8 * np.abs(uu - 0.5)) % 1.0) - 0.5)  # slanted sipes
    height -= 0.8 * np.exp(-(chevron / 0.05) ** 2) * (np.abs(uu - 0.5) > 0.22)
    return height_to_normal(np.clip(height, 0.0, 1.0), 6.0)


def paint_stripes(body_uvs: np.ndarray, body_positions: np.ndarray, *, size=(1024, 512),
                  paint=(0.03, 0.12, 0.45), stripe=(0.8, 0.8, 0.78), z_stripe=(0.07, 0.17),
                  u_range=(0.04, 0.985)) -> np.ndarray:
    """The car paint's sRGB base colour over the body's own UVs (u along the car, v around it): two
    racing stripes, bands of v that lie ``z_stripe`` metres either side of the centre line on the roof at
    mid-length (the body's position there read through the mesh, scattered linear interpolation), over
    ``u_range`` of its length. Bands of constant v follow the body's lofted sections smoothly."""
    from scipy.interpolate import griddata

    h, w = size
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    pos = griddata(body_uvs, body_positions, (np.full(h, 0.5), v), method="linear")
    z, y = np.nan_to_num(pos[:, 2]), np.nan_to_num(pos[:, 1], nan=-1.0)
    top = y > np.quantile(body_positions[:, 1], 0.55)
    rows = top & (np.abs(z) > z_stripe[0]) & (np.abs(z) < z_stripe[1])
    cols = (u > u_range[0]) & (u < u_range[1])
    band = rows[:, None] & cols[None, :]
    colour = np.where(band[..., None], np.asarray(stripe), np.asarray(paint))
    return _srgb(colour)


def badge(size: int = 128) -> np.ndarray:
    """A round badge, RGBA (sRGB colour, alpha 0 outside the disc): a silver ring around a red field with
    a white chevron."""
    t = (np.arange(size) + 0.5) / size * 2 - 1
    x, y = np.meshgrid(t, -t)  # y up the image
    r = np.hypot(x, y)
    colour = np.where((r > 0.8)[..., None], np.array([0.75, 0.75, 0.77]), np.array([0.55, 0.03, 0.03]))
    chevron = (np.abs(y - 0.6 * np.abs(x) + 0.15) < 0.12) & (np.abs(x) < 0.55)
    colour = np.where(chevron[..., None], np.array([0.9, 0.9, 0.9]), colour)
    alpha = (r <= 0.97).astype(np.float64)
    return np.concatenate([_srgb(colour), alpha[..., None]], axis=-1)


def ridges(size: int = 256, period: int = 2) -> np.ndarray:
    """A normal map of ridges ``period`` texels apart (the highest frequency a map can hold at 2), tilted
    about 45° on their flanks: the stress case of mipmapped normal maps seen at grazing angles."""
    x = np.arange(size)
    height = np.tile(np.where((x // max(period // 2, 1)) % 2 == 0, 0.0, 1.0)[None, :], (size, 1))
    return height_to_normal(height, 2.0)


def leaves(size: int = 256, *, count: int = 40, seed: int = 5) -> np.ndarray:
    """A foliage card, RGBA: random elliptical leaves (sRGB greens, alpha 1) on alpha 0."""
    rng = np.random.default_rng(seed)
    t = (np.arange(size) + 0.5) / size
    x, y = np.meshgrid(t, t)
    colour = np.zeros((size, size, 3))
    alpha = np.zeros((size, size))
    for _ in range(count):
        cx, cy = rng.uniform(0.12, 0.88, 2)
        a, b = rng.uniform(0.05, 0.11), rng.uniform(0.02, 0.04)
        th = rng.uniform(0, np.pi)
        dx, dy = x - cx, y - cy
        u, v = dx * np.cos(th) + dy * np.sin(th), -dx * np.sin(th) + dy * np.cos(th)
        inside = (u / a) ** 2 + (v / b) ** 2 <= 1.0
        colour[inside] = np.array([0.05, 0.25, 0.04]) * rng.uniform(0.6, 1.4)
        alpha[inside] = 1.0
    return np.concatenate([_srgb(colour), alpha[..., None]], axis=-1)


def wide_stripes(width: int = 8192, height: int = 4, period: int = 64) -> np.ndarray:
    """An sRGB map ``width`` texels wide (the largest size every renderer must take) of alternating
    light and dark stripes ``period`` texels wide."""
    x = np.arange(width)
    row = np.where((x // (period // 2)) % 2 == 0, 0.8, 0.1)
    return _srgb(np.repeat(np.tile(row[None, :], (height, 1))[..., None], 3, axis=2))
