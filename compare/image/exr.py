"""OpenEXR reading and writing with typed metadata, through the OpenEXR 3.x Python API.

Every HDR image the suite keeps (references, renderer outputs, caches) is an
EXR written by :func:`write_exr` and read back by :func:`read_exr`.

Metadata
--------
Metadata is a flat ``dict[str, str | int | float]``. Each entry becomes a custom
header attribute named ``compare:<key>`` (e.g. ``compare:renderer``,
``compare:spp``): the prefix keeps our keys apart from the standard attributes
(``owner``, ``comments``, ``capDate``...) and from other tools' keys, and reads
naturally in ``exrheader`` output. :func:`read_exr` returns only the
``compare:`` attributes, with the prefix removed. Every file also records
``compare_version`` (:data:`compare.__version__`) of the code that wrote it.

Types survive the round trip:

* ``str`` → string attribute.
* ``int`` → 32-bit int attribute when it fits; larger ints (e.g. a uint32
  Mitsuba seed) are stored as decimal strings and their keys listed in the
  string-vector attribute ``compare:_int_as_string``, so they read back as
  ``int``.
* ``float`` → **double** attribute. The binding stores a plain Python float as
  a 32-bit float attribute (0.1 reads back as 0.10000000149...), so floats are
  passed as one-element float64 arrays, which it maps to ``double``.
* ``bool``, ``None`` and anything else are refused: OpenEXR would store a
  bool as int 1 and hand back an int, and ``None`` has no attribute type.
  Convert explicitly (``int(flag)``, ``str(x)``).

Surprises in the OpenEXR 3.5 binding that this module works around
------------------------------------------------------------------
* Pixel arrays that are not C-contiguous (a transposed or strided view) are
  written **silently scrambled**; every array is made contiguous first.
* Ints outside int32 wrap or become 0 without an error; floats lose precision.
* A truncated file does not raise on open: the binding prints a warning to
  stdout, drops the damaged part, and the next access fails with
  ``ValueError: Invalid part index '0': file has 0 parts``. That warning is
  captured and put into the :class:`~compare.util.errors.ImageError`.
* ``File.__exit__`` empties the dicts that ``header()`` and ``channels()``
  returned (the pixel arrays survive): everything is copied out inside the
  ``with`` block.
* Channels of mixed pixel types cannot be coalesced into an "RGB" array, so
  channels are always read separately and stacked here.
* The C library also prints its own diagnostics to stderr for damaged files;
  those cannot be captured from Python and are harmless.
"""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path
from typing import Any

import numpy as np
import OpenEXR

from compare import __version__
from compare.util.errors import ImageError
from compare.util.files import atomic_path
from compare.image.checks import check_finite, check_rgb

__all__ = ["METADATA_PREFIX", "read_exr", "write_exr"]

#: Prefix of every header attribute that carries suite metadata.
METADATA_PREFIX = "compare:"

# Lists the keys whose string values are ints too wide for an int attribute.
_WIDE_INTS = METADATA_PREFIX + "_int_as_string"
_INT32 = (-(2**31), 2**31 - 1)
_HALF_MAX = float(np.finfo(np.float16).max)  # 65504
_F32_MAX = float(np.finfo(np.float32).max)
_EXR_MAGIC = b"\x76\x2f\x31\x01"
# EXR attribute names may be up to 255 bytes (with the long-names flag, which
# the library sets by itself when needed).
_MAX_NAME = 255

MetadataValue = str | int | float


def _encode_metadata(metadata: dict[str, Any] | None) -> dict[str, Any]:
    md = dict(metadata or {})
    # Overwritten, not refused, so that metadata read from one file can be
    # passed straight to write_exr: the new file records the code writing it.
    md["compare_version"] = __version__
    attrs: dict[str, Any] = {}
    wide: list[str] = []
    for key, value in md.items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"metadata keys must be non-empty strings, got {key!r}")
        if key.startswith("_"):
            raise ValueError(f"metadata key {key!r}: keys starting with '_' are reserved for the EXR writer")
        name = METADATA_PREFIX + key
        if len(name.encode("utf-8")) > _MAX_NAME:
            raise ValueError(f"metadata key {key!r} is too long for an EXR attribute name (max {_MAX_NAME - len(METADATA_PREFIX)} bytes)")
        if isinstance(value, (bool, np.bool_)):
            raise ValueError(f"metadata[{key!r}]: bool is not stored faithfully by OpenEXR; pass int({value!r}) or a string")
        if isinstance(value, str):
            attrs[name] = str(value)
        elif isinstance(value, (int, np.integer)):
            v = int(value)
            if _INT32[0] <= v <= _INT32[1]:
                attrs[name] = v
            else:
                attrs[name] = str(v)
                wide.append(key)
        elif isinstance(value, (float, np.floating)):
            # One-element float64 array -> DoubleAttribute (a bare float would
            # be narrowed to a 32-bit float attribute).
            attrs[name] = np.array([float(value)], dtype=np.float64)
        else:
            raise ValueError(
                f"metadata[{key!r}]: unsupported type {type(value).__name__}; use str, int or float"
            )
    if wide:
        attrs[_WIDE_INTS] = wide
    return attrs


