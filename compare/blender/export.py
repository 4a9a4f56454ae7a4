"""The neutral scene as the job a Blender worker builds its scene from (numpy only, no bpy).

Everything that decides how a :class:`compare.scene.loader.Scene` maps onto Blender's
data model is computed here, in the caller's process, so that it can be
tested without bpy and so that the worker (:mod:`compare.blender.worker`) only
copies numbers into Blender. The job is a folder with ``job.json`` (settings,
camera, materials, lights, environment), ``meshes.npz`` (world-space triangle
arrays) and, for a map environment, ``environment.exr``.

Coordinates
-----------
No axis conversion: the scene's coordinates go into Blender unchanged. Blender
calls +Z "up" only in its tools and in its world texture lookup; the renderers
themselves do not care. So the scene stays right-handed with +Y up, and only the
environment map lookup is turned (:data:`ENV_TO_BLENDER`).

Camera
------
Blender cameras look along their local −Z with +Y up, so the camera object's
matrix has the columns (right, up, −forward, position) of
:meth:`compare.scene.loader.Camera.basis`. The vertical field of view is set through
``sensor_fit = 'VERTICAL'``: ``lens = (sensor_height / 2) / tan(fov / 2)``.

Area lights and their radiometry
--------------------------------
A Blender area light of power ``P`` watts (``energy``), colour ``c`` and area
``A`` (with ``normalize`` on, the default) emits the radiance

    L = c · P / (π · A)            [W sr⁻¹ m⁻²]

uniformly in every direction of the hemisphere in front of it (its local −Z),
and nothing behind it: a one-sided Lambertian emitter, as in the scene model.
Cycles: ``eval_fac = M_1_PI_F * invarea`` in its area-light kernel with
``invarea = 1 / area`` (``intern/cycles/scene/light.cpp``); EEVEE: radiance
``= M_1_PI / area`` × power for rectangle lights (``eevee_light.cc``). The ``spread`` must stay at 180° (the
default): a smaller spread narrows the emission lobe and renormalises it, which
is no longer Lambertian. So each light gets ``energy = π · A · max(L)`` and
``color = L / max(L)`` (:func:`light_power`), which keeps the colour in [0, 1].
``tests/test_blender.py`` checks this convention by rendering a diffuse plane
under one light against Lambert's closed form (:func:`compare.metrics.closed_form.polygon_irradiance`).

Differences a Blender area light has from Mitsuba's ``rectangle`` + ``area``
emitter, and what is done about them:

* Mitsuba's rectangle is also a surface (with a black BSDF): it absorbs what
  hits its back and occludes. A Blender light is not a surface. So the worker
  adds a black, one-sided *backing* quad just behind each light
  (:data:`LIGHT_BACKING_OFFSET`), which absorbs and occludes like Mitsuba's.
* Mitsuba shows the emitter to the camera (``hide_emitters = False``). Cycles
  does with ``visible_camera = True`` on the light object; EEVEE never draws
  lights, so for EEVEE the backing quad also carries an emission of ``L`` on its
  front face (visible to the camera, casting no shadow, hidden from light probes).

Materials (glTF metallic-roughness → Principled BSDF v2 of Blender 4/5)
----------------------------------------------------------------------
``Base Color`` = base colour (or the base-colour texture, sRGB-decoded for
PNG/JPEG, linear for EXR, as Mitsuba's ``bitmap`` with ``raw = False``),
``Metallic`` = metallic, ``Roughness`` = perceptual roughness (Blender squares
it to α like glTF), ``IOR`` = 1.5 and ``Specular IOR Level`` = 0.5 (its neutral
value) so that F0 = ((1.5 − 1)/(1.5 + 1))² = 0.04 for dielectrics, ``Specular
Tint`` = white (no tint; for metals the F82 tint is then white too),
``Diffuse Roughness`` = 0 (Lambert; >0 would be Oren–Nayar), coat, sheen,
subsurface and transmission 0, ``distribution`` = the material's
``distribution`` (Blender's default ``MULTI_GGX`` unless the scene says
``ggx``, or GGX for every material with ``distribution="ggx"``, the
``cycles:ggx`` / ``eevee:ggx`` renderers; the worker reports what it set,
metadata ``distribution``). Multiscatter GGX adds back the energy lost between
microfacets (a few percent at roughness 1 for metals) and lets more light into
the diffuse under the specular layer (:mod:`compare.brdf.multiscatter`). With
GGX, what Cycles then evaluates differs from the
suite's glTF BSDF (the reference's ``shared`` mode) in two ways: the exact
dielectric Fresnel for IOR 1.5 in place of Schlick, and a Lambert lobe
scaled by one minus Cycles' estimate of the specular layer's albedo at the view
direction, in place of glTF's per-direction ``1 − F(v·h)``. The reference's
``cycles`` mode models exactly this (:mod:`compare.mitsuba.principled`, the
plugin's ``cycles`` flavour): with ``shared`` glossy materials differ from
Cycles, with ``cycles`` they agree, and with Lambert on both sides the regions
agree within noise, so the rest of the mapping is not the cause
(:mod:`compare.run.likeness`; the numbers are in ``docs/performance-notes.md``).
Emission = ``Emission Color`` with strength 1, made one-sided (as Mitsuba's
``area`` emitter on a mesh) by zeroing it on back faces. A
``metallic_roughness_texture`` drives Roughness (its G channel) and Metallic (B)
through a Separate Color node, the image read as Non-Color, as Blender's glTF
importer wires it (and as :mod:`compare.mitsuba.scene_dict` reads it); like the base
colour map it replaces the factors. An ``emissive_texture`` (sRGB) multiplies the
emission (a Mix node, Multiply), as glTF's emissiveTexture does. An
``occlusion_texture`` is left out: Cycles computes occlusion (as the reference does,
and as Blender's glTF importer leaves it unconnected). A ``normal_texture`` goes
through a Normal Map node in tangent space on the UV map, with ``normal_scale`` as
its strength (Blender's strength blends towards the unperturbed normal rather
than scaling x and y; the two agree at 1). An alpha mask drives the Principled
BSDF's Alpha with 1 where alpha × the base-colour map's alpha (the image read
channel-packed, not premultiplied) passes the cutoff and 0 elsewhere (Math nodes),
with EEVEE's transparent shadows on; Cycles' transparent bounces are set apart
from the depth (``MAX_HOLES``), as the reference's integrator counts holes.
Texture coordinates: Mitsuba's v runs down the image, Blender's up, so v → 1 − v.

Environment
-----------
A constant environment is the world's Background colour × intensity. A map is
looked up, in Mitsuba's convention (:mod:`compare.scene.environments`), through the
fixed rotation :data:`ENV_TO_BLENDER` applied to the world direction (after the
scene's ``rotation``), because Blender's equirectangular lookup puts +Z at the
top row and +X at the centre column, where Mitsuba has +Y and +Z. The rotation
is fed to the Environment Texture as three dot products (Vector Math nodes), so
no Euler-angle convention is involved. The map is resampled once to Blender's texel
positions (rows at (j + ½)/H) from Mitsuba's (rows at j/(H − 1), on the poles),
so both interpolate the same function at their texel centres. A hidden background
(``background = false``) is a transparent film: Cycles and EEVEE leave the world out
of the premultiplied colour where camera rays hit nothing, and it still lights the scene.

Pixel filter
------------
Mitsuba's reference uses a box filter one pixel wide. Cycles has one:
``pixel_filter_type = 'BOX'`` with ``filter_width = 1.0`` is exactly that (its
filter table is constant over [−½, ½]² px). EEVEE has only its film filter, a
Gaussian with σ = 0.284 × ``filter_size`` truncated at ``filter_size`` px
(``film_filter_weight`` in ``eevee_film_shared.hh``). :data:`EEVEE_FILTER_SIZE`
matches its variance to the box's (σ = 1/√12 px). The residual difference is
the Gaussian's shape: 84 % of its weight lies over the pixel's own square, 16 %
over its neighbours (Blender's default 1.5 px: 42 %), so edges are slightly
softer than the box's; on smooth shading it makes no difference.

Cycles settings
---------------
CPU device, ``samples`` = N with a fixed ``seed`` (no animated seed), adaptive
sampling off (every pixel gets N samples), denoising off, no clamping
(``sample_clamp_direct`` = ``sample_clamp_indirect`` = 0; the indirect default
is 10), "Filter Glossy" (``blur_glossy``) 0 (it blurs glossy paths after a
diffuse bounce: a bias), ``light_sampling_threshold`` 0, caustics on, path
guiding off. Sampling stays Blender's: the Tabulated Sobol pattern; next-event
estimation with multiple importance sampling against BSDF sampling
(``direct_light_sampling_type = 'MULTIPLE_IMPORTANCE_SAMPLING'``, MIS on every
light, the world sampled through its importance map, ``AUTOMATIC``); the light
tree (``use_light_tree``) picks lights by their estimated contribution. These
change the noise, not the expectation, and Mitsuba's ``path`` integrator (also
NEE + MIS) converges to the same image. Russian roulette in both.

EEVEE settings
--------------
``taa_render_samples`` = N (the paper: 64), shadows on with *jittered* soft
shadows on every light (``use_shadow_jitter``: the shadow map's origin moves
over the light from sample to sample, so penumbrae converge instead of being
filtered; ``shadow_jitter_overblur`` stays at Blender's 10 %), the shadow ray
and step counts, resolution scale and pool at Blender's defaults, no clamping
of direct or indirect light (``clamp_surface_*`` = 0), screen-space ray
tracing off (its default; pass ``settings={"use_raytracing": True}`` to
measure it), no baked light probes, so indirect light between surfaces is
absent apart from the world's. Each light's influence distance is set to the
scene's size (``use_custom_distance``): with the default ``light_threshold``
a weak light would be culled where it still contributes. EEVEE is
deterministic (its sample sequence has no seed). The first render of a
process compiles shaders, so by default one sample is rendered first and left
out of the timing (``warmup``).

Path depth
----------
Mitsuba's ``max_depth`` counts path segments (2 = direct light only); Cycles'
``max_bounces`` counts scattering events after the first hit (0 = direct light
only), so ``max_bounces = max_depth − 2`` (:func:`cycles_bounces`); every
per-type bounce limit gets the same value, so none is tighter. Unbounded
(``-1``) becomes 1024, Cycles' maximum.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from compare.brdf.multiscatter import DISTRIBUTIONS
from compare.scene.model import MAX_HOLES
from compare.scene.loader import AreaLight, Camera, Scene

#: Version of the job format shared by this module and the worker.
JOB_VERSION = 2
#: Material models: the glTF → Principled mapping, or Lambert only.
#: The material modes (compare.brdf.SUPPORTED_MATERIALS) Blender is given: its Principled BSDF, or Lambert only.
SUPPORTED_MATERIALS = ("cycles", "diffuse")
#: The suite's distribution names → Blender's enum identifiers of the Principled BSDF's ``distribution``.
BLENDER_DISTRIBUTIONS = {"multi_ggx": "MULTI_GGX", "ggx": "GGX"}
#: Public engine names → Blender's engine identifiers.
ENGINES = {"cycles": "CYCLES", "eevee": "BLENDER_EEVEE"}
#: EEVEE samples the paper used (Otto et al. 2020, Table 1).
EEVEE_PAPER_SAMPLES = 64
#: Cycles samples the paper used for its reference.
CYCLES_PAPER_SAMPLES = 1024
#: EEVEE's film filter: σ of its Gaussian per pixel of ``filter_size``.
EEVEE_FILTER_SIGMA_PER_SIZE = 0.284
#: Standard deviation (px) of a box filter one pixel wide.
BOX_FILTER_SIGMA = 1.0 / math.sqrt(12.0)
#: EEVEE ``filter_size`` whose Gaussian has the variance of the box filter (≈ 1.017 px).
EEVEE_FILTER_SIZE = BOX_FILTER_SIGMA / EEVEE_FILTER_SIGMA_PER_SIZE
#: Cycles' largest bounce count, used for an unbounded path depth (-1).
CYCLES_MAX_BOUNCES = 1024
#: Distance of a light's backing quad behind the light, as a fraction of its larger side.
LIGHT_BACKING_OFFSET = 1e-4
#: Rows of this matrix turn a direction in the map's frame (Mitsuba's: +Y up, centre +Z,
#: u = ¼ at +X) into the direction Blender's equirectangular lookup needs for the same
#: texel (+Z up, centre +X, u = ¼ at +Y): Blender (X, Y, Z) = (z, x, y), a cyclic
#: permutation (a proper rotation). Measured, not assumed: tests/test_blender.py renders
#: a map whose texels hold their own direction and checks every pixel.
ENV_TO_BLENDER = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
#: Height (mm) of the virtual sensor; any value works with sensor_fit = VERTICAL.
SENSOR_HEIGHT_MM = 24.0


def engine_id(engine: str) -> str:
    """Blender's identifier for ``engine`` ('cycles' or 'eevee')."""
    try:
        return ENGINES[engine]
    except KeyError:
        raise ValueError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}") from None


