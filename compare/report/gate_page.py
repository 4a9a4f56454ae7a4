"""The page of a gated run (``compare check --baseline ... --report DIR``).

``DIR/index.html`` shows the verdict, the tests that did not plainly pass (and all of them
folded), the images that changed (baseline, candidate, and the map of |z| of their
difference), and per scene × renderer the error and time curves of the baseline and the
candidate with the spread of their seeds. Like the run report it opens from disk, loads
nothing from the network and has no inline style or script (its CSP forbids both): the
run report's stylesheet is copied beside it.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np

from compare.util.errors import CompareError
from compare.util.files import atomic_folder, write_text_atomic
from compare.report.baseline import Baseline
from compare.report.gate import GateReport
from compare.report.results import RendererRun, Results

__all__ = ["build_gate_page"]

_HERE = Path(__file__).parent


_MARK = "<title>Regression gate"


def _is_gate_page(folder: Path) -> bool:
    """A folder this module wrote (replaced without asking)."""
    try:
        return _MARK in (folder / "index.html").read_text(encoding="utf-8")[:2000]
    except (OSError, UnicodeDecodeError):
        return False


def _band(run: RendererRun, metric: str) -> tuple[list, list, list, list]:
    """Per checkpoint: mean seconds, and mean, low and high (min and max over seeds) of ``metric``."""
    seeds = run.per_seed()
    t, mean, low, high = [], [], [], []
    for p in run.points:
        vals, secs = [], []
        for s in seeds:
            q = s.at(p.step)
            if q is None:
                continue
            secs.append(q["seconds"])
            v = q["seconds"] if metric == "seconds" else q["metrics"].get(metric)
            if v is not None:
                vals.append(float(v))
        if vals and secs:
            t.append(float(np.mean(secs)))
            mean.append(float(np.mean(vals)))
            low.append(min(vals))
            high.append(max(vals))
    return t, mean, low, high


def _curves(base: RendererRun, cand: RendererRun, metric: str, title: str, path: Path) -> Path:
    from compare.report.plots import _new_figure, _save, _text

    fig = _new_figure(10, 3.6)
    ax_e, ax_t = fig.subplots(1, 2)
    for run, name, style in ((base, "baseline", "o--"), (cand, "candidate", "s-")):
        t, m, lo, hi = _band(run, metric)
        if t:
            line, = ax_e.plot(t, m, style, label=name)
            ax_e.fill_between(t, lo, hi, alpha=0.2, color=line.get_color())
        steps = [p.step for p in run.points]
        _, tm, tlo, thi = _band(run, "seconds")
        if tm and len(tm) == len(steps):
            line, = ax_t.plot(steps, tm, style, label=name)
            ax_t.fill_between(steps, tlo, thi, alpha=0.2, color=line.get_color())
    for ax in (ax_e, ax_t):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    ax_e.set_xlabel("seconds")
    ax_e.set_ylabel(metric)
    ax_t.set_xlabel(base.unit)
    ax_t.set_ylabel("seconds")
    fig.suptitle(_text(title), fontsize=10)
    return _save(fig, path)


def build_gate_page(report: GateReport, out_dir: str | os.PathLike, *, baseline: Baseline | None = None,
                    candidate: Results | None = None) -> Path:
    """Write the gate's page into ``out_dir`` (replaced as a whole; see the module notes); returns index.html."""
    import jinja2

    from compare import __version__
    from compare.image.exr import read_exr
    from compare.image.maps import save_maps
    from compare.image.tonemap import write_png

    out_dir = Path(out_dir)
    baseline = baseline or Baseline.load(report.baseline)
    candidate = candidate or Results.load(report.candidate)
    cand_dir = Path(report.candidate).parent
    metric = report.settings.metrics[0]
    if out_dir.exists() and any(out_dir.iterdir()) and not _is_gate_page(out_dir):
        from compare.util.errors import OutputError

        raise OutputError(f"--report {out_dir}: a folder that is not a gate's page; choose a new or empty folder")
    with atomic_folder(out_dir, replace=out_dir.exists()) as tmp:
        (tmp / "static").mkdir()
        shutil.copyfile(_HERE / "report.css", tmp / "static" / "report.css")
        changed = []
        for i, g in enumerate(report.gates):
            if g.status != "changed" or g.zmap is None:
                continue
            brun = baseline.run(g.scene, g.size, g.renderer)
            scene = next(s for s in candidate.scenes if (s.name, s.size) == (g.scene, g.size))
            crun = scene.run(g.renderer)
            try:
                mean = np.mean([read_exr(cand_dir / s.image)[0] for s in crun.per_seed()], axis=0)
            except CompareError as e:
                raise CompareError(f"{report.candidate}: {g.name}: {e}") from e
            sub = Path("images") / f"{i:03d}"
            (tmp / sub).mkdir(parents=True, exist_ok=True)
            write_png(tmp / sub / "candidate.png", mean, exposure=candidate.settings.exposure,
                      operator=candidate.settings.tonemap)
            if brun.preview:
                shutil.copyfile(baseline.root / brun.preview, tmp / sub / "baseline.png")
            else:
                write_png(tmp / sub / "baseline.png", baseline.images(brun).mean(axis=0),
                          exposure=candidate.settings.exposure, operator=candidate.settings.tonemap)
            z = np.nan_to_num(g.zmap.max(axis=2), posinf=1e6)
            zmax = float(max(z.max(), 1e-12))
            save_maps(tmp / sub, {"z": z}, ranges={"z": (0.0, zmax)})
            changed.append({"title": g.name, "note": g.note, "baseline": (sub / "baseline.png").as_posix(),
                            "candidate": (sub / "candidate.png").as_posix(), "zmap": (sub / "z.png").as_posix(),
                            "zmax": f"{zmax:.3g}"})
        plots = []
        k = 0
        for bscene in baseline.results.scenes:
            cscene = next((s for s in candidate.scenes if (s.name, s.size) == (bscene.name, bscene.size)), None)
            if cscene is None:
                continue
            for brun in bscene.runs:
                crun = cscene.run(brun.renderer)
                if crun is None:
                    continue
                title = f"{bscene.name} {bscene.size} {brun.renderer}"
                rel = Path("plots") / f"{k:03d}.png"
                _curves(brun, crun, metric, title, tmp / rel)
                plots.append({"title": title, "path": rel.as_posix(),
                              "caption": f"{metric} against seconds, and seconds at each {brun.unit}: mean of the "
                                         "seeds, band from the smallest to the largest seed"})
                k += 1
        env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(_HERE)), autoescape=True,
                                 undefined=jinja2.StrictUndefined)
        rows = report.rows()
        html = env.get_template("gate.html.j2").render(
            version=__version__, verdict=report.verdict, summary=report.summary_line(),
            machine=report.machine, notes=report.notes,
            notable=[r for g, r in zip(report.gates, rows) if g.status != "pass"], everything=rows,
            changed=changed, plots=plots)
        write_text_atomic(tmp / "index.html", html)
    return out_dir / "index.html"
