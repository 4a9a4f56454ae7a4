"""Cycles' energy compensation of rough glass in numpy: the tables of ``glass_energy.npz`` and
:func:`energy_scale` (:mod:`compare.mitsuba.glass` describes the model; its plugin class reads the same
tables as Dr.Jit textures).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from compare.brdf.multiscatter import lookup_2d, lookup_3d

__all__ = ["TABLES", "TABLE_PATH", "energy_scale"]

TABLE_PATH = Path(__file__).with_name("glass_energy.npz")


def _load() -> dict[str, np.ndarray]:
    with np.load(TABLE_PATH) as data:
        return {k: data[k].astype(np.float64) for k in ("ggx_glass_E", "ggx_glass_Eavg", "ggx_glass_inv_E",
                                                        "ggx_glass_inv_Eavg")}


#: ``E[z, mu, r]`` and ``E_avg[z, r]`` on Cycles' 16-point grids (z = sqrt((ior - 1)/(ior + 1))), from outside
#: (ior > 1) and from inside (``_inv``: relative IOR 1/ior).
TABLES = _load()


def energy_scale(roughness, cos_i, ior, tint=(1.0, 1.0, 1.0)):
    """Cycles' factor on rough glass, per channel: ``1 + F_ms (1 - E) / E`` (see :mod:`compare.mitsuba.glass`).

    ``cos_i`` < 0 is the view from inside (the ``_inv`` tables); ``ior`` the material's (> 1).
    """
    c = np.asarray(cos_i, dtype=np.float64)
    inside = c < 0.0
    mu = np.abs(c)
    z = np.sqrt(np.abs((ior - 1.0) / (ior + 1.0)))
    r = np.clip(np.asarray(roughness, dtype=np.float64), 0.0, 1.0)
    e = np.where(inside, lookup_3d(TABLES["ggx_glass_inv_E"], r, mu, z), lookup_3d(TABLES["ggx_glass_E"], r, mu, z))
    e_avg = np.where(inside, lookup_2d(TABLES["ggx_glass_inv_Eavg"], r, z), lookup_2d(TABLES["ggx_glass_Eavg"], r, z))
    fss = np.asarray(tint, dtype=np.float64)
    e, e_avg = np.asarray(e)[..., None], np.asarray(e_avg)[..., None]
    f_ms = fss * e_avg / (1.0 - fss * (1.0 - e_avg))
    return 1.0 + f_ms * (1.0 - e) / e