def cycles_bounces(max_depth: int) -> int:
    """Cycles ``max_bounces`` for Mitsuba's ``max_depth`` (2 → 0 = direct light only; -1 → 1024)."""
    if max_depth == -1:
        return CYCLES_MAX_BOUNCES
    if max_depth < 2:
        raise ValueError(f"max_depth: Cycles cannot render max_depth={max_depth} (emitters only); "
                         "use 2 (direct light) or more")
    return min(int(max_depth) - 2, CYCLES_MAX_BOUNCES)


def camera_matrix(camera: Camera) -> np.ndarray:
    """4×4 object-to-world matrix of a Blender camera (looks along local −Z, +Y up)."""
    r, u, f = camera.basis()
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = r, u, -f, camera.position
    return m


def camera_lens_mm(camera: Camera) -> float:
    """Focal length (mm) giving ``camera.fov`` vertically on a :data:`SENSOR_HEIGHT_MM` sensor."""
    return 0.5 * SENSOR_HEIGHT_MM / math.tan(math.radians(camera.fov) / 2)


def clip_range(scene: Scene) -> tuple[float, float]:
    """Near and far clip distances enclosing the whole scene (EEVEE's depth buffer needs a sane ratio)."""
    lo, hi = scene.bounds()
    for light in scene.lights:
        c = light.corners()
        lo, hi = np.minimum(lo, c.min(0)), np.maximum(hi, c.max(0))
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    far = float(np.linalg.norm(corners - np.asarray(scene.camera.position), axis=1).max())
    far = max(far, 1e-3)
    return 1e-3 * far, 10.0 * far


