"""Point, spot and directional lights (``KHR_lights_punctual``) in the progressive rasterizer.

A punctual light needs no sampling: its light at a surface point is one BRDF
evaluation (``punctual_light.glsl``), exact, and its shadow is one visibility
test against one shadow map. So unlike an area light's samples it is not
spread over frames as an estimate:

* **From the first frame** every frame adds the exact unshadowed light of every
  punctual light (the forward-shaded frame 0 too, ``first_frame.glsl``) to its
  own running mean over frames (a :class:`~compare.progressive.frame.accumulate.PingPong`,
  ``punctual.glsl``, up to :data:`MAX_BATCH` lights per full-screen draw), which
  gives the light's anti-aliasing the same jitter as everything else.
* **The shadow map** of each light is the one costly step, and the sample
  distributor places it (:func:`compare.progressive.schedule.distributor.punctual_frames`,
  the frame budget's ``c_p``): light k in frame 1 + k. The scene is static, so
  the map is kept; from that frame on the light's term is shadowed. The mean
  restarts whenever a map arrives, so it never mixes shadowed and unshadowed
  frames of a light: after the last map the mean is the exact shadowed light,
  anti-aliased over the frames since.

Shadow maps (hard depth test, the area lights' bias in texels,
``punctual_shadow.glsl``):

* **point** — a cube, six 90° perspective faces of ``S/2`` texels in one atlas
  of 3 × 2 tiles (a face covers 90°, so its texels subtend the angle of an
  S-texel map of 180°), looked up by the major axis of the offset from the light;
* **spot** — one perspective face of ``S`` texels through the outer cone
  (``2·outer_cone`` wide) up to :data:`MAX_SPOT_FACE_DEGREES`; a wider cone
  gets the point light's cube;
* **directional** — one orthographic face of ``S`` texels, fitted across the
  light to the part of the scene's bounds that the camera can see (the camera
  rays' segments inside the bounds, :func:`visible_points`, as a box across the
  light), and along it to the whole scene, so that every caster between a
  visible receiver and the light is in it.

The depth stored is the distance from the light (a directional light's: along
its direction from the map's plane), as for area lights (``shadow.glsl``).
"""

from __future__ import annotations

import math

import numpy as np

from compare.progressive.frame.accumulate import PingPong
from compare.progressive.frame.gpu_scene import frustum, look_at, mat_bytes
from compare.progressive.gl.passes import RenderPass
from compare.progressive.gl.shaders import load_program, set_uniform
from compare.progressive.gl.units import bind, bind_array, units_of

#: Widest spot cone (full angle, degrees) drawn through one perspective face; wider ones get a cube.
MAX_SPOT_FACE_DEGREES = 120.0
#: The kinds' codes in the shaders.
KIND_CODES = {"point": 0.0, "spot": 1.0, "directional": 2.0}
_UNITS = units_of("punctual.glsl")
#: Most lights one draw of punctual.glsl shades: a shadow map each, as many as its row of texture units
#: holds (:mod:`compare.progressive.gl.units` says why that many).
MAX_BATCH = _UNITS["shadow_maps"].count
#: Most texels all punctual lights' kept maps may hold together (32-bit depth: 256 MiB); beyond it every
#: map's S shrinks alike, and the render says so.
MAX_SHADOW_TEXELS = 1 << 26


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _up_for(forward: np.ndarray) -> np.ndarray:
    return np.array([0.0, 1.0, 0.0]) if abs(forward[1]) < 0.9 else np.array([1.0, 0.0, 0.0])


def ortho(left: float, right: float, bottom: float, top: float, near: float, far: float) -> np.ndarray:
    """OpenGL ``glOrtho`` projection."""
    m = np.eye(4)
    m[0, 0], m[1, 1], m[2, 2] = 2 / (right - left), 2 / (top - bottom), -2 / (far - near)
    m[0, 3] = -(right + left) / (right - left)
    m[1, 3] = -(top + bottom) / (top - bottom)
    m[2, 3] = -(far + near) / (far - near)
    return m


