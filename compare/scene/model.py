"""The scene model every renderer reads: camera, materials, meshes, area lights, environment.

Built by :func:`compare.scene.loader.load_scene` from a scene file (TOML); see that
module for the file's conventions (units, handedness, light radiometry).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from compare.scene import geometry
from compare.util.errors import SceneError
from compare.util.files import sha256_bytes

MESH_SHAPES = ("quad", "box", "sphere", "cylinder", "file")
MESH_FILE_SUFFIXES = (".ply", ".obj")
TEXTURE_SUFFIXES = (".png", ".jpg", ".jpeg", ".exr")
ENV_FILE_SUFFIXES = (".exr", ".hdr")
#: Holes of alpha masks one path may cross without counting a bounce (Cycles' transparent bounces): every
#: path tracer of the suite stops there.
MAX_HOLES = 64
#: A material counts as glossy (needs specular lighting work) below this roughness, or when metallic.
GLOSSY_ROUGHNESS = 0.6
#: Indirect diffuse light in the rasterizer: none (the paper's technique) or an irradiance volume.
INDIRECT_MODES = ("none", "probes")
#: Default probes per axis and bounces of the irradiance volume (compare.progressive.indirect.probes).
DEFAULT_PROBE_GRID = (6, 6, 6)
DEFAULT_PROBE_BOUNCES = 2
#: Largest number of probes along one axis (keeps the volume's textures small).
MAX_PROBES_PER_AXIS = 64


@dataclass(frozen=True)
class Camera:
    """Pinhole camera: position, look-at target, up vector, vertical FOV in degrees, resolution (w, h)."""

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    fov: float = 45.0
    resolution: tuple[int, int] = (320, 240)

    @property
    def width(self) -> int:
        return self.resolution[0]

    @property
    def height(self) -> int:
        return self.resolution[1]

    @property
    def aspect(self) -> float:
        return self.resolution[0] / self.resolution[1]

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orthonormal (right, up, forward) in world space; image x grows along right."""
        f = np.subtract(self.target, self.position).astype(np.float64)
        f /= np.linalg.norm(f)
        r = np.cross(f, self.up)
        r /= np.linalg.norm(r)
        u = np.cross(r, f)
        return r, u, f

    def ray_directions(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Unit world directions through continuous film positions (x right, y down, in pixels).

        Pixel (i, j) covers [i, i+1) × [j, j+1) with row 0 at the top, as in
        Mitsuba's film and the rasterizer's readback.
        """
        r, u, f = self.basis()
        t = math.tan(math.radians(self.fov) / 2)
        sx = (2 * np.asarray(x, dtype=np.float64) / self.width - 1) * t * self.aspect
        sy = (1 - 2 * np.asarray(y, dtype=np.float64) / self.height) * t
        d = f + sx[..., None] * r + sy[..., None] * u
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def view_matrix(self) -> np.ndarray:
        """World → camera (OpenGL convention: camera looks down −Z, +Y up, +X right)."""
        r, u, f = self.basis()
        m = np.eye(4)
        m[0, :3], m[1, :3], m[2, :3] = r, u, -f
        m[:3, 3] = -m[:3, :3] @ np.asarray(self.position, dtype=np.float64)
        return m

    def projection_matrix(self, near: float, far: float, jitter: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
        """OpenGL perspective projection; ``jitter`` is a sub-pixel offset in pixels (x right, y up).

        Jitter (0, 0) puts pixel centres at (i + 0.5, j + 0.5), the same
        convention as Mitsuba's film.
        """
        t = 1.0 / math.tan(math.radians(self.fov) / 2)
        m = np.zeros((4, 4))
        m[0, 0] = t / self.aspect
        m[1, 1] = t
        m[2, 2] = (far + near) / (near - far)
        m[2, 3] = 2 * far * near / (near - far)
        m[3, 2] = -1.0
        # A shift of d pixels is 2d/width in NDC; added to clip x as 2d/width · w_clip.
        m[0, 2] = -2.0 * jitter[0] / self.width
        m[1, 2] = -2.0 * jitter[1] / self.height
        return m


@dataclass(frozen=True)
class Layer:
    """One parameter of a glTF material extension (``KHR_materials_*``) in the scene model: the field of
    :class:`Material`, its default, the extension and key it is read from and written to, whether it is a
    colour, and its valid range. :data:`LAYERS` is the one list the TOML loader, the glTF reader and writer
    and :meth:`Material.uses` derive from."""

    field: str
    default: Any
    extension: str
    key: str
    color: bool = False
    lo: float = 0.0
    hi: float = 1.0


#: The material extensions' parameters (factors; their maps are not read and the import says so).
LAYERS = (
    Layer("transmission", 0.0, "KHR_materials_transmission", "transmissionFactor"),
    Layer("ior", 1.5, "KHR_materials_ior", "ior", lo=1.0, hi=1e4),
    Layer("thickness", 0.0, "KHR_materials_volume", "thicknessFactor", hi=math.inf),
    Layer("attenuation_distance", math.inf, "KHR_materials_volume", "attenuationDistance", lo=1e-12, hi=math.inf),
    Layer("attenuation_color", (1.0, 1.0, 1.0), "KHR_materials_volume", "attenuationColor", color=True),
    Layer("clearcoat", 0.0, "KHR_materials_clearcoat", "clearcoatFactor"),
    Layer("clearcoat_roughness", 0.0, "KHR_materials_clearcoat", "clearcoatRoughnessFactor"),
    Layer("sheen_color", (0.0, 0.0, 0.0), "KHR_materials_sheen", "sheenColorFactor", color=True),
    Layer("sheen_roughness", 0.0, "KHR_materials_sheen", "sheenRoughnessFactor"),
    Layer("specular", 1.0, "KHR_materials_specular", "specularFactor"),
    Layer("specular_color", (1.0, 1.0, 1.0), "KHR_materials_specular", "specularColorFactor", color=True, hi=math.inf),
    Layer("dispersion", 0.0, "KHR_materials_dispersion", "dispersion", hi=math.inf),
    Layer("anisotropy_strength", 0.0, "KHR_materials_anisotropy", "anisotropyStrength"),
    Layer("anisotropy_rotation", 0.0, "KHR_materials_anisotropy", "anisotropyRotation", lo=-math.inf, hi=math.inf),
    Layer("iridescence", 0.0, "KHR_materials_iridescence", "iridescenceFactor"),
    Layer("iridescence_ior", 1.3, "KHR_materials_iridescence", "iridescenceIor", lo=1.0, hi=1e4),
    Layer("iridescence_thickness_min", 100.0, "KHR_materials_iridescence", "iridescenceThicknessMinimum",
          hi=math.inf),
    Layer("iridescence_thickness_max", 400.0, "KHR_materials_iridescence", "iridescenceThicknessMaximum",
          hi=math.inf),
)
#: How a map wraps ("repeat", "clamp", "mirror") and is filtered when magnified ("linear", "nearest").
TEXTURE_WRAPS = ("repeat", "clamp", "mirror")
TEXTURE_FILTERS = ("linear", "nearest")
#: The texture coordinate sets a map may read (glTF's TEXCOORD_0 and TEXCOORD_1).
TEXCOORD_SETS = 2


@dataclass(frozen=True)
class MapSampling:
    """How one map is read: glTF's ``texCoord`` of its textureInfo, its ``KHR_texture_transform`` (offset,
    rotation in degrees here, radians in glTF, scale; applied as offset · rotation · scale) and its texture's
    sampler (wrapS and wrapT apart; the magnification filter; whether minification reads mip levels)."""

    texcoord: int = 0
    offset: tuple[float, float] = (0.0, 0.0)
    rotation: float = 0.0
    scale: tuple[float, float] = (1.0, 1.0)
    wrap: tuple[str, str] = ("repeat", "repeat")
    filter: str = "linear"
    mipmaps: bool = True

    def uv_transform(self) -> np.ndarray:
        """The 3 × 3 matrix glTF's KHR_texture_transform applies to texture coordinates (column vectors)."""
        c, s = math.cos(math.radians(self.rotation)), math.sin(math.radians(self.rotation))
        t = np.array([[1.0, 0.0, self.offset[0]], [0.0, 1.0, self.offset[1]], [0.0, 0.0, 1.0]])
        r = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        return t @ r @ np.diag([self.scale[0], self.scale[1], 1.0])

    @property
    def has_uv_transform(self) -> bool:
        return (self.offset, self.rotation, self.scale) != ((0.0, 0.0), 0.0, (1.0, 1.0))


