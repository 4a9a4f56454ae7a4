"""Which features a renderer draws, measured rather than claimed.

Each feature has a probe: a tiny scene rendered twice by the renderer, once with the feature and
once without it (or, for the energy of rough metal, against the value the feature must reach), and
a number that says whether the feature changed the image as it must:

=====================  ===========================================================  ==============
feature                measured                                                     drawn when
=====================  ===========================================================  ==============
area-light shadows     floor under an occluder the camera does not see, with the    ratio < 0.5
                       occluder against without, lit by one area light
environment shadows    the same under a uniform environment                         ratio < 0.8
multiscatter energy    white rough metal (roughness 1) in a white furnace:          value > 0.9
                       the radiance it returns (1 with all scattering orders)
clearcoat, sheen,      a card with the layer against the same card without it:      change > 3 %
transmission, alpha    the mean relative change of its pixels
blend, texture
transform
punctual lights        a floor under one point light: its radiance against the      ratio in 0.5–2
                       ground truth's (Mitsuba)
=====================  ===========================================================  ==============

``python -m compare.bench.features --renderers threejs,babylon,playcanvas`` prints the table
(``--json`` for the numbers); ``docs/renderers.md`` holds the one measured on the suite's machine.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

__all__ = ["FEATURES", "Probe", "measure_features", "feature_table"]

#: The probes' scene files (package data): each probe renders one as it is and one changed by a few fields.
PROBES = Path(__file__).resolve().parent / "probes"


def _probe(name: str) -> dict:
    with open(PROBES / f"{name}.toml", "rb") as f:
        return tomllib.load(f)


def _without_mesh(data: dict, mesh: str) -> dict:
    return {**data, "meshes": [m for m in data["meshes"] if m["name"] != mesh]}


def _with_material(data: dict, name: str, fields: dict, *, replace: bool = False) -> dict:
    materials = dict(data["materials"])
    materials[name] = dict(fields) if replace else {**materials[name], **fields}
    return {**data, "materials": materials}


@dataclass(frozen=True)
class Probe:
    """One feature's probe: the two scenes (parsed TOML; ``None`` for a reference value), the number made
    from the two images, and the test that says the feature is drawn."""

    title: str
    scenes: Callable[[Path], tuple[dict, dict | str | None]]
    value: Callable[[np.ndarray, np.ndarray], float]
    drawn: Callable[[float], bool]
    unit: str


def _floor_middle(a: np.ndarray, b: np.ndarray) -> float:
    # the floor under the occluder's middle: the image's lower-middle pixels
    h, w = a.shape[:2]
    sl = (slice(h // 2, 3 * h // 4), slice(w // 3, 2 * w // 3))
    return float(a[sl].mean() / max(b[sl].mean(), 1e-12))


def _card_change(a: np.ndarray, b: np.ndarray) -> float:
    h, w = a.shape[:2]
    sl = (slice(h // 3, 2 * h // 3), slice(w // 3, 2 * w // 3))
    return float(np.abs(a[sl] - b[sl]).mean() / max(b[sl].mean(), 1e-12))


def _shadow(kind: str) -> Callable[[Path], tuple[dict, dict]]:
    def scenes(folder: Path) -> tuple[dict, dict]:
        data = _probe(f"shadow_{kind}")
        return data, _without_mesh(data, "occluder")
    return scenes


def _card(fields: dict) -> Callable[[Path], tuple[dict, dict]]:
    def scenes(folder: Path) -> tuple[dict, dict]:
        data = _probe("card")
        return _with_material(data, "card", fields), data
    return scenes


def _texture_transform(folder: Path) -> tuple[dict, dict]:
    from PIL import Image

    px = np.zeros((8, 8, 3), np.uint8)
    px[:4, :4], px[:4, 4:], px[4:, :4], px[4:, 4:] = (255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 0)
    Image.fromarray(px).save(folder / "quadrants.png")
    emitting = {"base_color": [0.0, 0.0, 0.0], "emission": [1.0, 1.0, 1.0], "emissive_texture": "quadrants.png"}
    base = _with_material(_probe("card"), "card", emitting, replace=True)
    return _with_material(base, "card", {"texture_rotation": 90.0}), base


#: Feature name → its probe, in the order of the table.
FEATURES: dict[str, Probe] = {
    "area_light_shadows": Probe("area-light shadows", _shadow("area"), _floor_middle, lambda v: v < 0.5,
                                "shadowed / unshadowed"),
    "environment_shadows": Probe("environment shadows", _shadow("env"), _floor_middle, lambda v: v < 0.8,
                                 "shadowed / unshadowed"),
    "multiscatter_energy": Probe("multiscatter energy", lambda f: (_probe("furnace"), None),
                                 lambda a, b: float(a[a.shape[0] // 4: -a.shape[0] // 4, a.shape[1] // 4: -a.shape[1] // 4].mean()),
                                 lambda v: v > 0.9, "furnace radiance (1 = all energy)"),
    "clearcoat": Probe("clearcoat", _card({"clearcoat": 1.0, "clearcoat_roughness": 0.1}),
                       _card_change, lambda v: v > 0.03, "relative change"),
    "sheen": Probe("sheen", _card({"sheen_color": [1.0, 1.0, 1.0], "sheen_roughness": 0.5}),
                   _card_change, lambda v: v > 0.03, "relative change"),
    "transmission": Probe("transmission", _card({"transmission": 1.0}), _card_change, lambda v: v > 0.03,
                          "relative change"),
    "alpha_blend": Probe("alpha blend", _card({"alpha_mode": "blend", "alpha": 0.4}),
                         _card_change, lambda v: v > 0.03, "relative change"),
    "texture_transform": Probe("texture transform", _texture_transform, _card_change, lambda v: v > 0.03,
                               "relative change"),
    "punctual_lights": Probe("punctual lights", lambda f: (_probe("point"), "reference"),
                             lambda a, b: float(a.mean() / max(b.mean(), 1e-12)), lambda v: 0.5 < v < 2.0,
                             "radiance / ground truth"),
}


def _scene(folder: Path, name: str, data: dict):
    from compare.scene.loader import parse_scene

    # a path in the probe's folder: its texture files (if any) are written there
    return parse_scene({**data, "name": name}, folder / f"{name}.toml")


def measure_features(specs: list[str], *, frames: int = 8, spp: int = 128, features: list[str] | None = None,
                     progress: Callable[[str], None] | None = None) -> dict[str, dict[str, dict]]:
    """``{renderer: {feature: {"value": number, "drawn": bool, "unit": text}}}`` for each renderer spec,
    from the probes of :data:`FEATURES` (all, or ``features``). A renderer that fails a probe gets
    ``{"error": message}`` for it; a probe lit by an area light is ``{"unmeasured": why}`` for a renderer
    that draws none (:attr:`~compare.renderers.base.Renderer.area_lights`)."""
    from compare.mitsuba.reference import ReferenceRenderer
    from compare.renderers import RenderContext
    from compare.renderers.registry import Registry
    from compare.renderers.base import RendererError
    from compare.report.results import RunSettings

    registry = Registry()
    out: dict[str, dict[str, dict]] = {s: {} for s in specs}
    with tempfile.TemporaryDirectory(prefix="compare-features-") as tmp, \
            RenderContext(RunSettings(frames=frames, spp=spp), cache_dir=False) as context:
        folder = Path(tmp)
        truth: dict[str, np.ndarray] = {}
        for name in features or list(FEATURES):
            probe = FEATURES[name]
            with_text, without_text = probe.scenes(folder)
            with_scene = _scene(folder, f"{name}-with", with_text)
            if without_text == "reference":
                if name not in truth:
                    truth[name] = ReferenceRenderer(with_scene, cache_dir=False, progress=False).render(spp).image
                without_scene = None
            else:
                without_scene = _scene(folder, f"{name}-without", without_text) if without_text else None
            for spec in specs:
                if progress:
                    progress(f"{spec}: {probe.title}")
                r = registry.get(spec)
                if not r.area_lights and with_scene.lights:
                    # a renderer without area lights would show the probe unlit: nothing to tell from it
                    out[spec][name] = {"unmeasured": "its probe is lit by an area light, which the renderer "
                                                      "does not draw"}
                    continue
                try:
                    images = []
                    for s in (with_scene, without_scene):
                        if s is None:
                            continue
                        given, _ = r.prepare(s)
                        images.append(r.render(given, steps=r.steps(context.settings), checkpoints=[r.steps(context.settings)],
                                               seed=0, context=context).checkpoints[-1].image)
                    b = images[1] if len(images) > 1 else truth.get(name, images[0])
                    v = probe.value(images[0], b)
                    out[spec][name] = {"value": round(v, 4), "drawn": bool(probe.drawn(v)), "unit": probe.unit}
                except RendererError as exc:
                    out[spec][name] = {"error": str(exc)}
    return out


def feature_table(measured: dict[str, dict[str, dict]]) -> str:
    """A Markdown table: one row per feature, one column per renderer, ✓ or ✗ with the measured number."""
    specs = list(measured)
    names = [n for n in FEATURES if any(n in measured[s] for s in specs)]
    lines = ["| feature (measured as) | " + " | ".join(f"`{s}`" for s in specs) + " |",
             "| --- | " + " | ".join("---" for _ in specs) + " |"]
    for n in names:
        cells = []
        for s in specs:
            m = measured[s].get(n, {})
            cells.append("error" if "error" in m else "n/a" if "unmeasured" in m
                         else f"{'✓' if m.get('drawn') else '✗'} {m.get('value', float('nan')):.2f}")
        lines.append(f"| {FEATURES[n].title} ({FEATURES[n].unit}) | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``python -m compare.bench.features``: measure and print the engine × feature table."""
    p = argparse.ArgumentParser(prog="python -m compare.bench.features", description=__doc__.split("\n\n")[0])
    p.add_argument("--renderers", default="threejs,babylon,playcanvas")
    p.add_argument("--features", default=None, help=f"comma-separated subset of {', '.join(FEATURES)}")
    p.add_argument("--json", action="store_true", help="print the numbers as JSON")
    a = p.parse_args(argv)
    measured = measure_features([s.strip() for s in a.renderers.split(",") if s.strip()],
                                features=a.features.split(",") if a.features else None,
                                progress=lambda m: print(m, file=sys.stderr))
    print(json.dumps(measured, indent=1) if a.json else feature_table(measured))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
