"""glTF 2.0 import (``.gltf`` and ``.glb``) into the scene model, and a small GLB writer.

The reader decodes accessors (strided, normalized, sparse; quantised ones as they are) with
numpy, hands compressed files (meshopt, Draco, WebP, KTX 2) to :mod:`compare.scene.gltf_decode`
first, walks the node hierarchy of the default scene, and returns
world-space parts that :func:`include` maps onto :mod:`compare.scene.loader` objects.
A TOML scene pulls a file in with ``[[include]]`` (see ``scenes/README.md``)
and may add lights, an environment and a camera around it.

Mapping decisions
-----------------
Geometry
    Every triangle primitive (modes 4, 5 and 6; points and lines are skipped
    with a warning) of every mesh node of the default scene becomes one
    :class:`~compare.scene.loader.Mesh` with ``shape = "gltf"``, its node's world
    matrix times the include's own transform. Missing normals get flat face
    normals (the glTF rule); zero or non-finite normals are replaced by
    area-weighted ones.
Morph targets and skins (:mod:`compare.scene.gltf_pose`)
    The pose the file gives without animation. Morph targets at their default
    weights (the node's ``weights``, else the mesh's, else 0): POSITION, NORMAL,
    TANGENT, TEXCOORD_0 and COLOR_0 = base + Σ wᵢ · targetᵢ (a target's count
    must be the base's, one finite weight per target). A node with a ``skin``:
    each vertex moved by Σ wⱼ · (joint j's world matrix · its inverse bind
    matrix) over JOINTS_n / WEIGHTS_n (every set; identity without
    ``inverseBindMatrices``), normals by the inverse transpose, faces turned
    where the blend mirrors them; the node's own transform does not apply (glTF),
    so the part's matrix is the identity. Bad indices, weights or counts are one
    error naming the field.
Materials
    ``pbrMetallicRoughness`` factors map one to one (the scene model *is* glTF's
    material model). ``alphaMode`` MASK with ``alphaCutoff`` and the alpha of
    ``baseColorFactor`` (times the base-colour image's alpha) cut holes; BLEND is
    rendered opaque, with a note. ``emissiveFactor`` × ``KHR_materials_emissive_strength``
    is the emission in W·sr⁻¹·m⁻², and ``emissiveTexture`` (sRGB) multiplies it.
    Each map keeps how the file reads it (``Material.map_sampling``): its ``texCoord``
    (TEXCOORD_0 or _1; a higher set is read on TEXCOORD_0, with a note), its
    ``KHR_texture_transform`` (offset, rotation, scale, and the texCoord it overrides)
    and its texture's sampler (wrapS and wrapT apart, magFilter, whether minFilter
    reads mip levels).
    ``occlusionTexture`` and its strength are the occlusion map, ``normalTexture`` and its scale the
    normal map; their tangents are the file's ``TANGENT``, else MikkTSpace's (:mod:`compare.scene.tangents`).
    Primitives without a material get glTF's
    default material (white, metallic 1, roughness 1). Textures: the base
    colour and metallic-roughness images become the material's texture files
    (external images are checked to stay inside the scene's folder; images
    embedded in a GLB or a data URI are written once, by content hash, to
    ``$COMPARE_CACHE/gltf-images``). glTF multiplies a map by its factor, where a
    scene material's map replaces it: a base-colour or metallic-roughness factor other
    than 1 is baked into its map (:func:`compare.scene.textures.factor_map`, a linear EXR in
    the cache). Names are ``<prefix><material name>``, and a TOML
    ``[materials."<prefix><name>"]`` of the same name replaces the imported one.
    ``KHR_materials_pbrSpecularGlossiness`` is converted as glTF-Transform's
    ``metalRough()`` does (:mod:`compare.scene.gltf_specgloss`): diffuse → base
    colour, metallic 0, roughness 1 − glossiness (a map of it baked from the
    specular-glossiness map's alpha), specular → ``KHR_materials_specular``'s colour
    (and its map's RGB) with ior 1000; its fallback ``pbrMetallicRoughness`` is not
    read, and the notes say the extension was converted.
Emissive quads
    A primitive that is a planar rectangle (two triangles, four corners, right
    angles) with an emissive material without an emission map becomes a one-sided rectangular
    ``[[lights]]`` entry emitting along its front-face (counter-clockwise)
    normal with the material's emission as radiance, so that both renderers
    light the scene with it (the rasterizer samples only rectangle lights).
    ``emissive_quads = "meshes"`` keeps it an emissive mesh instead.
``KHR_lights_punctual``
    The scene model has no delta lights, so each punctual light becomes small
    rectangle lights of side ``punctual_size`` (default 5 cm): a spot light
    one square facing along its direction (−Z of its node) with L = I / s², so
    that its on-axis intensity is I (the cone is not reproduced: the square
    falls off with the cosine); a point light a closed cube of six outward
    squares with L = 2I / (3s²), so that it emits the point light's power
    4πI. Intensities in candela are converted to W/sr with ``light_scale``,
    default 1/683 W/lm (the candela's definition at 555 nm). Directional
    lights have no rectangle equivalent: they are skipped with a warning (put
    a sun into the ``[environment]``). ``punctual = "ignore"`` skips all.
Cameras
    A perspective camera (``yfov``, node −Z forward, +Y up) fills whatever the
    TOML ``[camera]`` table leaves out (position, target, up, fov, and a
    resolution of 320 pixels wide at its ``aspectRatio``). Orthographic
    cameras are skipped with a warning.

Units: glTF is in metres with +Y up, as the scene model is.
"""

from __future__ import annotations

import base64
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from compare.scene import geometry, gltf_instancing, gltf_pose, gltf_specgloss
from compare.scene.model import LAYER_MAPS, LAYERS, TEXCOORD_SETS, MapSampling
from compare.scene.gltf_decode import DECODED_EXTENSIONS, DecodeError, decoded_glb, used
from compare.scene.glb import GlbError, parse_glb
from compare.util.files import sha256_bytes, write_bytes_atomic
from compare.scene.geometry import MeshFileError, TriangleMesh

COMPONENT_TYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
                   5126: np.float32}
TYPE_SIZES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
#: Extensions that are read. A file that *requires* any other (Draco, meshopt, BasisU, WebP, ...) is
#: refused; others it merely uses are ignored with one warning.
SUPPORTED_EXTENSIONS = ("KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_mesh_quantization",
                        "KHR_texture_transform", gltf_instancing.EXTENSION,
                        *dict.fromkeys(layer.extension for layer in LAYERS))
