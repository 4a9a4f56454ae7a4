"""The package's structure: render keys from the code that renders, and an import graph without circles."""

from __future__ import annotations

import ast
import shutil
from collections import defaultdict
from pathlib import Path

import pytest

from compare.util.code import code_fingerprint, import_closure
from tests.helpers import ROOT

PACKAGE = ROOT / "compare"
#: The layers of the package, bottom up; a package may import its own layer and those below it.
LAYERS = [("util",), ("image", "brdf"), ("scene", "metrics"), ("renderers", "report"),
          ("mitsuba", "ibl", "web"), ("progressive", "blender"), ("run",), ("bench",), ("cli",)]


@pytest.fixture(scope="module")
def package_copy(tmp_path_factory) -> Path:
    """A copy of the package to edit (never the checkout's own files)."""
    root = tmp_path_factory.mktemp("pkg") / "compare"
    shutil.copytree(PACKAGE, root, ignore=shutil.ignore_patterns("__pycache__"))
    return root


def test_rasterizer_key_follows_every_module_it_imports(package_copy):
    """Editing any module or data file the rasterizer's renderer reaches changes its key; the files
    a hand-kept list once missed are among them, and an unrelated module is not."""
    roots = {"compare": package_copy}
    module = "compare.progressive.renderer"
    closure = import_closure(module, roots)
    names = {p.relative_to(package_copy).as_posix() for p in closure}
    assert {"scene/textures.py", "scene/include.py", "scene/model.py", "scene/fields.py", "progressive/rasterizer.py",
            "progressive/options.py", "brdf/ltc.py", "ibl/prefilter.py"} <= names
    assert not names & {"run/runner.py", "cli/main.py", "report/html.py", "mitsuba/reference.py"}
    base = code_fingerprint(module, roots)
    data = [p for p in package_copy.rglob("*") if p.suffix in (".glsl", ".npz")
            and p.parent in {c.parent for c in closure}]
    assert any(p.name == "ltc_table.npz" for p in data) and any(p.name == "brdf.glsl" for p in data)
    for path in closure + data:
        original = path.read_bytes()
        path.write_bytes(original + b"\n")
        try:
            assert code_fingerprint(module, roots) != base, f"{path.relative_to(package_copy)} is not in the key"
        finally:
            path.write_bytes(original)
    assert code_fingerprint(module, roots) == base
    unrelated = package_copy / "report" / "html.py"
    unrelated.write_bytes(unrelated.read_bytes() + b"\n")
    assert code_fingerprint(module, roots) == base


def test_every_renderer_key_holds_its_code():
    from compare.renderers.registry import Registry

    reg = Registry()
    keys = {name: reg.get(name).code_key() for name in reg.builtins()}
    assert all(isinstance(k, str) and len(k) == 64 for k in keys.values())
    assert keys["progressive"] != keys["mitsuba"]


def _imports() -> dict[str, set[str]]:
    """Module → the package modules it imports (any import statement, at any depth)."""
    modules = {}
    for f in PACKAGE.rglob("*.py"):
        parts = ["compare", *f.relative_to(PACKAGE).with_suffix("").parts]
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = f
    graph: dict[str, set[str]] = defaultdict(set)
    for name, f in modules.items():
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            found = []
            if isinstance(node, ast.Import):
                found = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                assert node.level == 0, f"{f}: relative import"
                found = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            for target in found:
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                if target and target != name and target != "compare":
                    graph[name].add(target)
    return graph


