"""The HTML report: a self-contained folder that opens from disk (``file://``).

:func:`build_report` turns a :class:`compare.report.results.Results` into::

    index.html            the report (jinja2, autoescape on)
    static/report.css     layout
    static/report.js      the interactive viewer (swipe + exposure)
    static/magma.png      colour bar of the error maps
    data/<scene id>.js    linear HDR images for the viewer (see below)
    plots/<scene id>-*.png   error-vs-time and equal-time/equal-error figures
    runs/...              EXR/PNG images and error maps written by ``compare run``

No network: no CDN, no web fonts, no ``fetch``; a Content-Security-Policy
meta tag allows only scripts, styles and images from the page's own origin or
from local files (``'self' file:``: browsers differ in whether ``'self'``
covers other ``file://`` paths), never inline script or the network, so even
a scene name that slipped past escaping could not run script.
Every scene-provided string reaches the page through jinja2's autoescaping
(and through JSON with ``<``, ``>`` and ``&`` escaped in the data files).

HDR data for the exposure slider
--------------------------------
A page opened from ``file://`` may not ``fetch`` files beside it, and pixels
of an ``<img>`` loaded from disk taint a canvas (``getImageData`` throws), so
the linear images cannot be read from the EXR or PNG files. Instead each
scene's ``data/<id>.js`` is a plain script, included with ``<script src>``,
that registers::

    window.COMPARE_HDR["<id>"] = {
      "width": W, "height": H, "exposure": 1.0, "operator": "aces",
      "encoding": "float16le-base64",
      "images": [{"key": "reference", "label": "...", "data": "<base64>"}, ...]
    }

``data`` is the linear RGB image, rows top to bottom, as little-endian IEEE
half floats (3 per pixel), base64-encoded: 3 significant digits, which is
below what an 8-bit display can show after tone mapping. Values are clamped
to [0, 65504] (half's range; negatives display as black anyway, since every
operator clamps them). ``report.js`` decodes them, multiplies by the exposure
(``exposure × 2^EV`` from the slider) and applies the same curve as
:func:`compare.image.tonemap.to_ldr`'s default: Stephen Hill's ACES fit
(:func:`compare.image.tonemap.aces`) followed by the sRGB transfer function, then
rounds to 8 bits like :func:`compare.image.tonemap.write_png`. The browser test
checks the page's pixels against ``to_ldr`` to within one 8-bit step.
"""

from __future__ import annotations

import base64
import json
import math
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from compare.util.errors import CompareError
from compare.util.files import write_text_atomic
from compare.brdf import MATERIAL_MODES
from compare.image.layers import LAYER_TITLES
from compare.metrics.table import METRICS
from compare.report.results import Results, SceneResult, metric_value
from compare.scene.scenarios import RENDERER_NAMES

__all__ = ["ReportError", "build_report", "hdr_payload"]

_HERE = Path(__file__).parent
# Beside the template in the package (pyproject's package-data globs "*.css",
# "*.js", "*.j2" match files of the package folder itself); copied to static/.
_STATIC = ("report.css", "report.js")
_HALF_MAX = 65504.0

#: Metrics shown in tables, in order: (key for metric_value, heading, digits), from the one table.
TABLE_METRICS = tuple((m.name, m.heading, m.digits) for m in METRICS if m.shown)

_MAP_TITLES = {"flip": "FLIP (LDR)", "one_minus_ssim": "1 − SSIM", "relmse": "relMSE"}


class ReportError(CompareError, ValueError):
    """The report cannot be built (e.g. an image named in results.json is missing)."""


# --------------------------------------------------------------------------- formatting


def fmt_num(v: float | None, digits: int = 3) -> str:
    """Compact number for tables: significant digits, '—' for missing."""
    if v is None:
        return "—"
    v = float(v)
    if v != 0 and (abs(v) < 1e-3 or abs(v) >= 1e5):
        return f"{v:.{max(1, digits - 1)}e}"
    return f"{v:.{digits}g}"


