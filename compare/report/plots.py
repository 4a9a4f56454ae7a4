"""Error-against-time figures and the equal-time / equal-error analysis behind them.

Figures are drawn with matplotlib's object-oriented API on an Agg canvas
(:class:`matplotlib.figure.Figure` + ``FigureCanvasAgg``), never through
``pyplot``: no global backend is switched, nothing needs a display, and a
figure is freed as soon as it is saved.

Every curve is a :class:`compare.report.results.RendererRun`'s checkpoints; every
interpolated number comes from :meth:`RendererRun.error_at` (equal time) or
:meth:`RendererRun.seconds_to` (equal error), which interpolate on log–log axes
and never extrapolate. The tables in the HTML report show the same numbers as
the figures because both call :func:`equal_time` and :func:`equal_error`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from compare.util.files import atomic_path
from compare.report.results import Results, SceneResult, metric_value

__all__ = [
    "PLOT_METRICS",
    "Comparison",
    "bias_figure",
    "equal_error",
    "equal_time",
    "error_figure",
    "equal_figure",
    "make_plots",
]

#: Metrics drawn against time: (key for :func:`compare.report.results.metric_value`, axis label).
#: All are errors (lower is better); SSIM appears as 1 − SSIM so every curve falls.
PLOT_METRICS: tuple[tuple[str, str], ...] = (
    ("flip", "FLIP (LDR)"),
    ("one_minus_ssim", "1 − SSIM"),
    ("relmse", "relMSE"),
)

_STYLES = ("o-", "s-", "^-", "D-", "v-", "P-")


#: The most characters of a user's name (a scene's, a renderer's label) a plot shows; results.json keeps it whole.
MAX_TEXT = 80


def _short(name: str) -> str:
    """A user's name shortened to :data:`MAX_TEXT` characters for a plot."""
    return name if len(name) <= MAX_TEXT else name[:MAX_TEXT - 1] + "…"


def _text(s: str) -> str:
    """User text for matplotlib: at most :data:`MAX_TEXT` characters (a 100 kB scene name would take
    matplotlib's layout seconds to minutes), and '$', which would start mathtext, escaped."""
    return _short(s).replace("$", r"\$") if len(s) > 2 * MAX_TEXT else s.replace("$", r"\$")


@dataclass
class Comparison:
    """One row of an equal-time or equal-error table.

    Attributes
    ----------
    target : float
        The time budget (equal time, seconds) or the error level (equal error).
    source : str
        Which run's final checkpoint set the target (its renderer spec).
    values : dict
        Renderer spec → error reached in ``target`` seconds (equal time) or
        seconds needed to reach ``target`` (equal error); None where the run
        had no image yet (equal time) or never reached the error (equal error).
    finished : set of str
        Equal time only: runs that had finished their whole budget before
        ``target``; their value is their final error.
    """

    target: float
    source: str
    values: dict[str, float | None]
    finished: frozenset[str] = frozenset()


def equal_time(scene: SceneResult, metric: str) -> list[Comparison]:
    """Error every run reaches within each run's own total time.

    One row per run ``r`` with budget ``t = r.seconds``; the value for run
    ``q`` is ``q.error_at(t, metric, hold=True)``: a run that finished its
    budget before ``t`` keeps its final image and is listed in
    :attr:`Comparison.finished`; a run with no image yet by ``t`` gets None.
    """
    rows = []
    for r in scene.runs:
        t = r.seconds
        values = {q.renderer: q.error_at(t, metric, hold=True) for q in scene.runs}
        done = frozenset(q.renderer for q in scene.runs if q.points and q.seconds < t)
        rows.append(Comparison(t, r.renderer, values, done))
    return rows


def equal_error(scene: SceneResult, metric: str) -> list[Comparison]:
    """Seconds every run needs to reach each run's own final error.

    One row per run ``r`` with target ``e = metric of r's last checkpoint``;
    the value for run ``q`` is ``q.seconds_to(e, metric)``.
    """
    rows = []
    for r in scene.runs:
        e = metric_value(r.final.metrics, metric) if r.points else None
        if e is None:
            continue
        rows.append(Comparison(e, r.renderer, {q.renderer: q.seconds_to(e, metric) for q in scene.runs}))
    return rows


def _new_figure(width: float, height: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path, suffix=path.suffix) as tmp:
        # No "Software"/date metadata: identical results give identical files.
        meta = {"Software": None} if path.suffix == ".png" else {"Date": None, "Creator": None}
        fig.savefig(tmp, format=path.suffix.lstrip("."), metadata=meta)
    return path