def _decode_metadata(header: dict[str, Any], path: Path) -> dict[str, MetadataValue]:
    wide = header.get(_WIDE_INTS, [])
    if isinstance(wide, str):  # a single-element vector written by another tool
        wide = [wide]
    out: dict[str, MetadataValue] = {}
    for name, value in header.items():
        if not name.startswith(METADATA_PREFIX) or name == _WIDE_INTS:
            continue
        key = name[len(METADATA_PREFIX):]
        if key in wide:
            try:
                value = int(value)
            except (TypeError, ValueError) as e:
                raise ImageError(f"{path}: metadata {name} should hold an integer, got {value!r}") from e
        elif isinstance(value, np.ndarray) and value.size == 1:
            value = value.reshape(()).item()  # DoubleAttribute comes back as array([x])
        elif isinstance(value, np.generic):
            value = value.item()
        out[key] = value
    return out


def write_exr(
    path: str | os.PathLike,
    image,
    *,
    metadata: dict[str, MetadataValue] | None = None,
    half: bool = False,
    alpha=None,
) -> Path:
    """Write a linear RGB image to an OpenEXR file, atomically, with metadata.

    Parameters
    ----------
    path : str or os.PathLike
        Destination. Parent folders are created. The file is written to a
        temporary ``.exr`` beside it and renamed into place, so readers never
        see a half-written file and a failure leaves nothing behind.
    image : array_like, shape (H, W, 3)
        Linear RGB, finite, any real dtype (stored as float32, or float16 with
        ``half=True``).
    metadata : dict, optional
        ``str``/``int``/``float`` values, stored as ``compare:<key>`` header
        attributes (see the module notes). ``compare_version`` is always set to
        the writing code's version.
    half : bool, optional
        Store 16-bit half floats (half the size; about 3 significant digits,
        range ±65504). Default float32, which round-trips bit-exactly.
    alpha : array_like, shape (H, W), optional
        An ``A`` channel beside R, G, B (a texture's alpha), stored like them.

    Returns
    -------
    pathlib.Path
        The written path.

    Raises
    ------
    ImageError
        If the image is not (H, W, 3), holds NaN/Inf (count and first location
        in the message), exceeds the storage type's range, or cannot be written.
    ValueError
        For unsupported metadata keys or values.

    Notes
    -----
    Channels are named R, G, B (and A; readable by any EXR tool); compression is ZIP
    (lossless, 16 scanlines per block); storage is scanline, single part.
    """
    path = Path(path)
    a = check_rgb(image, f"{path}")
    check_finite(a, f"image for {path}")
    attrs = _encode_metadata(metadata)  # validate before touching the disk

    dtype = np.float16 if half else np.float32
    limit = _HALF_MAX if half else _F32_MAX
    if a.dtype != dtype:
        peak = float(np.max(np.abs(a), initial=0.0))
        if peak > limit:
            raise ImageError(
                f"{path}: largest magnitude {peak:g} exceeds the {np.dtype(dtype).name} maximum {limit:g}"
                + ("; write with half=False" if half else "")
            )
    # ascontiguousarray is not cosmetic: OpenEXR 3.5 writes non-C-contiguous
    # arrays with scrambled pixels and no error.
    pixels = np.ascontiguousarray(a, dtype=dtype)
    channels = {"RGB": pixels}
    if alpha is not None:
        alpha = np.asarray(alpha)
        if alpha.shape != a.shape[:2]:
            raise ImageError(f"{path}: alpha of shape {alpha.shape}, expected {a.shape[:2]}")
        check_finite(alpha[..., None], f"alpha for {path}")
        channels["A"] = np.ascontiguousarray(alpha, dtype=dtype)

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attrs}
    with atomic_path(path, suffix=".exr") as tmp:
        try:
            with OpenEXR.File(header, channels) as f:
                f.write(str(tmp))
        except Exception as e:  # the binding raises bare RuntimeError/ValueError
            raise ImageError(f"{path}: cannot write OpenEXR file: {e}") from e
    return path