def fmt_seconds(v: float | None) -> str:
    """Seconds with a unit that keeps 3 significant digits readable (ms below 1 s)."""
    if v is None:
        return "—"
    v = float(v)
    if v < 1.0:
        return f"{v * 1000:.3g} ms"
    if v < 600:
        return f"{v:.3g} s"
    return f"{v / 60:.3g} min"


# --------------------------------------------------------------------------- HDR data


def _js_json(obj: Any) -> str:
    """JSON safe to embed in a script: no '<', '>' or '&' can close a tag or open a comment."""
    text = json.dumps(obj, ensure_ascii=True, allow_nan=False, separators=(",", ":"))
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _encode_half(image: np.ndarray) -> str:
    a = np.clip(np.asarray(image, dtype=np.float32), 0.0, _HALF_MAX)
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f2").tobytes()).decode("ascii")


def hdr_payload(scene_id: str, images: list[tuple[str, str, np.ndarray]], *, exposure: float = 1.0,
                operator: str = "aces") -> str:
    """The text of a ``data/<id>.js`` file (format in the module docstring).

    Parameters
    ----------
    scene_id : str
        Key under ``window.COMPARE_HDR``.
    images : list of (key, label, image)
        Linear (H, W, 3) images, all the same size.
    exposure : float, optional
        Base exposure the slider starts from.
    operator : str, optional
        Tone-mapping operator name (the page implements ``"aces"``).
    """
    if not images:
        raise ValueError("hdr_payload: no images")
    h, w = images[0][2].shape[:2]
    for key, _, img in images:
        if img.shape != (h, w, 3):
            raise ValueError(f"hdr_payload: image {key!r} has shape {img.shape}, expected {(h, w, 3)}")
    payload = {
        "width": int(w), "height": int(h), "exposure": float(exposure), "operator": operator,
        "encoding": "float16le-base64",
        "images": [{"key": k, "label": label, "data": _encode_half(img)} for k, label, img in images],
    }
    return ("/* compare report: linear HDR images of one scene for the interactive viewer\n"
            "   (little-endian float16 RGB, rows top to bottom, base64; see compare/report/html.py). */\n"
            f"(window.COMPARE_HDR = window.COMPARE_HDR || {{}})[{_js_json(scene_id)}] = {_js_json(payload)};\n")


# --------------------------------------------------------------------------- view model


def _metrics_row(metrics: dict) -> list[str]:
    return [fmt_num(metric_value(metrics, k), d) for k, _, d in TABLE_METRICS]


def _gt_label(ref) -> str:
    """``Mitsuba path tracer (llvm_ad_rgb), 1024 spp``: the ground truth's renderer and budget."""
    unit = ref.unit + ("s" if ref.unit in ("frame", "sample") and ref.spp != 1 else "")
    return f"{ref.label or ref.renderer}, {ref.spp} {unit}"