def error_figure(scene: SceneResult, path: str | Path) -> Path:
    """Error against seconds on log–log axes, one panel per metric of :data:`PLOT_METRICS`.

    Every run of the scene is one line (markers at the checkpoints). The
    reference's noise floor is a dotted horizontal line, the ground truth's
    render time a dotted vertical one.
    """
    path = Path(path)
    fig = _new_figure(4.2 * len(PLOT_METRICS), 3.6)
    axes = fig.subplots(1, len(PLOT_METRICS), squeeze=False)[0]
    for ax, (metric, label) in zip(axes, PLOT_METRICS):
        drawn = False
        for k, run in enumerate(scene.runs):
            pts = [(t, e) for t, e in run.curve(metric) if e > 0]
            if not pts:
                continue
            ts, es = zip(*pts)
            ax.plot(ts, es, _STYLES[k % len(_STYLES)], ms=4, lw=1.4, label=_text(run.label))
            drawn = True
        nf = metric_value(scene.noise_floor.metrics, metric) if scene.noise_floor else None
        if nf is not None and nf > 0:
            ax.axhline(nf, color="0.35", ls=":", lw=1.2, label=f"noise floor ({scene.noise_floor.spp} spp vs itself)")
        if scene.reference.seconds > 0:
            ax.axvline(scene.reference.seconds, color="0.6", ls="--", lw=0.9,
                       label=f"ground truth time ({scene.reference.spp} spp)")
        if drawn:
            ax.set_xscale("log")
            ax.set_yscale("log")
        ax.set_xlabel("seconds (cumulative)")
        ax.set_ylabel(label)
        ax.set_title(label)
        ax.grid(True, which="both", alpha=0.25)
    axes[0].legend(fontsize=7, loc="best")
    fig.suptitle(_text(f"{_short(scene.name)} — {scene.size}: error against time"), fontsize=11)
    _save(fig, path)
    return path


def equal_figure(scene: SceneResult, path: str | Path, metric: str = "flip") -> Path:
    """Equal-time and equal-error bar charts for one metric.

    Left: the error each run reaches within each run's total time. Right: the
    seconds each run needs to reach each run's final error. A missing bar
    means "not reached within the measured checkpoints" and is labelled so.
    """
    path = Path(path)
    label = dict(PLOT_METRICS).get(metric, metric)
    n = max(1, len(scene.runs))
    crowded = n > 4  # n × n bars a panel: stack the panels, drop the value labels (the tables hold them)
    if crowded:
        fig = _new_figure(max(11.0, 1.9 * n), 8.6)
        left, right = fig.subplots(2, 1)
    else:
        fig = _new_figure(11, 4.2)
        left, right = fig.subplots(1, 2)
    panels = (
        (left, equal_time(scene, metric), label, "time of", lambda v: f"{v:.3g} s", "no image\nyet"),
        (right, equal_error(scene, metric), "seconds", "final error of", lambda v: f"{v:.3g}", "not\nreached"),
    )
    for ax, rows, ylabel, prefix, fmt, missing_text in panels:
        width = 0.8 / n
        drawn = False
        for k, run in enumerate(scene.runs):
            xs, hs, hatch, missing = [], [], [], []
            for i, row in enumerate(rows):
                v = row.values.get(run.renderer)
                x = i + (k - (n - 1) / 2) * width
                if v is None or v <= 0:
                    missing.append(x)
                else:
                    xs.append(x)
                    hs.append(v)
                    hatch.append("//" if run.renderer in row.finished else "")
            bars = ax.bar(xs, hs, width=width * 0.95, color=f"C{k}", alpha=0.9)
            drawn = drawn or bool(hs)
            for bar, h in zip(bars, hatch):
                bar.set_hatch(h)
            if not crowded:
                ax.bar_label(bars, fmt="%.3g", fontsize=7, padding=1)
            for x in missing:
                ax.annotate("×" if crowded else missing_text, (x, 0), xycoords=("data", "axes fraction"),
                            xytext=(0, 4), textcoords="offset points", ha="center", va="bottom",
                            fontsize=8 if crowded else 6, color=f"C{k}")
        gap = "\n" if crowded else " "
        ax.set_xticks(range(len(rows)), [_text(f"{prefix}{gap}{r.source}\n({fmt(r.target)})") for r in rows],
                      fontsize=7)
        if drawn:  # a log axis needs a positive value (none: the metric is undefined, e.g. a black ground truth)
            ax.set_yscale("log")
        ax.set_ylabel(ylabel)
        ax.margins(y=0.15)
        ax.grid(True, axis="y", which="both", alpha=0.25)
    left.set_title(f"Equal time: {label} within each run's total time\n(hatched: finished earlier, final image)",
                   fontsize=9)
    right.set_title(f"Equal error: seconds to reach each run's final {label}"
                    + (" (×: not reached)" if crowded else ""), fontsize=9)
    if crowded:
        left.set_title(left.get_title().replace("final image)", "final image; ×: no image yet)"), fontsize=9)
    if scene.runs:
        from matplotlib.patches import Patch

        # Explicit handles: the first bar of a series may be hatched, which must not define its legend entry.
        handles = [Patch(color=f"C{k}", label=_text(run.label)) for k, run in enumerate(scene.runs)]
        fig.legend(handles=handles, loc="outside lower center", ncols=min(len(scene.runs), 3), fontsize=8)
    fig.suptitle(_text(f"{_short(scene.name)} — {scene.size}"), fontsize=11)
    _save(fig, path)
    return path