def _package(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 2 or (PACKAGE / parts[1]).is_dir() else module


def test_no_import_circle_and_no_import_upwards():
    graph = _imports()
    layer = {pkg: k for k, pkgs in enumerate(LAYERS) for pkg in pkgs}
    top = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert top == set(layer), "a package without a layer (or a layer without a package)"
    upward = [f"{a} -> {b}" for a, bs in graph.items() for b in bs
              if layer[_package(b)] > layer[_package(a)]]
    assert not upward, "imports against the layering:\n" + "\n".join(sorted(upward))
    # circles between packages (a layer may hold two packages that must not import each other both ways)
    pkg_graph: dict[str, set[str]] = defaultdict(set)
    for a, bs in graph.items():
        pkg_graph[_package(a)].update(_package(b) for b in bs if _package(b) != _package(a))
    for a, bs in pkg_graph.items():
        for b in bs:
            assert a not in pkg_graph.get(b, ()), f"packages {a} and {b} import each other"
    # circles between modules
    state: dict[str, int] = {}

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                raise AssertionError("import circle: " + " -> ".join(path[path.index(nxt):] + [nxt]))
            if nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = 2

    for module in sorted(graph):
        if module not in state:
            visit(module, [module])
    assert len(LAYERS) <= 9


def test_the_command_line_imports_no_renderer_or_decoder_until_a_command_needs_it():
    """``import compare`` and building ``compare``'s parser load no renderer (Mitsuba, Dr.Jit, moderngl), no
    decoder of compressed glTF and no plotting: each command imports what it uses (the set-up bench
    measures the memory this keeps down)."""
    import subprocess
    import sys

    code = ("import sys, compare.cli.main as m; m._build_parser(); "
            "print(','.join(sorted({n.split('.')[0] for n in sys.modules})))")
    loaded = set(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
                 .stdout.strip().split(","))
    heavy = {"mitsuba", "drjit", "moderngl", "matplotlib", "skimage", "flip_evaluator", "meshopt", "DracoPy",
             "opengl_basisu", "PIL", "jinja2", "playwright", "scipy", "dask"}
    assert not loaded & heavy, sorted(loaded & heavy)


#: What renders no pixel and must stay out of every engine's key: measuring, reporting, the command line,
#: the run and bench stages, the registry that selects renderers and the external-command adapter.
NOT_RENDERING = ("metrics/", "report/", "cli/", "run/", "bench/", "renderers/registry.py", "renderers/external.py")


@pytest.mark.parametrize("module", ["compare.mitsuba.reference", "compare.mitsuba.renderer",
                                    "compare.progressive.renderer", "compare.web.renderer",
                                    "compare.blender.renderer"])
def test_no_engine_key_holds_code_that_renders_nothing(module):
    """An engine's render key (and the reference's pass-cache key) is the import closure of its code: a
    FLIP parameter, the registry or the external adapter changing must not throw away its renders."""
    closure = {p.relative_to(PACKAGE).as_posix() for p in import_closure(module, {"compare": PACKAGE})}
    held = sorted(f for f in closure if f.startswith(NOT_RENDERING))
    assert not held, f"{module}'s key holds {held}"


def test_the_likeness_key_holds_the_reference_it_renders():
    """The likeness renders Mitsuba's reference and Cycles itself, whatever the run's ground truth: its key is
    its own module's closure, which must hold both engines (and so follows an edit to either)."""
    closure = {p.relative_to(PACKAGE).as_posix() for p in import_closure("compare.run.likeness", {"compare": PACKAGE})}
    assert {"mitsuba/reference.py", "mitsuba/scene_dict.py", "blender/render.py"} <= closure


def test_editing_a_metric_renders_nothing_again(tmp_path):
    """A finished run, then a change to the metrics' code (a FLIP parameter, say): the rerun measures again
    but renders nothing, neither the reference (its pass cache and its finished unit) nor the rasterizer."""
    import os
    import subprocess
    import sys

    copy = tmp_path / "src" / "compare"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    scene = tmp_path / "box.toml"
    scene.write_text((PACKAGE.parent / "scenes" / "cornell.toml").read_text(encoding="utf-8"), encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(copy.parent), "COMPARE_CACHE": str(tmp_path / "cache")}
    code = "import compare; print(compare.__file__)"
    used = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path, capture_output=True, text=True)
    assert Path(used.stdout.strip()).parent == copy, used.stdout + used.stderr
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "compare.cli.main", "run", "--scenes", str(scene), "--renderers",
           "mitsuba,progressive", "--size", "16x12", "--spp", "4", "--frames", "2", "-o", str(out)]

    def run() -> dict[str, int]:
        # cwd outside the checkout: `-m` puts the working folder first on the path, before PYTHONPATH's copy
        done = subprocess.run(cmd, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        return {p.relative_to(tmp_path).as_posix(): p.stat().st_mtime_ns
                for p in [*out.rglob("*.exr"), *(tmp_path / "cache").rglob("*")] if p.is_file()}

    first = run()
    assert any(f.startswith("cache/") for f in first) and any(f.startswith("out/") for f in first)
    images = copy / "metrics" / "images.py"
    images.write_text(images.read_text(encoding="utf-8") + "\n# a metric edited\n", encoding="utf-8")
    second = run()
    assert {f: t for f, t in second.items() if f in first} == first, "a file rendered before was written again"
    assert not [f for f in second if f not in first and f.endswith(".exr")], "something was rendered again"


def test_the_rasterizer_lives_in_wings():
    """compare/progressive/ is split in wings (sub-packages) and no folder of it holds more than about 15
    modules and shaders, so a pass and its shaders are found together."""
    progressive = PACKAGE / "progressive"
    wings = [d for d in progressive.iterdir() if (d / "__init__.py").is_file()]
    assert len(wings) >= 4
    for folder in [progressive, *wings]:
        files = [f for f in folder.iterdir() if f.suffix in (".py", ".glsl") and f.name != "__init__.py"]
        assert len(files) <= 16, f"{folder.relative_to(PACKAGE)} holds {len(files)} modules and shaders"


def test_shader_includes_resolve_recursively_once_and_refuse_ambiguity(tmp_path, monkeypatch):
    """The loader's search path: an include of an include is expanded, a file named twice is included
    once, a circle and a name in two folders are errors naming the files."""
    from compare.progressive.gl import shaders

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "prog.glsl").write_text('#include "one.glsl"\n#include "two.glsl"\nvoid main() {}\n')
    (a / "one.glsl").write_text('#include "two.glsl"\nfloat one() { return two(); }\n')
    (b / "two.glsl").write_text("float two() { return 2.0; }\n")
    monkeypatch.setattr(shaders, "SEARCH_PATH", (a, b))
    shaders._find.cache_clear()
    try:
        src = shaders.shader_source("prog.glsl", "FRAGMENT_SHADER")
        assert src.count("float two()") == 1 and src.index("float two()") < src.index("float one()")
        (b / "two.glsl").write_text('#include "one.glsl"\n')
        with pytest.raises(RuntimeError, match="include circle"):
            shaders.shader_source("prog.glsl", "FRAGMENT_SHADER")
        (b / "one.glsl").write_text("\n")
        shaders._find.cache_clear()
        with pytest.raises(FileNotFoundError, match="one name, one file"):
            shaders.shader_source("one.glsl", "FRAGMENT_SHADER")
    finally:
        shaders._find.cache_clear()
