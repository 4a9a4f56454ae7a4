"""``compare measure``: measure checkpoint images made anywhere against a scene's ground truth.

A renderer that cannot be called from here (another machine, a GPU farm, a
web page) writes the same folder an external renderer writes
(``step-<N>.exr`` for each checkpoint and ``timings.json``, see
``docs/renderers.md``); ``compare measure`` renders the ground truth, measures
every checkpoint and writes ``results.json`` and the report, as ``compare run``
does.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from compare.cli.argtypes import positive_float, positive_int
from compare.util.errors import CompareError
from compare.util.files import sha256_bytes
from compare.renderers import RenderContext, Renderer, RendererError, Rendering
from compare.renderers.job import read_checkpoints, step_files

__all__ = ["ImageFolder", "add_measure_parser", "measure"]

_UNITS = {"frames": "frame", "spp": "spp", "samples": "sample"}


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
    return run([scene_path], out, settings, progress=progress, fresh=fresh, report=report, renderers=[images])


def add_measure_parser(subparsers) -> None:
    """Register ``compare measure``."""
    p = subparsers.add_parser("measure", help="measure checkpoint EXRs made anywhere against a scene's ground truth",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("images", type=Path, help="folder with step-<N>.exr and timings.json")
    p.add_argument("--scene", required=True, type=Path, help="the scene the images show (TOML)")
    p.add_argument("--name", default=None, help="the renderer's name in results.json (default: the folder's name)")
    p.add_argument("--label", default=None, help="the renderer's label in the report")
    p.add_argument("--unit", choices=sorted(_UNITS), default="frames", help="what a step counts")
    p.add_argument("--spp", type=positive_int, default=1024, help="ground-truth samples per pixel")
    p.add_argument("--seed", type=int, default=0, help="ground-truth seed")
    p.add_argument("--ground-truth", default="mitsuba", metavar="RENDERER", help="the ground-truth renderer")
    p.add_argument("--exposure", type=positive_float, default=1.0, help="exposure before tone mapping")
    p.add_argument("--fresh", action="store_true", help="redo finished units")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("-o", "--output", type=Path, required=True, help="output folder (results.json and the report)")
    p.set_defaults(func=_cmd_measure)


def _cmd_measure(args) -> int:
    from compare.report.results import RunSettings

    settings = RunSettings(spp=args.spp, seed=args.seed, exposure=args.exposure, ground_truth=args.ground_truth)
    res = measure(args.images, args.scene, args.output, name=args.name, label=args.label, unit=_UNITS[args.unit],
                  settings=settings, progress=not args.quiet, fresh=args.fresh)
    run = res.scenes[0].runs[0]
    print(f"{args.output / 'results.json'}: {run.label}, {len(run.points)} checkpoints, final FLIP "
          f"{run.final.metrics.get('flip'):.4f}; open {args.output / 'index.html'}", file=sys.stdout)
    return 0
