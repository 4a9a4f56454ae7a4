"""Shared pytest set-up: the cache folder, the OpenGL context, scene files and fuzzing sizes.

* ``$COMPARE_CACHE`` is a fresh folder per test run, removed at the end, never the user's cache.
  ``COMPARE_TEST_CACHE=<folder>`` runs the tests on that folder instead and keeps it, for tests
  that want what an earlier run cached (e.g. ``~/.cache/compare-tests``: reruns skip the BRDF
  table, environment and texture preprocessing, several seconds a run).
* ``gl_ctx`` hands out one headless OpenGL context per session, in OpenGL's initial state, and
  checks after each test for GL errors and GL objects not released. Every test that uses it,
  directly or through another fixture, is marked ``gl``.
* ``make_scene`` writes a scene TOML file into the test's temporary folder.
* ``web_pages`` is one Chromium for the web renders of a test module, ended after its last test.
* Optional components are markers: a test marked ``bpy`` (Blender's Python module), ``web`` (the web
  engines: Chromium, Playwright, their npm packages) or ``npm("package", ...)`` (Node.js and those packages
  in web/node_modules) is skipped with the component's own reason where it is missing (the checks are
  tests/helpers.py's). ``mi_llvm`` and ``mi_scalar`` hand out ``mitsuba`` with that variant active and the
  ``gltf_pbr`` plugin registered, and skip where the variant cannot be loaded; the variant active before a
  module's first such test is restored after its last.
* ``--update-golden`` makes the golden tests rewrite their files from the code as it is.
* Hypothesis sizes come from a profile, ``default`` (a few dozen cases) or ``slow`` (many more):
  ``HYPOTHESIS_PROFILE=<name>`` chooses, else ``-m``: a run that selects slow tests (``-m slow``)
  counts every property as one of them and runs it with ``slow``.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import textwrap
import tomllib
import weakref
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, is_hypothesis_test, settings

from tests.helpers import CAPABILITIES, WebPages

# ----------------------------------------------------------------------------- the cache folder

#: (folder, whether this process made it and removes it, $COMPARE_CACHE before the run)
_CACHE = pytest.StashKey[tuple]()
_WORKER_CACHE = "compare_cache"
_PREFIX = "compare-test-cache-"  # then the pid of the run that made it


def pytest_addoption(parser):
    parser.addoption("--update-golden", action="store_true",
                     help="rewrite the golden results (tests/data/*-golden.json) from this code instead of "
                          "comparing with them; review the diff before committing it")


@pytest.fixture
def update_golden(request) -> bool:
    """Whether ``--update-golden`` asks the golden tests to rewrite their files."""
    return bool(request.config.getoption("--update-golden"))


def pytest_configure(config):
    # os.environ, not monkeypatch: subprocesses (the CLI, executors, notebook kernels) inherit it.
    mine = os.environ.get("COMPARE_TEST_CACHE")
    if mine:
        folder, owned = mine, False
    elif hasattr(config, "workerinput"):  # a pytest-xdist worker: its controller's folder
        folder, owned = config.workerinput[_WORKER_CACHE], False
    else:
        _sweep_killed_runs()
        folder, owned = tempfile.mkdtemp(prefix=f"{_PREFIX}{os.getpid()}-"), True
    config.stash[_CACHE] = (folder, owned, os.environ.get("COMPARE_CACHE"))
    os.environ["COMPARE_CACHE"] = folder
    settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE") or ("slow" if _selects_slow(config) else "default"))


def pytest_unconfigure(config):
    folder, owned, before = config.stash.get(_CACHE, (None, False, None))
    if folder is None:
        return
    if before is None:
        os.environ.pop("COMPARE_CACHE", None)
    else:
        os.environ["COMPARE_CACHE"] = before
    if owned:
        shutil.rmtree(folder, ignore_errors=True)


def _sweep_killed_runs() -> None:
    """Remove the folders of runs that were killed before pytest_unconfigure (their pid is gone)."""
    for folder in Path(tempfile.gettempdir()).glob(f"{_PREFIX}*-*"):
        pid = folder.name[len(_PREFIX):].split("-")[0]
        if not pid.isdigit():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
        except OSError:  # alive, another user's
            pass


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """pytest-xdist: the workers share the controller's folder (the caches are content-keyed and
    written atomically, as for the suite's own executors)."""
    node.workerinput[_WORKER_CACHE] = node.config.stash[_CACHE][0]


