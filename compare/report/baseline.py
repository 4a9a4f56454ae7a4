"""Baselines as files: what a regression gate compares a candidate run with.

``compare baseline save DIR --results RUN/results.json`` writes a folder small enough to
commit or to keep in a CI cache (only the final images, no checkpoints, maps or previews
of intermediate steps)::

    DIR/baseline.json     this module's index (schema below; compare/schemas/baseline.schema.json)
    DIR/results.json      the run's results.json; paths to files not kept are null
    DIR/images/<scene id>/<n>-<renderer>/seed-<k>.exr     each independent run's final image (float32)
    DIR/images/<scene id>/<n>-<renderer>/final.exr        their mean
    DIR/images/<scene id>/<n>-<renderer>/final-variance.exr   per-pixel variance of the mean (K >= 2)
    DIR/images/<scene id>/<n>-<renderer>/final.png        the mean, tone-mapped, for the gate's page

Every path is relative to ``DIR``, in POSIX form. ``baseline.json`` (schema 1) is defined by
``compare/schemas/baseline.schema.json``, which :meth:`Baseline.load` validates it against: the
run's results file, its machine (timings are compared only on the same one) and, per scene, size
and renderer, the step, the seeds and the images above.

``compare baseline update DIR --results ...`` replaces a baseline after an accepted
change; both write a temporary folder beside ``DIR`` and rename it into place.
"""

from __future__ import annotations

import copy
import shutil
import datetime
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from compare.util.errors import CompareError
from compare.util.errors import OutputError
from compare.util.files import atomic_folder, sibling_lock, sweep_folder_parts, write_text_atomic
from compare.report.results import Machine, Results, ResultsError, schema_problem

__all__ = ["BASELINE_SCHEMA", "Baseline", "BaselineError", "BaselineRun", "save_baseline"]

#: The version of ``baseline.json``.
BASELINE_SCHEMA = 1
INDEX = "baseline.json"
#: What a baseline folder holds of its own; ``baseline update`` replaces these and keeps everything else.
OWNED = (INDEX, "results.json", "images")
KIND = "compare-baseline"


class BaselineError(CompareError, ValueError):
    """A baseline folder is missing, malformed or incomplete (the message names the file and field)."""


@dataclass(frozen=True)
class BaselineRun:
    """The final images of one scene × size × renderer of a baseline."""

    scene: str
    size: str
    scene_id: str
    renderer: str
    step: int
    seeds: list[int]
    images: list[str]
    mean: str
    variance: str | None
    dof: int | None
    preview: str | None

    def to_json(self) -> dict:
        """JSON-ready dict."""
        return dict(self.__dict__)