#: Extensions converted into the scene model's terms: name → what becomes of it.
CONVERTED_EXTENSIONS = {gltf_specgloss.EXTENSION: "converted to metallic-roughness with KHR_materials_specular and "
                                                  "KHR_materials_ior (glTF-Transform's metalRough)",
                        "KHR_materials_unlit": "converted: the base colour (map and factor) emitted by a black, "
                                               "non-specular surface, which no light shades"}
#: Components an accessor without a bufferView (zeros, or sparse) may have: 2^28, a billion bytes as float32.
MAX_ZERO_ELEMENTS = 1 << 28
#: Maps of the material extensions read apart from LAYER_MAPS (the coat's own normal map).
MAPS_READ_APART = ("clearcoatNormalTexture",)
#: A glTF texture key → the scene model's names of the maps it makes (Material.sampling): a spec-gloss
#: material's specularGlossinessTexture gives its roughness map and its specular colour.
MAP_KEYS = {"baseColorTexture": ("base_color_texture",), "diffuseTexture": ("base_color_texture",),
            "metallicRoughnessTexture": ("metallic_roughness_texture",),
            "specularGlossinessTexture": ("metallic_roughness_texture", "specular_color"),
            "emissiveTexture": ("emissive_texture",), "occlusionTexture": ("occlusion_texture",),
            "normalTexture": ("normal_texture",), "clearcoatNormalTexture": ("clearcoat_normal_texture",),
            **{key: (fld,) for key, (fld, _) in LAYER_MAPS.items()}}
#: glTF sampler codes → the scene model's texture_wrap and texture_filter.
GL_WRAPS = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
GL_FILTERS = {9728: "nearest", 9729: "linear"}
#: Watts per lumen at 555 nm: candela → W/sr for KHR_lights_punctual.
WATTS_PER_LUMEN = 1.0 / 683.0
DEFAULT_PUNCTUAL_SIZE = 0.05
#: Default width in pixels when a glTF camera supplies the aspect ratio.
DEFAULT_CAMERA_WIDTH = 320


class GltfError(MeshFileError):
    """A glTF file is unreadable or uses something unsupported; names the file and the JSON path."""


# ----------------------------------------------------------------------------- parsed document


@dataclass(frozen=True)
class GltfMaterial:
    """A glTF material's metallic-roughness factors, emission and texture image indices."""

    name: str
    base_color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    metallic: float = 1.0
    roughness: float = 1.0
    emission: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_color_image: int | None = None
    metallic_roughness_image: int | None = None
    emissive_image: int | None = None
    occlusion_image: int | None = None
    occlusion_strength: float = 1.0
    normal_image: int | None = None
    normal_scale: float = 1.0
    #: alphaMode ("opaque", "mask" or "blend"), baseColorFactor's alpha and alphaCutoff.
    alpha_mode: str = "opaque"
    alpha: float = 1.0
    alpha_cutoff: float = 0.5
    #: doubleSided (glTF's default: false, back faces culled).
    double_sided: bool = False
    #: The material extensions' factors (compare.scene.model.LAYERS) the file sets: field → value.
    layers: dict = field(default_factory=dict)
    #: Their maps that are read (compare.scene.model.LAYER_MAPS): (field, channel, image index).
    layer_images: tuple = ()
    #: KHR_materials_clearcoat's clearcoatNormalTexture: image index and scale.
    clearcoat_normal_image: int | None = None
    clearcoat_normal_scale: float = 1.0
    #: KHR_materials_unlit (converted: its base colour is the emission; compare.scene.include keeps its
    #: surfaces meshes, never area lights: what it shows is not a light of the scene's author).
    unlit: bool = False
    #: How each map is read (compare.scene.model.Material.map_sampling: the map's name in the scene model,
    #: its texCoord, KHR_texture_transform and sampler).
    sampling: tuple = ()


@dataclass(frozen=True)
class GltfPrimitive:
    """One triangle primitive in its node's coordinates, with the node's world matrix."""

    name: str
    mesh: TriangleMesh
    matrix: np.ndarray
    material: int | None


@dataclass(frozen=True)
class GltfCamera:
    name: str
    matrix: np.ndarray
    yfov: float
    """Vertical field of view in radians."""
    aspect: float | None


@dataclass(frozen=True)
class GltfLight:
    name: str
    kind: str
    """``"point"``, ``"spot"`` or ``"directional"``."""
    color: tuple[float, float, float]
    intensity: float
    matrix: np.ndarray
    inner_cone: float = 0.0
    """A spot's cone half-angles in radians (glTF's ``spot.innerConeAngle`` and ``outerConeAngle``)."""
    outer_cone: float = math.pi / 4
    range: float | None = None


@dataclass
class GltfDocument:
    """What :func:`load_gltf` read: world-space parts of the default scene."""

    path: Path
    primitives: list[GltfPrimitive]
    materials: list[GltfMaterial]
    images: list[Path | None]
    """Per glTF image: a readable file (external, or extracted to the cache), None if unusable; then the maps
    the reader derives from them (a spec-gloss material's roughness), which materials name by index too."""
    cameras: list[GltfCamera]
    lights: list[GltfLight]
    files: list[Path] = field(default_factory=list)
    """External files the document references (buffers, images), for the scene hash."""
    warnings: list[str] = field(default_factory=list)
    extensions: list[str] = field(default_factory=list)
    """Every extension the file uses or requires, as published (before decoding)."""

    def extension_fates(self) -> dict[str, str]:
        """What becomes of each extension of the file: read, decoded (by what), or ignored."""
        return {e: ("read" if e in SUPPORTED_EXTENSIONS else DECODED_EXTENSIONS.get(e) or CONVERTED_EXTENSIONS.get(e)
                    or "ignored") for e in self.extensions}


# ----------------------------------------------------------------------------- reading