def light_matrix(light: AreaLight) -> np.ndarray:
    """4×4 object-to-world matrix of a Blender area light: local X = tangent, local −Z = normal.

    Right-handed: X × Y = Z with Y = −bitangent (the light is symmetric in Y, so
    the sign does not matter for its shape).
    """
    m = np.eye(4)
    m[:3, 0] = light.tangent
    m[:3, 1] = -light.bitangent
    m[:3, 2] = -np.asarray(light.normal)
    m[:3, 3] = light.center
    return m


def _reach(scene, position, far: float) -> float:
    """A distance from ``position`` beyond every corner of the scene's bounds (at least ``far``)."""
    lo, hi = scene.extent()
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    return float(max(far, 2.0 * np.linalg.norm(corners - np.asarray(position), axis=1).max()))


def punctual_light(light) -> dict:
    """A point, spot or directional light as Blender's POINT, SPOT or SUN light of zero size, in the units of
    Blender's own glTF importer: a point or spot light's power is 4π × its intensity (W/sr; Blender defines a
    spot's power as that of the point light it is cut from), a sun's strength its irradiance (W/m²). The
    spot's cone is ``spot_size`` = 2 × the outer angle; Blender blends with smoothstep((cos θ − cos outer) /
    ((1 − cos outer) · spot_blend)), so ``spot_blend`` = (cos inner − cos outer) / (1 − cos outer) spans glTF's
    ramp exactly (the importer's 1 − inner / outer does not). Inside the ramp smoothstep is not glTF's square
    (:func:`blender_spot_falloff`): Blender is brighter there, by design of its light."""
    peak = max(light.intensity)
    color = [c / peak for c in light.intensity]
    # Blender's lights shine down their local -Z, as glTF's do
    out = {"name": light.name, "kind": light.kind, "color": color, "matrix": light.node_matrix().tolist()}
    if light.kind == "directional":
        out["energy"] = peak
    else:
        out["energy"] = 4.0 * math.pi * peak
    if light.kind == "spot":
        out["spot_size"] = math.radians(2.0 * light.outer_cone)
        out["spot_blend"] = spot_blend(light)
    return out


