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
    new_code_cell('''from compare.scene.loader import load_scene

scene = load_scene(ROOT / "scenes" / "cornell.toml").with_resolution(W, H)
print(scene.name, "needs:", scene.features().names())
print("left out:", scene.features().omitted())'''),
    new_markdown_cell("## The reference: an spp ladder\n\nIndependent passes of doubling size give checkpoints "
                      "at 1, 2, 4, … spp with their cumulative seconds. Passes are cached by content."),
    new_code_cell('''from compare.mitsuba.reference import ReferenceRenderer

ref = ReferenceRenderer(scene, progress=False)
ladder = ref.ladder(SPP, seed=1)
truth = ref.render(SPP, seed=0).image  # an independent ground truth for the ladder's own curve
[(c.step, round(c.seconds, 3)) for c in ladder]'''),
    new_markdown_cell("## The progressive rasterizer\n\nCheckpoints at frames 1, 2, 4, …; frame 1 is the cheap "
                      "preview."),
    new_code_cell('''from compare.progressive import render_progressive

steps = [2 ** k for k in range(FRAMES.bit_length()) if 2 ** k <= FRAMES]
prog = render_progressive(scene, frames=FRAMES, checkpoints=steps)
print(f"{FRAMES} frames in {prog.seconds:.3f} s, frame 1 {prog.frame_seconds[0] * 1e3:.2f} ms")'''),
    new_code_cell('''from compare.metrics.images import compare_images

ref_err = [compare_images(truth, c.image, flip_hdr=False) for c in ladder]
prog_err = [compare_images(truth, c.image, flip_hdr=False) for c in prog.checkpoints]
fig, axes = plt.subplots(1, 2, figsize=(10, 4))
for ax, key, label in ((axes[0], "flip", "FLIP"), (axes[1], "relmse", "relMSE")):
    ax.loglog([c.seconds for c in ladder], [e[key] for e in ref_err], "o-", label="Mitsuba")
    ax.loglog([c.seconds for c in prog.checkpoints], [e[key] for e in prog_err], "s-", label="progressive")
    ax.set_xlabel("seconds"); ax.set_ylabel(label); ax.legend(); ax.grid(True, which="both", alpha=.3)
fig.tight_layout()'''),
    new_code_cell('''from compare.image.tonemap import to_ldr

fig, axes = plt.subplots(1, 2, figsize=(10, 4))
for ax, img, title in ((axes[0], truth, f"reference {SPP} spp"), (axes[1], prog.image, f"progressive {FRAMES} frames")):
    ax.imshow(to_ldr(img)); ax.set_title(title); ax.axis("off")
assert np.isfinite(prog.image).all() and prog_err[-1]["flip"] <= prog_err[0]["flip"]'''),
]