#: The names of a material's maps a sampling is given for (:meth:`Material.sampling`): the core maps' fields,
#: the coat's normal map, and the extensions' maps by the field they multiply (:data:`LAYER_MAPS`).
CORE_MAPS = ("base_color_texture", "metallic_roughness_texture", "emissive_texture", "occlusion_texture",
             "normal_texture", "clearcoat_normal_texture")

#: The scene feature each material extension makes (Features fields); "alpha_blend" is alphaMode BLEND.
MATERIAL_FEATURES = {"KHR_materials_transmission": "transmission", "KHR_materials_volume": "volume",
                     "KHR_materials_ior": "ior", "KHR_materials_clearcoat": "clearcoat",
                     "KHR_materials_sheen": "sheen", "KHR_materials_specular": "specular",
                     "KHR_materials_dispersion": "dispersion", "KHR_materials_anisotropy": "anisotropy",
                     "KHR_materials_iridescence": "iridescence"}
#: The extensions' maps that are read: glTF key → (the field it multiplies, its channel).
LAYER_MAPS = {"transmissionTexture": ("transmission", "r"), "clearcoatTexture": ("clearcoat", "r"),
              "clearcoatRoughnessTexture": ("clearcoat_roughness", "g"),
              "sheenColorTexture": ("sheen_color", "rgb"), "sheenRoughnessTexture": ("sheen_roughness", "a"),
              "specularTexture": ("specular", "a"), "specularColorTexture": ("specular_color", "rgb"),
              # read and passed on (the job's glTF); the path tracers take the thickness from the geometry
              "thicknessTexture": ("thickness", "g"),
              # the direction in the tangent frame (RG, [0, 1] → [−1, 1]) and the strength's multiplier (B)
              "anisotropyTexture": ("anisotropy_strength", "xyz"),
              "iridescenceTexture": ("iridescence", "r"),
              # not a multiplier: the film's thickness is mix(minimum, maximum, G)
              "iridescenceThicknessTexture": ("iridescence_thickness_max", "g")}
