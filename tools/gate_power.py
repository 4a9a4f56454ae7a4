"""Measure the regression gate (``compare check --baseline``) on the Cornell box: its false-alarm rate over
pairs of same-code runs, and its power: the smallest brightness change and slowdown it detects.

    python -m tools.gate_power --pairs 20 --seeds 5 --size 64x48 --frames 32 --spp 256 -o /tmp/gate-power

Every run renders the Cornell box with the progressive rasterizer (its defaults) through a wrapper that
offsets the seeds by a per-run salt (so that two runs of the same code have independent noise, as two
CI runs of a renderer whose noise is not reproducible would; with equal seeds a deterministic renderer
repeats itself exactly and the error and image tests cannot raise a false alarm at all) and, for the
power sweep, multiplies the images by a brightness factor. Pair i is two independent runs, a baseline
and a candidate, rendered one after the other; the ground truth (Mitsuba) is one cached render.

* false alarms: the gate of candidate i against baseline i, at the gate's defaults, for every pair;
* brightness: candidate i re-rendered with its seeds and the images times b (the same noise: common
  random numbers over the sweep), gated against baseline i;
* slowdown: candidate i's timings (every seed's, at every checkpoint) times s, gated against baseline i.

Prints a table and writes ``power.json`` into the output folder.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from compare.renderers import Checkpoint, Registry, Renderer, Rendering
from compare.report.baseline import save_baseline
from compare.report.gate import GateSettings, run_gate
from compare.report.results import Results, RunSettings

ROOT = Path(__file__).resolve().parent.parent
NAME = "under-test"


class UnderTest(Renderer):
    """The progressive rasterizer, seeds offset by ``salt``, images times ``brightness``."""

    name = NAME
    label = "Progressive (under test)"
    unit = "frame"
    default_budget = "frames"
    portable = False
    _memo: dict = {}

    def __init__(self, brightness: float = 1.0, salt: int = 0):
        self.inner = Registry().get("progressive")
        self.brightness, self.salt = float(brightness), int(salt)

    def checkpoints(self, steps):
        return self.inner.checkpoints(steps)

    def key(self, scene, settings):
        return [NAME, self.inner.key(scene, settings), self.brightness, self.salt]

    def render(self, scene, *, steps, checkpoints, seed, context):
        seed = seed + 104729 * self.salt
        memo = (scene.hash, steps, tuple(checkpoints), seed)
        if memo not in self._memo:  # a brightness sweep reuses the render (and its measured times)
            self._memo.clear()
            self._memo[memo] = self.inner.render(scene, steps=steps, checkpoints=checkpoints, seed=seed,
                                                 context=context)
        r = self._memo[memo]
        return Rendering([Checkpoint(c.step, c.seconds, (c.image * self.brightness).astype(np.float32))
                          for c in r.checkpoints], r.setup_seconds, dict(r.metadata))


def _run(out: Path, settings: RunSettings, cache: Path, gl_ctx, **kw) -> Path:
    from compare.run.runner import run

    run([ROOT / "scenes" / "cornell.toml"], out, settings, progress=False, report=False, cache_dir=cache,
        gl_ctx=gl_ctx, renderers=[UnderTest(**kw)])
    return out / "results.json"


def _slowed(results: Path, factor: float) -> Path:
    """A copy of ``results`` beside it with every timing times ``factor``."""
    res = Results.load(results)
    for scene in res.scenes:
        for run in scene.runs:
            for p in run.points:
                p.seconds *= factor
            for s in run.seed_runs:
                for p in s.points:
                    p["seconds"] *= factor
    return res.save(results.parent / f"results-slow{factor:g}.json")


def _verdict(report, kind: str) -> bool:
    bad = {"error": "regression", "image": "changed", "time": "slower"}[kind]
    return any(g.kind == kind and g.status == bad for g in report.gates)


def main() -> None:
    from compare.progressive.context import create_context

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=20)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--size", default="64x48")
    ap.add_argument("--frames", type=int, default=32)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--brightness", default="0.999,0.998,0.995,0.99,0.98,0.95")
    ap.add_argument("--slowdown", default="1.05,1.1,1.15,1.2,1.25,1.3,1.5")
    ap.add_argument("-o", "--output", type=Path, required=True)
    args = ap.parse_args()
    w, h = (int(x) for x in args.size.split("x"))
    settings = RunSettings(frames=args.frames, spp=args.spp, sizes=[[w, h]], renderers=[NAME], seeds=args.seeds,
                           likeness=False)
    gate = GateSettings()
    brights = [float(x) for x in args.brightness.split(",")]
    slows = [float(x) for x in args.slowdown.split(",")]
    out, cache = args.output, args.output / "cache"
    gl_ctx = create_context()
    rows = {"false_alarm": [], "false_alarm_kinds": {"error": 0, "image": 0, "time": 0}, "inconclusive_time": 0,
            "brightness": {b: {"error": 0, "image": 0} for b in brights}, "slowdown": {s: 0 for s in slows}}
    t0 = time.time()
    for i in range(args.pairs):
        base = _run(out / f"pair{i:02d}" / "baseline", settings, cache, gl_ctx, salt=2 * i + 1)
        bl_dir = out / f"pair{i:02d}" / "baseline-folder"
        if not bl_dir.exists():
            save_baseline(base, bl_dir)
        cand = _run(out / f"pair{i:02d}" / "candidate", settings, cache, gl_ctx, salt=2 * i + 2)
        rep = run_gate(cand, bl_dir, gate)
        rows["false_alarm"].append(rep.failed)
        for kind in ("error", "image", "time"):
            rows["false_alarm_kinds"][kind] += _verdict(rep, kind)
        rows["inconclusive_time"] += any(g.kind == "time" and g.status == "inconclusive" for g in rep.gates)
        for b in brights:
            res = _run(out / f"pair{i:02d}" / f"bright{b:g}", settings, cache, gl_ctx, salt=2 * i + 2, brightness=b)
            r = run_gate(res, bl_dir, gate)
            rows["brightness"][b]["error"] += _verdict(r, "error")
            rows["brightness"][b]["image"] += _verdict(r, "image")
        for s in slows:
            rows["slowdown"][s] += _verdict(run_gate(_slowed(cand, s), bl_dir, gate), "time")
        print(f"pair {i + 1}/{args.pairs}: false alarm {rep.failed} "
              f"({', '.join(g.name + ' ' + g.status for g in rep.gates if g.failed(gate))}); "
              f"{time.time() - t0:.0f} s", flush=True)
    n = args.pairs
    fa = sum(rows["false_alarm"])
    from scipy.stats import beta

    upper = float(beta.ppf(0.95, fa + 1, n - fa)) if fa < n else 1.0  # one-sided 95 % Clopper-Pearson bound
    summary = {"settings": {**dataclasses.asdict(settings), "gate": {**dataclasses.asdict(gate),
                                                                     "metrics": list(gate.metrics)}},
               "pairs": n, "false_alarms": fa, "false_alarm_rate": fa / n, "false_alarm_upper95": upper,
               "false_alarms_by_kind": rows["false_alarm_kinds"], "pairs_with_inconclusive_time": rows["inconclusive_time"],
               "brightness": {f"{b:g}": {k: v / n for k, v in d.items()} for b, d in rows["brightness"].items()},
               "slowdown": {f"{s:g}": v / n for s, v in rows["slowdown"].items()}}
    (out / "power.json").write_text(json.dumps(summary, indent=1))
    print(f"false alarms: {fa} of {n} pairs (rate {fa / n:.3f}, one-sided 95 % upper bound {upper:.3f}; "
          f"level {gate.alpha:g}); by kind {rows['false_alarm_kinds']}; pairs with inconclusive timings "
          f"{rows['inconclusive_time']}")
    for b, d in summary["brightness"].items():
        print(f"brightness x{b}: error gate detects {d['error']:.0%}, image gate {d['image']:.0%}")
    for s, v in summary["slowdown"].items():
        print(f"slowdown x{s}: time gate detects {v:.0%}")


if __name__ == "__main__":
    main()
