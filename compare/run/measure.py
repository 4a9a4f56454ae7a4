"""``compare measure``: measure checkpoint images made anywhere against a scene's ground truth.

A renderer that cannot be called from here (another machine, a GPU farm, a
web page) writes the same folder an external renderer writes
(``step-<N>.exr`` for each checkpoint and ``timings.json``, see
``docs/renderers.md``); ``compare measure`` renders the ground truth, measures
every checkpoint and writes ``results.json`` and the report, as ``compare run``
does.
"""

from __future__ import annotations

import re
from pathlib import Path

from compare.util.errors import CompareError
from compare.util.files import sha256_bytes
from compare.renderers import RenderContext, Renderer, RendererError, Rendering
from compare.renderers.base import UNIT_PLURALS
from compare.renderers.job import read_checkpoints, step_files

__all__ = ["ImageFolder", "measure"]

#: ``--unit`` words (plural) → the unit a step counts.
UNITS = {plural: unit for unit, plural in UNIT_PLURALS.items()}


class ImageFolder(Renderer):
    """A folder of checkpoint images seen as a renderer (this process only)."""

    portable = False

    def __init__(self, folder: Path, *, name: str, label: str, unit: str):
        self.folder = Path(folder)
        self.name, self.label, self.unit = name, label, unit
        if not self.folder.is_dir():
            raise RendererError(f"compare measure: {self.folder} is not a folder")
        self._files = step_files(self.folder)
        steps = list(self._files)
        if not steps:
            raise RendererError(f"compare measure: {self.folder} holds no step-<N>.exr checkpoint")
        self._steps = steps

    def steps(self, settings) -> int:
        return self._steps[-1]

    def checkpoints(self, steps: int) -> list[int]:
        return list(self._steps)

    def key(self, scene, settings) -> list:
        files = sorted(p for p in self.folder.iterdir() if p.is_file() and (p.suffix == ".exr" or
                                                                             p.name == "timings.json"))
        return ["images", [(p.name, sha256_bytes(p.read_bytes())) for p in files]]

    def size(self) -> tuple[int, int]:
        """(width, height) of the first checkpoint."""
        from compare.image.exr import read_exr

        try:
            image, _ = read_exr(next(iter(self._files.values())))
        except CompareError as exc:
            raise RendererError(f"compare measure: {exc}") from None
        return image.shape[1], image.shape[0]

    def render(self, scene, *, steps: int, checkpoints: list[int], seed: int, context: RenderContext) -> Rendering:
        return read_checkpoints(self.folder, who=f"compare measure ({self.folder})", size=scene.camera.resolution,
                                checkpoints=checkpoints)


def measure(folder: str | Path, scene_path: str | Path, out: str | Path, *, name: str | None = None,
            label: str | None = None, unit: str = "frame", settings=None, progress: bool = True, fresh: bool = False,
            report: bool = True):
    """Measure ``folder``'s checkpoints against ``scene_path``'s ground truth; returns the Results."""
    from compare.report.results import RunSettings
    from compare.run.runner import run

    folder = Path(folder)
    name = name or (re.sub(r"[^a-z0-9_-]+", "-", folder.resolve().name.lower()).strip("-") or "images")
    images = ImageFolder(folder, name=name, label=label or name, unit=unit)
    settings = settings or RunSettings()
    settings.renderers = [name]
    settings.sizes = [list(images.size())]
    return run([scene_path], out, settings, progress=progress, fresh=fresh, report=report, renderers=[images],
               keep_going=False)  # the user's images are the one unit measured: a failure is the error