#: (Channel "rgb": an sRGB colour map; "xyz": a linear map's three channels, a vector; the others: one
#: channel of a linear map.)
def channel_iors(ior: float, dispersion: float) -> tuple[float, float, float]:
    """The red, green and blue IORs of a dispersive volume (KHR_materials_dispersion's rule for RGB renderers:
    green at the material's ior, red and blue half the spread n_F − n_C = (ior − 1) / V_d below and above it,
    V_d = 20 / dispersion; never below 1)."""
    half = (ior - 1.0) * 0.025 * dispersion
    return (max(ior - half, 1.0), ior, ior + half)


#: Every material feature a renderer may declare it renders (Renderer.renders).
MATERIAL_FEATURE_NAMES = ("alpha_blend", *MATERIAL_FEATURES.values(), "layer_maps")
#: What a mesh's vertices may carry beyond the core model, declared like a material feature (the materials
#: of the meshes that carry it): "vertex_colors", glTF's COLOR_0 multiplying base colour and alpha;
#: "single_sided", a material with doubleSided false, whose back faces are culled.
GEOMETRY_FEATURE_NAMES = ("vertex_colors", "single_sided")
#: How a material's maps are read beyond one texture coordinate set and one sampler, declared like a material
#: feature: "uv_sets", a map on TEXCOORD_1; "map_samplers", maps of one material with different texture
#: transforms or samplers, or a sampler whose wrapS and wrapT differ.
MAP_FEATURE_NAMES = ("uv_sets", "map_samplers")
#: What a scene as a whole may ask beyond the core model, declared like a material feature:
#: "hidden_background", an environment that lights the scene but is not seen where a camera ray hits no
#: surface (``[environment] background = false``; the image is black there).
SCENE_FEATURE_NAMES = ("hidden_background",)
#: Every feature a renderer may declare it renders (Renderer.renders, an external renderer's `renders`).
FEATURE_NAMES = MATERIAL_FEATURE_NAMES + MAP_FEATURE_NAMES + GEOMETRY_FEATURE_NAMES + SCENE_FEATURE_NAMES
#: glTF's alpha modes in the scene model.
ALPHA_MODES = ("opaque", "mask", "blend")


