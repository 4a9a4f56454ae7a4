"""A small external renderer for the regression-gate tests (tests/test_gate.py), run by `compare run`.

    gate_renderer.py BRIGHTNESS SLOWDOWN JITTER SALT JOB

It renders a smooth colour gradient times BRIGHTNESS plus Gaussian noise that falls as 1/sqrt(step)
(seeded by the job's seed and SALT: a salt makes a run's noise independent of another's with the
same seeds), and spends 10 ms × SLOWDOWN of CPU time per step; with JITTER > 0 each run's steps take a
random factor of that (log-normal, mean 1, spread JITTER: a machine whose speed changes between runs,
slower or faster on average by nothing). Its seconds are the CPU time it spent, which other processes
on a shared test machine do not change (their load stalls a wall clock by tens of milliseconds, and
the gate would rightly call those timings inconclusive). It reads nothing of the suite.
"""
import json
import sys
import time

import numpy as np
import OpenEXR

STEP_SECONDS = 0.010
SIGMA = 0.05


def busy(seconds: float) -> None:
    """Work (on the CPU) for ``seconds`` of this thread's CPU time."""
    end = time.thread_time() + seconds
    x = 1.0
    while time.thread_time() < end:
        for _ in range(200):
            x = x * 1.000001 + 1e-9


def main() -> None:
    bright, slow, jitter, salt = (float(x) for x in sys.argv[1:5])
    job = json.load(open(sys.argv[5]))
    w, h = job["camera"]["width"], job["camera"]["height"]
    out = job["output_dir"]
    rng = np.random.default_rng([int(job["seed"]), int(salt)])
    y, x = np.mgrid[0:h, 0:w]
    base = np.stack([0.2 + 0.6 * x / w, 0.3 + 0.5 * y / h, 0.5 + 0.2 * (x + y) / (w + h)], axis=-1)
    total = np.zeros((h, w, 3))
    factor = float(np.exp(rng.normal(0.0, jitter) - jitter * jitter / 2.0)) if jitter > 0 else 1.0
    seconds, elapsed, done = {}, 0.0, 0
    for step in job["checkpoints"]:
        t0 = time.thread_time()
        for _ in range(step - done):
            total += base + rng.normal(0.0, SIGMA, base.shape)
            busy(STEP_SECONDS * slow * factor)
        elapsed += time.thread_time() - t0
        done = step
        img = (total / step * bright).astype(np.float32)
        chans = {c: np.ascontiguousarray(img[..., i]) for i, c in enumerate("RGB")}
        OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, chans).write(
            f"{out}/step-{step}.exr")
        seconds[str(step)] = elapsed
    json.dump({"setup_seconds": 0.0, "seconds": seconds, "metadata": {"brightness": bright}},
              open(f"{out}/timings.json", "w"))


if __name__ == "__main__":
    main()
