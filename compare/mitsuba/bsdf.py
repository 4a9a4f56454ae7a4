"""The shared glTF 2.0 BRDF as a Mitsuba 3 BSDF plugin (``gltf_pbr``).

Same model, clamps and constants as :mod:`compare.brdf` (read its docstring),
written with Dr.Jit so that it runs in JIT variants (``llvm_ad_rgb``,
``cuda_ad_rgb``) and in ``scalar_rgb``. Usage::

    from compare.mitsuba.bsdf import register
    mi = register()                      # the active variant, or the best one
    bsdf = mi.load_dict({"type": "gltf_pbr", "base_color": {"type": "rgb", "value": [0.8, 0.1, 0.1]},
                         "metallic": 0.0, "roughness": 0.5})

Properties (each a float/rgb or a nested texture; defaults are glTF's):

``base_color``  linear base colour, default 1.0
``metallic``    default 1.0
``roughness``   perceptual roughness, default 1.0
``flavour``     string, ``"gltf"`` (default) or ``"cycles"``
``distribution`` string, flavour ``"cycles"`` only: ``"multi_ggx"`` (default, Blender's
                Multiscatter GGX) or ``"ggx"`` (single scattering)
``specular_f0``, ``specular_weight``  flavour ``"gltf"`` only: glTF's ior and specular extensions,
                the dielectric's F0 (rgb) and weight (:func:`compare.brdf.dielectric_specular`);
                without them the core model (F0 = 0.04) runs its own code.
``ior``, ``specular_ior_level``, ``specular_tint``  flavour ``"cycles"`` only: Blender's
                Principled v2 inputs of those names (float >= 1; float or texture, default 0.5;
                rgb or texture, default white), :func:`compare.mitsuba.principled.specular_ior`.

Flavours. ``"gltf"`` is the shared BRDF of :mod:`compare.brdf`, the same
definition as the rasterizer's GLSL. ``"cycles"`` is Blender's Principled BSDF
v2 as :mod:`compare.blender.export` configures it, the model of
:mod:`compare.mitsuba.principled` (read its docstring): the same GGX D and
height-correlated Smith V, but the exact dielectric Fresnel curve at the
adjusted IOR, remapped to the tinted F0, in place of Schlick with F0 = 0.04
(metals: Cycles' F82-tint, Schlick when the tint is white), and the Lambert lobe weighted by the view-only
``(1 - m)(1 - max_rgb E_s(r, cos_i))`` (Cycles' albedo scaling under the specular layer,
``E_s`` read from :data:`compare.mitsuba.principled.LAYER_S_TABLE_3D`, held in a
Dr.Jit ``Texture3f`` with Cycles' grid and trilinear interpolation) in place of
the per-direction ``(1 - m)(1 - F_d(v.h))``; with ``distribution = "multi_ggx"``
each specular lobe times Multiscatter GGX's view-dependent energy compensation
and the diffuse's layering albedo times its factor
(:mod:`compare.brdf.multiscatter`, tables ``ggx_E`` and ``ggx_Eavg`` as
Dr.Jit textures on Cycles' grid). The ``"gltf"`` flavour traces
exactly the code it always has, so its results are bit-identical to the
plugin without the option.

Conventions (Mitsuba's): directions in the local shading frame (z = normal),
``si.wi`` towards the viewer; ``eval`` returns ``f * cos(theta_o)``. One-sided,
like Mitsuba's ``diffuse`` and ``roughconductor``: zero when ``wi`` or ``wo`` is
below the horizon. Components: 0 = diffuse (``DiffuseReflection``), 1 = specular
(``GlossyReflection``); a ``BSDFContext`` may select either.

Sampling: with probability ``p_spec`` (:func:`compare.brdf.specular_sampling_probability`:
the Fresnel-weighted specular versus the diffuse albedo estimate at
``cos(theta_i)``, floored at 0.1 while a diffuse lobe exists; the ``cycles``
flavour uses its own Fresnel and diffuse weight in the same estimate,
:func:`compare.mitsuba.principled.specular_sampling_probability`) a GGX visible
normal is drawn (Dupuy & Benyoub 2023, spherical caps; the distribution of Heitz
2018) and ``wi`` reflected about it; otherwise a cosine-weighted direction.
``pdf`` is the mixture ``p_spec pdf_spec + (1 - p_spec) cos/pi`` whichever lobe
produced the direction (one-sample MIS), and ``sample``'s weight is
``eval / pdf`` of the returned direction.

Registration is per variant (``mi.register_bsdf`` registers with the variant
active at the call); :func:`register` is idempotent per variant. The class,
``GltfPbrBSDF`` of :mod:`compare.mitsuba.plugins.bsdf`, subclasses the classes
of that variant (:mod:`compare.mitsuba.plugins`), so an instance keeps working
after ``mi.set_variant`` switches to another variant.
"""