def spot_blend(light) -> float:
    """Blender's ``spot_blend`` whose ramp spans glTF's, from cos(outer) to cos(inner)."""
    ci, co = math.cos(math.radians(light.inner_cone)), math.cos(math.radians(light.outer_cone))
    return (ci - co) / (1.0 - co)


def blender_spot_falloff(light, cos_theta):
    """The cone factor Blender's SPOT light of :func:`punctual_light` gives at cos θ from its axis."""
    co = math.cos(math.radians(light.outer_cone))
    x = np.clip((np.asarray(cos_theta, dtype=np.float64) - co) / ((1.0 - co) * spot_blend(light)), 0.0, 1.0)
    return np.where(np.asarray(cos_theta) > co, x * x * (3.0 - 2.0 * x), 0.0)


def light_power(light: AreaLight) -> tuple[list[float], float]:
    """Blender ``(color, energy)`` of an area light: energy = π·A·max(L), colour = L / max(L).

    Blender's area light emits L = colour · energy / (π · A) (see the module notes).
    """
    radiance = np.asarray(light.radiance, dtype=np.float64)
    peak = float(radiance.max())
    return (radiance / peak).tolist(), math.pi * light.area * peak


def environment_lookup_matrix(rotation_deg: float) -> np.ndarray:
    """3×3 matrix taking a world direction to the vector Blender's equirect lookup needs.

    World → map frame (undo the scene's rotation about +Y, as Mitsuba's
    ``to_world``), then map frame → Blender's lookup frame (:data:`ENV_TO_BLENDER`).
    """
    from compare.scene.equirect import rotation_matrix

    return ENV_TO_BLENDER @ rotation_matrix(rotation_deg).T


def blender_environment_map(image: np.ndarray) -> np.ndarray:
    """Resample a map (Mitsuba's texel rows on the poles) to Blender's texel centres, same size.

    Row j of the result holds Mitsuba's interpolated radiance at v = (j + ½)/H,
    column i at u = (i + ½)/W (the same in both).
    """
    from compare.scene.equirect import sample_equirect, uv_to_direction

    h, w = image.shape[:2]
    u = (np.arange(w) + 0.5) / w
    v = (np.arange(h) + 0.5) / h
    uu, vv = np.meshgrid(u, v)
    out = sample_equirect(image, uv_to_direction(uu, vv))
    return np.ascontiguousarray(out, dtype=np.float32)


#: The UV layers of the meshes Blender gets: glTF's TEXCOORD_0 and TEXCOORD_1.
UV_LAYERS = ("UVMap", "UVMap.001")
#: The image node's extension of each wrap mode (one for both axes; per-axis wraps are math nodes).
BLENDER_EXTENSIONS = {"repeat": "REPEAT", "clamp": "EXTEND", "mirror": "MIRROR"}


