"""``compare check --baseline``: gate a candidate run against a baseline, with statistics.

Per scene × size × renderer × checkpoint the gate makes three kinds of test
(:mod:`compare.metrics.regression`):

* **error** — is the candidate's error (``relmse`` by default; any metric of
  results.json) larger beyond noise? A t-test on the errors of each side's
  independent runs (``compare run --seeds K``, K >= 2), with the interval of the
  difference: paired by seed where both sides ran the same seeds (the seed's own
  noise cancels: a deterministic renderer's unchanged code differs by nothing, a
  changed one stands out), else Welch's. ``error_test="ztest"`` judges the final checkpoint by the z-test of the
  final images instead (the images differ significantly *and* the mean error grew).
* **image** — did the final image change? The per-pixel (``block`` > 1: per-tile)
  z-test of the two sides' final images with the variances from their seeds (of the
  per-seed differences where the seeds are the same), even
  where the error is no worse (a change that is not a regression is reported, not
  failed, unless ``fail_on_change``).
* **time** — is the candidate slower? Welch's t-test on the repeated timings (each
  seed's cumulative seconds at the checkpoint) *and* a ratio of means of at least
  ``time_ratio`` (1.15, as Babylon.js' performance tests use), so that a tiny but
  significant drift does not fail; "inconclusive" when a side's coefficient of
  variation exceeds ``max_cv`` (the timings are too noisy to judge), and skipped at
  checkpoints shorter than ``min_seconds`` (a few hundred microseconds measure the
  timer, the caches and the scheduler more than the renderer). Timings are
  compared only on the same machine (CPU model, core count and the renderers' device
  facts); a baseline from another one compares errors and images only, and says why.

Every p-value of the run is corrected together (Holm), so that a gate of a candidate
that renders the same images as its baseline fails with probability at most
``alpha`` over all its tests. "Inconclusive" and "skipped" tests take no part and
never fail; a baseline run the candidate lacks fails (a renamed scene or a missing
renderer must not turn the gate green).
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from compare.util.errors import CompareError
from compare.metrics.regression import coefficient_of_variation, holm, image_test, paired, seed_outlier, welch
from compare.report.baseline import Baseline
from compare.report.gate_settings import GateError, GateSettings
from compare.report.results import Machine, RendererRun, Results, SceneResult

__all__ = ["Gate", "GateError", "GateReport", "GateSettings", "machine_difference", "run_gate"]

#: Outcomes that fail the gate (exit status 1).
FAILING = ("regression", "slower", "missing")


@dataclass
class Gate:
    """One test: an error metric, the final image or the time of one scene × size × renderer × checkpoint."""

    scene: str
    size: str
    renderer: str
    step: int | None
    kind: str  # "error", "image", "time" or "missing"
    metric: str
    status: str = "pass"  # pass, regression, slower, changed, inconclusive, skipped, missing
    p: float | None = None
    p_holm: float | None = None
    baseline: float | None = None
    candidate: float | None = None
    low: float | None = None
    high: float | None = None
    ratio: float | None = None
    cv: list[float] | None = None
    note: str = ""
    unit: str = ""
    #: the image test's |z| map (not written to JSON)
    zmap: np.ndarray | None = field(default=None, repr=False)

    @property
    def name(self) -> str:
        """E.g. ``Cornell box 64x48 progressive frame 32: error relmse``."""
        at = f" {self.unit or 'step'} {self.step}" if self.step is not None else ""
        return f"{self.scene} {self.size} {self.renderer}{at}: {self.kind} {self.metric}"

    def failed(self, settings: GateSettings) -> bool:
        """Whether this test fails the gate (a changed image only with ``fail_on_change``)."""
        return self.status in FAILING or (settings.fail_on_change and self.status == "changed")

    def to_json(self) -> dict:
        """JSON-ready dict (without the |z| map; infinities as null)."""
        def finite(v):  # JSON has no infinities (a CV of timings whose mean is 0)
            if isinstance(v, float) and not math.isfinite(v):
                return None
            return [finite(x) for x in v] if isinstance(v, list) else v

        d = asdict(self)
        d.pop("zmap")
        return {k: finite(v) for k, v in d.items()}

    def change(self) -> str:
        """The candidate against the baseline, in words."""
        if self.baseline is None or self.candidate is None:
            return ""
        if self.baseline != 0:
            return f"{100.0 * (self.candidate / self.baseline - 1.0):+.1f} %"
        return f"{self.candidate - self.baseline:+.3g}"


def machine_difference(a: Machine, b: Machine) -> str:
    """Why timings of ``a`` and ``b`` are not comparable ("" for the same machine): the CPU model, the core
    count and the devices the renderers reported (OpenGL, Mitsuba variant, WebGL)."""
    why = []
    if a.cpu != b.cpu:
        why.append(f"CPU {a.cpu!r} vs {b.cpu!r}")
    if a.cores != b.cores:
        why.append(f"{a.cores} vs {b.cores} cores")
    for k in sorted(set(a.facts) & set(b.facts)):
        if a.facts[k] != b.facts[k]:
            why.append(f"{k} {a.facts[k]!r} vs {b.facts[k]!r}")
    return "; ".join(why)


@dataclass
class GateReport:
    """Every test of a gated run, their Holm-corrected verdicts, and what the gate could not compare."""

    settings: GateSettings
    gates: list[Gate]
    machine: str  # "" or why timings were not compared
    notes: list[str]
    candidate: str
    baseline: str

    @property
    def failed(self) -> bool:
        """Whether any test fails the gate (exit status 1)."""
        return any(g.failed(self.settings) for g in self.gates)

    @property
    def verdict(self) -> str:
        """"failed"; "inconclusive" when no test could be judged (every one inconclusive or skipped: a
        gate that judged nothing has not passed); else "passed"."""
        if self.failed:
            return "failed"
        if self.gates and all(g.status in ("inconclusive", "skipped") for g in self.gates):
            return "inconclusive"
        return "passed"

    def count(self, status: str) -> int:
        """How many tests ended with ``status``."""
        return sum(g.status == status for g in self.gates)

    def summary_line(self) -> str:
        """One line: the verdict and the counts."""
        counts = ", ".join(f"{self.count(s)} {s}" for s in ("regression", "slower", "missing", "changed",
                                                             "inconclusive", "skipped", "pass") if self.count(s))
        verdict = "FAILED" if self.failed else self.verdict
        return (f"gate {verdict}: {len(self.gates)} test(s) of {self.candidate} against baseline {self.baseline} "
                f"({counts}; family-wise alpha {self.settings.alpha:g}, Holm)")

    def rows(self) -> list[list[str]]:
        """The table: status, what, baseline, candidate, change, p (Holm), note."""
        out = []
        for g in self.gates:
            out.append([g.status.upper() if g.failed(self.settings) else g.status, g.name,
                        _fmt(g.baseline), _fmt(g.candidate), g.change(),
                        "" if g.p is None else f"{g.p:.2g} ({g.p_holm:.2g})", g.note])
        return out

    def table(self, *, everything: bool = False) -> str:
        """Plain text for the terminal: the failing and notable tests (``everything``: all)."""
        head = ["status", "test", "baseline", "candidate", "change", "p (Holm)", "note"]
        rows = [r for g, r in zip(self.gates, self.rows()) if everything or g.status != "pass"]
        lines = [self.summary_line()]
        if self.machine:
            lines.append(f"timings not compared: the baseline is from another machine ({self.machine})")
        lines += [f"note: {n}" for n in self.notes]
        if rows:
            widths = [max(len(x) for x in col) for col in zip(head, *rows)]
            widths[-1] = 0
            for r in [head] + rows:
                lines.append("  ".join(x.ljust(w) for x, w in zip(r, widths)).rstrip())
        return "\n".join(lines)

    def markdown(self) -> str:
        """Markdown for a CI step summary: the verdict, every test that is not a plain pass, the counts."""
        from compare.util.text import markdown_text as cell  # names come from users' files

        icon = {"failed": "❌", "inconclusive": "⚠️"}.get(self.verdict, "✅")
        out = [f"## {icon} Regression gate", "", cell(self.summary_line()), ""]
        if self.machine:
            out += [f"Timings not compared: the baseline is from another machine ({cell(self.machine)}).", ""]
        out += [f"- {cell(n)}" for n in self.notes]
        rows = [r for g, r in zip(self.gates, self.rows()) if g.status != "pass"]
        if rows:
            out += ["", "| status | test | baseline | candidate | change | p (Holm) | note |",
                    "| --- | --- | ---: | ---: | ---: | ---: | --- |"]
            out += ["| " + " | ".join(cell(x) for x in r) + " |" for r in rows]
        else:
            out += ["", "Every test passed."]
        return "\n".join(out) + "\n"

    def to_json(self) -> dict:
        """JSON-ready: settings, verdict, counts and every test."""
        return {"schema": 1, "failed": self.failed, "verdict": self.verdict, "candidate": self.candidate, "baseline": self.baseline,
                "settings": {**asdict(self.settings), "metrics": list(self.settings.metrics)},
                "machine": self.machine or None, "notes": list(self.notes),
                "counts": {s: self.count(s) for s in ("pass", "regression", "slower", "missing", "changed",
                                                       "inconclusive", "skipped")},
                "gates": [g.to_json() for g in self.gates]}


def _bias_gate(g: Gate, a: np.ndarray, b: np.ndarray, same_seeds: bool, settings: GateSettings) -> Gate:
    """The final images' mean brightness per channel, seed by seed, baseline ``a`` against candidate ``b``
    (seeds, H, W, 3): a renderer made a few % darker or tinted moves every seed's mean by far more than its
    noise, where its error metrics (dominated by the noise) may not reach significance. Two-sided (paired
    by seed where both ran the same seeds), Šidák over the three channels."""
    ma, mb = a.mean(axis=(1, 2)), b.mean(axis=(1, 2))  # (seeds, 3)
    test = paired if same_seeds else welch
    ps, changes = [], []
    for c in range(3):
        up = test(ma[:, c], mb[:, c], level=1.0 - settings.alpha).p  # brighter
        down = test(mb[:, c], ma[:, c], level=1.0 - settings.alpha).p  # darker
        ps.append(min(1.0, 2.0 * min(up, down)))
        base = float(ma[:, c].mean())
        changes.append(float(mb[:, c].mean()) / base - 1.0 if base > 0 else math.inf)
    worst = int(np.argmin(ps))
    g.p = float(-math.expm1(3 * math.log1p(-min(ps[worst], 1.0 - 1e-16))))
    g.baseline, g.candidate = float(ma[:, worst].mean()), float(mb[:, worst].mean())
    g.note = ("mean brightness " + ", ".join(f"{'RGB'[c]} {100 * changes[c]:+.2f} %" for c in range(3))
              + f" ({'paired by seed' if same_seeds else 'Welch'})")
    return g


def _fmt(v: float | None) -> str:
    return "" if v is None else f"{v:.4g}"


def _candidate_images(run: RendererRun, folder: Path, what: str) -> np.ndarray:
    from compare.image.exr import read_exr

    images = []
    for s in run.per_seed():
        if s.image is None:
            raise GateError(f"{what}: seed {s.seed} has no final image in results.json")
        try:
            images.append(read_exr(folder / s.image)[0])
        except CompareError as e:
            raise GateError(f"{what}: {e}") from e
    return np.stack(images)


def _values(seeds, step: int, metric: str) -> list[float | None]:
    out = []
    for s in seeds:
        p = s.at(step)
        if p is None:
            out.append(None)
        elif metric == "seconds":
            out.append(float(p["seconds"]))
        else:
            v = p["metrics"].get(metric)
            out.append(None if v is None else float(v))
    return out


def _compare_runs(scene: SceneResult, base: RendererRun, cand: RendererRun, baseline: Baseline,
                  cand_dir: Path, settings: GateSettings, timings: bool, machine: str, notes: list[str]) -> list[Gate]:
    gates: list[Gate] = []
    bs, cs = base.per_seed(), cand.per_seed()
    steps_b, steps_c = [p.step for p in base.points], [p.step for p in cand.points]
    steps = [s for s in steps_c if s in steps_b]
    what = f"{scene.name} {scene.size} {cand.renderer}"
    lost = [s for s in steps_b if s not in steps_c]
    if lost:
        notes.append(f"{what}: checkpoints {lost} of the baseline are not in the candidate")
    if not steps:
        return [Gate(scene.name, scene.size, cand.renderer, None, "missing", "checkpoints", status="missing",
                     note=f"no checkpoint in common (baseline {steps_b}, candidate {steps_c})")]
    final = base.final.step if base.final.step == cand.final.step else None
    if final is None:
        notes.append(f"{what}: the final checkpoints differ ({base.unit} {base.final.step} in the baseline, "
                     f"{cand.final.step} in the candidate): final images not compared")
    same_seeds = len(bs) >= 2 and [s.seed for s in bs] == [s.seed for s in cs]
    one_seed = (f"{len(bs)} seed(s) in the baseline, {len(cs)} in the candidate: the noise of a side needs "
                "`compare run --seeds 2` or more")

    def gate(step, kind, metric, **kw) -> Gate:
        return Gate(scene.name, scene.size, cand.renderer, step, kind, metric, unit=cand.unit, **kw)

    image = None
    if final is not None:
        g = gate(final, "image", "final image")
        brun = baseline.run(scene.name, scene.size, cand.renderer)
        if brun is None:
            g.status, g.note = "inconclusive", "the baseline keeps no final images of this run"
        elif len(bs) < 2 or len(cs) < 2 or len(brun.images) < 2:
            g.status, g.note = "inconclusive", one_seed
        elif brun.seeds != [s.seed for s in bs]:
            g.status, g.note = "inconclusive", "the baseline's images are not those of its results.json's seeds"
        else:
            a, b = baseline.images(brun), _candidate_images(cand, cand_dir, what)
            if a.shape[1:] != b.shape[1:]:
                g.status, g.note = "inconclusive", f"image sizes differ ({a.shape[1:3]} vs {b.shape[1:3]})"
            elif settings.block > min(a.shape[1:3]):
                raise GateError(f"--block {settings.block} is larger than the {a.shape[2]}x{a.shape[1]} image")
            else:
                image = image_test(a, b, block=settings.block, pair=same_seeds)
                y, x, c = image.worst
                tile = "tile" if settings.block > 1 else "pixel"
                g.p, g.zmap = image.p, image.z
                g.note = (f"{image.values} values{f' ({settings.block}x{settings.block} tiles)' if settings.block > 1 else ''}"
                          f", largest |z| {image.max_abs_z:.3g} at {tile} ({x}, {y}) {'RGB'[c]}"
                          f"{', paired by seed' if same_seeds else ''}")
                gates.append(_bias_gate(gate(final, "bias", "mean per channel"), a, b, same_seeds, settings))
        gates.append(g)
    for step in steps:
        for metric in settings.metrics:
            g = gate(step, "error", metric)
            vb, vc = _values(bs, step, metric), _values(cs, step, metric)
            if any(v is None for v in vb + vc):
                g.status, g.note = "inconclusive", f"{metric} is missing or null at this checkpoint"
            elif settings.error_test == "ztest" and step == final:
                g.baseline, g.candidate = float(np.mean(vb)), float(np.mean(vc))
                if image is None:
                    g.status, g.note = "inconclusive", "no image z-test (see the image test)"
                else:
                    g.p = image.p if g.candidate > g.baseline else 1.0
                    g.note = "z-test of the final images; the error grew" if g.candidate > g.baseline else \
                        "the error did not grow"
            elif len(vb) < 2 or len(vc) < 2:
                g.status, g.note = "inconclusive", one_seed
                g.baseline, g.candidate = float(np.mean(vb)), float(np.mean(vc))
            else:
                test = paired if same_seeds else welch
                w = test(vb, vc, level=1.0 - settings.alpha)
                g.p, g.baseline, g.candidate, g.low, g.high = w.p, w.baseline_mean, w.candidate_mean, w.low, w.high
                how = f"paired by {len(vb)} seeds" if same_seeds else f"Welch, seeds {len(vb)} vs {len(vc)}"
                g.note = (f"difference {w.diff:+.3g}, {100 * (1 - settings.alpha):g} % interval "
                          f"[{w.low:+.3g}, {w.high:+.3g}] ({how})")
                # beside the means: one seed far above the baseline's spread (broken seeds widen the
                # candidate's own spread as much as they move its mean, which hides them from the t-tests)
                o = seed_outlier(vb, vc)
                s_gate = gate(step, "seed", metric, p=o.p, baseline=float(np.max(vb)), candidate=float(vc[o.worst]))
                s_gate.note = (f"worst seed {cs[o.worst].seed}: {o.t:.3g} prediction-interval units above the "
                               f"baseline's {len(vb)} seeds")
                gates.append(g)
                gates.append(s_gate)
                continue
            gates.append(g)
        g = gate(step, "time", "seconds")
        tb, tc = _values(bs, step, "seconds"), _values(cs, step, "seconds")
        if not timings:
            g.status, g.note = "skipped", f"baseline from another machine ({machine})"
        elif any(v is None for v in tb + tc):
            g.status, g.note = "inconclusive", "a seed has no time at this checkpoint"
        elif len(tb) < 2 or len(tc) < 2:
            g.status, g.note = "inconclusive", one_seed
            g.baseline, g.candidate = float(np.mean(tb)), float(np.mean(tc))
        else:
            g.baseline, g.candidate = float(np.mean(tb)), float(np.mean(tc))
            g.cv = [coefficient_of_variation(tb), coefficient_of_variation(tc)]
            g.ratio = None if g.baseline <= 0 else g.candidate / g.baseline
            if max(g.baseline, g.candidate) < settings.min_seconds:
                g.status = "skipped"
                g.note = f"shorter than {settings.min_seconds:g} s, which measures the timer more than the renderer"
            elif max(g.cv) > settings.max_cv:
                g.status = "inconclusive"
                g.note = (f"timings too noisy to judge: coefficient of variation {g.cv[0]:.2f} (baseline), "
                          f"{g.cv[1]:.2f} (candidate) > {settings.max_cv:g}")
            else:
                w = welch(tb, tc, level=1.0 - settings.alpha)
                g.p, g.low, g.high = w.p, w.low, w.high
                ratio = "n/a" if g.ratio is None else f"{g.ratio:.3f}"
                g.note = f"ratio {ratio} (fails at >= {settings.time_ratio:g} when significant), CV " \
                         f"{g.cv[0]:.3f} / {g.cv[1]:.3f}"
        gates.append(g)
    return gates


def run_gate(candidate: str | os.PathLike, baseline: str | os.PathLike | Baseline,
             settings: GateSettings | None = None, *, progress: bool = False) -> GateReport:
    """Gate the run ``candidate`` (its results.json) against ``baseline`` (a baseline folder).

    Raises
    ------
    compare.report.results.ResultsError, compare.report.baseline.BaselineError, GateError
        For a missing or malformed file, naming it and the field.
    """
    from tqdm.auto import tqdm

    settings = settings or GateSettings()
    cand_path = Path(candidate)
    res = Results.load(cand_path)
    base = baseline if isinstance(baseline, Baseline) else Baseline.load(baseline)
    machine = machine_difference(base.machine, res.machine)
    notes: list[str] = []
    gates: list[Gate] = []
    cand_scenes = {(s.name, s.size): s for s in res.scenes}
    pairs = []
    for bscene in base.results.scenes:
        cscene = cand_scenes.get((bscene.name, bscene.size))
        for brun in bscene.runs:
            crun = None if cscene is None else cscene.run(brun.renderer)
            if crun is None:
                gates.append(Gate(bscene.name, bscene.size, brun.renderer, None, "missing", "run", status="missing",
                                  note="in the baseline, not in the candidate (renamed scene or renderer left out?)"))
            else:
                pairs.append((cscene, brun, crun))
        if cscene is not None:
            if cscene.hash != bscene.hash:
                notes.append(f"{bscene.name} {bscene.size}: the scene's content changed since the baseline")
            if cscene.reference.key and bscene.reference.key and cscene.reference.key != bscene.reference.key:
                notes.append(f"{bscene.name} {bscene.size}: the ground truth differs from the baseline's: errors "
                             "are measured against another image")
            for crun in cscene.runs:
                if bscene.run(crun.renderer) is None:
                    notes.append(f"{bscene.name} {bscene.size} {crun.renderer}: new, not in the baseline")
    base_scenes = {(s.name, s.size) for s in base.results.scenes}
    for s in res.scenes:
        if (s.name, s.size) not in base_scenes:
            notes.append(f"{s.name} {s.size}: new, not in the baseline")
    for cscene, brun, crun in tqdm(pairs, desc="gate", unit="run", disable=not progress):
        gates += _compare_runs(cscene, brun, crun, base, cand_path.parent, settings, not machine, machine, notes)
    tested = [g for g in gates if g.p is not None]
    for g, adj in zip(tested, holm([g.p for g in tested])):
        g.p_holm = adj
        significant = adj <= settings.alpha
        if g.kind in ("error", "seed", "bias"):
            g.status = "regression" if significant else "pass"
        elif g.kind == "image":
            g.status = "changed" if significant else "pass"
        elif g.kind == "time":
            slow = significant and g.ratio is not None and g.ratio >= settings.time_ratio
            g.status = "slower" if slow else "pass"
            if significant and not slow:
                g.note += "; significantly different but within the ratio bound"
    return GateReport(settings=settings, gates=gates, machine=machine, notes=notes, candidate=str(cand_path),
                      baseline=str(base.root))
