"""Where renderers come from: the built-ins, installed plug-ins and renderer TOML files.

A renderer spec (``--renderers``, ``--renderer``) is looked up, in this order, among

1. renderer objects handed to :class:`Registry` in this process (tests, ``compare measure``);
2. the ``[renderer.<name>]`` tables of a renderer TOML file (``--renderer-config``;
   external commands, :mod:`compare.renderers.external`);
3. entry points of the group ``compare.renderers`` of installed packages: the entry
   point's name is the renderer's name and it loads a :class:`~compare.renderers.base.Renderer`
   instance, or a class or function that returns one when called without arguments::

       # pyproject.toml of a plug-in package
       [project.entry-points."compare.renderers"]
       mine = "my_package.compare_plugin:MyRenderer"

4. the built-ins: ``mitsuba``, ``progressive[:<option>[+<option>]]`` (:mod:`compare.progressive.options`),
   ``cycles`` and ``eevee``, and the web engines ``threejs`` and ``threejs-pathtracer``
   (``web`` names both).

A plug-in or a TOML file may not take a built-in's name.
"""

from __future__ import annotations

import tomllib
from importlib import metadata
from pathlib import Path
from typing import Iterable

from compare.renderers.base import UNITS, Renderer, RendererError
from compare.renderers.external import ConfigError, external_from_table

__all__ = ["BUILTIN", "ENTRY_POINT_GROUP", "TABLE_1", "Registry", "builtin"]

ENTRY_POINT_GROUP = "compare.renderers"
#: The built-in renderers' names (``progressive`` takes ``:<option>`` variants).
BUILTIN = ("mitsuba", "progressive", "cycles", "eevee", "threejs", "threejs-pathtracer")
#: ``--renderers web``: every web engine (compare.web.renderer).
WEB = ("threejs", "threejs-pathtracer")
#: What ``--renderers all`` means: the paper's Table 1 (and the three area models).
TABLE_1 = ("mitsuba", "progressive", "progressive:paper", "progressive:ltc", "cycles", "eevee")


def builtin(spec: str) -> Renderer | None:
    """The built-in renderer of ``spec``, or None if it names none (ValueError for a bad variant)."""
    base = spec.partition(":")[0]
    if spec == "mitsuba":
        from compare.mitsuba.renderer import MitsubaRenderer

        return MitsubaRenderer()
    if base == "progressive":
        from compare.progressive.renderer import ProgressiveRenderer

        return ProgressiveRenderer(spec)
    if base in ("cycles", "eevee"):
        from compare.blender.renderer import BlenderRenderer

        return BlenderRenderer(spec)  # ValueError for a bad option
    if base in WEB:
        from compare.web.renderer import WebRenderer

        return WebRenderer(spec)  # ValueError for a bad option
    return None


def _check(r: object, where: str) -> Renderer:
    """``r`` has what a renderer declares (duck typing: a Renderer subclass is not required)."""
    for attr in ("name", "label", "unit", "steps", "key", "render"):
        if not hasattr(r, attr):
            raise RendererError(f"{where}: {type(r).__name__} has no {attr!r} (see compare/renderers/base.py)")
    if not isinstance(r.name, str) or not r.name:
        raise RendererError(f"{where}: the renderer's name must be a non-empty string, got {r.name!r}")
    if r.unit not in UNITS:
        raise RendererError(f"{where}: unit {r.unit!r} is not one of {', '.join(UNITS)}")
    return r  # type: ignore[return-value]