def _pick_rgb(channels: dict[str, Any], path: Path) -> tuple[list[np.ndarray], str]:
    """Choose the channels that make up the colour image; returns (arrays, description)."""
    names = set(channels)

    def px(n: str) -> np.ndarray:
        return channels[n].pixels

    if {"R", "G", "B"} <= names:
        return [px("R"), px("G"), px("B")], "R,G,B"
    if "Y" in names:
        if names & {"RY", "BY"}:
            raise ImageError(
                f"{path}: luminance/chroma (Y, RY, BY) images are not supported; convert to RGB first "
                f"(channels: {sorted(names)})"
            )
        y = px("Y")
        return [y, y, y], "Y (broadcast to RGB)"
    # A single layer such as "diffuse.R/G/B" or Blender's "ViewLayer.Combined.R/G/B".
    layers = sorted(
        n[: -len(".R")] for n in names if n.endswith(".R") and {n[:-1] + "G", n[:-1] + "B"} <= names
    )
    if len(layers) == 1:
        p = layers[0]
        return [px(p + ".R"), px(p + ".G"), px(p + ".B")], f"{p}.R,G,B"
    hint = f"several RGB layers {layers}" if layers else "no R, G, B or Y channels"
    raise ImageError(f"{path}: {hint}; channels present: {sorted(names)}")


def read_exr(path: str | os.PathLike) -> tuple[np.ndarray, dict[str, MetadataValue]]:
    """Read an OpenEXR file as a float32 (H, W, 3) linear RGB image plus metadata.

    Parameters
    ----------
    path : str or os.PathLike
        The file. The first part of a multi-part file is read.

    Returns
    -------
    image : numpy.ndarray
        float32, C-contiguous, shape (H, W, 3). Half channels are converted
        exactly. Separate R, G, B channels are used when present; otherwise a
        luminance-only file (a single ``Y`` channel) is broadcast to grey RGB;
        otherwise a single layer ``<name>.R/.G/.B``. Non-finite pixels are
        returned as stored (the metrics refuse them with a clear message).
    metadata : dict
        The ``compare:`` attributes without the prefix, with their types
        restored (``str``, ``int``, ``float``); empty for files written by other
        tools.

    Raises
    ------
    ImageError
        Naming the path, for a missing file, a folder, a file that is not
        OpenEXR, a truncated or corrupt file, integer or subsampled colour
        channels, or a file without usable colour channels.
    """
    path = Path(path)
    if not path.exists():
        raise ImageError(f"{path}: no such file")
    if not path.is_file():
        raise ImageError(f"{path}: not a regular file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(4)
    except OSError as e:
        raise ImageError(f"{path}: cannot open: {e}") from e
    if not head:
        raise ImageError(f"{path}: empty file, not an OpenEXR image")
    if head != _EXR_MAGIC:
        raise ImageError(
            f"{path}: not an OpenEXR file (first bytes {head!r}, expected the EXR magic number 76 2f 31 01)"
        )

    # The binding reports unreadable pixel data by printing to sys.stdout and
    # dropping the part; capture that text to put it into the error instead.
    captured = io.StringIO()
    try:
        with contextlib.redirect_stdout(captured):
            exr = OpenEXR.File(str(path), separate_channels=True)
    except Exception as e:
        raise ImageError(f"{path}: unreadable OpenEXR file (truncated or corrupt?): {e}") from e
    with exr:
        detail = captured.getvalue().strip()
        if len(exr.parts) == 0:
            raise ImageError(
                f"{path}: truncated or corrupt OpenEXR file, pixel data unreadable"
                + (f" ({detail})" if detail else "")
            )
        try:
            header = exr.header()
            channels = exr.channels()
        except Exception as e:
            raise ImageError(f"{path}: unreadable OpenEXR file: {e}") from e

        lo, hi = header["dataWindow"]
        shape = (int(hi[1]) - int(lo[1]) + 1, int(hi[0]) - int(lo[0]) + 1)
        planes, which = _pick_rgb(channels, path)
        for p in planes:
            if p is None or not isinstance(p, np.ndarray):
                raise ImageError(f"{path}: channels {which} hold no pixel data (deep or header-only file?)")
            if p.dtype.kind not in "f":
                raise ImageError(f"{path}: channels {which} have integer pixel type {p.dtype}; expected half or float")
            if p.shape != shape:
                raise ImageError(
                    f"{path}: channels {which} have shape {p.shape}, data window is {shape} "
                    "(subsampled channels are not supported)"
                )
        image = np.stack([p.astype(np.float32, copy=False) for p in planes], axis=-1)
        metadata = _decode_metadata(header, path)
    return np.ascontiguousarray(image), metadata
