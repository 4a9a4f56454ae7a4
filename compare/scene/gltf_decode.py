"""Compressed glTF as published, decoded once into a plain GLB that every renderer reads.

Web-optimised downloads ship compressed: gltfpack writes ``EXT_meshopt_compression``
over ``KHR_mesh_quantization``, glTF-Transform and Blender write
``KHR_draco_mesh_compression``, and maps come as ``EXT_texture_webp`` or
``KHR_texture_basisu`` (KTX 2). Each is decoded by its maintained library, never by
hand: the ``meshopt`` bindings of meshoptimizer (``decode_gltf_buffer``, filters
included), ``DracoPy`` (Google's Draco), Pillow (WebP) and ``opengl_basisu`` (the
Basis Universal transcoder, to RGBA8).

:func:`decoded_glb` writes the decoded document once, named by the content hash of
the file, the external files it names and this module's code, to
``$COMPARE_CACHE/gltf-decoded`` (like embedded images). The result is plain glTF
2.0: one binary buffer, every bufferView uncompressed, Draco primitives as ordinary
accessors, decoded maps as embedded PNGs; image URIs that were not decoded stay as
they were (relative to the original file, which the reader keeps as its base).
``KHR_mesh_quantization`` stays: the reader reads quantised accessors as they are.
"""

from __future__ import annotations

import copy
import io
import math
from pathlib import Path
from typing import Callable

import numpy as np

from compare.image.pillow import MAX_TEXELS  # one limit for the decoders and every image reader

__all__ = ["DECODED_EXTENSIONS", "DecodeError", "decoded_glb", "decoder_note"]

#: Extension → what becomes of it (``compare inspect`` prints it).
DECODED_EXTENSIONS = {
    "EXT_meshopt_compression": "decoded with meshoptimizer (meshopt)",
    "KHR_draco_mesh_compression": "decoded with Draco (DracoPy)",
    "EXT_texture_webp": "decoded with Pillow",
    "KHR_texture_basisu": "transcoded to RGBA8 with Basis Universal (opengl_basisu)",
}
#: The pip distribution of each decoder, for the error when it is missing.
_DISTRIBUTIONS = {"EXT_meshopt_compression": ("meshopt", "meshopt"),
                  "KHR_draco_mesh_compression": ("DracoPy", "DracoPy"),
                  "EXT_texture_webp": ("PIL.WebPImagePlugin", "pillow"),
                  "KHR_texture_basisu": ("opengl_basisu", "opengl_basisu")}
_COMPONENT = {np.dtype(np.int8): 5120, np.dtype(np.uint8): 5121, np.dtype(np.int16): 5122,
              np.dtype(np.uint16): 5123, np.dtype(np.uint32): 5125, np.dtype(np.float32): 5126}
_TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}


class DecodeError(ValueError):
    """A compressed part cannot be decoded; ``where`` is its JSON path."""

    def __init__(self, where: str, message: str):
        super().__init__(message)
        self.where = where


def decoder_note(extension: str) -> str:
    """What becomes of ``extension`` (one phrase), or that it is not read."""
    return DECODED_EXTENSIONS.get(extension, "not read")


def used(doc: dict) -> list[str]:
    """The decoded extensions that the document ``doc`` uses or requires."""
    names = set(doc.get("extensionsUsed", [])) | set(doc.get("extensionsRequired", []))
    return [e for e in DECODED_EXTENSIONS if e in names]


def _module(extension: str):
    import importlib

    module, dist = _DISTRIBUTIONS[extension]
    try:
        return importlib.import_module(module)
    except ImportError:
        how = (f"install it with `pip install {dist}` (scripts/suite.sh setup installs it)"
               if extension != "KHR_texture_basisu" else
               f"install the Basis Universal transcoder with `pip install {dist}`, or convert the file's maps to PNG "
               "first, e.g. `npx @gltf-transform/cli png IN.glb OUT.glb`")
        raise DecodeError("extensionsUsed", f"{extension} needs the {dist} package, which is not installed: {how}") \
            from None