# ----------------------------------------------------------------------------- hypothesis profiles

settings.register_profile("default", max_examples=30, deadline=None, derandomize=True,
                          suppress_health_check=list(HealthCheck))
settings.register_profile("slow", max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))


def _selects_slow(config) -> bool:
    """Whether ``-m`` selects tests marked slow: ``-m slow`` or no ``-m``; not the default ``not slow``."""
    from _pytest.mark.expression import Expression  # what -m itself evaluates

    expr = config.option.markexpr
    return not expr or Expression.compile(expr).evaluate(lambda name, **kwargs: name == "slow")


# ----------------------------------------------------------------------------- markers

#: Fixtures that hand out the OpenGL context.
GL_FIXTURES = {"gl_ctx", "gl_session_ctx"}


@pytest.hookimpl(tryfirst=True)  # before -m deselects by marker
def pytest_collection_modifyitems(config, items):
    slow_run = _selects_slow(config)
    for item in items:
        if GL_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.gl)
        if slow_run and is_hypothesis_test(getattr(item, "obj", None)):
            item.add_marker(pytest.mark.slow)  # selected by -m slow, run with the slow profile
        for mark in list(item.iter_markers()):
            if mark.name in CAPABILITIES:
                why = CAPABILITIES[mark.name](*mark.args)
                if why:  # reported at the test, with the component's reason
                    item.add_marker(pytest.mark.skip(reason=why))


_CALL_REPORT = pytest.StashKey[pytest.TestReport]()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    report = yield
    if report.when == "call":
        item.stash[_CALL_REPORT] = report
    return report


# ----------------------------------------------------------------------------- the OpenGL context

#: The context's methods that make a GL object the caller must release (not detect_framebuffer
#: and external_*, which wrap objects made elsewhere, nor query: moderngl queries have no
#: release() and go with the context).
_FACTORIES = ("buffer", "texture", "texture3d", "texture_array", "texture_cube", "depth_texture",
              "depth_texture_cube", "framebuffer", "simple_framebuffer", "empty_framebuffer", "renderbuffer",
              "depth_renderbuffer", "program", "vertex_array", "simple_vertex_array", "sampler",
              "compute_shader", "scope")


