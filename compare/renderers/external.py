"""Renderers that are commands (any language): ``[renderer.<name>]`` tables of a renderer TOML file.

::

    [renderer.mine]
    command = ["python3", "tools/my_renderer.py", "{job}"]   # {job}: path of the job file
    # ({python} stands for the interpreter running the suite, with numpy and OpenEXR)
    label = "My renderer"
    unit = "frames"        # or "spp", "samples"
    steps = 64             # the budget; checkpoints at 1, 2, 4, ..., steps
    timeout = 600          # seconds; past it the renderer is stopped and the run says so
    # checkpoints = [1, 8, 64]   optional, ascending, ending with steps
    # env = {OMP_NUM_THREADS = "2"}   optional, added to the environment

Relative paths in ``command`` are relative to the folder of the TOML file. The
command runs in a fresh folder holding the job (:mod:`compare.renderers.job`);
what it writes is checked before anything is kept, and the folder is removed
afterwards, whatever happened.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from compare.util.files import sha256_bytes
from compare.renderers.base import RenderContext, Renderer, RendererError, Rendering, UNIT_PLURALS, UNITS, unit_word
from compare.renderers.job import JOB_SCHEMAS, read_checkpoints, write_job
from compare.util.files import log_tail
from compare.scene.model import FEATURE_NAMES

__all__ = ["ExternalRenderer", "external_from_table"]

_KEYS = {"command", "label", "unit", "steps", "timeout", "checkpoints", "env", "job_schema", "renders"}
TAIL_LINES = 12


class ConfigError(RendererError, ValueError):
    """A renderer TOML file is malformed; the message names the file and the field."""


class ExternalRenderer(Renderer):
    """A command that receives a job file and writes checkpoint EXRs and ``timings.json``."""

    def __init__(self, name: str, command: list[str], *, label: str, unit: str, steps: int, timeout: float,
                 checkpoints: list[int] | None = None, env: dict[str, str] | None = None, cwd: Path | None = None,
                 source: str = "", job_schema: int = 1, renders: tuple[str, ...] = ()):
        self.name = name
        #: The job file it reads: 1 (area lights only: a scene's point and spot lights come as stand-in
        #: squares) or 2 (with ``punctual`` lights).
        self.job_schema = int(job_schema)
        #: The material features it declares it renders (the job's glTF carries them either way).
        self.renders = frozenset(renders) | (frozenset({"punctual_lights"}) if self.job_schema >= 2 else frozenset())
        self.command = list(command)
        self.label = label
        self.unit = unit
        self._steps = int(steps)
        self.timeout = float(timeout)
        self._checkpoints = list(checkpoints) if checkpoints else None
        self.env = dict(env or {})
        self.cwd = Path(cwd) if cwd is not None else Path.cwd()
        self.source = source

    def _argv(self, job: Path) -> list[str]:
        argv = [part.replace("{job}", str(job)).replace("{python}", sys.executable) for part in self.command]
        # A relative path that names a file beside the TOML file means that file.
        return [str(self.cwd / a) if not os.path.isabs(a) and (self.cwd / a).is_file() else a for a in argv]

    def available(self) -> tuple[bool, str]:
        exe = self.command[0].replace("{python}", sys.executable)
        if os.path.isabs(exe) or (self.cwd / exe).is_file():
            path = Path(exe) if os.path.isabs(exe) else self.cwd / exe
            if not (path.is_file() and os.access(path, os.X_OK)):
                return False, f"{path} is not an executable file ({self.source})"
        elif shutil.which(exe) is None:
            return False, f"command {exe!r} is not on PATH ({self.source})"
        return True, ""

    def steps(self, settings) -> int:
        return self._steps

    def checkpoints(self, steps: int) -> list[int]:
        if self._checkpoints and steps == self._steps:
            return self._checkpoints
        return super().checkpoints(steps)

    def key(self, scene, settings) -> list:
        # The command and the bytes of every file it names (a script edited is a new renderer).
        files = []
        for a in self._argv(Path("job.json")):
            p = Path(a)
            if p.is_absolute() and p.is_file():
                files.append([p.name, sha256_bytes(p.read_bytes())])
        return ["external", self.command, sorted(self.env.items()), files]

    def render(self, scene, *, steps: int, checkpoints: list[int], seed: int, context: RenderContext) -> Rendering:
        who = f"renderer {self.name!r}"
        _sweep_job_folders()
        folder = Path(tempfile.mkdtemp(prefix=f"{JOB_PREFIX}{self.name[:20]}-"))
        (folder / OWNER).write_text(str(os.getpid()))
        try:
            out = folder / "output"
            out.mkdir()
            job = write_job(scene, folder, renderer=self.name, unit=self.unit, checkpoints=checkpoints, seed=seed,
                            schema=self.job_schema,
                            output_dir=out, cache_dir=context.cache_dir or None)
            argv = self._argv(job)
            stderr_path = folder / "stderr.txt"
            with open(stderr_path, "wb") as err, open(folder / "stdout.txt", "wb") as so:
                try:
                    proc = subprocess.Popen(argv, cwd=folder, stdout=so, stderr=err, stdin=subprocess.DEVNULL,
                                            env={**os.environ, **self.env}, start_new_session=True)
                except OSError as exc:
                    raise RendererError(f"{who}: cannot start {argv[0]!r}: {exc.strerror or exc}") from None
                t0 = time.perf_counter()
                limit, said = ((context.timeout, "--timeout") if context.timeout is not None
                               and context.timeout < self.timeout else (self.timeout, f"timeout in {self.source}"))
                try:
                    code = proc.wait(timeout=limit)
                except subprocess.TimeoutExpired:
                    _kill(proc)
                    raise RendererError(f"{who} did not finish within {limit:g} s ({said})"
                                        " and was stopped; the last lines of its stderr:\n"
                                        + log_tail(stderr_path, TAIL_LINES)) from None
                except BaseException:
                    _kill(proc)  # an interrupted run leaves no renderer behind
                    raise
                wall = time.perf_counter() - t0
                _kill(proc)  # it exited: anything it left running in its group goes with it
            if code != 0:
                why = f"was killed by signal {-code}" if code < 0 else f"exited with status {code}"
                raise RendererError(f"{who} {why}; the last lines of its stderr:\n"
                                    + log_tail(stderr_path, TAIL_LINES))
            rendering = read_checkpoints(out, who=who, size=scene.camera.resolution, checkpoints=checkpoints)
            rendering.metadata = {**rendering.metadata, "command": " ".join(self.command),
                                  "wall_seconds": round(wall, 6)}
            return rendering
        finally:
            shutil.rmtree(folder, ignore_errors=True)


#: Job folders are ``<temp>/compare-job-<name>-*`` and hold the pid of the process that made them.
JOB_PREFIX, OWNER = "compare-job-", "owner.pid"


def _sweep_job_folders() -> None:
    """Remove the job folders of processes that are gone (a SIGKILL leaves its folder behind)."""
    for folder in Path(tempfile.gettempdir()).glob(f"{JOB_PREFIX}*"):
        try:
            pid = int((folder / OWNER).read_text())
            os.kill(pid, 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
        except (OSError, ValueError):
            continue  # not ours to judge (unreadable, or a process of another user)


def _kill(proc: subprocess.Popen) -> None:
    """Stop the renderer and everything it started (its own process group)."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        proc.kill()
    proc.wait()


