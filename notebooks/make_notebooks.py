"""Write the notebooks of this folder from the cell sources below (kept without outputs).

Run ``python notebooks/make_notebooks.py`` after editing a cell here; the
``.ipynb`` files are generated so that their diffs stay readable in review.
Every notebook reads its image size and budgets from environment variables,
so the test suite can execute it at a tiny size (tests/test_notebooks.py).
"""

from __future__ import annotations

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

HERE = Path(__file__).resolve().parent

SETUP = '''import os
from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt

# Sizes and budgets: small defaults for a laptop; the test suite sets tiny ones.
W, H = (int(x) for x in os.environ.get("COMPARE_NB_SIZE", "320x240").split("x"))
FRAMES = int(os.environ.get("COMPARE_NB_FRAMES", "128"))
SPP = int(os.environ.get("COMPARE_NB_SPP", "256"))
ROOT = Path.cwd() if (Path.cwd() / "scenes").is_dir() else Path.cwd().parent
print(f"{W}x{H}, {FRAMES} frames, {SPP} spp")'''

QUICKSTART = [
    new_markdown_cell("# Quick start: render, compare, plot error against time\n\n"
                      "Render the Cornell box with the path-traced reference and the progressive rasterizer, "
                      "measure the rasterizer's error at every checkpoint and plot it against run time."),
    new_code_cell(SETUP),
    new_code_cell('''from compare.scene import load_scene

scene = load_scene(ROOT / "scenes" / "cornell.toml").with_resolution(W, H)
print(scene.name, "needs:", scene.features().names())
print("left out:", scene.features().omitted())'''),
    new_markdown_cell("## The reference: an spp ladder\n\nIndependent passes of doubling size give checkpoints "
                      "at 1, 2, 4, … spp with their cumulative seconds. Passes are cached by content."),
    new_code_cell('''from compare.reference import ReferenceRenderer

ref = ReferenceRenderer(scene, progress=False)
ladder = ref.ladder(SPP, seed=1)
truth = ref.render(SPP, seed=0).image  # an independent ground truth for the ladder's own curve
[(c.spp, round(c.seconds, 3)) for c in ladder]'''),
    new_markdown_cell("## The progressive rasterizer\n\nCheckpoints at frames 1, 2, 4, …; frame 1 is the cheap "
                      "preview."),
    new_code_cell('''from compare.progressive import render_progressive

steps = [2 ** k for k in range(FRAMES.bit_length()) if 2 ** k <= FRAMES]
prog = render_progressive(scene, frames=FRAMES, checkpoints=steps)
print(f"{FRAMES} frames in {prog.seconds:.3f} s, frame 1 {prog.frame_seconds[0] * 1e3:.2f} ms")'''),
    new_code_cell('''from compare.metrics import compare_images

ref_err = [compare_images(truth, c.image, flip_hdr=False) for c in ladder]
prog_err = [compare_images(truth, c.image, flip_hdr=False) for c in prog.checkpoints]
fig, axes = plt.subplots(1, 2, figsize=(10, 4))
for ax, key, label in ((axes[0], "flip", "FLIP"), (axes[1], "relmse", "relMSE")):
    ax.loglog([c.seconds for c in ladder], [e[key] for e in ref_err], "o-", label="Mitsuba")
    ax.loglog([c.seconds for c in prog.checkpoints], [e[key] for e in prog_err], "s-", label="progressive")
    ax.set_xlabel("seconds"); ax.set_ylabel(label); ax.legend(); ax.grid(True, which="both", alpha=.3)
fig.tight_layout()'''),
    new_code_cell('''from compare.tonemap import to_ldr

fig, axes = plt.subplots(1, 2, figsize=(10, 4))
for ax, img, title in ((axes[0], truth, f"reference {SPP} spp"), (axes[1], prog.image, f"progressive {FRAMES} frames")):
    ax.imshow(to_ldr(img)); ax.set_title(title); ax.axis("off")
assert np.isfinite(prog.image).all() and prog_err[-1]["flip"] <= prog_err[0]["flip"]'''),
]


def write(name: str, cells: list) -> None:
    nb = new_notebook(cells=cells, metadata={"kernelspec": {"name": "python3", "display_name": "Python 3",
                                                            "language": "python"}})
    nbformat.validate(nb)
    (HERE / name).write_text(nbformat.writes(nb) + "\n")


NOTEBOOKS = {"quickstart.ipynb": QUICKSTART}

if __name__ == "__main__":
    for name, cells in NOTEBOOKS.items():
        write(name, cells)
        print("wrote", HERE / name)