def _scene_view(scene: SceneResult, plots: dict[str, Path], out: Path, exposure: float,
                baseline: str = "progressive") -> dict:
    from compare.report.plots import PLOT_METRICS, equal_error, equal_time

    def rel(p: Path) -> str:
        return Path(os.path.relpath(p, out)).as_posix()

    runs = []
    for run in scene.runs:
        f = run.final.metrics if run.points else {}
        runs.append({
            "renderer": run.renderer,
            "label": run.label,
            "unit": run.unit,
            "steps": run.steps,
            "seconds": fmt_seconds(run.seconds),
            "first": fmt_seconds(run.first_frame_seconds),
            "setup": fmt_seconds(run.setup_seconds),
            "preview": run.preview,
            "flip": fmt_num(f.get("flip"), 3),
            "ssim": fmt_num(f.get("ssim"), 4),
            "maps": [{"title": _MAP_TITLES.get(k, k), "src": v} for k, v in run.maps.items()],
            "strip": [{"step": p.step, "seconds": fmt_seconds(p.seconds), "flip": fmt_num(p.metrics.get("flip"), 3),
                       "src": p.preview} for p in run.points if p.preview],
            "points": [{"step": p.step, "seconds": fmt_seconds(p.seconds), "vals": _metrics_row(p.metrics)}
                       for p in run.points],
            "metadata": sorted((str(k), str(v)) for k, v in run.metadata.items()),
        })
    labels = {r.renderer: r.label for r in scene.runs}
    equal = []
    for metric, title in PLOT_METRICS:
        et = equal_time(scene, metric)
        ee = equal_error(scene, metric)
        equal.append({
            "title": title,
            "time_rows": [{"target": fmt_seconds(c.target), "source": labels.get(c.source, c.source),
                           "vals": [fmt_num(c.values.get(r.renderer), 3) + (" †" if r.renderer in c.finished else "")
                                    for r in scene.runs]} for c in et],
            "error_rows": [{"target": fmt_num(c.target, 3), "source": labels.get(c.source, c.source),
                            "vals": [fmt_seconds(c.values.get(r.renderer)) for r in scene.runs]} for c in ee],
        })
    nf = scene.noise_floor
    viewer = [{"key": "reference", "label": f"Ground truth ({_gt_label(scene.reference)})"}]
    viewer += [{"key": r.renderer, "label": f"{r.label} ({r.steps} {r.unit}{'s' if r.unit == 'frame' else ''})"}
               for r in scene.runs if r.image]
    # The swipe starts on ground truth vs the first real-time renderer (the comparison the report is for).
    # (not the ground-truth renderer's own independent run)
    right = next((i for i, v in enumerate(viewer) if i and v["key"] != scene.reference.renderer),
                 min(1, len(viewer) - 1))
    return {
        "id": scene.id, "name": scene.name, "size": scene.size, "width": scene.width, "height": scene.height,
        "path": scene.path, "hash": scene.hash[:16],
        "features": scene.features, "omitted": sorted(scene.omitted.items()),
        "reference": {"spp": scene.reference.spp, "seed": scene.reference.seed,
                      "seconds": fmt_seconds(scene.reference.seconds),
                      "load": fmt_seconds(scene.reference.load_seconds),
                      "variant": scene.reference.variant, "preview": scene.reference.preview,
                      "what": _gt_label(scene.reference), "renderer": scene.reference.renderer,
                      "variance": scene.reference.variance, "variance_dof": scene.reference.variance_dof,
                      "hdr_range": (None if scene.reference.flip_hdr_exposure is None else
                                    [fmt_num(x, 3) for x in scene.reference.flip_hdr_exposure])},
        "noise_floor": None if nf is None else {"spp": nf.spp, "seeds": nf.seeds, "vals": _metrics_row(nf.metrics)},
        "runs": runs,
        "equal": equal,
        "ablations": _ablations(scene, baseline),
        "likeness": _likeness(scene),
        "layers": _layers(scene),
        "left_out": _left_out(scene),
        "noise_check": _noise_check(scene),
        "convergence": _convergence(scene.reference.convergence),
        "bias": _bias(scene),
        "plots": {k: rel(v) for k, v in plots.items()},
        "viewer": viewer,
        "viewer_right": right,
        "exposure": exposure,
    }


def _changed(metadata: dict) -> list[str]:
    """What a renderer changed or left out of a scene, as it declared (:meth:`compare.renderers.base.Renderer.prepare`):
    the phrases of its run's ``scene_changed``, or none."""
    return [w for w in str(metadata.get("scene_changed") or "").split("; ") if w]


def _left_out(scene: SceneResult) -> list[dict]:
    """What each renderer (the ground truth first) changed or left out of the scene (:func:`_changed`)."""
    out = []
    truth = _changed(scene.reference.metadata)
    if truth:
        out.append({"label": f"{_gt_label(scene.reference)} (ground truth)", "what": truth})
    for run in scene.runs:
        changed = _changed(run.metadata)
        if changed:
            out.append({"label": run.label, "what": changed})
    return out