class _Reader:
    def __init__(self, path: Path, root: Path):
        self.path = path
        self.root = root
        self.files: list[Path] = []
        self.notes: list[str] = []
        raw = self._read(path)
        self.bin: bytes | None = None
        if raw[:4] == b"glTF":
            self.doc = self._parse_glb(raw)
        else:
            try:
                self.doc = json.loads(raw.decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise self.err("", f"not a glTF JSON document nor a GLB container: {exc}") from exc
        if not isinstance(self.doc, dict):
            raise self.err("", "the JSON document is not an object")
        version = str(self.doc.get("asset", {}).get("version", ""))
        if not version.startswith("2."):
            raise self.err("asset.version", f"only glTF 2.x is supported, got {version or 'none'!r}")
        self.extensions = sorted(set(self.doc.get("extensionsUsed", [])) | set(self.doc.get("extensionsRequired", [])))
        known = set(SUPPORTED_EXTENSIONS) | set(DECODED_EXTENSIONS) | set(CONVERTED_EXTENSIONS)
        required = [e for e in self.doc.get("extensionsRequired", []) if e not in known]
        if required:
            raise self.err("extensionsRequired", f"unsupported required extension(s): {', '.join(required)}")
        ignored = sorted(set(self.doc.get("extensionsUsed", [])) - known)
        if ignored:
            self.notes.append(f"ignored extension(s): {', '.join(ignored)}")
        for e in sorted(set(self.extensions) & set(CONVERTED_EXTENSIONS)):
            self.notes.append(f"{e}: {CONVERTED_EXTENSIONS[e]}")
        #: Per glTF image its usable file (None: unusable), then the maps derived from them (materials name both
        #: by index): filled by _read_document before the materials are read.
        self.images: list[Path | None] = []
        self._buffers: dict[int, bytes] = {}
        self.decoded: list[str] = used(self.doc)
        if self.decoded:
            self._decode(raw)

    def _decode(self, raw: bytes) -> None:
        """Replace the compressed document by its plain decoded GLB (cached by content)."""
        hashed = [raw]
        for i, b in enumerate(self.doc.get("buffers", [])):
            if isinstance(b, dict) and isinstance(b.get("uri"), str) and not b["uri"].startswith("data:"):
                hashed.append(self.buffer(i, f"buffers[{i}]"))
        for i, img in enumerate(self.doc.get("images", [])):
            if isinstance(img, dict) and isinstance(img.get("uri"), str) and not img["uri"].startswith("data:"):
                hashed.append(self._read(self.external(img["uri"], f"images[{i}].uri")))

        def buffer(index: int) -> bytes:
            return self.buffer(index, "bufferViews")

        def image_bytes(index: int) -> bytes:
            img = self.item("images", index, "textures")
            if "uri" in img:
                decoded = self.data_uri(img["uri"])
                return decoded[1] if decoded else self._read(self.external(img["uri"], f"images[{index}].uri"))
            buf, start, length, _ = self.view_bytes(img.get("bufferView", -1), f"images[{index}].bufferView")
            return buf[start:start + length]

        try:
            plain = decoded_glb(self.doc, buffer, image_bytes, sha256_bytes(*hashed))
        except DecodeError as exc:
            raise self.err(exc.where, str(exc)) from None
        self.doc, self.bin = parse_glb(plain.read_bytes())
        self._buffers = {}

    def err(self, where: str, msg: str) -> GltfError:
        return GltfError(f"{self.path}: {where + ': ' if where else ''}{msg}")

    def _read(self, path: Path) -> bytes:
        try:
            return path.read_bytes()
        except OSError as exc:
            raise GltfError(f"{path}: cannot read glTF file: {exc}") from exc

    def _parse_glb(self, raw: bytes) -> dict:
        try:
            doc, self.bin = parse_glb(raw)
        except GlbError as exc:
            raise self.err("", str(exc)) from None
        return doc

    # -- helpers over the JSON --------------------------------------------------------------

    def item(self, kind: str, index: Any, where: str) -> dict:
        items = self.doc.get(kind, [])
        if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(items):
            raise self.err(where, f"{kind} index {index!r} out of range (the file has {len(items)})")
        value = items[index]
        if not isinstance(value, dict):
            raise self.err(f"{kind}[{index}]", "expected an object")
        return value

    def external(self, uri: str, where: str) -> Path:
        if "://" in uri or uri.startswith("/"):
            raise self.err(where, f"uri {uri!r} is not a relative file path")
        from urllib.parse import unquote

        full = (self.path.parent / unquote(uri)).resolve()
        if not full.is_relative_to(self.root):
            raise self.err(where, f"uri {uri!r} leaves the glTF file's folder {self.root}")
        if not full.is_file():
            raise self.err(where, f"file {uri!r} not found (looked for {full})")
        if full not in self.files:
            self.files.append(full)
        return full

    @staticmethod
    def data_uri(uri: str) -> tuple[str, bytes] | None:
        if not uri.startswith("data:"):
            return None
        head, _, payload = uri.partition(",")
        mime = head[5:].split(";")[0]
        if head.endswith(";base64"):
            return mime, base64.b64decode(payload)
        from urllib.parse import unquote_to_bytes

        return mime, unquote_to_bytes(payload)

    def buffer(self, index: int, where: str) -> bytes:
        if index in self._buffers:
            return self._buffers[index]
        b = self.item("buffers", index, where)
        uri = b.get("uri")
        if uri is None:
            if self.bin is None or index != 0:
                raise self.err(f"buffers[{index}]", "has no uri and there is no GLB binary chunk for it")
            data = self.bin
        else:
            decoded = self.data_uri(uri)
            data = decoded[1] if decoded else self._read(self.external(uri, f"buffers[{index}].uri"))
        length = b.get("byteLength", len(data))
        if len(data) < length:
            raise self.err(f"buffers[{index}]", f"byteLength {length} but only {len(data)} bytes available")
        self._buffers[index] = data
        return data

    def view_bytes(self, index: int, where: str) -> tuple[bytes, int, int, int | None]:
        """(buffer, start, length, byteStride) of a bufferView."""
        v = self.item("bufferViews", index, where)
        data = self.buffer(v.get("buffer", -1), f"bufferViews[{index}].buffer")
        start, length = int(v.get("byteOffset", 0)), int(v.get("byteLength", 0))
        if start < 0 or start + length > len(data):
            raise self.err(f"bufferViews[{index}]", f"bytes {start}…{start + length} exceed the buffer ({len(data)})")
        return data, start, length, v.get("byteStride")

    def accessor(self, index: int, where: str) -> np.ndarray:
        """An accessor's elements as (count, components) float64 (normalized integers scaled)."""
        a = self.item("accessors", index, where)
        w = f"accessors[{index}]"
        ctype, atype = a.get("componentType"), a.get("type")
        if ctype not in COMPONENT_TYPES or atype not in TYPE_SIZES:
            raise self.err(w, f"unsupported componentType {ctype!r} or type {atype!r}")
        dtype = np.dtype(COMPONENT_TYPES[ctype]).newbyteorder("<")
        n, count = TYPE_SIZES[atype], int(a.get("count", 0))
        if count < 0:
            raise self.err(w, f"negative count {count}")
        if "bufferView" in a:
            out = self._strided(a["bufferView"], int(a.get("byteOffset", 0)), dtype, n, count, w)
        else:  # all zeros (or sparse): no bytes back the count, so it is bounded here, before allocating
            if count * n > MAX_ZERO_ELEMENTS:
                raise self.err(w, f"{count} elements without a bufferView is more than the {MAX_ZERO_ELEMENTS:,} "
                                  "components an accessor without data may have")
            out = np.zeros((count, n), dtype=dtype)
        out = out.astype(np.float64)
        sparse = a.get("sparse")
        if sparse:
            k = int(sparse.get("count", 0))
            si, sv = sparse.get("indices", {}), sparse.get("values", {})
            it = COMPONENT_TYPES.get(si.get("componentType"))
            if it is None:
                raise self.err(f"{w}.sparse.indices", f"unsupported componentType {si.get('componentType')!r}")
            idx = self._strided(si.get("bufferView", -1), int(si.get("byteOffset", 0)), np.dtype(it), 1, k,
                                f"{w}.sparse.indices")[:, 0].astype(np.int64)
            vals = self._strided(sv.get("bufferView", -1), int(sv.get("byteOffset", 0)), dtype, n, k,
                                 f"{w}.sparse.values").astype(np.float64)
            if k and (idx.min() < 0 or idx.max() >= count):
                raise self.err(f"{w}.sparse.indices", f"index out of range 0…{count - 1}")
            out[idx] = vals
        if a.get("normalized"):
            if dtype.kind == "f":
                raise self.err(w, "normalized is only valid for integer components")
            info = np.iinfo(dtype)
            out = np.maximum(out / info.max, -1.0)
        return out

    def _strided(self, view: int, offset: int, dtype: np.dtype, n: int, count: int, where: str) -> np.ndarray:
        data, start, length, stride = self.view_bytes(view, where)
        elem = dtype.itemsize * n
        stride = int(stride or elem)
        if stride < elem:
            raise self.err(where, f"byteStride {stride} is smaller than one element ({elem} bytes)")
        need = offset + (count - 1) * stride + elem if count else 0
        if offset < 0 or need > length:
            raise self.err(where, f"{count} elements need {need} bytes, the bufferView has {length}")
        if count == 0:
            return np.zeros((0, n), dtype=dtype)
        arr = np.ndarray((count, n), dtype=dtype, buffer=data, offset=start + offset, strides=(stride, dtype.itemsize))
        return arr.copy()

    # -- parts ----------------------------------------------------------------------------

    def primitive(self, mesh_index: int, k: int, prim: dict, weights: tuple = (),
                  skin: np.ndarray | None = None) -> TriangleMesh | None:
        """One primitive's triangles, morphed at ``weights`` (one per target) and, with ``skin`` (its node's
        joint matrices, :func:`compare.scene.gltf_pose.skin_matrices`), posed in the glTF's world space; None
        for points and lines."""
        w = f"meshes[{mesh_index}].primitives[{k}]"
        mode = prim.get("mode", 4)
        if mode not in (4, 5, 6):
            self.notes.append(f"{w}: mode {mode} (points or lines) skipped")
            return None
        attrs = prim.get("attributes", {})
        if "POSITION" not in attrs:
            raise self.err(f"{w}.attributes", "no POSITION attribute")
        p = self.accessor(attrs["POSITION"], f"{w}.attributes.POSITION")
        if p.shape[1] != 3:
            raise self.err(f"{w}.attributes.POSITION", "expected VEC3 positions")
        if not np.all(np.isfinite(p)):
            raise self.err(f"{w}.attributes.POSITION", "non-finite vertex positions")
        nv = len(p)
        deltas = gltf_pose.morph_deltas(self, prim, w, nv, weights)
        p = p + deltas.get("POSITION", 0.0)
        if "indices" in prim:
            idx = self.accessor(prim["indices"], f"{w}.indices")[:, 0]
            if len(idx) and (idx.min() < 0 or idx.max() >= nv):
                raise self.err(f"{w}.indices", f"index out of range 0…{nv - 1}")
            idx = idx.astype(np.int64)
        else:
            idx = np.arange(nv, dtype=np.int64)
        if mode == 4:
            tri = idx[: len(idx) // 3 * 3].reshape(-1, 3)
        elif mode == 5:
            i = np.arange(max(len(idx) - 2, 0))
            odd = i % 2
            tri = np.stack([idx[i], idx[i + 1 + odd], idx[i + 2 - odd]], 1)
        else:
            i = np.arange(max(len(idx) - 2, 0))
            tri = np.stack([idx[i + 1], idx[i + 2], np.full_like(i, idx[0] if len(idx) else 0)], 1)
        if len(tri) == 0:
            self.notes.append(f"{w}: no triangles")
            return None
        uv = (self.accessor(attrs["TEXCOORD_0"], f"{w}.attributes.TEXCOORD_0") + deltas.get("TEXCOORD_0", 0.0)
              if "TEXCOORD_0" in attrs else np.zeros((nv, 2)))
        if "TEXCOORD_0" not in attrs and self._has_maps(prim.get("material")):
            self.notes.append(f"{w}: its material has texture maps but the primitive has no TEXCOORD_0: "
                              f"every map is read at texture coordinate (0, 0)")
        uv1 = (self.accessor(attrs["TEXCOORD_1"], f"{w}.attributes.TEXCOORD_1") + deltas.get("TEXCOORD_1", 0.0)
               if "TEXCOORD_1" in attrs else None)
        for key, where in ((uv, "TEXCOORD_0"), (uv1, "TEXCOORD_1")):
            if key is not None and (key.ndim != 2 or key.shape[1] != 2 or len(key) != nv):
                raise self.err(f"{w}.attributes.{where}", f"expected {nv} VEC2 texture coordinates")
        colors = self._colors(attrs, w, nv, deltas.get("COLOR_0"))
        n = tangents = None
        if "NORMAL" in attrs:
            n = self.accessor(attrs["NORMAL"], f"{w}.attributes.NORMAL") + deltas.get("NORMAL", 0.0)
            tangents = self._tangents(attrs, w, nv)
            if tangents is not None and "TANGENT" in deltas:
                tangents[:, :3] += deltas["TANGENT"]
        if skin is not None:
            p, n, tangents, mirrored = gltf_pose.skinned(self, attrs, w, nv, skin, p, n, tangents)
            # a mirroring pose turns the faces it mirrors (glTF's rule for a node transform, per vertex here)
            tri = np.where((mirrored[tri].sum(axis=1) >= 2)[:, None], tri[:, ::-1], tri)
            if not np.all(np.isfinite(p)):
                raise self.err(f"{w}.attributes.POSITION", "non-finite vertex positions after skinning")
        if tangents is not None and (deltas or skin is not None):
            length = np.linalg.norm(tangents[:, :3], axis=1)
            if not (length > 1e-12).all():
                raise self.err(f"{w}.attributes.TANGENT", f"{int((~(length > 1e-12)).sum())} tangents of zero "
                                                          "length after its morph targets or skin")
            tangents[:, :3] /= length[:, None]
        if n is not None:
            length = np.linalg.norm(n, axis=1)
            bad = ~(np.isfinite(length) & (length > 1e-12))
            if bad.any():
                self.notes.append(f"{w}: {int(bad.sum())} zero or non-finite normals replaced by face normals")
                n[bad] = geometry.vertex_normals(p, tri)[bad]
                length = np.linalg.norm(n, axis=1)
            n = n / length[:, None]
            return geometry._mesh(p, n, uv, tri, colors, tangents, uv1)
        # glTF: without normals, flat shading. Unweld so every triangle has its own face normal.
        pa, pb, pc = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
        fn = np.cross(pb - pa, pc - pa)
        length = np.linalg.norm(fn, axis=1, keepdims=True)
        fn = np.where(length > 1e-30, fn / np.maximum(length, 1e-30), np.array([0.0, 1.0, 0.0]))
        flat = tri.ravel()
        return geometry._mesh(p[flat], np.repeat(fn, 3, axis=0), uv[flat], np.arange(len(flat)).reshape(-1, 3),
                              None if colors is None else colors[flat], None, None if uv1 is None else uv1[flat])

    def _tangents(self, attrs: dict, w: str, nv: int) -> np.ndarray | None:
        """The file's TANGENT (nv, 4): xyz unit length, w = ±1 (glTF's rules; a file breaking them is named).
        None without it: renderers then take MikkTSpace's (compare.scene.tangents), as glTF prescribes."""
        if "TANGENT" not in attrs:
            return None
        where = f"{w}.attributes.TANGENT"
        t = self.accessor(attrs["TANGENT"], where)
        if t.shape[1] != 4:
            raise self.err(where, f"expected VEC4 tangents (xyz and the bitangent's sign w), got {t.shape[1]} components")
        if not np.isfinite(t).all():
            raise self.err(where, "NaN or infinite tangents")
        length = np.linalg.norm(t[:, :3], axis=1)
        if (length < 1e-12).any():
            raise self.err(where, f"{int((length < 1e-12).sum())} zero-length tangents")
        if not np.isin(t[:, 3], (-1.0, 1.0)).all():
            raise self.err(where, "w must be 1 or -1 (the bitangent's sign)")
        return np.concatenate([t[:, :3] / length[:, None], t[:, 3:]], axis=1)

    def _colors(self, attrs: dict, w: str, nv: int, delta: np.ndarray | None = None) -> np.ndarray | None:
        """COLOR_0 as linear RGBA (nv, 4), alpha 1 for VEC3, plus its morph targets' ``delta`` (clamped to
        [0, 1], with a note where it leaves that range); None without it (or where it is all white)."""
        if "COLOR_0" not in attrs:
            return None
        where = f"{w}.attributes.COLOR_0"
        c = self.accessor(attrs["COLOR_0"], where)
        if c.shape[1] not in (3, 4):
            raise self.err(where, f"expected VEC3 or VEC4 colours, got {c.shape[1]} components")
        if len(c) != nv:
            raise self.err(where, f"{len(c)} colours for {nv} vertices")
        if not np.all(np.isfinite(c)) or c.min() < 0.0 or c.max() > 1.0:
            raise self.err(where, "colours must be finite and in [0, 1] (glTF's COLOR_0 is linear RGB(A))")
        if c.shape[1] == 3:
            c = np.concatenate([c, np.ones((len(c), 1))], axis=1)
        if delta is not None:
            c = c + delta
            outside = ((c < 0.0) | (c > 1.0)).any(axis=1)
            if outside.any():
                self.notes.append(f"{where}: morphed colours of {int(outside.sum())} vertices leave [0, 1]; clamped")
                c = np.clip(c, 0.0, 1.0)
        return None if np.all(c == 1.0) else c.astype(np.float32)

    def _has_maps(self, index) -> bool:
        """Whether material ``index`` (None: the default material) names any texture (an alpha mask too)."""
        if index is None:
            return False
        m = self.item("materials", index, "material")
        pbr = m.get("pbrMetallicRoughness", {})
        sg = m.get("extensions", {}).get(gltf_specgloss.EXTENSION, {})
        return (any(k in pbr for k in ("baseColorTexture", "metallicRoughnessTexture"))
                or any(k in m for k in ("normalTexture", "occlusionTexture", "emissiveTexture"))
                or (isinstance(sg, dict) and any(k in sg for k in ("diffuseTexture", "specularGlossinessTexture")))
                or m.get("alphaMode") == "MASK")

    def material(self, index: int) -> GltfMaterial:
        m = self.item("materials", index, "material")
        w = f"materials[{index}]"
        exts = m.get("extensions", {}) if isinstance(m.get("extensions", {}), dict) else {}
        sg = exts.get(gltf_specgloss.EXTENSION)
        sg_where = f"{w}.extensions.{gltf_specgloss.EXTENSION}"
        if sg is not None:
            diffuse, specular, glossiness = gltf_specgloss.factors(sg, sg_where, self.err)
        # a spec-gloss material's pbrMetallicRoughness is the fallback of readers without the extension
        pbr = m.get("pbrMetallicRoughness", {}) if sg is None else {}
        base = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0]) if sg is None else diffuse
        if not (isinstance(base, list) and len(base) == 4):
            raise self.err(f"{w}.pbrMetallicRoughness.baseColorFactor", f"expected four numbers, got {base!r}")
        mode = m.get("alphaMode", "OPAQUE")
        if mode not in ("OPAQUE", "MASK", "BLEND"):
            raise self.err(f"{w}.alphaMode", f'expected "OPAQUE", "MASK" or "BLEND", got {mode!r}')
        cutoff = m.get("alphaCutoff", 0.5)
        if isinstance(cutoff, bool) or not isinstance(cutoff, (int, float)) or not 0.0 <= cutoff <= 1.0:
            raise self.err(f"{w}.alphaCutoff", f"expected a number in [0, 1], got {cutoff!r}")
        factor = m.get("emissiveFactor", [0.0, 0.0, 0.0])
        if (not isinstance(factor, list) or len(factor) != 3
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x >= 0
                           for x in factor)):
            raise self.err(f"{w}.emissiveFactor", f"expected three numbers >= 0, got {factor!r}")
        strength = m.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
        if isinstance(strength, bool) or not isinstance(strength, (int, float)) or not (
                math.isfinite(strength) and strength >= 0):
            raise self.err(f"{w}.extensions.KHR_materials_emissive_strength.emissiveStrength",
                           f"expected a finite number >= 0, got {strength!r}")
        emission = np.asarray(factor, dtype=np.float64) * float(strength)

        sampling: dict[str, MapSampling] = {}  # glTF texture key → how that map is read

        def image(key: str, table: dict | None = None, ext: str | None = None) -> int | None:
            info = (pbr if table is None else table).get(key)
            if info is None:
                return None
            xf = info.get("extensions", {}).get("KHR_texture_transform", {})
            where = (f"{w}.pbrMetallicRoughness.{key}" if table is None else
                     f"{w}.extensions.{ext}.{key}" if ext else f"{w}.{key}")
            # KHR_texture_transform's texCoord, where given, overrides the textureInfo's (the extension's text)
            texcoord = xf.get("texCoord", info.get("texCoord", 0))
            if isinstance(texcoord, bool) or not isinstance(texcoord, int) or texcoord < 0:
                raise self.err(f"{where}.texCoord", f"expected an integer >= 0, got {texcoord!r}")
            if texcoord >= TEXCOORD_SETS:
                self.notes.append(f"{w}.{key}: TEXCOORD_{texcoord} is not read (TEXCOORD_0 and _1 are); "
                                  "the map is read on TEXCOORD_0")
                texcoord = 0
            tex = self.item("textures", info.get("index", -1), f"{where}.index")
            sampler = self.item("samplers", tex["sampler"], f"{where}: texture sampler") if "sampler" in tex else {}
            wrap_s, wrap_t = sampler.get("wrapS", 10497), sampler.get("wrapT", 10497)
            try:
                offset = tuple(float(x) for x in xf.get("offset", [0.0, 0.0]))
                scale = tuple(float(x) for x in xf.get("scale", [1.0, 1.0]))
                rotation = math.degrees(float(xf.get("rotation", 0.0)))
            except (TypeError, ValueError):
                raise self.err(f"{where}.extensions.KHR_texture_transform", f"expected numbers, got {xf!r}") from None
            if len(offset) != 2 or len(scale) != 2 or not all(map(math.isfinite, offset + scale + (rotation,))):
                raise self.err(f"{where}.extensions.KHR_texture_transform", f"expected finite offset, rotation and "
                                                                            f"scale, got {xf!r}")
            # minFilter NEAREST or LINEAR reads level 0 only; absent or *_MIPMAP_*: mip levels
            sampling[key] = MapSampling(texcoord, offset, rotation, scale,
                                        (GL_WRAPS.get(wrap_s, "repeat"), GL_WRAPS.get(wrap_t, "repeat")),
                                        GL_FILTERS.get(sampler.get("magFilter", 9729), "linear"),
                                        sampler.get("minFilter") not in GL_FILTERS)
            src = tex.get("source")
            if src is None:
                self.notes.append(f"{w}.{key}: texture has no PNG/JPEG source; ignored")
            return src

        clamp = lambda v: min(max(float(v), 0.0), 1.0)  # noqa: E731
        if sg is None:
            maps = dict(base_color_image=image("baseColorTexture"),
                        metallic_roughness_image=image("metallicRoughnessTexture"))
            metallic, roughness = clamp(pbr.get("metallicFactor", 1.0)), clamp(pbr.get("roughnessFactor", 1.0))
        else:
            maps, roughness, sg_layers, sg_layer_images = gltf_specgloss.terms(self, sg, sg_where, image, specular,
                                                                               glossiness)
            metallic = 0.0
        images = dict(**maps, emissive_image=image("emissiveTexture", m),
                      occlusion_image=image("occlusionTexture", m),
                      normal_image=image("normalTexture", m))
        layer_images = []
        for ext in dict.fromkeys(layer.extension for layer in LAYERS):
            table = exts.get(ext)
            for key, (fld, channel) in LAYER_MAPS.items():
                if isinstance(table, dict) and key in table:
                    src = image(key, table, ext)
                    if src is not None:
                        layer_images.append((fld, channel, src))
        coat = exts.get("KHR_materials_clearcoat")
        coat_normal = coat.get("clearcoatNormalTexture") if isinstance(coat, dict) else None
        coat_normal_image = (image("clearcoatNormalTexture", coat, "KHR_materials_clearcoat")
                             if isinstance(coat_normal, dict) else None)
        coat_normal_scale = coat_normal.get("scale", 1.0) if isinstance(coat_normal, dict) else 1.0
        if isinstance(coat_normal_scale, bool) or not isinstance(coat_normal_scale, (int, float)) \
                or not math.isfinite(coat_normal_scale):
            raise self.err(f"{w}.extensions.KHR_materials_clearcoat.clearcoatNormalTexture.scale",
                           f"expected a finite number, got {coat_normal_scale!r}")
        layers = self._layers(m, w)
        if sg is not None:  # the conversion sets KHR_materials_specular and _ior (which must not sit beside it)
            clash = sorted({f for f in layers if f in gltf_specgloss.SETS}
                           | {f for f, _, _ in layer_images if f in gltf_specgloss.SETS})
            if clash:
                self.notes.append(f"{w}: its own {', '.join(clash)} replaced by the conversion of "
                                  f"{gltf_specgloss.EXTENSION}")
            layers.update(sg_layers)
            layer_images = [e for e in layer_images if e[0] not in gltf_specgloss.SETS] + sg_layer_images
        if "KHR_materials_unlit" in exts:
            # The base colour is what is seen, whatever the light: as emission of a surface that reflects
            # nothing (black, specularFactor 0), every renderer draws it with what it already has.
            emission = np.asarray(base[:3], dtype=np.float64)
            images.update(emissive_image=maps.get("base_color_image"), metallic_roughness_image=None,
                          occlusion_image=None, normal_image=None)
            base = [0.0, 0.0, 0.0, base[3]]  # the base map keeps only its alpha (a mask's holes)
            metallic, roughness = 0.0, 1.0
            layers, layer_images, coat_normal_image = {"specular": 0.0}, [], None
            if "baseColorTexture" in sampling:
                sampling["emissiveTexture"] = sampling["baseColorTexture"]
        if mode != "OPAQUE" and max(emission) > 0:
            self.notes.append(f"{w}: alphaMode {mode} of an emissive material is not modelled (rendered opaque)")
            mode = "OPAQUE"
        return GltfMaterial(
            name=str(m.get("name") or f"material{index}"),
            base_color=tuple(clamp(c) for c in base[:3]),  # type: ignore[arg-type]
            metallic=metallic,
            roughness=roughness,
            emission=tuple(float(max(e, 0.0)) for e in emission),  # type: ignore[arg-type]
            sampling=tuple((name, sampling[key]) for key, names in MAP_KEYS.items() if key in sampling
                           for name in names),
            **images,
            occlusion_strength=clamp(m.get("occlusionTexture", {}).get("strength", 1.0)),
            normal_scale=float(m.get("normalTexture", {}).get("scale", 1.0)),
            alpha_mode=mode.lower(),
            alpha=clamp(base[3]),
            alpha_cutoff=float(cutoff),
            double_sided=self._double_sided(m, w),
            layers=layers,
            layer_images=tuple(layer_images),
            clearcoat_normal_image=coat_normal_image,
            clearcoat_normal_scale=float(coat_normal_scale),
            unlit="KHR_materials_unlit" in exts,
        )

    def _double_sided(self, m: dict, w: str) -> bool:
        value = m.get("doubleSided", False)
        if not isinstance(value, bool):
            raise self.err(f"{w}.doubleSided", f"expected true or false, got {value!r}")
        return value

    def _layers(self, m: dict, w: str) -> dict:
        """The factors of the material extensions (LAYERS) that ``m`` sets; their maps are not read."""
        out = {}
        exts = m.get("extensions", {}) if isinstance(m.get("extensions", {}), dict) else {}
        for layer in LAYERS:
            table = exts.get(layer.extension)
            if not isinstance(table, dict) or layer.key not in table:
                continue
            where = f"{w}.extensions.{layer.extension}.{layer.key}"
            v = table[layer.key]
            if layer.color:
                ok = (isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                                  and math.isfinite(x) and x >= 0 for x in v))
                if not ok or max(v) > layer.hi:
                    rng = ">= 0" if math.isinf(layer.hi) else f"in [0, {layer.hi:g}]"
                    raise self.err(where, f"expected three numbers {rng}, got {v!r}")
                out[layer.field] = tuple(float(x) for x in v)
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
                raise self.err(where, f"expected a number, got {v!r}")
            if layer.field == "ior" and v == 0:
                v = 1e4  # glTF: ior 0 is a limit of infinite index, a Fresnel of 1 (a mirror)
            if not layer.lo <= v <= layer.hi:
                raise self.err(where, f"expected a number in [{layer.lo:g}, {layer.hi:g}], got {v!r}")
            out[layer.field] = float(v)
        for ext in dict.fromkeys(layer.extension for layer in LAYERS):
            maps = sorted(k for k in exts.get(ext, {})
                          if isinstance(k, str) and k.endswith("Texture") and k not in LAYER_MAPS
                          and k not in MAPS_READ_APART)
            if maps:
                self.notes.append(f"{w}.extensions.{ext}: {', '.join(maps)} not read (the factors are)")
        return out

    def image(self, index: int) -> Path | None:
        img = self.item("images", index, "image")
        w = f"images[{index}]"
        mime = img.get("mimeType", "")
        if "uri" in img:
            decoded = self.data_uri(img["uri"])
            if decoded is None:
                path = self.external(img["uri"], f"{w}.uri")
                if path.suffix.lower() not in (".png", ".jpg", ".jpeg"):
                    self.notes.append(f"{w}: {path.name} is not PNG or JPEG; ignored")
                    return None
                return path
            mime, data = decoded[0] or mime, decoded[1]
        elif "bufferView" in img:
            buf, start, length, _ = self.view_bytes(img["bufferView"], f"{w}.bufferView")
            data = buf[start:start + length]
        else:
            raise self.err(w, "needs a uri or a bufferView")
        suffix = {"image/png": ".png", "image/jpeg": ".jpg"}.get(mime)
        if suffix is None:
            self.notes.append(f"{w}: mime type {mime!r} is not PNG or JPEG; ignored")
            return None
        return _cache_image(data, suffix)