class _Made:
    """Every object the context's factories made, held weakly (moderngl keeps no list of live
    objects); gl_ctx empties it at each hand-out."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.objects: weakref.WeakSet = weakref.WeakSet()
        self.reported: set = set()  # the GL side of leaks already named, not to be named again
        for name in _FACTORIES:
            setattr(ctx, name, self._recording(getattr(ctx, name)))

    def _recording(self, factory):
        def make(*args, **kwargs):
            obj = factory(*args, **kwargs)
            self.objects.add(obj)
            if isinstance(obj, _moderngl().Framebuffer):
                obj.release = self._releasing(obj)
            return obj

        return make

    def _releasing(self, fbo):
        """``fbo.release`` that, when ``fbo`` is bound, records framebuffer 0 as bound, as GL binds it.
        moderngl 5.13 keeps recording the deleted framebuffer and rebinds it after its next framebuffer
        operation (creating, clearing or reading another one): GL_INVALID_OPERATION."""
        ctx, ref = self.ctx, weakref.ref(fbo)  # weak: no cycle through the object's own attribute

        def release():
            obj = ref()
            if obj is None:
                return
            bound = ctx.mglo.fbo is obj.mglo
            type(obj).release(obj)
            if bound:
                ctx.mglo.fbo = ctx.extra["framebuffer 0"]

        return release

    def unreleased(self) -> list[str]:
        invalid = _moderngl().InvalidObject
        live = [o for o in self.objects if not isinstance(o.mglo, invalid)]
        self.reported.update(o.mglo for o in live)
        return sorted(type(o).__name__ for o in live)


def _moderngl():
    import moderngl

    return moderngl


@pytest.fixture(scope="session")
def gl_session_ctx(request):
    """One headless OpenGL context for the whole session; skips when none can be made.

    Tests take :func:`gl_ctx`; this one is for fixtures wider than a function.
    """
    from compare.progressive.gl.context import create_context
    from compare.util.errors import MissingComponentError

    try:
        ctx = create_context()
    except MissingComponentError as exc:
        pytest.skip(f"no OpenGL 3.3+ context: {exc}")
    # An object garbage-collected without release() is queued on ctx.objects instead of keeping its
    # GL name unseen: gl_ctx names and frees it.
    ctx.gc_mode = "context_gc"
    ctx.extra = {"made": _Made(ctx), "framebuffer 0": ctx.mglo.fbo}
    request.config.stash[_GL_CONTEXT] = ctx
    yield ctx
    del request.config.stash[_GL_CONTEXT]
    ctx.release()


_GL_CONTEXT = pytest.StashKey[object]()


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    # moderngl draws with the thread's current context, the last one made or entered: after a test
    # (or the code it runs) made its own, the session's is not current until entered again. Here,
    # before the test's fixtures are set up, so that wider ones drawing for it use it too.
    ctx = item.config.stash.get(_GL_CONTEXT, None)
    if ctx is not None and GL_FIXTURES.intersection(item.fixturenames):
        ctx.__enter__()


def _reset_state(ctx) -> None:
    """OpenGL's initial state, for what the passes set: a test must not depend on the one before it."""
    ctx.enable_only(ctx.NOTHING)
    ctx.blend_func = ctx.ONE, ctx.ZERO
    ctx.blend_equation = ctx.FUNC_ADD
    ctx.depth_func = "<"
    ctx.front_face = "ccw"
    ctx.cull_face = "back"
    ctx.wireframe = False
    ctx.polygon_offset = (0.0, 0.0)
    ctx.line_width = 1.0
    ctx.point_size = 1.0
    ctx.clear_samplers()
    ctx.extra["framebuffer 0"].use()  # with the viewport and scissor the context was made with
    ctx.fbo = None  # as made: a surfaceless context has no default framebuffer object


def _gl_errors(ctx) -> list[str]:
    errors = []
    for _ in range(8):  # glGetError returns and clears one flag per call
        error = ctx.error
        if error == "GL_NO_ERROR":
            break
        errors.append(error)
    return errors


def _free_dropped(ctx) -> list[str]:
    """Release what was garbage-collected without release() (ctx.objects; released objects queue an
    InvalidObject, which ctx.gc() cannot handle); returns their kinds."""
    reported = ctx.extra["made"].reported
    dropped = []
    while ctx.objects:
        mglo = ctx.objects.popleft()
        if not isinstance(mglo, _moderngl().InvalidObject):
            if ctx.mglo.fbo is mglo:  # see _Made._releasing
                ctx.mglo.fbo = ctx.extra["framebuffer 0"]
            mglo.release()
            if mglo in reported:
                reported.discard(mglo)
            else:
                dropped.append(type(mglo).__name__)
    return dropped


@pytest.fixture
def gl_ctx(gl_session_ctx, request):
    """The session's OpenGL context in OpenGL's initial state. The test fails when it leaves a GL error
    or a GL object it made and did not release (a moderngl query, which cannot be released, aside).
    """
    ctx = gl_session_ctx
    made = ctx.extra["made"]
    ctx.__enter__()  # see pytest_runtest_setup
    # What wider fixtures or an earlier test's late garbage left is not this test's doing.
    _free_dropped(ctx)
    pending = _gl_errors(ctx)
    if pending:
        pytest.fail(f"GL error(s) before the test, left by a fixture: {', '.join(pending)}", pytrace=False)
    _reset_state(ctx)
    made.objects.clear()
    yield ctx
    ctx.__enter__()  # the test may have made another context current
    errors, dropped, live = _gl_errors(ctx), _free_dropped(ctx), made.unreleased()
    made.objects.clear()
    problems = ([f"GL error(s) {', '.join(errors)}"] if errors else []) + (
        [f"GL objects garbage-collected without release(): {', '.join(dropped)}"] if dropped else []) + (
        [f"GL objects still alive and not released: {', '.join(live)}"] if live else [])
    if not problems:
        return
    call = request.node.stash.get(_CALL_REPORT, None)
    if call is not None and not call.passed:  # already failed; its traceback holds the test's objects
        request.node.add_report_section("teardown", "gl_ctx", "; ".join(problems))
        return
    pytest.fail("; ".join(problems), pytrace=False)