@dataclass(frozen=True)
class Material:
    """glTF 2.0 metallic-roughness material (linear base colour, perceptual roughness)."""

    name: str
    base_color: tuple[float, float, float] = (0.8, 0.8, 0.8)
    metallic: float = 0.0
    roughness: float = 0.5
    emission: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_color_texture: Path | None = None
    metallic_roughness_texture: Path | None = None
    #: An sRGB emission map, multiplied by ``emission`` (glTF's emissiveTexture × emissiveFactor).
    emissive_texture: Path | None = None
    #: glTF's occlusion map (R channel, linear) and its strength: it darkens the ambient and indirect
    #: light a renderer approximates (environment light, irradiance probes), never the direct light. A
    #: path tracer computes that occlusion itself and leaves the map out (the reference, Cycles).
    occlusion_texture: Path | None = None
    occlusion_strength: float = 1.0
    #: glTF's tangent-space normal map (RGB linear, +X along increasing u, +Y up the image, +Z out of
    #: the surface) and its scale (the map's X and Y are multiplied by it before normalising).
    normal_texture: Path | None = None
    normal_scale: float = 1.0
    #: The texture transform of every map of the material (glTF's KHR_texture_transform): offset,
    #: rotation (degrees here; radians in glTF) and scale, applied as offset · rotation · scale.
    texture_offset: tuple[float, float] = (0.0, 0.0)
    texture_rotation: float = 0.0
    texture_scale: tuple[float, float] = (1.0, 1.0)
    #: How the maps are sampled: ``texture_wrap`` "repeat", "clamp" or "mirror"; ``texture_filter``
    #: "linear" (mipmapped where a renderer has mipmaps) or "nearest".
    texture_wrap: str = "repeat"
    texture_filter: str = "linear"
    #: glTF's alpha mode: "opaque" (alpha ignored) or "mask": the surface exists where its coverage,
    #: ``alpha`` (baseColorFactor's alpha) times the base-colour map's alpha channel, is at least
    #: ``alpha_cutoff``, and is a hole elsewhere, for camera rays, shadows and light alike.
    alpha_mode: str = "opaque"
    alpha: float = 1.0
    alpha_cutoff: float = 0.5
    #: glTF's doubleSided: False culls back faces (they are not there for camera rays, in every renderer;
    #: for the ground truth's other rays too); True shades them with the normal turned to the viewer. A
    #: scene file's own materials default to True, a glTF's to glTF's default, False.
    double_sided: bool = True
    #: The material extensions (:data:`LAYERS`): ``KHR_materials_transmission``, ``_ior``, ``_volume``
    #: (thickness 0: thin-walled), ``_clearcoat``, ``_sheen`` (Charlie), ``_specular``; glTF's defaults
    #: leave the core material as it is. ``alpha_mode = "blend"``: coverage ``alpha`` (times the base-colour
    #: map's alpha), as stochastic coverage where a renderer traces it.
    transmission: float = 0.0
    ior: float = 1.5
    thickness: float = 0.0
    attenuation_distance: float = math.inf
    attenuation_color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    clearcoat: float = 0.0
    clearcoat_roughness: float = 0.0
    sheen_color: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sheen_roughness: float = 0.0
    specular: float = 1.0
    specular_color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    #: KHR_materials_dispersion: 20 / Abbe number; the refracting volume's IOR per colour channel,
    #: (ior − h, ior, ior + h) with h = (ior − 1) · 0.025 · dispersion (:func:`channel_iors`).
    dispersion: float = 0.0
    #: KHR_materials_anisotropy: the strength s stretches the specular lobe along the anisotropy direction
    #: (α_t = mix(α, 1, s²), α_b = α), the direction being the tangent turned by ``anisotropy_rotation``
    #: (radians, counter-clockwise towards the bitangent).
    anisotropy_strength: float = 0.0
    anisotropy_rotation: float = 0.0
    #: KHR_materials_iridescence: a thin film (index ``iridescence_ior``, ``iridescence_thickness_max`` nm thick
    #: where no thickness map is read) whose Fresnel (:mod:`compare.brdf.iridescence`) the factor mixes in.
    iridescence: float = 0.0
    iridescence_ior: float = 1.3
    iridescence_thickness_min: float = 100.0
    iridescence_thickness_max: float = 400.0
    #: The extensions' maps that are read (:data:`LAYER_MAPS`): (field, channel, linear map), each multiplying
    #: its field's factor, with the material's texture transform.
    layer_maps: tuple[tuple[str, str, Path], ...] = ()
    #: glTF's clearcoatNormalTexture (tangent space, as normal_texture) and its scale: the coat's own
    #: normal; None: the geometry's (not the base's normal map).
    clearcoat_normal_texture: Path | None = None
    clearcoat_normal_scale: float = 1.0
    #: The maps read otherwise than the material-wide settings above (``texture_*``): (map name of
    #: :data:`CORE_MAPS` or a layer map's field, its :class:`MapSampling`), as a glTF gives each map its own.
    map_sampling: tuple[tuple[str, MapSampling], ...] = ()

    @property
    def default_sampling(self) -> MapSampling:
        """The sampling of every map not named in :attr:`map_sampling` (the ``texture_*`` fields)."""
        return MapSampling(0, self.texture_offset, self.texture_rotation, self.texture_scale,
                           (self.texture_wrap, self.texture_wrap), self.texture_filter, self.texture_filter != "nearest")

    def sampling(self, name: str) -> MapSampling:
        """How map ``name`` (a field of :data:`CORE_MAPS`, or a layer map's field) is read."""
        return dict(self.map_sampling).get(name, self.default_sampling)

    def map_names(self) -> list[str]:
        """The names (:meth:`sampling`) of the maps this material has."""
        core = [n for n in CORE_MAPS if getattr(self, n) is not None]
        return core + [fld for fld, _, _ in self.layer_maps]

    def uses(self) -> set[str]:
        """The features (:data:`MATERIAL_FEATURES`, "alpha_blend") this material needs beyond the core
        metallic-roughness model: an extension whose parameters are not all glTF's defaults. A volume
        without transmission changes nothing (glTF) and is not counted."""
        out = {"alpha_blend"} if self.alpha_mode == "blend" else set()
        extension_of = {layer.field: layer.extension for layer in LAYERS}
        for layer in LAYERS:
            if getattr(self, layer.field) != layer.default:
                out.add(MATERIAL_FEATURES[layer.extension])
        # A map changes its layer whatever the factor (a specular map under the default factor 1 lowers it);
        # "layer_maps": the material reads maps of the extensions at all (a renderer may draw factors only).
        for fld, _, _ in self.layer_maps:
            out.update({MATERIAL_FEATURES[extension_of[fld]], "layer_maps"})
        # A volume absorbs only with a finite attenuation distance, and only where light is transmitted;
        # its thickness alone makes the surface the boundary of a solid (refraction), part of transmission.
        if "volume" in out and (self.transmission == 0.0 or math.isinf(self.attenuation_distance)
                                or min(self.attenuation_color) >= 1.0):
            out.discard("volume")
        if self.clearcoat == 0.0:
            out.discard("clearcoat")
        if self.transmission == 0.0 or self.thickness == 0.0:
            out.discard("dispersion")  # glTF: dispersion spreads the IOR of a volume's refraction, nothing else
        if self.anisotropy_strength == 0.0:
            out.discard("anisotropy")  # a rotation alone stretches nothing
        if self.iridescence == 0.0:
            out.discard("iridescence")  # glTF: a factor of 0 leaves the material as it is
        if max(self.sheen_color) == 0.0:
            out.discard("sheen")
        if self.clearcoat_normal_texture is not None and "clearcoat" in out:
            out.add("layer_maps")
        elif not any(MATERIAL_FEATURES[extension_of[fld]] in out for fld, _, _ in self.layer_maps):
            out.discard("layer_maps")  # only maps of layers that a zero factor turns off
        samplings = {self.sampling(n) for n in self.map_names()}
        if any(s.texcoord != 0 for s in samplings):
            out.add("uv_sets")
        if len(samplings) > 1 or any(s.wrap[0] != s.wrap[1] for s in samplings):
            out.add("map_samplers")
        return out

    @property
    def normal_mapped(self) -> bool:
        """Whether the material reads glTF's tangent frame: a map in tangent space (normalTexture,
        clearcoatNormalTexture) or an anisotropy direction; its meshes need their tangent frame
        (:meth:`Mesh.triangles` with ``tangents``)."""
        return (self.normal_texture is not None or self.clearcoat_normal_texture is not None
                or self.anisotropy_strength > 0.0)  # an anisotropy direction is given in that frame too

    @property
    def tangent_uv(self) -> int:
        """The texture coordinate set of the tangent frame (glTF: MikkTSpace on the normal map's set)."""
        name = "normal_texture" if self.normal_texture is not None else "clearcoat_normal_texture"
        return self.sampling(name).texcoord
    #: The Principled BSDF's microfacet distribution in Blender (``multi_ggx``, Blender's default, or
    #: ``ggx``): what the Blender comparators set and the reference's ``cycles`` mode models. The
    #: glTF BRDF (the rasterizer, the ``shared`` reference) is single-scattering GGX either way.
    distribution: str = "multi_ggx"

    @property
    def is_masked(self) -> bool:
        """Whether the material cuts holes (alpha mode "mask")."""
        return self.alpha_mode == "mask"

    @property
    def has_maps(self) -> bool:
        """Whether the material samples any texture (an alpha mask reads texture coordinates too)."""
        return bool(self.base_color_texture or self.metallic_roughness_texture or self.emissive_texture
                    or self.occlusion_texture or self.normal_texture or self.is_masked or self.layer_maps)

    @property
    def is_emissive(self) -> bool:
        return max(self.emission) > 0.0

    @property
    def is_glossy(self) -> bool:
        return self.metallic > 0.0 or self.roughness < GLOSSY_ROUGHNESS


