"""Where the jobs of ``compare run`` execute: a local process pool or a dask cluster.

A **job** is one scene at one size with every renderer (its ground truth and
every run, :mod:`compare.run.scene_job`). Workers only *render* (checkpoint EXRs and
their ``render.json``); the client measures them. Jobs are independent, so a
sweep over scenes × sizes spreads over processes or machines.

``--executor local`` (default)
    a pool of worker processes on this machine. Its size follows the machine:
    one worker per 8 cores (at least one), each with Dr.Jit limited to its share
    of the cores, because every job's timings are part of its results and two
    jobs racing for the same cores would make each other slower. ``local:N``
    asks for N workers; ``serial`` runs in this process. A run of one job (or
    ``local:1``) renders in this process: Dr.Jit already spreads each of the
    reference's passes over every core of the machine, so spreading the passes
    over processes of the same machine gains nothing (``compare bench --only
    reference-dask``; docs/performance-notes.md).
``--executor dask://HOST:PORT``
    a dask.distributed scheduler (``pip install '.[dask]'``). Workers write
    their outputs into a private staging folder and send them back; the client
    writes them atomically into the output folder, so workers need no shared
    file system. What a worker needs:

    * this repository at the same version, with the package installed
      (``scripts/suite.sh setup`` does it: libLLVM 19, EGL/Mesa, the venv, plus
      ``.venv/bin/pip install '.[dask]'``);
    * the scene files at the same paths relative to its working directory
      (start the worker from the checkout); the worker checks the scene's
      content hash against the client's and refuses a different file;
    * its own reference cache (``$COMPARE_CACHE``); caches are content-keyed
      and written atomically, so several workers may share one on a network
      file system.

    **One reference over the whole cluster.** When the run has fewer jobs than the
    cluster has workers (one scene at one size on a cluster of several machines),
    workers would sit idle while one of them renders a reference pass after pass.
    Then each job's ground truth and its convergence run spread their passes' chunks
    over every worker (:mod:`compare.mitsuba.cluster`): the job's worker submits the
    chunks missing from its cache, the workers render them with the seeds a serial
    render uses and send back each image with its seconds, the job's worker caches
    them and merges them in the serial order, so the pixels are those of a render on
    one machine, bit for bit (given the same kind of CPU). The other renderers of
    the job render on the job's worker as before. The reference's ``seconds`` stay
    the sum of its passes' render times (on the workers that rendered them), not the
    wall time of the spread render. For this, every worker also needs the scene's
    files (meshes, maps, environments) at the paths the job's worker read them
    from: start the workers from checkouts at the same path, with the same
    ``$COMPARE_CACHE`` path. The same works outside ``compare run``:
    ``ReferenceRenderer(scene, workers=DaskWorkers(client))``
    (:class:`compare.mitsuba.cluster.DaskWorkers`), with any ``distributed.Client``,
    e.g. of a ``LocalCluster``.

    Starting a cluster::

        # on the scheduler machine
        .venv/bin/dask scheduler --port 8786
        # on each worker machine, from the checkout (one process, all cores per machine
        # keeps the timings comparable)
        .venv/bin/dask worker tcp://SCHEDULER:8786 --nworkers 1 --nthreads 1
        # on the client
        compare run --scenes scenes/*.toml --size 1280x720,1920x1080 --executor dask://SCHEDULER:8786

Results are identical to a local run (the same ``results.json`` apart from
timings and host names): every renderer is deterministic for its seed, and
finished units already in the output folder are sent to the worker, so
resuming works the same way.
"""

from __future__ import annotations

import multiprocessing
import os
import platform
import shutil
import tempfile
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

from compare.util.errors import CompareError
from compare.util.files import write_bytes_atomic

#: Cores one local worker gets; a job uses all the cores it is given.
CORES_PER_WORKER = 8


class ExecutorError(CompareError, ValueError):
    """A bad ``--executor`` value or a missing dask installation."""


@dataclass
class Job:
    """One scene at one size, as sent to a worker (plain data: it is pickled)."""

    scene_path: str
    size: tuple[int, int]
    scene_hash: str
    scene_id: str
    settings: dict
    out: str
    cache_dir: str | None | bool
    fresh: bool
    threads: int | None = None
    files: dict[str, bytes] = field(default_factory=dict)
    """Finished outputs of this job already in the client's folder (remote workers only)."""
    spread: bool = False
    """Spread the reference's passes over the dask cluster the job runs on (a run of fewer jobs than workers)."""


@dataclass
class JobResult:
    """What a worker sends back: facts about its machine (GL renderer, Mitsuba variant) and, from a
    remote worker, the files it rendered."""

    facts: dict[str, str]
    host: str
    files: dict[str, bytes] = field(default_factory=dict)