def blender_map_reading(sampling) -> dict[str, Any]:
    """How an image node reads one map (a :class:`compare.scene.model.MapSampling`): its UV layer, its texture
    transform as a Mapping node, its interpolation, and its wrap: the node's extension where both axes wrap
    alike, else ``axis_wraps`` (s, t) done by math nodes before an extended (clamped) lookup."""
    same = sampling.wrap[0] == sampling.wrap[1]
    return {"uv_map": UV_LAYERS[sampling.texcoord], "uv_mapping": blender_uv_mapping(sampling),
            "interpolation": "Closest" if sampling.filter == "nearest" else "Linear",
            "extension": BLENDER_EXTENSIONS[sampling.wrap[0]] if same else "EXTEND",
            "axis_wraps": None if same else list(sampling.wrap)}


def blender_uv_mapping(sampling) -> dict[str, list[float]] | None:
    """A map's texture transform (a :class:`compare.scene.model.MapSampling`) as a Blender Mapping node (POINT:
    scale, then rotate about Z, then translate), or None for none.

    The transform is glTF's, on glTF's coordinates (v down the image); Blender's v runs up
    (v_b = 1 − v, see the module notes), so the node applies F M F with F the flip of v. Its linear part is
    a rotation times the scales (M's rotation turns the other way in Blender's frame).
    """
    if not sampling.has_uv_transform:
        return None
    flip = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])
    a = flip @ sampling.uv_transform() @ flip
    lin = a[:2, :2]
    sx, sy = float(np.linalg.norm(lin[:, 0])), float(np.linalg.norm(lin[:, 1]))
    if np.linalg.det(lin) < 0:
        sy = -sy
    angle = math.atan2(lin[1, 0], lin[0, 0])
    return {"location": [float(a[0, 2]), float(a[1, 2]), 0.0], "rotation": [0.0, 0.0, angle], "scale": [sx, sy, 1.0]}


#: The Principled BSDF input of each material extension parameter that has a map (LAYER_MAPS; the thickness
#: map has none: Cycles takes the thickness from the geometry).
BLENDER_INPUTS = {"transmission": "Transmission Weight", "clearcoat": "Coat Weight",
                  "clearcoat_roughness": "Coat Roughness", "sheen_color": "Sheen Tint",
                  "sheen_roughness": "Sheen Roughness", "specular": "Specular IOR Level",
                  "specular_color": "Specular Tint"}
#: What a map's value is multiplied by on its input besides the factor (Specular IOR Level = specular / 2).
BLENDER_INPUT_SCALE = {"specular": 0.5}


def principled_inputs(mat) -> dict[str, Any]:
    """The Principled BSDF inputs of glTF's material extensions, as Blender's glTF importer sets them:
    transmission and IOR as they are, the coat at glTF's fixed IOR 1.5, sheen at full weight tinted by its
    colour, and ``KHR_materials_specular`` as ``Specular IOR Level`` = specular / 2 (0.5 is neutral: F0
    scaled by 2 × level) with its colour as ``Specular Tint`` (glTF's F90 = specular has no input)."""
    return {"Transmission Weight": float(mat.transmission), "IOR": float(min(mat.ior, 1e3)),
            "Coat Weight": float(mat.clearcoat), "Coat Roughness": float(mat.clearcoat_roughness), "Coat IOR": 1.5,
            "Sheen Weight": 1.0 if max(mat.sheen_color) > 0 else 0.0,
            "Sheen Tint": [*map(float, mat.sheen_color), 1.0], "Sheen Roughness": float(mat.sheen_roughness),
            "Specular IOR Level": 0.5 * float(mat.specular), "Specular Tint": [*map(float, mat.specular_color), 1.0]}


def volume_absorption(mat) -> dict[str, Any] | None:
    """``KHR_materials_volume``'s attenuation as a Volume Absorption node, or None: Beer's law
    ``T = c^(x/d)`` is an absorption coefficient ``−ln(c)/d`` per channel, which the node's
    ``density × (1 − color)`` gives with density 1/d and colour 1 + ln(c) (c ≥ 1/e)."""
    if mat.transmission == 0.0 or math.isinf(mat.attenuation_distance):
        return None
    color = [max(0.0, 1.0 + math.log(max(c, 1e-12))) for c in mat.attenuation_color]
    return {"color": color, "density": 1.0 / float(mat.attenuation_distance)}


def anisotropy_inputs(mat) -> dict[str, Any] | None:
    """``KHR_materials_anisotropy`` as the worker sets it on the Principled BSDF, or None.

    Cycles stretches the lobe as α_x = r²/a along the tangent and α_y = r²·a across it, a = √(1 − 0.9 A)
    (A its Anisotropic input); glTF as α_t = mix(α, 1, s²) and α_b = α. The two agree where r² = √(α_t α_b)
    and A = (1 − α_b/α_t) / 0.9, which the worker computes per point from the roughness (a map's too) and
    the strength (times the map's B); Blender's A ≤ 1 holds to α_b/α_t ≥ 0.1 (past it the stretch is
    Blender's most). The direction, the tangent of the UV map turned by the rotation and the map's RG angle,
    is the Anisotropic Rotation (turns) about the normal: glTF's bitangent is n × t where the UVs are not
    mirrored (w = +1), where the turn goes the same way.
    """
    if mat.anisotropy_strength == 0.0:
        return None
    found = next((m for m in mat.layer_maps if m[0] == "anisotropy_strength"), None)
    return {"strength": float(mat.anisotropy_strength), "rotation": float(mat.anisotropy_rotation),
            "map": str(found[2]) if found else None, "uv_map": UV_LAYERS[mat.tangent_uv]}