def external_from_table(name: str, table, *, source: Path) -> ExternalRenderer:
    """An :class:`ExternalRenderer` from its ``[renderer.<name>]`` table; :class:`ConfigError` names the field."""
    where = f"{source}: renderer.{name}"
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: expected a table")
    unknown = sorted(set(table) - _KEYS)
    if unknown:
        raise ConfigError(f"{where}: unknown field {unknown[0]!r} (known: {', '.join(sorted(_KEYS))})")
    command = table.get("command")
    if not (isinstance(command, list) and command and all(isinstance(c, str) and c for c in command)):
        raise ConfigError(f"{where}.command: expected a list of strings such as "
                          '["python3", "tools/my_renderer.py", "{job}"], got ' + repr(command))
    if not any("{job}" in c for c in command):
        raise ConfigError(f"{where}.command: no argument holds {{job}} (the path of the job file)")
    unit = unit_word(table.get("unit", "frames"))
    if unit not in UNITS:
        raise ConfigError(f"{where}.unit: expected one of {', '.join(UNIT_PLURALS.values())}, got {table.get('unit')!r}")
    steps = table.get("steps", 64)
    if not (isinstance(steps, int) and not isinstance(steps, bool) and steps >= 1):
        raise ConfigError(f"{where}.steps: expected a positive integer, got {steps!r}")
    timeout = table.get("timeout", 600)
    if not (isinstance(timeout, (int, float)) and not isinstance(timeout, bool) and 0 < timeout < float("inf")):
        raise ConfigError(f"{where}.timeout: expected a positive number of seconds, got {timeout!r}")
    cps = table.get("checkpoints")
    if cps is not None:
        ok = (isinstance(cps, list) and cps and all(isinstance(c, int) and not isinstance(c, bool) and c >= 1
                                                    for c in cps) and cps == sorted(set(cps)) and cps[-1] == steps)
        if not ok:
            raise ConfigError(f"{where}.checkpoints: expected ascending positive integers ending with steps "
                              f"({steps}), got {cps!r}")
    env = table.get("env") or {}
    if not (isinstance(env, dict) and all(isinstance(k, str) and isinstance(v, str) for k, v in env.items())):
        raise ConfigError(f"{where}.env: expected a table of strings")
    label = table.get("label", name)
    if not isinstance(label, str) or not label.strip():
        raise ConfigError(f"{where}.label: expected a non-empty string")
    schema = table.get("job_schema", 1)
    if schema not in JOB_SCHEMAS or isinstance(schema, bool):
        raise ConfigError(f"{where}.job_schema: expected one of {', '.join(map(str, JOB_SCHEMAS))} (the job file it "
                          f"reads, docs/renderers.md), got {schema!r}")
    renders = table.get("renders", [])
    if not (isinstance(renders, list) and all(r in FEATURE_NAMES for r in renders)):
        raise ConfigError(f"{where}.renders: expected a list of the features it renders, of "
                          f"{', '.join(FEATURE_NAMES)}; got {renders!r}")
    return ExternalRenderer(name, command, label=label, unit=unit, steps=steps, timeout=float(timeout),
                            checkpoints=cps, env=env, cwd=source.resolve().parent, source=str(source),
                            job_schema=schema, renders=tuple(renders))
