"""Where renderers come from: entry points (the built-ins and installed plug-ins) and renderer TOML files.

A renderer spec (``--renderers``, ``--renderer``) is ``<name>[:<option>[+<option>]]``
(:mod:`compare.renderers.options`). Its name is looked up, in this order, among

1. renderer objects handed to :class:`Registry` in this process (tests, ``compare measure``);
2. the ``[renderer.<name>]`` tables of a renderer TOML file (``--renderer-config``;
   external commands, :mod:`compare.renderers.external`);
3. entry points of the group ``compare.renderers``. The suite's own renderers are
   registered there by its own package, like any plug-in::

       # pyproject.toml of a plug-in package
       [project.entry-points."compare.renderers"]
       mine = "my_package.compare_plugin:MyRenderer"

   The entry point's name is the renderer's name; it loads a
   :class:`~compare.renderers.base.Renderer` subclass (built with
   :meth:`~compare.renderers.base.Renderer.from_spec`), an instance, or a function
   that returns one.

Renderer groups (``--renderers web``, ``all``) are data: ``groups.toml`` beside this module. A plug-in or a TOML file may not
take the name of one of the suite's renderers or of a group.
"""

from __future__ import annotations

import re

import tomllib
from importlib import metadata
from pathlib import Path
from typing import Iterable

from compare.renderers.base import Renderer, RendererError, check_renderer
from compare.renderers.external import ConfigError, external_from_table
from compare.renderers.options import split_spec

__all__ = ["DIST", "ENTRY_POINT_GROUP", "Registry"]

ENTRY_POINT_GROUP = "compare.renderers"
_GROUPS = tomllib.loads(Path(__file__).with_name("groups.toml").read_text(encoding="utf-8"))
#: The distribution whose entry points are the built-ins.
DIST = "compare-pbr"


def _entry_points() -> list[metadata.EntryPoint]:
    eps = list(metadata.entry_points(group=ENTRY_POINT_GROUP))
    if not any(_is_builtin(ep) for ep in eps):
        raise RendererError(f"no built-in renderers: the package {DIST} is not installed (its entry points of "
                            f"group {ENTRY_POINT_GROUP} register them); run scripts/suite.sh setup or pip install -e .")
    return eps


def _is_builtin(ep: metadata.EntryPoint) -> bool:
    return ep.dist is not None and ep.dist.name == DIST