def run_job(job: Job) -> JobResult:
    """Render one job in this process (called in a worker).

    With ``job.files`` set (a remote worker), the job runs in a private
    staging folder seeded with those files, and every output is sent back.
    """
    from compare.renderers import RenderContext
    from compare.renderers.registry import Registry
    from compare.report.results import RunSettings
    from compare.scene.loader import load_scene
    from compare.run.scene_job import SceneJob

    settings = RunSettings.from_json(job.settings)
    registry = Registry(settings.renderer_config)
    if job.threads:  # each renderer of the job keeps to this worker's share of the machine
        for spec in dict.fromkeys([settings.ground_truth, *settings.renderers]):
            registry.get(spec).limit_threads(job.threads)
    scene = load_scene(job.scene_path).with_resolution(*job.size)
    if scene.hash != job.scene_hash:
        raise CompareError(f"{job.scene_path}: the scene on worker {platform.node()} differs from the client's "
                           "(content hash mismatch); run the worker from the same checkout")
    workers = None
    if job.spread:  # this task's own connection to its cluster (dask's tasks-launching-tasks)
        from distributed import get_client

        workers = get_client()
    staging = None
    out = Path(job.out)
    if job.out == "":
        staging = Path(tempfile.mkdtemp(prefix="compare-job-"))
        out = staging
        for rel, data in job.files.items():
            write_bytes_atomic(out / rel, data)
    try:
        with RenderContext(settings, cache_dir=job.cache_dir, workers=workers) as context:
            scene_job = SceneJob(settings, out, registry=registry, context=context, fresh=job.fresh)
            scene_job.render(scene)
        files: dict[str, bytes] = {}
        if staging is not None:
            root = staging / "runs" / job.scene_id
            files = {p.relative_to(staging).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}
        return JobResult(scene_job.facts, platform.node(), files)
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)


def _existing_files(out: Path, scene_id: str) -> dict[str, bytes]:
    root = out / "runs" / scene_id
    if not root.is_dir():
        return {}
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and not p.name.startswith(".")}


def parse_executor(text: str) -> tuple[str, object]:
    """``serial`` | ``local`` | ``local:N`` | ``dask://HOST:PORT`` → (kind, detail)."""
    if text == "serial":
        return "serial", None
    if text == "local":
        return "local", max(1, (os.cpu_count() or 1) // CORES_PER_WORKER)
    if text.startswith("local:"):
        try:
            n = int(text.split(":", 1)[1])
        except ValueError:
            n = 0
        if n < 1:
            raise ExecutorError(f"--executor: expected local:N with N >= 1, got {text!r}")
        return "local", n
    if text.startswith("dask://"):
        address = text[len("dask://"):]
        if not address:
            raise ExecutorError("--executor: expected dask://HOST:PORT, got no address")
        return "dask", "tcp://" + address if "://" not in address else address
    raise ExecutorError(f"--executor: expected serial, local, local:N or dask://HOST:PORT, got {text!r}")


def execute(jobs: list[Job], spec: str | object, *, on_done: Callable[[int], None] | None = None
            ) -> Iterator[tuple[int, JobResult]]:
    """Run ``jobs`` on the executor named by ``spec``; yield (job index, result) as they finish.

    ``spec`` is a string for :func:`parse_executor` or a ``distributed.Client``
    (tests pass one connected to a ``LocalCluster``). Remote results' files are
    written into each job's output folder here, atomically. On a dask cluster with
    more workers than jobs, each job's reference spreads its passes over the
    cluster (the module's notes).
    """
    kind, detail = ("dask", spec) if not isinstance(spec, str) else parse_executor(spec)
    if kind == "serial" or (kind == "local" and len(jobs) <= 1):
        for i, job in enumerate(jobs):
            yield i, run_job(job)
        return
    if kind == "local":
        workers = min(int(detail), len(jobs))
        threads = max(1, (os.cpu_count() or 1) // workers)
        # spawn, not fork: the caller may hold Dr.Jit threads or a GL context, which do not survive fork
        with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = {pool.submit(run_job, _with(job, threads=threads)): i for i, job in enumerate(jobs)}
            for fut in as_completed(futures):
                yield futures[fut], fut.result()
        return
    client, own = _dask_client(detail)
    try:
        spread = len(jobs) < len(client.nthreads())  # idle workers: they render the references' passes
        remote = [_with(job, out="", files=_existing_files(Path(job.out), job.scene_id), spread=spread)
                  for job in jobs]
        futures = client.map(run_job, remote, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        from distributed import as_completed as dask_completed

        for fut in dask_completed(futures):
            i = index[fut.key]
            res = fut.result()
            for rel, data in res.files.items():
                write_bytes_atomic(Path(jobs[i].out) / rel, data)
            res.files = {}
            yield i, res
    finally:
        if own:
            client.close()


def _with(job: Job, **changes) -> Job:
    d = dict(job.__dict__)
    d.update(changes)
    return Job(**d)


def _dask_client(detail):
    if not isinstance(detail, str):
        return detail, False
    try:
        from distributed import Client
    except ImportError:
        raise ExecutorError("--executor dask://… needs dask.distributed: pip install '.[dask]'") from None
    try:
        return Client(detail, timeout="20s"), True
    except OSError as exc:
        raise ExecutorError(f"--executor: cannot reach the dask scheduler at {detail}: {exc}") from exc
