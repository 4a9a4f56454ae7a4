"""Tabulate the albedo of the reference's rough glass (``rough_glass`` without compensation: Mitsuba's
``roughdielectric`` with height-correlated masking) on Cycles' glass grids (``compare/mitsuba/glass_energy.npz``,
served by :mod:`compare.mitsuba.glass`): ``python -m tools.fit_glass``.

``E[z, mu, r]``: the mean sample weight (importance transport: no radiance scaling at refraction), reflection
and transmission, for a view at cosine ``mu`` (grid point j at j/15), roughness ``r`` (i/15, alpha = r²) and
relative IOR ``ior_from_F0(z⁴)`` (k/15) seen from outside; ``_inv``: the same IOR seen from inside.
``E_avg[z, r]``: ``2 ∫ mu E(mu) dmu``. What Cycles' ``cycles_precompute`` tabulates for its own glass.
"""

from __future__ import annotations

import argparse

import numpy as np

SIZE = 16


def _ior(z: float) -> float:
    f0 = min(max(z, 1e-3) ** 4, 0.99)
    s = np.sqrt(f0)
    return float((1.0 + s) / (1.0 - s))


def glass_tables(samples: int = 1 << 17, seed: int = 0) -> dict[str, np.ndarray]:
    """The four tables, ``samples`` visible-normal samples per cell (and 16 × that for each E_avg)."""
    from compare.mitsuba.glass import PLUGIN_NAME, register

    mi = register("llvm_ad_rgb")
    import drjit as dr

    ctx = mi.BSDFContext(mi.TransportMode.Importance)
    out = {k: np.zeros((SIZE, SIZE, SIZE)) for k in ("ggx_glass_E", "ggx_glass_inv_E")}
    out.update({k: np.zeros((SIZE, SIZE)) for k in ("ggx_glass_Eavg", "ggx_glass_inv_Eavg")})
    grid = np.arange(SIZE) / (SIZE - 1)
    count = SIZE * samples
    for k, z in enumerate(grid):
        ior = _ior(z)
        for i, r in enumerate(grid):
            rough = max(r, 1e-2)
            bsdf = mi.load_dict({"type": PLUGIN_NAME, "roughness": rough, "ior": ior, "bsdf": {
                "type": "roughdielectric", "distribution": "ggx", "alpha": rough ** 2, "int_ior": ior,
                "ext_ior": 1.0}})
            for inside, name in ((False, "ggx_glass"), (True, "ggx_glass_inv")):
                sampler = mi.load_dict({"type": "independent"})
                sampler.seed(seed + 7919 * (k * SIZE + i) + inside, count)
                # E on the mu grid: samples per grid point, the points one after another
                mu = np.repeat(np.clip(grid, 1e-4, 1.0), samples)
                # E_avg: uniform mu, weighted by 2 mu
                u = np.asarray(sampler.next_1d())
                for mus, store in ((mu, "E"), (np.maximum(u, 1e-4), "Eavg")):
                    si = dr.zeros(mi.SurfaceInteraction3f, count)
                    zc = -mus if inside else mus
                    si.wi = mi.Vector3f(mi.Float(np.sqrt(1.0 - mus * mus)), mi.Float(np.zeros(count)), mi.Float(zc))
                    _, w = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d())
                    w = np.asarray(w)
                    w = (w[0] if w.shape[0] == 3 else w[:, 0]).astype(np.float64)
                    if store == "E":
                        out[f"{name}_E"][k, :, i] = w.reshape(SIZE, samples).mean(axis=1)
                    else:
                        out[f"{name}_Eavg"][k, i] = float(np.mean(2.0 * mus * w))
    return out


def main(argv: list[str] | None = None) -> int:
    """Write the tables next to compare/mitsuba/glass.py."""
    from compare.mitsuba.glass import TABLE_PATH

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=1 << 17)
    args = parser.parse_args(argv)
    tables = glass_tables(args.samples)
    tmp = TABLE_PATH.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, **{k: v.astype(np.float32) for k, v in tables.items()})
    tmp.replace(TABLE_PATH)
    print(f"wrote {TABLE_PATH} ({args.samples} samples per cell)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