class Baseline:
    """A baseline folder, read and checked (:meth:`load`)."""

    def __init__(self, root: Path, index: dict, results: Results, runs: list[BaselineRun]):
        self.root = root
        self.index = index
        self.results = results
        self.runs = runs
        self.machine = results.machine

    def run(self, scene: str, size: str, renderer: str) -> BaselineRun | None:
        """The final images of (scene name, size, renderer spec), or None."""
        return next((r for r in self.runs if (r.scene, r.size, r.renderer) == (scene, size, renderer)), None)

    def images(self, run: BaselineRun) -> np.ndarray:
        """Each seed's final image, stacked (K, H, W, 3)."""
        from compare.image.exr import read_exr

        try:
            return np.stack([read_exr(self.root / p)[0] for p in run.images])
        except CompareError as e:
            raise BaselineError(f"{self.root / INDEX}: runs[{run.scene!r} {run.size} {run.renderer}]: {e}") from e

    @classmethod
    def load(cls, folder: str | os.PathLike) -> "Baseline":
        """Read ``folder/baseline.json`` and its ``results.json``; check that every file named is there.

        Raises
        ------
        BaselineError
            Naming the file and the field that is missing or wrong.
        """
        root = Path(folder)
        path = root / INDEX
        try:  # what a killed save or update left beside it (every baseline command sweeps it)
            with sibling_lock(root, "reading it"):
                sweep_folder_parts(root)
        except OutputError:
            pass  # being written now: its parts are the writer's
        if not root.is_dir():
            raise BaselineError(f"{root}: no such baseline folder (make one with `compare baseline save`)")
        try:
            index = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise BaselineError(f"{path}: no such file: {root} is not a baseline "
                                "(make one with `compare baseline save`)") from None
        except (OSError, ValueError) as e:
            raise BaselineError(f"{path}: cannot read: {e}") from e
        if isinstance(index, dict) and "schema" in index and index["schema"] != BASELINE_SCHEMA:
            # before the schema's `const`: the version says what to do about it
            raise BaselineError(f"{path}: schema: {index['schema']!r} is not supported (this code reads "
                                f"{BASELINE_SCHEMA}); save the baseline again with this version")
        problem = schema_problem(index, "baseline")
        if problem is not None:
            raise BaselineError(f"{path}: {problem}")
        try:
            results = Results.load(root / index["results"])
        except ResultsError as e:
            raise BaselineError(f"{path}: results: {e}") from e
        runs = []
        for i, r in enumerate(index["runs"]):
            w = f"{path}: runs[{i}]"
            run = BaselineRun(scene=r["scene"], size=r["size"], scene_id=r["scene_id"], renderer=r["renderer"],
                              step=int(r["step"]), seeds=[int(s) for s in r["seeds"]], images=list(r["images"]),
                              mean=r["mean"], variance=r["variance"], dof=r["dof"], preview=r["preview"])
            if len(run.images) != len(run.seeds):  # a schema cannot compare two lengths
                raise BaselineError(f"{w}.images: expected one image per seed ({len(run.seeds)}), "
                                    f"got {len(run.images)}")
            for key, p in [("mean", run.mean), ("variance", run.variance), ("preview", run.preview),
                           *((f"images[{k}]", p) for k, p in enumerate(run.images))]:
                if p is not None:  # the schema kept the text inside the folder; where a link leads, only the disk says
                    _contained(root, Path(p), f"{w}.{key}")
            runs.append(run)
        return cls(root, index, results, runs)


def _contained(root: Path, rel: Path, where: str) -> Path:
    """``root / rel``, a file inside ``root`` once links are resolved: a link in a baseline (a restored CI
    cache, say) must not make the gate page publish, or a check read, a file of somewhere else."""
    path = root / rel
    if not path.is_file():
        raise BaselineError(f"{where}: {path} is missing")
    if not path.resolve().is_relative_to(root.resolve()):
        raise BaselineError(f"{where}: {path} links to {path.resolve()}, outside the baseline folder {root}")
    return path


def _safe(rel: str, where: str) -> Path:
    p = Path(rel)
    if p.is_absolute() or ".." in p.parts:
        raise BaselineError(f"{where}: {rel!r} leaves the baseline folder")
    return p


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9_-]+", "-", text.lower()).strip("-") or "run"


def _strip_paths(d: dict) -> dict:
    """results.json of a baseline: every path to a file the baseline does not keep is null."""
    d = copy.deepcopy(d)
    for scene in d["scenes"]:
        for key in ("image", "preview", "variance"):
            scene["reference"][key] = None
        for run in scene["runs"]:
            run["image"] = run["preview"] = None
            run["maps"] = {}
            for layer in run.get("layers", {}).values():
                layer["map"] = None
            for p in run["points"]:
                p["image"] = p["preview"] = None
            for s in run.get("seed_runs", []):
                s["image"] = None
    return d


