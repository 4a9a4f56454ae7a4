"""``compare inspect``: what a scene or a glTF file holds (the library: :mod:`compare.scene.inspect`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from compare.util.errors import CompareError


def add_inspect_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``compare inspect`` to an argparse subparsers object; returns the new parser."""
    p = subparsers.add_parser(
        "inspect", help="print what a scene or glTF file holds: bounds, triangles, materials, extensions, maps, "
                        "lights, cameras; or the scenarios of a render-fidelity config.json",
        description="Print what a user needs to place a camera and choose units for a scene (TOML) or a glTF "
                    "file: its bounds in metres, triangle and material counts, the extensions it uses and what "
                    "becomes of each, its maps with their sizes, its lights and cameras. For a render-fidelity "
                    "config.json (google/model-viewer's format): each scenario's model, lighting, camera, size "
                    "and excluded renderers.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("scene", type=Path, nargs="?", default=None,
                   help="scene file (TOML), glTF file (.gltf, .glb) or scenario file (.json)")
    p.add_argument("--scenarios", type=Path, default=None, metavar="CONFIG",
                   help="a render-fidelity config.json (google/model-viewer's format), as `compare run --scenarios` "
                        "takes it, instead of SCENE")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=cmd_inspect)
    return p


def cmd_inspect(args: argparse.Namespace) -> int:
    """``compare inspect``; returns 0."""
    from compare.scene.inspect import format_inspection, inspect_path

    from compare.renderers.registry import Registry

    if (args.scene is None) == (args.scenarios is None):
        raise _UsageError("give one scene file (SCENE) or one scenario file (--scenarios CONFIG)")
    registry = Registry()
    path = args.scene if args.scenarios is None else args.scenarios
    scenarios = args.scenarios is not None or path.suffix.lower() == ".json"
    info = inspect_path(path, renderers=tuple(registry.names()) if scenarios else (),
                        renders=None if scenarios else {name: registry.get(name).renders for name in registry.names()},
                        scenarios=scenarios)
    from compare.util.text import terminal_text

    # JSON escapes control characters itself; the text names what the file says, made inert for the terminal
    print(json.dumps(info, indent=1) if args.json else terminal_text(format_inspection(info)))
    return 0


class _UsageError(CompareError, ValueError):
    """A bad combination of ``compare inspect`` options."""