def decoded_glb(doc: dict, buffer: Callable[[int], bytes], image_bytes: Callable[[int], bytes], key: str) -> Path:
    """The plain GLB of the compressed document ``doc``, from the cache or decoded now.

    ``buffer(i)`` gives the bytes of buffer ``i`` (the GLB chunk, a data URI or an external
    file), ``image_bytes(i)`` those of image ``i``; ``key`` is the content hash of the file
    and of every external file it names.
    """
    from compare.util.cache import default_cache_dir
    from compare.util.code import code_fingerprint
    from compare.util.files import sha256_bytes, write_bytes_atomic
    from compare.scene.glb import pack_glb

    versions = []
    for ext in used(doc):
        module = _module(ext)
        versions.append(f"{ext}={getattr(module, '__version__', '')}")
    name = sha256_bytes(key, code_fingerprint(__name__), *versions)[:32]
    path = default_cache_dir() / "gltf-decoded" / f"{name}.glb"
    digest = path.with_suffix(".sha256")  # the entry's checksum, written after it: no checksum, no entry
    try:
        if path.is_file() and digest.read_text(encoding="ascii").strip() == sha256_bytes(path.read_bytes()):
            return path
    except (OSError, UnicodeDecodeError):
        pass  # missing, unreadable, truncated or edited: decoded again below
    plain, data = _Decoder(doc, buffer, image_bytes).run()
    glb = pack_glb(plain, data)
    write_bytes_atomic(path, glb)
    write_bytes_atomic(digest, sha256_bytes(glb).encode("ascii"))
    return path


#: KTX 2's file identifier («KTX 20»\r\n\x1a\n).
KTX2_IDENTIFIER = b"\xabKTX 20\xbb\r\n\x1a\n"


