"""Recompute Cycles' ``ggx_gen_schlick_ior_s`` table (``compare/mitsuba/principled_table.npz``, served by
:mod:`compare.mitsuba.principled`): ``python -m tools.fit_principled``."""

from __future__ import annotations

import argparse

import numpy as np


def main(argv: list[str] | None = None) -> int:
    """Write the table; ``--samples`` visible normals per axis and cell (default 128: 16384 per cell)."""
    from compare.mitsuba.principled import TABLE_PATH, layer_table_3d

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=128)
    args = parser.parse_args(argv)
    table = layer_table_3d(args.samples)
    tmp = TABLE_PATH.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, ggx_gen_schlick_ior_s=table.astype(np.float32))
    tmp.replace(TABLE_PATH)
    print(f"wrote {TABLE_PATH} ({table.shape}, {args.samples}^2 samples per cell)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