def thin_film_inputs(mat) -> dict[str, Any] | None:
    """``KHR_materials_iridescence`` as the Principled BSDF's Thin Film (thickness in nm, its IOR), or None.
    glTF mixes the film's Fresnel in by the factor; the worker mixes a Principled BSDF with the film and one
    without by it (a map's R times it), and the thickness is mix(minimum, maximum, G) where a map gives it."""
    if mat.iridescence == 0.0:
        return None
    maps = {f: str(p) for f, _, p in mat.layer_maps if f in ("iridescence", "iridescence_thickness_max")}
    return {"factor": float(mat.iridescence), "ior": float(mat.iridescence_ior),
            "thickness_min": float(mat.iridescence_thickness_min),
            "thickness_max": float(mat.iridescence_thickness_max),
            "factor_map": maps.get("iridescence"), "thickness_map": maps.get("iridescence_thickness_max")}


def dispersion_inputs(mat) -> dict[str, Any] | None:
    """``KHR_materials_dispersion`` for Cycles, or None: Blender 5.0's Principled and Glass BSDFs have no
    dispersion input, so the worker draws the transmission as the reference does (compare.mitsuba.dispersion):
    three Glass BSDFs of the channels' IORs (:func:`compare.scene.model.channel_iors`), each tinted by its
    channel alone and added, a path picking one by its weight and carrying that channel; mixed with the
    Principled BSDF without transmission by the transmission weight."""
    if "dispersion" not in mat.uses():
        return None
    from compare.scene.model import channel_iors

    return {"iors": [float(n) for n in channel_iors(mat.ior, mat.dispersion)]}


def _material(mat, mode: str, distribution: str | None = None) -> dict[str, Any]:
    tex = mat.base_color_texture
    return {
        # how each map is read (its UV layer, transform, wrap and filter), by its name in the scene model
        "maps": {name: blender_map_reading(mat.sampling(name)) for name in mat.map_names()},
        # Blender's enum identifier of the Principled BSDF's distribution.
        "distribution": BLENDER_DISTRIBUTIONS[distribution or mat.distribution],
        "base_color": list(mat.base_color),
        "metallic": mat.metallic if mode == "cycles" else 0.0,
        "roughness": mat.roughness,
        # 0.5 is neutral (F0 = 0.04 at IOR 1.5); 0 removes the specular layer (pure Lambert).
        "specular_ior_level": 0.5 if mode == "cycles" else 0.0,
        "emission": list(mat.emission),
        "base_color_texture": str(tex) if tex else None,
        # glTF channels G = roughness, B = metallic (linear); with "diffuse" only the roughness is wired.
        "metallic_roughness_texture": (str(mat.metallic_roughness_texture)
                                       if mat.metallic_roughness_texture and mode == "cycles" else None),
        "emissive_texture": str(mat.emissive_texture) if mat.emissive_texture else None,
        "normal_texture": str(mat.normal_texture) if mat.normal_texture else None,
        "normal_scale": float(mat.normal_scale),
        "coat_normal_texture": (str(mat.clearcoat_normal_texture)
                                if mat.clearcoat_normal_texture and mat.clearcoat > 0 and mode == "cycles" else None),
        "coat_normal_scale": float(mat.clearcoat_normal_scale),
        # glTF's alpha mask: coverage (alpha × the base-colour map's alpha) >= cutoff, else a hole
        "alpha_mask": ({"alpha": float(mat.alpha), "cutoff": float(mat.alpha_cutoff)} if mat.is_masked else None),
        # glTF's material extensions as the Principled BSDF's inputs (Lambert only with "diffuse")
        "principled_inputs": principled_inputs(mat) if mode == "cycles" else {},
        # the extensions' maps, each times its factor on its input
        "input_maps": ([{"input": BLENDER_INPUTS[f], "file": str(p), "map": f,
                         "channel": {"r": "Red", "g": "Green", "b": "Blue", "a": "Alpha", "rgb": "Color"}[c],
                         "factor": ([float(x) for x in getattr(mat, f)] if c == "rgb"
                                    else float(getattr(mat, f)) * BLENDER_INPUT_SCALE.get(f, 1.0))}
                        for f, c, p in mat.layer_maps if f in BLENDER_INPUTS] if mode == "cycles" else []),
        # alphaMode BLEND: the coverage on Alpha (Cycles: stochastic transparency; EEVEE: dithered)
        "alpha_blend": float(mat.alpha) if mat.alpha_mode == "blend" else None,
        # glTF's doubleSided false, culled as the reference culls: not a transmissive solid (its inside is
        # its back)
        "single_sided": not mat.double_sided and mat.transmission == 0.0,
        "volume_absorption": volume_absorption(mat) if mode == "cycles" else None,
        "anisotropy": anisotropy_inputs(mat) if mode == "cycles" else None,
        "thin_film": thin_film_inputs(mat) if mode == "cycles" else None,
        "emissive_texture_colorspace": (None if not mat.emissive_texture else "Linear Rec.709"
                                        if Path(mat.emissive_texture).suffix.lower() == ".exr" else "sRGB"),
        # 8-bit images hold sRGB-encoded colour; EXR holds linear values.
        "base_color_texture_colorspace": (None if not tex else
                                          "Linear Rec.709" if Path(tex).suffix.lower() == ".exr" else "sRGB"),
    }