def _layers(scene: SceneResult) -> dict | None:
    """The per-effect table: each run with layers × each layer (share of the error, FLIP, relMSE, mean
    ratio, FLIP map); the runs measured on the full image only; None when the ground truth has no layers."""
    names = next((list(r.layers) for r in scene.runs if r.layers), None)
    if names is None:
        return None
    # A kind of light the scene does not have (dark in the ground truth, mean ratio undefined) and no run
    # adds (no share of the error) gets no column and no map.
    names = [n for n in names if any(r.layers.get(n, {}).get("mean_ratio") is not None
                                     or (r.layers.get(n, {}).get("share") or 0.0) != 0.0 for r in scene.runs)]
    rows = []
    for run in scene.runs:
        if not run.layers:
            continue
        cells = []
        for name in names:
            e = run.layers.get(name, {})
            share = e.get("share")
            cells.append({"share": "—" if share is None else f"{100 * share:.1f} %",
                          "flip": fmt_num(e.get("flip"), 3), "relmse": fmt_num(e.get("relmse"), 3),
                          "ratio": fmt_num(e.get("mean_ratio"), 3), "rendered": bool(e.get("rendered")),
                          "map": e.get("map")})
        top = max((n for n in names if run.layers.get(n, {}).get("share") is not None),
                  key=lambda n: run.layers[n]["share"], default=None)
        rows.append({"label": run.label, "cells": cells, "top": LAYER_TITLES.get(top, top) if top else None,
                     "top_share": (f"{100 * run.layers[top]['share']:.0f} %" if top else None)})
    return {"names": [LAYER_TITLES.get(n, n) for n in names], "rows": rows,
            "full_only": [r.label for r in scene.runs if not r.layers and r.renderer != scene.reference.renderer]}


#: The ground truth is converged enough to judge a run when its noise floor's relMSE is at most this
#: fraction of the smallest relMSE it judges.
NOISE_FRACTION = 0.1


def _noise_check(scene: SceneResult) -> dict | None:
    """How the ground truth's own noise compares with the errors it judges (relMSE, additive in noise):
    the fraction of the smallest, the spp that would bring it to :data:`NOISE_FRACTION`, and the runs
    whose error is within the noise floor (which then cannot tell them from the ground truth)."""
    nf = scene.noise_floor
    if nf is None:
        return None
    floor = nf.metrics.get("relmse")
    judged = [r for r in scene.runs if r.renderer != scene.reference.renderer and r.points
              and r.final.metrics.get("relmse") is not None]
    if floor is None or not judged:
        return None
    smallest = min(judged, key=lambda r: r.final.metrics["relmse"])
    err = smallest.final.metrics["relmse"]
    fraction = floor / err if err > 0 else float("inf")
    within = []
    for r in judged:
        m, f = r.final.metrics, nf.metrics
        if m["relmse"] <= floor or (m.get("flip") is not None and f.get("flip") is not None and m["flip"] <= f["flip"]):
            within.append(r.label)
    need = None
    if fraction > NOISE_FRACTION and scene.reference.unit == "spp" and math.isfinite(fraction):
        need = int(math.ceil(scene.reference.spp * fraction / NOISE_FRACTION))
    return {"fraction": f"{100 * fraction:.1f} %" if math.isfinite(fraction) else "∞",
            "ok": fraction <= NOISE_FRACTION, "target": f"{100 * NOISE_FRACTION:.0f} %",
            "smallest": smallest.label, "smallest_relmse": fmt_num(err, 3), "floor": fmt_num(floor, 3),
            "need_spp": need, "within": within}


def _convergence(c: dict | None) -> dict | None:
    """How a ground truth of ``--spp auto`` decided it had enough samples, for the report; None for a fixed
    budget."""
    if not c:
        return None
    return {"spp": c["spp"], "cap": c["cap"], "met": bool(c["met"]), "criterion": c["criterion"],
            "target": fmt_num(c["target"], 3), "estimate": fmt_num(c.get("estimate"), 3),
            "history": [{"spp": int(n), "estimate": fmt_num(e, 3)} for n, e in c.get("history") or []]}