@dataclass(frozen=True)
class Mesh:
    """One mesh: a primitive or a file, a transform and a material name."""

    name: str
    shape: str
    material: str
    params: dict[str, Any]
    transform: np.ndarray = field(default_factory=lambda: np.eye(4), compare=False)
    file: Path | None = None

    @property
    def has_vertex_colors(self) -> bool:
        """Whether the mesh's vertices carry colours (glTF's COLOR_0, not all white)."""
        tri = self.params.get("triangles") if self.shape == "gltf" else None
        return tri is not None and tri.colors is not None

    def triangles(self, *, tangents: bool = False, tangent_uv: int = 0) -> geometry.TriangleMesh:
        """World-space triangles of this mesh; with ``tangents``, with the tangent frame of its normal maps: the
        file's ``TANGENT``, else MikkTSpace's of the mesh in its own frame (what a baker and glTF assume), on
        texture coordinate set ``tangent_uv`` (:attr:`Material.tangent_uv`)."""
        local = self._local()
        if tangents and local.tangents is None:
            from compare.scene.tangents import with_tangents
            from compare.util.cache import default_cache_dir

            local = with_tangents(local, cache_dir=default_cache_dir(), texcoord=tangent_uv)
        return local.transformed(self.transform)

    def _local(self) -> geometry.TriangleMesh:
        p = self.params
        if self.shape == "quad":
            local = geometry.quad_from_corners(p["corners"]) if "corners" in p else geometry.quad(p["size"])
        elif self.shape == "box":
            local = geometry.box(p["size"])
        elif self.shape == "sphere":
            local = geometry.sphere(p["radius"], p.get("segments", 64), p.get("rings", 32))
        elif self.shape == "cylinder":
            local = geometry.cylinder(p["radius"], p["height"], p.get("segments", 64))
        elif self.shape == "gltf":  # made by an [[include]]: triangles in the glTF node's frame
            local = p["triangles"]
        else:
            assert self.file is not None
            local = geometry.load_ply(self.file) if self.file.suffix.lower() == ".ply" else geometry.load_obj(self.file)
        return local


