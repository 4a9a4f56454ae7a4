"""Measure the regression gate (``compare check --baseline``) on the Cornell box: its false-alarm rate over
pairs of same-code runs, and its power: the smallest brightness change and slowdown it detects.

    python -m tools.gate_power --pairs 24 --sweep-pairs 8 --seeds 5 --size 64x48 --frames 32 --spp 256 -o OUT

Every run renders the Cornell box with the progressive rasterizer (its defaults) through a wrapper that
can offset the seeds by a salt and multiply the images by a brightness factor; the gate runs at its
defaults (``GateSettings()``). Pair i is two runs rendered one after the other, a baseline (salt 2i+1)
and a candidate of the same code (salt 2i+2: noise independent of the baseline's, as two CI runs of a
renderer whose noise is not reproducible would have; the gate still pairs them by their recorded seeds,
which is valid, not more powerful); the ground truth (Mitsuba) is one cached render.

* false alarms: candidate i against baseline i, every pair; pair 0 also reruns the baseline's seeds
  (a deterministic renderer must repeat itself exactly);
* brightness, same seeds (what CI does: the code changed, the seeds did not): baseline i's renders times
  b, gated against baseline i, on the first ``--sweep-pairs`` pairs;
* brightness, independent noise: candidate i's renders times b, gated against baseline i;
* slowdown: candidate i's timings (every seed's, at every checkpoint) times s, every pair.

Prints a table and writes ``power.json`` into the output folder.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from compare.renderers import Checkpoint, Renderer, Rendering

from compare.renderers.registry import Registry
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

    def __init__(self, brightness: float = 1.0, salt: int = 0, fresh: bool = False, tag: str = ""):
        self.inner = Registry().get("progressive")
        self.brightness, self.salt, self.fresh, self.tag = float(brightness), int(salt), fresh, tag

    def checkpoints(self, steps):
        return self.inner.checkpoints(steps)

    def key(self, scene, settings):
        return [NAME, self.inner.key(scene, settings), self.brightness, self.salt, self.tag]

    def render(self, scene, *, steps, checkpoints, seed, context):
        seed = seed + 104729 * self.salt
        memo = (self.salt, scene.hash, steps, tuple(checkpoints), seed)
        if self.fresh or memo not in self._memo:  # a brightness sweep reuses the renders (and their times)
            if self.fresh or any(k[:4] != memo[:4] for k in self._memo):
                self._memo.clear()  # keep the renders of one salt only
            r = self.inner.render(scene, steps=steps, checkpoints=checkpoints, seed=seed, context=context)
            if not self.fresh:
                self._memo[memo] = r
        else:
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
    from compare.progressive.gl.context import create_context

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=24)
    ap.add_argument("--sweep-pairs", type=int, default=8)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--size", default="64x48")
    ap.add_argument("--frames", type=int, default=32)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--same-seed-brightness", default="0.9999,0.999,0.995,0.99")
    ap.add_argument("--brightness", default="0.99,0.98,0.95,0.9")
    ap.add_argument("--slowdown", default="1.1,1.15,1.2,1.3,1.5,2")
    ap.add_argument("-o", "--output", type=Path, required=True)
    args = ap.parse_args()
    w, h = (int(x) for x in args.size.split("x"))
    settings = RunSettings(frames=args.frames, spp=args.spp, sizes=[[w, h]], renderers=[NAME], seeds=args.seeds,
                           likeness=False)
    gate = GateSettings()
    same_b = [float(x) for x in args.same_seed_brightness.split(",")]
    ind_b = [float(x) for x in args.brightness.split(",")]
    slows = [float(x) for x in args.slowdown.split(",")]
    out, cache = args.output, args.output / "cache"
    gl_ctx = create_context()
    n, m = args.pairs, min(args.sweep_pairs, args.pairs)
    alarms, kinds, inconclusive, rerun = [], {"error": 0, "image": 0, "time": 0}, 0, None
    same = {b: {"error": 0, "image": 0} for b in same_b}
    ind = {b: {"error": 0, "image": 0} for b in ind_b}
    slow = {s: 0 for s in slows}
    t0 = time.time()
    for i in range(n):
        d = out / f"pair{i:02d}"
        base = _run(d / "baseline", settings, cache, gl_ctx, salt=2 * i + 1)
        if not (d / "baseline-folder").exists():
            save_baseline(base, d / "baseline-folder")
        bl = d / "baseline-folder"
        if i < m:
            for b in same_b:
                r = run_gate(_run(d / f"same-seeds-x{b:g}", settings, cache, gl_ctx, salt=2 * i + 1, brightness=b),
                             bl, gate)
                same[b]["error"] += _verdict(r, "error")
                same[b]["image"] += _verdict(r, "image")
        if i == 0:
            r = run_gate(_run(d / "rerun", settings, cache, gl_ctx, salt=1, fresh=True, tag="rerun"), bl, gate)
            rerun = {"failed": r.failed, "error_image_p": sorted({g.p for g in r.gates if g.kind != "time"}),
                     "time": [g.status for g in r.gates if g.kind == "time"]}
        cand = _run(d / "candidate", settings, cache, gl_ctx, salt=2 * i + 2)
        rep = run_gate(cand, bl, gate)
        alarms.append(rep.failed)
        for kind in kinds:
            kinds[kind] += _verdict(rep, kind)
        inconclusive += any(g.kind == "time" and g.status == "inconclusive" for g in rep.gates)
        if i < m:
            for b in ind_b:
                r = run_gate(_run(d / f"independent-x{b:g}", settings, cache, gl_ctx, salt=2 * i + 2, brightness=b),
                             bl, gate)
                ind[b]["error"] += _verdict(r, "error")
                ind[b]["image"] += _verdict(r, "image")
        for s in slows:
            slow[s] += _verdict(run_gate(_slowed(cand, s), bl, gate), "time")
        print(f"pair {i + 1}/{n}: false alarm {rep.failed} "
              f"({', '.join(g.name + ' ' + g.status for g in rep.gates if g.failed(gate))}); "
              f"{time.time() - t0:.0f} s", flush=True)
    from scipy.stats import beta

    fa = sum(alarms)
    upper = float(beta.ppf(0.95, fa + 1, n - fa)) if fa < n else 1.0  # one-sided 95 % Clopper-Pearson bound
    summary = {"settings": {**dataclasses.asdict(settings),
                            "gate": {**dataclasses.asdict(gate), "metrics": list(gate.metrics)}},
               "pairs": n, "sweep_pairs": m, "false_alarms": fa, "false_alarm_rate": fa / n,
               "false_alarm_upper95": upper, "false_alarms_by_kind": kinds,
               "pairs_with_inconclusive_time": inconclusive, "rerun_same_seeds": rerun,
               "brightness_same_seeds": {f"{b:g}": {k: v / m for k, v in x.items()} for b, x in same.items()},
               "brightness_independent": {f"{b:g}": {k: v / m for k, v in x.items()} for b, x in ind.items()},
               "slowdown": {f"{s:g}": v / n for s, v in slow.items()}}
    (out / "power.json").write_text(json.dumps(summary, indent=1))
    print(f"false alarms: {fa} of {n} pairs (rate {fa / n:.3f}, one-sided 95 % upper bound {upper:.3f}; level "
          f"{gate.alpha:g}); by kind {kinds}; pairs with an inconclusive time test {inconclusive}; rerun {rerun}")
    for name, table in (("same seeds", summary["brightness_same_seeds"]),
                        ("independent noise", summary["brightness_independent"])):
        for b, x in table.items():
            print(f"brightness x{b} ({name}, {m} pairs): error test {x['error']:.0%}, image test {x['image']:.0%}")
    for s, v in summary["slowdown"].items():
        print(f"slowdown x{s} ({n} pairs): time test {v:.0%}")


if __name__ == "__main__":
    main()