def _bias(scene: SceneResult) -> list[dict]:
    """The bias/variance split at each run's final checkpoint (settings.seeds >= 2)."""
    rows = []
    for r in scene.runs:
        m = r.final.metrics if r.points else {}
        if "rel_bias2" not in m:
            continue
        b, ci = m["rel_bias2"], m["rel_bias2_ci"]
        verdict = ("interval unknown (too few pixels)" if ci is None else
                   "biased" if b - ci > 0 else "no bias found (within its interval of 0)")
        rows.append({"label": r.label, "seeds": m.get("seeds"), "mse": fmt_num(m["relmse_mean"], 3),
                     "variance": fmt_num(m["rel_variance"], 3), "bias2": fmt_num(b, 3), "ci": fmt_num(ci, 2),
                     "share": f"{100 * max(b, 0.0) / m['relmse_mean']:.0f} %" if m["relmse_mean"] > 0 else "—",
                     "verdict": verdict})
    return rows


def _likeness(scene: SceneResult) -> dict | None:
    """The likeness the measure stage found (``cycles`` with ``--materials cycles``), formatted, or None."""
    m = scene.likeness
    if m is None:
        return None
    return {"spp": m.get("spp"), "cross": fmt_num(m.get("flip_cross"), 4), "seed": fmt_num(m.get("flip_seed"), 4),
            "ratio": fmt_num(m.get("ratio"), 3), "matched": fmt_num(m.get("ratio_noise_matched"), 3),
            "mitsuba": fmt_num(m.get("flip_mitsuba_seed"), 4), "regions": m.get("regions"),
            "mitsuba_spp": m.get("mitsuba_spp"), "relmse_ratio": fmt_num(m.get("relmse_ratio"), 3),
            "relmse_matched": fmt_num(m.get("relmse_ratio_noise_matched"), 3),
            "distribution": m.get("distribution"), "materials": m.get("materials")}


def _ablations(scene: SceneResult, baseline: str = "progressive") -> list[dict]:
    """Each run of the baseline's family (e.g. ``progressive:<option>``, compare.progressive.options) against the
    baseline run (the plain ``progressive`` by default).

    Final FLIP and relMSE of both, the time ratio, and the equal-time view: the
    variant's FLIP when the paper's technique has spent its whole time, and the
    paper's FLIP at the variant's total time (log–log interpolated, final image held).
    """
    base = scene.run(baseline)
    if base is None or not base.points:
        return []
    rows = []
    for run in scene.runs:
        if run is base or run.family != base.family or not run.points:
            continue
        what = run.variant_note or run.renderer
        f, b = run.final.metrics, base.final.metrics

        def delta(key: str) -> str:
            v, w = metric_value(f, key), metric_value(b, key)
            if v is None or w is None or not w:
                return "—"
            return f"{(v / w - 1) * 100:+.1f} %"

        rows.append({
            "label": run.label, "what": what,
            "flip": fmt_num(metric_value(f, "flip"), 4), "flip_delta": delta("flip"),
            "relmse": fmt_num(metric_value(f, "relmse"), 4), "relmse_delta": delta("relmse"),
            "seconds": fmt_seconds(run.seconds),
            "time_ratio": fmt_num(run.seconds / base.seconds if base.seconds else None, 3),
            "setup": fmt_seconds(run.setup_seconds),
            "steps": run.steps,
            "at_base_time": fmt_num(run.error_at(base.seconds, "flip", hold=True), 4),
            "base_at_time": fmt_num(base.error_at(run.seconds, "flip", hold=True), 4),
            "moved": _layer_moved(run, base),
        })
    return rows


