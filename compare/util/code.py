"""Which code makes a renderer's pixels: a module's import closure and the data files beside it.

A finished render is reused only while the code that made it is unchanged. The
files are found, not listed: :func:`import_closure` follows every ``import``
statement of a module (at module level and inside functions, absolute and
relative) through the modules of its own top-level package and of ``compare``,
and :func:`code_fingerprint` hashes those sources with the data files that sit
beside them (shaders, fitted tables, templates). Third-party packages are keyed
by their version elsewhere (e.g. the reference's Mitsuba version).
"""

from __future__ import annotations

import ast
import functools
import hashlib
import importlib.util
import json
from pathlib import Path
from typing import Mapping

__all__ = ["DATA_SUFFIXES", "code_fingerprint", "import_closure", "package_roots"]

#: Files beside a module that its code reads at run time.
DATA_SUFFIXES = (".glsl", ".npz", ".json", ".j2", ".css", ".js", ".html")


def package_roots(module: str) -> dict[str, Path]:
    """The folders of ``compare`` and of ``module``'s own top-level package (name → folder)."""
    roots = {}
    for top in dict.fromkeys(("compare", module.partition(".")[0])):
        spec = importlib.util.find_spec(top)
        if spec is None:
            raise ModuleNotFoundError(f"no module named {top!r}")
        if spec.submodule_search_locations:
            roots[top] = Path(list(spec.submodule_search_locations)[0])
        elif spec.origin:  # a top-level module of its own
            roots[top] = Path(spec.origin)
    return roots


def _file(name: str, roots: Mapping[str, Path]) -> Path | None:
    """The source file of the dotted module ``name`` under ``roots``, or None if it is not one of theirs."""
    top, _, rest = name.partition(".")
    root = roots.get(top)
    if root is None:
        return None
    if root.is_file():
        return root if not rest else None
    base = root.joinpath(*rest.split(".")) if rest else root
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _module_name(path: Path, roots: Mapping[str, Path]) -> str:
    for top, root in roots.items():
        if root.is_file():
            if path == root:
                return top
            continue
        try:
            rel = path.relative_to(root)
        except ValueError:
            continue
        parts = [top, *rel.with_suffix("").parts]
        return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
    raise ValueError(f"{path} is under none of {sorted(roots)}")


def _imports(path: Path, name: str) -> frozenset[str]:
    """Every module name an import statement of ``path`` (module ``name``) may load."""
    return _parsed_imports(name, path.name == "__init__.py", path.read_bytes())


@functools.lru_cache(maxsize=4096)
def _parsed_imports(name: str, is_package: bool, source: bytes) -> frozenset[str]:
    # Keyed by the source itself: an edited file is parsed again, an unchanged one is not.
    package = name if is_package else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(source, name)):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names)  # `from pkg import submodule`
    return frozenset(out)


def import_closure(module: str, roots: Mapping[str, Path] | None = None) -> list[Path]:
    """The source files of ``module`` and of every module it imports, directly or not, within ``roots``
    (default :func:`package_roots`), with the ``__init__.py`` of every package on the way; sorted."""
    roots = dict(roots) if roots is not None else package_roots(module)
    start = _file(module, roots)
    if start is None:
        raise ModuleNotFoundError(f"no source file of module {module!r} under {sorted(roots)}")
    seen: set[Path] = set()
    todo = [start]
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        name = _module_name(path, roots)
        parts = name.split(".")
        candidates = _imports(path, name) | {".".join(parts[:k]) for k in range(1, len(parts))}
        for imported in candidates:
            f = _file(imported, roots)
            if f is not None and f not in seen:
                todo.append(f)
    return sorted(seen)


def _data_files(sources: list[Path]) -> list[Path]:
    folders = sorted({p.parent for p in sources if p.suffix == ".py"})
    return [f for d in folders for f in sorted(d.iterdir()) if f.is_file() and f.suffix in DATA_SUFFIXES]


def fingerprint_files(files: list[Path], base: Path | None = None) -> str:
    """SHA-256 of the files' names (relative to ``base``) and contents."""
    parts = []
    for f in files:
        rel = f.relative_to(base).as_posix() if base and f.is_relative_to(base) else f.name
        parts.append((rel, hashlib.sha256(f.read_bytes()).hexdigest()))
    return hashlib.sha256(json.dumps(parts).encode()).hexdigest()


def code_fingerprint(module: str, roots: Mapping[str, Path] | None = None) -> str:
    """Hash of :func:`import_closure` of ``module`` and the data files beside those modules: in a render's
    key, so a finished render is redone once any code it ran changes (the version moves only at releases)."""
    if roots is None:
        return _cached_fingerprint(module)
    return _fingerprint(module, dict(roots))


def _fingerprint(module: str, roots: dict[str, Path]) -> str:
    sources = import_closure(module, roots)
    base = roots.get("compare")
    base = base.parent if base is not None else None
    return fingerprint_files(sources + _data_files(sources), base)


@functools.lru_cache(maxsize=None)
def _cached_fingerprint(module: str) -> str:
    # One process renders with the code it loaded: hashing it once per module is enough.
    return _fingerprint(module, package_roots(module))