ABLATIONS = [
    new_markdown_cell("# Ablations: what each approximation of the technique costs\n\n"
                      "Each cell changes one option of the progressive renderer and measures FLIP and relMSE against "
                      "the path-traced reference: the paper's point-light form against the radiometric area-light "
                      "form, samples per light, the occlusion distance d_occ, SH9 against the irradiance cube, and "
                      "RGBM or octahedral storage against float."),
    new_code_cell(SETUP),
    new_code_cell('''from compare.metrics.images import compare_images
from compare.progressive import render_progressive
from compare.mitsuba.reference import ReferenceRenderer
from compare.scene.loader import load_scene

def measure(scene, truth, **options):
    r = render_progressive(scene, frames=FRAMES, **options)
    m = compare_images(truth, r.image, flip_hdr=False)
    return {"seconds": round(r.seconds, 3), "flip": round(m["flip"], 4), "relmse": round(m["relmse"], 5)}

cornell = load_scene(ROOT / "scenes" / "cornell.toml").with_resolution(W, H)
direct_truth = ReferenceRenderer(cornell, max_depth=2, progress=False).render(SPP).image'''),
    new_markdown_cell("## Area-light model and light samples (Cornell box, against direct light only)"),
    new_code_cell('''rows = {model: measure(cornell, direct_truth, area_model=model) for model in ("radiometric", "paper")}
for n in (1, 4, 16):
    rows[f"radiometric, {n} samples/light"] = measure(cornell, direct_truth, samples_per_light=n)
rows'''),
    new_markdown_cell("## Environment options (car scene: studio environment, glossy paint)"),
    new_code_cell('''car = load_scene(ROOT / "scenes" / "car.toml").with_resolution(W, H)
car_truth = ReferenceRenderer(car, progress=False).render(SPP).image
small = dict(ibl_size=16, ibl_samples=32)  # tiny preprocessing keeps the notebook quick; raise for real numbers
env_rows = {}
for name, opts in {"float, cube": {}, "sh9": {"env_diffuse": "sh9"}, "rgbm": {"env_format": "rgbm"},
                   "octahedral": {"env_format": "octahedral"}, "no occlusion (d_occ 0)": {"d_occ": 0.0},
                   "d_occ 0.5 m": {"d_occ": 0.5}}.items():
    env_rows[name] = measure(car, car_truth, **small, **opts)
env_rows'''),
    new_markdown_cell("## Beyond the paper: irradiance probes, variance shadow maps, a frame budget\n\n"
                      "Probes add the diffuse bounces the technique lacks, so they are measured against the full "
                      "reference; VSM and the frame budget change how direct light converges, so against direct "
                      "light only. The same options are renderer variants of `compare run` "
                      "(`progressive:probes`, `progressive:vsm`, `progressive:budget16`)."),
    new_code_cell('''full_truth = ReferenceRenderer(cornell, progress=False).render(SPP).image
beyond = {
    "no probes (full GI)": measure(cornell, full_truth),
    "probes 4x4x4, 2 bounces (full GI)": measure(cornell, full_truth, indirect="probes", probe_grid=(4, 4, 4)),
    "hard shadows": measure(cornell, direct_truth),
    "VSM": measure(cornell, direct_truth, shadow_filter="vsm"),
    "frame budget 16 ms": measure(cornell, direct_truth, frame_budget_ms=16),
}
beyond'''),
    new_code_cell('''# Probes bring the missing bounce light: the error against the full reference must fall.
assert beyond["probes 4x4x4, 2 bounces (full GI)"]["relmse"] < beyond["no probes (full GI)"]["relmse"]
rows.update(beyond)'''),
    new_code_cell('''fig, ax = plt.subplots(figsize=(8, 3))
names = list(rows) + list(env_rows)
ax.barh(names, [v["flip"] for v in list(rows.values()) + list(env_rows.values())])
ax.set_xlabel("FLIP against the reference"); fig.tight_layout()
assert all(np.isfinite(v["flip"]) for v in list(rows.values()) + list(env_rows.values()))
# The radiometric form is the consistent one: it must not be worse than the paper's point-light form.
assert rows["radiometric"]["flip"] <= rows["paper"]["flip"]'''),
]

STABILITY = [
    new_markdown_cell("# Stability: the stress scenes\n\n"
                      "Each scene in `scenes/stress/` pushes one numerical limit (see the comment at the top of each "
                      "file). Both renderers must stay finite and non-negative; `tests/test_stress.py` asserts the "
                      "specific bound of each scene, this notebook shows the images and the numbers."),
    new_code_cell(SETUP),
    new_code_cell('''from compare.progressive import render_progressive
from compare.mitsuba.reference import ReferenceRenderer
from compare.scene.loader import load_scene
from compare.image.tonemap import to_ldr

names = ["roughness_sweep", "grazing", "dark", "scale_1e-3", "scale_1e4", "degenerate", "many_lights"]
table, images = {}, {}
for name in names:
    scene = load_scene(ROOT / "scenes" / "stress" / f"{name}.toml").with_resolution(W, H)
    ref = ReferenceRenderer(scene, progress=False).render(SPP).image
    prog = render_progressive(scene, frames=FRAMES).image
    table[name] = {"finite": bool(np.isfinite(ref).all() and np.isfinite(prog).all()),
                   "min": float(min(ref.min(), prog.min())),
                   "mean ref": float(ref.mean()), "mean progressive": float(prog.mean())}
    images[name] = (ref, prog)
table'''),
    new_code_cell('''fig, axes = plt.subplots(len(names), 2, figsize=(6, 2.2 * len(names)))
for row, name in zip(axes, names):
    ref, prog = images[name]
    scale = 1e6 if name == "dark" else 1.0  # the dark scene is 1e-6 times the Cornell box
    for ax, img, title in ((row[0], ref, "reference"), (row[1], prog, "progressive")):
        ax.imshow(to_ldr(img * scale)); ax.set_title(f"{name}: {title}", fontsize=8); ax.axis("off")
fig.tight_layout()
assert all(v["finite"] and v["min"] >= 0 for v in table.values())'''),
]


def write(name: str, cells: list) -> None:
    nb = new_notebook(cells=cells, metadata={"kernelspec": {"name": "python3", "display_name": "Python 3",
                                                            "language": "python"}})
    nbformat.validate(nb)
    (HERE / name).write_text(nbformat.writes(nb) + "\n")


NOTEBOOKS = {"quickstart.ipynb": QUICKSTART, "ablations.ipynb": ABLATIONS, "stability.ipynb": STABILITY}

if __name__ == "__main__":
    for name, cells in NOTEBOOKS.items():
        write(name, cells)
        print("wrote", HERE / name)
