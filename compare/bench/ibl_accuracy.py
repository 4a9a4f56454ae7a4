"""Accuracy of the environment approximations, as benchmark tables.

``python -m compare.bench.ibl_accuracy [--quick] [--json out.json]`` prints five tables:

``split_sum``
    The rasterizer's environment light on a sphere — frame 1 (split-sum specular
    + diffuse irradiance, no occlusion) — against a brute-force Monte Carlo of
    the same ``∫ L_env f cos`` for the shared BRDF at the very normals, positions
    and materials of the rasterizer's G-buffer (:mod:`compare.ibl.groundtruth`),
    per environment, material and roughness, for each storage variant: float
    cube atlas + convolved irradiance cube (the default), RGBM, octahedral, SH9.
    Columns: ``rel_l1`` = Σ|ras − MC| / Σ MC over the sphere's pixels, ``bias`` =
    Σ(ras − MC) / Σ MC, ``mc_noise`` = Σ (MC standard error) / Σ MC, the part of
    ``rel_l1`` that is the brute force's own noise.
``irradiance``
    SH9 and the convolved cube against the exact irradiance (a sum over every
    texel of a 64² source cube) at 2000 random normals: mean and max relative
    error.
``encodings``
    Round trip of the environment map through RGBM (Karis), RGBM sqrt/range 7
    and RGBE (:func:`compare.image.encodings.roundtrip_stats`).
``atlases``
    The prefiltered chain as the shader reads it from the float cube atlas and
    the octahedral atlas against the prefilter evaluated at 2000 random
    directions themselves (``*_vs_exact``: resolution and interpolation, plus
    the prefilter's own sampling noise from one direction to the next), and the
    RGBM cube atlas and the octahedral atlas against the float cube atlas
    (``rgbm_vs_float``, ``octahedral_vs_cube``: what the storage alone costs),
    per level (relative L1); ``rgbm_energy_lost`` is the share of the level's
    power (texels × solid angle) that RGBM's maximum of 49 clips.
``timings``
    Seconds of every preprocessing stage at the rasterizer's defaults
    (128² faces, 9 levels, 512 samples, octahedral too), computed without the
    cache, and of the split-sum LUT.

The environments are the procedural sky (with its 3.6e4 sun) and studio and,
when the ``bpy`` wheel is installed, Blender's ``interior`` and ``courtyard``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from compare.scene.environments import blender_studio_lights, environment_image
from compare.scene.loader import parse_scene
from compare.ibl import DEFAULT_LEVELS, DEFAULT_SAMPLES, DEFAULT_SIZE, preprocess, split_sum
from compare.ibl.atlas import sample_levels
from compare.ibl.cubemap import sample_faces
from compare.ibl.groundtruth import reflected_radiance
from compare.ibl.irradiance import irradiance_at, sh9_irradiance
from compare.ibl.lut import split_sum_lut
from compare.ibl.prefilter import source_chain

__all__ = ["accuracy_tables", "atlas_table", "encoding_table", "format_tables", "irradiance_table", "split_sum_table",
           "timing_table"]

#: Rasterizer variants measured: name → Rasterizer options.
VARIANTS = {
    "float+cube": {},
    "rgbm": {"env_format": "rgbm"},
    "octahedral": {"env_format": "octahedral"},
    "sh9": {"env_diffuse": "sh9"},
}
MATERIALS = {
    "metal": {"base_color": [0.9, 0.9, 0.9], "metallic": 1.0},
    "dielectric": {"base_color": [0.8, 0.8, 0.8], "metallic": 0.0},
}


def environments() -> dict[str, dict]:
    """Environment specs (scene-file form) measured by default."""
    envs = {"sky": {"procedural": "sky"}, "studio": {"procedural": "studio"}}
    lights = blender_studio_lights()
    for name in ("interior", "courtyard"):
        if name in lights:
            envs[f"blender:{name}"] = {"blender": name}
    return envs


def _sphere_scene(env: dict, material: dict, size: int):
    return parse_scene({
        "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "fov": 32, "resolution": [size, size]},
        "materials": {"m": material},
        "meshes": [{"shape": "sphere", "radius": 1.0, "material": "m", "segments": 192, "rings": 96}],
        "environment": env,
        "render": {"max_depth": 2},
    }, Path("accuracy-sphere.toml"))


def _read(texture) -> np.ndarray:
    w, h = texture.size
    return np.frombuffer(texture.read(), dtype=np.float32).reshape(h, w, 4)[::-1]


def split_sum_table(envs: dict[str, dict] | None = None, *, roughness=(0.0, 0.1, 0.25, 0.5, 0.75, 1.0),
                    materials=("metal", "dielectric"), variants=tuple(VARIANTS), size: int = 48,
                    stride: int = 2, samples: int = 1024, ibl_size: int = DEFAULT_SIZE,
                    ibl_samples: int = DEFAULT_SAMPLES, ctx=None) -> list[dict]:
    """Rasterizer frame 1 against brute-force MC on a sphere; see the module notes."""
    from compare.progressive.rasterizer import Rasterizer
    from compare.progressive.gl.context import create_context

    envs = environments() if envs is None else envs
    own = ctx is None
    ctx = create_context() if own else ctx
    rows = []
    try:
        for env_name, env in envs.items():
            for mat_name in materials:
                for r in roughness:
                    scene = _sphere_scene(env, {**MATERIALS[mat_name], "roughness": float(r)}, size)
                    truth = None
                    for variant in variants:
                        # The G-buffer path for frame 0: its targets are read back below.
                        with Rasterizer(scene, frames=1, ctx=ctx, d_occ=0.0, ibl_size=ibl_size,
                                                 ibl_samples=ibl_samples, first_frame="gbuffer",
                                                 **VARIANTS[variant]) as rend:
                            rend.render_frame()
                            image = rend.image()
                            if truth is None:
                                pos = _read(rend.gbuffer["position"])
                                nrm = _read(rend.gbuffer["normal"])
                                mat = _read(rend.gbuffer["material"])
                                cam = np.asarray(scene.camera.position)
                                view = cam - pos[..., :3]
                                view /= np.maximum(np.linalg.norm(view, axis=-1, keepdims=True), 1e-12)
                                n = nrm[..., :3] / np.maximum(np.linalg.norm(nrm[..., :3], axis=-1,
                                                                             keepdims=True), 1e-12)
                                sel = (pos[..., 3] > 0.5) & (np.sum(n * view, -1) > 0.05)
                                keep = np.zeros_like(sel)
                                keep[::stride, ::stride] = True
                                sel &= keep
                                gt, se = reflected_radiance(
                                    environment_image(scene.environment), n[sel], view[sel], mat[sel][:, :3],
                                    mat[sel][:, 3], nrm[sel][:, 3], samples=samples,
                                    rotation=scene.environment.rotation)
                                gt *= scene.environment.intensity
                                se *= scene.environment.intensity
                                truth = (sel, gt, se)
                        sel, gt, se = truth
                        ras = image[sel].astype(np.float64)
                        total = gt.sum()
                        rows.append({
                            "environment": env_name, "material": mat_name, "roughness": float(r),
                            "variant": variant, "pixels": int(sel.sum()),
                            "rel_l1": float(np.abs(ras - gt).sum() / total),
                            "bias": float((ras - gt).sum() / total),
                            "mc_noise": float(se.sum() / total),
                        })
    finally:
        if own:
            ctx.release()
    return rows


def irradiance_table(envs: dict[str, dict] | None = None, *, ibl_size: int = DEFAULT_SIZE,
                     normals: int = 2000) -> list[dict]:
    """SH9 and the convolved irradiance cube against the exact irradiance of a 64² source."""
    envs = environments() if envs is None else envs
    rows = []
    n = np.random.default_rng(0).normal(size=(normals, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    for env_name, env in envs.items():
        image = environment_image(_sphere_scene(env, MATERIALS["metal"], 8).environment)
        exact = irradiance_at(source_chain(image, 64)[0], n)
        ibl = preprocess(image, size=ibl_size)
        for name, got in (("cube", sample_faces(ibl.irradiance, n)),
                          ("sh9", np.maximum(sh9_irradiance(ibl.sh9, n), 0.0))):
            rel = np.abs(got - exact) / exact
            rows.append({"environment": env_name, "irradiance": name, "mean_rel": float(rel.mean()),
                         "max_rel": float(rel.max()), "rel_l1": float(np.abs(got - exact).sum() / exact.sum())})
    return rows


def encoding_table(envs: dict[str, dict] | None = None) -> list[dict]:
    """Round-trip statistics of each environment map through RGBM, RGBM sqrt/range 7 and RGBE."""
    from compare.image.encodings import roundtrip_stats

    envs = environments() if envs is None else envs
    rows = []
    for env_name, env in envs.items():
        image = environment_image(_sphere_scene(env, MATERIALS["metal"], 8).environment)
        for enc in ("rgbm", "rgbm7sqrt", "rgbe"):
            rows.append({"environment": env_name, "encoding": enc, **roundtrip_stats(enc, image)})
    return rows


def atlas_table(envs: dict[str, dict] | None = None, *, ibl_size: int = DEFAULT_SIZE,
                ibl_samples: int = DEFAULT_SAMPLES, directions: int = 2000) -> list[dict]:
    """Each storage of the prefiltered chain against the exact value and against the float cube, per level.

    The exact value at a direction is :func:`compare.ibl.prefilter.prefilter` evaluated
    there (level 0: the map itself, :func:`compare.scene.equirect.sample_equirect`); the
    storages are read as the shader reads them (:func:`compare.ibl.atlas.sample_levels`):
    float cube atlas, RGBM (sqrt, range 7) cube atlas filtered before decoding, float
    octahedral atlas.
    """
    from compare.image.encodings import RGBM_SQRT7, rgbm_decode, rgbm_encode
    from compare.scene.equirect import sample_equirect
    from compare.ibl.cubemap import texel_solid_angles
    from compare.ibl.prefilter import prefilter

    envs = environments() if envs is None else envs
    rows = []
    d = np.random.default_rng(1).normal(size=(directions, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for env_name, env in envs.items():
        image = environment_image(_sphere_scene(env, MATERIALS["metal"], 8).environment)
        ibl = preprocess(image, size=ibl_size, samples=ibl_samples, octahedral=True)
        chain = source_chain(image, ibl_size)
        for level in range(len(ibl.radiance)):
            exact = (sample_equirect(image, d) if level == 0
                     else prefilter(chain, d, float(ibl.roughness[level]), ibl_samples))
            cube = sample_levels(ibl.radiance, d, level)
            rgbm = sample_levels(ibl.radiance, d, level, rgbm=True)
            octa = sample_levels(ibl.octahedral, d, level, projection="octahedral")

            def rel(a, b):
                return float(np.abs(a - b).sum() / b.sum())

            faces = ibl.radiance[level][:, 1:-1, 1:-1].astype(np.float64)
            omega = texel_solid_angles(faces.shape[1])[None, :, :, None]
            decoded = rgbm_decode(rgbm_encode(faces, **RGBM_SQRT7), **RGBM_SQRT7)
            rows.append({"environment": env_name, "level": level, "roughness": float(ibl.roughness[level]),
                         "size": int(faces.shape[1]),
                         "cube_vs_exact": rel(cube, exact), "octahedral_vs_exact": rel(octa, exact),
                         "rgbm_vs_float": rel(rgbm, cube), "octahedral_vs_cube": rel(octa, cube),
                         "rgbm_energy_lost": float(1.0 - (decoded * omega).sum() / (faces * omega).sum())})
    return rows


def timing_table(envs: dict[str, dict] | None = None) -> list[dict]:
    """Preprocessing seconds at the defaults (no cache), and the LUT's."""
    envs = environments() if envs is None else envs
    rows = []
    for env_name, env in envs.items():
        t0 = time.perf_counter()
        image = environment_image(_sphere_scene(env, MATERIALS["metal"], 8).environment)
        load = time.perf_counter() - t0
        ibl = preprocess(image, size=DEFAULT_SIZE, levels=DEFAULT_LEVELS, samples=DEFAULT_SAMPLES,
                         octahedral=True, cache_dir=False)
        rows.append({"environment": env_name, "map": f"{image.shape[1]}x{image.shape[0]}", "load": load,
                     **{k: float(v) for k, v in ibl.timings.items()}})
    t0 = time.perf_counter()
    split_sum_lut()
    rows.append({"environment": "(any)", "map": "-", "lut": time.perf_counter() - t0})
    return rows


