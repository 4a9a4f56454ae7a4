"""Radiance ``.hdr`` (RGBE) files: read and write float32 RGB.

Written here rather than taken from a library: the format is a page of code, and the
readers at hand (imageio's FreeImage plug-in) are an optional binary download that a
bare machine lacks.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from compare.util.errors import ImageError
from compare.util.files import atomic_path

__all__ = ["read_hdr", "write_hdr"]


_HDR_RES = re.compile(rb"^-Y (\d+) \+X (\d+)$")


def read_hdr(path: str | Path) -> np.ndarray:
    """Read a Radiance RGBE (``.hdr``) file as float32 (H, W, 3) linear RGB.

    Supports flat and run-length-encoded scanlines in the standard orientation
    ``-Y H +X W`` (row 0 at the top). Pixels decode as ``m · 2^(e − 136)``
    (no half-step offset), the convention of Bruce Walter's rgbe.c, which is
    what Mitsuba's ``Bitmap`` reads (tested), so that both renderers see the
    same radiance.

    Raises
    ------
    ImageError
        Naming the file, for a missing or malformed file or another orientation.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ImageError(f"{path}: cannot read: {exc}") from exc
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise ImageError(f"{path}: not a Radiance .hdr file (expected '#?RADIANCE' at the start)")
    pos = 0
    fmt = None
    while True:
        end = data.find(b"\n", pos)
        if end < 0:
            raise ImageError(f"{path}: truncated header")
        line = data[pos:end].strip()
        pos = end + 1
        if not line:
            break
        if line.startswith(b"FORMAT="):
            fmt = line[7:]
    if fmt not in (None, b"32-bit_rle_rgbe"):
        raise ImageError(f"{path}: unsupported pixel format {fmt!r} (only 32-bit_rle_rgbe)")
    end = data.find(b"\n", pos)
    m = _HDR_RES.match(data[pos:end].strip()) if end >= 0 else None
    if m is None:
        raise ImageError(f"{path}: unsupported resolution line {data[pos:end][:40]!r} (only '-Y H +X W')")
    h, w = int(m.group(1)), int(m.group(2))
    pos = end + 1
    # Each row is at least 4 bytes (an RLE header) and each channel's run covers at most 127 pixels in
    # 2 bytes, so a header claiming more pixels than that is corrupt: refuse it before allocating.
    room = len(data) - pos
    if h < 1 or w < 1 or 4 * h + h * 4 * 2 * math.ceil(w / 127) > room:
        raise ImageError(f"{path}: the header claims {w}×{h} pixels, more than the file's {room} bytes of pixel "
                         "data can hold (corrupt or truncated)")
    buf = np.frombuffer(data, dtype=np.uint8)
    out = np.empty((h, w, 4), dtype=np.uint8)
    try:
        for row in range(h):
            rle = (8 <= w < 32768 and pos + 4 <= len(buf) and buf[pos] == 2 and buf[pos + 1] == 2
                   and not (buf[pos + 2] & 0x80) and (int(buf[pos + 2]) << 8 | int(buf[pos + 3])) == w)
            if not rle:
                out[row] = buf[pos:pos + 4 * w].reshape(w, 4)
                pos += 4 * w
                continue
            pos += 4
            for c in range(4):
                x = 0
                line = out[row, :, c]
                while x < w:
                    count = int(buf[pos])
                    pos += 1
                    if count > 128:
                        count -= 128
                        line[x:x + count] = buf[pos]
                        pos += 1
                    else:
                        line[x:x + count] = buf[pos:pos + count]
                        pos += count
                    x += count
    except (ValueError, IndexError) as exc:
        raise ImageError(f"{path}: truncated or corrupt pixel data ({exc})") from exc
    from compare.image.encodings import rgbe_decode

    return rgbe_decode(out).astype(np.float32)


def write_hdr(path: str | Path, image: np.ndarray) -> Path:
    """Write float (H, W, 3) as a Radiance ``.hdr`` (flat scanlines, atomically); returns the path."""
    from compare.image.encodings import rgbe_encode

    path = Path(path)
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ImageError(f"{path}: expected an (H, W, 3) image, got shape {img.shape}")
    h, w = img.shape[:2]
    head = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()
    with atomic_path(path) as tmp:
        tmp.write_bytes(head + rgbe_encode(img).tobytes())
    return path