def visible_points(camera, bounds, grid: int = 17) -> np.ndarray:
    """End points of the parts of the camera's rays (a ``grid`` × ``grid`` fan over the image, its
    edges and corners included) that lie inside the scene's ``bounds``: every point the camera can see
    lies on one of those segments up to the fan's spacing, so their box across a light is the part of
    the scene a directional shadow map needs (far tighter than the frustum, whose far plane reaches
    the farthest corner of the scene)."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in bounds)
    inv = np.linalg.inv(camera.view_proj((0.0, 0.0)))
    x, y = np.meshgrid(np.linspace(-1, 1, grid), np.linspace(-1, 1, grid))
    near = np.stack([x.ravel(), y.ravel(), -np.ones(x.size), np.ones(x.size)], axis=1) @ inv.T
    far = np.stack([x.ravel(), y.ravel(), np.ones(x.size), np.ones(x.size)], axis=1) @ inv.T
    a, b = near[:, :3] / near[:, 3:4], far[:, :3] / far[:, 3:4]
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - a) / d, (hi - a) / d
    t0 = np.where(np.abs(d) < 1e-300, np.where((a >= lo) & (a <= hi), -np.inf, np.inf), t0)
    t1 = np.where(np.abs(d) < 1e-300, np.where((a >= lo) & (a <= hi), np.inf, -np.inf), t1)
    enter = np.clip(np.max(np.minimum(t0, t1), axis=1), 0.0, 1.0)
    leave = np.clip(np.min(np.maximum(t0, t1), axis=1), 0.0, 1.0)
    seen = leave > enter
    if not seen.any():
        return np.zeros((0, 3))
    return np.concatenate([a[seen] + enter[seen, None] * d[seen], a[seen] + leave[seen, None] * d[seen]])


def _corners(lo, hi) -> np.ndarray:
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


class ShadowMap:
    """The layout of one punctual light's shadow map: faces, their matrices and atlas tiles, the
    depth metric (origin, direction, far) and the texel's world size (``texel = a·d + b``)."""

    def __init__(self, light, bounds: tuple[np.ndarray, np.ndarray], camera_corners: np.ndarray, size: int):
        lo, hi = (np.asarray(b, dtype=np.float64) for b in bounds)
        corners = _corners(lo, hi)
        diagonal = float(np.linalg.norm(hi - lo)) or 1.0
        self.ortho = light.kind == "directional"
        direction = _unit(light.direction)
        self.direction = direction
        cube = light.kind == "point" or (light.kind == "spot" and 2 * light.outer_cone > MAX_SPOT_FACE_DEGREES)
        if self.ortho:
            self._fit_orthographic(direction, corners, camera_corners, diagonal, size)
            return
        position = np.asarray(light.position, dtype=np.float64)
        self.origin = position
        self.far = float(np.linalg.norm(corners - position, axis=1).max() * 1.01 + 1e-3 * diagonal)
        near = 1e-5 * diagonal
        if cube:
            face = max(2, int(size) // 2)
            self.shape = (3 * face, 2 * face)
            axes = np.vstack([np.eye(3), -np.eye(3)])[[0, 3, 1, 4, 2, 5]]  # +x -x +y -y +z -z
            proj = frustum(-near, near, -near, near, near, self.far)
            self.view_proj = np.array([proj @ look_at(position, a, _up_for(a)) for a in axes])
            self.rects = np.array([((k % 3) * face, (k // 3) * face, face, face) for k in range(6)], dtype=np.float32)
            self.texel = (2.0 / face, 0.0)
        else:
            half = math.tan(math.radians(min(light.outer_cone + 0.5, 89.0)))
            proj = frustum(-near * half, near * half, -near * half, near * half, near, self.far)
            self.view_proj = proj @ look_at(position, direction, _up_for(direction))[None]
            self.shape = (int(size), int(size))
            self.rects = np.array([(0, 0, size, size)], dtype=np.float32)
            self.texel = (2.0 * half / size, 0.0)

    def _fit_orthographic(self, direction, corners, camera_corners, diagonal: float, size: int) -> None:
        up = _up_for(direction)
        centre = corners.mean(axis=0)
        margin = 0.01 * diagonal
        eye = centre - direction * (0.5 * diagonal + margin)  # behind every point of the scene
        view = look_at(eye, direction, up)
        scene_xy = (view[:3, :3] @ corners.T).T + view[:3, 3]
        box_lo, box_hi = scene_xy[:, :2].min(axis=0), scene_xy[:, :2].max(axis=0)
        if len(camera_corners):
            cam_xy = (view[:3, :3] @ camera_corners.T).T[:, :2] + view[:2, 3]
            lo2, hi2 = np.maximum(box_lo, cam_xy.min(axis=0)), np.minimum(box_hi, cam_xy.max(axis=0))
            if np.all(hi2 > lo2):
                box_lo, box_hi = lo2, hi2
        pad = 2.0 * float(np.max(box_hi - box_lo)) / size  # two texels: a receiver's offset stays inside
        box_lo, box_hi = box_lo - pad, box_hi + pad
        self.origin = eye
        self.far = float(diagonal + 2 * margin)
        proj = ortho(box_lo[0], box_hi[0], box_lo[1], box_hi[1], 0.0, self.far)
        self.view_proj = (proj @ view)[None]
        self.shape = (int(size), int(size))
        self.rects = np.array([(0, 0, size, size)], dtype=np.float32)
        self.texel = (0.0, float(np.max(box_hi - box_lo)) / size)

    @property
    def faces(self) -> int:
        return len(self.view_proj)

    def describe(self) -> str:
        kind = "orthographic" if self.ortho else "cube" if self.faces == 6 else "perspective"
        return f"{kind} {self.rects[0][2]:.0f}²" + (" ×6" if self.faces == 6 else "")


def set_shadow_maps(program, maps) -> None:
    """The ``u_pshadow_*`` and ``u_pface_*`` uniforms of ``punctual_shadow.glsl`` for ``maps`` (one
    :class:`ShadowMap` per light of the program's batch, in order)."""
    def arr(values, dtype=np.float32) -> bytes:
        return np.ascontiguousarray(values, dtype=dtype).tobytes()

    vp = np.zeros((6 * len(maps), 4, 4), dtype=np.float32)
    rects = np.zeros((6 * len(maps), 4), dtype=np.float32)
    for k, m in enumerate(maps):
        vp[6 * k:6 * k + m.faces] = m.view_proj
        rects[6 * k:6 * k + m.faces] = m.rects
    set_uniform(program, "u_pface_view_proj", arr(vp.transpose(0, 2, 1)))
    set_uniform(program, "u_pface_rect", arr(rects))
    set_uniform(program, "u_pshadow_faces", arr([m.faces for m in maps], np.int32))
    set_uniform(program, "u_pshadow_origin", arr([m.origin for m in maps]))
    set_uniform(program, "u_pshadow_direction", arr([m.direction for m in maps]))
    set_uniform(program, "u_pshadow_ortho", arr([float(m.ortho) for m in maps]))
    set_uniform(program, "u_pshadow_far", arr([m.far for m in maps]))
    set_uniform(program, "u_pshadow_texel", arr([m.texel for m in maps]))


def draw_shadow_map(ctx, gpu_scene, programs: dict, m: ShadowMap, fbo) -> None:
    """Draw the scene's occluders into ``fbo``'s depth, every face of ``m`` in its tile, with ``programs``
    (:meth:`GpuScene.occluder_programs` of ``shadow.glsl``, with ``ORTHO`` for an orthographic map)."""
    fbo.use()
    ctx.enable_only(ctx.DEPTH_TEST)
    ctx.depth_func = "<"
    fbo.clear(depth=1.0)
    for program in programs.values():
        set_uniform(program, "u_sample", tuple(float(x) for x in m.origin))
        set_uniform(program, "u_inv_far", 1.0 / m.far)
        if m.ortho:
            set_uniform(program, "u_direction", tuple(float(x) for x in m.direction))
    for k in range(m.faces):
        ctx.viewport = tuple(int(v) for v in m.rects[k])
        for program in programs.values():
            set_uniform(program, "u_view_proj", mat_bytes(m.view_proj[k]))
        gpu_scene.draw_occluders(programs)


def light_uniforms(light) -> dict:
    """One punctual light as ``punctual_light.glsl``'s inputs: kind code, position, unit direction,
    intensity and cone terms, by the names of a batch's uniform arrays (``u_kind``, ``u_light_*``)."""
    return {"u_kind": KIND_CODES[light.kind], "u_light_position": tuple(float(x) for x in light.position),
            "u_light_direction": tuple(float(x) for x in _unit(light.direction)),
            "u_light_intensity": tuple(float(x) for x in light.intensity),
            "u_light_cone": tuple(float(x) for x in light.cone_terms())}


class PunctualLights(RenderPass):
    """Shadow maps, programs and the running mean of a scene's punctual lights.

    ``camera`` is the rasterizer's :class:`~compare.progressive.frame.gpu_scene.CameraSetup` (a
    directional light's map is fitted to what it sees); ``shadow_size`` is S (module notes).
    """

    def __init__(self, ctx, gpu_scene, scene, camera, size: tuple[int, int], *, shadow_size: int,
                 materials: str = "shared"):
        self.ctx = ctx
        self.scene = gpu_scene
        self.lights = tuple(scene.punctual)
        bounds = scene.extent()
        camera_corners = visible_points(camera, bounds)
        self.maps = [ShadowMap(light, bounds, camera_corners, int(shadow_size)) for light in self.lights]
        self.notes: list[str] = []
        texels = sum(m.shape[0] * m.shape[1] for m in self.maps)
        if texels > MAX_SHADOW_TEXELS:
            smaller = int(shadow_size * math.sqrt(MAX_SHADOW_TEXELS / texels)) // 2 * 2
            self.maps = [ShadowMap(light, bounds, camera_corners, smaller) for light in self.lights]
            self.notes.append(f"{len(self.lights)} punctual lights' shadow maps drawn at S = {smaller} instead of "
                              f"{shadow_size}: their kept maps would hold {texels / 2 ** 20:.0f} Mi texels, "
                              f"more than {MAX_SHADOW_TEXELS / 2 ** 20:.0f} Mi")
        self._objects: list = []
        self.programs: dict = {}
        try:
            self.textures = []
            self.fbos = []
            for m in self.maps:
                depth = self._keep(ctx.depth_texture(m.shape))
                depth.compare_func = ""  # the stored value, no hardware comparison
                depth.filter = (ctx.NEAREST, ctx.NEAREST)
                self.textures.append(depth)
                self.fbos.append(self._keep(ctx.framebuffer(depth_attachment=depth)))
            self.caster_programs = {False: gpu_scene.occluder_programs(ctx, "shadow.glsl")}
            if any(m.ortho for m in self.maps):
                self.caster_programs[True] = gpu_scene.occluder_programs(ctx, "shadow.glsl", {"ORTHO": 1})
            defines = {"MATERIALS_DIFFUSE": int(materials == "diffuse"), **gpu_scene.layer_defines(materials)}
            self.batches = [tuple(range(k, min(k + MAX_BATCH, len(self.lights))))
                            for k in range(0, len(self.lights), MAX_BATCH)]
            for count in {len(b) for b in self.batches}:
                program = self._keep(load_program(ctx, "punctual.glsl", {**defines, "BATCH": count}))
                self.programs[count] = (program, self._keep(ctx.vertex_array(program, [])))
            self.acc = self._keep(PingPong(ctx, size))
        except BaseException:
            self.release()
            raise
        self.ready: set[int] = set()
        """Lights whose shadow map has been rendered since :meth:`reset`."""

    def _keep(self, obj):
        self._objects.append(obj)
        return obj

    def uniform_arrays(self) -> dict[str, bytes]:
        """The lights as uniform arrays of the forward-shaded first frame (``first_frame.glsl``)."""
        def arr(values) -> bytes:
            return np.ascontiguousarray(values, dtype=np.float32).tobytes()

        return {"u_punctual_kind": arr([KIND_CODES[lt.kind] for lt in self.lights]),
                "u_punctual_position": arr([lt.position for lt in self.lights]),
                "u_punctual_direction": arr([_unit(lt.direction) for lt in self.lights]),
                "u_punctual_intensity": arr([lt.intensity for lt in self.lights]),
                "u_punctual_cone": arr([lt.cone_terms() for lt in self.lights])}

    def render_shadow(self, index: int) -> None:
        """Render light ``index``'s shadow map (kept until :meth:`reset`); the mean restarts."""
        m = self.maps[index]
        draw_shadow_map(self.ctx, self.scene, self.caster_programs[m.ortho], m, self.fbos[index])
        self.ready.add(index)
        self.acc.reset()  # never mix a light's shadowed and unshadowed frames in one mean

    def run(self, gbuffer, camera_position, bias) -> None:
        """Fold this frame's light of every punctual light into the running mean."""
        ctx, acc = self.ctx, self.acc
        acc.target.use()
        n = acc.count + 1
        cam = tuple(float(x) for x in camera_position)
        for b, batch in enumerate(self.batches):
            program, vao = self.programs[len(batch)]
            if b == 0:
                ctx.enable_only(ctx.NOTHING)
            else:
                ctx.enable_only(ctx.BLEND)
                ctx.blend_func = ctx.ONE, ctx.ONE
                ctx.blend_equation = ctx.FUNC_ADD
            gbuffer.bind(program)
            gbuffer.bind_layers(program)
            bind(program, "u_previous", acc.current, _UNITS["previous"])
            set_uniform(program, "u_camera_position", cam)
            set_uniform(program, "u_inv_count", 1.0 / n)
            set_uniform(program, "u_fold", 1.0 if b == 0 else 0.0)
            set_uniform(program, "u_bias", tuple(float(x) for x in bias))
            self._set_batch(program, batch)
            vao.render(vertices=3)
        acc.swap()

    def _set_batch(self, program, batch: tuple[int, ...]) -> None:
        """The uniforms of the lights ``batch`` and their shadow maps (bound whether rendered or not)."""
        def arr(values, dtype=np.float32) -> bytes:
            return np.ascontiguousarray(values, dtype=dtype).tobytes()

        lights = [self.lights[i] for i in batch]
        bind_array(program, "u_pshadow", [self.textures[i] for i in batch], _UNITS["shadow_maps"])
        set_uniform(program, "u_kind", arr([KIND_CODES[lt.kind] for lt in lights]))
        set_uniform(program, "u_light_position", arr([lt.position for lt in lights]))
        set_uniform(program, "u_light_direction", arr([_unit(lt.direction) for lt in lights]))
        set_uniform(program, "u_light_intensity", arr([lt.intensity for lt in lights]))
        set_uniform(program, "u_light_cone", arr([lt.cone_terms() for lt in lights]))
        set_uniform(program, "u_shadowed", arr([float(i in self.ready) for i in batch]))
        set_shadow_maps(program, [self.maps[i] for i in batch])

    @property
    def texture(self):
        """The running mean (the display's punctual term)."""
        return self.acc.current

    def reset(self) -> None:
        """Forget the shadow maps and the mean (the maps' textures are kept for reuse)."""
        self.ready = set()
        self.acc.reset()

    def describe(self) -> dict:
        """The lights' count and their shadow maps."""
        return {"punctual_lights": len(self.lights),
                "punctual_shadow_maps": ", ".join(f"{lt.kind} {m.describe()}" for lt, m in zip(self.lights,
                                                                                              self.maps))}

    def release(self) -> None:
        for programs in getattr(self, "caster_programs", {}).values():
            self.scene.release_programs(programs)
        self.caster_programs = {}
        for obj in reversed(self._objects):
            obj.release()
        self._objects = []