def _layer_moved(run, base) -> str:
    """The kind of light whose relMSE the variant changed most against the baseline, as "layer: before →
    after" (the error-by-cause reading of an ablation); "—" without layers on both sides."""
    both = [n for n in run.layers if n in base.layers and n not in ("direct_area_unshadowed",)
            and run.layers[n].get("relmse") is not None and base.layers[n].get("relmse") is not None]
    if not both:
        return "—"
    name = max(both, key=lambda n: abs(run.layers[n]["relmse"] - base.layers[n]["relmse"]))
    return (f"{LAYER_TITLES.get(name, name)}: {fmt_num(base.layers[name]['relmse'], 4)} → "
            f"{fmt_num(run.layers[name]['relmse'], 4)}")


def _table1(results: Results) -> dict:
    """Paper's Table 1 layout: renderer rows × (scene, resolution) columns, seconds with errors."""
    cols = [{"name": s.name, "size": s.size, "id": s.id} for s in results.scenes]
    specs: list[tuple[str, str]] = []
    for s in results.scenes:
        for r in s.runs:
            if r.renderer not in [k for k, _ in specs]:
                specs.append((r.renderer, r.label))
    first = results.scenes[0].reference if results.scenes else None
    rows = [{"label": f"Ground truth ({first.label or first.renderer if first else '—'})", "cells": [
        {"seconds": fmt_seconds(s.reference.seconds), "detail": f"{s.reference.spp} {s.reference.unit}",
         "flip": None, "ssim": None}
        for s in results.scenes]}]
    first_rows = []
    for spec, label in specs:
        cells, firsts = [], []
        for s in results.scenes:
            r = s.run(spec)
            if r is None:
                cells.append(None)
                firsts.append(None)
                continue
            m = r.final.metrics
            cells.append({"seconds": fmt_seconds(r.seconds),
                          "detail": f"{r.steps} {r.unit}{'s' if r.unit == 'frame' else ''}",
                          "flip": fmt_num(m.get("flip"), 3), "ssim": fmt_num(m.get("ssim"), 4)})
            firsts.append({"first": fmt_seconds(r.first_frame_seconds), "setup": fmt_seconds(r.setup_seconds),
                           "flip": fmt_num(r.points[0].metrics.get("flip"), 3),
                           "scale": r.notes.get("first_image", "")})
        rows.append({"label": label, "cells": cells})
        first_rows.append({"label": label, "cells": firsts})
    return {"cols": cols, "rows": rows, "first_rows": first_rows}