class Registry:
    """The renderers one run can use.

    Parameters
    ----------
    config : path, optional
        A renderer TOML file (``[renderer.<name>]`` tables).
    renderers : iterable of Renderer, optional
        Renderer objects of this process; they take precedence over every other source.
    """

    def __init__(self, config: str | Path | None = None, renderers: Iterable[Renderer] = ()):
        self.config = Path(config) if config else None
        self._objects = {}
        for r in renderers:
            r = _check(r, "renderer object")
            self._objects[r.name] = r
        self._tables = self._load_config(self.config) if self.config else {}
        self._cache: dict[str, Renderer] = {}
        self._entry_points = None

    @staticmethod
    def _load_config(path: Path) -> dict[str, Renderer]:
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise ConfigError(f"{path}: no such renderer file") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"{path}: cannot read: {exc}") from None
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError(f"{path}: not valid TOML: {exc}") from None
        unknown = sorted(set(data) - {"renderer"})
        if unknown:
            raise ConfigError(f"{path}: unknown top-level key {unknown[0]!r} (expected [renderer.<name>] tables)")
        tables = data.get("renderer", {})
        if not isinstance(tables, dict) or not tables:
            raise ConfigError(f"{path}: no [renderer.<name>] table")
        out = {}
        for name, table in tables.items():
            if name.partition(":")[0] in BUILTIN or ":" in name:
                raise ConfigError(f"{path}: renderer.{name}: the name is taken by a built-in renderer or holds ':'")
            out[name] = external_from_table(name, table, source=path)
        return out

    def _plugins(self) -> dict[str, metadata.EntryPoint]:
        if self._entry_points is None:
            self._entry_points = {ep.name: ep for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}
        return self._entry_points

    def _plugin(self, name: str) -> Renderer:
        ep = self._plugins()[name]
        where = f"entry point {name!r} ({ep.value}) of group {ENTRY_POINT_GROUP}"
        try:
            obj = ep.load()
            if not isinstance(obj, Renderer) and callable(obj) and not hasattr(obj, "render"):
                obj = obj()
            elif isinstance(obj, type):
                obj = obj()
        except Exception as exc:  # noqa: BLE001 - a broken plug-in is reported, not fatal to others
            raise RendererError(f"{where}: cannot load it: {type(exc).__name__}: {exc}") from None
        r = _check(obj, where)
        if r.name != name:
            raise RendererError(f"{where}: it calls itself {r.name!r}; the entry point's name must be the same")
        return r

    def names(self) -> list[str]:
        """Every renderer name known here (built-ins first; ``progressive`` stands for its variants)."""
        names = list(BUILTIN)
        for n in list(self._plugins()) + list(self._tables) + list(self._objects):
            if n not in names:
                names.append(n)
        return names

    def get(self, spec: str) -> Renderer:
        """The renderer named ``spec``.

        Raises
        ------
        ValueError
            An unknown name or a bad ``progressive`` option, naming what is known.
        RendererError
            A plug-in that cannot be loaded or does not declare what a renderer must.
        """
        if spec in self._cache:
            return self._cache[spec]
        if spec in self._objects:
            r = self._objects[spec]
        elif spec in self._tables:
            r = self._tables[spec]
        elif spec.partition(":")[0] in BUILTIN:
            r = builtin(spec)
            if r is None:  # a built-in's name with ':' options it does not take
                raise ValueError(f"unknown renderer {spec!r}: {spec.partition(':')[0]} takes no ':' options")
        elif spec in self._plugins():
            r = self._plugin(spec)
        else:
            from compare.progressive.options import OPTIONS

            more = [n for n in self.names() if n not in BUILTIN]
            raise ValueError(f"unknown renderer {spec!r}; expected mitsuba, progressive, progressive:<option> "
                             f"(options: {', '.join(OPTIONS)}), cycles, cycles:ggx, eevee, eevee:ggx, threejs, threejs-pathtracer"
                             + (f", {', '.join(more)}" if more else "")
                             + " or all (renderers of a TOML file: --renderer-config FILE; `compare renderers` "
                               "lists what is available)")
        self._cache[spec] = r
        return r

    def parse(self, text: str | Iterable[str]) -> list[str]:
        """Validate a comma-separated renderer list; ``all`` is the paper's Table 1 (:data:`TABLE_1`)."""
        items = [s.strip() for s in (text.split(",") if isinstance(text, str) else text) if s.strip()]
        if not items:
            raise ValueError("expected at least one renderer, e.g. mitsuba,progressive")
        if "all" in items:
            items = list(TABLE_1) + [i for i in items if i != "all" and i not in TABLE_1]
        if "web" in items:
            k = items.index("web")
            items = items[:k] + [w for w in WEB if w not in items] + items[k + 1:]
        for item in items:
            self.get(item)  # names an unknown renderer before hours of reference rendering
        if len(set(items)) != len(items):
            raise ValueError(f"renderer listed twice in {items}")
        return items

    @property
    def portable(self) -> bool:
        """Whether worker processes can rebuild every renderer (no renderer objects of this process)."""
        return not self._objects

    def listing(self) -> list[dict]:
        """Every renderer with its label, unit, source and availability (``compare renderers``)."""
        rows = []
        specs = ["mitsuba", "progressive", *(f"progressive:{o}" for o in ("paper", "ltc", "probes", "vsm")),
                 "cycles", "cycles:ggx", "eevee", "eevee:ggx", *WEB, "threejs:shadows"]
        sources = {s: "built-in" for s in specs}
        for n in self._plugins():
            sources.setdefault(n, f"entry point {self._plugins()[n].value}")
        for n in self._tables:
            sources[n] = str(self.config)
        for n in self._objects:
            sources[n] = "this process"
        for spec, source in sources.items():
            try:
                r = self.get(spec)
                ok, why = r.available()
                rows.append({"name": spec, "label": r.label, "unit": r.unit, "source": source, "available": ok,
                             "why": why})
            except (ValueError, RendererError) as exc:
                rows.append({"name": spec, "label": "", "unit": "", "source": source, "available": False,
                             "why": str(exc)})
        return rows