def mesh_bounds(meshes) -> tuple[np.ndarray, np.ndarray]:
    """World-space axis-aligned bounds (min, max) of ``meshes`` (infinite when they hold no vertex)."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for m in meshes:
        p = m.triangles().positions
        if len(p):
            lo, hi = np.minimum(lo, p.min(0)), np.maximum(hi, p.max(0))
    return lo, hi


@dataclass(frozen=True)
class AreaLight:
    """A one-sided rectangular area light emitting along ``normal``.

    ``tangent`` is the direction of the first side (``size[0]``); the second
    side runs along ``bitangent = normal × tangent``, so that
    tangent × bitangent = normal.
    """

    name: str
    center: tuple[float, float, float]
    size: tuple[float, float]
    normal: tuple[float, float, float]
    tangent: tuple[float, float, float]
    radiance: tuple[float, float, float]

    @property
    def area(self) -> float:
        return self.size[0] * self.size[1]

    @property
    def bitangent(self) -> np.ndarray:
        return np.cross(self.normal, self.tangent)

    @property
    def power(self) -> np.ndarray:
        """Emitted power Φ = π·A·L per channel (Lambertian, one-sided)."""
        return math.pi * self.area * np.asarray(self.radiance)

    def corners(self) -> np.ndarray:
        """Four corners (4, 3), counter-clockwise seen from the lit side."""
        c = np.asarray(self.center, dtype=np.float64)
        du = np.asarray(self.tangent) * self.size[0] / 2
        dv = self.bitangent * self.size[1] / 2
        return np.array([c - du - dv, c + du - dv, c + du + dv, c - du + dv])


@dataclass(frozen=True)
class Environment:
    """Distant environment light: a constant radiance, an equirectangular map file, a procedural
    map or one of Blender's studio-light HDRIs (exactly one; see :mod:`compare.scene.environments`).

    ``rotation`` turns the map about +Y by that many degrees; ``intensity`` scales it. ``background``
    False: it still lights the scene, but a camera ray that hits no surface sees black (0) instead of
    the map (model-viewer's ``renderSkybox: false``); emitters seen directly stay visible.
    """

    constant: tuple[float, float, float] | None = None
    file: Path | None = None
    intensity: float = 1.0
    rotation: float = 0.0
    procedural: str | None = None
    """``"sky"``, ``"studio"`` or ``"axes"`` (:data:`compare.scene.procedural_env.PROCEDURAL`)."""
    parameters: tuple[tuple[str, Any], ...] = ()
    """The procedural map's parameters, complete (defaults filled in), sorted by name."""
    blender: str | None = None
    """Name of a Blender studio light (``"interior"``, ``"courtyard"``, ...)."""
    background: bool = True
    """Whether camera rays that hit no surface see the environment (False: black there)."""


#: The smallest side (m) of an area light: below it float32 positions cannot tell its corners apart in every
#: renderer (the rasterizer's samples and solid angle, the reference's sampling), so a smaller light is drawn
#: as a square of this side with the same power, with a warning.
LIGHT_SIDE_FLOOR = 1e-5


def floored_light(light: "AreaLight") -> tuple["AreaLight", str | None]:
    """``light`` with each side at least :data:`LIGHT_SIDE_FLOOR`, its power kept (radiance × old area / new
    area), and a note saying so; the light itself and None when it is large enough."""
    if min(light.size) >= LIGHT_SIDE_FLOOR:
        return light, None
    size = (max(light.size[0], LIGHT_SIDE_FLOOR), max(light.size[1], LIGHT_SIDE_FLOOR))
    k = light.size[0] * light.size[1] / (size[0] * size[1])
    note = (f"light {light.name!r} is {light.size[0]:.3g} x {light.size[1]:.3g} m, below the {LIGHT_SIDE_FLOOR:g} m "
            f"every renderer can resolve: drawn as {size[0]:.3g} x {size[1]:.3g} m with the same power")
    return dataclasses.replace(light, size=size, radiance=tuple(r * k for r in light.radiance)), note


#: Kinds of KHR_lights_punctual lights.
PUNCTUAL_KINDS = ("point", "spot", "directional")
#: Side (m) of the squares that stand in for point and spot lights in renderers with area lights only.
DEFAULT_STAND_IN_SIZE = 0.05


@dataclass(frozen=True)
class PunctualLight:
    """A point, spot or directional light, as ``KHR_lights_punctual`` defines them.

    ``intensity`` is radiometric and per channel: W/sr for point and spot lights, the irradiance in
    W/m² on a surface facing a directional light. ``direction`` is where the light travels (spot,
    directional). A spot's cone falls off as glTF's: the square of a clamped linear ramp in cos θ from
    ``outer_cone`` (0) to ``inner_cone`` (1), both half-angles in degrees. ``range`` is glTF's hint for
    where a light may be cut off; every renderer here ignores it (glTF allows it) and keeps the
    inverse-square law. ``stand_in_size``: the side of the squares it becomes in a renderer that has area
    lights only (:meth:`stand_ins`).
    """

    name: str
    kind: str
    position: tuple[float, float, float]
    direction: tuple[float, float, float]
    intensity: tuple[float, float, float]
    inner_cone: float = 0.0
    outer_cone: float = 45.0
    range: float | None = None
    stand_in_size: float = DEFAULT_STAND_IN_SIZE

    def cone_terms(self) -> tuple[float, float]:
        """(a, b) with glTF's spot factor ``clamp(a·cos θ + b, 0, 1)²``; (0, 1) for other kinds (a shader's
        form of :meth:`falloff`)."""
        if self.kind != "spot":
            return (0.0, 1.0)
        ci, co = math.cos(math.radians(self.inner_cone)), math.cos(math.radians(self.outer_cone))
        scale = 1.0 / max(1e-3, ci - co)  # the specification's own guard against inner == outer
        return (scale, -co * scale)

    def falloff(self, cos_theta) -> np.ndarray:
        """glTF's spot cone factor at cos θ from the axis (1 for point and directional lights)."""
        a, b = self.cone_terms()
        return np.clip(np.asarray(cos_theta, dtype=np.float64) * a + b, 0.0, 1.0) ** 2

    def node_matrix(self) -> np.ndarray:
        """4×4 world matrix of the light as glTF and Blender place a light: at its position, shining down
        its local −Z along :attr:`direction`."""
        z = -np.asarray(self.direction, dtype=np.float64)
        z /= np.linalg.norm(z)
        helper = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        x = np.cross(helper, z)
        x /= np.linalg.norm(x)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, np.cross(z, x), z, self.position
        return m

    def stand_ins(self) -> list["AreaLight"]:
        """The squares that stand in for this light where only area lights are drawn: a spot one square
        facing along its direction with L = I / s² (its on-axis intensity; the cone is lost), a point a
        closed cube of six outward squares with L = 2I / (3s²) (its power 4πI; the intensity of a cube
        depends on direction). A directional light has none."""
        side = self.stand_in_size
        intensity = np.asarray(self.intensity, dtype=np.float64)
        pos = np.asarray(self.position, dtype=np.float64)

        def frame(direction):
            d = np.asarray(direction, dtype=np.float64) / np.linalg.norm(direction)
            helper = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
            t = np.cross(helper, d)
            return tuple(d), tuple(t / np.linalg.norm(t))

        if self.kind == "spot":
            n, t = frame(self.direction)
            return [AreaLight(self.name, tuple(pos), (side, side), n, t, tuple(intensity / side ** 2))]
        if self.kind == "point":
            radiance = tuple(2.0 * intensity / (3.0 * side ** 2))
            out = []
            for axis, label in zip(np.vstack([np.eye(3), -np.eye(3)]), ("+x", "+y", "+z", "-x", "-y", "-z")):
                n, t = frame(axis)
                out.append(AreaLight(f"{self.name}{label}", tuple(pos + axis * side / 2), (side, side), n, t,
                                     radiance))
            return out
        return []


@dataclass(frozen=True)
class Features:
    """What a scene needs, so renderers and reports can leave out the rest."""

    environment: bool
    area_lights: bool
    glossy: bool
    metallic: bool
    textures: bool
    emissive_meshes: bool
    alpha_mask: bool = False
    punctual_lights: bool = False
    alpha_blend: bool = False
    transmission: bool = False
    volume: bool = False
    ior: bool = False
    clearcoat: bool = False
    sheen: bool = False
    specular: bool = False
    dispersion: bool = False
    anisotropy: bool = False
    iridescence: bool = False
    layer_maps: bool = False
    uv_sets: bool = False
    map_samplers: bool = False
    vertex_colors: bool = False
    single_sided: bool = False
    hidden_background: bool = False

    @property
    def holes(self) -> bool:
        """Whether rays pass some surfaces (alpha masks, alpha blending, culled back faces)."""
        return self.alpha_mask or self.alpha_blend or self.single_sided

    def names(self) -> list[str]:
        """Names of the features present."""
        return [f.name for f in dataclasses.fields(self) if getattr(self, f.name)]

    def omitted(self) -> dict[str, str]:
        """Work a renderer can skip, with the reason (for reports)."""
        out = {}
        if not self.environment:
            out["environment lighting (IBL prefiltering, env samples, occlusion)"] = "the scene has no environment"
        if not self.area_lights:
            out["area-light shadow maps and direct-light samples"] = "the scene has no area lights"
        if not self.textures:
            out["texture upload and sampling"] = "no material uses a texture"
        if not self.alpha_mask:
            out["alpha test in the geometry and shadow passes"] = "no material is alpha-masked"
        return out


@dataclass(frozen=True)
class Scene:
    """A validated scene. Build it with :func:`load_scene`."""

    path: Path
    name: str
    camera: Camera
    materials: dict[str, Material]
    meshes: tuple[Mesh, ...]
    lights: tuple[AreaLight, ...]
    environment: Environment | None
    max_depth: int
    referenced_files: tuple[Path, ...]
    file_hash: str
    # Rasterizer-only options ([render] table): they do not change the reference's pixels,
    # so they stay out of :attr:`hash` beyond the file's own bytes (which carry them).
    indirect: str = "none"
    """Indirect diffuse light of the rasterizer: ``"none"`` or ``"probes"`` (an irradiance volume)."""
    probe_grid: tuple[int, int, int] = DEFAULT_PROBE_GRID
    """Probes along x, y, z of the irradiance volume (each >= 2)."""
    probe_bounces: int = DEFAULT_PROBE_BOUNCES
    """Diffuse bounces baked into the irradiance volume (>= 1)."""
    punctual: tuple[PunctualLight, ...] = ()
    """Point, spot and directional lights (KHR_lights_punctual), beside the area lights."""

    def features(self) -> Features:
        """What this scene needs (environment, area lights, glossy materials, textures, ...)."""
        # each material once, however many meshes use it (a download has hundreds of meshes, few materials)
        used = [self.materials[name] for name in dict.fromkeys(m.material for m in self.meshes)]
        uses = [m.uses() for m in used]
        return Features(
            environment=self.environment is not None,
            area_lights=bool(self.lights),
            glossy=any(m.is_glossy for m in used),
            metallic=any(m.metallic > 0 for m in used),
            textures=any(m.has_maps for m in used),
            emissive_meshes=any(m.is_emissive for m in used),
            alpha_mask=any(m.is_masked for m in used),
            punctual_lights=bool(self.punctual),
            **{name: any(name in u for u in uses) for name in MATERIAL_FEATURE_NAMES + MAP_FEATURE_NAMES},
            vertex_colors=any(m.has_vertex_colors for m in self.meshes),
            single_sided=any(not m.double_sided for m in used),
            hidden_background=self.hides_background,
        )

    @property
    def hides_background(self) -> bool:
        """Whether the scene has an environment that camera rays hitting nothing must not see
        (``[environment] background = false``)."""
        return self.environment is not None and not self.environment.background

    def with_background(self) -> "Scene":
        """The same scene with its environment seen where camera rays hit nothing (for a renderer that
        cannot hide it)."""
        if not self.hides_background:
            return self
        return dataclasses.replace(self, environment=dataclasses.replace(self.environment, background=True))

    def material_features(self) -> dict[str, list[str]]:
        """The material features beyond the core model (alpha blending, the extensions of :data:`LAYERS`)
        that the meshes' materials use, and the geometry features (:data:`GEOMETRY_FEATURE_NAMES`) of the
        meshes: feature → the names of the materials that use it (or whose meshes carry it)."""
        out: dict[str, list[str]] = {}
        for name in dict.fromkeys(m.material for m in self.meshes):
            for feature in sorted(self.materials[name].uses()):
                out.setdefault(feature, []).append(name)
        colored = dict.fromkeys(m.material for m in self.meshes if m.has_vertex_colors)
        if colored:
            out["vertex_colors"] = list(colored)
        culled = [name for name in dict.fromkeys(m.material for m in self.meshes)
                  if not self.materials[name].double_sided]
        if culled:
            out["single_sided"] = culled
        return out

    @cached_property
    def hash(self) -> str:
        """Stable content hash of the scene file, every file it references and any overrides."""
        # The file's bytes carry a background = false of its own; said here too, so that a scene changed
        # in memory (with_background) never shares a hash with the scene it came from.
        hidden = ["background=false"] if self.hides_background else []
        return sha256_bytes(self.file_hash, repr(self.camera.resolution), str(self.max_depth), *hidden)

    def with_resolution(self, width: int, height: int) -> "Scene":
        """The same scene rendered at another resolution."""
        if width < 1 or height < 1:
            raise SceneError(f"{self.path}: camera.resolution: expected two positive integers, got [{width}, {height}]")
        cam = dataclasses.replace(self.camera, resolution=(int(width), int(height)))
        return dataclasses.replace(self, camera=cam)

    def without_maps(self) -> "Scene":
        """The same scene with every material's factors only: no maps, opaque (the texture benchmark's
        other side)."""
        plain = {k: dataclasses.replace(m, base_color_texture=None, metallic_roughness_texture=None,
                                        emissive_texture=None, occlusion_texture=None, normal_texture=None,
                                        alpha_mode="opaque")
                 for k, m in self.materials.items()}
        return dataclasses.replace(self, materials=plain)

    def with_punctual_as_area(self) -> tuple["Scene", list[str]]:
        """The scene for a renderer that draws area lights only: point and spot lights as their stand-in
        squares (:meth:`PunctualLight.stand_ins`), directional lights left out; and what was changed, one
        phrase each (empty when the scene has no punctual lights)."""
        if not self.punctual:
            return self, []
        squares = tuple(sq for light in self.punctual for sq in light.stand_ins())
        kinds = {k: sum(light.kind == k for light in self.punctual) for k in PUNCTUAL_KINDS}
        notes = []
        if kinds["point"] or kinds["spot"]:
            notes.append(f"{kinds['point'] + kinds['spot']} point/spot light(s) drawn as stand-in squares "
                         f"({len(squares)} area lights; a point light's cube, a spot light's cone lost)")
        if kinds["directional"]:
            notes.append(f"{kinds['directional']} directional light(s) not rendered")
        return dataclasses.replace(self, lights=self.lights + squares, punctual=()), notes

    def without_area_lights(self) -> "Scene":
        """The same scene without its rectangular area lights (for a renderer that draws none)."""
        return dataclasses.replace(self, lights=())

    def with_max_depth(self, max_depth: int) -> "Scene":
        """The same scene with another path depth for the reference (2 = direct light only)."""
        return dataclasses.replace(self, max_depth=int(max_depth))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space axis-aligned bounds (min, max) of all meshes."""
        # Kept on the (frozen) instance: a renderer's set-up asks several times, and each answer transforms
        # every mesh; a changed scene (dataclasses.replace) is a new instance and computes its own.
        cached = self.__dict__.get("_bounds")
        if cached is None:
            cached = mesh_bounds(self.meshes)
            object.__setattr__(self, "_bounds", cached)
        return cached[0].copy(), cached[1].copy()

    def extent(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space axis-aligned bounds (min, max) of every mesh and light rectangle."""
        lo, hi = self.bounds()
        for light in self.lights:
            c = light.corners()
            lo, hi = np.minimum(lo, c.min(0)), np.maximum(hi, c.max(0))
        return lo, hi
