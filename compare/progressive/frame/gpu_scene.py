"""Scene upload (once per scene) and the camera's matrices.

Every mesh gets one vertex buffer (position, normal, texture coordinates; float32,
interleaved) and one index buffer, and keeps its material as uniform values set before
its draw call, and its base-colour and metallic-roughness maps (uploaded once per file,
linear RGBA16F with mipmaps; :mod:`compare.progressive` samples them trilinearly) where
the material has them; an alpha-masked material's base-colour map carries its alpha.
Programs built without ``TEXTURES`` read no coordinates and no maps: a scene without
textures does no texture work; the G-buffer's programs are specialised per set of maps
(:meth:`GpuScene.map_set_defines`) and the occluder passes' per mask
(:meth:`GpuScene.occluder_programs`).
Each area light is uploaded as a quad too: the G-buffer pass shows it as an
emitter, and shadow maps of *other* lights see it as an occluder (the reference's
light rectangles block light as well).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import set_uniform
from compare.progressive.gl.units import LAYERS, MAPS, bind
from compare.scene.model import TEXTURE_WRAPS

#: The extensions' maps the rasterizer reads (the fields of compare.scene.model.LAYER_MAPS they multiply;
#: material.glsl's material_layer_*() and material_transmission()); a mesh keeps them in GpuMesh.layer_maps.
LAYER_MAP_SLOTS = ("transmission", "clearcoat", "clearcoat_roughness", "sheen_color", "sheen_roughness",
                   "specular", "specular_color")
#: The maps a mesh binds, in the order of material.glsl's slots (its u_map_transform and u_map_read) and of
#: the texture units of MAPS.
MAP_SLOTS = ("base_color_texture", "metallic_roughness_texture", "emissive_texture", "occlusion_texture",
             "normal_texture", *LAYER_MAP_SLOTS)
#: material.glsl's name of each map (u_<name>_map, u_has_<name>_map, HAS_<NAME>_MAP), in MAP_SLOTS order.
MAP_NAMES = ("base_color", "metallic_roughness", "emission", "occlusion", "normal", *LAYER_MAP_SLOTS)


def _set_array(program, name: str, data: bytes, count: int) -> None:
    """Write the elements of uniform array ``name`` the linker kept (it trims an array read at constant
    indices to the last one read); ``data`` holds ``count`` elements."""
    member = program.get(name, None)
    if member is not None:
        member.write(data[: len(data) // count * member.array_length])


#: OpenGL internal formats of 8-bit maps: colour (sRGB-encoded) and factors (linear).
GL_SRGB8, GL_SRGB8_ALPHA8, GL_RGB8, GL_RGBA8 = 0x8C41, 0x8C43, 0x8051, 0x8058
#: The G-buffer's layer targets (gbuffer.glsl, gbuffer_layers.glsl) with LAYERS.
LAYER_TARGETS = ("layer_f0", "layer_coat", "layer_sheen")
#: The material features the rasterizer renders as layers.glsl's lobes.
RENDERED_LAYERS = frozenset({"ior", "specular", "clearcoat", "sheen"})
#: material.glsl's layer uniforms, in the order of GpuMesh.layers.
LAYER_UNIFORMS = ("u_layer_f0", "u_layer_weight", "u_clearcoat", "u_clearcoat_roughness", "u_sheen_color",
                  "u_sheen_roughness")


def material_layers(mat) -> tuple:
    """``mat``'s layer factors as layers.glsl reads them (GpuMesh.layers); the core model's for None."""
    from compare.brdf import dielectric_specular

    if mat is None:
        return ((0.04, 0.04, 0.04), 1.0, 0.0, 0.0, (0.0, 0.0, 0.0), 0.0)
    f0, weight = dielectric_specular(mat.ior, mat.specular, mat.specular_color)
    return (tuple(float(x) for x in np.broadcast_to(f0, 3)), float(weight), float(mat.clearcoat),
            float(mat.clearcoat_roughness), tuple(float(x) for x in mat.sheen_color), float(mat.sheen_roughness))


_UNSET = object()  # a uniform value no program holds


#: transmission.glsl's uniforms, in the order of GpuMesh.glass.
GLASS_UNIFORMS = ("u_transmission", "u_glass_iors", "u_thickness", "u_glass_scale", "u_attenuation")


def glass_uniforms(mat, transform) -> tuple:
    """``mat``'s transmission as transmission.glsl reads it (GpuMesh.glass): the transmission factor, the ior
    of each colour channel (KHR_materials_dispersion's, :func:`compare.scene.model.channel_iors`, where the
    material disperses; else the ior three times), the thickness factor (the mesh's own units: 0 is a thin wall), the mesh's scale along each world axis
    (the lengths of its transform's columns, as three.js scales the thickness) and the Beer–Lambert
    coefficient −ln(attenuationColor) / attenuationDistance per unit of world length (0 where nothing is
    absorbed; the reference's :func:`compare.mitsuba.scene_dict.medium_dict`)."""
    scale = np.linalg.norm(np.asarray(transform, dtype=np.float64)[:3, :3], axis=0)
    c = np.clip(np.asarray(mat.attenuation_color, dtype=np.float64), 1e-12, 1.0)
    sigma = (np.maximum(-np.log(c), 0.0) / float(mat.attenuation_distance) if math.isfinite(mat.attenuation_distance)
             and mat.thickness > 0.0 else np.zeros(3))
    from compare.scene.model import channel_iors

    ior = float(min(mat.ior, 1e3))
    iors = channel_iors(ior, mat.dispersion) if "dispersion" in mat.uses() else (ior, ior, ior)
    return (float(mat.transmission), tuple(float(n) for n in iors), float(mat.thickness),
            tuple(float(x) for x in scale), tuple(float(x) for x in sigma))


def mat_bytes(m: np.ndarray) -> bytes:
    """A 4×4 matrix as the column-major float32 bytes a GLSL ``mat4`` expects."""
    return np.ascontiguousarray(np.asarray(m, dtype=np.float64).T, dtype=np.float32).tobytes()


def look_at(eye, forward, up) -> np.ndarray:
    """World → view matrix (OpenGL: the view looks down −Z) for a camera at ``eye`` facing ``forward``."""
    f = np.asarray(forward, dtype=np.float64)
    f = f / np.linalg.norm(f)
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = r, u, -f
    m[:3, 3] = -m[:3, :3] @ np.asarray(eye, dtype=np.float64)
    return m


def frustum(left: float, right: float, bottom: float, top: float, near: float, far: float) -> np.ndarray:
    """OpenGL ``glFrustum`` projection (bounds on the near plane)."""
    m = np.zeros((4, 4))
    m[0, 0] = 2 * near / (right - left)
    m[0, 2] = (right + left) / (right - left)
    m[1, 1] = 2 * near / (top - bottom)
    m[1, 2] = (top + bottom) / (top - bottom)
    m[2, 2] = -(far + near) / (far - near)
    m[2, 3] = -2 * far * near / (far - near)
    m[3, 2] = -1.0
    return m


class CameraSetup:
    """The scene camera's view and jittered projection, with near/far fitted to the scene.

    far reaches the farthest corner of the scene's bounds; near is half the distance
    to the bounds (a camera inside them gets far·1e-4), which keeps the 24-bit depth
    buffer's precision far below any gap between surfaces. Depth only orders the
    fragments here: the G-buffer stores world positions in float32.
    """

    def __init__(self, scene):
        cam = scene.camera
        self.camera = cam
        self.position = np.asarray(cam.position, dtype=np.float64)
        lo, hi = scene.extent()
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        self.far = float(np.linalg.norm(corners - self.position, axis=1).max() * 1.01 + 1e-3)
        outside = np.maximum(np.maximum(lo - self.position, self.position - hi), 0.0)
        self.near = float(max(0.5 * np.linalg.norm(outside), self.far * 1e-4))
        self.view = cam.view_matrix()

    def view_proj(self, jitter=(0.0, 0.0)) -> np.ndarray:
        """Projection × view for a sub-pixel ``jitter`` (pixels, x right, y up)."""
        return self.camera.projection_matrix(self.near, self.far, jitter=jitter) @ self.view


@dataclass
class GpuMesh:
    """Buffers and material uniforms of one mesh or light quad."""

    name: str
    vbo: object
    ibo: object
    base_color: tuple[float, float, float]
    metallic: float
    roughness: float
    emission: tuple[float, float, float]
    kind: float
    """1 = shaded surface, 2 = emitter that reflects nothing (a light's quad)."""
    light: int | None = None
    base_color_map: object = None
    metallic_roughness_map: object = None
    emission_map: object = None
    occlusion_map: object = None
    occlusion_strength: float = 1.0
    normal_map: object = None
    normal_scale: float = 1.0
    layer_maps: dict = field(default_factory=dict)
    """The extensions' maps it has, by the field they multiply (:data:`LAYER_MAP_SLOTS`)."""
    map_transforms: bytes = b""
    """Each map's texture transform (:data:`MAP_SLOTS` order; GLSL mat3, column-major)."""
    map_read: bytes = b""
    """Each map's (texture coordinate set, wrap s, wrap t) as material.glsl's u_map_read."""
    alpha: float = 1.0
    alpha_cutoff: float = -1.0
    """glTF's alpha mask: the coverage test's cutoff, negative for an opaque mesh."""
    blend: float = -1.0
    sides: float = 2.0
    """glTF's doubleSided: 2 double-sided, 1 single-sided (back faces culled for camera rays)."""
    """glTF's alphaMode BLEND: the coverage factor (times the base-colour map's alpha), negative otherwise.
    A blended mesh is drawn by the blend pass alone (:mod:`compare.progressive.blend`)."""
    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The centre of its bounds (the blend pass sorts by its distance)."""
    lo: tuple[float, float, float] = (0.0, 0.0, 0.0)
    hi: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Its world bounds (the irradiance volume's bake draws a mesh only into the cube faces they reach)."""
    layers: tuple = ()
    """glTF's layers as layers.glsl reads them: (dielectric F0, specular weight, clearcoat, its
    roughness, sheen colour, sheen roughness); empty without LAYERS."""
    glass: tuple = ()
    """glTF's transmission as transmission.glsl reads it (:func:`glass_uniforms`); empty for a mesh the
    G-buffer draws. A glass mesh is drawn by the glass pass (:mod:`compare.progressive.glass`) and frame 0."""


class GpuScene(RenderPass):
    """All geometry of a scene on the GPU, uploaded once."""

    def __init__(self, ctx, scene, *, glass: bool = True):
        self.ctx = ctx
        self.meshes: list[GpuMesh] = []
        self.light_quads: list[GpuMesh] = []
        self._vaos: dict[tuple[int, int, bool], object] = {}
        #: The material uniforms each program was last given by :meth:`draw_mesh` (program state in GL).
        self._held: dict[object, dict[str, object]] = {}
        self._maps: dict[tuple, object] = {}
        #: Whether any mesh has a map: the programs' TEXTURES define.
        self.textured = bool(scene.features().textures)
        #: Whether any mesh has an occlusion map: the OCCLUSION define of the passes of ambient light.
        self.occluded = any(scene.materials[m.material].occlusion_texture is not None for m in scene.meshes)
        #: Whether any mesh is alpha-masked: the ALPHA_MASK define, also of the passes that draw occluders.
        self.masked = bool(scene.features().alpha_mask)
        #: Whether any mesh is blended (alphaMode BLEND): the blend pass draws those, no other pass shades them.
        self.blended = bool(scene.features().alpha_blend)
        #: Whether any mesh has clearcoat, sheen, ior or specular: the LAYERS define (layers.glsl), the
        #: G-buffer's layer targets and the sheen albedo table.
        self.layered = bool(RENDERED_LAYERS & set().union(*(scene.materials[m.material].uses() for m in scene.meshes)))
        #: Whether any mesh carries glTF's COLOR_0: the VERTEX_COLORS define (material.glsl).
        self.colored = any(m.has_vertex_colors for m in scene.meshes)
        #: Whether transmissive meshes (glTF transmission, not alphaMode BLEND) are apart from the G-buffer,
        #: drawn by the glass pass: ``glass`` False (Lambert-only materials, as the reference's "diffuse"
        #: mode draws glass) keeps them opaque surfaces.
        self.glassy = glass and any(scene.materials[m.material].transmission > 0.0
                                    and scene.materials[m.material].alpha_mode != "blend" for m in scene.meshes)
        self.sheen_table = None
        try:
            for mesh in scene.meshes:
                mat = scene.materials[mesh.material]
                # normal maps in the file's tangent frame (its TANGENT, else MikkTSpace's), as every renderer
                tri = mesh.triangles(tangents=self.textured and mat.normal_mapped, tangent_uv=mat.tangent_uv)
                gm = self._upload(mesh.name, tri.positions, tri.normals, tri.indices, mat.base_color, mat.metallic,
                                  mat.roughness, mat.emission, 1.0, uvs=tri.uvs, colors=tri.colors,
                                  tangents=tri.tangents, uvs1=tri.uvs1)
                self.meshes.append(gm)  # owned (and released on failure) before its maps are made
                gm.centre = tuple(float(x) for x in (tri.positions.min(0) + tri.positions.max(0)) / 2)
                if mat.alpha_mode == "blend":
                    gm.blend = float(mat.alpha)
                gm.sides = 2.0 if mat.double_sided else 1.0
                if self.glassy and mat.transmission > 0.0 and mat.alpha_mode != "blend":
                    gm.glass = glass_uniforms(mat, mesh.transform)
                if self.layered:
                    gm.layers = material_layers(mat)
                if self.textured:
                    if mat.base_color_texture is not None:
                        gm.base_color_map = self._map(mat.base_color_texture, mat, "base_color_texture", srgb=True,
                                                      alpha=mat.is_masked or mat.alpha_mode == "blend")
                    if mat.is_masked:
                        gm.alpha, gm.alpha_cutoff = float(mat.alpha), float(mat.alpha_cutoff)
                    if mat.metallic_roughness_texture is not None:
                        gm.metallic_roughness_map = self._map(mat.metallic_roughness_texture, mat,
                                                              "metallic_roughness_texture", srgb=False)
                    if mat.emissive_texture is not None:
                        gm.emission_map = self._map(mat.emissive_texture, mat, "emissive_texture", srgb=True)
                    if mat.normal_texture is not None:
                        gm.normal_map = self._map(mat.normal_texture, mat, "normal_texture", srgb=False)
                        gm.normal_scale = float(mat.normal_scale)
                    if mat.occlusion_texture is not None:
                        gm.occlusion_map = self._map(mat.occlusion_texture, mat, "occlusion_texture", srgb=False)
                        gm.occlusion_strength = float(mat.occlusion_strength)
                    for fld, channel, path in mat.layer_maps:  # an sRGB colour, or one linear channel
                        if fld in LAYER_MAP_SLOTS:
                            gm.layer_maps[fld] = self._map(path, mat, fld, srgb=channel == "rgb",
                                                           alpha=channel == "a", coverage=False)
                    samplings = [mat.sampling(name) for name in MAP_SLOTS]
                    # GLSL mat3 is column-major: the bytes of the transpose of each row-major matrix
                    gm.map_transforms = np.ascontiguousarray([x.uv_transform().T for x in samplings],
                                                             dtype=np.float32).tobytes()
                    gm.map_read = np.asarray([(x.texcoord, *(TEXTURE_WRAPS.index(a) for a in x.wrap))
                                              for x in samplings], dtype=np.float32).tobytes()
            quad = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)
            for i, light in enumerate(scene.lights):
                normals = np.tile(np.asarray(light.normal, dtype=np.float32), (4, 1))
                self.light_quads.append(self._upload(light.name, light.corners(), normals, quad, (0.0, 0.0, 0.0),
                                                     0.0, 1.0, light.radiance, 2.0, light=i))
                if self.layered:
                    self.light_quads[-1].layers = material_layers(None)
            if self.layered:
                from compare.brdf.sheen import sheen_tables

                table = sheen_tables()  # rows n.v, columns roughness; (E, M)
                self.sheen_table = ctx.texture((table.shape[1], table.shape[0]), 2, table.tobytes(), dtype="f4")
                self.sheen_table.filter = (ctx.LINEAR, ctx.LINEAR)
                self.sheen_table.repeat_x = self.sheen_table.repeat_y = False
        except BaseException:
            self.release()  # a map the GPU refuses must not leave the uploaded meshes behind
            raise

    def defines(self) -> dict[str, int]:
        """The material defines of a pass that shades the scene (material.glsl)."""
        return {"TEXTURES": int(self.textured), "MAP_SLOT_COUNT": len(MAP_SLOTS), "ALPHA_MASK": int(self.masked),
                "LAYERS": int(self.layered),
                "VERTEX_COLORS": int(self.colored)}

    def layers_for(self, materials: str = "shared") -> bool:
        """Whether a lighting pass draws the material layers (layers.glsl): not for Lambert-only materials."""
        return self.layered and materials != "diffuse"

    def layer_defines(self, materials: str = "shared") -> dict[str, int]:
        """The LAYERS define of a lighting pass (:meth:`layers_for`)."""
        return {"LAYERS": int(self.layers_for(materials))}

    def bind_layers(self, program, gbuffer=None) -> None:
        """Bind the sheen albedo table and, with ``gbuffer``, its layer targets to ``program`` (a pass
        built with :meth:`layer_defines`); nothing without LAYERS."""
        if not self.layered:
            return
        bind(program, "u_sheen_albedo", self.sheen_table, LAYERS, 0)
        if gbuffer is not None:
            for k, name in enumerate(LAYER_TARGETS, start=1):
                bind(program, f"u_{name}", gbuffer[name], LAYERS, k)

    def map_set(self, mesh: GpuMesh) -> tuple[bool, ...]:
        """Which maps ``mesh`` has (base colour, metallic-roughness, emission, occlusion, normal) and
        whether it is alpha-masked: the key of a program specialised for it (:meth:`map_set_defines`)."""
        return (mesh.base_color_map is not None, mesh.metallic_roughness_map is not None,
                mesh.emission_map is not None, mesh.occlusion_map is not None, mesh.normal_map is not None,
                *(f in mesh.layer_maps for f in LAYER_MAP_SLOTS), mesh.alpha_cutoff >= 0.0)

    def map_sets(self) -> list[tuple[bool, ...]]:
        """The distinct :meth:`map_set` of the scene's meshes and light quads, in draw order."""
        return list(dict.fromkeys(self.map_set(m) for m in self.meshes + self.light_quads))

    def map_set_defines(self, key: tuple[bool, ...]) -> dict[str, object]:
        """:meth:`defines` for a program that draws only meshes of map set ``key``: whether each map is
        there is a constant, so the program samples only the maps those meshes have."""
        names = (*(f"HAS_{name.upper()}_MAP" for name in MAP_NAMES), "IS_MASKED")
        out: dict[str, object] = dict(self.defines())
        if self.textured:
            out.update({n: "true" if v else "false" for n, v in zip(names, key)})
        return out

    def occluder_programs(self, ctx, name: str, defines=None) -> dict:
        """The programs of a pass that only rasterizes the scene (depth, shadow maps), by whether the mesh
        they draw is alpha-masked: ``{False: positions only}``, and with alpha masks ``True``: texture
        coordinates and the base-colour map's alpha test (:meth:`draw_occluders` picks per mesh)."""
        from compare.progressive.gl.shaders import load_program

        base = dict(defines or {})
        programs = {False: load_program(ctx, name, {**base, "TEXTURES": 0, "ALPHA_MASK": 0})}
        if self.masked:
            try:
                programs[True] = load_program(ctx, name, {**base, "TEXTURES": 1, "MAP_SLOT_COUNT": len(MAP_SLOTS),
                                                          "ALPHA_MASK": 1,
                                                          "IS_MASKED": "true"})
            except BaseException:
                programs[False].release()
                raise
        return programs

    def _preserve_coverage(self, tex, alpha: np.ndarray, cutoff: float) -> None:
        """Rewrite the alpha of ``tex``'s mip levels (built by GL) so that each keeps level 0's coverage
        (``alpha``, float in [0, 1]), the fraction of texels at or above ``cutoff``: Castaño's
        coverage-preserving mipmaps. Averaged alpha drifts towards its mean, so plain mips make
        alpha-tested foliage thin out with distance, where a path tracer (which does not mipmap) keeps it."""
        from compare.progressive.gl.mipmaps import coverage_preserving_alpha

        h, w = alpha.shape
        eight = tex.dtype == "f1"
        for level, a in enumerate(coverage_preserving_alpha(alpha, cutoff), start=1):
            lw, lh = max(w >> level, 1), max(h >> level, 1)
            texels = np.frombuffer(tex.read(level=level, alignment=1), dtype=np.uint8 if eight else np.float16)
            texels = texels.reshape(lh, lw, 4).copy()
            texels[..., 3] = np.rint(a.reshape(lh, lw) * 255.0) if eight else a.reshape(lh, lw)
            tex.write(texels.tobytes(), level=level, alignment=1)

    def _map(self, path, mat, which: str, *, srgb: bool, alpha: bool = False, coverage: bool = True):
        """One map file as a texture, sampled as ``mat``'s map ``which`` is (its wrap per axis, its filters:
        mipmapped by the GPU unless its minification reads level 0 only; uploaded once per file, kind and
        sampler settings); ``alpha``: with the file's alpha channel (an
        alpha mask's, its mip levels keeping the mask's coverage; with ``coverage`` False, a factor's, plain
        mip levels), else without. An 8-bit file stays 8 bits per channel, an sRGB texture for colour
        (decoded to linear by the sampler, before filtering) and a linear one for factors and normals;
        only float files (EXR, 16-bit PNG) are uploaded as RGBA16F."""
        from compare.scene.textures import load_alpha, load_texels8, load_texture

        s = mat.sampling(which)
        key = (str(path), srgb, tuple(w == "repeat" for w in s.wrap), s.filter, s.mipmaps, alpha,
               (mat.alpha_cutoff / max(mat.alpha, 1e-9)) if alpha and coverage else None)
        if key not in self._maps:
            texels = load_texels8(path, alpha=alpha)
            if texels is not None:
                h, w, n = texels.shape
                internal = (GL_SRGB8_ALPHA8 if n == 4 else GL_SRGB8) if srgb else (GL_RGBA8 if n == 4 else GL_RGB8)
                kept = texels[..., 3].astype(np.float32) / np.float32(255.0) if alpha else None
            else:
                rgb = load_texture(path, srgb=srgb)
                h, w = rgb.shape[:2]
                a = load_alpha(path)[..., None] if alpha else np.ones((h, w, 1), dtype=np.float32)
                texels = np.ascontiguousarray(np.concatenate([rgb, a], axis=2), dtype=np.float16)
                kept = a[..., 0] if alpha else None
                n = 4
            largest = int(self.ctx.info.get("GL_MAX_TEXTURE_SIZE", 16384))
            if max(h, w) > largest:
                from compare.util.errors import ImageError

                raise ImageError(f"{path}: {w} x {h} texels, more than this OpenGL's largest texture "
                                 f"({largest} on a side): the rasterizer cannot upload it; scale the map down")
            # Rows top first: texture coordinate t = 0 is the image's top row, as glTF's v = 0 (and
            # Mitsuba's bitmap lookup) is. Linear values are filtered, never encoded ones.
            if texels.dtype == np.uint8:
                tex = self.ctx.texture((w, h), n, np.ascontiguousarray(texels), dtype="f1", alignment=1,
                                       internal_format=internal)
            else:
                tex = self.ctx.texture((w, h), 4, texels, dtype="f2")
            # "mirror" is wrapped in the shader; its samplers clamp, which at a mirror's seam is exact
            tex.repeat_x, tex.repeat_y = (w == "repeat" for w in s.wrap)
            mag = self.ctx.NEAREST if s.filter == "nearest" else self.ctx.LINEAR
            if not s.mipmaps:
                tex.filter = (mag, mag)
            else:
                tex.build_mipmaps()
                tex.filter = (self.ctx.NEAREST_MIPMAP_LINEAR if s.filter == "nearest" else self.ctx.LINEAR_MIPMAP_LINEAR,
                              mag)
                if alpha and coverage and mat.alpha > 0:
                    self._preserve_coverage(tex, kept, mat.alpha_cutoff / mat.alpha)
            self._maps[key] = tex
        return self._maps[key]

    def _upload(self, name, positions, normals, indices, base, metallic, roughness, emission, kind, light=None,
                uvs=None, colors=None, tangents=None, uvs1=None):
        n = len(positions)
        uv = np.zeros((n, 4), dtype=np.float32)  # TEXCOORD_0 and TEXCOORD_1 (zeros where absent)
        if uvs is not None:
            uv[:, :2] = uvs
        if uvs1 is not None:
            uv[:, 2:] = uvs1
        # Tangents only for normal maps (Mesh.triangles gives them): others do no tangent work.
        tangents = np.zeros((n, 4), dtype=np.float32) if tangents is None else np.asarray(tangents, np.float32)
        columns = [np.asarray(positions, dtype=np.float32), np.asarray(normals, dtype=np.float32), uv, tangents]
        if self.colored:  # COLOR_0 (white for meshes without it); no column in a scene without any
            columns.append(np.ones((n, 4), dtype=np.float32) if colors is None else np.asarray(colors, np.float32))
        data = np.hstack(columns)
        vbo = self.ctx.buffer(np.ascontiguousarray(data, dtype=np.float32).tobytes())
        ibo = self.ctx.buffer(np.ascontiguousarray(indices, dtype=np.uint32).tobytes())
        gm = GpuMesh(name, vbo, ibo, tuple(base), float(metallic), float(roughness), tuple(emission), float(kind),
                     light)
        if n:
            p = np.asarray(positions, dtype=np.float32)
            gm.lo, gm.hi = tuple(float(x) for x in p.min(0)), tuple(float(x) for x in p.max(0))
        return gm

    def _vao(self, program, index: int, mesh: GpuMesh):
        key = (id(program), index)
        vao = self._vaos.get(key)
        if vao is None:
            # The attributes the program reads, the others skipped (the vertex buffer is interleaved).
            fmt, names = [], []
            attributes = (("in_position", 3), ("in_normal", 3), ("in_uv", 4), ("in_tangent", 4))
            for name, size in attributes + ((("in_color", 4),) if self.colored else ()):
                if program.get(name, None) is not None:
                    fmt.append(f"{size}f")
                    names.append(name)
                else:
                    fmt.append(f"{4 * size}x")
            layout = (mesh.vbo, " ".join(fmt), *names)
            vao = self.ctx.vertex_array(program, [layout], index_buffer=mesh.ibo, index_element_size=4)
            self._vaos[key] = (vao, program)
            return vao
        return vao[0]

    def draw_shaded(self, program, instances: int = 1, map_set: tuple[bool, ...] | None = None, *,
                    glass: bool = True, cull: bool = False) -> None:
        """Draw meshes and light quads with their material uniforms (G-buffer pass).

        ``instances`` > 1 draws every mesh that many times in one call (the
        irradiance volume's bake places each instance in its own cube face).
        ``map_set``: only the meshes of that :meth:`map_set` (a program specialised for it).
        ``glass`` False leaves out the glass meshes (the G-buffer: the glass pass draws them).
        ``cull``: ``program`` is built with FACE_CULLING (material.glsl): GL culls the single-sided
        meshes' back faces (:meth:`face_culling`).
        """
        try:
            for index in self.shaded(map_set, glass=glass):
                self.draw_mesh(program, index, instances, cull=cull)
        finally:
            if cull:
                self.face_culling(None)

    def shaded(self, map_set: tuple[bool, ...] | None = None, *, glass: bool = True) -> list[int]:
        """The indices (of meshes + light quads) that :meth:`draw_shaded` draws with the same arguments."""
        return [index for index, mesh in enumerate(self.meshes + self.light_quads)
                if mesh.blend < 0.0 and (map_set is None or self.map_set(mesh) == map_set)
                and not (mesh.glass and not glass)]

    def face_culling(self, mesh: GpuMesh | None) -> None:
        """GL's back-face culling on for drawing a single-sided ``mesh`` (glTF's doubleSided false), off for a
        double-sided one or None: what material.glsl's cull_back_face() discards, in a program built with
        FACE_CULLING. GL decides what faces the viewer from the same window-space winding as gl_FrontFacing."""
        if mesh is not None and mesh.sides < 1.5:
            self.ctx.cull_face = "back"
            self.ctx.enable(self.ctx.CULL_FACE)
        else:
            self.ctx.disable(self.ctx.CULL_FACE)

    def draw_mesh(self, program, index: int, instances: int = 1, *, cull: bool = False) -> None:
        """Draw mesh ``index`` (of meshes + light quads) with its material uniforms; ``cull``: with GL's
        culling of its back faces where it is single-sided (:meth:`face_culling`), left on."""
        mesh = (self.meshes + self.light_quads)[index]
        if cull:
            self.face_culling(mesh)
        # Meshes drawn one after another mostly share their factors: a value the program holds already is
        # not written again (each write costs the draw loop a little, per mesh and pass).
        held = self._held.get(program)
        if held is None:
            held = self._held[program] = {}
        for name, value in (("u_base_color", mesh.base_color), ("u_metallic", mesh.metallic),
                            ("u_roughness", mesh.roughness), ("u_emission", mesh.emission), ("u_kind", mesh.kind),
                            ("u_blend_alpha", max(mesh.blend, 0.0)), ("u_sides", mesh.sides),
                            *zip(LAYER_UNIFORMS, mesh.layers)):
            if held.get(name, _UNSET) != value:
                set_uniform(program, name, value)
                held[name] = value
        if self.glassy:  # every mesh: frame 0's forward pass draws glass and the rest with one program
            set_uniform(program, "u_transmission", mesh.glass[0] if mesh.glass else 0.0)
            for name, value in zip(GLASS_UNIFORMS[1:], mesh.glass[1:]):
                set_uniform(program, name, value)
        if self.textured:
            self._bind_maps(program, mesh, all_maps=True)
        self._vao(program, index, mesh).render(instances=instances)

    def _bind_maps(self, program, mesh: GpuMesh, *, all_maps: bool) -> None:
        """Set ``mesh``'s texture uniforms and bind its maps (``all_maps`` False: only what the alpha
        test reads)."""
        if mesh.map_transforms:
            _set_array(program, "u_map_transform", mesh.map_transforms, len(MAP_SLOTS))
            _set_array(program, "u_map_read", mesh.map_read, len(MAP_SLOTS))
            set_uniform(program, "u_occlusion_strength", mesh.occlusion_strength)
            set_uniform(program, "u_normal_scale", mesh.normal_scale)
        set_uniform(program, "u_alpha", mesh.alpha)
        set_uniform(program, "u_alpha_cutoff", mesh.alpha_cutoff)
        maps = (mesh.base_color_map, mesh.metallic_roughness_map, mesh.emission_map, mesh.occlusion_map,
                mesh.normal_map, *(mesh.layer_maps.get(f) for f in LAYER_MAP_SLOTS))
        for k, (name, tex) in enumerate(zip(MAP_NAMES, maps if all_maps else maps[:1])):
            set_uniform(program, f"u_has_{name}_map", 0.0 if tex is None else 1.0)
            if tex is not None:
                bind(program, f"u_{name}_map", tex, MAPS, k)

    def draw_occluders(self, programs: dict, skip_light: int | None = None, *, casters: bool = True,
                       glass: bool = True, cull: bool = False) -> None:
        """Draw depth only: every mesh and every light quad except ``skip_light``'s (shadow pass), each with
        the program of :meth:`occluder_programs` for it; an alpha-masked mesh leaves out its holes. A blended
        mesh casts a shadow map's shadow where its coverage is at least ½ (``casters``; a hard shadow map
        has no partial shadow) and is left out of a depth pre-pass (``casters=False``); ``glass`` False leaves
        out the glass meshes (a depth pre-pass of what the glass pass draws over); ``cull`` as
        :meth:`draw_shaded`'s."""
        self.draw_depth(programs, [index for index, mesh in enumerate(self.meshes + self.light_quads)
                                   if not (mesh.light is not None and mesh.light == skip_light)
                                   and not (mesh.blend >= 0.0 and not (casters and mesh.blend >= 0.5))
                                   and not (mesh.glass and not glass)], cull=cull)

    def draw_depth(self, programs: dict, indices, *, cull: bool = False) -> None:
        """Draw depth only of the meshes ``indices`` (of meshes + light quads), each with the program of
        :meth:`occluder_programs` for it (the glass pass's depth pre-pass); ``cull`` as :meth:`draw_shaded`'s."""
        everything = self.meshes + self.light_quads
        try:
            for index in indices:
                mesh = everything[index]
                masked = mesh.alpha_cutoff >= 0.0 and True in programs
                program = programs[masked]
                if cull:
                    self.face_culling(mesh)
                set_uniform(program, "u_sides", mesh.sides)  # a depth pre-pass culls as the camera's passes do
                if masked:
                    self._bind_maps(program, mesh, all_maps=False)
                self._vao(program, index, mesh).render()
        finally:
            if cull:
                self.face_culling(None)

    def release_programs(self, programs: dict) -> None:
        """Forget the vertex arrays of ``programs`` (a dict's values, as :meth:`occluder_programs` gives) and
        release them."""
        for program in programs.values():
            self.forget(program)
            program.release()

    def forget(self, program) -> None:
        """Release the vertex arrays made for ``program`` (call before releasing a short-lived program)."""
        for key in [k for k, (_, prog) in self._vaos.items() if prog is program]:
            self._vaos.pop(key)[0].release()
        self._held.pop(program, None)

    def release(self) -> None:
        """Free the scene's buffers, maps, tables and vertex arrays."""
        if self.sheen_table is not None:
            self.sheen_table.release()
            self.sheen_table = None
        for vao, _ in self._vaos.values():
            vao.release()
        self._vaos.clear()
        self._held.clear()
        for mesh in self.meshes + self.light_quads:
            mesh.vbo.release()
            mesh.ibo.release()
        for tex in self._maps.values():
            tex.release()
        self._maps.clear()
        self.meshes, self.light_quads = [], []