def _cycles_settings(scene: Scene, samples: int, seed: int) -> dict[str, Any]:
    b = cycles_bounces(scene.max_depth)
    return {
        "device": "CPU",
        "samples": int(samples),
        "seed": int(seed) % 2**31,  # Blender's seed is a signed 32-bit int
        "use_animated_seed": False,
        "use_adaptive_sampling": False,
        "use_denoising": False,
        "use_preview_denoising": False,
        "sample_clamp_direct": 0.0,
        "sample_clamp_indirect": 0.0,
        "blur_glossy": 0.0,  # "Filter Glossy" blurs glossy paths after a diffuse bounce: biased
        "light_sampling_threshold": 0.0,
        "caustics_reflective": True,
        "caustics_refractive": True,
        "use_light_tree": True,
        "direct_light_sampling_type": "MULTIPLE_IMPORTANCE_SAMPLING",
        "use_guiding": False,
        "max_bounces": b,
        "diffuse_bounces": b,
        "glossy_bounces": b,
        "transmission_bounces": b,
        "volume_bounces": b,
        # Holes of alpha masks are transparent bounces, apart from max_bounces, as in the reference
        "transparent_max_bounces": MAX_HOLES,
        "min_light_bounces": 0,
        "min_transparent_bounces": 0,
        "pixel_filter_type": "BOX",
        "filter_width": 1.0,
        "film_exposure": 1.0,
        "time_limit": 0.0,
    }


def _eevee_settings(samples: int) -> dict[str, Any]:
    return {
        "taa_render_samples": int(samples),
        "use_shadows": True,
        # No clamping of indirect light (EEVEE's default clamps it at 10).
        "clamp_surface_direct": 0.0,
        "clamp_surface_indirect": 0.0,
        # Screen-space ray tracing stays at its default (off): the paper's EEVEE had
        # no ray tracing either. Pass settings={"use_raytracing": True} to measure it.
        "use_raytracing": False,
    }