# ----------------------------------------------------------------------------- scene files


def _with_tables(text: str, tables: dict) -> str:
    """``text`` (TOML) with ``tables`` added: a dict, a dict of dicts or a list of dicts each.

    Without tables the text is written as given (some tests give malformed TOML on purpose). With them
    the text is parsed and the whole file written by tomli-w: TOML has no way back to the top level
    after the text's ``[table]`` headers, and tomli-w writes a short list of dicts as a key (an inline
    array), which appended there would land in the text's last table."""
    if not tables:
        return text
    for name, value in tables.items():
        if not isinstance(value, dict) and not (isinstance(value, (list, tuple))
                                                and all(isinstance(v, dict) for v in value)):
            raise TypeError(f"{name}: a table is a dict, a dict of dicts or a list of dicts")
    doc = tomllib.loads(text)
    if doc.keys() & tables.keys():
        raise TypeError(f"{', '.join(sorted(doc.keys() & tables.keys()))}: given as text and as a table")
    return tomli_w.dumps({**doc, **tables})


@pytest.fixture
def make_scene(tmp_path):
    """``make_scene(*texts, name="scene.toml", folder=None, **tables) -> Path`` writes a scene file.

    The texts are TOML as written in the test (each dedented, in order); each keyword is a table
    after them: ``camera={"position": [0, 1, 3], ...}``, ``materials={"grey": {...}}``,
    ``meshes=[{...}, ...]``. The file goes into ``folder``, by default the test's ``tmp_path``.
    """

    def make(*texts: str, name: str = "scene.toml", folder: Path | None = None, **tables) -> Path:
        path = Path(folder or tmp_path) / name
        path.write_text(_with_tables("".join(textwrap.dedent(t) for t in texts), tables))
        return path

    return make


@pytest.fixture(scope="module")
def web_pages():
    """One Chromium for the web renders of a test module (:class:`tests.helpers.WebPages`): it starts at the
    first render, each engine's page is a new tab, and it ends after the module's last test."""
    pages = WebPages()
    yield pages
    pages.close()


# ----------------------------------------------------------------------------- Mitsuba variants


@pytest.fixture(scope="module")
def _mitsuba_variant_before():
    """The Mitsuba variant active before the module's first ``mi_*`` test, set again after its last."""
    import sys

    before = sys.modules["mitsuba"].variant() if "mitsuba" in sys.modules else None
    yield
    if before and sys.modules["mitsuba"].variant() != before:
        sys.modules["mitsuba"].set_variant(before)


def _mitsuba_variant(name: str):
    """``mitsuba`` with ``name`` active and the plugin registered with it; skips with Mitsuba's reason where
    the variant cannot be loaded (a registered variant is made active again at once)."""
    from compare.mitsuba.bsdf import register
    from compare.util.errors import MissingComponentError

    try:
        return register(name)
    except MissingComponentError as exc:
        pytest.skip(f"Mitsuba variant {name} unavailable: {exc}")


@pytest.fixture
def mi_llvm(_mitsuba_variant_before):
    """``mitsuba`` with ``llvm_ad_rgb`` (the JIT variant: needs libLLVM) active."""
    return _mitsuba_variant("llvm_ad_rgb")


@pytest.fixture
def mi_scalar(_mitsuba_variant_before):
    """``mitsuba`` with ``scalar_rgb`` active."""
    return _mitsuba_variant("scalar_rgb")