def _cache_image(data: bytes, suffix: str) -> Path:
    """Write an embedded image once, named by its content hash, where Mitsuba can read it."""
    from compare.util.cache import default_cache_dir

    path = default_cache_dir() / "gltf-images" / f"{sha256_bytes(data)[:32]}{suffix}"
    if not path.is_file() or path.stat().st_size != len(data):
        write_bytes_atomic(path, data)
    return path


def _numbers(node: dict, key: str, count: int, default, where: str, err) -> list[float]:
    """``node[key]``: ``count`` finite numbers, or one error naming the node's field."""
    v = node.get(key, default)
    if (not isinstance(v, list) or len(v) != count
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v)):
        raise err(f"{where}.{key}", f"expected {count} finite numbers, got {v!r}")
    return [float(x) for x in v]


def _node_matrix(node: dict, where: str, err) -> np.ndarray:
    """The node's local matrix (``matrix``, or translation · rotation · scale), every value checked;
    ``err(field, message)`` makes the error naming the file."""
    if "matrix" in node:
        return np.asarray(_numbers(node, "matrix", 16, None, where, err), dtype=np.float64).reshape(4, 4).T
    m = np.eye(4)
    x, y, z, w = _numbers(node, "rotation", 4, [0, 0, 0, 1], where, err)
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not norm > 1e-12:
        raise err(f"{where}.rotation", f"a rotation quaternion must have unit length, got {[x, y, z, w]}")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m[:3, :3] = r @ np.diag(np.asarray(_numbers(node, "scale", 3, [1, 1, 1], where, err), dtype=np.float64))
    m[:3, 3] = _numbers(node, "translation", 3, [0, 0, 0], where, err)
    return m