def save_baseline(results_path: str | os.PathLike, folder: str | os.PathLike, *, replace: bool = False,
                  progress: bool = False) -> Baseline:
    """Write a baseline of the run ``results_path`` into ``folder`` (see the module notes).

    ``replace``: ``folder`` must be a baseline already and is replaced (``compare baseline update``);
    without, ``folder`` must not exist. Returns the baseline, read back.

    Raises
    ------
    BaselineError
        For an unreadable results file or a final image it names that is missing.
    """
    from tqdm.auto import tqdm

    from compare import __version__
    from compare.image.exr import read_exr, write_exr
    from compare.image.tonemap import write_png

    results_path = Path(results_path)
    folder = Path(folder)
    try:
        res = Results.load(results_path)
    except ResultsError as e:
        raise BaselineError(str(e)) from e
    if replace:
        Baseline.load(folder)  # only a baseline is replaced, never an arbitrary folder
    src = results_path.parent
    d = _strip_paths(res.to_json())
    entries: list[dict] = []
    jobs = [(si, ri, scene, run) for si, scene in enumerate(res.scenes) for ri, run in enumerate(scene.runs)]
    with atomic_folder(folder, replace=replace) as tmp:
        for si, ri, scene, run in tqdm(jobs, desc="baseline", unit="run", disable=not progress):
            where = f"{results_path}: scenes[{si}].runs[{ri}] ({scene.name} {scene.size} {run.renderer})"
            seeds = run.per_seed()
            if not run.points or any(s.image is None for s in seeds):
                raise BaselineError(f"{where}: no final image to keep")
            images = []
            for s in seeds:
                try:
                    # only the run's own images: no absolute or ../ path, no link out of its folder
                    image = src / _safe(s.image, f"{where}: image {s.image!r}")
                    if not image.resolve().is_relative_to(src.resolve()):
                        raise BaselineError(f"{where}: {image} links to {image.resolve()}, outside the run's "
                                            f"folder {src}")
                    images.append(read_exr(image)[0])
                except CompareError as e:
                    raise BaselineError(f"{where}: {e}") from e
            stack = np.stack(images).astype(np.float64)
            sub = Path("images") / _slug(scene.id) / f"{ri:02d}-{_slug(run.renderer)}"
            names = []
            for s, image in zip(seeds, images):
                rel = sub / f"seed-{s.seed}.exr"
                write_exr(tmp / rel, image, metadata={"renderer": run.renderer, "seed": s.seed,
                                                      "step": run.final.step})
                names.append(rel.as_posix())
            mean = stack.mean(axis=0)
            write_exr(tmp / sub / "final.exr", mean, metadata={"renderer": run.renderer, "seeds": len(seeds)})
            var = None
            if len(seeds) >= 2:
                write_exr(tmp / sub / "final-variance.exr", stack.var(axis=0, ddof=1) / len(seeds),
                          metadata={"renderer": run.renderer, "what": "per-pixel variance of final.exr's mean",
                                    "dof": len(seeds) - 1})
                var = (sub / "final-variance.exr").as_posix()
            write_png(tmp / sub / "final.png", mean, exposure=res.settings.exposure, operator=res.settings.tonemap)
            entries.append(BaselineRun(scene=scene.name, size=scene.size, scene_id=scene.id, renderer=run.renderer,
                                       step=run.final.step, seeds=[s.seed for s in seeds], images=names,
                                       mean=(sub / "final.exr").as_posix(), variance=var,
                                       dof=len(seeds) - 1 if var else None,
                                       preview=(sub / "final.png").as_posix()).to_json())
        write_text_atomic(tmp / "results.json", json.dumps(d, indent=1, allow_nan=False, ensure_ascii=False) + "\n")
        index = {"schema": BASELINE_SCHEMA, "kind": KIND,
                 "created": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
                 "compare_version": __version__, "results": "results.json",
                 "machine": Machine.to_json(res.machine), "runs": entries}
        write_text_atomic(tmp / INDEX, json.dumps(index, indent=1, allow_nan=False, ensure_ascii=False) + "\n")
        if replace:  # what the user keeps there (a README, a .git) is theirs: copied into the new folder
            for extra in sorted(set(os.listdir(folder)) - set(OWNED)):
                old = folder / extra
                if old.is_dir() and not old.is_symlink():
                    shutil.copytree(old, tmp / extra, symlinks=True)
                else:
                    shutil.copy2(old, tmp / extra, follow_symlinks=False)
    return Baseline.load(folder)
