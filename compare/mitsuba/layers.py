"""Per-effect ground truths: a path tracer that writes each kind of light into its own layer.

The layers (:data:`compare.image.layers.LAYERS`) split the image by where its light comes from, so that a
renderer's error can be attributed to the approximation that causes it::

    image = emission + direct_area + direct_env + direct_punctual + indirect_diffuse + indirect_specular

``emission``
    light reaching the camera straight from an emitter: area lights, emissive
    meshes, the environment seen as background (paths of one segment; not that background where the
    scene hides it, ``background = false``).
``direct_area`` / ``direct_env``
    light of emitting surfaces (area lights, emissive meshes) / of the
    environment, reflected once at the first surface the camera sees (shadowed).
``direct_punctual``
    light of point, spot and directional lights (Mitsuba's delta emitters: a directional light is
    "infinite" too, but its light is here, not in ``direct_env``), reflected once at the first surface.
``indirect_diffuse`` / ``indirect_specular``
    all light that bounced more than once, split by the lobe the path's first
    bounce sampled at that first surface (diffuse, or glossy/specular).

``direct_area_unshadowed`` is not part of the sum: the area lights' direct
light without visibility (emitter sampling at the first surface with no shadow
ray), what a renderer's unshadowed light model (LTC, the preview) converges to.

:class:`LayersIntegrator` is Mitsuba's ``path`` algorithm (emitter sampling and
BSDF sampling combined by the power heuristic, Russian roulette from depth 5),
written in Python with Dr.Jit so that every contribution can be routed to its
layer as it is added. The layers sum to its image exactly (the same float
additions), and its image converges to the one of Mitsuba's ``path``
(``tests/test_reference_layers.py`` checks both against independent renders).
Registered as the integrator ``compare_layers``.

Holes of alpha masks (Mitsuba's ``mask``, a null interaction) count as no
surface here: neither for the layer a contribution goes to nor for
``max_depth`` and Russian roulette, as Cycles keeps its transparent bounces
apart (up to :data:`MAX_HOLES` of them). Mitsuba's ``path`` counts each hole as
a bounce, which darkens what is seen through holes at a small ``max_depth``; so
the reference renders a scene with alpha masks with this integrator
(``layers = false``: the image alone). Without holes it is ``path``.
"""

from __future__ import annotations

import numpy as np

from compare.image.layers import LAYERS
from compare.scene.model import MAX_HOLES

__all__ = ["INTEGRATOR_NAME", "register", "split_layers"]


#: Name under which :class:`LayersIntegrator` is registered.
INTEGRATOR_NAME = "compare_layers"


def register():
    """Register ``compare_layers`` for the active Mitsuba variant (idempotent); returns ``mitsuba``."""
    from compare.mitsuba.backend import register_integrator_once

    return register_integrator_once(INTEGRATOR_NAME, _make_class)