def load_gltf(path: str | os.PathLike, *, root: str | os.PathLike | None = None) -> GltfDocument:
    """Read a ``.gltf`` or ``.glb`` file: primitives, materials, images, cameras, lights.

    Parameters
    ----------
    path
        The file. External buffers and images are resolved relative to it.
    root
        Folder that external files must stay inside (the scene file's folder);
        default: the glTF file's folder.

    Raises
    ------
    GltfError
        Naming the file and the JSON path, for anything malformed or unsupported.
    """
    path = Path(path)
    try:
        r = _Reader(path, Path(root).resolve() if root is not None else path.parent.resolve())
        return _read_document(path, r)
    except GltfError:
        raise
    except (AttributeError, TypeError, KeyError, IndexError, ValueError, OverflowError) as exc:
        # The reader checks the fields it knows to go wrong by name; any other field of the wrong
        # JSON type (an object where a list belongs, a string for an index) ends here, as one
        # error naming the file, instead of a check per field of the glTF schema.
        raise GltfError(f"{path}: malformed glTF ({type(exc).__name__}: {exc}); check it with the Khronos "
                        "glTF validator") from None


def _mesh_triangles(r: "_Reader", mesh_index: int) -> int:
    """Triangles mesh ``mesh_index`` holds, from its accessors' counts (nothing decoded)."""
    total = 0
    for p in r.item("meshes", mesh_index, "mesh").get("primitives", []):
        key = p.get("indices", p.get("attributes", {}).get("POSITION"))
        count = r.item("accessors", key, "accessor").get("count", 0) if key is not None else 0
        total += max(int(count) // 3, 1) if isinstance(count, int) else 1
    return total


def _read_document(path: Path, r: "_Reader") -> GltfDocument:
    doc = r.doc
    nodes = doc.get("nodes", [])
    scenes = doc.get("scenes")
    if scenes:
        s = r.item("scenes", doc.get("scene", 0), "scene")
        roots = list(s.get("nodes", []))
    else:  # no scenes: every node that is nobody's child
        children = {c for n in nodes for c in n.get("children", [])}
        roots = [i for i in range(len(nodes)) if i not in children]
        if nodes and not roots:  # every node is somebody's child: the hierarchy is a cycle
            raise r.err("nodes", "the node hierarchy has a cycle (every node is another's child, and the file has "
                                 "no scenes to say where it starts)")
    light_defs = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])

    cameras: list[GltfCamera] = []
    lights: list[GltfLight] = []
    worlds: dict[int, np.ndarray] = {}
    parts: list[tuple[int, str, np.ndarray, int]] = []  # (node, name, world, mesh) of each mesh node, in order
    instanced: dict[str, int] = {}  # parts and triangles of EXT_mesh_gpu_instancing so far (bounded)

    def visit(index: int, parent: np.ndarray, parent_index: int | None, inherited: str | None) -> list:
        """One node's parts; returns its children to visit, as (index, world, its index, inherited name)."""
        if index in on_path:
            raise r.err(f"nodes[{index}]", "the node hierarchy has a cycle")
        node = r.item("nodes", index, f"nodes[{parent_index}].children" if parent_index is not None else "scene.nodes")
        world = parent @ _node_matrix(node, f"nodes[{index}]", r.err)
        worlds[index] = world
        # A part's name: its node's, else its mesh's, else its nearest named ancestor's (optimisers such as
        # gltfpack put a mesh on an unnamed child node that holds the dequantisation transform).
        own = node.get("name") or None
        if own is None and "mesh" in node:
            own = r.item("meshes", node["mesh"], f"nodes[{index}].mesh").get("name") or None
        name = str(own or inherited or f"node{index}")
        if "mesh" in node:  # made once every node's world is known: a skin's joints may come later
            instances = gltf_instancing.instance_matrices(r, node, f"nodes[{index}]", _mesh_triangles(r, node["mesh"]),
                                                          instanced)
            if instances is None:
                parts.append((index, name, world, node["mesh"]))
            else:  # each instance a part of its own, sharing the mesh's triangles
                parts.extend((index, f"{name}#{k}", world @ m, node["mesh"]) for k, m in enumerate(instances))
        if "camera" in node:
            cam = r.item("cameras", node["camera"], f"nodes[{index}].camera")
            if cam.get("type") == "perspective" and "perspective" in cam:
                pp = cam["perspective"]
                cameras.append(GltfCamera(str(cam.get("name") or name), world, float(pp.get("yfov", 0.8)),
                                          float(pp["aspectRatio"]) if pp.get("aspectRatio") else None))
            else:
                r.notes.append(f"cameras[{node['camera']}]: only perspective cameras are supported; skipped")
        ext = node.get("extensions", {}).get("KHR_lights_punctual")
        if ext is not None:
            li = ext.get("light", -1)
            if isinstance(li, bool) or not isinstance(li, int) or not 0 <= li < len(light_defs):
                raise r.err(f"nodes[{index}].extensions.KHR_lights_punctual.light", f"index {li!r} out of range")
            d = light_defs[li]
            kind = d.get("type")
            where = f"extensions.KHR_lights_punctual.lights[{li}]"
            if kind not in ("point", "spot", "directional"):
                raise r.err(f"{where}.type", f"expected 'point', 'spot' or 'directional', got {kind!r}")
            spot = d.get("spot", {}) if kind == "spot" else {}
            inner, outer = float(spot.get("innerConeAngle", 0.0)), float(spot.get("outerConeAngle", math.pi / 4))
            if kind == "spot" and not 0 <= inner < outer <= math.pi / 2:
                raise r.err(f"{where}.spot", f"expected 0 <= innerConeAngle < outerConeAngle <= pi/2, got {inner} "
                                             f"and {outer}")
            rng = d.get("range")
            reach = float(np.max(np.abs(world[:3, 3])))
            problem = (geometry.world_range_problem(reach) if np.all(np.isfinite(world))
                       else "a transform that is not finite (its node's or an ancestor's)")
            if problem:
                raise r.err(f"nodes[{index}]", f"the light's position reaches {problem}")
            if kind != "point" and not np.linalg.norm(world[:3, 2]) > 1e-12:
                raise r.err(f"nodes[{index}]", f"the {kind} light's node transform has zero scale along its -Z: "
                                               "it has no direction")
            lights.append(GltfLight(str(d.get("name") or f"light{li}"), kind,
                                    tuple(float(c) for c in d.get("color", [1, 1, 1])),  # type: ignore[arg-type]
                                    float(d.get("intensity", 1.0)), world, inner, outer,
                                    None if rng is None else float(rng)))
        return [(child, world, index, str(own) if own else inherited) for child in node.get("children", [])]

    # Depth first without recursion (a chain of thousands of nodes is valid glTF); `on_path` holds the
    # ancestors of the node being visited, so a cycle is found whatever the depth.
    on_path: set[int] = set()
    todo: list = [("enter", (root, np.eye(4), None, None)) for root in reversed(roots)]
    while todo:
        what, item = todo.pop()
        if what == "exit":
            on_path.discard(item)
            continue
        children = visit(*item)
        on_path.add(item[0])
        todo.append(("exit", item[0]))
        todo.extend(("enter", child) for child in reversed(children))
    primitives = [GltfPrimitive(*part) for part in gltf_pose.posed_parts(r, parts, worlds)]
    if doc.get("animations"):
        r.notes.append(f"{len(doc['animations'])} animation(s) not played: nodes, morph weights and skins take the "
                       "pose the file gives without them")
    r.images = [r.image(i) for i in range(len(doc.get("images", [])))]
    materials = [r.material(i) for i in range(len(doc.get("materials", [])))]
    return GltfDocument(path, primitives, materials, r.images, cameras, lights, r.files, r.notes, r.extensions)