def _fidelity(results: Results) -> dict | None:
    """The scenario table of a run of ``compare run --scenarios`` (None for a run of scene files), as
    model-viewer's fidelity page lays it out: a row per scenario and size, in the file's order, and a column
    per renderer; each cell the renderer's final image, its FLIP and model-viewer RMS (dB) against the ground
    truth, the seconds to that image, and what the renderer left out of the scene (:func:`_changed`, as in the
    scene's own list, :func:`_left_out`); a renderer the scenario's ``exclude`` names is marked excluded, a unit
    that failed says so, and a scenario not rendered is one row saying why. Each cell carries its numbers for
    sorting (``data-*`` attributes read by report.js)."""
    record = results.scenarios
    if record is None:
        return None
    truth = results.settings.ground_truth
    by_id = {s.id: s for s in results.scenes}
    specs: list[tuple[str, str]] = []
    for spec in results.settings.renderers:  # the run's order; a label from a run that has one
        if spec not in [k for k, _ in specs]:
            label = next((r.label for s in results.scenes for r in s.runs if r.renderer == spec), spec)
            specs.append((spec, label))
    failed = {(f["scene"], f["renderer"]): f["message"] for f in results.failures}
    rows = []
    for order, sc in enumerate(record.scenarios):
        base = {"name": sc.name, "order": order, "exclude": sc.exclude, "excluded": sc.excluded}
        if sc.unavailable is not None:
            rows.append({**base, "status": f"not rendered: {sc.unavailable}", "size": "", "id": None})
            continue
        # its scenes; in a record without their ids (written by another tool), the scenes of its name
        sc_ids = list(sc.scenes) or [s.id for s in results.scenes if s.name == sc.name]
        if not sc_ids:
            rows.append({**base, "status": "not measured: the run has no scene of this scenario", "size": "",
                         "id": None})
        for sid in sc_ids:
            scene = by_id.get(sid)
            if scene is None:  # its ground truth failed: the scene was not measured
                why = failed.get((sid, truth), "the ground truth did not render")
                rows.append({**base, "status": f"not measured: the ground truth ({truth}) failed: {why}",
                             "size": sid.rsplit("-", 1)[-1], "id": None})
                continue
            ref = scene.reference
            truth_cell = {"preview": ref.preview, "seconds": fmt_seconds(ref.seconds), "raw_seconds": ref.seconds,
                          "what": f"{ref.spp} {ref.unit}",
                          "left_out": _changed(ref.metadata)}
            cells = []
            for spec, label in specs:
                run = scene.run(spec)
                if run is not None and run.points:
                    m = run.final.metrics
                    flip, db = metric_value(m, "flip"), metric_value(m, "mv_rms_db")
                    cells.append({"state": "run", "label": label, "preview": run.preview,
                                  "flip": fmt_num(flip, 3), "db": "—" if db is None else f"{db:.1f}",
                                  "seconds": fmt_seconds(run.seconds),
                                  "sort": {"flip": flip, "db": db, "seconds": run.seconds},
                                  "steps": f"{run.steps} {run.unit}{'s' if run.unit == 'frame' and run.steps != 1 else ''}",
                                  "left_out": _changed(run.metadata)})
                elif (sid, spec) in failed:
                    cells.append({"state": "failed", "label": label, "text": f"failed: {failed[(sid, spec)]}"})
                elif spec.split(":", 1)[0] in sc.excluded and spec != truth:
                    # the file's name of the renderer (model-viewer's, e.g. blender-cycles for cycles)
                    names = [n for n in sc.exclude if RENDERER_NAMES.get(n, n) == spec.split(":", 1)[0]]
                    cells.append({"state": "excluded", "label": label,
                                  "text": f"excluded by the scenario (exclude: {', '.join(names or sc.exclude)})"})
                else:
                    cells.append({"state": "none", "label": label, "text": "not run"})
            rows.append({**base, "status": None, "size": scene.size, "id": scene.id, "truth": truth_cell,
                         "cells": cells})
    summary = []
    for k, (spec, label) in enumerate(specs):
        done = [r["cells"][k] for r in rows if r.get("cells") and r["cells"][k]["state"] == "run"]
        flips = [c["sort"]["flip"] for c in done if c["sort"]["flip"] is not None]
        dbs = [c["sort"]["db"] for c in done if c["sort"]["db"] is not None]
        summary.append({"count": len(done), "flip": fmt_num(sum(flips) / len(flips), 3) if flips else "—",
                        "db": f"{sum(dbs) / len(dbs):.1f}" if dbs else "—",
                        "seconds": fmt_seconds(sum(c["sort"]["seconds"] for c in done)) if done else "—"})
    gt = next((s.reference for s in results.scenes), None)
    return {"file": record.file, "renderers": [{"spec": s, "label": lab} for s, lab in specs], "rows": rows,
            "summary": summary, "total": len(record.scenarios), "left_out": len(record.left_out),
            "truth": f"{gt.label or gt.renderer}" if gt is not None else truth}


# --------------------------------------------------------------------------- building


def _referenced(results: Results) -> list[str]:
    paths = []
    for s in results.scenes:
        for p in (s.reference.image, s.reference.preview, s.reference.variance):
            if p:
                paths.append(p)
        for r in s.runs:
            paths += [p for p in (r.image, r.preview) if p]
            paths += list(r.maps.values())
            paths += [e["map"] for e in r.layers.values() if isinstance(e.get("map"), str)]
            for pt in r.points:
                paths += [p for p in (pt.image, pt.preview) if p]
    return paths


