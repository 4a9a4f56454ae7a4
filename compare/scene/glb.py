"""The GLB container of glTF 2.0: a JSON chunk and an optional binary chunk, read and written.

Shared by the reader (:mod:`compare.scene.gltf_read`), the writer (:mod:`compare.scene.gltf_write`)
and the decoder of compressed files (:mod:`compare.scene.gltf_decode`).
"""

from __future__ import annotations

import json
import struct

__all__ = ["CHUNK_BIN", "CHUNK_JSON", "GLB_MAGIC", "GlbError", "pack_glb", "parse_glb"]

GLB_MAGIC = 0x46546C67  # "glTF"
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942


class GlbError(ValueError):
    """A GLB container is malformed (the message says where, without the file name)."""


def parse_glb(raw: bytes) -> tuple[dict, bytes | None]:
    """The JSON document and the binary chunk (None if absent) of the GLB bytes ``raw``."""
    if len(raw) < 20:
        raise GlbError("truncated GLB header")
    magic, version, length = struct.unpack_from("<III", raw, 0)
    if magic != GLB_MAGIC or version != 2:
        raise GlbError(f"GLB version {version} is not supported (expected 2)")
    if length > len(raw):
        raise GlbError(f"GLB header says {length} bytes, the file has {len(raw)}")
    off, doc, binary = 12, None, None
    view = memoryview(raw)
    while off + 8 <= length:
        size, kind = struct.unpack_from("<II", raw, off)
        if off + 8 + size > len(raw):
            raise GlbError(f"truncated GLB chunk at byte {off}")
        body = view[off + 8: off + 8 + size]
        if kind == CHUNK_JSON and doc is None:
            try:
                doc = json.loads(bytes(body).decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise GlbError(f"GLB JSON chunk is malformed: {exc}") from exc
        elif kind == CHUNK_BIN and binary is None:
            binary = bytes(body)
        off += 8 + size + (-size % 4)
    if doc is None:
        raise GlbError("GLB file has no JSON chunk")
    return doc, binary


def pack_glb(doc: dict, binary: bytes | bytearray = b"") -> bytes:
    """GLB bytes of the JSON document ``doc`` and the binary chunk ``binary`` (left out when empty)."""
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js += b" " * (-len(js) % 4)
    out = [struct.pack("<II", len(js), CHUNK_JSON), js]
    if binary:
        out += [struct.pack("<II", len(binary) + (-len(binary) % 4), CHUNK_BIN), bytes(binary),
                b"\0" * (-len(binary) % 4)]
    total = 12 + sum(len(part) for part in out)
    return struct.pack("<III", GLB_MAGIC, 2, total) + b"".join(out)
