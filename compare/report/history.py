"""``compare history``: error and time of every renderer over a series of runs (e.g. one per CI run).

Each ``results.json`` of the series is one point on the x axis, in the order given (a
series over commits). Per scene × size × renderer the page shows the final checkpoint's
error and time with their noise band: the 95 % interval of the mean over the run's seeds
(Student's t; ``compare run --seeds K``, K >= 2), so that a step in the curve can be told
from noise by eye; a run with one seed has no band. The page, like the run report, opens
from disk and has no inline style or script.
"""

from __future__ import annotations

import math
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from compare.util.files import atomic_folder, write_text_atomic
from compare.report.results import Results, ResultsError

__all__ = ["Series", "build_history", "series"]

_HERE = Path(__file__).parent
_MARK = "<title>History"


@dataclass
class Series:
    """One scene × size × renderer over the runs: per run, the mean and band of the error and the time."""

    scene: str
    size: str
    renderer: str
    label: str
    unit: str
    step: list[int | None] = field(default_factory=list)
    error: list[tuple[float, float, float] | None] = field(default_factory=list)  # mean, low, high
    seconds: list[tuple[float, float, float] | None] = field(default_factory=list)


def _band(values: list[float]) -> tuple[float, float, float]:
    """Mean and its 95 % interval (Student's t over the seeds); the mean alone for one value."""
    x = np.asarray(values, dtype=np.float64)
    m = float(x.mean())
    if x.size < 2:
        return m, m, m
    from scipy.stats import t as student_t

    h = float(student_t.ppf(0.975, x.size - 1)) * float(x.std(ddof=1)) / math.sqrt(x.size)
    return m, m - h, m + h


def series(runs: list[Results], metric: str = "relmse") -> list[Series]:
    """The series of every scene × size × renderer found in any of ``runs`` (None where a run lacks it)."""
    out: dict[tuple[str, str, str], Series] = {}
    for res in runs:
        for scene in res.scenes:
            for run in scene.runs:
                key = (scene.name, scene.size, run.renderer)
                out.setdefault(key, Series(scene.name, scene.size, run.renderer, run.label, run.unit))
    for i, res in enumerate(runs):
        for key, s in out.items():
            scene = next((x for x in res.scenes if (x.name, x.size) == key[:2]), None)
            run = None if scene is None else scene.run(key[2])
            if run is None or not run.points:
                s.step.append(None)
                s.error.append(None)
                s.seconds.append(None)
                continue
            step = run.final.step
            pts = [p for p in (sd.at(step) for sd in run.per_seed()) if p is not None]
            errs = [float(p["metrics"][metric]) for p in pts if p["metrics"].get(metric) is not None]
            s.step.append(step)
            s.error.append(_band(errs) if errs else None)
            s.seconds.append(_band([float(p["seconds"]) for p in pts]))
    return list(out.values())


def _figure(s: Series, labels: list[str], metric: str, path: Path) -> Path:
    from compare.report.plots import _new_figure, _save, _text

    fig = _new_figure(10, 3.4)
    axes = fig.subplots(1, 2)
    x = np.arange(len(labels))
    for ax, data, name in ((axes[0], s.error, metric), (axes[1], s.seconds, "seconds")):
        idx = [i for i, d in enumerate(data) if d is not None]
        if idx:
            m = [data[i][0] for i in idx]
            ax.plot(x[idx], m, "o-")
            ax.fill_between(x[idx], [data[i][1] for i in idx], [data[i][2] for i in idx], alpha=0.25)
        ax.set_xticks(x, [_text(label) for label in labels], rotation=30, ha="right", fontsize=7)
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    fig.suptitle(_text(f"{s.scene} {s.size} {s.renderer}: final {s.unit}, mean and 95 % band over seeds"),
                 fontsize=10)
    return _save(fig, path)


def build_history(paths: list[str | os.PathLike], out_dir: str | os.PathLike, *, labels: list[str] | None = None,
                  metric: str = "relmse", progress: bool = False) -> Path:
    """Write the history page of the runs ``paths`` (results.json files, in series order) into ``out_dir``.

    ``labels`` name the runs on the x axis (default: each results.json's folder name). Returns index.html.

    Raises
    ------
    compare.report.results.ResultsError
        For a file that cannot be read, naming it.
    compare.util.errors.OutputError
        For an ``out_dir`` that holds something else than a history page.
    """
    import jinja2
    from tqdm.auto import tqdm

    from compare import __version__
    from compare.util.errors import OutputError

    paths = [Path(p) for p in paths]
    if not paths:
        raise ResultsError("history: no results.json given")
    labels = list(labels) if labels else [p.parent.name or str(p) for p in paths]
    if len(labels) != len(paths):
        raise ResultsError(f"history: {len(labels)} label(s) for {len(paths)} results file(s)")
    runs = [Results.load(p) for p in tqdm(paths, desc="history", unit="run", disable=not progress)]
    out_dir = Path(out_dir)
    if out_dir.exists() and any(out_dir.iterdir()):
        try:
            ours = _MARK in (out_dir / "index.html").read_text(encoding="utf-8")[:2000]
        except (OSError, UnicodeDecodeError):
            ours = False
        if not ours:
            raise OutputError(f"-o {out_dir}: a folder that is not a history page; choose a new or empty folder")
    all_series = series(runs, metric)
    with atomic_folder(out_dir, replace=out_dir.exists()) as tmp:
        (tmp / "static").mkdir()
        shutil.copyfile(_HERE / "report.css", tmp / "static" / "report.css")
        views = []
        for k, s in enumerate(tqdm(all_series, desc="plots", unit="plot", disable=not progress)):
            rel = Path("plots") / f"{k:03d}.png"
            _figure(s, labels, metric, tmp / rel)
            rows = []
            for label, step, e, t in zip(labels, s.step, s.error, s.seconds):
                rows.append([label, "" if step is None else str(step),
                             "" if e is None else f"{e[0]:.4g} [{e[1]:.4g}, {e[2]:.4g}]",
                             "" if t is None else f"{t[0]:.4g} [{t[1]:.4g}, {t[2]:.4g}]"])
            views.append({"title": f"{s.scene} {s.size} {s.label}", "plot": rel.as_posix(), "rows": rows,
                          "unit": s.unit})
        env = jinja2.Environment(loader=jinja2.FileSystemLoader(str(_HERE)), autoescape=True,
                                 undefined=jinja2.StrictUndefined)
        html = env.get_template("history.html.j2").render(version=__version__, metric=metric, views=views,
                                                          runs=list(zip(labels, [str(p) for p in paths])))
        write_text_atomic(tmp / "index.html", html)
    return out_dir / "index.html"