def _safe_rel(rel: str) -> Path:
    p = Path(rel)
    if p.is_absolute() or ".." in p.parts:
        raise ReportError(f"results.json names {rel!r}: image paths must stay inside the results folder")
    return p


def _colorbar(path: Path) -> None:
    import imageio.v3 as iio
    import matplotlib

    ramp = matplotlib.colormaps["magma"](np.linspace(0.0, 1.0, 256))[:, :3]
    img = np.round(np.repeat(ramp[None], 12, axis=0) * 255).astype(np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(path, img, extension=".png")


def build_report(results: Results, out_dir: str | os.PathLike, *, source_dir: str | os.PathLike | None = None,
                 plot_format: str = "png", index_name: str = "index.html") -> Path:
    """Write the HTML report of ``results`` into ``out_dir``.

    Parameters
    ----------
    results : Results
        What ``compare run`` measured.
    out_dir : path
        The report folder. Usually the folder of ``results.json`` itself.
    source_dir : path, optional
        The folder ``results.json``'s relative image paths are relative to;
        default ``out_dir``. When it differs, the images are copied over so
        the report folder stands alone.
    plot_format : {"png", "svg"}, optional
        Format of the figures.

    Returns
    -------
    pathlib.Path
        ``out_dir / "index.html"``.

    Raises
    ------
    ReportError
        If an image named in the results is missing.
    """
    from jinja2 import Environment, FileSystemLoader, StrictUndefined

    from compare import __version__
    from compare.image.exr import read_exr
    from compare.report.plots import make_plots

    out = Path(out_dir)
    src = Path(source_dir) if source_dir is not None else out
    out.mkdir(parents=True, exist_ok=True)
    root = src.resolve()
    for rel in _referenced(results):
        a, b = src / _safe_rel(rel), out / _safe_rel(rel)
        if not a.is_file():
            raise ReportError(f"{a}: named in results.json but missing; rerun `compare run` to recreate it")
        if not a.resolve().is_relative_to(root):
            raise ReportError(f"{a}: links to {a.resolve()}, outside the results folder {src}: a report copies "
                              "only what its run wrote")
        if a.resolve() != b.resolve():
            b.parent.mkdir(parents=True, exist_ok=True)
            if b.is_symlink():  # replace a link in the report folder, never write through it
                b.unlink()
            shutil.copy2(a, b)

    static = out / "static"
    static.mkdir(exist_ok=True)
    for name in _STATIC:
        shutil.copyfile(_HERE / name, static / name)
    _colorbar(static / "magma.png")

    plots = make_plots(results, out / "plots", fmt=plot_format)
    for scene in results.scenes:
        images = [("reference", "ground truth", read_exr(out / scene.reference.image)[0])]
        images += [(r.renderer, r.label, read_exr(out / r.image)[0]) for r in scene.runs if r.image]
        write_text_atomic(out / "data" / f"{scene.id}.js",
                          hdr_payload(scene.id, images, exposure=results.settings.exposure,
                                      operator=results.settings.tonemap))

    env = Environment(loader=FileSystemLoader(_HERE), autoescape=True, undefined=StrictUndefined,
                      trim_blocks=True, lstrip_blocks=True)
    template = env.get_template("report.html.j2")
    html = template.render(
        title="Renderer comparison",
        results=results,
        settings=results.settings,
        machine=results.machine,
        table1=_table1(results),
        fidelity=_fidelity(results),
        materials_note=MATERIAL_MODES.get(results.settings.materials, results.settings.materials),
        scenes=[_scene_view(s, plots[s.id], out, results.settings.exposure, results.settings.baseline)
                for s in results.scenes],
        metric_headings=[h for _, h, _ in TABLE_METRICS],
        version=__version__,
    )
    index = out / index_name  # another name: a caller that replaces index.html with results.json together
    write_text_atomic(index, html)
    if src.resolve() != out.resolve():
        results.save(out / "results.json")  # the copied report folder stands alone
    return index


# --------------------------------------------------------------------------- CLI