from __future__ import annotations

from compare.mitsuba import principled

__all__ = ["FLAVOURS", "PLUGIN_NAME", "evaluate", "register", "registered_variants"]

#: Name under which the plugin is registered (``{"type": PLUGIN_NAME, ...}``).
PLUGIN_NAME = "gltf_pbr"
#: Values of the ``flavour`` property: the shared glTF BRDF, Blender's Principled BSDF v2.
FLAVOURS = principled.FLAVOURS
#: Properties of flavour ``cycles`` only: Blender's Principled BSDF v2 inputs of the same names.
CYCLES_INPUTS = principled.CYCLES_INPUTS


def registered_variants() -> tuple[str, ...]:
    """Variants in which :data:`PLUGIN_NAME` has been registered by this process."""
    from compare.mitsuba.plugins import registered_variants  # noqa: PLC0415

    return registered_variants(PLUGIN_NAME)


def register(variant: str | None = None):
    """Register ``gltf_pbr`` with Mitsuba for a variant and return the ``mitsuba`` module.

    Parameters
    ----------
    variant : str, optional
        Variant to register with (and make active). Default: the variant that
        is active now, or, when Mitsuba has not been loaded yet, the one
        :func:`compare.mitsuba.backend.load_mitsuba` picks.

    Returns
    -------
    module
        ``mitsuba``, with the variant active. Calling again is cheap and does
        not register twice.
    """
    from compare.mitsuba.backend import load_active_mitsuba  # noqa: PLC0415 - Mitsuba is loaded lazily

    load_active_mitsuba(variant)  # first: the class subclasses the classes of the variant set
    from compare.mitsuba.plugins import bsdf as classes, register_plugin  # noqa: PLC0415

    return register_plugin(PLUGIN_NAME, classes, "GltfPbrBSDF")


def evaluate(wi, wo, base_color, metallic, roughness, *, variant: str | None = None, flavour: str = "gltf",
             distribution: str | None = None, dielectric=None, principled_inputs: dict | None = None,
             extra: dict | None = None):
    """Evaluate the plugin's ``eval_pdf`` for per-direction materials; numpy in, numpy out.

    The materials vary per row: they are passed as N x 1 ``bitmap`` textures
    (nearest filtering, raw values) and each row's ``si.uv`` points at its texel,
    so a JIT variant evaluates all rows in one call. ``scalar_rgb`` loops.

    Parameters
    ----------
    wi, wo : array_like, shape (N, 3)
        Local-frame directions (z = normal); ``wi`` towards the viewer.
    base_color : array_like, shape (N, 3)
    metallic, roughness : array_like, shape (N,)
    variant : str, optional
        Passed to :func:`register`.
    flavour : str
        The plugin's ``flavour`` (:data:`FLAVOURS`).
    distribution : str, optional
        The plugin's ``distribution`` (flavour ``cycles``); None leaves it unset (the default).
    dielectric : (F0, weight), optional
        glTF's ior and specular extensions (:func:`compare.brdf.dielectric_specular`) as the plugin's
        ``specular_f0`` and ``specular_weight``.
    principled_inputs : dict, optional
        Flavour ``cycles``: ``ior`` (float), ``specular_ior_level`` (per row, shape (N,)) and
        ``specular_tint`` (per row, shape (N, 3)), :data:`CYCLES_INPUTS`.
    extra : dict, optional
        Other properties of the plugin: a number as it is, an array of N rows (shape (N,) or (N, k)) as a
        per-row texture (e.g. ``anisotropy_map``, ``iridescence``).

    Returns
    -------
    value : ndarray, shape (N, 3)
        ``f * cos(theta_o)`` as Mitsuba returns it (float32 values, as float64).
    pdf : ndarray, shape (N,)
    """
    import numpy as np  # noqa: PLC0415

    mi = register(variant)
    wi = np.asarray(wi, dtype=np.float32).reshape(-1, 3)
    wo = np.asarray(wo, dtype=np.float32).reshape(-1, 3)
    props = _row_material(mi, len(wi), base_color, metallic, roughness, flavour=flavour, distribution=distribution,
                          dielectric=dielectric, principled_inputs=principled_inputs)
    for key, value in (extra or {}).items():
        rows = np.asarray(value, dtype=np.float32)
        props[key] = float(value) if rows.ndim == 0 else _row_bitmap(mi, rows.reshape(len(wi), -1))
    return _eval_pdf_rows(mi, mi.load_dict(props), wi, wo)