def build_job(scene: Scene, *, engine: str, samples: int, seed: int, folder: Path,
              materials: str = "cycles", settings: Mapping[str, Any] | None = None, warmup: bool = False,
              threads: int = 0, ladder: Sequence[int] = (), distribution: str | None = None,
              gltf_import: bool = False) -> dict[str, Any]:
    """Write the job for one render into ``folder`` and return its ``job.json`` content.

    ``materials``: ``"cycles"`` (the mapping in the module notes) or
    ``"diffuse"`` (Lambert only, reflectance = base colour: the same Principled
    BSDF with metallic 0 and ``Specular IOR Level`` 0, which removes the specular
    layer; the counterpart of the reference's ``diffuse`` mode, for closed forms).

    ``settings`` overrides attributes of ``scene.cycles`` or ``scene.eevee`` by
    name (recorded in the metadata). ``warmup`` renders one sample first
    (shader compilation, buffers) and leaves it out of the timed render.
    ``ladder``: sample counts below ``samples`` to render first as checkpoints.
    ``distribution``: the Principled BSDF's distribution for every material
    (``"multi_ggx"`` or ``"ggx"``); None keeps each material's own.
    """
    eng = engine_id(engine)
    if materials not in SUPPORTED_MATERIALS:
        raise ValueError(f"materials: expected one of {', '.join(SUPPORTED_MATERIALS)}, got {materials!r}")
    if distribution is not None and distribution not in DISTRIBUTIONS:
        raise ValueError(f"distribution: expected one of {', '.join(DISTRIBUTIONS)} or None, got {distribution!r}")
    if int(samples) < 1:
        raise ValueError(f"samples: expected a positive integer, got {samples}")
    ladder = sorted({int(n) for n in ladder})
    if ladder and (ladder[0] < 1 or ladder[-1] >= int(samples)):
        raise ValueError(f"ladder: expected sample counts in [1, {int(samples) - 1}], got {ladder}")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    cam = scene.camera
    near, far = clip_range(scene)

    arrays: dict[str, np.ndarray] = {}
    meshes = []
    imports: dict[str, dict] = {}
    # COLOR_0 on every mesh once one has it (white where a mesh has none): every material multiplies by it
    colored = any(m.has_vertex_colors for m in scene.meshes)
    for k, mesh in enumerate(scene.meshes):
        if gltf_import and mesh.shape == "gltf" and mesh.file is not None:
            # the file as Blender's own importer reads it, placed by the include's transform
            xf = np.asarray(mesh.params["include_matrix"], dtype=np.float64)
            imports.setdefault(f"{mesh.file}|{xf.tobytes().hex()}", {"file": str(mesh.file), "matrix": xf.tolist()})
            continue
        tri = mesh.triangles()
        uv = np.array(tri.uvs, dtype=np.float32, copy=True)
        uv[:, 1] = 1.0 - uv[:, 1]  # Mitsuba's v runs down the image, Blender's up
        arrays[f"m{k}_positions"] = np.asarray(tri.positions, dtype=np.float32)
        arrays[f"m{k}_normals"] = np.asarray(tri.normals, dtype=np.float32)
        arrays[f"m{k}_uvs"] = uv
        if tri.uvs1 is not None:  # TEXCOORD_1, flipped alike
            arrays[f"m{k}_uvs1"] = np.column_stack([tri.uvs1[:, 0], 1.0 - tri.uvs1[:, 1]]).astype(np.float32)
        arrays[f"m{k}_indices"] = np.asarray(tri.indices, dtype=np.int32)
        if colored:
            arrays[f"m{k}_colors"] = (np.asarray(tri.colors, dtype=np.float32) if tri.colors is not None
                                      else np.ones((len(tri.positions), 4), dtype=np.float32))
        meshes.append({"name": mesh.name, "material": mesh.material, "key": f"m{k}"})
    np.savez(folder / "meshes.npz", **arrays)

    lights = []
    for light in scene.lights:
        color, energy = light_power(light)
        lights.append({
            "name": light.name,
            "matrix": light_matrix(light).tolist(),
            "size": [light.size[0], light.size[1]],
            "color": color,
            "energy": energy,
            "radiance": list(light.radiance),
            "backing_offset": LIGHT_BACKING_OFFSET * max(light.size),
            "corners": light.corners().tolist(),
            "normal": list(light.normal),
            # EEVEE culls a light beyond the distance where it falls under light_threshold;
            # a custom distance as large as the scene's far clip turns that off.
            "cutoff_distance": far,
        })

    env = scene.environment
    environment: dict[str, Any] | None = None
    if env is not None and env.constant is not None:
        environment = {"constant": [c * env.intensity for c in env.constant]}
    elif env is not None:
        from compare.scene.environments import environment_image
        from compare.image.exr import write_exr

        write_exr(folder / "environment.exr", blender_environment_map(environment_image(env)),
                  metadata={"renderer": "blender-environment"})
        environment = {"file": "environment.exr", "strength": env.intensity,
                       "lookup": environment_lookup_matrix(env.rotation).tolist()}
    if environment is not None:
        # false: the film is transparent where camera rays hit nothing (the background is left out of the
        # premultiplied RGB, 0 there; the world still lights the scene)
        environment["background"] = bool(env.background)

    engine_settings = _cycles_settings(scene, samples, seed) if eng == "CYCLES" else _eevee_settings(samples)
    overrides = dict(settings or {})
    for key, value in overrides.items():
        if not isinstance(key, str) or not isinstance(value, (bool, int, float, str)):
            raise ValueError(f"settings: expected name → bool/int/float/str, got {key!r}: {value!r}")
    engine_settings.update(overrides)

    job = {
        "version": JOB_VERSION,
        "engine": eng,
        "samples": int(samples),
        "seed": int(seed),
        "threads": int(threads),
        "warmup": bool(warmup),
        "ladder": ladder,
        "resolution": [cam.width, cam.height],
        "camera": {"matrix": camera_matrix(cam).tolist(), "lens": camera_lens_mm(cam),
                   "sensor_height": SENSOR_HEIGHT_MM, "clip_start": near, "clip_end": far},
        "eevee_filter_size": EEVEE_FILTER_SIZE,
        "materials": {name: {**_material(m, materials, distribution), "vertex_colors": colored,
                             "dispersion": dispersion_inputs(m) if engine == "cycles" and materials == "cycles"
                             else None}
                      for name, m in scene.materials.items()},
        "material_model": materials,
        "meshes": meshes,
        # glTF files to import with Blender's glTF importer (their meshes and materials; not their cameras or
        # lights, which the scene has read into "camera", "lights" and "punctual")
        "imports": list(imports.values()),
        "lights": lights,
        # EEVEE culls a light beyond the distance where it falls under light_threshold: as for the
        # area lights, a distance reaching every corner of the scene from the light turns that off.
        "punctual": [{**punctual_light(light), "cutoff_distance": _reach(scene, light.position, far)}
                     for light in scene.punctual],
        "environment": environment,
        "settings": engine_settings,
        "overrides": overrides,
        "output": "render.exr",
        "result": "result.json",
    }
    (folder / "job.json").write_text(json.dumps(job, indent=1))
    return job