def split_layers(channels: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(image, {layer: image}) of a render's channels (H, W, 3 + 3 · len(LAYERS)), float32."""
    channels = np.asarray(channels, dtype=np.float32)
    want = 3 + 3 * len(LAYERS)
    if channels.ndim != 3 or channels.shape[2] != want:
        raise ValueError(f"expected (H, W, {want}) channels of the layers integrator, got {channels.shape}")
    layers = {name: np.ascontiguousarray(channels[..., 3 + 3 * k: 6 + 3 * k]) for k, name in enumerate(LAYERS)}
    return np.ascontiguousarray(channels[..., :3]), layers


def mis_weight(pdf_a, pdf_b):
    """The power heuristic, Mitsuba's own (the one its Python integrators use)."""
    from mitsuba.python.ad.integrators.common import mis_weight as mitsuba_mis_weight

    return mitsuba_mis_weight(pdf_a, pdf_b)


def infinite(emitter):
    """Whether ``emitter`` (an EmitterPtr) is an environment (or a directional light: see :func:`punctual`)."""
    import mitsuba as mi

    return mi.has_flag(emitter.flags(), mi.EmitterFlags.Infinite)


def punctual(emitter):
    """Whether ``emitter`` (an EmitterPtr) is a point, spot or directional light (a delta in position or
    direction)."""
    import mitsuba as mi

    flags = emitter.flags()
    return mi.has_flag(flags, mi.EmitterFlags.DeltaPosition) | mi.has_flag(flags, mi.EmitterFlags.DeltaDirection)


def _make_class(mi):
    import drjit as dr

    # dr.syntax turns the path's Python loop and branches into Dr.Jit's; it rewrites a module-level
    # function (a closure's cells do not survive the rewrite), so mi and dr travel as arguments.
    trace = dr.syntax(_trace)
    transmittance = dr.syntax(_transmittance)

    class LayersIntegrator(mi.SamplingIntegrator):
        """Mitsuba's path tracer with each contribution routed to its layer (see the module notes)."""

        def __init__(self, props):
            mi.SamplingIntegrator.__init__(self, props)
            self.max_depth = int(props.get("max_depth", -1))
            self.rr_depth = int(props.get("rr_depth", 5))
            if self.max_depth < -1 or self.max_depth == 0:
                raise ValueError(f"{INTEGRATOR_NAME}: max_depth must be -1 or >= 1, got {self.max_depth}")
            self.limit = 2**31 - 1 if self.max_depth == -1 else self.max_depth
            self.layers = bool(props.get("layers", True))
            # Shadow rays through holes only where there are holes: elsewhere Mitsuba's own shadow ray.
            self.holes = bool(props.get("holes", False))
            # False: the environment is not seen where a camera ray hits nothing (through holes either)
            self.background = bool(props.get("background", True))

        def aov_names(self):
            return [f"{name}.{c}" for name in LAYERS for c in "RGB"] if self.layers else []

        def sample(self, scene, sampler, ray, medium=None, active=True):
            L, valid, aovs = trace(mi, dr, self.limit, self.rr_depth, scene, sampler, ray, active,
                                   transmittance if self.holes else None, self.background)
            return L, valid, aovs if self.layers else []

        def to_string(self):
            return f"LayersIntegrator[max_depth = {self.max_depth}, rr_depth = {self.rr_depth}]"

    return LayersIntegrator


def _shadowed_emitter_sample(mi, dr, scene, si, sample, active, transmittance):
    """Emitter sampling at ``si`` with visibility: Mitsuba's shadow ray, or with ``transmittance`` (a scene
    with alpha masks) a shadow ray that passes the masks' holes."""
    if transmittance is None:
        return scene.sample_emitter_direction(si, sample, True, active)
    ds, weight = scene.sample_emitter_direction(si, sample, False, active)
    return ds, weight * transmittance(mi, dr, scene, si, ds.p, active & (ds.pdf != 0.0))


def _transmittance(mi, dr, scene, si, target, active):
    """The fraction of light that travels from ``si`` to ``target``: the product of the null transmission
    (1 − opacity of a mask) of the surfaces in between; 0 at any other surface."""
    tr = mi.Spectrum(1.0)
    ray = si.spawn_ray_to(target)
    active = mi.Bool(active)
    crossed = mi.UInt32(0)
    while dr.hint(active, label="compare_shadow"):
        hit = scene.ray_intersect(ray, mi.RayFlags.All, False, active)
        active &= hit.is_valid()
        tr[active] *= hit.bsdf(ray).eval_null_transmission(hit, active)
        crossed += 1
        tr[active & (crossed > MAX_HOLES)] = 0.0
        active &= (dr.max(tr) > 0.0) & (crossed <= MAX_HOLES)
        ray = hit.spawn_ray_to(target)
    return tr


def _trace(mi, dr, limit, rr_depth, scene, sampler, ray, active, transmittance, background=True):
    """One path (see the module notes): (radiance, valid, the layers' channels); without ``background``, a
    camera ray that meets no surface (holes passed) sees nothing of the environment."""
    hide = mi.Bool(not background)
    ctx = mi.BSDFContext()
    ray = mi.Ray3f(ray)
    depth = mi.UInt32(0)
    L = mi.Spectrum(0.0)
    emission = mi.Spectrum(0.0)
    d_area = mi.Spectrum(0.0)
    d_env = mi.Spectrum(0.0)
    d_punct = mi.Spectrum(0.0)
    i_diff = mi.Spectrum(0.0)
    i_spec = mi.Spectrum(0.0)
    d_unshadowed = mi.Spectrum(0.0)
    beta = mi.Spectrum(1.0)
    eta = mi.Float(1.0)
    first_diffuse = mi.Bool(False)
    active = mi.Bool(active)
    # The last surface that scattered (holes are passed through): the emitter-hit MIS weights need its pdfs.
    prev_si = dr.zeros(mi.SurfaceInteraction3f)
    prev_bsdf_pdf = mi.Float(1.0)
    prev_bsdf_delta = mi.Bool(True)
    # Surfaces met so far, not counting the holes of alpha masks (null interactions): the layer of a
    # contribution, max_depth and Russian roulette are decided by this count.
    bounce = mi.UInt32(0)

    while dr.hint(active, label="compare_layers"):
        si = scene.ray_intersect(ray, ray_flags=mi.RayFlags.All, coherent=(depth == 0))

        # Emitter hit (BSDF sampling), weighted against emitter sampling of the previous vertex.
        ds = mi.DirectionSample3f(scene, si=si, ref=prev_si)
        mis = mis_weight(prev_bsdf_pdf, scene.pdf_emitter_direction(prev_si, ds, ~prev_bsdf_delta))
        le = beta * mis * ds.emitter.eval(si)
        hit_env = infinite(ds.emitter)
        le = dr.select(hide & (bounce == 0) & ~si.is_valid(), 0.0, le)
        if bounce == 0:
            emission += le
        elif bounce == 1:
            if hit_env:
                d_env += le
            else:
                d_area += le
        elif first_diffuse:
            i_diff += le
        else:
            i_spec += le
        L += le

        can_scatter = (bounce + 1 < limit) & si.is_valid()
        bsdf = si.bsdf(ray)

        # Emitter sampling (with visibility), weighted against BSDF sampling.
        active_em = can_scatter & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
        ds_em, em_weight = _shadowed_emitter_sample(mi, dr, scene, si, sampler.next_2d(), active_em, transmittance)
        active_em &= ds_em.pdf != 0.0
        wo = si.to_local(ds_em.d)
        bsdf_val, bsdf_pdf = bsdf.eval_pdf(ctx, si, wo, active_em)
        mis_em = dr.select(ds_em.delta, 1.0, mis_weight(ds_em.pdf, bsdf_pdf))
        lr = dr.select(active_em, beta * mis_em * bsdf_val * em_weight, 0.0)
        em_env = infinite(ds_em.emitter)
        em_punctual = punctual(ds_em.emitter)
        if bounce == 0:
            if em_punctual:
                d_punct += lr
            elif em_env:
                d_env += lr
            else:
                d_area += lr
        elif first_diffuse:
            i_diff += lr
        else:
            i_spec += lr
        L += lr

        # The area lights' direct light without visibility, at the first surface only.
        active_u = can_scatter & (bounce == 0) & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
        ds_u, w_u = scene.sample_emitter_direction(si, sampler.next_2d(), False, active_u)
        active_u &= (ds_u.pdf != 0.0) & ~infinite(ds_u.emitter) & ~ds_u.delta
        val_u = bsdf.eval(ctx, si, si.to_local(ds_u.d), active_u)
        d_unshadowed += dr.select(active_u, val_u * w_u, 0.0)

        # Continue the path by BSDF sampling; through a hole it goes on whatever the bounce count.
        may_pass = si.is_valid() & (depth - bounce < MAX_HOLES)
        bs, bsdf_weight = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d(), may_pass)
        through = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Null)
        active_next = dr.select(through, may_pass, can_scatter)
        if (bounce == 0) & ~through:
            first_diffuse = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Diffuse)
        ray = si.spawn_ray(si.to_world(bs.wo))
        eta *= bs.eta
        beta *= bsdf_weight
        if ~through:
            prev_si = si
            prev_bsdf_pdf = bs.pdf
            prev_bsdf_delta = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)

        beta_max = dr.max(beta)
        active_next &= beta_max != 0.0
        rr_prob = dr.minimum(beta_max * dr.square(eta), 0.95)
        rr_active = (bounce >= rr_depth) & ~through
        beta[rr_active] *= dr.rcp(rr_prob)
        active_next &= ~rr_active | (sampler.next_1d() < rr_prob)
        depth[si.is_valid()] += 1
        bounce[si.is_valid() & ~through] += 1
        active = active_next

    aovs = []
    for layer in (emission, d_area, d_env, d_punct, i_diff, i_spec, d_unshadowed):
        aovs += [layer[0], layer[1], layer[2]]
    return L, mi.Bool(True), aovs