def _row_material(mi, count, base_color, metallic, roughness, *, flavour, distribution, dielectric,
                  principled_inputs) -> dict:
    """The plugin's properties for :func:`evaluate`: each per-row input an N x 1 ``bitmap`` (row i at
    u = (i + 0.5) / N)."""
    import numpy as np  # noqa: PLC0415

    base = np.broadcast_to(np.asarray(base_color, dtype=np.float32), (count, 3))
    met = np.broadcast_to(np.asarray(metallic, dtype=np.float32), (count,))
    rough = np.broadcast_to(np.asarray(roughness, dtype=np.float32), (count,))

    def bitmap(data):
        return _row_bitmap(mi, data.reshape(count, -1))

    props = {"type": PLUGIN_NAME, "base_color": bitmap(base), "flavour": flavour,
             "metallic": bitmap(met), "roughness": bitmap(rough)}
    if distribution is not None:
        props["distribution"] = distribution
    if dielectric is not None:  # (F0, weight) of compare.brdf.dielectric_specular
        props["specular_f0"] = {"type": "rgb", "value": [float(x) for x in np.broadcast_to(dielectric[0], 3)]}
        props["specular_weight"] = float(dielectric[1])
    for key, value in (principled_inputs or {}).items():
        if key == "ior":
            props[key] = float(value)
        else:
            props[key] = bitmap(np.broadcast_to(np.asarray(value, dtype=np.float32),
                                                (count, 3) if key == "specular_tint" else (count,)))
    return props


def _row_bitmap(mi, rows) -> dict:
    """An N x 1 ``bitmap`` of N rows of values (nearest, raw): row i at u = (i + 0.5) / N."""
    import numpy as np  # noqa: PLC0415

    return {"type": "bitmap", "data": mi.TensorXf(np.ascontiguousarray(rows.reshape(1, len(rows), -1))),
            "raw": True, "filter_type": "nearest", "wrap_mode": "clamp"}


def _eval_pdf_rows(mi, bsdf, wi, wo):
    """(value, pdf) of ``bsdf.eval_pdf`` for each row of ``wi``, ``wo`` (float32), row i at its texel."""
    import drjit as dr  # noqa: PLC0415
    import numpy as np  # noqa: PLC0415

    count = len(wi)
    ctx = mi.BSDFContext()
    u = (np.arange(count, dtype=np.float64) + 0.5) / count
    if dr.is_jit_v(mi.Float):
        si = dr.zeros(mi.SurfaceInteraction3f, count)
        si.wi = mi.Vector3f(wi.T)
        si.uv = mi.Point2f(mi.Float(u), mi.Float(np.full(count, 0.5)))
        value, pdf = bsdf.eval_pdf(ctx, si, mi.Vector3f(wo.T))
        return np.array(value, dtype=np.float64).T.copy(), np.array(pdf, dtype=np.float64)
    values = np.zeros((count, 3))
    pdfs = np.zeros(count)
    si = dr.zeros(mi.SurfaceInteraction3f)
    for i in range(count):
        si.wi = mi.Vector3f(*map(float, wi[i]))
        si.uv = mi.Point2f(float(u[i]), 0.5)
        value, pdf = bsdf.eval_pdf(ctx, si, mi.Vector3f(*map(float, wo[i])))
        values[i] = [value[0], value[1], value[2]]
        pdfs[i] = pdf
    return values, pdfs
