"""Writing glTF 2.0: the suite's generated scene data, the job file's glTF of external renderers, and tests.

Deterministic output (insertion order, float32 data); GLB, or ``.gltf`` with an embedded buffer.
The reader is :mod:`compare.scene.gltf_read`.
"""

from __future__ import annotations

import base64
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from compare.scene.geometry import TriangleMesh
from compare.scene.glb import pack_glb
from compare.util.files import write_bytes_atomic

__all__ = ["GltfWriter"]


class GltfWriter:
    """Builds a small glTF 2.0 document and writes it as GLB (or .gltf with an embedded buffer).

    Enough for the suite's generated scene data and for tests: triangle meshes
    with normals and optional UVs, metallic-roughness materials, nodes with
    transforms, perspective cameras and ``KHR_lights_punctual`` lights. Output
    is deterministic (insertion order, float32 data).
    """

    def __init__(self, generator: str = "compare.scene.gltf_write"):
        self.doc: dict[str, Any] = {"asset": {"version": "2.0", "generator": generator}}
        self.bin = bytearray()
        self._children: set[int] = set()

    def _add(self, kind: str, value: dict) -> int:
        self.doc.setdefault(kind, []).append(value)
        return len(self.doc[kind]) - 1

    def view(self, data: bytes, target: int | None = None) -> int:
        """Append bytes (4-byte aligned) as a bufferView; returns its index."""
        self.bin.extend(b"\0" * (-len(self.bin) % 4))
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target is not None:
            v["target"] = target
        self.bin.extend(data)
        return self._add("bufferViews", v)

    def accessor(self, array: np.ndarray, *, indices: bool = False, bounds: bool = False) -> int:
        a = np.asarray(array)
        if indices:
            a = a.astype(np.uint16 if a.size == 0 or a.max() < 65535 else np.uint32).ravel()
            ctype = 5123 if a.dtype == np.uint16 else 5125
            kind = "SCALAR"
        else:
            a = a.astype(np.float32)
            ctype = 5126
            kind = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[a.shape[1] if a.ndim == 2 else 1]
        view = self.view(np.ascontiguousarray(a).tobytes(), 34963 if indices else 34962)
        acc = {"bufferView": view, "componentType": ctype, "count": int(a.shape[0]), "type": kind}
        if bounds and a.ndim == 2 and len(a):
            acc["min"] = [float(x) for x in a.min(0)]
            acc["max"] = [float(x) for x in a.max(0)]
        return self._add("accessors", acc)

    def material(self, name: str, base_color=(0.8, 0.8, 0.8), metallic: float = 0.0, roughness: float = 0.5,
                 emission=(0.0, 0.0, 0.0)) -> int:
        m: dict[str, Any] = {"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": [float(c) for c in base_color] + [1.0],
            "metallicFactor": float(metallic), "roughnessFactor": float(roughness)}}
        e = [float(c) for c in emission]
        if max(e) > 0:
            peak = max(e)
            if peak > 1.0:
                m["emissiveFactor"] = [c / peak for c in e]
                m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": peak}}
                self._use("KHR_materials_emissive_strength")
            else:
                m["emissiveFactor"] = e
        return self._add("materials", m)

    def texture(self, data: bytes, mime: str = "image/png", *, scale=None) -> dict:
        """A texture info over the image bytes ``data``, embedded once however often it is used;
        ``scale``: a ``KHR_texture_transform`` scale of the texture coordinates."""
        images = getattr(self, "_images", None)
        if images is None:
            images = self._images = {}
        if data not in images:
            images[data] = self._add("images", {"bufferView": self.view(data), "mimeType": mime})
        info: dict[str, Any] = {"index": self._add("textures", {"source": images[data]})}
        if scale is not None and tuple(scale) != (1.0, 1.0):
            info["extensions"] = {"KHR_texture_transform": {"scale": [float(v) for v in scale]}}
            self._use("KHR_texture_transform")
        return info

    def _use(self, ext: str) -> None:
        used = self.doc.setdefault("extensionsUsed", [])
        if ext not in used:
            used.append(ext)

    def mesh(self, name: str, parts: list[tuple[TriangleMesh, int | None]], *, normals: bool = True,
             uvs: bool = False) -> int:
        """A mesh of one primitive per (triangles, material index) part."""
        prims = []
        for tri, material in parts:
            attrs = {"POSITION": self.accessor(tri.positions, bounds=True)}
            if normals:
                attrs["NORMAL"] = self.accessor(tri.normals)
            if uvs:
                attrs["TEXCOORD_0"] = self.accessor(tri.uvs)
                if tri.uvs1 is not None:  # the second set a map may name (texCoord 1)
                    attrs["TEXCOORD_1"] = self.accessor(tri.uvs1)
            if tri.colors is not None:  # glTF's COLOR_0: linear RGBA, multiplying base colour and alpha
                attrs["COLOR_0"] = self.accessor(tri.colors)
            if tri.tangents is not None and normals:  # the frame of its normal maps: no reader guesses its own
                attrs["TANGENT"] = self.accessor(tri.tangents)
            prim: dict[str, Any] = {"attributes": attrs, "indices": self.accessor(tri.indices, indices=True)}
            if material is not None:
                prim["material"] = material
            prims.append(prim)
        return self._add("meshes", {"name": name, "primitives": prims})

    def camera(self, name: str, yfov_degrees: float, aspect: float | None = None, znear: float = 0.01) -> int:
        p: dict[str, Any] = {"yfov": math.radians(yfov_degrees), "znear": znear}
        if aspect:
            p["aspectRatio"] = aspect
        return self._add("cameras", {"name": name, "type": "perspective", "perspective": p})

    def light(self, name: str, kind: str, intensity: float, color=(1.0, 1.0, 1.0)) -> int:
        self._use("KHR_lights_punctual")
        ext = self.doc.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
        d: dict[str, Any] = {"name": name, "type": kind, "intensity": float(intensity), "color": list(color)}
        if kind == "spot":
            d["spot"] = {"innerConeAngle": 0.0, "outerConeAngle": math.pi / 4}
        ext["lights"].append(d)
        return len(ext["lights"]) - 1

    def node(self, name: str | None = None, *, mesh: int | None = None, camera: int | None = None,
             light: int | None = None, translation=None, rotation=None, scale=None, matrix=None,
             children: tuple[int, ...] = ()) -> int:
        n: dict[str, Any] = {}
        if name:
            n["name"] = name
        for key, value in (("mesh", mesh), ("camera", camera)):
            if value is not None:
                n[key] = value
        if light is not None:
            n["extensions"] = {"KHR_lights_punctual": {"light": light}}
        if matrix is not None:
            n["matrix"] = [float(x) for x in np.asarray(matrix, dtype=np.float64).T.ravel()]
        for key, value in (("translation", translation), ("rotation", rotation), ("scale", scale)):
            if value is not None:
                n[key] = [float(x) for x in value]
        if children:
            n["children"] = list(children)
            self._children.update(children)
        return self._add("nodes", n)

    def document(self, *, embed_buffer: bool = False) -> dict:
        doc = json.loads(json.dumps(self.doc))
        roots = [i for i in range(len(doc.get("nodes", []))) if i not in self._children]
        doc["scenes"] = [{"nodes": roots}]
        doc["scene"] = 0
        if self.bin:
            buf: dict[str, Any] = {"byteLength": len(self.bin)}
            if embed_buffer:
                buf["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bin)).decode()
            doc["buffers"] = [buf]
        return doc

    def glb(self) -> bytes:
        return pack_glb(self.document(), self.bin)

    def write(self, path: str | os.PathLike) -> Path:
        """Write ``.glb`` (binary) or ``.gltf`` (JSON with the buffer as a data URI), atomically."""
        path = Path(path)
        if path.suffix.lower() == ".glb":
            write_bytes_atomic(path, self.glb())
        else:
            write_bytes_atomic(path, json.dumps(self.document(embed_buffer=True), indent=1).encode("utf-8"))
        return path