def accuracy_tables(*, quick: bool = False, ctx=None) -> dict[str, list[dict]]:
    """All five tables; ``quick`` uses fewer roughnesses, samples and smaller preprocessing."""
    envs = environments()
    if quick:
        return {
            "split_sum": split_sum_table(envs, roughness=(0.0, 0.5, 1.0), size=32, samples=256, ibl_size=64,
                                         ibl_samples=128, ctx=ctx),
            "irradiance": irradiance_table(envs, ibl_size=64, normals=500),
            "encodings": encoding_table(envs),
            "atlases": atlas_table(envs, ibl_size=32, ibl_samples=128, directions=500),
            "timings": [],
        }
    split_sum(cache_dir=None)
    return {"split_sum": split_sum_table(envs, ctx=ctx), "irradiance": irradiance_table(envs),
            "encodings": encoding_table(envs), "atlases": atlas_table(envs), "timings": timing_table(envs)}


def format_tables(tables: dict[str, list[dict]]) -> str:
    """Plain-text tables (one column per key)."""
    out = []
    for name, rows in tables.items():
        if not rows:
            continue
        keys = list(dict.fromkeys(k for r in rows for k in r))
        cells = [[_fmt(r.get(k, "")) for k in keys] for r in rows]
        widths = [max(len(k), *(len(c[i]) for c in cells)) for i, k in enumerate(keys)]
        out.append(f"== {name}")
        out.append("  ".join(k.ljust(w) for k, w in zip(keys, widths)))
        out.extend("  ".join(c.ljust(w) for c, w in zip(row, widths)) for row in cells)
        out.append("")
    return "\n".join(out)


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}" if abs(v) < 1e4 else f"{v:.3e}"
    return str(v)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m compare.bench.ibl_accuracy", description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer roughnesses and samples (a minute or two)")
    parser.add_argument("--json", type=Path, default=None, help="also write the tables as JSON")
    args = parser.parse_args(argv)
    tables = accuracy_tables(quick=args.quick)
    print(format_tables(tables))
    if args.json:
        from compare.util.files import write_text_atomic

        write_text_atomic(args.json, json.dumps(tables, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