def bias_figure(scene: SceneResult, path: str | Path) -> Path | None:
    """Squared bias (with its 95 % interval) and variance beside the relMSE, against seconds, one
    panel per run that has the split (``settings.seeds`` >= 2, :mod:`compare.metrics.bias`); None if none has."""
    runs = [r for r in scene.runs if any("rel_bias2" in p.metrics for p in r.points)]
    if not runs:
        return None
    path = Path(path)
    fig = _new_figure(4.2 * len(runs), 3.6)
    axes = fig.subplots(1, len(runs), squeeze=False)[0]
    for ax, run in zip(axes, runs):
        pts = [p for p in run.points if "rel_bias2" in p.metrics and p.seconds > 0]
        ts = [p.seconds for p in pts]
        mse = [p.metrics["relmse_mean"] for p in pts]
        var = [p.metrics["rel_variance"] for p in pts]
        b2 = [p.metrics["rel_bias2"] for p in pts]
        ci = [p.metrics["rel_bias2_ci"] or 0.0 for p in pts]  # None: no interval (a single pixel)
        ax.plot(ts, mse, "o-", ms=4, lw=1.4, label="relMSE")
        ax.plot(ts, var, "s--", ms=3, lw=1.2, label="variance (noise)")
        # A log axis shows no zero or negative estimate: those sit on a floor a hundredth of the
        # smallest variance, hollow when the interval holds 0 (no bias found), filled when biased.
        floor = 0.01 * min([v for v in var + mse if v > 0] or [1e-12])
        ax.plot(ts, [max(b, floor) for b in b2], "-", color="C2", lw=1.4, label="bias²")
        found = [b - c > 0 for b, c in zip(b2, ci)]
        ax.plot([t for t, f in zip(ts, found) if f], [b for b, f in zip(b2, found) if f], "^", color="C2", ms=5)
        ax.plot([t for t, f in zip(ts, found) if not f], [max(b, floor) for b, f in zip(b2, found) if not f], "^",
                mfc="none", color="C2", ms=5, label="bias² within its interval of 0")
        lo = [max(b - c, floor) for b, c in zip(b2, ci)]
        hi = [max(b + c, floor) for b, c in zip(b2, ci)]
        ax.fill_between(ts, lo, hi, alpha=0.2, color="C2", label="bias² 95 % interval")
        ax.set_xscale("log")
        ax.set_yscale("log")
        from matplotlib.ticker import NullFormatter

        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("seconds (cumulative)")
        ax.set_ylabel("relMSE")
        ax.set_title(_text(f"{run.label} ({pts[0].metrics.get('seeds', '')} seeds)" if pts else run.label),
                     fontsize=9)
        ax.grid(True, which="both", alpha=0.25)
    axes[0].legend(fontsize=7, loc="best")
    fig.suptitle(_text(f"{_short(scene.name)} — {scene.size}: bias against noise"), fontsize=11)
    _save(fig, path)
    return path


def make_plots(results: Results, out_dir: str | Path, *, fmt: str = "png") -> dict[str, dict[str, Path]]:
    """Draw every figure of a result set.

    Parameters
    ----------
    results : Results
        The run's results.
    out_dir : path
        Folder for the figures (created).
    fmt : {"png", "svg"}, optional
        File format.

    Returns
    -------
    dict
        Scene id → ``{"error": path, "equal": path}``, and ``"bias"`` where a run has the
        bias/variance split.
    """
    if fmt not in ("png", "svg"):
        raise ValueError(f"fmt: expected 'png' or 'svg', got {fmt!r}")
    out_dir = Path(out_dir)
    made: dict[str, dict[str, Path]] = {}
    for scene in results.scenes:
        made[scene.id] = {
            "error": error_figure(scene, out_dir / f"{scene.id}-error.{fmt}"),
            "equal": equal_figure(scene, out_dir / f"{scene.id}-equal.{fmt}"),
        }
        bias = bias_figure(scene, out_dir / f"{scene.id}-bias.{fmt}")
        if bias is not None:
            made[scene.id]["bias"] = bias
    return made