#: The grammar of a renderer's name (a spec adds ``:option[+option]``): it names a folder of the results, so it
#: is lowercase (two names that differ in case would share one) and has no path separator.
NAME = re.compile(r"[a-z0-9][a-z0-9_-]{0,63}")
#: The folder of the ground truth's render in each scene's folder of a run: no renderer may be named so.
TRUTH_FOLDER = "reference"


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
            r = check_renderer(r, "renderer object")
            self._objects[r.name] = r
        self._cache: dict[str, Renderer] = {}
        self._classes: dict[str, type[Renderer]] = {}
        eps = _entry_points()
        self._builtin = {ep.name: ep for ep in eps if _is_builtin(ep)}
        # a plug-in may not take a built-in's name
        self._plugins = {ep.name: ep for ep in eps if not _is_builtin(ep) and ep.name not in self._builtin}
        self._tables = self._load_config(self.config) if self.config else {}

    # -- sources ------------------------------------------------------------------------------

    def _reserved(self) -> set[str]:
        return set(self._builtin) | set(self.groups()) | {TRUTH_FOLDER}

    def _load_config(self, path: Path) -> dict[str, Renderer]:
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
        reserved = self._reserved()
        for name, table in tables.items():
            if name in reserved:
                raise ConfigError(f"{path}: renderer.{name}: the name is taken by a built-in renderer, a group "
                                  f"({', '.join(sorted(self.groups()))}) or the ground truth's folder (reference)")
            if not NAME.fullmatch(name):
                raise ConfigError(f"{path}: renderer.{name!r}: a renderer's name is 1 to 64 lowercase letters, digits, "
                                  "'-' or '_', starting with a letter or digit (it names a folder of the results)")
            out[name] = external_from_table(name, table, source=path)
        return out

    def _load(self, ep: metadata.EntryPoint) -> object:
        where = f"entry point {ep.name!r} ({ep.value}) of group {ENTRY_POINT_GROUP}"
        try:
            return ep.load()
        except Exception as exc:  # noqa: BLE001 - a broken plug-in is reported, not fatal to others
            raise RendererError(f"{where}: cannot load it: {type(exc).__name__}: {exc}") from None

    def _class(self, name: str) -> type[Renderer] | None:
        """The Renderer subclass a built-in entry point names."""
        if name not in self._classes:
            obj = self._load(self._builtin[name])
            if not (isinstance(obj, type) and issubclass(obj, Renderer)):
                raise RendererError(f"built-in entry point {name!r}: {obj!r} is not a Renderer subclass")
            self._classes[name] = obj
        return self._classes[name]

    def _from_entry_point(self, ep: metadata.EntryPoint, spec: str) -> Renderer:
        where = f"entry point {ep.name!r} ({ep.value}) of group {ENTRY_POINT_GROUP}"
        obj = self._load(ep)
        try:
            if isinstance(obj, type) and issubclass(obj, Renderer):
                r = obj.from_spec(spec)
            elif isinstance(obj, Renderer) or isinstance(obj, type):
                r = obj  # an instance, or a class that is not a renderer (refused below)
            elif callable(obj):
                r = obj()
            else:
                r = obj
        except ValueError:
            raise
        except Exception as exc:  # noqa: BLE001 - a broken plug-in is reported, not fatal to others
            raise RendererError(f"{where}: cannot build it: {type(exc).__name__}: {exc}") from None
        r = check_renderer(r, where)
        if r.name != spec:
            raise RendererError(f"{where}: it calls itself {r.name!r}; the entry point's name must be the same")
        return r

    # -- queries ------------------------------------------------------------------------------

    def builtins(self) -> list[str]:
        """The names of the suite's own renderers (its entry points)."""
        return list(self._builtin)

    def names(self) -> list[str]:
        """Every renderer name known here (built-ins first; a name stands for its ``:<option>`` variants)."""
        names = self.builtins()
        for n in list(self._plugins) + list(self._tables) + list(self._objects):
            if n not in names:
                names.append(n)
        return names

    @staticmethod
    def groups() -> dict[str, list[str]]:
        """Renderer groups of ``--renderers`` (``web``, ``all``): ``groups.toml``."""
        return {k: list(v) for k, v in _GROUPS.items()}

    def specs(self) -> list[str]:
        """Every built-in spec worth listing: each name and its declared variants."""
        out = []
        for name in self._builtin:
            out += [name, *(v for v in self._class(name).VARIANTS if split_spec(v)[0] == name)]
        return out

    def describe(self) -> str:
        """The renderers and their options in words, for help and errors."""
        words = []
        for name in self._builtin:
            opts = self._class(name).OPTIONS
            words.append(f"{name}[:{'|'.join(opts)}]" if opts else name)
        more = [n for n in self.names() if n not in self._builtin]
        groups = ", ".join(f"{g} ({', '.join(s)})" for g, s in self.groups().items())
        return (", ".join(words + more) + f"; options combine with '+'; groups: {groups}")

    def get(self, spec: str) -> Renderer:
        """The renderer named ``spec``.

        Raises
        ------
        ValueError
            An unknown name or a bad option, naming what is known.
        RendererError
            A plug-in that cannot be loaded or is not a renderer.
        """
        if spec in self._cache:
            return self._cache[spec]
        name, _ = split_spec(spec)
        if spec in self._objects:
            r = self._objects[spec]
        elif spec in self._tables:
            r = self._tables[spec]
        elif name in self._builtin:
            r = check_renderer(self._class(name).from_spec(spec), f"built-in renderer {name!r}")
        elif name in self._plugins:
            if spec != name:
                raise ValueError(f"unknown renderer {spec!r}: the plug-in {name} takes no ':' options")
            r = self._from_entry_point(self._plugins[name], spec)
        else:
            raise ValueError(f"unknown renderer {spec!r}; expected one of {self.describe()} (renderers of a "
                             "TOML file: --renderer-config FILE; `compare renderers` lists what is available)")
        self._cache[spec] = r
        return r

    def parse(self, text: str | Iterable[str]) -> list[str]:
        """Validate a comma-separated renderer list; a group's name stands for its renderers."""
        items = [s.strip() for s in (text.split(",") if isinstance(text, str) else text) if s.strip()]
        if not items:
            raise ValueError("expected at least one renderer, e.g. mitsuba,progressive")
        groups = self.groups()
        expanded: list[str] = []
        for item in items:
            if item in groups and item not in self._objects and item not in self._tables:
                expanded += [s for s in groups[item] if s not in expanded and s not in items]
            else:
                expanded.append(item)
        for item in expanded:
            self.get(item)  # names an unknown renderer before hours of reference rendering
        if len(set(expanded)) != len(expanded):
            raise ValueError(f"renderer listed twice in {expanded}")
        return expanded

    @property
    def portable(self) -> bool:
        """Whether worker processes can rebuild every renderer (no renderer objects of this process)."""
        return not self._objects

    def listing(self) -> list[dict]:
        """Every renderer with its label, unit, source and availability (``compare renderers``)."""
        sources = {s: "built-in" for s in self.specs()}
        for n, ep in self._plugins.items():
            sources.setdefault(n, f"entry point {ep.value}")
        for n in self._tables:
            sources[n] = str(self.config)
        for n in self._objects:
            sources[n] = "this process"
        rows = []
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