def ktx2_header_problem(head: bytes) -> str | None:
    """Why the KTX 2 file whose first bytes are ``head`` must not be transcoded (None if it may): more texels
    than a map may have (:data:`MAX_TEXELS`), or a level whose declared uncompressed size is more than its
    texels need (a Zstd payload of a few KB may claim a GiB; UASTC holds 16 bytes per 4×4 block)."""
    import struct

    if len(head) < 80 or head[:12] != KTX2_IDENTIFIER:
        return "not a KTX 2 file (no KTX 2 identifier)"
    width, height = struct.unpack_from("<II", head, 20)
    levels, scheme = struct.unpack_from("<II", head, 40)
    if width * max(height, 1) > MAX_TEXELS:
        return f"its header declares {width} × {height} texels, more than the {MAX_TEXELS:,} (16384²) a map may have"
    for level in range(min(max(levels, 1), 16)):
        at = 80 + 24 * level
        if len(head) < at + 24:
            break
        _, _, uncompressed = struct.unpack_from("<QQQ", head, at)
        w, h = max(width >> level, 1), max(height >> level, 1)
        need = ((w + 3) // 4) * ((h + 3) // 4) * 16
        if scheme == 2 and uncompressed > need:  # Zstd (BasisLZ's scheme 1 declares 0 here)
            return (f"level {level} declares {uncompressed:,} bytes uncompressed, where its {w} × {h} texels "
                    f"need {need:,}")
    return None


class _Decoder:
    def __init__(self, doc: dict, buffer: Callable[[int], bytes], image_bytes: Callable[[int], bytes]):
        self.src = doc
        self.doc = copy.deepcopy(doc)
        self.buffer = buffer
        self.image_bytes = image_bytes
        self.out = bytearray()

    def _append(self, data: bytes, stride: int | None = None) -> int:
        """A new bufferView over ``data`` in the output buffer (4-byte aligned); its index."""
        self.out += b"\0" * (-len(self.out) % 4)
        view = {"buffer": 0, "byteOffset": len(self.out), "byteLength": len(data)}
        if stride:
            view["byteStride"] = int(stride)
        self.out += data
        views = self.doc.setdefault("bufferViews", [])
        views.append(view)
        return len(views) - 1

    def run(self) -> tuple[dict, bytes]:
        ext = set(used(self.src))
        self._views()
        if "KHR_draco_mesh_compression" in ext:
            self._draco()
        for name in ("EXT_texture_webp", "KHR_texture_basisu"):
            if name in ext:
                self._textures(name)
        doc = self.doc
        doc["buffers"] = [{"byteLength": len(self.out)}] if self.out else []
        for key in ("extensionsUsed", "extensionsRequired"):
            if key in doc:
                doc[key] = [e for e in doc[key] if e not in DECODED_EXTENSIONS]
                if not doc[key]:
                    del doc[key]
        return doc, bytes(self.out)

    # -- buffer views -------------------------------------------------------------------------

    def _views(self) -> None:
        """Every bufferView copied (or decoded, for meshopt) into the one output buffer, index kept."""
        views = self.src.get("bufferViews", [])
        self.doc["bufferViews"] = []
        for i, v in enumerate(views):
            where = f"bufferViews[{i}]"
            mo = v.get("extensions", {}).get("EXT_meshopt_compression")
            if mo is not None:
                data = self._meshopt(mo, f"{where}.extensions.EXT_meshopt_compression")
            else:
                fallback = self.src.get("buffers", [])[v.get("buffer", 0)] if self.src.get("buffers") else {}
                if fallback.get("extensions", {}).get("EXT_meshopt_compression", {}).get("fallback"):
                    data = b""  # a placeholder that only compressed views name (the meshopt fallback buffer)
                else:
                    raw = self.buffer(v.get("buffer", -1))
                    start, length = int(v.get("byteOffset", 0)), int(v.get("byteLength", 0))
                    if start < 0 or length < 0 or start + length > len(raw):
                        raise DecodeError(where, f"bytes {start}…{start + length} exceed the buffer ({len(raw)})")
                    data = raw[start:start + length]
            new = self._append(data, v.get("byteStride"))
            for key in ("name", "target"):
                if key in v:
                    self.doc["bufferViews"][new][key] = v[key]

    def _meshopt(self, mo: dict, where: str) -> bytes:
        meshopt = _module("EXT_meshopt_compression")
        raw = self.buffer(mo.get("buffer", -1))
        start, length = int(mo.get("byteOffset", 0)), int(mo.get("byteLength", 0))
        count, stride = int(mo.get("count", -1)), int(mo.get("byteStride", -1))
        mode, filt = mo.get("mode"), mo.get("filter", "NONE")
        if start < 0 or length < 0 or start + length > len(raw):
            raise DecodeError(where, f"bytes {start}…{start + length} exceed the buffer ({len(raw)})")
        if count < 0 or not 1 <= stride <= 256:
            raise DecodeError(where, f"count {count} and byteStride {stride} are not a valid layout")
        # What a stream may decode to is bounded by its length (meshopt spends at least 2 header bits per
        # 16 bytes of output): refuse, before allocating, a count that no stream of this length could hold.
        if count * stride > 256 * length + (1 << 16):
            raise DecodeError(where, f"{count} × {stride} bytes cannot come from {length} compressed bytes")
        try:
            out = meshopt.decode_gltf_buffer(bytes(raw[start:start + length]), count, stride, mode,
                                             None if filt == "NONE" else filt)
        except Exception as exc:  # the binding raises ValueError/RuntimeError for a corrupt stream
            raise DecodeError(where, f"meshopt could not decode it ({exc})") from None
        return np.ascontiguousarray(out).tobytes()

    # -- Draco ----------------------------------------------------------------------------------

    def _draco(self) -> None:
        draco = _module("KHR_draco_mesh_compression")
        accessors = self.doc.setdefault("accessors", [])
        for mi, mesh in enumerate(self.doc.get("meshes", [])):
            for pi, prim in enumerate(mesh.get("primitives", [])):
                ext = prim.get("extensions", {}).get("KHR_draco_mesh_compression")
                if ext is None:
                    continue
                where = f"meshes[{mi}].primitives[{pi}].extensions.KHR_draco_mesh_compression"
                vi = ext.get("bufferView", -1)
                views = self.doc["bufferViews"]
                if isinstance(vi, bool) or not isinstance(vi, int) or not 0 <= vi < len(views):
                    raise DecodeError(f"{where}.bufferView", f"index {vi!r} out of range")
                v = views[vi]
                data = bytes(self.out[v["byteOffset"]: v["byteOffset"] + v["byteLength"]])
                try:
                    decoded = draco.decode(data)
                except Exception as exc:  # DracoPy raises its own types for corrupt streams
                    raise DecodeError(where, f"Draco could not decode it ({exc})") from None
                faces = np.asarray(decoded.faces, dtype=np.uint32).reshape(-1)
                if "indices" in prim:
                    prim["indices"] = self._accessor(faces, accessors, accessors[prim["indices"]], indices=True)
                for semantic, uid in ext.get("attributes", {}).items():
                    attr = decoded.get_attribute_by_unique_id(uid)
                    if attr is None or semantic not in prim.get("attributes", {}):
                        raise DecodeError(f"{where}.attributes.{semantic}", f"no Draco attribute with id {uid!r}")
                    values = np.asarray(attr["data"])
                    values = values.reshape(len(values), -1)
                    original = accessors[prim["attributes"][semantic]]
                    prim["attributes"][semantic] = self._accessor(values, accessors, original)
                del prim["extensions"]["KHR_draco_mesh_compression"]
                if not prim["extensions"]:
                    del prim["extensions"]

    def _accessor(self, values: np.ndarray, accessors: list, original: dict, *, indices: bool = False) -> int:
        """A new accessor over ``values``, with the original's normalisation where its type is kept."""
        values = np.ascontiguousarray(values)
        if values.dtype not in _COMPONENT:
            values = values.astype(np.float32 if values.dtype.kind == "f" else np.uint32)
        n = 1 if values.ndim == 1 else values.shape[1]
        acc = {"bufferView": self._append(values.tobytes()), "componentType": _COMPONENT[values.dtype],
               "count": int(len(values)), "type": "SCALAR" if indices else _TYPES.get(n, original.get("type"))}
        if original.get("normalized") and values.dtype.kind in "iu":
            acc["normalized"] = True
        if values.dtype.kind == "f" and len(values):
            acc["min"] = values.reshape(len(values), -1).min(0).tolist()
            acc["max"] = values.reshape(len(values), -1).max(0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    # -- textures -------------------------------------------------------------------------------

    def _textures(self, extension: str) -> None:
        decode = self._webp if extension == "EXT_texture_webp" else self._basisu
        images = self.doc.setdefault("images", [])
        done: set[int] = set()
        for ti, tex in enumerate(self.doc.get("textures", [])):
            ext = tex.get("extensions", {}).get(extension)
            if ext is None:
                continue
            src = ext.get("source", -1)
            where = f"textures[{ti}].extensions.{extension}.source"
            if isinstance(src, bool) or not isinstance(src, int) or not 0 <= src < len(self.src.get("images", [])):
                raise DecodeError(where, f"image index {src!r} out of range")
            if src not in done:  # the image itself becomes the PNG, so nothing else refers to a WebP/KTX 2 one
                png = decode(self.image_bytes(src), f"images[{src}]")
                name = images[src].get("name")
                images[src] = {"bufferView": self._append(png), "mimeType": "image/png", **({"name": name} if name
                                                                                            else {})}
                done.add(src)
            tex["source"] = src
            del tex["extensions"][extension]
            if not tex["extensions"]:
                del tex["extensions"]

    @staticmethod
    def _png(pixels: np.ndarray) -> bytes:
        from compare.image.pillow import Image

        buf = io.BytesIO()
        Image.fromarray(pixels).save(buf, format="PNG", compress_level=1)  # a cache file: speed over size
        return buf.getvalue()

    def _webp(self, data: bytes, where: str) -> bytes:
        _module("EXT_texture_webp")
        from compare.image.pillow import Image

        try:
            with Image.open(io.BytesIO(data)) as im:
                if im.format != "WEBP":
                    raise DecodeError(where, f"EXT_texture_webp names a {im.format} image, not WebP")
                im.load()
                out = io.BytesIO()
                im.save(out, format="PNG", compress_level=1)  # a cache file: speed over size
        except (OSError, ValueError, Image.DecompressionBombError) as exc:
            if isinstance(exc, DecodeError):
                raise
            raise DecodeError(where, f"unreadable WebP image ({exc})") from None
        return out.getvalue()

    def _basisu(self, data: bytes, where: str) -> bytes:
        basisu = _module("KHR_texture_basisu")
        problem = ktx2_header_problem(bytes(data[:80 + 24 * 16]))
        if problem:  # before the transcoder allocates what the header declares
            raise DecodeError(where, problem)
        try:
            tex = basisu.open(bytes(data))
            if tex.faces != 1 or tex.layers != 1:
                raise DecodeError(where, "KHR_texture_basisu allows 2D textures only")
            if tex.width * tex.height > MAX_TEXELS:  # checked on the header, before anything is allocated
                raise DecodeError(where, f"{tex.width} × {tex.height} texels is more than the {MAX_TEXELS:,} "
                                         "(16384²) a map may have")
            image = tex.transcode(basisu.Target.RGBA8, level=0)
        except (basisu.BasisuError, basisu.UnsupportedError, ValueError) as exc:
            raise DecodeError(where, f"not a valid KTX 2 file with a Basis Universal payload ({exc})") from None
        pixels = np.asarray(image.data, dtype=np.uint8).reshape(image.height, image.width, 4)
        if math.prod(pixels.shape) and not tex.has_alpha:
            pixels = pixels[..., :3]
        return self._png(np.ascontiguousarray(pixels))
